#!/usr/bin/env python3
"""The demo's example mesh (examples/mesh/): a procedural PBR asset of our own, lit-baked for `supermat mesh`.

A torus and a sphere side by side (Y up, glTF), one material, one texture atlas (the torus in the left half of
the UV square, the sphere in the right half; seams where the angles wrap), their albedo / roughness / metallic
drawn with supermat_tools.gen_data's procedural materials (seeded) at each texel's own 3D point. Writes into OUT:

  example_pbr.gltf (+ .bin, _baseColor.png, _metallicRoughness.png)   the PBR asset (the truth)
  lit/                                                                 supermat_tools.litbake's output: example_pbr_lit.gltf
                                                                       (the input `supermat mesh` expects: lighting
                                                                       baked into the base colour), the truth textures,
                                                                       the chart mask

  PYTHONPATH=python /usr/bin/python3 -m supermat_tools.make_example_mesh --hdri-dir HDRI --out examples/mesh [--size 256] [--seed 7]

Lighting: HDRI/venice_sunset_1k.hdr (CC0 Poly Haven, pmndrs/drei-assets), a map no training render used.
Needs python3-numpy, -scipy, -pil.
"""
import argparse
import json
import os
import sys

import numpy as np
from PIL import Image

from supermat_tools import gen_data as G
from supermat_tools import smrender as R
from supermat_tools.common import run_tool

TORUS_R, TORUS_r, TORUS_C = 0.55, 0.25, np.array([-0.55, 0.0, 0.0])
SPHERE_R, SPHERE_C = 0.45, np.array([0.75, 0.0, 0.0])


def torus(u, v):
    """u, v in [0, 1] -> point, normal (the tube's angle v, the ring's angle u; the ring in the XZ plane)."""
    a, b = 2 * np.pi * u, 2 * np.pi * v
    n = np.stack([np.cos(b) * np.cos(a), np.sin(b), np.cos(b) * np.sin(a)], -1)
    ring = np.stack([np.cos(a), np.zeros_like(a), np.sin(a)], -1) * TORUS_R
    return TORUS_C + ring + TORUS_r * n, n


def sphere(u, v):
    a, b = 2 * np.pi * u, np.pi * (v - 0.5)
    n = np.stack([np.cos(b) * np.cos(a), np.sin(b), np.cos(b) * np.sin(a)], -1)
    return SPHERE_C + SPHERE_R * n, n


# each part: (surface function, the UV rectangle it maps to: u0, u1, v0, v1, inset so the charts keep a gap)
PARTS = ((torus, (0.02, 0.48, 0.02, 0.98)), (sphere, (0.52, 0.98, 0.02, 0.98)))


def grid(fn, rect, nu, nv):
    u0, u1, v0, v1 = rect
    su, sv = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1))
    p, n = fn(su, sv)
    uv = np.stack([u0 + su * (u1 - u0), v0 + sv * (v1 - v0)], -1)
    idx = []
    for j in range(nv):
        for i in range(nu):
            a = j * (nu + 1) + i
            b, c, d = a + 1, a + nu + 2, a + nu + 1
            idx += [a, c, b, a, d, c] if fn is torus else [a, b, c, a, c, d]
    return p.reshape(-1, 3), n.reshape(-1, 3), uv.reshape(-1, 2), np.asarray(idx, np.uint32)


def textures(size, rng):
    """albedo (linear), roughness, metallic at every texel of the atlas, from gen_data's materials evaluated
    at the texel's 3D point (object space, the asset scaled into the unit box the materials expect)."""
    alb = np.full((size, size, 3), 0.5, np.float32)
    rough = np.full((size, size), 0.5, np.float32)
    metal = np.zeros((size, size), np.float32)
    c = (np.arange(size) + 0.5) / size
    U, V = np.meshgrid(c, c)
    for k, (fn, (u0, u1, v0, v1)) in enumerate(PARTS):
        m = G.make_material(rng, photo=0.0)
        sel = (U >= u0 - 0.01) & (U <= u1 + 0.01) & (V >= v0 - 0.01) & (V <= v1 + 0.01)   # a little past the chart
        su = np.clip((U[sel] - u0) / (u1 - u0), 0, 1)
        sv = np.clip((V[sel] - v0) / (v1 - v0), 0, 1)
        p, _ = fn(su, sv)
        a, r, mt = G.eval_material(m, (p / 1.3).astype(np.float32), np.zeros(len(p), np.float32))
        alb[sel], rough[sel], metal[sel] = a, r, mt
    return alb, rough, metal


def write_pbr_gltf(out, name, pos, nrm, uv, idx, alb, rough, metal, generator="supermat supermat_tools.make_example_mesh"):
    """One mesh, one material: OUT/NAME.gltf + .bin + _baseColor.png (sRGB of the linear albedo) +
    _metallicRoughness.png (G roughness, B metallic). Also supermat_tools.gen_refine_data's writer."""
    blobs = [pos.tobytes(), nrm.tobytes(), uv.tobytes(), idx.tobytes()]
    views, o = [], 0
    for b in blobs:
        views.append({"buffer": 0, "byteOffset": o, "byteLength": len(b)})
        o += len(b)
    with open(os.path.join(out, name + ".bin"), "wb") as f:
        f.write(b"".join(blobs))
    q8 = lambda x: np.clip(np.round(x * 255), 0, 255).astype(np.uint8)  # noqa: E731
    Image.fromarray(q8(R.srgb_encode(alb))).save(os.path.join(out, name + "_baseColor.png"))
    Image.fromarray(q8(np.stack([np.ones_like(rough), rough, metal], -1))).save(os.path.join(out, name + "_metallicRoughness.png"))
    g = {"asset": {"version": "2.0", "generator": generator},
         "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "example"}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                     "material": 0}]}],
         "materials": [{"name": "example", "pbrMetallicRoughness": {
             "baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1}}}],
         "samplers": [{"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}],
         "images": [{"uri": name + "_baseColor.png"}, {"uri": name + "_metallicRoughness.png"}],
         "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}],
         "buffers": [{"uri": name + ".bin", "byteLength": o}], "bufferViews": views,
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3",
                        "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
                       {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC3"},
                       {"bufferView": 2, "componentType": 5126, "count": len(pos), "type": "VEC2"},
                       {"bufferView": 3, "componentType": 5125, "count": len(idx), "type": "SCALAR"}]}
    path = os.path.join(out, name + ".gltf")
    with open(path, "w") as f:
        json.dump(g, f, indent=1)
    return path


def write_gltf(out, name, size, rng):
    parts = [grid(fn, rect, 64, 32) for fn, rect in PARTS]
    pos = np.concatenate([p[0] for p in parts]).astype(np.float32)
    nrm = np.concatenate([p[1] for p in parts]).astype(np.float32)
    uv = np.concatenate([p[2] for p in parts]).astype(np.float32)
    off, idx = 0, []
    for p in parts:
        idx.append(p[3] + off)
        off += len(p[0])
    idx = np.concatenate(idx).astype(np.uint32)
    return write_pbr_gltf(out, name, pos, nrm, uv, idx, *textures(size, rng))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hdri-dir", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    path = write_gltf(args.out, "example_pbr", args.size, np.random.default_rng([args.seed, 77]))
    r = run_tool("litbake", path, os.path.join(args.out, "lit"),
                        "--hdri", os.path.join(args.hdri_dir, "venice_sunset_1k.hdr"), "--size", str(args.size),
                        "--force")
    sys.exit(r.returncode)


if __name__ == "__main__":
    main()
