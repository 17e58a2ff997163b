#!/usr/bin/env bash
# The Windows build of the library: MinGW-w64 (Debian's gcc-mingw-w64-x86-64, static) and wine64 (wine64).
# Compiles the kernel, golden and Windows tests as Windows programs (-Wall -Wextra -pedantic -Werror) and runs
# them under wine: the kernel tests against float64 on every kernel this CPU has; the goldens of the tiny
# single-view, multi-view and UV-refine models and of the trained default model, with the bounds of the Linux
# runs, on the kernel the dispatch picks and 2 threads; tests/test_win32.c: the same CPU features and kernel as
# the Linux build sees (its Linux compile prints them), the Win32 thread pool on several OS threads, the
# default thread count from the affinity mask, 1 thread = 3 threads bit for bit. wine runs the x86 code
# natively, so timings would mean something; this test checks correctness only.
# usage: test_mingw.sh WORKDIR SRC DATA TINY TINY_MV TINY_UV DEFAULT_MODEL   (exit 77 = skipped)
set -euo pipefail
work=$1 src=$2 data=$3 tiny=$4 tiny_mv=$5 tiny_uv=$6 default_model=$7
mcc=$(command -v x86_64-w64-mingw32-gcc || true)
wine=$(command -v wine64 || true)
[ -z "$wine" ] && [ -x /usr/lib/wine/wine64 ] && wine=/usr/lib/wine/wine64   # Debian's wine64 package puts it there
if [ -z "$mcc" ] || [ -z "$wine" ]; then
  echo "SKIP: needs x86_64-w64-mingw32-gcc and wine64 (Debian: gcc-mingw-w64-x86-64 wine64)"
  exit 77
fi
mkdir -p "$work"
export WINEPREFIX="$work/wineprefix" WINEDEBUG=-all
for t in test_kernels test_golden test_win32; do
  "$mcc" -std=c99 -O2 -Wall -Wextra -pedantic -Werror -static -I"$src/tests" -o "$work/$t.exe" "$src/tests/$t.c" -lm
done
"${CC:-cc}" -std=c99 -O2 -I"$src/tests" -o "$work/test_win32_linux" "$src/tests/test_win32.c" -lm -lpthread
expect=$("$work/test_win32_linux")
run() { echo "== wine: $*"; "$wine" "$@"; }
out=$(run "$work/test_kernels.exe" 2>&1) || { echo "$out"; exit 1; }
echo "$out" | tail -n 4
case ",$expect," in
  *,avx2,*) echo "$out" | grep -q "kernel avx2:" || { echo "FAIL: the AVX2 kernel did not run on Windows"; exit 1; } ;;
esac
case ",$expect," in
  *,avx512,*) echo "$out" | grep -q "kernel avx512:" || { echo "FAIL: the AVX-512 kernel did not run on Windows"; exit 1; } ;;
esac
run "$work/test_golden.exe" "$tiny" auto 2 "$data/golden/single_sphere_64" "$data/golden/single_box_40" "$data/golden/single_ring_48x72" | tail -n 1
run "$work/test_golden.exe" "$tiny" auto:wf4 2 "$data/golden/single_box_40" | tail -n 1
run "$work/test_golden.exe" "$tiny_mv" auto 2 "$data/golden/mv6_64" | tail -n 1
run "$work/test_golden.exe" "$tiny_uv" auto 2 "$data/golden/uv_128" | tail -n 1
run "$work/test_golden.exe" "$default_model" auto 2 "$data/golden/default_obj00_128" | tail -n 1
run "$work/test_win32.exe" "$tiny" "$expect"
echo "mingw: kernels, goldens and the Win32 pool pass as a Windows program (wine)"
