#!/usr/bin/env python3
"""An evaluation set from an independent renderer: glTF assets rendered by Blender's Cycles, with ground truth.

The default models were trained and first judged on pictures of the project's own renderer (smrender: one
shading model, one tone curve).  This tool makes pictures the project did not make: Debian's `blender` (3.4,
Cycles on the CPU, path traced with interreflection, shadows and the glTF importer's Principled BSDF) lights each
asset with the world maps Blender ships (datafiles/studiolights/world: city, courtyard, forest, interior, night,
studio, sunrise, sunset), and writes, per view,

  inputs/<asset>_<v>_<look>.png   the RGBA picture (straight alpha from the transparent film), tone mapped by
                                  Blender's own colour management, one file per look: std0 (view transform
                                  Standard at the auto exposure), std-1 (one stop under), std+1 (one stop over),
                                  filmic0 (Filmic at the auto exposure);
  truth/<asset>_<v>_albedo.png     the material's base colour at the first hit (shader AOV, the same samples and
                                  pixel filter as the picture), sRGB 8-bit as glTF stores it;
  truth/<asset>_<v>_roughness.png  roughness and metallic (the values that reach the Principled BSDF: texture x
  truth/<asset>_<v>_metallic.png   factor), linear 8-bit;
  meta/<asset>_<v>.json            world, its rotation, camera, auto exposure.

The auto exposure puts the median luminance of the object's pixels (linear, alpha >= 0.5) at 0.18.  View 0
faces the asset's front (glTF +Z) from 10 degrees above; the others are seeded: azimuth uniform, elevation in
[-10, 40] degrees, a world chosen by the seed (each view its own), rotated about the vertical.  Perspective
camera (50 mm on 36 mm) aimed at the middle of the object's projected extent, at the distance where that
extent fills 85 % of the frame (the framing of the project's own renders).

Two halves in one file:
  python3 -m supermat_tools.cycles_render --gltf-dir DIR --out OUT [--assets A,B,...] [--views 8] [--size 256]
          [--samples 64] [--seed 0] [--threads 0] [--blender blender] [--world-dir DIR --worlds A,B] [--normals]
      runs blender once per asset (resumable: an asset whose views are all there is skipped; a view is written
      to temporary names and renamed, so an interrupted run never leaves a half view), and writes OUT/index.json;
  blender -b --factory-startup --python cycles_render.py -- --gltf FILE --asset NAME --out OUT ...
      renders one asset (what the first half runs).

About a second or two per 256x256 view at 64 samples on two Zen 5 cores, plus Blender's start and the import.
"""
import json
import math
import os
import random
import subprocess
import sys
import time

LOOKS = (("std0", "Standard", 0.0), ("std-1", "Standard", -1.0), ("std+1", "Standard", 1.0),
         ("filmic0", "Filmic", 0.0))
WORLDS = ("city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset")


def parse(argv):
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--gltf", help="(inside blender) the asset's .gltf or .glb")
    ap.add_argument("--asset", help="(inside blender) the asset's name")
    ap.add_argument("--gltf-dir", help="folder holding ASSET/glTF/ASSET.gltf (the sample-models layout)")
    ap.add_argument("--assets", default="", help="comma-separated asset names (default: every folder)")
    ap.add_argument("--out", default="", help="the set's folder (rendering)")
    ap.add_argument("--views", type=int, default=8)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=0, help="Cycles threads (0: all)")
    ap.add_argument("--worlds", default=",".join(WORLDS))
    ap.add_argument("--world-dir", default="", help="the world maps' folder (NAME.exr or NAME.hdr; default: the maps "
                    "Blender ships, datafiles/studiolights/world)")
    ap.add_argument("--normals", action="store_true", help="also write truth/<asset>_<v>_normal.npy: the shading "
                    "normal at the first hit in the camera's frame (x right, y up, the camera looking down -Z), "
                    "float16 HxWx3, as supermat_tools.gen_data stores it (training data)")
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--bake", default="", help="(inside blender) bake the lit texture into this PNG instead")
    ap.add_argument("--mask", default="", help="(inside blender, --bake) litbake's chart mask (the exposure's texels)")
    ap.add_argument("--world", default="city", help="(--bake) the world map")
    ap.add_argument("--world-rotation", type=float, default=0.0, help="(--bake) degrees about the vertical")
    return ap.parse_args(argv)


