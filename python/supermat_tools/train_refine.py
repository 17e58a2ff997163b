#!/usr/bin/env python3
"""The two UV-refine networks (albedo, roughness / metallic) trained here, in the official code.

    PYTHONPATH=python /usr/bin/python3 -m supermat_tools.train_refine --data REFDATA --out RUN --init-from models/supermat_default.safetensors \\
        [--phases bc,rm,export] [--steps 1500] [--batch 8] [--lr 1e-4] [--amp bf16] [--seconds bc=S,rm=S]

REFDATA: supermat_tools.gen_refine_data output (the view model's back-projected maps on procedural meshes, with the
meshes' true UV textures).  Each network is the official UV-refine UNet (UVRefineUNet2DConditionModel, as the project's port
supermat_tools.supermat_adapters has it, `replicate(1)`: conv_in and the first down block renamed rep_conv_in.0 / first_down_blocks.0, the last up block
and conv_out last_up_blocks.0 / rep_conv_out.0), built as the official UVRefineAdapterWrapper.convert builds it
from a base UNet, with one difference: its input is [the partial map's latent, the mask, the position map], so
in_channels = the VAE's latent channels + 4 = 20 with this project's 16-channel VAE (the official SD VAE: 4 + 4
= 8, which the official wrapper writes as a constant). The base UNet is the model of --init-from (the
single-view default, or the multi-view default without its camera MLP) with its albedo branch (bc) or its roughness /
metallic branch (rm) as the plain last up block and conv_out; conv_in's weights for the latent are the base's,
those for the mask and position start at zero (the official wrapper leaves them at their random initialisation),
so that training starts from the base network.
The VAE is that model's, frozen.

It is run as supermat_uv.h and the official refine pipeline run it: the partial map (unseen texels 0) in
[-1, 1] -> VAE encode (mode x scaling factor), the mask and position bilinearly resized to the latent size
(align_corners false), one UNet step at t = 999 on zero latents, v-prediction x0, VAE decode.  The target is
the true map: sRGB albedo, or the (0, roughness, metallic) image.  Loss, on the decoded map: L1 + gradient L1,
weighted per texel (--seen-weight on the chart texels a view saw, --unseen-weight on those none saw,
--off-weight off the charts; default 1 / 1 / 0.1), computed on a random --crop x --crop window of the latent's
decoding (the decoder is the cost); --init-refine RUN starts from another run's networks; flips and 90-degree turns of the whole UV layout (position map alike) and,
for the albedo, colour-channel permutations of partial map and truth together.

Phases (each checkpoints to RUN/ckpt_<phase>.pt and resumes; --seconds PHASE=S, --until as train_default.py):
  bc      the albedo refine network      rm      the roughness / metallic one
  export  RUN/release/uv_refine_bc.pth and uv_refine_rm.pth (state dicts, float16-rounded, torch.save) and the
          base folder (vae/, text_encoder/, tokenizer/, scheduler/, unet/config.json), which
          `supermat convert --kind uv-refine --unet RUN/release/uv_refine_bc.pth --base RUN/release/base` reads;
          RUN/release/report_refine.json: masked PSNR on the held-out meshes' chart texels (all, and the unseen
          ones alone) of the refined maps and of the partial maps (unseen texels filled from the nearest seen
          one, what --no-refine bakes); RUN/release/golden/refine_<bc|rm>_128: one held-out mesh's maps through
          the exported network in float32, in the layout of tests/test_golden.c (the C runtime on the converted
          file must match it: `test_golden FILE auto 2 DIR`)

Measured (README): 800 meshes, bc 570 + rm 485 steps of batch 8 at lr 2e-4 in 37 min on 2 cores (bf16 on AMX);
the refined maps do not beat the partial maps on either held-out procedural meshes or real assets.  On a lent
H200 (scripts/train_gpu.sh device-refine, --init-from the multi-view default): 512 meshes, 880 / 887 steps of
batch 32 at lr 2e-4, 300 ms a step: the refined albedo beats the partial map on held-out procedural meshes
(13.90 against 12.73 dB) but not on real assets (15.59 against 16.40 on the README's held-out five).
"""
import argparse
import json
import os

