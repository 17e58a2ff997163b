#!/usr/bin/env python3
"""Material quality against ground truth: held-out real glTF assets, rendered, predicted, measured.

What it does
  1. loads each glTF 2.0 asset (.gltf + .bin + PNG/JPEG textures): every TRIANGLES (also strip / fan)
     primitive reachable from the default scene (or from the node FILE.gltf#NODE names), node transforms
     applied, with its pbrMetallicRoughness material (base colour factor x texture, sRGB -> linear;
     roughness / metallic factors x the G / B channels of metallicRoughnessTexture).  Normal, occlusion
     and emissive maps, vertex colours, alpha modes and KHR_texture_transform are ignored;
  2. per view (view 0: the asset's own front, +Y up, facing +Z; then seeded random rotations) centres the
     rotated mesh's projected bounding box, scales its larger side to 0.85 of the orthographic frame and
     rasterises a G-buffer at 2x the output size (numpy z-buffer; trilinear mip-mapped texture lookups,
     level of detail per triangle from its texel / pixel area ratio);
  3. shades it with smrender under a held-out environment map (seeded rotation about Y, no sun),
     auto-exposes (key in 0.18..0.3 on the median luminance), averages the linear colour over the 2x2
     samples weighted by coverage (straight alpha = mean coverage), tone maps (white balance 1) and
     quantises to the 8-bit RGBA input; the ground truth maps are averaged likewise and quantised as the
     training data is: albedo sRGB 8-bit (glTF baseColor convention), roughness / metallic linear 8-bit.
     This is the recipe of the training-data generator (supermat_tools.gen_data), which uses the same module;
  4. runs the predictors on each input: `--model NAME=FILE` models through `supermat image --native --float`
     (PFM maps, PNG if no PFM; its defaults, so since 2026-11-27 with --detail 1/64: the albedo keeps the
     picture's detail, and since 2026-11-30 with --chroma 1: it takes the picture's colour at its own
     luminance; --image-args "--detail off --chroma off" for the network's maps alone), and the baselines
       input_as_albedo  albedo = the input's RGB, roughness / metallic = dataset means,
       dataset_mean     every map = its dataset mean (--dataset-stats JSON: albedo_srgb_mean [3],
                        rough_mean, metal_mean; default 0.5 gray / 0.5 / 0.0),
       oracle           the ground truth itself (checks the metrics: 100 dB, SSIM 1);
  5. measures, over the pixels with alpha >= 0.5, each map's PSNR (10 log10(1 / MSE), capped at 100 dB)
     and SSIM (11x11 Gaussian, sigma 1.5, C1 = 0.01^2, C2 = 0.03^2, on the whole image with both images
     zeroed outside the mask, averaged over the mask, per channel then averaged; albedo in sRGB), and the
     re-render PSNR: ground truth and predicted maps shaded with the ground-truth normals under the OTHER
     held-out map, both tone mapped with the exposure auto-chosen for the ground truth;
     --env-in all does all of this under each held-out map in turn, re-rendered under the next one (3x the
     views: one map's colour cast or contrast weighs less in the mean);
  6. prints markdown tables (overall = mean over every asset-view, per input lighting with --env-in all, then
     per asset), and writes the JSON
     (--json), contact sheets (--sheets DIR: one PNG per view, one row per predictor: input over gray |
     pred albedo | pred roughness | pred metallic | gt albedo | gt roughness | gt metallic).
     supermat_tools.eval_ci reads that JSON: each predictor's difference to another, paired view by view, with a
     Student-t interval over the assets (how far the difference could move on other assets like these).
  --decompose also reports the albedo PSNR after the best least-squares gain per view (one for all channels:
  the exposure, which the input's auto-exposure hides, taken out of the error) and after the best gain per view
  and channel (exposure and white balance): how much of a predictor's albedo error is global brightness and
  colour, and how much is the map itself; and the albedo's level (its mean linear luminance over the object) per
  view against the truth's: correlation, R2 and RMSE of the log2 levels (level_stats; supermat_tools.eval_level does the
  same on the generator's own renders), the geometric mean level per asset.
  --levers MODEL [--levers-modes all|LIST] also measures the speed / accuracy levers of MODEL against the
  truth: per view, `supermat bench --model MODEL --image WORK/inputs/<stem>.png --truth-albedo
  WORK/truth/<stem>_albedo.png --truth-roughness ... --truth-metallic ... --modes LIST --json
  WORK/levers/<stem>.json --repeats 1 --threads N` (the same input and the same 8-bit truth as above;
  the table it prints in WORK/levers/<stem>.txt), then prints the table of bench/bench_table.py (bench_rows.markdown): per
  mode the mean over the views of seconds, speed-up, PSNR against the f32 maps and against the truth
  (gt_psnr); the JSON (--json) gets it as "levers".
  --write-slice DIR --slice-views K instead writes a small test slice (CC0 assets only: Avocado,
  WaterBottle): DIR/<asset>_<view>.png (RGBA input), _albedo.png (sRGB RGB), _roughness.png and
  _metallic.png (8-bit gray), and DIR/index.txt (the stems, one a line); size 128 unless --size.

Run (from the repository root, with Debian's python3: numpy, Pillow, scipy):
  G=$MIRROR_DIR/sbtron+glTF-Sample-Models/repo       # the bare mirror `fetch` makes of the public repository
  for a in Avocado WaterBottle; do git --git-dir=$G archive HEAD 2.0/$a/glTF | tar -x -C $WORK/gltf; done
  PYTHONPATH=python python3 -m supermat_tools.eval_quality --assets $WORK/gltf/2.0/{Avocado,WaterBottle}/glTF/*.gltf --hdri-dir $WORK/hdri \
      --model default=models/supermat_default.safetensors --model tiny=$WORK/tiny.safetensors \
      --dataset-stats DATA/stats.json --json quality.json --sheets sheets/   # DATA: gen_data.py --out
  PYTHONPATH=python python3 -m supermat_tools.eval_quality --assets .../Avocado.gltf .../WaterBottle.gltf --hdri-dir $WORK/hdri \
      --write-slice tests/data/eval --slice-views 4        # the committed CI slice

Data and licences
  * assets: glTF 2.0 sample models of KhronosGroup/glTF-Sample-Models, evaluation only (never training).
    Avocado and WaterBottle: "Donated by Microsoft for glTF testing", CC0 in Khronos' listing, the only
    ones --write-slice accepts; Suzanne: CC0 (Blender); DamagedHelmet: CC-BY-NC 4.0 (theblueturtle_),
    may be evaluated locally, never written into the repository;
  * lighting: the held-out CC0 Poly Haven maps venice_sunset_1k, studio_small_03_1k and kiara_1_dawn_1k
    (in --hdri-dir); the training data never uses them.
Deterministic for a given --seed (each asset's views are seeded by the seed and the asset's name, view k
does not depend on --views).
"""
import argparse
import base64
import io
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.parse
import zlib

