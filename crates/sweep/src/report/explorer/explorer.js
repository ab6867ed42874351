/* The report's image explorer (crates/sweep/src/report/explorer/).
 *
 * Plain JavaScript for a page opened from file://, where fetch, XHR, modules and workers
 * from files are blocked: each cell's pixel data is a script file under explorer/ that
 * calls volphotExplorerData(path, data), loaded when the cell is shown. Every pixel value
 * shown, compared or read out comes from those half floats, never from a PNG (a canvas that
 * drew a file:// image cannot be read back).
 *
 * Layout of a data file's layers: planar RGB (R plane, G plane, B plane) of half floats,
 * all high bytes then all low bytes, raw deflate, base64. The FLIP map: one byte per
 * pixel, round(255 · error). */
(() => {
  'use strict';
  const M = JSON.parse(document.getElementById('explorer-manifest').textContent);
  const $ = (id) => document.getElementById(id);
  const root = $('explorer');
  const LAYERS = ['total', 'single', 'multiple', 'emission', 'reference'];
  const MODES = ['image', 'diff', 'rel', 'flip'];
  const COMPARES = ['side', 'split', 'flip'];
  const PANES = ['a', 'b'];
  /* What tests and curious users can reach: state, manifest, actions, last readout. */
  const hook = (window.explorer = { manifest: M, renders: 0, readyAt: null, lastReadout: null, errors: [] });

  /* ---------- half floats and data files ---------- */

  const F16 = new Float32Array(65536); /* every half float's value, exact */
  for (let h = 0; h < 65536; h++) {
    const e = (h >> 10) & 31, m = h & 1023, sign = h & 0x8000 ? -1 : 1;
    F16[h] = e === 0 ? sign * m * 2 ** -24 : e === 31 ? (m ? NaN : sign * Infinity) : sign * (1024 + m) * 2 ** (e - 25);
  }

  function bytesOf(b64) {
    if (Uint8Array.fromBase64) return Uint8Array.fromBase64(b64);
    const bin = atob(b64), out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }

  async function inflate(b64) {
    const stream = new Blob([bytesOf(b64)]).stream().pipeThrough(new DecompressionStream('deflate-raw'));
    return new Uint8Array(await new Response(stream).arrayBuffer());
  }

  /* A packed layer as planar RGB floats; an omitted (all-zero) layer as zeros. */
  async function halfPlanes(b64, n, what) {
    if (b64 == null) return new Float32Array(3 * n);
    const b = await inflate(b64), half = b.length >> 1;
    if (half !== 3 * n) throw new Error(`${what}: ${half} values, expected ${3 * n}`);
    const out = new Float32Array(half);
    for (let i = 0; i < half; i++) out[i] = F16[(b[i] << 8) | b[half + i]];
    return out;
  }

  const arrivals = new Map(); /* data file path -> resolve of its pending load */
  window.volphotExplorerData = (path, data) => {
    const resolve = arrivals.get(path);
    if (resolve) { arrivals.delete(path); resolve(data); }
  };

  function loadScript(path) {
    return new Promise((resolve, reject) => {
      arrivals.set(path, resolve);
      const s = document.createElement('script');
      s.src = path; /* relative to report.html */
      s.onload = () => { s.remove(); if (arrivals.delete(path)) reject(new Error(`${path} holds no explorer data`)); };
      s.onerror = () => { s.remove(); arrivals.delete(path); reject(new Error(`cannot load ${path}`)); };
      document.head.appendChild(s);
    });
  }

  async function decodeFilm(path, d) {
    const n = d.width * d.height;
    const names = ['single', 'multiple', 'emission'];
    const planes = await Promise.all(names.map((l) => halfPlanes(d.layers[l], n, `${path} ${l}`)));
    const flip = d.flip ? await inflate(d.flip) : null;
    if (flip && flip.length !== n) throw new Error(`${path}: FLIP map of ${flip.length} pixels, expected ${n}`);
    return { w: d.width, h: d.height, bin: d.bin || 1, n, layers: Object.fromEntries(names.map((l, i) => [l, planes[i]])), flip, sums: new Map() };
  }

  /* Decoded films by data path, least recently used first; a few 512² films are ~10 MB each. */
  const films = new Map();
  const FILMS_KEPT = 12;
  function film(path) {
    let p = films.get(path);
    if (p) { films.delete(path); films.set(path, p); return p; }
    p = loadScript(path).then((d) => decodeFilm(path, d));
    p.catch(() => films.delete(path));
    films.set(path, p);
    while (films.size > FILMS_KEPT) films.delete(films.keys().next().value);
    return p;
  }

  /* The sum of some layers (a cell's displayed image), computed once per film. */
  function sum(f, names) {
    const key = names.join('+');
    let t = f.sums.get(key);
    if (!t) {
      t = new Float32Array(3 * f.n);
      for (const l of names) { const a = f.layers[l]; for (let i = 0; i < t.length; i++) t[i] += a[i]; }
      f.sums.set(key, t);
    }
    return t;
  }

  /* ---------- cells and state ---------- */

  const S = {
    a: 0, b: 0, layer: 'total', mode: 'image', compare: 'side', flipped: false, split: 0.5,
    exposure: 0, transfer: 'srgb', gamma: 2.2, range: -2, axis: Math.max(0, M.axes.length - 1),
    view: null, /* {s, tx, ty}: view px = image px · s + t, shared by every view */
    hover: null, /* image pixel under the cursor */
  };
  hook.state = S;
  const byCoords = new Map(M.cells.map((c, i) => [c.coords.join(','), i]));
  const byIndex = new Map(M.cells.map((c, i) => [c.index, i]));
  const cellLabel = (i) => `cell ${M.cells[i].index}: ${M.cells[i].label}`;

  /* The cell at these coordinates, else the one sharing most of them with the `fixed` axes
   * equal (a sparse grid), finished cells first; -1 when none has the fixed values. */
  function closest(coords, fixed) {
    const exact = byCoords.get(coords.join(','));
    if (exact !== undefined) return exact;
    let best = -1, score = -1;
    M.cells.forEach((c, i) => {
      if (fixed.some((k) => c.coords[k] !== coords[k])) return;
      const s = 2 * c.coords.reduce((n, v, k) => n + (v === coords[k] ? 1 : 0), 0) + (c.data ? 1 : 0);
      if (s > score) { score = s; best = i; }
    });
    return best;
  }

  /* Of several cells (a plot point's mean), the one most like pane `pane`'s cell. */
  function likeCurrent(candidates, pane) {
    const here = M.cells[S[pane]].coords;
    let best = candidates[0], score = -1;
    for (const i of candidates) {
      const s = M.cells[i].coords.reduce((n, v, k) => n + (v === here[k] ? 1 : 0), 0);
      if (s > score) { score = s; best = i; }
    }
    return best;
  }

  function select(pane, i) {
    if (!(i >= 0 && i < M.cells.length)) return busy;
    S[pane] = i;
    saveHash();
    syncControls();
    return render();
  }

  /* Steps pane's cell along the marked axis to the next value that has a cell. */
  function step(pane, dir) {
    const k = S.axis, axis = M.axes[k];
    if (!axis) return;
    const coords = M.cells[S[pane]].coords.slice();
    for (let j = (coords[k] ?? 0) + dir; j >= 0 && j < axis.values.length; j += dir) {
      coords[k] = j;
      const i = closest(coords, [k]);
      if (i >= 0) { select(pane, i); return; }
    }
  }

  /* ---------- colour ---------- */

  /* Linear [0, 1] -> 8 bit through sRGB or a power law, 65536 entries (fine enough that
   * dark tones do not band under a steep gamma). */
  let toneLut = null, toneKey = '';
  function tone() {
    const key = `${S.transfer} ${S.gamma}`;
    if (key !== toneKey) {
      toneLut = new Uint8Array(65536);
      const g = 1 / Math.max(0.05, S.gamma);
      for (let i = 0; i < 65536; i++) {
        const v = i / 65535;
        const e = S.transfer === 'srgb' ? (v <= 0.0031308 ? 12.92 * v : 1.055 * v ** (1 / 2.4) - 0.055) : v ** g;
        toneLut[i] = Math.round(255 * e);
      }
      toneKey = key;
    }
    return toneLut;
  }

  function lut(stops) { /* piecewise-linear map through RGB stops in [0, 1] */
    const out = new Uint8Array(768);
    for (let i = 0; i < 256; i++) {
      const t = (i / 255) * (stops.length - 1), k = Math.min(stops.length - 2, Math.floor(t)), u = t - k;
      for (let c = 0; c < 3; c++) out[3 * i + c] = Math.round(255 * (stops[k][c] + (stops[k + 1][c] - stops[k][c]) * u));
    }
    return out;
  }
  /* Diverging blue - grey - red (Moreland's cool-warm end points). */
  const COOLWARM = lut([[0.230, 0.299, 0.754], [0.865, 0.865, 0.865], [0.706, 0.016, 0.150]]);
  /* viridis, sampled at eleven points (matplotlib's table). */
  const VIRIDIS = lut([[0.267, 0.005, 0.329], [0.283, 0.141, 0.458], [0.254, 0.265, 0.530], [0.207, 0.372, 0.553],
    [0.164, 0.471, 0.558], [0.128, 0.567, 0.551], [0.135, 0.659, 0.518], [0.267, 0.749, 0.441],
    [0.478, 0.821, 0.318], [0.741, 0.873, 0.150], [0.993, 0.906, 0.144]]);
  /* FLIP's own magma map, from nv-flip. */
  const MAGMA = bytesOf(M.magma);
  const REL_DECADES = [-3, 1]; /* relative error shown from 1e-3 to 10, log scale */

  const lumAt = (X, n, i) => 0.2126 * X[i] + 0.7152 * X[n + i] + 0.0722 * X[2 * n + i];

  /* ---------- painting a pane (native size, offscreen) ---------- */

  const panes = Object.fromEntries(PANES.map((p) => [p, { canvas: document.createElement('canvas'), data: null, note: '' }]));

  /* What a pane shows: the cell, its film and its reference's film (either may be absent). */
  async function paneData(i) {
    const cell = M.cells[i];
    if (!cell.data) return { i, cell, film: null, ref: null };
    const ref = cell.reference != null ? M.references[cell.reference] : null;
    const [f, r] = await Promise.all([film(cell.data), ref ? film(ref.data) : null]);
    return { i, cell, film: f, ref: r };
  }

  /* A layer of a pane's cell (`reference`: its reference as the cell displays it). */
  function values(d, layer) {
    if (!d.film) return null;
    if (layer === 'reference') return d.ref ? sum(d.ref, d.cell.shows) : null;
    if (layer === 'total') return sum(d.film, d.cell.shows);
    return d.film.layers[layer];
  }

  /* The reference's counterpart of a layer, for the relative error. */
  function refValues(d, layer) {
    if (!d.ref || d.ref.n !== d.film.n) return null;
    return layer === 'total' || layer === 'reference' ? sum(d.ref, d.cell.shows) : d.ref.layers[layer];
  }

  function paintImage(o, X, n) {
    const k = 65535 * 2 ** S.exposure, T = tone();
    for (let i = 0, j = 0; i < n; i++, j += 4) {
      for (let c = 0; c < 3; c++) {
        const v = X[c * n + i] * k;
        o[j + c] = T[v >= 65535 ? 65535 : v > 0 ? (v + 0.5) | 0 : 0];
      }
      o[j + 3] = 255;
    }
  }

  function paintMap(o, n, map, t) { /* t(i) in [0, 1] -> colour */
    for (let i = 0, j = 0; i < n; i++, j += 4) {
      const v = t(i), q = 3 * Math.round(255 * (v > 1 ? 1 : v > 0 ? v : 0));
      o[j] = map[q]; o[j + 1] = map[q + 1]; o[j + 2] = map[q + 2]; o[j + 3] = 255;
    }
  }

  const diffRange = () => 2 ** (S.range - S.exposure);

  /* |X - R| / sqrt(R² + 0.01 mean(R)²) on luminance: the regulariser of the report's relMSE. */
  function relative(X, R, n) {
    let mean = 0;
    for (let i = 0; i < n; i++) mean += lumAt(R, n, i);
    const eps2 = 0.01 * (mean / n) ** 2 || 1e-30;
    return (i) => { const r = lumAt(R, n, i); return Math.abs(lumAt(X, n, i) - r) / Math.sqrt(r * r + eps2); };
  }

  /* Paints pane `p` from its data `d`; `other` is the other pane's (for A − B). */
  function paint(p, d, other) {
    p.data = d;
    p.note = '';
    const f = d.film;
    if (!f) { p.note = `${cellLabel(d.i)} is ${d.cell.status}: no image`; return; }
    const n = f.n, c = p.canvas;
    if (c.width !== f.w || c.height !== f.h) { c.width = f.w; c.height = f.h; }
    const img = new ImageData(f.w, f.h), o = img.data;
    const X = values(d, S.layer);
    if (!X) p.note = `${cellLabel(d.i)} has no reference`;
    else if (S.mode === 'image') paintImage(o, X, n);
    else if (S.mode === 'diff') {
      const Y = other.film && other.film.n === n && other.film.w === f.w ? values(other, S.layer) : null;
      if (!Y) p.note = other.film ? 'A and B differ in size' : 'the other cell has no image';
      else { const r = diffRange(); paintMap(o, n, COOLWARM, (i) => 0.5 + (0.5 * (lumAt(X, n, i) - lumAt(Y, n, i))) / r); }
    } else if (S.mode === 'rel') {
      const R = refValues(d, S.layer);
      if (!R) p.note = `${cellLabel(d.i)} has no reference`;
      else {
        const rel = relative(X, R, n), [lo, hi] = REL_DECADES;
        paintMap(o, n, VIRIDIS, (i) => (Math.log10(rel(i) + 1e-30) - lo) / (hi - lo));
      }
    } else if (!f.flip) p.note = `${cellLabel(d.i)} has no reference, so no FLIP map`;
    else paintMap(o, n, MAGMA, (i) => f.flip[i] / 255);
    c.getContext('2d').putImageData(img, 0, 0);
  }

  /* ---------- views: display canvases sharing one zoom and pan ---------- */

  const views = [0, 1].map((k) => ({ el: $(`ex-view-${k}`), canvas: $(`ex-canvas-${k}`), tag: $(`ex-tag-${k}`), msg: $(`ex-msg-${k}`) }));
  const splitCanvas = $('ex-canvas-split');

  /* Which pane a view shows (view 0 in split mode shows A, with B right of the line). */
  function paneOf(view) {
    if (view === 1) return 'b';
    return S.compare === 'flip' && S.flipped ? 'b' : 'a';
  }

  function blit(canvas, p) {
    const dpr = window.devicePixelRatio || 1, w = Math.round(canvas.clientWidth * dpr), h = Math.round(canvas.clientHeight * dpr);
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    const g = canvas.getContext('2d'), v = S.view;
    g.setTransform(1, 0, 0, 1, 0, 0);
    g.clearRect(0, 0, w, h);
    if (!v || !p.data || !p.data.film || p.note) return;
    g.imageSmoothingEnabled = false; /* nearest neighbour: pixels stay pixels */
    g.setTransform(dpr * v.s, 0, 0, dpr * v.s, dpr * v.tx, dpr * v.ty);
    g.drawImage(p.canvas, 0, 0);
    if (S.hover && v.s >= 6) { /* outline the pixel under the cursor */
      g.setTransform(1, 0, 0, 1, 0, 0);
      g.strokeStyle = '#39ff14';
      g.lineWidth = 1;
      g.strokeRect(Math.round(dpr * (v.tx + S.hover.x * v.s)) + 0.5, Math.round(dpr * (v.ty + S.hover.y * v.s)) + 0.5,
        Math.round(dpr * v.s) - 1, Math.round(dpr * v.s) - 1);
    }
  }

  function tagText(pane) {
    const i = S[pane];
    return `${pane.toUpperCase()}: ${M.cells[i].label}`;
  }

  /* Draws every view from the panes' canvases: cheap, run on every zoom, pan and split. */
  let viewWidth = 0;
  function present() {
    const side = S.compare === 'side', split = S.compare === 'split';
    views[1].el.hidden = !side;
    $('ex-views').classList.toggle('ex-one', !side); /* split and flip use the full width */
    const width = views[0].el.clientWidth;
    if (S.view && viewWidth && width !== viewWidth) S.view = { ...S.view, tx: S.view.tx + (width - viewWidth) / 2 };
    viewWidth = width; /* a wider or narrower view keeps the image centred */
    $('ex-clip').hidden = !split;
    $('ex-split-line').hidden = !split;
    const first = paneOf(0);
    blit(views[0].canvas, panes[first]);
    views[0].tag.textContent = split ? `${tagText('a')}  |  ${tagText('b')}` : tagText(first);
    views[0].msg.textContent = panes[first].note || (split ? panes.b.note : '');
    if (side) {
      blit(views[1].canvas, panes.b);
      views[1].tag.textContent = tagText('b');
      views[1].msg.textContent = panes.b.note;
    }
    if (split) {
      blit(splitCanvas, panes.b);
      $('ex-clip').style.clipPath = `inset(0 0 0 ${100 * S.split}%)`;
      $('ex-split-line').style.left = `${100 * S.split}%`;
    }
  }

  function fit() {
    const f = (panes.a.data && panes.a.data.film) || (panes.b.data && panes.b.data.film);
    if (!f) return;
    const r = views[0].el.getBoundingClientRect(), s = Math.min(r.width / f.w, r.height / f.h);
    setView(s, (r.width - f.w * s) / 2, (r.height - f.h * s) / 2);
  }

  function setView(s, tx, ty) {
    S.view = { s, tx, ty };
    present();
  }

  function zoomAt(factor, mx, my) {
    const v = S.view;
    if (!v) return;
    const s = Math.min(512, Math.max(0.02, v.s * factor));
    setView(s, mx - ((mx - v.tx) * s) / v.s, my - ((my - v.ty) * s) / v.s);
  }

  function zoomCentre(factor) {
    const r = views[0].el.getBoundingClientRect();
    zoomAt(factor, r.width / 2, r.height / 2);
  }

  /* The screen point (client coordinates) of image pixel (x, y)'s centre in a view. */
  function clientPoint(x, y, view = 0) {
    const r = views[view].el.getBoundingClientRect(), v = S.view;
    return { x: r.left + v.tx + (x + 0.5) * v.s, y: r.top + v.ty + (y + 0.5) * v.s };
  }

  function bindViews() {
    for (const view of views) {
      const el = view.el;
      el.addEventListener('wheel', (e) => {
        e.preventDefault();
        const r = el.getBoundingClientRect();
        zoomAt(e.deltaY < 0 ? 1.25 : 0.8, e.clientX - r.left, e.clientY - r.top);
        hover(e, el);
      }, { passive: false });
      let drag = null;
      el.addEventListener('pointerdown', (e) => {
        if (!S.view || e.button !== 0) return;
        const r = el.getBoundingClientRect();
        const onLine = S.compare === 'split' && Math.abs(e.clientX - r.left - S.split * r.width) < 8;
        drag = { line: onLine, x: e.clientX, y: e.clientY, tx: S.view.tx, ty: S.view.ty };
        el.setPointerCapture(e.pointerId);
        root.focus({ preventScroll: true });
      });
      el.addEventListener('pointerup', () => { drag = null; });
      el.addEventListener('pointercancel', () => { drag = null; });
      el.addEventListener('pointermove', (e) => {
        if (drag && e.buttons & 1) {
          const r = el.getBoundingClientRect();
          if (drag.line) { S.split = Math.min(1, Math.max(0, (e.clientX - r.left) / r.width)); $('ex-split').value = S.split; }
          else S.view = { s: S.view.s, tx: drag.tx + e.clientX - drag.x, ty: drag.ty + e.clientY - drag.y };
        }
        hover(e, el);
      });
      el.addEventListener('pointerleave', () => { S.hover = null; present(); });
      el.addEventListener('dblclick', fit);
    }
    window.addEventListener('resize', present);
  }

  function hover(e, el) {
    if (!S.view) return;
    const r = el.getBoundingClientRect();
    const x = Math.floor((e.clientX - r.left - S.view.tx) / S.view.s), y = Math.floor((e.clientY - r.top - S.view.ty) / S.view.s);
    S.hover = { x, y };
    present();
    readout();
  }

  /* ---------- pixel readout ---------- */

  const fmt = (v) => {
    if (!Number.isFinite(v)) return String(v);
    if (v === 0) return '0';
    const a = Math.abs(v);
    return a >= 1e4 || a < 1e-3 ? v.toExponential(3) : v.toPrecision(4);
  };
  const rgbAt = (X, n, i) => (X ? [X[i], X[n + i], X[2 * n + i]] : null);

  /* Linear values of every layer of both panes at the hovered pixel (null outside). */
  function samples(x, y) {
    const out = { x, y };
    for (const pane of PANES) {
      const d = panes[pane].data;
      const f = d && d.film;
      if (!f || x < 0 || y < 0 || x >= f.w || y >= f.h) { out[pane] = null; continue; }
      const i = y * f.w + x, s = { pixel: i };
      for (const l of LAYERS) s[l] = rgbAt(values(d, l), f.n, i);
      const R = refValues(d, 'total');
      if (R) s.rel = relative(values(d, 'total'), R, f.n)(i);
      if (f.flip) s.flip = f.flip[i] / 255;
      out[pane] = s;
    }
    return out;
  }

  function readout() {
    const t = $('ex-readout');
    if (!S.hover) { t.textContent = ''; return; }
    const r = samples(S.hover.x, S.hover.y);
    hook.lastReadout = r;
    const lum = (v) => 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
    const cell = (pane, f) => { const s = r[pane]; return s ? f(s) : '–'; };
    /* A committed report may hold binned pixel data: each value is the mean of bin × bin pixels. */
    const film = PANES.map((p) => panes[p].data && panes[p].data.film).find((f) => f);
    const bin = film ? film.bin : 1;
    const at = bin > 1
      ? `pixels (${r.x * bin}–${r.x * bin + bin - 1}, ${r.y * bin}–${r.y * bin + bin - 1}), mean of ${bin}×${bin}`
      : `pixel (${r.x}, ${r.y})`;
    const rows = [[at, 'A', 'B']];
    for (const l of LAYERS) {
      rows.push([l + (l === S.layer ? ' ◂' : ''), ...PANES.map((p) => cell(p, (s) => (s[l] ? s[l].map(fmt).join('  ') : '–')))]);
    }
    const ta = r.a && r.a.total, tb = r.b && r.b.total;
    rows.push(['A − B (luminance, total)', ta && tb ? fmt(lum(ta) - lum(tb)) : '–', '']);
    rows.push(['relative error vs reference', ...PANES.map((p) => cell(p, (s) => (s.rel != null ? fmt(s.rel) : '–')))]);
    rows.push(['FLIP vs reference', ...PANES.map((p) => cell(p, (s) => (s.flip != null ? fmt(s.flip) : '–')))]);
    t.replaceChildren(...rows.map((row, k) => {
      const tr = document.createElement('tr');
      for (const text of row) { const td = document.createElement(k === 0 ? 'th' : 'td'); td.textContent = text; tr.append(td); }
      return tr;
    }));
  }

  /* ---------- rendering ---------- */

  let renderSeq = 0;
  let busy = Promise.resolve();

  function fail(e) {
    hook.errors.push(String(e && e.message ? e.message : e));
    views[0].msg.textContent = String(e && e.message ? e.message : e);
    console.error('explorer:', e);
  }

  /* Loads and paints both panes; a newer call supersedes an older one still loading. */
  function render() {
    const seq = ++renderSeq;
    busy = (async () => {
      const t0 = performance.now();
      const [A, B] = await Promise.all([paneData(S.a), paneData(S.b)]);
      if (seq !== renderSeq) return;
      paint(panes.a, A, B);
      paint(panes.b, B, A);
      if (!S.view) fit();
      present();
      legend();
      if (S.hover) readout();
      hook.renders++;
      hook.lastRenderMs = performance.now() - t0;
      if (hook.readyAt == null) hook.readyAt = performance.now();
      document.body.dataset.explorerRendered = String(hook.renders);
    })().catch(fail);
    return busy;
  }

  function legend() {
    const bar = $('ex-legend-bar'), text = $('ex-legend-text');
    const map = { diff: COOLWARM, rel: VIRIDIS, flip: MAGMA }[S.mode];
    bar.hidden = !map;
    if (map) {
      const g = bar.getContext('2d'), img = g.createImageData(256, 1);
      for (let i = 0; i < 256; i++) { img.data.set(map.subarray(3 * i, 3 * i + 3), 4 * i); img.data[4 * i + 3] = 255; }
      g.putImageData(img, 0, 0);
    }
    const ev = `exposure ${S.exposure >= 0 ? '+' : ''}${S.exposure.toFixed(1)} EV, ${S.transfer === 'srgb' ? 'sRGB' : `gamma ${S.gamma}`}`;
    const flipEv = M.cells[S.a].exposure;
    text.textContent = {
      image: `${S.layer}: ${ev}`,
      diff: `luminance of ${S.layer}, this pane minus the other: blue −${fmt(diffRange())} … grey 0 … red +${fmt(diffRange())}`,
      rel: `|${S.layer} − reference| / √(reference² + 0.01·mean²), luminance: 10^${REL_DECADES[0]} … 10^${REL_DECADES[1]} (log)`,
      flip: `FLIP of the displayed image against the reference at ${flipEv == null ? 'the cell’s' : `${flipEv} EV`} exposure: 0 … 1` +
        (M.cells[S.a].flip != null ? ` (A's mean ${fmt(M.cells[S.a].flip)})` : ''),
    }[S.mode];
  }

  /* ---------- controls ---------- */

  function buildPickers() {
    for (const pane of PANES) {
      const box = $(`ex-pick-${pane}`);
      M.axes.forEach((axis, k) => {
        const label = document.createElement('label');
        label.className = 'ex-axis';
        label.dataset.axis = k;
        label.title = axis.key;
        const sel = document.createElement('select');
        sel.id = `ex-pick-${pane}-${k}`;
        axis.values.forEach((v, j) => sel.add(new Option(v, String(j))));
        sel.addEventListener('change', () => {
          const coords = M.cells[S[pane]].coords.slice();
          coords[k] = +sel.value;
          S.axis = k;
          const i = closest(coords, [k]);
          if (i >= 0) select(pane, i); else syncControls();
        });
        label.append(`${axis.name} `, sel);
        box.append(label);
      });
      const status = document.createElement('span');
      status.className = 'ex-status';
      status.id = `ex-status-${pane}`;
      box.append(status);
    }
  }

  function bindControls() {
    const on = (id, key, parse, then) => $(id).addEventListener('input', (e) => { S[key] = parse(e.target.value); then(); saveHash(); });
    const text = (v) => v, num = (v) => +v;
    on('ex-compare', 'compare', text, () => { S.flipped = false; present(); syncControls(); });
    on('ex-split', 'split', num, present);
    on('ex-layer', 'layer', text, render);
    on('ex-mode', 'mode', text, render);
    on('ex-exposure', 'exposure', num, () => { syncControls(); render(); });
    on('ex-transfer', 'transfer', text, render);
    on('ex-gamma', 'gamma', (v) => Math.min(5, Math.max(0.2, +v || 2.2)), render);
    on('ex-range', 'range', num, () => { syncControls(); render(); });
    $('ex-fit').addEventListener('click', fit);
    $('ex-one').addEventListener('click', () => zoomCentre(1 / S.view.s));
    $('ex-swap').addEventListener('click', swap);
  }

  function swap() {
    [S.a, S.b] = [S.b, S.a];
    saveHash();
    syncControls();
    return render();
  }

  function flip() {
    if (S.compare !== 'flip') { S.compare = 'flip'; S.flipped = true; } else S.flipped = !S.flipped;
    present();
    syncControls();
    saveHash();
  }

  const cycle = (list, v, by) => list[(list.indexOf(v) + by + list.length) % list.length];

  /* Keys anywhere on the page except while typing; arrows only over or inside the explorer
   * (elsewhere they scroll the page). */
  function onKey(e) {
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    const t = e.target;
    if (t instanceof Element && t.closest('textarea, select, [contenteditable], input:not([type=range])')) return;
    const arrow = e.key.startsWith('Arrow');
    if (arrow && (t instanceof HTMLInputElement || !(root.contains(document.activeElement) || root.matches(':hover')))) return;
    const k = e.key;
    if (k === 'f') flip();
    else if (k === 'c') { S.compare = cycle(COMPARES, S.compare, 1); S.flipped = false; present(); syncControls(); saveHash(); }
    else if (k >= '1' && k <= '5') { S.layer = LAYERS[+k - 1]; syncControls(); saveHash(); render(); }
    else if (k === 'm' || k === 'M') { S.mode = cycle(MODES, S.mode, k === 'm' ? 1 : -1); syncControls(); saveHash(); render(); }
    else if (k === 'e' || k === 'E') { S.exposure += k === 'e' ? 0.5 : -0.5; syncControls(); saveHash(); render(); }
    else if (k === 'g') { S.transfer = S.transfer === 'srgb' ? 'power' : 'srgb'; syncControls(); render(); }
    else if (k === '+' || k === '=') zoomCentre(2);
    else if (k === '-') zoomCentre(0.5);
    else if (k === '0') fit();
    else if (k === 'o') zoomCentre(1 / S.view.s);
    else if (k === 'x') swap();
    else if (k === 'ArrowRight' || k === 'ArrowLeft') step(e.shiftKey ? 'b' : 'a', k === 'ArrowRight' ? 1 : -1);
    else if ((k === 'ArrowUp' || k === 'ArrowDown') && M.axes.length) {
      S.axis = (S.axis + (k === 'ArrowDown' ? 1 : -1) + M.axes.length) % M.axes.length;
      syncControls();
    } else return;
    e.preventDefault();
  }

  /* Puts the state into every control, the table and the plots. */
  function syncControls() {
    for (const pane of PANES) {
      const c = M.cells[S[pane]];
      M.axes.forEach((_, k) => {
        const sel = $(`ex-pick-${pane}-${k}`);
        if (c.coords[k] != null) sel.value = String(c.coords[k]);
        sel.parentElement.classList.toggle('ex-active', k === S.axis);
      });
      $(`ex-status-${pane}`).textContent = c.status === 'done' ? '' : c.status;
    }
    $('ex-compare').value = S.compare;
    $('ex-split-control').hidden = S.compare !== 'split';
    $('ex-range-control').hidden = S.mode !== 'diff';
    $('ex-layer').value = S.layer;
    $('ex-mode').value = S.mode;
    $('ex-exposure').value = S.exposure;
    $('ex-exposure-value').textContent = `${S.exposure >= 0 ? '+' : ''}${S.exposure.toFixed(1)} EV`;
    $('ex-transfer').value = S.transfer;
    $('ex-gamma').value = S.gamma;
    $('ex-gamma').hidden = S.transfer !== 'power';
    $('ex-range').value = S.range;
    $('ex-range-value').textContent = fmt(diffRange());
    markCells();
  }

  /* ---------- plots and the cells table open cells ---------- */

  const plotPoints = Array.from(document.querySelectorAll('svg.plot-points circle')).map((el) => ({
    el, cells: el.dataset.cells.split(' ').map((s) => byIndex.get(+s)).filter((i) => i !== undefined),
  }));
  const tableRows = [];

  function markCells() {
    for (const p of plotPoints) {
      p.el.classList.toggle('ex-a', p.cells.includes(S.a));
      p.el.classList.toggle('ex-b', p.cells.includes(S.b));
    }
    for (const r of tableRows) {
      r.el.classList.toggle('ex-a', r.cell === S.a);
      r.el.classList.toggle('ex-b', r.cell === S.b);
    }
  }

  function linkPlots() {
    for (const p of plotPoints) {
      p.el.addEventListener('click', (e) => {
        if (!p.cells.length) return;
        const pane = e.shiftKey ? 'b' : 'a';
        select(pane, likeCurrent(p.cells, pane));
        root.scrollIntoView({ block: 'start' });
      });
    }
  }

  /* Sorting by a header click, a filter box, and a row click that opens the cell. */
  function linkTable() {
    const table = $('cells-table');
    if (!table) return;
    const header = table.rows[0], body = table.tBodies[0] || header.parentElement;
    const names = Array.from(header.cells, (c) => c.textContent.trim().toLowerCase());
    for (const tr of Array.from(table.rows).slice(1)) {
      const cell = byIndex.get(+tr.cells[0].textContent);
      if (cell === undefined) continue;
      tr.classList.add('ex-row');
      tr.title = 'open in A (shift: in B)';
      tableRows.push({ el: tr, cell, texts: Array.from(tr.cells, (c) => c.textContent.trim()) });
      tr.addEventListener('click', (e) => {
        const pane = e.shiftKey ? 'b' : 'a';
        select(pane, cell);
        root.scrollIntoView({ block: 'start' });
      });
    }
    let sortBy = -1, dir = 1;
    Array.from(header.cells).forEach((th, k) => {
      th.title = 'sort';
      th.addEventListener('click', () => {
        dir = sortBy === k ? -dir : 1;
        sortBy = k;
        for (const c of header.cells) c.classList.remove('ex-up', 'ex-down');
        th.classList.add(dir > 0 ? 'ex-up' : 'ex-down');
        const numeric = tableRows.every((r) => r.texts[k] === '' || Number.isFinite(Number(r.texts[k])));
        const key = (r) => (numeric ? (r.texts[k] === '' ? NaN : Number(r.texts[k])) : r.texts[k]);
        const sorted = tableRows.slice().sort((x, y) => {
          const a = key(x), b = key(y);
          if (numeric && (Number.isNaN(a) || Number.isNaN(b))) return Number.isNaN(a) - Number.isNaN(b); /* empty last */
          return (a < b ? -1 : a > b ? 1 : 0) * dir || x.cell - y.cell;
        });
        body.append(...sorted.map((r) => r.el));
      });
    });
    const box = document.createElement('div');
    box.className = 'ex-filter';
    box.innerHTML = '<label>filter <input id="cells-filter" type="search" placeholder="text, or column=value, column&lt;number, …"></label> <span id="cells-count"></span>';
    table.before(box);
    const input = $('cells-filter');
    input.addEventListener('input', () => filterRows(names, input.value));
    filterRows(names, '');
  }

  /* Terms separated by spaces or commas, all of which a row must meet: `col=v`, `col!=v`,
   * `col<v`, `col<=v`, `col>v`, `col>=v` (col: a header, or the end of one, like `nused`)
   * or plain text anywhere in the row. */
  function filterRows(names, query) {
    const terms = query.replace(/\s*(<=|>=|!=|=|<|>)\s*/g, '$1').split(/[\s,]+/).filter(Boolean).map((term) => {
      const m = term.match(/^([^<>=!]+)(<=|>=|!=|=|<|>)(.*)$/);
      if (!m) return { text: term.toLowerCase() };
      const name = m[1].toLowerCase();
      const col = names.findIndex((h) => h === name || h.endsWith('.' + name) || h.startsWith(name + ' '));
      return col < 0 ? { text: term.toLowerCase() } : { col, op: m[2], value: m[3] };
    });
    const test = (r, t) => {
      if (t.text) return r.texts.some((s) => s.toLowerCase().includes(t.text));
      const s = r.texts[t.col], a = Number(s), b = Number(t.value), num = s !== '' && Number.isFinite(a) && Number.isFinite(b);
      switch (t.op) {
        case '=': return num ? a === b : s.toLowerCase() === t.value.toLowerCase();
        case '!=': return num ? a !== b : s.toLowerCase() !== t.value.toLowerCase();
        case '<': return num && a < b;
        case '<=': return num && a <= b;
        case '>': return num && a > b;
        default: return num && a >= b;
      }
    };
    let shown = 0;
    for (const r of tableRows) {
      const ok = terms.every((t) => test(r, t));
      r.el.hidden = !ok;
      shown += ok ? 1 : 0;
    }
    $('cells-count').textContent = `${shown} of ${tableRows.length} cells`;
  }

  /* ---------- the state in the address (#a=…&b=…), so a view can be shared ---------- */

  function saveHash() {
    const p = new URLSearchParams({ a: M.cells[S.a].index, b: M.cells[S.b].index, layer: S.layer, mode: S.mode, compare: S.compare, ev: S.exposure });
    try { history.replaceState(null, '', `#${p}`); } catch (_) { /* some file:// setups refuse; the state just is not kept */ }
  }

  function restoreHash() {
    const p = new URLSearchParams(location.hash.slice(1));
    const cell = (k) => (p.has(k) ? byIndex.get(Number(p.get(k))) : undefined); /* Number(null) is 0 */
    if (cell('a') !== undefined) S.a = cell('a');
    if (cell('b') !== undefined) S.b = cell('b');
    if (LAYERS.includes(p.get('layer'))) S.layer = p.get('layer');
    if (MODES.includes(p.get('mode'))) S.mode = p.get('mode');
    if (COMPARES.includes(p.get('compare'))) S.compare = p.get('compare');
    if (p.has('ev') && Number.isFinite(+p.get('ev'))) S.exposure = +p.get('ev');
  }

  /* ---------- start ---------- */

  function start() {
    const done = M.cells.map((c, i) => (c.data ? i : -1)).filter((i) => i >= 0);
    /* The study's own pair (the swept axis's ends), else the first two finished cells. */
    const pair = M.start;
    S.a = pair ? pair[0] : done.length ? done[0] : 0;
    S.b = pair ? pair[1] : done.length > 1 ? done[1] : S.a;
    S.exposure = M.cells[S.a].exposure || 0;
    restoreHash();
    buildPickers();
    bindControls();
    bindViews();
    linkPlots();
    linkTable();
    document.addEventListener('keydown', onKey);
    syncControls();
    if (!M.cells.length || typeof DecompressionStream === 'undefined') {
      views[0].msg.textContent = M.cells.length ? 'this browser cannot inflate the pixel data (no DecompressionStream)' : 'no cells';
      hook.readyAt = performance.now();
      return;
    }
    render();
  }

  Object.assign(hook, {
    select, step, swap, flip, setView, fit, zoomAt, clientPoint, samples,
    render: () => render(),
    idle: () => busy,
    uiMs: 0,
  });
  const t0 = performance.now();
  start();
  hook.uiMs = performance.now() - t0;
})();
