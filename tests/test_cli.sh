#!/usr/bin/env bash
# tests/test_cli.sh - end-to-end test of the `supermat` command-line tool.
#
#   tests/test_cli.sh BUILD/supermat tests/data
#
# Converts the tiny official-format checkpoint, runs `info`, runs `image` on two test images (square and
# non-square) with and without --float, and checks file names, PNG sizes and colour types (IHDR bytes
# read with od), PFM headers and sizes, that --outputs limits what is written, that threads do not
# change the bits, and that bad input (an image that is not a multiple of 8, a missing model, bad
# options) fails with a message and the documented exit code.
# The default model (no --model): SUPERMAT_MODEL naming the tiny model is used by image, info and bench,
# naming a missing file is an error naming it, a copy of the tool in PREFIX/bin finds
# PREFIX/share/supermat/supermat_default.safetensors, and without any the message lists the places
# (SUPERMAT_MODEL is removed from the environment of every other run). `sheet`: the PNG size of a
# 2-row sheet with labels and of one without, and its errors (a missing input: exit 1, nothing written,
# an older sheet untouched; bad rows, --cell and --labels: exit 2). A PNG write that fails (a file size
# limit) exits 1 and leaves no file, for `sheet` and `image`. The overwrite policy: existing outputs
# (files, live and dangling symbolic links) refused before any work, --skip-existing, --force (a link is
# replaced, its target untouched), `convert` likewise. `convert --from`: another work size written into a
# converted file (plain and pre-packed; the header kept at its length or grown by 64 bytes, the maps those of
# --work-size on the original), and its refusals (no --work-size, checkpoint options, onto itself, over a
# file, a cut file, a checkpoint).
# Then the same for the multi-view and UV-refine models: converts both, runs `views` (6 views, 3 views,
# one view with a numeric index and a flat matrix) and `refine`, compares their --float maps with the
# official goldens (max abs error 1e-4, tests/pfm_npy_diff.c built with ${CC:-cc}), checks the camera
# file errors (missing index, malformed JSON, duplicate index, short / non-numeric / non-finite /
# missing matrix), size mismatches, a model of the wrong kind for each command, and `bench` on all
# three kinds; `bench --image` (the speed / accuracy table: its JSON parsed by a small awk parser, the
# f32 reference at 200 dB, f16 finite and below, a map a mode does not compute as null) and its usage
# errors; bench --image against ground truth (--truth-albedo/-roughness/-metallic: `image`'s own PNGs as
# the truth give the f32 row 200 dB, a map a mode skips or without truth null; a truth of the wrong
# size, colour type or model kind exits 1 with a message and writes no JSON; without --image exits 2).
# Needs bash, coreutils, od, awk and a C compiler (without one the golden comparison is skipped).
set -eu