import numpy as np
from PIL import Image
from scipy import ndimage

from supermat_tools import smrender as smr
from supermat_tools.bench_rows import aggregate as bench_aggregate, load as bench_load, markdown as bench_markdown
from supermat_tools.common import SUPERMAT, read_pfm, split_asset  # noqa: F401  (read_pfm: evq.read_pfm)

HELD_OUT_ENVS = ("venice_sunset_1k", "studio_small_03_1k", "kiara_1_dawn_1k")
CC0_ASSETS = ("Avocado", "WaterBottle")
FRAME_FILL = 0.85                       # the projected bounding box's larger side, in frame widths
KEY_RANGE = (0.18, 0.3)                 # auto-exposure key (median luminance), as the training data
MAPS = ("albedo", "roughness", "metallic")
DECOMPOSE = ("albedo_psnr_gain", "albedo_psnr_wb", "albedo_level", "albedo_level_true")   # --decompose
METRICS = ("albedo_psnr", "albedo_ssim", "roughness_psnr", "roughness_ssim", "metallic_psnr",
           "metallic_ssim", "rerender_psnr")


# ----------------------------------------------------------------------------------------------------------
# glTF loading
# ----------------------------------------------------------------------------------------------------------
COMPONENT_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
                    5126: np.float32}
TYPE_SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
WRAP_CLAMP, WRAP_MIRROR = 33071, 33648


def _read_uri(base_dir, uri):
    if uri.startswith("data:"):
        return base64.b64decode(uri.split(",", 1)[1])
    with open(os.path.join(base_dir, urllib.parse.unquote(uri)), "rb") as f:
        return f.read()


class Texture:
    """A mip-mapped float texture (HxWxC, level 0 first) with the sampler's wrap modes."""

    def __init__(self, img, wrap_s, wrap_t):
        self.wrap = (wrap_s, wrap_t)
        self.levels = [img]
        while max(img.shape[:2]) > 1:
            h, w = img.shape[:2]
            size = (max(1, w // 2), max(1, h // 2))
            img = np.stack([np.asarray(Image.fromarray(np.ascontiguousarray(img[..., c]), "F").resize(size, Image.BOX))
                            for c in range(img.shape[2])], -1)
            self.levels.append(img)

    def log2_texels(self):
        h, w = self.levels[0].shape[:2]
        return float(np.log2(h * w))

    @staticmethod
    def _wrap_index(i, n, mode):
        if mode == WRAP_CLAMP:
            return np.clip(i, 0, n - 1)
        if mode == WRAP_MIRROR:
            i = np.mod(i, 2 * n)
            return np.where(i < n, i, 2 * n - 1 - i)
        return np.mod(i, n)                                     # REPEAT (the default)

    def _bilinear(self, level, uv):
        img = self.levels[level]
        h, w = img.shape[:2]
        fx = uv[:, 0] * w - 0.5                                 # glTF UV (0, 0) = the image's top-left texel
        fy = uv[:, 1] * h - 0.5
        x0 = np.floor(fx).astype(np.int64)
        y0 = np.floor(fy).astype(np.int64)
        tx = (fx - x0)[:, None].astype(np.float32)
        ty = (fy - y0)[:, None].astype(np.float32)
        xa, xb = self._wrap_index(x0, w, self.wrap[0]), self._wrap_index(x0 + 1, w, self.wrap[0])
        ya, yb = self._wrap_index(y0, h, self.wrap[1]), self._wrap_index(y0 + 1, h, self.wrap[1])
        return ((img[ya, xa] * (1 - tx) + img[ya, xb] * tx) * (1 - ty) +
                (img[yb, xa] * (1 - tx) + img[yb, xb] * tx) * ty)

    def sample(self, uv, lod):
        """Trilinear lookup at uv (Mx2) with level of detail lod (M,)."""
        lod = np.clip(lod, 0, len(self.levels) - 1)
        l0 = np.floor(lod).astype(np.int64)
        t = (lod - l0)[:, None].astype(np.float32)
        out = np.empty((uv.shape[0], self.levels[0].shape[2]), np.float32)
        for level in np.unique(l0):
            m = l0 == level
            a = self._bilinear(level, uv[m])
            b = self._bilinear(min(level + 1, len(self.levels) - 1), uv[m])
            out[m] = a * (1 - t[m]) + b * t[m]
        return out


def _node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], np.float64).reshape(4, 4).T     # glTF stores column-major
    t = np.array(node.get("translation", [0, 0, 0]), np.float64)
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = np.array(node.get("scale", [1, 1, 1]), np.float64)
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * s[None, :]
    m[:3, 3] = t
    return m


