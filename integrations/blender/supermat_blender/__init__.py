"""supermat for Blender: estimate PBR materials (base colour, roughness, metallic) from a mesh's base-colour
texture, or maps from one image, with the project's Python module `supermat` (ctypes over libsupermat.so).

Object > Estimate PBR material (bpy.ops.object.supermat_estimate_material): each selected mesh object's material
slots whose Principled BSDF reads an image into Base Color are baked by supermat.bake() (the multi-view default
model, or the official ones) into two new packed images: the base colour (sRGB) and the glTF metallic-roughness
texture (Non-Color; G roughness, B metallic) through a Separate Color node. Image editor > Image > Estimate PBR
maps (bpy.ops.image.supermat_estimate_maps): the active image -> three new images by Model.image().
See integrations/blender/README.md.
"""
bl_info = {
    "name": "supermat: estimate PBR materials",
    "author": "the supermat project",
    "version": (0, 2, 0),
    "blender": (3, 4, 0),
    "location": "3D Viewport > Object > Estimate PBR material; Image Editor > Image > Estimate PBR maps",
    "description": "Albedo, roughness and metallic from a base-colour texture or a picture (supermat, on the CPU)",
    "category": "Material",
}

import os
import threading

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from . import core

_LEVERS = {
    "kernel": ("auto", "scalar", "avx2", "avx512", "neon", "amx"),
    "weights": ("default", "f32", "f16", "bf16", "int8"),
    "conv": ("direct", "winograd-f2", "winograd-f4"),
    "compute": ("f32", "bf16", "int8"),
}
_models = {}   # (path, threads, levers) -> supermat.Model, loaded once per session


def _enum(values):
    return [(v, v, "") for v in values]


class SupermatPreferences(bpy.types.AddonPreferences):
    bl_idname = __name__

    module_path: StringProperty(name="Module folder", subtype="DIR_PATH", default="",
                                description="Folder holding the Python package supermat (python/ of a supermat "
                                "checkout); empty: the checkout this add-on sits in, else an installed supermat")
    library_path: StringProperty(name="Library", subtype="FILE_PATH", default="",
                                 description="libsupermat.so to load (SUPERMAT_LIBRARY); empty: the module finds it. "
                                 "Read when first loaded: restart Blender after a change")
    model_dir: StringProperty(name="Model folder", subtype="DIR_PATH", default="",
                              description="Where `supermat download official` put the official models "
                              "(SUPERMAT_MODEL_DIR); empty: ~/.local/share/supermat")
    models: EnumProperty(name="Models", default="DEFAULT", items=[
        ("DEFAULT", "Default", "The project's default models (found by the module)"),
        ("OFFICIAL", "Official", "The official SuperMat networks converted by `supermat download official` into the "
         "model folder"),
        ("FILES", "Files", "The model files below")])
    mv_model_file: StringProperty(name="Multi-view model", subtype="FILE_PATH", default="",
                                  description="supermat-mv model file for meshes (or a single-view one)")
    sv_model_file: StringProperty(name="Single-view model", subtype="FILE_PATH", default="",
                                  description="supermat model file for images")
    refine: BoolProperty(name="UV refine", default=False,
                         description="Refine the baked textures in UV space (supermat mesh --refine)")
    threads: IntProperty(name="Threads", default=0, min=0, max=1024, description="Cores per run, 0 = all")
    texture_size: IntProperty(name="Texture size", default=1024, min=64, max=8192, step=8,
                              description="Side of the baked textures (a multiple of 8)")
    view_size: IntProperty(name="View size", default=512, min=64, max=4096, step=8,
                           description="Side of the rendered views the network sees")
    kernel: EnumProperty(name="Kernel", items=_enum(_LEVERS["kernel"]), default="auto")
    weights: EnumProperty(name="Weights", items=_enum(_LEVERS["weights"]), default="default",
                          description="Weight precision: smaller is faster, less exact (docs/levers.md)")
    conv: EnumProperty(name="Convolution", items=_enum(_LEVERS["conv"]), default="direct")
    compute: EnumProperty(name="Compute", items=_enum(_LEVERS["compute"]), default="f32")

    def draw(self, context):
        col = self.layout.column()
        col.prop(self, "module_path")
        col.prop(self, "library_path")
        col.prop(self, "model_dir")
        col.prop(self, "models", expand=True)
        if self.models == "FILES":
            col.prop(self, "mv_model_file")
            col.prop(self, "sv_model_file")
        col.prop(self, "refine")
        row = col.row()
        row.prop(self, "texture_size")
        row.prop(self, "view_size")
        row.prop(self, "threads")
        box = col.box()
        box.label(text="Speed / accuracy (docs/levers.md)")
        row = box.row()
        for k in ("kernel", "weights", "conv", "compute"):
            row.prop(self, k)
        try:
            sm = core.import_supermat(self.module_path, self.library_path, self.model_dir)
            col.label(text="supermat %s, library %s" % (sm.__version__, sm.library_path()))
        except Exception as e:   # shown, not raised: the preferences must stay usable to fix the paths
            col.label(text=str(e).split("\n")[0], icon="ERROR")


