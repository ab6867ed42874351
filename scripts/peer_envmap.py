#!/usr/bin/env python3
"""Integrates the environment of a scene exported by `sweep export --format mitsuba` as
Mitsuba 3 reads it: its radiance integral over the sphere, its irradiance on given normals
and the centroid of its light, by a midpoint rule on an equirectangular grid of directions
(world space). Prints one JSON object:

    {"variant": ..., "grid": [W, H], "integral": [r, g, b],
     "irradiance": [[r, g, b], ...], "centroid": [x, y, z]}

`centroid` is ∫ L̄(ω)·ω dω / ∫ L̄(ω) dω with L̄ the mean of the channels. volphot's test
(tests/end_to_end/peer.rs) integrates its own environment on the same grid, so the two
differ only by how each reconstructs the map between texels.
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def normals(text):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError("%r: expected x,y,z triples separated by commas" % text)
    if not values or len(values) % 3:
        raise argparse.ArgumentTypeError("%r: expected x,y,z triples separated by commas" % text)
    return [values[i:i + 3] for i in range(0, len(values), 3)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", help="the exported Mitsuba XML")
    ap.add_argument("--grid", type=int, default=1024, help="directions per π of longitude (height of the grid)")
    ap.add_argument("--normals", type=normals, default=[[0, 0, 1]], help="x,y,z triples")
    ap.add_argument("--variant", default="auto", choices=["auto", "scalar_rgb", "llvm_ad_rgb"])
    args = ap.parse_args()
    if not os.path.isfile(args.scene):
        ap.error("%s: no such file (expected an exported Mitsuba XML)" % args.scene)
    if args.grid < 8:
        ap.error("--grid %d: expected at least 8" % args.grid)
    from peer_mitsuba import import_mitsuba, pick_variant
    dr, mi, np = import_mitsuba(ap)

    variant = pick_variant(args.variant)
    mi.set_variant(variant)
    scene = mi.load_file(args.scene)
    env = scene.environment()
    if env is None:
        ap.error("%s: the scene has no environment emitter" % args.scene)
    h, w = args.grid, 2 * args.grid
    theta = (np.arange(h) + 0.5) * math.pi / h
    phi = (np.arange(w) + 0.5) * 2 * math.pi / w
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    # World directions: z up in this grid (the grid only has to match volphot's).
    d = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1).reshape(-1, 3)
    weight = (np.sin(tt) * (math.pi / h) * (2 * math.pi / w)).reshape(-1)
    radiance = np.zeros((d.shape[0], 3))
    chunk = 1 << 20 if variant.startswith("llvm") else 1
    if variant.startswith("llvm"):
        for s in range(0, d.shape[0], chunk):
            part = d[s:s + chunk]
            si = dr.zeros(mi.SurfaceInteraction3f, part.shape[0])
            si.wi = mi.Vector3f(-part[:, 0], -part[:, 1], -part[:, 2])
            value = np.array(env.eval(si))
            # drjit returns channels first (3 × n) for wide variants.
            radiance[s:s + chunk] = value.T if value.shape[0] == 3 and value.shape[-1] != 3 else value
    else:
        for i in range(d.shape[0]):
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*(-d[i]))
            radiance[i] = np.array(env.eval(si))
    integral = (radiance * weight[:, None]).sum(axis=0)
    grey = radiance.mean(axis=1) * weight
    centroid = (d * grey[:, None]).sum(axis=0) / grey.sum()
    irradiance = []
    for n in args.normals:
        n = np.array(n, dtype=float) / np.linalg.norm(n)
        cos = np.clip(d @ n, 0, None)
        irradiance.append(list((radiance * (weight * cos)[:, None]).sum(axis=0)))
    print(json.dumps({"variant": variant, "grid": [w, h], "integral": list(integral),
                      "irradiance": irradiance, "centroid": list(centroid)}))


if __name__ == "__main__":
    main()
