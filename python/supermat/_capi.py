"""The C API of supermat.h and supermat_uv.h as ctypes declarations, and loading libsupermat.so.

The structs mirror the headers field by field, in order, with their C types (enums are C ints). Every one is
checked against the library that was loaded: lib/supermat_shared.c exports supermat_shared_layout, which
answers each struct's sizeof and each field's offsetof as the library was compiled, so a library built from
another supermat.h is refused with a message instead of being handed a struct of the wrong shape.
"""
import ctypes
from ctypes import (CFUNCTYPE, POINTER, Structure, c_char, c_char_p, c_double, c_float, c_int, c_longlong, c_size_t,
                    c_uint, c_uint32, c_uint64, c_void_p)
import threading

from . import _paths

# ---- constants (supermat.h) ---------------------------------------------------------------------------
SUCCESS = 0
ERROR_INVALID_ARGUMENT = -1
ERROR_OUT_OF_MEMORY = -2
ERROR_MALFORMED_FILE = -3
ERROR_UNSUPPORTED = -4
ERROR_MISSING_TENSOR = -5
ERROR_SHAPE_MISMATCH = -6
ERROR_NONFINITE = -7
ERROR_CANCELLED = -8
ERROR_BAD_IMAGE = -9
ERROR_INTERNAL = -10
ERROR_IO = -11

FORMAT_U8, FORMAT_F32 = 0, 1
OUTPUT_ALBEDO, OUTPUT_ROUGHNESS, OUTPUT_METALLIC = 1, 2, 4
WORK_NATIVE = -1
OFF = -1.0
CURVE_OFF = -1
CURVE_MAX_KNOTS = 33

KERNELS = {"auto": 0, "scalar": 1, "avx2": 2, "avx512": 3, "neon": 4, "amx": 5}
WEIGHTS = {"default": 0, "f32": 1, "f16": 2, "bf16": 3, "int8": 4}
CONVS = {"direct": 0, "winograd-f2": 1, "winograd-f4": 2}
COMPUTES = {"f32": 0, "bf16": 1, "int8": 2}
KINDS = {0: "unknown", 1: "supermat", 2: "supermat-mv", 3: "uv-refine"}

# ---- callbacks -------------------------------------------------------------------------------------------
PROGRESS_FN = CFUNCTYPE(c_int, c_void_p, c_float, c_char_p)
INSPECT_FN = CFUNCTYPE(None, c_void_p, c_int, c_int, POINTER(c_float), c_int, c_int, c_int, c_int)
ALLOC_FN = CFUNCTYPE(c_void_p, c_void_p, c_size_t, c_size_t)
FREE_FN = CFUNCTYPE(None, c_void_p, c_void_p, c_size_t)
TASK_FN = CFUNCTYPE(None, c_void_p, c_int, c_int)
PARALLEL_FOR_FN = CFUNCTYPE(None, c_void_p, c_int, TASK_FN, c_void_p)
UV_DEBUG_FN = CFUNCTYPE(None, c_void_p, c_int, c_int, POINTER(c_float), c_int, c_int, c_int)


# ---- structs (named as in C; the order of _fields_ is the header's) ---------------------------------------
class supermat_error(Structure):
    _fields_ = [("result", c_int), ("message", c_char * 256), ("tensor", c_char * 160)]


class supermat_allocator(Structure):
    _fields_ = [("alloc", ALLOC_FN), ("free", FREE_FN), ("user", c_void_p)]


class supermat_threading(Structure):
    _fields_ = [("parallel_for", PARALLEL_FOR_FN), ("user", c_void_p), ("max_threads", c_int)]


class supermat_model_desc(Structure):
    _fields_ = [("_start_canary", c_uint32), ("data", c_void_p), ("size", c_size_t), ("copy_data", c_int),
                ("kernel", c_int), ("weights", c_int), ("conv", c_int), ("allocator", supermat_allocator),
                ("compute", c_int), ("max_memory", c_size_t), ("_end_canary", c_uint32)]


class supermat_model_info(Structure):
    _fields_ = [("kind", c_int), ("kernel", c_int), ("weights", c_int), ("conv", c_int), ("compute", c_int),
                ("unet_in_channels", c_int), ("unet_out_channels", c_int), ("unet_levels", c_int),
                ("layers_per_block", c_int), ("norm_groups", c_int),
                ("block_channels", c_int * 8), ("num_heads", c_int * 8),
                ("cross_attention_dim", c_int), ("context_tokens", c_int), ("branches", c_int),
                ("class_embed_in", c_int),
                ("vae_block_channels", c_int * 8), ("vae_levels", c_int), ("latent_channels", c_int),
                ("scaling_factor", c_float), ("timestep", c_int), ("alphas_cumprod", c_float),
                ("v_prediction", c_int),
                ("unet_params", c_uint64), ("branch_params", c_uint64), ("vae_params", c_uint64),
                ("model_bytes", c_size_t), ("prepacked", c_int), ("prepacked_bytes", c_size_t),
                ("work_size", c_int), ("detail_sigma", c_float), ("chroma_weight", c_float),
                ("bake_detail_sigma", c_float), ("roughness_knots", c_int),
                ("roughness_curve", c_float * CURVE_MAX_KNOTS), ("metallic_knots", c_int),
                ("metallic_curve", c_float * CURVE_MAX_KNOTS)]


