#!/usr/bin/env python3
"""Render the small procedural RGBA test inputs under tests/data/img/ (deterministic, no external data).

    PYTHONPATH=python python3 -m supermat_tools.make_test_images [--out tests/data/img]

Writes
  sphere_64.png         64x64 RGBA  lit, textured sphere
  box_40.png            40x40 RGBA  lit, textured rotated rounded box (latent 5x5: not a multiple of 8)
  ring_48x72.png        72 wide x 48 high RGBA  tilted torus (latent 6x9: non-square)
  mv/color_000K.png     K=0..5, 64x64 RGBA  six orthographic views of one object (cameras of mv/meta.json)
  mv/meta.json          {"locations": [{"index": "000K", "transform_matrix": 4x4 c2w}, ...]}
  uv/uv_bc.png          128x128 RGB  partial base-colour UV map (0 where unobserved / outside charts)
  uv/uv_mask.png        128x128 L    min(#views that saw the texel, 3)/3 -> 0, 85, 170, 255
  uv/uv_position.png    128x128 RGB  (p+1)/2 of the surface point, gray 127 outside the charts

Images are produced by sphere tracing signed distance functions with orthographic cameras, 4x4
supersampling per pixel: alpha = covered fraction, RGB = mean colour of the covered samples (straight,
not premultiplied).  Where alpha is 0 the RGB is deterministic noise ("garbage", as in real renders),
because the pipeline composites over gray 0.5 with alpha.

Only numpy and Pillow are used; the output is bit-identical across runs (seeded generators, no threads).
"""
import argparse
import json
from pathlib import Path

import numpy as np
from PIL import Image

from supermat_tools.common import REPO

SS = 4  # supersampling per axis

# Camera-to-world matrices (Blender/OpenGL convention: camera looks down its -Z, +Y up; world Z up),
# the same numbers as the official example's meta.json: 0 front (-Y), 1 right (+X), 2 back (+Y),
# 3 left (-X), 4 top (+Z), 5 bottom (-Z).
C2W = [
    [[1.0, 0.0, 6.123233601181349e-17, 6.123234262925839e-17],
     [6.123233601181349e-17, 3.422854177870249e-08, -0.9999999403953552, -1.0],
     [0.0, 0.9999999403953552, 3.422854177870249e-08, 0.0],
     [0.0, 0.0, 0.0, 1.0]],
    [[1.1920928244535389e-07, 0.0, 0.9999998807907104, 1.0],
     [0.9999998807907104, 1.1920928244535389e-07, 0.0, 0.0],
     [0.0, 0.9999998807907104, 1.1920928244535389e-07, 0.0],
     [0.0, 0.0, 0.0, 1.0]],
    [[-0.9999999403953552, 8.742277657347586e-08, 0.0, 6.123234262925839e-17],
     [0.0, 3.4228538225988814e-08, 0.9999999403953552, 1.0],
     [8.742277657347586e-08, 0.9999999403953552, 3.4228538225988814e-08, 0.0],
     [0.0, 0.0, 0.0, 1.0]],
    [[5.9604641222676946e-08, 0.0, -0.9999999403953552, -1.0],
     [-0.9999999403953552, 1.1920928244535389e-07, 0.0, 1.2246468525851679e-16],
     [5.9604641222676946e-08, 0.9999999403953552, 5.9604641222676946e-08, 0.0],
     [0.0, 0.0, 0.0, 1.0]],
    [[-1.0000001192092896, 8.742277657347586e-08, 1.5258152380459578e-11, 1.0687059615292178e-20],
     [-8.742277657347586e-08, -1.0, -0.0003490658418741077, -0.00017453292093705386],
     [-1.5258152380459578e-11, -0.0003490658418741077, 0.9999999403953552, 1.0],
     [0.0, 0.0, 0.0, 1.0]],
    [[-1.0000001192092896, -8.742277657347586e-08, 1.526579557209473e-11, 1.0687059615292178e-20],
     [-8.742277657347586e-08, 0.9999999403953552, -0.00034915326978079975, -0.00017453292093705386],
     [1.5258152380459578e-11, -0.00034915326978079975, -1.0, -1.0],
     [0.0, 0.0, 0.0, 1.0]],
]


# ----------------------------------------------------------------------------------------------------
# signed distance functions (p: [N,3])
def sd_sphere(p, c, r):
    return np.linalg.norm(p - np.asarray(c), axis=-1) - r


def sd_round_box(p, c, half, r):
    q = np.abs(p - np.asarray(c)) - np.asarray(half)
    return (np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)) - r


