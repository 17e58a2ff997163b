#!/usr/bin/env python3
"""ctest gen_views: supermat_tools.gen_data --views 6 (SuperMatMV training data) against supermat_uv.h's geometry.

usage: test_gen_views.py OUT_DIR [SUPERMAT_MESH]

The surface points of each view (kept by render_views(keep_pos=True)) are projected into every other view with
supermat_uv.h's own orthographic projection, written out again here (pixel = ((X.(q - T)) / 1.1 + 1) W / 2,
row = (1 - (Y.(q - T)) / 1.1) H / 2); where the other view sees the same point (its position within 0.05), the
true albedo and the world normal must agree: a camera, axis or pixel convention that differs from the
runtime's breaks that.  Also: the object fills supermat_uv.h's view frame (bounding box centred within 0.04,
largest half extent 0.93..1.02 from the pixels' positions), the views are lit alike (one exposure), the same
seed gives the same arrays, and the command line writes shards with a view axis and the cameras.  --shading
facing (the lit-baked look): the closed form under a constant map, the same objects as the camera shading.  With
SUPERMAT_MESH: supermat_tools.eval_views's six views of an asymmetric glTF have the silhouettes of `supermat mesh`'s.
Lighting: a synthetic sky map written here (no map from elsewhere is needed).
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
from supermat_tools import gen_data as G  # noqa: E402
from supermat_tools import smrender as R  # noqa: E402
from test_litbake import split_sum_normal, srgb_decode, srgb_encode, write_gltf, write_hdr  # noqa: E402

fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what)
    fails += 0 if ok else 1


def cameras_from_header():
    """supermat_uv.h's matrices, parsed here independently of gen_data.official_cameras."""
    text = open(os.path.join(ROOT, "supermat_uv.h")).read()
    start = text.index("supermat_uv__cam[SUPERMAT_UV_VIEWS][16]")
    block = text[text.index("{", start) + 1:text.index("};", start)]
    nums = [float(t) for t in block.replace("{", " ").replace("}", " ").replace(",", " ").split()]
    return np.array(nums).reshape(6, 4, 4)


