#!/usr/bin/env bash
# tests/cli/test_image.sh - `supermat image`: maps of one picture with the single-view model.
#
#   bash tests/cli/test_image.sh BUILD/supermat tests/data
#
# The preprocessing: the model's work size (the official 512 recorded by convert) by default, --native, a
# model recording none (the picture's own size), --work-size 512 / 100 (exit 2). Runs `image` on two test
# pictures (square and non-square) with and without --float, and checks file names, PNG sizes and colour types
# (IHDR bytes read with od), PFM headers and sizes, that --outputs limits what is written, that threads do not
# change the bits, --kernel scalar, --compute int8 (maps with AVX512_VNNI, else exit 1 naming it; int4 exits 2),
# the f16 model; a PNG write that fails (a file size limit) exits 1 and leaves no file; --max-memory refused
# before allocating with the sizes in the message; --detail and --chroma (the defaults change the albedo only,
# explicit values, bad values exit 2, refine refuses both); --roughness-curve and --metallic-curve (convert
# --from records them, info shows them, image applies the file's or the command line's within 1e-6 of
# 0.1 + 0.8 x where alpha > 0 and nowhere else, the other maps untouched, both in one file each on its own map,
# off, bad lists exit 2, a uv-refine file refuses them); the picture's alpha kept in the maps (RGBA and gray +
# alpha PNGs, the channels otherwise those of --alpha drop, the same PNGs with --float) or dropped.
# (Input formats and bad pictures are in test_inputs.sh, the overwrite policy in test_usage.sh.)
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny
setup_tiny_f16   # F16: converted without --work-size, the official 512

# ---- preprocessing: the official square work size by default (pipeline.work_size) --------------
run info "$F16"
check "info: a converted model records the official work size 512" grep -Eq '^work size +512x512' "$T/out"
run info "$MODEL"
check "info: --work-size native records none" grep -Eq '^work size +none' "$T/out"
run image --model "$F16" --out "$T/pre_default" --float "$SPHERE"
check "image at the model's work size exits 0" [ $RC -eq 0 ]
check_png "$T/pre_default/sphere_64_albedo.png" 64 64 6
run image --model "$F16" --out "$T/pre_512" --float --work-size 512 "$SPHERE"
check "image: the default is the 512 work size" cmp -s "$T/pre_default/sphere_64_albedo.pfm" "$T/pre_512/sphere_64_albedo.pfm"
run image --model "$F16" --out "$T/pre_native" --float --native "$SPHERE"
check "image --native exits 0" [ $RC -eq 0 ]
check "image --native: other maps than at 512" bash -c "! cmp -s '$T/pre_default/sphere_64_albedo.pfm' '$T/pre_native/sphere_64_albedo.pfm'"
run image --model "$MODEL" --out "$T/pre_none" --float "$SPHERE"
run image --model "$MODEL" --out "$T/pre_none_native" --float --native "$SPHERE"
check "image with a model recording no work size: the picture's own size (= --native)" cmp -s "$T/pre_none/sphere_64_albedo.pfm" "$T/pre_none_native/sphere_64_albedo.pfm"
run image --model "$MODEL" --out "$T/pre_none_512" --float --work-size 512 "$SPHERE"
check "image --work-size 512 with that model: other maps" bash -c "! cmp -s '$T/pre_none/sphere_64_albedo.pfm' '$T/pre_none_512/sphere_64_albedo.pfm'"
run image --model "$F16" --out "$T/pre_bad" --work-size 100 "$SPHERE"
check "image --work-size 100 exits 2" [ $RC -eq 2 ]

