#!/usr/bin/env python3
"""Train supermat's default model: the official SuperMat architecture at small widths, on the renders of
supermat_tools.gen_data, in the official code (diffusers' AutoencoderKL / UNet2DConditionModel and SuperMat's own
SuperMatAdapterWrapper, in this project's port of it: supermat_tools.supermat_adapters).

    PYTHONPATH=python /usr/bin/python3 -m supermat_tools.train_default --data DATA --out RUN [--phases vae,latent,e2e,export]

One command, from scratch or resumed: every phase checkpoints to RUN/ckpt_<phase>.pt every --ckpt-every
seconds and at its end, and a phase that finished (RUN/<phase>.done) is skipped, so running the same
command again after an interruption carries on where it stopped.  Seeds are fixed (--seed); with the
same thread count a run is repeatable.

Phases
  vae     AutoencoderKL (SD layout: 4 levels, factor 8, but 16 latent channels instead of SD 2.1's 4 --
          at these widths and this CPU budget a 4-channel VAE reached only 14-18 dB of reconstruction PSNR
          on the objects after 600 steps; the UNet's in/out channels follow) on input pictures (composited over gray
          0.5, as the pipeline feeds them) and on material maps (albedo, ORM = (1, roughness, metallic));
          L1 + image-gradient L1 + a small KL term.  Its scaling factor is 1 / std of the latents and is
          written into vae/config.json.
  vae_more  (not in the default phases yet) the VAE trained on from vae_crops, 3000 steps on whole renders,
          batch 8, every training render: real-asset albedo reconstruction 19.1 -> 24.5 dB, held-out renders
          (pictures / albedo / ORM) 19.0 / 18.1 / 18.6 -> 22.4 / 22.3 / 23.4 dB; 66 min with --amp bf16.  The
          UNet trained after it (latent, e2e as below) gained only 0.1-0.2 dB on the real assets (docs/notebook/default_model.md).
  vae_colour  (not in the default phases yet) the VAE trained on from its last phase, encoder and decoder,
          with the colour differences R - G and B - G weighted once more in the loss: --vae-colour-steps on
          --vae-colour-crop crops, batch --vae-colour-batch, every training render (--data may name several
          sets, comma separated).  The shipped VAE returns half the saturation it is given and its decoder
          reads 3 of its 16 latent channels (docs/notebook/default_model.md); the UNet phases after this one start from new latents.
  latent  the SuperMat UNet (two expert branches: the last up block and conv_out replicated by the
          official SuperMatAdapterWrapper) run as the runtime runs it: one step at t = 999 of the trailing
          DDIM schedule, zero latents, x0 = -sqrt(1 - alphas_cumprod[999]) * v; trained against the
          latents of the ground-truth maps (cheap: no decoder).
  e2e     the same UNet end to end on the decoded maps (VAE frozen): masked L1 + gradient L1 per map,
          plus a re-render loss: predicted and true maps shaded (split-sum GGX, the shading of
          supermat_tools.smrender) under another training environment map, tone mapped, L1.
  joint, joint_mse  (not in the default phases: measured, not shipped) the UNet and the VAE decoder together
          end to end, encoder frozen: the e2e losses, the decoder's own reconstruction of the true maps' latents,
          channel swaps of picture and albedo together; joint_mse continues with squared map errors.  After
          800 + 250 steps (72 + 22 min) on the default model's run: 64 held-out renders albedo / roughness /
          metallic 12.02 / 12.15 / 4.30 -> 12.49 / 12.17 / 4.31 (joint) -> 12.19 / 12.28 / 6.38 (joint_mse),
          VAE ORM reconstruction 18.6 -> 19.8 dB (joint); but on the real evaluation assets 13.70 / 12.12 / 8.95
          -> 13.34 / 12.91 / 8.91 -> 13.54 / 12.39 / 7.45 dB, so the default model stays the e2e one.
  alb     (not in the default phases: measured, not shipped) the albedo expert branch alone (its last up
          block and conv_out), everything else frozen, end to end with squared errors: 600 steps from the
          shipped model on the first 5936 renders moved the real assets' albedo 13.70 -> 13.72 dB and lowered
          the CI slice's (12.07 -> 11.52): the shared trunk, not the branch, limits the albedo.
  ft, ft_e2e  the latent and e2e phases again on a second data set (--data; a latent cache of its own,
          RUN/latents_ft.pt), from the UNet the run has: --ft-steps at --ft-lr, then --e2e-steps.  The shipped
          model: the default phases on 20 000 renders, then ft + ft_e2e (--amp bf16) on 6 000 renders with
          fewer metals (gen_data.py --seed 1 --mode-probs 0.62,0.12,0.13,0.13; scripts/train_default.sh does
          both): real assets albedo / roughness / metallic 13.70 / 12.12 / 8.95 -> 14.66 / 12.23 / 8.87 dB.
  ft2, ft2_e2e  (not in the default phases: measured, not shipped) ft and ft_e2e again on a third data set
          (own cache RUN/latents_ft2.pt), from the UNet the run has.  From the shipped model (--init-from), 2000 +
          100 steps on 5 000 renders of gen_data.py --seed 3 --mode-probs 0.7,0.1,0.1,0.1 --albedo-floor 0.12
          --anodised 0.1: real assets 14.66 / 12.23 / 8.87 -> 14.22 / 12.50 / 8.96 dB (48 min, --amp bf16, no AMX).
  e2e_more  (not in the default phases: measured, not shipped) the e2e phase again, longer (--e2e-more-steps,
          --e2e-more-lr), on another data set (--data), from the UNet the run has (unet_source).  900 steps from
          the shipped model (--init-from) on a third set (gen_data.py --seed 2, the second set's material modes):
          its held-out renders 11.08 / 11.35 / 9.31 -> 11.57 / 11.60 / 9.31 dB, the real assets 14.66 / 12.23 /
          8.87 -> 14.18 / 12.13 / 8.94 dB (59 min with --amp bf16 on AVX512_BF16 without AMX).  With
          --e2e-permute 1 (colour channels of picture and albedo swapped together on half the samples), 600 steps
          on the same set: over the three held-out maps 13.84 / 12.23 / 8.81 -> 13.48 / 12.74 / 8.91 dB.
  dec     (not in the default phases: measured, not shipped) the VAE decoder alone on reconstructions of
          pictures, albedo and ORM maps, encoder frozen (the UNet's latent space unchanged): --dec-steps, batch
          --dec-batch of --dec-crop crops, --dec-lr.  1000 steps from the shipped model (14.5 min, --amp bf16):
          round trips of the real assets' true maps 19.07 / 12.83 / 20.45 -> 20.64 / 17.26 / 20.48 dB (the
          shipped decoder returns a flat metal's roughness as 0.74-0.86 whatever it is), but the model's maps
          14.66 / 12.23 / 8.87 -> 14.57 / 12.00 / 8.89 dB.
  rm      (not in the default phases: measured, not shipped) the roughness / metallic branch alone, trunk and
          albedo branch frozen (the albedo bit-identical), end to end: 600 steps from the shipped model on the
          seed-2 set with --e2e-permute 1 (34 min, --amp bf16): real assets 14.66 / 12.23 / 8.87 -> 14.66 / 12.11
          / 8.87 dB; the GPU round's roughness gain (docs/notebook/default_model.md) came from the shared trunk.  With --rm-loss squared
          (the conditional mean instead of the median): 300 steps from the shipped model on 1 536 renders of seed
          31, batch 8, --e2e-permute 1 (30 min here, fp32, Zen 3): on 400 unseen renders (seed 97) 28.5 % of the
          metal pixels found instead of 0.1 % (6.6 % of the others called metal), metallic 7.37 dB instead of
          4.97; on the nine real assets (`eval_quality.py --env-in all`, 216 views) metallic 20.23 -> 10.09 dB
          ((b) 8.84): more metal found on WaterBottle / Suzanne / DamagedHelmet (2.48 / 0.14 / 3.25 -> 5.79 /
          2.37 / 5.86) but the metal-free assets called partly metal (Avocado 28.15 -> 18.78, Duck 40.78 ->
          15.11), roughness 9.79 -> 9.46, re-render 13.16 -> 13.19: not shipped.  The same on 1 600 renders of
          gen_data.py --seed 33 --dark-metal 0.6 (darker metals, as real assets author them): more real metal
          found and as much of the rest called metal (WaterBottle 45.5 % / 50.8 %), ROC AUC of metal against
          the other pixels of an asset 0.46-0.56 for every model: chance; not shipped (docs/notebook/default_model.md).
  export  the official release format: RUN/release/supermat.pth (torch.save of the UNet state dict) and
          RUN/release/base/ (diffusers layout: vae/, text_encoder/, tokenizer/, scheduler/ v_prediction,
          unet/config.json), every weight rounded to float16 so the f16 model file of `supermat convert
          --precision f16` holds exactly the weights this framework runs.

--init-from MODEL starts RUN from a released default model file (`supermat convert` output of this script's
release, f16): its VAE, scaling factor and UNet become the finished vae, vae_crops, latent and e2e phases, so
the later phases continue from the shipped model without its data or checkpoints (exporting such a run
unchanged converts back to the same file, byte for byte).

The text encoder is a small CLIP text model with fixed random weights (no pretrained one exists here);
SuperMat only ever feeds it the empty prompt, so its output is one constant context the UNet learns with.

--amp bf16 runs the forward passes under bfloat16 autocast (group and layer norms in float32): on this
project's Sapphire Rapids (AMX) 1.1 s a VAE step at 128² x 8 instead of 2.1, 0.53 s a latent UNet step
instead of 1.6, the latent cache in 27 min instead of 80; on a Xeon with AVX512_BF16 but no AMX an e2e step
takes 3.7 s instead of 4.25; slower on CPUs without either.
--device cuda trains on a GPU where there is one (never required; scripts/train_gpu.sh runs one round there).
--seconds PHASE=S,... gives phases wall-clock budgets: such a phase times its steps 20-120, then lowers its
step count to what fits (the learning-rate schedule follows) and stops at the budget in any case.
Needs torch (Debian's python3-torch 1.13.1, + libopenblas0-pthread, or any newer one), diffusers 0.27 or newer
(checked with 0.31.0; `pip install diffusers==0.31.0`), transformers (CLIPTextModel / CLIPTokenizer for the
release's text encoder and tokenizer) and safetensors, all from the ordinary Python path (pip, or PYTHONPATH
set by the caller); the SuperMat classes come from supermat_tools.supermat_adapters, which also gives torch 1.13 the
scaled-dot-product attention diffusers expects.  HARNESS_DEPS, when set, is a dependency folder whose site/
(extracted diffusers / huggingface_hub sources) scripts/train_env.sh and train_gpu.sh put first on PYTHONPATH:
an optional stand-in for pip (run directly: PYTHONPATH=$HARNESS_DEPS/site:python).
"""
import argparse
import json
import math
import os
import time
import zlib