def main():
    out = sys.argv[1]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(os.path.join(out, "hdri"))
    sky = np.full((64, 128, 3), 0.05, np.float32)
    sky[:32] = np.linspace(0.3, 2.0, 32)[:, None, None] * np.array([0.8, 0.9, 1.0], np.float32)
    sky[4:10, 40:50] = 40.0                                   # a sun-like spot: lighting that is not uniform
    write_hdr(os.path.join(out, "hdri", "test_sky.hdr"), sky)
    envs = [R.EnvLight(p) for p in G.env_paths(os.path.join(out, "hdri"))]

    cams = G.official_cameras()
    check(np.array_equal(cams, cameras_from_header()), "the six cameras are supermat_uv.h's")
    size, hw = 64, 1.1
    matched, alb_err, ang = 0, [], []
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for seed in range(3):
        s = G.render_views(np.random.default_rng([11, seed]), envs, size, keep_pos=True)
        check(s is not None and s["rgba"].shape == (6, size, size, 4) and s["cams"].shape == (6, 4, 4),
              f"seed {seed}: six views of {size}x{size}")
        full = s["rgba"][..., 3] == 255
        for v in range(6):
            P = s["pos"][v][full[v]]
            lo, hi = np.minimum(lo, P.min(0)), np.maximum(hi, P.max(0))
        wn = [s["normal"][v].astype(np.float64) @ cams[v][:3, :3].T for v in range(6)]   # camera -> world
        for a in range(6):
            ya, xa = np.nonzero(full[a])
            q = s["pos"][a][ya, xa].astype(np.float64)
            for b in range(6):
                if a == b:
                    continue
                X, Y, T = cams[b][:3, 0], cams[b][:3, 1], cams[b][:3, 3]
                r = q - T
                fx = ((r @ X) / hw + 1) * 0.5 * size
                fy = (1 - (r @ Y) / hw) * 0.5 * size
                ix, iy = np.floor(fx).astype(int), np.floor(fy).astype(int)
                ok = (ix >= 0) & (ix < size) & (iy >= 0) & (iy < size)
                ix, iy, sel = ix[ok], iy[ok], np.nonzero(ok)[0]
                vis = full[b][iy, ix] & (np.linalg.norm(s["pos"][b][iy, ix] - q[sel], axis=1) < 0.05)
                # only points the other view sees face-on enough (grazing views mix neighbouring texels)
                vis &= s["normal"][b][iy, ix, 2].astype(np.float64) > 0.3
                vis &= s["normal"][a][ya[sel], xa[sel], 2].astype(np.float64) > 0.3
                if not vis.any():
                    continue
                i = sel[vis]
                matched += int(vis.sum())
                alb_err.append(np.abs(s["albedo"][a][ya[i], xa[i]].astype(np.float64)
                                      - s["albedo"][b][iy[vis], ix[vis]]).mean(1))
                na, nb = wn[a][ya[i], xa[i]], wn[b][iy[vis], ix[vis]]
                ang.append(np.degrees(np.arccos(np.clip((na * nb).sum(1) / np.linalg.norm(na, axis=1)
                                                        / np.linalg.norm(nb, axis=1), -1, 1))))
    alb_err, ang = np.concatenate(alb_err), np.concatenate(ang)
    print(f"     {matched} points seen by two views: albedo |diff| median {np.median(alb_err):.1f} / 255, "
          f"mean {alb_err.mean():.1f}; world normals median {np.median(ang):.1f} deg, mean {ang.mean():.1f}")
    check(matched >= 10000, f"at least 10000 points seen in two views ({matched}; a flipped row convention leaves ~1000)")
    check(np.median(alb_err) <= 3 and alb_err.mean() <= 12,
          "the same point's true albedo in two views: median <= 3/255, mean <= 12/255")
    check(np.median(ang) <= 5 and ang.mean() <= 10, "the same point's world normal in two views: median <= 5, mean <= 10 deg")
    c, half = (lo + hi) / 2, (hi - lo) / 2
    print(f"     positions over all views: centre {np.round(c, 3)}, largest half extent {half.max():.3f}")
    check(np.abs(c).max() <= 0.04 and 0.93 <= half.max() <= 1.02, "the object in supermat_uv.h's view frame")

    s1 = G.render_views(np.random.default_rng([11, 0]), envs, 32)
    s2 = G.render_views(np.random.default_rng([11, 0]), envs, 32)
    check(all(np.array_equal(np.asarray(s1[k]), np.asarray(s2[k])) for k in s1), "the same seed, the same arrays")
    check(np.ndim(s1["exposure"]) == 0, "one exposure for the six views")

    d = os.path.join(out, "data")
    r = subprocess.run([sys.executable, "-m", "supermat_tools.gen_data", "--hdri-dir", os.path.join(out, "hdri"),
                        "--out", d, "--count", "3", "--size", "32", "--shard", "2", "--jobs", "1", "--views", "6"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    check(r.returncode == 0, "gen_data.py --views 6: exit 0" + ("" if r.returncode == 0 else ": " + r.stderr[-1500:]))
    if r.returncode == 0:
        z0, z1 = np.load(os.path.join(d, "shard_0000.npz")), np.load(os.path.join(d, "shard_0001.npz"))
        check(z0["rgba"].shape == (2, 6, 32, 32, 4) and z1["rgba"].shape == (1, 6, 32, 32, 4)
              and z0["cams"].shape == (2, 6, 4, 4) and np.allclose(z0["cams"][1], cams.astype(np.float32)),
              "shards: samples x 6 views, the cameras with them")
        with open(os.path.join(d, "meta.json")) as f:
            check(json.load(f)["views"] == 6, "meta.json says views 6")
    # --shading facing (what `supermat mesh` shows its networks of a lit-baked mesh): under a constant map of
    # radiance 1 every pixel is the closed form of supermat_tools.litbake's test, (1 - F0)(1 - metallic) albedo + F0 A + B
    # with float64 split-sum terms at n . v = 1, exposed and tone mapped with the sample's own exposure and white
    # balance; the same draws give the same objects as the camera shading, whose reflections differ
    os.makedirs(os.path.join(out, "hdri_const"), exist_ok=True)
    write_hdr(os.path.join(out, "hdri_const", "const.hdr"), np.ones((32, 64, 3), np.float32))
    envc = [R.EnvLight(os.path.join(out, "hdri_const", "const.hdr"))]
    errs = {True: [], False: []}
    ab_cache = {}
    for seed in range(4):
        sf = G.render_sample(np.random.default_rng([12, seed]), envc, 64, facing=True)
        sc = G.render_sample(np.random.default_rng([12, seed]), envc, 64)
        check(all(np.array_equal(sf[k], sc[k]) for k in ("albedo", "rough", "metal", "normal")),
              f"seed {seed}: facing and camera shading, the same object and materials")
        full = sf["rgba"][..., 3] == 255
        inner = full.copy()   # away from the silhouette (the supersampled edge pixels mix with the background)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                inner &= np.roll(np.roll(full, dy, 0), dx, 1)
        alb = srgb_decode(sf["albedo"][inner] / 255.0)
        rough, met = sf["rough"][inner] / 255.0, (sf["metal"][inner] / 255.0)[:, None]
        for r8 in np.unique(sf["rough"][inner]):
            if r8 not in ab_cache:
                ab_cache[r8] = split_sum_normal(np.array([r8 / 255.0]))[0]
        ab = np.array([ab_cache[r8] for r8 in sf["rough"][inner]])
        f0 = 0.04 * (1 - met) + alb * met
        lin = (1 - f0) * (1 - met) * alb + f0 * ab[:, :1] + ab[:, 1:2]
        for facing, smp in ((True, sf), (False, sc)):   # each under its own exposure and white balance
            want = srgb_encode(lin * float(smp["exposure"]) * smp["wb"]) * 255
            errs[facing].append(np.abs(smp["rgba"][inner][:, :3] - want).max(1))
    ef, ec = np.concatenate(errs[True]), np.concatenate(errs[False])
    print(f"     facing shading vs the closed form ({ef.size} inner pixels): median {np.median(ef):.2f} / 255, "
          f"90th percentile {np.percentile(ef, 90):.2f}, max {ef.max():.1f}; camera shading: median {np.median(ec):.2f}, "
          f"90th {np.percentile(ec, 90):.2f}")
    check(ef.size >= 2000 and np.median(ef) <= 1.5 and np.percentile(ef, 90) <= 4,
          "facing shading = the closed form under a constant map (median <= 1.5/255, 90th percentile <= 4/255)")
    check(np.percentile(ec, 90) > 2 * np.percentile(ef, 90) + 2, "camera shading differs from it (view-dependent terms)")
    # supermat_tools.eval_views renders an asset in the six views as `supermat mesh` does (its --debug-dir views): an
    # asymmetric glTF (a box with a smaller box on its +X / +Y / +Z corner), silhouettes compared per view
    if len(sys.argv) > 2:
        from supermat_tools import eval_quality as evq
        from supermat_tools import eval_views as EV
        from PIL import Image
        adir = os.path.join(out, "asset")
        os.makedirs(adir, exist_ok=True)
        Image.fromarray(np.full((4, 4, 3), 180, np.uint8)).save(os.path.join(adir, "base.png"))
        Image.fromarray(np.full((4, 4, 3), 128, np.uint8)).save(os.path.join(adir, "mr.png"))

        def box(lo, hi):
            (x0, y0, z0), (x1, y1, z1) = lo, hi
            uv = [(0, 1), (1, 1), (1, 0), (0, 0)]
            return [([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)], (0, 0, 1), uv),
                    ([(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)], (0, 0, -1), uv),
                    ([(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)], (1, 0, 0), uv),
                    ([(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)], (-1, 0, 0), uv),
                    ([(x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (x0, y1, z0)], (0, 1, 0), uv),
                    ([(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)], (0, -1, 0), uv)]
        write_gltf(os.path.join(adir, "boxes.gltf"), box((-1, -0.6, -0.4), (0.6, 0.5, 0.5)) + box((0.3, 0.2, 0.2), (1.0, 1.1, 0.9)))
        dbg = os.path.join(out, "mesh_views")
        os.makedirs(dbg, exist_ok=True)
        r = subprocess.run([sys.argv[2], "--passthrough", "--force", "--debug-dir", dbg, "--views-size", "96", "--size", "64",
                            os.path.join(adir, "boxes.gltf"), os.path.join(dbg, "o.gltf")],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        check(r.returncode == 0, "supermat mesh --debug-dir on the boxes: exit 0" + ("" if r.returncode == 0 else ": " + r.stderr))
        if r.returncode == 0:
            rgba, _, _ = EV.six_views(evq.Mesh(os.path.join(adir, "boxes.gltf")), 96, envs[0], 0.0, 0.2)
            ious = []
            for v in range(6):
                a = rgba[v][..., 3] >= 128
                b = np.asarray(Image.open(os.path.join(dbg, f"view_{v}.png")))[..., 3] >= 128
                ious.append((a & b).sum() / max((a | b).sum(), 1))
            print("     eval_views vs supermat mesh silhouettes, IoU per view: " + " ".join(f"{i:.3f}" for i in ious))
            check(min(ious) >= 0.95, "eval_views renders the six views as supermat mesh does (IoU >= 0.95 each)")

    print(f"gen_views: {fails} failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
