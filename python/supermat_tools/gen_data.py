#!/usr/bin/env python3
"""Training data for supermat's default model: procedural objects rendered under image-based lighting,
with the ground-truth material maps at the same pixels.  Deterministic by seed; numpy only.

    PYTHONPATH=python /usr/bin/python3 -m supermat_tools.gen_data --hdri-dir HDRI --out DATA [--count 4000] [--size 128] [--jobs 2] [--seed 0]

HDRI: a folder with the CC0 Poly Haven maps of the public repository pmndrs/drei-assets (hdri/*.hdr);
the maps named in HELD_OUT are never used here (they light the evaluation).  No mesh or texture from
anywhere else enters the data: every object and material is made here.

Each sample (shards DATA/shard_NNNN.npz of `--shard` samples; a shard that exists is kept, so an
interrupted run resumes):
  rgba    uint8 HxWx4  the input: one object, straight alpha, lit by an environment map (random
                       rotation, exposure and white balance; 30 % with a directional light and shadows),
                       tone mapped as a renderer's "Standard" view (clip + sRGB)
  albedo  uint8 HxWx3  ground truth, sRGB (glTF baseColor: a metal's albedo is its F0 colour)
  rough   uint8 HxW    ground truth roughness, linear
  metal   uint8 HxW    ground truth metallic, linear
  normal  f16 HxWx3    unit normal (camera space: the camera looks down -Z), for re-render losses
  env     int          index into the sorted training map names (meta.json), env_rot [3x3], exposure, wb
With --views 6 (training data for SuperMatMV) a sample is one object in the six official views: the arrays
above gain a view axis after the sample axis (rgba [6xHxWx4], ..., normals in each view's camera frame),
plus cams [6x4x4], the camera-to-world matrices supermat_uv.h uses (read from it); the object is moved
into supermat_uv.h's view frame (bounding box centred, largest half extent 1, world Z up, views covering
[-1.1, 1.1]) and lit once for all six (map and sun fixed in the world, one exposure and white balance).
Objects: 1-3 of superquadric / ellipsoid / torus / rounded box / capsule / displaced blob, smoothly
united, randomly rotated, orthographic camera, 2x2 supersampling.  Materials in object space: fBm,
Voronoi cells, stripes, checks, decals, worn edges (exposed metal under paint), roughness over
[0.05, 1], metallic mostly binary with coloured metals; each material is dielectric, metal, masked metal
or worn edges with the probabilities --mode-probs (default 0.42 / 0.2 / 0.2 / 0.18: 29 % of the object
pixels metallic; 0.62 / 0.12 / 0.13 / 0.13: 18 %; the same random draws whatever the probabilities).
--albedo-floor F lifts the palettes' darkest values (v -> F + (1 - F) v; PBR charts put dielectric albedo at
30-240 of 255 in sRGB, F = 0.12 is 31) and --anodised P sets how often a metal is a random coloured one
(default 0.25); both keep the random draws, so the same objects and patterns come out.  --dark-metal P darkens a
metal's F0 colour with probability P (times 2^U(-3, 0) in linear light, drawn from the material's own stream, so
P = 0 reproduces the earlier sets): the F0 table starts at 0.77 sRGB, while real assets author their metals'
base colours at 0.3-0.55 (WaterBottle, Suzanne, DamagedHelmet).  --metal-rough P gives the metal of a
masked-metal or worn-edge material, with probability P, a roughness of its own (U(0.05, 1), drawn from the
material's own stream; P = 0 reproduces the earlier sets) instead of half its surroundings': with that halving
the metal is the smoother part of nearly every such object, and smoothness alone ranks a render's metal pixels
at ROC AUC 0.72 (400 renders), while real assets' metals are as often the rougher part.  --photo P makes a
material's albedo, with probability P, a photographic crop of one of the training environment maps (the same
CC0 images that light the scenes; hue turned and saturation scaled at random, squeezed into the albedo range,
projected along a random axis; its roughness follows the photo's luminance a little); drawn from each
material's own stream, so P = 0 reproduces the earlier sets exactly.  --assembly P makes an object, with
probability P, an assembly of 3-7 parts instead (a body and attached parts: surfaces of revolution, capped
cylinders, boxes, ellipsoids, tori, capsules; sharp or slightly smoothed unions; most parts with a material of
their own), drawn from a stream of its own, so P = 0 reproduces the earlier sets and P > 0 keeps every other
sample.  Shading: supermat_tools.smrender (Cook-Torrance GGX,
Smith, Schlick + Lambert, split-sum prefiltered environment).
"""
import argparse
import json
import os
import time

import numpy as np

from supermat_tools import smrender as R
from supermat_tools.common import REPO

HELD_OUT = ("venice_sunset_1k", "studio_small_03_1k", "kiara_1_dawn_1k")


# ----------------------------------------------------------------------------------------------------------
# noise (object space)
# ----------------------------------------------------------------------------------------------------------
def _hash(ix, iy, iz, seed):
    h = (ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791) ^ (seed * 2654435761)
    h &= 0xFFFFFFFF
    h ^= h >> 13
    h = (h * 1274126177) & 0xFFFFFFFF
    h ^= h >> 16
    return (h & 0xFFFFFF).astype(np.float32) / np.float32(0xFFFFFF)


def vnoise(p, seed):
    f = np.floor(p)
    t = (p - f).astype(np.float32)
    t = t * t * (3 - 2 * t)
    i = f.astype(np.int64)
    out = 0
    for dx in (0, 1):
        wx = t[..., 0] if dx else 1 - t[..., 0]
        for dy in (0, 1):
            wy = t[..., 1] if dy else 1 - t[..., 1]
            for dz in (0, 1):
                wz = t[..., 2] if dz else 1 - t[..., 2]
                out = out + wx * wy * wz * _hash(i[..., 0] + dx, i[..., 1] + dy, i[..., 2] + dz, seed)
    return out


def fbm(p, seed, octaves=4, lac=2.0, gain=0.5):
    s, a, norm = 0.0, 1.0, 0.0
    for o in range(octaves):
        s = s + a * vnoise(p * (lac ** o), seed + 17 * o)
        norm += a
        a *= gain
    return s / norm


def voronoi(p, seed):
    """(cell id in [0,1), F1 distance, F2 - F1) of jittered-grid cells."""
    f = np.floor(p).astype(np.int64)
    best = np.full(p.shape[:-1], 1e9, np.float32)
    second = np.full(p.shape[:-1], 1e9, np.float32)
    cid = np.zeros(p.shape[:-1], np.float32)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                c = f + np.array([dx, dy, dz])
                jit = np.stack([_hash(c[..., 0], c[..., 1], c[..., 2], seed + k) for k in range(3)], -1)
                d = np.linalg.norm(c + jit - p, axis=-1).astype(np.float32)
                closer = d < best
                second = np.where(closer, best, np.minimum(second, d))
                cid = np.where(closer, _hash(c[..., 0], c[..., 1], c[..., 2], seed + 9), cid)
                best = np.minimum(best, d)
    return cid, best, second - best


def smoothstep(a, b, x):
    t = np.clip((x - a) / (b - a), 0, 1)
    return t * t * (3 - 2 * t)


