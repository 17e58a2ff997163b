#!/usr/bin/env bash
# The same harnesses under AFL++ (Debian's afl++): built with afl-clang-fast / afl-clang-fast++ and
# -fsanitize=fuzzer (AFL++'s libFuzzer driver), with ASan + UBSan, then optionally one run.
#
#   bash fuzz/afl.sh OUTDIR                      build every harness into OUTDIR
#   bash fuzz/afl.sh OUTDIR json 3600            build fuzz_json only and run it under afl-fuzz for 3600 s
#                                                (corpus fuzz/corpus/json, findings in OUTDIR/afl_json)
# (each harness compiles supermat.h instrumented: 55-120 s apiece on a Zen 3 core, so a run builds only its
# own; the clang build compiles every harness from the same sources for libFuzzer)
set -euo pipefail
SRC=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
OUT=${1:?usage: afl.sh OUTDIR [HARNESS SECONDS]}
mkdir -p "$OUT"
export AFL_USE_ASAN=1 AFL_USE_UBSAN=1 AFL_QUIET=1
FLAGS=(-g -O1 -fsanitize=fuzzer -I"$SRC" -I"$SRC/convert" -I"$SRC/cli")
want() { [ $# -lt 3 ] || [ "$2" = "$h" ]; }
for h in model json uv; do want "$@" || continue; afl-clang-fast "${FLAGS[@]}" "$SRC/fuzz/fuzz_$h.c" -o "$OUT/fuzz_$h" -lm -lpthread; done
for h in pth cameras config picture; do
    want "$@" || continue
    extra=(); [ "$h" = picture ] && extra=(-fno-sanitize=undefined -fsanitize=bounds)   # as CMakeLists.txt says
    afl-clang-fast "${FLAGS[@]}" "${extra[@]}" -DSUPERMAT_FUZZ_TINY="\"$SRC/tests/data/tiny\"" "$SRC/fuzz/fuzz_$h.c" "$SRC/convert/sm_convert.c" -o "$OUT/fuzz_$h" -lm -lpthread
done
h=gltf
if [ -f /usr/include/tiny_gltf.h ] && want "$@"; then
    afl-clang-fast++ "${FLAGS[@]}" "$SRC/fuzz/fuzz_gltf.cpp" -o "$OUT/fuzz_gltf" -ltinygltf -lstb -lpthread
fi
if [ $# -ge 3 ] && [ ! -x "$OUT/fuzz_$2" ]; then echo "afl.sh: no harness fuzz_$2 (model json uv pth cameras config picture gltf)"; exit 2; fi
echo "afl.sh: built $(ls "$OUT" | grep -c '^fuzz_') harnesses in $OUT"
if [ $# -ge 3 ]; then
    h=$2
    seeds=$SRC/fuzz/corpus/$h
    rm -rf "$OUT/afl_$h"
    AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1 \
        afl-fuzz -i "$seeds" -o "$OUT/afl_$h" -V "$3" -- "$OUT/fuzz_$h" >/dev/null
    grep -E '^(execs_done|execs_per_sec|bitmap_cvg|saved_crashes|saved_hangs) ' "$OUT/afl_$h/default/fuzzer_stats"
    [ "$(awk '/^saved_crashes/ {print $3}' "$OUT/afl_$h/default/fuzzer_stats")" = 0 ]
fi