class Mesh:
    """Every triangle of a glTF scene in world space, as corner arrays: P, N (F x 3 corners x 3),
    UV (F x 3 x 2), mat (F,) indices into `materials` (dicts: base_factor (3,), base_tex, rough, metal,
    mr_tex; textures are Texture or None)."""

    def __init__(self, path):
        path, node_name = split_asset(path)                     # FILE.gltf#NODE: that node's subtree alone
        self.name = node_name or os.path.splitext(os.path.basename(path))[0]
        self.dir = os.path.dirname(os.path.abspath(path))
        with open(path) as f:
            self.gltf = json.load(f)
        g = self.gltf
        self.buffers = [_read_uri(self.dir, b["uri"]) for b in g.get("buffers", [])]
        self._textures = {}
        self.materials = [self._material(m) for m in g.get("materials", [])]
        self.materials.append(self._material({}))              # the glTF default material
        P, N, UV, mat = [], [], [], []
        if node_name is None:
            roots = g["scenes"][g.get("scene", 0)]["nodes"]
        else:                                                   # its own transform kept, its parents' not
            roots = [i for i, n in enumerate(g.get("nodes", [])) if n.get("name") == node_name]
            if len(roots) != 1:
                raise ValueError(f"{path}: {len(roots)} nodes named {node_name!r} (one expected)")
        stack = [(n, np.eye(4)) for n in roots]
        while stack:
            ni, parent = stack.pop()
            node = g["nodes"][ni]
            m = parent @ _node_matrix(node)
            stack.extend((c, m) for c in node.get("children", []))
            if "mesh" not in node:
                continue
            nm = np.linalg.inv(m[:3, :3]).T
            for prim in g["meshes"][node["mesh"]]["primitives"]:
                tri = self._triangles(prim)
                if tri is None:
                    continue
                a = prim["attributes"]
                p = self._accessor(a["POSITION"]).astype(np.float64) @ m[:3, :3].T + m[:3, 3]
                P.append(p[tri])
                if "NORMAL" in a:
                    n = self._accessor(a["NORMAL"]).astype(np.float64) @ nm.T
                    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)
                    N.append(n[tri])
                else:                                           # glTF: flat normals when none are given
                    fn = np.cross(P[-1][:, 1] - P[-1][:, 0], P[-1][:, 2] - P[-1][:, 0])
                    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-20)
                    N.append(np.repeat(fn[:, None], 3, 1))
                if "TEXCOORD_0" in a:
                    UV.append(self._accessor(a["TEXCOORD_0"]).astype(np.float64)[tri])
                else:
                    UV.append(np.zeros(tri.shape + (2,)))
                mat.append(np.full(len(tri), prim.get("material", len(self.materials) - 1), np.int64))
        if not P:
            where = f"node {node_name!r}" if node_name else "the default scene"
            raise ValueError(f"{path}: no triangles in {where}")
        self.P, self.N, self.UV = np.concatenate(P), np.concatenate(N), np.concatenate(UV)
        self.mat = np.concatenate(mat)

    def _accessor(self, index):
        acc = self.gltf["accessors"][index]
        if "sparse" in acc or "bufferView" not in acc:
            raise ValueError(f"{self.name}: sparse or buffer-less accessor {index} is not supported")
        view = self.gltf["bufferViews"][acc["bufferView"]]
        dtype = np.dtype(COMPONENT_DTYPES[acc["componentType"]])
        nc = TYPE_SIZES[acc["type"]]
        stride = view.get("byteStride", dtype.itemsize * nc)
        arr = np.ndarray((acc["count"], nc), dtype, self.buffers[view["buffer"]],
                         view.get("byteOffset", 0) + acc.get("byteOffset", 0), (stride, dtype.itemsize))
        out = arr.astype(np.float64) if dtype.kind == "f" else arr.astype(np.int64)
        if acc.get("normalized") and dtype.kind != "f":
            out = np.maximum(out / np.iinfo(dtype).max, -1.0)
        return out[:, 0] if nc == 1 else out

    def _triangles(self, prim):
        """Fx3 vertex indices of a primitive, None (with a warning) for points and lines."""
        mode = prim.get("mode", 4)
        if "indices" in prim:
            idx = self._accessor(prim["indices"]).astype(np.int64)
        else:
            idx = np.arange(self.gltf["accessors"][prim["attributes"]["POSITION"]]["count"])
        if mode == 4:
            return idx[:len(idx) // 3 * 3].reshape(-1, 3)
        if mode == 5 and len(idx) >= 3:
            return np.stack([idx[:-2], idx[1:-1], idx[2:]], 1)
        if mode == 6 and len(idx) >= 3:
            return np.stack([np.full(len(idx) - 2, idx[0]), idx[1:-1], idx[2:]], 1)
        print(f"warning: {self.name}: primitive mode {mode} skipped", file=sys.stderr)
        return None

    def _texture(self, info, srgb, channels):
        """Texture of a textureInfo: the image's `channels` as floats (sRGB decoded when srgb)."""
        if info is None:
            return None
        if "KHR_texture_transform" in info.get("extensions", {}):
            print(f"warning: {self.name}: KHR_texture_transform ignored", file=sys.stderr)
        key = (info["index"], srgb, channels)
        if key not in self._textures:
            tex = self.gltf["textures"][info["index"]]
            im = self.gltf["images"][tex["source"]]
            if "uri" in im:
                img = Image.open(os.path.join(self.dir, urllib.parse.unquote(im["uri"])))
            else:
                view = self.gltf["bufferViews"][im["bufferView"]]
                o = view.get("byteOffset", 0)
                img = Image.open(io.BytesIO(self.buffers[view["buffer"]][o:o + view["byteLength"]]))
            a = np.asarray(img.convert("RGB"), np.float32)[..., list(channels)] / 255.0
            if srgb:
                a = smr.srgb_decode(a)
            s = self.gltf.get("samplers", [{}])[tex["sampler"]] if "sampler" in tex else {}
            self._textures[key] = Texture(a, s.get("wrapS", 10497), s.get("wrapT", 10497))
        return self._textures[key]

    def _material(self, m):
        pbr = m.get("pbrMetallicRoughness", {})
        return dict(base_factor=np.array(pbr.get("baseColorFactor", [1, 1, 1, 1])[:3], np.float32),
                    base_tex=self._texture(pbr.get("baseColorTexture"), True, (0, 1, 2)),
                    rough=float(pbr.get("roughnessFactor", 1.0)), metal=float(pbr.get("metallicFactor", 1.0)),
                    mr_tex=self._texture(pbr.get("metallicRoughnessTexture"), False, (1, 2)))


# ----------------------------------------------------------------------------------------------------------
# rasterisation: G-buffer of a view
# ----------------------------------------------------------------------------------------------------------
def rasterize(xy, z, res, budget=1 << 20):
    """Z-buffer of triangles in pixel coordinates (xy: Fx3x2, x right, y down, pixel centres at +0.5;
    z: Fx3, larger = nearer) on a res x res grid.  Triangles are grouped by the power-of-two size of
    their pixel bounding box and tested in chunks of about `budget` candidate pixels; the nearest
    fragment of each pixel wins.  Returns tri (res*res,) int64 (-1: empty) and bary (res*res x 3)."""
    x0, y0 = xy[:, 0, 0], xy[:, 0, 1]
    e1x, e1y = xy[:, 1, 0] - x0, xy[:, 1, 1] - y0
    e2x, e2y = xy[:, 2, 0] - x0, xy[:, 2, 1] - y0
    area = e1x * e2y - e2x * e1y
    i0 = np.maximum(np.ceil(xy[..., 0].min(1) - 0.5), 0).astype(np.int64)
    i1 = np.minimum(np.floor(xy[..., 0].max(1) - 0.5), res - 1).astype(np.int64)
    j0 = np.maximum(np.ceil(xy[..., 1].min(1) - 0.5), 0).astype(np.int64)
    j1 = np.minimum(np.floor(xy[..., 1].max(1) - 0.5), res - 1).astype(np.int64)
    ok = (np.abs(area) > 1e-12) & (i1 >= i0) & (j1 >= j0)
    cw = np.left_shift(1, np.ceil(np.log2(np.maximum(i1 - i0 + 1, 1))).astype(np.int64))
    ch = np.left_shift(1, np.ceil(np.log2(np.maximum(j1 - j0 + 1, 1))).astype(np.int64))
    key = cw * (2 * res) + ch
    frags = []
    for k in np.unique(key[ok]):
        ids = np.nonzero(ok & (key == k))[0]
        w, h = int(k // (2 * res)), int(k % (2 * res))
        gx, gy = np.meshgrid(np.arange(w), np.arange(h))
        gx, gy = gx.ravel()[None, :], gy.ravel()[None, :]
        step = max(1, budget // (w * h))
        for s in range(0, len(ids), step):
            t = ids[s:s + step, None]
            px, py = i0[t] + gx, j0[t] + gy
            dx, dy = px + 0.5 - x0[t], py + 0.5 - y0[t]
            b1 = (dx * e2y[t] - e2x[t] * dy) / area[t]
            b2 = (e1x[t] * dy - dx * e1y[t]) / area[t]
            inside = ((px <= i1[t]) & (py <= j1[t]) & (b1 >= -1e-7) & (b2 >= -1e-7) & (b1 + b2 <= 1 + 1e-7))
            tt = np.broadcast_to(t, inside.shape)[inside]
            b1, b2 = b1[inside], b2[inside]
            depth = z[tt, 0] + b1 * (z[tt, 1] - z[tt, 0]) + b2 * (z[tt, 2] - z[tt, 0])
            frags.append((py[inside] * res + px[inside], depth, tt, b1, b2))
    tri = np.full(res * res, -1, np.int64)
    bary = np.zeros((res * res, 3))
    if frags:
        pix, depth, tt, b1, b2 = (np.concatenate(a) for a in zip(*frags))
        order = np.lexsort((-depth, pix))
        first = order[np.r_[True, pix[order][1:] != pix[order][:-1]]]
        tri[pix[first]] = tt[first]
        bary[pix[first]] = np.stack([1 - b1[first] - b2[first], b1[first], b2[first]], 1)
    return tri, bary


def gbuffer(mesh, rot, res):
    """G-buffer (smrender's convention, coverage 0 / 1) of the mesh turned by `rot`, framed so that its
    projected bounding box is centred and its larger side FRAME_FILL of the frame [-1, 1]^2."""
    P = mesh.P @ rot.T.astype(np.float64)
    N = mesh.N @ rot.T.astype(np.float64)
    lo, hi = P.reshape(-1, 3).min(0), P.reshape(-1, 3).max(0)
    P = (P - (lo + hi) / 2) * (2 * FRAME_FILL / max(hi[0] - lo[0], hi[1] - lo[1]))
    return gbuffer_framed(mesh, P, N, res)


def gbuffer_framed(mesh, P, N, res):
    """The G-buffer of corners P and normals N (F x 3 x 3) already in the frame: x right and y up in
    [-1, 1], z towards the viewer (larger = nearer)."""
    xy = np.stack([(P[..., 0] + 1) * 0.5 * res, (1 - P[..., 1]) * 0.5 * res], -1)
    tri, bary = rasterize(xy, P[..., 2], res)
    hit = tri >= 0
    t, b = tri[hit], bary[hit][..., None]

    g = np.cross(P[t, 1] - P[t, 0], P[t, 2] - P[t, 0])         # geometric normal, turned to the viewer
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-30)
    g *= np.where(g[:, 2] < 0, -1.0, 1.0)[:, None]
    n = (N[t] * b).sum(1)
    n *= np.where((n * g).sum(1) < 0, -1.0, 1.0)[:, None]      # the side of the surface that is seen
    n[:, 2] = np.maximum(n[:, 2], 0.0)                          # grazing normals onto the silhouette
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(ln > 1e-12, n / np.maximum(ln, 1e-30), g)

    uv = (mesh.UV[t] * b).sum(1)
    duv1, duv2 = mesh.UV[:, 1] - mesh.UV[:, 0], mesh.UV[:, 2] - mesh.UV[:, 0]
    uv_area = np.abs(duv1[:, 0] * duv2[:, 1] - duv2[:, 0] * duv1[:, 1])
    px_area = np.abs(np.cross(xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]))
    half_log_ratio = 0.5 * np.log2(np.maximum(uv_area, 1e-30) / np.maximum(px_area, 1e-30))  # + log2(texels)/2 = lod
    albedo = np.empty((len(t), 3), np.float32)
    rough = np.empty(len(t), np.float32)
    metal = np.empty(len(t), np.float32)
    mi = mesh.mat[t]
    for k in np.unique(mi):
        m = mi == k
        mat = mesh.materials[k]
        albedo[m] = mat["base_factor"]
        rough[m], metal[m] = mat["rough"], mat["metal"]
        if mat["base_tex"] is not None:
            tex = mat["base_tex"]
            albedo[m] *= tex.sample(uv[m], half_log_ratio[t[m]] + 0.5 * tex.log2_texels())
        if mat["mr_tex"] is not None:
            tex = mat["mr_tex"]
            rm = tex.sample(uv[m], half_log_ratio[t[m]] + 0.5 * tex.log2_texels())
            rough[m] *= rm[:, 0]
            metal[m] *= rm[:, 1]

    def image(values, channels):
        out = np.zeros((res * res, channels) if channels > 1 else res * res, np.float32)
        out[hit] = values
        return out.reshape((res, res, channels) if channels > 1 else (res, res))
    return dict(cov=hit.reshape(res, res).astype(np.float32), n=image(n, 3), p=image((P[t] * b).sum(1), 3),
                albedo=image(albedo, 3), rough=image(rough, 1), metal=image(metal, 1))


def cov_average(img, cov):
    """2x2 box average of img weighted by coverage (0 where nothing is covered)."""
    c = cov if img.ndim == 2 else cov[..., None]
    w = smr.box_down(c, 2)
    return np.where(w > 0, smr.box_down(img * c, 2) / np.maximum(w, 1e-12), 0.0).astype(np.float32)


def downsample(gb):
    """The G-buffer at half the resolution: coverage = mean coverage, the rest coverage-weighted."""
    out = {k: cov_average(v, gb["cov"]) for k, v in gb.items() if k != "cov"}
    out["cov"] = smr.box_down(gb["cov"], 2)
    out["n"] /= np.maximum(np.linalg.norm(out["n"], axis=-1, keepdims=True), 1e-12)
    return out


def quantise(x):
    return np.round(np.clip(x, 0.0, 1.0) * 255.0).astype(np.uint8)


# ----------------------------------------------------------------------------------------------------------
# views: input picture and ground truth
# ----------------------------------------------------------------------------------------------------------
def view_params(name, seed, count):
    """Per view: object rotation (view 0: the asset's front), environment rotations, exposure key."""
    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
    out = []
    for v in range(count):
        rot = np.eye(3, dtype=np.float32) if v == 0 else smr.random_rotation(rng)
        out.append(dict(rot=rot, env_angle=float(rng.uniform(0, 2 * np.pi)),
                        relight_angle=float(rng.uniform(0, 2 * np.pi)), key=float(rng.uniform(*KEY_RANGE))))
    return out


def render_view(mesh, params, size, env):
    """The 8-bit RGBA input, the 8-bit ground truth maps (albedo sRGB HxWx3, roughness, metallic HxW),
    and the G-buffer at the output size (for re-rendering)."""
    gb2 = gbuffer(mesh, params["rot"], 2 * size)
    lin = cov_average(smr.shade(gb2, env, smr.rotation_y(params["env_angle"])), gb2["cov"])
    gb = downsample(gb2)
    alpha = gb["cov"]
    exposure = smr.auto_exposure(lin, alpha, params["key"])
    rgb = np.where(alpha[..., None] > 0, smr.tonemap(lin, exposure, (1, 1, 1)), 0.0)
    rgba8 = np.concatenate([quantise(rgb), quantise(alpha)[..., None]], -1)
    gt8 = dict(albedo=quantise(smr.srgb_encode(gb["albedo"])), roughness=quantise(gb["rough"]),
               metallic=quantise(gb["metal"]))
    return rgba8, gt8, gb


def relight(gb, maps, env, rot):
    """Linear radiance of maps (albedo sRGB) on the G-buffer's coverage and normals."""
    return smr.shade(dict(cov=gb["cov"], n=gb["n"], albedo=smr.srgb_decode(maps["albedo"]),
                          rough=maps["roughness"], metal=maps["metallic"]), env, rot)


# ----------------------------------------------------------------------------------------------------------
# predictors
# ----------------------------------------------------------------------------------------------------------
def read_map(out_dir, stem, name):
    pfm = os.path.join(out_dir, f"{stem}_{name}.pfm")
    if os.path.exists(pfm):
        a = read_pfm(pfm)
    else:
        a = np.asarray(Image.open(os.path.join(out_dir, f"{stem}_{name}.png")), np.float32) / 255.0
    a = np.clip(a.astype(np.float32), 0.0, 1.0)
    if name == "albedo":
        return np.repeat(a[..., None], 3, -1) if a.ndim == 2 else a[..., :3]
    return a if a.ndim == 2 else a[..., 0]


def run_model(supermat, model, inputs, out_dir, threads, extra=()):
    """Maps of every input (stem -> paths) by `supermat image` (its defaults, --detail and --chroma included, and
    `extra`)."""
    os.makedirs(out_dir, exist_ok=True)
    cmd = [supermat, "image", "--force", "--native", "--model", model, "--out", out_dir, "--float", "--threads", str(threads)]
    cmd += list(extra)
    subprocess.run(cmd + list(inputs.values()), check=True, stdout=subprocess.DEVNULL)
    return {stem: {name: read_map(out_dir, stem, name) for name in MAPS} for stem in inputs}


def run_levers(args, inputs, work):
    """`supermat bench --image` with the truth files on every view (see --levers): the JSON paths."""
    out_dir = os.path.join(work, "levers")
    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for stem, image in inputs.items():
        t0 = time.time()
        js = os.path.join(out_dir, stem + ".json")
        cmd = [args.supermat, "bench", "--force", "--model", args.levers, "--image", image]
        for name in MAPS:
            cmd += [f"--truth-{name}", os.path.join(work, "truth", f"{stem}_{name}.png")]
        cmd += ["--modes", args.levers_modes, "--json", js, "--repeats", "1", "--threads", str(args.threads)]
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        with open(os.path.join(out_dir, stem + ".txt"), "w") as f:
            f.write(r.stdout)
        if r.returncode != 0:
            sys.exit(f"error: --levers: `{' '.join(cmd)}` failed (exit status {r.returncode}):\n{r.stderr.strip()}")
        paths.append(js)
        print(f"levers on {stem} ({time.time() - t0:.1f} s)", file=sys.stderr)
    return paths


def baseline(kind, rgba8, gt, stats):
    h, w = rgba8.shape[:2]
    if kind == "oracle":
        return gt
    const = dict(albedo=np.broadcast_to(np.asarray(stats["albedo_srgb_mean"], np.float32), (h, w, 3)),
                 roughness=np.full((h, w), stats["rough_mean"], np.float32),
                 metallic=np.full((h, w), stats["metal_mean"], np.float32))
    if kind == "input_as_albedo":
        const["albedo"] = rgba8[..., :3].astype(np.float32) / 255.0
    return const


# ----------------------------------------------------------------------------------------------------------
# metrics
# ----------------------------------------------------------------------------------------------------------
def masked_psnr(a, b, mask):
    mse = float(np.mean(np.square(a[mask].astype(np.float64) - b[mask])))
    return min(100.0, 10.0 * np.log10(1.0 / max(mse, 1e-30)))


def masked_ssim(a, b, mask):
    """SSIM (11x11 Gaussian window, sigma 1.5) on the images zeroed outside the mask, averaged over the
    mask; each channel separately, then averaged."""
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    a = a.reshape(mask.shape + (-1,)).astype(np.float64)
    b = b.reshape(mask.shape + (-1,)).astype(np.float64)
    vals = []
    for c in range(a.shape[2]):
        x, y = np.where(mask, a[..., c], 0.0), np.where(mask, b[..., c], 0.0)

        def f(im):
            return ndimage.gaussian_filter(im, 1.5, truncate=3.5)      # radius 5: 11 taps
        mx, my = f(x), f(y)
        sxx, syy, sxy = f(x * x) - mx * mx, f(y * y) - my * my, f(x * y) - mx * my
        s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
        vals.append(s[mask].mean())
    return float(np.mean(vals))


def gain_psnr(pred, gt, mask, per_channel):
    """PSNR after the best least-squares gain on the prediction (one for all channels, or one a channel):
    what is left once the picture's unknown exposure (and white balance) is taken out of the error."""
    p, g = pred[mask].astype(np.float64), gt[mask].astype(np.float64)
    axis = 0 if per_channel else None
    k = np.sum(p * g, axis=axis) / np.maximum(np.sum(p * p, axis=axis), 1e-12)
    return masked_psnr(np.clip(pred * k, 0.0, 1.0), gt, mask)


def albedo_level(albedo, mask):
    """An albedo map's level: the mean linear luminance (Rec. 709 weights) of its sRGB values over the mask."""
    y = smr.luminance(smr.srgb_decode(np.asarray(albedo, np.float32)).astype(np.float64))[mask]
    return float(y.mean()) if y.size else float("nan")


def level_stats(pred, true):
    """How closely predicted albedo levels follow the true ones, per view, in log2 units (log2(level + 1e-4)):
    Pearson's correlation, R2 of the prediction as it stands (1 - SSE / SST: 0 is what the true mean as a constant
    scores, below 0 worse), the RMSE, the constant's RMSE (the true levels' standard deviation), the best linear
    fit's slope (true on predicted: below 1, the prediction swings too far; above 1, too little), and the
    geometric mean levels (linear)."""
    p = np.log2(np.asarray(pred, np.float64) + 1e-4)
    t = np.log2(np.asarray(true, np.float64) + 1e-4)
    sst = float(((t - t.mean()) ** 2).sum())
    sse = float(((p - t) ** 2).sum())
    vp = float(((p - p.mean()) ** 2).sum())
    if p.std() < 1e-6:   # a constant, up to float rounding (the dataset mean over differently sized masks)
        vp = 0.0
    cov = float(((p - p.mean()) * (t - t.mean())).sum())
    corr = cov / np.sqrt(vp * sst) if vp > 0 and sst > 0 else float("nan")
    return dict(n=int(t.size), corr=float(corr), r2=1.0 - sse / sst if sst > 0 else float("nan"),
                rmse=float(np.sqrt(sse / t.size)), rmse_const=float(np.sqrt(sst / t.size)),
                slope=cov / vp if vp > 0 else float("nan"), pred_std=float(p.std()), true_std=float(t.std()),
                pred_gmean=float(2 ** p.mean()), true_gmean=float(2 ** t.mean()))


def level_table(stats):
    """Markdown: one level_stats() row per name."""
    out = ["| predictor | views | true level | predicted | log2 std true / predicted | corr | R2 | RMSE log2 "
           "(constant) | slope |", "|---|---|---|---|---|---|---|---|---|"]
    for name, s in stats:
        out.append(f"| {name} | {s['n']} | {s['true_gmean']:.3f} | {s['pred_gmean']:.3f} | {s['true_std']:.2f} / "
                   f"{s['pred_std']:.2f} | {s['corr']:.3f} | {s['r2']:.3f} | {s['rmse']:.2f} ({s['rmse_const']:.2f}) | "
                   f"{s['slope']:.2f} |")
    return "\n".join(out)


def measure(pred, gt, mask, relit_pred, relit_gt, decompose=False):
    out = {}
    for name in MAPS:
        out[f"{name}_psnr"] = masked_psnr(pred[name], gt[name], mask)
        out[f"{name}_ssim"] = masked_ssim(pred[name], gt[name], mask)
    out["rerender_psnr"] = masked_psnr(relit_pred, relit_gt, mask)
    if decompose:
        out["albedo_psnr_gain"] = gain_psnr(pred["albedo"], gt["albedo"], mask, False)
        out["albedo_psnr_wb"] = gain_psnr(pred["albedo"], gt["albedo"], mask, True)
        out["albedo_level"] = albedo_level(pred["albedo"], mask)
        out["albedo_level_true"] = albedo_level(gt["albedo"], mask)
    return out


# ----------------------------------------------------------------------------------------------------------
# report
# ----------------------------------------------------------------------------------------------------------
def summarise(rows, predictors):
    def mean(sel):
        return {m: float(np.mean([r[m] for r in sel])) for m in METRICS + DECOMPOSE if m in sel[0]}
    assets = list(dict.fromkeys(r["asset"] for r in rows))
    return (
        {p: mean([r for r in rows if r["predictor"] == p]) for p in predictors},
        {a: {p: mean([r for r in rows if r["predictor"] == p and r["asset"] == a]) for p in predictors}
         for a in assets})


def markdown(table, first="predictor"):
    head = (f"| {first} | albedo PSNR | albedo SSIM | rough PSNR | rough SSIM | metal PSNR | metal SSIM "
            "| re-render PSNR |")
    lines = [head, "|" + "---|" * 8]
    for name, m in table:
        lines.append(f"| {name} | " + " | ".join(
            f"{m[k]:.4f}" if k.endswith("ssim") else f"{m[k]:.2f}" for k in METRICS) + " |")
    return "\n".join(lines)


def contact_sheet(path, rgba8, gt, preds):
    """One row per predictor: input over gray | predicted albedo, roughness, metallic | ground truth."""
    def tile(a):
        a = np.asarray(a, np.float32)
        return np.repeat(a[..., None], 3, -1) if a.ndim == 2 else a
    a = rgba8[..., 3:].astype(np.float32) / 255.0
    shown = rgba8[..., :3].astype(np.float32) / 255.0 * a + 0.5 * (1 - a)
    rows = [np.concatenate([shown] + [tile(p[n]) for n in MAPS] + [tile(gt[n]) for n in MAPS], 1)
            for p in preds]
    Image.fromarray(quantise(np.concatenate(rows, 0))).save(path)


# ----------------------------------------------------------------------------------------------------------
# main
# ----------------------------------------------------------------------------------------------------------
def write_png(path, a):
    Image.fromarray(a).save(path, optimize=True)


def write_slice(args, meshes):
    for mesh in meshes:
        if mesh.name not in CC0_ASSETS:
            sys.exit(f"error: --write-slice takes the CC0 assets only ({', '.join(CC0_ASSETS)}), not {mesh.name}")
    os.makedirs(args.write_slice, exist_ok=True)
    env = smr.EnvLight(os.path.join(args.hdri_dir, args.env_in + ".hdr"))
    stems = []
    for mesh in meshes:
        for v, params in enumerate(view_params(mesh.name, args.seed, args.slice_views)):
            stem = f"{mesh.name}_{v:02d}"
            rgba8, gt8, _ = render_view(mesh, params, args.size, env)
            write_png(os.path.join(args.write_slice, stem + ".png"), rgba8)
            for name in MAPS:
                write_png(os.path.join(args.write_slice, f"{stem}_{name}.png"), gt8[name])
            stems.append(stem)
    with open(os.path.join(args.write_slice, "index.txt"), "w") as f:
        f.write("".join(s + "\n" for s in stems))
    total = sum(os.path.getsize(os.path.join(args.write_slice, n)) for n in os.listdir(args.write_slice))
    print(f"wrote {len(stems)} views to {args.write_slice} ({total / 1024:.0f} KiB)")


def lightings(args):
    """(input map, re-render map) pairs: the one asked for, or with --env-in all each held-out map lighting the
    input in turn, re-rendered under the next one."""
    if args.env_in != "all":
        return [(args.env_in, args.env_relight)]
    return [(e, HELD_OUT_ENVS[(i + 1) % len(HELD_OUT_ENVS)]) for i, e in enumerate(HELD_OUT_ENVS)]


def evaluate(args, meshes, work):
    pairs = lightings(args)
    envs = {e: smr.EnvLight(os.path.join(args.hdri_dir, e + ".hdr")) for pair in pairs for e in pair}
    stats = dict(albedo_srgb_mean=[0.5, 0.5, 0.5], rough_mean=0.5, metal_mean=0.0)
    if args.dataset_stats:
        with open(args.dataset_stats) as f:
            stats.update({k: v for k, v in json.load(f).items() if k in stats})
    views, inputs = {}, {}
    t_render = 0.0
    os.makedirs(os.path.join(work, "inputs"), exist_ok=True)
    if args.levers:
        os.makedirs(os.path.join(work, "truth"), exist_ok=True)
    for env_in, env_rl in pairs:
        for mesh in meshes:
            for v, params in enumerate(view_params(mesh.name, args.seed, args.views)):
                t0 = time.time()
                stem = f"{mesh.name}_{v:02d}" + (f"_{env_in}" if len(pairs) > 1 else "")
                rgba8, gt8, gb = render_view(mesh, params, args.size, envs[env_in])
                gt = {k: a.astype(np.float32) / 255.0 for k, a in gt8.items()}
                rot_rl = smr.rotation_y(params["relight_angle"])
                lin = relight(gb, gt, envs[env_rl], rot_rl)
                exposure = smr.auto_exposure(lin, gb["cov"], params["key"])
                views[stem] = dict(asset=mesh.name, view=v, rgba8=rgba8, gt=gt, gb=gb, rot_rl=rot_rl,
                                   env_in=env_in, env_rl=env_rl,
                                   exposure=exposure, relit_gt=smr.tonemap(lin, exposure, (1, 1, 1)))
                inputs[stem] = os.path.join(work, "inputs", stem + ".png")
                write_png(inputs[stem], rgba8)
                if args.levers:                                     # the 8-bit truth as PNGs for `supermat bench`
                    for name in MAPS:
                        write_png(os.path.join(work, "truth", f"{stem}_{name}.png"), gt8[name])
                t_render += time.time() - t0
                print(f"rendered {stem} ({time.time() - t0:.1f} s)", file=sys.stderr)

    preds, t_pred = {}, {}
    for name, path in args.model:
        t0 = time.time()
        preds[name] = run_model(args.supermat, path, inputs, os.path.join(work, "pred_" + name), args.threads,
                                args.image_args.split())
        t_pred[name] = (time.time() - t0) / len(inputs)
        print(f"predicted with {name} ({t_pred[name]:.1f} s a view)", file=sys.stderr)
        if args.curves:                     # the same maps through calibration curves (eval_cycles --fit)
            from supermat_tools.eval_cycles import apply_curve
            with open(args.curves) as f:
                c = json.load(f)[args.curves_name or name]
            preds[name + "+curves"] = {s: dict(m, roughness=apply_curve(m["roughness"], c["roughness"]),
                                                 metallic=apply_curve(m["metallic"], c["metallic"]))
                                       for s, m in preds[name].items()}
    for kind in args.baselines:
        preds[kind] = {s: baseline(kind, v["rgba8"], v["gt"], stats) for s, v in views.items()}
    lever_files = run_levers(args, inputs, work) if args.levers else []

    rows = []
    t0 = time.time()
    if args.sheets:
        os.makedirs(args.sheets, exist_ok=True)
    for stem, v in views.items():
        mask = v["rgba8"][..., 3] >= 128
        for p in preds:
            relit = smr.tonemap(relight(v["gb"], preds[p][stem], envs[v["env_rl"]], v["rot_rl"]), v["exposure"],
                                (1, 1, 1))
            rows.append(dict(asset=v["asset"], view=v["view"], env_in=v["env_in"], predictor=p,
                             **measure(preds[p][stem], v["gt"], mask, relit, v["relit_gt"], args.decompose)))
        if args.sheets:
            contact_sheet(os.path.join(args.sheets, stem + ".png"), v["rgba8"], v["gt"],
                          [preds[p][stem] for p in preds])
    t_metrics = (time.time() - t0) / len(views)

    overall, per_asset = summarise(rows, list(preds))
    level = None
    print(f"## overall ({len(views)} views, {args.size}x{args.size}, "
          + ", ".join(f"lit by {a}, re-rendered under {b}" for a, b in pairs) + ")\n")
    print(markdown(overall.items()))
    per_env = {}
    if len(pairs) > 1:
        per_env = {a: summarise([r for r in rows if r["env_in"] == a], list(preds))[0] for a, _ in pairs}
        print("\n## per input lighting\n")
        print(markdown([(f"{a} / {p}", m) for a, t in per_env.items() for p, m in t.items()], "lighting / predictor"))
    print("\n## per asset\n")
    print(markdown([(f"{a} / {p}", m) for a, t in per_asset.items() for p, m in t.items()], "asset / predictor"))
    if args.decompose:
        print("\n## albedo error decomposed (PSNR as measured | after the best gain per view | after the best gain "
              "per view and channel)\n")
        print("| asset / predictor | albedo PSNR | best gain | best gains per channel |\n|---|---|---|---|")
        for a, t in [("all", overall)] + list(per_asset.items()):
            for p, m in t.items():
                print(f"| {a} / {p} | {m['albedo_psnr']:.2f} | {m['albedo_psnr_gain']:.2f} | {m['albedo_psnr_wb']:.2f} |")
        level = {p: level_stats([r["albedo_level"] for r in rows if r["predictor"] == p],
                                [r["albedo_level_true"] for r in rows if r["predictor"] == p]) for p in preds}
        print("\n## albedo level (mean linear luminance over the object) per view, predicted against true, in log2\n")
        print(level_table(list(level.items())))
        print("\n| asset / predictor | true level | predicted |\n|---|---|---|")
        for a in per_asset:
            for p in preds:
                s = level_stats([r["albedo_level"] for r in rows if r["predictor"] == p and r["asset"] == a],
                                [r["albedo_level_true"] for r in rows if r["predictor"] == p and r["asset"] == a])
                print(f"| {a} / {p} | {s['true_gmean']:.3f} | {s['pred_gmean']:.3f} |")
    timing = dict(render_s_per_view=t_render / len(views), metrics_s_per_view=t_metrics,
                  predict_s_per_view=t_pred)
    print(f"\ntime per asset-view: render {timing['render_s_per_view']:.1f} s, metrics (all predictors) "
          f"{t_metrics:.1f} s" + "".join(f", {n} {t:.1f} s" for n, t in t_pred.items()))
    levers = None
    if args.levers:
        files = bench_load(lever_files)
        print(f"\n## speed / accuracy levers of {args.levers} ({len(files)} views, modes {args.levers_modes}, "
              f"PSNR vs truth over alpha >= 128)\n")
        print(bench_markdown(files))
        levers = dict(model=args.levers, modes=args.levers_modes, views=len(files),
                      rows=bench_aggregate(files))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(config=dict(assets=[m.name for m in meshes], size=args.size, views=args.views,
                                       seed=args.seed, lightings=pairs,
                                       models=dict(args.model), dataset_stats=stats),
                           overall=overall, per_asset=per_asset, per_lighting=per_env, views=rows, timing=timing,
                           **(dict(levers=levers) if levers else {}),
                           **(dict(albedo_level=level) if args.decompose else {})), f, indent=1)


