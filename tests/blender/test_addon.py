"""ctest blender_addon: the Blender add-on integrations/blender/supermat_blender in Debian's Blender (3.4), headless.

Run by tests/blender/run_test.sh as
    blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_addon.py -- WORK CLI LIBRARY
Checks:
  - the add-on folder, zipped, installs (preferences.addon_install) and enables; its preferences point it at the
    checkout's python/ and the library under test;
  - a glTF cube of the project's making (tests/python/test_module.py's write_cube_gltf) imported with Blender's
    glTF importer, then Object > Estimate PBR material on it (64 px textures, 64 px views, the multi-view default
    model): the Principled BSDF's Base Color, Roughness and Metallic come from the add-on's image nodes (sRGB base
    colour; Non-Color metallic-roughness through Separate Color G and B), its other inputs are untouched, and the
    new images equal `supermat mesh`'s textures of the same glTF within 1/255;
  - a cancel flag set while the bake runs on a thread (what Esc does) stops it (supermat.Cancelled);
  - Image > Estimate PBR maps on the cube's texture makes three images equal to Model.image()'s maps within 1/255;
  - Models: Official without the files reports an error naming them and changes nothing; with them (the default
    multi-view file linked in under the official name) a second run bakes the original texture again, reusing
    the add-on's nodes;
  - the .blend saved and opened again keeps the links and the (packed) images' pixels;
  - the lit example mesh (examples/mesh/lit, 8064 triangles) at 256 px equals `supermat mesh` within 1/255, and a
    320x240 Cycles render of it (WORK/blender_addon.png; docs/img/blender_addon.png is one).
  - a folder linked into scripts/addons finds the checkout's python/;
  - a mesh with two material slots (the cube split in halves): each slot's textures equal supermat.bake() on its
    own triangles (`supermat mesh`, which renders all materials in the same views, differs: printed, not checked).
"""
import json
import os
import subprocess
import sys
import time
import zipfile

import bpy
import numpy as np

T0 = time.time()
argv = sys.argv[sys.argv.index("--") + 1:]
WORK, CLI, LIB = argv[:3]
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ADDON = os.path.join(REPO, "integrations", "blender", "supermat_blender")
sys.path[:0] = [os.path.join(REPO, "python"), os.path.join(REPO, "tests", "python")]
from test_module import write_cube_gltf   # noqa: E402  (the cube of the module's bake test)

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def log(what):
    print("[%5.1f s] %s" % (time.time() - T0, what))


def pixels(img):
    """A Blender image's (H, W, 3) bytes, top row first."""
    w, h = img.size
    px = np.empty(w * h * img.channels, np.float32)
    img.pixels.foreach_get(px)
    return np.rint(px.reshape(h, w, img.channels)[::-1, :, :3] * 255).astype(np.int32)


def png(path):
    img = bpy.data.images.load(path, check_existing=False)
    a = pixels(img)
    bpy.data.images.remove(img)
    return a


# ---- the glTF and `supermat mesh`'s textures ----------------------------------------------------------------
os.makedirs(os.path.join(WORK, "out"), exist_ok=True)
write_cube_gltf(WORK)
subprocess.run([CLI, "mesh", "--force", "--size", "64", "--views-size", "64", os.path.join(WORK, "cube.gltf"),
                os.path.join(WORK, "out", "cube.gltf")], check=True)
g = json.load(open(os.path.join(WORK, "out", "cube.gltf")))
pbr = g["materials"][0]["pbrMetallicRoughness"]
cli_tex = {k: png(os.path.join(WORK, "out", g["images"][g["textures"][pbr[k]["index"]]["source"]]["uri"]))
           for k in ("baseColorTexture", "metallicRoughnessTexture")}
log("supermat mesh done")

# ---- install and enable the add-on from the repository ----------------------------------------------------
bpy.ops.wm.read_factory_settings(use_empty=True)
zpath = os.path.join(WORK, "supermat_blender.zip")
with zipfile.ZipFile(zpath, "w") as z:
    for name in sorted(os.listdir(ADDON)):
        if name.endswith(".py"):
            z.write(os.path.join(ADDON, name), "supermat_blender/" + name)
