#!/usr/bin/env bash
# tests/cli/test_pack.sh - `supermat pack` and pre-packed model files.
#
#   bash tests/cli/test_pack.sh BUILD/supermat tests/data
#
# pack writes a file whose panels are used in place (info says so; image gives the original's bytes), as does
# convert --packed and convert --from of a pre-packed file; a Winograd-packed file runs with the options it
# was packed for, other weights than packed for exit 1; packing a pre-packed file, over an existing file, a
# bad --conv (exit 2) and a write that fails (exit 1, no file left) are refused.
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny

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

summary
