#!/usr/bin/env bash
# The main job on the default model: build the tool, turn pictures into albedo / roughness / metallic
# maps under out/, and put each picture and its maps side by side in out/sheet.png; then bake the example
# mesh examples/mesh/ with `supermat mesh` (out/mesh/, out/mesh_sheet.png) and render the input, the bake
# and the truth under a new light (out/mesh_relight.png; supermat_tools.relight_demo, numpy / Pillow / scipy).
#
#   bash scripts/demo.sh
#
# Pictures: examples/pictures/*.png (RGBA, width and height multiples of 8). A file named
# <stem>_gt_albedo.png, <stem>_gt_roughness.png or <stem>_gt_metallic.png there is a true map of
# <stem>.png, not a picture: the sheet shows it in a "true ..." column. When that folder has no
# pictures, tests/data/img/sphere_64.png is used. IMAGE="a.png b.png" picks other pictures.
# Model: the default model, found by `supermat` itself (SUPERMAT_MODEL, the installed data folder,
# the source tree's models/supermat_default.safetensors: `build/supermat image --help`). To run the
# official model instead, convert its checkpoint and a Stable Diffusion 2.1 folder (diffusers layout):
#   MODEL_PTH=supermat.pth BASE_DIR=stable-diffusion-2-1 bash scripts/demo.sh
# (written to out/model.safetensors and given with --model).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export PYTHONPATH="$PWD/python${PYTHONPATH:+:$PYTHONPATH}"   # the tools: python -m supermat_tools.X (python/README.md)
need=()
# nlohmann-json3-dev: `supermat mesh` needs it beside libtinygltf-dev (which does not depend on it)
for p in cmake make gcc g++ libstb-dev libtinygltf-dev nlohmann-json3-dev python3 python3-numpy python3-pil python3-scipy; do
  dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  echo "demo: updating the package lists (apt-get update)"
  $SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
  echo "demo: installing ${#need[@]} package$([ ${#need[@]} -eq 1 ] || echo s): ${need[*]} (waits up to 10 minutes for another apt)"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq "${need[@]}" >/dev/null
fi
echo "demo: building build/supermat"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_UV_TESTS=OFF >/dev/null
cmake --build build -j"$(nproc 2>/dev/null || echo 2)" --target supermat >/dev/null
SM=build/supermat
mkdir -p out

# the pictures
pics=()
if [ -n "${IMAGE:-}" ]; then
  read -r -a pics <<<"$IMAGE"
else
  for f in examples/pictures/*.png; do
    [ -f "$f" ] || continue
    case "$f" in *_gt_albedo.png | *_gt_roughness.png | *_gt_metallic.png) continue ;; esac
    pics+=("$f")
  done
  if [ ${#pics[@]} -eq 0 ]; then
    echo "demo: no pictures in examples/pictures: using tests/data/img/sphere_64.png"
    pics=(tests/data/img/sphere_64.png)
  fi
fi

# the model: the default one, unless MODEL_PTH asks for a conversion
model=()
if [ -n "${MODEL_PTH:-}" ]; then
  if [ -z "${BASE_DIR:-}" ]; then
    echo "demo: MODEL_PTH needs BASE_DIR, the Stable Diffusion 2.1 folder (diffusers layout)" >&2
    exit 2
  fi
  "$SM" convert --force --kind supermat --unet "$MODEL_PTH" --base "$BASE_DIR" --out out/model.safetensors
  model=(--model out/model.safetensors)
  echo "model: out/model.safetensors (converted from $MODEL_PTH)"
else
  if ! info=$("$SM" info); then
    echo "demo: no default model (see the places above). Give one with SUPERMAT_MODEL=FILE.safetensors," >&2
    echo "      or convert a checkpoint: MODEL_PTH=supermat.pth BASE_DIR=stable-diffusion-2-1 bash scripts/demo.sh" >&2
    exit 1
  fi
  echo "model: $(sed -n 's/^default *//p' <<<"$info")"
fi

# the maps
# out/ is the demo's own folder: --force replaces the maps of an earlier run
"$SM" image --force ${model[@]+"${model[@]}"} --out out "${pics[@]}"

