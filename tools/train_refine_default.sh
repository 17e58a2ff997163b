#!/usr/bin/env bash
# Train the two UV-refine defaults (models/supermat_refine_albedo_default.safetensors and
# models/supermat_refine_rm_default.safetensors, which `supermat mesh --refine` takes) from the multi-view default,
# or resume an interrupted run: refine data baked by the mesh pipeline itself on procedural meshes ->
# tools/train_refine.py, the albedo and the roughness / metallic network side by side -> official-format release
# (state dicts + base folder, and the goldens of the training framework's own forward pass) -> `supermat convert
# --kind uv-refine` -> the C runtime checked against those goldens (tests/test_golden.c).
#
#   MIRROR_DIR=<mirrors> HARNESS_DEPS=<deps> WORK=<scratch dir> bash tools/train_refine_default.sh
#
#   MIRROR_DIR, HARNESS_DEPS, WORK, THREADS, AMP: read by tools/train_env.sh, as for tools/train_default.sh (run the
#     same command again to resume: finished data shards and phases are kept, the others restart from their last
#     checkpoint)
#   COUNT     procedural meshes (default 600; the last 40 are train_refine.py's held-out meshes)
#   STEPS_BC, STEPS_RM  the two networks' steps of batch 8 (default 691 and 715)
#   OUTDIR    where the two model files go (default models/)
#
# The shipped files were made on 2026-11-29 on a 2-core Zen 5 (AVX512_BF16, --amp bf16) with a wall-clock budget
# of 30 min per network (--seconds bc=1800 / rm=1800, both side by side with one thread each), which set the step
# totals 691 / 715 (and with them the cosine learning-rate schedule's length); this script gives those step counts,
# so it makes the same recipe, not the same bytes on another CPU. Measured there: data 659 s (600 meshes at 256²,
# 2 processes), the two networks 30 min side by side, export (goldens, held-out report) and conversion about 1 min.
# The shipped files convert byte for byte from that run's release folder.
# shellcheck source=tools/train_env.sh
source "$(dirname "${BASH_SOURCE[0]}")/train_env.sh"
COUNT="${COUNT:-600}"
STEPS_BC="${STEPS_BC:-691}"
STEPS_RM="${STEPS_RM:-715}"
OUTDIR="${OUTDIR:-models}"
MV=models/supermat_mv_default.safetensors
[ -f "$MV" ] || { echo "train_refine_default: $MV missing (tools/train_mv_default.sh makes it)" >&2; exit 1; }

need=()   # the mesh command (tinygltf) and the data generator's scipy
for p in libtinygltf-dev python3-scipy; do dpkg -s "$p" >/dev/null 2>&1 || need+=("$p"); done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$THREADS" --target supermat test_golden >/dev/null
mesh_help=$(build/supermat mesh --help 2>&1 || true)
[[ "$mesh_help" == *--refine* ]] || { echo "train_refine_default: build/supermat has no mesh command (libtinygltf-dev)" >&2; exit 1; }

echo "== refine data ($COUNT procedural meshes baked by the multi-view default, seed 0, 256x256)"
$PY tools/gen_refine_data.py --hdri-dir "$WORK/hdri" --out "$WORK/refdata" --model "$MV" --count "$COUNT" --seed 0 \
    --jobs "$THREADS"

R=("$PY" tools/train_refine.py --data "$WORK/refdata" --init-from "$MV" --batch 8 --lr 2e-4 --unseen-weight 3
   --level-aug 0.3 --seed 0 --amp "$AMP")
if [ "$THREADS" -ge 2 ]; then
  half=$((THREADS / 2))
  echo "== the two networks side by side, $half thread(s) each: albedo $STEPS_BC steps, roughness / metallic $STEPS_RM"
  "${R[@]}" --out "$WORK/refine_bc" --phases bc --steps "$STEPS_BC" --threads "$half" > "$WORK/refine_bc.log" 2>&1 &
  pid=$!
  rc_rm=0
  "${R[@]}" --out "$WORK/refine_rm" --phases rm --steps "$STEPS_RM" --threads "$half" > "$WORK/refine_rm.log" 2>&1 || rc_rm=$?
  rc_bc=0
  wait "$pid" || rc_bc=$?
  tail -n 2 "$WORK/refine_bc.log" "$WORK/refine_rm.log"
  [ "$rc_bc" -eq 0 ] && [ "$rc_rm" -eq 0 ] || { echo "train_refine_default: training failed (bc $rc_bc, rm $rc_rm; logs in $WORK)" >&2; exit 1; }
else
  echo "== the two networks one after the other: albedo $STEPS_BC steps, roughness / metallic $STEPS_RM"
  "${R[@]}" --out "$WORK/refine_bc" --phases bc --steps "$STEPS_BC" --threads "$THREADS"
  "${R[@]}" --out "$WORK/refine_rm" --phases rm --steps "$STEPS_RM" --threads "$THREADS"
fi

echo "== export (state dicts, base folder, goldens, held-out report)"
cp "$WORK/refine_rm/ckpt_rm.pt" "$WORK/refine_bc/ckpt_rm.pt"
"${R[@]}" --out "$WORK/refine_bc" --phases export --steps "$STEPS_BC" --threads "$THREADS"
REL="$WORK/refine_bc/release"

echo "== conversion and the C runtime against the training framework's forward pass"
mkdir -p "$OUTDIR"
for n in bc:albedo rm:rm; do
  net="${n%%:*}"; file="$OUTDIR/supermat_refine_${n#*:}_default.safetensors"
  build/supermat convert --force --kind uv-refine --unet "$REL/uv_refine_$net.pth" --base "$REL/base" --precision f16 \
      --work-size 256 --out "$file"
  build/test_golden "$file" auto "$THREADS" "$REL/golden/refine_${net}_128" | tail -n 1
done
cat "$REL/report_refine.json"
echo "(to make these the tests' goldens: cp -r $REL/golden/refine_bc_128 tests/data/golden/refine_bc_default_128, and rm alike)"
