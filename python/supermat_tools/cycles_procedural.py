#!/usr/bin/env python3
"""Procedural glTF assets for the independent renderer's validation part (supermat_tools.cycles_render).

The real sample assets that a validation part can use without touching either renderer's held-out set have
no metal and roughness 1 (the glTF default: their authors gave none), so nothing about roughness or metallic
can be chosen on them.  These assets carry the training generator's materials (supermat_tools.gen_data's
procedural and photo-texture materials, metal included) on supermat_tools.gen_refine_data's procedural
meshes (1-3 parametric parts, a UV atlas), written as ordinary glTF (base colour and metallic-roughness
textures at --size texels): Cycles then renders them as it renders any asset, so what is measured on them is
how the default model reads a path tracer's pictures of materials it could know.  Seeds are their own
(never the training runs' 0..N), so no asset is a training sample.

  PYTHONPATH=python /usr/bin/python3 -m supermat_tools.cycles_procedural --hdri-dir HDRI --out DIR \\
      [--count 24] [--seed 61000] [--size 512] [--photo 0.5] [--dark-metal P] [--metal-rough P]
writes DIR/proc_NNN/glTF/proc_NNN.gltf (+ .bin and two PNGs), the sample-models layout cycles_render reads;
an asset already there is kept.  HDRI: the folder of the training maps (gen_data takes its photo textures
from them; the held-out maps are never used).  --dark-metal and --metal-rough are gen_data's (a metal's F0 darkened,
a masked or worn metal's roughness of its own, each with probability P, from the material's own stream, so P = 0
reproduces the earlier assets); an asset already in DIR is kept whatever they are, so a different setting wants
a folder of its own.
"""
import argparse
import os
import shutil
import tempfile

import numpy as np

from supermat_tools import gen_data as G
from supermat_tools import gen_refine_data as R
from supermat_tools import make_example_mesh as M


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hdri-dir", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--count", type=int, default=24)
    ap.add_argument("--seed", type=int, default=61000)
    ap.add_argument("--size", type=int, default=512, help="texture size")
    ap.add_argument("--photo", type=float, default=0.5)
    ap.add_argument("--mode-probs", default="0.62,0.12,0.13,0.13")
    ap.add_argument("--dark-metal", type=float, default=0.0, help="probability that a metal's F0 is darkened")
    ap.add_argument("--metal-rough", type=float, default=0.0,
                    help="probability that a masked / worn metal takes a roughness of its own")
    args = ap.parse_args()
    if not 0 <= args.dark_metal <= 1 or not 0 <= args.metal_rough <= 1:
        raise SystemExit("cycles_procedural: --dark-metal and --metal-rough want [0, 1]")
    mode_p = [float(x) for x in args.mode_probs.split(",")]
    photos = G.photo_textures(G.env_paths(args.hdri_dir)) if args.photo > 0 else None
    for i in range(args.count):
        name = f"proc_{i:03d}"
        final = os.path.join(args.out, name, "glTF")
        if os.path.exists(os.path.join(final, name + ".gltf")):
            continue
        rng = np.random.default_rng([args.seed, i])
        mesh = R.build(rng, args.size, photos, mode_p, args.photo, args.dark_metal, args.metal_rough)
        os.makedirs(os.path.join(args.out, name), exist_ok=True)
        tmp = tempfile.mkdtemp(prefix=".tmp_", dir=os.path.join(args.out, name))
        M.write_pbr_gltf(tmp, name, *mesh, generator="supermat supermat_tools.cycles_procedural")
        shutil.rmtree(final, ignore_errors=True)
        os.rename(tmp, final)
        print(f"{name}: metal {float(mesh[6].mean()):.2f}, roughness {float(mesh[5].mean()):.2f}", flush=True)


if __name__ == "__main__":
    main()
