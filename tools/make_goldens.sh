#!/usr/bin/env bash
# Regenerate everything under tests/data/ (test images, tiny random-weight models, golden tensors) with the
# SuperMat reference harness (official SuperMat + diffusers code, CPU float32).  See tests/data/README.md.
#
#   HARNESS=<reference harness dir> HARNESS_DEPS=<its extracted deps> OUT=<scratch dir> tools/make_goldens.sh
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
"$PYTHON" "$REPO/tools/make_test_images.py" --out "$IMG"

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
"$PYTHON" "$REPO/tools/golden_extra.py" --harness "$HARNESS" --models "$M" --threads "$THREADS" \
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

"$PYTHON" - "$RUNS" "$DEST" "$HARNESS_DEPS/VERSIONS.txt" <<'EOF'
import json, shutil, sys
from pathlib import Path
import numpy as np

runs, dest, versions = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
common = ["encoder_hidden_states", "image_latent", "x0_latents"]
sv = ["inputs/source_image", "inputs/resized_rgba_u8", "unet_out_b0", "unet_out_b1",
      "vae_decoded_b0", "vae_decoded_b1", "albedo", "orm"]
cases = {
    "single_sphere_64": common + sv,
    "single_box_40": common + sv,
    "single_ring_48x72": common + sv,
    "mv6_64": common + [s for s in sv if s != "inputs/resized_rgba_u8"] + ["inputs/camera_embeds"]
              + [f"inputs/resized_rgba_u8_{k:04d}" for k in range(6)],
    "uv_128": common + ["inputs/uv_map", "inputs/uv_position", "inputs/uv_mask", "inputs/uv_map_resized_u8",
                        "inputs/uv_position_resized_u8", "inputs/uv_mask_resized_u8", "unet_input",
                        "unet_out_b0", "vae_decoded_b0", "uv_refined"],
}
ver_lines = versions.read_text().split("\n")
ver_lines = [l for l in ver_lines if l.strip()]


def check(p):
    a = np.load(p, allow_pickle=False)
    with open(p, "rb") as f:
        version = np.lib.format.read_magic(f)
        rd = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, fortran, dtype = rd(f)
    ok_dtype = dtype.str in ("<f4", "|u1")
    if not ok_dtype or fortran:
        raise SystemExit(f"bad npy {p}: dtype {dtype.str} fortran {fortran}")
    if "_u8" in p.name and dtype.str != "|u1":
        raise SystemExit(f"{p}: expected uint8")
    return {"shape": list(shape), "dtype": dtype.str}


for case, files in cases.items():
    src, dst = runs / case, dest / "golden" / case
    listing = {}
    for f in files:
        s = src / (f + ".npy")
        d = dst / (f + ".npy")
        d.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(s, d)
        listing[f + ".npy"] = check(d)
    if case == "single_sphere_64":
        # the full blocks/ dump is ~5.8 MB (VAE activations at 64x64): keep only the UNet's top-level modules
        for s in sorted((src / "blocks").glob("*_unet.*.npy")):
            d = dst / "blocks" / s.name
            d.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(s, d)
            listing["blocks/" + s.name] = check(d)
    info = json.load(open(src / "run.json"))
    trimmed = {
        "harness_versions": ver_lines,
        "mode": info["mode"],
        "image_size": info.get("image_size", info.get("image_hw")),
        "env": {k: v for k, v in info["env"].items() if k not in ("diffusers_path", "supermat_root")},
        "checkpoint": Path(info["checkpoint"]).name,
        "load_state_dict": info["load_state_dict"],
        "attn_processors": info["attn_processors"],
        "runs": [{k: r[k] for k in ("name", "stats", "manual_check") if k in r} for r in info["runs"]],
        "files": listing,
    }
    for k in ("tool", "image_hw", "loader_check"):
        if k in info:
            trimmed[k] = info[k]
    if "loader_check" in trimmed:
        trimmed["loader_check"]["image"] = Path(trimmed["loader_check"]["image"]).name
    with open(dst / "run.json", "w") as f:
        json.dump(trimmed, f, indent=1)
        f.write("\n")
    print(case, len(listing), "npy files")

# the models' own .npy
for p in (dest / "tiny").rglob("*.npy"):
    check(p)
print("all .npy: little-endian float32 / uint8, C order")
EOF

du -sh "$DEST" "$DEST"/*
