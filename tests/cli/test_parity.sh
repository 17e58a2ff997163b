#!/usr/bin/env bash
# tests/cli/test_parity.sh - the shortest correct program gets the same maps as the CLI (issue 59).
#
#   bash tests/cli/test_parity.sh BUILD/supermat tests/data
#
# examples/image_to_pbr.c leaves every session field 0 (the model file's pipeline: work size, detail,
# colour) and asks the library for RGBA / gray + alpha maps when the picture has a transparent pixel;
# `supermat image` sets nothing of its own. On pictures made here (256x256 RGB, 1000x750 RGB, 97x131 RGBA
# with a transparent background and soft alpha edges, an opaque RGBA file, a gray + alpha file) both give,
# with the default model, the same decoded pixels in the three PNGs (size, channels, every byte: the PNG
# files may differ), and the example gives them again on the default model pre-packed by `supermat pack`.
# Also: `image --native` refuses the 97x131 picture (exit 1, multiples of 8) and the example exits 1 on a
# missing picture or model file. The example is BUILD/example_image_to_pbr (the target of the ctest `example`,
# built by the default target with the CLI's flags: -ffp-contract=off, multiply-adds never fused; built
# with gcc's GNU default -ffp-contract=fast a few values differ by 1/255). Pictures are written and PNGs
# decoded by /usr/bin/python3 with numpy and zlib (the comparison is checked to find one changed byte first).
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

PY=/usr/bin/python3
EXAMPLE=$(dirname "$BIN")/example_image_to_pbr
if [ ! -x "$EXAMPLE" ]; then
    bad "setup: $EXAMPLE is missing (build the target example_image_to_pbr)"
    summary
fi
if ! "$PY" -c 'import numpy, zlib' 2>/dev/null; then
    bad "setup: $PY with numpy is needed (Debian's python3-numpy)"
    summary
fi

# png.py: make PICTURE DIR (the pictures), cmp A B (decoded pixels; exit 1 with the first differing pixel),
# selftest PNG DIR (the comparison finds one changed byte, and a re-encoded copy equal)
cat >"$T/png.py" <<'EOF'
import struct, sys, zlib
import numpy as np

def write(path, px):
    """8-bit PNG of an HxW (gray), HxWx2/3/4 array, filter 0 on every row"""
    px = np.ascontiguousarray(px, dtype=np.uint8)
    h, w = px.shape[:2]
    c = 1 if px.ndim == 2 else px.shape[2]
    raw = b"".join(b"\0" + px[y].tobytes() for y in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    ihdr = struct.pack(">IIBBBBB", w, h, 8, {1: 0, 2: 4, 3: 2, 4: 6}[c], 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))

def chunks(path):
    """(IHDR fields, the decompressed IDAT stream) of a PNG"""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(path + ": not a PNG")
    pos, idat, hdr = 8, [], None
    while pos < len(data):
        n, t = struct.unpack(">I4s", data[pos:pos + 8])
        if t == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", data[pos + 8:pos + 21])
        elif t == b"IDAT":
            idat.append(data[pos + 8:pos + 8 + n])
        elif t == b"IEND":
            break
        pos += 12 + n
    if hdr is None:
        raise ValueError(path + ": no IHDR")
    return hdr, zlib.decompress(b"".join(idat))

def checked(path):
    """(IHDR fields, stream, channels) of an 8-bit, non-interlaced PNG of colour type 0/2/4/6 (else an error)"""
    hdr, raw = chunks(path)
    w, h, depth, ctype, _, _, interlace = hdr
    if depth != 8 or interlace or ctype not in (0, 2, 4, 6):
        raise ValueError("%s: depth %d, colour type %d, interlace %d: not read here" % (path, depth, ctype, interlace))
    c = {0: 1, 2: 3, 4: 2, 6: 4}[ctype]
    if len(raw) != h * (w * c + 1):
        raise ValueError("%s: %d bytes of pixel data, expected %d" % (path, len(raw), h * (w * c + 1)))
    if max(raw[::w * c + 1]) > 4:
        raise ValueError("%s: a row filter > 4" % path)
    return hdr, raw, c

