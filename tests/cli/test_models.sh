#!/usr/bin/env bash
# tests/cli/test_models.sh - the named models: `--model official` (and official-mv, official-refine-albedo,
# official-refine-rm, default) and the model folder they live in ($SUPERMAT_MODEL_DIR, else
# $XDG_DATA_HOME/supermat, else ~/.local/share/supermat), which `supermat download official` fills.
#
#   bash tests/cli/test_models.sh BUILD/supermat tests/data
#
# The tiny official-format networks, converted here, stand in the folder under the official files' names.
# Checks: image, pack, info and views resolve each name to its file (the same maps, bytes, kind as the file
# given by path); `--model default` is the default model; the folder comes from each variable in its order;
# a name whose file is missing exits 1 naming the file, the folder and `supermat download official`;
# `supermat info` without FILE lists what it finds and where; `supermat mesh --model official` bakes with
# the official SuperMatMV and both refine networks (the same bytes as the three files given by path), with
# --no-refine the SuperMatMV alone, and refuses other model flags beside it (exit 2).
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny
setup_tiny_mv
setup_tiny_uv
MD=$T/models
mkdir -p "$MD"
cp "$MODEL" "$MD/supermat_official.safetensors"
cp "$MV" "$MD/supermat_mv_official.safetensors"
cp "$UV" "$MD/supermat_refine_albedo_official.safetensors"
cp "$UV" "$MD/supermat_refine_rm_official.safetensors"

# ---- image: the name and the file give the same maps --------------------------------------------
run image --model "$MODEL" --out "$T/by_path" "$SPHERE"
check "image --model FILE: exit 0" [ $RC -eq 0 ]
run_env SUPERMAT_MODEL_DIR="$MD" -- image --model official --out "$T/by_name" "$SPHERE"
check "image --model official: exit 0" [ $RC -eq 0 ] || cat "$T/err"
for m in albedo roughness metallic; do
    check "image --model official: ${m} as with the file" cmp -s "$T/by_path/sphere_64_$m.png" "$T/by_name/sphere_64_$m.png"
done
# the folder from XDG_DATA_HOME, then HOME, when SUPERMAT_MODEL_DIR is not set
mkdir -p "$T/xdg/supermat" "$T/hm/.local/share/supermat"
cp "$MODEL" "$T/xdg/supermat/supermat_official.safetensors"
cp "$MODEL" "$T/hm/.local/share/supermat/supermat_official.safetensors"
run_env -u SUPERMAT_MODEL_DIR XDG_DATA_HOME="$T/xdg" HOME="$T/none" -- image --model official --out "$T/by_xdg" "$SPHERE"
check "image --model official from \$XDG_DATA_HOME/supermat: exit 0" [ $RC -eq 0 ]
check "image --model official from \$XDG_DATA_HOME/supermat: the same albedo" cmp -s "$T/by_path/sphere_64_albedo.png" "$T/by_xdg/sphere_64_albedo.png"
run_env -u SUPERMAT_MODEL_DIR -u XDG_DATA_HOME HOME="$T/hm" -- image --model official --out "$T/by_home" "$SPHERE"
check "image --model official from ~/.local/share/supermat: exit 0" [ $RC -eq 0 ]
check "image --model official from ~/.local/share/supermat: the same albedo" cmp -s "$T/by_path/sphere_64_albedo.png" "$T/by_home/sphere_64_albedo.png"
# SUPERMAT_MODEL_DIR wins over XDG_DATA_HOME: an empty folder there is not skipped
mkdir -p "$T/empty"
run_env SUPERMAT_MODEL_DIR="$T/empty" XDG_DATA_HOME="$T/xdg" -- image --model official --out "$T/by_none" "$SPHERE"
check "a missing official file: exit 1" [ $RC -eq 1 ]
check "a missing official file: the file named" grep -q "$T/empty/supermat_official.safetensors" "$T/err"
check "a missing official file: where the folder came from" grep -q 'SUPERMAT_MODEL_DIR' "$T/err"
check "a missing official file: the command that gets it" grep -q 'supermat download official' "$T/err"
absent "$T/by_none/sphere_64_albedo.png"
run_env -u SUPERMAT_MODEL_DIR -u XDG_DATA_HOME -u HOME -- image --model official --out "$T/by_none" "$SPHERE"
check "no folder at all (HOME unset): exit 1" [ $RC -eq 1 ]
check "no folder at all: says so" grep -q 'HOME' "$T/err"
# ./official is a file; `default` is the default model
cp "$MODEL" "$T/official"
cd "$T"
run image --model ./official --out "$T/by_dot" "$SPHERE"
cd - >/dev/null
check "image --model ./official (a file of that name): exit 0" [ $RC -eq 0 ]
run_env SUPERMAT_MODEL="$MODEL" -- image --model default --out "$T/by_default" "$SPHERE"
check "image --model default: exit 0" [ $RC -eq 0 ]
check "image --model default: the default model (\$SUPERMAT_MODEL here)" cmp -s "$T/by_path/sphere_64_albedo.png" "$T/by_default/sphere_64_albedo.png"
run views --model default --out "$T/v" "$SPHERE"
check "views --model default (views has none): exit 2" [ $RC -eq 2 ]