# ----------------------------------------------------------------------------------------------------------
# shapes
# ----------------------------------------------------------------------------------------------------------
def make_shape(rng):
    kind = rng.choice(["superquadric", "ellipsoid", "torus", "roundbox", "capsule", "blob"],
                      p=[0.2, 0.15, 0.15, 0.2, 0.12, 0.18])
    sh = {"kind": str(kind), "rot": R.random_rotation(rng), "off": rng.uniform(-0.35, 0.35, 3).astype(np.float32)}
    if kind == "superquadric":
        sh["e"] = float(rng.choice([rng.uniform(1.2, 2.0), rng.uniform(2.5, 8.0)]))
        sh["r"] = rng.uniform(0.35, 0.7, 3).astype(np.float32)
        sh["bound"] = float(sh["r"].max() * 1.8)
    elif kind == "ellipsoid":
        sh["r"] = rng.uniform(0.3, 0.7, 3).astype(np.float32)
        sh["bound"] = float(sh["r"].max())
    elif kind == "torus":
        sh["R"] = float(rng.uniform(0.35, 0.6))
        sh["r"] = float(rng.uniform(0.08, 0.25))
        sh["bound"] = sh["R"] + sh["r"]
    elif kind == "roundbox":
        sh["b"] = rng.uniform(0.2, 0.6, 3).astype(np.float32)
        sh["rr"] = float(rng.uniform(0.01, 0.15))
        sh["bound"] = float(np.linalg.norm(sh["b"]) + sh["rr"])
    elif kind == "capsule":
        sh["h"] = float(rng.uniform(0.1, 0.5))
        sh["r"] = float(rng.uniform(0.15, 0.35))
        sh["bound"] = sh["h"] + sh["r"]
    else:
        sh["r"] = float(rng.uniform(0.4, 0.6))
        sh["amp"] = float(rng.uniform(0.05, 0.2))
        sh["freq"] = float(rng.uniform(1.5, 4.0))
        sh["seed"] = int(rng.integers(1 << 20))
        sh["bound"] = sh["r"] + sh["amp"]
    return sh


def sdf_shape(sh, p):
    q = (p - sh["off"]) @ sh["rot"]
    k = sh["kind"]
    if k == "superquadric":
        e = sh["e"]
        a = np.abs(q) / sh["r"] + 1e-9
        f = np.power(np.power(a, e).sum(-1), 1.0 / e)
        return (f - 1) * sh["r"].min() * 0.8
    if k == "ellipsoid":
        k0 = np.linalg.norm(q / sh["r"], axis=-1)
        k1 = np.linalg.norm(q / (sh["r"] * sh["r"]), axis=-1)
        return k0 * (k0 - 1) / np.maximum(k1, 1e-9) * sh.get("lip", 1.0)
    if k == "torus":
        xz = np.sqrt(q[..., 0] ** 2 + q[..., 2] ** 2) - sh["R"]
        return np.sqrt(xz * xz + q[..., 1] ** 2) - sh["r"]
    if k == "roundbox":
        d = np.abs(q) - sh["b"]
        return (np.linalg.norm(np.maximum(d, 0), axis=-1) + np.minimum(d.max(-1), 0) - sh["rr"])
    if k == "capsule":
        y = np.clip(q[..., 1], -sh["h"], sh["h"])
        return np.sqrt(q[..., 0] ** 2 + (q[..., 1] - y) ** 2 + q[..., 2] ** 2) - sh["r"]
    if k == "lathe":     # a surface of revolution about y: bottles, vases, knobs, fruit
        rho = np.sqrt(q[..., 0] ** 2 + q[..., 2] ** 2)
        t = np.clip((q[..., 1] + sh["h"]) / (2 * sh["h"]), 0, 1)
        r = sh["r0"] * (1 + sum(a * np.sin((j + 1) * np.pi * t + ph) for j, (a, ph) in enumerate(sh["harm"])))
        r = np.maximum(r, sh["rmin"])
        return np.maximum((rho - r) * sh["lip"], np.abs(q[..., 1]) - sh["h"])
    if k == "cylinder":  # capped, its rims rounded by rr (0: sharp)
        rho = np.sqrt(q[..., 0] ** 2 + q[..., 2] ** 2)
        d = np.stack([rho - sh["r"] + sh["rr"], np.abs(q[..., 1]) - sh["h"] + sh["rr"]], -1)
        return np.linalg.norm(np.maximum(d, 0), axis=-1) + np.minimum(d.max(-1), 0) - sh["rr"]
    d = np.linalg.norm(q, axis=-1) - sh["r"]
    return (d - sh["amp"] * (2 * fbm(q * sh["freq"], sh["seed"], 3) - 1)) * 0.7


def smin(a, b, k):
    if k <= 0:
        return np.minimum(a, b)
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0, 1)
    return b * (1 - h) + a * h - k * h * (1 - h)


class Obj:
    def __init__(self, rng):
        n = int(rng.choice([1, 2, 3], p=[0.55, 0.3, 0.15]))
        self.shapes = [make_shape(rng) for _ in range(n)]
        if n == 1:
            self.shapes[0]["off"][:] = 0
        self.k = float(rng.choice([0.0, rng.uniform(0.02, 0.15)]))
        self.rot = R.random_rotation(rng)
        bound = max(np.linalg.norm(s["off"]) + s["bound"] for s in self.shapes)
        self.scale = float(rng.uniform(0.6, 0.95) / bound)
        self.center = np.array([*rng.uniform(-0.08, 0.08, 2), 0], np.float32)

    def local(self, pw):
        return ((pw - self.center) @ self.rot) / self.scale

    def sdf_parts(self, pw):
        q = self.local(pw)
        return [sdf_shape(s, q) * self.scale for s in self.shapes]

    def sdf(self, pw):
        ds = self.sdf_parts(pw)
        d = ds[0]
        for e in ds[1:]:
            d = smin(d, e, self.k * self.scale)
        return d


