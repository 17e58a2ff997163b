#!/usr/bin/env bash
# tests/cli/test_bench.sh - `supermat bench`: speed, and speed against accuracy.
#
#   bash tests/cli/test_bench.sh BUILD/supermat tests/data
#
# `bench` on all three kinds (pipeline only), --json (and its overwrite policy), the dot peak of bf16 / int8
# compute beside the FMA peak (where the CPU has it), --conv, --views with the single-view model;
# `bench --image` (the speed / accuracy table: its JSON parsed by a small awk parser, the f32 reference at
# 200 dB, f16 finite and below, a map a mode does not compute as null) and its usage errors; bench --image
# against ground truth (--truth-albedo/-roughness/-metallic: `image`'s own PNGs as the truth give the f32 row
# 200 dB, a map a mode skips or without truth null; a truth of the wrong size, colour type or model kind exits
# 1 with a message and writes no JSON; without --image exits 2); --modes errors; a 30x30 image.
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny
setup_tiny_mv
setup_tiny_uv
make_bad_png

# ---- bench --------------------------------------------------------------------------------------
# bench on the three kinds (pipeline only: no FMA peak or GEMM, quick)
run bench --model "$MODEL" --size 64 --pipeline-only --json "$T/bench.json"
check "bench supermat exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "bench: a trunk row" grep -q '^unet trunk ' "$T/out"
check "bench: an albedo branch row" grep -q '^unet branch albedo ' "$T/out"
check "bench: a roughness/metallic branch row" grep -q '^unet branch roughness/metallic ' "$T/out"
check "bench: no x0 row" bash -c "! grep -q 'x0' '$T/out'"
cp "$T/bench.json" "$T/bench_before.json"
run bench --model "$MODEL" --size 64 --pipeline-only --json "$T/bench.json"
check "bench --json over an existing report exits 1" [ $RC -eq 1 ]
check "bench --json over an existing report: nothing measured" bash -c "! grep -q '^unet trunk ' '$T/out'"
check "bench --json over an existing report: it is untouched" cmp -s "$T/bench.json" "$T/bench_before.json"
check "bench: JSON written" grep -q '"stage": "unet trunk"' "$T/bench.json"
run bench --model "$MV" --size 64 --views 2 --pipeline-only --outputs albedo
check "bench supermat-mv --views 2 exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "bench mv: 2 views" grep -q '64x64 x 2 views' "$T/out"
check "bench mv: one branch row" [ "$(grep -c '^unet branch' "$T/out")" -eq 1 ]
run bench --model "$UV" --size 64 --pipeline-only
check "bench uv-refine exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "bench uv: the refined branch row" grep -q '^unet branch refined ' "$T/out"
check "bench uv: the unet input row" grep -q '^unet input (mask, position)' "$T/out"
# the peak of the dot instruction a bf16 / int8 compute multiplies with, measured beside the FMA peak: one
# vdpbf16ps carries 64 flops (the FMA 32), one vpdpbusd zmm 128 ops, so at any issue rate from a quarter of the
# FMA's (measured on an AMX Xeon, 2026-11-29: vdpbf16ps zmm 231 GOP/s against the FMA's 478 GFLOP/s, 0.48) to the
# FMA's own (Zen 5: 1.85) the ratio to the FMA peak lies in [0.5, 2] (bf16), and in [2, 4] (int8); the bounds
# below leave room for a busy machine. f32 compute: no dot peak, JSON null; nor for bf16 compute on AMX tiles
# (what `auto` picks where the CPU and OS allow AMX), whose vdpbf16ps kernel is then measured by name.
json_num() { grep -o "\"$2\": [-0-9.e+]*" "$1" | head -1 | awk '{print $2}'; }
run bench --model "$MODEL" --size 64 --json "$T/bench_f32.json"
check "bench (f32, with peaks) exits 0" [ $RC -eq 0 ]
check "bench f32: no dot peak line" bash -c "! grep -q '^dot peak' '$T/out'"
check "bench f32: dot_peak_gops null" grep -q '"dot_peak_gops": null' "$T/bench_f32.json"
dot_case() { # $1 compute, $2 isa name, $3 lowest ratio, $4 highest ratio, [$5 kernel]
  run bench --model "$MODEL" --size 64 --compute "$1" ${5:+--kernel "$5"} --json "$T/bench_$1.json"
  check "bench --compute $1 (with peaks) exits 0" [ $RC -eq 0 ]
  [ $RC -eq 0 ] || cat "$T/err"
  check "bench --compute $1: the dot peak line names $2" grep -q "^dot peak .*($2," "$T/out"
  check "bench --compute $1: a % dot column" grep -q '% dot$' "$T/out"
  local fma dot
  fma=$(json_num "$T/bench_$1.json" fma_peak_gflops); dot=$(json_num "$T/bench_$1.json" dot_peak_gops)
  check "bench --compute $1: dot peak $dot / FMA peak $fma within [$3, $4]" awk -v f="$fma" -v d="$dot" -v lo="$3" -v hi="$4" \
    'BEGIN { exit !(f > 0 && d / f >= lo && d / f <= hi) }'
  check "bench --compute $1: JSON names $2" grep -q "\"dot_peak_isa\": \"$2\"" "$T/bench_$1.json"
}
if grep -qw avx512_bf16 /proc/cpuinfo 2>/dev/null; then
  run bench --model "$MODEL" --size 64 --compute bf16 --json "$T/bench_bf16_auto.json"
  check "bench --compute bf16 (auto kernel) exits 0" [ $RC -eq 0 ]
  if grep -q '^supermat bench: .*kernel amx, bf16 compute' "$T/out"; then
    check "bench --compute bf16 on AMX: no dot peak line" bash -c "! grep -q '^dot peak' '$T/out'"
    check "bench --compute bf16 on AMX: dot_peak_gops null" grep -q '"dot_peak_gops": null' "$T/bench_bf16_auto.json"
    dot_case bf16 "vdpbf16ps zmm" 0.35 2.6 avx512
  else
    check "bench --compute bf16 without AMX: the AVX-512 kernel" grep -q '^supermat bench: .*kernel avx512, bf16 compute' "$T/out"
    dot_case bf16 "vdpbf16ps zmm" 0.35 2.6
  fi
