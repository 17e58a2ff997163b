#!/usr/bin/env python3
"""Training data for the UV-refine networks: what the mesh pipeline itself produces on procedural meshes.

Each sample is one procedural asset of our own, made and baked here:
  1. 1-3 parametric parts (ellipsoids, superquadrics, rounded boxes, capsules, tori, displaced blobs), each
     turned and placed at random, in one mesh with UVs: every part is cut into 1 or 2 charts along its
     angle (seams where the angles wrap and where it is cut), the charts laid out in a grid atlas with
     random gaps; vertex normals from the faces;
  2. its true albedo / roughness / metallic textures from supermat_tools.gen_data's procedural materials (one
     material per part, evaluated at each texel's 3D point; --photo, --mode-probs as gen_data);
  3. supermat_tools.litbake bakes its lighting into the base colour under a training map (never the held-out
     ones: gen_data.HELD_OUT), turned at random: the input `supermat mesh` expects;
  4. `supermat mesh --no-refine --debug-dir` runs the view model (--model: a SuperMatMV model, or a
     single-view one view by view) on the six official views and back-projects its maps: the refine
     networks' inputs (partial albedo and RM maps, the mask of how many views saw a texel, the UV position
     map), exactly as supermat_uv.h makes them (--model passthrough: no network, the lit colours back-projected,
     roughness 0.5, metallic 0: a check of the texel alignment, ctest uv_gen_refine).
A shard (shard_NNNN.npz, written as .tmp then renamed; finished shards are kept when the command runs again)
holds per sample, at --size x --size texels, uint8: partial_albedo, partial_rm (0, roughness, metallic),
mask (min(views, 3) / 3), position, chart (255 on a triangle), lit (the lit texture), truth_albedo (sRGB),
truth_rough, truth_metal.

  PYTHONPATH=python /usr/bin/python3 -m supermat_tools.gen_refine_data --hdri-dir HDRI --out DIR --model MV.safetensors \\
      [--count 1000] [--size 256] [--views-size 256] [--seed 0] [--jobs 2] [--photo 0.5]

Needs build/supermat built with the mesh command (libtinygltf-dev) and python3-numpy / -scipy / -pil.
"""
import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np
from PIL import Image

from supermat_tools import gen_data as G
from supermat_tools import make_example_mesh as M  # (its glTF writer)
from supermat_tools import smrender as R
from supermat_tools.common import SUPERMAT, tool_command, tool_env

KEYS = ("partial_albedo", "partial_rm", "mask", "position", "chart", "lit", "truth_albedo", "truth_rough",
        "truth_metal")


def _spow(x, e):
    return np.sign(x) * np.abs(x) ** e


def make_part(rng):
    """A parametric part: fn(u, v) -> local points (u, v in [0, 1]; u the angle that wraps)."""
    kind = str(rng.choice(["ellipsoid", "superquadric", "roundbox", "capsule", "torus", "blob"],
                          p=[0.2, 0.2, 0.15, 0.15, 0.15, 0.15]))
    if kind == "torus":
        Rr, r = float(rng.uniform(0.35, 0.6)), float(rng.uniform(0.1, 0.25))

        def fn(u, v):
            a, b = 2 * np.pi * u, 2 * np.pi * v
            return np.stack([(Rr + r * np.cos(b)) * np.cos(a), (Rr + r * np.cos(b)) * np.sin(a), r * np.sin(b)], -1)
    elif kind == "capsule":
        h, r = float(rng.uniform(0.1, 0.45)), float(rng.uniform(0.15, 0.35))

        def fn(u, v):
            a, b = 2 * np.pi * u, np.pi * (v - 0.5)
            n = np.stack([np.cos(b) * np.cos(a), np.cos(b) * np.sin(a), np.sin(b)], -1)
            return r * n + np.stack([0 * u, 0 * u, h * np.sign(np.sin(b))], -1)
    elif kind == "blob":
        r, amp, freq, seed = float(rng.uniform(0.4, 0.6)), float(rng.uniform(0.05, 0.2)), float(rng.uniform(1.5, 4)), \
            int(rng.integers(1 << 20))

        def fn(u, v):
            a, b = 2 * np.pi * u, np.pi * (v - 0.5)
            n = np.stack([np.cos(b) * np.cos(a), np.cos(b) * np.sin(a), np.sin(b)], -1)
            d = G.fbm((n * freq).reshape(-1, 3).astype(np.float32), seed, 3).reshape(n.shape[:-1])
            return n * (r + amp * (d - 0.5) * 2)[..., None]
    else:
        e = 2.0 if kind == "ellipsoid" else float(rng.uniform(2.5, 8.0)) if kind == "roundbox" else \
            float(rng.choice([rng.uniform(1.2, 2.0), rng.uniform(2.5, 5.0)]))
        rad = rng.uniform(0.3, 0.65, 3)

        def fn(u, v):
            a, b = 2 * np.pi * u, np.pi * (v - 0.5)
            ce, se = _spow(np.cos(b), 2 / e), _spow(np.sin(b), 2 / e)
            return np.stack([rad[0] * ce * _spow(np.cos(a), 2 / e), rad[1] * ce * _spow(np.sin(a), 2 / e),
                             rad[2] * se], -1)
    rot = R.random_rotation(rng).astype(np.float64)
    off = rng.uniform(-0.4, 0.4, 3)
    return {"fn": lambda u, v: fn(u, v) @ rot.T + off, "charts": int(rng.choice([1, 2], p=[0.6, 0.4]))}


