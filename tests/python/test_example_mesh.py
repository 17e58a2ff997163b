#!/usr/bin/env python3
"""ctest uv_example_mesh: the demo's example mesh (examples/mesh/, supermat_tools.make_example_mesh) baked by
`supermat mesh` with no model flags (the multi-view default beside the default model in the source tree, no
refinement), measured against the example's true textures on its chart texels: a regression guard for the
default mesh path, its floors set from the first measurement (2026-11-26, 2-core Xeon, AVX-512, the
single-view default view by view: albedo 9.32 dB against the lit texture's 8.04; roughness 9.71, metallic
3.98), the albedo floor lowered when `supermat mesh` began keeping the input's detail (--detail 1/32 by
default, 2026-11-27: 9.16 dB on this 256x256 example, 0.16 below --detail off here; +1.37 dB on the five
held-out assets, README).  With the multi-view default (models/supermat_mv_default.safetensors, 2026-11-27):
albedo 9.29, roughness 9.70, metallic 4.00, the relit bake 15.86 dB; the floors stand.

Then the demo's relighting (supermat_tools.relight_demo: the input as given, the bake and the truth under
examples/mesh/studio_small_03_256.hdr, two views, the truth's exposure): PSNR of each against the truth's
render over its pixels, floors from the first measurement (2026-11-27: the bake 15.66 dB, the input as given
14.62), and a malformed asset argument refused.

`supermat mesh --refine` (the UV-refine defaults too, models/supermat_refine_*_default.safetensors, 2026-11-29):
albedo 7.81, roughness 10.25 dB on this example (every texel seen by a view; the refinement trades 1.5 dB of
albedo for 0.55 of roughness here, which is why the default bake does not refine): floors 7.5 / 9.9.

usage: test_example_mesh.py SUPERMAT OUT_DIR
"""
import os
import shutil
import subprocess
import sys

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
EX = os.path.join(HERE, "..", "..", "examples", "mesh", "lit", "example_pbr")
ALBEDO_FLOOR, ALBEDO_OVER_LIT, ROUGH_FLOOR = 8.9, 1.0, 9.3
RELIGHT_FLOOR, RELIGHT_OVER_INPUT = 15.0, 0.5
REFINED_ALBEDO_FLOOR, REFINED_ROUGH_FLOOR = 7.5, 9.9   # --refine, first measured 2026-11-29 (Zen 5): 7.81 / 10.25
HDRI = os.path.join(HERE, "..", "..", "examples", "mesh", "studio_small_03_256.hdr")
TRUTH = os.path.join(HERE, "..", "..", "examples", "mesh", "example_pbr.gltf")

fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what)
    fails += 0 if ok else 1


def read(path, mode):
    return np.asarray(Image.open(path).convert(mode)).astype(np.float64) / 255.0


def main():
    sm, out = sys.argv[1], sys.argv[2]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    env = {k: v for k, v in os.environ.items() if k != "SUPERMAT_MODEL"}   # the source tree's default model
    r = subprocess.run([sm, "mesh", "--size", "256", EX + "_lit.gltf", os.path.join(out, "example.gltf")], env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    check(r.returncode == 0, "supermat mesh without model flags bakes the example: exit 0 " + r.stderr[-500:])
    if r.returncode != 0:
        return 1
    check("supermat_mv_default.safetensors" in r.stderr, "without model flags it loads the multi-view default")
    m = read(EX + "_mask.png", "L") > 0
    psnr = lambda a, b: 10 * np.log10(1 / np.mean((a - b)[m] ** 2))  # noqa: E731
    alb = psnr(read(os.path.join(out, "example_baseColor.png"), "RGB"), read(EX + "_truth_albedo.png", "RGB"))
    lit = psnr(read(EX + "_lit_baseColor.png", "RGB"), read(EX + "_truth_albedo.png", "RGB"))
    mr = read(os.path.join(out, "example_metallicRoughness.png"), "RGB")
    rough = psnr(mr[..., 1], read(EX + "_truth_roughness.png", "L"))
    metal = psnr(mr[..., 2], read(EX + "_truth_metallic.png", "L"))
    print(f"     albedo {alb:.2f} dB (the lit texture {lit:.2f}), roughness {rough:.2f}, metallic {metal:.2f}")
    check(alb >= ALBEDO_FLOOR and alb >= lit + ALBEDO_OVER_LIT,
          f"albedo >= {ALBEDO_FLOOR} dB and >= the lit texture + {ALBEDO_OVER_LIT} dB")
    check(rough >= ROUGH_FLOOR, f"roughness >= {ROUGH_FLOOR} dB")
    # `supermat mesh --refine`: the UV-refine defaults too (models/supermat_refine_*_default.safetensors)
    r = subprocess.run([sm, "mesh", "--refine", "--size", "256", EX + "_lit.gltf", os.path.join(out, "refined.gltf")],
                       env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    check(r.returncode == 0 and "supermat_refine_albedo_default.safetensors" in r.stderr
          and "supermat_refine_rm_default.safetensors" in r.stderr,
          "supermat mesh --refine bakes the example with both refine defaults " + r.stderr[-300:])
    if r.returncode == 0:
        ralb = psnr(read(os.path.join(out, "refined_baseColor.png"), "RGB"), read(EX + "_truth_albedo.png", "RGB"))
        rmr = read(os.path.join(out, "refined_metallicRoughness.png"), "RGB")
        rrough = psnr(rmr[..., 1], read(EX + "_truth_roughness.png", "L"))
        print(f"     --refine: albedo {ralb:.2f} dB, roughness {rrough:.2f}")
        check(not np.array_equal(rmr, mr) and ralb >= REFINED_ALBEDO_FLOOR and rrough >= REFINED_ROUGH_FLOOR,
              f"--refine: other maps than without, albedo >= {REFINED_ALBEDO_FLOOR} dB, roughness >= {REFINED_ROUGH_FLOOR} dB")
    # the demo's relighting
    rl = os.path.join(out, "relit")
    cmd = [sys.executable, "-m", "supermat_tools.relight_demo", "--hdri", HDRI, "--out", rl, "--views", "2"]
    r = subprocess.run(cmd + ["input=" + EX + "_lit.gltf", "baked=" + os.path.join(out, "example.gltf"), "truth=" + TRUTH],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    check(r.returncode == 0, "relight_demo.py renders input, bake and truth: exit 0 " + r.stderr[-500:])
    if r.returncode == 0:
        got = {}
        for n in ("input", "baked"):
            ps = []
            for v in (0, 1):
                t = read(os.path.join(rl, f"truth_v{v}.png"), "RGBA")
                x = read(os.path.join(rl, f"{n}_v{v}.png"), "RGBA")
                cov = t[..., 3] >= 0.5
                ps.append(10 * np.log10(1 / np.mean((x[..., :3] - t[..., :3])[cov] ** 2)))
            got[n] = float(np.mean(ps))
        print(f"     relit: the bake {got['baked']:.2f} dB, the input as given {got['input']:.2f} dB from the truth's render")
        check(got["baked"] >= RELIGHT_FLOOR and got["baked"] >= got["input"] + RELIGHT_OVER_INPUT,
              f"relit bake >= {RELIGHT_FLOOR} dB and >= the input's + {RELIGHT_OVER_INPUT} dB")
    r = subprocess.run(cmd + ["no-equals-sign"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    check(r.returncode != 0 and "NAME=FILE.gltf" in r.stderr, "relight_demo.py: a malformed asset argument -> an error")
    print(f"example_mesh: {fails} failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
