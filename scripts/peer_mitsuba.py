#!/usr/bin/env python3
"""Renders a scene exported by `sweep export --format mitsuba` with Mitsuba 3.

Called by `sweep bench --peer mitsuba` (through scripts/peer-mitsuba.sh, which installs
Mitsuba into its own virtual environment). For every (max_depth, spp, seed) asked for it
writes a PFM and prints one JSON line:

    {"max_depth": 2, "spp": 16, "seed": 0, "file": ".../mitsuba-d2-spp16-s0.pfm",
     "cpu_s": 0.41, "wall_s": 0.22, "mean": [r, g, b], "variant": "scalar_rgb"}

CPU seconds are the process's (all threads) around `mi.render` and the read-back that
forces evaluation; scene loading, interpreter start and JIT warm-up are excluded (a 1-spp
render of the same scene precedes each timed one, so llvm kernels are compiled and cached).

Pitfalls handled (see volphot's crates/core/src/scene/export.rs for the scene side):
  * llvm variants crash on libLLVM 15/16 (`Cannot select fminimum`): `--variant auto` uses
    llvm_ad_rgb only when a libLLVM >= 17 is found (Debian's libllvm19), else scalar_rgb;
  * the same seed gives the same noise: seeds are explicit;
  * scalar renders depend on the thread count beyond 2 threads: the count is set.
"""
import argparse
import glob
import json
import os
import re
import sys
import time


def pick_variant(requested):
    if requested != "auto":
        return requested
    candidates = []
    for path in glob.glob("/usr/lib/*-linux-gnu/libLLVM*.so*"):
        m = re.search(r"libLLVM(?:-|\.so\.)(\d+)", os.path.basename(path))
        if m and int(m.group(1)) >= 17:
            candidates.append((int(m.group(1)), path))
    if not candidates:
        return "scalar_rgb"
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", max(candidates)[1])
    return "llvm_ad_rgb"


def write_pfm(path, image):
    import numpy as np

    h, w = image.shape[:2]
    with open(path + ".tmp", "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(np.flipud(image[:, :, :3]), dtype="<f4").tobytes())
    os.replace(path + ".tmp", path)


def existing_file(text):
    """An argparse type: a readable regular file (the scene), checked before Mitsuba loads."""
    if not os.path.isfile(text):
        raise argparse.ArgumentTypeError("%s: no such file (expected an exported Mitsuba XML)" % text)
    if not os.access(text, os.R_OK):
        raise argparse.ArgumentTypeError("%s: not readable" % text)
    return text


def comma_list(kind, what, valid):
    """An argparse type: comma-separated values of `kind`, each passing `valid`."""
    def parse(text):
        values = []
        for part in text.split(","):
            try:
                value = kind(part.strip())
            except ValueError:
                raise argparse.ArgumentTypeError("%r: expected %s" % (part, what))
            if not valid(value):
                raise argparse.ArgumentTypeError("%r: expected %s" % (part, what))
            values.append(value)
        return values
    return parse


def at_least(low, what):
    """An argparse type: an integer >= low."""
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError("%r: expected %s" % (text, what))
        if value < low:
            raise argparse.ArgumentTypeError("%r: expected %s" % (text, what))
        return value
    return parse


def max_depth(value):
    """Mitsuba's max_depth: -1 (unbounded) or at least 1."""
    return value == -1 or value >= 1


def import_mitsuba(ap):
    """drjit, mitsuba and numpy, imported once the arguments are read; without them, an
    error that says how to get them instead of a traceback."""
    try:
        import drjit as dr
        import mitsuba as mi
        import numpy as np
    except ImportError as e:
        ap.exit(2, "%s: error: %s: Mitsuba 3 is not installed for %s; "
                   "scripts/peer-mitsuba.sh installs it into its own virtual environment\n"
                   % (ap.prog, e, sys.executable))
    return dr, mi, np


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", type=existing_file, help="the exported Mitsuba XML")
    ap.add_argument("--out", required=True, help="folder for the PFM images")
    ap.add_argument("--max-depth", default="2,-1",
                    type=comma_list(int, "-1 or an integer >= 1", max_depth),
                    help="comma-separated (2: single scattering, -1: all)")
    ap.add_argument("--spp", default="4,16,64",
                    type=comma_list(int, "an integer >= 1", lambda v: v >= 1),
                    help="comma-separated samples per pixel")
    ap.add_argument("--seeds", type=at_least(1, "an integer >= 1"), default=1,
                    help="seeds 0..N-1 per setting")
    ap.add_argument("--variant", default="auto", choices=["auto", "scalar_rgb", "llvm_ad_rgb"])
    ap.add_argument("--threads", type=at_least(1, "an integer >= 1"), default=2)
    args = ap.parse_args()
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        ap.error("--out %s: is a file; expected a folder" % args.out)

    variant = pick_variant(args.variant)
    dr, mi, np = import_mitsuba(ap)
    mi.set_variant(variant)
    dr.set_thread_count(args.threads)
    os.makedirs(args.out, exist_ok=True)
    for depth in args.max_depth:
        scene = mi.load_file(args.scene, max_depth=depth)
        np.array(mi.render(scene, spp=1, seed=10**6))  # warm-up (JIT compile), not timed
        for spp in args.spp:
            for seed in range(args.seeds):
                wall, cpu = time.perf_counter(), time.process_time()
                image = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float32)
                cpu = time.process_time() - cpu
                wall = time.perf_counter() - wall
                name = "mitsuba-d%d-spp%d-s%d.pfm" % (depth, spp, seed)
                path = os.path.join(args.out, name)
                write_pfm(path, image)
                print(json.dumps({
                    "max_depth": depth, "spp": spp, "seed": seed, "file": path,
                    "cpu_s": cpu, "wall_s": wall, "variant": variant,
                    "mitsuba": mi.__version__,
                    "mean": [float(v) for v in image.reshape(-1, 3).mean(0)],
                }), flush=True)


if __name__ == "__main__":
    sys.exit(main())
