"""The add-on's work without operators: finding the module `supermat`, reading a Blender mesh and image into the
arrays supermat.bake() and Model.image() take, writing the results back as images, wiring them into a material.

Conventions: Blender is Z up with the front facing -Y, as supermat_uv.h takes a mesh (its glTF importer converts
(x, y, z) -> (x, -z, y), as `supermat mesh` does). Blender's UVs have v = 0 at the bottom and its image pixels
start at the bottom row; supermat's start at the top row (glTF): both are flipped here.
"""
import os
import sys

import numpy as np

# the add-on's nodes in a material, found again by these names when the operator runs a second time
NODE_BASE_COLOR = "supermat base color"
NODE_ORM = "supermat metallic roughness"
NODE_SEPARATE = "supermat separate"
NODE_UV = "supermat uv"
SOURCE_KEY = "supermat_source_image"   # material custom property: the base-colour image the bake read

_module = None


def checkout_python_dir():
    """python/ of the repository checkout this add-on sits in (integrations/blender/supermat_blender/..), or None.
    Symbolic links are followed: an add-on folder linked into Blender's scripts/addons finds its checkout."""
    d = os.path.normpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "..", "..", "python"))
    return d if os.path.isfile(os.path.join(d, "supermat", "__init__.py")) else None


def import_supermat(module_path="", library_path="", model_dir=""):
    """The module `supermat`: from module_path (a folder holding the package `supermat`) if given, else from the
    checkout this add-on sits in, else an installed one. library_path and model_dir set SUPERMAT_LIBRARY and
    SUPERMAT_MODEL_DIR (read when the library is first loaded: a change needs a restart of Blender)."""
    global _module
    if library_path:
        os.environ["SUPERMAT_LIBRARY"] = bpy_abspath(library_path)
    if model_dir:
        os.environ["SUPERMAT_MODEL_DIR"] = bpy_abspath(model_dir)
    if _module is not None:
        return _module
    if "supermat" not in sys.modules:
        for d in (bpy_abspath(module_path) if module_path else None, checkout_python_dir()):
            if d and os.path.isfile(os.path.join(d, "supermat", "__init__.py")):
                if d not in sys.path:
                    sys.path.insert(0, d)
                break
    try:
        import supermat
    except ImportError as e:
        raise RuntimeError("cannot import the Python module supermat (%s): set its folder in the add-on's "
                           "preferences (python/ of a supermat checkout), or pip install it" % e) from None
    _module = supermat
    return supermat


def bpy_abspath(p):
    try:
        import bpy
        return bpy.path.abspath(p)
    except ImportError:
        return p


# ---- images ----------------------------------------------------------------------------------------------
def image_to_array(img):
    """A Blender image -> (H, W, 4) top row first: uint8 (its stored sRGB bytes) for 8-bit images, float32 for
    float ones (linear)."""
    w, h = img.size
    if w == 0 or h == 0:
        raise RuntimeError("image '%s' has no pixels (is its file there?)" % img.name)
    px = np.empty(w * h * img.channels, np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, img.channels)[::-1]
    if img.channels < 3:
        px = np.repeat(px[..., :1], 3, axis=2)
    elif img.channels > 4:
        px = px[..., :4]
    if img.is_float:
        return np.ascontiguousarray(px)
    return np.ascontiguousarray(np.clip(np.rint(px * 255.0), 0, 255).astype(np.uint8))


def new_image(bpy, name, array, colorspace):
    """(H, W, 3) or (H, W) uint8 top row first -> a new packed Blender image (8-bit, no alpha)."""
    a = np.asarray(array)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    h, w = a.shape[:2]
    rgba = np.empty((h, w, 4), np.float32)
    rgba[..., :3] = a[..., :3].astype(np.float32) / 255.0
    rgba[..., 3] = 1.0
    img = bpy.data.images.new(name, w, h, alpha=False)
    img.colorspace_settings.name = colorspace
    img.pixels.foreach_set(rgba[::-1].reshape(-1))
    img.file_format = "PNG"
    img.pack()   # a generated image is packed as PNG: it is saved in the .blend
    return img


