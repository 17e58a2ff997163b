#!/usr/bin/env python3
"""Copy selected tensors of reference-harness runs into committed golden folders (trimmed run.json).

    golden_copy.py RUNS DEST VERSIONS.txt CASE:KIND[+blocks]...

KIND is single, mv or uv (which files a case keeps); +blocks also keeps the UNet's top-level block dumps.
RUNS/CASE -> DEST/golden/CASE.  Used by scripts/make_goldens.sh and scripts/make_default_golden.sh.
"""
import json, shutil, sys
from pathlib import Path
import numpy as np

runs, dest, versions = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
wanted = [a.split(":") for a in sys.argv[4:]]
common = ["encoder_hidden_states", "image_latent", "x0_latents"]
sv = ["inputs/source_image", "inputs/resized_rgba_u8", "unet_out_b0", "unet_out_b1",
      "vae_decoded_b0", "vae_decoded_b1", "albedo", "orm"]
kinds = {
    "single": common + sv,
    "mv": common + [s for s in sv if s != "inputs/resized_rgba_u8"] + ["inputs/camera_embeds"]
              + [f"inputs/resized_rgba_u8_{k:04d}" for k in range(6)],
    "uv": common + ["inputs/uv_map", "inputs/uv_position", "inputs/uv_mask", "inputs/uv_map_resized_u8",
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


for case, kind in wanted:
    files = kinds[kind.split("+")[0]]
    src, dst = runs / case, dest / "golden" / case
    listing = {}
    for f in files:
        s = src / (f + ".npy")
        d = dst / (f + ".npy")
        d.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(s, d)
        listing[f + ".npy"] = check(d)
    if kind.endswith("+blocks"):
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
