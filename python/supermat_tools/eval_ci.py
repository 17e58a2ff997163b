#!/usr/bin/env python3
"""How sure is a difference in material quality?  Paired differences and their intervals over the assets, from
the JSON of supermat_tools.eval_quality (or of supermat_tools.eval_bake: one bake per asset, its relighting PSNR in the
re-render column).

usage: eval_ci.py RESULT.json [MORE.json ...] --ref PRED [--pred PRED ...] [--level L] [--json OUT]

PRED is a predictor name (`input_as_albedo`, a `--model` name: its views in all the files together, so runs on
different assets add up), or FILE:NAME for that file's views alone (two models evaluated in separate runs on the
same assets, views and lightings: eval_quality.py renders them deterministically from --seed).  Each --pred
(default: every predictor of the files but the reference) is paired with --ref view by view (asset, view number,
input lighting); a view missing on either side, or measured twice under one name, is an error.

For each metric (albedo, roughness, metallic and re-render PSNR, albedo SSIM) it prints the mean difference
PRED - REF (the mean over the assets of each asset's mean over its views: eval_quality.py's overall difference
when every asset has as many views) and its two-sided Student-t interval at --level (default 0.95) over the
per-asset means (k assets, k - 1 degrees of freedom).  The asset is the unit: views of one asset share its mesh
and material, so they are not independent samples, and the interval says how far the figure could move on k
other assets like these (with five, about 1.2 times their spread either way).  Also how many assets the
difference favours and the per-asset extremes.  ctest `eval_ci` checks the pairing and the interval's coverage
on synthetic data.
"""
import argparse
import json
import sys

import numpy as np
from scipy.stats import t as student_t

from supermat_tools.common import write_json

METRICS = ("albedo_psnr", "albedo_ssim", "roughness_psnr", "metallic_psnr", "rerender_psnr")


BAKE_NAMES = {"rough_psnr": "roughness_psnr", "metal_psnr": "metallic_psnr", "relight_psnr": "rerender_psnr"}


def load_rows(j):
    """The per-view rows of an eval_quality.py JSON ('views'), or an eval_bake.py JSON's per-asset rows ('rows':
    one bake per asset, its relighting PSNR as the re-render's) in the same form; None for anything else."""
    if "views" in j:
        return j["views"]
    if "rows" in j:
        return [dict({BAKE_NAMES.get(k, k): v for k, v in r.items()}, view=0, env_in="") for r in j["rows"]]
    return None


def view_key(r):
    return (r["asset"], int(r["view"]), r.get("env_in", ""))


def paired(rows_a, name_a, rows_b, name_b, metric):
    """{asset: [diff per view]} of a - b, paired by view; raises ValueError on a view missing from one side or
    measured twice for one predictor."""
    def views(rows, name):
        d = {}
        for r in rows:
            if r["predictor"] == name:
                k = view_key(r)
                if k in d:
                    raise ValueError(f"view {k} of {name} appears twice: name the file (FILE:NAME)")
                d[k] = r[metric]
        if not d:
            raise ValueError(f"no views of predictor {name}")
        return d
    a, b = views(rows_a, name_a), views(rows_b, name_b)
    if a.keys() != b.keys():
        miss = sorted(set(a) ^ set(b))[:3]
        raise ValueError(f"{name_a} and {name_b} are not measured on the same views (e.g. {miss})")
    out = {}
    for k in sorted(a):
        out.setdefault(k[0], []).append(float(a[k]) - float(b[k]))
    return out


def interval(diffs, level=0.95):
    """diffs: {asset: [per-view differences]}.  The mean of the per-asset means and its Student-t interval over
    them (k - 1 degrees of freedom; None with one asset).  Returns dict(mean, lo, hi, assets, favour (assets whose
    mean is > 0), worst, best (per-asset means))."""
    assets = sorted(diffs)
    means = np.array([np.mean(np.asarray(diffs[a], np.float64)) for a in assets])
    k = len(means)
    mean = float(means.mean())
    lo = hi = None
    if k > 1:
        half = float(student_t.ppf(0.5 + level / 2.0, k - 1) * means.std(ddof=1) / np.sqrt(k))
        lo, hi = mean - half, mean + half
    return dict(mean=mean, lo=lo, hi=hi, assets=k, favour=int((means > 0).sum()),
                worst=(assets[int(means.argmin())], float(means.min())),
                best=(assets[int(means.argmax())], float(means.max())))


def resolve(spec, files):
    """PRED (its views in every file, merged) or FILE:NAME (that file's) -> (rows, name)."""
    if ":" in spec and spec.rsplit(":", 1)[0] in files:
        path, name = spec.rsplit(":", 1)
        return files[path]["views"], name
    return [r for f in files.values() for r in f["views"]], spec


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results", nargs="+", help="supermat_tools.eval_quality or eval_bake.py --json files")
    ap.add_argument("--ref", required=True, help="the reference predictor (e.g. input_as_albedo)")
    ap.add_argument("--pred", action="append", default=[], help="a predictor to compare (repeatable)")
    ap.add_argument("--level", type=float, default=0.95)
    ap.add_argument("--json", help="also write the intervals here")
    args = ap.parse_args()
    if not 0.0 < args.level < 1.0:
        ap.error("--level must lie in (0, 1)")
    files = {}
    for p in args.results:
        try:
            with open(p) as f:
                rows = load_rows(json.load(f))
        except (OSError, ValueError) as e:
            sys.exit(f"error: {p}: {e}")
        if not isinstance(rows, list):
            sys.exit(f"error: {p}: not a supermat_tools.eval_quality or eval_bake.py --json file (no 'views' or 'rows')")
        files[p] = {"views": rows}
    preds = args.pred or [p for p in dict.fromkeys(r["predictor"] for f in files.values() for r in f["views"])
                          if p != args.ref]
    ref_rows, ref_name = resolve(args.ref, files)
    pct = f"{100 * args.level:g} %"
    print(f"## difference to {args.ref}: mean over the assets' means, {pct} Student-t interval over them\n")
    print("| predictor | " + " | ".join(METRICS) + " | per-asset range (albedo PSNR) |")
    print("|---|" + "---|" * (len(METRICS) + 1))
    out = {}
    for spec in preds:
        rows, name = resolve(spec, files)
        res = {}
        for m in METRICS:
            try:
                res[m] = interval(paired(rows, name, ref_rows, ref_name, m), args.level)
            except ValueError as e:
                sys.exit(f"error: {e}")
            except KeyError:
                continue   # a metric this file does not have
        out[spec] = res

        def cell(r, m):
            d = 3 if m.endswith("ssim") else 2
            return (f"{r['mean']:+.{d}f}" + (f" [{r['lo']:+.{d}f}, {r['hi']:+.{d}f}]" if r["lo"] is not None else "")
                    + f" ({r['favour']}/{r['assets']})")
        a = res["albedo_psnr"]
        print(f"| {spec} | " + " | ".join(cell(res[m], m) if m in res else "-" for m in METRICS)
              + f" | {a['worst'][0]} {a['worst'][1]:+.2f} .. {a['best'][0]} {a['best'][1]:+.2f} |")
    print("\n(n/k: the difference favours the predictor on n of the k assets)")
    if args.json:   # whole or not at all
        try:
            write_json(args.json, dict(ref=args.ref, level=args.level, intervals=out))
        except OSError as e:
            sys.exit(f"error: {args.json}: {e}")


if __name__ == "__main__":
    main()
