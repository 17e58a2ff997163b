#!/usr/bin/env python3
"""Multi-view material quality against ground truth: held-out glTF assets in the six official views.

For each asset (FILE.gltf, or FILE.gltf#NODE) and input map (--env-in, or all three held-out maps):
  1. the asset in supermat_uv.h's frames, as `supermat mesh` renders it: glTF Y up turned Z up, its bounding box
     centred, the largest half extent 1; the six official cameras (read from supermat_uv.h by gen_data.py)
     covering [-1.1, 1.1]; one lighting for all six views (the map at a seeded rotation about the up axis, one
     exposure: gen_data.py --views 6's recipe), each view rasterised at 2x and averaged down like
     eval_quality.py's views, with its truth maps;
  2. predicts: --mv-model NAME=FILE models with `supermat views` (the six views together, their cameras in a
     meta.json of the official format), --model NAME=FILE single-view models with `supermat image` view by
     view (the paper's ablation: no multi-view attention), baseline input_as_albedo; --args "..." go to both
     commands (their --detail and --chroma defaults differ: image 1/64 and 1, views off; pass both to compare
     like with like);
  3. masked PSNR / SSIM per map over each view's object, averaged over the views, per asset and overall.

  PYTHONPATH=python /usr/bin/python3 -m supermat_tools.eval_views --assets WaterBottle.gltf ... --hdri-dir HDRI \\
      --mv-model mv=mv.safetensors --model default=models/supermat_default.safetensors
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import zlib

import numpy as np

from supermat_tools import smrender as smr
from supermat_tools import eval_quality as evq
from supermat_tools import gen_data
from supermat_tools.common import SUPERMAT, write_json

YUP_TO_ZUP = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)   # glTF (x, y, z) -> (x, -z, y)
MAPS = ("albedo", "roughness", "metallic")


def six_views(mesh, size, env, env_angle, key):
    """RGBA inputs (6 x size x size x 4, uint8), truths (dicts of float maps) and the cameras (6 x 4 x 4)."""
    cams = gen_data.official_cameras()
    P = mesh.P @ YUP_TO_ZUP.T
    N = mesh.N @ YUP_TO_ZUP.T
    lo, hi = P.reshape(-1, 3).min(0), P.reshape(-1, 3).max(0)
    P = (P - (lo + hi) / 2) / (max(hi - lo) / 2)                 # supermat_uv.h's view frame
    rot_world = smr.rotation_y(env_angle) @ gen_data.Z_UP_TO_MAP.astype(np.float64)
    lins, gbs = [], []
    for cam in cams:
        Rc, T = cam[:3, :3], cam[:3, 3]
        Pc = (P - T) @ Rc / gen_data.ORTHO_HALF_WIDTH           # camera coordinates, the frame [-1, 1]
        gb2 = evq.gbuffer_framed(mesh, Pc, N @ Rc, 2 * size)
        lins.append(evq.cov_average(smr.shade(gb2, env, (rot_world @ Rc).astype(np.float32)), gb2["cov"]))
        gbs.append(evq.downsample(gb2))
    expo = smr.auto_exposure(np.concatenate(lins, 0), np.concatenate([g["cov"] for g in gbs], 0), key)
    rgba, truth = [], []
    for lin, gb in zip(lins, gbs):
        alpha = gb["cov"]
        rgb = np.where(alpha[..., None] > 0, smr.tonemap(lin, expo, (1, 1, 1)), 0.0)
        rgba.append(np.concatenate([evq.quantise(rgb), evq.quantise(alpha)[..., None]], -1))
        truth.append({"albedo": evq.quantise(smr.srgb_encode(gb["albedo"])) / np.float32(255),
                      "roughness": evq.quantise(gb["rough"]) / np.float32(255),
                      "metallic": evq.quantise(gb["metal"]) / np.float32(255)})
    return np.stack(rgba), truth, cams


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--assets", nargs="+", required=True, help=".gltf files (FILE.gltf#NODE: one node)")
    ap.add_argument("--hdri-dir", required=True)
    ap.add_argument("--env-in", default=evq.HELD_OUT_ENVS[0], help="a held-out map, or all")
    ap.add_argument("--mv-model", action="append", type=evq.model_option, default=[], metavar="NAME=FILE")
    ap.add_argument("--model", action="append", type=evq.model_option, default=[], metavar="NAME=FILE")
    ap.add_argument("--baselines", default="input_as_albedo", help="input_as_albedo or nothing")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--supermat", default=SUPERMAT)
    ap.add_argument("--work", help="keep the views and maps here")
    ap.add_argument("--json")
    ap.add_argument("--args", default="", help="more options for both `supermat views` and `supermat image`, e.g. "
                    "\"--detail off --chroma off\" (image's default keeps the picture's detail and colour, views' does not) "
                    "or \"--detail 0.015625 --chroma 1\"")
    args = ap.parse_args()
    if not args.mv_model and not args.model and not args.baselines:
        ap.error("nothing to measure")
    envs = list(evq.HELD_OUT_ENVS) if args.env_in == "all" else [args.env_in]
    try:
        meshes = [evq.Mesh(p) for p in args.assets]
        lights = {e: smr.EnvLight(os.path.join(args.hdri_dir, e + ".hdr")) for e in envs}
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"error: {e}")
    work = args.work or tempfile.mkdtemp(prefix="eval_views.")
    rows = []
    for env in envs:
        for mesh in meshes:
            rng = np.random.default_rng([args.seed, zlib.crc32((mesh.name + env).encode())])
            t0 = time.time()
            rgba, truth, cams = six_views(mesh, args.size, lights[env], float(rng.uniform(0, 2 * np.pi)),
                                          float(rng.uniform(*evq.KEY_RANGE)))
            case = os.path.join(work, f"{mesh.name}_{env}")
            os.makedirs(case, exist_ok=True)
            inputs = {}
            for v in range(6):
                inputs[f"color_{v:04d}"] = os.path.join(case, f"color_{v:04d}.png")
                evq.write_png(inputs[f"color_{v:04d}"], rgba[v])
            with open(os.path.join(case, "meta.json"), "w") as f:
                json.dump({"locations": [{"index": f"{v:04d}", "transform_matrix": cams[v].tolist()}
                                         for v in range(6)]}, f)
            print(f"rendered {mesh.name} under {env} ({time.time() - t0:.1f} s)", file=sys.stderr)
            preds = {}
            for name, path in args.mv_model:
                out = os.path.join(case, "pred_" + name)
                os.makedirs(out, exist_ok=True)
                subprocess.run([args.supermat, "views", "--force", "--native", "--float", "--model", path, "--cameras",
                                os.path.join(case, "meta.json"), "--out", out, "--threads", str(args.threads)]
                               + args.args.split() + list(inputs.values()), check=True, stdout=subprocess.DEVNULL)
                preds[name] = [{m: evq.read_map(out, stem, m) for m in MAPS} for stem in inputs]
            for name, path in args.model:
                out = os.path.join(case, "pred_" + name)
                got = evq.run_model(args.supermat, path, inputs, out, args.threads, args.args.split())
                preds[name] = [got[stem] for stem in inputs]
            if args.baselines:
                preds["input_as_albedo"] = [dict(albedo=rgba[v][..., :3] / np.float32(255),
                                                 roughness=np.full(rgba.shape[1:3], 0.5, np.float32),
                                                 metallic=np.zeros(rgba.shape[1:3], np.float32)) for v in range(6)]
            for name, maps in preds.items():
                for v in range(6):
                    mask = rgba[v][..., 3] >= 128
                    if not mask.any():
                        continue
                    row = dict(asset=mesh.name, env=env, view=v, predictor=name)
                    for m in MAPS:
                        row[m + "_psnr"] = evq.masked_psnr(maps[v][m], truth[v][m], mask)
                        row[m + "_ssim"] = evq.masked_ssim(maps[v][m], truth[v][m], mask)
                    rows.append(row)
    metrics = [m + k for m in MAPS for k in ("_psnr", "_ssim")]
    order = list(dict.fromkeys(r["predictor"] for r in rows))
    head = "| {} | albedo PSNR | albedo SSIM | rough PSNR | rough SSIM | metal PSNR | metal SSIM |\n|---|---|---|---|---|---|---|"
    print(f"## overall ({len(meshes)} assets x {len(envs)} maps x 6 official views, {args.size}²)\n")
    print(head.format("predictor"))
    overall = {}
    for p in order:
        sel = [r for r in rows if r["predictor"] == p]
        overall[p] = {m: float(np.mean([r[m] for r in sel])) for m in metrics}
        print(f"| {p} | " + " | ".join(f"{overall[p][m]:.4f}" if m.endswith("ssim") else f"{overall[p][m]:.2f}"
                                       for m in metrics) + " |")
    print("\n## per asset\n\n" + head.format("asset / predictor"))
    for a in dict.fromkeys(r["asset"] for r in rows):
        for p in order:
            sel = [r for r in rows if r["predictor"] == p and r["asset"] == a]
            print(f"| {a} / {p} | " + " | ".join(
                f"{np.mean([r[m] for r in sel]):.4f}" if m.endswith("ssim") else f"{np.mean([r[m] for r in sel]):.2f}"
                for m in metrics) + " |")
    if args.json:
        write_json(args.json, dict(config=vars(args), overall=overall, rows=rows))


if __name__ == "__main__":
    main()
