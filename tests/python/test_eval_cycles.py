#!/usr/bin/env python3
"""ctest eval_cycles: supermat_tools.eval_cycles (scores on the independent renderer's set) and, where Debian's
`blender` is installed, supermat_tools.cycles_render (that set's renderer).  Checks:
  - fit_curve: recovers a known monotone curve from noisy pixels (within 0.01 a knot); on a relation that
    falls, the curve is still non-decreasing and in [0, 1], and its squared error is no larger than every
    other member of the family tried (the best constant, the identity, 2000 random monotone curves);
  - score: the pooled PSNR equals a hand computation over two pictures with masks of different sizes (each
    object pixel weighs alike), a perfect map scores the 100 dB cap;
  - the command line on a synthetic set (no model): the baselines' JSON numbers equal a direct computation;
  - cycles_render (skipped without blender): a sphere with one constant material (base colour 0.8/0.2/0.1,
    roughness 0.3, metallic 1.0) rendered at 48x48, 16 samples, 2 views: the truth maps equal the material
    on every object pixel (within 1/255 inside, where no edge mixes the background), the picture's alpha
    covers the object, one stop under (std-1) is darker than std0 and one over (std+1) brighter, the meta
    file records the exposure, a second run renders nothing (resumable);
  - training renders (skipped without blender): the sphere lit by a map of a --world-dir (a constant Radiance
    .hdr written here) with --normals: the camera-frame normals are unit length, face the camera and point up
    at the top and left at the left; supermat_tools.cycles_data packs 2 views x 4 looks into shards holding the
    PNGs' bytes and the normals, lists the training maps, and refuses a set without normals or lit by a map
    outside the training list.
usage: test_eval_cycles.py WORKDIR
"""
import base64
import json
import math
import os
import shutil
import struct
import subprocess
import sys

import numpy as np
from PIL import Image

from supermat_tools import eval_cycles as ec

FAILS = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        FAILS.append(what)


def items_of(pred, truth, m="metallic"):
    return [dict(mask=np.ones(pred.shape, bool), truth={m: truth}, pred={m: pred})]


def sq_err(items, curve, m="metallic"):
    return sum(float(np.sum((ec.apply_curve(it["pred"][m], curve) - it["truth"][m]) ** 2)) for it in items)


def test_fit(rng):
    x = rng.random((200, 200)).astype(np.float32)
    true_curve = [0.05, 0.05, 0.1, 0.3, 0.35, 0.5, 0.8, 0.9, 0.95]
    t = ec.apply_curve(x, true_curve) + rng.normal(0, 0.05, x.shape)
    items = items_of(x, t)
    c = ec.fit_curve(items, lambda it: it["pred"], "metallic")
    check(max(abs(a - b) for a, b in zip(c, true_curve)) < 0.01,
          f"fit_curve recovers a known curve: {np.round(c, 3).tolist()}")
    # a relation that falls: truth = 1 - pred, clipped noise
    t2 = np.clip(1 - x + rng.normal(0, 0.1, x.shape), 0, 1)
    items2 = items_of(x, t2)
    c2 = ec.fit_curve(items2, lambda it: it["pred"], "metallic")
    check(all(b >= a - 1e-9 for a, b in zip(c2, c2[1:])) and min(c2) >= 0 and max(c2) <= 1,
          f"a falling relation still gives a non-decreasing curve in [0, 1]: {np.round(c2, 3).tolist()}")
    e = sq_err(items2, c2)
    mean = float(t2.mean())
    others = [[mean] * 9, list(np.linspace(0, 1, 9))]
    for _ in range(2000):
        v = np.sort(rng.random(9))
        others.append(list(v * rng.random() + rng.random() * (1 - v.max())))
    worst = min(sq_err(items2, o) for o in others)
    check(e <= worst * (1 + 1e-6), f"its error {e:.2f} <= every other monotone curve tried (best {worst:.2f})")


def test_score(rng):
    t1 = rng.random((8, 8)).astype(np.float32)
    t2 = rng.random((8, 8)).astype(np.float32)
    m1 = np.zeros((8, 8), bool)
    m1[:2] = True                      # 16 pixels
    m2 = np.ones((8, 8), bool)         # 64 pixels
    p1, p2 = np.clip(t1 + 0.1, 0, 1), np.clip(t2 - 0.2, 0, 1)
    alb = np.zeros((8, 8, 3), np.float32)
    items = [dict(asset="a", mask=m1, truth=dict(albedo=alb, roughness=t1, metallic=t1),
                  pred=dict(albedo=alb, roughness=p1, metallic=t1)),
             dict(asset="b", mask=m2, truth=dict(albedo=alb, roughness=t2, metallic=t2),
                  pred=dict(albedo=alb, roughness=p2, metallic=t2))]
    r = ec.score(items, lambda it: it["pred"])
    se = float(np.sum((p1 - t1)[m1] ** 2) + np.sum((p2 - t2)[m2] ** 2))
    want = 10 * math.log10(1 / (se / 80))
    check(abs(r["roughness"] - want) < 1e-4, f"pooled PSNR {r['roughness']:.6f} = by hand {want:.6f}")
    want_a = 10 * math.log10(1 / float(np.mean((p1 - t1)[m1] ** 2)))
    check(abs(r["assets"]["a"]["roughness"] - want_a) < 1e-4, "the per-asset PSNR by hand")
    check(r["metallic"] == 100.0 and r["albedo"] == 100.0, "a perfect map scores the 100 dB cap")