from supermat_tools import train_default as T  # (diffusers, and supermat_adapters.py: the SuperMat classes)
import numpy as np
import torch
import torch.nn.functional as F
from scipy import ndimage
from supermat_tools.supermat_adapters import UVRefineUNet2DConditionModel

BRANCH = {"bc": 0, "rm": 1}
EXTRA = 4   # mask (1) + position (3)


def base_from_supermat(sd, branch):
    """A plain diffusers UNet2DConditionModel from a two-branch SuperMat UNet's state dict, with expert branch
    `branch` as its last up block and conv_out."""
    base = T.UNet2DConditionModel.from_config(T.UNET)
    last = len(base.up_blocks) - 1
    out = {}
    for k, v in sd.items():
        if k.startswith("last_up_blocks."):
            b, rest = k[len("last_up_blocks."):].split(".", 1)
            if int(b) == branch:
                out[f"up_blocks.{last}.{rest}"] = v
        elif k.startswith("rep_conv_out."):
            b, rest = k[len("rep_conv_out."):].split(".", 1)
            if int(b) == branch:
                out[f"conv_out.{rest}"] = v
        else:
            out[k] = v
    base.load_state_dict(out, strict=True)
    return base


def build_refine(base=None):
    """The official UV-refine UNet (UVRefineAdapterWrapper.convert's steps) with in_channels = latent + 4."""
    cfg = T.UNET if base is None else base.config
    unet = UVRefineUNet2DConditionModel.from_config(cfg, in_channels=T.UNET["in_channels"] + EXTRA)
    if base is not None:
        r = unet.load_state_dict({k: v for k, v in base.state_dict().items() if k != "conv_in.weight"}, strict=False)
        if r.unexpected_keys or r.missing_keys != ["conv_in.weight"]:
            raise SystemExit(f"train_refine: the base UNet does not fit: {r}")
        with torch.no_grad():
            unet.conv_in.weight.zero_()
            unet.conv_in.weight[:, :T.UNET["in_channels"]] = base.conv_in.weight
    unet.replicate(replicate_num=1, shared_blocks_lora=False)
    return unet.to(T.DEV)


