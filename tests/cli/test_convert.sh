#!/usr/bin/env bash
# tests/cli/test_convert.sh - `supermat convert`: the tiny official-format checkpoints into model files.
#
#   bash tests/cli/test_convert.sh BUILD/supermat tests/data
#
# Converts the tiny checkpoint (kind given and detected; f32, --dtype f16, --precision int8 and --weights int8,
# which write the same file) and its refusals: a missing output folder (exit 1 before reading the base folder,
# nothing created), a bad --weights (exit 2), a missing checkpoint (exit 1, nothing written). --work-size
# recorded (128; 100 exits 2). `convert --from`: another work size written into a converted file (the header
# kept at its length or grown by 64 bytes, the tensor bytes the original's, the maps those of --work-size on
# the original), the default model's work size in image/bench --help, and its refusals (no --work-size,
# checkpoint options, onto itself, over a file, a cut file, a checkpoint). --detail / --chroma: recorded only when on
# (off: the official file byte for byte), 1/64 and 0.5 read, out of range a usage error, refused for uv-refine;
# `convert --from` with each subset of --work-size, --detail, --chroma changes just those keys (off removes one),
# the tensor bytes kept. --bake-detail (pipeline.bake_detail_sigma, the detail step `mesh` bakes with): the same
# checks (recorded only when on, read back by `info`, off removes it, refused for uv-refine and out of range,
# --from with it alone and with the others, the tensors byte for byte). --weights: what `info` reports and
# `image` runs for the f16 and int8 files and --weights int8 / bf16 / q4 (exit 2).
# (convert --packed is in test_pack.sh, the multi-view and UV-refine kinds in test_views.sh / test_refine.sh.)
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# ---- convert ----------------------------------------------------------------------------------
# the models most checks use record no work size (--work-size native): the pictures run at their own
# size, as the goldens were made; the preprocessing checks (test_image.sh) use one with the official 512
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$MODEL" --work-size native
check "convert exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "convert writes the model" [ -s "$MODEL" ]
absent "$MODEL.tmp"
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_f16.safetensors" --dtype f16
check "convert --dtype f16 (kind detected) exits 0" [ $RC -eq 0 ]
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_i8.safetensors" --precision int8
check "convert --precision int8 exits 0" [ $RC -eq 0 ]
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/no_such_dir/x.safetensors"
check "convert into a missing folder exits 1" [ $RC -eq 1 ]
check "convert into a missing folder names it" grep -q "no_such_dir" "$T/err"
check "convert into a missing folder fails before reading the base folder" bash -c "! grep -q 'text_encoder' '$T/err'"
absent "$T/no_such_dir"
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_i8w.safetensors" --weights int8
check "convert --weights int8 exits 0" [ $RC -eq 0 ]
check "convert --weights int8 writes what --precision int8 (its old spelling) writes" cmp -s "$T/tiny_i8.safetensors" "$T/tiny_i8w.safetensors"
run convert --unet x.pth --base x --out y --weights f8
check "convert bad --weights exits 2" [ $RC -eq 2 ]
check "convert bad --weights: its message names --weights" grep -q -- "--weights: 'f8'" "$T/err"
run convert --unet "$T/missing.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors"
check "convert of a missing checkpoint exits 1" [ $RC -eq 1 ]
check "convert error names the file" grep -q 'missing.pth' "$T/err"
absent "$T/never.safetensors"

