"""Where the shared library and the default model are: pure Python, no ctypes (so that it can be tested and
printed without loading anything).

The library (libsupermat.so, CMake's target supermat_shared), the first that exists of:
  1. $SUPERMAT_LIBRARY, when set and not empty (a file that is not there is an error: no fallback);
  2. beside this package (a copy put into python/supermat/ or the installed package's folder);
  3. in a source checkout (this package at <repo>/python/supermat): <repo>/build*/libsupermat.so, the most
     recently built first;
  4. the standard prefixes: <sys.prefix>/lib, /usr/local/lib (and lib64, lib/<multiarch>), /usr/lib, ...;
  5. what ctypes.util.find_library("supermat") finds (the dynamic linker's cache).

The default model (supermat_default.safetensors), as `supermat image` finds it, the first that exists of:
  1. $SUPERMAT_MODEL, when set and not empty (a file that is not there is an error: no fallback);
  2. installed beside the library: <libdir>/../share/supermat/ (and ../../share for lib/<multiarch>);
  3. the source checkout's models/ (this package's, or the one whose build folder holds the library);
  4. the model folder `supermat download` fills: $SUPERMAT_MODEL_DIR, else $XDG_DATA_HOME/supermat, else
     ~/.local/share/supermat;
  5. <sys.prefix>/share/supermat, /usr/local/share/supermat, /usr/share/supermat.
"""
import ctypes.util
import glob
import os
import sys
import sysconfig

PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
DEFAULT_MODEL = "supermat_default.safetensors"
# the files `supermat download official` writes into the model folder (cli/model.c, cli_named_models)
NAMED_MODELS = {
    "official": "supermat_official.safetensors",
    "official-mv": "supermat_mv_official.safetensors",
    "official-refine-albedo": "supermat_refine_albedo_official.safetensors",
    "official-refine-rm": "supermat_refine_rm_official.safetensors",
}


def _library_names():
    """The library's file names on this platform, unversioned first."""
    if sys.platform == "win32":
        return ["supermat.dll", "libsupermat.dll"]
    if sys.platform == "darwin":
        return ["libsupermat.dylib"]
    return ["libsupermat.so"]


def source_checkout():
    """The repository root when this package is python/supermat of a source checkout, else None."""
    repo = os.path.dirname(os.path.dirname(PACKAGE_DIR))
    if os.path.isfile(os.path.join(repo, "supermat.h")) and os.path.isfile(os.path.join(repo, "CMakeLists.txt")):
        return repo
    return None


def _prefix_lib_dirs():
    """The library folders of the usual prefixes, this Python's first."""
    multiarch = sysconfig.get_config_var("MULTIARCH") or ""
    dirs = []
    for prefix in (sys.prefix, "/usr/local", "/usr"):
        for sub in ("lib", "lib64", os.path.join("lib", multiarch) if multiarch else None):
            if sub:
                dirs.append(os.path.join(prefix, sub))
    dirs.append(os.path.expanduser("~/.local/lib"))
    seen, out = set(), []
    for d in dirs:
        if d not in seen:
            seen.add(d)
            out.append(d)
    return out


def library_candidates():
    """(path or name, where) in the order they are tried; the env var's entry is always first when set."""
    out = []
    env = os.environ.get("SUPERMAT_LIBRARY")
    if env:
        return [(env, "$SUPERMAT_LIBRARY")]
    for name in _library_names():
        out.append((os.path.join(PACKAGE_DIR, name), "beside the package"))
    repo = source_checkout()
    if repo:
        found = []
        for name in _library_names():
            found += glob.glob(os.path.join(repo, "build*", name))
        found.sort(key=lambda p: os.path.getmtime(p) if os.path.exists(p) else 0, reverse=True)
        out += [(p, "the source checkout's build folder") for p in found]
        if not found:
            out.append((os.path.join(repo, "build*", _library_names()[0]), "the source checkout's build folders"))
    for d in _prefix_lib_dirs():
        for name in _library_names():
            out.append((os.path.join(d, name), "a standard prefix"))
    return out


def find_library():
    """(path, tried): the library's path (or a name the dynamic linker resolves), or None and the places tried.
    $SUPERMAT_LIBRARY naming a missing file gives None."""
    tried = []
    for path, where in library_candidates():
        tried.append("%s (%s)" % (path, where))
        if os.path.isfile(path):
            return path, tried
        if where == "$SUPERMAT_LIBRARY":
            return None, tried
    name = ctypes.util.find_library("supermat")
    tried.append("ctypes.util.find_library('supermat'): %s" % (name or "nothing"))
    return name, tried


def model_dir():
    """The model folder of the CLI ($SUPERMAT_MODEL_DIR, $XDG_DATA_HOME/supermat, ~/.local/share/supermat), or None."""
    env = os.environ.get("SUPERMAT_MODEL_DIR")
    if env:
        return env.rstrip("/") or "/"
    xdg = os.environ.get("XDG_DATA_HOME")
    if sys.platform == "win32":
        local = os.environ.get("LOCALAPPDATA")
        return os.path.join(local, "supermat") if local else None
    if xdg and xdg.startswith("/"):
        return os.path.join(xdg, "supermat")
    home = os.environ.get("HOME")
    if not home:
        return None
    if sys.platform == "darwin":
        return os.path.join(home, "Library", "Application Support", "supermat")
    return os.path.join(home, ".local", "share", "supermat")


def default_model_candidates(library_path=None):
    """(path, where) in the order they are tried (see the module's docstring)."""
    env = os.environ.get("SUPERMAT_MODEL")
    if env:
        return [(env, "$SUPERMAT_MODEL")]
    out = []
    if library_path and os.path.isabs(library_path):
        libdir = os.path.dirname(os.path.realpath(library_path))
        for up in ("..", os.path.join("..", "..")):
            p = os.path.normpath(os.path.join(libdir, up, "share", "supermat", DEFAULT_MODEL))
            out.append((p, "installed beside the library"))
    repo = source_checkout()
    if repo:
        out.append((os.path.join(repo, "models", DEFAULT_MODEL), "the source checkout"))
    if library_path and os.path.isabs(library_path):
        # a library used from a checkout's build folder (an installed module, SUPERMAT_LIBRARY): that checkout's
        built_in = os.path.dirname(os.path.dirname(os.path.realpath(library_path)))
        if os.path.isfile(os.path.join(built_in, "supermat.h")):
            out.append((os.path.join(built_in, "models", DEFAULT_MODEL), "the checkout the library was built in"))
    d = model_dir()
    if d:
        out.append((os.path.join(d, DEFAULT_MODEL), "the model folder"))
    for prefix in (sys.prefix, "/usr/local", "/usr"):
        out.append((os.path.join(prefix, "share", "supermat", DEFAULT_MODEL), "a standard prefix"))
    seen, uniq = set(), []
    for p, w in out:
        if p not in seen:
            seen.add(p)
            uniq.append((p, w))
    return uniq


def find_default_model(library_path=None):
    """(path, tried): the default model's path, or None and the places tried."""
    tried = []
    for path, where in default_model_candidates(library_path):
        tried.append("%s (%s)" % (path, where))
        if os.path.isfile(path) or where == "$SUPERMAT_MODEL":
            return (path if os.path.isfile(path) else None), tried
    return None, tried
