#!/usr/bin/env bash
# tests/cli/test_info.sh - `supermat info`: what it says about a model file.
#
#   bash tests/cli/test_info.sh BUILD/supermat tests/data
#
# The kind, architecture, branch and VAE parameters, dtypes (F32, F16), the file size, model and session
# memory of the tiny model; the bake detail it records (none; the multi-view default in models/ 1/32, the
# single-view default none); a PNG instead of a model exits 1 with a message. (info on the other kinds is in
# test_views.sh / test_refine.sh, --weights and --work-size in test_convert.sh, pre-packed files in
# test_pack.sh, info without FILE in test_default_model.sh.)
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny
setup_tiny_f16

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
check "info: no bake detail recorded" grep -Eq '^bake detail +none' "$T/out"
MODELS_DIR=$TESTS_DIR/../models
if [ -f "$MODELS_DIR/supermat_mv_default.safetensors" ]; then
    run info "$MODELS_DIR/supermat_mv_default.safetensors"
    check "info on the multi-view default: kind supermat-mv" grep -Eq '^kind +supermat-mv$' "$T/out"
    check "info on the multi-view default: bake detail 1/32" grep -Eq "^bake detail +0.03125 of the texture's larger side" "$T/out"
fi
if [ -f "$MODELS_DIR/supermat_default.safetensors" ]; then
    run info "$MODELS_DIR/supermat_default.safetensors"
    check "info on the single-view default: no bake detail" grep -Eq '^bake detail +none' "$T/out"
fi
run info "$T/tiny_f16.safetensors"
check "info f16: F16 tensors" grep -q 'F16: [0-9]* tensor' "$T/out"
run info "$SPHERE"
check "info on a PNG exits 1" [ $RC -eq 1 ]
check "info on a PNG explains" grep -q 'error' "$T/err"

summary
