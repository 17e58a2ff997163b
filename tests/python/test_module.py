"""ctest python_module: the Python module python/supermat (ctypes over libsupermat.so), under pytest.

Checks:
  - the ctypes structs against the library's own sizeof / offsetof (lib/supermat_shared.c), its version against
    supermat.h's; the library and the default model found without environment variables;
  - the maps equal `supermat image`'s files on the same pictures and the default model: the 8-bit maps the PNGs'
    decoded pixels (their alpha the picture's), float32 input (the 8-bit values / 255, as the library reads them)
    the --float PFMs, bit for bit; a subset of outputs, strided input and the progress callback change nothing;
  - each error path raises supermat.Error (or its subclass) with the library's message and result code: a bad
    array dtype / shape / channel count, NaN pixels, a missing model file, a file that is not a model (the
    message `supermat image` prints for it), an empty file, a model of another kind, a closed model;
  - a cancel from the progress callback stops the run (supermat.Cancelled), an exception in it is raised again;
  - two threads sharing one model give the maps of one thread, and a run lets other Python threads run (the GIL
    is released).
Environment (CMakeLists.txt sets them): SUPERMAT_LIBRARY (the library under test), SUPERMAT_TEST_CLI (the
`supermat` tool), SUPERMAT_TEST_WORK (a scratch folder; default: pytest's tmp_path).
usage: python3 -m pytest tests/python/test_module.py   (PYTHONPATH=python)
"""
import json
import os
import re
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from PIL import Image

import supermat
from supermat import _capi
from supermat_tools.common import read_pfm

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
IMG = os.path.join(REPO, "tests", "data", "img")
# RGBA pictures with transparent pixels, and one RGB picture
PICTURES = ["box_40", "ring_48x72", "sphere_64", "ring_exif6_upright"]
FLOAT_PICTURES = ["box_40", "ring_48x72"]
CLI = os.environ.get("SUPERMAT_TEST_CLI") or os.path.join(REPO, "build", "supermat")


def picture(stem):
    return np.asarray(Image.open(os.path.join(IMG, stem + ".png")))


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    w = os.environ.get("SUPERMAT_TEST_WORK")
    if w:
        os.makedirs(w, exist_ok=True)
        return w
    return str(tmp_path_factory.mktemp("python_module"))


@pytest.fixture(scope="module")
def model():
    with supermat.Model() as m:
        yield m


@pytest.fixture(scope="module")
def cli_maps(work):
    """`supermat image` on the pictures (default model): 8-bit PNGs in work/u8, --float PFMs in work/f."""
    if not os.path.isfile(CLI):
        pytest.skip("no supermat tool at %s (SUPERMAT_TEST_CLI)" % CLI)
    for sub, extra, stems in (("u8", [], PICTURES), ("f", ["--float"], FLOAT_PICTURES)):
        out = os.path.join(work, sub)
        subprocess.run([CLI, "image", "--force", "--out", out] + extra +
                       [os.path.join(IMG, s + ".png") for s in stems], check=True)
    return work


_module_maps = {}


def module_maps(model, stem):
    """model.image() of a picture, computed once (the threads test compares against them)."""
    if stem not in _module_maps:
        _module_maps[stem] = model.image(picture(stem))
    return _module_maps[stem]


# ---- the library and the files -------------------------------------------------------------------------
def test_layout_and_version():
    lib = _capi.load()
    assert _capi.layout_mismatches(lib) == []
    header = open(os.path.join(REPO, "supermat.h")).read()
    v = [re.search(r"#define SUPERMAT_VERSION_%s (\d+)" % k, header).group(1) for k in ("MAJOR", "MINOR", "PATCH")]
    assert supermat.library_version() == ".".join(v)
    # the canaries of a fresh descriptor are 0, as the library wants them
    for cls in (_capi.supermat_model_desc, _capi.supermat_session_desc, _capi.supermat_run_desc):
        d = cls()
        assert d._start_canary == 0 and d._end_canary == 0