class RefData:
    def __init__(self, path, holdout=40, level_aug=0.0):
        self.level_aug = level_aug
        sh = sorted(f for f in os.listdir(path) if f.startswith("shard_") and f.endswith(".npz") and ".tmp" not in f)
        if not sh:
            raise SystemExit(f"train_refine: no shards in {path} (supermat_tools.gen_refine_data)")
        parts = [np.load(os.path.join(path, f)) for f in sh]
        self.a = {k: np.concatenate([p[k] for p in parts]) for k in parts[0].files}
        n = len(self.a["chart"])
        holdout = min(holdout, n // 5)
        self.val = np.arange(n - holdout, n)
        self.train = np.arange(0, n - holdout)
        print(f"data: {n} meshes, {self.a['chart'].shape[1]}^2 texels ({len(self.train)} train, {len(self.val)} "
              f"validation)", flush=True)

    def batch(self, idx, which, rng=None):
        f = lambda k: torch.from_numpy(self.a[k][idx]).float().div(255)  # noqa: E731
        if which == "bc":
            inp, tgt = f("partial_albedo").permute(0, 3, 1, 2), f("truth_albedo").permute(0, 3, 1, 2)
        else:
            inp = f("partial_rm").permute(0, 3, 1, 2)
            inp[:, 0] = 0
            tgt = torch.stack([torch.zeros_like(f("truth_rough")), f("truth_rough"), f("truth_metal")], 1)
        b = {"inp": inp, "tgt": tgt, "mask": f("mask")[:, None], "pos": f("position").permute(0, 3, 1, 2),
             "chart": (f("chart") > 0.5).float()[:, None]}
        if rng is not None:
            k, fl = int(rng.integers(4)), bool(rng.integers(2))
            for key in b:
                x = torch.rot90(b[key], k, (2, 3))
                b[key] = torch.flip(x, (3,)) if fl else x
            if which == "bc" and rng.random() < 0.5:
                o = list(rng.permutation(3))
                b["inp"], b["tgt"] = b["inp"][:, o], b["tgt"][:, o]
            if self.level_aug > 0:   # the same level / tint change on partial map and truth: no level prior to learn
                s, n = self.level_aug, len(idx)
                seen = (b["mask"] > 0).float()
                if which == "bc":
                    g = np.exp(rng.uniform(-s, s, (n, 1, 1, 1)) + rng.uniform(-s / 2, s / 2, (n, 3, 1, 1)))
                    g = torch.from_numpy(g).float()
                    b["inp"], b["tgt"] = (b["inp"] * g).clamp(0, 1) * seen, (b["tgt"] * g).clamp(0, 1)
                else:   # roughness scaled about 0.5 and shifted; metallic as it is
                    g = torch.from_numpy(np.exp(rng.uniform(-s, s, (n, 1, 1)))).float()
                    o = torch.from_numpy(rng.uniform(-s / 2, s / 2, (n, 1, 1))).float()
                    f = lambda r: ((r - 0.5) * g + 0.5 + o).clamp(0, 1)  # noqa: E731
                    b["inp"][:, 1], b["tgt"][:, 1] = f(b["inp"][:, 1]) * seen[:, 0], f(b["tgt"][:, 1])
        return {k: v.contiguous().to(T.DEV) for k, v in b.items()}


def refine_forward(unet, vae, sf, ctx, coef, b):
    with torch.no_grad(), T.amp():
        z = vae.encode(b["inp"] * 2 - 1).latent_dist.mode().float() * sf
    hw = z.shape[-2:]
    m = F.interpolate(b["mask"], size=hw, mode="bilinear")
    p = F.interpolate(b["pos"], size=hw, mode="bilinear")
    with T.amp():
        out = unet([torch.cat([z, m, p], 1)], 999, encoder_hidden_states=ctx.expand(z.shape[0], -1, -1))[0]
    return coef * out[0].float()


def phase_refine(args, data, name):
    vae, sf, ctx, coef = setup(args)
    if args.init_refine:   # go on from another run's network (its weights only: a new schedule and optimiser)
        unet = build_refine()
        unet.load_state_dict(T.load_ckpt(os.path.join(args.init_refine, f"ckpt_{name}.pt"))["models"]["unet"])
    else:
        unet = build_refine(base_from_supermat(T.load_unet(args.out, "e2e").state_dict(), BRANCH[name]))
    opt = torch.optim.AdamW(unet.parameters(), lr=args.lr, weight_decay=0.0)
    ph = T.Phase(args.out, name, {"unet": unet}, opt, args.steps, args.ckpt_every, args.seed)
    unet.train()
    c = args.crop // 8
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = T.lr_at(ph.step, ph.total, args.lr, warm=20)
        b = data.batch(ph.rng.choice(data.train, args.batch, replace=False), name, ph.rng)
        x0 = refine_forward(unet, vae, sf, ctx, coef, b)
        H, W = x0.shape[-2:]
        y0, x0_ = int(ph.rng.integers(0, H - c + 1)), int(ph.rng.integers(0, W - c + 1))
        with T.amp():
            pred = (vae.decode(x0[:, :, y0:y0 + c, x0_:x0_ + c] / sf).sample.float() / 2 + 0.5).clamp(0, 1)
        sl = (slice(None), slice(None), slice(y0 * 8, (y0 + c) * 8), slice(x0_ * 8, (x0_ + c) * 8))
        tgt, ch = b["tgt"][sl], b["chart"][sl]
        if name == "rm":
            pred, tgt = pred[:, 1:], tgt[:, 1:]
        unseen = (b["mask"][sl] <= 0).float() * ch
        w = args.off_weight * (1 - ch) + args.seen_weight * (ch - unseen) + args.unseen_weight * unseen
        l1 = ((pred - tgt).abs() * w).mean()
        loss = l1 + T.grad_l1(pred, tgt, w.clamp(max=1))
        ph.update(loss, list(unet.parameters()))
        ph.tick(f"l1 {l1.item():.4f}")
    ph.finish()


def setup(args):
    vae = T.load_vae(args.out)
    for p in vae.parameters():
        p.requires_grad_(False)
    return vae, vae.config.scaling_factor, T.context(args.out), T.x0_coefficient()[0]


def fill_unseen(x, seen):
    """Unseen texels take the nearest seen texel's value (what supermat_uv.h's --no-refine fill approximates)."""
    if not seen.any():
        return x
    _, (iy, ix) = ndimage.distance_transform_edt(~seen, return_indices=True)
    return x[iy, ix]


@torch.no_grad()
def evaluate(args, data, unets, vae):
    sf, ctx, coef = vae.config.scaling_factor, T.context(args.out), T.x0_coefficient()[0]
    res = {}
    for name, unet in unets.items():
        unet.eval()
        acc = {"refined": [], "partial_filled": [], "refined_unseen": [], "partial_filled_unseen": []}
        for i in data.val:
            b = data.batch(np.array([i]), name)
            x0 = refine_forward(unet, vae, sf, ctx, coef, b)
            pred = (vae.decode(x0 / sf).sample.float() / 2 + 0.5).clamp(0, 1)
            pred = torch.round(pred * 255) / 255
            seen = (b["mask"][0, 0] > 0).cpu().numpy()
            filled = np.stack([fill_unseen(c, seen) for c in b["inp"][0].cpu().numpy()])
            filled = torch.from_numpy(filled)[None].to(T.DEV)
            ch = b["chart"]
            sel = slice(0, 3) if name == "bc" else slice(1, 3)
            un = ch * (b["mask"] <= 0).float()
            for k, x in (("refined", pred), ("partial_filled", filled)):
                for suffix, m in (("", ch), ("_unseen", un)):
                    if m.sum() < 1:
                        continue
                    if name == "bc":
                        acc[k + suffix].append(T.psnr_masked(x[:, sel], b["tgt"][:, sel], m))
                    else:
                        acc[k + suffix].append([T.psnr_masked(x[:, j:j + 1], b["tgt"][:, j:j + 1], m) for j in (1, 2)])
        res[name] = {k: np.mean(v, 0).tolist() for k, v in acc.items()}
        print(f"{name}: held-out meshes {res[name]}", flush=True)
    return res


@torch.no_grad()
def write_golden(args, data, name, unet, vae, size=128):
    """Golden tensors of one held-out mesh's maps (area-resized to size x size) through this network in float32,
    in the reference harness' layout (inputs/uv_map.npy, uv_mask.npy, uv_position.npy; image_latent, unet_input,
    unet_out_b0, x0_latents, vae_decoded_b0, uv_refined: NCHW float32), for the C runtime's test_golden."""
    out = os.path.join(args.out, "release", "golden", f"refine_{name}_{size}")
    os.makedirs(os.path.join(out, "inputs"), exist_ok=True)
    b = data.batch(data.val[:1], name)
    k = b["inp"].shape[-1] // size
    ds = lambda x: F.avg_pool2d(x.float().cpu(), k) if k > 1 else x.float().cpu()  # noqa: E731
    inp, mask, pos = ds(b["inp"]), ds(b["mask"]), ds(b["pos"])
    vae, unet = vae.cpu().float(), unet.cpu().float()
    ctx = T.context(args.out).cpu()
    sf, coef = vae.config.scaling_factor, T.x0_coefficient()[0]
    lat = vae.encode(inp * 2 - 1).latent_dist.mode() * sf
    hw = lat.shape[-2:]
    x = torch.cat([lat, F.interpolate(mask, size=hw, mode="bilinear"), F.interpolate(pos, size=hw, mode="bilinear")], 1)
    v = unet([x], 999, encoder_hidden_states=ctx)[0][0]
    x0 = coef * v
    dec = vae.decode(x0 / sf).sample
    arrs = {"inputs/uv_map": inp, "inputs/uv_mask": mask, "inputs/uv_position": pos, "image_latent": lat,
            "unet_input": x, "unet_out_b0": v, "x0_latents": x0, "vae_decoded_b0": dec,
            "uv_refined": (dec / 2 + 0.5).clamp(0, 1), "encoder_hidden_states": ctx}
    for k_, a in arrs.items():
        np.save(os.path.join(out, k_ + ".npy"), a.numpy().astype(np.float32))
    with open(os.path.join(out, "run.json"), "w") as f:
        json.dump({"mode": "uv", "made_by": "supermat_tools.train_refine (the training framework's float32 forward, "
                   "f16-rounded weights)", "network": name, "image_size": size, "sample": int(data.val[0]),
                   "torch": torch.__version__}, f, indent=1)
    vae.to(T.DEV)
    unet.to(T.DEV)
    print(f"golden: {out}", flush=True)


def phase_export(args, data):
    base = T.write_base(args.out, args.seed)
    vae = T.load_vae(args.out)
    T.f16_round_(vae)
    vae.to("cpu").save_pretrained(os.path.join(base, "vae"), safe_serialization=True)
    vae.to(T.DEV)
    unets = {}
    for name in ("bc", "rm"):
        st = T.load_ckpt(os.path.join(args.out, f"ckpt_{name}.pt"))
        if st is None:
            continue
        unet = build_refine()
        unet.load_state_dict(st["models"]["unet"])
        T.f16_round_(unet)
        path = os.path.join(args.out, "release", f"uv_refine_{name}.pth")
        torch.save({k: v.cpu() for k, v in unet.state_dict().items()}, path + ".tmp")
        os.replace(path + ".tmp", path)
        unets[name] = unet
        write_golden(args, data, name, unet, vae)
    report = {"unet_params": {k: sum(p.numel() for p in u.parameters()) for k, u in unets.items()},
              "validation_psnr": evaluate(args, data, unets, vae)}
    with open(os.path.join(args.out, "release", "report_refine.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(f"export: {sorted(unets)} -> {args.out}/release", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="a gen_refine_data.py folder")
    ap.add_argument("--out", required=True)
    ap.add_argument("--init-from", required=True, metavar="MODEL",
                    help="the single-view or the multi-view default model file (the base UNet: its branch; the VAE)")
    ap.add_argument("--phases", default="bc,rm,export")
    ap.add_argument("--steps", type=int, default=1500)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--crop", type=int, default=128, help="decoded window for the loss (texels, multiple of 8)")
    ap.add_argument("--lr", type=float, default=1e-4)
    ap.add_argument("--init-refine", default="", metavar="RUN", help="start each network from RUN's (weights only)")
    ap.add_argument("--seen-weight", type=float, default=1.0, help="loss weight of the chart texels a view saw")
    ap.add_argument("--unseen-weight", type=float, default=1.0, help="loss weight of the chart texels no view saw")
    ap.add_argument("--off-weight", type=float, default=0.1, help="loss weight of the texels off the charts")
    ap.add_argument("--level-aug", type=float, default=0.0, metavar="S",
                    help="per mesh, partial map and truth changed alike: albedo x exp(U(-S, S) + U(-S/2, S/2) per "
                    "channel), roughness scaled about 0.5 by exp(U(-S, S)) and shifted by U(-S/2, S/2)")
    T.add_run_args(ap)
    args = ap.parse_args()
    T.configure(args)
    torch.manual_seed(args.seed)
    os.makedirs(args.out, exist_ok=True)
    data = RefData(args.data, level_aug=args.level_aug)
    T.write_base(args.out, args.seed)
    T.init_from(args, allow_mv=True)    # the view model's VAE (and scaling factor) as this run's, its UNet the base
    with open(os.path.join(args.out, "args_refine.json"), "w") as f:
        json.dump(vars(args), f, indent=1)
    T.run_phases(args, data, {"bc": lambda a, d: phase_refine(a, d, "bc"), "rm": lambda a, d: phase_refine(a, d, "rm"),
                              "export": phase_export})


if __name__ == "__main__":
    main()