def layout(n, rng):
    """n chart rectangles (u0, u1, v0, v1) in a grid atlas, each inset by a random gap."""
    cols = int(np.ceil(np.sqrt(n)))
    rows = int(np.ceil(n / cols))
    order = rng.permutation(cols * rows)[:n]
    out = []
    for k in order:
        c, r = k % cols, k // cols
        g = rng.uniform(0.01, 0.04)
        out.append((c / cols + g, (c + 1) / cols - g, r / rows + g, (r + 1) / rows - g))
    return out


def build(rng, size, photos, mode_p, photo, dark=0.0, mrough=0.0):
    parts = [make_part(rng) for _ in range(int(rng.choice([1, 2, 3], p=[0.45, 0.35, 0.2])))]
    charts = [(p, k) for p in parts for k in range(p["charts"])]
    rects = layout(len(charts), rng)
    mats = {id(p): G.make_material(rng, mode_p=mode_p, photo=photo, photos=photos, dark=dark, mrough=mrough)
            for p in parts}
    pos, uv, idx = [], [], []
    alb = np.full((size, size, 3), 0.5, np.float32)
    rough = np.full((size, size), 0.5, np.float32)
    metal = np.zeros((size, size), np.float32)
    c = (np.arange(size) + 0.5) / size
    U, V = np.meshgrid(c, c)
    off = 0
    for (p, k), (u0, u1, v0, v1) in zip(charts, rects):
        nu, nv = 64 // p["charts"], 40
        ua, ub = k / p["charts"], (k + 1) / p["charts"]
        su, sv = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1))
        pts = p["fn"](ua + su * (ub - ua), sv)
        pos.append(pts.reshape(-1, 3))
        uv.append(np.stack([u0 + su * (u1 - u0), v0 + sv * (v1 - v0)], -1).reshape(-1, 2))
        for j in range(nv):
            for i in range(nu):
                a = off + j * (nu + 1) + i
                idx += [a, a + 1, a + nu + 2, a, a + nu + 2, a + nu + 1]
        off += (nu + 1) * (nv + 1)
        sel = (U >= u0 - 0.01) & (U <= u1 + 0.01) & (V >= v0 - 0.01) & (V <= v1 + 0.01)
        tu = np.clip((U[sel] - u0) / (u1 - u0), 0, 1)
        tv = np.clip((V[sel] - v0) / (v1 - v0), 0, 1)
        q = p["fn"](ua + tu * (ub - ua), tv)
        a, r, mt = G.eval_material(mats[id(p)], (q / 1.3).astype(np.float32), np.zeros(len(q), np.float32))
        alb[sel], rough[sel], metal[sel] = a, r, mt
    pos = np.concatenate(pos).astype(np.float32)
    uv = np.concatenate(uv).astype(np.float32)
    idx = np.asarray(idx, np.uint32).reshape(-1, 3)
    # vertex normals from the faces (area weighted), turned outwards from each part's centre
    fn_ = np.cross(pos[idx[:, 1]] - pos[idx[:, 0]], pos[idx[:, 2]] - pos[idx[:, 0]])
    nrm = np.zeros_like(pos)
    for j in range(3):
        np.add.at(nrm, idx[:, j], fn_)
    if np.sum(nrm * (pos - pos.mean(0))) < 0:
        nrm, idx = -nrm, idx[:, ::-1].copy()
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    nrm[~np.isfinite(nrm).all(1)] = (0, 0, 1)
    return pos, nrm.astype(np.float32), uv, idx.ravel(), alb, rough, metal


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=tool_env())
    if r.returncode:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout[-2000:]}")