def prefs(context=None):
    return (context or bpy.context).preferences.addons[__name__].preferences


def _model(sm, p, path):
    key = (path, p.threads, p.kernel, p.weights, p.conv, p.compute)
    m = _models.get(key)
    if m is None:
        m = _models[key] = sm.Model(path, threads=p.threads, kernel=p.kernel, weights=p.weights, conv=p.conv,
                                    compute=p.compute)
    return m


def bake_settings(sm, p, texture_size=0, view_size=0):
    """The models and sizes of the preferences as supermat.bake()'s arguments."""
    s = {"texture_size": texture_size or p.texture_size, "view_size": view_size or p.view_size, "threads": p.threads}
    if p.models == "OFFICIAL":
        names = ("official-mv", "official-refine-albedo", "official-refine-rm")
    elif p.models == "FILES":
        names = (bpy.path.abspath(p.mv_model_file) if p.mv_model_file else None, None, None)
    else:
        d = os.path.dirname(sm.default_model_path())
        mv = os.path.join(d, "supermat_mv_default.safetensors")
        names = (mv if os.path.isfile(mv) else None, os.path.join(d, "supermat_refine_albedo_default.safetensors"),
                 os.path.join(d, "supermat_refine_rm_default.safetensors"))
    s["model"] = _model(sm, p, names[0])
    if p.refine:
        if not (names[1] and names[2]):
            raise RuntimeError("UV refine needs the default or the official models")
        s["albedo_refine"], s["rm_refine"] = _model(sm, p, names[1]), _model(sm, p, names[2])
    return s


def image_model(sm, p):
    if p.models == "OFFICIAL":
        return _model(sm, p, "official")
    if p.models == "FILES" and p.sv_model_file:
        return _model(sm, p, bpy.path.abspath(p.sv_model_file))
    return _model(sm, p, None)


# ---- Object > Estimate PBR material --------------------------------------------------------------------------
class OBJECT_OT_supermat_estimate_material(bpy.types.Operator):
    """Bake albedo, roughness and metallic textures from each selected mesh's base-colour texture and wire them
    into its Principled BSDF"""
    bl_idname = "object.supermat_estimate_material"
    bl_label = "Estimate PBR material"
    bl_options = {"REGISTER", "UNDO"}

    texture_size: IntProperty(name="Texture size", default=0, min=0, max=8192,
                              description="0 = the preferences'")
    view_size: IntProperty(name="View size", default=0, min=0, max=4096, description="0 = the preferences'")

    _thread = None
    _timer = None

    @classmethod
    def poll(cls, context):
        return any(o.type == "MESH" for o in context.selected_objects)

    def _prepare(self, context):
        p = prefs(context)
        sm = core.import_supermat(p.module_path, p.library_path, p.model_dir)
        settings = bake_settings(sm, p, self.texture_size, self.view_size)
        jobs, warnings = core.collect_jobs(context.selected_objects, context.evaluated_depsgraph_get())
        for w in warnings:
            self.report({"WARNING"}, w)
        return sm, settings, jobs

    def _apply(self, context, jobs):
        n = 0
        for job in jobs:
            if job.apply(bpy):
                n += 1
        self.report({"INFO"}, "supermat: %d material(s) estimated" % n)
        return {"FINISHED"} if n else {"CANCELLED"}

    # from a script or in the background: the bakes run here, progress in the status bar, no Esc (no event loop)
    def execute(self, context):
        try:
            sm, settings, jobs = self._prepare(context)
        except Exception as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if not jobs:
            self.report({"WARNING"}, "supermat: nothing to bake")
            return {"CANCELLED"}
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        try:
            core.run_jobs(sm, settings, jobs, lambda f: wm.progress_update(int(1000 * f)))
        except Exception as e:
            self.report({"ERROR"}, "supermat: %s" % e)
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        return self._apply(context, jobs)

    # from the UI: the bakes run on a thread (the module releases the GIL), Esc cancels between two layers
    def invoke(self, context, event):
        if bpy.app.background or context.window is None:   # no event loop to run a modal operator
            return self.execute(context)
        try:
            self._sm, self._settings, self._jobs = self._prepare(context)
        except Exception as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if not self._jobs:
            self.report({"WARNING"}, "supermat: nothing to bake")
            return {"CANCELLED"}
        self._cancel = threading.Event()
        self._fraction = 0.0
        self._error = None

        def work():
            try:
                core.run_jobs(self._sm, self._settings, self._jobs, lambda f: setattr(self, "_fraction", f),
                              self._cancel.is_set)
            except Exception as e:   # supermat.Cancelled too: reported by modal()
                self._error = e
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(0.1, window=context.window)
        self._thread = threading.Thread(target=work, daemon=True)
        self._thread.start()
        wm.modal_handler_add(self)
        context.workspace.status_text_set("supermat: estimating materials (Esc cancels)")
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._cancel.set()
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}   # the UI stays usable while the bake runs
        if self._thread.is_alive():
            context.window_manager.progress_update(int(1000 * self._fraction))
            return {"RUNNING_MODAL"}
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        if self._error is not None:
            self.report({"WARNING" if self._cancel.is_set() else "ERROR"}, "supermat: %s" % self._error)
            return {"CANCELLED"}
        return self._apply(context, self._jobs)