def _env():
    """This process's environment, PYTHONPATH made absolute: a child in another folder imports this supermat."""
    env = dict(os.environ)
    here = os.path.dirname(os.path.dirname(os.path.abspath(supermat.__file__)))
    paths = [os.path.abspath(p) for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    env["PYTHONPATH"] = os.pathsep.join([here] + paths)
    return env


def _python(code, **env_changes):
    env = _env()
    for k, v in env_changes.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = v
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)


def test_found_without_environment():
    # no SUPERMAT_LIBRARY / SUPERMAT_MODEL: a source checkout's build folder and models/
    r = _python("import supermat; print(supermat.library_path()); print(supermat.default_model_path())",
                SUPERMAT_LIBRARY=None, SUPERMAT_MODEL=None)
    assert r.returncode == 0, r.stderr
    lib, mod = r.stdout.split("\n")[:2]
    assert os.path.isfile(lib) and os.path.realpath(lib).startswith(os.path.realpath(REPO) + os.sep)
    assert os.path.basename(os.path.dirname(lib)).startswith("build")
    assert os.path.realpath(mod) == os.path.realpath(os.path.join(REPO, "models", "supermat_default.safetensors"))
    # SUPERMAT_LIBRARY naming a missing file: an error naming it, no fallback
    r = _python("import supermat\ntry:\n supermat.library_path()\nexcept supermat.LibraryNotFound as e:\n print(e)",
                SUPERMAT_LIBRARY="/nonexistent/libsupermat.so")
    assert r.returncode == 0 and "/nonexistent/libsupermat.so" in r.stdout, r.stdout + r.stderr


# ---- the maps against `supermat image` ---------------------------------------------------------------------
@pytest.mark.parametrize("stem", PICTURES)
def test_maps_equal_cli(model, cli_maps, stem):
    pic = picture(stem)
    maps = module_maps(model, stem)
    assert sorted(maps) == sorted(supermat.MAPS)
    has_alpha = pic.shape[2] == 4 and (pic[..., 3] != 255).any()
    for name, got in maps.items():
        png = np.asarray(Image.open(os.path.join(cli_maps, "u8", "%s_%s.png" % (stem, name))))
        ch = 3 if name == "albedo" else 1
        assert got.dtype == np.uint8 and got.shape == pic.shape[:2] + ((3,) if ch == 3 else ())
        if has_alpha:   # --alpha keep: RGBA / gray + alpha, the alpha the picture's
            assert png.shape[2] == ch + 1
            assert np.array_equal(png[..., ch], pic[..., 3])
            png = png[..., :ch]
        if ch == 1 and png.ndim == 3:
            png = png[..., 0]
        assert np.array_equal(png, got), "%s %s: %d pixels differ" % (stem, name, int((png != got).sum()))


@pytest.mark.parametrize("stem", FLOAT_PICTURES)
def test_float_maps_equal_cli_pfm(model, cli_maps, stem):
    pic = picture(stem).astype(np.float32) / np.float32(255)   # what the library reads from the 8-bit values
    maps = model.image(pic)
    for name, got in maps.items():
        pfm = read_pfm(os.path.join(cli_maps, "f", "%s_%s.pfm" % (stem, name)))
        assert got.dtype == np.float32 and got.shape == pfm.shape
        assert np.array_equal(pfm, got), "%s %s: max difference %g" % (stem, name, np.abs(pfm - got).max())


def test_outputs_strides_and_progress(model):
    stem = "sphere_64"
    full = module_maps(model, stem)
    # a crop of a bigger array (strided rows, read in place) and one output: the same roughness map
    pic = picture(stem)
    big = np.zeros((80, 90, 4), np.uint8)
    big[5:69, 7:71] = pic
    calls = []
    maps = model.image(big[5:69, 7:71], outputs=("roughness",), progress=lambda f, what: calls.append((f, what)))
    assert list(maps) == ["roughness"]
    assert np.array_equal(maps["roughness"], full["roughness"])
    assert calls and all(0.0 <= f <= 1.0 for f, _ in calls)
    assert [f for f, _ in calls] == sorted(f for f, _ in calls)
    assert all(isinstance(w, str) for _, w in calls)