def read(path):
    """(pixels H x W x channels uint8, channels) of a PNG that checked() takes"""
    hdr, raw, c = checked(path)
    w, h = hdr[0], hdr[1]
    stride = w * c
    out = np.zeros((h, stride), np.uint8)
    prev = np.zeros(stride, np.int32)
    for y in range(h):
        f = raw[y * (stride + 1)]
        row = np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int32)
        if f == 0:
            cur = row
        elif f == 2:
            cur = (row + prev) & 255
        elif f == 1:   # Sub: a running sum per channel
            cur = np.cumsum(row.reshape(w, c), axis=0).reshape(stride) & 255
        elif f in (3, 4):   # Average, Paeth: left to right
            r, p, cur = row.tolist(), prev.tolist(), [0] * stride
            for i in range(stride):
                a = cur[i - c] if i >= c else 0
                b = p[i]
                if f == 3:
                    cur[i] = (r[i] + ((a + b) >> 1)) & 255
                else:
                    d = p[i - c] if i >= c else 0
                    pa, pb, pc = abs(b - d), abs(a - d), abs(a + b - 2 * d)
                    cur[i] = (r[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else d)) & 255
            cur = np.array(cur, np.int32)
        else:
            raise ValueError("%s: row %d has filter %d" % (path, y, f))
        out[y] = cur
        prev = cur
    return out.reshape(h, w, c), c

def compare(a, b):
    """None when the decoded pixels are identical, else what differs first"""
    if checked(a)[:2] == checked(b)[:2]:   # the same header and filtered rows: the same pixels, not unfiltered
        return None
    pa, ca = read(a)
    pb, cb = read(b)
    if pa.shape != pb.shape:
        return "%s is %dx%d, %d channels; %s is %dx%d, %d channels" % (a, pa.shape[1], pa.shape[0], ca, b, pb.shape[1], pb.shape[0], cb)
    diff = np.any(pa != pb, axis=2)
    if not diff.any():
        return None
    y, x = np.argwhere(diff)[0]
    return "%d of %d pixels differ, the first at x=%d y=%d: %s %s, %s %s" % (
        diff.sum(), diff.size, x, y, a, list(pa[y, x]), b, list(pb[y, x]))

