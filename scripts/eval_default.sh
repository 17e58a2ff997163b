#!/usr/bin/env bash
# The README's measurement of a model's material quality, one command: extracts the real glTF assets and the
# held-out lighting from the `fetch` mirrors, renders and predicts as `supermat image PICTURE` does (256² pictures,
# the network at the model's own work size, its defaults: the detail step on), measures against the truth and
# the two baselines, and prints each difference with its 95 % interval over the assets (supermat_tools.eval_ci).
#
#   MIRROR_DIR=<mirrors> WORK=<scratch dir> bash scripts/eval_default.sh [MODEL] [SET]
#
#   MIRROR_DIR  the folder of the bare git mirrors of github pmndrs/drei-assets (the CC0 Poly Haven maps; only
#               the three held-out ones light the evaluation) and sbtron/glTF-Sample-Models (evaluation only,
#               never training data; the assets are extracted under WORK and never committed), as the search
#               tool's `fetch` lays them out (MIRROR_DIR/<owner>+<name>/repo, bare or holding .git)
#   WORK        where the assets, renders, maps and results go (outside the repository)
#   MODEL       default: models/supermat_default.safetensors
#   SET         heldout (default: Avocado, WaterBottle, Suzanne, DamagedHelmet, BoomBox: the README's table),
#               validation (Monster, CesiumMan: what the settings were chosen on), other (CesiumMilkTruck, Duck,
#               2CylinderEngine, ReciprocatingSaw: used for no choice), or all
#   SIZE        picture size (default 256); VIEWS per asset and lighting (default 8); THREADS (default all)
#
# Each asset is seen in VIEWS views under each of the three held-out maps and re-rendered under the next one
# (eval_quality.py --env-in all); baseline (b) takes the generator's statistics from 400 renders of seed 0
# (supermat_tools.gen_data, about a minute). Writes WORK/<SET>.json (eval_quality.py), WORK/<SET>_vs_a.json and
# WORK/<SET>_vs_b.json (eval_ci.py). On 2026-11-29 (Zen 5, 2 threads) the held-out set took about 2 minutes with
# the network at 128²; on 2026-12-01 (AMX Xeon, 2 threads) about 4 minutes at the default model's 256², all eleven 6 min 49 s.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export PYTHONPATH="$PWD/python${PYTHONPATH:+:$PYTHONPATH}"   # the tools: python -m supermat_tools.X (python/README.md)
: "${MIRROR_DIR:?set MIRROR_DIR to the folder holding pmndrs+drei-assets and sbtron+glTF-Sample-Models}"
: "${WORK:?set WORK to a scratch folder outside the repository}"
MODEL="${1:-models/supermat_default.safetensors}"
SET="${2:-heldout}"
SIZE="${SIZE:-256}"; VIEWS="${VIEWS:-8}"; THREADS="${THREADS:-0}"
PY=/usr/bin/python3

gitdir() {   # the mirror's git directory, bare or not
  local d="$MIRROR_DIR/$1/repo"
  [ -d "$d/.git" ] && d="$d/.git"
  git --git-dir="$d" rev-parse --git-dir >/dev/null 2>&1 || { echo "eval_default: no git mirror at $d" >&2; exit 1; }
  echo "$d"
}
case "$SET" in
  heldout)    ASSETS="Avocado WaterBottle Suzanne DamagedHelmet BoomBoxWithAxes" ;;
  validation) ASSETS="Monster CesiumMan" ;;
  other)      ASSETS="CesiumMilkTruck Duck 2CylinderEngine ReciprocatingSaw" ;;
  all)        ASSETS="Avocado WaterBottle Suzanne DamagedHelmet BoomBoxWithAxes Monster CesiumMan CesiumMilkTruck Duck 2CylinderEngine ReciprocatingSaw" ;;
  *) echo "eval_default: SET is heldout, validation, other or all, not '$SET'" >&2; exit 2 ;;
esac
[ -f "$MODEL" ] || { echo "eval_default: no model file $MODEL" >&2; exit 1; }
H="$(gitdir pmndrs+drei-assets)"
G="$(gitdir sbtron+glTF-Sample-Models)"
[ -x build/supermat ] || { cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null && cmake --build build -j"$(nproc)" --target supermat >/dev/null; }

mkdir -p "$WORK/gltf"
git --git-dir="$H" archive HEAD hdri | tar -x -C "$WORK"
paths=()
for a in $ASSETS; do
  [ -f "$WORK/gltf/2.0/$a/glTF/$a.gltf" ] || git --git-dir="$G" archive HEAD "2.0/$a/glTF" | tar -x -C "$WORK/gltf"
  p="$WORK/gltf/2.0/$a/glTF/$a.gltf"
  [ "$a" = BoomBoxWithAxes ] && p="$p#BoomBox"   # the box alone, without the axes (2.0/BoomBox/glTF is incomplete in the mirror)
  paths+=("$p")
done

[ -f "$WORK/stats400/stats.json" ] || $PY -m supermat_tools.gen_data --hdri-dir "$WORK/hdri" --out "$WORK/stats400" --count 400 \
    --size 128 --seed 0 --jobs "$(nproc)" >/dev/null
ws=$(build/supermat info "$MODEL" | sed -n 's/^work size *\([0-9]*\)x.*/\1/p' | head -1)
$PY -m supermat_tools.eval_quality --assets "${paths[@]}" --env-in all --size "$SIZE" --views "$VIEWS" --hdri-dir "$WORK/hdri" \
    --model "model=$MODEL" ${ws:+--image-args "--work-size $ws"} --baselines input_as_albedo,dataset_mean \
    --dataset-stats "$WORK/stats400/stats.json" --threads "$THREADS" --work "$WORK/$SET" --json "$WORK/$SET.json"
echo
$PY -m supermat_tools.eval_ci "$WORK/$SET.json" --ref input_as_albedo --pred model --json "$WORK/${SET}_vs_a.json"
echo
$PY -m supermat_tools.eval_ci "$WORK/$SET.json" --ref dataset_mean --pred model --json "$WORK/${SET}_vs_b.json"