def make_part(rng, s):
    """One part of an assembly (--assembly), its size scaled by s: the kinds above plus lathes and cylinders."""
    kind = str(rng.choice(["lathe", "cylinder", "roundbox", "ellipsoid", "superquadric", "torus", "capsule"],
                          p=[0.25, 0.2, 0.2, 0.1, 0.1, 0.08, 0.07]))
    sh = {"kind": kind, "rot": R.random_rotation(rng), "off": np.zeros(3, np.float32)}
    if kind == "lathe":
        h, r0 = float(rng.uniform(0.25, 0.7) * s), float(rng.uniform(0.15, 0.45) * s)
        harm = [(float(rng.uniform(-0.3, 0.3) / (j + 1)), float(rng.uniform(0, 2 * np.pi))) for j in range(3)]
        slope = r0 * np.pi * sum(abs(a) * (j + 1) for j, (a, _) in enumerate(harm)) / (2 * h)
        sh.update(h=h, r0=r0, harm=harm, rmin=0.03 * s, lip=float(0.9 / np.sqrt(1 + slope * slope)))
        rmax = r0 * (1 + sum(abs(a) for a, _ in harm))
        sh["bound"], sh["ext"] = float(np.hypot(h, rmax)), float(max(h, rmax) * 0.8)
    elif kind == "cylinder":
        sh["r"], sh["h"] = float(rng.uniform(0.12, 0.45) * s), float(rng.uniform(0.05, 0.6) * s)
        sh["rr"] = float(rng.choice([0.0, rng.uniform(0.05, 0.3)]) * min(sh["r"], sh["h"]))
        sh["bound"], sh["ext"] = float(np.hypot(sh["r"], sh["h"])), float(max(sh["r"], sh["h"]) * 0.8)
    elif kind == "roundbox":
        sh["b"] = (rng.uniform(0.05, 0.6, 3) * s).astype(np.float32)
        sh["rr"] = float(rng.uniform(0.0, 0.5) * sh["b"].min())
        sh["b"] = (sh["b"] - sh["rr"]).astype(np.float32)
        sh["bound"], sh["ext"] = float(np.linalg.norm(sh["b"]) + sh["rr"]), float(sh["b"].max() * 0.8)
    elif kind in ("ellipsoid", "superquadric"):
        sh["r"] = (rng.uniform(0.15, 0.6) * rng.uniform(0.4, 1.0, 3) * s).astype(np.float32)
        # the ellipsoid's distance bound is steeper than 1 off flat ones, where the tracer's steps would
        # overshoot: scaled by the shortest radius over the longest (exact for old sets: they have no "lip")
        sh["lip"] = float(sh["r"].min() / sh["r"].max())
        sh["e"] = float(rng.uniform(2.5, 6.0))
        sh["bound"] = float(sh["r"].max() * (1.8 if kind == "superquadric" else 1.0))
        sh["ext"] = float(sh["r"].max() * 0.8)
    elif kind == "torus":
        sh["R"], sh["r"] = float(rng.uniform(0.2, 0.5) * s), float(rng.uniform(0.03, 0.15) * s)
        sh["bound"], sh["ext"] = sh["R"] + sh["r"], sh["R"]
    else:
        sh["h"], sh["r"] = float(rng.uniform(0.1, 0.5) * s), float(rng.uniform(0.05, 0.25) * s)
        sh["bound"], sh["ext"] = sh["h"] + sh["r"], sh["h"] + sh["r"] * 0.5
    return sh


class Assembly(Obj):
    """--assembly: a body and 2-6 attached parts (sharp or slightly smoothed unions), most with a material of their
    own, as real assets are made of parts: a lathe-turned bottle with a cap, a box with knobs and a handle."""

    def __init__(self, rng):
        n = int(rng.integers(3, 8))
        body = make_part(rng, 1.0)
        self.shapes = [body]
        for _ in range(n - 1):
            part = make_part(rng, float(rng.uniform(0.2, 0.6)))
            u = rng.normal(size=3)
            part["off"] = (u / np.linalg.norm(u) * body["ext"] * rng.uniform(0.6, 1.1)).astype(np.float32)
            self.shapes.append(part)
        self.k = 0.0 if rng.random() < 0.6 else float(rng.uniform(0.01, 0.05))
        self.rot = R.random_rotation(rng)
        bound = max(np.linalg.norm(s["off"]) + s["bound"] for s in self.shapes)
        self.scale = float(rng.uniform(0.6, 0.95) / bound)
        self.center = np.array([*rng.uniform(-0.08, 0.08, 2), 0], np.float32)


def assembly_materials(rng, n, *args):
    """The materials of an assembly's n parts: each part's own, or (30 %) a copy of an earlier part's."""
    mats = []
    for k in range(n):
        mats.append(mats[int(rng.integers(k))] if k and rng.random() < 0.3 else make_material(rng, *args))
    return mats


def frame(obj, extent, n=40):
    """Centre the object and scale it so its silhouette spans `extent` of the frame (low-res trace)."""
    for _ in range(2):
        xs = (np.arange(n, dtype=np.float32) + 0.5) / n * 2.4 - 1.2
        X, Y = np.meshgrid(xs, -xs)
        o = np.stack([X.ravel(), Y.ravel(), np.full(n * n, 3.0, np.float32)], -1)
        hit, _ = trace(obj, o, np.tile(np.array([0, 0, -1], np.float32), (n * n, 1)), steps=64, eps=1e-3)
        if not hit.any():
            return
        lo, hi = o[hit, :2].min(0) - 1.2 / n, o[hit, :2].max(0) + 1.2 / n
        f = extent / max((hi - lo).max() / 2, 1e-3)
        mid = np.append((lo + hi) / 2, 0).astype(np.float32)
        obj.center = ((obj.center - mid) * f).astype(np.float32)
        obj.scale *= f


def trace(obj, o, d, steps=96, tmax=6.0, eps=2e-4):
    n = o.shape[0]
    t = np.zeros(n, np.float32)
    hit = np.zeros(n, bool)
    act = np.arange(n)
    for _ in range(steps):
        if act.size == 0:
            break
        dist = obj.sdf(o[act] + d[act] * t[act, None])
        t[act] += dist * 0.9
        done = dist < eps
        hit[act[done]] = True
        act = act[~done & (t[act] < tmax)]
    return hit, t


def normals(obj, p, h=5e-4):
    e = np.eye(3, dtype=np.float32) * h
    g = np.stack([obj.sdf(p + e[i]) - obj.sdf(p - e[i]) for i in range(3)], -1)
    return g / np.maximum(np.linalg.norm(g, axis=-1, keepdims=True), 1e-12)


def soft_shadow(obj, p, l, k=12.0, steps=48):
    vis = np.ones(p.shape[0], np.float32)
    t = np.full(p.shape[0], 0.01, np.float32)
    act = np.arange(p.shape[0])
    for _ in range(steps):
        if act.size == 0:
            break
        dist = obj.sdf(p[act] + l * t[act, None])
        vis[act] = np.minimum(vis[act], np.clip(k * dist / t[act], 0, 1))
        t[act] += np.clip(dist, 0.005, 0.2)
        act = act[(vis[act] > 0.01) & (t[act] < 3.0)]
    return vis


# ----------------------------------------------------------------------------------------------------------
# materials
# ----------------------------------------------------------------------------------------------------------
METALS = np.array([[1.000, 0.766, 0.336], [0.972, 0.960, 0.915], [0.955, 0.637, 0.538], [0.560, 0.570, 0.580],
                   [0.913, 0.922, 0.924], [0.910, 0.780, 0.420], [0.550, 0.556, 0.554], [0.660, 0.610, 0.530]],
                  np.float32)  # gold, silver, copper, iron, aluminium, brass, chromium, bronze (linear F0)


MODE_P = (0.42, 0.2, 0.2, 0.18)   # material modes dielectric / metal / metal mask / worn edges (--mode-probs)
ANODISED = 0.25                   # probability that a metal is a random coloured one, not one of METALS (--anodised)
DARK_STOPS = 3.0                  # --dark-metal: such a metal's F0 times 2^U(-3, 0), down to 1/8 of it