def make(which, path):
    rng = np.random.default_rng(59)
    if which == "rgb256":   # a lit sphere with a checker pattern on a flat backdrop
        h = w = 256
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
        nx, ny = (xx - 128) / 100, (yy - 120) / 100
        inside = nx * nx + ny * ny < 1
        nz = np.sqrt(np.clip(1 - nx * nx - ny * ny, 0, 1))
        shade = np.clip(0.2 + 0.8 * (-0.4 * nx - 0.5 * ny + 0.77 * nz), 0, 1)
        check = ((xx // 16 + yy // 16) % 2)[..., None]
        base = np.where(check, [0.8, 0.3, 0.2], [0.9, 0.85, 0.7])
        px = np.where(inside[..., None], base * shade[..., None], [0.35, 0.4, 0.45] + 0.1 * yy[..., None] / h)
        write(path, np.round(np.clip(px, 0, 1) * 255))
    elif which == "rgb1000x750":   # gradients, stripes and noise: no multiple of the work size
        h, w = 750, 1000
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
        px = np.stack([xx / w, yy / h, 0.5 + 0.4 * np.sin(xx / 23.0) * np.cos(yy / 17.0)], axis=2)
        px += rng.normal(0, 0.04, px.shape)
        write(path, np.round(np.clip(px, 0, 1) * 255))
    elif which == "rgba97x131":   # an ellipse on a transparent background (its colour junk), soft edges
        h, w = 131, 97
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
        r = np.sqrt(((xx - 48) / 40) ** 2 + ((yy - 65) / 55) ** 2)
        alpha = np.clip((1 - r) / 0.15, 0, 1)   # 0 outside, a ramp of ~6-8 pixels, 1 inside
        rgb = np.stack([0.3 + 0.5 * xx / w, 0.6 - 0.3 * yy / h, 0.4 + 0.3 * np.sin(xx / 5.0)], axis=2)
        rgb = np.where(alpha[..., None] > 0, rgb, rng.uniform(0, 1, rgb.shape))
        px = np.concatenate([rgb, alpha[..., None]], axis=2)
        write(path, np.round(np.clip(px, 0, 1) * 255))
    elif which == "rgba_opaque":   # a 4-channel file whose alpha is all 255: no alpha in the maps
        px = np.concatenate([rng.integers(0, 256, (48, 64, 3)), np.full((48, 64, 1), 255)], axis=2)
        write(path, px)
    elif which == "gray_alpha":   # a 2-channel file with transparent pixels: alpha in the maps
        yy, xx = np.mgrid[0:40, 0:50]
        write(path, np.stack([(xx * 5) % 256, np.where(xx < 10, 0, np.minimum(255, (xx - 10) * 20))], axis=2))
    else:
        raise ValueError(which)

def selftest(png, tmp):
    """the comparison finds a re-encoded copy (other filters) equal and one changed byte different"""
    px, c = read(png)
    px = px[..., 0] if c == 1 else px
    write(tmp + "/same.png", px)
    if compare(png, tmp + "/same.png") is not None:
        return "a re-encoded copy of %s compares different: %s" % (png, compare(png, tmp + "/same.png"))
    h, w = px.shape[:2]
    px = px.copy()
    px[h // 2, w // 3] ^= 1
    write(tmp + "/changed.png", px)
    got = compare(png, tmp + "/changed.png")
    want = "1 of %d pixels differ, the first at x=%d y=%d:" % (w * h, w // 3, h // 2)
    if got is None or not got.startswith(want):
        return "one changed byte of %s: the comparison says %r, expected %r..." % (png, got, want)
    return None

if __name__ == "__main__":
    a = sys.argv[2:]
    if sys.argv[1] == "make":   # make DIR NAME...: DIR/NAME.png
        for name in a[1:]:
            make(name, "%s/%s.png" % (a[0], name))
    elif sys.argv[1] == "cmp":   # cmp LABEL A B [LABEL A B...]: "same LABEL" or "differ LABEL: what" per pair
        for i in range(0, len(a), 3):
            try:
                msg = compare(a[i + 1], a[i + 2])
            except (OSError, ValueError) as e:
                msg = str(e)
            print("same " + a[i] if msg is None else "differ %s: %s" % (a[i], msg))
    else:   # selftest PNG DIR: exit 1 with what went wrong
        msg = selftest(a[0], a[1])
        if msg:
            print(msg)
            sys.exit(1)
EOF

# ---- the pictures ----
P=$T/pics
mkdir -p "$P"
PICS=(rgb256 rgb1000x750 rgba97x131 rgba_opaque gray_alpha)
"$PY" "$T/png.py" make "$P" "${PICS[@]}" || bad "setup: python3 could not make the pictures"
check_png "$P/rgb256.png" 256 256 2
check_png "$P/rgb1000x750.png" 1000 750 2
check_png "$P/rgba97x131.png" 97 131 6
check_png "$P/rgba_opaque.png" 64 48 6
check_png "$P/gray_alpha.png" 50 40 4

# ---- the default model, as `supermat image` without --model finds it (info without FILE names it) ----
run info
check "info without FILE (the default model) exits 0" [ $RC -eq 0 ]
DEFAULT=$(sed -n 's/^default  *\(.*\) (the default model: .*)$/\1/p' "$T/out")
check "info names the default model ($DEFAULT)" [ -f "$DEFAULT" ]

# ---- supermat image (no options) and the example: the same pixels ----
run image --out "$T/cli" "$P/rgb256.png" "$P/rgb1000x750.png" "$P/rgba97x131.png" "$P/rgba_opaque.png" "$P/gray_alpha.png"
check "image (the default model, no options) on the five pictures exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
# the maps' PNG colour types: RGB / gray, RGBA / gray + alpha for the pictures with transparent pixels
check_png "$T/cli/rgb256_albedo.png" 256 256 2
check_png "$T/cli/rgb256_roughness.png" 256 256 0
check_png "$T/cli/rgb1000x750_albedo.png" 1000 750 2
check_png "$T/cli/rgb1000x750_metallic.png" 1000 750 0
check_png "$T/cli/rgba97x131_albedo.png" 97 131 6
check_png "$T/cli/rgba97x131_roughness.png" 97 131 4
check_png "$T/cli/rgba97x131_metallic.png" 97 131 4
check_png "$T/cli/rgba_opaque_albedo.png" 64 48 2
check_png "$T/cli/rgba_opaque_roughness.png" 64 48 0
check_png "$T/cli/gray_alpha_albedo.png" 50 40 6
check_png "$T/cli/gray_alpha_metallic.png" 50 40 4

# the comparison itself can fail: one changed byte is found, a re-encoded copy is equal
mkdir -p "$T/selftest"
for f in rgb256_albedo rgba97x131_roughness; do
    if "$PY" "$T/png.py" selftest "$T/cli/$f.png" "$T/selftest" >"$T/cmp_out" 2>&1; then ok; else bad "the comparison's self-test on $f.png: $(cat "$T/cmp_out")"; fi
done

same_maps() { # same_maps WHAT DIR_A DIR_B STEM: the three maps DIR_*/STEM_*.png, decoded, are identical
    local m line n=0 args=()
    for m in albedo roughness metallic; do args+=("$1, $m" "$2/$4_$m.png" "$3/$4_$m.png"); done
    "$PY" "$T/png.py" cmp "${args[@]}" >"$T/cmp_out" 2>&1 || true
    while IFS= read -r line; do
        case $line in
        "same "*) ok; n=$((n + 1)) ;;
        "differ "*) bad "${line#differ }"; n=$((n + 1)) ;;
        *) echo "$line" ;;
        esac
    done <"$T/cmp_out"
    [ $n -eq 3 ] || bad "$1: the comparison gave $n results of 3"
}
mkdir -p "$T/ex"
for p in "${PICS[@]}"; do
    set +e
    "$EXAMPLE" "$DEFAULT" "$P/$p.png" "$T/ex/$p" >"$T/ex_out" 2>&1
    RC=$?
    set -e
    check "example on $p exits 0" [ $RC -eq 0 ]
    [ $RC -eq 0 ] || cat "$T/ex_out"
    same_maps "$p: supermat image vs the example" "$T/cli" "$T/ex" "$p"
done

# ---- the default model pre-packed (default options): the example's maps again ----
run pack --model "$DEFAULT" --out "$T/packed.safetensors"
check "pack (default options) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
run info "$T/packed.safetensors"
check "info calls the packed file pre-packed" grep -qi 'pre-packed' "$T/out"
mkdir -p "$T/expk"
for p in rgb256 rgb1000x750 rgba97x131; do
    set +e
    "$EXAMPLE" "$T/packed.safetensors" "$P/$p.png" "$T/expk/$p" >"$T/ex_out" 2>&1
    RC=$?
    set -e
    check "example on the packed model, $p, exits 0" [ $RC -eq 0 ]
    [ $RC -eq 0 ] || cat "$T/ex_out"
    same_maps "$p: the example on the packed model vs on the model" "$T/ex" "$T/expk" "$p"
done

# ---- refusals ----
run image --native --out "$T/native" "$P/rgba97x131.png"
check "image --native on 97x131 exits 1" [ $RC -eq 1 ]
check "image --native on 97x131: the message says multiples of 8" grep -q 'multiples of 8' "$T/err"
absent "$T/native/rgba97x131_albedo.png"
for missing in picture model; do
    if [ $missing = picture ]; then args=("$DEFAULT" "$T/no_such_picture.png" "$T/missing/x")
    else args=("$T/no_such_model.safetensors" "$P/rgb256.png" "$T/missing/x"); fi
    mkdir -p "$T/missing"
    set +e
    "$EXAMPLE" "${args[@]}" >"$T/ex_out" 2>&1
    RC=$?
    set -e
    check "example, a missing $missing: exits 1, not 0 nor a crash (got $RC)" [ $RC -eq 1 ]
    check "example, a missing $missing: a message naming it" grep -q "no_such_$missing" "$T/ex_out"
    absent "$T/missing/x_albedo.png"
done

summary
