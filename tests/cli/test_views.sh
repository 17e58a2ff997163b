#!/usr/bin/env bash
# tests/cli/test_views.sh - `supermat views`: the multi-view model.
#
#   bash tests/cli/test_views.sh BUILD/supermat tests/data
#
# Converts the tiny multi-view checkpoint, `info` on it, runs `views` (6 views, 3 views with --outputs, one
# view with a numeric index and a flat matrix), compares the --float maps with the official goldens (max abs
# error 1e-4, tests/pfm_npy_diff.c built with ${CC:-cc}; skipped without a compiler), --chroma (off by
# default), --conv winograd-f4 against the goldens (and info --conv, a bad --conv), --work-size; the camera
# file errors (missing index, malformed JSON, duplicate index, short / non-numeric / non-finite / missing
# matrix, too many locations) and view errors (sizes, names, multiples of 8, no --cameras); and a model of
# the wrong kind for image, views and refine (exit 1, pointing to the right command).
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny
setup_tiny_uv
make_bad_png

# ---- multi-view (views) ----------------------------------------------------------------------
run convert --kind supermat-mv --unet "$DATA/tiny/supermat_mv.pth" --base "$DATA/tiny/base" --out "$MV" --work-size native
check "convert supermat-mv exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"

run info "$MV"
check "info mv exits 0" [ $RC -eq 0 ]
check "info mv: kind" grep -Eq '^kind +supermat-mv$' "$T/out"
check "info mv: camera embedding" grep -q 'camera embedding in 16' "$T/out"
check "info mv: session for 6 views" grep -q '6 views' "$T/out"
check "info mv: the command" grep -q 'supermat views' "$T/out"

golden_setup

VIEWS=()
for k in 0 1 2 3 4 5; do VIEWS+=("$MVIMG/color_000$k.png"); done
OV=$T/views6
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OV" --float "${VIEWS[@]}"
check "views (6 views) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check "views writes nothing on stdout" [ ! -s "$T/out" ]
for k in 0 1 2 3 4 5; do
    check_png "$OV/color_000${k}_albedo.png" 64 64 2
    check_png "$OV/color_000${k}_roughness.png" 64 64 0
    check_png "$OV/color_000${k}_metallic.png" 64 64 0
    check_pfm "$OV/color_000${k}_albedo.pfm" 64 64 3
    check_pfm "$OV/color_000${k}_metallic.pfm" 64 64 1
done
check "views: 36 files (18 PNG, 18 PFM)" [ "$(find "$OV" -type f | wc -l)" -eq 36 ]
golden "views albedo vs golden mv6_64/albedo.npy" "$DATA/golden/mv6_64/albedo.npy" "$OV"/color_000{0,1,2,3,4,5}_albedo.pfm
golden "views roughness vs golden mv6_64/orm.npy G" --channel 1 "$DATA/golden/mv6_64/orm.npy" "$OV"/color_000{0,1,2,3,4,5}_roughness.pfm
golden "views metallic vs golden mv6_64/orm.npy B" --channel 2 "$DATA/golden/mv6_64/orm.npy" "$OV"/color_000{0,1,2,3,4,5}_metallic.pfm
# --chroma: off by default in views (the goldens above are the official computation); asked for, it changes
# every view's albedo and nothing else
OVC=$T/views6_chroma
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OVC" --chroma 1 "${VIEWS[@]}"
check "views --chroma 1 exits 0" [ $RC -eq 0 ]
for k in 0 5; do
    check "views --chroma 1: view $k's albedo changed" bash -c "! cmp -s '$OVC/color_000${k}_albedo.png' '$OV/color_000${k}_albedo.png'"
    check "views --chroma 1: view $k's roughness and metallic unchanged" bash -c "cmp -s '$OVC/color_000${k}_roughness.png' '$OV/color_000${k}_roughness.png' && cmp -s '$OVC/color_000${k}_metallic.png' '$OV/color_000${k}_metallic.png'"
