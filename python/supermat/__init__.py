"""supermat: pictures of objects -> albedo, roughness and metallic maps, on the CPU (the SuperMat UNet).

A Python module over the C library supermat.h, through ctypes and numpy alone: it loads libsupermat.so (CMake's
target supermat_shared) and gives the maps `supermat image` writes, as numpy arrays.

    import numpy as np, supermat
    from PIL import Image
    model = supermat.Model()                      # the default model, as `supermat image` finds it
    maps = model.image(np.asarray(Image.open("photo.png").convert("RGBA")))
    maps["albedo"]      # (H, W, 3) uint8, sRGB
    maps["roughness"]   # (H, W) uint8, linear
    maps["metallic"]    # (H, W) uint8, linear

The model file's pipeline (its work size, detail and colour steps, roughness and metallic curves) is applied
unless an argument says otherwise, so the maps are `supermat image`'s, byte for byte. supermat.bake() does the same for
a textured mesh (supermat_uv.h, `supermat mesh`). Where the library and the default
model are looked for: supermat._paths (or supermat.library_path(), supermat.default_model_path()).
"""
import mmap
import os
import signal
import threading

import numpy as np

from . import _capi, _paths
from ._capi import LoadError

__all__ = ["Model", "bake", "Error", "Cancelled", "InvalidArgument", "ModelNotFound", "LibraryNotFound", "library_path",
           "default_model_path", "library_version", "MAPS"]
__version__ = "0.2.0"

# the maps image() makes, in the CLI's order
MAPS = ("albedo", "roughness", "metallic")
_OUTPUT_BITS = {"albedo": _capi.OUTPUT_ALBEDO, "roughness": _capi.OUTPUT_ROUGHNESS, "metallic": _capi.OUTPUT_METALLIC}


# ---- errors ---------------------------------------------------------------------------------------------
class Error(Exception):
    """An error of the library or of this module. message: the library's message (supermat_error.message) or
    this module's; result: the library's result code (supermat.h's supermat_result, e.g. -3 for
    SUPERMAT_ERROR_MALFORMED_FILE), None for errors the library never saw; result_string: the library's name
    for it (supermat_result_string: "cancelled", ...); tensor: the model file's tensor concerned, or "";
    str(e): what was being done, then the message."""

    def __init__(self, message, result=None, tensor="", context=""):
        self.message = message
        self.result = result
        self.tensor = tensor
        self.result_string = _result_string(result)
        text = (context + ": " if context else "") + message
        if tensor:
            text += " (tensor %s)" % tensor
        super().__init__(text)


class InvalidArgument(Error, ValueError):
    """A bad argument: an array of the wrong shape or type, an unknown option; the library's INVALID_ARGUMENT
    and BAD_IMAGE results."""


class Cancelled(Error):
    """The progress callback asked to stop (returned True): the library's CANCELLED result."""


class ModelNotFound(Error, FileNotFoundError):
    """The model file is not there, or no default model was found."""


class LibraryNotFound(Error, ImportError):
    """libsupermat could not be found or loaded, or was built from another supermat.h."""


def _result_string(result):
    if result is None:
        return None
    try:
        s = _capi.load().supermat_result_string(result)
        return s.decode() if s else None
    except LoadError:
        return None


def _raise(result, err, context):
    """Raise the Error subclass for a library result with the supermat_error it filled."""
    cls = {_capi.ERROR_CANCELLED: Cancelled, _capi.ERROR_INVALID_ARGUMENT: InvalidArgument,
           _capi.ERROR_BAD_IMAGE: InvalidArgument}.get(result, Error)
    raise cls(err.message.decode("utf-8", "replace"), result, err.tensor.decode("utf-8", "replace"), context)


def _lib():
    try:
        return _capi.load()
    except LoadError as e:
        raise LibraryNotFound(str(e)) from None


# ---- where things are ------------------------------------------------------------------------------------
def library_path():
    """The path of the libsupermat this module uses (loading it)."""
    _lib()
    return _capi.loaded_path()


def library_version():
    """The version of the supermat.h the library was built from, as "major.minor.patch"."""
    v = _lib().supermat_shared_version()
    return "%d.%d.%d" % (v >> 16, (v >> 8) & 255, v & 255)