# ---- --work-size recorded; convert --from: another work size in a converted file -------------
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_ws128.safetensors" --work-size 128
check "convert --work-size 128 exits 0" [ $RC -eq 0 ]
run info "$T/tiny_ws128.safetensors"
check "info: --work-size 128 recorded" grep -Eq '^work size +128x128' "$T/out"
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors" --work-size 100
check "convert --work-size 100 exits 2" [ $RC -eq 2 ]
# convert --from: an already converted file with another work size, the tensors byte for byte
run convert --from "$T/tiny_ws128.safetensors" --work-size 64 --out "$T/tiny_ws64.safetensors"
check "convert --from --work-size 64 exits 0" [ $RC -eq 0 ]
absent "$T/tiny_ws64.safetensors.tmp"
# --help states the work size of the default model actually found (one source of truth: the file)
run_env SUPERMAT_MODEL="$T/tiny_ws64.safetensors" -- image --help
check "image --help names the default model used and its work size, 64x64" grep -q "used: $T/tiny_ws64.safetensors, work size 64x64" "$T/out"
run_env SUPERMAT_MODEL="$T/tiny_ws128.safetensors" -- bench --help
check "bench --help: the work size of the model used, 128x128" grep -q "used: $T/tiny_ws128.safetensors, work size 128x128" "$T/out"
run info "$T/tiny_ws64.safetensors"
check "convert --from: --work-size 64 recorded" grep -Eq '^work size +64x64' "$T/out"
check "convert --from: the same size (the header padded back to its length)" [ "$(stat -c %s "$T/tiny_ws64.safetensors")" = "$(stat -c %s "$T/tiny_ws128.safetensors")" ]
HL=$(od -An -tu8 -N8 "$T/tiny_ws128.safetensors" | tr -d ' ')
check "convert --from: the tensor bytes after the header are the original's" \
    cmp -s <(tail -c +$((HL + 9)) "$T/tiny_ws128.safetensors") <(tail -c +$((HL + 9)) "$T/tiny_ws64.safetensors")
check "convert --from: the header differs (the value)" bash -c "! cmp -s '$T/tiny_ws128.safetensors' '$T/tiny_ws64.safetensors'"
run image --model "$T/tiny_ws64.safetensors" --out "$T/from64" --float "$SPHERE"
run image --model "$T/tiny_ws128.safetensors" --out "$T/from64b" --float --work-size 64 "$SPHERE"
check "convert --from: its default work size gives the maps of --work-size 64 on the original" \
    cmp -s "$T/from64/sphere_64_albedo.pfm" "$T/from64b/sphere_64_albedo.pfm"
run convert --from "$T/tiny_ws64.safetensors" --work-size 16384 --out "$T/tiny_ws16k.safetensors"
check "convert --from: a longer value exits 0" [ $RC -eq 0 ]
D16K=$(( $(stat -c %s "$T/tiny_ws16k.safetensors") - $(stat -c %s "$T/tiny_ws64.safetensors") ))
check "convert --from: a longer value keeps the header's length (in its padding) or grows it by 64 bytes, not $D16K" \
    [ "$D16K" -eq 0 -o "$D16K" -eq 64 ]
run info "$T/tiny_ws16k.safetensors"
check "convert --from: --work-size 16384 recorded" grep -Eq '^work size +16384x16384' "$T/out"
run convert --from "$T/tiny_ws16k.safetensors" --work-size native --out "$T/tiny_wsnone.safetensors"
run info "$T/tiny_wsnone.safetensors"
check "convert --from --work-size native records none" grep -Eq '^work size +none' "$T/out"
run convert --from "$T/tiny_ws64.safetensors" --out "$T/never.safetensors"
check "convert --from without --work-size exits 2" [ $RC -eq 2 ]
run convert --from "$T/tiny_ws64.safetensors" --work-size 64 --dtype f16 --out "$T/never.safetensors"
check "convert --from with --dtype exits 2" [ $RC -eq 2 ]
run convert --from "$T/tiny_ws64.safetensors" --work-size 64 --out "$T/tiny_ws64.safetensors"
check "convert --from onto itself exits 1" [ $RC -eq 1 ]
run convert --from "$T/tiny_ws64.safetensors" --work-size 32 --out "$T/tiny_ws128.safetensors"
check "convert --from over an existing file exits 1" [ $RC -eq 1 ]
run info "$T/tiny_ws128.safetensors"
check "convert --from over an existing file: kept as it was" grep -Eq '^work size +128x128' "$T/out"
head -c 4096 "$T/tiny_ws64.safetensors" > "$T/cut.safetensors"
run convert --from "$T/cut.safetensors" --work-size 64 --out "$T/never.safetensors"
check "convert --from a cut file exits 1" [ $RC -eq 1 ]
check "convert --from a cut file: the message names it" grep -q "cut.safetensors" "$T/err"
run convert --from "$DATA/tiny/supermat.pth" --work-size 64 --out "$T/never.safetensors"
check "convert --from a checkpoint (not a model file) exits 1" [ $RC -eq 1 ]
absent "$T/never.safetensors"
absent "$T/never.safetensors.tmp"

