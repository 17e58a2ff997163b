#!/usr/bin/env python3
"""ctest eval_level: supermat_tools.eval_level (how much of the albedo's level a model reads) on renders of
supermat_tools.gen_data, every number recomputed here independently.

usage: test_eval_level.py OUT_DIR SUPERMAT MODEL

- eval_quality.level_stats on levels whose answer is known in closed form (a constant factor of 2: correlation
  1, RMSE 1 in log2, slope 1; the levels reversed: correlation -1; a constant: R2 of the true mean's constant 0);
- gen_data.py renders under a synthetic sky written here, the tool run on them with MODEL: exit 0; each render's
  level recomputed here from the shard arrays and the maps `supermat image` wrote (float64 sRGB decode and
  luminance, written here) within 1e-6; the statistics recomputed with numpy's corrcoef / polyfit within 1e-9;
  the truth as predictor scores correlation 1, R2 1, RMSE 0; every predictor's albedo PSNR after the best gain
  is at least its PSNR as measured; the metallic table's counts and pooled PSNR recomputed from the shards and
  the model's PFM maps (the truth 100 dB and every metal pixel, the constant 0 none); its ROC AUCs, pooled and
  the mean within a render, recomputed by counting (for each metal pixel, the others scoring below it, ties a
  half: searchsorted on the sorted others, not the tool's ranks) within 1e-9; the constant 0.5, the truth 1;
- a folder with no renders: exit status not 0 and a message naming it.
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from supermat_tools import eval_quality as eq  # noqa: E402
from test_litbake import write_hdr  # noqa: E402

fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what)
    fails += 0 if ok else 1


def level64(srgb, mask):
    """The mean linear luminance over the mask, float64, written here (IEC 61966-2-1, Rec. 709 weights)."""
    x = np.clip(np.asarray(srgb, np.float64), 0.0, 1.0)
    lin = np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
    return float((lin[..., 0] * 0.2126 + lin[..., 1] * 0.7152 + lin[..., 2] * 0.0722)[mask].mean())


def read_pfm(path):
    """A colour PFM (written by `supermat image --float`), read here: rows stored bottom first."""
    with open(path, "rb") as f:
        kind, dims, scale = f.readline().strip(), f.readline().split(), float(f.readline())
        w, h = int(dims[0]), int(dims[1])
        a = np.frombuffer(f.read(), ("<" if scale < 0 else ">") + "f4")
    return a.reshape(h, w, 3 if kind == b"PF" else 1)[::-1].astype(np.float64)


def auc_count(pos, neg):
    """ROC AUC by counting, written here: for each positive, the negatives below it plus half the equal ones."""
    pos, neg = np.asarray(pos, np.float64), np.sort(np.asarray(neg, np.float64))
    below = np.searchsorted(neg, pos, "left")
    equal = np.searchsorted(neg, pos, "right") - below
    return float((below + 0.5 * equal).sum() / (len(pos) * len(neg)))


def stats64(pred, true):
    p, t = np.log2(np.asarray(pred) + 1e-4), np.log2(np.asarray(true) + 1e-4)
    return dict(corr=np.corrcoef(p, t)[0, 1], r2=1 - np.sum((p - t) ** 2) / np.sum((t - t.mean()) ** 2),
                rmse=np.sqrt(np.mean((p - t) ** 2)), slope=np.polyfit(p, t, 1)[0], rmse_const=t.std())


def main():
    out, supermat, model = sys.argv[1:4]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(os.path.join(out, "hdri"))

    t = np.array([0.02, 0.1, 0.3, 0.5, 0.8]) - 1e-4
    s = eq.level_stats(2 * t + 1e-4, t)
    check(abs(s["corr"] - 1) < 1e-12 and abs(s["rmse"] - 1) < 1e-12 and abs(s["slope"] - 1) < 1e-12,
          f"level_stats, prediction = 2 x truth: corr {s['corr']:.6f}, RMSE {s['rmse']:.6f} log2, slope {s['slope']:.6f}")
    s = eq.level_stats((t + 1e-4) ** -1 - 1e-4, t)
    check(abs(s["corr"] + 1) < 1e-12, f"level_stats, prediction = 1 / truth: corr {s['corr']:.6f}")
    gm = float(2 ** np.log2(t + 1e-4).mean())
    s = eq.level_stats(np.full(5, gm - 1e-4) * (1 + 1e-8 * np.arange(5)), t)
    check(abs(s["r2"]) < 1e-6 and np.isnan(s["corr"]) and np.isnan(s["slope"]), f"level_stats, the true geometric mean as a constant (up to rounding): R2 {s['r2']:.2e}, corr nan")

    sky = np.full((64, 128, 3), 0.05, np.float32)
    sky[:32] = np.linspace(0.3, 2.0, 32)[:, None, None] * np.array([0.8, 0.9, 1.0], np.float32)
    sky[4:10, 40:50] = 40.0
    write_hdr(os.path.join(out, "hdri", "test_sky.hdr"), sky)
    data = os.path.join(out, "data")
    r = subprocess.run([sys.executable, "-m", "supermat_tools.gen_data", "--hdri-dir", os.path.join(out, "hdri"),
                        "--out", data, "--count", "16", "--size", "64", "--shard", "8", "--jobs", "1", "--seed", "5"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    check(r.returncode == 0, "gen_data.py: exit 0" + ("" if r.returncode == 0 else ": " + r.stderr[-1500:]))
    if r.returncode != 0:
        return 1

    js, work = os.path.join(out, "level.json"), os.path.join(out, "work")
    cmd = [sys.executable, "-m", "supermat_tools.eval_level", "--data", data, "--model", "m=" + model,
           "--supermat", supermat, "--threads", "2", "--work", work, "--json", js, "--min-pixels", "100"]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    print(r.stdout)
    check(r.returncode == 0 and os.path.exists(js), "eval_level.py: exit 0, JSON written" + ("" if r.returncode == 0 else ": " + r.stderr[-1500:]))
    if r.returncode != 0:
        return 1
    with open(js) as f:
        res = json.load(f)

    shards = [np.load(os.path.join(data, n)) for n in ("shard_0000.npz", "shard_0001.npz")]
    renders, shard_metal = {}, {}
    for k, z in enumerate(shards):
        for i in range(len(z["rgba"])):
            renders[f"data_shard_{k:04d}_{i:04d}"] = (z["rgba"][i], z["albedo"][i] / 255.0)
            shard_metal[f"data_shard_{k:04d}_{i:04d}"] = z["metal"][i] / 255.0
    kept = {st: v for st, v in renders.items() if (v[0][..., 3] >= 128).sum() >= 100}
    check(res["renders"] == len(kept) >= 8, f"{res['renders']} renders kept (object >= 100 pixels), {len(kept)} here")

    worst, worst_psnr = 0.0, 0.0
    for p, rows in res["rows"].items():
        for row in rows:
            rgba, alb = kept[row["stem"]]
            mask = rgba[..., 3] >= 128
            if p == "m":
                a = read_pfm(os.path.join(work, "pred_m", row["stem"] + "_albedo.pfm"))
            else:
                a = rgba[..., :3] / 255.0 if p == "picture" else alb
            worst = max(worst, abs(row["level"] - level64(a, mask)), abs(row["level_true"] - level64(alb, mask)))
            worst_psnr = min(worst_psnr, row["albedo_psnr_gain"] - row["albedo_psnr"])
    check(worst <= 1e-6, f"each render's level recomputed here in float64 (model, picture, truth): worst {worst:.2e}")
    check(worst_psnr >= -1e-9, f"albedo PSNR after the best gain >= as measured, every render and predictor (worst {worst_psnr:+.2e} dB)")

    worst = 0.0
    for p, st in res["level"].items():
        ref = stats64([row["level"] for row in res["rows"][p]], [row["level_true"] for row in res["rows"][p]])
        for k in ("corr", "r2", "rmse", "rmse_const", "slope"):
            worst = max(worst, abs(st[k] - ref[k]))
    check(worst <= 1e-9, f"corr, R2, RMSE, slope recomputed with numpy's corrcoef / polyfit: worst {worst:.2e}")
    # the metallic table: counts and pooled PSNR recomputed from the shards and the model's PFM maps
    worst, counts_ok, worst_auc = 0.0, True, 0.0
    for p, c in res["metallic"].items():
        se = n = metal = found = other = false = 0
        pos, neg, within = [], [], []
        for stem, (rgba, _) in kept.items():
            mask = rgba[..., 3] >= 128
            tm = shard_metal[stem][mask]
            pm = (read_pfm(os.path.join(work, "pred_m", stem + "_metallic.pfm"))[..., 0][mask] if p == "m"
                  else np.zeros_like(tm) if p == "constant 0" else tm)
            t = tm > 0.5
            metal += t.sum(); found += (t & (pm > 0.5)).sum(); other += (~t).sum(); false += (~t & (pm > 0.5)).sum()
            se += ((np.clip(pm, 0, 1) - tm) ** 2).sum(); n += mask.sum()
            pos.append(pm[t]); neg.append(pm[~t])
            if t.any() and (~t).any():
                within.append(auc_count(pm[t], pm[~t]))
        counts_ok &= (c["metal"], c["found"], c["other"], c["false"]) == (metal, found, other, false)
        worst_auc = max(worst_auc, abs(c["auc"] - auc_count(np.concatenate(pos), np.concatenate(neg))),
                        abs(c["auc_within"] - np.mean(within)))
        counts_ok &= c["mixed_renders"] == len(within) > 0
        ref = 100.0 if se / n <= 1e-10 else 10 * np.log10(n / se)
        worst = max(worst, abs(c["psnr"] - ref))
    check(counts_ok and worst <= 1e-6 and res["metallic"]["truth"]["psnr"] == 100 and res["metallic"]["truth"]["recall"] == 1,
          f"metallic: metal pixels found / called, recomputed here; pooled PSNR within {worst:.1e} dB; the truth 100 dB")
    check(worst_auc <= 1e-9 and res["metallic"]["constant 0"]["auc"] == 0.5 and res["metallic"]["truth"]["auc"] == 1
          and res["metallic"]["truth"]["auc_within"] == 1,
          f"metallic ROC AUC, pooled and within a render ({res['metallic']['m']['mixed_renders']} renders), recomputed "
          f"by counting: worst {worst_auc:.1e}; the constant 0.5, the truth 1 (the model: "
          f"{res['metallic']['m']['auc']:.3f} / {res['metallic']['m']['auc_within']:.3f})")
    check(res["metallic"]["constant 0"]["found"] == 0 and res["metallic"]["constant 0"]["metal"] > 0,
          f"constant 0 finds none of the {res['metallic']['constant 0']['metal']} metal pixels")
    tr = res["level"]["truth"]
    check(abs(tr["corr"] - 1) < 1e-12 and abs(tr["r2"] - 1) < 1e-12 and tr["rmse"] < 1e-12,
          "the truth as predictor: corr 1, R2 1, RMSE 0")
    check("| m |" in r.stdout and "| picture |" in r.stdout, "the tables printed")

    os.makedirs(os.path.join(out, "empty"))
    r = subprocess.run([sys.executable, "-m", "supermat_tools.eval_level", "--data", os.path.join(out, "empty")],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    check(r.returncode != 0 and "no shard_" in r.stderr and "empty" in r.stderr,
          f"a folder with no renders: exit {r.returncode}, {r.stderr.strip()[:100]!r}")

    print(f"{fails} failure(s)")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
