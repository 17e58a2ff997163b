#!/usr/bin/env bash
# The aarch64 NEON path, cross-compiled with Debian's gcc-aarch64-linux-gnu (static) and run under
# qemu-user-static: the kernel tests against float64 (scalar and NEON modes) and the golden tests of
# the tiny single-view and UV-refine models and of the trained default model on the NEON kernel, with
# the bounds of the x86 runs; the NEON passes against their scalar twins (test_kernels) and the
# instructions each executes against its twin (tests/neon_insns.c). qemu's wall time says nothing about speed.
# usage: test_neon.sh WORKDIR SRC DATA TINY TINY_UV DEFAULT_MODEL   (exit 77 = skipped)
set -euo pipefail
work=$1 src=$2 data=$3 tiny=$4 tiny_uv=$5 default_model=$6
cc=$(command -v aarch64-linux-gnu-gcc || true)
qemu=$(command -v qemu-aarch64-static || command -v qemu-aarch64 || true)
if [ -z "$cc" ] || [ -z "$qemu" ]; then
  echo "SKIP: needs aarch64-linux-gnu-gcc and qemu-aarch64(-static) (Debian: gcc-aarch64-linux-gnu qemu-user-static)"
  exit 77
fi
mkdir -p "$work"
for t in test_kernels test_golden; do
  "$cc" -std=c99 -O2 -Wall -Wextra -pedantic -Werror -static -I"$src/tests" -o "$work/$t" "$src/tests/$t.c" -lm -lpthread
done
file "$work/test_golden" 2>/dev/null | grep -q aarch64 || { echo "FAIL: $work/test_golden is not an aarch64 binary"; exit 1; }
run() { echo "== qemu-aarch64: $*"; "$qemu" "$@"; }
out=$(run "$work/test_kernels" 2>&1) || { echo "$out"; exit 1; }
echo "$out" | tail -n 4
# the NEON modes must have run (no SKIP for them), or this test proves nothing
if echo "$out" | grep -q "no NEON"; then echo "FAIL: the NEON kernel was skipped on aarch64"; exit 1; fi
echo "$out" | grep -q "kernel neon:" || { echo "FAIL: no NEON kernel line"; exit 1; }
# one golden a model kind (the x86 builds run them all): the non-square single view, the UV refine and the
# default model's real widths; the multi-view model adds no kernel of its own (its views are attention rows,
# which test_kernels checks on NEON) and cost 5 of this test's 16 minutes under qemu, so it runs on x86 only
run "$work/test_golden" "$tiny" neon 2 "$data/golden/single_ring_48x72" | tail -n 1
run "$work/test_golden" "$tiny" neon:wf4 2 "$data/golden/single_box_40" | tail -n 1
run "$work/test_golden" "$tiny_uv" neon 2 "$data/golden/uv_128" | tail -n 1
run "$work/test_golden" "$default_model" neon 2 "$data/golden/default_obj00_128" | tail -n 1
run "$work/test_golden" "$tiny" auto 2 "$data/golden/single_box_40" | tail -n 1   # the dispatch picks NEON
# instructions executed by each NEON pass and by its scalar twin (qemu -singlestep -d exec,nochain: a
# "Trace" line per executed instruction; qemu's wall time says nothing about a real core): per call, the
# program's start-up subtracted; each NEON pass must execute fewer than its twin
"$cc" -std=c99 -O2 -Wall -Wextra -pedantic -Werror -static -I"$src/tests" -o "$work/neon_insns" "$src/tests/neon_insns.c" -lm
insns() { "$qemu" -singlestep -d exec,nochain -D /dev/stdout "$work/neon_insns" "$@" | grep -c '^Trace'; }
echo "instructions a call (aarch64 under qemu): pass, scalar, NEON, ratio"
for p in widen_f16 widen_bf16 widen_i8 silu geglu srgb layernorm softmax groupnorm lowpass; do
  s0=$(insns $p scalar 0); s2=$(insns $p scalar 2); n0=$(insns $p neon 0); n2=$(insns $p neon 2)
  sc=$(( (s2 - s0) / 2 )); ne=$(( (n2 - n0) / 2 ))
  [ "$ne" -gt 0 ] && [ "$sc" -gt "$ne" ] || { echo "FAIL: $p: NEON $ne instructions, scalar $sc"; exit 1; }
  awk -v p="$p" -v s="$sc" -v n="$ne" 'BEGIN { printf "  %-10s %8d %8d  %.1fx\n", p, s, n, s / n }'
done
echo "neon: kernels and goldens pass on aarch64 (qemu)"
