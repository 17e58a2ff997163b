#!/usr/bin/env bash
# tests/uv/test_bake_parity.sh - examples/bake_gltf.cpp gets `supermat mesh`'s textures (issue 59).
#
#   bash tests/uv/test_bake_parity.sh BUILD/supermat BUILD/example_bake_gltf SRC_DIR OUT_DIR
#
# The example leaves every supermat_uv_bake_desc field it does not need 0 (each model file's pipeline: the
# networks' work sizes, the view model's detail step) and `supermat mesh` sets nothing of its own, so on
# examples/mesh/example_pbr.gltf (one mesh, one primitive, no node transform, an opaque material) at the
# default 1024x1024:
#   (a) `supermat mesh IN OUT` (no model flags: the multi-view default found in the source tree) and
#       `bake_gltf models/supermat_mv_default.safetensors IN OUT`,
#   (b) `supermat mesh --refine IN OUT` and `bake_gltf MV BC_REFINE RM_REFINE IN OUT` (the three defaults)
# give the same decoded base colour and metallicRoughness pixels (the images the output glTF's material
# points at; every byte of every pixel, no tolerance). Other way round: `supermat mesh --detail off` gives
# another base colour than (a) (the detail step the model file records is in both), and bake_gltf exits 1
# with a message on a missing model file, a missing glTF and an output folder that does not exist.
# The example must be built as the CLI builds supermat.h's implementation, without fused multiply-adds
# (-ffp-contract=off: g++ fuses by default, which moves a few 8-bit values by 1). PNGs are decoded by
# /usr/bin/python3 with numpy and PIL. About 36 s on 2 cores.
set -eu
if [ $# -ne 4 ]; then
    echo "usage: $0 SUPERMAT EXAMPLE_BAKE_GLTF SRC_DIR OUT_DIR" >&2
    exit 2
fi
SM=$1 EX=$2 SRC=$3 OUT=$4
PY=/usr/bin/python3
IN=$SRC/examples/mesh/example_pbr.gltf
MV=$SRC/models/supermat_mv_default.safetensors
BC=$SRC/models/supermat_refine_albedo_default.safetensors
RM=$SRC/models/supermat_refine_rm_default.safetensors
PASS=0 FAIL=0
ok() { PASS=$((PASS + 1)); echo "ok   $*"; }
bad() { FAIL=$((FAIL + 1)); echo "FAIL $*"; }
summary() { echo "$PASS passed, $FAIL failed"; [ "$FAIL" -eq 0 ]; }
for f in "$SM" "$EX" "$IN" "$MV" "$BC" "$RM"; do
    [ -e "$f" ] || { bad "setup: $f is missing"; summary; exit 1; }
done
"$PY" -c 'import numpy, PIL' 2>/dev/null || { bad "setup: $PY with numpy and PIL is needed"; summary; exit 1; }
rm -rf "$OUT"
mkdir -p "$OUT"

# run NAME CMD...: CMD's exit code in RC, its stderr in $OUT/NAME.err (each run writes into its own folder)
run() {
    local name=$1
    shift
    mkdir -p "$OUT/$name"
    RC=0
    "$@" >"$OUT/$name.out" 2>"$OUT/$name.err" || RC=$?
}
# the CLI with no SUPERMAT_MODEL: it finds the default models in the source tree, as a user's checkout
mesh() { run "$1" env -u SUPERMAT_MODEL "$SM" mesh "${@:3}" "$IN" "$OUT/$1/$2"; }

# textures.py GLTF_A GLTF_B [differ]: the base colour and metallicRoughness images each glTF's first
# primitive's material points at, decoded; prints pixels compared, differing pixels and the largest
# difference; exit 0 when every pair is identical (with `differ`: when the base colours differ)
cat >"$OUT/textures.py" <<'EOF'
import json, os, sys
from urllib.parse import unquote
import numpy as np
from PIL import Image

def images(path):
    g = json.load(open(path))
    mat = g["materials"][g["meshes"][0]["primitives"][0]["material"]]["pbrMetallicRoughness"]
    uri = lambda slot: g["images"][g["textures"][mat[slot]["index"]]["source"]]["uri"]  # noqa: E731
    return [os.path.join(os.path.dirname(path), unquote(uri(s))) for s in ("baseColorTexture", "metallicRoughnessTexture")]

a, b = images(sys.argv[1]), images(sys.argv[2])
differ = len(sys.argv) > 3
same = True
for name, pa, pb in zip(("base colour", "metallicRoughness"), a, b):
    A, B = (np.asarray(Image.open(p)) for p in (pa, pb))
    if A.shape != B.shape or A.dtype != B.dtype:
        print(f"     {name}: {os.path.basename(pa)} {A.shape} {A.dtype} vs {os.path.basename(pb)} {B.shape} {B.dtype}")
        same = False
        continue
    d = np.abs(A.astype(np.int32) - B.astype(np.int32))
    px = d.reshape(A.shape[0], A.shape[1], -1).max(axis=2)
    print(f"     {name}: {A.shape[1]}x{A.shape[0]}x{A.shape[2] if A.ndim == 3 else 1} = {px.size} pixels compared, "
          f"{int((px > 0).sum())} differ, max difference {int(d.max())}/255")
    if px.any():
        y, x = np.argwhere(px)[0]
        print(f"     first at ({x}, {y}): {A[y, x]} vs {B[y, x]}")
        same = False
    if differ:
        break
sys.exit(0 if same != differ else 1)
EOF
compare() { "$PY" "$OUT/textures.py" "$@"; }
HINT=" (differences of 1/255 in a few pixels: is the example built with -ffp-contract=off, as the CLI builds supermat.h?)"
# exited WHAT NAME: the last run exited 0
exited() { if [ "$RC" -eq 0 ]; then ok "$1"; else bad "$1: exit $RC $(tail -c 400 "$OUT/$2.err")"; fi; }

# (a) the view model alone
mesh cli cli.gltf
if [ "$RC" -eq 0 ] && grep -q supermat_mv_default.safetensors "$OUT/cli.err"; then ok "supermat mesh without model flags (the multi-view default)"
else bad "supermat mesh without model flags: exit $RC $(tail -c 400 "$OUT/cli.err")"; fi
run ex "$EX" "$MV" "$IN" "$OUT/ex/ex.gltf"
exited "bake_gltf MV IN OUT" ex
if compare "$OUT/cli/cli.gltf" "$OUT/ex/ex.gltf"; then ok "(a) the same textures: supermat mesh = bake_gltf MV"
else bad "(a) supermat mesh and bake_gltf MV give different textures$HINT"; fi

# (b) and the two UV-refine models
mesh cli_refine cli.gltf --refine
if [ "$RC" -eq 0 ] && grep -q supermat_refine_albedo_default.safetensors "$OUT/cli_refine.err" &&
    grep -q supermat_refine_rm_default.safetensors "$OUT/cli_refine.err"; then ok "supermat mesh --refine (the refine defaults)"
else bad "supermat mesh --refine: exit $RC $(tail -c 400 "$OUT/cli_refine.err")"; fi
run ex_refine "$EX" "$MV" "$BC" "$RM" "$IN" "$OUT/ex_refine/ex.gltf"
exited "bake_gltf MV BC RM IN OUT" ex_refine
if compare "$OUT/cli_refine/cli.gltf" "$OUT/ex_refine/ex.gltf"; then ok "(b) the same textures: supermat mesh --refine = bake_gltf MV BC RM"
else bad "(b) supermat mesh --refine and bake_gltf MV BC RM give different textures$HINT"; fi

# the other way: the detail step is on in (a), so turning it off changes the base colour
mesh cli_nodetail cli.gltf --detail off
exited "supermat mesh --detail off" cli_nodetail
if compare "$OUT/cli/cli.gltf" "$OUT/cli_nodetail/cli.gltf" differ; then ok "--detail off gives another base colour (the model file's detail step is on by default)"
else bad "--detail off gives the default's base colour: the view model records no detail step (pipeline.bake_detail_sigma)"; fi

# bake_gltf's errors: exit 1 and a message naming what failed
expect_fail() { # what needle cmd...
    local what=$1 needle=$2
    shift 2
    run fail "$@"
    if [ "$RC" -eq 1 ] && grep -qF -- "$needle" "$OUT/fail.err"; then ok "bake_gltf $what: exit 1, $(head -c 200 "$OUT/fail.err" | head -n 1)"
    else bad "bake_gltf $what: exit $RC (want 1), stderr: $(head -c 300 "$OUT/fail.err")"; fi
}
expect_fail "on a missing model file" "$OUT/missing.safetensors" "$EX" "$OUT/missing.safetensors" "$IN" "$OUT/fail/x.gltf"
expect_fail "on a missing refine model" "$OUT/missing_rm.safetensors" "$EX" "$MV" "$BC" "$OUT/missing_rm.safetensors" "$IN" "$OUT/fail/x.gltf"
expect_fail "on a missing glTF" "$OUT/missing.gltf" "$EX" "$MV" "$OUT/missing.gltf" "$OUT/fail/x.gltf"
expect_fail "on an output folder that does not exist" "cannot write" "$EX" --passthrough "$IN" "$OUT/no/such/folder/x.gltf"
summary