def default_model_path():
    """The default model's path, as Model() finds it; ModelNotFound listing the places when there is none."""
    lib_path = library_path()
    path, tried = _paths.find_default_model(lib_path)
    if path:
        return path
    env = os.environ.get("SUPERMAT_MODEL")
    if env:
        raise ModelNotFound("SUPERMAT_MODEL is set to '%s', which is not there (unset it for the default model)" % env)
    raise ModelNotFound("no default model (%s); looked at:\n  %s\nGive Model(path), or set SUPERMAT_MODEL"
                        % (_paths.DEFAULT_MODEL, "\n  ".join(tried)))


def _model_path(path):
    """A Model's path argument -> a file: None or "default" = the default model, a name of
    `supermat download official` (official, official-mv, ...) = its file in the model folder, else a path."""
    if path is None or path == "default":
        return default_model_path()
    path = os.fspath(path)
    if path in _paths.NAMED_MODELS:
        d = _paths.model_dir()
        if not d:
            raise ModelNotFound("model %s: no model folder (neither SUPERMAT_MODEL_DIR nor HOME is set)" % path)
        p = os.path.join(d, _paths.NAMED_MODELS[path])
        if not os.path.isfile(p):
            raise ModelNotFound("model %s: %s is not there (`supermat download official` downloads and converts the "
                                "official networks into the model folder %s)" % (path, p, d))
        return p
    return path


def _choice(what, value, table):
    try:
        return table[value]
    except (KeyError, TypeError):
        raise InvalidArgument("%s=%r: one of %s" % (what, value, ", ".join(sorted(table))),
                              _capi.ERROR_INVALID_ARGUMENT) from None


