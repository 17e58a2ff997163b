#!/usr/bin/env python3
"""Lit-baked test inputs for `supermat mesh`: a PBR glTF asset's lit appearance in its own UV space.

The mesh pipeline expects what scans and texture generators give: a mesh whose base-colour texture has the
lighting baked in.  This tool makes such an input from a PBR glTF asset whose true maps are known, and keeps
those maps as the truth to measure a bake against:

  1. loads the asset with supermat_tools.eval_quality's loader (every triangle of the default scene, or of the
     node FILE.gltf#NODE names; node transforms applied; one material for all of it, TEXCOORD_0 its UVs);
  2. rasterises the triangles in UV space onto SIZE x SIZE texels (texel centres; where UV charts overlap
     the first triangle wins; a triangle whose centroid lies in another UV tile, e.g. v in [1, 2], is moved
     into [0, 1] by whole tiles, as a repeating texture reads it; one crossing a tile's edge is cut there);
  3. at each covered texel: the world position's interpolated normal, the material's base colour
     (factor x texture, linear), roughness and metallic (factors x the G / B channels), each texture read
     with the mip level of one output texel;
  4. shades it with smrender (Cook-Torrance GGX, Smith, Schlick + Lambert, split-sum prefiltered
     environment map: the training data's shading), the viewer along the texel's own normal (what a camera
     facing that spot sees: the diffuse part and the specular reflection at normal incidence), under the
     environment map --hdri turned by --env-angle degrees about +Y (normal maps, occlusion, emission and
     shadows ignored);
  5. exposes it (--exposure: a factor, or auto: key --key on the median luminance of the covered texels,
     the recipe of the training pictures), tone maps it as a renderer's "Standard" view (clip, sRGB) and
     spreads the covered texels --gutter texels into the empty ones (nearest covered texel), so that
     bilinear reads across a chart's edge stay on the surface.

Writes into OUT_DIR (created if missing), each file as FILE.tmp renamed into place when complete; an
existing file is not replaced without --force (exit 1 before any work):
  NAME_lit.gltf                the asset with one unlit-looking material: the lit bake as base colour,
                               metallic 0, roughness 1, no other texture; its buffers copied beside it
  NAME_lit_baseColor.png       the lit bake (sRGB 8-bit RGB)
  NAME_truth_albedo.png        the true base colour (sRGB 8-bit, the glTF convention), same texels
  NAME_truth_roughness.png     true roughness, linear 8-bit gray
  NAME_truth_metallic.png      true metallic, linear 8-bit gray
  NAME_mask.png                255 where a triangle covers the texel centre, else 0
where NAME is the asset's file name without extension (or NODE).  Exit status 0 ok, 1 error (message on
stderr), 2 usage.

  supermat_tools.litbake WaterBottle.gltf out/ --hdri venice_sunset_1k.hdr --size 1024
"""
import argparse
import copy
import json
import os
import shutil
import sys
import urllib.parse

import numpy as np
from PIL import Image
from scipy import ndimage

from supermat_tools import smrender as smr
from supermat_tools import eval_quality as evq
from supermat_tools.common import split_asset