# ------------------------------------------------------------------------------------------------------------
# the driver (plain python3)
# ------------------------------------------------------------------------------------------------------------
def view_done(out, asset, v, normals=False):
    names = [f"inputs/{asset}_{v}_{look}.png" for look, _, _ in LOOKS]
    names += [f"truth/{asset}_{v}_{m}.png" for m in ("albedo", "roughness", "metallic")]
    names += [f"truth/{asset}_{v}_normal.npy"] if normals else []
    names += [f"meta/{asset}_{v}.json"]
    return all(os.path.exists(os.path.join(out, n)) for n in names)


def drive(args):
    assets = [a for a in args.assets.split(",") if a] or sorted(os.listdir(args.gltf_dir))
    for sub in ("inputs", "truth", "meta"):
        os.makedirs(os.path.join(args.out, sub), exist_ok=True)
    me = os.path.abspath(__file__)
    index = {"assets": assets, "views": args.views, "size": args.size, "samples": args.samples,
             "seed": args.seed, "looks": [look for look, _, _ in LOOKS], "worlds": args.worlds.split(","),
             "renderer": "Blender Cycles (CPU)", "world_dir": os.path.abspath(args.world_dir) if args.world_dir else "",
             "normals": args.normals}
    with open(os.path.join(args.out, "index.json.tmp"), "w") as f:   # written first: a set still rendering (or
        json.dump(index, f, indent=1)                                  # cut) says what it will hold
    os.replace(os.path.join(args.out, "index.json.tmp"), os.path.join(args.out, "index.json"))
    for asset in assets:
        if all(view_done(args.out, asset, v, args.normals) for v in range(args.views)):
            print(f"{asset}: done before", file=sys.stderr)
            continue
        base = os.path.join(args.gltf_dir, asset)
        cands = [os.path.join(base, "glTF", asset + ".gltf"), os.path.join(base, "glTF-Binary", asset + ".glb"),
                 os.path.join(base, asset + ".gltf"), os.path.join(base, asset + ".glb")]
        gltf = next((c for c in cands if os.path.exists(c)), None)
        if gltf is None:
            sys.exit(f"cycles_render: no glTF for {asset} under {base}")
        t0 = time.time()
        cmd = [args.blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", me, "--",
               "--gltf", gltf, "--asset", asset, "--out", args.out, "--views", str(args.views),
               "--size", str(args.size), "--samples", str(args.samples), "--seed", str(args.seed),
               "--threads", str(args.threads), "--worlds", args.worlds]
        cmd += ["--world-dir", os.path.abspath(args.world_dir)] if args.world_dir else []
        cmd += ["--normals"] if args.normals else []
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
        if r.returncode != 0 or not all(view_done(args.out, asset, v, args.normals) for v in range(args.views)):
            sys.exit(f"cycles_render: blender failed on {asset} (exit {r.returncode}):\n{r.stdout[-3000:]}")
        print(f"{asset}: {args.views} views in {time.time() - t0:.1f} s", file=sys.stderr)


# ------------------------------------------------------------------------------------------------------------
# inside blender
# ------------------------------------------------------------------------------------------------------------
def principled_inputs(mat):
    """The sockets (or constants) that feed the material's first Principled BSDF: base colour, roughness,
    metallic."""
    node = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None) if mat.use_nodes else None
    if node is None:
        c = tuple(mat.diffuse_color)[:3]
        return (None, c), (None, mat.roughness), (None, mat.metallic)
    out = []
    for name in ("Base Color", "Roughness", "Metallic"):
        s = node.inputs[name]
        if s.is_linked:
            out.append((s.links[0].from_socket, None))
        else:
            v = s.default_value
            out.append((None, tuple(v)[:3] if name == "Base Color" else float(v)))
    return out


def add_truth_aovs(bpy):
    vl = bpy.context.scene.view_layers[0]
    for name, kind in (("albedo", "COLOR"), ("rough", "VALUE"), ("metal", "VALUE")):
        a = vl.aovs.add()
        a.name, a.type = name, kind
    for mat in bpy.data.materials:
        if not mat.use_nodes:
            mat.use_nodes = True
        feeds = principled_inputs(mat)
        nt = mat.node_tree
        for (sock, const), name in zip(feeds, ("albedo", "rough", "metal")):
            aov = nt.nodes.new("ShaderNodeOutputAOV")
            aov.label = "truth_" + name
            aov.name = name          # on this node type, `name` is the AOV's name (it shadows the node's)
            field = "Color" if name == "albedo" else "Value"
            if sock is not None:
                nt.links.new(sock, aov.inputs[field])
            elif name == "albedo":
                aov.inputs["Color"].default_value = tuple(const) + (1.0,)
            else:
                aov.inputs["Value"].default_value = const


