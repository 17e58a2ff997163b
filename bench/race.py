#!/usr/bin/env python3
"""The race: supermat against ONNX Runtime and PyTorch on the same weights, the same picture and the same
machine, in one run, stage by stage.

    PYTHONPATH=python /usr/bin/python3 bench/race.py --model FULL.safetensors --base SD21_FOLDER --work DIR [options]

--model is an f32 model file made by `supermat convert` from the official checkpoint (its tensors keep the
official key names, so PyTorch and ONNX Runtime get exactly the weights supermat runs); --base is the
SD 2.1-layout folder it was converted with (unet/config.json, vae/config.json, scheduler/).

What runs, one engine after the other, every engine on the same threads (--threads, default 2):
  torch     the official modules (diffusers AutoencoderKL, SuperMat's branched UNet as the project's port of
            the official SuperMat code has it, supermat_tools.supermat_adapters) in float32 under torch.no_grad(): VAE encode (latent_dist.mode() x scaling),
            the UNet once (both branches) and the DDIM x0 step, one VAE decode per branch.
  ort       the same three modules exported to ONNX here (torch.onnx.export, opset 17, static shapes,
            the UNet's weights as external data) and run by ONNX Runtime for Node.js (npm onnxruntime-node,
            bench/race_ort.js), graph optimisation level "all", sequential, intra-op threads = --threads.
  supermat  `supermat bench --pipeline-only` per mode (--modes: f32, winograd_f4, bf16, bf16_wf4, int8; bf16 is
            --compute bf16: AMX tiles where the CPU has them, else vdpbf16ps; skipped without AVX512_BF16;
            int8 is --compute int8, skipped without AVX512_VNNI or AVX-VNNI; f32_avx2 and int8_avx2 (not in the
            default list) run the AVX2 kernel: f32, and int8 compute on AVX-VNNI);
            the FMA peak is measured once by `supermat bench` in the same run.
Each engine and mode runs --runs times (default 2: the first warms caches and allocators) and the fastest
run is reported, stage by stage. Accuracy: every engine and mode also writes its maps for the picture,
compared with the PyTorch float32 maps (the official code): PSNR over all pixels and channels (maps in
[0, 1]), per map. supermat's maps come from `supermat image --native --float` with the mode's options.

FLOPs per stage are the direct algorithm's multiply-adds x 2 as `supermat bench` counts them; GFLOP/s and
"% of peak" use them for every engine and mode (Winograd performs fewer, so its figures are "effective"),
against the f32 FMA peak `supermat bench` measures (AVX-512 where the CPU has it, else AVX2): bf16 on AMX
tiles can pass 100 %.

Needs: Debian's python3-torch (with libopenblas0-pthread installed: without it torch runs its Linear layers
on the reference BLAS, many times slower; the script says which BLAS is in use), python3-onnx is not
imported (torch writes the ONNX files itself), python3-pil, diffusers 0.27 or newer (checked with 0.31.0) on the
ordinary Python path (or a folder of extracted diffusers / huggingface_hub sources first on PYTHONPATH, e.g.
PYTHONPATH=$HARNESS_DEPS/site:python), Node.js and `npm install --ignore-scripts
onnxruntime-node` in --ort-dir (default: --work/ort; done by this script when missing; --ignore-scripts skips
the package's download of CUDA binaries, the CPU library is in the package).

Writes --work/race.json and prints a markdown table (also to --markdown FILE).
Full size (885M parameters), 512x512, 2 threads, 2 runs: about 9 minutes on a 2-core Sapphire Rapids, plus the ONNX
export the first time (reused while the model file and size stay the same: --work/onnx/source.json).
"""
import argparse
import json
import math
import os
import platform
import shutil
import struct
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
os.environ.setdefault("HF_HUB_OFFLINE", "1")
# attention in one piece (torch 1.13's SDPA stand-in splits score matrices over 2^26 elements along the queries
# to bound the memory of multi-view runs; one view at 512 needs 84M): one MatMul-Softmax-MatMul in the ONNX graph
os.environ.setdefault("SUPERMAT_SDPA_CHUNK_ELEMS", str(1 << 30))
from supermat_tools import supermat_adapters  # noqa: E402  (before diffusers: the SDPA shim for torch 1.13; the SuperMat UNet)
import numpy as np  # noqa: E402
import torch  # noqa: E402
from diffusers import AutoencoderKL, DDIMScheduler, UNet2DConditionModel  # noqa: E402
from PIL import Image  # noqa: E402
from supermat_tools.common import read_pfm  # noqa: E402
from supermat_tools.supermat_adapters import SuperMatAdapterWrapper  # noqa: E402