def hsv2rgb(h, s, v):
    i = int(h * 6) % 6
    f = h * 6 - int(h * 6)
    p, q, t = v * (1 - s), v * (1 - f * s), v * (1 - (1 - f) * s)
    return np.array([(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i], np.float32)


def palette(rng, n, floor=0.0):
    """n sRGB colours of one random style; the values v in [0, 1] become floor + (1 - floor) v (--albedo-floor:
    the same draws, a floor for dark colours)."""
    style = rng.choice(["earthy", "vivid", "pastel", "dark", "grey", "mixed"])
    h0 = rng.random()
    cols = []
    for i in range(n):
        h = (h0 + rng.normal(0, 0.08) + (0.5 * i if style == "vivid" and i % 2 else 0)) % 1.0
        if style == "earthy":
            s, v = rng.uniform(0.2, 0.6), rng.uniform(0.2, 0.75)
        elif style == "vivid":
            s, v = rng.uniform(0.6, 1.0), rng.uniform(0.5, 1.0)
        elif style == "pastel":
            s, v = rng.uniform(0.15, 0.4), rng.uniform(0.75, 0.98)
        elif style == "dark":
            s, v = rng.uniform(0.1, 0.7), rng.uniform(0.03, 0.3)
        elif style == "grey":
            s, v = rng.uniform(0, 0.08), rng.uniform(0.05, 0.95)
        else:
            s, v = rng.uniform(0, 1), rng.uniform(0.05, 1)
        v = floor + (1 - floor) * v
        cols.append(hsv2rgb(h, s, v))
    return np.array(cols)  # sRGB-space colours


# photographic albedo (--photo P): crops of the training environment maps themselves (CC0 Poly Haven, the only
# images this generator may use), tone mapped to 8-bit-like sRGB and squeezed into the albedo range, projected
# on the object along a random axis.  Natural-image texture statistics (grain, foliage, stone, wood, sky
# gradients) that the procedural patterns lack.  Drawn from a stream of their own (the material's seed), so
# --photo 0 leaves every other draw, hence every earlier data set, unchanged.
_PHOTOS = {}


def photo_textures(paths):
    """The training maps as LDR sRGB textures (H x W x 3, float32), cached per process."""
    key = tuple(paths)
    if key not in _PHOTOS:
        out = []
        for p in paths:
            hdr = R.read_hdr(p).astype(np.float32)
            lum = R.luminance(hdr)
            h = hdr.shape[0]
            band = lum[int(0.15 * h):int(0.95 * h)]   # the rows crops come from (no poles); white at their 97th percentile
            white = float(np.percentile(band, 97)) + 1e-6
            out.append(R.srgb_encode(np.clip(hdr / white, 0, 1)).astype(np.float32))
        _PHOTOS[key] = out
    return _PHOTOS[key]


def make_photo(m, photos, floor):
    """Parameters of a photographic albedo for material m (its own stream)."""
    r = np.random.default_rng([m["seed"], 0x70686f])
    tex = photos[int(r.integers(len(photos)))]
    h, w = tex.shape[:2]
    size = int(r.uniform(0.12, 0.45) * h)                       # crop side in texels
    y0 = int(r.uniform(0.15 * h, 0.95 * h - size))
    x0 = int(r.integers(w - size))
    crop = tex[y0:y0 + size, x0:x0 + size]
    a = r.normal(size=3)
    a /= np.linalg.norm(a)
    b = np.cross(a, r.normal(size=3))
    b /= np.linalg.norm(b)
    c = np.cross(a, b)                                          # b, c: the projection plane (normal a)
    lo = floor + (1 - floor) * r.uniform(0.03, 0.15)
    hi = r.uniform(0.75, 0.95)
    return {"crop": crop, "axes": np.stack([b, c]).astype(np.float32), "scale": float(r.uniform(0.35, 1.0)),
            "off": r.uniform(0, 1, 2).astype(np.float32),
            # colour: the chroma plane turned by a random angle half the time, saturation scaled, a tint a quarter
            "hue": float(r.uniform(0, 2 * np.pi)) if r.random() < 0.5 else 0.0,
            "sat": float(r.uniform(0.7, 1.8)), "lo": float(lo), "hi": float(hi),
            "tint": hsv2rgb(r.random(), r.uniform(0.2, 0.7), 1.0) if r.random() < 0.25 else None,
            "rough_k": float(r.uniform(-0.5, 0.5))}


def eval_photo(ph, q):
    """sRGB albedo N x 3 and a luminance-like field N of photo ph at object-space points q (bilinear, mirrored
    repeat)."""
    crop = ph["crop"]
    n = crop.shape[0]
    uv = (q @ ph["axes"].T) * ph["scale"] * 0.5 + ph["off"]
    uv = np.abs(((uv % 2) + 2) % 2 - 1) * (n - 1)              # mirrored repeat, texel units
    i0 = np.floor(uv).astype(np.int64)
    f = (uv - i0).astype(np.float32)
    i0 = np.clip(i0, 0, n - 1)
    i1 = np.clip(i0 + 1, 0, n - 1)
    t = (crop[i0[:, 1], i0[:, 0]] * ((1 - f[:, :1]) * (1 - f[:, 1:])) + crop[i0[:, 1], i1[:, 0]] * (f[:, :1] * (1 - f[:, 1:]))
         + crop[i1[:, 1], i0[:, 0]] * ((1 - f[:, :1]) * f[:, 1:]) + crop[i1[:, 1], i1[:, 0]] * (f[:, :1] * f[:, 1:]))
    y = t.mean(-1, keepdims=True)
    ch = t - y
    if ph["hue"]:
        # rotate the chroma about the grey axis (Rodrigues, unit axis (1,1,1)/sqrt 3)
        k = np.full(3, 1 / np.sqrt(3), np.float32)
        cs, sn = np.cos(ph["hue"]), np.sin(ph["hue"])
        ch = ch * cs + np.cross(k, ch) * sn + k * (ch @ k)[:, None] * (1 - cs)
    t = y + ch * ph["sat"]
    if ph["tint"] is not None:
        t = t * ph["tint"][None]
    t = np.clip(t, 0, 1)
    return (ph["lo"] + (ph["hi"] - ph["lo"]) * t).astype(np.float32), y[:, 0]


def make_material(rng, mode_p=MODE_P, floor=0.0, anodised=ANODISED, photo=0.0, photos=None, dark=0.0, mrough=0.0):
    m = {"pattern": str(rng.choice(["plain", "fbm", "voronoi", "stripes", "checks"], p=[0.15, 0.3, 0.2, 0.2, 0.15])),
         "cols": palette(rng, 3, floor), "seed": int(rng.integers(1 << 20)), "freq": float(rng.uniform(1.5, 8)),
         "dir": rng.normal(size=3).astype(np.float32), "rough": rng.uniform(0.05, 1.0, 2).astype(np.float32),
         "rough_var": float(rng.uniform(0, 0.25)), "mode": str(rng.choice(["dielectric", "metal", "mask", "worn"],
                                                                           p=mode_p)),
         "metal_col": METALS[rng.integers(len(METALS))].copy(), "decals": []}
    m["dir"] /= np.linalg.norm(m["dir"])
    if rng.random() < anodised:  # anodised / coloured metal
        m["metal_col"] = R.srgb_decode(hsv2rgb(rng.random(), rng.uniform(0.3, 0.8), rng.uniform(0.7, 1.0)))
    for _ in range(int(rng.choice([0, 0, 1, 2, 3]))):
        m["decals"].append((rng.normal(size=3).astype(np.float32) * 0.5, float(rng.uniform(0.08, 0.3)),
                            palette(rng, 1, floor)[0], float(rng.uniform(0.1, 0.9))))
    m["photo"] = None
    if photo > 0 and photos and np.random.default_rng([m["seed"], 0x7068]).random() < photo:
        m["photo"] = make_photo(m, photos, floor)
    if dark > 0:   # --dark-metal: a darker F0 (dirt, paint wear, authored base colours), from the material's own stream
        drng = np.random.default_rng([m["seed"], 0x646b])
        if drng.random() < dark:
            m["metal_col"] = (m["metal_col"] * 2.0 ** drng.uniform(-DARK_STOPS, 0)).astype(np.float32)
    m["metal_rough"] = None
    if mrough > 0:  # --metal-rough: the metal of a mask / worn-edge material takes a roughness of its own
        rrng = np.random.default_rng([m["seed"], 0x726d])
        if rrng.random() < mrough:
            m["metal_rough"] = float(rrng.uniform(0.05, 1.0))
    return m


def eval_material(m, q, curv):
    """q: Nx3 object-space points; curv: N curvature proxy. -> linear albedo Nx3, rough N, metal N."""
    n = q.shape[0]
    cols = m["cols"]
    f = m["freq"]
    pat = m["pattern"]
    if pat == "plain":
        t = np.zeros(n, np.float32)
    elif pat == "fbm":
        t = smoothstep(0.35, 0.65, fbm(q * f * 0.5, m["seed"], 5))
    elif pat == "voronoi":
        cid, _, edge = voronoi(q * f * 0.6, m["seed"])
        t = cid
    elif pat == "stripes":
        t = (np.sin((q @ m["dir"]) * f * np.pi) > 0).astype(np.float32)
    else:
        c = np.floor(q * f * 0.5).astype(np.int64).sum(-1)
        t = (c & 1).astype(np.float32)
    if pat == "voronoi":
        idx = np.minimum((t * 3).astype(np.int64), 2)
        alb = cols[idx]
    else:
        alb = cols[0][None] * (1 - t[:, None]) + cols[1][None] * t[:, None]
    grain = fbm(q * 12.0, m["seed"] + 5, 3)
    alb = alb * (0.85 + 0.3 * grain[:, None])
    if m.get("photo") is not None:   # the photo replaces the pattern's colours (its pattern still shapes the rest)
        alb, py = eval_photo(m["photo"], q)
    rnoise = m["rough_var"] * (fbm(q * 4.0, m["seed"] + 7, 4) - 0.5)
    rough = m["rough"][0] * (1 - t) + m["rough"][1] * t + rnoise
    if m.get("photo") is not None:
        rough = rough + m["photo"]["rough_k"] * (py - 0.5)
    metal = np.zeros(n, np.float32)
    mode = m["mode"]
    if mode == "metal":
        metal[:] = 1
    elif mode == "mask":
        metal = (t > 0.5).astype(np.float32) if pat not in ("plain", "voronoi") else \
            (fbm(q * f * 0.4, m["seed"] + 11, 4) > 0.5).astype(np.float32)
    elif mode == "worn":
        wear = (curv + 0.6 * (fbm(q * 6.0, m["seed"] + 13, 4) - 0.5)) > 0.55
        metal = wear.astype(np.float32)
    alb = np.clip(alb, 0, 1)
    alb_lin = R.srgb_decode(alb)
    mc = m["metal_col"] * (0.92 + 0.16 * grain[:, None])
    alb_lin = np.where(metal[:, None] > 0.5, np.clip(mc, 0, 1), alb_lin)
    if mode in ("worn", "mask"):   # --metal-rough: its own level with the same variation; else half the surroundings'
        own = m.get("metal_rough")
        rough = np.where(metal > 0.5, own + rnoise if own is not None else np.clip(rough * 0.5, 0.05, 1), rough)
    for c, r, col, rg in m["decals"]:
        dm = smoothstep(r, r * 0.9, np.linalg.norm(q - c, axis=-1))
        alb_lin = alb_lin * (1 - dm[:, None]) + R.srgb_decode(col)[None] * dm[:, None]
        rough = rough * (1 - dm) + rg * dm
        metal = metal * (1 - (dm > 0.5))
    return alb_lin.astype(np.float32), np.clip(rough, 0.05, 1.0).astype(np.float32), metal


# ----------------------------------------------------------------------------------------------------------
# one sample
# ----------------------------------------------------------------------------------------------------------
def surface(obj, mats, p):
    """Normals and material maps at surface points p (world): no random draws."""
    n = normals(obj, p)
    # curvature proxy: how much the SDF bends around p (mean of 6 offsets), positive on convex edges
    hh = 0.02
    lap = sum(obj.sdf(p + np.eye(3, dtype=np.float32)[i] * s * hh) for i in range(3) for s in (-1, 1)) / 6
    curv = np.clip(lap / hh * 4, -1, 1).astype(np.float32)
    parts = np.stack(obj.sdf_parts(p), -1).argmin(-1)
    q = obj.local(p)
    alb = np.zeros((p.shape[0], 3), np.float32)
    rough = np.zeros(p.shape[0], np.float32)
    metal = np.zeros(p.shape[0], np.float32)
    for k, m in enumerate(mats):
        sel = parts == k
        if sel.any():
            alb[sel], rough[sel], metal[sel] = eval_material(m, q[sel], curv[sel])
    return n, alb, rough, metal


def shade_facing(gb, env, rot):
    """A G-buffer lit as supermat_tools.litbake lights a texture: every pixel as seen along its own normal
    (view-independent; no sun), what `supermat mesh` shows its networks of a lit-baked mesh."""
    out = np.zeros(gb["cov"].shape + (3,), np.float32)
    m = gb["cov"] > 0
    out[m] = R.shade_facing(gb["n"][m].astype(np.float32), gb["albedo"][m], gb["rough"][m], gb["metal"][m], env, rot)
    return out


def render_sample(rng, envs, size, ss=2, mode_p=MODE_P, floor=0.0, anodised=ANODISED, photo=0.0, photos=None,
                  facing=False, dark=0.0, mrough=0.0, assembly=0.0, arng=None):
    obj = Obj(rng)
    mats = [make_material(rng, mode_p, floor, anodised, photo, photos, dark, mrough) for _ in obj.shapes]
    if rng.random() < 0.3:  # one material for the whole group
        mats = [mats[0]] * len(mats)
    if assembly > 0 and arng is not None and arng.random() < assembly:
        # --assembly: an object of parts instead, from a stream of its own (arng), so that the main stream's
        # draws, hence every other sample and every set made without it, stay the same
        obj = Assembly(arng)
        mats = assembly_materials(arng, len(obj.shapes), mode_p, floor, anodised, photo, photos, dark, mrough)
    frame(obj, rng.uniform(0.55, 0.92))
    S = size * ss
    xs = (np.arange(S, dtype=np.float32) + 0.5) / S * 2 - 1
    X, Y = np.meshgrid(xs, -xs)
    o = np.stack([X.ravel(), Y.ravel(), np.full(S * S, 3.0, np.float32)], -1)
    d = np.tile(np.array([0, 0, -1], np.float32), (S * S, 1))
    hit, t = trace(obj, o, d)
    idx = np.nonzero(hit)[0]
    p = o[idx] + d[idx] * t[idx, None]
    n, alb, rough, metal = surface(obj, mats, p)
    gb = {"cov": hit.reshape(S, S).astype(np.float32)}
    for key, val, ch in (("n", n, 3), ("p", p, 3), ("albedo", alb, 3), ("rough", rough, 1), ("metal", metal, 1)):
        a = np.zeros((S * S, ch), np.float32)
        a[idx] = val.reshape(idx.size, ch)
        gb[key] = a.reshape(S, S, ch) if ch == 3 else a.reshape(S, S)
    ei = int(rng.integers(len(envs)))
    env_rot = R.rotation_y(rng.uniform(0, 2 * np.pi)) @ (R.rotation_y(0) if rng.random() < 0.7 else
                                                         _tilt(rng))
    sun = None
    if rng.random() < 0.3:
        ld = rng.normal(size=3)
        ld[2] = abs(ld[2]) + 0.3
        ld = (ld / np.linalg.norm(ld)).astype(np.float32)
        vis = np.zeros(S * S, np.float32)
        if not facing:   # (the draws stay: a facing set has the same objects, materials and maps)
            vis[idx] = soft_shadow(obj, p + n * 2e-3, ld)
        amb = float(R.luminance(envs[ei].irr).mean())
        sun = {"dir": ld, "rgb": np.array([1.0, 0.95, 0.85], np.float32) * amb * rng.uniform(1.0, 4.0),
               "vis": vis.reshape(S, S)}
    lin = shade_facing(gb, envs[ei], env_rot) if facing else R.shade(gb, envs[ei], env_rot, sun)
    # supersample down: colour weighted by coverage (straight alpha), truth likewise
    cov = R.box_down(gb["cov"], ss)
    w = np.maximum(cov, 1e-8)

    def down(a):
        if a.ndim == 2:
            return R.box_down(a * gb["cov"], ss) / w
        return R.box_down(a * gb["cov"][..., None], ss) / w[..., None]

    lin_d = down(lin)
    key = rng.uniform(0.16, 0.32)
    expo = R.auto_exposure(lin_d, cov, key) * float(2 ** rng.normal(0, 0.3))
    wt = rng.uniform(-0.08, 0.08)
    wb = np.array([1 + wt, 1 + rng.uniform(-0.03, 0.03), 1 - wt], np.float32)
    wb /= wb.mean()
    rgb = R.tonemap(lin_d, expo, wb)
    alpha = cov
    rgba = np.concatenate([np.where(alpha[..., None] > 0, rgb, 0), alpha[..., None]], -1)
    nrm = down(gb["n"])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=-1, keepdims=True), 1e-8)
    q8 = lambda x: np.clip(np.round(x * 255), 0, 255).astype(np.uint8)  # noqa: E731
    return {"rgba": q8(rgba), "albedo": q8(R.srgb_encode(down(gb["albedo"])) * (alpha[..., None] > 0)),
            "rough": q8(down(gb["rough"]) * (alpha > 0)), "metal": q8(down(gb["metal"]) * (alpha > 0)),
            "normal": (nrm * (alpha[..., None] > 0)).astype(np.float16), "env": ei, "env_rot": env_rot,
            "exposure": np.float32(expo), "wb": wb}


