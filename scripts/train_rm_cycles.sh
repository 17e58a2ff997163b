#!/usr/bin/env bash
# One round of the default model's roughness / metallic branch on pictures of the independent renderer (issue 61;
# measured, not shipped): procedural assets with seeds of their own rendered by Blender's Cycles under the training
# maps, beside the project renderer's samples; the rm phase (that branch alone, the albedo bit-identical) from the
# shipped default model; the candidate converted with the shipped model's pipeline (work size, detail, colour,
# roughness curve); both scored on the validation part: procedural assets of seed 61000 under Blender's own world
# maps, which no training picture is lit by (docs/notebook/default_model.md, *Cycles training renders*).
#
#   MIRROR_DIR=<mirrors> WORK=<scratch dir> bash scripts/train_rm_cycles.sh
#
#   MIRROR_DIR, WORK, THREADS, AMP, HARNESS_DEPS   as scripts/train_default.sh (train_env.sh); MIRROR_DIR must also
#               hold sbtron+glTF-Sample-Models when HELDOUT=1
#   COUNT       procedural training assets (default 240), VIEWS of each (8), at 128² and 32 samples
#   DARK_METAL, METAL_ROUGH   cycles_procedural's --dark-metal / --metal-rough for those assets (default 0 and 0:
#               the earlier rounds' assets); with others the assets, renders, run and results carry _dD_rR
#   GEN_COUNT   project-renderer samples beside them (default 2048; gen_data seed 15, --photo 0.5)
#   STEPS       rm steps of batch 8 (default 400), RM_LOSS (default squared), RM_DISTIL (default roughness: the
#               roughness target is the shipped model's own map while the metallic learns; none: the truth)
#   VAL_COUNT   validation assets (default 12), 4 views at 256², 64 samples
#   HELDOUT=1   also scores the Cycles held-out four (real assets; look once per change)
#
# Every step resumes: assets and renders already there are kept, data shards and training phases continue
# (train_default), the conversion and the scores are redone. Writes WORK/rm.safetensors, WORK/val.json (and
# WORK/heldout.json). Times on 2 cores: about 11-19 s of Cycles per training asset, 5-8 min per 1000 project
# samples, an rm step of batch 8 1.1 s with AMX and bf16 (docs/notebook/default_model.md).
set -euo pipefail
TRAIN_PACKAGES="blender"
# shellcheck source=scripts/train_env.sh
source "$(dirname "${BASH_SOURCE[0]}")/train_env.sh"
COUNT="${COUNT:-240}"; VIEWS="${VIEWS:-8}"; GEN_COUNT="${GEN_COUNT:-2048}"; STEPS="${STEPS:-400}"
RM_LOSS="${RM_LOSS:-squared}"; RM_DISTIL="${RM_DISTIL:-roughness}"; VAL_COUNT="${VAL_COUNT:-12}"
DARK_METAL="${DARK_METAL:-0}"; METAL_ROUGH="${METAL_ROUGH:-0}"
sfx=""   # the files of a round with other assets carry their setting: cyc_d0.6_r0.5_set, run_d0.6_r0.5, rm_d0.6_r0.5...
[ "$DARK_METAL" = 0 ] && [ "$METAL_ROUGH" = 0 ] || sfx="_d${DARK_METAL}_r${METAL_ROUGH}"
SHIPPED=models/supermat_default.safetensors

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_UV_TESTS=OFF >/dev/null
cmake --build build -j"$THREADS" --target supermat >/dev/null

echo "== training renders: $COUNT procedural assets (seed 62000), Cycles under the training maps"
$PY -m supermat_tools.cycles_procedural --hdri-dir "$WORK/hdri" --out "$WORK/cyc${sfx}_assets" --count "$COUNT" \
    --seed 62000 --size 256 --mode-probs 0.42,0.2,0.2,0.18 --dark-metal "$DARK_METAL" --metal-rough "$METAL_ROUGH"
