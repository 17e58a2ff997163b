#!/usr/bin/env python3
"""Training data from the independent renderer: a supermat_tools.cycles_render set, rendered with --normals,
repacked as supermat_tools.gen_data shards, so that train_default's phases read it beside the project
renderer's data (issue 61: a default model that reads more than one renderer).

    PYTHONPATH=python /usr/bin/python3 -m supermat_tools.cycles_data --set SET --hdri-dir HDRI --out DATA \\
        [--looks std0,std-1,std+1,filmic0] [--shard 256]

SET: a cycles_render folder of training assets (supermat_tools.cycles_procedural with seeds of their own, lit by
the training maps through --world-dir; never the sample assets, never Blender's world maps, which light the
evaluation).  Each (asset, view, look) is a sample: rgba the look's picture (straight alpha), albedo / rough /
metal the truth PNGs, normal the camera-frame normals; samples in asset order, so the last assets' views are
the ones train_default keeps for validation.  meta.json lists the training maps as gen_data does (the list
train_default checks when it concatenates data folders; the re-render loss draws its lighting from it).
"""
import argparse
import json
import os

import numpy as np
from PIL import Image

from supermat_tools import cycles_render as CR
from supermat_tools import gen_data as G


def load_view(set_dir, stem, look):
    def png(sub, name, mode):
        return np.asarray(Image.open(os.path.join(set_dir, sub, f"{stem}_{name}.png")).convert(mode))
    return {"rgba": png("inputs", look, "RGBA"), "albedo": png("truth", "albedo", "RGB"),
            "rough": png("truth", "roughness", "L"), "metal": png("truth", "metallic", "L"),
            "normal": np.load(os.path.join(set_dir, "truth", f"{stem}_normal.npy")).astype(np.float16)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", required=True, help="the cycles_render folder (rendered with --normals)")
    ap.add_argument("--hdri-dir", required=True, help="the training maps (the folder gen_data reads)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--looks", default="", help="comma list (default: every look the set has)")
    ap.add_argument("--shard", type=int, default=256)
    args = ap.parse_args()
    with open(os.path.join(args.set, "index.json")) as f:
        index = json.load(f)
    if not index.get("normals"):
        raise SystemExit(f"cycles_data: {args.set} was rendered without --normals (the re-render loss needs them)")
    envs = [os.path.basename(p) for p in G.env_paths(args.hdri_dir)]
    worlds = [w + ".hdr" for w in index["worlds"]]
    if not set(worlds) <= set(envs):
        raise SystemExit(f"cycles_data: {args.set} was lit by maps outside the training list: "
                         f"{sorted(set(worlds) - set(envs))}")
    looks = [x for x in args.looks.split(",") if x] or index["looks"]
    done = [a for a in index["assets"] if all(CR.view_done(args.set, a, v, True) for v in range(index["views"]))]
    if len(done) < len(index["assets"]):   # a set still rendering, or cut: its finished assets
        print(f"cycles_data: {len(index['assets']) - len(done)} of {len(index['assets'])} assets not (all) rendered: "
              f"left out", flush=True)
    if not done:
        raise SystemExit(f"cycles_data: no asset of {args.set} is rendered")
    index["assets"] = done
    items = [(f"{a}_{v}", look) for a in index["assets"] for v in range(index["views"]) for look in looks]
    os.makedirs(args.out, exist_ok=True)
    mpath = os.path.join(args.out, "meta.json")
    if os.path.exists(mpath):   # the shards kept by a resumed run must be of the same set, looks and shard size
        with open(mpath) as f:
            old = json.load(f)
        if (old.get("set"), old.get("looks"), old.get("shard")) != (os.path.abspath(args.set), looks, args.shard):
            raise SystemExit(f"cycles_data: {args.out} holds shards of another set, looks or shard size: "
                             "a new --out, or remove it")
    meta = {"size": index["size"], "count": len(items), "shard": args.shard, "views": 1, "renderer": index["renderer"],
            "set": os.path.abspath(args.set), "looks": looks, "envs": envs, "hdri_dir": os.path.abspath(args.hdri_dir),
            "held_out": list(G.HELD_OUT)}
    with open(mpath, "w") as f:
        json.dump(meta, f, indent=1)
    for s in range(0, len(items), args.shard):
        path = os.path.join(args.out, f"shard_{s // args.shard:04d}.npz")
        if os.path.exists(path) and s + args.shard <= len(items):   # a full shard is kept (a last one is remade)
            continue
        views = [load_view(args.set, stem, look) for stem, look in items[s:s + args.shard]]
        out = {k: np.stack([v[k] for v in views]) for k in views[0]}
        np.savez(path + ".tmp.npz", **out)
        os.replace(path + ".tmp.npz", path)
    metal = np.mean([float(np.asarray(Image.open(os.path.join(args.set, "truth", f"{a}_{v}_metallic.png"))).mean())
                     for a in index["assets"] for v in range(index["views"])]) / 255
    print(f"cycles_data: {len(items)} samples ({len(index['assets'])} assets x {index['views']} views x "
          f"{len(looks)} looks) in {(len(items) + args.shard - 1) // args.shard} shards; mean metallic "
          f"{metal:.3f} (background included)", flush=True)


if __name__ == "__main__":
    main()
