#!/usr/bin/env bash
# tests/test_hostile.sh - untrusted assets and shared output folders (docs/security.md states the promises).
#
#   tests/test_hostile.sh BUILD/supermat TINY_SUPERMAT_MODEL TESTS_DATA_DIR
#
# The corpus is made here (links and FIFOs cannot be committed): a secret file outside the asset holds a
# marker string, a victim folder outside the output holds files whose bytes are recorded. Every case checks
# the exit code, the message, that no byte of the secret reached the output (grep of the marker), that
# nothing outside the output changed (the victim's checksums) and that nothing was left behind (no
# temporary file, no staging folder).
#   Reads  (`mesh` .gltf and .glb, `batch mesh`): image and buffer URIs '../', %-encoded '../', absolute,
#          file:, a drive letter, backslashes, a link inside the asset's folder to outside, a FIFO (no
#          hang), a name found only in the current folder; --allow-outside-refs reads '../' but still
#          refuses the FIFO. `image` / `batch image`: a FIFO picture; a linked picture to outside a
#          batch's input folder is left out.
#   Writes (`image`, `batch image`, `mesh`, `batch mesh`): a planted PATH.tmp link, a planted stage link
#          (old and new names) pointing at the victim, an unmarked stage-named folder (kept), a marked stale
#          stage of a dead process (removed), a linked sub-folder in the output, a linked journal.
#   Batch: the output folder as the input folder (refused), inside it (excluded), a second batch while
#          the journal is locked (refused).
#   Limits: buffers claiming 1 TB (a file and a data URI) under a 4 GB address space, a picture whose
#          decoded bytes exceed --max-memory; FIFOs as model files (`mesh`, `image`) and in `convert --base`.
set -u
if [ $# -ne 3 ]; then echo "usage: $0 PATH/TO/supermat TINY_MODEL TESTS_DATA_DIR" >&2; exit 2; fi
BIN=$(realpath "$1")
MODEL=$(realpath "$2")
DATA=$(realpath "$3")
T=$(mktemp -d "${TMPDIR:-/tmp}/supermat_hostile.XXXXXX")
trap 'rm -rf "$T"' EXIT
cd "$T" || exit 1
PASS=0
FAIL=0
SKIP=0
bad() { FAIL=$((FAIL + 1)); echo "FAIL: $*"; }
check() { local what=$1; shift; if "$@"; then PASS=$((PASS + 1)); else bad "$what"; fi; }
RC=0
# run ARGS: the tool with a 60 s limit (a hang is a failure: exit 124), output in $T/out and $T/err
run() { timeout 60 "$BIN" "$@" >"$T/out" 2>"$T/err"; RC=$?; }
says() { grep -qF -- "$1" "$T/err" || { echo "  stderr was: $(head -c 600 "$T/err")"; return 1; }; }
MARK=SUPERMAT-SECRET-7f3a9c
no_secret() { ! grep -rqa "$MARK" "$1" 2>/dev/null && ! grep -rqa "$(printf '%s' "$MARK" | base64)" "$1" 2>/dev/null; }
no_leftovers() { [ -z "$(find "$1" \( -name '*.tmp' -o -name '.supermat-mesh-*' \) 2>/dev/null)" ]; }
victim_sum() { (cd "$T/victim" && find . -type f -print0 | sort -z | xargs -0 sha256sum; find . | sort) | sha256sum; }

# ---- outside everything: the secret and the victim ----
mkdir -p secret victim/deep
printf '%s: the bytes of a file outside the asset\n' "$MARK" > secret/s.png
cp secret/s.png secret/s.bin
printf 'victim file\n' > victim/a.txt
printf 'victim file 2\n' > victim/deep/b.txt
VSUM=$(victim_sum)
victim_same() { [ "$(victim_sum)" = "$VSUM" ]; }

# this machine's tag in the names of leftovers (smio_host_tag: FNV-1a of the host name)
HT=$(python3 -c 'import socket
h = 2166136261
for c in socket.gethostname().encode(): h = ((h ^ c) * 16777619) & 0xffffffff
print("%08x" % h)')
OTHER=$(printf '%08x' $(( (0x$HT + 1) & 0xffffffff )))   # another machine's tag
HAVE_MESH=0
"$BIN" --version 2>/dev/null | grep -q mesh && HAVE_MESH=1

# ---- a small textured glTF (one quad, a 16x16 PNG texture, a .bin buffer), written by python3 ----
python3 - "$DATA/img/sphere_64.png" <<'EOF' || { echo "FAIL: python3 could not make the corpus"; exit 1; }
import base64, json, struct, sys, os, shutil
pos = [-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0]
uv = [0, 1, 1, 1, 1, 0, 0, 0]
idx = [0, 1, 2, 0, 2, 3]
b = struct.pack('<12f', *pos) + struct.pack('<8f', *uv) + struct.pack('<6H', *idx) + b'\0\0\0\0'
os.makedirs('asset/sub', exist_ok=True)
open('asset/a.bin', 'wb').write(b)
shutil.copy(sys.argv[1], 'asset/tex.png')
shutil.copy(sys.argv[1], 'asset/sub/t2.png')
def gltf(image_uri, buffer_uri='a.bin', data=None, normal_uri=None):
    g = {
        'asset': {'version': '2.0'}, 'scene': 0, 'scenes': [{'nodes': [0]}], 'nodes': [{'mesh': 0}],
        'meshes': [{'primitives': [{'attributes': {'POSITION': 0, 'TEXCOORD_0': 1}, 'indices': 2, 'material': 0}]}],
        'materials': [{'pbrMetallicRoughness': {'baseColorTexture': {'index': 0}}}],
        'textures': [{'source': 0}], 'images': [{'uri': image_uri}],
        'buffers': [{'uri': buffer_uri, 'byteLength': len(b)} if data is None else {'byteLength': len(b)}],
        'bufferViews': [{'buffer': 0, 'byteOffset': 0, 'byteLength': 48}, {'buffer': 0, 'byteOffset': 48, 'byteLength': 32},
                        {'buffer': 0, 'byteOffset': 80, 'byteLength': 12}],
        'accessors': [{'bufferView': 0, 'componentType': 5126, 'count': 4, 'type': 'VEC3', 'min': [-1, -1, 0], 'max': [1, 1, 0]},
                      {'bufferView': 1, 'componentType': 5126, 'count': 4, 'type': 'VEC2'},
                      {'bufferView': 2, 'componentType': 5123, 'count': 6, 'type': 'SCALAR'}]}
    if normal_uri:  # a second image the bake keeps as it is (a normal map): copied beside OUT under its name
        g['images'].append({'uri': normal_uri})
        g['textures'].append({'source': 1})
        g['materials'][0]['normalTexture'] = {'index': 1}
    return g
T = os.getcwd()
cases = {
    'ok': gltf('tex.png'),
    'okSub': gltf('tex.png', normal_uri='sub/t2.png'),
    'dotdot': gltf('../secret/s.png'),
    'pct': gltf('%2E%2E/secret/s.png'),
    'abs': gltf(T + '/secret/s.png'),
    'fileuri': gltf('file://' + T + '/secret/s.png'),
    'drive': gltf('C:/secret/s.png'),
    'backslash': gltf('..\\secret\\s.png'),
    'link': gltf('link.png'),
    'sublink': gltf('lsub/s.png'),
    'fifo': gltf('fifo.png'),
    'cwd': gltf('only_in_cwd.png'),
    'bufdotdot': gltf('tex.png', '../secret/s.bin'),
    'buflink': gltf('tex.png', 'linkbin.bin'),
}
big = gltf('tex.png')
big['buffers'][0]['byteLength'] = 10**12        # a buffer that claims more than its file
cases['bigbuf'] = big
bigd = gltf('tex.png')
bigd['buffers'][0] = {'uri': 'data:application/octet-stream;base64,' + base64.b64encode(b).decode(), 'byteLength': 10**12}
cases['bigdata'] = bigd
cases['hard'] = gltf('hard.png')                  # a hard link to a file outside
dup = gltf('tex.png', normal_uri='tex.png')        # two images, one file: legal glTF
cases['dupimg'] = dup
shutil.copy(sys.argv[1], 'asset/out.gltf')         # an image named like OUT, and like the stage's marker
shutil.copy(sys.argv[1], 'asset/.supermat-stage')
cases['clash'] = gltf('tex.png', normal_uri='out.gltf')
cases['clash2'] = gltf('tex.png', normal_uri='.supermat-stage')
for k, v in cases.items():
    json.dump(v, open('asset/%s.gltf' % k, 'w'))
# a GLB with the quad in its BIN chunk and an image URI outside
g = gltf('../secret/s.png', data=True)
js = json.dumps(g).encode()
js += b' ' * (-len(js) % 4)
glb = b'glTF' + struct.pack('<II', 2, 12 + 8 + len(js) + 8 + len(b)) + struct.pack('<I', len(js)) + b'JSON' + js + struct.pack('<I', len(b)) + b'BIN\0' + b
open('asset/glbdotdot.glb', 'wb').write(glb)
EOF
ln -s ../secret/s.png asset/link.png
ln secret/s.png asset/hard.png
ln -s ../secret/s.bin asset/linkbin.bin
ln -s ../secret asset/lsub
mkfifo asset/fifo.png
cp secret/s.png secret/only_in_cwd.png

if [ $HAVE_MESH = 1 ]; then
    # the asset as it is: exit 0 (the corpus is sound)
    mkdir -p o_ok
    run mesh --passthrough --size 32 --views-size 32 asset/ok.gltf o_ok/ok.gltf
    check "mesh: the sound asset exits 0 ($RC)" [ $RC -eq 0 ]
    check "mesh: the sound asset: no leftovers" no_leftovers o_ok
    # references that leave the asset
    for c in dotdot:'../secret/s.png' pct:'../secret/s.png' abs:'is an absolute path' fileuri:'scheme' drive:'names a drive' \
             backslash:'backslash' link:'link.png' sublink:'lsub/s.png' fifo:'a FIFO' bufdotdot:'../secret/s.bin' buflink:'linkbin.bin' \
             hard:'hard links'; do
        name=${c%%:*}; msg=${c#*:}
        for ext in gltf glb; do
            rm -rf "o_$name"; mkdir -p "o_$name"
            run mesh --passthrough --size 32 --views-size 32 "asset/$name.gltf" "o_$name/out.$ext"
            check "mesh $name -> .$ext: exit 1 (got $RC)" [ $RC -eq 1 ]
            check "mesh $name -> .$ext: the message names it ($msg)" says "$msg"
            check "mesh $name -> .$ext: no secret byte in the output" no_secret "o_$name"
            check "mesh $name -> .$ext: nothing written, nothing left" [ -z "$(ls -A "o_$name")" ]
        done
    done
    rm -rf o_glb; mkdir o_glb
    run mesh --passthrough --size 32 --views-size 32 asset/glbdotdot.glb o_glb/out.glb
    check "mesh .glb with '../' image: exit 1 (got $RC)" [ $RC -eq 1 ]
    check "mesh .glb with '../' image: named" says "../secret/s.png"
    check "mesh .glb with '../' image: no secret byte" no_secret o_glb
    # the current folder is never searched
    rm -rf o_cwd; mkdir o_cwd
    (cd secret && timeout 60 "$BIN" mesh --passthrough --size 32 --views-size 32 "$T/asset/cwd.gltf" "$T/o_cwd/out.gltf" >/dev/null 2>"$T/err")
    check "mesh: a name found only in the current folder: not read" no_secret o_cwd
    # images that share one file, or whose names are OUT's or the stage's own: written once, renamed
    for name in dupimg clash clash2; do
        rm -rf "o_$name"; mkdir "o_$name"
        run mesh --passthrough --size 32 --views-size 32 "asset/$name.gltf" "o_$name/out.gltf"
        check "mesh $name: exit 0 (got $RC)" [ $RC -eq 0 ]
        check "mesh $name: OUT is the glTF" python3 -c "import json,sys; json.load(open(sys.argv[1]))" "o_$name/out.gltf"
        check "mesh $name: no leftovers" no_leftovers "o_$name"
    done
    check "mesh clash2: no stage marker taken into OUT" [ ! -e o_clash2/.supermat-stage ]
    # trusted local use: --allow-outside-refs reads '../', never a FIFO
    rm -rf o_allow; mkdir o_allow
    run mesh --allow-outside-refs --passthrough --size 32 --views-size 32 asset/dotdot.gltf o_allow/out.gltf
    check "mesh --allow-outside-refs '../': exit 0 (got $RC)" [ $RC -eq 0 ]
    run mesh --allow-outside-refs --passthrough --size 32 --views-size 32 asset/fifo.gltf o_allow/out2.gltf
    check "mesh --allow-outside-refs FIFO: still refused (got $RC)" [ $RC -eq 1 ]
    check "mesh --allow-outside-refs FIFO: says FIFO" says "a FIFO"
    # buffers that claim more bytes than they have: refused, nothing allocated for the claim (4 GB address space;
    # not under AddressSanitizer, whose shadow memory alone is larger)
    VLIMIT=0
    (ulimit -v 4000000; "$BIN" --version) >/dev/null 2>&1 && VLIMIT=1
    for name in bigbuf bigdata; do
        rm -rf "o_$name"; mkdir "o_$name"
        RC=0; ( [ $VLIMIT = 1 ] && ulimit -v 4000000; timeout 60 "$BIN" mesh --passthrough --size 32 --views-size 32 "asset/$name.gltf" "o_$name/out.gltf" >"$T/out" 2>"$T/err") || RC=$?
        check "mesh $name (1 TB claimed): exit 1 (got $RC)" [ $RC -eq 1 ]
        check "mesh $name: nothing written" [ -z "$(ls -A "o_$name")" ]
    done
    # a model that is a FIFO: refused, no hang
    mkfifo model_fifo.safetensors
    run mesh --mv-model model_fifo.safetensors --size 32 --views-size 32 asset/ok.gltf o_ok/fifo_model.gltf
    check "mesh --mv-model FIFO: exit 1, no hang (got $RC)" [ $RC -eq 1 ]
    check "mesh --mv-model FIFO: says so" says "FIFO"
    # IN itself a FIFO: refused, no hang
    mkfifo in_fifo.gltf
    run mesh --passthrough in_fifo.gltf o_ok/x.gltf
    check "mesh: IN a FIFO: exit 1, no hang (got $RC)" [ $RC -eq 1 ]

    # ---- writes: planted links and stages in the output folder ----
    rm -rf o_w; mkdir o_w
    ln -s "$T/victim" o_w/.supermat-mesh-$$.tmp                 # the old name, this shell's (live) pid
    ln -s "$T/victim" o_w/.supermat-mesh-999999999-1-$HT.tmp   # the new name, a dead pid, a link
    mkdir o_w/.supermat-mesh-999999998-2-$HT.tmp               # a dead pid's folder without our marker: not ours
    touch o_w/.supermat-mesh-999999998-2-$HT.tmp/keep
    mkdir o_w/.supermat-mesh-999999997-3-$HT.tmp               # a dead pid's marked stage: ours, removed
    touch o_w/.supermat-mesh-999999997-3-$HT.tmp/.supermat-stage o_w/.supermat-mesh-999999997-3-$HT.tmp/half.png
    mkdir o_w/.supermat-mesh-999999997-4-$OTHER.tmp            # marked, but another machine's: its pid means nothing here
    touch o_w/.supermat-mesh-999999997-4-$OTHER.tmp/.supermat-stage
    ln -s "$T/victim/a.txt" o_w/.out.gltf.999999996-1-$HT.supermat.tmp   # a dead pid's temporary name, a link
    ln -s "$T/victim" o_w/sub                                   # a linked sub-folder
    run mesh --passthrough --size 32 --views-size 32 asset/ok.gltf o_w/out.gltf
    check "mesh with planted links: exit 0 (got $RC)" [ $RC -eq 0 ]
    check "mesh with planted links: the victim unchanged" victim_same
    check "mesh: the linked stages are still links (not followed, not ours)" [ -L o_w/.supermat-mesh-999999999-1-$HT.tmp ]
    check "mesh: the linked stages are still links (not followed, not ours) (2)" [ -L o_w/.supermat-mesh-$$.tmp ]
    check "mesh: an unmarked stage-named folder is kept" [ -f o_w/.supermat-mesh-999999998-2-$HT.tmp/keep ]
    check "mesh: a dead run's marked stage is removed" [ ! -e o_w/.supermat-mesh-999999997-3-$HT.tmp ]
    check "mesh: another machine's marked stage is kept (a shared folder)" [ -f o_w/.supermat-mesh-999999997-4-$OTHER.tmp/.supermat-stage ]
    check "mesh: the dead run's linked temporary name is not followed" victim_same
    run mesh --force --passthrough --size 32 --views-size 32 asset/okSub.gltf o_w/out2.gltf
    check "mesh: an image in a sub-folder through a linked OUT/sub: exit 1 (got $RC)" [ $RC -eq 1 ]
    check "mesh: the linked sub-folder is named" says "symbolic link"
    check "mesh: nothing written through the linked sub-folder" victim_same
    rm -rf o_sub; mkdir o_sub
    run mesh --passthrough --size 32 --views-size 32 asset/okSub.gltf o_sub/out.gltf
    check "mesh: an image in a sub-folder: exit 0 (got $RC)" [ $RC -eq 0 ]
    check "mesh: the sub-folder image copied" [ -f o_sub/sub/t2.png ]
    check "mesh: no stage or temporary file left (sub-folders included)" no_leftovers o_sub
    # an output file that is a link: --force replaces the link, never writes its target
    rm -rf o_l; mkdir o_l
    ln -s "$T/victim/a.txt" o_l/out.gltf
    run mesh --force --passthrough --size 32 --views-size 32 asset/ok.gltf o_l/out.gltf
    check "mesh --force over a linked OUT: exit 0 (got $RC)" [ $RC -eq 0 ]
    check "mesh --force over a linked OUT: the link replaced by a file" [ -f o_l/out.gltf ]
    check "mesh --force over a linked OUT: the link replaced by a file (2)" [ ! -L o_l/out.gltf ]
    check "mesh --force over a linked OUT: the target unchanged" victim_same

    # ---- batch mesh ----
    mkdir -p bm_in
    cp asset/ok.gltf asset/a.bin asset/tex.png bm_in/
    cp asset/dotdot.gltf bm_in/
    mkdir -p bm_out
    ln -s "$T/victim" bm_out/.supermat-mesh-999999995-1-$HT.tmp
    run batch mesh --passthrough --size 32 --views-size 32 --out bm_out bm_in
    check "batch mesh: exit 1 (one hostile asset) (got $RC)" [ $RC -eq 1 ]
    check "batch mesh: the hostile asset failed" grep -q '"item":"dotdot".*"status":"failed"' bm_out/journal.jsonl
    check "batch mesh: the hostile reference named" says "../secret/s.png"
    check "batch mesh: the sound asset done" grep -q '"item":"ok".*"status":"done"' bm_out/journal.jsonl
    check "batch mesh: no secret byte in the output" no_secret bm_out
    check "batch mesh: the victim unchanged" victim_same
else
    SKIP=$((SKIP + 1)); echo "SKIP: mesh cases (this supermat is built without tinygltf)"
fi

# ---- pictures: image and batch image ----
RUN=(--model "$MODEL" --work-size 64 --threads 1)
mkdir -p pics/sub
cp "$DATA/img/sphere_64.png" pics/a.png
cp "$DATA/img/sphere_64.png" pics/sub/b.png
mkfifo fifo_pic.png
run image "${RUN[@]}" --out o_fifo fifo_pic.png
check "image: a FIFO picture: exit 1, no hang (got $RC)" [ $RC -eq 1 ]
check "image: a FIFO picture: says so" says "FIFO"
[ -p model_fifo.safetensors ] || mkfifo model_fifo.safetensors
run image --model model_fifo.safetensors --out o_fifo pics/a.png
check "image --model FIFO: exit 1, no hang (got $RC)" [ $RC -eq 1 ]
# a picture whose decoded bytes exceed --max-memory: refused from its header, before decoding
run image "${RUN[@]}" --max-memory 8K --out o_mem pics/a.png
check "image: a picture over --max-memory: exit 1 (got $RC)" [ $RC -eq 1 ]
check "image: a picture over --max-memory: says so" says "more than --max-memory"
# convert: a FIFO in the base folder (its unet config) is refused, not waited on
cp -r "$DATA/tiny/base" base_fifo
rm base_fifo/unet/config.json && mkfifo base_fifo/unet/config.json
run convert --unet "$DATA/tiny/supermat.pth" --base base_fifo --out conv_fifo.safetensors
check "convert, a FIFO config: exit 1, no hang (got $RC)" [ $RC -eq 1 ]
check "convert, a FIFO config: says so" says "not a regular file"
check "convert, a FIFO config: nothing written" [ -z "$(ls -A . | grep conv_fifo)" ]
# a planted PATH.tmp (the old temporary name) and a planted link at the new names' place: never followed
mkdir -p o_img
ln -s "$T/victim/a.txt" o_img/a_albedo.png.tmp
run image "${RUN[@]}" --out o_img pics/a.png
check "image with a planted PATH.tmp link: exit 0 (got $RC)" [ $RC -eq 0 ]
check "image: the link's target unchanged" victim_same
check "image: the map is a regular file, not a link" [ -f o_img/a_albedo.png ]
check "image: the map is a regular file, not a link (2)" [ ! -L o_img/a_albedo.png ]
ln -s "$T/victim/a.txt" o_img/link_albedo.png
cp pics/a.png link.png
run image "${RUN[@]}" --force --out o_img link.png
check "image --force over a linked map: exit 0 (got $RC)" [ $RC -eq 0 ]
check "image --force over a linked map: the link replaced, its target unchanged" [ ! -L o_img/link_albedo.png ]
check "image --force over a linked map: the link replaced, its target unchanged (2)" victim_same
# a killed run's temporary file (a dead pid) is removed by the next run into that folder
touch o_img/.a_roughness.png.999999994-1-$HT.supermat.tmp o_img/.a_metallic.png.999999994-2-$OTHER.supermat.tmp
run image "${RUN[@]}" --force --out o_img pics/a.png
check "image: a dead run's temporary file removed" [ ! -e o_img/.a_roughness.png.999999994-1-$HT.supermat.tmp ]
check "image: another machine's temporary file kept (its run may be alive)" [ -e o_img/.a_metallic.png.999999994-2-$OTHER.supermat.tmp ]
rm o_img/.a_metallic.png.999999994-2-$OTHER.supermat.tmp
rm o_img/a_albedo.png.tmp   # the planted link (kept: not ours)
check "image: nothing left behind" no_leftovers o_img

# batch image: a linked sub-folder in DIR
mkdir -p b_out
ln -s "$T/victim" b_out/sub
run batch image "${RUN[@]}" --out b_out pics
check "batch image, linked DIR/sub: exit 1 (got $RC)" [ $RC -eq 1 ]
check "batch image, linked DIR/sub: the item failed naming the link" grep -q '"status":"failed".*symbolic link' b_out/journal.jsonl
check "batch image, linked DIR/sub: the other item done" grep -q '"item":"a".*"status":"done"' b_out/journal.jsonl
check "batch image, linked DIR/sub: nothing written through it" victim_same
# a linked journal is refused
mkdir -p b_j
ln -s "$T/victim/a.txt" b_j/journal.jsonl
run batch image "${RUN[@]}" --out b_j pics
check "batch image, linked journal: exit 1 (got $RC)" [ $RC -eq 1 ]
check "batch image, linked journal: the victim unchanged" victim_same
# outputs are never inputs
cp -r pics same
n0=$(find same -type f | wc -l)
run batch image "${RUN[@]}" --out same same
check "batch image --out DIR DIR: exit 2 (got $RC)" [ $RC -eq 2 ]
check "batch image --out DIR DIR: says why" says "the output folder"
check "batch image --out DIR DIR: nothing written" [ "$(find same -type f | wc -l)" = "$n0" ]
run batch image "${RUN[@]}" --out pics/maps pics
check "batch image, DIR inside the input folder: exit 0 (got $RC)" [ $RC -eq 0 ]
run batch image "${RUN[@]}" --retry-failed --out pics/maps pics
check "batch image re-run, DIR inside the input folder: still 2 items (no map taken as a picture)" grep -q "batch: 2 item(s)" "$T/err"
run batch image "${RUN[@]}" --out pics/maps pics/maps/a_albedo.png
check "batch image: a named input inside DIR refused: exit 2 (got $RC)" [ $RC -eq 2 ]
# a linked picture to outside a batch's input folder is left out
mkdir -p lin
cp pics/a.png lin/
ln -s "$T/secret/s.png" lin/evil.png
run batch image "${RUN[@]}" --out lin_out lin
check "batch image, a linked picture outside the folder: left out, named" says "evil.png"
check "batch image, a linked picture outside the folder: one item" grep -q "batch: 1 item(s)" "$T/err"
# two batches on one output folder: the second refuses while the first holds the journal
if command -v flock >/dev/null 2>&1; then
    mkdir -p two
    touch two/journal.jsonl
    flock two/journal.jsonl sleep 20 &
    LOCKER=$!
    sleep 0.5
    run batch image "${RUN[@]}" --out two pics/a.png
    check "a second batch on a locked journal: exit 1 (got $RC)" [ $RC -eq 1 ]
    check "a second batch on a locked journal: says so" says "another batch"
    kill $LOCKER 2>/dev/null; wait $LOCKER 2>/dev/null
else
    SKIP=$((SKIP + 1)); echo "SKIP: flock(1) missing"
fi
check "outside the outputs: the victim unchanged at the end" victim_same
echo "$PASS passed, $FAIL failed, $SKIP skipped"
[ $FAIL -eq 0 ]