def sample(args, i, envs, photos):
    rng = np.random.default_rng([args.seed, i])
    mesh = build(rng, args.size, photos, args.mode_probs, args.photo)
    env = envs[int(rng.integers(len(envs)))]
    angle = float(rng.uniform(0, 360))
    tmp = tempfile.mkdtemp(prefix="smref_", dir=args.out)
    try:
        src = M.write_pbr_gltf(tmp, "asset", *mesh, generator="supermat supermat_tools.gen_refine_data")
        run(tool_command("litbake", src, os.path.join(tmp, "lit"), "--hdri", env,
             "--env-angle", str(angle), "--size", str(args.size), "--force"))
        dbg = os.path.join(tmp, "dbg")
        model = ["--passthrough"] if args.model == "passthrough" else ["--mv-model", args.model, "--no-refine"]
        cmd = [args.supermat, "mesh"] + model + ["--detail", "off", "--size", str(args.size), "--views-size",
                                                 str(args.views_size), "--threads", "1", "--debug-dir", dbg,
                                                 os.path.join(tmp, "lit", "asset_lit.gltf"), os.path.join(tmp, "baked.gltf")]
        run(cmd)
        rd = lambda d, f: np.asarray(Image.open(os.path.join(tmp, d, f)))  # noqa: E731
        s = {"partial_albedo": rd("dbg", "partial_albedo.png")[..., :3], "partial_rm": rd("dbg", "partial_rm.png")[..., :3],
             "mask": rd("dbg", "mask.png"), "position": rd("dbg", "position.png")[..., :3],
             "chart": rd("lit", "asset_mask.png"), "lit": rd("lit", "asset_lit_baseColor.png")[..., :3],
             "truth_albedo": rd("lit", "asset_truth_albedo.png")[..., :3],
             "truth_rough": rd("lit", "asset_truth_roughness.png"), "truth_metal": rd("lit", "asset_truth_metallic.png")}
        for k in ("mask", "chart", "truth_rough", "truth_metal"):
            if s[k].ndim == 3:
                s[k] = s[k][..., 0]
        for k, v in s.items():
            if v.shape[:2] != (args.size, args.size) or v.dtype != np.uint8:
                raise RuntimeError(f"sample {i}: {k} is {v.shape} {v.dtype}")
        return s
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def make_shard(args, shard):
    path = os.path.join(args.out, f"shard_{shard:04d}.npz")
    if os.path.exists(path):
        return path, 0.0
    t0 = time.time()
    envs = G.env_paths(args.hdri_dir)
    photos = G.photo_textures(envs) if args.photo > 0 else None
    R.brdf_lut()
    out = {k: [] for k in KEYS}
    for i in range(shard * args.shard, min((shard + 1) * args.shard, args.count)):
        s = sample(args, i, envs, photos)
        for k in KEYS:
            out[k].append(s[k])
    tmp = path + ".tmp.npz"
    np.savez(tmp, **{k: np.stack(v) for k, v in out.items()})
    os.replace(tmp, path)
    return path, time.time() - t0


def _star(a):
    return make_shard(*a)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hdri-dir", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--model", required=True, help="the view model: SuperMatMV, or single-view (view by view); "
                    "'passthrough': no network (`supermat mesh --passthrough`: the lit colours back-projected, a check)")
    ap.add_argument("--supermat", default=SUPERMAT)
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--size", type=int, default=256, help="texture size")
    ap.add_argument("--views-size", type=int, default=256)
    ap.add_argument("--shard", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--photo", type=float, default=0.5)
    ap.add_argument("--mode-probs", default="0.62,0.12,0.13,0.13")
    args = ap.parse_args()
    args.mode_probs = [float(x) for x in args.mode_probs.split(",")]
    if args.model != "passthrough":
        args.model = os.path.abspath(args.model)
    os.makedirs(args.out, exist_ok=True)
    meta = {"count": args.count, "size": args.size, "views_size": args.views_size, "seed": args.seed,
            "model": args.model, "photo": args.photo, "mode_probs": args.mode_probs,
            "envs": [os.path.basename(p) for p in G.env_paths(args.hdri_dir)], "held_out": list(G.HELD_OUT)}
    with open(os.path.join(args.out, "meta.json"), "w") as f:
        json.dump(meta, f, indent=1)
    shards = list(range((args.count + args.shard - 1) // args.shard))
    t0 = time.time()
    if args.jobs > 1:
        import multiprocessing as mp
        with mp.Pool(args.jobs) as pool:
            for p, dt in pool.imap_unordered(_star, [(args, s) for s in shards]):
                print(f"{p}: {dt:.0f} s", flush=True)
    else:
        for s in shards:
            p, dt = make_shard(args, s)
            print(f"{p}: {dt:.0f} s", flush=True)
    print(f"{args.count} samples in {time.time() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