worlds=$($PY -c "import os, sys; from supermat_tools import gen_data as G
print(','.join(sorted(f[:-4] for f in os.listdir(sys.argv[1]) if f.endswith('.hdr') and f[:-4] not in G.HELD_OUT)))" "$WORK/hdri")
$PY -m supermat_tools.cycles_render --gltf-dir "$WORK/cyc${sfx}_assets" --out "$WORK/cyc${sfx}_set" --views "$VIEWS" --size 128 \
    --samples 32 --seed 62 --world-dir "$WORK/hdri" --worlds "$worlds" --normals --threads "$THREADS"
$PY -m supermat_tools.cycles_data --set "$WORK/cyc${sfx}_set" --hdri-dir "$WORK/hdri" --out "$WORK/cyc${sfx}_data"

echo "== $GEN_COUNT project-renderer samples (seed 15)"
$PY -m supermat_tools.gen_data --hdri-dir "$WORK/hdri" --out "$WORK/data_s15" --count "$GEN_COUNT" --size 128 \
    --seed 15 --photo 0.5 --jobs "$THREADS"

echo "== rm phase: $STEPS steps, loss $RM_LOSS, distilled: $RM_DISTIL"
$PY -m supermat_tools.train_default --data "$WORK/cyc${sfx}_data,$WORK/data_s15" --out "$WORK/run$sfx" --hdri-dir "$WORK/hdri" \
    --threads "$THREADS" --amp "$AMP" --init-from "$SHIPPED" --phases rm,export --rm-steps "$STEPS" \
    --rm-loss "$RM_LOSS" --rm-distil "$RM_DISTIL" --e2e-batch 8 --e2e-permute 1
curve=$(build/supermat info "$SHIPPED" | sed -n 's/^roughness *through the curve \([0-9.,]*\).*/\1/p')
[ -n "$curve" ] || { echo "train_rm_cycles: $SHIPPED records no roughness curve" >&2; exit 1; }
build/supermat convert --force --kind supermat --unet "$WORK/run$sfx/release/supermat.pth" --base "$WORK/run$sfx/release/base" \
    --weights f16 --work-size 256 --detail 0.015625 --chroma 1 --roughness-curve "$curve" --out "$WORK/rm$sfx.safetensors"

echo "== validation: $VAL_COUNT procedural assets (seed 61000) under Blender's world maps"
$PY -m supermat_tools.cycles_procedural --hdri-dir "$WORK/hdri" --out "$WORK/val_assets" --count "$VAL_COUNT" --seed 61000
$PY -m supermat_tools.cycles_render --gltf-dir "$WORK/val_assets" --out "$WORK/val_set" --views 4 --seed 61 --threads "$THREADS"
val=$(cd "$WORK/val_assets" && ls -d proc_* | head -n "$VAL_COUNT" | paste -sd, -)
score() {  # score SET JSON [eval_cycles options]: the shipped model and the candidate, constants at the generator's means
  local set=$1 json=$2
  shift 2
  $PY -m supermat_tools.eval_cycles --set "$set" "$@" --dataset-stats "$WORK/data_s15/stats.json" \
      --model shipped="$SHIPPED" --model rm="$WORK/rm$sfx.safetensors" --supermat build/supermat --threads "$THREADS" \
      --work "$WORK/maps_$(basename "$json" .json)" --json "$json"
}
score "$WORK/val_set" "$WORK/val$sfx.json" --assets "$val" --reliability

if [ "${HELDOUT:-0}" = 1 ]; then
  echo "== the Cycles held-out four (real assets)"
  d="$MIRROR_DIR/sbtron+glTF-Sample-Models/repo"
  [ -d "$d/.git" ] && d="$d/.git"
  mkdir -p "$WORK/gltf"
  for a in Avocado WaterBottle Suzanne DamagedHelmet; do
    [ -f "$WORK/gltf/2.0/$a/glTF/$a.gltf" ] || git --git-dir="$d" archive HEAD "2.0/$a/glTF" | tar -x -C "$WORK/gltf"
  done
  $PY -m supermat_tools.cycles_render --gltf-dir "$WORK/gltf/2.0" --assets Avocado,WaterBottle,Suzanne,DamagedHelmet \
      --out "$WORK/heldout_set" --threads "$THREADS"
  score "$WORK/heldout_set" "$WORK/heldout$sfx.json" --part heldout
fi
