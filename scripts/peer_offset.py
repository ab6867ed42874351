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
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_mitsuba import (  # noqa: E402
    at_least, comma_list, existing_file, import_mitsuba, max_depth, pick_variant)


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
    ap.add_argument("scene", type=existing_file, help="the exported Mitsuba XML")
    ap.add_argument("--translate", default="0,4,9", help="comma-separated T",
                    type=comma_list(float, "a finite number", math.isfinite))
    ap.add_argument("--spp", type=at_least(1, "an integer >= 1"), default=64)
    ap.add_argument("--seeds", type=at_least(2, "an integer >= 2 (the standard error needs two)"),
                    default=6)
    ap.add_argument("--max-depth", type=int, default=2, help="2: single scattering, -1: all")
    ap.add_argument("--variant", default="auto", choices=["auto", "scalar_rgb", "llvm_ad_rgb"])
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    if not max_depth(args.max_depth):
        ap.error("--max-depth %d: expected -1 or an integer >= 1" % args.max_depth)
    if args.json and not os.path.isdir(os.path.dirname(os.path.abspath(args.json))):
        ap.error("--json %s: its folder does not exist" % args.json)
    if not args.scene.endswith(".xml"):
        ap.error("%s: expected an exported Mitsuba scene (.xml)" % args.scene)
    variant = pick_variant(args.variant)
    dr, mi, np = import_mitsuba(ap)

    mi.set_variant(variant)
    dr.set_thread_count(2)
    xml = open(args.scene).read()
    rows = []
    for t in args.translate:
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
