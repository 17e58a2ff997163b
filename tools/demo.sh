#!/usr/bin/env bash
# The main job on the embedded default model: build the tool, convert the model, turn a picture into
# albedo / roughness / metallic maps under out/.
# NOTE: no trained default model can be shipped yet; the default is the TINY RANDOM-WEIGHT model in
# tests/data/tiny (official architecture, random weights). Its maps are not meaningful materials;
# the pipeline, file formats and speed path are the real ones. Point MODEL_PTH/BASE_DIR at the official
# supermat.pth and a Stable Diffusion 2.1 folder to run the real model.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
MODEL_PTH="${MODEL_PTH:-tests/data/tiny/supermat.pth}"
BASE_DIR="${BASE_DIR:-tests/data/tiny/base}"
IMAGE="${IMAGE:-tests/data/img/sphere_64.png}"
need=()
for p in cmake make gcc g++ libstb-dev; do dpkg -s "$p" >/dev/null 2>&1 || need+=("$p"); done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_UV_TESTS=OFF >/dev/null
cmake --build build -j"$(nproc 2>/dev/null || echo 2)" --target supermat
mkdir -p out
build/supermat convert --kind supermat --unet "$MODEL_PTH" --base "$BASE_DIR" --out out/model.safetensors
build/supermat image --model out/model.safetensors --out out "$IMAGE"
ls -l out