# ---- Image editor > Image > Estimate PBR maps -------------------------------------------------------------------
class IMAGE_OT_supermat_estimate_maps(bpy.types.Operator):
    """Turn the active image into three new images: albedo (sRGB), roughness and metallic (Non-Color)"""
    bl_idname = "image.supermat_estimate_maps"
    bl_label = "Estimate PBR maps"
    bl_options = {"REGISTER", "UNDO"}

    image: StringProperty(name="Image", default="", description="The image's name; empty: the editor's image")

    @classmethod
    def poll(cls, context):
        return True   # the editor's image, or image= from a script

    def execute(self, context):
        img = bpy.data.images.get(self.image) if self.image else getattr(context.space_data, "image", None)
        if img is None:
            self.report({"ERROR"}, "supermat: no image (open one, or give image=)")
            return {"CANCELLED"}
        p = prefs(context)
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        try:
            sm = core.import_supermat(p.module_path, p.library_path, p.model_dir)
            a = core.image_to_array(img)
            if a.dtype != "uint8":   # a float image is linear: the model reads sRGB-encoded values
                a = core.srgb_encode(a)
            maps = image_model(sm, p).image(a, progress=lambda f, w: wm.progress_update(int(1000 * f)) and False)
        except Exception as e:
            self.report({"ERROR"}, "supermat: %s" % e)
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        stem = os.path.splitext(img.name)[0]
        for name in ("albedo", "roughness", "metallic"):
            m = maps[name]
            if m.dtype != "uint8":
                m = (m.clip(0, 1) * 255 + 0.5).astype("uint8")
            core.new_image(bpy, "%s_%s" % (stem, name), m, "sRGB" if name == "albedo" else "Non-Color")
        self.report({"INFO"}, "supermat: %s_albedo, _roughness, _metallic" % stem)
        return {"FINISHED"}


def _menu_object(self, context):
    self.layout.separator()
    self.layout.operator(OBJECT_OT_supermat_estimate_material.bl_idname)


def _menu_image(self, context):
    self.layout.separator()
    self.layout.operator(IMAGE_OT_supermat_estimate_maps.bl_idname)


_classes = (SupermatPreferences, OBJECT_OT_supermat_estimate_material, IMAGE_OT_supermat_estimate_maps)


def register():
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.VIEW3D_MT_object.append(_menu_object)
    bpy.types.IMAGE_MT_image.append(_menu_image)


def unregister():
    bpy.types.IMAGE_MT_image.remove(_menu_image)
    bpy.types.VIEW3D_MT_object.remove(_menu_object)
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    for m in _models.values():
        try:
            m.close()
        except Exception:
            pass
    _models.clear()
