#!/bin/sh
# ctest blender_addon: tests/blender/test_addon.py in Debian's Blender, headless, with its user folders in WORK
# (the add-on is installed there, not in ~/.config/blender). Exit 77 (skipped) where there is no blender or the
# supermat tool was built without `supermat mesh` (libtinygltf-dev).
# usage: tests/blender/run_test.sh WORK CLI LIBRARY [BLENDER]
set -eu
work=$1 cli=$2 lib=$3 blender=${4:-blender}
if ! command -v "$blender" >/dev/null 2>&1; then
  echo "SKIP: no blender ($blender)"; exit 77
fi
if ! "$cli" --version | grep -q '^built with:.*\bmesh\b'; then
  echo "SKIP: $cli was built without supermat mesh (libtinygltf-dev)"; exit 77
fi
rm -rf "$work"
mkdir -p "$work/user/scripts" "$work/user/config"
here=$(cd "$(dirname "$0")" && pwd)
BLENDER_USER_SCRIPTS="$work/user/scripts" BLENDER_USER_CONFIG="$work/user/config" \
  exec "$blender" -b --factory-startup --python-exit-code 1 --python "$here/test_addon.py" -- "$work" "$cli" "$lib"