# ---- image ------------------------------------------------------------------------------------
O1=$T/out1/nested
run image --model "$MODEL" --out "$O1" "$SPHERE" "$RING"
check "image exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$O1/sphere_64_albedo.png" 64 64 6
check_png "$O1/sphere_64_roughness.png" 64 64 4
check_png "$O1/sphere_64_metallic.png" 64 64 4
check_png "$O1/ring_48x72_albedo.png" 72 48 6
check_png "$O1/ring_48x72_roughness.png" 72 48 4
check_png "$O1/ring_48x72_metallic.png" 72 48 4
absent "$O1/sphere_64_albedo.pfm"
check "image writes nothing on stdout" [ ! -s "$T/out" ]

O2=$T/out2
run image --model "$MODEL" --out "$O2" --float --threads 1 "$SPHERE" "$RING"
check "image --float exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$O2/sphere_64_albedo.png" 64 64 6
check_png "$O2/ring_48x72_metallic.png" 72 48 4
check_pfm "$O2/sphere_64_albedo.pfm" 64 64 3
check_pfm "$O2/sphere_64_roughness.pfm" 64 64 1
check_pfm "$O2/sphere_64_metallic.pfm" 64 64 1
check_pfm "$O2/ring_48x72_albedo.pfm" 72 48 3
check_pfm "$O2/ring_48x72_roughness.pfm" 72 48 1
check_pfm "$O2/ring_48x72_metallic.pfm" 72 48 1
for f in sphere_64_albedo sphere_64_roughness ring_48x72_metallic; do
    check "$f.png identical with 1 thread and all threads" cmp -s "$O1/$f.png" "$O2/$f.png"
done

O3=$T/out3
run image --model "$MODEL" --out "$O3" --outputs albedo --float "$SPHERE"
check "image --outputs albedo exits 0" [ $RC -eq 0 ]
check_png "$O3/sphere_64_albedo.png" 64 64 6
check_pfm "$O3/sphere_64_albedo.pfm" 64 64 3
absent "$O3/sphere_64_roughness.png"
absent "$O3/sphere_64_metallic.png"
absent "$O3/sphere_64_roughness.pfm"
check "--outputs albedo gives the same albedo" cmp -s "$O1/sphere_64_albedo.png" "$O3/sphere_64_albedo.png"

O4=$T/out4
run image --model "$MODEL" --out "$O4" --outputs metallic --kernel scalar "$RING"
check "image --outputs metallic --kernel scalar exits 0" [ $RC -eq 0 ]
check_png "$O4/ring_48x72_metallic.png" 72 48 4
absent "$O4/ring_48x72_albedo.png"
absent "$O4/ring_48x72_roughness.png"

# int8 compute: maps on a CPU with AVX512_VNNI (+ BW), else exit 1 naming what is missing; a bad value is usage
O6=$T/out_i8c
run image --model "$MODEL" --out "$O6" --compute int8 "$SPHERE"
if grep -qw avx512_vnni /proc/cpuinfo 2>/dev/null && grep -qw avx512bw /proc/cpuinfo 2>/dev/null; then
    check "image --compute int8 exits 0 (AVX512_VNNI here)" [ $RC -eq 0 ]
    check_png "$O6/sphere_64_albedo.png" 64 64 6
else
    check "image --compute int8 without AVX512_VNNI exits 1" [ $RC -eq 1 ]
    check "image --compute int8 without AVX512_VNNI says so" grep -q "AVX512_VNNI" "$T/err"
fi
run image --model "$MODEL" --out "$O6" --compute int4 "$SPHERE"
check "image --compute int4 exits 2" [ $RC -eq 2 ]
check "image --compute int4: the message lists the values" grep -q "f32, bf16 or int8" "$T/err"

O5=$T/out5
run image --model "$T/tiny_f16.safetensors" --out "$O5" "$SPHERE"
check "image with the f16 model exits 0" [ $RC -eq 0 ]
check_png "$O5/sphere_64_albedo.png" 64 64 6

