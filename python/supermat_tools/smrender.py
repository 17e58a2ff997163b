"""Physically based shading shared by supermat's training-data generator and its quality evaluation.

numpy only.  One convention everywhere:
  * world space = camera space: the camera looks down -Z, +Y is up, +X right; orthographic views, so
    the direction to the viewer is +Z at every pixel;
  * a G-buffer is a dict of HxW(x3) float32 arrays: 'cov' (coverage 0..1), 'n' (unit normal),
    'p' (position), 'albedo' (LINEAR base colour; a metal's is its F0), 'rough', 'metal' (linear);
  * shading is Cook-Torrance GGX (Smith, Schlick Fresnel) + Lambert under an environment map with
    split-sum prefiltering, optionally plus one directional light (shadows are the caller's: 'sun_vis');
  * the picture is tone mapped as a renderer's "Standard" view: exposure x white balance, clip, sRGB.

Environment maps are Radiance .hdr equirectangular images (only the CC0 Poly Haven maps of the public
pmndrs/drei-assets repository are used).  Prefiltered levels are cached next to the map (.smenv.npz).
"""
import os
import numpy as np

ROUGH_LEVELS = np.array([0.0, 0.2, 0.35, 0.5, 0.7, 1.0], np.float32)


# ----------------------------------------------------------------------------------------------------------
# colour
# ----------------------------------------------------------------------------------------------------------
def srgb_encode(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055).astype(np.float32)


def srgb_decode(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4)).astype(np.float32)


def luminance(rgb):
    return rgb[..., 0] * 0.2126 + rgb[..., 1] * 0.7152 + rgb[..., 2] * 0.0722


# ----------------------------------------------------------------------------------------------------------
# Radiance .hdr
# ----------------------------------------------------------------------------------------------------------
def read_hdr(path):
    """Radiance RGBE (new-style run-length encoded or flat) -> HxWx3 float32 linear."""
    with open(path, "rb") as f:
        data = f.read()
    pos = 0
    header_end = data.find(b"\n\n")
    if header_end < 0 or not data.startswith(b"#?"):
        raise ValueError(f"{path}: not a Radiance HDR file")
    pos = header_end + 2
    eol = data.find(b"\n", pos)
    res = data[pos:eol].split()
    pos = eol + 1
    if len(res) != 4 or res[0] != b"-Y" or res[2] != b"+X":
        raise ValueError(f"{path}: unsupported orientation {res}")
    h, w = int(res[1]), int(res[3])
    buf = np.frombuffer(data, np.uint8, offset=pos)
    out = np.empty((h, w, 4), np.uint8)
    i = 0
    for y in range(h):
        if w >= 8 and w < 32768 and buf[i] == 2 and buf[i + 1] == 2 and not (buf[i + 2] & 0x80):
            i += 4
            for c in range(4):
                x = 0
                row = out[y, :, c]
                while x < w:
                    n = int(buf[i])
                    i += 1
                    if n > 128:
                        n -= 128
                        row[x:x + n] = buf[i]
                        i += 1
                    else:
                        row[x:x + n] = buf[i:i + n]
                        i += n
                    x += n
        else:
            out[y] = buf[i:i + 4 * w].reshape(w, 4)
            i += 4 * w
    e = out[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0).astype(np.float32)
    return out[..., :3].astype(np.float32) * scale[..., None]


