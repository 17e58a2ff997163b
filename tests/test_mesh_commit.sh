#!/usr/bin/env bash
# tests/test_mesh_commit.sh - `supermat mesh --force` over an existing .gltf commits as a whole.
#
#   tests/test_mesh_commit.sh BUILD/supermat
#
# An asset (a quad, a .bin, a base colour texture, a normal map in a sub-folder) is baked once at 16x16
# (the OLD output), and once more over a copy at 32x32 (the NEW output: other texture bytes, so the side
# files get fresh names). Then the second run is killed with SIGKILL at every call of each file system
# call it makes (strace -e inject=...:signal=SIGKILL:when=N, N = 1, 2, ... until a run is not killed):
# rename/renameat, unlink/unlinkat, link/linkat, write, fsync, mkdir/mkdirat. After every kill, OUT's
# .gltf is byte for byte the OLD one or the NEW one and every file it refers to is that version's file,
# complete (LeakSanitizer cannot run under ptrace: off for the traced runs of a sanitizer build); then a run
# to the end leaves the NEW output whole and nothing else (no temporary file, no
# staging folder, no older side file; the side files may carry the other of their two names).
set -u
if [ $# -ne 1 ]; then echo "usage: $0 PATH/TO/supermat" >&2; exit 2; fi
BIN=$(realpath "$1")
if ! "$BIN" --version | grep -q mesh; then echo "SKIP: built without mesh"; echo "0 passed, 0 failed, 1 skipped"; exit 0; fi
if ! command -v strace >/dev/null 2>&1; then echo "SKIP: strace is not installed"; echo "0 passed, 0 failed, 1 skipped"; exit 0; fi
if ! strace -f -o /dev/null true 2>/dev/null; then echo "SKIP: ptrace is not allowed here"; echo "0 passed, 0 failed, 1 skipped"; exit 0; fi
T=$(mktemp -d "${TMPDIR:-/tmp}/supermat_commit.XXXXXX")
trap 'rm -rf "$T"' EXIT
cd "$T" || exit 1
PASS=0
FAIL=0
bad() { FAIL=$((FAIL + 1)); echo "FAIL: $*"; }
check() { local what=$1; shift; if "$@"; then PASS=$((PASS + 1)); else bad "$what"; fi; }

python3 - <<'EOF' || { echo "FAIL: python3 could not make the asset"; exit 1; }
import json, os, struct, zlib
pos = [-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0]
uv = [0, 1, 1, 1, 1, 0, 0, 0]
idx = [0, 1, 2, 0, 2, 3]
b = struct.pack('<12f', *pos) + struct.pack('<8f', *uv) + struct.pack('<6H', *idx) + b'\0' * 4
def png(w, h, f):
    raw = b''.join(b'\0' + bytes(c for x in range(w) for c in f(x, y)) for y in range(h))
    chunk = lambda t, d: struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    return b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b'')
os.makedirs('in/sub', exist_ok=True)
open('in/a.bin', 'wb').write(b)
open('in/tex.png', 'wb').write(png(16, 16, lambda x, y: (16 * x, 16 * y, 128)))
open('in/sub/n.png', 'wb').write(png(4, 4, lambda x, y: (128, 128, 255)))
g = {'asset': {'version': '2.0'}, 'scene': 0, 'scenes': [{'nodes': [0]}], 'nodes': [{'mesh': 0}],
     'meshes': [{'primitives': [{'attributes': {'POSITION': 0, 'TEXCOORD_0': 1}, 'indices': 2, 'material': 0}]}],
     'materials': [{'pbrMetallicRoughness': {'baseColorTexture': {'index': 0}}, 'normalTexture': {'index': 1}}],
     'textures': [{'source': 0}, {'source': 1}], 'images': [{'uri': 'tex.png'}, {'uri': 'sub/n.png'}],
     'buffers': [{'uri': 'a.bin', 'byteLength': len(b)}],
     'bufferViews': [{'buffer': 0, 'byteOffset': 0, 'byteLength': 48}, {'buffer': 0, 'byteOffset': 48, 'byteLength': 32},
                     {'buffer': 0, 'byteOffset': 80, 'byteLength': 12}],
     'accessors': [{'bufferView': 0, 'componentType': 5126, 'count': 4, 'type': 'VEC3', 'min': [-1, -1, 0], 'max': [1, 1, 0]},
                   {'bufferView': 1, 'componentType': 5126, 'count': 4, 'type': 'VEC2'},
                   {'bufferView': 2, 'componentType': 5123, 'count': 6, 'type': 'SCALAR'}]}
