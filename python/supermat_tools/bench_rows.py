"""The rows of `supermat bench --image ... --json FILE` results and their markdown table (bench/bench_table.py
prints it; eval_quality.py --levers uses it): load, aggregate, markdown."""
import json
import sys

MAPS = ("albedo", "roughness", "metallic", "refined")


def load(paths):
    """The rows (lists of dicts) of each JSON file, with a clear message on a bad file."""
    files = []
    for p in paths:
        try:
            with open(p) as f:
                rows = json.load(f)
        except (OSError, ValueError) as e:
            sys.exit(f"bench_table: cannot read {p}: {e}")
        if not isinstance(rows, list) or not all(isinstance(r, dict) and "mode" in r for r in rows):
            sys.exit(f"bench_table: {p} is not a `supermat bench --image --json` list of rows")
        files.append(rows)
    return files


def _mean(vals):
    vals = [v for v in vals if v is not None]
    return sum(vals) / len(vals) if vals else None


def _fraction(r, peak):
    p = peak or r.get("fma_peak_gflops")
    return r["flops"] / 1e9 / r["seconds"] / p if p and r.get("seconds") else None


def aggregate(files, peak=None):
    """One row per mode (in the order modes first appear): the mean over the files that have it, with
    n = that count, frac = the fraction of the FMA peak (None without one), and per map psnr / gt_psnr
    means, max_abs the largest."""
    modes = list(dict.fromkeys(r["mode"] for rows in files for r in rows))
    out = []
    for mode in modes:
        sel = [r for rows in files for r in rows if r["mode"] == mode]
        row = dict(mode=mode, n=len(sel), seconds=_mean([r["seconds"] for r in sel]),
                   speedup=_mean([r["speedup"] for r in sel]), peak_bytes=_mean([r["peak_bytes"] for r in sel]),
                   flops=_mean([r["flops"] for r in sel]), frac=_mean([_fraction(r, peak) for r in sel]),
                   psnr={}, max_abs={}, gt_psnr={})
        for m in MAPS:
            if any(m in r.get("psnr", {}) for r in sel):
                row["psnr"][m] = _mean([r["psnr"].get(m) for r in sel])
                abs_vals = [r["max_abs"].get(m) for r in sel if r["max_abs"].get(m) is not None]
                row["max_abs"][m] = max(abs_vals) if abs_vals else None
            gt = [r.get("gt_psnr", {}).get(m) for r in sel]
            if any(v is not None for v in gt):
                row["gt_psnr"][m] = _mean(gt)
        out.append(row)
    return out


def markdown(files, peak=None):
    """The markdown table (a string) of one or several files' rows."""
    rows = aggregate(files, peak)
    several = len(files) > 1
    show_peak = any(r["frac"] is not None for r in rows)
    maps = [m for m in MAPS if any(m in r["psnr"] for r in rows)]
    gt_maps = [m for m in maps if any(r["gt_psnr"].get(m) is not None for r in rows)]
    partial = several and any(r["n"] != len(files) for r in rows)
    head = ["mode"] + (["n"] if partial else []) + ["s", "speed-up", "peak MiB", "GFLOP"] + \
           (["% of peak"] if show_peak else []) + \
           [f"{m} PSNR dB / max abs" for m in maps] + [f"{m} PSNR vs truth dB" for m in gt_maps]
    lines = []
    if several:
        lines += [f"mean over {len(files)} files per mode" +
                  (" (n: the files that have the mode)" if partial else "") +
                  "; speed-up: the mean of each file's; max abs: the largest; PSNR: the mean in dB over the files "
                  "where the map has one", ""]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    for r in rows:
        cells = [r["mode"]] + ([str(r["n"])] if partial else []) + \
                [f"{r['seconds']:.3g}", f"{r['speedup']:.2f}×", f"{r['peak_bytes'] / 2**20:.0f}",
                 f"{r['flops'] / 1e9:.1f}"]
        if show_peak:
            cells.append("–" if r["frac"] is None else f"{100 * r['frac']:.0f} %")
        for m in maps:
            p, a = r["psnr"].get(m), r["max_abs"].get(m)
            cells.append("–" if p is None or a is None else f"{p:.1f} / {a:.1e}")
        for m in gt_maps:
            g = r["gt_psnr"].get(m)
            cells.append("–" if g is None else f"{g:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)