def model_option(s):
    name, sep, path = s.partition("=")
    return (name, path) if sep else (os.path.splitext(os.path.basename(s))[0], s)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--assets", nargs="+", required=True,
                    help=".gltf files; FILE.gltf#NODE: only the node of that name and its children (e.g. "
                         "BoomBoxWithAxes.gltf#BoomBox, without the axes), the asset then named NODE")
    ap.add_argument("--model", action="append", type=model_option, default=[], metavar="NAME=FILE",
                    help="a supermat model to measure (repeatable)")
    ap.add_argument("--baselines", type=lambda s: [b for b in s.split(",") if b],
                    default=["input_as_albedo", "dataset_mean"],
                    help="comma list of input_as_albedo, dataset_mean, oracle (default: the first two)")
    ap.add_argument("--dataset-stats", help="JSON: albedo_srgb_mean [3], rough_mean, metal_mean")
    ap.add_argument("--size", type=int, help="output size, a multiple of 8 (default 256; 128 with --write-slice)")
    ap.add_argument("--views", type=int, default=8, help="views per asset (default 8)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--env-in", default=HELD_OUT_ENVS[0],
                    help="held-out map lighting the input, or all: each held-out map in turn, re-rendered under "
                         "the next one (--env-relight ignored; 3x the views)")
    ap.add_argument("--env-relight", default=HELD_OUT_ENVS[1], help="held-out map of the re-render check")
    ap.add_argument("--hdri-dir", required=True, help="folder with the held-out .hdr maps (pmndrs/drei-assets hdri/)")
    ap.add_argument("--supermat", default=SUPERMAT)
    ap.add_argument("--work", help="folder for the inputs and predicted maps (default: a temporary one)")
    ap.add_argument("--threads", type=int, default=0, help="supermat threads (default 0 = all cores)")
    ap.add_argument("--curves", default="", help="also each model's maps through the roughness / metallic "
                    "calibration curves of this JSON file (supermat_tools.eval_cycles --fit), as NAME+curves")
    ap.add_argument("--curves-name", default="", help="the curves' entry in --curves (default: the model's NAME)")
    ap.add_argument("--image-args", default="", help="more `supermat image` options for --model runs, e.g. "
                    "\"--detail off --chroma off\" (the network's maps alone) or \"--work-size 128\" (after --native)")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--decompose", action="store_true",
                    help="also the albedo PSNR after the best gain per view (the unknown exposure taken out) and "
                         "after the best gain per view and channel (exposure and white balance)")
    ap.add_argument("--sheets", help="write a contact sheet per view into this folder")
    ap.add_argument("--levers", metavar="MODEL",
                    help="also run `supermat bench --image` with the truth on every view (all its speed / "
                         "accuracy levers) and print the mean table")
    ap.add_argument("--levers-modes", metavar="all|LIST",
                    help="--levers: the bench modes (default all)")
    ap.add_argument("--write-slice", metavar="DIR", help="write a test slice instead of evaluating")
    ap.add_argument("--slice-views", type=int, default=2, help="views per asset of the slice (default 2)")
    args = ap.parse_args()
    if args.size is None:
        args.size = 128 if args.write_slice else 256
    if args.size % 8 or args.size < 8:
        ap.error("--size must be a positive multiple of 8")
    if args.env_in == "all" and (args.write_slice or args.levers):
        ap.error("--env-in all does not apply with --write-slice or --levers")
    for e in (args.env_in, args.env_relight) if args.env_in != "all" else ():
        if e not in HELD_OUT_ENVS:
            ap.error(f"{e} is not a held-out environment map ({', '.join(HELD_OUT_ENVS)})")
    if args.env_in == args.env_relight and args.env_in != "all":
        ap.error("--env-in and --env-relight must differ")
    for b in args.baselines:
        if b not in ("input_as_albedo", "dataset_mean", "oracle"):
            ap.error(f"unknown baseline {b}")
    if not args.write_slice and not args.model and not args.baselines:
        ap.error("nothing to measure: give --model or --baselines")
    if args.levers_modes is not None and not args.levers:
        ap.error("--levers-modes needs --levers MODEL")
    if args.levers and args.write_slice:
        ap.error("--levers does not apply with --write-slice")
    if args.levers and not os.path.isfile(args.levers):
        ap.error(f"--levers: no model file {args.levers}")
    args.levers_modes = args.levers_modes or "all"

    t0 = time.time()
    try:
        meshes = [Mesh(p) for p in args.assets]
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"error: {e}")
    print(f"loaded {len(meshes)} assets ({time.time() - t0:.1f} s): "
          + ", ".join(f"{m.name} {len(m.P)} triangles" for m in meshes), file=sys.stderr)
    if args.write_slice:
        write_slice(args, meshes)
        return
    work = args.work or tempfile.mkdtemp(prefix="eval_quality.")
    try:
        evaluate(args, meshes, work)
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