bpy.ops.preferences.addon_install(filepath=zpath, overwrite=True)
bpy.ops.preferences.addon_enable(module="supermat_blender")
check("supermat_blender" in bpy.context.preferences.addons, "the add-on installs from a zip and enables")
prefs = bpy.context.preferences.addons["supermat_blender"].preferences
prefs.module_path = os.path.join(REPO, "python")
prefs.library_path = LIB
check(hasattr(bpy.ops.object, "supermat_estimate_material") and hasattr(bpy.ops.image, "supermat_estimate_maps"),
      "its operators are registered")
# a zip-installed copy has no checkout around it (the preference above); a folder linked into scripts/addons
# finds the checkout's python/ through the link
import importlib.util   # noqa: E402
os.symlink(ADDON, os.path.join(WORK, "linked_addon"))
spec = importlib.util.spec_from_file_location("linked_core", os.path.join(WORK, "linked_addon", "core.py"))
linked = importlib.util.module_from_spec(spec)
spec.loader.exec_module(linked)
check(linked.checkout_python_dir() == os.path.join(REPO, "python"),
      "a linked add-on folder finds the checkout's python/ (%s)" % linked.checkout_python_dir())
import supermat_blender   # noqa: E402  (the installed copy)
from supermat_blender import core   # noqa: E402

# ---- the operator on an imported glTF -----------------------------------------------------------------------
# Debian 12's Blender 3.4 runs with Debian's numpy 1.24, which dropped np.bool: the glTF importer (io_scene_gltf2
# 3.4) still uses it for meshes with normals
if "bool" not in np.__dict__:
    np.bool = bool
bpy.ops.import_scene.gltf(filepath=os.path.join(WORK, "cube.gltf"))
obj = next(o for o in bpy.context.scene.objects if o.type == "MESH")
mat = obj.active_material
bsdf = core.principled(mat)
KEYS = ("Base Color", "Roughness", "Metallic")


def inputs_state(b):
    out = {}
    for i in b.inputs:
        v = getattr(i, "default_value", None)
        v = tuple(v) if hasattr(v, "__len__") else v
        out[i.identifier] = (v, [(l.from_node.name, l.from_socket.identifier) for l in i.links])
    return out
before = {k: v for k, v in inputs_state(bsdf).items() if k not in KEYS}
src = core.source_image(mat, bsdf)
check(src is not None and src.name.startswith("cube"), "the importer's base-colour image is found (%s)" % src)

bpy.ops.object.select_all(action="DESELECT")
obj.select_set(True)
bpy.context.view_layer.objects.active = obj
t = time.time()
r = bpy.ops.object.supermat_estimate_material(texture_size=64, view_size=64)
log("operator: %s in %.2f s" % (r, time.time() - t))
check(r == {"FINISHED"}, "Estimate PBR material finishes")


def check_material(mat, when):
    b = core.principled(mat)
    ln = {k: b.inputs[k].links[0] if b.inputs[k].is_linked else None for k in KEYS}
    bc, rough, metal = ln["Base Color"], ln["Roughness"], ln["Metallic"]
    check(bc is not None and bc.from_node.name == core.NODE_BASE_COLOR and bc.from_socket.name == "Color",
          "%s: Base Color <- the add-on's image node" % when)
    check(rough is not None and rough.from_node.type == "SEPARATE_COLOR" and rough.from_socket.name == "Green" and
          metal is not None and metal.from_node == rough.from_node and metal.from_socket.name == "Blue",
          "%s: Roughness <- Separate Color G, Metallic <- B" % when)
    sep = rough.from_node
    orm_link = sep.inputs["Color"].links[0] if sep.inputs["Color"].is_linked else None
    check(orm_link is not None and orm_link.from_node.name == core.NODE_ORM, "%s: Separate Color <- the ORM image" % when)
    bci, ormi = bc.from_node.image, orm_link.from_node.image
    check(bci.colorspace_settings.name == "sRGB" and ormi.colorspace_settings.name == "Non-Color",
          "%s: base colour sRGB, metallic-roughness Non-Color" % when)
    check(bci.packed_file is not None and ormi.packed_file is not None, "%s: the new images are packed" % when)
    after = {k: v for k, v in inputs_state(b).items() if k not in KEYS}
    check(after == before, "%s: the BSDF's other inputs are untouched" % when)
    for key, img in (("baseColorTexture", bci), ("metallicRoughnessTexture", ormi)):
        d = np.abs(pixels(img) - cli_tex[key])
        check(img.size[0] == 64 and int(d.max()) <= 1,
              "%s: %s equals supermat mesh's within 1/255 (max difference %d, %.1f%% of values differ)"
              % (when, key, d.max(), 100.0 * np.mean(d > 0)))
    return bci, ormi