# ---- meshes ----------------------------------------------------------------------------------------------
def mesh_arrays(obj, depsgraph, material_index=None):
    """The evaluated mesh (modifiers applied) of obj in world coordinates, triangulated, one vertex per face
    corner: positions (N, 3), normals (N, 3), uvs (N, 2) in glTF's convention (its active UV map), indices (T, 3);
    only the triangles of material slot material_index (None = all). Raises when the mesh has no UV map."""
    ev = obj.evaluated_get(depsgraph)
    me = ev.to_mesh()
    try:
        if not me.uv_layers.active:
            raise RuntimeError("object '%s' has no UV map" % obj.name)
        uv_name = me.uv_layers.active.name
        me.calc_loop_triangles()
        if hasattr(me, "calc_normals_split"):
            me.calc_normals_split()
        nt = len(me.loop_triangles)
        tri = np.empty(nt * 3, np.int32)
        me.loop_triangles.foreach_get("loops", tri)
        tri = tri.reshape(-1, 3)
        if material_index is not None:
            mi = np.empty(nt, np.int32)
            me.loop_triangles.foreach_get("material_index", mi)
            tri = tri[mi == material_index]
        nl = len(me.loops)
        vi = np.empty(nl, np.int32)
        me.loops.foreach_get("vertex_index", vi)
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        ln = np.empty(nl * 3, np.float32)
        me.loops.foreach_get("normal", ln)
        uv = np.empty(nl * 2, np.float32)
        me.uv_layers.active.data.foreach_get("uv", uv)
        # the face corners the triangles use, in order of first use
        used, inverse = np.unique(tri.reshape(-1), return_inverse=True)
        m = np.array(obj.matrix_world, np.float64)
        pos = co[vi[used]].astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        nrm = ln.reshape(-1, 3)[used].astype(np.float64) @ np.linalg.inv(m[:3, :3])
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
        uvs = uv.reshape(-1, 2)[used].copy()
        uvs[:, 1] = 1.0 - uvs[:, 1]
        return (pos.astype(np.float32), nrm.astype(np.float32), uvs, inverse.reshape(-1, 3).astype(np.uint32),
                uv_name)
    finally:
        ev.to_mesh_clear()