os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("DIFFUSERS_NO_ADVISORY_WARNINGS", "1")
from supermat_tools import supermat_adapters  # noqa: E402,F401  (before diffusers: the SDPA shim for torch 1.13)
import importlib.util  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
import torch.nn.functional as F  # noqa: E402

_find_spec = importlib.util.find_spec


def _find_spec_no_peft(name, package=None):
    """diffusers 0.31 imports an installed peft (the GPU machines' images have one), and peft imports parts of
    transformers that a stand-in transformers may lack: hide peft, which this script never uses."""
    return None if name.split(".")[0] == "peft" else _find_spec(name, package)


importlib.util.find_spec = _find_spec_no_peft
from diffusers import AutoencoderKL, DDIMScheduler, UNet2DConditionModel  # noqa: E402
from safetensors.torch import safe_open  # noqa: E402
from supermat_tools.supermat_adapters import SuperMatAdapterWrapper, synthetic_clip_vocab  # noqa: E402
from transformers import CLIPTextConfig, CLIPTextModel, CLIPTokenizer  # noqa: E402

from supermat_tools import smrender as R  # noqa: E402

# ----------------------------------------------------------------------------------------------------------
# configuration: the official SD 2.1 configs at small widths
# ----------------------------------------------------------------------------------------------------------
UNET = {
    "act_fn": "silu", "attention_head_dim": [2, 4, 4, 4], "block_out_channels": [48, 96, 96, 96],
    "center_input_sample": False, "cross_attention_dim": 64,
    "down_block_types": ["CrossAttnDownBlock2D", "CrossAttnDownBlock2D", "CrossAttnDownBlock2D", "DownBlock2D"],
    "downsample_padding": 1, "dual_cross_attention": False, "flip_sin_to_cos": True, "freq_shift": 0,
    "in_channels": 16, "layers_per_block": 2, "mid_block_scale_factor": 1, "norm_eps": 1e-05, "norm_num_groups": 16,
    "num_class_embeds": None, "only_cross_attention": False, "out_channels": 16, "sample_size": 16,
    "up_block_types": ["UpBlock2D", "CrossAttnUpBlock2D", "CrossAttnUpBlock2D", "CrossAttnUpBlock2D"],
    "upcast_attention": True, "use_linear_projection": True,
}
VAE = {
    "act_fn": "silu", "block_out_channels": [32, 64, 128, 128], "down_block_types": ["DownEncoderBlock2D"] * 4,
    "in_channels": 3, "latent_channels": 16, "layers_per_block": 2, "norm_num_groups": 16, "out_channels": 3,
    "sample_size": 128, "up_block_types": ["UpDecoderBlock2D"] * 4, "scaling_factor": 0.18215,
}
TEXT = {
    "architectures": ["CLIPTextModel"], "attention_dropout": 0.0, "bos_token_id": 0, "dropout": 0.0,
    "eos_token_id": 2, "hidden_act": "gelu", "hidden_size": 64, "initializer_factor": 1.0,
    "initializer_range": 0.02, "intermediate_size": 128, "layer_norm_eps": 1e-05, "max_position_embeddings": 77,
    "model_type": "clip_text_model", "num_attention_heads": 4, "num_hidden_layers": 2, "pad_token_id": 1,
    "projection_dim": 64, "vocab_size": 49408,
}
SCHEDULER = {
    "beta_end": 0.012, "beta_schedule": "scaled_linear", "beta_start": 0.00085, "clip_sample": False,
    "num_train_timesteps": 1000, "prediction_type": "v_prediction", "set_alpha_to_one": False,
    "skip_prk_steps": True, "steps_offset": 1, "trained_betas": None, "timestep_spacing": "trailing",
}
TOKENIZER_SPECIAL = {"bos_token": "<|startoftext|>", "eos_token": "<|endoftext|>", "pad_token": "!",
                     "unk_token": "<|endoftext|>"}


DEV = torch.device("cpu")  # --device: where the models and batches live
AMP = False                # --amp bf16: network forward passes under bfloat16 autocast


def amp():
    """Autocast context for the networks' forward passes (a no-op unless --amp bf16)."""
    return torch.autocast(DEV.type, dtype=torch.bfloat16, enabled=AMP)


_group_norm = F.group_norm


def _group_norm_f32(x, num_groups, weight=None, bias=None, eps=1e-5):
    """torch 1.13's CPU autocast hands group_norm bfloat16 activations with float32 weights, which it
    refuses: normalise in float32 (the statistics want it anyway); the next convolution casts back."""
    return _group_norm(x.float(), num_groups, weight, bias, eps)


_layer_norm = F.layer_norm


def _layer_norm_f32(x, normalized_shape, weight=None, bias=None, eps=1e-5):
    """The same for layer_norm (the UNet's transformer blocks)."""
    return _layer_norm(x.float(), normalized_shape, weight, bias, eps)


class _PipeShim:
    def __init__(self, unet):
        self.unet = unet


def build_unet():
    base = UNet2DConditionModel.from_config(UNET)
    return SuperMatAdapterWrapper.convert(_PipeShim(base), use_camera_embeddings=False, replicate_num=2).unet.to(DEV)


def load_unet(run, phase):
    """The UNet as phase `phase` of the run left it."""
    unet = build_unet()
    unet.load_state_dict(load_ckpt(os.path.join(run, f"ckpt_{phase}.pt"))["models"]["unet"])
    return unet


def x0_coefficient():
    """-sqrt(1 - alphas_cumprod[999]) exactly as diffusers' DDIM step computes it (float32)."""
    s = DDIMScheduler.from_config(SCHEDULER)
    s.set_timesteps(1)
    t = int(s.timesteps[0])
    assert t == 999, t
    v = torch.ones(1, 1, 1, 1)
    return float(s.step(v, t, torch.zeros_like(v)).pred_original_sample), t


