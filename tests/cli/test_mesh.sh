#!/usr/bin/env bash
# tests/cli/test_mesh.sh - `supermat mesh` options, where the tool is built with the mesh command.
#
#   bash tests/cli/test_mesh.sh BUILD/supermat tests/data
#
# The renamed options (--texture-size, --view-weight) and their old spellings (--size, --weight) bake the same
# file; --view-weight cos changes the bake. Without the mesh command nothing is checked (0 passed). (The
# mesh command's own tests are ctest uv_mesh_cli, batch, mesh_commit; a hostile texture is in test_inputs.sh.)
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# mesh's renamed options (--texture-size, --view-weight) and their old spellings (--size, --weight): the same bake
if "$BIN" mesh --help 2>&1 | grep -q -- '--texture-size'; then
  EXM="$(cd "$DATA/../../examples/mesh" && pwd)/example_pbr.gltf"
  run mesh --passthrough --texture-size 64 --views-size 64 --view-weight cos "$EXM" "$T/mesh_new.glb"
  check "mesh --texture-size 64 --view-weight cos exits 0" [ $RC -eq 0 ]
  run mesh --passthrough --size 64 --views-size 64 --weight cos "$EXM" "$T/mesh_old.glb"
  check "mesh --size 64 --weight cos (the old spellings) exits 0" [ $RC -eq 0 ]
  check "mesh: the old spellings bake what the new ones bake" cmp -s "$T/mesh_new.glb" "$T/mesh_old.glb"
  run mesh --passthrough --texture-size 64 --views-size 64 "$EXM" "$T/mesh_avg.glb"
  check "mesh --view-weight cos changes the bake" bash -c "! cmp -s '$T/mesh_new.glb' '$T/mesh_avg.glb'"
fi

summary