# ---- the model -------------------------------------------------------------------------------------------
class Model:
    """A model file, memory-mapped and loaded once (weights packed for this CPU); shared by threads: each
    image() call runs its own session (C: supermat_session), so calls from several threads run at once.

    path: a model file made by `supermat convert`; None or "default": the default model (as `supermat image`
    finds it: $SUPERMAT_MODEL, the installed share/supermat/, the source checkout's models/, the model folder);
    "official" (and official-mv, ...): the files `supermat download official` writes into the model folder.
    threads: per image() call, 0 = all cores the process may use, 1 = the calling thread only.
    kernel ("auto", "scalar", "avx2", "avx512", "neon", "amx"), weights ("default", "f32", "f16", "bf16",
    "int8"), conv ("direct", "winograd-f2", "winograd-f4"), compute ("f32", "bf16", "int8"): the speed levers of
    supermat_model_desc (docs/levers.md; the defaults are `supermat image`'s). max_memory: bytes the model may
    hold (0 = no limit).

    The file stays mapped as long as the model (the C model borrows it); close() (or `with Model() as m:`)
    releases both at once, else the garbage collector does."""

    def __init__(self, path=None, threads=0, *, kernel="auto", weights="default", conv="direct", compute="f32",
                 max_memory=0):
        self._handle = None
        self._map = None
        self._lock = threading.Lock()
        self._active = 0
        lib = _lib()
        self.path = _model_path(path)
        self.threads = int(threads)
        desc = _capi.supermat_model_desc()
        desc.kernel = _choice("kernel", kernel, _capi.KERNELS)
        desc.weights = _choice("weights", weights, _capi.WEIGHTS)
        desc.conv = _choice("conv", conv, _capi.CONVS)
        desc.compute = _choice("compute", compute, _capi.COMPUTES)
        desc.max_memory = int(max_memory)
        context = "model '%s'" % self.path
        try:
            with open(self.path, "rb") as f:
                size = os.fstat(f.fileno()).st_size
                # an empty file cannot be mapped: the library is given no bytes and says what is wrong
                mapped = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) if size else None
        except FileNotFoundError as e:
            raise ModelNotFound("%s: %s" % (self.path, e.strerror), context="model") from None
        except OSError as e:
            raise Error("cannot read %s: %s" % (self.path, e.strerror), context="model") from None
        # the mapping's address through numpy (ctypes takes only writable buffers); the array keeps it exported
        view = np.frombuffer(mapped, dtype=np.uint8) if mapped is not None else None
        desc.data = view.ctypes.data if view is not None else None
        desc.size = size
        handle = _capi.c_void_p()
        err = _capi.supermat_error()
        r = lib.supermat_model_create(desc, handle, err)
        if r != _capi.SUCCESS:
            del view
            if mapped is not None:
                mapped.close()
            _raise(r, err, context)
        self._handle = handle
        self._map = (mapped, view)
        info = _capi.supermat_model_info()
        lib.supermat_model_get_info(handle, info)
        self._info = info

    # ---- what the file is ----
    @property
    def kind(self):
        """"supermat" (single view: image()), "supermat-mv" or "uv-refine"."""
        return _capi.KINDS.get(self._info.kind, "unknown")

    @property
    def info(self):
        """supermat_model_info as a dict: kind, work_size, detail_sigma, chroma_weight, roughness_curve,
        metallic_curve (the pipeline the file records), model_bytes, unet_params, ..."""
        i = self._info
        out = {}
        for name, _ in _capi.supermat_model_info._fields_:
            v = getattr(i, name)
            out[name] = list(v) if hasattr(v, "__len__") else v
        out["kind"] = self.kind
        out["roughness_curve"] = list(i.roughness_curve[:max(i.roughness_knots, 0)])
        out["metallic_curve"] = list(i.metallic_curve[:max(i.metallic_knots, 0)])
        for name, table in (("kernel", _capi.KERNELS), ("weights", _capi.WEIGHTS), ("conv", _capi.CONVS),
                            ("compute", _capi.COMPUTES)):
            out[name] = {v: k for k, v in table.items()}.get(out[name], out[name])
        return out

    # ---- life ----
    def close(self):
        """Destroy the C model and unmap the file (also done by the garbage collector). Not while a call runs."""
        with self._lock:
            if self._active:
                raise Error("the model is in use by %d running call(s)" % self._active, context="close")
            handle, self._handle = self._handle, None
            mapped, self._map = self._map, None
        if handle:
            _capi.load().supermat_model_destroy(handle)
        if mapped is not None:
            m = mapped[0]
            del mapped   # the last reference to the numpy view, which holds the mapping's buffer exported
            if m is not None:
                m.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            if getattr(self, "_handle", None):
                self.close()
        except Exception:
            pass

    def __repr__(self):
        return "supermat.Model(%r, kind=%s, work_size=%d)" % (self.path, self.kind, self._info.work_size)

    def _acquire(self):
        with self._lock:
            if not self._handle:
                raise Error("the model was closed", context="model")
            self._active += 1
            return self._handle

    def _release(self):
        with self._lock:
            self._active -= 1

    # ---- one picture ----
    def image(self, array, work_size=None, outputs=MAPS, progress=None, *, detail=None, chroma=None,
              roughness_curve=None, metallic_curve=None, threads=None, max_memory=0):
        """One picture -> its maps, as `supermat image` makes them: a dict name -> numpy array.

        array: (H, W, 3) RGB or (H, W, 4) RGBA (straight alpha), uint8 (0..255) or float32 (0..1), sRGB-encoded
        as pictures are; any size (rows may be strided: a crop of a bigger array is read in place).
        Returns, at the picture's size, for uint8 input: "albedo" (H, W, 3) uint8 sRGB, "roughness" and
        "metallic" (H, W) uint8 linear; for float32 input the same shapes as float32 in 0..1. Only the names in
        `outputs` are computed and returned.
        Alpha: the maps have no alpha channel. `supermat image` writes a picture with transparent pixels as RGBA
        and gray + alpha PNGs whose alpha is the picture's own (array[..., 3]); the RGB and gray values are these.
        Pixels of alpha 0 hold what the network computed over the gray 0.5 background.

        work_size: None = the model file's (the default model's 256), "native" = the picture's own size
        (multiples of 8), N = N x N (--native, --work-size N). detail, chroma: None = the file's, "off" (or
        False), or a value (--detail, --chroma). roughness_curve: None = the file's, "off", or the knots (a
        list, or the CLI's text "0.2,0.5,0.8"); metallic_curve the same (--metallic-curve). threads: None = the
        model's. max_memory: bytes this call's session may take (0 = no limit).
        progress: a callable progress(fraction, what) called between layers (on the calling thread, with the
        GIL); a true return value stops the run with supermat.Cancelled, an exception stops it and is raised
        again here. Ctrl-C (KeyboardInterrupt) stops a run between two layers, with or without a callable.
        Raises supermat.Error (InvalidArgument for bad arrays and options, Cancelled) with the library's
        message and result code."""
        lib = _lib()
        a, fmt = _input_array(array)
        h, w, c = a.shape
        if isinstance(outputs, str):
            outputs = (outputs,)
        outputs = tuple(outputs)
        bits = 0
        for name in outputs:
            if name not in _OUTPUT_BITS:
                raise InvalidArgument("outputs: %r is not one of %s" % (name, ", ".join(MAPS)),
                                      _capi.ERROR_INVALID_ARGUMENT)
            bits |= _OUTPUT_BITS[name]
        if not bits:
            raise InvalidArgument("outputs: none asked for (albedo, roughness, metallic)", _capi.ERROR_INVALID_ARGUMENT)

        sd = _capi.supermat_session_desc()
        sd.width, sd.height, sd.outputs = w, h, bits
        sd.threads = self.threads if threads is None else int(threads)
        sd.work_width = sd.work_height = _work(work_size)
        sd.detail_sigma = _step("detail", detail)
        sd.chroma_weight = _step("chroma", chroma)
        curves = []  # the knot arrays stay alive until the run
        for name, v in (("roughness", roughness_curve), ("metallic", metallic_curve)):
            knots = _curve(lib, name + "_curve", v)
            if knots is None:
                setattr(sd, name + "_knots", 0)
            elif isinstance(knots, int):
                setattr(sd, name + "_knots", _capi.CURVE_OFF)
            else:
                setattr(sd, name + "_knots", len(knots))
                setattr(sd, name + "_curve", knots)
                curves.append(knots)
        sd.max_memory = int(max_memory)

        dtype = np.uint8 if fmt == _capi.FORMAT_U8 else np.float32
        maps = {}
        rd = _capi.supermat_run_desc()
        rd.input = _image(a, fmt)
        for name in MAPS:
            if name in outputs:
                maps[name] = np.empty((h, w, 3) if name == "albedo" else (h, w), dtype)
                setattr(rd, name, _image(maps[name], fmt))

        err = _capi.supermat_error()
        handle = self._acquire()
        try:
            if self._info.kind != 1:
                raise InvalidArgument("model '%s' is a %s model; image() runs supermat (single-view) models"
                                      % (self.path, self.kind), _capi.ERROR_INVALID_ARGUMENT)
            sd.model = handle
            sess = _capi.c_void_p()
            r = lib.supermat_session_create(sd, sess, err)
            if r != _capi.SUCCESS:
                _raise(r, err, "session for a %dx%d picture" % (w, h))
            try:
                r, caught, interrupted = _with_progress(lambda: lib.supermat_run(sess, rd, err), rd, progress)
            finally:
                lib.supermat_session_destroy(sess)
        finally:
            self._release()
        _check(r, caught, interrupted, err, "image")
        return maps


