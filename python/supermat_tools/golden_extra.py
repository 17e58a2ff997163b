#!/usr/bin/env python3
"""Golden tensors for a NON-SQUARE single-view input, which the reference harness' reference_run.py cannot
produce (its loaders resize to a square --image-size).

    HARNESS_DEPS=<deps> PYTHONPATH=<reference harness dir>:python /usr/bin/python3 -m supermat_tools.golden_extra \
        --models <models dir from make_random_models.py> --input tests/data/img/ring_48x72.png --out <dir>

The pipeline is built and recorded by the harness' own reference_run.py functions (the harness dir on
PYTHONPATH, imported at run time: build_pipeline = the official inference_supermat.build_pipeline, attach_recorders, save,
manual_recompute), and run through the OFFICIAL SuperMatStableDiffusionPipeline.__call__.  The only thing done
here instead of the official loader (src.utils.load_rgba_image_as_rgb_tensor, which always resizes to a square)
is the image load, with the loader's exact arithmetic and NO resize:

    rgba = asarray(Image.open(p).convert("RGBA")).astype(float32) / 255
    rgb  = rgba[..., :3] * a + 0.5 * (1 - a)          -> [1,3,H,W]

It is checked against the official loader on a square image (--check-square IMG, default: sphere_64.png next
to the input) where the official resize is the identity, and must be bitwise equal.

Writes into --out the same files as reference_run.py --mode single (inputs/source_image.npy,
inputs/resized_rgba_u8.npy (= the unresized RGBA), input_ids, encoder_hidden_states, timesteps, image_latent,
unet_out_b0/b1, x0_latents, vae_decoded_b0/b1, albedo, orm, optional blocks/) and run.json.
"""
import argparse
import json
import sys
import time
from pathlib import Path


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", required=True)
    ap.add_argument("--input", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--check-square", default=None)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--dump-blocks", action="store_true")
    a = ap.parse_args()
    try:
        import reference_run as rr  # imports harness_env first (sys.path for diffusers / SuperMat sources)
    except ImportError as e:
        sys.exit(f"golden_extra: the harness' reference_run.py is not importable ({e}): put the reference harness "
                 "dir first on PYTHONPATH (scripts/make_goldens.sh does)")
    import numpy as np
    import torch
    from PIL import Image
    from src.utils import load_rgba_image_as_rgb_tensor

    torch.set_num_threads(a.threads)
    device = torch.device("cpu")

    def load_unresized(path):
        rgba = np.asarray(Image.open(path).convert("RGBA")).astype(np.float32) / 255.0
        rgb = rgba[:, :, :3]
        alpha = rgba[:, :, 3:4]
        rgb = rgb * alpha + 0.5 * (1.0 - alpha)
        return torch.from_numpy(rgb).permute(2, 0, 1).unsqueeze(0).to(device)

    # self-check of the loader against the official one where the official resize is the identity
    sq = Path(a.check_square) if a.check_square else Path(a.input).parent / "sphere_64.png"
    im = Image.open(sq)
    assert im.size[0] == im.size[1], "--check-square needs a square image"
    off = load_rgba_image_as_rgb_tensor(sq, image_size=im.size[0], device=device)
    loader_equal = bool(torch.equal(off, load_unresized(sq)))
    if not loader_equal:
        sys.exit(f"loader mismatch vs official load_rgba_image_as_rgb_tensor on {sq}")

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    args = argparse.Namespace(models=a.models, mode="single", checkpoint=None, num_views=6,
                              no_camera_embeds=False, mv_processor="sdpa", allow_incompatible=False)
    info = {"mode": "single", "tool": "golden_extra.py (non-square, no resize)", "env": rr.harness_env.describe(),
            "threads": torch.get_num_threads(), "loader_check": {"image": str(sq), "bitwise_equal": loader_equal}}
    pipe = rr.build_pipeline(args, info)

    p = Path(a.input)
    src = load_unresized(p)
    info["image_hw"] = list(src.shape[-2:])
    R = rr.Recorder()
    rr.attach_recorders(pipe, R, a.dump_blocks)
    (out / "inputs").mkdir(parents=True, exist_ok=True)
    np.save(out / "inputs" / "resized_rgba_u8.npy", np.asarray(Image.open(p).convert("RGBA")))
    rr.save(out, "inputs/source_image", src)
    t1 = time.perf_counter()
    with torch.no_grad():
        images = pipe(prompt="", num_inference_steps=1, source_image=src, output_type="pt", generator=None)
    rinfo = {"name": p.stem, "pipeline_seconds": time.perf_counter() - t1}
    rr.detach_recorders(pipe)
    rec = R.rec
    rr.save(out, "input_ids", rec["input_ids"])
    rr.save(out, "encoder_hidden_states", rec["encoder_hidden_states"])
    rr.save(out, "timesteps", pipe.scheduler.timesteps)
    latent = rec["latent_mode_unscaled"] * pipe.vae.config.scaling_factor
    rr.save(out, "image_latent", latent)
    for i, o in enumerate(rec["unet_out"]):
        rr.save(out, f"unet_out_b{i}", o)
    rr.save(out, "x0_latents", rec["x0_latents"])
    for i, d in enumerate(rec["vae_decoded"]):
        rr.save(out, f"vae_decoded_b{i}", d)
    rr.save(out, "albedo", images[0])
    rr.save(out, "orm", images[1])
    if a.dump_blocks:
        for nm, t in rec.get("blocks", []):
            rr.save(out, "blocks/" + nm.replace("#", "_call"), t)
    rinfo["stats"] = {
        "source_image": rr.stats(src),
        "encoder_hidden_states": rr.stats(rec["encoder_hidden_states"]),
        "image_latent": rr.stats(latent),
        **{f"unet_out_b{i}": rr.stats(o) for i, o in enumerate(rec["unet_out"])},
        "x0_latents": rr.stats(rec["x0_latents"]),
        **{f"vae_decoded_b{i}": rr.stats(d) for i, d in enumerate(rec["vae_decoded"])},
        **{f"image_b{i}": rr.stats(im) for i, im in enumerate(images)},
        "input_ids": rec["input_ids"][0].tolist(),
        "timesteps": pipe.scheduler.timesteps.tolist(),
    }
    m = rr.manual_recompute(pipe, rec, "single", len(images))
    rinfo["manual_check"] = {
        "t": m["t"], "alphas_cumprod[t]": m["alpha_t"], "x0_coeff_on_v": -(1 - m["alpha_t"]) ** 0.5,
        "maxabs_latent": rr.maxdiff(m["latent"], latent),
        "maxabs_x0": rr.maxdiff(m["x0"], rec["x0_latents"]),
        "maxabs_images": [rr.maxdiff(x, y) for x, y in zip(m["images"], images)],
    }
    info["runs"] = [rinfo]
    with open(out / "run.json", "w") as f:
        json.dump(info, f, indent=1)
    print(p.stem, "HxW", info["image_hw"], "latent", list(latent.shape), "manual check:",
          json.dumps(rinfo["manual_check"]))
    print("wrote", out)


if __name__ == "__main__":
    main()