# a write that fails (a 4 KiB file size limit with SIGXFSZ ignored: write() fails with EFBIG): exit 1,
# a message, and no file left, neither the PNG nor its .tmp (the albedo is ~12 KB)
run_limited image --model "$MODEL" --out "$T/limited" "$SPHERE"
check "image whose write fails exits 1" [ $RC -eq 1 ]
check "image whose write fails: the message names the file" grep -q "cannot write '.*sphere_64_albedo.png'" "$T/err"
absent "$T/limited/sphere_64_albedo.png"
absent "$T/limited/sphere_64_albedo.png.tmp"

# ---- the picture's alpha: kept in the maps (RGBA albedo, gray + alpha roughness / metallic) unless --alpha drop ----
# (the channels are compared through `supermat sheet FILE:c`, one 64-pixel cell: equal sheets, equal channels)
chan_sheet() { "$BIN" sheet --cell 64 --out "$1" "$2" >/dev/null 2>&1; }
OA=$T/alpha_keep; OD=$T/alpha_drop; OF=$T/alpha_float
run image --model "$MODEL" --out "$OA" "$SPHERE" "$DATA/img/ring_exif6_upright.png"
check "image, alpha: exit 0" [ $RC -eq 0 ]
run image --model "$MODEL" --out "$OD" --alpha drop "$SPHERE"
check "image --alpha drop: exit 0" [ $RC -eq 0 ]
check_png "$OD/sphere_64_albedo.png" 64 64 2
check_png "$OD/sphere_64_roughness.png" 64 64 0
check_png "$OD/sphere_64_metallic.png" 64 64 0
check_png "$OA/ring_exif6_upright_albedo.png" 72 48 2     # an RGB picture: no alpha to keep
check_png "$OA/ring_exif6_upright_metallic.png" 72 48 0
for m in albedo roughness metallic; do
    chan_sheet "$T/a_in.png" "$SPHERE:a" && chan_sheet "$T/a_out.png" "$OA/sphere_64_$m.png:a"
    check "image, alpha: the $m map's alpha is the picture's" cmp -s "$T/a_in.png" "$T/a_out.png"
    for c in r g b; do
        [ $m != albedo ] && [ $c != r ] && continue
        chan_sheet "$T/c_keep.png" "$OA/sphere_64_$m.png:$c" && chan_sheet "$T/c_drop.png" "$OD/sphere_64_$m.png:$c"
        check "image, alpha: the $m map's $c channel as with --alpha drop" cmp -s "$T/c_keep.png" "$T/c_drop.png"
    done
done
run image --model "$MODEL" --out "$OF" --float "$SPHERE"
for m in albedo roughness metallic; do
    check "image --float: the same $m PNG (quantised here) as without (quantised by the library)" cmp -s "$OA/sphere_64_$m.png" "$OF/sphere_64_$m.png"
done
check_pfm "$OF/sphere_64_albedo.pfm" 64 64 3
run image --model "$MODEL" --out "$T/alpha_bad" --alpha none "$SPHERE"
check "image --alpha none: exit 2, a message" [ $RC -eq 2 ]
check "image --alpha none: exit 2, a message (2)" grep -q "is not keep or drop" "$T/err"

# ---- --max-memory: refused before allocating, with the sizes in the message --------------------------
run image --model "$MODEL" --max-memory 1M --out "$T/mm1" "$SPHERE"
check "--max-memory below the model: exit 1" [ $RC -eq 1 ]
check "--max-memory below the model: the message" grep -q "the model needs more than max_memory" "$T/err"
absent "$T/mm1/sphere_64_albedo.png"
MB=$(awk '/^model memory/ {print int($3 / 1048576) + 1}' < <("$BIN" info "$MODEL" 2>/dev/null))
run image --model "$MODEL" --max-memory "${MB}M" --out "$T/mm2" "$SPHERE"
check "--max-memory leaving no room for the session: exit 1" [ $RC -eq 1 ]
check "--max-memory leaving no room for the session: the session's size in the message" grep -q "the session for 64x64 (1 view) needs [0-9]* bytes" "$T/err"
check "--max-memory: the message says how it was shared" grep -q "the model holds" "$T/err"
absent "$T/mm2/sphere_64_albedo.png"
run image --model "$MODEL" --max-memory 4G --out "$T/mm3" "$SPHERE"
check "--max-memory 4G: exit 0" [ $RC -eq 0 ]
check_png "$T/mm3/sphere_64_albedo.png" 64 64 6
run image --model "$MODEL" --max-memory lots --out "$T/mm4" "$SPHERE"
check "--max-memory with a bad size: exit 2" [ $RC -eq 2 ]