def sd_torus(p, c, R, r):
    """Torus around the local z axis."""
    q = p - np.asarray(c)
    a = np.sqrt(q[:, 0] ** 2 + q[:, 1] ** 2) - R
    return np.sqrt(a * a + q[:, 2] ** 2) - r


def rot(ax, ay, az):
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


class Scene:
    """Union of primitives; each has an sdf(p) in world space and a colour(p, n) function."""

    def __init__(self, prims):
        self.prims = prims  # list of (sdf, colour_fn)

    def dist(self, p):
        d = np.stack([f(p) for f, _ in self.prims], axis=0)
        return d.min(axis=0), d.argmin(axis=0)

    def normal(self, p, eps=1e-4):
        n = np.zeros_like(p)
        for k in range(3):
            e = np.zeros(3)
            e[k] = eps
            n[:, k] = self.dist(p + e)[0] - self.dist(p - e)[0]
        return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)


def shade(scene, p, n, view_dir, mat):
    """Base colour from the primitive's procedural texture, Lambert + ambient + Blinn highlight."""
    base = np.zeros_like(p)
    for k, (_, col) in enumerate(scene.prims):
        m = mat == k
        if m.any():
            base[m] = col(p[m], n[m])
    light = np.array([-0.45, -0.6, 0.66])
    light /= np.linalg.norm(light)
    ndl = np.clip(n @ light, 0.0, None)[:, None]
    h = light[None, :] - view_dir
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    spec = np.clip((n * h).sum(-1), 0.0, None)[:, None] ** 40
    rgb = base * (0.25 + 0.75 * ndl) + 0.35 * spec
    return np.clip(rgb, 0.0, 1.0)


def render(scene, W, H, c2w, half_w, half_h, seed, dist=3.0, iters=400):
    """Orthographic render; returns uint8 RGBA [H,W,4] with straight alpha and noise under alpha 0."""
    c2w = np.asarray(c2w, dtype=np.float64)
    right, up, back, centre = c2w[:3, 0], c2w[:3, 1], c2w[:3, 2], c2w[:3, 3]
    back = back / np.linalg.norm(back)
    # sub-pixel sample grid (row 0 = top of the image)
    js = (np.arange(W * SS) + 0.5) / (W * SS)
    is_ = (np.arange(H * SS) + 0.5) / (H * SS)
    u = (js * 2 - 1) * half_w
    v = (1 - is_ * 2) * half_h
    U, V = np.meshgrid(u, v)
    # ray origins on a plane through the camera centre's projection, moved back along the view axis
    o = (centre[None, :] - np.dot(centre, back) * back[None, :] + dist * back[None, :]
         + U.reshape(-1, 1) * right[None, :] + V.reshape(-1, 1) * up[None, :])
    d = -back
    t = np.zeros(o.shape[0])
    hit = np.zeros(o.shape[0], dtype=bool)
    alive = np.ones(o.shape[0], dtype=bool)
    for _ in range(iters):
        idx = np.nonzero(alive)[0]
        if idx.size == 0:
            break
        dd, _ = scene.dist(o[idx] + t[idx, None] * d[None, :])
        t[idx] += dd
        h = dd < 2e-4
        hit[idx[h]] = True
        alive[idx[h]] = False
        alive[idx[t[idx] > 2 * dist]] = False
    p = o[hit] + t[hit, None] * d[None, :]
    n = scene.normal(p)
    _, mat = scene.dist(p)
    col = np.zeros((o.shape[0], 3))
    col[hit] = shade(scene, p, n, np.broadcast_to(d, p.shape), mat)
    # box-filter the supersamples: alpha = coverage, straight colour = mean over covered samples
    cov = hit.reshape(H, SS, W, SS).astype(np.float64).mean(axis=(1, 3))
    csum = col.reshape(H, SS, W, SS, 3).sum(axis=(1, 3))
    cnt = hit.reshape(H, SS, W, SS).sum(axis=(1, 3))[..., None]
    straight = np.where(cnt > 0, csum / np.maximum(cnt, 1), 0.0)
    rgba = np.zeros((H, W, 4), dtype=np.uint8)
    rgba[..., :3] = np.round(straight * 255).astype(np.uint8)
    rgba[..., 3] = np.round(cov * 255).astype(np.uint8)
    garbage = np.random.default_rng(seed).integers(0, 256, size=(H, W, 3), dtype=np.uint8)
    rgba[..., :3] = np.where(rgba[..., 3:4] == 0, garbage, rgba[..., :3])
    return rgba