# ----------------------------------------------------------------------------------------------------------
# the six official views (SuperMatMV): supermat_uv.h's cameras and view frame
# ----------------------------------------------------------------------------------------------------------
ORTHO_HALF_WIDTH = 1.1                      # supermat_uv.h: the views cover [-1.1, 1.1] of the view frame
Z_UP_TO_MAP = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], np.float32)   # world (Z up) -> map (Y up)


def official_cameras():
    """The six camera-to-world matrices (4x4, float64) as supermat_uv.h holds them (read from that file,
    so that the data and the runtime never disagree): columns X, Y, Z (the camera looks down -Z, +Y up)
    and the translation."""
    path = os.path.join(REPO, "supermat_uv.h")
    with open(path) as f:
        text = f.read()
    body = text[text.index("supermat_uv__cam[SUPERMAT_UV_VIEWS][16] = {"):]
    body = body[body.index("{") + 1:body.index("};")]
    rows = [r for r in body.replace("\n", " ").split("}") if "{" in r]
    cams = np.array([[float(v) for v in r[r.index("{") + 1:].split(",") if v.strip()] for r in rows])
    if cams.shape != (6, 16):
        raise SystemExit(f"gen_data: {path}: cannot read the six cameras ({cams.shape})")
    return cams.reshape(6, 4, 4)


