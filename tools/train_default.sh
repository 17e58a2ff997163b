#!/usr/bin/env bash
# Train the default model from scratch, or resume an interrupted run: data -> VAE -> UNet -> a second data set
# with fewer metals -> UNet fine-tuned on it -> official-format release -> `supermat convert --precision f16`
# -> models/supermat_default.safetensors.
#
#   MIRROR_DIR=<mirrors> HARNESS_DEPS=<deps> WORK=<scratch dir> bash tools/train_default.sh
#
#   MIRROR_DIR    folder with the bare git mirror of github pmndrs/drei-assets (MIRROR_DIR/pmndrs+drei-assets/repo,
#                 as the search tool's `fetch` lays it out): its CC0 Poly Haven hdri/*.hdr are the only lighting
#   HARNESS_DEPS  the reference harness' extracted diffusers / SuperMat sources (../shared/reference/README.md)
#   WORK          where data, checkpoints and logs go (outside the repository); run the same command again
#                 to resume: finished data shards and training phases are kept, the others restart from
#                 their last checkpoint
#   COUNT         training samples (default 20000), SEED (default 0), THREADS (default: all cores)
#   COUNT2        samples of the second set (default 6000, seed SEED + 1); AMP bf16 | off for its phases
#   TRAIN_ARGS    extra arguments for tools/train_default.py (step counts, batch sizes, learning rates)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
: "${MIRROR_DIR:?set MIRROR_DIR to the folder holding pmndrs+drei-assets/repo}"
: "${HARNESS_DEPS:?set HARNESS_DEPS to the reference harness dependency folder}"
: "${WORK:?set WORK to a scratch folder outside the repository}"
export HARNESS_DEPS
COUNT="${COUNT:-20000}"
SEED="${SEED:-0}"
THREADS="${THREADS:-$(nproc 2>/dev/null || echo 2)}"
COUNT2="${COUNT2:-6000}"
# bf16 autocast for the fine-tuning where the CPU has AMX or AVX512_BF16 (the shipped model's ft phases ran so;
# an e2e step: 1.56 s on AMX; 3.7 s with AVX512_BF16 but no AMX, where float32 takes 4.25 s), else float32
AMP="${AMP:-$(grep -qwE 'amx_bf16|avx512_bf16' /proc/cpuinfo 2>/dev/null && echo bf16 || echo off)}"
PY=/usr/bin/python3

need=()
for p in python3-torch python3-numpy python3-pil libopenblas0-pthread cmake make gcc g++ libstb-dev; do
  dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi

mkdir -p "$WORK/hdri"
git --git-dir="$MIRROR_DIR/pmndrs+drei-assets/repo" archive HEAD hdri | tar -x -C "$WORK"

echo "== data ($COUNT samples, 128x128)"
$PY tools/gen_data.py --hdri-dir "$WORK/hdri" --out "$WORK/data128" --count "$COUNT" --size 128 \
    --seed "$SEED" --jobs "$THREADS"

echo "== training"
# shellcheck disable=SC2086
$PY tools/train_default.py --data "$WORK/data128" --out "$WORK/run" --hdri-dir "$WORK/hdri" --seed "$SEED" \
    --threads "$THREADS" ${TRAIN_ARGS:-}

echo "== data, second set ($COUNT2 samples, seed $((SEED + 1)), fewer metals: material modes 0.62 / 0.12 / 0.13 / 0.13)"
$PY tools/gen_data.py --hdri-dir "$WORK/hdri" --out "$WORK/data128b" --count "$COUNT2" --size 128 \
    --seed "$((SEED + 1))" --jobs "$THREADS" --mode-probs 0.62,0.12,0.13,0.13

echo "== fine-tuning on it (latent 2000 steps, end to end 100)"
$PY tools/train_default.py --data "$WORK/data128b" --out "$WORK/run" --hdri-dir "$WORK/hdri" --seed "$SEED" \
    --threads "$THREADS" --amp "$AMP" --phases ft,ft_e2e,export

echo "== conversion"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_UV_TESTS=OFF >/dev/null
cmake --build build -j"$THREADS" --target supermat
mkdir -p models
build/supermat convert --force --kind supermat --unet "$WORK/run/release/supermat.pth" --base "$WORK/run/release/base" \
    --precision f16 --work-size 128 --out models/supermat_default.safetensors
build/supermat info models/supermat_default.safetensors
