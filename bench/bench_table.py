#!/usr/bin/env python3
"""Markdown table of `supermat bench --image ... --json FILE` results (the README's tables).
usage: PYTHONPATH=python python3 bench/bench_table.py FILE.json [FILE.json ...] [PEAK_GFLOPS]

One file: its rows as they are. Several files (e.g. one per view of supermat_tools.eval_quality --levers):
per mode the mean over the files that have it (a mode skipped or failed in a file is left out there;
a column n then says over how many): seconds, speed-up (the mean of each file's speed-up), peak MiB,
GFLOP, % of peak, the PSNR against the f32 maps and the PSNR against the truth (gt_psnr, columns shown
when the rows carry one) in dB, each map over the files where it is not null; max abs is the largest
over the files. PEAK_GFLOPS (the last argument, a number that is not a file) replaces each file's
measured FMA peak in % of peak."""
import os
import sys

from supermat_tools.bench_rows import load, markdown


def main(argv=None):
    args = list(sys.argv[1:] if argv is None else argv)
    peak = None
    if len(args) > 1 and not os.path.exists(args[-1]):
        try:
            peak = float(args[-1])
        except ValueError:
            pass
        else:
            args.pop()
    if not args:
        sys.exit(__doc__)
    print(markdown(load(args), peak))


if __name__ == "__main__":
    main()