# ---- materials -------------------------------------------------------------------------------------------
def principled(mat):
    """The Principled BSDF of a node material: the one the active output reaches, else the first; or None."""
    if not mat or not mat.use_nodes or not mat.node_tree:
        return None
    nodes = mat.node_tree.nodes
    out = next((n for n in nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
    if out and out.inputs["Surface"].is_linked:
        n = out.inputs["Surface"].links[0].from_node
        if n.type == "BSDF_PRINCIPLED":
            return n
    return next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)


def source_image(mat, bsdf):
    """The base-colour image the bake reads: the one recorded at an earlier run of the add-on, else the first
    Image Texture upstream of the Base Color input (directly, or through mix / multiply nodes); None if none."""
    import bpy
    name = mat.get(SOURCE_KEY)
    if name and name in bpy.data.images:
        return bpy.data.images[name]
    seen, todo = set(), [bsdf.inputs["Base Color"]]
    while todo:
        sock = todo.pop(0)
        for link in sock.links:
            n = link.from_node
            if n.name in seen:
                continue
            seen.add(n.name)
            if n.type == "TEX_IMAGE" and n.image:
                return n.image
            todo.extend(i for i in n.inputs if i.is_linked)
    return None


def wire(mat, bsdf, base_color_img, orm_img, uv_name):
    """Link base_color_img (sRGB) to the Base Color input and orm_img (Non-Color; G roughness, B metallic, as
    glTF's metallicRoughness texture) through a Separate Color node to Roughness and Metallic, both read with
    the UV map uv_name. The add-on's nodes are reused when they are there; no other input is touched (the old
    base-colour node stays in the tree, unlinked from Base Color)."""
    nt = mat.node_tree
    nodes, links = nt.nodes, nt.links

    def node(name, kind, x, y):
        n = nodes.get(name)
        if n is None or n.bl_idname != kind:
            n = nodes.new(kind)
            n.name = name
            n.location = (bsdf.location.x + x, bsdf.location.y + y)
        n.label = name
        return n
    uvn = node(NODE_UV, "ShaderNodeUVMap", -900, -150)
    uvn.uv_map = uv_name
    bc = node(NODE_BASE_COLOR, "ShaderNodeTexImage", -600, 100)
    bc.image = base_color_img
    orm = node(NODE_ORM, "ShaderNodeTexImage", -600, -250)
    orm.image = orm_img
    sep = node(NODE_SEPARATE, "ShaderNodeSeparateColor", -250, -250)
    for sock in (bsdf.inputs["Base Color"], bsdf.inputs["Roughness"], bsdf.inputs["Metallic"]):
        for link in list(sock.links):
            links.remove(link)
    links.new(uvn.outputs["UV"], bc.inputs["Vector"])
    links.new(uvn.outputs["UV"], orm.inputs["Vector"])
    links.new(bc.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(orm.outputs["Color"], sep.inputs["Color"])
    links.new(sep.outputs["Green"], bsdf.inputs["Roughness"])
    links.new(sep.outputs["Blue"], bsdf.inputs["Metallic"])


# ---- jobs ------------------------------------------------------------------------------------------------
class BakeJob:
    """One material slot of one object: the arrays read on the main thread, baked (on any thread), then applied
    on the main thread."""

    def __init__(self, obj, slot, mat, bsdf, src, arrays):
        self.obj_name, self.slot, self.mat_name = obj.name, slot, mat.name
        self.src_name = src.name
        self.bsdf_name = bsdf.name
        self.pos, self.nrm, self.uv, self.idx, self.uv_name = arrays
        self.texture = image_to_array(src)
        self.result = None

    def run(self, sm, settings, progress=None):
        self.result = sm.bake(self.pos, self.uv, self.texture, indices=self.idx, normals=self.nrm,
                              model=settings.get("model"), albedo_refine=settings.get("albedo_refine"),
                              rm_refine=settings.get("rm_refine"), texture_size=settings["texture_size"],
                              view_size=settings["view_size"], threads=settings["threads"], progress=progress)

    def apply(self, bpy):
        mat = bpy.data.materials.get(self.mat_name)   # (from the menu, the scene may change while the bake runs)
        bsdf = mat.node_tree.nodes.get(self.bsdf_name) if mat is not None and mat.node_tree else None
        if bsdf is None or self.result is None:
            return None
        base = "%s_%s" % (self.obj_name, self.mat_name)
        bc = new_image(bpy, base + "_supermat_base_color", self.result["base_color"], "sRGB")
        orm = new_image(bpy, base + "_supermat_metallic_roughness", self.result["metallic_roughness"], "Non-Color")
        mat[SOURCE_KEY] = self.src_name
        wire(mat, bsdf, bc, orm, self.uv_name)
        return bc, orm


def run_jobs(sm, settings, jobs, on_fraction=None, cancelled=None):
    """Bake the jobs one after the other (on any thread: no bpy here): on_fraction(f) with the overall fraction
    between layers; cancelled() true stops the run between two layers (supermat.Cancelled is raised)."""
    n = len(jobs)
    for i, job in enumerate(jobs):
        def progress(f, what, i=i):
            if on_fraction is not None:
                on_fraction((i + f) / n)
            return bool(cancelled and cancelled())
        job.run(sm, settings, progress)


def srgb_encode(linear):
    """Linear float values -> sRGB-encoded ones (0..1), for float images given to Model.image()."""
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055).astype(np.float32)


def collect_jobs(objects, depsgraph):
    """The BakeJobs for the mesh objects given (each material slot whose Principled BSDF has a base-colour image;
    a material shared by several slots or objects is baked once, for the first) and the warnings for the rest."""
    jobs, warnings, done = [], [], set()
    for obj in objects:
        if obj.type != "MESH":
            continue
        found = False
        for slot, ms in enumerate(obj.material_slots):
            mat = ms.material
            bsdf = principled(mat)
            if bsdf is None:
                continue
            src = source_image(mat, bsdf)
            if src is None:
                continue
            found = True
            if mat.name in done:
                warnings.append("material '%s' is baked once, for its first object" % mat.name)
                continue
            arrays = mesh_arrays(obj, depsgraph, slot if len(obj.material_slots) > 1 else None)
            if len(arrays[3]) == 0:
                continue
            done.add(mat.name)
            jobs.append(BakeJob(obj, slot, mat, bsdf, src, arrays))
        if not found:
            warnings.append("object '%s': no material with a Principled BSDF whose Base Color has an image" % obj.name)
    return jobs, warnings