STAGES = ["encode", "unet", "decode_albedo", "decode_rm"]
STAGE_NAMES = {"encode": "VAE encode", "unet": "UNet (trunk + 2 branches)", "decode_albedo": "VAE decode, albedo",
               "decode_rm": "VAE decode, roughness/metallic", "total": "**total**"}
SUPERMAT_MODES = {  # name: (bench / image options, what)
    "f32": ([], "f32, direct convolutions (the exact path)"),
    "winograd_f4": (["--conv", "winograd-f4"], "f32, Winograd F(4x4,3x3)"),
    "bf16": (["--compute", "bf16"], "bf16 compute (AMX where present)"),
    "bf16_wf4": (["--compute", "bf16", "--conv", "winograd-f4"], "bf16 compute + Winograd F4"),
    "int8": (["--compute", "int8"], "int8 compute (AVX512_VNNI, else AVX-VNNI)"),
    "f32_avx2": (["--kernel", "avx2"], "f32, direct, on the AVX2 kernel (what an AVX2-only CPU runs)"),
    "int8_avx2": (["--compute", "int8", "--kernel", "avx2"], "int8 compute on AVX-VNNI (the AVX2 kernel)"),
}


def log(*a):
    print(*a, file=sys.stderr, flush=True)


# ------------------------------------------------------------------------------------------------------
# the model file: safetensors header + memory-mapped f32 tensors
# ------------------------------------------------------------------------------------------------------
def read_safetensors(path):
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
    meta = header.pop("__metadata__", {})
    mm = np.memmap(path, dtype=np.uint8, mode="r")
    tensors = {}
    for k, v in header.items():
        if v["dtype"] != "F32":
            sys.exit(f"race: {path}: tensor {k} is {v['dtype']}: give the f32 file (`supermat convert` without --precision)")
        a, b = v["data_offsets"]
        tensors[k] = mm[8 + n + a:8 + n + b].view(np.float32).reshape(v["shape"])
    return meta, tensors


class _PipeShim:
    def __init__(self, unet):
        self.unet = unet


