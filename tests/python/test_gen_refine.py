#!/usr/bin/env python3
"""ctest uv_gen_refine: supermat_tools.gen_refine_data (the UV-refine networks' training data) checked through
`supermat mesh --passthrough` (--model passthrough: no network, the lit colours rendered into the six views and
back-projected, roughness 0.5, metallic 0).

usage: test_gen_refine.py OUT_DIR SUPERMAT

Two procedural meshes at 128x128 texels, views at 384x384, under a synthetic sky map written here:
  - the shard holds every array at the texture size, uint8, the mask in min(views, 3) / 3 steps;
  - the back-projected texels lie on the charts litbake.py rasterised, and cover most of them;
  - the partial albedo at those texels is the lit texture (passthrough: the colours go round the views and
    back), within a mean of 6/255 (measured 4.45 and 2.53; 11.4 and 7.8 with 128x128 views: the views' resampling
    blur), and at least 3x closer than the lit texture turned upside down (a row or
    UV convention that differs between supermat_tools.litbake and supermat_uv.h breaks that);
  - the partial RM map there is (0, 0.5, 0); the position map is gray 127 off the charts;
  - the same seed writes the same arrays; a folder with only the held-out maps is refused (exit != 0).
"""
import os
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from test_litbake import write_hdr  # noqa: E402

fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    fails += 0 if ok else 1


def gen(sm, hdri, out, seed=5, count=2):
    cmd = [sys.executable, "-m", "supermat_tools.gen_refine_data", "--hdri-dir", hdri, "--out", out,
           "--model", "passthrough", "--supermat", sm, "--count", str(count), "--shard", str(count), "--jobs", "1",
           "--size", "128", "--views-size", "384", "--seed", str(seed)]
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)


def main():
    out, sm = sys.argv[1], sys.argv[2]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(os.path.join(out, "hdri"))
    sky = np.full((64, 128, 3), 0.05, np.float32)
    sky[:32] = np.linspace(0.3, 2.0, 32)[:, None, None] * np.array([0.8, 0.9, 1.0], np.float32)
    sky[4:10, 40:50] = 40.0
    write_hdr(os.path.join(out, "hdri", "test_sky.hdr"), sky)
    r = gen(sm, os.path.join(out, "hdri"), os.path.join(out, "a"))
    check(r.returncode == 0, "gen_refine_data.py --model passthrough writes a shard: exit 0 " + r.stdout[-800:])
    if r.returncode:
        return 1
    d = np.load(os.path.join(out, "a", "shard_0000.npz"))
    keys = ("partial_albedo", "partial_rm", "mask", "position", "chart", "lit", "truth_albedo", "truth_rough", "truth_metal")
    check(sorted(d.files) == sorted(keys), f"the shard's arrays: {sorted(d.files)}")
    shapes_ok = all(d[k].dtype == np.uint8 and d[k].shape[:3] == (2, 128, 128) and
                    d[k].shape[3:] == ((3,) if k in ("partial_albedo", "partial_rm", "position", "lit", "truth_albedo") else ())
                    for k in keys)
    check(shapes_ok, "every array uint8, 2 x 128 x 128 (x 3)")
    check(set(np.unique(d["mask"]).tolist()) <= {0, 85, 170, 255}, f"mask levels {sorted(set(np.unique(d['mask']).tolist()))}")
    for i in range(2):
        chart = d["chart"][i] > 127
        seen = d["mask"][i] > 0
        cov = chart.mean()
        check(0.05 < cov < 0.95, f"mesh {i}: charts cover {cov:.1%} of the texture")
        off = (seen & ~chart).sum() / max(seen.sum(), 1)
        frac = (seen & chart).sum() / max(chart.sum(), 1)
        check(off < 0.01 and frac > 0.5, f"mesh {i}: {frac:.1%} of the chart texels seen, {off:.2%} of the seen ones off the charts")
        pa = d["partial_albedo"][i].astype(np.float64)
        lit = d["lit"][i].astype(np.float64)
        e = np.abs(pa - lit)[seen].mean()
        e_flip = np.abs(pa - lit[::-1])[seen].mean()
        check(e <= 6 and e * 3 <= e_flip, f"mesh {i}: partial albedo - lit texture, mean {e:.2f}/255 (upside down {e_flip:.2f})")
        rm = d["partial_rm"][i][seen].astype(np.float64)
        check(np.abs(rm[:, 0]).max() == 0 and np.abs(rm[:, 1] - 127.5).max() <= 1.5 and rm[:, 2].max() == 0,
              f"mesh {i}: partial RM (0, 0.5, 0) on the seen texels (G {rm[:, 1].min():.0f}..{rm[:, 1].max():.0f})")
        pos = d["position"][i][~chart]
        g = np.mean(np.all(pos == 127, -1))
        check(g > 0.9, f"mesh {i}: position gray 127 on {g:.1%} of the texels off the charts")
    r = gen(sm, os.path.join(out, "hdri"), os.path.join(out, "b"))
    same = r.returncode == 0 and all(np.array_equal(d[k], np.load(os.path.join(out, "b", "shard_0000.npz"))[k]) for k in keys)
    check(same, "the same seed writes the same arrays")
    os.makedirs(os.path.join(out, "hdri_held_out"))
    write_hdr(os.path.join(out, "hdri_held_out", "venice_sunset_1k.hdr"), sky)
    r = gen(sm, os.path.join(out, "hdri_held_out"), os.path.join(out, "c"), count=1)
    check(r.returncode != 0 and not os.path.exists(os.path.join(out, "c", "shard_0000.npz")),
          f"only held-out maps: refused, exit {r.returncode}")
    print(f"{fails} failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