class supermat_session_desc(Structure):
    _fields_ = [("_start_canary", c_uint32), ("model", c_void_p), ("width", c_int), ("height", c_int),
                ("outputs", c_uint), ("views", c_int), ("threads", c_int), ("threading", supermat_threading),
                ("allocator", supermat_allocator), ("work_width", c_int), ("work_height", c_int),
                ("vae_tile", c_int), ("vae_overlap", c_int), ("skip_background", c_int), ("mv_attention", c_int),
                ("mv_key_stride", c_int), ("max_memory", c_size_t), ("detail_sigma", c_float),
                ("chroma_weight", c_float), ("roughness_knots", c_int), ("roughness_curve", POINTER(c_float)),
                ("metallic_knots", c_int), ("metallic_curve", POINTER(c_float)),
                ("_end_canary", c_uint32)]


class supermat_image(Structure):
    _fields_ = [("pixels", c_void_p), ("width", c_int), ("height", c_int), ("channels", c_int),
                ("stride", c_size_t), ("format", c_int)]


class supermat_run_desc(Structure):
    _fields_ = [("_start_canary", c_uint32), ("input", supermat_image),
                ("albedo", supermat_image), ("roughness", supermat_image), ("metallic", supermat_image),
                ("orm", supermat_image),
                ("input_views", POINTER(supermat_image)), ("cameras", POINTER(c_float)),
                ("albedo_views", POINTER(supermat_image)), ("roughness_views", POINTER(supermat_image)),
                ("metallic_views", POINTER(supermat_image)), ("orm_views", POINTER(supermat_image)),
                ("mask", supermat_image), ("position", supermat_image), ("refined", supermat_image),
                ("chart", supermat_image),
                ("progress", PROGRESS_FN), ("progress_user", c_void_p),
                ("inspect", INSPECT_FN), ("inspect_user", c_void_p), ("_end_canary", c_uint32)]


class supermat_uv_part(Structure):
    _fields_ = [("_start_canary", c_uint32), ("positions", POINTER(c_float)), ("position_stride", c_size_t),
                ("uvs", POINTER(c_float)), ("uv_stride", c_size_t), ("normals", POINTER(c_float)),
                ("normal_stride", c_size_t), ("vertex_count", c_uint32), ("indices", POINTER(c_uint32)),
                ("index_stride", c_size_t), ("index_count", c_uint32), ("base_color", supermat_image),
                ("base_color_factor", POINTER(c_float)), ("wrap_u", c_int), ("wrap_v", c_int), ("output", c_int),
                ("_end_canary", c_uint32)]


class supermat_uv_bake_desc(Structure):
    _fields_ = [("_start_canary", c_uint32), ("parts", POINTER(supermat_uv_part)), ("part_count", c_int),
                ("output_count", c_int), ("texture_width", c_int), ("texture_height", c_int), ("view_size", c_int),
                ("view_work_size", c_int), ("refine_work_size", c_int), ("supersample", c_int),
                ("ortho_half_width", c_float), ("uv_origin_bottom_left", c_int), ("position_frame", c_int),
                ("passthrough", c_int), ("mv_model", c_void_p), ("albedo_refine_model", c_void_p),
                ("rm_refine_model", c_void_p), ("keep_observed", c_int), ("weight", c_int), ("cos_power", c_float),
                ("max_angle_deg", c_float), ("depth_tolerance", c_float), ("edge_reject", c_int),
                ("keep_mixed", c_int), ("gutter", c_int), ("threads", c_int), ("threading", supermat_threading),
                ("allocator", supermat_allocator), ("max_memory", c_size_t),
                ("progress", PROGRESS_FN), ("progress_user", c_void_p),
                ("debug", UV_DEBUG_FN), ("debug_user", c_void_p), ("detail_sigma", c_float),
                ("detail_limit", c_float), ("_end_canary", c_uint32)]


class supermat_uv_output(Structure):
    _fields_ = [("base_color", supermat_image), ("metallic_roughness", supermat_image)]


