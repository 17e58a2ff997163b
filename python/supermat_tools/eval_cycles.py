#!/usr/bin/env python3
"""Material quality on pictures from an independent renderer (supermat_tools.cycles_render's Cycles set).

For every input picture of the chosen part of the set (all views, all looks: the exposures and tone curves),
each predictor gives albedo, roughness and metallic maps; each map is compared with the truth over the
object's pixels (the picture's alpha >= 0.5):

  model NAME=FILE   `supermat image --model FILE` with its defaults, as a user runs it (--float: the maps
                    before 8-bit quantisation), plus --image-args;
  picture           the picture's own RGB as albedo (the obvious albedo: what a user has without any tool);
  constant          every map at the dataset means: the means of the validation part's truth (fitted there,
                    so the held-out part never sets its own baseline), or with --dataset-stats the training
                    generator's (eval_quality's baselines (a) and (b));
  metal0            metallic 0 everywhere (the other obvious metallic: most objects have no metal);
  oracle_constant   every map at the evaluated part's own truth means: the best any constant can score there
                    (not something a user has; the strictest constant to beat).

Scores, for each map: PSNR (dB) of the mean squared error pooled over every object pixel of the part (each
pixel of each view and look weighs alike: a view whose truth is constant cannot send a per-view PSNR to
infinity), the same per asset, and the mean over assets of the per-asset PSNR (capped at 100 dB).  The
headline columns are the pooled PSNR; the margins printed are the model minus the picture (albedo) and minus
the best of the constants (roughness: constant, oracle_constant; metallic: those and metal0).

Parts (by asset; assets of sbtron/glTF-Sample-Models, evaluation only, never training data):
  validation  what choices are made on;   heldout  looked at once per change;   all
--assets overrides the part's list.

  PYTHONPATH=python /usr/bin/python3 -m supermat_tools.eval_cycles --set SET --part validation \\
      --model default=models/supermat_default.safetensors [--json out.json] [--work DIR]

Needs python3-numpy and -pil and the built `supermat` (--supermat, default build/supermat).
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np
from PIL import Image

from supermat_tools.common import SUPERMAT, read_pfm

MAPS = ("albedo", "roughness", "metallic")
PARTS = {
    # the split of scripts/eval_default.sh (the project renderer's sets): validation = its validation and other
    # assets, held-out = its held-out ones (BoomBox's textures are incomplete in the mirror), so no asset that a
    # choice is fitted on is in the held-out set of either renderer.  The validation assets have no metal and
    # roughness 1 (the glTF default: no roughness texture or factor); the held-out ones are textured.
    "validation": ("Monster", "CesiumMan", "CesiumMilkTruck", "Duck", "2CylinderEngine", "ReciprocatingSaw"),
    "heldout": ("Avocado", "WaterBottle", "Suzanne", "DamagedHelmet"),
}


def read8(path):
    return np.asarray(Image.open(path), np.float32) / 255.0


def load_set(set_dir, assets, looks):
    """[(stem, asset, input path, truth dict, mask)] for every view and look of the assets."""
    index = json.load(open(os.path.join(set_dir, "index.json")))
    items = []
    for asset in assets:
        if asset not in index["assets"]:
            sys.exit(f"eval_cycles: {asset} is not in {set_dir} (has {', '.join(index['assets'])})")
        for v in range(index["views"]):
            truth = {m: read8(os.path.join(set_dir, "truth", f"{asset}_{v}_{m}.png")) for m in MAPS}
            truth["albedo"] = truth["albedo"][..., :3]
            for look in looks or index["looks"]:
                path = os.path.join(set_dir, "inputs", f"{asset}_{v}_{look}.png")
                rgba = np.asarray(Image.open(path).convert("RGBA"), np.float32) / 255.0
                items.append(dict(stem=f"{asset}_{v}_{look}", asset=asset, path=path, truth=truth,
                                  mask=rgba[..., 3] >= 0.5, rgb=rgba[..., :3]))
    return items


def truth_means(items):
    """The dataset means of the truth over the object pixels (albedo as stored: sRGB)."""
    seen, acc = set(), {m: [] for m in MAPS}
    for it in items:
        key = it["stem"].rsplit("_", 1)[0]          # one truth a view, whatever the look
        if key in seen:
            continue
        seen.add(key)
        for m in MAPS:
            acc[m].append(it["truth"][m][it["mask"]])
    return {m: np.concatenate(acc[m]).reshape(-1, *(3,) if m == "albedo" else ()).mean(0).tolist() for m in MAPS}


def run_model(supermat, model, items, out_dir, threads, extra):
    os.makedirs(out_dir, exist_ok=True)
    todo = [it for it in items if not all(os.path.exists(os.path.join(out_dir, f"{it['stem']}_{m}.pfm"))
                                          for m in MAPS)]
    for i in range(0, len(todo), 64):
        cmd = [supermat, "image", "--force", "--model", model, "--out", out_dir, "--float", "--threads",
               str(threads)] + list(extra) + [it["path"] for it in todo[i:i + 64]]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    preds = {}
    for it in items:
        p = {m: np.clip(read_pfm(os.path.join(out_dir, f"{it['stem']}_{m}.pfm")), 0.0, 1.0) for m in MAPS}
        preds[it["stem"]] = p
    return preds


def psnr(se, n):
    if n == 0:
        return float("nan")
    return min(100.0, 10.0 * np.log10(1.0 / max(se / n, 1e-10)))


def score(items, predict):
    """Pooled and per-asset PSNR of each map; predict(item) -> {map: array}."""
    tot = {m: [0.0, 0] for m in MAPS}
    per = {}
    for it in items:
        pred = predict(it)
        mk = it["mask"]
        a = per.setdefault(it["asset"], {m: [0.0, 0] for m in MAPS})
        for m in MAPS:
            d = (np.asarray(pred[m], np.float64) - it["truth"][m])[mk]
            se = float(np.sum(d * d)) / (3 if m == "albedo" else 1)
            for acc in (tot[m], a[m]):
                acc[0] += se
                acc[1] += int(mk.sum())
    out = {m: psnr(*tot[m]) for m in MAPS}
    out["assets"] = {k: {m: psnr(*v[m]) for m in MAPS} for k, v in per.items()}
    for m in MAPS:
        out[m + "_asset_mean"] = float(np.mean([out["assets"][k][m] for k in out["assets"]]))
    return out


def reliability(items, pred_of, name, bins=10):
    """The metallic map's reliability curve (per bin of predicted metallic: pixels, mean prediction, mean truth)
    and roughness's: how far the prediction can be taken at its word."""
    rows = {}
    for m in ("metallic", "roughness"):
        cnt, sp, st = np.zeros(bins), np.zeros(bins), np.zeros(bins)
        for it in items:
            p = np.asarray(pred_of(it)[m])[it["mask"]]
            t = it["truth"][m][it["mask"]]
            b = np.minimum((p * bins).astype(int), bins - 1)
            cnt += np.bincount(b, minlength=bins)
            sp += np.bincount(b, p, minlength=bins)
            st += np.bincount(b, t, minlength=bins)
        rows[m] = [(i / bins, int(c), float(a / c) if c else float("nan"), float(t / c) if c else float("nan"))
                   for i, (c, a, t) in enumerate(zip(cnt, sp, st))]
    print(f"\nreliability of {name} (bin lower edge: pixels, mean prediction, mean truth):")
    for m, r in rows.items():
        print(f"  {m}: " + "; ".join(f"{lo:.1f}: {c} {a:.3f}/{t:.3f}" for lo, c, a, t in r if c))
    return rows