# ---- --detail / --chroma recorded; convert --from with any of --work-size, --detail, --chroma ------
# hdr FILE: the header's JSON less its padding; meta FILE KEY: a metadata value, empty when absent
hdr() { tail -c +9 "$1" | head -c "$(od -An -tu8 -N8 "$1" | tr -d ' ')" | sed 's/ *$//'; }
meta() { hdr "$1" | grep -o "\"$2\":\"[^\"]*\"" | head -n 1 | sed 's/^.*:"\(.*\)"$/\1/'; }
tensors() { tail -c +$(($(od -An -tu8 -N8 "$1" | tr -d ' ') + 9)) "$1"; }
DS='"pipeline.detail_sigma"'
CW='"pipeline.chroma_weight"'
check "an official conversion records no detail step" bash -c "! grep -q 'pipeline.detail_sigma' <(tail -c +9 '$MODEL' | head -c 100000)"
check "an official conversion records no colour step" bash -c "! grep -q 'pipeline.chroma_weight' <(tail -c +9 '$MODEL' | head -c 100000)"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_off.safetensors" --work-size native --detail off --chroma off
check "convert --detail off --chroma off exits 0" [ $RC -eq 0 ]
check "convert --detail off --chroma off writes the file written without them, byte for byte" cmp -s "$MODEL" "$T/tiny_off.safetensors"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_dc.safetensors" --work-size native --detail 1/64 --chroma 1
check "convert --detail 1/64 --chroma 1 exits 0" [ $RC -eq 0 ]
check "convert --detail 1/64 records pipeline.detail_sigma 0.015625" [ "$(meta "$T/tiny_dc.safetensors" pipeline.detail_sigma)" = 0.015625 ]
check "convert --chroma 1 records pipeline.chroma_weight 1" [ "$(meta "$T/tiny_dc.safetensors" pipeline.chroma_weight)" = 1 ]
check "convert --detail --chroma: the header is the official one with the two keys after the work size" \
    [ "$(hdr "$T/tiny_dc.safetensors")" = "$(hdr "$MODEL" | sed "s/\"pipeline.work_size\":\"0\"/&,$DS:\"0.015625\",$CW:\"1\"/")" ]
check "convert --detail --chroma: the tensor bytes the official conversion's" cmp -s <(tensors "$MODEL") <(tensors "$T/tiny_dc.safetensors")
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_d05.safetensors" --detail 0.5
check "convert --detail 0.5 (no --chroma): 0.5 recorded, no colour step" \
    [ "$(meta "$T/tiny_d05.safetensors" pipeline.detail_sigma),$(meta "$T/tiny_d05.safetensors" pipeline.chroma_weight)" = "0.5," ]
for opt in --detail --chroma; do
    for bad in 2 -1 abc 1/0 ''; do
        run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors" $opt "$bad"
        check "convert $opt '$bad' exits 2" [ $RC -eq 2 ]
        check "convert $opt '$bad': the message names the option and the value" grep -q -- "$opt: 'off' or .* from 0 to 1 (0.5, 1/64), not '$bad'" "$T/err"
        run convert --from "$T/tiny_dc.safetensors" --out "$T/never.safetensors" $opt "$bad"
        check "convert --from $opt '$bad' exits 2" [ $RC -eq 2 ]
    done