else echo "skip: bench --compute bf16 dot peak (no AVX512_BF16 on this CPU)"; fi
if grep -qw avx512_vnni /proc/cpuinfo 2>/dev/null && grep -qw avx512bw /proc/cpuinfo 2>/dev/null; then dot_case int8 "vpdpbusd zmm" 1.4 5.2
elif grep -qw avx_vnni /proc/cpuinfo 2>/dev/null; then dot_case int8 "vpdpbusd ymm" 1.4 5.2
else echo "skip: bench --compute int8 dot peak (no AVX512_VNNI or AVX-VNNI on this CPU)"; fi
run bench --model "$MODEL" --size 64 --pipeline-only --views 2
check "bench --views 2 with the single-view model exits 1" [ $RC -eq 1 ]
check "bench --views 2 with the single-view model explains" grep -q 'supermat-mv' "$T/err"

# --conv: the Winograd lever in bench
VIEWS=()
for k in 0 1 2 3 4 5; do VIEWS+=("$MVIMG/color_000$k.png"); done
run bench --model "$MV" --size 64 --views 2 --pipeline-only --conv winograd-f2
check "bench --conv winograd-f2 exits 0" [ $RC -eq 0 ]
check "bench --conv winograd-f2: the header says so" grep -q "winograd-f2 convolutions" "$T/out"
run bench --model "$MV" --image "${VIEWS[0]}" --conv winograd-f2
check "bench --image --conv: exit 2 (the modes choose)" [ $RC -eq 2 ]