class supermat_uv_stats(Structure):
    _fields_ = [("triangles", c_uint32), ("triangles_degenerate", c_uint32), ("triangles_uv_degenerate", c_uint32),
                ("triangles_uv_too_large", c_uint32), ("view_center", c_double * 3), ("view_scale", c_double),
                ("position_center", c_double * 3), ("position_scale", c_double), ("texels_chart", c_uint64),
                ("texels_seen", c_uint64), ("texels_overlap", c_uint64)]


STRUCTS = [supermat_error, supermat_allocator, supermat_threading, supermat_model_desc, supermat_model_info,
           supermat_session_desc, supermat_image, supermat_run_desc, supermat_uv_part, supermat_uv_bake_desc,
           supermat_uv_output, supermat_uv_stats]

# ---- functions: name -> (restype, argtypes) ----------------------------------------------------------------
E = POINTER(supermat_error)
FUNCTIONS = {
    "supermat_shared_version": (c_int, []),
    "supermat_shared_layout": (c_longlong, [c_char_p]),
    "supermat_result_string": (c_char_p, [c_int]),
    "supermat_model_create": (c_int, [POINTER(supermat_model_desc), POINTER(c_void_p), E]),
    "supermat_model_get_info": (None, [c_void_p, POINTER(supermat_model_info)]),
    "supermat_model_destroy": (None, [c_void_p]),
    "supermat_session_memory": (c_int, [POINTER(supermat_session_desc), POINTER(c_size_t), E]),
    "supermat_session_create": (c_int, [POINTER(supermat_session_desc), POINTER(c_void_p), E]),
    "supermat_session_destroy": (None, [c_void_p]),
    "supermat_run": (c_int, [c_void_p, POINTER(supermat_run_desc), E]),
    "supermat_parse_curve": (c_int, [c_char_p, POINTER(c_float), POINTER(c_int), E]),
    "supermat_default_threads": (c_int, []),
    "supermat_uv_cameras": (None, [POINTER(c_float)]),
    "supermat_uv_bake_memory": (c_int, [POINTER(supermat_uv_bake_desc), POINTER(c_size_t), E]),
    "supermat_uv_bake": (c_int, [POINTER(supermat_uv_bake_desc), POINTER(supermat_uv_output),
                                 POINTER(supermat_uv_stats), E]),
}


class LoadError(Exception):
    """The library was not found, could not be loaded, or does not match these declarations."""


def layout_mismatches(lib):
    """The differences between the ctypes structs and the loaded library's (empty when they agree)."""
    bad = []
    for cls in STRUCTS:
        name = cls.__name__
        want = lib.supermat_shared_layout(name.encode())
        if want != ctypes.sizeof(cls):
            bad.append("sizeof(%s): library %d, module %d" % (name, want, ctypes.sizeof(cls)))
        for field in cls._fields_:
            want = lib.supermat_shared_layout(("%s.%s" % (name, field[0])).encode())
            have = getattr(cls, field[0]).offset
            if want != have:
                bad.append("offsetof(%s, %s): library %d, module %d" % (name, field[0], want, have))
    return bad


_lock = threading.Lock()
_lib = None
_lib_path = None


def load():
    """The loaded library (ctypes.CDLL: every call releases the GIL), loaded once; LoadError if it cannot be."""
    global _lib, _lib_path
    with _lock:
        if _lib is not None:
            return _lib
        path, tried = _paths.find_library()
        if path is None:
            raise LoadError("libsupermat (the shared library of supermat.h) was not found; looked at:\n  " +
                            "\n  ".join(tried) + "\nBuild it with `cmake --build build --target supermat_shared` "
                            "(or install it with `cmake --install build`), or set SUPERMAT_LIBRARY to its path")
        try:
            lib = ctypes.CDLL(path)
        except OSError as e:
            raise LoadError("cannot load %s: %s" % (path, e)) from None
        for name, (restype, argtypes) in FUNCTIONS.items():
            try:
                fn = getattr(lib, name)
            except AttributeError:
                raise LoadError("%s has no function %s: not a libsupermat built from lib/supermat_shared.c of this "
                                "version" % (path, name)) from None
            fn.restype = restype
            fn.argtypes = argtypes
        bad = layout_mismatches(lib)
        if bad:
            v = lib.supermat_shared_version()
            raise LoadError("%s (supermat.h %d.%d.%d) does not match this module's declarations of the C structs: "
                            "%s. Use the library and the module of one checkout or release"
                            % (path, v >> 16, (v >> 8) & 255, v & 255, "; ".join(bad[:6])))
        _lib, _lib_path = lib, path
        return lib


def loaded_path():
    """The path (or linker name) of the loaded library, loading it if needed."""
    load()
    return _lib_path
