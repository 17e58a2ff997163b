#!/usr/bin/env python3
"""ctest eval_ci: supermat_tools.eval_ci (paired differences of supermat_tools.eval_quality results, Student-t intervals over
the assets).  Checks, on synthetic eval_quality.py JSON:
  - the pairing: views matched by (asset, view, lighting) whatever their order; a view missing on one side, or
    twice under one name, is an error (exit status 1 from the command line);
  - a difference that is the same constant on every view: that mean, an interval of width 0;
  - mean and interval against scipy's one-sample t-test interval over the per-asset means (another code path),
    and swapping the two predictors negates both;
  - coverage: on 2000 synthetic evaluations of 5 assets (asset effects N(1, 1), view noise N(0, 1)) the 95 %
    interval holds the true effect 93-97 % of the time (an interval over views instead of assets, or a
    percentile bootstrap over 5 means, falls far below);
  - the command line: FILE:NAME against another file, --json written, the table printed; an eval_bake.py JSON.
usage: test_eval_ci.py WORKDIR
"""
import json
import os
import subprocess
import sys

import numpy as np
from scipy import stats

from supermat_tools import eval_ci

FAILS = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        FAILS.append(what)


def rows_for(name, values, envs=("e0",)):
    """values[asset][view] (one lighting per view index) -> eval_quality.py view rows."""
    out = []
    for a, vs in values.items():
        for i, v in enumerate(vs):
            out.append(dict(asset=a, view=i // len(envs), env_in=envs[i % len(envs)], predictor=name,
                            albedo_psnr=v, albedo_ssim=v / 100, roughness_psnr=v, metallic_psnr=v,
                            rerender_psnr=v))
    return out