# ---- pack, info: the names ----------------------------------------------------------------------
run pack --model "$MODEL" --out "$T/p_path.safetensors"
run_env SUPERMAT_MODEL_DIR="$MD" -- pack --model official --out "$T/p_name.safetensors"
check "pack --model official: exit 0" [ $RC -eq 0 ]
check "pack --model official: the bytes of the file's" cmp -s "$T/p_path.safetensors" "$T/p_name.safetensors"
for n in official:supermat official-mv:supermat-mv official-refine-albedo:uv-refine official-refine-rm:uv-refine; do
    run_env SUPERMAT_MODEL_DIR="$MD" -- info "${n%%:*}"
    check "info ${n%%:*}: exit 0" [ $RC -eq 0 ]
    check "info ${n%%:*}: kind ${n#*:}" grep -Eq "^kind +${n#*:}\$" "$T/out"
done
run_env SUPERMAT_MODEL_DIR="$MD" SUPERMAT_MODEL="$MODEL" -- info
check "info: exit 0" [ $RC -eq 0 ]
check "info: the model folder and where it came from" grep -Eq "^  model folder +$MD \(\\\$SUPERMAT_MODEL_DIR\)" "$T/out"
check "info: official found, with its size" grep -Eq "^  official +$MD/supermat_official.safetensors \([0-9.]+ MiB\)" "$T/out"
check "info: official-refine-rm found" grep -Eq "^  official-refine-rm +$MD/supermat_refine_rm_official.safetensors \(" "$T/out"
check "info: the default model" grep -Eq "^  default +$MODEL \(\\\$SUPERMAT_MODEL\)" "$T/out"
run_env SUPERMAT_MODEL_DIR="$T/empty" SUPERMAT_MODEL="$MODEL" -- info
check "info, an empty folder: official not downloaded" grep -Eq "^  official +$T/empty/supermat_official.safetensors: not downloaded" "$T/out"

# ---- views --model official: the multi-view network ---------------------------------------------
VIEWS=()
for k in 0 1 2 3 4 5; do VIEWS+=("$MVIMG/color_000$k.png"); done
run views --model "$MV" --cameras "$MVIMG/meta.json" --out "$T/views_path" "${VIEWS[@]}"
run_env SUPERMAT_MODEL_DIR="$MD" -- views --model official --cameras "$MVIMG/meta.json" --out "$T/views_name" "${VIEWS[@]}"
check "views --model official: exit 0" [ $RC -eq 0 ] || cat "$T/err"
check "views --model official: the multi-view file's maps" cmp -s "$T/views_path/color_0003_albedo.png" "$T/views_name/color_0003_albedo.png"

# ---- mesh --model official ----------------------------------------------------------------------
if "$BIN" mesh --help 2>&1 | grep -q -- '--model NAME'; then
    EXM="$(cd "$DATA/../../examples/mesh" && pwd)/example_pbr.gltf"
    SZ=(--texture-size 64 --views-size 64)
    run mesh "${SZ[@]}" --mv-model "$MV" --albedo-refine "$UV" --rm-refine "$UV" "$EXM" "$T/m_path.glb"
    check "mesh with the three files: exit 0" [ $RC -eq 0 ] || cat "$T/err"
    run_env SUPERMAT_MODEL_DIR="$MD" -- mesh "${SZ[@]}" --model official "$EXM" "$T/m_name.glb"
    check "mesh --model official: exit 0" [ $RC -eq 0 ] || cat "$T/err"
    check "mesh --model official: the bake of the three files" cmp -s "$T/m_path.glb" "$T/m_name.glb"
    run mesh "${SZ[@]}" --mv-model "$MV" --no-refine "$EXM" "$T/m_path_nr.glb"
    run_env SUPERMAT_MODEL_DIR="$MD" -- mesh "${SZ[@]}" --model official --no-refine "$EXM" "$T/m_name_nr.glb"
    check "mesh --model official --no-refine: exit 0" [ $RC -eq 0 ]
    check "mesh --model official --no-refine: the SuperMatMV's bake alone" cmp -s "$T/m_path_nr.glb" "$T/m_name_nr.glb"
    check "mesh --model official: the refinement changed the bake" bash -c "! cmp -s '$T/m_name.glb' '$T/m_name_nr.glb'"
    for extra in --refine "--mv-model $MV" "--albedo-refine $UV" --passthrough; do
        # shellcheck disable=SC2086   # extra is split on purpose
        run_env SUPERMAT_MODEL_DIR="$MD" -- mesh "${SZ[@]}" --model official $extra "$EXM" "$T/m_bad.glb"
        check "mesh --model official $extra: exit 2" [ $RC -eq 2 ]
    done
    run mesh --model nonsense "$EXM" "$T/m_bad.glb"
    check "mesh --model nonsense: exit 2" [ $RC -eq 2 ]
    rm -f "$MD/supermat_refine_rm_official.safetensors"
    run_env SUPERMAT_MODEL_DIR="$MD" -- mesh "${SZ[@]}" --model official "$EXM" "$T/m_miss.glb"
    check "mesh --model official, a refine file missing: exit 1" [ $RC -eq 1 ]
    check "mesh --model official, a refine file missing: named" grep -q "supermat_refine_rm_official.safetensors" "$T/err"
    absent "$T/m_miss.glb"
    run_env SUPERMAT_MODEL_DIR="$MD" -- mesh "${SZ[@]}" --model official --no-refine "$EXM" "$T/m_nr2.glb"
    check "mesh --model official --no-refine needs no refine file: exit 0" [ $RC -eq 0 ]
else
    echo "SKIP: mesh --model (the tool is built without the mesh command)"
fi
summary
