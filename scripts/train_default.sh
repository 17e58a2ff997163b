#!/usr/bin/env bash
# Train the default model from scratch, or resume an interrupted run: data -> VAE -> UNet -> a second data set
# with fewer metals -> UNet fine-tuned on it -> official-format release -> `supermat convert --weights f16`
# (the third version) -> with STAGE4=1 (the default) the fourth version: the VAE trained on with a colour term,
# the UNet on its latents, then end to end -> models/supermat_default.safetensors.
#
#   MIRROR_DIR=<mirrors> WORK=<scratch dir> bash scripts/train_default.sh
#
#   MIRROR_DIR    folder with the bare git mirror of github pmndrs/drei-assets (MIRROR_DIR/pmndrs+drei-assets/repo,
#                 as the search tool's `fetch` lays it out): its CC0 Poly Haven hdri/*.hdr are the only lighting
#   Python packages: diffusers 0.27 or newer (checked with 0.31.0), transformers and safetensors on the ordinary
#                 Python path (pip or PYTHONPATH; checked by scripts/train_env.sh before any data is rendered);
#                 the SuperMat classes are the project's own, supermat_tools.supermat_adapters
#   HARNESS_DEPS  optional: a folder whose site/ holds extracted diffusers / huggingface_hub (/ transformers /
#                 safetensors) sources, put first on the Python path (no default)
#   WORK          where data, checkpoints and logs go (outside the repository); run the same command again
#                 to resume: finished data shards and training phases are kept, the others restart from
#                 their last checkpoint
#   COUNT         training samples (default 20000), SEED (default 0), THREADS (default: all cores)
#   COUNT2        samples of the second set (default 6000, seed SEED + 1); AMP bf16 | off for its phases
#   TRAIN_ARGS    extra arguments for supermat_tools.train_default (step counts, batch sizes, learning rates)
#   STAGE4        1 (default): go on to the fourth version (below); 0: stop at the third
#
# The fourth version as shipped was made partly on a lent GPU (scripts/train_gpu.sh: seeds 13 and 14, its renders
# cut by wall-clock budgets); STAGE4 replays it on the CPU with the step counts those budgets set (the logs:
# ft 242 of 242, ft_e2e 730 of a 797-step schedule, e2e_more 354 of 354) and render counts (4175, 2075: the
# device kept the shards its 16 processes finished in time, which need not be shards 0..N-1 exactly), so
# it gives a model of the same recipe, not the same file.  Measured (2026-11-29, Zen 5, 2 cores, AVX512_BF16):
# data 48 min, vae_colour 39 min, latent cache 18 min, ft 11 min, the seed-13 cache and 242 steps 10 min, then
# the end-to-end phases at batch 32 at 6.6-7.6 s a step (bf16 autocast): 2.1 h for their 1084 steps (4.2 h in all);
# the result scored 14.38 dB held-out albedo against the shipped fourth version's 14.46 (docs/notebook/default_model.md).
# From an empty WORK (2026-11-29, Zen 5, 2 cores, AVX512_BF16): the third version in about 3.3 h (data 42 min,
# VAE 29 min, latent cache 18 min, UNet 67 min, second set 13 min, fine-tuning 20 min; the README's training row).
# The network's work size recorded in the file: 256 since 2026-12-01 (trained at 128x128 renders; on the six
# validation assets every map is better with the network at 256, README *The network at 256*); the files shipped
# before were converted with --work-size 128, and `supermat convert --from FILE --work-size N` changes it.
# shellcheck source=scripts/train_env.sh
source "$(dirname "${BASH_SOURCE[0]}")/train_env.sh"
COUNT="${COUNT:-20000}"
SEED="${SEED:-0}"
COUNT2="${COUNT2:-6000}"

gen() {  # gen OUT SEED COUNT extra args...
  local out="$1" seed="$2" count="$3"; shift 3
  $PY -m supermat_tools.gen_data --hdri-dir "$WORK/hdri" --out "$out" --count "$count" --size 128 --seed "$seed" \
      --jobs "$THREADS" "$@"
}
convert() {  # convert RUN OUT
  build/supermat convert --force --kind supermat --unet "$1/release/supermat.pth" --base "$1/release/base" \
      --weights f16 --work-size 256 --out "$2"
}
MODES=0.62,0.12,0.13,0.13   # material modes of the sets with fewer metals (gen_data.py --mode-probs)