done
run convert --kind uv-refine --unet "$DATA/tiny/uv_refine_bc.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors" --chroma 1
check "convert --kind uv-refine --chroma 1 exits 2 (no input picture)" [ $RC -eq 2 ]
check "convert --kind uv-refine --chroma 1: the message says why" grep -q "uv-refine model has no input picture" "$T/err"
run convert --unet "$DATA/tiny/uv_refine_bc.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors" --detail 1/64
check "convert of a uv-refine checkpoint (kind detected) with --detail exits 1" [ $RC -eq 1 ]
check "convert of a uv-refine checkpoint with --detail: the message says why" grep -q "uv-refine model has no input picture" "$T/err"
absent "$T/never.safetensors"
# --from: each subset changes just its keys, the tensors byte for byte
run convert --from "$MODEL" --detail 1/64 --chroma 1 --out "$T/from_dc.safetensors"
check "convert --from --detail 1/64 --chroma 1 exits 0" [ $RC -eq 0 ]
check "convert --from --detail --chroma: says what it set" grep -q "with detail 0.015625, colour 1$" "$T/out"
check "convert --from --detail --chroma: the header a conversion with them writes" [ "$(hdr "$T/from_dc.safetensors")" = "$(hdr "$T/tiny_dc.safetensors")" ]
check "convert --from --detail --chroma: the tensor bytes the original's" cmp -s <(tensors "$MODEL") <(tensors "$T/from_dc.safetensors")
run convert --from "$T/tiny_dc.safetensors" --detail off --chroma off --out "$T/from_off.safetensors"
check "convert --from --detail off --chroma off exits 0" [ $RC -eq 0 ]
check "convert --from --detail off --chroma off: the official header (both keys removed)" [ "$(hdr "$T/from_off.safetensors")" = "$(hdr "$MODEL")" ]
check "convert --from --detail off --chroma off: the size kept (the header padded)" [ "$(stat -c %s "$T/from_off.safetensors")" = "$(stat -c %s "$T/tiny_dc.safetensors")" ]
run convert --from "$T/tiny_dc.safetensors" --detail off --out "$T/from_d0.safetensors"
check "convert --from --detail off: only the detail key removed" \
    [ "$(hdr "$T/from_d0.safetensors")" = "$(hdr "$T/tiny_dc.safetensors" | sed "s/,$DS:\"0.015625\"//")" ]
check "convert --from --detail off: says so" grep -q "with detail off$" "$T/out"
run convert --from "$T/tiny_dc.safetensors" --chroma 0.5 --out "$T/from_c05.safetensors"
check "convert --from --chroma 0.5: only the colour value changed" \
    [ "$(hdr "$T/from_c05.safetensors")" = "$(hdr "$T/tiny_dc.safetensors" | sed "s/$CW:\"1\"/$CW:\"0.5\"/")" ]
run convert --from "$T/tiny_dc.safetensors" --work-size 64 --out "$T/from_w64.safetensors"
check "convert --from --work-size 64: only the work size changed (the steps kept)" \
    [ "$(hdr "$T/from_w64.safetensors")" = "$(hdr "$T/tiny_dc.safetensors" | sed 's/"pipeline.work_size":"0"/"pipeline.work_size":"64"/')" ]
run convert --from "$T/tiny_dc.safetensors" --work-size 64 --detail 0.25 --chroma off --out "$T/from_all.safetensors"
check "convert --from with all three exits 0" [ $RC -eq 0 ]
check "convert --from with all three: each changed" \
    [ "$(hdr "$T/from_all.safetensors")" = "$(hdr "$T/tiny_dc.safetensors" | sed "s/\"pipeline.work_size\":\"0\"/\"pipeline.work_size\":\"64\"/; s/$DS:\"0.015625\"/$DS:\"0.25\"/; s/,$CW:\"1\"//")" ]
check "convert --from with all three: says what it set" grep -q "with work size 64x64, detail 0.25, colour off$" "$T/out"
check "convert --from with all three: the tensor bytes the original's" cmp -s <(tensors "$T/tiny_dc.safetensors") <(tensors "$T/from_all.safetensors")
run convert --from "$T/tiny_dc.safetensors" --out "$T/never.safetensors"
check "convert --from with none of --work-size, --detail, --chroma, --bake-detail, --roughness-curve, --metallic-curve exits 2" [ $RC -eq 2 ]
check "convert --from with none of the pipeline options: the message names them" \
    grep -q -- "--from needs --work-size N|native, --detail F|off, --chroma W|off, --bake-detail F|off, --roughness-curve LIST|off or --metallic-curve LIST|off" "$T/err"
run convert --kind uv-refine --unet "$DATA/tiny/uv_refine_bc.pth" --base "$DATA/tiny/base" --out "$T/tiny_uv.safetensors" --work-size native
run convert --from "$T/tiny_uv.safetensors" --detail 1/64 --out "$T/never.safetensors"
check "convert --from a uv-refine file --detail 1/64 exits 1" [ $RC -eq 1 ]
check "convert --from a uv-refine file --detail: the message says why" grep -q "uv-refine model has no input picture" "$T/err"
absent "$T/never.safetensors"