json.dump(g, open('in/a.gltf', 'w'))
EOF
ARGS=(--passthrough --views-size 32 --threads 1)
mkdir old
"$BIN" mesh "${ARGS[@]}" --size 16 in/a.gltf old/a.gltf >/dev/null 2>&1 || bad "the OLD bake exits 0"
cp -a old new
"$BIN" mesh --force "${ARGS[@]}" --size 32 in/a.gltf new/a.gltf >/dev/null 2>&1 || bad "the NEW bake exits 0"
check "the NEW output has fresh side-file names (the commit test means something)" [ "$(ls new | sort)" != "$(ls old | sort)" ]
check "the NEW output: the OLD textures removed after the commit" bash -c "! ls new | grep -qx a_baseColor.png"

# whole VERSION_DIR OUT_DIR [roles]: OUT's .gltf is VERSION's byte for byte, and every file it refers to is
# VERSION's file. With "roles": the .gltf may name its files otherwise (a run after a kill picks the names
# free then), but is VERSION's with the URIs left out, each buffer and image has VERSION's bytes, and OUT
# holds no file its .gltf does not refer to.
whole() {
    python3 - "$1" "$2" "${3:-}" <<'EOF2'
import json, sys, os, urllib.parse
ver, out, roles = sys.argv[1], sys.argv[2], sys.argv[3] == 'roles'
g = open(os.path.join(out, 'a.gltf'), 'rb').read()
gv = open(os.path.join(ver, 'a.gltf'), 'rb').read()
j, jv = json.loads(g), json.loads(gv)
if not roles and g != gv: sys.exit(1)
def files(jj):
    return [urllib.parse.unquote(e.get('uri', '')) if e.get('uri', '') and not e['uri'].startswith('data:') else None
            for k in ('buffers', 'images') for e in jj.get(k, [])]
fo, fv = files(j), files(jv)
if len(fo) != len(fv): sys.exit(1)
for a, b in zip(fo, fv):
    if (a is None) != (b is None): sys.exit(1)
    if a is None: continue
    pa, pb = os.path.join(out, a), os.path.join(ver, b)
    if not os.path.isfile(pa) or open(pa, 'rb').read() != open(pb, 'rb').read():
        print('  %s: not %s\'s file' % (a, ver)); sys.exit(1)
if roles:
    for jj in (j, jv):
        for k in ('buffers', 'images'):
            for e in jj.get(k, []): e.pop('uri', None)
    if j != jv: print('  the .gltf differs beyond its URIs'); sys.exit(1)
    have = set()
    for root, dirs, names in os.walk(out):
        for n in names: have.add(os.path.relpath(os.path.join(root, n), out))
    extra = have - set(x for x in fo if x) - {'a.gltf'}
    if extra: print('  left behind: %s' % sorted(extra)); sys.exit(1)
EOF2
}
kills=0
for group in rename,renameat,renameat2 unlink,unlinkat link,linkat write fsync mkdir,mkdirat; do
    n=1
    while [ $n -le 400 ]; do
        rm -rf k; cp -a old k
        (ASAN_OPTIONS="${ASAN_OPTIONS:-}:detect_leaks=0" strace -f -o /dev/null -e trace="$group" -e inject="$group":signal=SIGKILL:when=$n \
            "$BIN" mesh --force "${ARGS[@]}" --size 32 in/a.gltf k/a.gltf; echo $? >"$T/rc") >/dev/null 2>&1 # (the subshell keeps "Killed" quiet)
        rc=$(cat "$T/rc")
        [ $rc -eq 0 ] && break # ran to the end: every call of this group has been a kill point
        kills=$((kills + 1))
        if whole old k >/dev/null || whole new k >/dev/null; then PASS=$((PASS + 1))
        else bad "killed at $group #$n: OUT is neither the whole OLD asset nor the whole NEW one"; whole old k; whole new k; fi
        "$BIN" mesh --force "${ARGS[@]}" --size 32 in/a.gltf k/a.gltf >/dev/null 2>&1 || bad "after the kill at $group #$n: the next run exits 0"
        check "after the kill at $group #$n: the next run leaves the NEW asset whole, nothing else (no temporary file, stage or older side file)" whole new k roles
        check "after the kill at $group #$n: no hidden leftovers" [ -z "$(find k -name '.*' -mindepth 1)" ]
        n=$((n + 1))
    done
done
check "the runs were killed at many points ($kills)" [ $kills -ge 10 ]
echo "$PASS passed, $FAIL failed, 0 skipped"
[ $FAIL -eq 0 ]