# ---- --detail and --chroma: the albedo keeps the picture's detail and colour -------------------
# Their defaults are what the model file records: MODEL records none (as an official file), STEPS the same
# network recording the default model's detail 1/64 and colour 1.
STEPS=$T/tiny_steps.safetensors
run convert --from "$MODEL" --detail 1/64 --chroma 1 --out "$STEPS"
check "setup: the tiny model recording detail 1/64 and colour 1" [ $RC -eq 0 ]
# the network's maps alone, to compare with
GT=$T/gt
run image --model "$STEPS" --detail off --chroma off --out "$GT" "$SPHERE"
check "image --detail off --chroma off exits 0" [ $RC -eq 0 ]
run image --model "$MODEL" --out "$T/no_steps" "$SPHERE"
check "image: a model that records no step gets none by default" cmp -s "$T/no_steps/sphere_64_albedo.png" "$GT/sphere_64_albedo.png"
# --detail: the recorded 1/64 changes the albedo only; a value out of range is a usage error
DT=$T/detail_default
run image --model "$STEPS" --chroma off --out "$DT" "$SPHERE"
check "image with the default --detail exits 0" [ $RC -eq 0 ]
check "image: the default --detail changes the albedo" bash -c "! cmp -s '$DT/sphere_64_albedo.png' '$GT/sphere_64_albedo.png'"
check "image: the default --detail leaves roughness and metallic" bash -c "cmp -s '$DT/sphere_64_roughness.png' '$GT/sphere_64_roughness.png' && cmp -s '$DT/sphere_64_metallic.png' '$GT/sphere_64_metallic.png'"
run image --model "$MODEL" --detail 0.015625 --chroma off --out "$T/detail_explicit" "$SPHERE"
check "image --detail 0.015625 = the default" cmp -s "$T/detail_explicit/sphere_64_albedo.png" "$DT/sphere_64_albedo.png"
run image --model "$MODEL" --detail 1/64 --chroma off --out "$T/detail_fraction" "$SPHERE"
check "image --detail 1/64 (a fraction) = --detail 0.015625" cmp -s "$T/detail_fraction/sphere_64_albedo.png" "$DT/sphere_64_albedo.png"
run image --model "$MODEL" --detail 1.5 --out "$T/detail_bad" "$SPHERE"
check "image --detail 1.5 exits 2" [ $RC -eq 2 ]
check "image --detail 1.5 explains" grep -q -- "--detail" "$T/err"
run refine --detail 0.1 --map "$SPHERE" --mask "$SPHERE" --position "$SPHERE" --out "$T/detail_refine"
check "refine --detail exits 2 (a UV map has no picture)" [ $RC -eq 2 ]
# --chroma: image's default (1, after the detail step) changes the albedo only; 0 and off are the same;
# a value out of range is a usage error; views' default is off
CH=$T/chroma_default
run image --model "$STEPS" --out "$CH" "$SPHERE"
check "image with the default --chroma exits 0" [ $RC -eq 0 ]
check "image: the default --chroma changes the albedo" bash -c "! cmp -s '$CH/sphere_64_albedo.png' '$DT/sphere_64_albedo.png'"
check "image: the default --chroma leaves roughness and metallic" bash -c "cmp -s '$CH/sphere_64_roughness.png' '$DT/sphere_64_roughness.png' && cmp -s '$CH/sphere_64_metallic.png' '$DT/sphere_64_metallic.png'"
run image --model "$MODEL" --chroma 1 --detail 0.015625 --out "$T/chroma_explicit" "$SPHERE"
check "image --chroma 1 --detail 0.015625 = the default" cmp -s "$T/chroma_explicit/sphere_64_albedo.png" "$CH/sphere_64_albedo.png"
run image --model "$STEPS" --chroma 0 --out "$T/chroma_zero" "$SPHERE"
check "image --chroma 0 = --chroma off" cmp -s "$T/chroma_zero/sphere_64_albedo.png" "$DT/sphere_64_albedo.png"
run image --model "$STEPS" --chroma 0.5 --out "$T/chroma_half" "$SPHERE"
check "image --chroma 0.5 differs from 0 and 1" bash -c "! cmp -s '$T/chroma_half/sphere_64_albedo.png' '$DT/sphere_64_albedo.png' && ! cmp -s '$T/chroma_half/sphere_64_albedo.png' '$CH/sphere_64_albedo.png'"
for bad in 1.5 -0.1 nan grey; do
    run image --model "$MODEL" --chroma "$bad" --out "$T/chroma_bad" "$SPHERE"
    check "image --chroma $bad exits 2" [ $RC -eq 2 ]
    check "image --chroma $bad explains" grep -q -- "--chroma" "$T/err"