echo "== data ($COUNT samples, 128x128)"
gen "$WORK/data128" "$SEED" "$COUNT"

echo "== training"
# shellcheck disable=SC2086
$PY -m supermat_tools.train_default --data "$WORK/data128" --out "$WORK/run" --hdri-dir "$WORK/hdri" --seed "$SEED" \
    --threads "$THREADS" ${TRAIN_ARGS:-}

echo "== data, second set ($COUNT2 samples, seed $((SEED + 1)), fewer metals: material modes 0.62 / 0.12 / 0.13 / 0.13)"
gen "$WORK/data128b" $((SEED + 1)) "$COUNT2" --mode-probs $MODES

echo "== fine-tuning on it (latent 2000 steps, end to end 100)"
$PY -m supermat_tools.train_default --data "$WORK/data128b" --out "$WORK/run" --hdri-dir "$WORK/hdri" --seed "$SEED" \
    --threads "$THREADS" --amp "$AMP" --phases ft,ft_e2e,export

echo "== conversion"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_UV_TESTS=OFF >/dev/null
cmake --build build -j"$THREADS" --target supermat
mkdir -p models
convert "$WORK/run" models/supermat_default.safetensors
[ "${STAGE4:-1}" = 1 ] || { build/supermat info models/supermat_default.safetensors; exit 0; }
V3="$WORK/supermat_v3.safetensors"
[ -f "$V3" ] || cp models/supermat_default.safetensors "$V3"   # the third version, kept for a resumed run

echo "== fourth version: data (seeds 2, 3, 12 for the colour VAE and its UNet; 13, 14 end to end)"
gen "$WORK/data128c" $((SEED + 2)) 6000 --mode-probs $MODES
gen "$WORK/data128d" $((SEED + 3)) 5000 --mode-probs 0.7,0.1,0.1,0.1 --albedo-floor 0.12 --anodised 0.1
gen "$WORK/data128p" $((SEED + 12)) 5000 --mode-probs $MODES --photo 0.5
gen "$WORK/data128s13" $((SEED + 13)) 4175 --mode-probs $MODES --photo 0.5
gen "$WORK/data128s14" $((SEED + 14)) 2075 --mode-probs $MODES --photo 0.5
T=("$PY" -m supermat_tools.train_default --hdri-dir "$WORK/hdri" --seed "$SEED" --threads "$THREADS" --amp "$AMP")

echo "== colour VAE (3103 of 3352 steps) and the UNet on its latents (1860 steps)"
D3="$WORK/data128c,$WORK/data128d,$WORK/data128p"
"${T[@]}" --data "$D3" --out "$WORK/run4a" --init-from "$V3" --phases vae_colour --amp off \
    --vae-colour-steps 3352 --until vae_colour=3103          # float32, as measured
"${T[@]}" --data "$D3" --out "$WORK/run4a" --init-from "$V3" --phases ft,export --ft-steps 1860
convert "$WORK/run4a" "$WORK/supermat_v4a.safetensors"

echo "== latent 242 steps (batch 64, lr 3e-4), end to end 730 of 797 steps (batch 32, lr 2e-4, colour permutations)"
"${T[@]}" --data "$WORK/data128s13" --out "$WORK/run4b" --init-from "$WORK/supermat_v4a.safetensors" \
    --phases ft,ft_e2e,export --ft-steps 242 --ft-lr 3e-4 --latent-batch 64 \
    --e2e-steps 797 --until ft_e2e=730 --e2e-lr 2e-4 --e2e-batch 32 --e2e-permute 1
convert "$WORK/run4b" "$WORK/supermat_v4b.safetensors"

echo "== end to end 354 more steps (lr 1e-4) on new renders"
"${T[@]}" --data "$WORK/data128s14" --out "$WORK/run4c" --init-from "$WORK/supermat_v4b.safetensors" \
    --phases e2e_more,export --e2e-more-steps 354 --e2e-more-lr 1e-4 --e2e-batch 32 --e2e-permute 1
convert "$WORK/run4c" models/supermat_default.safetensors
build/supermat info models/supermat_default.safetensors
