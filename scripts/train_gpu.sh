#!/usr/bin/env bash
# One short training round on a borrowed GPU machine that has PyTorch but no network: fresh renders made on
# its cores, then the shipped model fine-tuned on them (latent phase, then end to end), within fixed
# wall-clock budgets.  Never required: the default model and CI use the CPU only (scripts/train_default.sh).
#
#   here:   [HARNESS_DEPS=<deps>] HDRI=<hdri dir> bash scripts/train_gpu.sh pack    -> .gpu/payload.tar.gz
#   there:  OUT=<folder> bash scripts/train_gpu.sh device                            -> OUT/unet_*.npz, logs
#   there:  OUT=<folder> bash scripts/train_gpu.sh device-mv                         -> OUT/unet_mv.npz (SuperMatMV)
#   there:  OUT=<folder> bash scripts/train_gpu.sh device-refine   -> OUT/refine_bc.npz, refine_rm.npz (UV refine)
#   back:   bash scripts/train_gpu.sh import OUT/unet_ft_e2e.npz RUN ft_e2e                 -> RUN/ckpt_ft_e2e.pt
#           then train_default.py --data D --out RUN --init-from models/supermat_default.safetensors
#           --phases export, and `supermat convert` as in train_default.sh
#
# pack: with HARNESS_DEPS set, its site/ (extracted package sources for a device without them: diffusers 0.27 or
#   newer, checked with 0.31.0, huggingface_hub, and where the device lacks them transformers / safetensors; put
#   first on the device's Python path, except a safetensors there when the device has its own), and the prefiltered
#   training maps
#   (HDRI/*.hdr.smenv.npz: the .hdr files travel as empty stand-ins older than their caches, which
#   smrender.EnvLight then reads instead), 6.4 MB.  Add /.gpu/ to .git/info/exclude.  Where the lent
#   machine takes at most 64 MiB of working tree, move tests/data (59 MB) aside for the call.  PHOTO_HDR=1 packs
#   the training maps themselves (+12 MB: 18.3 MB in all), which the device's renders need for PHOTO > 0.
# device: budgets in seconds GEN_S (renders, default 160), FT_S (latent phase, 30), E2E_S (end to end, 220);
#   TRAIN_TIMEOUT (default 380) bounds the whole training call; FT_BATCH (64), E2E_BATCH (32).  INIT: the model
#   file to start from (default the shipped one; e.g. a candidate with another VAE, carried in .gpu/); SEED (11)
#   PHOTO (0: gen_data --photo) and SHADING (camera | facing: gen_data --shading) for the renders; PHASES (ft,ft_e2e,export); TRAIN_EXTRA: more arguments
#   for train_default.py (a later --seconds replaces the one above: e.g. PHASES=e2e_more,export TRAIN_EXTRA=
#   "--seconds e2e_more=120 --e2e-more-steps 100000 --e2e-more-lr 1e-4" continues a model end to end).  Gives back
#   the UNet after each phase that ran (unet_ft.npz, unet_ft_e2e.npz, unet_e2e_more.npz), float16
#   (the release rounds to it anyway), the logs and the export report.
# Measured (2026-11-26, H200, 16 cores): 4 600 renders in 194 s; a latent step of batch 64 162 ms, an end-to-end
#   step of batch 32 271 ms, not profiled (the batch assembly took 66 ms of a step on 2 CPU threads here, and
#   the re-render loss waited on the GPU 32 times a step: both are done on the device at once since); 485 s in
#   all, with 30-40 s to start the machine.  Results: docs/notebook/default_model.md ("A GPU round").
# Measured (2026-11-26, H100, 16 cores, INIT = the colour-VAE model, PHOTO=0.5): 4 175 renders in 175 s; a latent
#   step of batch 64 203 ms, an end-to-end step of batch 32 263 ms; 488 s for renders, 242 latent and 730
#   end-to-end steps; a second call (PHASES=e2e_more,export) 2 075 renders and 354 steps in 273 s.  Batches built
#   on the device did not make the end-to-end step faster (263 against 271 ms): it is bound elsewhere, unprofiled.
# device-mv measured (2026-11-26, H100, 16 cores; GEN_S=120 MV_S=150): 488 six-view objects in 128 s, 533 steps
#   of 8 objects x 6 views (255 ms a step), 292 s in all (README, "A first multi-view model").
# device-refine measured (2026-11-27, H200, 16 cores; GEN_S=230 END_S=565 TAIL_S=40, the payload packed with REFINE=1
#   PHOTO_HDR=1, tests/data and models/supermat_default.safetensors moved aside for the call): 512 meshes in 238 s,
#   880 / 887 steps of batch 32 for the two networks at once (300 ms a step each), 529 s in all (README, "A GPU
#   round for the refine networks").
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export PYTHONPATH="$PWD/python${PYTHONPATH:+:$PYTHONPATH}"   # the tools: python -m supermat_tools.X (python/README.md)
mode="${1:-}"
if [ "$mode" = pack ]; then
    : "${HDRI:?}"
    st=$(mktemp -d)
    mkdir -p "$st/hdri" .gpu
    if [ -n "${HARNESS_DEPS:-}" ]; then
        mkdir -p "$st/deps" && cp -r "$HARNESS_DEPS/site" "$st/deps/" || exit 1
        [ -f "$HARNESS_DEPS/VERSIONS.txt" ] && cp "$HARNESS_DEPS/VERSIONS.txt" "$st/deps/"
    fi
    held="venice_sunset_1k|studio_small_03_1k|kiara_1_dawn_1k"
    for f in "$HDRI"/*.hdr; do
        b=$(basename "$f")
        echo "$b" | grep -qE "^($held)\.hdr$" && continue
        [ -f "$f.smenv.npz" ] || { echo "train_gpu: $f.smenv.npz missing (run gen_data.py once here)" >&2; exit 1; }
        cp "$f.smenv.npz" "$st/hdri/"
        if [ "${PHOTO_HDR:-0}" = 1 ]; then cp -p "$f" "$st/hdri/"   # gen_data --photo crops the maps themselves
        else : > "$st/hdri/$b"; touch -d '2000-01-01' "$st/hdri/$b"; fi
    done
    if [ "${REFINE:-0}" = 1 ]; then   # device-refine: build/supermat (the mesh command) and the libraries it
        mkdir -p "$st/bin" "$st/lib"     # takes from Debian (tinygltf, stb, webp; libc / libstdc++ are the device's)
        cp build/supermat "$st/bin/" || exit 1
        ldd build/supermat | awk '/=> \// {print $3}' | grep -E 'lib(tinygltf|stb|webp|sharpyuv)' | xargs -r cp -t "$st/lib/"
    fi
    find "$st" -name __pycache__ -prune -exec rm -rf {} +
    tar -C "$st" -czf .gpu/payload.tar.gz . && rm -rf "$st"
    ls -l .gpu/payload.tar.gz
    exit 0
fi
if [ "$mode" = import ]; then
    [ $# -eq 4 ] || { echo "usage: train_gpu.sh import NPZ RUN PHASE" >&2; exit 2; }
    mkdir -p "$3" && /usr/bin/python3 - "$2" "$3" "$4" <<'EOF' || exit 1
import os, sys
import numpy as np
import torch
npz, run, ph = sys.argv[1:]
sd = {k: torch.from_numpy(v.astype(np.float32)) for k, v in np.load(npz).items()}
tmp = os.path.join(run, f"ckpt_{ph}.pt.tmp")
torch.save({"models": {"unet": sd}}, tmp)
os.replace(tmp, os.path.join(run, f"ckpt_{ph}.pt"))
open(os.path.join(run, f"{ph}.done"), "w").write("imported\n")
print(f"{npz} -> {run}/ckpt_{ph}.pt ({len(sd)} tensors)")
EOF
    exit 0
fi
# the device modes: the payload unpacked into W (default /tmp/smgpu), its packages (if any) on the path, T0 and PY set
unpack() {
    : "${OUT:?}"
    T0=$(date +%s)
    W="${W:-/tmp/smgpu}"
    rm -rf "$W" && mkdir -p "$W/w" && tar -C "$W/w" -xzf .gpu/payload.tar.gz || exit 1
    export PYTHONUNBUFFERED=1
    PY="${PY:-python3}"
    if [ -d "$W/w/deps/site" ]; then
        export HARNESS_DEPS="$W/w/deps"
        export PYTHONPATH="$HARNESS_DEPS/site:$PYTHONPATH"   # first on the path: a stand-in for pip
        # a real safetensors there: diffusers then imports more of it than a packed stand-in may have
        $PY -c 'import safetensors.torch' 2>/dev/null && rm -rf "$W/w/deps/site/safetensors" "$W/w/deps/site"/safetensors-*.dist-info
    fi
}
# ckpt_npz CKPT NPZ: a run's checkpoint's UNet as float16 npz, what comes back from the device (the f32 .pt is over
# the lent machine's size limit for returned files; the releases round to f16 anyway); says its step
ckpt_npz() {
    [ -f "$1" ] || { echo "$(basename "$1"): no checkpoint"; return 1; }
    $PY - "$1" "$2" <<'EOF'
import os, sys
import numpy as np
import torch
ckpt, npz = sys.argv[1:]
st = torch.load(ckpt, map_location="cpu", weights_only=False)
np.savez(npz, **{k: v.half().numpy() for k, v in st["models"]["unet"].items()})
done = os.path.exists(os.path.join(os.path.dirname(ckpt), os.path.basename(ckpt)[5:-3] + ".done"))
print(os.path.basename(ckpt), "step", st["step"], "of", st.get("total"), "done" if done else "NOT done", "->", npz)
EOF
}
if [ "$mode" = device-mv ]; then
    # six-view renders on the device's cores, then supermat_tools.train_mv from INIT (the shipped single-view model);
    # gives back the multi-view UNet as float16 npz (OUT/unet_mv.npz: the f32 .pth is over the lent machine's
    # size limit for returned files), its report and logs.  Import here: `train_gpu.sh import-mv NPZ RELEASE`.
    unpack
    nvidia-smi -L > "$OUT/env.txt" 2>&1
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 timeout -s INT "${GEN_S:-120}" $PY -m supermat_tools.gen_data --hdri-dir "$W/w/hdri" \
        --out "$W/mv" --count 100000 --size 128 --shard 8 --seed "${SEED:-21}" --jobs "$(nproc)" --views 6 \
        --photo "${PHOTO:-0.5}" --mode-probs 0.62,0.12,0.13,0.13 --shading "${SHADING:-camera}" > "$W/gen.log" 2>&1
    pkill -f supermat_tools.gen_data; sleep 1
    echo "renders: $(ls "$W/mv" | grep -c '^shard_') shards of 8 objects at $(( $(date +%s) - T0 )) s" | tee -a "$OUT/env.txt"
    timeout "${TRAIN_TIMEOUT:-230}" $PY -m supermat_tools.train_mv --data "$W/mv" --out "$W/run" \
        --init-from "${INIT:-models/supermat_default.safetensors}" --hdri-dir "$W/w/hdri" --device cuda --amp bf16 \
        --threads 8 --steps 100000 --batch "${MV_BATCH:-8}" --lr "${MV_LR:-1e-4}" --seconds "mv=${MV_S:-150}" \
        --ckpt-every 30 > "$OUT/train_mv.log" 2>&1
    echo "training rc $? at $(( $(date +%s) - T0 )) s" | tee -a "$OUT/env.txt"
    ckpt_npz "$W/run/ckpt_mv.pt" "$OUT/unet_mv.npz"
    cp "$W/run/release/report_mv.json" "$W/run/log_mv.txt" "$OUT/" 2>/dev/null
    echo "device: $(( $(date +%s) - T0 )) s"
    exit 0
fi
if [ "$mode" = import-mv ]; then
    # NPZ (device-mv's unet_mv.npz) -> RELEASE/supermat_mv.pth; RELEASE/base: a train_mv.py run's release/base
    # (or train_default.py's: the same text encoder, scheduler and VAE); then `supermat convert --kind supermat-mv`
    [ $# -eq 3 ] || { echo "usage: train_gpu.sh import-mv NPZ RELEASE" >&2; exit 2; }
    /usr/bin/python3 - "$2" "$3" <<'EOF2' || exit 1
import os, sys
import numpy as np
import torch
npz, rel = sys.argv[1:]
z = np.load(npz)
torch.save({k: torch.from_numpy(z[k].astype(np.float32)) for k in z.files}, os.path.join(rel, "supermat_mv.pth.tmp"))
os.replace(os.path.join(rel, "supermat_mv.pth.tmp"), os.path.join(rel, "supermat_mv.pth"))
print(f"{npz} -> {rel}/supermat_mv.pth ({len(z.files)} tensors)")
EOF2
    exit 0
fi
if [ "$mode" = device-refine ]; then
    # procedural meshes baked by the view model on the device's cores (supermat_tools.gen_refine_data: needs a payload
    # packed with REFINE=1 PHOTO_HDR=1), then the two UV-refine networks trained at once, one process each, from
    # INIT (default: the multi-view default, its branches as the bases); all of it ends by END_S (default 560)
    # seconds after the start.  Gives back OUT/refine_bc.npz and refine_rm.npz (float16), the logs and each
    # run's report.  Here: `train_gpu.sh import OUT/refine_bc.npz RUN bc` (and rm), then train_refine.py
    # --phases export on RUN.
    unpack
    export LD_LIBRARY_PATH="$W/w/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    VIEW="${VIEW_MODEL:-models/supermat_mv_default.safetensors}"
    { nvidia-smi -L; nproc; "$W/w/bin/supermat" --version; } > "$OUT/env.txt" 2>&1 || { cat "$OUT/env.txt"; exit 1; }
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 timeout -s INT "${GEN_S:-210}" $PY -m supermat_tools.gen_refine_data \
        --hdri-dir "$W/w/hdri" --out "$W/ref" --model "$VIEW" --supermat "$W/w/bin/supermat" --count 100000 --shard 8 \
        --seed "${SEED:-5}" --jobs "${JOBS:-$(nproc)}" > "$W/gen.log" 2>&1
    pkill -f supermat_tools.gen_refine_data; pkill -f "$W/w/bin/supermat"; sleep 1
    n=$(ls "$W/ref" | grep -c '^shard_[0-9]*\.npz$')
    echo "meshes: $n shards of 8 at $(( $(date +%s) - T0 )) s" | tee -a "$OUT/env.txt"
    tail -5 "$W/gen.log" >> "$OUT/env.txt"
    [ "$n" -gt 0 ] || { tail -40 "$W/gen.log"; exit 1; }
    left=$(( ${END_S:-560} - ($(date +%s) - T0) ))
    for net in bc rm; do
        timeout "$left" $PY -m supermat_tools.train_refine --data "$W/ref" --out "$W/run_$net" --init-from "${INIT:-$VIEW}" \
            --phases "$net" --device "${DEVICE:-cuda}" --amp bf16 --threads 4 --steps 100000 --batch "${BATCH:-32}" \
            --lr "${LR:-2e-4}" --seconds "$net=$(( left - ${TAIL_S:-60} ))" --ckpt-every 60 ${TRAIN_EXTRA:-} \
            > "$OUT/train_$net.log" 2>&1 &
    done
    wait
    echo "training ended at $(( $(date +%s) - T0 )) s" | tee -a "$OUT/env.txt"
    for net in bc rm; do ckpt_npz "$W/run_$net/ckpt_$net.pt" "$OUT/refine_$net.npz"; done
    echo "device: $(( $(date +%s) - T0 )) s"
    exit 0
fi
[ "$mode" = device ] || { echo "usage: train_gpu.sh pack|device|device-mv|device-refine|import|import-mv" >&2; exit 2; }
unpack
DEVICE="${DEVICE:-cuda}"
JOBS="${JOBS:-$(nproc)}"
{ nvidia-smi -L; $PY -c 'import torch, numpy; print("torch", torch.__version__, "numpy", numpy.__version__, "cuda", torch.cuda.is_available())'; nproc; } 2>&1 | tee "$OUT/env.txt"
# the training script's imports and one UNet step on the device, before minutes go into renders
$PY - "$DEVICE" "$(ls "$W"/w/hdri/*.hdr | head -1)" <<'EOF' 2>&1 | tee -a "$OUT/env.txt"
import sys, time
import torch
from supermat_tools import train_default as T
T.DEV = torch.device(sys.argv[1])
T.F.group_norm, T.F.layer_norm = T._group_norm_f32, T._layer_norm_f32   # as --amp bf16 does
u = T.build_unet()
z = torch.randn(4, 16, 16, 16, device=T.DEV)
ctx = torch.zeros(4, 77, 64, device=T.DEV)
t = time.time()
with torch.autocast(T.DEV.type, dtype=torch.bfloat16):
    out = u(z, 999, encoder_hidden_states=ctx).sample
sum(o.float().square().mean() for o in out).backward()
vae = T.make_vae()
x = torch.rand(2, 3, 128, 128, device=T.DEV, requires_grad=True)
with torch.autocast(T.DEV.type, dtype=torch.bfloat16):
    y = vae.decode(vae.encode(x).latent_dist.mode()).sample
from supermat_tools import smrender as R
env = T.TorchEnv(R.EnvLight(sys.argv[2]))
nrm = torch.nn.functional.normalize(torch.randn(2, 3, 128, 128, device=T.DEV), dim=1)
img = T.shade_t(env, R.rotation_y(0.3), nrm, y.float().clamp(0, 1), x[:, :1], x[:, 1:2])
T.tonemap_t(img, torch.ones(2, 1, 1, 1, device=T.DEV)).mean().backward()
print("preflight: x0 coefficient", T.x0_coefficient()[0], "VAE + shading backward", x.grad.abs().sum().item() > 0)
print("preflight: UNet", sum(p.numel() for p in u.parameters()), "parameters, forward + backward", f"{time.time() - t:.2f} s")
EOF
[ "${PIPESTATUS[0]}" = 0 ] || { echo "train_gpu: preflight failed"; exit 1; }

echo "== renders: $JOBS jobs for ${GEN_S:-160} s (seed ${SEED:-11}, material modes 0.62 / 0.12 / 0.13 / 0.13, photo ${PHOTO:-0})"
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 timeout -s INT "${GEN_S:-160}" \
    $PY -m supermat_tools.gen_data --hdri-dir "$W/w/hdri" --out "$W/data" --count 100000 --size 128 --shard 25 \
    --seed "${SEED:-11}" --jobs "$JOBS" --mode-probs 0.62,0.12,0.13,0.13 --photo "${PHOTO:-0}" --shading "${SHADING:-camera}" > "$W/gen.log" 2>&1
pkill -f supermat_tools.gen_data; sleep 1
n=$(ls "$W/data" | grep -c '^shard_[0-9]*\.npz$')
echo "renders: $n shards of 25 in $(( $(date +%s) - T0 )) s" | tee -a "$OUT/env.txt"
tail -3 "$W/gen.log"
[ "$n" -gt 0 ] || { tail -30 "$W/gen.log" | tee -a "$OUT/env.txt"; exit 1; }

echo "== training"
timeout "${TRAIN_TIMEOUT:-380}" $PY -m supermat_tools.train_default --data "$W/data" --out "$W/run" --hdri-dir "$W/w/hdri" \
    --device "$DEVICE" --amp bf16 --threads 8 --seed 0 --init-from "${INIT:-models/supermat_default.safetensors}" \
    --phases "${PHASES:-ft,ft_e2e,export}" --ckpt-every 30 --seconds "ft=${FT_S:-30},ft_e2e=${E2E_S:-220}" \
    --ft-steps 100000 --ft-lr 3e-4 --latent-batch "${FT_BATCH:-64}" \
    --e2e-steps 100000 --e2e-lr 2e-4 --e2e-batch "${E2E_BATCH:-32}" --e2e-permute 1 ${TRAIN_EXTRA:-} 2>&1 | tee "$OUT/train.log"
echo "training rc ${PIPESTATUS[0]} at $(( $(date +%s) - T0 )) s"

for ph in ft ft_e2e e2e_more; do ckpt_npz "$W/run/ckpt_$ph.pt" "$OUT/unet_$ph.npz"; done
cp "$W"/run/log_*.txt "$W/run/release/report.json" "$OUT/" 2>/dev/null
echo "device: $(( $(date +%s) - T0 )) s"