def uv_gbuffer(mesh, size):
    """Per texel of a size x size texture: coverage, world normal and the material's true maps."""
    if len(np.unique(mesh.mat)) != 1:
        raise ValueError(f"{mesh.name}: {len(np.unique(mesh.mat))} materials; one material for every "
                         "triangle is what a single set of UV textures can hold")
    uv = mesh.UV
    duv1, duv2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    if not np.any(np.abs(duv1[:, 0] * duv2[:, 1] - duv2[:, 0] * duv1[:, 1]) > 1e-12):
        raise ValueError(f"{mesh.name}: no UV layout (TEXCOORD_0 missing or of zero area)")
    tile = np.floor(uv.mean(1, keepdims=True))                 # a triangle in UV tile (i, j) is baked into
    tri, bary = evq.rasterize((uv - tile) * size, np.zeros(uv.shape[:2]), size)   # [0, 1]: repeating textures
    hit = tri >= 0
    if not hit.any():
        raise ValueError(f"{mesh.name}: no texel centre inside a UV triangle at {size}x{size}")
    t, b = tri[hit], bary[hit][..., None]
    n = (mesh.N[t] * b).sum(1)
    g = np.cross(mesh.P[t, 1] - mesh.P[t, 0], mesh.P[t, 2] - mesh.P[t, 0])
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-30)
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(ln > 1e-12, n / np.maximum(ln, 1e-30), g)
    mat = mesh.materials[int(mesh.mat[0])]
    tuv = (uv[t] * b).sum(1)
    albedo = np.broadcast_to(mat["base_factor"], (len(t), 3)).astype(np.float32)
    rough = np.full(len(t), mat["rough"], np.float32)
    metal = np.full(len(t), mat["metal"], np.float32)
    if mat["base_tex"] is not None:
        tex = mat["base_tex"]
        albedo = albedo * tex.sample(tuv, np.full(len(t), 0.5 * tex.log2_texels() - np.log2(size)))
    if mat["mr_tex"] is not None:
        tex = mat["mr_tex"]
        rm = tex.sample(tuv, np.full(len(t), 0.5 * tex.log2_texels() - np.log2(size)))
        rough, metal = rough * rm[:, 0], metal * rm[:, 1]
    return dict(hit=hit, n=n.astype(np.float32), albedo=np.clip(albedo, 0, 1),
                rough=np.clip(rough, 0, 1), metal=np.clip(metal, 0, 1))


shade_facing = smr.shade_facing   # (in smrender: gen_data.py --shading facing renders with it too)


def spread(img, hit, gutter):
    """Copy the nearest covered texel into the empty texels within `gutter` texels of the surface."""
    if gutter <= 0:
        return img
    dist, idx = ndimage.distance_transform_edt(~hit, return_indices=True)
    near = (~hit) & (dist <= gutter)
    out = img.copy()
    out[near] = img[idx[0][near], idx[1][near]]
    return out