def fit_curve(items, pred_of, m, knots=9):
    """The monotone (non-decreasing) piecewise-linear curve, values in [0, 1] at `knots` evenly spaced
    predictions, that maps the predicted map to the truth with the least squared error over the items' object
    pixels: exact least squares on the hat basis with the curve written as a start value and non-negative
    steps (scipy's bounded least squares on the normal equations' Cholesky factor)."""
    from scipy.optimize import lsq_linear
    k = knots - 1
    ata, atb = np.zeros((knots, knots)), np.zeros(knots)
    for it in items:
        p = np.clip(np.asarray(pred_of(it)[m], np.float64)[it["mask"]], 0, 1) * k
        t = it["truth"][m][it["mask"]].astype(np.float64)
        i0 = np.minimum(p.astype(int), k - 1)
        f = p - i0
        for a, wa in ((i0, 1 - f), (i0 + 1, f)):
            np.add.at(atb, a, wa * t)
            for b, wb in ((i0, 1 - f), (i0 + 1, f)):
                np.add.at(ata, (a, b), wa * wb)
    c = np.tril(np.ones((knots, knots)))           # values = c @ steps: steps[0] the start, the rest >= 0
    g = c.T @ ata @ c + 1e-9 * np.eye(knots)
    r = np.linalg.cholesky(g).T                     # |r s - r^-T c^T atb|^2 = the squared error up to a constant
    rhs = np.linalg.solve(r.T, c.T @ atb)
    lo = np.r_[0.0, np.zeros(k)]
    hi = np.r_[1.0, np.ones(k)]
    steps = lsq_linear(r, rhs, bounds=(lo, hi), method="bvls").x
    return np.clip(c @ steps, 0, 1).tolist()