# the sheet: picture, albedo, roughness, metallic (+ the true maps when there are any)
gt=0
for p in "${pics[@]}"; do
  for m in albedo roughness metallic; do [ -f "${p%.png}_gt_$m.png" ] && gt=1; done
done
rows=()
for p in "${pics[@]}"; do
  s=$(basename "${p%.*}")
  row="$p,out/${s}_albedo.png,out/${s}_roughness.png,out/${s}_metallic.png"
  if [ $gt = 1 ]; then
    for m in albedo roughness metallic; do
      if [ -f "${p%.png}_gt_$m.png" ]; then row="$row,${p%.png}_gt_$m.png"; else row="$row,-"; fi
    done
  fi
  rows+=("$row")
done
labels="input,albedo,roughness,metallic"
[ $gt = 1 ] && labels="$labels,true albedo,true roughness,true metallic"
"$SM" sheet --force --out out/sheet.png --cell 160 --labels "$labels" "${rows[@]}" >/dev/null

echo
echo "maps (${#pics[@]} picture$([ ${#pics[@]} -eq 1 ] || echo s)):"
for p in "${pics[@]}"; do
  s=$(basename "${p%.*}")
  echo "  out/${s}_albedo.png  out/${s}_roughness.png  out/${s}_metallic.png   (from $p)"
done
echo "sheet: out/sheet.png (each row: $labels)"

# the mesh: examples/mesh/lit/example_pbr_lit.gltf, a procedural torus and sphere of ours whose base colour has
# its lighting baked in (supermat_tools.make_example_mesh and .litbake; the true textures beside it), baked by
# `supermat mesh` with no model flags: the multi-view default (models/supermat_mv_default.safetensors) on the six
# views together, no refinement (`--refine` would add the UV-refine defaults, which lose on the assets measured: docs/mesh.md)
mesh_help=$("$SM" mesh --help 2>&1 || true)
if grep -q "usage: supermat mesh" <<<"$mesh_help"; then
  mkdir -p out/mesh
  ex=examples/mesh/lit/example_pbr
  "$SM" mesh --force --size 256 --debug-dir out/mesh/debug "$ex"_lit.gltf out/mesh/example.gltf
  "$SM" sheet --force --out out/mesh_sheet.png --cell 160 \
    --labels "input (front),lit texture,albedo,roughness,metallic,true albedo,true roughness,true metallic" \
    "out/mesh/debug/view_0.png,${ex}_lit_baseColor.png,out/mesh/example_baseColor.png,out/mesh/example_metallicRoughness.png:g,out/mesh/example_metallicRoughness.png:b,${ex}_truth_albedo.png,${ex}_truth_roughness.png,${ex}_truth_metallic.png" >/dev/null
  echo "mesh: out/mesh/example.gltf (+ its textures); sheet: out/mesh_sheet.png (the input's front view, its lit"
  echo "      texture, the baked albedo / roughness / metallic textures, the true ones)"
  # the input as given, the bake and the truth, rendered under a map the lit texture did not see
  PY=python3; [ -x /usr/bin/python3 ] && PY=/usr/bin/python3
  r=out/mesh/relit
  "$PY" -m supermat_tools.relight_demo --hdri examples/mesh/studio_small_03_256.hdr --out "$r" --views 2 \
    input="$ex"_lit.gltf baked=out/mesh/example.gltf truth=examples/mesh/example_pbr.gltf >/dev/null
  "$SM" sheet --force --out out/mesh_relight.png --cell 160 \
    --labels "input as given (new light),baked (new light),truth (new light)" \
    "$r/input_v0.png,$r/baked_v0.png,$r/truth_v0.png" "$r/input_v1.png,$r/baked_v1.png,$r/truth_v1.png" >/dev/null
  echo "relit: out/mesh_relight.png (the input mesh as given, the baked one and the truth under studio_small_03,"
  echo "       two views, one exposure)"
else
  echo "mesh: skipped (this supermat was built without glTF support: apt install libtinygltf-dev nlohmann-json3-dev)"
fi
