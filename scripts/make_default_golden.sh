#!/usr/bin/env bash
# Golden tensors of the trained default model from the official pipeline (reference harness: official SuperMat
# + diffusers code, CPU float32), for ctest golden_default: the C runtime on models/supermat_default.safetensors
# must match the training framework's own forward pass.
#
#   HARNESS=<reference harness dir> HARNESS_DEPS=<its deps> RELEASE=<train run>/release OUT=<scratch> \
#       scripts/make_default_golden.sh
#
# RELEASE is the folder supermat_tools.train_default exports (supermat.pth + base/); its weights are float16 values,
# so the f16 model file holds exactly what the official code runs here.  Input: examples/pictures/obj00.png
# resized to 128x128 by the official loader (PIL bilinear; the resized 8-bit picture is kept):
# tests/data/golden/default_obj00_128.
#
# MV_RELEASE=<train_mv.py run>/release (supermat_mv.pth + base/) adds the multi-view default's golden,
# tests/data/golden/mv_default_example_128: the official multi-view pipeline on the six official views of the
# committed example mesh (examples/mesh/lit, rendered by `supermat mesh --passthrough --debug-dir` at 128², the
# cameras of tests/data/img/mv/meta.json, which are supermat_uv.h's six).  Needs build/supermat.
set -euo pipefail
: "${HARNESS:?}"; : "${HARNESS_DEPS:?}"; : "${OUT:?}"
[ -n "${RELEASE:-}${MV_RELEASE:-}" ] || { echo "make_default_golden.sh: set RELEASE, MV_RELEASE or both"; exit 2; }
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PYTHON="${PYTHON:-/usr/bin/python3}"
export PYTHONPATH="$REPO/python${PYTHONPATH:+:$PYTHONPATH}"   # the tools: python -m supermat_tools.X
export HARNESS_DEPS
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
if [ -n "${RELEASE:-}" ]; then
  RELEASE="$(cd "$RELEASE" && pwd)"
  IMG="$REPO/examples/pictures/obj00.png"
  rm -rf "$OUT/default_obj00_128"
  (cd "$HARNESS" && "$PYTHON" reference_run.py --models "$RELEASE" --mode single --input "$IMG" \
      --image-size 128 --threads "${THREADS:-2}" --out "$OUT/default_obj00_128")
  "$PYTHON" -m supermat_tools.golden_copy "$OUT" "$REPO/tests/data" "$HARNESS_DEPS/VERSIONS.txt" default_obj00_128:single
fi

if [ -n "${MV_RELEASE:-}" ]; then
  MV_RELEASE="$(cd "$MV_RELEASE" && pwd)"
  CASE="$OUT/mv_example_views"
  rm -rf "$CASE" "$OUT/mv_default_example_128"
  mkdir -p "$CASE/debug"
  "$REPO/build/supermat" mesh --passthrough --views-size 128 --size 256 --debug-dir "$CASE/debug" \
      "$REPO/examples/mesh/lit/example_pbr_lit.gltf" "$CASE/debug/out.gltf"
  for k in 0 1 2 3 4 5; do cp "$CASE/debug/view_$k.png" "$CASE/color_000$k.png"; done
  cp "$REPO/tests/data/img/mv/meta.json" "$CASE/"
  (cd "$HARNESS" && "$PYTHON" reference_run.py --models "$MV_RELEASE" --mode mv --input "$CASE" --num-views 6 \
      --image-size 128 --threads "${THREADS:-2}" --out "$OUT/mv_default_example_128")
  "$PYTHON" -m supermat_tools.golden_copy "$OUT" "$REPO/tests/data" "$HARNESS_DEPS/VERSIONS.txt" mv_default_example_128:mv
fi