def test_pipeline_options(model):
    # the model file's roughness curve given back as a list (and as the CLI's text) changes nothing; "off" does
    stem = "box_40"
    full = module_maps(model, stem)["roughness"]
    curve = model.info["roughness_curve"]
    assert len(curve) >= 2 and model.info["work_size"] == 256
    as_list = model.image(picture(stem), outputs="roughness", roughness_curve=curve)["roughness"]
    as_text = model.image(picture(stem), outputs="roughness",
                          roughness_curve=",".join(repr(float(v)) for v in curve))["roughness"]
    off = model.image(picture(stem), outputs="roughness", roughness_curve="off")["roughness"]
    assert np.array_equal(as_list, full) and np.array_equal(as_text, full)
    assert not np.array_equal(off, full)
    # the metallic curve (the default model records none): the caller's, on the float maps, is the float64 curve
    # of the network's metallic where the picture is opaque; the roughness untouched
    assert model.info["metallic_curve"] == []
    pic = picture(stem).astype(np.float32) / 255.0
    plain = model.image(pic, outputs=("roughness", "metallic"))
    knots = [0.0, 0.02, 0.3, 0.8, 1.0]
    bent = model.image(pic, outputs=("roughness", "metallic"), metallic_curve=knots)
    want = np.interp(np.clip(plain["metallic"].astype(np.float64), 0, 1), np.linspace(0, 1, len(knots)), knots)
    opaque = pic[..., 3] > 0 if pic.shape[2] == 4 else np.ones(pic.shape[:2], bool)
    assert np.abs(bent["metallic"] - want)[opaque].max() <= 1e-6
    assert np.array_equal(bent["metallic"][~opaque], plain["metallic"][~opaque])
    assert not np.array_equal(bent["metallic"], plain["metallic"])
    assert np.array_equal(bent["roughness"], plain["roughness"])
    assert np.array_equal(model.image(pic, outputs="metallic", metallic_curve="off")["metallic"], plain["metallic"])


# ---- errors ----------------------------------------------------------------------------------------------
def test_cancel(model):
    pic = picture("box_40")
    seen = []

    def cancel(fraction, what):
        seen.append(fraction)
        return True
    with pytest.raises(supermat.Cancelled) as e:
        model.image(pic, progress=cancel)
    assert isinstance(e.value, supermat.Error)
    assert e.value.result == _capi.ERROR_CANCELLED and e.value.result_string == "cancelled"
    assert e.value.message and e.value.message in str(e.value)
    assert len(seen) == 1   # stopped at the first report

    # an exception in the callback stops the run and comes out as itself
    def boom(fraction, what):
        raise KeyError("from the callback")
    with pytest.raises(KeyError, match="from the callback"):
        model.image(pic, progress=boom)
    # the model still works after both
    assert np.array_equal(model.image(pic)["albedo"], module_maps(model, "box_40")["albedo"])


