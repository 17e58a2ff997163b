#!/usr/bin/env python3
"""How much of the albedo's level a model reads from the picture, on the generator's own renders.

usage: eval_level.py --data GEN_DIR[,GEN_DIR...] [--model NAME=FILE ...] [--limit N] [--json F] [--work DIR]
                     [--supermat BIN] [--threads N] [--image-args "ARGS"] [--min-pixels P]

The input pictures are auto-exposed (supermat_tools.gen_data and supermat_tools.eval_quality both key the exposure to the
object's median luminance, then jitter it), so an object's albedo level -- the mean linear luminance of its true
albedo over the object -- is not in the picture's brightness; only cues such as the highlights' strength against
the diffuse shading and the Fresnel rim carry it.  This tool measures, on renders of supermat_tools.gen_data (single
view; use a seed no training run used: training used 0-3, 5, 11-14, 21 and 23), how closely each predictor's level
follows the truth, per render, in log2 units (eval_quality.level_stats: correlation, R2 of the prediction as it
stands, RMSE against the constant's), and its albedo PSNR over the object (alpha >= 128) as measured and after the
best gain (eval_quality.gain_psnr: the level taken out).  And the metallic map, the object's pixels pooled over
all renders: how many of the metal pixels (truth > 0.5) each predictor calls metal (> 0.5), how many others it
calls metal, the PSNR, and the area under the ROC curve of the predicted metallic as a score of metal pixels
against the others -- pooled over all renders, and the mean over the renders that have both (does the map tell
which pixels of an object are metal, or only how metal the object is?); ties count a half, so a constant scores
0.5 and the truth 1 (rows: each --model, `constant 0`, `truth`).

Predictors: each --model (run by `supermat image --native --float`, its defaults and --image-args, as
supermat_tools.eval_quality runs it), `picture` (the input's RGB as albedo: baseline (a)) and `truth` (the true albedo:
a check of the measurement, correlation 1 and R2 1).  Renders whose object covers fewer than --min-pixels pixels
are left out.  --json writes the tables and each render's levels.
"""
import argparse
import glob
import json
import os
import sys
import tempfile

import numpy as np
from scipy.stats import rankdata

from supermat_tools import eval_quality as eq
from supermat_tools.common import SUPERMAT


def load(dirs, limit, min_pixels):
    """(stem, rgba uint8 HxWx4, true albedo float [0, 1] HxWx3, true metallic float [0, 1] HxW) for the
    single-view renders of each folder."""
    out = []
    for d in dirs:
        shards = sorted(glob.glob(os.path.join(d, "shard_*.npz")))
        if not shards:
            sys.exit(f"error: {d}: no shard_*.npz (a supermat_tools.gen_data folder)")
        for f in shards:
            z = np.load(f)
            if "rgba" not in z or "albedo" not in z or "metal" not in z or z["rgba"].ndim != 4:
                sys.exit(f"error: {f}: not a single-view gen_data.py shard (rgba N x H x W x 4, albedo N x H x W x 3, "
                         "metal N x H x W)")
            for i in range(len(z["rgba"])):
                if (z["rgba"][i][..., 3] >= 128).sum() < min_pixels:
                    continue
                stem = f"{os.path.basename(os.path.normpath(d))}_{os.path.basename(f)[:-4]}_{i:04d}"
                out.append((stem, z["rgba"][i], z["albedo"][i].astype(np.float32) / 255.0,
                            z["metal"][i].astype(np.float32) / 255.0))
                if limit and len(out) >= limit:
                    return out
    return out


