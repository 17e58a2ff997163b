#!/usr/bin/env bash
# Regenerate everything under tests/data/ (test images, tiny random-weight models, golden tensors) with the
# SuperMat reference harness (official SuperMat + diffusers code, CPU float32).  See tests/data/README.md.
#
#   HARNESS=<reference harness dir> HARNESS_DEPS=<its extracted deps> OUT=<scratch dir> scripts/make_goldens.sh
#
# Variables:
#   HARNESS       the reference harness directory (make_random_models.py, reference_run.py); required
#   HARNESS_DEPS  the harness' dependency folder prepared by its setup_env.sh (VERSIONS.txt inside); required
#   OUT           scratch output folder for models and full harness runs (NOT inside the repo); required
#   DEST          where the committed fixtures go (default: <repo>/tests/data)
#   PYTHON        default /usr/bin/python3 (Debian's, which sees python3-torch)
#   THREADS       torch threads (default 2)
# Nothing of the harness is copied here: this script only calls it and copies selected outputs.
set -euo pipefail
: "${HARNESS:?set HARNESS to the reference harness directory}"
: "${HARNESS_DEPS:?set HARNESS_DEPS to the harness dependency folder}"
: "${OUT:?set OUT to a scratch output directory (outside the repo)}"
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEST="${DEST:-$REPO/tests/data}"
PYTHON="${PYTHON:-/usr/bin/python3}"
export PYTHONPATH="$REPO/python${PYTHONPATH:+:$PYTHONPATH}"   # the tools: python -m supermat_tools.X
THREADS="${THREADS:-2}"
export HARNESS_DEPS
HARNESS="$(cd "$HARNESS" && pwd)"
mkdir -p "$OUT" "$DEST"
OUT="$(cd "$OUT" && pwd)"
DEST="$(cd "$DEST" && pwd)"
case "$OUT/" in "$REPO"/*) echo "OUT must be outside the repo"; exit 1;; esac
M="$OUT/models_tiny"
RUNS="$OUT/runs"
IMG="$DEST/img"

echo "== harness versions"; cat "$HARNESS_DEPS/VERSIONS.txt"

echo "== test images -> $IMG"
"$PYTHON" -m supermat_tools.make_test_images --out "$IMG"

echo "== tiny random models -> $M"
(cd "$HARNESS" && "$PYTHON" make_random_models.py --size tiny --seed 0 --out "$M" --threads "$THREADS")

echo "== reference runs -> $RUNS"
rm -rf "$RUNS"
run() { (cd "$HARNESS" && "$PYTHON" reference_run.py --models "$M" --threads "$THREADS" "$@"); }
run --mode single --input "$IMG/sphere_64.png" --image-size 64 --dump-blocks --out "$RUNS/single_sphere_64"
run --mode single --input "$IMG/box_40.png" --image-size 40 --out "$RUNS/single_box_40"
run --mode mv --input "$IMG/mv" --image-size 64 --num-views 6 --out "$RUNS/mv6_64"
run --mode uv --uv-map "$IMG/uv/uv_bc.png" --uv-position "$IMG/uv/uv_position.png" \
    --uv-mask "$IMG/uv/uv_mask.png" --image-size 128 --out "$RUNS/uv_128"
# non-square (reference_run.py only does square sizes): official pipeline via the harness' functions
PYTHONPATH="$HARNESS:$PYTHONPATH" "$PYTHON" -m supermat_tools.golden_extra --models "$M" --threads "$THREADS" \
    --input "$IMG/ring_48x72.png" --check-square "$IMG/sphere_64.png" --out "$RUNS/single_ring_48x72"

echo "== copy the selected files -> $DEST/tiny, $DEST/golden"
rm -rf "$DEST/tiny" "$DEST/golden"
mkdir -p "$DEST/tiny/base"
cp "$M/supermat.pth" "$M/supermat_mv.pth" "$M/uv_refine_bc.pth" "$M/manifest.json" "$DEST/tiny/"
for f in model_index.json empty_prompt_embeds.npy vae/config.json vae/diffusion_pytorch_model.safetensors \
         text_encoder/config.json text_encoder/model.safetensors scheduler/scheduler_config.json unet/config.json; do
  mkdir -p "$(dirname "$DEST/tiny/base/$f")"
  cp "$M/base/$f" "$DEST/tiny/base/$f"
done

"$PYTHON" -m supermat_tools.golden_copy "$RUNS" "$DEST" "$HARNESS_DEPS/VERSIONS.txt" \
    single_sphere_64:single+blocks single_box_40:single single_ring_48x72:single mv6_64:mv uv_128:uv

du -sh "$DEST" "$DEST"/*