# ---- --bake-detail: pipeline.bake_detail_sigma, the detail step `mesh` bakes with -------------------
BD='"pipeline.bake_detail_sigma"'
check "an official conversion records no bake detail step" bash -c "! grep -q 'pipeline.bake_detail_sigma' <(tail -c +9 '$MODEL' | head -c 100000)"
run info "$MODEL"
check "info: no bake detail recorded says none" grep -Eq '^bake detail +none' "$T/out"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_b0.safetensors" --work-size native --bake-detail off
check "convert --bake-detail off exits 0" [ $RC -eq 0 ]
check "convert --bake-detail off writes the file written without it, byte for byte" cmp -s "$MODEL" "$T/tiny_b0.safetensors"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_b.safetensors" --work-size native --bake-detail 1/32
check "convert --bake-detail 1/32 exits 0" [ $RC -eq 0 ]
check "convert --bake-detail 1/32 records pipeline.bake_detail_sigma 0.03125" [ "$(meta "$T/tiny_b.safetensors" pipeline.bake_detail_sigma)" = 0.03125 ]
check "convert --bake-detail: the header is the official one with the key after the work size" \
    [ "$(hdr "$T/tiny_b.safetensors")" = "$(hdr "$MODEL" | sed "s/\"pipeline.work_size\":\"0\"/&,$BD:\"0.03125\"/")" ]
check "convert --bake-detail: the tensor bytes the official conversion's" cmp -s <(tensors "$MODEL") <(tensors "$T/tiny_b.safetensors")
run info "$T/tiny_b.safetensors"
check "info reads the bake detail back" grep -Eq "^bake detail +0.03125 of the texture's larger side" "$T/out"
check "info: the bake detail is not the picture's detail step" grep -Eq '^detail +none' "$T/out"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_dcb.safetensors" --work-size native --detail 1/64 --chroma 1 --bake-detail 1/32
check "convert --detail --chroma --bake-detail: the three keys in the converter's order" \
    [ "$(hdr "$T/tiny_dcb.safetensors")" = "$(hdr "$MODEL" | sed "s/\"pipeline.work_size\":\"0\"/&,$DS:\"0.015625\",$CW:\"1\",$BD:\"0.03125\"/")" ]
for bad in 2 -1 abc 1/0 ''; do
    run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors" --bake-detail "$bad"
    check "convert --bake-detail '$bad' exits 2" [ $RC -eq 2 ]
    check "convert --bake-detail '$bad': the message names the option and the value" grep -q -- "--bake-detail: 'off' or .* from 0 to 1 (0.5, 1/64), not '$bad'" "$T/err"
    run convert --from "$T/tiny_b.safetensors" --out "$T/never.safetensors" --bake-detail "$bad"
    check "convert --from --bake-detail '$bad' exits 2" [ $RC -eq 2 ]
done
run convert --kind uv-refine --unet "$DATA/tiny/uv_refine_bc.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors" --bake-detail 1/32
check "convert --kind uv-refine --bake-detail 1/32 exits 2" [ $RC -eq 2 ]
check "convert --kind uv-refine --bake-detail: the message says why" grep -q "uv-refine model has no input picture for the bake detail step" "$T/err"
run convert --unet "$DATA/tiny/uv_refine_bc.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors" --bake-detail 1/32
check "convert of a uv-refine checkpoint (kind detected) with --bake-detail exits 1" [ $RC -eq 1 ]
check "convert of a uv-refine checkpoint with --bake-detail: the message names the key" grep -q "pipeline.bake_detail_sigma: a uv-refine model" "$T/err"
run convert --from "$T/tiny_uv.safetensors" --bake-detail 1/32 --out "$T/never.safetensors"
check "convert --from a uv-refine file --bake-detail 1/32 exits 1" [ $RC -eq 1 ]
check "convert --from a uv-refine file --bake-detail: the message says why" grep -q "uv-refine model has no input picture" "$T/err"
run info "$T/tiny_uv.safetensors"
check "info on a uv-refine file: no bake detail line" bash -c "! grep -q '^bake detail' '$T/out'"
absent "$T/never.safetensors"
# --from: alone, with the others, off; the tensors byte for byte
run convert --from "$MODEL" --bake-detail 1/32 --out "$T/from_b.safetensors"
check "convert --from --bake-detail 1/32 exits 0" [ $RC -eq 0 ]
check "convert --from --bake-detail: says what it set" grep -q "with bake detail 0.03125$" "$T/out"
check "convert --from --bake-detail: the header a conversion with it writes" [ "$(hdr "$T/from_b.safetensors")" = "$(hdr "$T/tiny_b.safetensors")" ]
check "convert --from --bake-detail: the tensor bytes the original's" cmp -s <(tensors "$MODEL") <(tensors "$T/from_b.safetensors")
run convert --from "$T/tiny_dc.safetensors" --bake-detail 1/32 --out "$T/from_dcb.safetensors"
check "convert --from --bake-detail on a file with both steps: after the colour key" [ "$(hdr "$T/from_dcb.safetensors")" = "$(hdr "$T/tiny_dcb.safetensors")" ]
run convert --from "$T/tiny_dcb.safetensors" --bake-detail off --out "$T/from_b0.safetensors"
check "convert --from --bake-detail off exits 0" [ $RC -eq 0 ]
check "convert --from --bake-detail off: only the bake detail key removed" [ "$(hdr "$T/from_b0.safetensors")" = "$(hdr "$T/tiny_dc.safetensors")" ]
check "convert --from --bake-detail off: says so" grep -q "with bake detail off$" "$T/out"
run info "$T/from_b0.safetensors"
check "info after --bake-detail off: none" grep -Eq '^bake detail +none' "$T/out"
run convert --from "$T/tiny_dcb.safetensors" --detail off --out "$T/from_d0b.safetensors"
check "convert --from --detail off: the bake detail kept" \
    [ "$(hdr "$T/from_d0b.safetensors")" = "$(hdr "$T/tiny_dcb.safetensors" | sed "s/,$DS:\"0.015625\"//")" ]