def view_frame(obj, passes=((64, 1.3), (128, 1.05))):
    """Move and scale the object into supermat_uv.h's view frame: its bounding box centred, its largest
    half extent 1.  The box comes from silhouettes traced along -Z and -Y (the SDF has no vertices), each
    side widened by half a pixel: within 1.05 / 128 of the true extent after the second pass."""
    for n, half in passes:
        xs = (np.arange(n, dtype=np.float32) + 0.5) / n * 2 * half - half
        A, B = np.meshgrid(xs, xs)
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for axis in (2, 1):
            other = [a for a in range(3) if a != axis]
            o = np.zeros((n * n, 3), np.float32)
            o[:, other[0]], o[:, other[1]], o[:, axis] = A.ravel(), B.ravel(), 3.0
            d = np.zeros((n * n, 3), np.float32)
            d[:, axis] = -1
            hit, _ = trace(obj, o, d, steps=64, eps=1e-3)
            if not hit.any():
                return False
            for k in other:
                lo[k] = min(lo[k], o[hit, k].min() - half / n)
                hi[k] = max(hi[k], o[hit, k].max() + half / n)
        c = (lo + hi) / 2
        f = 1.0 / max(float((hi - lo).max()) / 2, 1e-3)
        obj.center = ((obj.center - c) * f).astype(np.float32)
        obj.scale *= f
    return True


