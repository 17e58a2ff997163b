#!/usr/bin/env bash
# tests/test_cli.sh - end-to-end test of the `supermat` command-line tool.
#
#   tests/test_cli.sh BUILD/supermat tests/data
#
# Converts the tiny official-format checkpoint, runs `info`, runs `image` on two test images (square and
# non-square) with and without --float, and checks file names, PNG sizes and colour types (IHDR bytes
# read with od), PFM headers and sizes, that --outputs limits what is written, that threads do not
# change the bits, and that bad input (an image that is not a multiple of 8, a missing model, bad
# options) fails with a message and the documented exit code. Needs only bash, coreutils and od.
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

# runs the tool, keeping stdout, stderr and the exit code
run() {
    set +e
    "$BIN" "$@" >"$T/out" 2>"$T/err"
    RC=$?
    set -e
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
for c in convert image info bench; do
    run "$c" --help
    check "$c --help exits 0" [ $RC -eq 0 ]
    check "$c --help prints usage" grep -q "usage: supermat $c" "$T/out"
done
run image --help
check "image --help says images are not resized" grep -q 'NOT resized' "$T/out"
check "image --help says multiples of 8" grep -q 'multiples of 8' "$T/out"
run
check "no command exits 2" [ $RC -eq 2 ]
run frobnicate
check "unknown command exits 2" [ $RC -eq 2 ]
run image --model x --out "$T/o" --no-such-option "$SPHERE"
check "unknown option exits 2" [ $RC -eq 2 ]
check "unknown option is named" grep -q 'no-such-option' "$T/err"
run image --out "$T/o" "$SPHERE"
check "image without --model exits 2" [ $RC -eq 2 ]
run image --model x --out "$T/o" --outputs albedo,shininess "$SPHERE"
check "bad --outputs exits 2" [ $RC -eq 2 ]
run image --model x --out "$T/o" --threads
check "option without value exits 2" [ $RC -eq 2 ]
run bench --model x --size 30
check "bench --size 30 exits 2" [ $RC -eq 2 ]
run convert --unet x.pth --base x --out y --dtype f8
check "convert bad --dtype exits 2" [ $RC -eq 2 ]

# ---- convert ----------------------------------------------------------------------------------
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$MODEL"
check "convert exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "convert writes the model" [ -s "$MODEL" ]
absent "$MODEL.tmp"
run convert --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$T/tiny_f16.safetensors" --dtype f16
check "convert --dtype f16 (kind detected) exits 0" [ $RC -eq 0 ]
run convert --unet "$T/missing.pth" --base "$DATA/tiny/base" --out "$T/never.safetensors"
check "convert of a missing checkpoint exits 1" [ $RC -eq 1 ]
check "convert error names the file" grep -q 'missing.pth' "$T/err"
absent "$T/never.safetensors"

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

O5=$T/out5
run image --model "$T/tiny_f16.safetensors" --out "$O5" "$SPHERE"
check "image with the f16 model exits 0" [ $RC -eq 0 ]
check_png "$O5/sphere_64_albedo.png" 64 64 2

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

echo "$PASS passed, $FAIL failed"
[ "$FAIL" -eq 0 ]