check_material(mat, "after the operator")

# ---- cancelling -------------------------------------------------------------------------------------------
# as Esc does from the menu (the modal operator; background mode has no event loop to run it): the bake on a
# thread, the cancel flag set from this thread once progress is seen; the bake stops with supermat.Cancelled
import threading   # noqa: E402
sm = core.import_supermat()
jobs, _ = core.collect_jobs([obj], bpy.context.evaluated_depsgraph_get())
settings = supermat_blender.bake_settings(sm, prefs, 64, 64)
cancel, seen, errors = threading.Event(), threading.Event(), []


def worker():
    try:
        core.run_jobs(sm, settings, jobs, lambda f: seen.set(), cancel.is_set)
    except Exception as e:
        errors.append(e)
th = threading.Thread(target=worker)
th.start()
seen.wait(60)
cancel.set()
th.join(60)
check(not th.is_alive() and len(errors) == 1 and isinstance(errors[0], sm.Cancelled) and jobs[0].result is None,
      "a cancel flag set while the bake runs on a thread stops it (supermat.Cancelled: %r)" % errors)

# ---- Image > Estimate PBR maps ---------------------------------------------------------------------------------
r = bpy.ops.image.supermat_estimate_maps(image=src.name)
check(r == {"FINISHED"}, "Estimate PBR maps finishes")
arr = core.image_to_array(src)
with sm.Model() as m:
    want = m.image(arr)
for name in ("albedo", "roughness", "metallic"):
    img = bpy.data.images.get("cube_" + name)
    w = want[name] if want[name].ndim == 3 else np.repeat(want[name][..., None], 3, 2)
    d = np.abs(pixels(img) - w) if img else None
    check(img is not None and int(d.max()) <= 1 and
          img.colorspace_settings.name == ("sRGB" if name == "albedo" else "Non-Color"),
          "image cube_%s equals Model.image()'s %s within 1/255" % (name, name))
log("image operator done")

# ---- the official models, not downloaded: an error naming them, the material unchanged -------------------------
empty = os.path.join(WORK, "no_models")
os.makedirs(empty, exist_ok=True)
prefs.models, prefs.model_dir = "OFFICIAL", empty
links_before = [(l.from_node.name, l.to_node.name, l.to_socket.identifier) for l in mat.node_tree.links]
try:
    r = bpy.ops.object.supermat_estimate_material(texture_size=64, view_size=64)
    message = ""
except RuntimeError as e:   # an operator's ERROR report is raised in background mode
    r, message = {"CANCELLED"}, str(e)
check(r == {"CANCELLED"} and "official" in message and empty in message and
      [(l.from_node.name, l.to_node.name, l.to_socket.identifier) for l in mat.node_tree.links] == links_before,
      "Models: Official without the files: an error naming them (%s), the material unchanged"
      % message.strip().splitlines()[-1:])
# ... and with them (the default multi-view model linked in under the official name): that file is baked with,
# and a second run reuses the add-on's nodes and reads the original texture again
official = os.path.join(WORK, "official_models")
os.makedirs(official, exist_ok=True)
os.symlink(os.path.join(REPO, "models", "supermat_mv_default.safetensors"),
           os.path.join(official, "supermat_mv_official.safetensors"))
