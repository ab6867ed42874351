#!/usr/bin/env python3
"""Measures Mitsuba's ray-spawn offset at a null surface on an exported scene.

Mitsuba 3 spawns a ray that crosses a surface about (1 + max|p|)·1e-4 past it (p the hit
point), so a camera ray entering a medium through a null surface skips that much of it.
Translating the whole scene by T along (1, 1, 1) changes nothing for volphot but grows the
skipped layer with T: this renders the exported scene (single scattering, `--max-depth 2`,
or all of it, `-1`) as written and translated by each T, and writes the mean of each with its standard error over
seeds. A clipped volume's cut face is such a surface (docs/peer.md).

    scripts/peer_offset.py EXPORT.xml --translate 0,4,9 --spp 64 --seeds 6 --json OUT.json
    scripts/peer_offset.py EXPORT.xml --max-depth -1 --translate 0,100 --json OUT.json

Run it with the peer's Python (scripts/peer-mitsuba.sh installs Mitsuba into
${XDG_CACHE_HOME:-~/.cache}/volphot/mitsuba-venv); the variant is chosen as the peer's is.
"""
import argparse
import json
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_mitsuba import pick_variant  # noqa: E402


def translated(xml, t):
    """The scene moved by t along (1, 1, 1): every to_world but the environment's (a
    direction only) gains a translation; a shape without one gets it."""
    step = '<translate value="%g, %g, %g"/>' % (t, t, t)
    out = []
    for block in re.split(r'(?=<(?:shape|sensor|emitter|volume) )', xml):
        if block.startswith('<emitter type="envmap"'):
            out.append(block)
            continue
        if '</transform>' in block:
            block = block.replace('</transform>', step + '</transform>', 1)
        elif block.startswith('<shape '):
            head, rest = block.split('>', 1)
            block = head + '><transform name="to_world">' + step + '</transform>' + rest
        out.append(block)
    return ''.join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", help="the exported Mitsuba XML")
    ap.add_argument("--translate", default="0,4,9", help="comma-separated T")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--max-depth", type=int, default=2, help="2: single scattering, -1: all")
    ap.add_argument("--variant", default="auto")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    variant = pick_variant(args.variant)
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    dr.set_thread_count(2)
    xml = open(args.scene).read()
    rows = []
    for t in [float(v) for v in args.translate.split(",")]:
        path = args.scene.replace(".xml", "-moved.xml")
        with open(path, "w") as f:
            f.write(translated(xml, t))
        scene = mi.load_file(path, max_depth=args.max_depth)
        means = [float(np.array(mi.render(scene, spp=args.spp, seed=s), dtype=np.float64)
                       .reshape(-1, 3).mean()) for s in range(args.seeds)]
        mean = float(np.mean(means))
        se = float(np.std(means, ddof=1) / np.sqrt(len(means)))
        rows.append({"translate": t, "mean": mean, "standard_error": se})
        print("T = %-5g mean %.6f ± %.6f (%d seeds × %d spp)" % (t, mean, se, args.seeds, args.spp),
              flush=True)
        os.remove(path)
    if args.json:
        result = {"scene": os.path.basename(args.scene), "spp": args.spp, "seeds": args.seeds,
                  "variant": variant, "mitsuba": mi.__version__,
                  "part": "single" if args.max_depth == 2 else "all", "rows": rows}
        with open(args.json + ".tmp", "w") as f:
            json.dump(result, f, indent=2)
        os.replace(args.json + ".tmp", args.json)


if __name__ == "__main__":
    sys.exit(main())
