"""Helpers the tools share (one copy each): the repository's paths, starting a sibling tool in a new process,
the asset#node syntax, PFM reading and atomic JSON writes."""
import json
import os
import subprocess
import sys

import numpy as np

PACKAGE_PARENT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))   # <repo>/python
REPO = os.path.dirname(PACKAGE_PARENT)
SUPERMAT = os.path.join(REPO, "build", "supermat")   # the default `supermat` executable


def tool_command(name, *args):
    """The command line that runs the sibling tool NAME (python -m supermat_tools.NAME) with this interpreter."""
    return [sys.executable, "-m", f"supermat_tools.{name}", *map(str, args)]


def tool_env():
    """os.environ with this package's parent first on PYTHONPATH, so a child tool imports this same package."""
    env = dict(os.environ)
    paths = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    if not paths or os.path.abspath(paths[0]) != PACKAGE_PARENT:
        env["PYTHONPATH"] = os.pathsep.join([PACKAGE_PARENT] + paths)
    return env


def run_tool(name, *args, **kw):
    """subprocess.run of the sibling tool NAME with ARGS (keywords go to subprocess.run)."""
    return subprocess.run(tool_command(name, *args), env=tool_env(), **kw)


def split_asset(asset):
    """FILE.gltf#NODE -> (FILE.gltf, NODE); a plain path (or one that exists with its '#') -> (path, None)."""
    if "#" in asset and not os.path.exists(asset):
        path, node = asset.rsplit("#", 1)
        return path, node
    return asset, None


def read_pfm(path):
    """A PFM file as float32 (H, W, 3) or (H, W), top row first."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        c = 3 if kind == b"PF" else 1
        a = np.frombuffer(f.read(w * h * c * 4), "<f4" if scale < 0 else ">f4").reshape(h, w, c)[::-1]
    return a[..., 0] if c == 1 else a


def write_json(path, obj):
    """json.dump(obj, indent=1) into PATH through PATH.tmp (a reader never sees half a file)."""
    with open(path + ".tmp", "w") as f:
        json.dump(obj, f, indent=1)
    os.replace(path + ".tmp", path)