def mesh_points(bpy, mathutils):
    """Every vertex of every mesh, in world space, as the render sees them (modifiers and skins applied)."""
    dg = bpy.context.evaluated_depsgraph_get()
    pts = []
    for o in bpy.context.scene.objects:
        if o.type != "MESH":
            continue
        e = o.evaluated_get(dg)
        m = e.to_mesh()
        mw = e.matrix_world
        pts += [mw @ v.co for v in m.vertices]
        e.to_mesh_clear()
    return pts


def frame(pts, d, fill, tan_half):
    """The camera's target and distance along direction d (unit, from the object towards the camera) at which
    the object's projected extent fills `fill` of the frame, centred."""
    import mathutils
    fwd = -d
    right = fwd.cross(mathutils.Vector((0, 0, 1)))
    if right.length < 1e-6:
        right = mathutils.Vector((1, 0, 0))
    right.normalize()
    up = right.cross(fwd)
    xs = [p.dot(right) for p in pts]
    ys = [p.dot(up) for p in pts]
    target = right * (min(xs) + max(xs)) * 0.5 + up * (min(ys) + max(ys)) * 0.5
    zs = [p.dot(d) for p in pts]
    target += d * (min(zs) + max(zs)) * 0.5
    dist = 0.0
    for p in pts:
        q = p - target
        x, y, z = abs(q.dot(right)), abs(q.dot(up)), q.dot(d)
        dist = max(dist, z + max(x, y) / (tan_half * fill))
    return target, dist


def read_exr(bpy, np, path):
    img = bpy.data.images.load(path)
    w, h = img.size
    a = np.array(img.pixels[:], np.float32).reshape(h, w, 4)[::-1]
    bpy.data.images.remove(img)
    return a