prefs.model_dir = official
nodes_before = len(mat.node_tree.nodes)
r = bpy.ops.object.supermat_estimate_material(texture_size=64, view_size=64)
check(r == {"FINISHED"} and len(mat.node_tree.nodes) == nodes_before and
      any(m.path == os.path.join(official, "supermat_mv_official.safetensors")
          for m in supermat_blender._models.values()),
      "Models: Official bakes with the model folder's supermat_mv_official; a second run adds no nodes")
check_material(mat, "after a second run (official)")
prefs.models, prefs.model_dir = "DEFAULT", ""

# ---- two materials on one mesh (the cube's faces 0-2 and 3-5) ---------------------------------------------------
# supermat.bake() takes one part: each slot is baked with its own triangles alone, equal to supermat.bake() on that
# half of the cube. `supermat mesh` renders all materials in the same views: its textures differ (printed only).
g = json.load(open(os.path.join(WORK, "cube.gltf")))
n = g["accessors"][0]["count"]
for half in range(2):
    g["bufferViews"].append(dict(buffer=0, byteOffset=n * 32 + half * 72, byteLength=72))
    g["accessors"].append(dict(bufferView=4 + half, componentType=5125, count=18, type="SCALAR"))
attrs = g["meshes"][0]["primitives"][0]["attributes"]
g["meshes"][0]["primitives"] = [dict(attributes=attrs, indices=4 + h, material=h) for h in range(2)]
g["materials"] = [dict(g["materials"][0], name=nm) for nm in ("half_a", "half_b")]
json.dump(g, open(os.path.join(WORK, "cube2.gltf"), "w"))
subprocess.run([CLI, "mesh", "--force", "--size", "64", "--views-size", "64", os.path.join(WORK, "cube2.gltf"),
                os.path.join(WORK, "out", "cube2.gltf")], check=True)
g = json.load(open(os.path.join(WORK, "out", "cube2.gltf")))
before_objects = set(bpy.data.objects)
bpy.ops.import_scene.gltf(filepath=os.path.join(WORK, "cube2.gltf"))
obj2 = next(o for o in bpy.data.objects if o not in before_objects and o.type == "MESH")
bpy.ops.object.select_all(action="DESELECT")
obj2.select_set(True)
r = bpy.ops.object.supermat_estimate_material(texture_size=64, view_size=64)
check(r == {"FINISHED"} and len(obj2.material_slots) == 2, "two material slots: the operator finishes")
os.makedirs(os.path.join(WORK, "cube_arrays"), exist_ok=True)
cpos, cnrm, cuv, cidx, ctex = write_cube_gltf(os.path.join(WORK, "cube_arrays"))   # the same cube, Z up
for h, gm in enumerate(g["materials"]):
    m2 = bpy.data.materials[gm["name"]]
    b = core.principled(m2)
    got = {"base_color": b.inputs["Base Color"].links[0].from_node.image,
           "metallic_roughness": b.inputs["Roughness"].links[0].from_node.inputs["Color"].links[0].from_node.image}
    want = sm.bake(cpos, cuv, ctex, indices=cidx[18 * h:18 * (h + 1)].reshape(-1, 3), normals=cnrm,
                   model=settings["model"], texture_size=64, view_size=64)
    for (key, img), gkey in zip(got.items(), ("baseColorTexture", "metallicRoughnessTexture")):
        d = np.abs(pixels(img) - want[key])
        check(int(d.max()) <= 1, "two material slots: %s %s equals supermat.bake() on its triangles within 1/255 "
              "(max difference %d)" % (gm["name"], key, d.max()))
        cli = png(os.path.join(WORK, "out", g["images"][g["textures"][gm["pbrMetallicRoughness"][gkey]["index"]]["source"]]["uri"]))
        print("     (supermat mesh, all materials in the same views: max difference %d)" % np.abs(pixels(img) - cli).max())