done
# --conv: the Winograd lever from the command line, against the same official goldens
OVW=$T/views6_wf4
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OVW" --float --conv winograd-f4 "${VIEWS[@]}"
check "views --conv winograd-f4 exits 0" [ $RC -eq 0 ]
golden "views --conv winograd-f4 albedo vs golden mv6_64/albedo.npy" "$DATA/golden/mv6_64/albedo.npy" "$OVW"/color_000{0,1,2,3,4,5}_albedo.pfm
golden "views --conv winograd-f4 metallic vs golden mv6_64/orm.npy B" --channel 2 "$DATA/golden/mv6_64/orm.npy" "$OVW"/color_000{0,1,2,3,4,5}_metallic.pfm
run info --conv f4 "$MV"
check "info --conv f4 reports Winograd F4" grep -Eq '^convolutions +winograd-f4' "$T/out"
run info "$MV"
check "info: direct convolutions by default" grep -Eq '^convolutions +direct' "$T/out"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_badconv" --conv winograd-f9 "${VIEWS[@]}"
check "--conv winograd-f9 exits 2" [ $RC -eq 2 ]
check "--conv winograd-f9: the message" grep -q "is not direct, winograd-f2 or winograd-f4" "$T/err"
absent "$T/views_badconv"


OV3=$T/views3
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$OV3" --outputs albedo,metallic --threads 1 \
    "$MVIMG/color_0004.png" "$MVIMG/color_0001.png" "$MVIMG/color_0002.png"
check "views (3 views, --outputs albedo,metallic) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
for k in 1 2 4; do
    check_png "$OV3/color_000${k}_albedo.png" 64 64 2
    check_png "$OV3/color_000${k}_metallic.png" 64 64 0
    absent "$OV3/color_000${k}_roughness.png"
done
absent "$OV3/color_0000_albedo.png"

# one view; a numeric index and a flat 16-number matrix (color_0003's camera)
CAM3=$(tr -d ' \n' <"$MVIMG/meta.json" | sed 's/.*"index":"0003","transform_matrix":\[\(\[[^]]*\]\),\(\[[^]]*\]\),\(\[[^]]*\]\),\(\[[^]]*\]\)\].*/\1,\2,\3,\4/' | tr -d '[]')
printf '{"locations": [{"index": 3, "transform_matrix": [%s]}]}\n' "$CAM3" >"$T/meta_num.json"
OV1=$T/views1
run views --model "$MV" --cameras "$T/meta_num.json" --out "$OV1" "$MVIMG/color_0003.png"
check "views (1 view, numeric index, flat matrix) exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || { cat "$T/err"; cat "$T/meta_num.json"; }
check_png "$OV1/color_0003_albedo.png" 64 64 2
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views1s" "$MVIMG/color_0003.png"
check "views (1 view, the official meta.json) exits 0" [ $RC -eq 0 ]
check "index 3 and \"0003\", nested and flat matrix: the same camera" cmp -s "$OV1/color_0003_albedo.png" "$T/views1s/color_0003_albedo.png"

# camera file errors: exit 1, a message naming the file, nothing written
ID='[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]'
cam_error() { # cam_error "description" 'pattern in the message' JSON
    local what=$1 pat=$2
    printf '%s\n' "$3" >"$T/meta_bad.json"
    run views --model "$MV" --cameras "$T/meta_bad.json" --out "$T/views_bad" "$MVIMG/color_0000.png" "$MVIMG/color_0001.png"
    check "$what: exits 1" [ $RC -eq 1 ]
    check "$what: the message names the file" grep -q 'meta_bad.json' "$T/err"
    if grep -q -- "$pat" "$T/err"; then ok; else bad "$what: no '$pat' in: $(cat "$T/err")"; fi
    absent "$T/views_bad"
}
cam_error "meta.json without index 1" 'no location with index 1' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0002\", \"transform_matrix\": $ID}]}"
cam_error "malformed meta.json" 'not valid JSON' "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID},"
cam_error "meta.json without locations" 'no "locations"' '{"frames": []}'
cam_error "duplicate index" 'index 1 appears twice' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0001\", \"transform_matrix\": $ID}, {\"index\": 1, \"transform_matrix\": $ID}]}"
cam_error "short matrix row" 'row 2 has 3 numbers' \
    '{"locations": [{"index": "0000", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1],[0,0,0,1]]}, {"index": "0001", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}'