def box_down(img, f):
    h, w = img.shape[:2]
    return img[:h - h % f, :w - w % f].reshape(h // f, f, w // f, f, *img.shape[2:]).mean(axis=(1, 3))


# ----------------------------------------------------------------------------------------------------------
# equirectangular directions (world +Y up; u = 0.5 looks down -Z)
# ----------------------------------------------------------------------------------------------------------
def equirect_dirs(h, w):
    v = (np.arange(h, dtype=np.float64) + 0.5) / h
    u = (np.arange(w, dtype=np.float64) + 0.5) / w
    theta = v * np.pi
    phi = (u - 0.5) * 2 * np.pi
    st = np.sin(theta)[:, None]
    d = np.stack([st * np.sin(phi)[None, :], np.cos(theta)[:, None] * np.ones((1, w)),
                  -st * np.cos(phi)[None, :]], -1)
    dw = (2 * np.pi / w) * (np.pi / h) * st * np.ones((1, w))
    return d, dw


def sample_equirect(img, d):
    """Bilinear lookup of an equirect image in directions d (...x3, unit)."""
    h, w = img.shape[:2]
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    u = np.arctan2(x, -z) / (2 * np.pi) + 0.5
    v = np.arccos(np.clip(y, -1, 1)) / np.pi
    fx = u * w - 0.5
    fy = np.clip(v * h - 0.5, 0, h - 1)
    x0 = np.floor(fx).astype(np.int64)
    y0 = np.floor(fy).astype(np.int64)
    tx = (fx - x0)[..., None].astype(np.float32)
    ty = (fy - y0)[..., None].astype(np.float32)
    x1 = (x0 + 1) % w
    x0 = x0 % w
    y1 = np.minimum(y0 + 1, h - 1)
    return ((img[y0, x0] * (1 - tx) + img[y0, x1] * tx) * (1 - ty) +
            (img[y1, x0] * (1 - tx) + img[y1, x1] * tx) * ty)


def ggx_d(nh, a):
    a2 = a * a
    t = nh * nh * (a2 - 1) + 1
    return a2 / (np.pi * t * t)


def _convolve(src, src_dirs, src_dw, out_dirs, weight_fn, chunk=512):
    s = src.reshape(-1, 3).astype(np.float64)
    sd = src_dirs.reshape(-1, 3)
    sw = src_dw.reshape(-1)
    od = out_dirs.reshape(-1, 3)
    out = np.empty((od.shape[0], 3))
    for i in range(0, od.shape[0], chunk):
        c = od[i:i + chunk] @ sd.T
        wgt = weight_fn(c) * sw[None, :]
        out[i:i + chunk] = (wgt @ s) / np.maximum(wgt.sum(1, keepdims=True), 1e-30)
    return out.reshape(*out_dirs.shape[:-1], 3).astype(np.float32)


class EnvLight:
    """An environment map prepared for split-sum shading: mirror + prefiltered specular levels and
    irradiance.  `rot` (3x3) turns world directions into map directions."""

    def __init__(self, path, cache=True):
        self.path = path
        self.name = os.path.basename(path).split(".")[0]
        cpath = path + ".smenv.npz"
        if cache and os.path.exists(cpath) and os.path.getmtime(cpath) >= os.path.getmtime(path):
            z = np.load(cpath)
            self.levels = [z[f"l{i}"] for i in range(len(ROUGH_LEVELS))]
            self.irr = z["irr"]
            return
        hdr = read_hdr(path)
        f = max(1, hdr.shape[1] // 256)
        mirror = box_down(hdr, f)                              # 256x128
        s128 = box_down(mirror, 2)                             # 128x64
        s64 = box_down(mirror, 4)                              # 64x32
        d128, w128 = equirect_dirs(*s128.shape[:2])
        d64, w64 = equirect_dirs(*s64.shape[:2])
        self.levels = [mirror.astype(np.float32)]
        for r in ROUGH_LEVELS[1:]:
            a = float(r) ** 2
            fn = (lambda c, a=a: ggx_d(np.sqrt(np.clip((1 + c) / 2, 0, 1)), a) * np.maximum(c, 0))
            if r < 0.3:
                self.levels.append(_convolve(s128, d128, w128, d128, fn))
            else:
                self.levels.append(_convolve(s64, d64, w64, d64, fn))
        d32, _ = equirect_dirs(16, 32)
        self.irr = (np.pi * _convolve(s64, d64, w64, d32, lambda c: np.maximum(c, 0)))  # E(n)
        if cache:
            try:
                np.savez(cpath, irr=self.irr, **{f"l{i}": l for i, l in enumerate(self.levels)})
            except OSError:
                pass

    def specular(self, r_dirs, rough):
        """Prefiltered radiance along reflection directions, interpolated in roughness."""
        rough = np.clip(rough, 0, 1)
        idx = np.clip(np.searchsorted(ROUGH_LEVELS, rough, side="right") - 1, 0, len(ROUGH_LEVELS) - 2)
        t = ((rough - ROUGH_LEVELS[idx]) / (ROUGH_LEVELS[idx + 1] - ROUGH_LEVELS[idx]))[..., None]
        out = np.zeros(r_dirs.shape, np.float32)
        for i in range(len(ROUGH_LEVELS) - 1):
            m = idx == i
            if not m.any():
                continue
            a = sample_equirect(self.levels[i], r_dirs[m])
            b = sample_equirect(self.levels[i + 1], r_dirs[m])
            out[m] = a * (1 - t[m]) + b * t[m]
        return out

    def irradiance(self, n_dirs):
        return sample_equirect(self.irr, n_dirs)

    def background(self, d):
        return sample_equirect(self.levels[0], d)


_LUT = None


def brdf_lut(n=32, samples=1024):
    """Split-sum scale/bias (A, B) for F0 over (n.v, roughness), GGX + Smith (k = a/2), Schlick."""
    global _LUT
    if _LUT is not None:
        return _LUT
    rng = np.random.default_rng(1234)
    u1 = (np.arange(samples) + 0.5) / samples
    u2 = rng.random(samples)
    lut = np.zeros((n, n, 2), np.float32)
    for j in range(n):
        r = max((j + 0.5) / n, 0.02)
        a = r * r
        k = a / 2
        ct = np.sqrt((1 - u1) / (1 + (a * a - 1) * u1))
        st = np.sqrt(1 - ct * ct)
        ph = 2 * np.pi * u2
        hx, hz = st * np.cos(ph), ct
        for i in range(n):
            nv = (i + 0.5) / n
            vx, vz = np.sqrt(1 - nv * nv), nv
            vh = vx * hx + vz * hz
            lz = 2 * vh * hz - vz
            ok = lz > 0
            nl, nh, vh_ = lz[ok], hz[ok], vh[ok]
            g = (nl / (nl * (1 - k) + k)) * (nv / (nv * (1 - k) + k))
            gv = g * vh_ / (nh * nv)
            fc = (1 - vh_) ** 5
            lut[j, i, 0] = ((1 - fc) * gv).sum() / samples
            lut[j, i, 1] = (fc * gv).sum() / samples
    _LUT = lut
    return lut


def lut_lookup(nv, rough):
    lut = brdf_lut()
    n = lut.shape[0]
    fi = np.clip(nv * n - 0.5, 0, n - 1)
    fj = np.clip(rough * n - 0.5, 0, n - 1)
    i0 = np.floor(fi).astype(np.int64)
    j0 = np.floor(fj).astype(np.int64)
    i1 = np.minimum(i0 + 1, n - 1)
    j1 = np.minimum(j0 + 1, n - 1)
    ti = (fi - i0)[..., None]
    tj = (fj - j0)[..., None]
    return ((lut[j0, i0] * (1 - ti) + lut[j0, i1] * ti) * (1 - tj) + (lut[j1, i0] * (1 - ti) + lut[j1, i1] * ti) * tj)


def shade(gb, env, rot=np.eye(3), sun=None):
    """Linear HDR radiance of every pixel of a G-buffer (background left 0).

    env: EnvLight; rot: 3x3 world -> map rotation; sun: None or dict(dir=unit 3-vector towards the light,
    rgb=irradiance (3,), vis=HxW visibility in 0..1)."""
    cov = gb["cov"]
    m = cov > 0
    n = gb["n"][m].astype(np.float32)
    alb = gb["albedo"][m]
    r = np.clip(gb["rough"][m], 0.02, 1.0)
    met = gb["metal"][m][..., None]
    v = np.array([0, 0, 1], np.float32)
    nv = np.clip(n @ v, 1e-4, 1.0)
    refl = 2 * nv[:, None] * n - v[None, :]
    f0 = 0.04 * (1 - met) + alb * met
    ab = lut_lookup(nv, r)
    spec = env.specular(refl @ rot.T, r) * (f0 * ab[:, :1] + ab[:, 1:2])
    fr = f0 + (np.maximum(1 - r[:, None], f0) - f0) * ((1 - nv) ** 5)[:, None]   # roughness-aware Schlick
    kd = (1 - fr) * (1 - met)
    diff = kd * alb / np.pi * env.irradiance(n @ rot.T)
    col = diff + spec
    if sun is not None:
        l = np.asarray(sun["dir"], np.float32)
        nl = np.clip(n @ l, 0, 1)
        h = (l + v) / np.linalg.norm(l + v)
        nh = np.clip(n @ h, 0, 1)
        vh = float(np.clip(v @ h, 0, 1))
        a = r * r
        k = (r + 1) ** 2 / 8
        g = (nl / (nl * (1 - k) + k)) * (nv / (nv * (1 - k) + k))
        fs = f0 + (1 - f0) * (1 - vh) ** 5
        brdf = fs * (ggx_d(nh, a) * g / np.maximum(4 * nl * nv, 1e-4))[:, None] + (1 - fs) * (1 - met) * alb / np.pi
        col = col + brdf * (nl * sun["vis"][m])[:, None] * np.asarray(sun["rgb"], np.float32)[None, :]
    out = np.zeros(cov.shape + (3,), np.float32)
    out[m] = col
    return out


def shade_facing(n, albedo, rough, metal, env, rot):
    """Linear radiance towards a viewer along the normal (n . v = 1), smrender's model (smr.shade's split-sum
    terms with v = n): diffuse (1 - F0)(1 - metallic) albedo / pi x irradiance + prefiltered radiance along
    n x (F0 A + B)."""
    r = np.clip(rough, 0.02, 1.0)
    met = metal[:, None]
    f0 = 0.04 * (1 - met) + albedo * met
    ab = lut_lookup(np.ones_like(r), r)
    spec = env.specular(n @ rot.T, r) * (f0 * ab[:, :1] + ab[:, 1:2])
    diff = (1 - f0) * (1 - met) * albedo / np.pi * env.irradiance(n @ rot.T)
    return diff + spec


def tonemap(lin, exposure, wb):
    """Renderer 'Standard' view: scale, clip to [0,1], sRGB OETF."""
    return srgb_encode(lin * exposure * np.asarray(wb, np.float32))


def auto_exposure(lin, cov, key):
    lum = luminance(lin)[cov > 0.5]
    if lum.size == 0:
        return 1.0
    med = float(np.median(lum))
    return key / max(med, 1e-6)


def rotation_y(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], np.float32)


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]], np.float32)