def test_bad_arrays(model):
    pic = picture("box_40")
    for bad in (pic.astype(np.float64), pic.astype(np.int32), pic.astype(">f4")):
        with pytest.raises(supermat.InvalidArgument, match="uint8 .* or float32"):
            model.image(bad)
    with pytest.raises(supermat.InvalidArgument, match="shape"):
        model.image(pic[..., 0])
    # what the library refuses: its message and result code
    for bad in (pic[..., :2], np.zeros((0, 8, 3), np.uint8)):
        with pytest.raises(supermat.Error) as e:
            model.image(np.ascontiguousarray(bad))
        assert e.value.result in (_capi.ERROR_INVALID_ARGUMENT, _capi.ERROR_BAD_IMAGE) and e.value.message
    nan = pic.astype(np.float32) / 255
    nan[3, 4, 1] = np.nan
    with pytest.raises(supermat.Error) as e:
        model.image(nan)
    assert e.value.result == _capi.ERROR_NONFINITE and e.value.message
    with pytest.raises(supermat.InvalidArgument):
        model.image(pic, outputs=("albedo", "normal"))
    with pytest.raises(supermat.InvalidArgument):
        model.image(pic, work_size=13)   # the library: not a multiple of 8
    with pytest.raises(supermat.InvalidArgument):
        model.image(pic, roughness_curve="0.5,0.2")   # supermat_parse_curve: falling
    with pytest.raises(supermat.InvalidArgument, match="metallic_curve"):
        model.image(pic, metallic_curve=[0.2, 1.5])   # the library: out of [0, 1]
    with pytest.raises(supermat.InvalidArgument, match="metallic_curve"):
        model.image(pic, metallic_curve=[])
    with pytest.raises(supermat.InvalidArgument, match="kernel"):
        supermat.Model(kernel="fastest")


def test_bad_model_files(work):
    missing = os.path.join(work, "no_such_model.safetensors")
    with pytest.raises(supermat.ModelNotFound) as e:
        supermat.Model(missing)
    assert isinstance(e.value, FileNotFoundError) and isinstance(e.value, supermat.Error) and missing in str(e.value)
    # a file that is not a model: the library's message, the one `supermat image` prints
    not_model = os.path.join(IMG, "box_40.png")
    with pytest.raises(supermat.Error) as e:
        supermat.Model(not_model)
    assert e.value.result == _capi.ERROR_MALFORMED_FILE and e.value.message
    if os.path.isfile(CLI):
        r = subprocess.run([CLI, "image", "--model", not_model, "--out", os.path.join(work, "x"), not_model],
                           capture_output=True, text=True)
        assert r.returncode == 1 and e.value.message in r.stderr, r.stderr
    empty = os.path.join(work, "empty.safetensors")
    open(empty, "wb").close()
    with pytest.raises(supermat.Error) as e:
        supermat.Model(empty)
    assert e.value.result is not None and e.value.message
    # a model of another kind: it loads, image() refuses it
    with supermat.Model(os.path.join(REPO, "models", "supermat_mv_default.safetensors")) as mv:
        assert mv.kind == "supermat-mv"
        with pytest.raises(supermat.InvalidArgument, match="supermat-mv"):
            mv.image(picture("box_40"))
    # a closed model
    m = supermat.Model()
    m.close()
    with pytest.raises(supermat.Error, match="closed"):
        m.image(picture("box_40"))