bpy.data.objects.remove(obj2)
obj.select_set(True)

# ---- save, open again -------------------------------------------------------------------------------------------
blend = os.path.join(WORK, "result.blend")
mat_name = mat.name
bpy.ops.wm.save_as_mainfile(filepath=blend)
bpy.ops.wm.open_mainfile(filepath=blend)
mat = bpy.data.materials[mat_name]
check_material(mat, "after save and reload")
log("reloaded")

# ---- the lit example mesh (examples/mesh/lit), a small render of the result -----------------------------------
# a real mesh (a torus and a sphere, 8064 triangles) through the importer and the operator at 256 px, against
# `supermat mesh` at the same sizes; then the Cycles render under the example's studio light
LIT = os.path.join(REPO, "examples", "mesh", "lit", "example_pbr_lit.gltf")
subprocess.run([CLI, "mesh", "--force", "--size", "256", "--views-size", "256", LIT,
                os.path.join(WORK, "out", "lit.gltf")], check=True)
g = json.load(open(os.path.join(WORK, "out", "lit.gltf")))
pbr = g["materials"][0]["pbrMetallicRoughness"]
cli_lit = {k: png(os.path.join(WORK, "out", g["images"][g["textures"][pbr[k]["index"]]["source"]]["uri"]))
           for k in ("baseColorTexture", "metallicRoughnessTexture")}
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
bpy.ops.import_scene.gltf(filepath=LIT)
obj = next(o for o in bpy.context.scene.objects if o.type == "MESH")
bpy.ops.object.select_all(action="DESELECT")
obj.select_set(True)
bpy.context.view_layer.objects.active = obj
t = time.time()
r = bpy.ops.object.supermat_estimate_material("INVOKE_DEFAULT", texture_size=256, view_size=256)   # as the menu
log("operator on the lit example mesh: %s in %.2f s" % (r, time.time() - t))
b = core.principled(obj.active_material)
got = {"baseColorTexture": b.inputs["Base Color"].links[0].from_node.image,
       "metallicRoughnessTexture": b.inputs["Roughness"].links[0].from_node.inputs["Color"].links[0].from_node.image}
for key, img in got.items():
    d = np.abs(pixels(img) - cli_lit[key])
    check(r == {"FINISHED"} and int(d.max()) <= 1,
          "lit example: %s equals supermat mesh's within 1/255 (max difference %d, %d of %d values differ)"
          % (key, d.max(), np.count_nonzero(d), d.size))

import mathutils   # noqa: E402
scene = bpy.context.scene
corners = [obj.matrix_world @ mathutils.Vector(c) for c in obj.bound_box]
center = sum(corners, mathutils.Vector()) / 8
radius = max((c - center).length for c in corners)
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(cam)
cam.location = center + mathutils.Vector((0.9, -2.0, 1.1)).normalized() * radius * 3.4
cam.rotation_euler = (center - cam.location).to_track_quat("-Z", "Y").to_euler()
scene.camera = cam
if scene.world is None:
    scene.world = bpy.data.worlds.new("world")
scene.world.use_nodes = True
wn = scene.world.node_tree
env = wn.nodes.new("ShaderNodeTexEnvironment")
env.image = bpy.data.images.load(os.path.join(REPO, "examples", "mesh", "studio_small_03_256.hdr"))
wn.links.new(env.outputs["Color"], wn.nodes["Background"].inputs["Color"])
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 32
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 320, 240, 100
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGBA"
scene.render.film_transparent = True   # the studio light lights, the page shows through
scene.render.filepath = os.path.join(WORK, "blender_addon.png")
bpy.ops.render.render(write_still=True)
check(os.path.isfile(scene.render.filepath), "rendered %s" % scene.render.filepath)
log("rendered")

bpy.ops.preferences.addon_disable(module="supermat_blender")
print("%d failure(s) in %.1f s" % (len(failures), time.time() - T0))
sys.exit(1 if failures else 0)