def roc_auc(pos, neg):
    """Area under the ROC curve of scores pos (metal pixels) against neg (the others): the probability that a
    random metal pixel scores above a random other one, ties a half (the Mann-Whitney U over len(pos) len(neg),
    average ranks); nan where either is empty."""
    pos, neg = np.asarray(pos, np.float64).ravel(), np.asarray(neg, np.float64).ravel()
    if not len(pos) or not len(neg):
        return float("nan")
    ranks = rankdata(np.concatenate([pos, neg]))                   # 1-based, ties averaged
    u = ranks[:len(pos)].sum() - len(pos) * (len(pos) + 1) / 2.0
    return float(u / (len(pos) * len(neg)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="supermat_tools.gen_data folders, comma separated")
    ap.add_argument("--model", action="append", default=[], metavar="NAME=FILE", type=eq.model_option)
    ap.add_argument("--limit", type=int, default=0, help="at most this many renders (0: all)")
    ap.add_argument("--min-pixels", type=int, default=200)
    ap.add_argument("--supermat", default=SUPERMAT)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--image-args", default="", help="more arguments for `supermat image`")
    ap.add_argument("--work", default=None, help="where the pictures and maps go (default: a temporary folder)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()

    renders = load(args.data.split(","), args.limit, args.min_pixels)
    if len(renders) < 2:
        sys.exit(f"error: {len(renders)} render(s) with at least {args.min_pixels} object pixels: need two or more")
    work = args.work or tempfile.mkdtemp(prefix="eval_level_")
    os.makedirs(os.path.join(work, "inputs"), exist_ok=True)
    inputs = {}
    for stem, rgba, _, _ in renders:
        inputs[stem] = os.path.join(work, "inputs", stem + ".png")
        eq.write_png(inputs[stem], rgba)

    preds, metal = {}, {}
    for name, path in args.model:
        maps = eq.run_model(args.supermat, path, inputs, os.path.join(work, "pred_" + name), args.threads,
                            args.image_args.split())
        preds[name] = {s: m["albedo"] for s, m in maps.items()}
        metal[name] = {s: m["metallic"] for s, m in maps.items()}
    preds["picture"] = {stem: rgba[..., :3].astype(np.float32) / 255.0 for stem, rgba, _, _ in renders}
    preds["truth"] = {stem: alb for stem, _, alb, _ in renders}
    metal["constant 0"] = {stem: np.zeros(rgba.shape[:2], np.float32) for stem, rgba, _, _ in renders}
    metal["truth"] = {stem: m for stem, _, _, m in renders}

    rows = {p: [] for p in preds}
    mrows = {p: dict(metal=0, found=0, false=0, other=0, se=0.0, pixels=0) for p in metal}
    scores = {p: ([], [], []) for p in metal}   # metal pixels' scores, the others', per-render AUCs
    for stem, rgba, alb, tm in renders:
        mask = rgba[..., 3] >= 128
        for p in metal:
            pm, t = metal[p][stem][mask], tm[mask] > 0.5
            c = mrows[p]
            c["metal"] += int(t.sum()); c["found"] += int((t & (pm > 0.5)).sum())
            c["other"] += int((~t).sum()); c["false"] += int((~t & (pm > 0.5)).sum())
            c["se"] += float(((pm.astype(np.float64) - tm[mask]) ** 2).sum()); c["pixels"] += int(mask.sum())
            scores[p][0].append(pm[t]); scores[p][1].append(pm[~t])
            if t.any() and (~t).any():
                scores[p][2].append(roc_auc(pm[t], pm[~t]))
        true_level = eq.albedo_level(alb, mask)
        for p in preds:
            a = preds[p][stem]
            rows[p].append(dict(stem=stem, level=eq.albedo_level(a, mask), level_true=true_level,
                                albedo_psnr=eq.masked_psnr(a, alb, mask),
                                albedo_psnr_gain=eq.gain_psnr(a, alb, mask, False)))
    stats = {p: eq.level_stats([r["level"] for r in rows[p]], [r["level_true"] for r in rows[p]]) for p in preds}
    psnr = {p: dict(albedo_psnr=float(np.mean([r["albedo_psnr"] for r in rows[p]])),
                    albedo_psnr_gain=float(np.mean([r["albedo_psnr_gain"] for r in rows[p]]))) for p in preds}
    print(f"## albedo level on {len(renders)} renders of {args.data} (log2 of the mean linear luminance over the object)\n")
    print(eq.level_table(list(stats.items())))
    print("\n| predictor | albedo PSNR | after the best gain |\n|---|---|---|")
    for p in preds:
        print(f"| {p} | {psnr[p]['albedo_psnr']:.2f} | {psnr[p]['albedo_psnr_gain']:.2f} |")
    for p, c in mrows.items():
        c["auc"] = roc_auc(np.concatenate(scores[p][0]), np.concatenate(scores[p][1]))
        c["auc_within"] = float(np.mean(scores[p][2])) if scores[p][2] else float("nan")
        c["mixed_renders"] = len(scores[p][2])
        c["recall"] = c["found"] / c["metal"] if c["metal"] else float("nan")
        c["false_rate"] = c["false"] / c["other"] if c["other"] else float("nan")
        mse = c["se"] / max(c["pixels"], 1)
        c["psnr"] = 100.0 if mse <= 1e-10 else float(10 * np.log10(1 / mse))
    mixed = next(iter(mrows.values()))["mixed_renders"]
    print("\n| metallic, object pixels pooled | metal pixels (truth > 0.5) found (prediction > 0.5) | other pixels called "
          f"metal | PSNR | ROC AUC pooled | ROC AUC within a render (mean of {mixed}) |\n|---|---|---|---|---|---|")
    for p, c in mrows.items():
        print(f"| {p} | {c['found']} of {c['metal']} ({100 * c['recall']:.1f} %) | {c['false']} of {c['other']} "
              f"({100 * c['false_rate']:.1f} %) | {c['psnr']:.2f} | {c['auc']:.3f} | {c['auc_within']:.3f} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(data=args.data, renders=len(renders), models=dict(args.model), level=stats, psnr=psnr,
                           metallic=mrows, rows=rows), f, indent=1)


if __name__ == "__main__":
    main()