# ---- threads -----------------------------------------------------------------------------------------------
def test_threads_share_a_model(model):
    stems = ["box_40", "ring_48x72"]
    expected = {s: module_maps(model, s) for s in stems}
    results, errors = {}, []

    def worker(i):
        try:
            for s in (stems if i == 0 else stems[::-1]):
                results[(i, s)] = model.image(picture(s))
        except BaseException as e:   # reported by the main thread
            errors.append(e)
    ticks = [0]
    threads = [threading.Thread(target=worker, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    # while the runs are in C, this thread keeps running: the GIL is released
    while any(t.is_alive() for t in threads):
        ticks[0] += 1
        time.sleep(0.001)
    for t in threads:
        t.join()
    assert not errors, errors
    assert ticks[0] > 50
    for (i, s), maps in results.items():
        for name in supermat.MAPS:
            assert np.array_equal(maps[name], expected[s][name]), "thread %d, %s, %s" % (i, s, name)
    assert len(results) == 4


# ---- the manual's examples -------------------------------------------------------------------------------
@pytest.mark.parametrize("doc", ["README.md", os.path.join("python", "README.md")])
def test_doc_examples_run(work, doc):
    # the ```python block of each, run in a folder where photo.png is a test picture
    text = open(os.path.join(REPO, doc)).read()
    blocks = re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)
    assert len(blocks) == 1, doc
    folder = os.path.join(work, "doc_" + doc.replace(os.sep, "_"))
    os.makedirs(folder, exist_ok=True)
    Image.open(os.path.join(IMG, "sphere_64.png")).save(os.path.join(folder, "photo.png"))
    r = subprocess.run([sys.executable, "-c", blocks[0]], cwd=folder, env=_env(), capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_ctrl_c_stops_a_run():
    # SIGINT during a long run (the picture at 1024x1024: many seconds) without a progress callable: the
    # run stops at the next layer and KeyboardInterrupt comes out of image()
    code = """if 1:
        import os, signal, threading, time, numpy as np, supermat
        m = supermat.Model()
        pic = np.full((64, 64, 3), 128, np.uint8)
        threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        t0 = time.time()
        try:
            m.image(pic, work_size=1024)
            print("finished")
        except KeyboardInterrupt:
            print("interrupted after %.2f s" % (time.time() - t0))
    """
    r = _python(code)
    assert r.returncode == 0 and "interrupted" in r.stdout, r.stdout + r.stderr
    print(r.stdout)


# ---- bake: the mesh path ---------------------------------------------------------------------------------
def write_cube_gltf(folder):
    """A unit cube (glTF: Y up) into folder/cube.gltf (+ .bin, .png): each face its own 4 vertices with normals,
    UVs in a 3x2 atlas, a patterned texture. Returns the same mesh as supermat_uv.h takes it (Z up) and the
    texture."""
    pos, nrm, uv, idx = [], [], [], []
    faces = [((1, 0, 0), (0, 0, -1), (0, 1, 0)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)), ((0, 1, 0), (1, 0, 0), (0, 0, -1)),
             ((0, -1, 0), (1, 0, 0), (0, 0, 1)), ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (-1, 0, 0), (0, 1, 0))]
    for f, (n, u, v) in enumerate(faces):
        n, u, v = np.array(n, float), np.array(u, float), np.array(v, float)
        cu, cv = (f % 3) / 3.0, (f // 3) / 2.0
        base = len(pos)
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            pos.append(0.5 * (n + a * u + b * v))
            nrm.append(n)
            uv.append((cu + (a + 1) / 2 / 3.0 * 0.9 + 0.015, cv + (1 - b) / 2 / 2.0 * 0.9 + 0.025))
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    pos = np.array(pos, np.float32); nrm = np.array(nrm, np.float32); uv = np.array(uv, np.float32)
    idx = np.array(idx, np.uint32)
    blob = pos.tobytes() + nrm.tobytes() + uv.tobytes() + idx.tobytes()
    n = len(pos)
    views = [dict(buffer=0, byteOffset=0, byteLength=n * 12), dict(buffer=0, byteOffset=n * 12, byteLength=n * 12),
             dict(buffer=0, byteOffset=n * 24, byteLength=n * 8), dict(buffer=0, byteOffset=n * 32, byteLength=idx.size * 4)]
    acc = [dict(bufferView=0, componentType=5126, count=n, type="VEC3", min=pos.min(0).tolist(), max=pos.max(0).tolist()),
           dict(bufferView=1, componentType=5126, count=n, type="VEC3"),
           dict(bufferView=2, componentType=5126, count=n, type="VEC2"),
           dict(bufferView=3, componentType=5125, count=int(idx.size), type="SCALAR")]
    g = dict(asset=dict(version="2.0"), scene=0, scenes=[dict(nodes=[0])], nodes=[dict(mesh=0)],
             meshes=[dict(primitives=[dict(attributes=dict(POSITION=0, NORMAL=1, TEXCOORD_0=2), indices=3, material=0)])],
             materials=[dict(pbrMetallicRoughness=dict(baseColorTexture=dict(index=0), metallicFactor=0.0))],
             textures=[dict(source=0)], images=[dict(uri="cube.png")],
             buffers=[dict(uri="cube.bin", byteLength=len(blob))], bufferViews=views, accessors=acc)
    yy, xx = np.mgrid[0:96, 0:96]
    tex = np.stack([(xx * 2.5) % 256, (yy * 2.5) % 256, ((xx + yy) * 1.3) % 256], -1).astype(np.uint8)
    Image.fromarray(tex).save(folder + "/cube.png")
    open(folder + "/cube.bin", "wb").write(blob)
    json.dump(g, open(folder + "/cube.gltf", "w"))
    # the same mesh as supermat_uv.h takes it: Z up
    def zup(a):
        return np.stack([a[:, 0], -a[:, 2], a[:, 1]], 1)
    return zup(pos), zup(nrm), uv, idx, tex


@pytest.mark.parametrize("passthrough", [True, False])
def test_bake_equals_cli_mesh(work, passthrough):
    # `supermat mesh` on a glTF cube and supermat.bake() on the same mesh: the same texture bytes (passthrough,
    # and the multi-view default model both find without model options)
    if not os.path.isfile(CLI):
        pytest.skip("no supermat tool at %s (SUPERMAT_TEST_CLI)" % CLI)
    built = subprocess.run([CLI, "--version"], capture_output=True, text=True).stdout
    if not re.search(r"^built with:.*\bmesh\b", built, re.M):
        pytest.skip("this supermat was built without `supermat mesh` (libtinygltf-dev)")
    folder = os.path.join(work, "bake_" + ("passthrough" if passthrough else "model"))
    os.makedirs(os.path.join(folder, "out"), exist_ok=True)
    pos, nrm, uv, idx, tex = write_cube_gltf(folder)
    subprocess.run([CLI, "mesh", "--force", "--size", "64", "--views-size", "64"] +
                   (["--passthrough"] if passthrough else []) +
                   [os.path.join(folder, "cube.gltf"), os.path.join(folder, "out", "cube.gltf")], check=True)
    g = json.load(open(os.path.join(folder, "out", "cube.gltf")))
    m = g["materials"][0]["pbrMetallicRoughness"]

    def texture(t):
        uri = g["images"][g["textures"][t["index"]]["source"]]["uri"]
        return np.asarray(Image.open(os.path.join(folder, "out", uri)))[..., :3]
    r = supermat.bake(pos, uv, tex, indices=idx.reshape(-1, 3), normals=nrm, passthrough=passthrough,
                      texture_size=64, view_size=64)
    assert r["base_color"].shape == (64, 64, 3) and r["base_color"].dtype == np.uint8
    assert np.array_equal(texture(m["baseColorTexture"]), r["base_color"])
    assert np.array_equal(texture(m["metallicRoughnessTexture"]), r["metallic_roughness"])
    assert r["stats"]["triangles"] == 12 and r["stats"]["texels_chart"] > 0


def test_bake_errors(work):
    pos, nrm, uv, idx, tex = write_cube_gltf(os.path.join(work))
    with pytest.raises(supermat.InvalidArgument, match="positions"):
        supermat.bake(pos[:, :2], uv, tex, passthrough=True, texture_size=64, view_size=64)
    bad = pos.copy()
    bad[5, 1] = np.nan
    with pytest.raises(supermat.Error) as e:
        supermat.bake(bad, uv, tex, indices=idx, passthrough=True, texture_size=64, view_size=64)
    assert e.value.result is not None and e.value.message
    with pytest.raises(supermat.Error) as e:
        supermat.bake(pos, uv, tex, indices=idx, passthrough=True, texture_size=60, view_size=64)
    assert e.value.result == _capi.ERROR_INVALID_ARGUMENT and e.value.message
    with pytest.raises(supermat.Cancelled):
        supermat.bake(pos, uv, tex, indices=idx, texture_size=64, view_size=64, progress=lambda f, w: True)