def _with_progress(call, desc, progress):
    """call() (a supermat_run or supermat_uv_bake of desc) with desc.progress set: (result, [exception], interrupted).

    progress: the callable's answer, or its exception (kept, and raised again by the caller after the run). The
    callback is installed without a callable too, for Ctrl-C: the library calls it between layers on the calling
    thread, where Python runs its signal handlers; while the run is in C, SIGINT only sets `interrupted` (a
    KeyboardInterrupt raised on entering the callback would be swallowed by ctypes), the callback then cancels
    the run and the caller raises KeyboardInterrupt."""
    caught, interrupted = [], []

    def on_progress(user, fraction, what):
        try:
            if interrupted:
                return 1
            if progress is None:
                return 0
            return 1 if progress(float(fraction), what.decode() if what else "") else 0
        except BaseException as e:  # re-raised after the run (KeyboardInterrupt too)
            caught.append(e)
            return 1
    desc.progress = _capi.PROGRESS_FN(on_progress)
    old_sigint = None   # only the main thread has signal handlers; a program's own handler is kept
    if (threading.current_thread() is threading.main_thread() and
            signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        old_sigint = signal.signal(signal.SIGINT, lambda signum, frame: interrupted.append(signum))
    try:
        r = call()
    finally:
        if old_sigint is not None:
            signal.signal(signal.SIGINT, old_sigint)
    return r, caught, bool(interrupted)


def _check(r, caught, interrupted, err, context):
    """After _with_progress's call: the callable's exception, then Ctrl-C, then the library's error, raised."""
    if caught:
        raise caught[0]
    if interrupted:
        raise KeyboardInterrupt
    if r != _capi.SUCCESS:
        _raise(r, err, context)


# ---- arguments -> C ----------------------------------------------------------------------------------------
def _input_array(array, gray=False):
    """(array, format): an (H, W, C) uint8 or float32 array whose pixels are packed (rows may be strided);
    gray: an (H, W) array is taken as (H, W, 1)."""
    a = np.asarray(array)
    if gray and a.ndim == 2:
        a = a[:, :, None]
    if a.dtype == np.uint8:
        fmt = _capi.FORMAT_U8
    elif a.dtype == np.float32 and a.dtype.isnative:
        fmt = _capi.FORMAT_F32
    else:
        raise InvalidArgument("the picture is a %s array: give uint8 (0..255) or float32 (0..1), e.g. "
                              "array.astype(np.float32)" % a.dtype, _capi.ERROR_INVALID_ARGUMENT)
    if a.ndim != 3:
        raise InvalidArgument("the picture has shape %s: give (height, width, 3) RGB or (height, width, 4) RGBA"
                              % (a.shape,), _capi.ERROR_INVALID_ARGUMENT)
    s = a.strides
    if not (s[2] == a.itemsize and s[1] == a.shape[2] * a.itemsize and s[0] >= s[1] * a.shape[1]):
        a = np.ascontiguousarray(a)
    return a, fmt


def _image(a, fmt):
    """A supermat_image over a numpy array (H, W) or (H, W, C); borrows its memory."""
    img = _capi.supermat_image()
    img.pixels = a.ctypes.data if a.size else None
    img.height, img.width = int(a.shape[0]), int(a.shape[1])
    img.channels = int(a.shape[2]) if a.ndim == 3 else 1
    img.stride = int(a.strides[0])
    img.format = fmt
    return img


def _work(v):
    """work_size -> session_desc.work_width/height: None 0 (the file's), "native" SUPERMAT_WORK_NATIVE, N."""
    if v is None:
        return 0
    if v == "native":
        return _capi.WORK_NATIVE
    if isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v > 0:
        return int(v)
    raise InvalidArgument("work_size=%r: None (the model's), 'native' or a positive multiple of 8" % (v,),
                          _capi.ERROR_INVALID_ARGUMENT)


def _step(what, v):
    """detail / chroma -> the session field: None 0 (the file's), "off" / False SUPERMAT_OFF, a value."""
    if v is None:
        return 0.0
    if v is False or v == "off":
        return _capi.OFF
    if isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool) and v > 0:
        return float(v)
    raise InvalidArgument("%s=%r: None (the model's), 'off' or a value > 0" % (what, v), _capi.ERROR_INVALID_ARGUMENT)


def _curve(lib, what, v):
    """roughness_curve / metallic_curve (what) -> None (the file's), CURVE_OFF, or a ctypes float array of knots."""
    if v is None:
        return None
    if v is False or v == "off":
        return _capi.CURVE_OFF
    if isinstance(v, str):
        knots = (_capi.c_float * _capi.CURVE_MAX_KNOTS)()
        n = _capi.c_int()
        err = _capi.supermat_error()
        r = lib.supermat_parse_curve(v.encode(), knots, n, err)
        if r != _capi.SUCCESS:
            _raise(r, err, what)
        return (_capi.c_float * n.value)(*knots[:n.value])
    vals = [float(x) for x in v]
    if not vals:
        raise InvalidArgument("%s=[]: None (the model's), 'off' or 2 to %d knots" % (what, _capi.CURVE_MAX_KNOTS),
                              _capi.ERROR_INVALID_ARGUMENT)
    return (_capi.c_float * len(vals))(*vals)


from ._bake import bake  # noqa: E402 (it uses the names above)
