#!/usr/bin/env python3
"""ctest uv_litbake: supermat_tools.litbake against an independent float64 reference.

usage: test_litbake.py SUPERMAT_MESH OUT_DIR [TINY_MV TINY_UV SUPERMAT [TINY]]

1. a quad facing +Z, one material (16x16 base colour and metallic-roughness textures, seeded), baked at
   16x16 (one output texel per texture texel) under a constant environment of radiance 1, exposure 1:
   every texel covered; the truth textures equal the asset's (8-bit, +-1); the lit texel equals
   (1 - F0)(1 - metallic) albedo + F0 A + B, with A, B the GGX (Smith k = a/2, Schlick) directional albedo at
   normal incidence integrated here in float64 (not smrender's table);
2. two quads, one facing +Y and one facing -Y, under a sky-only map (radiance 1 above the horizon, 0 below):
   the upward one as under the constant map, the downward one black (the world's up axis and the map's
   orientation agree);
3. `supermat mesh --passthrough` takes the lit glTF and bakes the lit texture back (the output is a
   glTF the pipeline reads, buffers copied beside it);
4. failures: an existing output without --force, a missing map, two materials, no UVs: exit 1, a message;
5. with the tiny models: supermat_tools.eval_bake on the quad (the truth as a bake, the lit baseline's numbers
   recomputed here, a bake with the tiny random models); with TINY, the single-view model view by view
   (eval_bake NAME=SV) and `supermat mesh` without model flags (the default model, $SUPERMAT_MODEL here:
   the same bytes as --mv-model TINY --no-refine; a missing one: exit 1).
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
LITBAKE = ["-m", "supermat_tools.litbake"]   # run with the package on PYTHONPATH (ctest sets it)
fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what)
    fails += 0 if ok else 1


def write_hdr(path, img):
    """Flat (not run-length encoded) Radiance RGBE."""
    h, w, _ = img.shape
    m = img.max(-1)
    e = np.where(m > 1e-32, np.floor(np.log2(np.maximum(m, 1e-32))) + 1, 0)
    sc = np.where(m > 1e-32, 256.0 / np.exp2(e), 0)
    rgbe = np.zeros((h, w, 4), np.uint8)
    rgbe[..., :3] = np.clip(np.floor(img * sc[..., None]), 0, 255)
    rgbe[..., 3] = np.where(m > 1e-32, e + 128, 0)
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode() + rgbe.tobytes())


def write_gltf(path, quads, materials=1, uvs=True):
    """quads: list of (4 corners (4x3), normal (3,), 4 UVs (4x2)); an external .bin, PNG textures."""
    pos, nrm, uv, idx = [], [], [], []
    for q, (corners, n, quv) in enumerate(quads):
        pos += list(corners)
        nrm += [n] * 4
        uv += list(quv)
        idx += [4 * q + i for i in (0, 1, 2, 0, 2, 3)]
    pos, nrm, uv = (np.asarray(a, np.float32) for a in (pos, nrm, uv))
    idx = np.asarray(idx, np.uint16)
    blobs = [pos.tobytes(), nrm.tobytes(), uv.tobytes(), idx.tobytes()]
    views, off = [], 0
    for b in blobs:
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(b)})
        off += (len(b) + 3) // 4 * 4
    data = b"".join(b + b"\0" * ((4 - len(b) % 4) % 4) for b in blobs)
    name = os.path.splitext(os.path.basename(path))[0]
    with open(os.path.join(os.path.dirname(path), name + ".bin"), "wb") as f:
        f.write(data)
    acc = [{"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3",
            "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
           {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC3"},
           {"bufferView": 2, "componentType": 5126, "count": len(pos), "type": "VEC2"},
           {"bufferView": 3, "componentType": 5123, "count": len(idx), "type": "SCALAR"}]
    attrs = {"POSITION": 0, "NORMAL": 1}
    if uvs:
        attrs["TEXCOORD_0"] = 2
    mat = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1}},
           "normalTexture": {"index": 1}}
    prims = [{"attributes": attrs, "indices": 3, "material": 0}]
    if materials == 2:
        prims.append({"attributes": attrs, "indices": 3, "material": 1})
    g = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
         "meshes": [{"primitives": prims}], "materials": [mat] * materials,
         "buffers": [{"uri": name + ".bin", "byteLength": len(data)}], "bufferViews": views, "accessors": acc,
         "images": [{"uri": "base.png"}, {"uri": "mr.png"}], "textures": [{"source": 0}, {"source": 1}],
         "extensionsUsed": ["KHR_materials_emissive_strength"]}
    with open(path, "w") as f:
        json.dump(g, f)


def srgb_decode(s):
    return np.where(s <= 0.04045, s / 12.92, ((s + 0.055) / 1.055) ** 2.4)


def srgb_encode(x):
    x = np.clip(x, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def split_sum_normal(rough):
    """A, B of the split sum at n . v = 1 for each roughness (clamped at 0.02 as smrender does), float64
    quadrature over the angle of the light from the normal (the integrand is symmetric about it)."""
    th = (np.arange(400000) + 0.5) * (np.pi / 2) / 400000
    dth = (np.pi / 2) / 400000
    nl = np.cos(th)
    nh = vh = np.cos(th / 2)
    fc = (1 - vh) ** 5
    out = []
    for r in np.clip(rough, 0.02, 1.0):
        a = r * r
        k = a / 2
        d = a * a / (np.pi * (nh * nh * (a * a - 1) + 1) ** 2)
        g1 = nl / (nl * (1 - k) + k)
        base = d * g1 / 4 * 2 * np.pi * np.sin(th) * dth   # f / F x cos x solid angle (G1(n.v = 1) = 1)
        out.append(((base * (1 - fc)).sum(), (base * fc).sum()))
    return np.array(out)


def run(args, expect):
    r = subprocess.run([sys.executable] + LITBAKE + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    if r.returncode != expect:
        print(r.stdout + r.stderr)
    return r


def main():
    mesh_exe, out = sys.argv[1], sys.argv[2]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(os.path.join(out, "asset"))
    rng = np.random.default_rng(7)
    base8 = rng.integers(20, 205, (16, 16, 3)).astype(np.uint8)          # albedo <= 0.8: no clipping at 1
    mr8 = np.zeros((16, 16, 3), np.uint8)
    mr8[..., 1] = rng.integers(77, 256, (16, 16))                          # roughness 0.3 .. 1
    mr8[..., 2] = np.where(rng.random((16, 16)) < 0.3, 255, 0)            # metallic, binary
    Image.fromarray(base8).save(os.path.join(out, "asset", "base.png"))
    Image.fromarray(mr8).save(os.path.join(out, "asset", "mr.png"))
    quad_z = ([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], (0, 0, 1), [(0, 1), (1, 1), (1, 0), (0, 0)])
    write_gltf(os.path.join(out, "asset", "quad.gltf"), [quad_z])
    const = os.path.join(out, "const.hdr")
    write_hdr(const, np.ones((32, 64, 3), np.float32))
    sky = np.zeros((32, 64, 3), np.float32)
    sky[:16] = 1.0
    write_hdr(os.path.join(out, "sky.hdr"), sky)

    # 1. constant environment: the closed form with float64 split-sum terms
    bake = os.path.join(out, "bake")
    r = run([os.path.join(out, "asset", "quad.gltf"), bake, "--hdri", const, "--size", "16", "--exposure", "1",
             "--gutter", "0"], 0)
    check(r.returncode == 0, "litbake quad under a constant map: exit 0")
    rd = lambda n: np.asarray(Image.open(os.path.join(bake, "quad_" + n)))  # noqa: E731
    check(bool((rd("mask.png") == 255).all()), "every texel covered")
    check(int(np.abs(rd("truth_albedo.png").astype(int) - base8).max()) <= 1, "truth albedo = the base colour texture (+-1)")
    check(int(np.abs(rd("truth_roughness.png").astype(int) - mr8[..., 1]).max()) <= 1, "truth roughness = G (+-1)")
    check(int(np.abs(rd("truth_metallic.png").astype(int) - mr8[..., 2]).max()) <= 1, "truth metallic = B (+-1)")
    alb = srgb_decode(base8 / 255.0)
    rough, met = mr8[..., 1] / 255.0, mr8[..., 2:3] / 255.0
    ab = split_sum_normal(rough.ravel()).reshape(16, 16, 2)
    f0 = 0.04 * (1 - met) + alb * met
    ref = (1 - f0) * (1 - met) * alb + f0 * ab[..., :1] + ab[..., 1:]
    lit = rd("lit_baseColor.png") / 255.0
    err = np.abs(lit - srgb_encode(ref))
    print(f"     lit vs float64 closed form: max {err.max() * 255:.2f} / 255, mean {err.mean() * 255:.2f} / 255 (sRGB)")
    # smrender's split-sum table: 32 x 32 bins (its n . v = 1 is the bin at 0.984), 1024 samples a bin
    check(err.max() <= 4 / 255 and err.mean() <= 1 / 255, "lit texels = closed form within 4/255 (mean 1/255)")

    # a repeating texture's other UV tile (v in [1, 2]) bakes into the same texels
    quad_t = (quad_z[0], quad_z[1], [(u, v + 1) for u, v in quad_z[2]])
    write_gltf(os.path.join(out, "asset", "tile.gltf"), [quad_t])
    r = run([os.path.join(out, "asset", "tile.gltf"), os.path.join(out, "tile"), "--hdri", const, "--size", "16",
             "--exposure", "1", "--gutter", "0"], 0)
    same = r.returncode == 0 and all(
        np.array_equal(np.asarray(Image.open(os.path.join(out, "tile", "tile_" + n))), rd(n))
        for n in ("lit_baseColor.png", "truth_albedo.png", "mask.png"))
    check(same, "UVs one tile up (v in [1, 2]) bake the same texels")

    # 2. sky only: the upward quad as under the constant map, the downward one black
    up = ([(-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)], (0, 1, 0), [(0, 1), (0.5, 1), (0.5, 0), (0, 0)])
    down = ([(-1, -2, -1), (1, -2, -1), (1, -2, 1), (-1, -2, 1)], (0, -1, 0), [(0.5, 1), (1, 1), (1, 0), (0.5, 0)])
    write_gltf(os.path.join(out, "asset", "updown.gltf"), [up, down])
    bake2 = os.path.join(out, "bake2")
    r = run([os.path.join(out, "asset", "updown.gltf"), bake2, "--hdri", os.path.join(out, "sky.hdr"), "--size", "32",
             "--exposure", "1", "--gutter", "0"], 0)
    check(r.returncode == 0, "litbake up / down quads under a sky-only map: exit 0")
    lit2 = np.asarray(Image.open(os.path.join(bake2, "updown_lit_baseColor.png"))) / 255.0
    # texture texels (16) at 32x32 output: each output texel reads one source texel's neighbourhood (mip 0,
    # bilinear at the output texel centre); the reference, from the truth the tool wrote, is per texel
    alb2 = srgb_decode(np.asarray(Image.open(os.path.join(bake2, "updown_truth_albedo.png"))) / 255.0)
    r2 = np.asarray(Image.open(os.path.join(bake2, "updown_truth_roughness.png"))) / 255.0
    m2 = np.asarray(Image.open(os.path.join(bake2, "updown_truth_metallic.png")))[..., None] / 255.0
    ab2 = split_sum_normal(r2[:, :16].ravel()).reshape(32, 16, 2)
    f02 = 0.04 * (1 - m2[:, :16]) + alb2[:, :16] * m2[:, :16]
    ref_up = (1 - f02) * (1 - m2[:, :16]) * alb2[:, :16] + f02 * ab2[..., :1] + ab2[..., 1:]
    # the irradiance near the pole (the map's first row, 5.6 degrees off +Y) misses a sliver of the sky
    e_up = np.abs(lit2[:, 1:15] - srgb_encode(ref_up)[:, 1:15])
    print(f"     upward quad vs closed form: max {e_up.max() * 255:.2f} / 255, mean {e_up.mean() * 255:.2f} / 255")
    check(e_up.max() <= 4 / 255 and e_up.mean() <= 1 / 255, "upward quad = the constant-map closed form (max 4/255, mean 1/255)")
    check(float(lit2[:, 17:31].max()) <= 2 / 255, f"downward quad black (max {lit2[:, 17:31].max() * 255:.0f} / 255)")

    # 3. the lit glTF through the mesh pipeline (no networks): its base colour is the lit bake
    baked = os.path.join(out, "mesh")
    os.makedirs(baked)
    r = subprocess.run([mesh_exe, "--passthrough", os.path.join(bake, "quad_lit.gltf"), os.path.join(baked, "q.gltf"),
                        "--size", "16", "--views-size", "256"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    check(r.returncode == 0, "supermat mesh --passthrough reads the lit glTF: exit 0" + ("" if r.returncode == 0 else ": " + r.stderr))
    with open(os.path.join(bake, "quad_lit.gltf")) as f:
        g = json.load(f)
    check(len(g["materials"]) == 1 and "metallicRoughnessTexture" not in g["materials"][0]["pbrMetallicRoughness"]
          and "normalTexture" not in g["materials"][0] and "extensionsUsed" not in g
          and os.path.exists(os.path.join(bake, "quad.bin")), "lit glTF: one material, the lit texture alone, buffer copied")
    if r.returncode == 0:
        back = np.asarray(Image.open(os.path.join(baked, "q_baseColor.png")).convert("RGB")) / 255.0
        e = np.abs(back - lit)[2:14, 2:14]
        e_alb = np.abs(back - base8 / 255.0)[2:14, 2:14]
        print(f"     passthrough bake vs the lit texture (inner texels): max {e.max() * 255:.1f} / 255, mean "
              f"{e.mean() * 255:.2f} / 255 (vs the true albedo: mean {e_alb.mean() * 255:.1f} / 255)")
        check(e.max() <= 12 / 255 and e.mean() <= 4 / 255 and e.mean() < e_alb.mean() / 4,
              "passthrough bake reproduces the lit texture (inner texels: max 12/255, mean 4/255; "
              "under a quarter of its distance to the true albedo)")

    # 5. supermat_tools.eval_bake on the quad: the truth as a bake scores the cap and relights within 40 dB of the
    #    original (the views of the original and of a bake line up), the lit baseline's numbers are those of
    #    the files it wrote, and a bake with the tiny random models runs through
    if len(sys.argv) > 4:
        js = os.path.join(out, "eval_bake.json")
        cmd = [sys.executable, "-m", "supermat_tools.eval_bake", "--assets",
               os.path.join(out, "asset", "quad.gltf"), "--hdri-dir", out, "--env-bake", "const", "--env-relight", "sky",
               "--size", "16", "--views-size", "64", "--mesh-args", "--work-size native", "--views", "2", "--relight-size", "64", "--baselines",
               "lit,passthrough,truth", "--bake", f"tiny={sys.argv[3]},{sys.argv[4]},{sys.argv[4]}",
               "--bake", f"tiny_mv={sys.argv[3]}", "--bake", f"tiny_alb={sys.argv[3]},{sys.argv[4]},"] + (["--bake", f"tiny_sv={sys.argv[6]}"] if len(sys.argv) > 6 else []) + [
               "--supermat", sys.argv[5], "--work", os.path.join(out, "eval_bake"), "--json", js, "--decompose"]
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        check(r.returncode == 0, "eval_bake: exit 0" + ("" if r.returncode == 0 else ": " + r.stderr[-2000:]))
        if r.returncode == 0:
            with open(js) as f:
                res = {row["predictor"]: row for row in json.load(f)["rows"]}
            t = res["truth"]
            print(f"     eval_bake truth: relight {t['relight_psnr']:.1f} dB, SSIM {t['relight_ssim']:.4f}")
            check(t["albedo_psnr"] == 100 and t["rough_psnr"] == 100 and t["metal_psnr"] == 100
                  and t["relight_psnr"] >= 40, "eval_bake: the truth as a bake: 100 dB maps, relit >= 40 dB")
            d = os.path.join(out, "eval_bake", "quad", "input")
            m = np.asarray(Image.open(os.path.join(d, "quad_mask.png"))) > 0
            lit8 = np.asarray(Image.open(os.path.join(d, "quad_lit_baseColor.png"))) / 255.0
            alb8 = np.asarray(Image.open(os.path.join(d, "quad_truth_albedo.png"))) / 255.0
            met8 = np.asarray(Image.open(os.path.join(d, "quad_truth_metallic.png"))) / 255.0
            own = 10 * np.log10(1 / np.mean((lit8 - alb8)[m] ** 2))
            own_m = 10 * np.log10(1 / np.mean(met8[m] ** 2))
            check(abs(res["lit"]["albedo_psnr"] - own) < 1e-6 and abs(res["lit"]["metal_psnr"] - own_m) < 1e-6,
                  f"eval_bake: lit albedo {res['lit']['albedo_psnr']:.3f} / metallic {res['lit']['metal_psnr']:.3f} dB = "
                  f"this test's own {own:.3f} / {own_m:.3f}")
            # --decompose: the best gain on the lit texture, recomputed here (one gain, then one a channel)
            own_g = []
            for axis in (None, 0):
                k = np.sum(lit8[m] * alb8[m], axis=axis) / np.sum(lit8[m] ** 2, axis=axis)
                own_g.append(10 * np.log10(1 / np.mean((np.clip(lit8 * k, 0, 1) - alb8)[m] ** 2)))
            got_g = (res["lit"]["albedo_psnr_gain"], res["lit"]["albedo_psnr_wb"])
            check(all(abs(a - b) < 1e-6 for a, b in zip(got_g, own_g))
                  and res["truth"]["albedo_psnr_gain"] == 100 and "albedo error decomposed" in r.stdout,
                  f"eval_bake --decompose: lit albedo after the best gain {got_g[0]:.3f} / per channel {got_g[1]:.3f} dB = "
                  f"this test's own {own_g[0]:.3f} / {own_g[1]:.3f}")
            check(all(np.isfinite(res["tiny"][k]) for k in ("albedo_psnr", "rough_psnr", "metal_psnr", "relight_psnr")),
                  "eval_bake: the tiny models' bake measured")
            # --no-refine: the multi-view model's back-projection alone, which the refine networks then change
            nr = res["tiny_mv"]
            check(all(np.isfinite(nr[k]) for k in ("albedo_psnr", "rough_psnr", "metal_psnr"))
                  and abs(nr["albedo_psnr"] - res["tiny"]["albedo_psnr"]) > 1e-3,
                  f"eval_bake NAME=MV (supermat mesh --no-refine): measured, {nr['albedo_psnr']:.2f} dB against "
                  f"{res['tiny']['albedo_psnr']:.2f} with the refine models")
            # an empty refine slot (NAME=MV,ALB,): that map unrefined, the other refined
            al = res["tiny_alb"]
            check(al["albedo_psnr"] == res["tiny"]["albedo_psnr"] and al["rough_psnr"] == nr["rough_psnr"]
                  and al["metal_psnr"] == nr["metal_psnr"],
                  f"eval_bake NAME=MV,ALB, (--albedo-refine alone): the albedo of the full bake ({al['albedo_psnr']:.2f} dB), "
                  f"the roughness / metallic of --no-refine ({al['rough_psnr']:.2f} / {al['metal_psnr']:.2f})")
        if len(sys.argv) > 6 and r.returncode == 0:
            # a single-view model as --mv-model: run view by view (the paper's ablation)
            sv = res["tiny_sv"]
            check(all(np.isfinite(sv[k]) for k in ("albedo_psnr", "rough_psnr", "metal_psnr"))
                  and abs(sv["albedo_psnr"] - nr["albedo_psnr"]) > 1e-3,
                  f"eval_bake NAME=SV (a single-view model, view by view): measured, {sv['albedo_psnr']:.2f} dB against "
                  f"{nr['albedo_psnr']:.2f} with the multi-view model")
            # no model flags: the default model (here $SUPERMAT_MODEL = the tiny one), view by view, no refinement:
            # the same bytes as --mv-model TINY --no-refine
            lit = os.path.join(out, "eval_bake", "quad", "input", "quad_lit.gltf")
            small = ["--size", "16", "--views-size", "64", "--work-size", "64"]
            d_flags, d_none = os.path.join(out, "sv_flags"), os.path.join(out, "sv_default")
            for d in (d_flags, d_none):
                shutil.rmtree(d, ignore_errors=True)
                os.makedirs(d)
            env = dict(os.environ, SUPERMAT_MODEL=sys.argv[6])
            r1 = subprocess.run([sys.argv[5], "mesh", "--mv-model", sys.argv[6], "--no-refine", lit,
                                 os.path.join(d_flags, "q.gltf")] + small, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                universal_newlines=True)
            r2 = subprocess.run([sys.argv[5], "mesh", lit, os.path.join(d_none, "q.gltf")] + small, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
            names = sorted(os.listdir(d_flags))
            same = r1.returncode == 0 and r2.returncode == 0 and names == sorted(os.listdir(d_none)) and len(names) >= 3 and all(
                open(os.path.join(d_flags, n), "rb").read() == open(os.path.join(d_none, n), "rb").read() for n in names)
            check(same, f"supermat mesh without model flags = --mv-model $SUPERMAT_MODEL --no-refine, byte for byte ({names}): "
                        f"{r1.stderr[-300:]} {r2.stderr[-300:]}")
            # the mesh defaults beside the default model: with the three files there, no model flags = the
            # multi-view one without refinement, --refine = the flags naming all three
            def mesh_bake(args, env=None, tag="b"):
                d = os.path.join(out, "md_" + tag)
                shutil.rmtree(d, ignore_errors=True)
                os.makedirs(d)
                rr = subprocess.run([sys.argv[5], "mesh"] + args + [lit, os.path.join(d, "q.gltf")] + small,
                                    env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
                if rr.returncode != 0:
                    print(rr.stderr[-400:])
                    return None
                return {n: open(os.path.join(d, n), "rb").read() for n in sorted(os.listdir(d))}
            md = os.path.join(out, "mesh_defaults")
            shutil.rmtree(md, ignore_errors=True)
            os.makedirs(md)
            links = {"supermat_default.safetensors": sys.argv[6], "supermat_mv_default.safetensors": sys.argv[3],
                     "supermat_refine_albedo_default.safetensors": sys.argv[4], "supermat_refine_rm_default.safetensors": sys.argv[4]}
            for n, t in links.items():
                os.symlink(os.path.abspath(t), os.path.join(md, n))
            env = dict(os.environ, SUPERMAT_MODEL=os.path.join(md, "supermat_default.safetensors"))
            full = mesh_bake(["--mv-model", sys.argv[3], "--albedo-refine", sys.argv[4], "--rm-refine", sys.argv[4]], tag="full")
            got = mesh_bake(["--refine"], env, "full_default")
            check(full is not None and full == got, "the three mesh defaults beside the default model: --refine = "
                                                    "--mv-model MV --albedo-refine UV --rm-refine UV, byte for byte")
            got = mesh_bake(["--mv-model", sys.argv[3], "--refine"], env, "full_mv_refine")
            check(full is not None and full == got, "--mv-model MV --refine: that view model and the refine defaults, "
                                                    "byte for byte")
            mv_only = mesh_bake(["--mv-model", sys.argv[3], "--no-refine"], tag="mv")
            got = mesh_bake([], env, "mv_default")
            check(mv_only is not None and mv_only == got and mv_only != full,
                  "no model flags, the refine defaults there too: the multi-view default alone, byte for byte")
            got = mesh_bake(["--no-refine"], env, "mv_default_nr")
            check(mv_only is not None and mv_only == got, "no model flags with --no-refine: the same bytes")
            got = mesh_bake(["--mv-model", sys.argv[3]], tag="mv_alone")
            check(mv_only is not None and mv_only == got, "--mv-model MV and no refine flag: = --no-refine, byte for byte")
            for bad, what in ((["--refine", "--no-refine"], "--no-refine"), (["--refine", "--passthrough"], "--passthrough"),
                              (["--refine", "--albedo-refine", sys.argv[4], "--mv-model", sys.argv[3]], "--albedo-refine"),
                              (["--keep-observed"], "--keep-observed")):
                rb = subprocess.run([sys.argv[5], "mesh"] + bad + [lit, os.path.join(out, "bad.gltf")], env=env,
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
                check(rb.returncode == 2 and what in rb.stderr and not os.path.exists(os.path.join(out, "bad.gltf")),
                      f"supermat mesh {' '.join(bad[:2])}: usage error naming {what}, nothing written")
            # one refine network alone: its map is the full bake's, the other map the view model's (the two
            # refinements are independent); beside the default model, only the file that is there is used
            alb_only = mesh_bake(["--mv-model", sys.argv[3], "--albedo-refine", sys.argv[4]], tag="alb")
            rm_only = mesh_bake(["--mv-model", sys.argv[3], "--rm-refine", sys.argv[4]], tag="rm")
            bcn, mrn = "q_baseColor.png", "q_metallicRoughness.png"
            check(alb_only is not None and full is not None and mv_only is not None and alb_only[bcn] == full[bcn]
                  and alb_only[mrn] == mv_only[mrn] and full[bcn] != mv_only[bcn],
                  "--albedo-refine alone: the albedo of the full bake, the metallic-roughness of --no-refine")
            check(rm_only is not None and full is not None and mv_only is not None and rm_only[mrn] == full[mrn]
                  and rm_only[bcn] == mv_only[bcn] and full[mrn] != mv_only[mrn],
                  "--rm-refine alone: the metallic-roughness of the full bake, the albedo of --no-refine")
            os.unlink(os.path.join(md, "supermat_refine_rm_default.safetensors"))
            got = mesh_bake(["--refine"], env, "alb_default")
            check(alb_only is not None and alb_only == got, "only the albedo refine default beside the default model: "
                  "--refine = --albedo-refine alone, byte for byte")
            os.unlink(os.path.join(md, "supermat_refine_albedo_default.safetensors"))
            got = mesh_bake([], env, "mv_default_alone")
            check(mv_only == got, "only the multi-view default beside the default model: it bakes without refinement")
            rn = subprocess.run([sys.argv[5], "mesh", "--refine", lit, os.path.join(out, "nr.gltf")] + small, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
            check(rn.returncode == 1 and "no UV-refine default" in rn.stderr and not os.path.exists(os.path.join(out, "nr.gltf")),
                  "--refine with no refine default beside the default model: exit 1, a message, nothing written")
            # --keep-observed: the refined maps fill only the texels no view saw; the seen ones stay the
            # back-projection's (--detail off: the detail step would mix neighbours in)
            lit_dbg = os.path.join(out, "keep_dbg")
            ko = mesh_bake(["--mv-model", sys.argv[3], "--albedo-refine", sys.argv[4], "--rm-refine", sys.argv[4],
                       "--keep-observed", "--detail", "off", "--debug-dir", lit_dbg], tag="keep")
            nr2 = mesh_bake(["--mv-model", sys.argv[3], "--no-refine", "--detail", "off"], tag="keep_nr")
            rf = mesh_bake(["--mv-model", sys.argv[3], "--albedo-refine", sys.argv[4], "--rm-refine", sys.argv[4],
                       "--detail", "off"], tag="keep_rf")
            if ko and nr2 and rf:
                import io
                img = lambda b: np.asarray(Image.open(io.BytesIO(b)).convert("RGB")).astype(int)  # noqa: E731
                seen = np.asarray(Image.open(os.path.join(lit_dbg, "mask.png"))) > 0
                a_ko, a_nr, a_rf = (img(x["q_baseColor.png"]) for x in (ko, nr2, rf))
                m_ko, m_nr = (img(x["q_metallicRoughness.png"]) for x in (ko, nr2))
                check(seen.any() and np.array_equal(a_ko[seen], a_nr[seen]) and np.array_equal(m_ko[seen], m_nr[seen])
                      and not np.array_equal(a_rf[seen], a_nr[seen]),
                      f"--keep-observed: the {int(seen.sum())} seen texels = --no-refine's (refined everywhere: they differ)")
            else:
                check(False, "--keep-observed bakes")
            rk = subprocess.run([sys.argv[5], "mesh", "--mv-model", sys.argv[3], "--no-refine", "--keep-observed", lit,
                                 os.path.join(out, "k.gltf")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                universal_newlines=True)
            check(rk.returncode == 2 and "--keep-observed" in rk.stderr and not os.path.exists(os.path.join(out, "k.gltf")),
                  "--keep-observed with --no-refine: usage error")
            # --work-size: the network's size (default: the file's pipeline.work_size); another size, other maps
            outs = []
            for ws in ("native", "32"):
                d = os.path.join(out, "sv_ws_" + ws)
                shutil.rmtree(d, ignore_errors=True)
                os.makedirs(d)
                rw = subprocess.run([sys.argv[5], "mesh", "--mv-model", sys.argv[6], "--no-refine", lit,
                                     os.path.join(d, "q.gltf")] + small + ["--work-size", ws], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                    universal_newlines=True)
                outs.append(open(os.path.join(d, "q_baseColor.png"), "rb").read() if rw.returncode == 0 else None)
            check(outs[0] is not None and outs[1] is not None and outs[0] != outs[1],
                  "supermat mesh --work-size native / 32: both bake, different maps")
            rw = subprocess.run([sys.argv[5], "mesh", "--work-size", "12", lit, os.path.join(out, "z.gltf")],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
            check(rw.returncode == 2 and "--work-size" in rw.stderr and not os.path.exists(os.path.join(out, "z.gltf")),
                  "--work-size 12: usage error")
            env = dict(os.environ, SUPERMAT_MODEL=os.path.join(out, "no_such_model.safetensors"))
            r3 = subprocess.run([sys.argv[5], "mesh", lit, os.path.join(d_none, "x.gltf")] + small, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
            check(r3.returncode == 1 and "SUPERMAT_MODEL" in r3.stderr and not os.path.exists(os.path.join(d_none, "x.gltf")),
                  "no model flags, $SUPERMAT_MODEL names a missing file: exit 1, a message, nothing written")
            r4 = subprocess.run([sys.argv[5], "mesh", "--albedo-refine", sys.argv[4], lit, os.path.join(d_none, "y.gltf")],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
            check(r4.returncode == 2 and "--mv-model" in r4.stderr, "--albedo-refine without --mv-model: usage error")
        r = subprocess.run([mesh_exe, "--no-refine", "--passthrough", "a.gltf", "b.gltf"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, universal_newlines=True)
        check(r.returncode == 2 and "--no-refine" in r.stderr, "supermat mesh --no-refine --passthrough: usage error")
        r = subprocess.run([mesh_exe, "--mv-model", sys.argv[3], "--keep-observed", "a.gltf", "b.gltf"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, universal_newlines=True)
        check(r.returncode == 2 and "--keep-observed" in r.stderr,
              "supermat mesh --mv-model --keep-observed without a refine network: usage error")

    # 4. failures
    r = run([os.path.join(out, "asset", "quad.gltf"), bake, "--hdri", const, "--size", "16"], 1)
    check(r.returncode == 1 and "exists" in r.stderr, "an existing output without --force: exit 1")
    r = run([os.path.join(out, "asset", "quad.gltf"), bake, "--hdri", const, "--size", "16", "--force"], 0)
    check(r.returncode == 0, "--force replaces it")
    check(not any(n.endswith(".tmp") for n in os.listdir(bake)), "no .tmp file left")
    r = run([os.path.join(out, "asset", "quad.gltf"), os.path.join(out, "x"), "--hdri", os.path.join(out, "no.hdr")], 1)
    check(r.returncode == 1 and "error:" in r.stderr and not os.path.exists(os.path.join(out, "x")),
          "a missing map: exit 1, nothing written")
    write_gltf(os.path.join(out, "asset", "two.gltf"), [quad_z], materials=2)
    r = run([os.path.join(out, "asset", "two.gltf"), os.path.join(out, "x"), "--hdri", const], 1)
    check(r.returncode == 1 and "materials" in r.stderr, "two materials: exit 1")
    write_gltf(os.path.join(out, "asset", "nouv.gltf"), [quad_z], uvs=False)
    r = run([os.path.join(out, "asset", "nouv.gltf"), os.path.join(out, "x"), "--hdri", const], 1)
    check(r.returncode == 1 and "UV" in r.stderr, "no UVs: exit 1")
    r = run([os.path.join(out, "asset", "quad.gltf"), os.path.join(out, "x"), "--hdri", const, "--size", "3"], 2)
    check(r.returncode == 2, "--size 3: usage error")
    print(f"litbake: {fails} failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