# ----------------------------------------------------------------------------------------------------
# procedural textures
def checker_sphere(p, n):
    lon = np.arctan2(p[:, 1], p[:, 0])
    lat = np.arcsin(np.clip(p[:, 2] / np.linalg.norm(p, axis=-1), -1, 1))
    c = (np.floor(lon / (np.pi / 6)) + np.floor(lat / (np.pi / 8))) % 2
    a = np.array([0.85, 0.32, 0.18])
    b = np.array([0.95, 0.86, 0.55])
    return np.where(c[:, None] > 0, a, b)


def make_box_texture(R, centre):
    Rt = R.T

    def tex(p, n):
        q = (p - centre) @ Rt.T  # object frame
        nl = n @ R  # normal in object frame
        face = np.argmax(np.abs(nl), axis=-1) * 2 + (np.take_along_axis(nl, np.argmax(np.abs(nl), -1)[:, None], 1)[:, 0] > 0)
        palette = np.array([[0.20, 0.45, 0.80], [0.85, 0.75, 0.20], [0.25, 0.70, 0.35],
                            [0.75, 0.25, 0.55], [0.90, 0.50, 0.15], [0.50, 0.50, 0.55]])
        base = palette[face]
        stripes = (np.sin(q[:, 0] * 18 + q[:, 1] * 11 + q[:, 2] * 7) > 0.3)[:, None]
        return np.where(stripes, base * 0.55, base)
    return tex


def torus_tex(p, n):
    ang = np.arctan2(p[:, 1], p[:, 0])
    s = 0.5 + 0.5 * np.sin(ang * 7)
    return np.stack([0.75 + 0.2 * s, 0.60 * s + 0.2, 0.15 + 0.1 * s], -1)


def ring_scene():
    R = rot(1.05, 0.25, 0.3)
    Rt = R.T
    c = np.array([0.0, 0.0, 0.0])

    def sdf(p):
        q = (p - c) @ Rt.T
        return sd_torus(q, (0, 0, 0), 1.0, 0.28)

    def tex(p, n):
        q = (p - c) @ Rt.T
        return torus_tex(q, n)
    gem = (0.0, -0.2, 1.05)
    return Scene([(sdf, tex),
                  (lambda p: sd_sphere(p, gem, 0.22), lambda p, n: np.tile([0.2, 0.35, 0.9], (len(p), 1)))])


def mv_scene():
    """A bag-like asymmetric object: body, handle, front knob, side pocket; |coords| < ~0.85."""
    def body_tex(p, n):
        band = (np.abs(np.sin(p[:, 2] * 9)) > 0.8)[:, None]
        base = np.stack([0.55 + 0.3 * p[:, 0], 0.35 + 0.2 * p[:, 1], 0.25 + 0.15 * (p[:, 2] + 0.5)], -1)
        return np.where(band, np.array([0.9, 0.85, 0.7]), np.clip(base, 0, 1))

    def handle_sdf(p):
        q = p[:, [0, 2, 1]] - np.array([0.0, 0.42, 0.0])  # torus in the x-z plane, above the body
        return sd_torus(q, (0, 0, 0), 0.32, 0.06)
    return Scene([
        (lambda p: sd_round_box(p, (0, 0, -0.1), (0.55, 0.3, 0.4), 0.08), body_tex),
        (handle_sdf, lambda p, n: np.tile([0.35, 0.2, 0.1], (len(p), 1))),
        (lambda p: sd_sphere(p, (0.2, -0.42, 0.0), 0.12), lambda p, n: np.tile([0.85, 0.8, 0.2], (len(p), 1))),
        (lambda p: sd_round_box(p, (0.66, 0.05, -0.25), (0.06, 0.18, 0.15), 0.03),
         lambda p, n: np.tile([0.2, 0.55, 0.5], (len(p), 1))),
    ])


# a camera looking along +Y (front), Z up, used for the single-view images
FRONT = C2W[0]


