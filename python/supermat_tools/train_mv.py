#!/usr/bin/env python3
"""SuperMatMV trained here: the single-view default model fine-tuned on six-view renders, in the official code.

    PYTHONPATH=python /usr/bin/python3 -m supermat_tools.train_mv --data MVDATA --out RUN --init-from models/supermat_default.safetensors \\
        [--phases mv,export] [--steps 2000] [--batch 4] [--lr 1e-4] [--device cuda] [--amp bf16]
        [--init-mv RUN] [--distill-albedo A] [--distill-rm R]

MVDATA: supermat_tools.gen_data --views 6 output (each sample one object in the six official views, lit alike).
The network is the official multi-view one (the project's port of the official classes, supermat_tools.supermat_adapters,
same modules and key names), built exactly as the official inference script builds it: SuperMatAdapterWrapper.convert(use_camera_embeddings=True, camera_embeddings_dim=16, replicate_num=2)
(the camera MLP: diffusers' "projection" class embedding of each view's flattened camera-to-world matrix,
added to the timestep embedding) and set_supermat_mv_self_attention(num_views=6) (every self-attention
layer attends over the six views' tokens together).  It starts from the single-view model of --init-from
(its UNet loaded into the multi-view one: everything but the camera MLP, whose last layer starts at zero, so
the cameras' first effect is learnt), the VAE frozen, and trains end to end as train_default.py's e2e phase
does (one step at t = 999, zero latents, v-prediction x0; masked L1 + gradient per map, a re-render loss
under another training map), batches of --batch objects x 6 views, colour permutations per object.

--init-mv RUN starts from another run's multi-view model instead (a second round); --distill-albedo A and
--distill-rm R add A (R) x the mean L1 between the albedo (roughness / metallic) branch's x0 latent and the
single-view model's on the same views, run view by view without gradients: what that model learnt from tens
of thousands of renders is held while the views' attention is learnt from a few hundred objects
(scripts/train_mv_default.sh: the shipped recipe).

Phases (each checkpoints to RUN/ckpt_<phase>.pt and resumes; --seconds PHASE=S and --until as in
train_default.py):
  mv      the fine-tuning above (--steps, --lr, --batch)
  export  RUN/release/supermat_mv.pth (the UNet state dict, float16-rounded, torch.save) and the base folder
          (vae/, text_encoder/, tokenizer/, scheduler/, unet/config.json), which `supermat convert --kind
          supermat-mv --unet RUN/release/supermat_mv.pth --base RUN/release/base` reads; RUN/release/
          report_mv.json: masked PSNR per map on the held-out objects' views, of this model and of the
          single-view model run view by view (the paper's ablation of multi-view attention)
"""
import argparse
import json
import os

from supermat_tools import train_default as T  # (diffusers, and supermat_adapters.py: the SuperMat classes)
import numpy as np
import torch
from supermat_tools.supermat_adapters import SuperMatAdapterWrapper, set_supermat_mv_self_attention

from supermat_tools import smrender as R

VIEWS = 6
CAM_DIM = 16


def build_unet_mv():
    """The official multi-view UNet at train_default.py's widths, as inference_supermat_mv.py builds it."""
    base = T.UNet2DConditionModel.from_config(T.UNET)
    unet = SuperMatAdapterWrapper.convert(T._PipeShim(base), use_camera_embeddings=True,
                                          camera_embeddings_dim=CAM_DIM, replicate_num=2).unet
    set_supermat_mv_self_attention(unet, num_views=VIEWS, use_xformers=False)
    return unet.to(T.DEV)


def from_single_view(unet_mv, unet_sv):
    """Load the single-view UNet into the multi-view one: only the camera MLP is new (its last layer zero)."""
    r = unet_mv.load_state_dict(unet_sv.state_dict(), strict=False)
    if r.unexpected_keys or any(not k.startswith("class_embedding.") for k in r.missing_keys):
        raise SystemExit(f"train_mv: the single-view UNet does not fit: {r}")
    with torch.no_grad():
        unet_mv.class_embedding.linear_2.weight.zero_()
        unet_mv.class_embedding.linear_2.bias.zero_()