def write_set(d, rng):
    for sub in ("inputs", "truth"):
        os.makedirs(os.path.join(d, sub), exist_ok=True)
    assets = ec.PARTS["validation"] + ec.PARTS["heldout"]
    for a in assets:
        for v in range(2):
            rgba = (rng.random((16, 16, 4)) * 255).astype(np.uint8)
            rgba[..., 3] = np.where(rng.random((16, 16)) < 0.7, 255, 0)
            Image.fromarray(rgba).save(os.path.join(d, "inputs", f"{a}_{v}_std0.png"))
            Image.fromarray((rng.random((16, 16, 3)) * 255).astype(np.uint8)).save(
                os.path.join(d, "truth", f"{a}_{v}_albedo.png"))
            for m in ("roughness", "metallic"):
                Image.fromarray((rng.random((16, 16)) * 255).astype(np.uint8)).save(
                    os.path.join(d, "truth", f"{a}_{v}_{m}.png"))
    with open(os.path.join(d, "index.json"), "w") as f:
        json.dump({"assets": list(assets), "views": 2, "looks": ["std0"]}, f)


def test_cli(work, rng):
    d = os.path.join(work, "set")
    write_set(d, rng)
    js = os.path.join(work, "out.json")
    env = dict(os.environ)
    r = subprocess.run([sys.executable, "-m", "supermat_tools.eval_cycles", "--set", d, "--part", "heldout",
                        "--json", js], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
                       env=env)
    check(r.returncode == 0, "eval_cycles runs on a synthetic set without a model")
    if r.returncode != 0:
        print(r.stdout)
        return
    res = json.load(open(js))
    # direct: dataset means from the validation truth, then pooled PSNR of the picture baseline on held-out
    rd, md, n = [], [], 0
    for a in ec.PARTS["validation"]:
        for v in range(2):
            al = np.asarray(Image.open(os.path.join(d, "inputs", f"{a}_{v}_std0.png")))[..., 3] >= 128
            rd.append(np.asarray(Image.open(os.path.join(d, "truth", f"{a}_{v}_roughness.png")), float)[al] / 255)
            md.append(np.asarray(Image.open(os.path.join(d, "truth", f"{a}_{v}_metallic.png")), float)[al] / 255)
    rmean, mmean = np.concatenate(rd).mean(), np.concatenate(md).mean()
    check(abs(res["means"]["roughness"] - rmean) < 1e-6 and abs(res["means"]["metallic"] - mmean) < 1e-6,
          "the dataset means are the validation truth's")
    se_a = se_m = se_m0 = 0.0
    for a in ec.PARTS["heldout"]:
        for v in range(2):
            x = np.asarray(Image.open(os.path.join(d, "inputs", f"{a}_{v}_std0.png")), float) / 255
            al = x[..., 3] >= 0.5
            ta = np.asarray(Image.open(os.path.join(d, "truth", f"{a}_{v}_albedo.png")), float) / 255
            tm = np.asarray(Image.open(os.path.join(d, "truth", f"{a}_{v}_metallic.png")), float) / 255
            se_a += np.sum((x[..., :3] - ta)[al] ** 2) / 3
            se_m += np.sum((mmean - tm)[al] ** 2)
            se_m0 += np.sum(tm[al] ** 2)
            n += int(al.sum())
    p = res["results"]
    check(abs(p["picture"]["albedo"] - 10 * math.log10(n / se_a)) < 1e-4, "picture-as-albedo PSNR by hand")
    check(abs(p["constant"]["metallic"] - 10 * math.log10(n / se_m)) < 1e-4, "constant metallic PSNR by hand")
    check(abs(p["metal0"]["metallic"] - 10 * math.log10(n / se_m0)) < 1e-4, "metallic-0 PSNR by hand")


