#!/usr/bin/env bash
# Golden tensors of the trained default model from the official pipeline (reference harness: official SuperMat
# + diffusers code, CPU float32), for ctest golden_default: the C runtime on models/supermat_default.safetensors
# must match the training framework's own forward pass.
#
#   HARNESS=<reference harness dir> HARNESS_DEPS=<its deps> RELEASE=<train run>/release OUT=<scratch> \
#       tools/make_default_golden.sh
#
# RELEASE is the folder tools/train_default.py exports (supermat.pth + base/); its weights are float16 values,
# so the f16 model file holds exactly what the official code runs here.  Input: examples/pictures/obj00.png
# resized to 128x128 by the official loader (PIL bilinear; the resized 8-bit picture is kept):
# tests/data/golden/default_obj00_128.
set -euo pipefail
: "${HARNESS:?}"; : "${HARNESS_DEPS:?}"; : "${RELEASE:?}"; : "${OUT:?}"
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PYTHON="${PYTHON:-/usr/bin/python3}"
export HARNESS_DEPS
RELEASE="$(cd "$RELEASE" && pwd)"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
IMG="$REPO/examples/pictures/obj00.png"
rm -rf "$OUT/default_obj00_128"
(cd "$HARNESS" && "$PYTHON" reference_run.py --models "$RELEASE" --mode single --input "$IMG" \
    --image-size 128 --threads "${THREADS:-2}" --out "$OUT/default_obj00_128")
"$PYTHON" "$REPO/tools/golden_copy.py" "$OUT" "$REPO/tests/data" "$HARNESS_DEPS/VERSIONS.txt" default_obj00_128:single
