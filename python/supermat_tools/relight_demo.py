#!/usr/bin/env python3
"""Renders glTF assets under a new environment map from a few views, all with one exposure: what the demo
shows beside a bake (the input mesh as given, the baked result and the truth, relit the same way).

  relight_demo.py --hdri MAP.hdr --out DIR [--size 256] [--views 2] [--angle DEG] [--exposure-from NAME]
                  NAME=FILE.gltf ...

Writes DIR/NAME_vK.png (RGBA, straight alpha) for each asset and view K. The exposure of each view is the
one auto-chosen (supermat_tools.smrender) for the --exposure-from asset (default: the last one, e.g. the truth), so
the pictures compare as they are. View 0 looks at the asset's front turned 30 degrees about the vertical,
from 25 degrees above; view k adds 360 / views degrees. Needs numpy, Pillow and scipy (Debian: python3-numpy
python3-pil python3-scipy)."""
import argparse
import os
import sys

import numpy as np
from PIL import Image

from supermat_tools import smrender as smr
from supermat_tools import eval_quality as evq


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hdri", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--views", type=int, default=2)
    ap.add_argument("--angle", type=float, default=120.0, help="the map's turn about the vertical, degrees")
    ap.add_argument("--key", type=float, default=0.18, help="the exposure key (mean luminance after exposure)")
    ap.add_argument("--exposure-from", default=None, help="the asset whose exposure every picture uses (default: the last)")
    ap.add_argument("assets", nargs="+", metavar="NAME=FILE.gltf")
    args = ap.parse_args()
    if args.size < 16 or args.views < 1:
        sys.exit("error: --size >= 16 and --views >= 1")
    assets = []
    for a in args.assets:
        name, eq, path = a.partition("=")
        if not eq or not name or not path:
            sys.exit(f"error: '{a}' is not NAME=FILE.gltf")
        try:
            assets.append((name, evq.Mesh(path)))
        except (OSError, ValueError, KeyError) as e:
            sys.exit(f"error: {path}: {e}")
    try:
        env = smr.EnvLight(args.hdri, cache=False)
    except (OSError, ValueError) as e:
        sys.exit(f"error: {args.hdri}: {e}")
    ref = args.exposure_from or assets[-1][0]
    if ref not in [n for n, _ in assets]:
        sys.exit(f"error: --exposure-from {ref}: no such asset")
    os.makedirs(args.out, exist_ok=True)
    env_rot = smr.rotation_y(np.radians(args.angle))
    for v in range(args.views):
        t = np.radians(25.0)
        tilt = np.array([[1, 0, 0], [0, np.cos(t), -np.sin(t)], [0, np.sin(t), np.cos(t)]])
        rot = (tilt @ smr.rotation_y(np.radians(30.0 + 360.0 * v / args.views))).astype(np.float32)
        shaded = {}
        for name, mesh in assets:
            gb = evq.downsample(evq.gbuffer(mesh, rot, 2 * args.size))
            shaded[name] = (gb, smr.shade(gb, env, env_rot))
        expo = smr.auto_exposure(shaded[ref][1], shaded[ref][0]["cov"], args.key)
        for name, _ in assets:
            gb, lin = shaded[name]
            rgb = np.where(gb["cov"][..., None] > 0, smr.tonemap(lin, expo, (1, 1, 1)), 0.0)
            rgba = np.concatenate([evq.quantise(rgb), evq.quantise(gb["cov"])[..., None]], -1)
            path = os.path.join(args.out, f"{name}_v{v}.png")
            try:
                Image.fromarray(rgba, "RGBA").save(path)
            except OSError as e:
                sys.exit(f"error: {path}: {e}")
            print(path)


if __name__ == "__main__":
    main()
