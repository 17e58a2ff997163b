#!/usr/bin/env python3
"""Markdown table of a `supermat bench --image ... --json FILE` result (the README's tables).
usage: python3 tools/bench_table.py FILE.json [PEAK_GFLOPS]"""
import json
import sys


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    rows = json.load(open(sys.argv[1]))
    peak = float(sys.argv[2]) if len(sys.argv) > 2 else rows[0].get("fma_peak_gflops") if rows else None
    maps = [m for m in ("albedo", "roughness", "metallic", "refined") if any(m in r["psnr"] for r in rows)]
    head = ["mode", "s", "speed-up", "peak MiB", "GFLOP"] + (["% of peak"] if peak else []) + \
           [f"{m} PSNR dB / max abs" for m in maps]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        cells = [r["mode"], f"{r['seconds']:.3g}", f"{r['speedup']:.2f}×", f"{r['peak_bytes'] / 2**20:.0f}",
                 f"{r['flops'] / 1e9:.1f}"]
        if peak:
            cells.append(f"{100 * r['flops'] / 1e9 / r['seconds'] / peak:.0f} %")
        for m in maps:
            p, a = r["psnr"].get(m), r["max_abs"].get(m)
            cells.append("–" if p is None else f"{p:.1f} / {a:.1e}")
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