done
check "image --chroma bad: nothing written" bash -c "! ls '$T/chroma_bad'/*.png >/dev/null 2>&1"
run refine --chroma 1 --map "$SPHERE" --mask "$SPHERE" --position "$SPHERE" --out "$T/chroma_refine"
check "refine --chroma exits 2 (a UV map has no picture)" [ $RC -eq 2 ]

# ---- --roughness-curve, --metallic-curve: a map through a calibration curve (pipeline.roughness_curve /
# metallic_curve) ------------------------------------------------------------------------------------------
# convert --from records it (info shows it), image applies the file's by default, --MAP-curve off is the
# network's map, a curve on the command line replaces the file's; every pixel either through the curve (the
# sphere's 2128 pixels of alpha > 0) or unchanged (alpha 0); the other two maps untouched; malformed lists are
# usage errors
# pfm_vals FILE: the floats of a 64x64 gray PFM, one a line
pfm_vals() { tail -c +15 "$1" | od -An -v -f | tr -s ' ' '\n' | sed '/^$/d'; }
setup_tiny_uv
for map in roughness metallic; do
    other=metallic; [ $map = metallic ] && other=roughness
    RCM=$T/tiny_${map}_curve.safetensors
    run convert --from "$MODEL" --$map-curve 0.1,0.9 --out "$RCM"
    check "convert --from --$map-curve 0.1,0.9 exits 0" [ $RC -eq 0 ]
    run info "$RCM"
    check "info shows the recorded $map curve" grep -Eq "^$map +through the curve 0.1,0.9 " "$T/out"
    check "info: the $other map without a curve says the network's" grep -Eq "^$other +the network's" "$T/out"
    run info "$MODEL"
    check "info: a file without a $map curve says the network's" grep -Eq "^$map +the network's" "$T/out"
    run image --model "$RCM" --float --out "$T/${map}_on" "$SPHERE"
    check "image with the file's $map curve exits 0" [ $RC -eq 0 ]
    run image --model "$RCM" --$map-curve off --float --out "$T/${map}_off" "$SPHERE"
    check "image --$map-curve off exits 0" [ $RC -eq 0 ]
    run image --model "$MODEL" --$map-curve 0.1,0.9 --float --out "$T/${map}_cli" "$SPHERE"
    check "image --$map-curve 0.1,0.9 on a file without one exits 0" [ $RC -eq 0 ]
    check "image: the command line's $map curve = the file's" cmp -s "$T/${map}_cli/sphere_64_$map.pfm" "$T/${map}_on/sphere_64_$map.pfm"
    check "image --$map-curve off: albedo and $other as with the curve" \
        bash -c "cmp -s '$T/${map}_on/sphere_64_albedo.png' '$T/${map}_off/sphere_64_albedo.png' && cmp -s '$T/${map}_on/sphere_64_$other.pfm' '$T/${map}_off/sphere_64_$other.pfm'"
    through=$(paste <(pfm_vals "$T/${map}_on/sphere_64_$map.pfm") <(pfm_vals "$T/${map}_off/sphere_64_$map.pfm") |
        awk '{ x = $2 < 0 ? 0 : $2 > 1 ? 1 : $2; w = 0.1 + 0.8 * x; c = ($1 - w) < 1e-6 && (w - $1) < 1e-6; u = $1 == $2
               if (c) n++; if (!c && !u) other++ } END { printf "%d %d %d\n", NR, n, other }')
    check "image: every $map value through 0.1 + 0.8 x (within 1e-6) or unchanged, >= 2128 through it (4096 total, 0 other): $through" \
        awk -v t="$through" 'BEGIN { split(t, a, " "); exit !(a[1] == 4096 && a[2] >= 2128 && a[3] == 0) }'
    for bad in 0.5 0.6,0.4 0,x 0,1.5 nan,1 "0;1" off,1; do
        run image --model "$MODEL" --$map-curve "$bad" --out "$T/${map}_bad" "$SPHERE"
        check "image --$map-curve $bad exits 2" [ $RC -eq 2 ]
        check "image --$map-curve $bad explains" grep -q -- "--$map-curve" "$T/err"
    done
    check "image --$map-curve bad: nothing written" bash -c "! ls '$T/${map}_bad'/*.png >/dev/null 2>&1"
    run convert --from "$MODEL" --$map-curve 0.9,0.1 --out "$T/never.safetensors"
    check "convert --from --$map-curve 0.9,0.1 (falling) exits 2" [ $RC -eq 2 ]
    run convert --from "$RCM" --$map-curve off --out "$T/tiny_${map}_curve_off.safetensors"
    check "convert --from --$map-curve off exits 0" [ $RC -eq 0 ]
    run info "$T/tiny_${map}_curve_off.safetensors"
    check "convert --from --$map-curve off: the key removed" grep -Eq "^$map +the network's" "$T/out"
    check "convert --from --$map-curve off: the header keeps its length" [ "$(stat -c %s "$T/tiny_${map}_curve_off.safetensors")" = "$(stat -c %s "$RCM")" ]
    run convert --from "$UV" --$map-curve 0,1 --out "$T/never.safetensors"
    check "convert --from a uv-refine file --$map-curve exits 1 (no $map map)" [ $RC -eq 1 ]
    check "convert --from a uv-refine file --$map-curve: nothing written" [ ! -e "$T/never.safetensors" ]
done
# both curves in one file, through one conversion; each map through its own
run convert --from "$MODEL" --roughness-curve 0.1,0.9 --metallic-curve 0,0.5 --out "$T/tiny_both_curves.safetensors"
check "convert --from with both curves exits 0" [ $RC -eq 0 ]
run image --model "$T/tiny_both_curves.safetensors" --float --out "$T/both_on" "$SPHERE"
check "image with both curves exits 0" [ $RC -eq 0 ]
check "image with both curves: the roughness as with the roughness curve alone" cmp -s "$T/both_on/sphere_64_roughness.pfm" "$T/roughness_on/sphere_64_roughness.pfm"
run image --model "$MODEL" --metallic-curve 0,0.5 --float --out "$T/both_m" "$SPHERE"
check "image with both curves: the metallic as --metallic-curve 0,0.5 alone" cmp -s "$T/both_on/sphere_64_metallic.pfm" "$T/both_m/sphere_64_metallic.pfm"

summary