def sphere_gltf(path):
    """A UV sphere (24 x 12) with one material: base colour (0.8, 0.2, 0.1), roughness 0.3, metallic 1."""
    pos, idx = [], []
    nu, nv = 24, 12
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            pos += [math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)]
    for j in range(nv):
        for i in range(nu):
            a, b = j * (nu + 1) + i, (j + 1) * (nu + 1) + i
            idx += [a, b, a + 1, a + 1, b, b + 1]
    pb = struct.pack(f"<{len(pos)}f", *pos)
    ib = struct.pack(f"<{len(idx)}I", *idx)
    buf = pb + ib
    g = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
         "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.1, 1.0], "roughnessFactor": 0.3,
                                                 "metallicFactor": 1.0}}],
         "buffers": [{"byteLength": len(buf),
                      "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
         "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pb)},
                         {"buffer": 0, "byteOffset": len(pb), "byteLength": len(ib)}],
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(pos) // 3, "type": "VEC3",
                        "min": [-1, -1, -1], "max": [1, 1, 1]},
                       {"bufferView": 1, "componentType": 5125, "count": len(idx), "type": "SCALAR"}]}
    with open(path, "w") as f:
        json.dump(g, f)


def test_render(work):
    if shutil.which("blender") is None:
        print("skip cycles_render: no blender (Debian: blender)")
        return
    gd = os.path.join(work, "gltf", "Ball", "glTF")
    os.makedirs(gd, exist_ok=True)
    sphere_gltf(os.path.join(gd, "Ball.gltf"))
    out = os.path.join(work, "cycles")
    cmd = [sys.executable, "-m", "supermat_tools.cycles_render", "--gltf-dir", os.path.join(work, "gltf"),
           "--assets", "Ball", "--out", out, "--views", "2", "--size", "48", "--samples", "16", "--threads", "2"]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    check(r.returncode == 0, "cycles_render renders a sphere")
    if r.returncode != 0:
        print(r.stdout[-3000:])
        return
    srgb = [round(255 * (1.055 * c ** (1 / 2.4) - 0.055)) for c in (0.8, 0.2, 0.1)]
    for v in range(2):
        rgba = {look: np.asarray(Image.open(os.path.join(out, "inputs", f"Ball_{v}_{look}.png")).convert("RGBA"),
                                 float) for look in ("std0", "std-1", "std+1", "filmic0")}
        a = rgba["std0"][..., 3]
        inner = np.asarray(Image.fromarray((a >= 255).astype(np.uint8)).filter(
            __import__("PIL.ImageFilter", fromlist=["MinFilter"]).MinFilter(3))) > 0
        check(80 < inner.sum() < 48 * 48, f"view {v}: the object covers {int(inner.sum())} inner pixels")
        alb = np.asarray(Image.open(os.path.join(out, "truth", f"Ball_{v}_albedo.png")), float)
        rough = np.asarray(Image.open(os.path.join(out, "truth", f"Ball_{v}_roughness.png")), float)
        metal = np.asarray(Image.open(os.path.join(out, "truth", f"Ball_{v}_metallic.png")), float)
        check(np.abs(alb[inner] - srgb).max() <= 1, f"view {v}: albedo truth = sRGB {srgb} within 1")
        check(np.abs(rough[inner] - round(0.3 * 255)).max() <= 1, f"view {v}: roughness truth = 0.3 within 1/255")
        check(np.abs(metal[inner] - 255).max() <= 1, f"view {v}: metallic truth = 1 within 1/255")
        lum = {k: x[..., :3][inner].mean() for k, x in rgba.items()}
        check(lum["std-1"] < lum["std0"] < lum["std+1"],
              f"view {v}: one stop under / at / over: {lum['std-1']:.1f} < {lum['std0']:.1f} < {lum['std+1']:.1f}")
        meta = json.load(open(os.path.join(out, "meta", f"Ball_{v}.json")))
        check(math.isfinite(meta["exposure"]) and meta["world"] in ("city", "courtyard", "forest", "interior",
                                                                     "night", "studio", "sunrise", "sunset"),
              f"view {v}: meta records exposure {meta['exposure']:+.2f} and world {meta['world']}")
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    check(r.returncode == 0 and "done before" in r.stdout, "a second run renders nothing")


def write_hdr(path, w=16, h=8):
    """A constant Radiance map (flat RGBE scanlines, every texel 1.0)."""
    with open(path, "wb") as f:
        f.write(f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode())
        f.write(bytes([128, 128, 128, 129]) * (w * h))