if [ $# -ne 2 ]; then
    echo "usage: $0 PATH/TO/supermat TESTS_DATA_DIR" >&2
    exit 2
fi
BIN=$1
DATA=$2
T=$(mktemp -d "${TMPDIR:-/tmp}/supermat_cli.XXXXXX")
trap 'rm -rf "$T"' EXIT

PASS=0
FAIL=0
ok() { PASS=$((PASS + 1)); }
bad() { FAIL=$((FAIL + 1)); echo "FAIL: $*"; }
check() { # check "description" command...
    local what=$1
    shift
    if "$@"; then ok; else bad "$what"; fi
}

# runs the tool, keeping stdout, stderr and the exit code; a sanitizer report (ASan exits 1 too, like
# an expected error) is a failure of its own. SUPERMAT_MODEL (the default model) is removed from the
# environment: only run_env sets it.
run() { run_env -- "$@"; }
# run_env [VAR=VALUE...] -- ARGS: the same with these variables set
run_env() {
    local vars=()
    while [ "$1" != "--" ]; do vars+=("$1"); shift; done
    shift
    set +e
    env -u SUPERMAT_MODEL ${vars[@]+"${vars[@]}"} "$BIN" "$@" >"$T/out" 2>"$T/err"
    RC=$?
    set -e
    if grep -Eq 'Sanitizer|runtime error:' "$T/err"; then
        bad "sanitizer report from: supermat $*"
        cat "$T/err"
    fi
}

# PNG width, height, bit depth, colour type from the IHDR chunk (bytes 16..25)
png_ihdr() {
    local b
    read -r -a b <<<"$(od -An -v -tu1 -j16 -N10 "$1")"
    [ ${#b[@]} -eq 10 ] || { echo "0 0 0 0"; return; }
    echo "$(((b[0] << 24) | (b[1] << 16) | (b[2] << 8) | b[3])) $(((b[4] << 24) | (b[5] << 16) | (b[6] << 8) | b[7])) ${b[8]} ${b[9]}"
}
is_png() { [ "$(od -An -v -tx1 -N8 "$1" | tr -d ' \n')" = "89504e470d0a1a0a" ]; }
# check_png FILE W H COLOURTYPE (0 gray, 2 RGB)
check_png() {
    if [ ! -f "$1" ]; then bad "$1 missing"; return; fi
    if ! is_png "$1"; then bad "$1 is not a PNG"; return; fi
    local got
    got=$(png_ihdr "$1")
    if [ "$got" = "$2 $3 8 $4" ]; then ok; else bad "$1: IHDR '$got', expected '$2 $3 8 $4'"; fi
}
# check_pfm FILE W H CHANNELS
check_pfm() {
    if [ ! -f "$1" ]; then bad "$1 missing"; return; fi
    local magic=Pf hdr size want
    [ "$4" -eq 3 ] && magic=PF
    hdr=$(head -n 3 "$1" | tr '\n' '|')
    if [ "$hdr" = "$magic|$2 $3|-1.0|" ]; then ok; else bad "$1: header '$hdr', expected '$magic|$2 $3|-1.0|'"; fi
    size=$(wc -c <"$1")
    want=$((${#magic} + 1 + ${#2} + 1 + ${#3} + 1 + 5 + $2 * $3 * $4 * 4))
    if [ "$size" -eq "$want" ]; then ok; else bad "$1: $size bytes, expected $want"; fi
}
absent() { if [ -e "$1" ]; then bad "$1 should not exist"; else ok; fi; }

SPHERE=$DATA/img/sphere_64.png   # 64 x 64
RING=$DATA/img/ring_48x72.png    # 72 wide, 48 high
MODEL=$T/tiny.safetensors

# ---- help, version, usage errors ----------------------------------------------------------------
run --version
check "--version exits 0" [ $RC -eq 0 ]
check "--version prints the version" grep -Eq '^supermat [0-9]+\.[0-9]+\.[0-9]+$' "$T/out"
run --help
check "--help exits 0" [ $RC -eq 0 ]
check "--help lists the commands" grep -q 'convert' "$T/out"
for c in convert image views refine info bench sheet; do
    run "$c" --help
    check "$c --help exits 0" [ $RC -eq 0 ]
    check "$c --help prints usage" grep -q "usage: supermat $c" "$T/out"
done
run image --help
check "image --help states the preprocessing (work size, --native)" grep -q 'resized to the model.s work size' "$T/out"
check "image --help says multiples of 8" grep -q 'multiples of 8' "$T/out"
check "image --help: the default model's search order" grep -q 'SUPERMAT_MODEL' "$T/out"
check "image --help: the installed default model" grep -q 'share/supermat/supermat_default.safetensors' "$T/out"
check "image --help: the source tree's default model" grep -q 'models/supermat_default.safetensors' "$T/out"
run
check "no command exits 2" [ $RC -eq 2 ]
run frobnicate
check "unknown command exits 2" [ $RC -eq 2 ]
run image --model x --out "$T/o" --no-such-option "$SPHERE"
check "unknown option exits 2" [ $RC -eq 2 ]
check "unknown option is named" grep -q 'no-such-option' "$T/err"
run image --model x "$SPHERE"
check "image without --out exits 2" [ $RC -eq 2 ]
run views --cameras x --out "$T/o" "$SPHERE"
check "views without --model exits 2 (no default model for views)" [ $RC -eq 2 ]
run image --model x --out "$T/o" --outputs albedo,shininess "$SPHERE"
check "bad --outputs exits 2" [ $RC -eq 2 ]
run image --model x --out "$T/o" --threads
check "option without value exits 2" [ $RC -eq 2 ]
run bench --model x --size 30
check "bench --size 30 exits 2" [ $RC -eq 2 ]
run convert --unet x.pth --base x --out y --dtype f8
check "convert bad --dtype exits 2" [ $RC -eq 2 ]

# ---- convert ----------------------------------------------------------------------------------
# the models most checks use record no work size (--work-size native): the pictures run at their own
# size, as the goldens were made; the preprocessing section below uses one with the official 512
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

# ---- preprocessing: the official square work size by default (pipeline.work_size) --------------
F16=$T/tiny_f16.safetensors   # converted above without --work-size: the official 512
run info "$F16"
check "info: a converted model records the official work size 512" grep -Eq '^work size +512x512' "$T/out"
run info "$MODEL"
check "info: --work-size native records none" grep -Eq '^work size +none' "$T/out"
run image --model "$F16" --out "$T/pre_default" --float "$SPHERE"
check "image at the model's work size exits 0" [ $RC -eq 0 ]
check_png "$T/pre_default/sphere_64_albedo.png" 64 64 2
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
check_png "$T/w_i8/sphere_64_albedo.png" 64 64 2
run image --weights bf16 --model "$MODEL" --out "$T/w_bf16" "$DATA/img/sphere_64.png"
check "image --weights bf16 exits 0" [ $RC -eq 0 ]
check_png "$T/w_bf16/sphere_64_albedo.png" 64 64 2
run image --weights q4 --model "$MODEL" --out "$T/w_bad" "$DATA/img/sphere_64.png"
check "--weights q4 exits 2" [ $RC -eq 2 ]

# ---- info -------------------------------------------------------------------------------------
run info "$MODEL"
check "info exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "info: kind" grep -Eq '^kind +supermat$' "$T/out"
check "info: architecture" grep -q 'channels 32,64,64,64' "$T/out"
check "info: branch parameters" grep -q 'per branch' "$T/out"
check "info: VAE parameters" grep -q 'VAE [0-9]' "$T/out"
check "info: dtypes" grep -Eq '^dtypes +F32: [0-9]+ tensor' "$T/out"
check "info: file size" grep -q "^size *$(wc -c <"$MODEL") bytes" "$T/out"
check "info: model memory" grep -Eq '^model memory +[0-9]+ bytes' "$T/out"
check "info: session memory" grep -Eq '^session 512 +[0-9]+ bytes .* all outputs, [0-9]+ bytes .* albedo only' "$T/out"
run info "$T/tiny_f16.safetensors"
check "info f16: F16 tensors" grep -q 'F16: [0-9]* tensor' "$T/out"
run info "$SPHERE"
check "info on a PNG exits 1" [ $RC -eq 1 ]
check "info on a PNG explains" grep -q 'error' "$T/err"

# ---- image ------------------------------------------------------------------------------------
O1=$T/out1/nested
run image --model "$MODEL" --out "$O1" "$SPHERE" "$RING"
check "image exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$O1/sphere_64_albedo.png" 64 64 2
check_png "$O1/sphere_64_roughness.png" 64 64 0
check_png "$O1/sphere_64_metallic.png" 64 64 0
check_png "$O1/ring_48x72_albedo.png" 72 48 2
check_png "$O1/ring_48x72_roughness.png" 72 48 0
check_png "$O1/ring_48x72_metallic.png" 72 48 0
absent "$O1/sphere_64_albedo.pfm"
check "image writes nothing on stdout" [ ! -s "$T/out" ]

O2=$T/out2
run image --model "$MODEL" --out "$O2" --float --threads 1 "$SPHERE" "$RING"
check "image --float exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$O2/sphere_64_albedo.png" 64 64 2
check_png "$O2/ring_48x72_metallic.png" 72 48 0
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
check_png "$O3/sphere_64_albedo.png" 64 64 2
check_pfm "$O3/sphere_64_albedo.pfm" 64 64 3
absent "$O3/sphere_64_roughness.png"
absent "$O3/sphere_64_metallic.png"
absent "$O3/sphere_64_roughness.pfm"
check "--outputs albedo gives the same albedo" cmp -s "$O1/sphere_64_albedo.png" "$O3/sphere_64_albedo.png"

O4=$T/out4
run image --model "$MODEL" --out "$O4" --outputs metallic --kernel scalar "$RING"
check "image --outputs metallic --kernel scalar exits 0" [ $RC -eq 0 ]
check_png "$O4/ring_48x72_metallic.png" 72 48 0
absent "$O4/ring_48x72_albedo.png"
absent "$O4/ring_48x72_roughness.png"

# int8 compute: maps on a CPU with AVX512_VNNI (+ BW), else exit 1 naming what is missing; a bad value is usage
O6=$T/out_i8c
run image --model "$MODEL" --out "$O6" --compute int8 "$SPHERE"
if grep -qw avx512_vnni /proc/cpuinfo 2>/dev/null && grep -qw avx512bw /proc/cpuinfo 2>/dev/null; then
    check "image --compute int8 exits 0 (AVX512_VNNI here)" [ $RC -eq 0 ]
    check_png "$O6/sphere_64_albedo.png" 64 64 2
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
check_png "$O5/sphere_64_albedo.png" 64 64 2

# ---- the default model: no --model -> $SUPERMAT_MODEL, the installed data folder, the source tree ----
OD=$T/default_env
run_env SUPERMAT_MODEL="$MODEL" -- image --out "$OD" "$SPHERE"
check "image without --model, SUPERMAT_MODEL set, exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$OD/sphere_64_albedo.png" 64 64 2
check_png "$OD/sphere_64_roughness.png" 64 64 0
check_png "$OD/sphere_64_metallic.png" 64 64 0
check "SUPERMAT_MODEL: the same maps as --model" cmp -s "$O1/sphere_64_albedo.png" "$OD/sphere_64_albedo.png"
run_env SUPERMAT_MODEL="$T/no_such_model.safetensors" -- image --out "$T/default_bad" "$SPHERE"
check "SUPERMAT_MODEL naming a missing file exits 1" [ $RC -eq 1 ]
check "SUPERMAT_MODEL naming a missing file: the message names the file" grep -q 'no_such_model.safetensors' "$T/err"
check "SUPERMAT_MODEL naming a missing file: the message names SUPERMAT_MODEL" grep -q 'SUPERMAT_MODEL' "$T/err"
absent "$T/default_bad"
run_env SUPERMAT_MODEL="$T/no_such_model.safetensors" -- image --model "$MODEL" --out "$T/default_given" "$SPHERE"
check "--model wins over SUPERMAT_MODEL" [ $RC -eq 0 ]
run_env SUPERMAT_MODEL="$MODEL" -- info
check "info without FILE (SUPERMAT_MODEL) exits 0" [ $RC -eq 0 ]
check "info without FILE names the default model" grep -qF "default       $MODEL (the default model: \$SUPERMAT_MODEL)" "$T/out"
check "info without FILE describes it" grep -Eq '^kind +supermat$' "$T/out"
run_env SUPERMAT_MODEL="$T/no_such_model.safetensors" -- info
check "info without FILE, SUPERMAT_MODEL missing, exits 1" [ $RC -eq 1 ]
check "info without FILE, SUPERMAT_MODEL missing: the message names the file" grep -q 'no_such_model.safetensors' "$T/err"
run_env SUPERMAT_MODEL="$MODEL" -- bench --size 64 --pipeline-only
check "bench without --model (SUPERMAT_MODEL) exits 0" [ $RC -eq 0 ]
check "bench without --model runs the default model" grep -qF "supermat bench: $MODEL (supermat" "$T/out"
run_env SUPERMAT_MODEL="$MODEL" -- bench --image "$SPHERE" --modes branch_albedo
check "bench --image without --model (SUPERMAT_MODEL) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
run_env SUPERMAT_MODEL="$T/no_such_model.safetensors" -- bench --size 64 --pipeline-only
check "bench, SUPERMAT_MODEL missing, exits 1" [ $RC -eq 1 ]
# an install that was moved: PREFIX/bin/supermat finds PREFIX/share/supermat/supermat_default.safetensors
mkdir -p "$T/prefix/bin" "$T/prefix/share/supermat"
cp "$BIN" "$T/prefix/bin/supermat"
cp "$MODEL" "$T/prefix/share/supermat/supermat_default.safetensors"
BIN_SAVED=$BIN
BIN=$T/prefix/bin/supermat
run info
check "a moved install: info without FILE exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "a moved install: the model beside the executable" \
    grep -q 'prefix/share/supermat/supermat_default.safetensors (the default model: installed, beside this executable)' "$T/out"
run image --out "$T/default_moved" "$SPHERE"
check "a moved install: image without --model exits 0" [ $RC -eq 0 ]
check "a moved install: the same maps" cmp -s "$O1/sphere_64_albedo.png" "$T/default_moved/sphere_64_albedo.png"
BIN=$BIN_SAVED
rm -rf "$T/prefix"
# and here: the installed or source tree's default model if there is one, else exit 1 naming every place
run info
if [ $RC -eq 0 ]; then
    check "info without FILE: a default model from the install or the source tree" \
        grep -Eq '^default .*/supermat_default.safetensors \(the default model: (installed|installed, beside this executable|source tree)\)$' "$T/out"
else
    check "no default model: exit 1" [ $RC -eq 1 ]
    check "no default model: the message names SUPERMAT_MODEL" grep -q 'SUPERMAT_MODEL: not set' "$T/err"
    check "no default model: the message names the installed place" grep -q 'share/supermat/supermat_default.safetensors (installed' "$T/err"
    check "no default model: the message names the source tree" grep -q 'models/supermat_default.safetensors (source tree)' "$T/err"
fi

# ---- sheet: a contact sheet ---------------------------------------------------------------------
# 2 rows x 3 columns of 64-pixel cells with labels: 4 + 3 * (64 + 4) = 208 wide,
# 4 + (8 + 4) + 2 * (64 + 4) = 152 high (RGBA, RGB and gray inputs, non-square, an empty cell)
SH=$T/sheets/sheet.png
mkdir -p "$T/sheets"
run sheet --out "$SH" --cell 64 --labels "input,ring (72x48),box_40" "$SPHERE,$RING,$DATA/img/box_40.png" "$DATA/img/uv/uv_bc.png,-,$DATA/img/uv/uv_mask.png"
check "sheet exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$SH" 208 152 2
absent "$SH.tmp"
run sheet --out "$T/sheets/plain.png" "$SPHERE,$RING" "$DATA/img/box_40.png"
check "sheet without labels, default cell exits 0" [ $RC -eq 0 ]
check_png "$T/sheets/plain.png" 268 268 2
cp "$SH" "$T/sheets/before.png"
run sheet --force --out "$SH" "$SPHERE,$T/no_such_picture.png"
check "sheet with a missing input exits 1" [ $RC -eq 1 ]
check "sheet with a missing input: the message names it" grep -q 'no_such_picture.png' "$T/err"
check "sheet with a missing input: the old sheet is untouched" cmp -s "$SH" "$T/sheets/before.png"
absent "$SH.tmp"
printf 'not a picture\n' >"$T/sheets/text.png"
run sheet --out "$T/sheets/never.png" "$SPHERE,$T/sheets/text.png"
check "sheet with a file that is not an image exits 1" [ $RC -eq 1 ]
absent "$T/sheets/never.png"
absent "$T/sheets/never.png.tmp"
# FILE:r/:g/:b/:a: one channel as gray: a gray image's :r is the image; a colour image's :g is not
run sheet --out "$T/sheets/m.png" --cell 32 "$DATA/img/uv/uv_mask.png"
run sheet --out "$T/sheets/m_r.png" --cell 32 "$DATA/img/uv/uv_mask.png:r"
check "sheet FILE:r of a gray image = the image" cmp -s "$T/sheets/m.png" "$T/sheets/m_r.png"
run sheet --out "$T/sheets/c.png" --cell 32 "$DATA/img/uv/uv_bc.png"
run sheet --out "$T/sheets/c_g.png" --cell 32 "$DATA/img/uv/uv_bc.png:g"
check "sheet FILE:g of a colour image: exit 0" [ $RC -eq 0 ]
check "sheet FILE:g of a colour image: another sheet than the image's" [ "$(cmp -s "$T/sheets/c.png" "$T/sheets/c_g.png"; echo $?)" = 1 ]
run sheet --out "$T/sheets/never.png" "$DATA/img/uv/uv_bc.png:x"
check "sheet FILE:x (no such channel, no such file) exits 1" [ $RC -eq 1 ]
run sheet --out "$T/sheets/never.png"
check "sheet without rows exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" --cell 7 "$SPHERE"
check "sheet --cell 7 exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" --cell x "$SPHERE"
check "sheet --cell x exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" "$SPHERE,,$RING"
check "sheet with an empty entry exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" --labels a,b,c "$SPHERE,$RING"
check "sheet with more labels than columns exits 2" [ $RC -eq 2 ]
run sheet "$SPHERE"
check "sheet without --out exits 2" [ $RC -eq 2 ]
absent "$T/sheets/never.png"
run sheet --out "$T/no_such_dir/sheet.png" "$SPHERE"
check "sheet into a missing folder exits 1" [ $RC -eq 1 ]

# a write that fails (a 4 KiB file size limit with SIGXFSZ ignored: write() fails with EFBIG): exit 1,
# a message, and no file left, neither the PNG nor its .tmp (the sheet is ~95 KB, the albedo ~12 KB)
run_limited() {
    set +e
    (trap '' XFSZ; ulimit -f 4; exec env -u SUPERMAT_MODEL "$BIN" "$@") >"$T/out" 2>"$T/err"
    RC=$?
    set -e
}
run_limited sheet --out "$T/sheets/limited.png" --cell 256 "$SPHERE,$RING"
check "sheet whose write fails exits 1" [ $RC -eq 1 ]
check "sheet whose write fails: the message names the file" grep -q "cannot write '.*limited.png'" "$T/err"
absent "$T/sheets/limited.png"
absent "$T/sheets/limited.png.tmp"
run_limited image --model "$MODEL" --out "$T/limited" "$SPHERE"
check "image whose write fails exits 1" [ $RC -eq 1 ]
check "image whose write fails: the message names the file" grep -q "cannot write '.*sphere_64_albedo.png'" "$T/err"
absent "$T/limited/sphere_64_albedo.png"
absent "$T/limited/sphere_64_albedo.png.tmp"

# ---- pack: the pre-packed model file ------------------------------------------------------------
PK=$T/pack
mkdir -p "$PK"
run pack --model "$MODEL" --out "$PK/tiny.packed.safetensors"
check "pack exits 0" [ $RC -eq 0 ]
check "pack says what it wrote" grep -q "wrote .*tiny.packed.safetensors" "$T/out"
run info "$PK/tiny.packed.safetensors"
check "info on a pre-packed file exits 0" [ $RC -eq 0 ]
check "info says the panels are used in place" grep -q "^pre-packed    yes" "$T/out"
run image --model "$MODEL" --out "$PK/a" --float "$SPHERE"
run image --model "$PK/tiny.packed.safetensors" --out "$PK/b" --float "$SPHERE"
check "image on the pre-packed file exits 0" [ $RC -eq 0 ]
for f in albedo roughness metallic; do
    check "pre-packed $f.pfm has the original's bytes" cmp -s "$PK/a/sphere_64_$f.pfm" "$PK/b/sphere_64_$f.pfm"
done
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$PK/conv.packed.safetensors" --packed --work-size native
check "convert --packed exits 0" [ $RC -eq 0 ]
run info "$PK/conv.packed.safetensors"
check "convert --packed writes a pre-packed file" grep -q "^pre-packed    yes" "$T/out"
absent "$PK/conv.packed.safetensors.tmp"
run image --model "$PK/conv.packed.safetensors" --out "$PK/e" --float "$SPHERE"
check "convert --packed: the same albedo as the unpacked file" cmp -s "$PK/a/sphere_64_albedo.pfm" "$PK/e/sphere_64_albedo.pfm"
run convert --from "$PK/conv.packed.safetensors" --work-size 16384 --out "$PK/conv16k.packed.safetensors"
check "convert --from a pre-packed file exits 0" [ $RC -eq 0 ]
run image --model "$PK/conv16k.packed.safetensors" --native --out "$PK/f" --float "$SPHERE"
check "convert --from a pre-packed file (its header rewritten): its panels in place, the same albedo" cmp -s "$PK/a/sphere_64_albedo.pfm" "$PK/f/sphere_64_albedo.pfm"
run pack --model "$MODEL" --out "$PK/tiny.wf4.safetensors" --weights f16 --conv winograd-f4
check "pack --weights f16 --conv winograd-f4 exits 0" [ $RC -eq 0 ]
run image --model "$PK/tiny.wf4.safetensors" --out "$PK/c" "$SPHERE"
check "a Winograd-packed file runs with the options it was packed for" [ $RC -eq 0 ]
run image --model "$PK/tiny.packed.safetensors" --weights int8 --out "$PK/d" "$SPHERE"
check "other weights than packed for: exit 1" [ $RC -eq 1 ]
check "other weights than packed for: the message says what it was packed for" grep -q "pre-packed for weights f32" "$T/err"
absent "$PK/d/sphere_64_albedo.png"
run pack --model "$PK/tiny.packed.safetensors" --out "$PK/again.safetensors"
check "packing a pre-packed file: exit 1" [ $RC -eq 1 ]
check "packing a pre-packed file: the message" grep -q "pre-packed already" "$T/err"
absent "$PK/again.safetensors"
run pack --model "$MODEL" --out "$PK/tiny.packed.safetensors"
check "pack over an existing file: exit 1 (overwrite policy)" [ $RC -eq 1 ]
run pack --model "$MODEL" --out "$PK/x.safetensors" --conv winograd-f9
check "pack --conv with a bad value: exit 2" [ $RC -eq 2 ]
run_limited pack --model "$MODEL" --out "$PK/limited.safetensors"
check "pack whose write fails exits 1" [ $RC -eq 1 ]
check "pack whose write fails: the message names the file" grep -q "cannot write '.*limited.safetensors'" "$T/err"
absent "$PK/limited.safetensors"
absent "$PK/limited.safetensors.tmp"

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
check_png "$T/mm3/sphere_64_albedo.png" 64 64 2
run image --model "$MODEL" --max-memory lots --out "$T/mm4" "$SPHERE"
check "--max-memory with a bad size: exit 2" [ $RC -eq 2 ]

# ---- the overwrite policy (every command): refuse / --force / --skip-existing -------------------
OW=$T/overwrite
run image --model "$MODEL" --out "$OW" "$SPHERE"
check "image into a new folder exits 0" [ $RC -eq 0 ]
printf 'mine\n' >"$OW/sphere_64_roughness.png"
cp "$OW/sphere_64_albedo.png" "$T/ow_albedo_before.png"
run image --model "$MODEL" --out "$OW" "$SPHERE"
check "image over existing maps exits 1" [ $RC -eq 1 ]
check "image over existing maps: the message names the file and the options" grep -q "sphere_64_albedo.png' exists and was not written by this run: --force replaces it, --skip-existing keeps it" "$T/err"
check "image over existing maps: a user's file is untouched" grep -q mine "$OW/sphere_64_roughness.png"
check "image over existing maps: the maps are untouched" cmp -s "$OW/sphere_64_albedo.png" "$T/ow_albedo_before.png"
absent "$OW/sphere_64_albedo.png.tmp"
run image --model "$MODEL" --out "$OW" --skip-existing "$SPHERE"
check "--skip-existing exits 0" [ $RC -eq 0 ]
check "--skip-existing: the picture is not run" grep -q "kept the maps of '.*sphere_64.png'" "$T/err"
check "--skip-existing: a user's file is kept" grep -q mine "$OW/sphere_64_roughness.png"
rm "$OW/sphere_64_metallic.png"
run image --model "$MODEL" --out "$OW" --skip-existing "$SPHERE"
check "--skip-existing with one map missing exits 0" [ $RC -eq 0 ]
check_png "$OW/sphere_64_metallic.png" 64 64 0
check "--skip-existing with one map missing: the others are kept" grep -q mine "$OW/sphere_64_roughness.png"
run image --model "$MODEL" --out "$OW" "$SPHERE" --force
check "--force exits 0" [ $RC -eq 0 ]
check_png "$OW/sphere_64_roughness.png" 64 64 0
run image --model "$MODEL" --out "$OW" --force --skip-existing "$SPHERE"
check "--force with --skip-existing exits 2" [ $RC -eq 2 ]
# symbolic links, live or dangling: refused; --force replaces the link itself, never its target
printf 'target\n' >"$T/ow_target"
rm "$OW/sphere_64_albedo.png"
ln -s "$T/ow_target" "$OW/sphere_64_albedo.png"
run image --model "$MODEL" --out "$OW" "$SPHERE"
check "a symbolic link among the outputs exits 1" [ $RC -eq 1 ]
check "a symbolic link among the outputs: said so" grep -q "sphere_64_albedo.png' exists (a symbolic link)" "$T/err"
check "a symbolic link among the outputs: its target is untouched" grep -qx target "$T/ow_target"
run image --model "$MODEL" --out "$OW" --force "$SPHERE"
check "--force over a symbolic link exits 0" [ $RC -eq 0 ]
check "--force over a symbolic link: the link is now the file" [ ! -L "$OW/sphere_64_albedo.png" ]
check_png "$OW/sphere_64_albedo.png" 64 64 2
check "--force over a symbolic link: its target is untouched" grep -qx target "$T/ow_target"
ln -s "$T/ow_nowhere.png" "$T/ow_dangling.png"
run sheet --out "$T/ow_dangling.png" "$SPHERE"
check "sheet over a dangling symbolic link exits 1" [ $RC -eq 1 ]
absent "$T/ow_nowhere.png"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$MODEL"
check "convert over an existing model exits 1" [ $RC -eq 1 ]
check "convert over an existing model: the message names it" grep -q "tiny.safetensors' exists" "$T/err"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$MODEL" --skip-existing
check "convert --skip-existing over an existing model exits 0" [ $RC -eq 0 ]

# ---- inputs as users have them ------------------------------------------------------------------
# max |a - b| over two PFMs of the same size (header skipped, floats as od prints them)
pfm_maxdiff() {
    paste <(od -An -v -f -j "$(head -3 "$1" | wc -c)" "$1" | tr -s ' ' '\n' | grep -v '^$') \
          <(od -An -v -f -j "$(head -3 "$2" | wc -c)" "$2" | tr -s ' ' '\n' | grep -v '^$') |
        awk 'BEGIN { m = 0; n = 0 } { d = $1 - $2; if (d < 0) d = -d; if (d > m) m = d; n++ } END { if (n == 0) print "nan"; else print m }'
}
# a 16-bit PNG (the 8-bit sphere x 257): read at full precision as float input, so the same maps as the 8-bit file
run image --model "$MODEL" --out "$T/in16" "$DATA/img/sphere_64_16bit.png" "$SPHERE"
check "a 16-bit PNG exits 0" [ $RC -eq 0 ]
check "a 16-bit PNG: the maps of its 8-bit twin" cmp -s "$T/in16/sphere_64_16bit_albedo.png" "$T/in16/sphere_64_albedo.png"
run refine --model "$MODEL" --map "$DATA/img/sphere_64_16bit.png" --mask "$DATA/img/uv/uv_mask.png" --position "$DATA/img/uv/uv_position.png" --out "$T/in16r"
check "a 16-bit PNG where 8 bits are read (refine) exits 1" [ $RC -eq 1 ]
check "a 16-bit PNG where 8 bits are read: said so" grep -q "has 16 bits per channel" "$T/err"
# a PNG header claiming 16400 x 16400 pixels (a few hundred bytes; decoding would take 800 MB): refused from the header
printf '\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x40\x10\x00\x00\x40\x10\x08\x02\x00\x00\x00\x02\xd2\x04\xa0\x00\x00\x00\x00IEND\xae\x42\x60\x82' > "$T/huge.png"
run image --model "$MODEL" --out "$T/huge" "$T/huge.png"
check "a picture claiming 16400x16400: exit 1" [ $RC -eq 1 ]
check "a picture claiming 16400x16400: refused from its header" grep -q "16400x16400: at most 16384 pixels a side" "$T/err"
# 20000 x 20000: stb_image refuses the claim with the last decoder's "unknown type" message; the size is said instead
printf '\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x4e\x20\x00\x00\x4e\x20\x08\x02\x00\x00\x00\x02\xd2\x04\xa0\x00\x00\x00\x00IEND\xae\x42\x60\x82' > "$T/huge2.png"
run image --model "$MODEL" --out "$T/huge" "$T/huge2.png"
check "a PNG claiming 20000x20000: exit 1" [ $RC -eq 1 ]
check "a PNG claiming 20000x20000: says its size and the limit" grep -q "20000x20000: at most 16384 pixels a side" "$T/err"
# hostile pictures from fuzz/fuzz_picture.c (fuzz/corpus/picture/regress_*): Debian's stb_image 2.27 writes past a
# Huffman table for a JPEG table of more than 256 codes (also behind leading fill bytes, or cut off by the end of
# the file: stb_image counts zeros there); a BMP's negative width
# came back from the header as it was; formats the CLI does not document are refused by their signature
FZ="$DATA/../../fuzz/corpus/picture"
for f in regress_dht_over_256.jpg regress_dht_after_fill.jpg regress_dht_past_end.jpg; do
    run image --model "$MODEL" --out "$T/hostile" "$FZ/$f"
    check "$f: exit 1" [ $RC -eq 1 ]
    check "$f: refused before decoding" grep -q "is a corrupt JPEG (a Huffman table of more than 256 codes)" "$T/err"
    absent "$T/hostile/${f%.jpg}_albedo.png"
done
run sheet --out "$T/hostile_sheet.png" "$FZ/regress_dht_over_256.jpg"
check "a hostile JPEG in a contact sheet: exit 1" [ $RC -eq 1 ]
check "a hostile JPEG in a contact sheet: refused" grep -q "is a corrupt JPEG" "$T/err"
absent "$T/hostile_sheet.png"
run image --model "$MODEL" --out "$T/hostile" "$FZ/regress_bmp_negative_width.bmp"
check "a BMP of negative width: exit 1" [ $RC -eq 1 ]
check "a BMP of negative width: said so" grep -q "claims a size of -2147483632x8 pixels: a corrupt picture" "$T/err"
for f in a.gif a.hdr a.ppm; do
    run image --model "$MODEL" --out "$T/hostile" "$FZ/$f"
    check "$f: exit 1" [ $RC -eq 1 ]
    check "$f: refused by its signature" grep -q "which supermat does not read (PNG, JPEG, BMP, TGA or WebP)" "$T/err"
done
if "$BIN" --version | grep -q "built with:.* mesh"; then   # the same JPEG as a glTF's base colour texture
    run mesh --passthrough --force "$DATA/../../fuzz/corpus/gltf/regress_dht_texture.gltf" "$T/hostile_mesh.gltf"
    check "a hostile JPEG texture: the bake goes on (exit 0)" [ $RC -eq 0 ]
    check "a hostile JPEG texture: refused before decoding, its factor used" grep -q "material 0 is a corrupt JPEG (a Huffman table of more than 256 codes)" "$T/err"
fi
run image --model "$MODEL" --out "$T/hostile_ok" --outputs albedo "$FZ/base.jpg" "$FZ/prog.jpg" "$FZ/exif6.jpg" "$FZ/rgb.bmp" "$FZ/rle.tga" "$FZ/pal.png"
check "the corpus' valid JPEG / BMP / TGA / PNG pictures still read: exit 0" [ $RC -eq 0 ]
check_png "$T/hostile_ok/exif6_albedo.png" 8 16 2
# a JPEG with EXIF orientation 6 (stored 48 wide, 72 high, shown 72 x 48): processed upright, as a viewer
# shows it; its maps are those of the upright picture (ring_exif6_upright.png, decoded by another JPEG
# decoder: measured 0.038 apart; turned 180 degrees or mirrored they are 0.87 / 1.0 apart)
run image --model "$MODEL" --out "$T/exif" --float "$DATA/img/ring_exif6.jpg" "$DATA/img/ring_exif6_upright.png"
check "an EXIF-rotated JPEG exits 0" [ $RC -eq 0 ]
check_png "$T/exif/ring_exif6_albedo.png" 72 48 2
d=$(pfm_maxdiff "$T/exif/ring_exif6_albedo.pfm" "$T/exif/ring_exif6_upright_albedo.pfm")
check "an EXIF-rotated JPEG: the upright picture's maps (max diff $d <= 0.1)" awk -v x="$d" 'BEGIN { exit !(x ~ /^[0-9.eE+-]+$/ && x + 0 <= 0.1) }'
# a folder, a WebP file: named as such
mkdir -p "$T/a_folder"
run image --model "$MODEL" --out "$T/in_dir" "$T/a_folder"
check "a folder as a picture exits 1" [ $RC -eq 1 ]
check "a folder as a picture: said so" grep -q "a_folder' is a folder: give the picture files" "$T/err"
# WebP (the official examples' format): a lossless WebP of the sphere gives the PNG's maps when the build
# has libwebp (`supermat --version` says "built with: webp"), else it is refused saying what to do
printf 'RIFF\032\000\000\000WEBPVP8 \016\000\000\000' >"$T/pic.webp"
run image --model "$MODEL" --out "$T/in_webp" "$T/pic.webp"
check "a broken WebP picture exits 1" [ $RC -eq 1 ]
cp "$T/err" "$T/err_webp"
run --version
if grep -q '^built with:.* webp' "$T/out"; then
    check "a broken WebP picture: said so" grep -q "pic.webp': not a valid WebP file" "$T/err_webp"
    run image --model "$MODEL" --out "$T/in_webp" "$DATA/img/sphere_64.webp"
    check "a WebP picture exits 0" [ $RC -eq 0 ]
    run image --model "$MODEL" --out "$T/in_webp_png" "$SPHERE"
    check "a lossless WebP picture: the maps of its PNG" cmp -s "$T/in_webp/sphere_64_albedo.png" "$T/in_webp_png/sphere_64_albedo.png"
    check "a lossless WebP picture: the maps of its PNG (roughness)" cmp -s "$T/in_webp/sphere_64_roughness.png" "$T/in_webp_png/sphere_64_roughness.png"
else
    check "a WebP picture without libwebp: said so, with what to do" grep -q "pic.webp' is WebP, which this build does not read" "$T/err_webp"
fi

# ---- bad input --------------------------------------------------------------------------------
# a valid 30x30 8-bit gray PNG (zlib stream and CRCs included)
BAD=$T/bad_30x30.png
printf '\211\120\116\107\015\012\032\012\000\000\000\015\111\110\104\122\000\000\000\036\000\000\000\036\010\000\000\000\000\036\133\361\176\000\000\000\025\111\104\101\124\170\332\143\150\300\013\030\106\245\107\245\107\245\007\122\032\000\225\201\302\020\354\122\050\077\000\000\000\000\111\105\116\104\256\102\140\202' >"$BAD"
check_png "$BAD" 30 30 0
O6=$T/out6
run image --model "$MODEL" --out "$O6" "$BAD"
check "30x30 image exits 1" [ $RC -eq 1 ]
check "30x30 image: the message gives the size" grep -q '30x30' "$T/err"
check "30x30 image: the message says multiples of 8" grep -q 'multiples of 8' "$T/err"
absent "$O6/bad_30x30_albedo.png"
run image --model "$MODEL" --out "$O6" "$SPHERE" "$BAD"
check "a bad image among good ones exits 1 before any work" [ $RC -eq 1 ]
absent "$O6/sphere_64_albedo.png"

run image --model "$T/no_such_model.safetensors" --out "$T/out7" "$SPHERE"
check "missing model exits 1" [ $RC -eq 1 ]
check "missing model: the message names it" grep -q 'no_such_model.safetensors' "$T/err"

run image --model "$SPHERE" --out "$T/out8" "$SPHERE"
check "a PNG as the model exits 1" [ $RC -eq 1 ]
check "a PNG as the model: the library's message" grep -q 'malformed model file' "$T/err"

run image --model "$MODEL" --out "$T/out9" "$T/no_such_image.png"
check "missing image exits 1" [ $RC -eq 1 ]
check "missing image: the message names it" grep -q 'no_such_image.png' "$T/err"

run image --model "$MODEL" --out "$T/out10" "$SPHERE" "$T/sphere_64.png"
check "two images with one stem exit 2" [ $RC -eq 2 ]

# ---- multi-view (views) and UV refine (refine) ---------------------------------------------------
MV=$T/tiny_mv.safetensors
UV=$T/tiny_uv.safetensors
MVIMG=$DATA/img/mv
UVIMG=$DATA/img/uv
run convert --kind supermat-mv --unet "$DATA/tiny/supermat_mv.pth" --base "$DATA/tiny/base" --out "$MV" --work-size native
check "convert supermat-mv exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
run convert --kind uv-refine --unet "$DATA/tiny/uv_refine_bc.pth" --base "$DATA/tiny/base" --out "$UV" --work-size native
check "convert uv-refine exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"

run info "$MV"
check "info mv exits 0" [ $RC -eq 0 ]
check "info mv: kind" grep -Eq '^kind +supermat-mv$' "$T/out"
check "info mv: camera embedding" grep -q 'camera embedding in 16' "$T/out"
check "info mv: session for 6 views" grep -q '6 views' "$T/out"
check "info mv: the command" grep -q 'supermat views' "$T/out"
run info "$UV"
check "info uv exits 0" [ $RC -eq 0 ]
check "info uv: kind" grep -Eq '^kind +uv-refine$' "$T/out"
check "info uv: input channels" grep -q 'UNet input 8 channels = latent 4 + mask 1 + position 3' "$T/out"
check "info uv: the command" grep -q 'supermat refine' "$T/out"

# the golden comparison tool (max abs error of PFMs against a float32 NCHW .npy)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
DIFF=""
if command -v "${CC:-cc}" >/dev/null 2>&1; then
    if ${CC:-cc} -std=c99 -O2 -o "$T/pfm_npy_diff" "$HERE/pfm_npy_diff.c" -lm 2>"$T/cc_err"; then DIFF=$T/pfm_npy_diff
    else bad "cannot compile tests/pfm_npy_diff.c"; cat "$T/cc_err"; fi
else
    echo "SKIP: no C compiler (${CC:-cc}): the PFM vs golden comparisons do not run"
fi
golden() { # golden "description" [--channel C] REF.npy PFM...
    local what=$1
    shift
    [ -n "$DIFF" ] || return 0
    local ch=()
    if [ "$1" = "--channel" ]; then ch=(--channel "$2"); shift 2; fi
    if "$DIFF" ${ch[@]+"${ch[@]}"} 1e-4 "$@" >"$T/diff_out" 2>&1; then
        ok
        echo "$what: $(cat "$T/diff_out")"
    else
        bad "$what: $(cat "$T/diff_out")"
    fi
}

VIEWS=()
for k in 0 1 2 3 4 5; do VIEWS+=("$MVIMG/color_000$k.png"); done
OV=$T/views6
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OV" --float "${VIEWS[@]}"
check "views (6 views) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "views writes nothing on stdout" [ ! -s "$T/out" ]
for k in 0 1 2 3 4 5; do
    check_png "$OV/color_000${k}_albedo.png" 64 64 2
    check_png "$OV/color_000${k}_roughness.png" 64 64 0
    check_png "$OV/color_000${k}_metallic.png" 64 64 0
    check_pfm "$OV/color_000${k}_albedo.pfm" 64 64 3
    check_pfm "$OV/color_000${k}_metallic.pfm" 64 64 1
done
check "views: 36 files (18 PNG, 18 PFM)" [ "$(find "$OV" -type f | wc -l)" -eq 36 ]
golden "views albedo vs golden mv6_64/albedo.npy" "$DATA/golden/mv6_64/albedo.npy" "$OV"/color_000{0,1,2,3,4,5}_albedo.pfm
golden "views roughness vs golden mv6_64/orm.npy G" --channel 1 "$DATA/golden/mv6_64/orm.npy" "$OV"/color_000{0,1,2,3,4,5}_roughness.pfm
golden "views metallic vs golden mv6_64/orm.npy B" --channel 2 "$DATA/golden/mv6_64/orm.npy" "$OV"/color_000{0,1,2,3,4,5}_metallic.pfm
# --chroma: off by default in views (the goldens above are the official computation); asked for, it changes
# every view's albedo and nothing else
OVC=$T/views6_chroma
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OVC" --chroma 1 "${VIEWS[@]}"
check "views --chroma 1 exits 0" [ $RC -eq 0 ]
for k in 0 5; do
    check "views --chroma 1: view $k's albedo changed" bash -c "! cmp -s '$OVC/color_000${k}_albedo.png' '$OV/color_000${k}_albedo.png'"
    check "views --chroma 1: view $k's roughness and metallic unchanged" bash -c "cmp -s '$OVC/color_000${k}_roughness.png' '$OV/color_000${k}_roughness.png' && cmp -s '$OVC/color_000${k}_metallic.png' '$OV/color_000${k}_metallic.png'"
done
# --conv: the Winograd lever from the command line, against the same official goldens
OVW=$T/views6_wf4
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OVW" --float --conv winograd-f4 "${VIEWS[@]}"
check "views --conv winograd-f4 exits 0" [ $RC -eq 0 ]
golden "views --conv winograd-f4 albedo vs golden mv6_64/albedo.npy" "$DATA/golden/mv6_64/albedo.npy" "$OVW"/color_000{0,1,2,3,4,5}_albedo.pfm
golden "views --conv winograd-f4 metallic vs golden mv6_64/orm.npy B" --channel 2 "$DATA/golden/mv6_64/orm.npy" "$OVW"/color_000{0,1,2,3,4,5}_metallic.pfm
run info --conv f4 "$MV"
check "info --conv f4 reports Winograd F4" grep -Eq '^convolutions +winograd-f4' "$T/out"
run info "$MV"
check "info: direct convolutions by default" grep -Eq '^convolutions +direct' "$T/out"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_badconv" --conv winograd-f9 "${VIEWS[@]}"
check "--conv winograd-f9 exits 2" [ $RC -eq 2 ]
check "--conv winograd-f9: the message" grep -q "is not direct, winograd-f2 or winograd-f4" "$T/err"
absent "$T/views_badconv"
run bench --model "$MV" --size 64 --views 2 --pipeline-only --conv winograd-f2
check "bench --conv winograd-f2 exits 0" [ $RC -eq 0 ]
check "bench --conv winograd-f2: the header says so" grep -q "winograd-f2 convolutions" "$T/out"
run bench --model "$MV" --image "${VIEWS[0]}" --conv winograd-f2
check "bench --image --conv: exit 2 (the modes choose)" [ $RC -eq 2 ]

OV3=$T/views3
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OV3" --outputs albedo,metallic --threads 1 \
    "$MVIMG/color_0004.png" "$MVIMG/color_0001.png" "$MVIMG/color_0002.png"
check "views (3 views, --outputs albedo,metallic) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
for k in 1 2 4; do
    check_png "$OV3/color_000${k}_albedo.png" 64 64 2
    check_png "$OV3/color_000${k}_metallic.png" 64 64 0
    absent "$OV3/color_000${k}_roughness.png"
done
absent "$OV3/color_0000_albedo.png"

# one view; a numeric index and a flat 16-number matrix (color_0003's camera)
CAM3=$(tr -d ' \n' <"$MVIMG/meta.json" | sed 's/.*"index":"0003","transform_matrix":\[\(\[[^]]*\]\),\(\[[^]]*\]\),\(\[[^]]*\]\),\(\[[^]]*\]\)\].*/\1,\2,\3,\4/' | tr -d '[]')
printf '{"locations": [{"index": 3, "transform_matrix": [%s]}]}\n' "$CAM3" >"$T/meta_num.json"
OV1=$T/views1
run views --model "$MV" --cameras "$T/meta_num.json" --out "$OV1" "$MVIMG/color_0003.png"
check "views (1 view, numeric index, flat matrix) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || { cat "$T/err"; cat "$T/meta_num.json"; }
check_png "$OV1/color_0003_albedo.png" 64 64 2
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views1s" "$MVIMG/color_0003.png"
check "views (1 view, the official meta.json) exits 0" [ $RC -eq 0 ]
check "index 3 and \"0003\", nested and flat matrix: the same camera" cmp -s "$OV1/color_0003_albedo.png" "$T/views1s/color_0003_albedo.png"

# camera file errors: exit 1, a message naming the file, nothing written
ID='[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]'
cam_error() { # cam_error "description" 'pattern in the message' JSON
    local what=$1 pat=$2
    printf '%s\n' "$3" >"$T/meta_bad.json"
    run views --model "$MV" --cameras "$T/meta_bad.json" --out "$T/views_bad" "$MVIMG/color_0000.png" "$MVIMG/color_0001.png"
    check "$what: exits 1" [ $RC -eq 1 ]
    check "$what: the message names the file" grep -q 'meta_bad.json' "$T/err"
    if grep -q -- "$pat" "$T/err"; then ok; else bad "$what: no '$pat' in: $(cat "$T/err")"; fi
    absent "$T/views_bad"
}
cam_error "meta.json without index 1" 'no location with index 1' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0002\", \"transform_matrix\": $ID}]}"
cam_error "malformed meta.json" 'not valid JSON' "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID},"
cam_error "meta.json without locations" 'no "locations"' '{"frames": []}'
cam_error "duplicate index" 'index 1 appears twice' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0001\", \"transform_matrix\": $ID}, {\"index\": 1, \"transform_matrix\": $ID}]}"
cam_error "short matrix row" 'row 2 has 3 numbers' \
    '{"locations": [{"index": "0000", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1],[0,0,0,1]]}, {"index": "0001", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}'
cam_error "three matrix rows" 'has 3 rows' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}, {\"index\": \"0001\", \"transform_matrix\": $ID}]}"
cam_error "non-numeric matrix element" 'transform_matrix\[1\]\[2\] is not a number' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0001\", \"transform_matrix\": [[1,0,0,0],[0,1,\"x\",0],[0,0,1,0],[0,0,0,1]]}]}"
cam_error "non-finite matrix element" 'not a finite' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,1e999],[0,0,0,1]]}, {\"index\": \"0001\", \"transform_matrix\": $ID}]}"
cam_error "missing matrix" 'no "transform_matrix"' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0001\"}]}"
cam_error "non-numeric index" 'index "front" is not a whole number' \
    "{\"locations\": [{\"index\": \"front\", \"transform_matrix\": $ID}]}"
many=$(for i in $(seq 0 4100); do printf '{"index": %d, "transform_matrix": %s},' "$i" "$ID"; done)
cam_error "4101 locations (the duplicate check is quadratic: capped)" 'at most 4096 are read' "{\"locations\": [${many%,}]}"

# view errors
mkdir -p "$T/vin"
cp "$RING" "$T/vin/ring_0002.png"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_bad" "$MVIMG/color_0000.png" "$T/vin/ring_0002.png"
check "views of two sizes exit 1" [ $RC -eq 1 ]
check "views of two sizes: the message names the view" grep -q 'ring_0002.png' "$T/err"
check "views of two sizes: the message says same size" grep -q 'same size' "$T/err"
cp "$SPHERE" "$T/vin/front.png"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_bad" "$T/vin/front.png"
check "a view without a number exits 1" [ $RC -eq 1 ]
check "a view without a number: the message names it" grep -q 'front.png' "$T/err"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_bad" "$BAD"
check "a 30x30 view exits 1" [ $RC -eq 1 ]
check "a 30x30 view: multiples of 8" grep -q 'multiples of 8' "$T/err"
run views --model "$MV" --cameras "$T/no_such_meta.json" --out "$T/views_bad" "$MVIMG/color_0000.png"
check "a missing meta.json exits 1" [ $RC -eq 1 ]
check "a missing meta.json: the message names it" grep -q 'no_such_meta.json' "$T/err"
run views --model "$MV" --out "$T/views_bad" "$MVIMG/color_0000.png"
check "views without --cameras exits 2" [ $RC -eq 2 ]
absent "$T/views_bad"

# refine
OU=$T/refine
run refine --model "$UV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --out "$OU" --float
check "refine exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$OU/uv_bc_refined.png" 128 128 2
# at another work size (views and refine): the maps come back at the input's size, and differ
run refine --model "$UV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --out "$T/refine_ws" --work-size 64
check "refine --work-size 64 exits 0" [ $RC -eq 0 ]
check_png "$T/refine_ws/uv_bc_refined.png" 128 128 2
check "refine --work-size 64: other maps than at the native 128" bash -c "! cmp -s '$OU/uv_bc_refined.png' '$T/refine_ws/uv_bc_refined.png'"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_ws" --work-size 32 "$MVIMG/color_0000.png" "$MVIMG/color_0001.png"
check "views --work-size 32 exits 0" [ $RC -eq 0 ]
check_png "$T/views_ws/color_0000_albedo.png" 64 64 2
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

# a model of the wrong kind: exit 1, pointing to the right command
run image --model "$MV" --out "$T/kind_bad" "$SPHERE"
check "image with the MV model exits 1" [ $RC -eq 1 ]
check "image with the MV model points to views" grep -q 'supermat views' "$T/err"
run image --model "$UV" --out "$T/kind_bad" "$SPHERE"
check "image with the UV model exits 1" [ $RC -eq 1 ]
check "image with the UV model points to refine" grep -q 'supermat refine' "$T/err"
run views --model "$MODEL" --cameras "$MVIMG/meta.json" --out "$T/kind_bad" "$MVIMG/color_0000.png"
check "views with the single-view model exits 1" [ $RC -eq 1 ]
check "views with the single-view model points to image" grep -q 'supermat image' "$T/err"
run refine --model "$MV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --out "$T/kind_bad"
check "refine with the MV model exits 1" [ $RC -eq 1 ]
check "refine with the MV model points to views" grep -q 'supermat views' "$T/err"
absent "$T/kind_bad"

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
# --detail: image's default (1/64) changes the albedo only; a value out of range is a usage error
DT=$T/detail_default
run image --model "$MODEL" --chroma off --out "$DT" "$SPHERE"
check "image with the default --detail exits 0" [ $RC -eq 0 ]
check "image: the default --detail changes the albedo" bash -c "! cmp -s '$DT/sphere_64_albedo.png' '$GT/sphere_64_albedo.png'"
check "image: the default --detail leaves roughness and metallic" bash -c "cmp -s '$DT/sphere_64_roughness.png' '$GT/sphere_64_roughness.png' && cmp -s '$DT/sphere_64_metallic.png' '$GT/sphere_64_metallic.png'"
run image --model "$MODEL" --detail 0.015625 --chroma off --out "$T/detail_explicit" "$SPHERE"
check "image --detail 0.015625 = the default" cmp -s "$T/detail_explicit/sphere_64_albedo.png" "$DT/sphere_64_albedo.png"
run image --model "$MODEL" --detail 1.5 --out "$T/detail_bad" "$SPHERE"
check "image --detail 1.5 exits 2" [ $RC -eq 2 ]
check "image --detail 1.5 explains" grep -q -- "--detail" "$T/err"
run refine --detail 0.1 --map "$SPHERE" --mask "$SPHERE" --position "$SPHERE" --out "$T/detail_refine"
check "refine --detail exits 2 (a UV map has no picture)" [ $RC -eq 2 ]
# --chroma: image's default (1, after the detail step) changes the albedo only; 0 and off are the same;
# a value out of range is a usage error; views' default is off
CH=$T/chroma_default
run image --model "$MODEL" --out "$CH" "$SPHERE"
check "image with the default --chroma exits 0" [ $RC -eq 0 ]
check "image: the default --chroma changes the albedo" bash -c "! cmp -s '$CH/sphere_64_albedo.png' '$DT/sphere_64_albedo.png'"
check "image: the default --chroma leaves roughness and metallic" bash -c "cmp -s '$CH/sphere_64_roughness.png' '$DT/sphere_64_roughness.png' && cmp -s '$CH/sphere_64_metallic.png' '$DT/sphere_64_metallic.png'"
run image --model "$MODEL" --chroma 1 --detail 0.015625 --out "$T/chroma_explicit" "$SPHERE"
check "image --chroma 1 --detail 0.015625 = the default" cmp -s "$T/chroma_explicit/sphere_64_albedo.png" "$CH/sphere_64_albedo.png"
run image --model "$MODEL" --chroma 0 --out "$T/chroma_zero" "$SPHERE"
check "image --chroma 0 = --chroma off" cmp -s "$T/chroma_zero/sphere_64_albedo.png" "$DT/sphere_64_albedo.png"
run image --model "$MODEL" --chroma 0.5 --out "$T/chroma_half" "$SPHERE"
check "image --chroma 0.5 differs from 0 and 1" bash -c "! cmp -s '$T/chroma_half/sphere_64_albedo.png' '$DT/sphere_64_albedo.png' && ! cmp -s '$T/chroma_half/sphere_64_albedo.png' '$CH/sphere_64_albedo.png'"
for bad in 1.5 -0.1 nan grey; do
    run image --model "$MODEL" --chroma "$bad" --out "$T/chroma_bad" "$SPHERE"
    check "image --chroma $bad exits 2" [ $RC -eq 2 ]
    check "image --chroma $bad explains" grep -q -- "--chroma" "$T/err"
done
check "image --chroma bad: nothing written" bash -c "! ls '$T/chroma_bad'/*.png >/dev/null 2>&1"
run refine --chroma 1 --map "$SPHERE" --mask "$SPHERE" --position "$SPHERE" --out "$T/chroma_refine"
check "refine --chroma exits 2 (a UV map has no picture)" [ $RC -eq 2 ]

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

# mesh's renamed options (--texture-size, --view-weight) and their old spellings (--size, --weight): the same bake
if "$BIN" mesh --help 2>&1 | grep -q -- '--texture-size'; then
  EXM="$(cd "$DATA/../../examples/mesh" && pwd)/example_pbr.gltf"
  run mesh --passthrough --texture-size 64 --views-size 64 --view-weight cos "$EXM" "$T/mesh_new.glb"
  check "mesh --texture-size 64 --view-weight cos exits 0" [ $RC -eq 0 ]
  run mesh --passthrough --size 64 --views-size 64 --weight cos "$EXM" "$T/mesh_old.glb"
  check "mesh --size 64 --weight cos (the old spellings) exits 0" [ $RC -eq 0 ]
  check "mesh: the old spellings bake what the new ones bake" cmp -s "$T/mesh_new.glb" "$T/mesh_old.glb"
  run mesh --passthrough --texture-size 64 --views-size 64 "$EXM" "$T/mesh_avg.glb"
  check "mesh --view-weight cos changes the bake" bash -c "! cmp -s '$T/mesh_new.glb' '$T/mesh_avg.glb'"
fi

echo "$PASS passed, $FAIL failed"
[ "$FAIL" -eq 0 ]