def render_views(rng, envs, size, ss=2, mode_p=MODE_P, floor=0.0, anodised=ANODISED, photo=0.0, photos=None,
                 keep_pos=False, facing=False, dark=0.0, mrough=0.0):
    """One object in the six official views under one world-fixed lighting (the map, its rotation about
    the world's up axis, a sun and its shadows, one exposure and white balance for all six): the arrays
    of render_sample with a leading view axis, normals in each view's camera frame, and `cams` (6x4x4,
    the camera-to-world matrices).  The object: render_sample's draws, then the view frame (above)."""
    obj = Obj(rng)
    mats = [make_material(rng, mode_p, floor, anodised, photo, photos, dark, mrough) for _ in obj.shapes]
    if rng.random() < 0.3:
        mats = [mats[0]] * len(mats)
    if not view_frame(obj):
        return None
    cams = official_cameras()
    ei = int(rng.integers(len(envs)))
    env_rot = R.rotation_y(rng.uniform(0, 2 * np.pi)) @ (R.rotation_y(0) if rng.random() < 0.7 else _tilt(rng))
    rot_world = (env_rot @ Z_UP_TO_MAP).astype(np.float32)
    sun = None
    if rng.random() < 0.3:
        ld = rng.normal(size=3)
        ld[2] = abs(ld[2]) + 0.3                               # from above (world Z up)
        sun = dict(dir=(ld / np.linalg.norm(ld)).astype(np.float32),
                   rgb=np.array([1.0, 0.95, 0.85], np.float32) * float(R.luminance(envs[ei].irr).mean())
                   * rng.uniform(1.0, 4.0))
    S = size * ss
    xs = ((np.arange(S, dtype=np.float32) + 0.5) / S * 2 - 1) * ORTHO_HALF_WIDTH
    Xc, Yc = (a.ravel() for a in np.meshgrid(xs, -xs))
    views = []
    for cam in cams:
        Rc = cam[:3, :3].astype(np.float32)                      # columns: the camera's X, Y, Z in the world
        T = cam[:3, 3].astype(np.float32)
        o = T + Xc[:, None] * Rc[:, 0] + Yc[:, None] * Rc[:, 1] + 3.0 * Rc[:, 2]
        d = np.tile(-Rc[:, 2], (S * S, 1))
        hit, t = trace(obj, o, d, tmax=8.0)
        idx = np.nonzero(hit)[0]
        p = o[idx] + d[idx] * t[idx, None]
        n, alb, rough, metal = surface(obj, mats, p)
        gb = {"cov": hit.reshape(S, S).astype(np.float32)}
        for key, val, ch in (("n", n @ Rc, 3), ("p", p, 3), ("albedo", alb, 3), ("rough", rough, 1),
                             ("metal", metal, 1)):
            a = np.zeros((S * S, ch), np.float32)
            a[idx] = val.reshape(idx.size, ch)
            gb[key] = a.reshape(S, S, ch) if ch == 3 else a.reshape(S, S)
        sun_v = None
        if sun is not None and not facing:
            vis = np.zeros(S * S, np.float32)
            vis[idx] = soft_shadow(obj, p + n * 2e-3, sun["dir"])
            sun_v = dict(dir=sun["dir"] @ Rc, rgb=sun["rgb"], vis=vis.reshape(S, S))
        lin = shade_facing(gb, envs[ei], rot_world @ Rc) if facing else R.shade(gb, envs[ei], rot_world @ Rc, sun_v)
        cov = R.box_down(gb["cov"], ss)
        w = np.maximum(cov, 1e-8)

        def down(a, gb=gb, w=w):
            if a.ndim == 2:
                return R.box_down(a * gb["cov"], ss) / w
            return R.box_down(a * gb["cov"][..., None], ss) / w[..., None]
        views.append(dict(lin=down(lin), cov=cov, gb=gb, down=down))
    key = rng.uniform(0.16, 0.32)
    lin_all = np.concatenate([v["lin"] for v in views], 0)
    cov_all = np.concatenate([v["cov"] for v in views], 0)
    expo = R.auto_exposure(lin_all, cov_all, key) * float(2 ** rng.normal(0, 0.3))
    wt = rng.uniform(-0.08, 0.08)
    wb = np.array([1 + wt, 1 + rng.uniform(-0.03, 0.03), 1 - wt], np.float32)
    wb /= wb.mean()
    q8 = lambda x: np.clip(np.round(x * 255), 0, 255).astype(np.uint8)  # noqa: E731
    out = {k: [] for k in ("rgba", "albedo", "rough", "metal", "normal") + (("pos",) if keep_pos else ())}
    for v in views:
        alpha, down, gb = v["cov"], v["down"], v["gb"]
        rgb = R.tonemap(v["lin"], expo, wb)
        out["rgba"].append(q8(np.concatenate([np.where(alpha[..., None] > 0, rgb, 0), alpha[..., None]], -1)))
        out["albedo"].append(q8(R.srgb_encode(down(gb["albedo"])) * (alpha[..., None] > 0)))
        out["rough"].append(q8(down(gb["rough"]) * (alpha > 0)))
        out["metal"].append(q8(down(gb["metal"]) * (alpha > 0)))
        nrm = down(gb["n"])
        nrm /= np.maximum(np.linalg.norm(nrm, axis=-1, keepdims=True), 1e-8)
        out["normal"].append((nrm * (alpha[..., None] > 0)).astype(np.float16))
        if keep_pos:
            out["pos"].append(down(gb["p"]))
    out = {k: np.stack(a) for k, a in out.items()}
    out.update(cams=cams.astype(np.float32), env=ei, env_rot=env_rot, exposure=np.float32(expo), wb=wb)
    return out


def _tilt(rng):
    a = rng.uniform(-0.3, 0.3)
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], np.float32)


def env_paths(hdri_dir):
    names = sorted(f for f in os.listdir(hdri_dir) if f.endswith(".hdr"))
    train = [f for f in names if f[:-4] not in HELD_OUT]
    if not train:
        raise SystemExit(f"gen_data: no training .hdr maps in {hdri_dir}")
    return [os.path.join(hdri_dir, f) for f in train]


def make_shard(args, shard):
    path = os.path.join(args.out, f"shard_{shard:04d}.npz")
    if os.path.exists(path):
        return path, 0.0
    t0 = time.time()
    envs = [R.EnvLight(p) for p in env_paths(args.hdri_dir)]
    photos = photo_textures(env_paths(args.hdri_dir)) if args.photo > 0 else None
    R.brdf_lut()
    samples = []
    first = shard * args.shard
    for i in range(first, min(first + args.shard, args.count)):
        rng = np.random.default_rng([args.seed, i])
        # --assembly's own stream, made once per sample so that a retry draws another object from it too
        extra = {} if args.views == 6 else {"assembly": args.assembly,
                                              "arng": np.random.default_rng([args.seed, i, 0x6173])}
        for _ in range(8):  # an object that misses the frame (rare) is drawn again from the same stream
            render = render_views if args.views == 6 else render_sample
            s = render(rng, envs, args.size, mode_p=args.mode_probs, floor=args.albedo_floor,
                       anodised=args.anodised, photo=args.photo, photos=photos, facing=args.shading == "facing",
                       dark=args.dark_metal, mrough=args.metal_rough, **extra)
            if s is not None and s["rgba"][..., 3].astype(np.float32).mean() > 0.05 * 255:
                break
        samples.append(s)
    out = {k: np.stack([s[k] for s in samples]) for k in samples[0]}
    tmp = path + ".tmp.npz"
    np.savez(tmp, **out)
    os.replace(tmp, path)
    return path, time.time() - t0