# bench --image: the speed / accuracy table (f32 reference, f16 weights, the albedo branch alone)
# json_ok FILE: FILE is one valid JSON value (a small recursive-descent parser in awk)
json_ok() {
    awk '
    function ws() { while (pos <= n && index(" \t\r\n", substr(s, pos, 1))) pos++ }
    function str(   c) {
        if (substr(s, pos, 1) != "\"") return 0
        for (pos++; pos <= n; pos++) {
            c = substr(s, pos, 1)
            if (c == "\\") pos++
            else if (c == "\"") { pos++; return 1 }
        }
        return 0
    }
    function val(   c) {
        ws(); c = substr(s, pos, 1)
        if (c == "{") return obj()
        if (c == "[") return arr()
        if (c == "\"") return str()
        if (substr(s, pos, 4) == "null" || substr(s, pos, 4) == "true") { pos += 4; return 1 }
        if (substr(s, pos, 5) == "false") { pos += 5; return 1 }
        if (match(substr(s, pos), /^-?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][-+]?[0-9]+)?/)) { pos += RLENGTH; return RLENGTH > 0 }
        return 0
    }
    function arr(   c) {
        pos++; ws()
        if (substr(s, pos, 1) == "]") { pos++; return 1 }
        for (;;) {
            if (!val()) return 0
            ws(); c = substr(s, pos++, 1)
            if (c == "]") return 1
            if (c != ",") return 0
        }
    }
    function obj(   c) {
        pos++; ws()
        if (substr(s, pos, 1) == "}") { pos++; return 1 }
        for (;;) {
            ws()
            if (!str()) return 0
            ws()
            if (substr(s, pos++, 1) != ":") return 0
            if (!val()) return 0
            ws(); c = substr(s, pos++, 1)
            if (c == "}") return 1
            if (c != ",") return 0
        }
    }
    { s = s $0 "\n" }
    END { n = length(s); pos = 1; ok = val(); ws(); exit !(ok && pos > n) }' "$1"
}
# jfield FILE MODE KEY [MAP]: a value from the line of MODE in bench --image's JSON (one object per line)
jfield() {
    local line
    line=$(grep "\"mode\": \"$2\"" "$1") || { echo missing; return; }
    if [ $# -eq 4 ]; then sed -n "s/.*\"$3\": {[^}]*\"$4\": \([^,}]*\).*/\1/p" <<<"$line"
    else sed -n "s/.*\"$3\": \([^,}]*\).*/\1/p" <<<"$line"; fi
}
# num_in X LO HI: X is a finite JSON number with LO < X < HI
num_in() { awk -v x="$1" -v lo="$2" -v hi="$3" 'BEGIN { exit !(x ~ /^-?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?$/ && x + 0 > lo + 0 && x + 0 < hi + 0) }'; }
BJ=$T/bench_modes.json
run bench --model "$MODEL" --image "$SPHERE" --modes f16,branch_albedo --json "$BJ"
check "bench --image exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "bench --image: the table header" grep -q '^mode .* seconds .* speedup .* psnr_fg' "$T/out"
check "bench --image: machine info" grep -q '^machine .*thread' "$T/out"
check "bench --image: f32 row first" [ "$(grep -E '^(f32|f16|branch_albedo) ' "$T/out" | head -n 1 | cut -d' ' -f1)" = f32 ]
check "bench --image: branch_albedo row with - for roughness" grep -Eq '^branch_albedo .*\| +[0-9.]+ +[0-9.]+ +[0-9.e+-]+ \| +- +- +- \| +- +- +-$' "$T/out"
check "bench --image: the JSON parses" json_ok "$BJ"
check "bench --image: the JSON is a list" [ "$(head -c 1 "$BJ")" = "[" ]
check "bench --image: 3 modes (f32 added)" [ "$(grep -c '"mode": ' "$BJ")" -eq 3 ]
for mode in f32 f16 branch_albedo; do
    check "bench --image JSON: mode $mode" grep -q "\"mode\": \"$mode\"" "$BJ"
    v=$(jfield "$BJ" $mode seconds)
    check "bench --image JSON: $mode seconds $v > 0" num_in "$v" 0 1e9
    v=$(jfield "$BJ" $mode flops)
    check "bench --image JSON: $mode flops $v > 0" num_in "$v" 0 1e30
    v=$(jfield "$BJ" $mode peak_bytes)
    check "bench --image JSON: $mode peak_bytes $v > 0" num_in "$v" 0 1e30
done
for map in albedo roughness metallic; do
    v=$(jfield "$BJ" f32 psnr $map)
    check "bench --image JSON: f32 psnr $map is 200 ($v)" [ "$v" = 200 ]
    v=$(jfield "$BJ" f32 max_abs $map)
    check "bench --image JSON: f32 max_abs $map is 0 ($v)" [ "$v" = 0 ]
    v=$(jfield "$BJ" f16 psnr $map)
    check "bench --image JSON: f16 psnr $map finite, in (20, 200) ($v)" num_in "$v" 20 200
    v=$(jfield "$BJ" f16 psnr_fg $map)
    check "bench --image JSON: f16 psnr_fg $map finite, in (20, 200) ($v)" num_in "$v" 20 200
done
v=$(jfield "$BJ" branch_albedo psnr albedo)
check "bench --image JSON: branch_albedo psnr albedo is 200 ($v)" [ "$v" = 200 ]
v=$(jfield "$BJ" f32 gt_psnr albedo)
check "bench --image JSON without truth: gt_psnr albedo is null ($v)" [ "$v" = null ]
check "bench --image without truth: no gt_psnr column" bash -c "! grep -q gt_psnr '$T/out'"

# bench --image against ground truth: `supermat image`'s PNGs of the same model are the truth, so the
# f32 row (the same computation, quantised the same way) is at the cap; bench measures the network's maps,
# so the truth is made with --detail off --chroma off (image's default keeps the picture's detail and
# colour in the albedo)
GT=$T/gt
run image --model "$MODEL" --detail off --chroma off --out "$GT" "$SPHERE"
check "image for the truth maps exits 0" [ $RC -eq 0 ]

TRUTH=(--truth-albedo "$GT/sphere_64_albedo.png" --truth-roughness "$GT/sphere_64_roughness.png" --truth-metallic "$GT/sphere_64_metallic.png")
BG=$T/bench_gt.json
run bench --model "$MODEL" --image "$SPHERE" --modes f16,branch_rm "${TRUTH[@]}" --json "$BG"
check "bench --image with truth exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "bench --image with truth: a gt_psnr column" grep -q '^mode .* max_abs gt_psnr |' "$T/out"
check "bench --image with truth: the truth line" grep -q "^truth .*albedo $GT/sphere_64_albedo.png" "$T/out"
check "bench --image with truth: f32 row at 200 for the truth" grep -Eq '^f32 .*\| +200\.00 +200\.00 +0\.000e\+00 +200\.00 \| +200\.00 +200\.00 +0\.000e\+00 +200\.00 \| +200\.00 +200\.00 +0\.000e\+00 +200\.00$' "$T/out"
check "bench --image with truth: the JSON parses" json_ok "$BG"
check "bench --image with truth: every row has gt_psnr" [ "$(grep -c '"gt_psnr": {' "$BG")" -eq 3 ]
for map in albedo roughness metallic; do
    v=$(jfield "$BG" f32 gt_psnr $map)
    check "bench --image truth JSON: f32 gt_psnr $map is the cap, 200 ($v)" [ "$v" = 200 ]
    v=$(jfield "$BG" f16 gt_psnr $map)
    check "bench --image truth JSON: f16 gt_psnr $map finite, in (20, 200] ($v)" num_in "$v" 20 200.5
done
v=$(jfield "$BG" branch_rm gt_psnr albedo)
check "bench --image truth JSON: branch_rm gt_psnr albedo is null ($v)" [ "$v" = null ]
v=$(jfield "$BG" branch_rm gt_psnr metallic)
check "bench --image truth JSON: branch_rm gt_psnr metallic is 200 ($v)" [ "$v" = 200 ]
rm -f "$BG"
run bench --model "$MODEL" --image "$SPHERE" --modes f32 --truth-roughness "$GT/sphere_64_roughness.png" --json "$BG"
check "bench --image with one truth file exits 0" [ $RC -eq 0 ]
v=$(jfield "$BG" f32 gt_psnr roughness)
check "bench --image one truth: roughness 200 ($v)" [ "$v" = 200 ]
v=$(jfield "$BG" f32 gt_psnr albedo)
check "bench --image one truth: albedo null ($v)" [ "$v" = null ]
rm -f "$BG"
run bench --model "$MODEL" --image "$SPHERE" --truth-albedo "$DATA/img/box_40.png" --json "$BG"
check "bench --image with a truth of the wrong size exits 1" [ $RC -eq 1 ]
check "bench --image with a truth of the wrong size: the message" grep -q "albedo truth '$DATA/img/box_40.png' is 40x40 but the image '$SPHERE' is 64x64" "$T/err"
absent "$BG"
run bench --model "$MODEL" --image "$SPHERE" --truth-albedo "$GT/sphere_64_roughness.png"
check "bench --image with a gray albedo truth exits 1" [ $RC -eq 1 ]
check "bench --image with a gray albedo truth: the message" grep -q "albedo truth .* is gray: give an 8-bit RGB" "$T/err"
run bench --model "$MODEL" --image "$SPHERE" --truth-metallic "$GT/sphere_64_albedo.png"
check "bench --image with a colour metallic truth exits 1" [ $RC -eq 1 ]
check "bench --image with a colour metallic truth: the message" grep -q "metallic truth .* is in colour: give an 8-bit gray" "$T/err"
run bench --model "$MODEL" --image "$SPHERE" --truth-roughness "$T/no_such_truth.png"
check "bench --image with a missing truth exits 1" [ $RC -eq 1 ]
check "bench --image with a missing truth names it" grep -q "cannot read the roughness truth '$T/no_such_truth.png'" "$T/err"
run bench --model "$MODEL" --truth-albedo "$GT/sphere_64_albedo.png"
check "bench --truth-albedo without --image exits 2" [ $RC -eq 2 ]
check "bench --truth-albedo without --image explains" grep -q -- "--truth-albedo needs --image" "$T/err"
run bench --model "$MODEL" --image "$SPHERE" --truth-color "$GT/sphere_64_albedo.png"
check "bench --truth-color exits 2" [ $RC -eq 2 ]
for key in psnr psnr_fg max_abs; do
    v=$(jfield "$BJ" branch_albedo $key roughness)
    check "bench --image JSON: branch_albedo $key roughness is null ($v)" [ "$v" = null ]
    v=$(jfield "$BJ" branch_albedo $key metallic)
    check "bench --image JSON: branch_albedo $key metallic is null ($v)" [ "$v" = null ]
done
run bench --model "$MV" --image "$MVIMG/color_0000.png" --views 2 --modes f32,mv_window_own --json "$T/bench_mv.json"
check "bench --image supermat-mv (one image, 2 views) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "bench --image supermat-mv: the JSON parses" json_ok "$T/bench_mv.json"
check "bench --image supermat-mv: an mv_window_own row" grep -q '^mv_window_own ' "$T/out"
run bench --model "$MV" --image "$MVIMG/color_0000.png" --views 2 --modes f32 --truth-roughness "$GT/sphere_64_roughness.png" --json "$BG"
check "bench --image supermat-mv with a truth exits 1" [ $RC -eq 1 ]
check "bench --image supermat-mv with a truth: for a supermat model" grep -q "are for a supermat model (one image); model .* is a supermat-mv model" "$T/err"
absent "$BG"
run bench --model "$UV" --image "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --modes int8 --json "$T/bench_uv.json"
check "bench --image uv-refine exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "bench --image uv-refine: the JSON parses" json_ok "$T/bench_uv.json"
v=$(jfield "$T/bench_uv.json" int8 psnr refined)
check "bench --image uv-refine: int8 psnr refined finite, in (20, 200) ($v)" num_in "$v" 20 200
run bench --model "$MODEL" --image "$SPHERE" --modes f32,warp9
check "bench --modes with an unknown mode exits 2" [ $RC -eq 2 ]
check "bench --modes with an unknown mode: the message names it" grep -q "unknown mode 'warp9'" "$T/err"
run bench --model "$MODEL" --modes f16
check "bench --modes without --image exits 2" [ $RC -eq 2 ]
run bench --model "$UV" --image "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --modes branch_rm --json "$T/bench_never.json"
check "bench --modes branch_rm with a uv-refine model exits 1" [ $RC -eq 1 ]
check "bench --modes branch_rm with a uv-refine model explains" grep -q "does not apply" "$T/err"
absent "$T/bench_never.json"
run bench --model "$MODEL" --image "$BAD"
check "bench --image of 30x30 exits 1" [ $RC -eq 1 ]
check "bench --image of 30x30: multiples of 8" grep -q 'multiples of 8' "$T/err"

summary