def build_torch(model_path, base):
    meta, t = read_safetensors(model_path)
    if meta.get("supermat.kind") != "supermat":
        sys.exit(f"race: {model_path} is a '{meta.get('supermat.kind')}' model; the race runs single-view supermat models")
    branches = int(meta.get("unet.branches", "2"))
    with open(os.path.join(base, "unet", "config.json")) as f:
        ucfg = json.load(f)
    with open(os.path.join(base, "vae", "config.json")) as f:
        vcfg = json.load(f)
    torch.manual_seed(0)
    unet = UNet2DConditionModel.from_config(ucfg)
    unet = SuperMatAdapterWrapper.convert(_PipeShim(unet), use_camera_embeddings=False, replicate_num=branches).unet
    usd = {k: torch.from_numpy(np.array(v)) for k, v in t.items() if not k.startswith("vae.") and k != "context"}
    missing, unexpected = unet.load_state_dict(usd, strict=False)
    if missing or unexpected:
        sys.exit(f"race: the model file's UNet tensors are not the official module's: missing {missing[:5]}, "
                 f"unexpected {unexpected[:5]}")
    del usd
    vae = AutoencoderKL.from_config(vcfg)
    vsd = {k[4:]: torch.from_numpy(np.array(v)) for k, v in t.items() if k.startswith("vae.")}
    missing, unexpected = vae.load_state_dict(vsd, strict=False)
    if missing or unexpected:
        sys.exit(f"race: the model file's VAE tensors are not AutoencoderKL's: missing {missing[:5]}, unexpected {unexpected[:5]}")
    del vsd
    ctx = torch.from_numpy(np.array(t["context"]))[None]
    # the scheduler as the converter recorded it (the official script's trailing spacing: one step at t = 999)
    sched = DDIMScheduler(num_train_timesteps=int(meta["sched.num_train_timesteps"]), beta_start=float(meta["sched.beta_start"]),
                          beta_end=float(meta["sched.beta_end"]), beta_schedule=meta["sched.beta_schedule"],
                          prediction_type=meta["sched.prediction_type"], steps_offset=int(meta["sched.steps_offset"]),
                          set_alpha_to_one=meta["sched.set_alpha_to_one"] == "1", timestep_spacing=meta["sched.timestep_spacing"],
                          clip_sample=False)
    sched.set_timesteps(1)
    step = int(sched.timesteps[0])
    one = torch.ones(1, 1, 1, 1)
    coef = float(sched.step(one, step, torch.zeros_like(one)).pred_original_sample)  # x0 = coef * v (zero latents)
    unet.eval()
    vae.eval()
    return unet, vae, ctx, step, coef, float(vae.config.scaling_factor), branches


class Encode(torch.nn.Module):
    def __init__(self, vae, sf):
        super().__init__()
        self.vae, self.sf = vae, sf

    def forward(self, x):
        return self.vae.encode(x).latent_dist.mode() * self.sf


class UNetX0(torch.nn.Module):
    """the UNet once (every branch) and the one-step DDIM x0 of each branch"""
    def __init__(self, unet, ctx, step, coef):
        super().__init__()
        self.unet, self.step, self.coef = unet, step, coef
        self.register_buffer("ctx", ctx)

    def forward(self, z):
        out = self.unet(z, self.step, encoder_hidden_states=self.ctx).sample
        return tuple(self.coef * v for v in out)


class Decode(torch.nn.Module):
    def __init__(self, vae, sf):
        super().__init__()
        self.vae, self.sf = vae, sf

    def forward(self, z):
        return self.vae.decode(z / self.sf).sample


def maps_from(dec_albedo, dec_rm):
    """decoder outputs [1,3,H,W] in [-1,1] -> albedo [H,W,3], roughness [H,W], metallic [H,W] in [0,1]"""
    a = np.clip(np.asarray(dec_albedo, np.float32)[0] / 2 + 0.5, 0, 1)
    o = np.clip(np.asarray(dec_rm, np.float32)[0] / 2 + 0.5, 0, 1)
    return {"albedo": a.transpose(1, 2, 0), "roughness": o[1], "metallic": o[2]}


def psnr(a, b):
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return 200.0 if mse == 0 else min(200.0, 10 * math.log10(1.0 / mse))


# ------------------------------------------------------------------------------------------------------
# the picture
# ------------------------------------------------------------------------------------------------------
def make_picture(path, size, seed):
    """a deterministic RGBA picture: a shaded, textured sphere on a transparent background"""
    rng = np.random.default_rng(seed)
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size * 2 - 1
    r2 = x * x + y * y
    inside = r2 < 0.85 ** 2
    nz = np.sqrt(np.clip(0.85 ** 2 - r2, 0, None)) / 0.85
    shade = np.clip(0.25 + 0.75 * (0.5 * x / 0.85 * -0.4 + 0.6 * -y / 0.85 * 0.5 + nz * 0.8), 0, 1)
    freq = rng.uniform(3, 9, 3)
    tex = 0.5 + 0.35 * np.stack([np.sin(freq[i] * (x + 0.3 * i) * math.pi) * np.cos(freq[(i + 1) % 3] * y * math.pi)
                                 for i in range(3)], -1)
    rgb = np.clip(tex * shade[..., None] + 0.3 * np.clip(nz, 0, 1)[..., None] ** 40, 0, 1)
    rgba = np.zeros((size, size, 4), np.uint8)
    rgba[..., :3] = np.round(rgb * 255)
    rgba[..., 3] = np.where(inside, 255, 0)
    Image.fromarray(rgba, "RGBA").save(path)