# ----------------------------------------------------------------------------------------------------------
# data
# ----------------------------------------------------------------------------------------------------------
class Data:
    def __init__(self, path, holdout=64):
        """path: a gen_data.py folder, or several separated by commas (concatenated in that order; the
        validation renders are the last folder's last ones; the folders must share their lighting list)."""
        parts, shards, self.meta = [], [], None
        for one in path.split(","):
            sh = sorted(f for f in os.listdir(one) if f.startswith("shard_") and f.endswith(".npz")
                        and ".tmp" not in f)
            if not sh:
                raise SystemExit(f"train_default: no shards in {one} (run supermat_tools.gen_data)")
            with open(os.path.join(one, "meta.json")) as f:
                meta = json.load(f)
            if self.meta is not None and meta["envs"] != self.meta["envs"]:
                raise SystemExit(f"train_default: {one} was lit by other maps than {path.split(',')[0]}")
            self.meta = self.meta or meta
            shards += sh
            parts += [np.load(os.path.join(one, f)) for f in sh]
        self.rgba = np.concatenate([p["rgba"] for p in parts])
        self.albedo = np.concatenate([p["albedo"] for p in parts])
        self.rough = np.concatenate([p["rough"] for p in parts])
        self.metal = np.concatenate([p["metal"] for p in parts])
        self.normal = np.concatenate([p["normal"] for p in parts])
        n = self.rgba.shape[0]
        holdout = min(holdout, n // 4)
        self.val = np.arange(n - holdout, n)     # the last samples are never trained on
        self.train = np.arange(0, n - holdout)
        print(f"data: {n} samples of {self.rgba.shape[1]}x{self.rgba.shape[2]} from {len(shards)} shards "
              f"({len(self.train)} train, {len(self.val)} validation)", flush=True)

    def batch(self, idx, aug_rng=None):
        """Tensors in [0,1], NCHW: input (over gray 0.5), albedo, orm, mask, normal (made on --device from the
        stored 8-bit / f16 arrays, augmented there)."""
        def t(x):
            return torch.from_numpy(x).to(DEV)
        a = t(self.rgba[idx]).float().div_(255).permute(0, 3, 1, 2)
        m = a[:, 3:4]
        inp = a[:, :3] * m + 0.5 * (1 - m)
        alb = t(self.albedo[idx]).float().div_(255).permute(0, 3, 1, 2)
        r = t(self.rough[idx]).float().div_(255)[:, None]
        mt = t(self.metal[idx]).float().div_(255)[:, None]
        orm = torch.cat([torch.ones_like(r), r, mt], 1)
        # maps over gray 0.5 where there is no object, like the input
        alb = alb * m + 0.5 * (1 - m)
        orm = orm * m + 0.5 * (1 - m)
        nrm = t(self.normal[idx]).float().permute(0, 3, 1, 2)
        b = {"inp": inp, "alb": alb, "orm": orm, "mask": m, "nrm": nrm}
        if aug_rng is not None:
            b = augment(b, aug_rng)
        return b


def augment(b, rng):
    """Horizontal flips and quarter turns of the picture (normals turned with it).  The draws are made per
    sample in order (quarter turns, then flip), then applied to each group of samples at once."""
    draws = [(int(rng.integers(4)), bool(rng.integers(2))) for _ in range(b["inp"].shape[0])]
    out = {k: v.clone() for k, v in b.items()}
    for k in range(4):
        for flip in (False, True):
            sel = [i for i, d in enumerate(draws) if d == (k, flip)]
            if not sel or (k == 0 and not flip):
                continue
            ii = torch.tensor(sel, device=b["inp"].device)
            for key in out:
                x = b[key][ii]
                if flip:
                    x = x.flip(-1)
                    if key == "nrm":
                        x = x * torch.tensor([-1.0, 1, 1], device=x.device)[:, None, None]
                if k:
                    x = torch.rot90(x, k, (-2, -1))
                    if key == "nrm":
                        # rot90 by k quarter turns counter-clockwise in image space: rotate (x, y) the same way
                        nx, ny = x[:, 0].clone(), x[:, 1].clone()
                        for _ in range(k):
                            nx, ny = -ny, nx
                        x = torch.stack([nx, ny, x[:, 2]], 1)
                out[key][ii] = x
    return out


# ----------------------------------------------------------------------------------------------------------
# shading in torch (the split-sum shading of supermat_tools.smrender, differentiable in the maps)
# ----------------------------------------------------------------------------------------------------------
class TorchEnv:
    def __init__(self, env):
        self.levels = [torch.from_numpy(l).permute(2, 0, 1)[None].float().to(DEV) for l in env.levels]
        self.irr = torch.from_numpy(env.irr).permute(2, 0, 1)[None].float().to(DEV)

    @staticmethod
    def _sample(img, d):
        # d: B,3,H,W unit directions -> B,3,H,W radiance (equirect, bilinear, u wraps approximately)
        u = torch.atan2(d[:, 0], -d[:, 2]) / math.pi             # -1..1
        v = torch.acos(d[:, 1].clamp(-1, 1)) / math.pi * 2 - 1  # -1..1
        grid = torch.stack([u, v], -1)
        return F.grid_sample(img.expand(d.shape[0], -1, -1, -1), grid, mode="bilinear", padding_mode="border",
                             align_corners=False)

    def specular(self, d, rough):
        lv = torch.tensor(R.ROUGH_LEVELS, device=DEV)
        out = 0
        for i in range(len(lv)):
            lo = lv[i - 1] if i > 0 else lv[0] - 1
            hi = lv[i + 1] if i + 1 < len(lv) else lv[-1] + 1
            w = torch.where(rough < lv[i], (rough - lo) / (lv[i] - lo), (hi - rough) / (hi - lv[i])).clamp(min=0)
            out = out + w * self._sample(self.levels[i], d)
        return out

    def irradiance(self, n):
        return self._sample(self.irr, n)


_LUT_T = None


def shade_t(env, rot, nrm, alb_srgb, rough, metal):
    """nrm B3HW (camera space), alb in sRGB [0,1], rough/metal B1HW; rot 3x3 world->map."""
    global _LUT_T
    if _LUT_T is None:
        _LUT_T = torch.from_numpy(R.brdf_lut()).permute(2, 0, 1)[None].to(DEV)  # 1,2,rough,nv
    alb = torch.where(alb_srgb <= 0.04045, alb_srgb / 12.92, ((alb_srgb.clamp(min=0) + 0.055) / 1.055) ** 2.4)
    rough = rough.clamp(0.02, 1)
    nv = nrm[:, 2:3].clamp(1e-4, 1)
    refl = 2 * nv * nrm - torch.tensor([0.0, 0, 1], device=DEV)[None, :, None, None]
    rt = torch.as_tensor(rot, dtype=torch.float32, device=DEV)
    rd = torch.einsum("ij,bjhw->bihw", rt, refl)
    nd = torch.einsum("ij,bjhw->bihw", rt, nrm)
    f0 = 0.04 * (1 - metal) + alb * metal
    grid = torch.stack([nv[:, 0] * 2 - 1, rough[:, 0] * 2 - 1], -1)
    ab = F.grid_sample(_LUT_T.expand(nrm.shape[0], -1, -1, -1), grid, align_corners=False, padding_mode="border")
    spec = env.specular(rd, rough) * (f0 * ab[:, :1] + ab[:, 1:2])
    fr = f0 + (torch.maximum(1 - rough, f0) - f0) * (1 - nv) ** 5
    diff = (1 - fr) * (1 - metal) * alb / math.pi * env.irradiance(nd)
    return diff + spec


def tonemap_t(lin, expo):
    x = (lin * expo).clamp(0, 1)
    return torch.where(x <= 0.0031308, 12.92 * x, 1.055 * (x + 1e-8) ** (1 / 2.4) - 0.055)


# ----------------------------------------------------------------------------------------------------------
# losses
# ----------------------------------------------------------------------------------------------------------
def grad_l1(a, b, w):
    dxa, dxb = a[..., :, 1:] - a[..., :, :-1], b[..., :, 1:] - b[..., :, :-1]
    dya, dyb = a[..., 1:, :] - a[..., :-1, :], b[..., 1:, :] - b[..., :-1, :]
    wx = w[..., :, 1:] * w[..., :, :-1]
    wy = w[..., 1:, :] * w[..., :-1, :]
    return ((dxa - dxb).abs() * wx).mean() + ((dya - dyb).abs() * wy).mean()


def psnr_masked(a, b, m):
    mse = (((a - b) ** 2) * m).sum() / (m.sum() * a.shape[1]).clamp(min=1)
    return float(10 * torch.log10(1 / mse.clamp(min=1e-10)))


# ----------------------------------------------------------------------------------------------------------
# checkpoints
# ----------------------------------------------------------------------------------------------------------
def save_ckpt(path, **state):
    tmp = path + ".tmp"
    torch.save(state, tmp)
    os.replace(tmp, path)


def load_ckpt(path):
    # weights_only=False: these are this script's own files (numpy RNG states, a tuple-valued cache), and
    # torch >= 2.6 would otherwise refuse them
    return torch.load(path, map_location="cpu", weights_only=False) if os.path.exists(path) else None


def lr_at(step, total, base, warm=100):
    if step < warm:
        return base * (step + 1) / warm
    return base * 0.5 * (1 + math.cos(math.pi * min(1.0, (step - warm) / max(1, total - warm)))) * 0.95 + base * 0.05


SECONDS = {}  # --seconds: phase name -> wall-clock budget
UNTIL = {}    # --until: phase name -> the step it ends at (its learning-rate schedule still reads `total`)


class Phase:
    """Step loop with time-based checkpoints and resumption.  A phase with a --seconds budget times its
    steps 20-120 of this run and then lowers `total` (never raises it) so that the rest fits the budget; the
    learning-rate schedules read `total` each step, so they end where the phase ends.  The total is saved
    with the checkpoint, so a resumed phase keeps it."""

    def __init__(self, run, name, models, opt, total, ckpt_every, seed):
        self.run, self.name, self.models, self.opt, self.total = run, name, models, opt, total
        self.path = os.path.join(run, f"ckpt_{name}.pt")
        self.ckpt_every = ckpt_every
        self.step = 0
        self.rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
        self.log = open(os.path.join(run, f"log_{name}.txt"), "a")
        st = load_ckpt(self.path)
        if st is not None:
            for k, m in models.items():
                m.load_state_dict(st["models"][k])
            opt.load_state_dict(st["opt"])
            self.step = st["step"]
            self.total = min(self.total, st.get("total", self.total))
            self.rng.bit_generator.state = st["rng"]
            torch.set_rng_state(st["torch_rng"])
            print(f"{name}: resumed at step {self.step}/{total}", flush=True)
        self.last = time.time()
        self.t0 = time.time()
        self.budget = SECONDS.get(name)
        self.first = self.step
        self.t20 = None

    def update(self, loss, params, clip=1.0):
        """One optimiser step: gradients of loss, clipped to norm `clip`."""
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(params, clip)
        self.opt.step()

    def save(self):
        save_ckpt(self.path, models={k: m.state_dict() for k, m in self.models.items()}, opt=self.opt.state_dict(),
                  step=self.step, total=self.total, rng=self.rng.bit_generator.state, torch_rng=torch.get_rng_state())

    def tick(self, msg):
        self.step += 1
        if self.budget is not None and self.step - self.first in (20, 120):
            if DEV.type == "cuda":
                torch.cuda.synchronize()
            if self.step - self.first == 20:
                self.t20 = time.time()
            else:
                per = (time.time() - self.t20) / 100
                fit = self.step + int((self.budget - (time.time() - self.t0)) / per)
                self.total = max(self.step, min(self.total, fit))
                print(f"{self.name}: {per * 1000:.1f} ms a step, {self.total} steps fit --seconds {self.budget:g}", flush=True)
        if self.budget is not None and time.time() - self.t0 > self.budget and self.total > self.step:
            self.total = self.step   # over budget before the estimate (slow first steps): end here
            print(f"{self.name}: --seconds {self.budget:g} spent at step {self.step}", flush=True)
        if self.name in UNTIL and self.step >= UNTIL[self.name] and self.total > self.step:
            self.total = self.step   # --until: end here, as a --seconds budget would have (a run's replay)
            print(f"{self.name}: --until {UNTIL[self.name]}", flush=True)
        if self.step % 20 == 0 or self.step == self.total:
            line = f"{self.name} {self.step}/{self.total} {time.time() - self.t0:.0f}s {msg}"
            print(line, flush=True)
            self.log.write(line + "\n")
            self.log.flush()
        if time.time() - self.last > self.ckpt_every:
            self.save()
            self.last = time.time()

    def finish(self):
        self.save()
        open(os.path.join(self.run, f"{self.name}.done"), "w").write(f"{self.step}\n")


def done(run, name):
    return os.path.exists(os.path.join(run, f"{name}.done"))


# ----------------------------------------------------------------------------------------------------------
# phases
# ----------------------------------------------------------------------------------------------------------
def make_vae():
    return AutoencoderKL.from_config(VAE).to(DEV)


def last_vae_phase(run):
    return next((p for p in ("vae_colour", "vae_more", "vae_crops") if done(run, p)), "vae")


def load_vae(run):
    vae = make_vae()
    st = load_ckpt(os.path.join(run, f"ckpt_{last_vae_phase(run)}.pt"))
    vae.load_state_dict(st["models"]["vae"])
    with open(os.path.join(run, "vae_scaling.json")) as f:
        sf = json.load(f)["scaling_factor"]
    vae.register_to_config(scaling_factor=sf)
    for ph in ("dec", "joint_mse", "joint"):  # the decoder as the last dec / joint phase left it (the encoder, hence the latents, unchanged)
        if done(run, ph):
            vae.load_state_dict(load_ckpt(os.path.join(run, f"ckpt_{ph}.pt"))["models"]["vae"])
            break
    return vae.eval()


def phase_vae(args, data, name="vae", steps=None, crop=0, prev=None, batch=None, lr=None, train=None, chroma=0.0):
    torch.manual_seed(args.seed)
    vae = make_vae()
    if prev:  # continues from an earlier VAE phase
        vae.load_state_dict(load_ckpt(os.path.join(args.out, f"ckpt_{prev}.pt"))["models"]["vae"])
    lr = lr or args.vae_lr
    batch = batch or args.vae_batch
    train = vae_train(args, data) if train is None else train
    opt = torch.optim.AdamW(vae.parameters(), lr=lr, weight_decay=0.0)
    ph = Phase(args.out, name, {"vae": vae}, opt, steps or args.vae_steps, args.ckpt_every, args.seed)
    vae.train()
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = lr_at(ph.step, ph.total, lr)
        idx = ph.rng.choice(train, batch, replace=False)
        b = data.batch(idx, ph.rng)
        if crop:
            y0, x0 = (int(v) * 8 for v in ph.rng.integers(0, (b["inp"].shape[-1] - crop) // 8 + 1, 2))
            b = {k: v[..., y0:y0 + crop, x0:x0 + crop] for k, v in b.items()}
        kind = torch.from_numpy(ph.rng.choice(3, batch, p=[0.4, 0.3, 0.3])).to(DEV)[:, None, None, None]
        x = torch.where(kind == 0, b["inp"], torch.where(kind == 1, b["alb"], b["orm"])) * 2 - 1
        with amp():
            post = vae.encode(x).latent_dist
            z = post.sample()
            y = vae.decode(z).sample.float()
        w = 0.25 + 0.75 * b["mask"]   # the object matters most; the background must stay plain too
        rec = ((y - x).abs() * w).mean()
        kl = post.kl().mean() / x[0].numel()
        loss = rec + 0.5 * grad_l1(y, x, w) + args.vae_kl * kl
        if chroma:   # the colour differences R - G and B - G again, weighted: see phase_vae_colour
            cy, cx = y[:, 0::2] - y[:, 1:2], x[:, 0::2] - x[:, 1:2]
            lc = ((cy - cx).abs() * w).mean()
            loss = loss + chroma * lc
        ph.update(loss, vae.parameters())
        ph.tick(f"rec {rec.item():.4f} kl {kl.item():.3f}" + (f" chroma {lc.item():.4f}" if chroma else ""))
    ph.finish()
    # scaling factor: 1 / std of the latents (mode) of the three kinds of image
    write_scaling(args, data, vae)


def phase_vae_crops(args, data):
    """More VAE steps on 64x64 crops: four times the steps per second (the VAE is convolutional; its
    mid-block attention then sees 8x8 instead of 16x16 latents)."""
    phase_vae(args, data, "vae_crops", args.vae_crop_steps, 64, prev="vae")


def phase_vae_more(args, data):
    """The VAE trained on, from vae_crops: --vae-more-steps on --vae-more-crop crops of every training render,
    batch --vae-more-batch (the shipped VAE's 2300 steps left its reconstruction of the real assets' albedo
    at 17.7 dB: saturated colours come back grey)."""
    phase_vae(args, data, "vae_more", args.vae_more_steps, args.vae_more_crop, prev="vae_crops",
              batch=args.vae_more_batch, lr=args.vae_more_lr, train=data.train)


def phase_vae_colour(args, data):
    """The VAE trained on from the run's last VAE phase (encoder and decoder: the latent space moves, so the UNet
    phases after it start again from their cache), --vae-colour-steps on --vae-colour-crop crops of every training
    render, batch --vae-colour-batch, with the colour differences (R - G, B - G) weighted --vae-colour-chroma more.
    Why: the shipped VAE gives back half the saturation it is given (32 held-out renders' albedo: mean max - min
    0.197 in, 0.091 out) and its decoder reads 3 of its 16 latent channels (setting any other to its mean moves
    the round trip by < 0.1 dB), so no UNet on it can keep an object's colour.  Measured run (docs/notebook/default_model.md): the
    defaults with --seconds vae_colour=3300 (the budget set 3352 steps; it ended at 3103), 16 000 renders."""
    phase_vae(args, data, "vae_colour", args.vae_colour_steps, args.vae_colour_crop, prev=last_vae_phase(args.out),
              batch=args.vae_colour_batch, lr=args.vae_colour_lr, train=data.train, chroma=args.vae_colour_chroma)


def decoder_only(vae):
    """Freeze the VAE but its decoder (+ post_quant_conv), whose parameters it returns: the encoder, hence the
    latent space the UNet works in, stays as it is."""
    for p in vae.parameters():
        p.requires_grad_(False)
    dec = list(vae.decoder.parameters()) + list(vae.post_quant_conv.parameters())
    for p in dec:
        p.requires_grad_(True)
    return dec


def branch_only(unet, prefixes):
    """Freeze the UNet but the parameters named with one of `prefixes` (an expert branch), which it returns."""
    params = []
    for k, p in unet.named_parameters():
        p.requires_grad_(k.startswith(prefixes))
        if p.requires_grad:
            params.append(p)
    return params


def phase_dec(args, data):
    """The VAE decoder alone (+ post_quant_conv) on reconstructions of the pictures, albedo and ORM maps, the
    encoder frozen so that the latent space the UNet predicts in stays the same: --dec-steps, batch
    --dec-batch, --dec-crop crops (0: whole pictures), lr --dec-lr; L1 + gradient L1, object pixels weighted
    1, background 0.25.  Made for a measured defect: the shipped decoder returns a flat metal ORM (1, r, 1)
    with roughness 0.74-0.86 whatever r is (0.05-1), although the encoder keeps r apart (docs/notebook/default_model.md)."""
    vae = load_vae(args.out)
    dec = decoder_only(vae)
    opt = torch.optim.AdamW(dec, lr=args.dec_lr, weight_decay=0.0)
    ph = Phase(args.out, "dec", {"vae": vae}, opt, args.dec_steps, args.ckpt_every, args.seed)
    vae.eval()
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = lr_at(ph.step, ph.total, args.dec_lr, warm=20)
        idx = ph.rng.choice(data.train, args.dec_batch, replace=False)
        b = data.batch(idx, ph.rng)
        third = max(1, args.dec_batch // 3)
        x = torch.cat([b["inp"][:third], b["alb"][third:2 * third], b["orm"][2 * third:]])
        w = 0.25 + 0.75 * b["mask"]
        if args.dec_crop:   # one crop for the batch, on the latent grid
            c = args.dec_crop
            y0, x0 = (8 * int(ph.rng.integers((x.shape[-1] - c) // 8 + 1)) for _ in range(2))
            x, w = x[..., y0:y0 + c, x0:x0 + c], w[..., y0:y0 + c, x0:x0 + c]
        with torch.no_grad(), amp():
            z = vae.encode(x * 2 - 1).latent_dist.mode().float()
        with amp():
            y = vae.decode(z).sample.float() / 2 + 0.5
        loss = ((y - x).abs() * w).mean() + 0.5 * grad_l1(y, x, w)
        ph.update(loss, dec)
        ph.tick(f"decoder {loss.item():.4f}")
    ph.finish()


def vae_train(args, data):
    """The renders the VAE trains on: the first --vae-samples of the training split (all with 0)."""
    return data.train[:args.vae_samples] if args.vae_samples > 0 else data.train


def write_scaling(args, data, vae):
    vae.eval()
    zs = []
    tr = vae_train(args, data)
    with torch.no_grad():
        for i in range(0, min(len(tr), 512), 32):
            b = data.batch(tr[i:i + 32])
            for k in ("inp", "alb", "orm"):
                zs.append(vae.encode(b[k] * 2 - 1).latent_dist.mode())
    sf = float(1.0 / torch.cat(zs).std())
    with open(os.path.join(args.out, "vae_scaling.json"), "w") as f:
        json.dump({"scaling_factor": sf}, f)
    print(f"vae: scaling factor {sf:.5f}", flush=True)


@torch.no_grad()
def vae_report(args, data, vae):
    res = {}
    b = data.batch(data.val)
    for k in ("inp", "alb", "orm"):
        y = (vae.decode(vae.encode(b[k] * 2 - 1).latent_dist.mode()).sample / 2 + 0.5).clamp(0, 1)
        y = torch.round(y * 255) / 255
        res[k] = {"psnr_object": psnr_masked(y, b[k], b["mask"]),
                  "psnr_image": psnr_masked(y, b[k], torch.ones_like(b["mask"]))}
    print("vae reconstruction PSNR (validation):", json.dumps(res), flush=True)
    return res


def context(run):
    p = os.path.join(run, "release", "base", "empty_prompt_embeds.npy")
    return torch.from_numpy(np.load(p)).to(DEV)


def unet_forward(unet, z_in, ctx, coef):
    out = unet(z_in, 999, encoder_hidden_states=ctx.expand(z_in.shape[0], -1, -1)).sample
    return [coef * v.float() for v in out]


@torch.no_grad()
def encode_all(vae, data, idx, sf, flip=False, bs=32):
    """Latents (mode x scaling factor) of the input, albedo and ORM images, optionally mirrored."""
    out = {"inp": [], "alb": [], "orm": []}
    for i in range(0, len(idx), bs):
        b = data.batch(idx[i:i + bs])
        for k in out:
            x = b[k].flip(-1) if flip else b[k]
            with amp():
                out[k].append(vae.encode(x * 2 - 1).latent_dist.mode().float() * sf)
    return tuple(torch.cat(out[k]) for k in ("inp", "alb", "orm"))


def phase_latent(args, data, name="latent", cache_name="latents.pt", steps=None, lr=None, init=None):
    vae = load_vae(args.out)
    sf = vae.config.scaling_factor
    cache = os.path.join(args.out, cache_name)
    if os.path.exists(cache):
        lat = {k: tuple(t.to(DEV) for t in v) for k, v in torch.load(cache, map_location="cpu", weights_only=False).items()}
        if lat[False][0].shape[0] != len(data.train):
            raise SystemExit(f"train_default: {cache} holds {lat[False][0].shape[0]} latents, --data has "
                             f"{len(data.train)} training renders (another data set? delete the cache)")
    else:
        t0 = time.time()
        flips = (False, True) if args.latent_flips else (False,)
        lat = {flip: encode_all(vae, data, data.train, sf, flip) for flip in flips}
        torch.save({k: tuple(t.cpu() for t in v) for k, v in lat.items()}, cache + ".tmp")
        os.replace(cache + ".tmp", cache)
        print(f"latent: encoded {len(data.train)} x 3 images x {len(flips)} flip(s) in {time.time() - t0:.0f} s", flush=True)
    ctx = context(args.out)
    coef, _ = x0_coefficient()
    torch.manual_seed(args.seed + 1)
    unet = load_unet(args.out, init) if init else build_unet()
    if init:
        print(f"{name}: from {init}", flush=True)
    lr = lr or args.unet_lr
    opt = torch.optim.AdamW(unet.parameters(), lr=lr, weight_decay=0.0)
    ph = Phase(args.out, name, {"unet": unet}, opt, steps or args.latent_steps, args.ckpt_every, args.seed)
    unet.train()
    n = len(data.train)
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = lr_at(ph.step, ph.total, lr)
        j = torch.from_numpy(ph.rng.choice(n, args.latent_batch, replace=False)).to(DEV)
        flip = bool(ph.rng.integers(2)) and True in lat
        zi, za, zo = (t[j] for t in lat[flip])
        with amp():
            x0a, x0o = unet_forward(unet, zi, ctx, coef)
        la = F.mse_loss(x0a, za)
        lo = F.mse_loss(x0o, zo)
        loss = la + lo
        ph.update(loss, unet.parameters())
        ph.tick(f"albedo {la.item():.4f} orm {lo.item():.4f}")
    ph.finish()


MAPS = ("albedo", "roughness", "metallic")


def map_losses(pa, po, b, squared=()):
    """Per map: masked L1, or for the maps named in `squared` 4 x squared error (what PSNR measures; under
    ambiguity it asks for the conditional mean where L1 asks for the median, e.g. 0 for a metal that is
    unlikely); + gradient L1."""
    m = b["mask"]
    w = 0.1 + 0.9 * m
    def err(name, d):
        return 4 * d * d if name in squared else d.abs()
    la = (err("albedo", pa - b["alb"]) * w).mean() + grad_l1(pa, b["alb"], m)
    lr = (err("roughness", po[:, 1:2] - b["orm"][:, 1:2]) * w).mean() + grad_l1(po[:, 1:2], b["orm"][:, 1:2], m)
    lm = (err("metallic", po[:, 2:3] - b["orm"][:, 2:3]) * w).mean() + grad_l1(po[:, 2:3], b["orm"][:, 2:3], m)
    lo = ((po[:, 0:1] - 1).abs() * m).mean()
    return la, lr, lm, lo


def rerender_loss(envs, rng, b, pa, po):
    """Predicted and true maps shaded under another environment map (random rotation about Y), both tone
    mapped with the exposure auto-chosen for the truth (key 0.25 on the median luminance), masked L1."""
    env = envs[int(rng.integers(len(envs)))]
    rot = R.rotation_y(rng.uniform(0, 2 * np.pi))
    m = b["mask"]
    with torch.no_grad():
        gt_lin = shade_t(env, rot, b["nrm"], b["alb"], b["orm"][:, 1:2], b["orm"][:, 2:3])
        lum = (gt_lin * torch.tensor([0.2126, 0.7152, 0.0722], device=DEV)[None, :, None, None]).sum(1, keepdim=True)
        inside = (m > 0.5).flatten(1)   # the median over each sample's object pixels (1 where it has none)
        med = torch.nanmedian(lum.flatten(1).masked_fill(~inside, float("nan")), dim=1).values
        med = torch.where(inside.any(1), med, torch.ones_like(med))
        expo = (0.25 / med.clamp(min=1e-6))[:, None, None, None]
        gt_img = tonemap_t(gt_lin, expo)
    pr_img = tonemap_t(shade_t(env, rot, b["nrm"], pa, po[:, 1:2], po[:, 2:3]), expo)
    return ((pr_img - gt_img).abs() * m).mean()


def end_to_end_setup(run, src):
    """What the end-to-end phases with a frozen VAE start from: the VAE (no gradients), its scaling factor,
    the empty-prompt context, the x0 coefficient and the UNet of phase `src`."""
    vae = load_vae(run)
    for p in vae.parameters():
        p.requires_grad_(False)
    return vae, vae.config.scaling_factor, context(run), x0_coefficient()[0], load_unet(run, src)


def phase_e2e(args, data, name="e2e", src="latent", steps=None, lr=None, only=None, squared=(), distil=()):
    """End to end (see the phases above); only=RM_BRANCH trains that branch alone (everything else frozen, the
    albedo map then decoded without gradients: none of its losses reaches the branch); squared: the maps (of MAPS)
    whose squared errors replace L1 (map_losses); distil: the maps of the second branch ("roughness",
    "metallic") whose targets are the starting model's own maps of the same batch instead of the truth (a frozen
    copy of the UNet run beside it: that map is kept where it was while the others learn; the re-render loss
    then shades the same targets)."""
    steps = args.e2e_steps if steps is None else steps
    base_lr = args.e2e_lr if lr is None else lr   # (the loop's `lr` is the roughness loss)
    vae, sf, ctx, coef, unet = end_to_end_setup(args.out, src)
    params = branch_only(unet, only) if only else list(unet.parameters())
    teacher = None
    if distil:
        teacher = load_unet(args.out, src).to(DEV).eval()
        for p in teacher.parameters():
            p.requires_grad_(False)
        print(f"{name}: {', '.join(distil)} distilled from {src}", flush=True)
    if only:
        print(f"{name}: from {src}, {sum(p.numel() for p in params)} trainable parameters", flush=True)
    envs = [TorchEnv(R.EnvLight(os.path.join(args.hdri_dir, e))) for e in data.meta["envs"]]
    opt = torch.optim.AdamW(params, lr=base_lr, weight_decay=0.0)
    ph = Phase(args.out, name, {"unet": unet}, opt, steps, args.ckpt_every, args.seed)
    unet.train()
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = lr_at(ph.step, ph.total, base_lr, warm=20)
        idx = ph.rng.choice(data.train, args.e2e_batch, replace=False)
        b = data.batch(idx, ph.rng)
        if args.e2e_permute:
            b = permute_colour(b, ph.rng)
        with torch.no_grad(), amp():
            zi = vae.encode(b["inp"] * 2 - 1).latent_dist.mode().float() * sf
        with amp():
            x0a, x0o = unet_forward(unet, zi, ctx, coef)
            with torch.set_grad_enabled(only != RM_BRANCH):
                pa = (vae.decode(x0a / sf).sample.float() / 2 + 0.5).clamp(0, 1)
            po = (vae.decode(x0o / sf).sample.float() / 2 + 0.5).clamp(0, 1)
        if teacher is not None:
            with torch.no_grad(), amp():
                pt = (vae.decode(unet_forward(teacher, zi, ctx, coef)[1] / sf).sample.float() / 2 + 0.5).clamp(0, 1)
            orm = b["orm"].clone()
            for ch, m in ((1, "roughness"), (2, "metallic")):
                if m in distil:
                    orm[:, ch:ch + 1] = pt[:, ch:ch + 1]
            b = dict(b, orm=orm)
        la, lr, lm, lo = map_losses(pa, po, b, squared)
        lrr = rerender_loss(envs, ph.rng, b, pa, po)
        loss = la + lr + lm + 0.1 * lo + args.rerender_weight * lrr
        ph.update(loss, params)
        ph.tick(f"albedo {la.item():.4f} rough {lr.item():.4f} metal {lm.item():.4f} rerender {lrr.item():.4f}")
    ph.finish()


def phase_ft(args, data, name="ft"):
    """Fine-tuning on another data set (--data, e.g. renders with other material-mode probabilities): the
    latent phase again, from the UNet the run has (unet_source), --ft-steps at --ft-lr, on that data's own
    latent cache (RUN/latents_<name>.pt).  name ft2: a third data set's round (not run by train_default.sh:
    measured, not shipped)."""
    phase_latent(args, data, name, f"latents_{name}.pt", args.ft_steps, args.ft_lr, init=unet_source(args.out))


def phase_ft_e2e(args, data, name="ft_e2e"):
    """The e2e phase after ft (ft2_e2e: after ft2), on the same data."""
    phase_e2e(args, data, name, name[:-len("_e2e")])


def phase_e2e_more(args, data):
    """The e2e phase again, longer, on --data (another data set), from the UNet the run has (unet_source,
    resolved before this phase counts as done).  Not run by train_default.sh: measured, not shipped."""
    src = unet_source(args.out)
    phase_e2e(args, data, "e2e_more", src, args.e2e_more_steps, args.e2e_more_lr)


def permute_colour(b, rng, p=0.5):
    """Swap the colour channels of the picture and the albedo together (half the samples, one of the five
    other orders each): exactly the render of the swapped albedo under the swapped environment map."""
    out = dict(b)
    n = b["inp"].shape[0]
    perms = [(0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    order = [[0, 1, 2]] * n
    for i in range(n):
        if rng.random() < p:
            order[i] = list(perms[int(rng.integers(len(perms)))])
    dev = b["inp"].device
    rows, order = torch.arange(n, device=dev)[:, None], torch.tensor(order, device=dev)
    out["inp"], out["alb"] = b["inp"][rows, order], b["alb"][rows, order]
    return out


def phase_joint_mse(args, data):
    """The joint phase continued with squared map errors (lower learning rate)."""
    phase_joint(args, data, "joint_mse")


def phase_joint(args, data, name="joint"):
    """The UNet and the VAE decoder together, end to end on the decoded maps (the encoder, hence the input
    latents and the scaling factor, frozen): the losses of e2e plus the decoder's own reconstruction of the
    true maps' latents, so that it stays a decoder of the latent space the UNet was trained in."""
    vae = load_vae(args.out)
    sf = vae.config.scaling_factor
    dec = decoder_only(vae)
    ctx = context(args.out)
    coef, _ = x0_coefficient()
    squared = name == "joint_mse"
    unet = load_unet(args.out, "joint" if squared else "e2e" if done(args.out, "e2e") else "latent")
    envs = [TorchEnv(R.EnvLight(os.path.join(args.hdri_dir, e))) for e in data.meta["envs"]]
    lr0 = args.joint_mse_lr if squared else args.joint_lr
    opt = torch.optim.AdamW([{"params": list(unet.parameters())}, {"params": dec}], lr=lr0, weight_decay=0.0)
    ph = Phase(args.out, name, {"unet": unet, "vae": vae}, opt, args.joint_mse_steps if squared else args.joint_steps,
               args.ckpt_every, args.seed)
    unet.train()
    vae.eval()   # no dropout / batch statistics in the VAE; the decoder's weights still learn
    params = list(unet.parameters()) + dec
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = lr_at(ph.step, ph.total, lr0, warm=20)
        idx = ph.rng.choice(data.train, args.e2e_batch, replace=False)
        b = permute_colour(data.batch(idx, ph.rng), ph.rng)
        with torch.no_grad(), amp():
            zi = vae.encode(b["inp"] * 2 - 1).latent_dist.mode().float() * sf
            h = b["inp"].shape[0] // 2
            zt = torch.cat([vae.encode(b["alb"][:h] * 2 - 1).latent_dist.mode(),
                            vae.encode(b["orm"][h:] * 2 - 1).latent_dist.mode()]).float()
        with amp():
            x0a, x0o = unet_forward(unet, zi, ctx, coef)
            pa = (vae.decode(x0a / sf).sample.float() / 2 + 0.5).clamp(0, 1)
            po = (vae.decode(x0o / sf).sample.float() / 2 + 0.5).clamp(0, 1)
            # the decoder on the true maps' latents (half albedo, half ORM)
            yt = vae.decode(zt).sample.float() / 2 + 0.5
        la, lr, lm, lo = map_losses(pa, po, b, MAPS if squared else ())
        xt = torch.cat([b["alb"][:h], b["orm"][h:]])
        wt = 0.25 + 0.75 * b["mask"]
        lrec = ((yt - xt).abs() * wt).mean() + 0.5 * grad_l1(yt, xt, wt)
        lrr = rerender_loss(envs, ph.rng, b, pa, po)
        loss = la + lr + lm + 0.1 * lo + args.rerender_weight * lrr + lrec
        ph.update(loss, params)
        ph.tick(f"albedo {la.item():.4f} rough {lr.item():.4f} metal {lm.item():.4f} rerender {lrr.item():.4f} "
                f"decoder {lrec.item():.4f}")
    ph.finish()


ALB_BRANCH = ("last_up_blocks.0.", "rep_conv_out.0.")   # the albedo expert branch (output 0 of unet_forward)


def unet_source(run):
    """The phase whose UNet the later phases start from / the release takes."""
    return next(p for p in ("rm", "ft2_e2e", "ft2", "e2e_more", "ft_e2e", "ft", "alb", "joint_mse", "joint", "e2e", "latent") if done(run, p))


def phase_alb(args, data):
    """The albedo expert branch alone (the replicated last up block and conv_out of branch 0), everything
    else frozen, so that the roughness / metallic maps stay bit-identical: --alb-steps on the first
    --alb-samples training renders, end to end through the frozen decoder with squared errors (what PSNR
    measures: under the albedo level's ambiguity they ask for the conditional mean, L1 for the median)
    + gradient L1, colour channels of picture and albedo permuted together on half the samples."""
    src = unet_source(args.out)
    vae, sf, ctx, coef, unet = end_to_end_setup(args.out, src)
    params = branch_only(unet, ALB_BRANCH)
    print(f"alb: from {src}, {sum(p.numel() for p in params)} trainable parameters (the albedo branch)", flush=True)
    train = data.train[:args.alb_samples] if args.alb_samples > 0 else data.train
    opt = torch.optim.AdamW(params, lr=args.alb_lr, weight_decay=0.0)
    ph = Phase(args.out, "alb", {"unet": unet}, opt, args.alb_steps, args.ckpt_every, args.seed)
    unet.train()
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = lr_at(ph.step, ph.total, args.alb_lr, warm=20)
        idx = ph.rng.choice(train, args.alb_batch, replace=False)
        b = data.batch(idx, ph.rng)
        if args.alb_permute:
            b = permute_colour(b, ph.rng)
        with torch.no_grad(), amp():
            zi = vae.encode(b["inp"] * 2 - 1).latent_dist.mode().float() * sf
        with amp():
            x0a = unet_forward(unet, zi, ctx, coef)[0]
            pa = (vae.decode(x0a / sf).sample.float() / 2 + 0.5).clamp(0, 1)
        w = 0.1 + 0.9 * b["mask"]
        mse = (((pa - b["alb"]) ** 2) * w).mean()
        loss = 4 * mse + grad_l1(pa, b["alb"], b["mask"])
        ph.update(loss, params)
        ph.tick(f"albedo mse {mse.item():.5f}")
    ph.finish()


RM_BRANCH = ("last_up_blocks.1.", "rep_conv_out.1.")   # the roughness / metallic expert branch (output 1)


def phase_rm(args, data):
    """The roughness / metallic expert branch alone (the replicated last up block and conv_out of branch 1),
    everything else frozen, so that the albedo stays bit-identical: --rm-steps end to end (the e2e phase's
    roughness, metallic, occlusion and re-render losses; the re-render shades the frozen albedo branch's map),
    batch --e2e-batch, lr --rm-lr, colour permutations as --e2e-permute, map errors L1 or squared (--rm-loss), one
    map distilled from the starting model (--rm-distil)."""
    phase_e2e(args, data, "rm", unet_source(args.out), args.rm_steps, args.rm_lr, only=RM_BRANCH,
              squared={"l1": (), "squared": MAPS, "metal-squared": ("metallic",)}[args.rm_loss],
              distil=() if args.rm_distil == "none" else (args.rm_distil,))


def init_from(args, allow_mv=False):
    """Seed RUN with a released default model (a `supermat convert` file of this script's release): its VAE as
    the finished vae / vae_crops phases, its scaling factor, its UNet as the finished latent / e2e phases, so
    that later phases (alb, joint, ...) continue from it.  The release rounded every weight to float16, so
    this is the f16-rounded state of those phases of the run that made the file.  allow_mv: the file may be a
    SuperMatMV one of supermat_tools.train_mv's release (the same VAE; its UNet without the camera MLP,
    class_embedding.*, is a single-view two-branch UNet: the multi-view attention has no weights of its own)."""
    if done(args.out, "e2e"):
        return
    kinds = ("supermat", "supermat-mv") if allow_mv else ("supermat",)
    with safe_open(args.init_from, framework="pt") as f:
        meta = f.metadata() or {}
        if meta.get("supermat.kind") not in kinds or int(meta.get("unet.branches", 0)) != 2:
            raise SystemExit(f"train_default: {args.init_from} is not a two-branch SuperMat model file")
        tensors = {k: f.get_tensor(k) for k in f.keys() if not k.startswith("class_embedding.")}
    bad = [k for k, v in tensors.items() if not v.is_floating_point()]
    if bad:
        raise SystemExit(f"train_default: {args.init_from}: {bad[0]} is {tensors[bad[0]].dtype} (f32 / f16 / bf16 files only)")
    tensors = {k: v.float() for k, v in tensors.items()}
    ctx = tensors.pop("context")
    sd_vae = {k[4:]: v for k, v in tensors.items() if k.startswith("vae.")}
    sd_unet = {k: v for k, v in tensors.items() if not k.startswith("vae.")}
    vae = make_vae()
    vae.load_state_dict(sd_vae, strict=True)
    unet = build_unet()
    unet.load_state_dict(sd_unet, strict=True)
    mine = torch.from_numpy(np.load(os.path.join(args.out, "release", "base", "empty_prompt_embeds.npy")))
    err = float((mine.reshape(ctx.shape) - ctx).abs().max())
    if err > 1e-2:
        raise SystemExit(f"train_default: {args.init_from} was made with another text encoder (context differs by "
                         f"{err:.3g}; --seed must be the release's)")
    for ph in ("vae", "vae_crops"):
        save_ckpt(os.path.join(args.out, f"ckpt_{ph}.pt"), models={"vae": vae.state_dict()})
    with open(os.path.join(args.out, "vae_scaling.json"), "w") as f:
        json.dump({"scaling_factor": float(meta["vae.scaling_factor"])}, f)
    for ph in ("latent", "e2e"):
        save_ckpt(os.path.join(args.out, f"ckpt_{ph}.pt"), models={"unet": unet.state_dict()})
    for ph in ("vae", "vae_crops", "latent", "e2e"):
        open(os.path.join(args.out, f"{ph}.done"), "w").write("init-from\n")
    print(f"init-from: {args.init_from} -> {args.out} (vae, vae_crops, latent, e2e done; context {err:.2g})", flush=True)


@torch.no_grad()
def evaluate(args, data, unet, vae, tag):
    ctx = context(args.out)
    coef, _ = x0_coefficient()
    sf = vae.config.scaling_factor
    unet.eval()
    b = data.batch(data.val)
    zi = vae.encode(b["inp"] * 2 - 1).latent_dist.mode() * sf
    x0a, x0o = unet_forward(unet, zi, ctx, coef)
    pa = (vae.decode(x0a / sf).sample / 2 + 0.5).clamp(0, 1)
    po = (vae.decode(x0o / sf).sample / 2 + 0.5).clamp(0, 1)
    q = lambda x: torch.round(x * 255) / 255  # noqa: E731
    m = b["mask"]
    res = {"albedo": psnr_masked(q(pa), b["alb"], m), "roughness": psnr_masked(q(po[:, 1:2]), b["orm"][:, 1:2], m),
           "metallic": psnr_masked(q(po[:, 2:3]), b["orm"][:, 2:3], m)}
    print(f"validation PSNR ({tag}, {len(data.val)} held-out renders):", json.dumps(res), flush=True)
    return res


# ----------------------------------------------------------------------------------------------------------
# release (official format)
# ----------------------------------------------------------------------------------------------------------
def f16_round_(module):
    with torch.no_grad():
        for p in module.state_dict().values():
            if p.dtype == torch.float32:
                p.copy_(p.half().float())


def write_base(run, seed):
    """diffusers-layout base folder: text encoder (fixed random), tokenizer, scheduler, unet config."""
    base = os.path.join(run, "release", "base")
    if os.path.exists(os.path.join(base, "empty_prompt_embeds.npy")):
        return base
    os.makedirs(base, exist_ok=True)
    tok_dir = os.path.join(base, "tokenizer")
    os.makedirs(tok_dir, exist_ok=True)
    with open(os.path.join(tok_dir, "vocab.json"), "w", encoding="utf-8") as f:
        json.dump(synthetic_clip_vocab(TEXT["vocab_size"]), f, ensure_ascii=False)
    with open(os.path.join(tok_dir, "merges.txt"), "w", encoding="utf-8") as f:
        f.write("#version: 0.2\n")
    with open(os.path.join(tok_dir, "special_tokens_map.json"), "w") as f:
        json.dump(TOKENIZER_SPECIAL, f, indent=2)
    with open(os.path.join(tok_dir, "tokenizer_config.json"), "w") as f:
        json.dump(dict(TOKENIZER_SPECIAL, tokenizer_class="CLIPTokenizer", model_max_length=77, do_lower_case=True),
                  f, indent=2)
    tokenizer = CLIPTokenizer.from_pretrained(tok_dir)
    torch.manual_seed(seed + 7)
    text = CLIPTextModel(CLIPTextConfig(**TEXT)).eval()
    f16_round_(text)
    text.save_pretrained(os.path.join(base, "text_encoder"))
    sched = DDIMScheduler.from_config(SCHEDULER)
    sched.save_pretrained(os.path.join(base, "scheduler"))
    os.makedirs(os.path.join(base, "unet"), exist_ok=True)
    UNet2DConditionModel.from_config(UNET).save_config(os.path.join(base, "unet"))
    with open(os.path.join(base, "model_index.json"), "w") as f:
        json.dump({"_class_name": "StableDiffusionPipeline", "_diffusers_version": "0.31.0",
                   "feature_extractor": [None, None], "requires_safety_checker": False,
                   "safety_checker": [None, None], "scheduler": ["diffusers", "DDIMScheduler"],
                   "text_encoder": ["transformers", "CLIPTextModel"], "tokenizer": ["transformers", "CLIPTokenizer"],
                   "unet": ["diffusers", "UNet2DConditionModel"], "vae": ["diffusers", "AutoencoderKL"]}, f, indent=2)
    ids = tokenizer("", max_length=tokenizer.model_max_length, padding="max_length", truncation=True,
                    return_tensors="pt")["input_ids"]
    with torch.no_grad():
        ehs = text(ids, return_dict=False)[0].float()
    np.save(os.path.join(base, "empty_prompt_embeds.npy"), ehs.numpy())
    return base


def phase_export(args, data):
    base = os.path.join(args.out, "release", "base")
    vae = load_vae(args.out)
    f16_round_(vae)
    vae.to("cpu").save_pretrained(os.path.join(base, "vae"), safe_serialization=True)
    vae.to(DEV)
    src = unet_source(args.out)
    unet = load_unet(args.out, src)
    f16_round_(unet)
    torch.save({k: v.cpu() for k, v in unet.state_dict().items()}, os.path.join(args.out, "release", "supermat.pth"))
    report = {"unet_from": src, "unet_params": sum(p.numel() for p in unet.parameters()),
              "vae_params": sum(p.numel() for p in vae.parameters()), "unet_config": UNET, "vae_config": dict(VAE),
              "scaling_factor": vae.config.scaling_factor, "vae_psnr": vae_report(args, data, vae),
              "validation_psnr": evaluate(args, data, unet, vae, src)}
    report["vae_config"]["scaling_factor"] = vae.config.scaling_factor
    with open(os.path.join(args.out, "release", "report.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(f"export: {args.out}/release (supermat.pth + base/), UNet {report['unet_params']} + VAE "
          f"{report['vae_params']} parameters", flush=True)


def run_phases(args, data, phases):
    """Runs the phases of args.phases (comma separated) in that order, each PHASES[name](args, data); a phase
    whose .done marker is in args.out already is skipped (export always runs); says each one's seconds.  Also
    train_mv.py's and train_refine.py's loop."""
    for name in args.phases.split(","):
        if name != "export" and done(args.out, name):
            print(f"{name}: done already", flush=True)
            continue
        t0 = time.time()
        phases[name](args, data)
        print(f"{name}: {time.time() - t0:.0f} s this run", flush=True)


def add_run_args(ap):
    """The run options supermat_tools.train_mv and supermat_tools.train_refine share (what configure() reads)."""
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--amp", default="off", choices=("off", "bf16"))
    ap.add_argument("--seconds", default="", metavar="PHASE=S,...")
    ap.add_argument("--until", default="", metavar="PHASE=STEP,...")
    ap.add_argument("--ckpt-every", type=float, default=120.0)


def configure(args):
    """What --threads, --device, --seconds, --until and --amp set for the whole run (also supermat_tools.train_mv's)."""
    global DEV, AMP
    torch.set_num_threads(args.threads)
    DEV = torch.device(args.device)
    for item in filter(None, args.seconds.split(",")):
        k, _, v = item.partition("=")
        SECONDS[k] = float(v)
    for item in filter(None, args.until.split(",")):
        k, _, v = item.partition("=")
        UNTIL[k] = int(v)
    if DEV.type == "cuda":
        torch.backends.cuda.matmul.allow_tf32 = True
        torch.backends.cudnn.allow_tf32 = True
        torch.backends.cudnn.benchmark = True
    AMP = args.amp == "bf16"
    if AMP:
        F.group_norm = _group_norm_f32
        F.layer_norm = _layer_norm_f32


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="a gen_data.py folder, or several, comma separated")
    ap.add_argument("--out", required=True)
    ap.add_argument("--hdri-dir", default=None, help="the maps gen_data.py used (default: from DATA/meta.json)")
    ap.add_argument("--phases", default="vae,vae_crops,latent,e2e,export")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--amp", default="off", choices=("off", "bf16"),
                    help="bf16: forward passes under bfloat16 autocast (2x the steps per second where the CPU has "
                         "AMX: oneDNN's bf16 convolutions; slower without AMX / AVX512_BF16)")
    ap.add_argument("--device", default="cpu", help="torch device, e.g. cuda (never required; CI and the defaults use the CPU)")
    ap.add_argument("--seconds", default="", metavar="PHASE=S,...",
                    help="wall-clock budgets: such a phase runs min(its steps, what fits S seconds) (see Phase)")
    ap.add_argument("--until", default="", metavar="PHASE=STEP,...",
                    help="end these phases at these steps, their schedules unchanged (to replay a run a --seconds budget ended)")
    ap.add_argument("--ckpt-every", type=float, default=120.0, help="seconds between checkpoints")
    ap.add_argument("--vae-steps", type=int, default=700)
    ap.add_argument("--vae-crop-steps", type=int, default=1600)
    ap.add_argument("--vae-batch", type=int, default=8)
    ap.add_argument("--vae-more-steps", type=int, default=3000)
    ap.add_argument("--vae-more-crop", type=int, default=0, help="0: whole pictures")
    ap.add_argument("--vae-more-batch", type=int, default=8)
    ap.add_argument("--vae-more-lr", type=float, default=2e-4)
    ap.add_argument("--vae-colour-steps", type=int, default=6000)
    ap.add_argument("--vae-colour-crop", type=int, default=64, help="0: whole pictures")
    ap.add_argument("--vae-colour-batch", type=int, default=16)
    ap.add_argument("--vae-colour-lr", type=float, default=2e-4)
    ap.add_argument("--vae-colour-chroma", type=float, default=1.0)
    ap.add_argument("--vae-lr", type=float, default=4e-4)
    ap.add_argument("--vae-kl", type=float, default=1e-4)
    ap.add_argument("--vae-samples", type=int, default=3936,
                    help="the VAE trains on the first N training renders (0 = all); 3936: the default model's VAE "
                         "was trained on the first 4000-render data set (its 64 last ones held out)")
    ap.add_argument("--latent-steps", type=int, default=2400)
    ap.add_argument("--latent-batch", type=int, default=16)
    ap.add_argument("--latent-flips", type=int, default=0, help="also encode mirrored pictures (1 doubles the encoding time and the cache)")
    ap.add_argument("--unet-lr", type=float, default=4e-4)
    ap.add_argument("--e2e-steps", type=int, default=100)
    ap.add_argument("--e2e-batch", type=int, default=8)
    ap.add_argument("--e2e-lr", type=float, default=1e-4)
    ap.add_argument("--e2e-permute", type=int, default=0,
                    help="end-to-end phases: permute the colour channels of picture and albedo on half the samples")
    ap.add_argument("--e2e-more-steps", type=int, default=900)
    ap.add_argument("--e2e-more-lr", type=float, default=1e-4)
    ap.add_argument("--rerender-weight", type=float, default=0.5)
    ap.add_argument("--joint-steps", type=int, default=800)
    ap.add_argument("--joint-lr", type=float, default=1e-4)
    ap.add_argument("--joint-mse-steps", type=int, default=250)
    ap.add_argument("--joint-mse-lr", type=float, default=5e-5)
    ap.add_argument("--dec-steps", type=int, default=1000)
    ap.add_argument("--dec-batch", type=int, default=12)
    ap.add_argument("--dec-lr", type=float, default=1e-4)
    ap.add_argument("--dec-crop", type=int, default=64, help="crop size, a multiple of 8 (0: whole pictures)")
    ap.add_argument("--ft-steps", type=int, default=2000)
    ap.add_argument("--ft-lr", type=float, default=2e-4)
    ap.add_argument("--rm-steps", type=int, default=600)
    ap.add_argument("--rm-lr", type=float, default=1e-4)
    ap.add_argument("--rm-loss", default="l1", choices=("l1", "squared", "metal-squared"),
                    help="the rm phase's map errors: l1 (asks for the median: 0 for a metal the network is unsure "
                         "of), squared (the conditional mean, what PSNR measures) or metal-squared (roughness L1, "
                         "metallic squared)")
    ap.add_argument("--rm-distil", default="none", choices=("none", "roughness", "metallic"),
                    help="the rm phase: this map's target is the starting model's own map of the batch instead of "
                         "the truth (kept where it was while the other map learns)")
    ap.add_argument("--alb-steps", type=int, default=600)
    ap.add_argument("--alb-batch", type=int, default=8)
    ap.add_argument("--alb-lr", type=float, default=1e-4)
    ap.add_argument("--alb-samples", type=int, default=5936,
                    help="the alb phase trains on the first N training renders (0 = all)")
    ap.add_argument("--alb-permute", type=int, default=1, help="permute the colour channels of half the samples")
    ap.add_argument("--init-from", metavar="MODEL", help="start from a released default model (see init_from)")
    args = ap.parse_args()
    configure(args)
    os.makedirs(args.out, exist_ok=True)
    data = Data(args.data)
    if args.hdri_dir is None:
        args.hdri_dir = data.meta.get("hdri_dir", "")
    write_base(args.out, args.seed)
    if args.init_from:
        init_from(args)
    with open(os.path.join(args.out, "args.json"), "w") as f:
        json.dump(vars(args), f, indent=1)
    run_phases(args, data, {"vae": phase_vae, "vae_crops": phase_vae_crops, "vae_more": phase_vae_more, "vae_colour": phase_vae_colour, "latent": phase_latent, "e2e": phase_e2e,
         "joint": phase_joint, "joint_mse": phase_joint_mse, "alb": phase_alb, "ft": phase_ft,
         "ft_e2e": phase_ft_e2e, "ft2": lambda a, d: phase_ft(a, d, "ft2"),
         "ft2_e2e": lambda a, d: phase_ft_e2e(a, d, "ft2_e2e"), "e2e_more": phase_e2e_more, "dec": phase_dec, "rm": phase_rm, "export": phase_export})


if __name__ == "__main__":
    main()