def apply_curve(x, curve):
    k = len(curve) - 1
    return np.interp(np.clip(x, 0, 1), np.linspace(0, 1, k + 1), curve).astype(np.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", required=True, help="the folder cycles_render wrote")
    ap.add_argument("--part", default="validation", choices=("validation", "heldout", "all"))
    ap.add_argument("--assets", default="", help="comma list instead of the part's")
    ap.add_argument("--looks", default="", help="comma list of looks (default: all the set has)")
    ap.add_argument("--model", action="append", default=[], help="NAME=FILE (repeatable)")
    ap.add_argument("--image-args", default="", help="extra arguments for supermat image")
    ap.add_argument("--supermat", default=SUPERMAT)
    ap.add_argument("--work", default="", help="where the maps go (default: SET/maps)")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--json", default="")
    ap.add_argument("--dataset-stats", default="", help="the constants at these means instead (the generator's "
                    "stats.json, as eval_quality's baselines: albedo_srgb_mean, rough_mean, metal_mean)")
    ap.add_argument("--reliability", action="store_true", help="print each model's reliability curves")
    ap.add_argument("--fit", default="", help="fit a monotone curve for roughness and metallic of each model on "
                    "the validation part and write them to this JSON file")
    ap.add_argument("--fit-set", default="", help="fit on every asset of this set instead of the validation part")
    ap.add_argument("--curves", default="", help="also score each model with the curves of this JSON file "
                    "(--fit's), as NAME+curves")
    ap.add_argument("--curve-maps", default="roughness,metallic", help="the maps --curves puts through their curve "
                    "(default both)")
    args = ap.parse_args()

    parts = PARTS if args.part != "all" else {"all": PARTS["validation"] + PARTS["heldout"]}
    assets = [a for a in args.assets.split(",") if a] or list(parts.get(args.part, parts.get("all")))
    looks = [x for x in args.looks.split(",") if x]
    items = load_set(args.set, assets, looks)
    if args.dataset_stats:                      # the generator's statistics instead (eval_quality's baselines)
        with open(args.dataset_stats) as f:
            st = json.load(f)
        means = {"albedo": st["albedo_srgb_mean"], "roughness": st["rough_mean"], "metallic": st["metal_mean"]}
    else:                                       # the validation part's truth (a set rendered without it: give stats)
        means = truth_means(load_set(args.set, PARTS["validation"], looks))
    preds = {}
    for spec in args.model:
        name, _, path = spec.partition("=")
        out = os.path.join(args.work or os.path.join(args.set, "maps"), name)
        p = run_model(args.supermat, path, items, out, args.threads, args.image_args.split())
        preds[name] = lambda it, p=p: p[it["stem"]]
        if args.fit:
            if args.fit_set:                    # every asset of another set (cycles_procedural's, say)
                fa = json.load(open(os.path.join(args.fit_set, "index.json")))["assets"]
                val = load_set(args.fit_set, fa, looks)
                fout = os.path.join(args.fit_set, "maps", name)
            else:
                val, fout = load_set(args.set, PARTS["validation"], looks), out
            pv = run_model(args.supermat, path, val, fout, args.threads, args.image_args.split())
            curves = {m: fit_curve(val, lambda it: pv[it["stem"]], m) for m in ("roughness", "metallic")}
            fits = json.load(open(args.fit)) if os.path.exists(args.fit) else {}
            fits[name] = curves
            with open(args.fit, "w") as f:
                json.dump(fits, f, indent=1)
            print(f"{name}: curves fitted on the validation part: " +
                  "; ".join(f"{m} " + " ".join(f"{v:.3f}" for v in c) for m, c in curves.items()))
            print(f"{name}: to record the curves in the model file (on top of any it records): supermat convert "
                  f"--from {path} --roughness-curve {','.join(f'{v:.3f}' for v in curves['roughness'])} "
                  f"--metallic-curve {','.join(f'{v:.3f}' for v in curves['metallic'])} --out NEW.safetensors")
        if args.curves:
            c = json.load(open(args.curves))[name]
            cm = [m for m in args.curve_maps.split(",") if m]
            if not set(cm) <= {"roughness", "metallic"}:
                ap.error(f"--curve-maps {args.curve_maps}: roughness, metallic or both")
            preds[name + "+curves"] = lambda it, p=p, c=c, cm=cm: dict(
                p[it["stem"]], **{m: apply_curve(p[it["stem"]][m], c[m]) for m in cm})
    h, w = items[0]["mask"].shape

    def const(it, metal):
        return {"albedo": np.broadcast_to(np.float32(means["albedo"]), (h, w, 3)),
                "roughness": np.full((h, w), means["roughness"], np.float32),
                "metallic": np.full((h, w), metal, np.float32)}
    preds["picture"] = lambda it: dict(const(it, means["metallic"]), albedo=it["rgb"])
    preds["constant"] = lambda it: const(it, means["metallic"])
    preds["metal0"] = lambda it: const(it, 0.0)
    own = truth_means(items)                   # the best any constant can do here: the part's own truth means
    preds["oracle_constant"] = lambda it: {"albedo": np.broadcast_to(np.float32(own["albedo"]), (h, w, 3)),
                                           "roughness": np.full((h, w), own["roughness"], np.float32),
                                           "metallic": np.full((h, w), own["metallic"], np.float32)}
    res = {name: score(items, f) for name, f in preds.items()}
    if args.reliability:
        for spec in args.model:
            name = spec.partition("=")[0]
            reliability(items, preds[name], name)

    print(f"# {args.part if not args.assets else 'assets ' + args.assets}: {len(assets)} assets, {len(items)} pictures; dataset means "
          f"({'--dataset-stats' if args.dataset_stats else 'validation truth'}): "
          f"roughness {means['roughness']:.3f}, metallic {means['metallic']:.3f}")
    print("| predictor | albedo | roughness | metallic | albedo (asset mean) | roughness (asset mean) | "
          "metallic (asset mean) |")
    print("|---|---|---|---|---|---|---|")
    for name, r in res.items():
        print(f"| {name} | " + " | ".join(f"{r[m]:.2f}" for m in MAPS) + " | " +
              " | ".join(f"{r[m + '_asset_mean']:.2f}" for m in MAPS) + " |")
    best_r = max(res["constant"]["roughness"], res["oracle_constant"]["roughness"])
    best_m = max(res["constant"]["metallic"], res["metal0"]["metallic"], res["oracle_constant"]["metallic"])
    margins = {}
    for name in [n for n in res if n not in ("picture", "constant", "metal0", "oracle_constant")]:
        r = res[name]
        margins[name] = {"albedo": r["albedo"] - res["picture"]["albedo"], "roughness": r["roughness"] - best_r,
                         "metallic": r["metallic"] - best_m}
        print(f"{name}: albedo {margins[name]['albedo']:+.2f} dB over the picture, roughness "
              f"{margins[name]['roughness']:+.2f} and metallic {margins[name]['metallic']:+.2f} over the best "
              f"constant")
    print("\nper asset (pooled PSNR albedo / roughness / metallic):")
    for a in assets:
        print(f"  {a}: " + "; ".join(f"{n} " + "/".join(f"{res[n]['assets'][a][m]:.1f}" for m in MAPS)
                                      for n in res))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"part": args.part, "assets": assets, "pictures": len(items), "means": means,
                       "results": res, "margins": margins}, f, indent=1)


if __name__ == "__main__":
    main()