def picture_tensor(path):
    """as supermat reads it: straight alpha composited over grey 0.5, then to [-1, 1]"""
    a = np.asarray(Image.open(path).convert("RGBA"), np.float32) / 255.0
    rgb = a[..., :3] * a[..., 3:4] + 0.5 * (1 - a[..., 3:4])
    return torch.from_numpy(np.ascontiguousarray((rgb * 2 - 1).transpose(2, 0, 1)[None]))


# ------------------------------------------------------------------------------------------------------
# engines
# ------------------------------------------------------------------------------------------------------
def run_torch(mods, x, runs):
    enc, unx0, dec = mods
    best, outs = None, None
    with torch.no_grad():
        for r in range(runs):
            t = {}
            t0 = time.perf_counter()
            z = enc(x)
            t["encode"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            x0 = unx0(z)
            t["unet"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            da = dec(x0[0])
            t["decode_albedo"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            dr = dec(x0[1])
            t["decode_rm"] = time.perf_counter() - t0
            t["total"] = sum(t[s] for s in STAGES)
            log(f"  torch run {r + 1}/{runs}: {t['total']:.2f} s")
            if best is None or t["total"] < best["total"]:
                best = t
            outs = (da.numpy(), dr.numpy())
    return best, outs


def export_onnx(mods, x, onnx_dir):
    enc, unx0, dec = mods
    os.makedirs(onnx_dir, exist_ok=True)
    t0 = time.perf_counter()
    with torch.no_grad():
        z = enc(x)
        torch.onnx.export(enc, (x,), os.path.join(onnx_dir, "encode.onnx"), opset_version=17, input_names=["x"],
                          output_names=["z"])
        log(f"  exported encode.onnx ({time.perf_counter() - t0:.0f} s)")
        os.makedirs(os.path.join(onnx_dir, "unet"), exist_ok=True)
        torch.onnx.export(unx0, (z,), os.path.join(onnx_dir, "unet", "unet.onnx"), opset_version=17, input_names=["z"],
                          output_names=["x0_albedo", "x0_rm"])
        log(f"  exported unet/unet.onnx ({time.perf_counter() - t0:.0f} s)")
        torch.onnx.export(dec, (z,), os.path.join(onnx_dir, "decode.onnx"), opset_version=17, input_names=["z"],
                          output_names=["y"])
        log(f"  exported decode.onnx ({time.perf_counter() - t0:.0f} s)")
    return time.perf_counter() - t0


def run_ort(args, onnx_dir, x):
    ort_dir = args.ort_dir or os.path.join(args.work, "ort")
    if not os.path.exists(os.path.join(ort_dir, "node_modules", "onnxruntime-node")):
        os.makedirs(ort_dir, exist_ok=True)
        log(f"  npm install --ignore-scripts onnxruntime-node@{args.ort_version} in {ort_dir}")
        subprocess.run(["npm", "install", "--no-save", "--ignore-scripts", f"onnxruntime-node@{args.ort_version}"],
                       cwd=ort_dir, check=True, stdout=subprocess.DEVNULL)
    xin = os.path.join(args.work, "input.f32")
    x.numpy().astype("<f4").tofile(xin)
    out = os.path.join(args.work, "ort_out")
    os.makedirs(out, exist_ok=True)
    env = dict(os.environ, NODE_PATH=os.path.join(ort_dir, "node_modules"))
    cmd = ["node", os.path.join(HERE, "race_ort.js"), onnx_dir, xin, ",".join(map(str, x.shape)), str(args.threads),
           str(args.runs), out]
    p = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"race_ort.js exited {p.returncode}")
    res = json.loads(p.stdout)
    best = min(res["runs"], key=lambda r: r["total"])
    shape = tuple(x.shape)
    da = np.fromfile(os.path.join(out, "decode_albedo.f32"), "<f4").reshape(shape)
    dr = np.fromfile(os.path.join(out, "decode_rm.f32"), "<f4").reshape(shape)
    return best, (da, dr), res


def run_supermat_bench(args, name, opts, peak):
    jf = os.path.join(args.work, f"bench_{name}.json")
    if os.path.exists(jf):
        os.remove(jf)
    cmd = [args.supermat, "bench", "--model", args.model, "--size", str(args.size), "--threads", str(args.threads),
           "--repeats", str(args.runs), "--json", jf] + opts
    if not peak:
        cmd.append("--pipeline-only")
    log("  " + " ".join(cmd))
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        return None, p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}"
    with open(jf) as f:
        j = json.load(f)
    st = {s["stage"]: s for s in j["stages"]}
    t = {"encode": st["vae encode"]["seconds"],
         "unet": st["unet trunk"]["seconds"] + st["unet branch albedo"]["seconds"] + st["unet branch roughness/metallic"]["seconds"],
         "decode_albedo": st["vae decode albedo"]["seconds"], "decode_rm": st["vae decode roughness/metallic"]["seconds"]}
    t["total"] = sum(t[s] for s in STAGES)
    g = {"encode": st["vae encode"]["gflop"],
         "unet": st["unet trunk"]["gflop"] + st["unet branch albedo"]["gflop"] + st["unet branch roughness/metallic"]["gflop"],
         "decode_albedo": st["vae decode albedo"]["gflop"], "decode_rm": st["vae decode roughness/metallic"]["gflop"]}
    g["total"] = sum(g[s] for s in STAGES)
    return {"seconds": t, "gflop": g, "json": j}, None


def run_supermat_maps(args, opts, picture, name):
    out = os.path.join(args.work, "supermat_" + name)
    shutil.rmtree(out, ignore_errors=True)
    cmd = [args.supermat, "image", "--model", args.model, "--native", "--float", "--threads", str(args.threads),
           "--detail", "off", "--chroma", "off", "--out", out] + opts + [picture]  # the official computation (image's
    # default adds the detail and colour steps)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    stem = os.path.splitext(os.path.basename(picture))[0]
    return {m: read_pfm(os.path.join(out, f"{stem}_{m}.pfm")) for m in ("albedo", "roughness", "metallic")}


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def blas_in_use():
    try:
        p = subprocess.run(["update-alternatives", "--query", "libblas.so.3-x86_64-linux-gnu"], stdout=subprocess.PIPE,
                           stderr=subprocess.DEVNULL, text=True)
        for line in p.stdout.splitlines():
            if line.startswith("Value:"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def main():
    root = os.path.dirname(HERE)
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", required=True, help="f32 single-view model file made by `supermat convert`")
    ap.add_argument("--base", required=True, help="the SD 2.1-layout folder it was converted with")
    ap.add_argument("--work", required=True, help="folder for the picture, the ONNX files, maps and race.json")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=int, default=2, help="runs per engine and mode; the fastest is reported (default 2)")
    ap.add_argument("--engines", default="supermat,ort,torch")
    ap.add_argument("--modes", default="f32,winograd_f4,bf16,bf16_wf4,int8", help="supermat modes: " + ",".join(SUPERMAT_MODES))
    ap.add_argument("--image", help="an RGBA picture of --size (default: a synthetic sphere written to --work)")
    ap.add_argument("--supermat", default=os.path.join(root, "build", "supermat"))
    ap.add_argument("--ort-dir", help="folder with node_modules/onnxruntime-node (default --work/ort)")
    ap.add_argument("--ort-version", default="1.30.0")
    ap.add_argument("--no-accuracy", action="store_true", help="skip the maps' PSNR against PyTorch")
    ap.add_argument("--markdown", help="also write the table here")
    args = ap.parse_args()
    engines = [e for e in args.engines.split(",") if e]
    modes = [m for m in args.modes.split(",") if m]
    for e in engines:
        if e not in ("supermat", "ort", "torch"):
            sys.exit(f"race: unknown engine '{e}' (supermat, ort, torch)")
    for m in modes:
        if m not in SUPERMAT_MODES:
            sys.exit(f"race: unknown mode '{m}' ({', '.join(SUPERMAT_MODES)})")
    if args.size % 8 or args.size < 64:
        sys.exit("race: --size must be a multiple of 8, at least 64")
    os.makedirs(args.work, exist_ok=True)
    torch.set_num_threads(args.threads)
    picture = args.image or os.path.join(args.work, f"race_{args.size}.png")
    if not args.image:
        make_picture(picture, args.size, 0)
    x = picture_tensor(picture)
    if x.shape[-1] != args.size or x.shape[-2] != args.size:
        sys.exit(f"race: {picture} is not {args.size}x{args.size}")

    report = {"cpu": cpu_name(), "threads": args.threads, "size": args.size, "runs": args.runs, "model": args.model,
              "blas": blas_in_use(), "torch": torch.__version__, "engines": {}, "notes": []}
    log(f"race: {report['cpu']}, {args.threads} threads, {args.size}x{args.size}, {args.runs} runs each; torch "
        f"{torch.__version__} with BLAS {report['blas']}")
    if "openblas" not in report["blas"]:
        log("race: WARNING: torch is not on OpenBLAS (install libopenblas0-pthread): its Linear layers will be slow")

    # 1. supermat first: its bench measures the FMA peak, and it needs the memory to itself
    peak = None
    sm = {}
    if "supermat" in engines:
        for m in modes:
            log(f"supermat {m}:")
            r, why = run_supermat_bench(args, m, SUPERMAT_MODES[m][0], peak=peak is None)
            if r is None:
                log(f"  skipped: {why}")
                report["notes"].append(f"supermat {m} skipped: {why}")
                continue
            if peak is None:  # the first mode that ran measured the FMA peak
                peak = r["json"].get("fma_peak_gflops") or None
                report["fma_peak_gflops"] = peak
                report["kernel"] = r["json"].get("kernel")
            r["what"] = SUPERMAT_MODES[m][1]
            r["kernel"], r["compute"], r["conv"] = r["json"]["kernel"], r["json"].get("compute"), r["json"].get("conv")
            del r["json"]
            sm[m] = r
            log(f"  {r['seconds']['total']:.2f} s ({r['kernel']}, {r['compute']}, {r['conv']})")
    # FLOPs of the direct algorithm (every engine): from supermat's f32 count, else none
    gflop = sm["f32"]["gflop"] if "f32" in sm else None

    # 2. PyTorch (the official modules), then its export for ONNX Runtime
    need_torch = "torch" in engines or "ort" in engines or not args.no_accuracy
    ref_maps = None
    if need_torch:
        log("torch: building the official modules from the model file")
        t0 = time.perf_counter()
        unet, vae, ctx, step, coef, sf, branches = build_torch(args.model, args.base)
        if branches != 2:
            sys.exit("race: the race times a two-branch (albedo, roughness/metallic) model")
        mods = (Encode(vae, sf).eval(), UNetX0(unet, ctx, step, coef).eval(), Decode(vae, sf).eval())
        log(f"  built in {time.perf_counter() - t0:.0f} s")
        truns = args.runs if "torch" in engines else 1
        t, outs = run_torch(mods, x, truns)
        ref_maps = maps_from(*outs)
        np.savez(os.path.join(args.work, "torch_maps.npz"), **ref_maps)
        if "torch" in engines:
            report["engines"]["torch"] = {"f32": {"seconds": t, "what": "PyTorch float32 (official modules)"}}
        if "ort" in engines:
            onnx_dir = os.path.join(args.work, "onnx")
            st = os.stat(args.model)
            stamp = {"model": os.path.abspath(args.model), "bytes": st.st_size, "mtime": st.st_mtime, "size": args.size,
                     "sdpa_chunk": supermat_adapters.SDPA_CHUNK_ELEMS}
            try:
                with open(os.path.join(onnx_dir, "source.json")) as f:
                    same = json.load(f) == stamp
            except (OSError, ValueError):
                same = False
            if same:
                log(f"onnx: reusing {onnx_dir} (exported from this model file at this size)")
            else:
                log("onnx: exporting the three modules")
                shutil.rmtree(onnx_dir, ignore_errors=True)
                report["onnx_export_seconds"] = export_onnx(mods, x, onnx_dir)
                with open(os.path.join(onnx_dir, "source.json"), "w") as f:
                    json.dump(stamp, f)
        del mods, unet, vae
    if "ort" in engines:
        log("ort:")
        t, outs, res = run_ort(args, os.path.join(args.work, "onnx"), x)
        report["engines"]["ort"] = {"f32": {"seconds": t, "what": f"ONNX Runtime {res.get('version', '?')} float32",
                                            "session_create_seconds": res.get("create_seconds")}}
        if ref_maps is not None:
            om = maps_from(*outs)
            report["engines"]["ort"]["f32"]["psnr"] = {k: psnr(om[k], ref_maps[k]) for k in om}
    if "torch" in report["engines"]:
        report["engines"]["torch"]["f32"]["psnr"] = {k: 200.0 for k in ("albedo", "roughness", "metallic")}
    if sm:
        report["engines"]["supermat"] = sm
        if ref_maps is not None and not args.no_accuracy:
            for m in sm:
                log(f"supermat {m}: maps for the accuracy columns")
                mm = run_supermat_maps(args, SUPERMAT_MODES[m][0], picture, m)
                sm[m]["psnr"] = {k: psnr(mm[k], ref_maps[k]) for k in mm}

    # 3. the table
    ref_total = report["engines"].get("ort", {}).get("f32", {}).get("seconds", {}).get("total")
    lines = [f"Race: {report['cpu']}, {args.threads} threads, {args.size}x{args.size}, one picture, fastest of "
             f"{args.runs} runs per engine and mode; FMA peak {peak:.1f} GFLOP/s ({report.get('kernel')} f32, measured in the same run)"
             if peak else f"Race: {report['cpu']}, {args.threads} threads, {args.size}x{args.size}", "",
             "| engine / mode | stage | s | × ONNX Runtime | GFLOP/s | % of peak | PSNR vs PyTorch f32 (albedo / rough / metal) |",
             "|---|---|---:|---:|---:|---:|---|"]
    order = [("ort", "f32"), ("torch", "f32")] + [("supermat", m) for m in modes]
    for eng, m in order:
        r = report["engines"].get(eng, {}).get(m)
        if not r:
            continue
        label = {"ort": "ONNX Runtime f32", "torch": "PyTorch f32"}.get(eng, f"supermat {m}")
        ps = r.get("psnr")
        pstr = " / ".join(f"{ps[k]:.1f}" for k in ("albedo", "roughness", "metallic")) if ps else "–"
        for s in STAGES + ["total"]:
            sec = r["seconds"][s]
            ort_s = report["engines"].get("ort", {}).get("f32", {}).get("seconds", {}).get(s)
            ratio = f"{sec / ort_s:.2f}" if ort_s else "–"
            gfs = gflop[s] / sec if gflop else None
            lines.append(f"| {label if s == 'encode' else ''} | {STAGE_NAMES[s]} | {sec:.2f} | {ratio} | "
                         f"{gfs:.0f} | {100 * gfs / peak:.0f} % | {pstr if s == 'total' else ''} |" if gfs and peak else
                         f"| {label if s == 'encode' else ''} | {STAGE_NAMES[s]} | {sec:.2f} | {ratio} | – | – | "
                         f"{pstr if s == 'total' else ''} |")
    table = "\n".join(lines)
    report["table"] = table
    report["ort_total_seconds"] = ref_total
    with open(os.path.join(args.work, "race.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(table)
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(table + "\n")


if __name__ == "__main__":
    main()