cam_error "three matrix rows" 'has 3 rows' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}, {\"index\": \"0001\", \"transform_matrix\": $ID}]}"
cam_error "non-numeric matrix element" 'transform_matrix\[1\]\[2\] is not a number' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0001\", \"transform_matrix\": [[1,0,0,0],[0,1,\"x\",0],[0,0,1,0],[0,0,0,1]]}]}"
cam_error "non-finite matrix element" 'not a finite' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,1e999],[0,0,0,1]]}, {\"index\": \"0001\", \"transform_matrix\": $ID}]}"
cam_error "missing matrix" 'no "transform_matrix"' \
    "{\"locations\": [{\"index\": \"0000\", \"transform_matrix\": $ID}, {\"index\": \"0001\"}]}"
cam_error "non-numeric index" 'index "front" is not a whole number' \
    "{\"locations\": [{\"index\": \"front\", \"transform_matrix\": $ID}]}"
many=$(for i in $(seq 0 4100); do printf '{"index": %d, "transform_matrix": %s},' "$i" "$ID"; done)
cam_error "4101 locations (the duplicate check is quadratic: capped)" 'at most 4096 are read' "{\"locations\": [${many%,}]}"

# view errors
mkdir -p "$T/vin"
cp "$RING" "$T/vin/ring_0002.png"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_bad" "$MVIMG/color_0000.png" "$T/vin/ring_0002.png"
check "views of two sizes exit 1" [ $RC -eq 1 ]
check "views of two sizes: the message names the view" grep -q 'ring_0002.png' "$T/err"
check "views of two sizes: the message says same size" grep -q 'same size' "$T/err"
cp "$SPHERE" "$T/vin/front.png"
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_bad" "$T/vin/front.png"
check "a view without a number exits 1" [ $RC -eq 1 ]
check "a view without a number: the message names it" grep -q 'front.png' "$T/err"
cp "$BAD" "$T/vin/bad_0000.png" # a camera index that meta.json has: the size is what is wrong
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_bad" "$T/vin/bad_0000.png"
check "a 30x30 view exits 1 (the model records no work size: the views' own size)" [ $RC -eq 1 ]
check "a 30x30 view: multiples of 8" grep -q 'multiples of 8' "$T/err"
run views --model "$MV" --cameras "$T/no_such_meta.json" --out "$T/views_bad" "$MVIMG/color_0000.png"
check "a missing meta.json exits 1" [ $RC -eq 1 ]
check "a missing meta.json: the message names it" grep -q 'no_such_meta.json' "$T/err"
run views --model "$MV" --out "$T/views_bad" "$MVIMG/color_0000.png"
check "views without --cameras exits 2" [ $RC -eq 2 ]
absent "$T/views_bad"

# at another work size: the maps come back at the input's size
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_ws" --work-size 32 "$MVIMG/color_0000.png" "$MVIMG/color_0001.png"
check "views --work-size 32 exits 0" [ $RC -eq 0 ]
check_png "$T/views_ws/color_0000_albedo.png" 64 64 2

# a model of the wrong kind: exit 1, pointing to the right command
run image --model "$MV" --out "$T/kind_bad" "$SPHERE"
check "image with the MV model exits 1" [ $RC -eq 1 ]
check "image with the MV model points to views" grep -q 'supermat views' "$T/err"
run image --model "$UV" --out "$T/kind_bad" "$SPHERE"
check "image with the UV model exits 1" [ $RC -eq 1 ]
check "image with the UV model points to refine" grep -q 'supermat refine' "$T/err"
run views --model "$MODEL" --cameras "$MVIMG/meta.json" --out "$T/kind_bad" "$MVIMG/color_0000.png"
check "views with the single-view model exits 1" [ $RC -eq 1 ]
check "views with the single-view model points to image" grep -q 'supermat image' "$T/err"
run refine --model "$MV" --map "$UVIMG/uv_bc.png" --mask "$UVIMG/uv_mask.png" --position "$UVIMG/uv_position.png" --out "$T/kind_bad"
check "refine with the MV model exits 1" [ $RC -eq 1 ]
check "refine with the MV model points to views" grep -q 'supermat views' "$T/err"
absent "$T/kind_bad"

summary
