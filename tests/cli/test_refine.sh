#!/usr/bin/env bash
# tests/cli/test_refine.sh - `supermat refine`: the UV-refine model.
#
#   bash tests/cli/test_refine.sh BUILD/supermat tests/data
#
# Converts the tiny UV-refine checkpoint, `info` on it, runs `refine` (the --float map against the official
# golden, max abs error 1e-4, tests/pfm_npy_diff.c built with ${CC:-cc}; skipped without a compiler),
# --work-size 64, an RGB mask; size mismatches of the mask and the position map (exit 1), no --mask (exit 2).
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# ---- UV refine (refine) -----------------------------------------------------------------------
run convert --kind uv-refine --unet "$DATA/tiny/uv_refine_bc.pth" --base "$DATA/tiny/base" --out "$UV" --work-size native
check "convert uv-refine exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"

run info "$UV"
check "info uv exits 0" [ $RC -eq 0 ]
check "info uv: kind" grep -Eq '^kind +uv-refine$' "$T/out"
check "info uv: input channels" grep -q 'UNet input 8 channels = latent 4 + mask 1 + position 3' "$T/out"
check "info uv: the command" grep -q 'supermat refine' "$T/out"

golden_setup

# refine
OU=$T/refine
run refine --model "$UV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --out "$OU" --float
check "refine exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$OU/uv_bc_refined.png" 128 128 2
# at another work size (views: test_views.sh): the maps come back at the input's size, and differ
run refine --model "$UV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --out "$T/refine_ws" --work-size 64
check "refine --work-size 64 exits 0" [ $RC -eq 0 ]
check_png "$T/refine_ws/uv_bc_refined.png" 128 128 2
check "refine --work-size 64: other maps than at the native 128" bash -c "! cmp -s '$OU/uv_bc_refined.png' '$T/refine_ws/uv_bc_refined.png'"
check_pfm "$OU/uv_bc_refined.pfm" 128 128 3
check "refine: 2 files" [ "$(find "$OU" -type f | wc -l)" -eq 2 ]
golden "refined vs golden uv_128/uv_refined.npy" "$DATA/golden/uv_128/uv_refined.npy" "$OU/uv_bc_refined.pfm"

run refine --model "$UV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_position.png" --position "$UVIMG/uv_position.png" --out "$T/refine_rgbmask"
check "refine with an RGB mask (converted to gray) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$T/refine_rgbmask/uv_bc_refined.png" 128 128 2

# a valid 64x64 8-bit gray PNG (a horizontal ramp): a mask smaller than the 128x128 map
SMALL=$T/small_64.png
printf '\211\120\116\107\015\012\032\012\000\000\000\015\111\110\104\122\000\000\000\100\000\000\000\100\010\000\000\000\000\217\002\056\002\000\000\000\162\111\104\101\124\170\332\143\140\140\341\340\021\020\221\220\121\120\321\320\061\060\261\260\161\160\361\360\011\010\211\210\111\110\311\310\051\050\251\250\151\150\351\350\231\060\145\306\234\005\113\126\254\331\260\145\307\236\003\107\116\234\271\160\345\306\235\007\117\136\274\371\360\345\307\037\206\121\003\106\015\030\065\140\324\200\121\003\106\015\030\065\140\324\200\121\003\106\015\030\065\140\324\200\121\003\106\015\030\065\140\270\033\000\000\173\066\340\152\221\332\203\037\000\000\000\000\111\105\116\104\256\102\140\202' >"$SMALL"
check_png "$SMALL" 64 64 0
run refine --model "$UV" --map "$UVIMG/uv_bc.png" --mask "$SMALL" --position "$UVIMG/uv_position.png" --out "$T/refine_bad"
check "refine with a smaller mask exits 1" [ $RC -eq 1 ]
check "refine with a smaller mask: the message names it" grep -q 'small_64.png' "$T/err"
check "refine with a smaller mask: the message says same size" grep -q 'same size' "$T/err"
run refine --model "$UV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$SPHERE" --out "$T/refine_bad"
check "refine with a smaller position map exits 1" [ $RC -eq 1 ]
check "refine with a smaller position map: the message names it" grep -q 'sphere_64.png' "$T/err"
absent "$T/refine_bad"
run refine --model "$UV" --map "$UVIMG/uv_bc.png" --position "$UVIMG/uv_position.png" --out "$T/refine_bad"
check "refine without --mask exits 2" [ $RC -eq 2 ]

summary