def srgb8(np, x):
    x = np.clip(x, 0.0, 1.0)
    y = np.where(x <= 0.0031308, x * 12.92, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.clip(np.round(y * 255.0), 0, 255).astype(np.uint8)


def lin8(np, x):
    return np.clip(np.round(np.clip(x, 0.0, 1.0) * 255.0), 0, 255).astype(np.uint8)


def world_file(world_dir, name):
    """The world map NAME in world_dir: NAME.exr (Blender's own maps) or NAME.hdr (Radiance, e.g. Poly Haven's)."""
    for ext in (".exr", ".hdr"):
        if os.path.exists(os.path.join(world_dir, name + ext)):
            return os.path.join(world_dir, name + ext)
    sys.exit(f"cycles_render: no world map {name}.exr or {name}.hdr in {world_dir}")


def make_world(bpy, scene, world_dir=""):
    """An environment-texture world turned by a Mapping node: (texture node, mapping node, maps folder)."""
    world = bpy.data.worlds.new("w")
    scene.world = world
    world.use_nodes = True
    wn = world.node_tree
    env = wn.nodes.new("ShaderNodeTexEnvironment")
    mapping = wn.nodes.new("ShaderNodeMapping")
    coord = wn.nodes.new("ShaderNodeTexCoord")
    wn.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    wn.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    wn.links.new(env.outputs["Color"], wn.nodes["Background"].inputs["Color"])
    return env, mapping, world_dir or os.path.join(bpy.utils.system_resource("DATAFILES"), "studiolights", "world")


def import_asset(bpy, path):
    import numpy as np
    if "bool" not in np.__dict__:   # Debian's Blender 3.4 glTF importer still says np.bool (gone in numpy 1.24)
        np.bool = bool
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    scene = bpy.context.scene
    for o in list(scene.objects):          # lights and cameras of the file would change the lighting
        if o.type in ("LIGHT", "CAMERA"):
            bpy.data.objects.remove(o, do_unlink=True)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    return scene


def bake_asset(args):
    """The mesh counterpart: the asset's lit appearance baked by Cycles into its own UVs (TEXCOORD_0) at
    --size texels (bake type Combined: direct and indirect light, shadows, the specular seen along each texel's
    normal), under --world turned by --world-rotation; exposed so that the median luminance of the chart
    texels (--mask) is 0.18, Standard view (clip, sRGB), 16 texels of margin; written to --bake (sRGB RGB PNG,
    in glTF's image orientation), as a temporary file renamed into place."""
    import bpy
    import numpy as np
    from PIL import Image
    scene = import_asset(bpy, args.gltf)
    scene.cycles.samples = args.samples
    scene.cycles.seed = args.seed
    scene.cycles.use_adaptive_sampling = False   # with it on, Blender 3.4.1's bakes come out black (all zero)
    scene.cycles.use_denoising = False
    if args.threads > 0:
        scene.render.threads_mode, scene.render.threads = "FIXED", args.threads
    env, mapping, world_dir = make_world(bpy, scene, args.world_dir)
    env.image = bpy.data.images.load(world_file(world_dir, args.world))
    mapping.inputs["Rotation"].default_value[2] = math.radians(args.world_rotation)
    img = bpy.data.images.new("lit", args.size, args.size, alpha=False, float_buffer=True)
    meshes = [o for o in scene.objects if o.type == "MESH"]
    for o in meshes:        # UVs in another tile (DamagedHelmet's v in [1, 2]) moved into [0, 1] face by face, as
        me = o.data         # a repeating texture reads them (and litbake does); Cycles bakes only the first tile
        if not me.uv_layers.active:
            continue
        uv = np.empty(len(me.loops) * 2, np.float32)
        me.uv_layers.active.data.foreach_get("uv", uv)
        uv = uv.reshape(-1, 2)
        start = np.empty(len(me.polygons), np.int64)
        count = np.empty(len(me.polygons), np.int64)
        me.polygons.foreach_get("loop_start", start)
        me.polygons.foreach_get("loop_total", count)
        face = np.repeat(np.arange(len(me.polygons)), count)
        cen = np.zeros((len(me.polygons), 2))
        np.add.at(cen, face, uv)
        tile = np.floor(cen / count[:, None])
        uv -= tile[face].astype(np.float32)
        me.uv_layers.active.data.foreach_set("uv", uv.ravel())
    for mat in bpy.data.materials:
        if not mat.use_nodes:
            mat.use_nodes = True
        n = mat.node_tree.nodes.new("ShaderNodeTexImage")
        n.image = img
        for other in mat.node_tree.nodes:
            other.select = False
        n.select = True
        mat.node_tree.nodes.active = n
    bpy.ops.object.select_all(action="DESELECT")
    for o in meshes:
        o.select_set(True)
    bpy.context.view_layer.objects.active = meshes[0]
    bpy.ops.object.bake(type="COMBINED", margin=16, use_clear=True, target="IMAGE_TEXTURES",
                        pass_filter={"DIRECT", "INDIRECT", "DIFFUSE", "GLOSSY", "TRANSMISSION", "EMIT"})
    rgb = np.array(img.pixels[:], np.float32).reshape(args.size, args.size, 4)[::-1, :, :3]
    mask = np.asarray(Image.open(args.mask).convert("L")) > 0 if args.mask else np.ones(rgb.shape[:2], bool)
    if mask.shape != rgb.shape[:2]:
        sys.exit(f"cycles_render: the mask is {mask.shape[1]}x{mask.shape[0]}, the bake {args.size}")
    lum = rgb @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    med = float(np.median(lum[mask])) if mask.any() else 0.18
    out = srgb8(np, rgb * (0.18 / max(med, 1e-6)))
    Image.fromarray(out).save(args.bake + ".tmp.png")
    os.replace(args.bake + ".tmp.png", args.bake)
    print(f"cycles_render: baked {args.gltf} under {args.world} (median {med:.4f})", flush=True)


def render_asset(args):
    import bpy
    import mathutils
    import numpy as np
    from PIL import Image
    scene = import_asset(bpy, args.gltf)
    pts = mesh_points(bpy, mathutils)
    add_truth_aovs(bpy)

    r = scene.render
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = False
    scene.cycles.seed = args.seed
    r.film_transparent = True
    r.resolution_x = r.resolution_y = args.size
    r.resolution_percentage = 100
    if args.threads > 0:
        r.threads_mode, r.threads = "FIXED", args.threads
    scene.display_settings.display_device = "sRGB"
    scene.view_settings.look = "None"

    cam_data = bpy.data.cameras.new("cam")
    cam_data.lens, cam_data.sensor_width = 50.0, 36.0
    cam = bpy.data.objects.new("cam", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    tan_half = 18.0 / 50.0

    env, mapping, world_dir = make_world(bpy, scene, args.world_dir)
    passes = ["beauty", "albedo", "rough", "metal"] + (["normal"] if args.normals else [])
    if args.normals:
        scene.view_layers[0].use_pass_normal = True

    scene.use_nodes = True
    ct = scene.node_tree
    rl = ct.nodes["Render Layers"]
    fo = ct.nodes.new("CompositorNodeOutputFile")
    tmp = os.path.join(args.out, "tmp_" + args.asset)
    os.makedirs(tmp, exist_ok=True)
    fo.base_path = tmp
    fo.format.file_format, fo.format.color_depth, fo.format.color_mode = "OPEN_EXR", "32", "RGBA"
    fo.file_slots.clear()
    for name, sock in zip(passes, ("Image", "albedo", "rough", "metal", "Normal")):
        fo.file_slots.new(name)
        ct.links.new(rl.outputs[sock], fo.inputs[name])

    rng = random.Random(f"{args.seed}:{args.asset}")
    worlds = args.worlds.split(",")
    for v in range(args.views):
        az, el = (0.0, 10.0) if v == 0 else (rng.uniform(0, 360), rng.uniform(-10, 40))
        wname = rng.choice(worlds)
        wrot = rng.uniform(0, 360)
        if view_done(args.out, args.asset, v, args.normals):
            continue
        env.image = bpy.data.images.load(world_file(world_dir, wname), check_existing=True)
        mapping.inputs["Rotation"].default_value[2] = math.radians(wrot)
        a, e = math.radians(az), math.radians(el)
        d = mathutils.Vector((math.sin(a) * math.cos(e), -math.cos(a) * math.cos(e), math.sin(e)))
        target, dist = frame(pts, d, 0.85, tan_half)
        cam_data.clip_start, cam_data.clip_end = dist * 0.001, dist * 10
        cam.location = target + d * dist
        cam.rotation_euler = (-d).to_track_quat("-Z", "Y").to_euler()
        scene.frame_set(1)
        bpy.ops.render.render(write_still=False)
        px = {n: read_exr(bpy, np, os.path.join(tmp, f"{n}0001.exr")) for n in passes}
        alpha = px["beauty"][..., 3]
        cov = np.maximum(alpha, 1e-6)[..., None]
        rgb = px["beauty"][..., :3] / cov                     # straight colour (the film is premultiplied)
        mask = alpha >= 0.5
        lum = rgb @ np.array([0.2126, 0.7152, 0.0722], np.float32)
        med = float(np.median(lum[mask])) if mask.any() else 0.18
        expo = math.log2(0.18 / max(med, 1e-6))
        stem = f"{args.asset}_{v}"
        # the looks: Blender's colour management on the straight float picture (save_render applies the
        # scene's view transform and exposure)
        img = bpy.data.images.new("look", args.size, args.size, alpha=True, float_buffer=True)
        img.alpha_mode = "STRAIGHT"
        img.pixels[:] = np.concatenate([rgb, alpha[..., None]], -1)[::-1].ravel()
        r.image_settings.file_format, r.image_settings.color_mode, r.image_settings.color_depth = "PNG", "RGBA", "8"
        for look, transform, stops in LOOKS:
            scene.view_settings.view_transform = transform
            scene.view_settings.exposure = expo + stops
            path = os.path.join(args.out, "inputs", f"{stem}_{look}.png")
            img.save_render(path + ".tmp.png", scene=scene)
            os.replace(path + ".tmp.png", path)
        bpy.data.images.remove(img)
        truth = {"albedo": srgb8(np, px["albedo"][..., :3] / cov),
                 "roughness": lin8(np, px["rough"][..., 0] / cov[..., 0]),
                 "metallic": lin8(np, px["metal"][..., 0] / cov[..., 0])}
        for name, arr in truth.items():
            path = os.path.join(args.out, "truth", f"{stem}_{name}.png")
            Image.fromarray(arr).save(path + ".tmp.png")
            os.replace(path + ".tmp.png", path)
        if args.normals:    # world-space normals (premultiplied by coverage) into the camera's frame, unit length
            rot = np.array(cam.matrix_world.to_3x3(), np.float32)   # camera axes as columns, in world space
            n = px["normal"][..., :3] @ rot
            n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-6)
            n[alpha <= 0] = (0.0, 0.0, 1.0)
            path = os.path.join(args.out, "truth", f"{stem}_normal.npy")
            np.save(path + ".tmp.npy", n.astype(np.float16))
            os.replace(path + ".tmp.npy", path)
        meta = {"asset": args.asset, "view": v, "azimuth": az, "elevation": el, "world": wname,
                "world_rotation": wrot, "exposure": expo, "median_luminance": med, "samples": args.samples,
                "size": args.size, "blender": bpy.app.version_string}
        path = os.path.join(args.out, "meta", f"{stem}.json")
        with open(path + ".tmp", "w") as f:
            json.dump(meta, f, indent=1)
        os.replace(path + ".tmp", path)
        print(f"cycles_render: {stem} world {wname} exposure {expo:+.2f}", flush=True)
    for n in os.listdir(tmp):
        os.remove(os.path.join(tmp, n))
    os.rmdir(tmp)


if __name__ == "__main__":
    if "--" in sys.argv:        # inside blender: the arguments after --
        a = parse(sys.argv[sys.argv.index("--") + 1:])
        bake_asset(a) if a.bake else render_asset(a)
    else:
        drive(parse(sys.argv[1:]))
