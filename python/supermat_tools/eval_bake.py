#!/usr/bin/env python3
"""Mesh bakes against ground truth: held-out glTF assets, lit-baked, baked by `supermat mesh`, measured.

For each asset (FILE.gltf, or FILE.gltf#NODE for one node's subtree):
  1. supermat_tools.litbake makes the input: its lit appearance in its own UV space under a held-out environment
     map (--env-bake), the true albedo / roughness / metallic textures and the chart mask at the same texels;
     with --cycles-world W the lit texture is Blender Cycles' bake under Blender's world map W instead
     (supermat_tools.cycles_render --bake: an independent renderer, with shadows and interreflection);
  2. each predictor bakes it:
       lit          the lit texture itself as albedo, roughness 0.5, metallic 0 (the passthrough baseline
                    of the issue; no rendering, no network)
       passthrough  `supermat mesh --passthrough`: the lit colours rendered into the six views and
                    back-projected (the pipeline's geometry, no network), roughness 0.5, metallic 0
       truth        the truth textures themselves (not a baseline: the measurement's own check; its relight
                    PSNR says how far the texture resampling alone moves the renders)
       NAME=MV,ALB,RM  `supermat mesh` with those three model files (SuperMatMV, albedo and
                    roughness/metallic UV refine), --bake NAME=MV,ALB,RM, repeatable; one refine slot may
                    be empty (NAME=MV,ALB, or NAME=MV,,RM: that map unrefined)
       NAME=MV      `supermat mesh --no-refine`: the multi-view model alone (the paper's ablation without
                    the refine networks)
  3. measures, on the chart texels (the mask): masked PSNR and SSIM of the albedo (sRGB 8-bit), of the
     roughness and of the metallic texture (linear 8-bit); and the novel-view relighting check: --views views
     of the baked asset and of the original (seeded rotations), shaded under a second held-out map
     (--env-relight, turned at random about +Y) with the exposure auto-chosen for the original, tone
     mapped, PSNR and SSIM over the object; and each bake's seconds and peak memory (`supermat mesh`'s own
     report).
  --decompose also reports the albedo PSNR after the best least-squares gain on the baked texture (one for all
  channels, then one a channel), as eval_quality.py --decompose does per view: the lit texture's level is
  whatever its lighting and exposure made it, so this separates a bake's albedo level from the rest.
Normal maps, occlusion and emission are ignored throughout (as in eval_quality.py).

  PYTHONPATH=python /usr/bin/python3 -m supermat_tools.eval_bake --assets WaterBottle.gltf BoomBoxWithAxes.gltf#BoomBox \\
      --hdri-dir HDRI --bake default=mv.safetensors,uv_bc.safetensors,uv_rm.safetensors

prints a Markdown table per asset and over all, --json FILE also writes it.  Needs python3-numpy, -scipy,
-pil and the built `supermat` (or --supermat).
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np
from PIL import Image

from supermat_tools import smrender as smr
from supermat_tools import eval_quality as evq
from supermat_tools import litbake
from supermat_tools.common import SUPERMAT, run_tool, split_asset, write_json

METRICS = ("albedo_psnr", "albedo_ssim", "rough_psnr", "rough_ssim", "metal_psnr", "metal_ssim", "relight_psnr",
           "relight_ssim")


def read8(path, mode):
    return np.asarray(Image.open(path).convert(mode))


def psnr8(a, b, mask):
    return evq.masked_psnr(a.astype(np.float64) / 255.0, b.astype(np.float64) / 255.0, mask)


def line(o):
    """A table row's numbers: PSNR / SSIM per metric, seconds, peak memory (MB; 0 where nothing ran)."""
    return " | ".join(f"{o[m]:.4f}" if m.endswith("ssim") else f"{o[m]:.2f}" for m in METRICS) + \
        f" | {o['seconds']:.1f} | {o['peak_mb'] or '-'} |"