def lit_gltf(mesh_path, node, base_png, out_dir):
    """The asset's JSON with one material: the lit bake as base colour, metallic 0, roughness 1."""
    with open(mesh_path) as f:
        g = json.load(f)
    src_dir = os.path.dirname(os.path.abspath(mesh_path))
    g = copy.deepcopy(g)
    if node is not None:
        idx = [i for i, n in enumerate(g["nodes"]) if n.get("name") == node]
        g["scenes"] = [{"nodes": idx}]
        g["scene"] = 0
    g["images"] = [{"uri": urllib.parse.quote(base_png)}]
    g["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]   # repeat: see 2.
    g["textures"] = [{"sampler": 0, "source": 0}]
    g["materials"] = [{"name": "lit_bake", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": 0, "texCoord": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0}}]
    for m in g.get("meshes", []):
        for p in m["primitives"]:
            p["material"] = 0
    for key in ("extensionsUsed", "extensionsRequired"):
        if key in g:
            g[key] = [e for e in g[key] if not e.startswith(("KHR_materials_", "KHR_texture_"))]
            if not g[key]:
                del g[key]
    copies = []
    for b in g.get("buffers", []):
        uri = b.get("uri", "")
        if uri and not uri.startswith("data:"):
            copies.append((os.path.join(src_dir, urllib.parse.unquote(uri)),
                           os.path.join(out_dir, os.path.basename(urllib.parse.unquote(uri)))))
            b["uri"] = urllib.parse.quote(os.path.basename(urllib.parse.unquote(uri)))
    return g, copies


def write_atomic(path, write):
    tmp = path + ".tmp"
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("asset", help="a .gltf file, or FILE.gltf#NODE")
    ap.add_argument("out_dir")
    ap.add_argument("--hdri", required=True, help="a Radiance .hdr environment map")
    ap.add_argument("--env-angle", type=float, default=0.0, help="the map turned about +Y, degrees")
    ap.add_argument("--size", type=int, default=1024, help="texture size (default 1024)")
    ap.add_argument("--exposure", default="auto", help="auto, or a factor (1: radiance 1 is white)")
    ap.add_argument("--key", type=float, default=0.18, help="auto exposure: the median luminance's target")
    ap.add_argument("--gutter", type=int, default=16,
                    help="texels spread beyond each chart (default 16: mip levels up to 4 stay on the surface)")
    ap.add_argument("--force", action="store_true", help="replace existing output files")
    args = ap.parse_args()
    if not 8 <= args.size <= 16384:
        ap.error("--size must be in 8..16384")
    if args.exposure != "auto":
        try:
            expo = float(args.exposure)
        except ValueError:
            ap.error(f"--exposure: auto or a number, not {args.exposure!r}")
        if not np.isfinite(expo) or expo <= 0:
            ap.error("--exposure must be positive")
    if not (np.isfinite(args.key) and args.key > 0) or args.gutter < 0:
        ap.error("--key must be positive and --gutter >= 0")

    path, node = split_asset(args.asset)
    name = node or os.path.splitext(os.path.basename(path))[0]
    outs = {k: os.path.join(args.out_dir, f"{name}_{k}") for k in (
        "lit.gltf", "lit_baseColor.png", "truth_albedo.png", "truth_roughness.png", "truth_metallic.png",
        "mask.png")}
    try:
        mesh = evq.Mesh(args.asset)
        g, copies = lit_gltf(path, node, os.path.basename(outs["lit_baseColor.png"]), args.out_dir)
        for _, dst in copies:
            outs[dst] = dst
        if not args.force:
            there = [p for p in outs.values() if os.path.lexists(p)]
            if there:
                sys.exit(f"error: {there[0]} exists (--force replaces it)")
        env = smr.EnvLight(args.hdri)
        gb = uv_gbuffer(mesh, args.size)
    except (OSError, ValueError, KeyError, IndexError) as e:
        sys.exit(f"error: {e}")

    hit = gb["hit"].reshape(args.size, args.size)
    a = np.deg2rad(args.env_angle)
    lin = shade_facing(gb["n"], gb["albedo"], gb["rough"], gb["metal"], env, smr.rotation_y(a))
    if args.exposure == "auto":
        expo = args.key / max(float(np.median(smr.luminance(lin))), 1e-6)
    q8 = lambda x: np.clip(np.round(x * 255), 0, 255).astype(np.uint8)  # noqa: E731

    def image(values, channels):
        out = np.zeros((args.size * args.size, channels), np.float32)
        out[hit.ravel()] = values.reshape(-1, channels)
        return out.reshape(args.size, args.size, channels)
    lit = spread(image(smr.tonemap(lin, expo, (1, 1, 1)), 3), hit, args.gutter)
    pngs = {"lit_baseColor.png": q8(lit),
            "truth_albedo.png": q8(image(smr.srgb_encode(gb["albedo"]), 3)),
            "truth_roughness.png": q8(image(gb["rough"], 1)[..., 0]),
            "truth_metallic.png": q8(image(gb["metal"], 1)[..., 0]),
            "mask.png": (hit * 255).astype(np.uint8)}
    try:
        os.makedirs(args.out_dir, exist_ok=True)
        for k, a8 in pngs.items():
            write_atomic(outs[k], lambda p, a8=a8: Image.fromarray(a8).save(p, format="PNG"))
        for src, dst in copies:
            write_atomic(dst, lambda p, src=src: shutil.copyfile(src, p))
        def write_json(p):
            with open(p, "w") as f:
                f.write(json.dumps(g, indent=1) + "\n")
        write_atomic(outs["lit.gltf"], write_json)
    except OSError as e:
        sys.exit(f"error: writing {args.out_dir}: {e}")
    print(f"{name}: {int(hit.sum())} of {args.size * args.size} texels covered ({100 * hit.mean():.1f} %), "
          f"exposure {expo:.4g}; wrote {outs['lit.gltf']}")


if __name__ == "__main__":
    main()