# ----------------------------------------------------------------------------------------------------
# UV maps
def uv_maps(S=128):
    """Three charts of a unit sphere (|p|<=1): north / south hemisphere disks (orthographic projection
    along z) and a cylindrical equator strip.  Mask = min(#axis views with n.v > 0.25, 3)/3, with an
    'occluded' patch (texels whose z < -0.8 and x > 0, as if resting on something) forced to 0."""
    pos = np.full((S, S, 3), 127, dtype=np.uint8)
    bc = np.zeros((S, S, 3), dtype=np.uint8)
    mask = np.zeros((S, S), dtype=np.uint8)
    jj, ii = np.meshgrid(np.arange(S) + 0.5, np.arange(S) + 0.5)
    P = np.zeros((S, S, 3))
    inside = np.zeros((S, S), dtype=bool)
    r = 0.22 * S
    for cx, sign in ((0.27 * S, 1.0), (0.73 * S, -1.0)):
        cy = 0.3 * S
        u, v = (jj - cx) / r, (ii - cy) / r
        m = u * u + v * v <= 0.81  # |z| >= ~0.44: the strip covers the rest
        z = sign * np.sqrt(np.clip(1 - u * u - v * v, 0, 1))
        P[m] = np.stack([u, v, z], -1)[m]
        inside |= m
    # equator strip: longitude along x, z in [-0.46, 0.46]
    x0, x1, y0, y1 = 0.05 * S, 0.95 * S, 0.62 * S, 0.92 * S
    m = (jj >= x0) & (jj < x1) & (ii >= y0) & (ii < y1)
    lon = (jj - x0) / (x1 - x0) * 2 * np.pi - np.pi
    z = 0.46 - (ii - y0) / (y1 - y0) * 0.92
    rho = np.sqrt(np.clip(1 - z * z, 0, 1))
    P[m] = np.stack([rho * np.cos(lon), rho * np.sin(lon), z], -1)[m]
    inside |= m
    n = P / np.maximum(np.linalg.norm(P, axis=-1, keepdims=True), 1e-12)
    views = np.array([[0, -1, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)
    count = (np.einsum("hwc,vc->hwv", n, views) > 0.25).sum(-1)
    count[(P[..., 2] < -0.8) & (P[..., 0] > 0)] = 0
    count = np.where(inside, np.minimum(count, 3), 0)
    mask[...] = np.round(count / 3 * 255).astype(np.uint8)
    pos[inside] = np.round((P[inside] + 1) / 2 * 255).astype(np.uint8)
    # base colour: latitude bands x longitude checker, only where observed
    lon_all = np.arctan2(P[..., 1], P[..., 0])
    chk = (np.floor(lon_all / (np.pi / 5)) + np.floor(P[..., 2] * 4)) % 2
    col = np.where(chk[..., None] > 0, np.array([0.80, 0.30, 0.25]), np.array([0.30, 0.55, 0.85]))
    col = col * (0.8 + 0.2 * P[..., 2:3])
    obs = inside & (count > 0)
    bc[obs] = np.round(np.clip(col[obs], 0, 1) * 255).astype(np.uint8)
    return bc, mask, pos


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(Path(REPO) / "tests" / "data" / "img"))
    args = ap.parse_args()
    out = Path(args.out)
    (out / "mv").mkdir(parents=True, exist_ok=True)
    (out / "uv").mkdir(parents=True, exist_ok=True)

    def save(arr, path, mode):
        Image.fromarray(arr, mode).save(path, optimize=False)
        print("wrote", path, arr.shape)

    sph = Scene([(lambda p: sd_sphere(p, (0, 0, 0), 0.8), checker_sphere)])
    save(render(sph, 64, 64, FRONT, 1.0, 1.0, seed=1), out / "sphere_64.png", "RGBA")

    R = rot(0.5, 0.35, 0.6)
    box = Scene([(lambda p: sd_round_box(p @ R, (0, 0, 0), (0.42, 0.38, 0.45), 0.05),
                  make_box_texture(R, np.zeros(3)))])
    save(render(box, 40, 40, FRONT, 1.0, 1.0, seed=2), out / "box_40.png", "RGBA")

    save(render(ring_scene(), 72, 48, FRONT, 1.5, 1.0, seed=3), out / "ring_48x72.png", "RGBA")

    mv = mv_scene()
    meta = {"locations": []}
    for k, c2w in enumerate(C2W):
        idx = f"{k:04d}"
        save(render(mv, 64, 64, c2w, 0.9, 0.9, seed=10 + k), out / "mv" / f"color_{idx}.png", "RGBA")
        meta["locations"].append({"index": idx, "transform_matrix": c2w})
    with open(out / "mv" / "meta.json", "w") as f:
        json.dump(meta, f, indent=2)
        f.write("\n")

    bc, mask, pos = uv_maps(128)
    save(bc, out / "uv" / "uv_bc.png", "RGB")
    save(mask, out / "uv" / "uv_mask.png", "L")
    save(pos, out / "uv" / "uv_position.png", "RGB")


if __name__ == "__main__":
    main()