def main():
    work = sys.argv[1]
    os.makedirs(work, exist_ok=True)
    rng = np.random.default_rng(7)

    # a constant difference
    base = {f"a{k}": list(rng.normal(12, 2, 6)) for k in range(4)}
    plus = {a: [v + 1.25 for v in vs] for a, vs in base.items()}
    rows = rows_for("ref", base, ("e0", "e1")) + rows_for("m", plus, ("e0", "e1"))
    r = eval_ci.interval(eval_ci.paired(rows, "m", rows, "ref", "albedo_psnr"))
    check(abs(r["mean"] - 1.25) < 1e-12 and abs(r["lo"] - 1.25) < 1e-9 and abs(r["hi"] - 1.25) < 1e-9
          and r["favour"] == 4 and r["assets"] == 4, f"constant +1.25: {r['mean']} [{r['lo']}, {r['hi']}]")

    # against scipy's t-test interval over the asset means; order of rows; swapped predictors
    eff = {f"a{k}": rng.normal(0.5, 1.0) for k in range(7)}
    base7 = {f"a{k}": list(rng.normal(12, 2, 5)) for k in range(7)}
    pred7 = {a: [v + eff[a] + rng.normal(0, 0.7) for v in vs] for a, vs in base7.items()}
    rows = rows_for("ref", base7) + rows_for("m", pred7)
    r = eval_ci.interval(eval_ci.paired(rows, "m", rows, "ref", "albedo_psnr"), 0.9)
    means = [np.mean(np.subtract(pred7[a], base7[a])) for a in sorted(base7)]
    ci = stats.ttest_1samp(means, 0.0).confidence_interval(0.9)
    check(abs(r["mean"] - np.mean(means)) < 1e-12 and abs(r["lo"] - ci.low) < 1e-9 and abs(r["hi"] - ci.high) < 1e-9,
          f"t interval {r['lo']:.6f} {r['hi']:.6f} against scipy's {ci.low:.6f} {ci.high:.6f}")
    shuffled = [rows[i] for i in rng.permutation(len(rows))]
    r2 = eval_ci.interval(eval_ci.paired(shuffled, "m", shuffled, "ref", "albedo_psnr"), 0.9)
    check(r2 == r, "rows in another order: the same result")
    rs = eval_ci.interval(eval_ci.paired(rows, "ref", rows, "m", "albedo_psnr"), 0.9)
    check(abs(rs["mean"] + r["mean"]) < 1e-12 and abs(rs["lo"] + r["hi"]) < 1e-9 and abs(rs["hi"] + r["lo"]) < 1e-9,
          "swapped predictors: negated")
    one = eval_ci.interval({"a0": [1.0, 2.0, 3.0]})
    check(one["lo"] is None and one["hi"] is None and one["mean"] == 2.0, "one asset: a mean, no interval")
    for what, bad in (("a view missing", rows[:-1]), ("a view twice", rows + rows[-1:])):
        try:
            eval_ci.paired(bad, "m", bad, "ref", "albedo_psnr")
            check(False, f"{what}: an error")
        except ValueError as e:
            check(True, f"{what}: an error ({e})")

    # coverage of the 95 % interval, 5 assets x 8 views
    trials, hits = 2000, 0
    covered_view = 0
    for t in range(trials):
        eff = rng.normal(1.0, 1.0, 5)
        d = {f"a{k}": list(eff[k] + rng.normal(0, 1.0, 8)) for k in range(5)}
        r = eval_ci.interval(d)
        hits += r["lo"] <= 1.0 <= r["hi"]
        allv = np.concatenate([d[a] for a in d])   # the naive interval over the 40 views, for contrast
        half = stats.t.ppf(0.975, len(allv) - 1) * allv.std(ddof=1) / np.sqrt(len(allv))
        covered_view += (allv.mean() - half <= 1.0 <= allv.mean() + half)
    cov, cov_v = hits / trials, covered_view / trials
    check(0.93 <= cov <= 0.97, f"coverage of the 95 % interval over assets: {cov:.3f} (over views: {cov_v:.3f})")
    check(cov_v < 0.85, f"the interval over views would not cover: {cov_v:.3f}")

    # the command line
    fa, fb, fo = (os.path.join(work, n) for n in ("a.json", "b.json", "ci.json"))
    with open(fa, "w") as f:
        json.dump(dict(views=rows_for("ref", base7) + rows_for("input_as_albedo", base7)), f)
    with open(fb, "w") as f:
        json.dump(dict(views=rows_for("m", pred7)), f)
    tool = ["-m", "supermat_tools.eval_ci"]
    p = subprocess.run([sys.executable, *tool, fa, fb, "--ref", f"{fa}:ref", "--pred", f"{fb}:m", "--level", "0.9",
                        "--json", fo], capture_output=True, text=True)
    ok = p.returncode == 0 and os.path.isfile(fo)
    if ok:
        with open(fo) as f:
            j = json.load(f)["intervals"][f"{fb}:m"]["albedo_psnr"]
        ok = abs(j["lo"] - ci.low) < 1e-9 and abs(j["hi"] - ci.high) < 1e-9 and "| " + fb + ":m |" in p.stdout
    check(ok, f"command line, FILE:NAME across files (rc {p.returncode}) {p.stderr.strip()}")
    with open(fb, "w") as f:
        json.dump(dict(views=rows_for("m", pred7)[:-1]), f)
    p = subprocess.run([sys.executable, *tool, fa, fb, "--ref", "ref", "--pred", "m"], capture_output=True, text=True)
    check(p.returncode == 1 and "not measured on the same views" in p.stderr,
          f"command line, a view missing: exit {p.returncode}, {p.stderr.strip()}")
    # an eval_bake.py JSON: one row per asset, rough_psnr / metal_psnr / relight_psnr
    bake = [dict(asset=a, predictor=n, albedo_psnr=v, albedo_ssim=0.5, rough_psnr=v + 1, metal_psnr=v + 2,
                 relight_psnr=v + d) for a, v in zip("pqrs", (10.0, 12.0, 9.0, 15.0))
            for n, d in (("lit", 0.0), ("mv", 0.5))]
    fk = os.path.join(work, "bake.json")
    with open(fk, "w") as f:
        json.dump(dict(config={}, overall={}, rows=bake), f)
    p = subprocess.run([sys.executable, *tool, fk, "--ref", "lit", "--json", fo], capture_output=True, text=True)
    ok = p.returncode == 0
    if ok:
        with open(fo) as f:
            j = json.load(f)["intervals"]["mv"]
        ok = (abs(j["rerender_psnr"]["mean"] - 0.5) < 1e-12 and j["rerender_psnr"]["lo"] == j["rerender_psnr"]["hi"]
              and j["albedo_psnr"]["mean"] == 0.0 and j["roughness_psnr"]["assets"] == 4)
    check(ok, f"an eval_bake.py JSON: relighting as the re-render column (rc {p.returncode}) {p.stderr.strip()}")
    p = subprocess.run([sys.executable, *tool, fa, "--ref", "nobody"], capture_output=True, text=True)
    check(p.returncode == 1 and "no views of predictor nobody" in p.stderr, "command line, an unknown reference")

    if FAILS:
        print(f"{len(FAILS)} check(s) failed")
        sys.exit(1)
    print("all checks passed")


if __name__ == "__main__":
    main()