run convert --from "$T/tiny_dcb.safetensors" --work-size 64 --detail 0.25 --chroma off --bake-detail 0.5 --out "$T/from_all4.safetensors"
check "convert --from with all four exits 0" [ $RC -eq 0 ]
check "convert --from with all four: each changed" \
    [ "$(hdr "$T/from_all4.safetensors")" = "$(hdr "$T/tiny_dcb.safetensors" | sed "s/\"pipeline.work_size\":\"0\"/\"pipeline.work_size\":\"64\"/; s/$DS:\"0.015625\"/$DS:\"0.25\"/; s/,$CW:\"1\"//; s/$BD:\"0.03125\"/$BD:\"0.5\"/")" ]
check "convert --from with all four: says what it set" grep -q "with work size 64x64, detail 0.25, colour off, bake detail 0.5$" "$T/out"
check "convert --from with all four: the tensor bytes the original's" cmp -s <(tensors "$T/tiny_dcb.safetensors") <(tensors "$T/from_all4.safetensors")
run convert --from "$T/tiny_b.safetensors" --work-size 64 --chroma 1 --out "$T/from_wcb.safetensors"
check "convert --from --work-size --chroma on a file with a bake detail: the colour between detail's place and the bake detail" \
    [ "$(hdr "$T/from_wcb.safetensors")" = "$(hdr "$T/tiny_b.safetensors" | sed "s/\"pipeline.work_size\":\"0\"/\"pipeline.work_size\":\"64\",$CW:\"1\"/")" ]

# ---- --weights (GEMM weight storage) ----------------------------------------------------------
run info --weights int8 "$MODEL"
check "info --weights int8 exits 0" [ $RC -eq 0 ]
check "info --weights int8 reports int8" grep -Eq '^weights +int8' "$T/out"
run info "$T/tiny_f16.safetensors"
check "an f16 file is held as f16 by default" grep -Eq '^weights +f16' "$T/out"
run info "$T/tiny_i8.safetensors"
check "an int8 file is held as int8 by default" grep -Eq '^weights +int8' "$T/out"
check "info int8: I8 tensors" grep -Eq 'I8: [0-9]+ tensors' "$T/out"
run image --model "$T/tiny_i8.safetensors" --out "$T/w_i8" "$DATA/img/sphere_64.png"
check "image with the int8 file exits 0" [ $RC -eq 0 ]
check_png "$T/w_i8/sphere_64_albedo.png" 64 64 6
run image --weights bf16 --model "$MODEL" --out "$T/w_bf16" "$DATA/img/sphere_64.png"
check "image --weights bf16 exits 0" [ $RC -eq 0 ]
check_png "$T/w_bf16/sphere_64_albedo.png" 64 64 6
run image --weights q4 --model "$MODEL" --out "$T/w_bad" "$DATA/img/sphere_64.png"
check "--weights q4 exits 2" [ $RC -eq 2 ]

summary