class MVData:
    """gen_data.py --views 6 shards: per-view arrays flattened object-major (object o's views are rows
    6o..6o+5, the order the multi-view attention groups them in), the cameras as [N*6, 16] (row-major c2w,
    as the official inference reads meta.json's transform_matrix)."""

    def __init__(self, path, holdout=16):
        sh = sorted(f for f in os.listdir(path) if f.startswith("shard_") and f.endswith(".npz") and ".tmp" not in f)
        if not sh:
            raise SystemExit(f"train_mv: no shards in {path} (supermat_tools.gen_data --views 6)")
        with open(os.path.join(path, "meta.json")) as f:
            self.meta = json.load(f)
        if self.meta.get("views") != VIEWS:
            raise SystemExit(f"train_mv: {path} is not six-view data (gen_data.py --views 6)")
        parts = [np.load(os.path.join(path, f)) for f in sh]
        for k in ("rgba", "albedo", "rough", "metal", "normal", "cams"):
            a = np.concatenate([p[k] for p in parts])
            setattr(self, k, a.reshape((-1,) + a.shape[2:]))
        self.cams = self.cams.reshape(-1, 16).astype(np.float32)
        n = self.rgba.shape[0] // VIEWS
        holdout = min(holdout, n // 4)
        self.val = np.arange(n - holdout, n)
        self.train = np.arange(0, n - holdout)
        print(f"data: {n} objects x {VIEWS} views of {self.rgba.shape[1]}x{self.rgba.shape[2]} "
              f"({len(self.train)} train, {len(self.val)} validation)", flush=True)

    def batch(self, objs):
        idx = (np.asarray(objs)[:, None] * VIEWS + np.arange(VIEWS)).ravel()
        b = T.Data.batch(self, idx)                             # no flips or turns: the cameras are fixed
        b["cams"] = torch.from_numpy(self.cams[idx]).to(T.DEV)
        return b


def permute_objects(b, rng, p=0.5):
    """train_default.permute_colour with one draw per object, applied to its six views alike."""
    n = b["inp"].shape[0] // VIEWS
    perms = [(0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    order = []
    for _ in range(n):
        o = list(perms[int(rng.integers(len(perms)))]) if rng.random() < p else [0, 1, 2]
        order += [o] * VIEWS
    out = dict(b)
    rows = torch.arange(n * VIEWS, device=b["inp"].device)[:, None]
    order = torch.tensor(order, device=b["inp"].device)
    out["inp"], out["alb"] = b["inp"][rows, order], b["alb"][rows, order]
    return out


def forward_mv(unet, z, ctx, coef, cams):
    out = unet(z, 999, encoder_hidden_states=ctx.expand(z.shape[0], -1, -1), class_labels=cams).sample
    return [coef * v.float() for v in out]


def phase_mv(args, data):
    vae, sf, ctx, coef, sv = T.end_to_end_setup(args.out, T.unet_source(args.out))
    if args.init_mv:                      # continue another run's multi-view model
        unet = load_mv(args.init_mv)
    else:
        unet = build_unet_mv()
        from_single_view(unet, sv)
    teach = args.distill_albedo > 0 or args.distill_rm > 0
    if teach:
        sv.eval()
        for p in sv.parameters():
            p.requires_grad_(False)
    else:
        del sv
    envs = [T.TorchEnv(R.EnvLight(os.path.join(args.hdri_dir, e))) for e in data.meta["envs"]]
    opt = torch.optim.AdamW(unet.parameters(), lr=args.lr, weight_decay=0.0)
    ph = T.Phase(args.out, "mv", {"unet": unet}, opt, args.steps, args.ckpt_every, args.seed)
    unet.train()
    while ph.step < ph.total:
        for g in opt.param_groups:
            g["lr"] = T.lr_at(ph.step, ph.total, args.lr, warm=20)
        b = data.batch(ph.rng.choice(data.train, args.batch, replace=False))
        if args.permute:
            b = permute_objects(b, ph.rng)
        with torch.no_grad(), T.amp():
            zi = vae.encode(b["inp"] * 2 - 1).latent_dist.mode().float() * sf
        with T.amp():
            x0a, x0o = forward_mv(unet, zi, ctx, coef, b["cams"])
            pa = (vae.decode(x0a / sf).sample.float() / 2 + 0.5).clamp(0, 1)
            po = (vae.decode(x0o / sf).sample.float() / 2 + 0.5).clamp(0, 1)
        la, lr, lm, lo = T.map_losses(pa, po, b)
        lrr = T.rerender_loss(envs, ph.rng, b, pa, po)
        loss = la + lr + lm + 0.1 * lo + args.rerender_weight * lrr
        msg = ""
        if teach:   # keep each branch's latent near the single-view model's, view by view (what it learnt
            with torch.no_grad(), T.amp():    # from tens of thousands of renders)
                ta, to = T.unet_forward(sv, zi, ctx, coef)
            da, do = (x0a - ta).abs().mean(), (x0o - to).abs().mean()
            loss = loss + args.distill_albedo * da + args.distill_rm * do
            msg = f" distill {da.item():.4f} {do.item():.4f}"
        ph.update(loss, list(unet.parameters()))
        ph.tick(f"albedo {la.item():.4f} rough {lr.item():.4f} metal {lm.item():.4f} rerender {lrr.item():.4f}{msg}")
    ph.finish()


def load_mv(run):
    unet = build_unet_mv()
    unet.load_state_dict(T.load_ckpt(os.path.join(run, "ckpt_mv.pt"))["models"]["unet"])
    return unet


@torch.no_grad()
def evaluate_mv(args, data, unet, sv, vae):
    """Masked PSNR per map over the held-out objects' views: the multi-view model, and the single-view one
    view by view."""
    ctx, coef, sf = T.context(args.out), T.x0_coefficient()[0], vae.config.scaling_factor
    unet.eval()
    sv.eval()
    acc = {k: {"albedo": [], "roughness": [], "metallic": []} for k in ("mv", "single_view")}
    for o in data.val:
        b = data.batch(np.array([o]))
        with T.amp():
            zi = vae.encode(b["inp"] * 2 - 1).latent_dist.mode().float() * sf
            for k, outs in (("mv", forward_mv(unet, zi, ctx, coef, b["cams"])), ("single_view", T.unet_forward(sv, zi, ctx, coef))):
                pa = (vae.decode(outs[0] / sf).sample.float() / 2 + 0.5).clamp(0, 1)
                po = (vae.decode(outs[1] / sf).sample.float() / 2 + 0.5).clamp(0, 1)
                m = b["mask"]
                acc[k]["albedo"].append(T.psnr_masked(pa, b["alb"], m))
                acc[k]["roughness"].append(T.psnr_masked(po[:, 1:2], b["orm"][:, 1:2], m))
                acc[k]["metallic"].append(T.psnr_masked(po[:, 2:3], b["orm"][:, 2:3], m))
    return {k: {m: float(np.mean(v)) for m, v in d.items()} for k, d in acc.items()}


def phase_export(args, data):
    base = T.write_base(args.out, args.seed)
    vae = T.load_vae(args.out)
    T.f16_round_(vae)
    vae.to("cpu").save_pretrained(os.path.join(base, "vae"), safe_serialization=True)
    vae.to(T.DEV)
    unet = load_mv(args.out)
    T.f16_round_(unet)
    path = os.path.join(args.out, "release", "supermat_mv.pth")
    torch.save({k: v.cpu() for k, v in unet.state_dict().items()}, path + ".tmp")
    os.replace(path + ".tmp", path)
    sv = T.load_unet(args.out, T.unet_source(args.out))
    report = {"unet_params": sum(p.numel() for p in unet.parameters()),
              "camera_mlp_params": sum(p.numel() for p in unet.class_embedding.parameters()),
              "validation_psnr": evaluate_mv(args, data, unet, sv, vae)}
    with open(os.path.join(args.out, "release", "report_mv.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(f"export: {path} ({report['unet_params']} parameters); held-out views: {report['validation_psnr']}", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="a gen_data.py --views 6 folder")
    ap.add_argument("--out", required=True)
    ap.add_argument("--init-from", required=True, metavar="MODEL", help="the single-view model file to start from")
    ap.add_argument("--hdri-dir", default=None, help="the maps gen_data.py used (default: from DATA/meta.json)")
    ap.add_argument("--phases", default="mv,export")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--batch", type=int, default=4, help="objects a step (x 6 views)")
    ap.add_argument("--lr", type=float, default=1e-4)
    ap.add_argument("--permute", type=int, default=1, help="colour permutations, one per object")
    ap.add_argument("--rerender-weight", type=float, default=0.5)
    ap.add_argument("--init-mv", default="", metavar="RUN",
                    help="start the mv phase from another run's multi-view model (RUN/ckpt_mv.pt)")
    ap.add_argument("--distill-albedo", type=float, default=0.0,
                    help="weight of the L1 between the albedo branch's latent and the single-view model's")
    ap.add_argument("--distill-rm", type=float, default=0.0,
                    help="the same for the roughness / metallic branch")
    T.add_run_args(ap)
    args = ap.parse_args()
    T.configure(args)
    torch.manual_seed(args.seed)
    os.makedirs(args.out, exist_ok=True)
    data = MVData(args.data)
    if args.hdri_dir is None:
        args.hdri_dir = data.meta.get("hdri_dir", "")
    T.write_base(args.out, args.seed)
    T.init_from(args)
    with open(os.path.join(args.out, "args_mv.json"), "w") as f:
        json.dump(vars(args), f, indent=1)
    T.run_phases(args, data, {"mv": phase_mv, "export": phase_export})


if __name__ == "__main__":
    main()
