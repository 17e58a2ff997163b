#!/usr/bin/env bash
# tests/cli/test_default_model.sh - the default model: no --model -> $SUPERMAT_MODEL, the installed data folder, the source tree.
#
#   bash tests/cli/test_default_model.sh BUILD/supermat tests/data
#
# SUPERMAT_MODEL naming the tiny model is used by image (the maps of --model), info and bench (also
# bench --image), naming a missing file is an error naming it, --model wins over it; a copy of the tool in
# PREFIX/bin finds PREFIX/share/supermat/supermat_default.safetensors, and without any the message lists the
# places (lib.sh removes SUPERMAT_MODEL from the environment of every other run). (--help naming the default
# model's work size is in test_convert.sh.)
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny
# the maps of --model, to compare with
O1=$T/out1/nested
run image --model "$MODEL" --out "$O1" "$SPHERE"
check "image --model (the maps to compare with) exits 0" [ $RC -eq 0 ]

# ---- the default model: no --model -> $SUPERMAT_MODEL, the installed data folder, the source tree ----
OD=$T/default_env
run_env SUPERMAT_MODEL="$MODEL" -- image --out "$OD" "$SPHERE"
check "image without --model, SUPERMAT_MODEL set, exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$OD/sphere_64_albedo.png" 64 64 6
check_png "$OD/sphere_64_roughness.png" 64 64 4
check_png "$OD/sphere_64_metallic.png" 64 64 4
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

summary