def test_training(work):
    if shutil.which("blender") is None:
        print("skip cycles_render --normals / cycles_data: no blender (Debian: blender)")
        return
    hdri = os.path.join(work, "hdri")
    os.makedirs(hdri, exist_ok=True)
    write_hdr(os.path.join(hdri, "flat_1k.hdr"))
    out = os.path.join(work, "cycles_train")
    cmd = [sys.executable, "-m", "supermat_tools.cycles_render", "--gltf-dir", os.path.join(work, "gltf"),
           "--assets", "Ball", "--out", out, "--views", "2", "--size", "48", "--samples", "8", "--threads", "2",
           "--world-dir", hdri, "--worlds", "flat_1k", "--normals"]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    check(r.returncode == 0, "cycles_render --world-dir --normals renders the sphere")
    if r.returncode != 0:
        print(r.stdout[-3000:])
        return
    for v in range(2):
        n = np.load(os.path.join(out, "truth", f"Ball_{v}_normal.npy")).astype(np.float32)
        a = np.asarray(Image.open(os.path.join(out, "inputs", f"Ball_{v}_std0.png")).convert("RGBA"))[..., 3] >= 255
        ys, xs = np.nonzero(a)
        top, left = a & (np.arange(48)[:, None] < ys.min() + 6), a & (np.arange(48)[None, :] < xs.min() + 6)
        check(n.shape == (48, 48, 3) and np.abs(np.linalg.norm(n[a], axis=1) - 1).max() < 2e-3,
              f"view {v}: normals {n.shape}, unit length on the object")
        check(n[a][:, 2].mean() > 0.6 and n[top][:, 1].mean() > 0.5 and n[left][:, 0].mean() < -0.5,
              f"view {v}: normals face the camera (z {n[a][:, 2].mean():.2f}), up at the top "
              f"({n[top][:, 1].mean():.2f}), left at the left ({n[left][:, 0].mean():.2f})")
        meta = json.load(open(os.path.join(out, "meta", f"Ball_{v}.json")))
        check(meta["world"] == "flat_1k", f"view {v}: lit by the --world-dir map ({meta['world']})")
    data = os.path.join(work, "cycles_data")
    dcmd = [sys.executable, "-m", "supermat_tools.cycles_data", "--set", out, "--hdri-dir", hdri, "--out", data,
            "--shard", "5"]
    r = subprocess.run(dcmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    check(r.returncode == 0 and "8 samples" in r.stdout, "cycles_data packs 2 views x 4 looks")
    if r.returncode != 0:
        print(r.stdout[-3000:])
        return
    sh = [np.load(os.path.join(data, f)) for f in sorted(os.listdir(data)) if f.startswith("shard_")]
    check([x["rgba"].shape[0] for x in sh] == [5, 3], "two shards of 5 and 3 samples")
    rgba = np.concatenate([x["rgba"] for x in sh])
    nrm = np.concatenate([x["normal"] for x in sh])
    looks = ("std0", "std-1", "std+1", "filmic0")
    same = all(np.array_equal(rgba[v * 4 + k], np.asarray(Image.open(os.path.join(out, "inputs", f"Ball_{v}_{lk}.png"))
                                                          .convert("RGBA"))) for v in range(2) for k, lk in enumerate(looks))
    check(same, "each sample's rgba is its look's PNG, in asset, view, look order")
    check(np.array_equal(nrm[5], np.load(os.path.join(out, "truth", "Ball_1_normal.npy"))), "normals carried as written")
    meta = json.load(open(os.path.join(data, "meta.json")))
    check(meta["envs"] == ["flat_1k.hdr"], f"meta.json lists the training maps: {meta['envs']}")
    r = subprocess.run(dcmd[:-2] + ["--shard", "4"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       universal_newlines=True)
    check(r.returncode != 0 and "another set" in r.stdout, "a folder of other shards is refused, not mixed")
    other = os.path.join(work, "hdri_other")
    os.makedirs(other, exist_ok=True)
    write_hdr(os.path.join(other, "elsewhere_1k.hdr"))
    r = subprocess.run(dcmd[:5] + ["--hdri-dir", other, "--out", data + "2"], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, universal_newlines=True)
    check(r.returncode != 0 and "outside the training list" in r.stdout, "a set lit by another map is refused")
    r = subprocess.run(dcmd[:3] + ["--set", os.path.join(work, "cycles"), "--hdri-dir", hdri, "--out", data + "3"],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    check(r.returncode != 0 and "without --normals" in r.stdout, "a set rendered without normals is refused")


def main():
    work = sys.argv[1]
    shutil.rmtree(work, ignore_errors=True)     # a fresh folder: a render left by an earlier run proves nothing
    os.makedirs(work)
    rng = np.random.default_rng(61)
    test_fit(rng)
    test_score(rng)
    test_cli(work, rng)
    test_render(work)
    test_training(work)
    print(f"{len(FAILS)} failed")
    sys.exit(1 if FAILS else 0)


if __name__ == "__main__":
    main()