def relight_views(orig, baked, params, size, env):
    """PSNR / SSIM of the baked asset against the original, per view, under env (see 3. above)."""
    out = []
    for p in params:
        g0 = evq.downsample(evq.gbuffer(orig, p["rot"], 2 * size))
        g1 = evq.downsample(evq.gbuffer(baked, p["rot"], 2 * size))
        rot = smr.rotation_y(p["relight_angle"])
        lin0 = smr.shade(g0, env, rot)
        lin1 = smr.shade(dict(g1, cov=g0["cov"], n=g0["n"]), env, rot)   # the original's coverage and normals
        expo = smr.auto_exposure(lin0, g0["cov"], p["key"])
        a = smr.tonemap(lin0, expo, (1, 1, 1))
        b = smr.tonemap(lin1, expo, (1, 1, 1))
        m = g0["cov"] >= 0.5
        out.append((evq.masked_psnr(b, a, m), evq.masked_ssim(b, a, m)))
    return np.mean([o[0] for o in out]), np.mean([o[1] for o in out])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--assets", nargs="+", required=True, help=".gltf files (FILE.gltf#NODE: one node)")
    ap.add_argument("--hdri-dir", required=True, help="the folder of the held-out maps")
    ap.add_argument("--env-bake", default=evq.HELD_OUT_ENVS[0], help="the map of the lit bake")
    ap.add_argument("--env-relight", default=evq.HELD_OUT_ENVS[1], help="the map of the relighting check")
    ap.add_argument("--bake", action="append", default=[], metavar="NAME=MV,ALB,RM",
                    help="a predictor: supermat mesh with these three model files, or NAME=MV: --no-refine (repeatable)")
    ap.add_argument("--baselines", default="lit,passthrough", help="comma list of lit, passthrough, truth")
    ap.add_argument("--size", type=int, default=1024, help="texture size (default 1024)")
    ap.add_argument("--views-size", type=int, default=512, help="supermat mesh --views-size (default 512)")
    ap.add_argument("--mesh-args", default="", help="more `supermat mesh` options for every bake, one string "
                                                       "(e.g. \"--weight cos --edge-reject 2\", \"--work-size native\")")
    ap.add_argument("--views", type=int, default=4, help="relighting views per asset (default 4)")
    ap.add_argument("--relight-size", type=int, default=256, help="relighting view size (default 256)")
    ap.add_argument("--cycles-world", default="",
                    help="the lit texture from Blender's Cycles instead (an independent renderer: shadows, "
                         "interreflection; supermat_tools.cycles_render --bake) under this Blender world map "
                         "(city, courtyard, forest, interior, night, studio, sunrise, sunset); the truth and "
                         "mask stay litbake's")
    ap.add_argument("--cycles-samples", type=int, default=32, help="Cycles samples a texel (default 32)")
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--supermat", default=SUPERMAT)
    ap.add_argument("--work", help="keep the bakes here (default: a temporary folder)")
    ap.add_argument("--json", help="also write the results here")
    ap.add_argument("--decompose", action="store_true",
                    help="also the albedo PSNR after the best gain (and per channel) on each bake")
    args = ap.parse_args()
    bakes = []
    for b in args.bake:
        name, _, files = b.partition("=")
        files = files.split(",")
        if not name or len(files) not in (1, 3) or name in ("lit", "passthrough", "truth"):
            ap.error(f"--bake NAME=MV,ALB,RM or NAME=MV, not {b!r}")
        if len(files) == 3 and not files[1] and not files[2]:
            ap.error(f"--bake {name}: NAME=MV for no refinement, not two empty refine slots")
        if not files[0]:
            ap.error(f"--bake {name}: no view model")
        for f in filter(None, files):
            if not os.path.isfile(f):
                ap.error(f"--bake {name}: no model file {f}")
        bakes.append((name, files))
    baselines = [b for b in args.baselines.split(",") if b]
    for b in baselines:
        if b not in ("lit", "passthrough", "truth"):
            ap.error(f"unknown baseline {b}")
    if not baselines and not bakes:
        ap.error("nothing to measure")
    if not os.path.isfile(args.supermat) and (bakes or "passthrough" in baselines):
        ap.error(f"no supermat executable {args.supermat} (--supermat)")
    envs = {}
    for e in (args.env_bake, args.env_relight):
        path = os.path.join(args.hdri_dir, e + ".hdr")
        if not os.path.isfile(path):
            ap.error(f"no map {path}")
        envs[e] = path
    work = args.work or tempfile.mkdtemp(prefix="eval_bake.")
    rows = []
    for asset in args.assets:
        path, node = split_asset(asset)
        name = node or os.path.splitext(os.path.basename(path))[0]
        lb = os.path.join(work, name, "input")
        t0 = time.time()
        r = run_tool("litbake", asset, lb, "--hdri", envs[args.env_bake], "--size", str(args.size), "--force",
                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        if r.returncode != 0:
            sys.exit(f"error: litbake {asset}: {r.stderr.strip()}")
        print(r.stdout.strip(), f"({time.time() - t0:.1f} s)", file=sys.stderr)
        if args.cycles_world:
            t0 = time.time()
            me = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cycles_render.py")
            cmd = [args.blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", me, "--",
                   "--gltf", path, "--bake", os.path.join(lb, name + "_lit_baseColor.png"),
                   "--mask", os.path.join(lb, name + "_mask.png"), "--size", str(args.size),
                   "--samples", str(args.cycles_samples), "--world", args.cycles_world,
                   "--seed", str(args.seed), "--threads", str(args.threads)]
            r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
            if r.returncode != 0:
                sys.exit(f"error: the Cycles bake of {asset} failed (exit {r.returncode}):\n{r.stdout[-2000:]}")
            print(f"Cycles lit bake of {name} under {args.cycles_world} ({time.time() - t0:.1f} s)", file=sys.stderr)
        mask = read8(os.path.join(lb, name + "_mask.png"), "L") > 0
        truth = dict(albedo=read8(os.path.join(lb, name + "_truth_albedo.png"), "RGB"),
                     rough=read8(os.path.join(lb, name + "_truth_roughness.png"), "L"),
                     metal=read8(os.path.join(lb, name + "_truth_metallic.png"), "L"))
        try:
            orig = evq.Mesh(asset)
        except (OSError, ValueError, KeyError) as e:
            sys.exit(f"error: {e}")
        params = evq.view_params(name, args.seed, args.views)
        env_rl = smr.EnvLight(envs[args.env_relight])
        preds = []
        lit_gltf = os.path.join(lb, name + "_lit.gltf")
        for kind in baselines + [b[0] for b in bakes]:
            t0 = time.time()
            if kind in ("lit", "truth"):
                gltf = lit_gltf
                if kind == "lit":
                    albedo = read8(os.path.join(lb, name + "_lit_baseColor.png"), "RGB")
                    rough8 = np.full(mask.shape, 128, np.uint8)
                    metal8 = np.zeros(mask.shape, np.uint8)
                else:
                    albedo, rough8, metal8 = truth["albedo"], truth["rough"], truth["metal"]
            else:
                out = os.path.join(work, name, kind)
                os.makedirs(out, exist_ok=True)
                gltf = os.path.join(out, name + ".gltf")
                cmd = [args.supermat, "mesh", "--force", "--size", str(args.size), "--views-size", str(args.views_size),
                       "--threads", str(args.threads)] + args.mesh_args.split()
                if kind == "passthrough":
                    cmd.append("--passthrough")
                else:
                    files = dict(bakes)[kind]
                    cmd += ["--mv-model", files[0]]
                    if len(files) == 3:
                        cmd += (["--albedo-refine", files[1]] if files[1] else []) + (["--rm-refine", files[2]] if files[2] else [])
                    else:
                        cmd += ["--no-refine"]
                r = subprocess.run(cmd + [lit_gltf, gltf], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   universal_newlines=True)
                if r.returncode != 0:
                    sys.exit(f"error: {' '.join(cmd)} {lit_gltf} {gltf}: {r.stderr.strip()}")
                albedo = read8(os.path.join(out, name + "_baseColor.png"), "RGB")
                mr = read8(os.path.join(out, name + "_metallicRoughness.png"), "RGB")
                rough8, metal8 = mr[..., 1], mr[..., 2]
            t_bake = time.time() - t0
            mb = re.search(r"peak memory (\d+) MB", r.stdout) if kind not in ("lit", "truth") else None
            baked = evq.Mesh(gltf)
            if kind == "lit":                                   # constant roughness / metallic, as above
                for m in baked.materials:
                    m["rough"], m["metal"], m["mr_tex"] = 0.5, 0.0, None
            elif kind == "truth":                               # the truth textures on the lit glTF's UVs
                for m in baked.materials:
                    m["base_factor"][:] = 1.0
                    m["rough"], m["metal"] = 1.0, 1.0
                    # spread beyond the charts as the lit texture is: mip levels read across chart edges
                    a = litbake.spread(smr.srgb_decode(albedo / np.float32(255)), mask, 16)
                    rm = litbake.spread(np.stack([rough8, metal8], -1) / np.float32(255), mask, 16)
                    m["base_tex"] = evq.Texture(a.astype(np.float32), 10497, 10497)
                    m["mr_tex"] = evq.Texture(rm.astype(np.float32), 10497, 10497)
            rl = relight_views(orig, baked, params, args.relight_size, env_rl)
            row = dict(asset=name, predictor=kind, seconds=t_bake,
                       albedo_psnr=psnr8(albedo, truth["albedo"], mask),
                       albedo_ssim=evq.masked_ssim(albedo / 255.0, truth["albedo"] / 255.0, mask),
                       rough_psnr=psnr8(rough8, truth["rough"], mask),
                       rough_ssim=evq.masked_ssim(rough8 / 255.0, truth["rough"] / 255.0, mask),
                       metal_psnr=psnr8(metal8, truth["metal"], mask),
                       metal_ssim=evq.masked_ssim(metal8 / 255.0, truth["metal"] / 255.0, mask),
                       albedo_psnr_gain=evq.gain_psnr(albedo / 255.0, truth["albedo"] / 255.0, mask, False),
                       albedo_psnr_wb=evq.gain_psnr(albedo / 255.0, truth["albedo"] / 255.0, mask, True),
                       peak_mb=int(mb.group(1)) if mb else 0,
                       relight_psnr=float(rl[0]), relight_ssim=float(rl[1]))
            rows.append(row)
            preds.append(kind)
            print(f"{name} / {kind}: {t_bake:.1f} s", file=sys.stderr)

    order = list(dict.fromkeys(r["predictor"] for r in rows))
    print(f"## overall ({len(args.assets)} assets, {args.size}² textures, lit-baked under {args.env_bake}, "
          f"relit under {args.env_relight}, {args.views} views of {args.relight_size}²)\n")
    head = ("| predictor | albedo PSNR | albedo SSIM | roughness PSNR | roughness SSIM | metallic PSNR | metallic SSIM "
            "| relight PSNR | relight SSIM | bake s | peak MB |\n|---|---|---|---|---|---|---|---|---|---|---|")
    print(head)
    overall = {}
    for p in order:
        sel = [r for r in rows if r["predictor"] == p]
        overall[p] = {m: float(np.mean([r[m] for r in sel])) for m in METRICS + ("seconds",)}
        overall[p]["peak_mb"] = max(r["peak_mb"] for r in sel)
        print("| " + p + " | " + line(overall[p]))
    print("\n## per asset\n\n" + head.replace("| predictor |", "| asset / predictor |"))
    for r in rows:
        print(f"| {r['asset']} / {r['predictor']} | " + line(r))
    if args.decompose:
        print("\n## albedo error decomposed (PSNR as measured | after the best gain | after the best gain per channel)"
              "\n\n| asset / predictor | albedo PSNR | best gain | best gains per channel |\n|---|---|---|---|")
        for p in order:
            sel = [r for r in rows if r["predictor"] == p]
            print(f"| all / {p} | " + " | ".join(f"{np.mean([r[m] for r in sel]):.2f}"
                                                 for m in ("albedo_psnr", "albedo_psnr_gain", "albedo_psnr_wb")) + " |")
        for r in rows:
            print(f"| {r['asset']} / {r['predictor']} | {r['albedo_psnr']:.2f} | {r['albedo_psnr_gain']:.2f} | "
                  f"{r['albedo_psnr_wb']:.2f} |")
    if args.json:
        write_json(args.json, dict(config=dict(vars(args)), overall=overall, rows=rows))


if __name__ == "__main__":
    main()
