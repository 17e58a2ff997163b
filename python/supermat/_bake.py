"""supermat.bake: a textured mesh -> albedo and metallic-roughness UV textures (supermat_uv.h's supermat_uv_bake),
for one mesh with one base-colour texture and one output texture, as `supermat mesh` bakes each material."""
import ctypes
import os

import numpy as np

from . import _capi

_WRAPS = {"repeat": 0, "clamp": 1, "mirror": 2}


def _floats(name, a, width):
    """A packed (N, width) float32 array (a copy only when needed)."""
    from . import InvalidArgument
    a = np.ascontiguousarray(np.asarray(a, dtype=np.float32))
    if a.ndim != 2 or a.shape[1] != width:
        raise InvalidArgument("%s has shape %s: give (count, %d)" % (name, a.shape, width), _capi.ERROR_INVALID_ARGUMENT)
    return a


def _default_view_model():
    """The model `supermat mesh` bakes with when no model is named: supermat_mv_default.safetensors beside the
    default model, else the default (single-view) model itself, run view by view."""
    from . import Model, default_model_path
    sv = default_model_path()
    mv = os.path.join(os.path.dirname(sv), "supermat_mv_default.safetensors")
    return Model(mv if os.path.isfile(mv) else sv)


def bake(positions, uvs, base_color=None, *, indices=None, normals=None, base_color_factor=None, wrap="repeat",
         model=None, albedo_refine=None, rm_refine=None, passthrough=False, texture_size=1024, view_size=512,
         detail=None, detail_limit=None, threads=0, progress=None, float_output=False):
    """One textured mesh -> {"base_color", "metallic_roughness", "stats"}, as `supermat mesh` bakes a material.

    positions (N, 3) and normals (N, 3, optional): world coordinates, Z up, the object's front facing -Y (a glTF
    asset is Y up: (x, y, z) -> (x, -z, y), as `supermat mesh` converts it); uvs (N, 2): glTF UVs (v = 0 at the
    texture's first row); indices: (T, 3) or (3T,) vertex indices, None = a plain triangle list. base_color: the
    texture, (H, W, C) with C 1 to 4 (alpha ignored), uint8 sRGB or float32 linear; None = the factor alone.
    base_color_factor: linear RGBA (glTF baseColorFactor), None = 1. wrap: "repeat" (glTF's default), "clamp",
    "mirror", or a (u, v) pair.
    model: a supermat.Model of kind supermat-mv (or a single-view one, run view by view); None = what
    `supermat mesh` uses without model options (the multi-view default beside the default model).
    albedo_refine, rm_refine: UV-refine Models (`supermat mesh --refine`), None = no refinement.
    passthrough: no network (albedo = the rendered colour, roughness 0.5, metallic 0): tests the geometry.
    texture_size: the output's side (a multiple of 8; `supermat mesh --size`), view_size: the rendered views'
    (`--views-size`); detail: None = the view model's, "off", or a value (`--detail`); detail_limit: None = 4 (the
    library's), "off" (unbounded) or a ratio above 1 (`--detail-limit`); threads: 0 = all cores.
    Returns "base_color" (S, S, 3) uint8 sRGB and "metallic_roughness" (S, S, 3) uint8 linear (R 1, G roughness,
    B metallic), float32 (the base colour linear) with float_output; "stats": supermat_uv_stats as a dict.
    progress, errors and Ctrl-C: as Model.image()."""
    from . import InvalidArgument, Model, _check, _lib, _step, _input_array, _image, _with_progress
    lib = _lib()
    pos = _floats("positions", positions, 3)
    uv = _floats("uvs", uvs, 2)
    if uv.shape[0] != pos.shape[0]:
        raise InvalidArgument("uvs has %d rows, positions %d" % (uv.shape[0], pos.shape[0]),
                              _capi.ERROR_INVALID_ARGUMENT)
    nrm = _floats("normals", normals, 3) if normals is not None else None
    if nrm is not None and nrm.shape[0] != pos.shape[0]:
        raise InvalidArgument("normals has %d rows, positions %d" % (nrm.shape[0], pos.shape[0]),
                              _capi.ERROR_INVALID_ARGUMENT)
    idx = None
    if indices is not None:
        idx = np.asarray(indices)
        if idx.dtype.kind not in "iu":
            raise InvalidArgument("indices are %s: give integers" % idx.dtype, _capi.ERROR_INVALID_ARGUMENT)
        if idx.size and (idx.min() < 0 or idx.max() > 0xFFFFFFFF):
            raise InvalidArgument("indices out of range", _capi.ERROR_INVALID_ARGUMENT)
        idx = np.ascontiguousarray(idx.reshape(-1), dtype=np.uint32)
    tex = None
    if base_color is not None:
        tex, tex_fmt = _input_array(base_color, gray=True)
    factor = None
    if base_color_factor is not None:
        factor = np.ascontiguousarray(np.asarray(base_color_factor, dtype=np.float32).reshape(-1))
        if factor.size != 4:
            raise InvalidArgument("base_color_factor: 4 values (linear RGBA)", _capi.ERROR_INVALID_ARGUMENT)
    wu, wv = (wrap, wrap) if isinstance(wrap, str) else tuple(wrap)
    fp = _capi.POINTER(_capi.c_float)

    part = _capi.supermat_uv_part()
    part.positions = pos.ctypes.data_as(fp)
    part.uvs = uv.ctypes.data_as(fp)
    part.vertex_count = pos.shape[0]
    if nrm is not None:
        part.normals = nrm.ctypes.data_as(fp)
    if idx is not None:
        part.indices = idx.ctypes.data_as(_capi.POINTER(_capi.c_uint32))
        part.index_count = idx.size
    if tex is not None:
        part.base_color = _image(tex, tex_fmt)
    if factor is not None:
        part.base_color_factor = factor.ctypes.data_as(fp)
    part.wrap_u = _WRAPS.get(wu, -1)
    part.wrap_v = _WRAPS.get(wv, -1)
    if part.wrap_u < 0 or part.wrap_v < 0:
        raise InvalidArgument("wrap=%r: repeat, clamp or mirror (or a pair)" % (wrap,), _capi.ERROR_INVALID_ARGUMENT)

    s = int(texture_size)
    dtype, fmt = (np.float32, _capi.FORMAT_F32) if float_output else (np.uint8, _capi.FORMAT_U8)
    out_bc = np.empty((s, s, 3), dtype)
    out_mr = np.empty((s, s, 3), dtype)
    out = _capi.supermat_uv_output()
    out.base_color = _image(out_bc, fmt)
    out.metallic_roughness = _image(out_mr, fmt)

    bd = _capi.supermat_uv_bake_desc()
    bd.parts = ctypes.pointer(part)
    bd.part_count = 1
    bd.output_count = 1
    bd.texture_width = bd.texture_height = s
    bd.view_size = int(view_size)
    bd.passthrough = 1 if passthrough else 0
    bd.detail_sigma = _step("detail", detail)
    bd.detail_limit = _step("detail_limit", detail_limit)
    bd.threads = int(threads)

    owned = None   # a model this call loads (model=None), closed at its end
    models = []
    try:
        if not passthrough:
            if model is None:
                model = owned = _default_view_model()
            for m, field in ((model, "mv_model"), (albedo_refine, "albedo_refine_model"), (rm_refine, "rm_refine_model")):
                if m is None:
                    continue
                if not isinstance(m, Model):
                    raise InvalidArgument("%s: a supermat.Model" % field, _capi.ERROR_INVALID_ARGUMENT)
                setattr(bd, field, m._acquire())
                models.append(m)
        err = _capi.supermat_error()
        stats = _capi.supermat_uv_stats()
        r, caught, interrupted = _with_progress(lambda: lib.supermat_uv_bake(bd, out, stats, err), bd, progress)
    finally:
        for m in models:
            m._release()
        if owned is not None:
            owned.close()
    _check(r, caught, interrupted, err, "bake")
    st = {name: (list(getattr(stats, name)) if hasattr(getattr(stats, name), "__len__") else getattr(stats, name))
          for name, _ in _capi.supermat_uv_stats._fields_}
    return {"base_color": out_bc, "metallic_roughness": out_mr, "stats": st}