def write_examples(args):
    """Pictures for the demo: <out>/objNN.png (RGBA) and objNN_gt_albedo/_gt_roughness/_gt_metallic.png."""
    from PIL import Image
    env = R.EnvLight(os.path.join(args.hdri_dir, args.example_env + ".hdr"))
    for i in range(args.count):
        rng = np.random.default_rng([args.seed, 1 << 30, i])   # a stream no training sample uses
        s = render_sample(rng, [env], args.size, mode_p=args.mode_probs, floor=args.albedo_floor,
                          anodised=args.anodised, photo=args.photo, dark=args.dark_metal, mrough=args.metal_rough,
                          photos=photo_textures(env_paths(args.hdri_dir)) if args.photo > 0 else None)
        stem = os.path.join(args.out, f"obj{i:02d}")
        Image.fromarray(s["rgba"]).save(stem + ".png")
        Image.fromarray(s["albedo"]).save(stem + "_gt_albedo.png")
        Image.fromarray(s["rough"]).save(stem + "_gt_roughness.png")
        Image.fromarray(s["metal"]).save(stem + "_gt_metallic.png")
        print(stem + ".png", flush=True)


def _make_shard_star(a):
    return make_shard(*a)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hdri-dir", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--count", type=int, default=4000)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--shard", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--examples", action="store_true",
                    help="write --count PNG pictures + truth maps into --out instead of shards, lit by the "
                         "held-out map --example-env (for the demo and README)")
    ap.add_argument("--example-env", default=HELD_OUT[0])
    ap.add_argument("--mode-probs", default="0.42,0.2,0.2,0.18",
                    help="probabilities of the material modes dielectric, metal, metal mask, worn edges (the same "
                         "random draws: only the modes change)")
    ap.add_argument("--albedo-floor", type=float, default=0.0,
                    help="lowest palette value (HSV V, sRGB): values v become floor + (1 - floor) v, the same draws "
                         "(PBR charts put dielectric albedo at 30-240 of 255 sRGB; 0.12 = 31)")
    ap.add_argument("--anodised", type=float, default=0.25,
                    help="probability that a metal is a random coloured (anodised) one (default 0.25)")
    ap.add_argument("--dark-metal", type=float, default=0.0,
                    help="probability that a metal's F0 colour is darkened, times 2^U(-3, 0) in linear light (real "
                         "assets author metal base colours of 0.3-0.55 sRGB, the F0 table's start at 0.77; default 0)")
    ap.add_argument("--metal-rough", type=float, default=0.0,
                    help="probability that the metal of a masked-metal or worn-edge material takes a roughness of its "
                         "own, U(0.05, 1), instead of half its surroundings' (which makes the metal the smoother part "
                         "in 95 %% of such materials; default 0)")
    ap.add_argument("--views", type=int, default=1, choices=(1, 6),
                    help="6: each sample is one object in the six official SuperMatMV views (supermat_uv.h's "
                         "cameras and view frame, Z up), lit alike; arrays gain a view axis, plus cams [6x4x4]")
    ap.add_argument("--shading", default="camera", choices=("camera", "facing"),
                    help="camera: rendered as a camera sees it (view-dependent reflections, a sun); facing: every "
                         "point as seen along its own normal, as supermat_tools.litbake bakes a texture, which `supermat "
                         "mesh` then shows its networks (the lit-baked inputs the mesh pipeline expects)")
    ap.add_argument("--photo", type=float, default=0.0,
                    help="probability that a material's albedo is a photographic crop of a training environment map "
                         "(hue-turned and resaturated at random; default 0: the procedural palettes only)")
    ap.add_argument("--assembly", type=float, default=0.0,
                    help="probability that an object is an assembly of 3-7 parts (lathes, cylinders, boxes, ...), most "
                         "with a material of their own, drawn from a stream of its own (default 0: the earlier sets)")
    args = ap.parse_args()
    if not 0 <= args.assembly <= 1 or (args.assembly > 0 and args.views == 6):
        raise SystemExit("gen_data: --assembly wants [0, 1], single views only")
    if not 0 <= args.albedo_floor < 1 or not 0 <= args.anodised <= 1 or not 0 <= args.photo <= 1 or \
            not 0 <= args.dark_metal <= 1 or not 0 <= args.metal_rough <= 1:
        raise SystemExit("gen_data: --albedo-floor wants [0, 1), --anodised, --photo, --dark-metal and --metal-rough [0, 1]")
    args.mode_probs = [float(v) for v in args.mode_probs.split(",")]
    if len(args.mode_probs) != 4 or min(args.mode_probs) < 0 or abs(sum(args.mode_probs) - 1) > 1e-6:
        raise SystemExit("gen_data: --mode-probs wants four probabilities that sum to 1")
    os.makedirs(args.out, exist_ok=True)
    if args.examples:
        if args.views != 1:
            raise SystemExit("gen_data: --examples writes single-view pictures (no --views 6)")
        write_examples(args)
        return
    paths = env_paths(args.hdri_dir)
    for p in paths:  # prefilter once (cached beside the map) before the workers start
        R.EnvLight(p)
    meta = {"size": args.size, "count": args.count, "seed": args.seed, "shard": args.shard, "mode_probs": args.mode_probs,
            "albedo_floor": args.albedo_floor, "anodised": args.anodised, "photo": args.photo, "dark_metal": args.dark_metal, "metal_rough": args.metal_rough, "assembly": args.assembly, "views": args.views, "shading": args.shading,
            "envs": [os.path.basename(p) for p in paths], "hdri_dir": os.path.abspath(args.hdri_dir), "held_out": list(HELD_OUT)}
    with open(os.path.join(args.out, "meta.json"), "w") as f:
        json.dump(meta, f, indent=1)
    shards = list(range((args.count + args.shard - 1) // args.shard))
    t0 = time.time()
    made = 0
    if args.jobs > 1:
        from multiprocessing import Pool
        with Pool(args.jobs) as pool:
            for path, sec in pool.imap_unordered(_make_shard_star, [(args, s) for s in shards]):
                made += sec > 0
                print(f"{path} {sec:.1f} s", flush=True)
    else:
        for s in shards:
            path, sec = make_shard(args, s)
            made += sec > 0
            print(f"{path} {sec:.1f} s", flush=True)
    wall = time.time() - t0
    # dataset statistics over object pixels (the evaluation's "dataset mean" baseline)
    acc = {"albedo": np.zeros(3), "rough": 0.0, "metal": 0.0, "n": 0}
    for s in shards:
        z = np.load(os.path.join(args.out, f"shard_{s:04d}.npz"))
        m = z["rgba"][..., 3] >= 128
        acc["albedo"] += z["albedo"][m].astype(np.float64).sum(0) / 255
        acc["rough"] += z["rough"][m].astype(np.float64).sum() / 255
        acc["metal"] += z["metal"][m].astype(np.float64).sum() / 255
        acc["n"] += int(m.sum())
    stats = {"albedo_srgb_mean": (acc["albedo"] / acc["n"]).tolist(), "rough_mean": acc["rough"] / acc["n"],
             "metal_mean": acc["metal"] / acc["n"], "pixels": acc["n"], "samples": args.count,
             "seconds_this_run": wall, "shards_made": made, "jobs": args.jobs,
             "seconds_per_1000": (wall / max(made * args.shard, 1)) * 1000 if made else None}
    with open(os.path.join(args.out, "stats.json"), "w") as f:
        json.dump(stats, f, indent=1)
    print(json.dumps(stats))


if __name__ == "__main__":
    main()
