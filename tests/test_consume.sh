#!/usr/bin/env bash
# supermat as a dependency of another CMake project, and through pkg-config:
#   test_consume.sh SOURCE_DIR BUILD_DIR WORK_DIR
# 1. `cmake --install BUILD_DIR --prefix WORK/prefix`: headers, CLI, CMake package, supermat.pc are there
# 2. tests/consumer built with find_package(supermat CONFIG) against that prefix
# 3. the same with FetchContent and with add_subdirectory of SOURCE_DIR: only the library is configured
#    (no CLI, tests or test dependencies; a C-only project), and supermat's install rules stay off
# 4. a plain compiler line with `pkg-config --cflags --libs supermat`
# Each consumer compiles with -Wall -Wextra -pedantic -Werror, two SUPERMAT_STATIC copies included, and runs.
set -euo pipefail
src=$(cd "$1" && pwd); build=$2; work=$3
CC=${CC:-cc}
rm -rf "$work"; mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }

echo "== install"
cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
for f in include/supermat.h include/supermat_uv.h bin/supermat share/cmake/supermat/supermatConfig.cmake \
         share/cmake/supermat/supermatConfigVersion.cmake share/cmake/supermat/supermatTargets.cmake \
         share/pkgconfig/supermat.pc; do
  [ -f "$work/prefix/$f" ] || fail "cmake --install did not install $f"
done

for mode in find_package fetchcontent subdirectory; do
  echo "== consumer: $mode"
  args=(-DMODE=$mode)
  if [ $mode = find_package ]; then args+=(-DCMAKE_PREFIX_PATH="$work/prefix"); else args+=(-DSUPERMAT_SRC="$src"); fi
  cmake -S "$src/tests/consumer" -B "$work/$mode" "${args[@]}" >"$work/$mode.log" 2>&1 || { cat "$work/$mode.log"; fail "$mode: configure"; }
  cmake --build "$work/$mode" >>"$work/$mode.log" 2>&1 || { cat "$work/$mode.log"; fail "$mode: build"; }
  "$work/$mode/consumer" > "$work/$mode.out" || { cat "$work/$mode.out"; fail "$mode: the consumer failed"; }
  cat "$work/$mode.out"
  # no build type given: the target's -O2 for the empty configuration (GCC, Clang) makes it an optimised build
  case "$CC" in *gcc*|*clang*|cc) grep -qx 'optimized 1' "$work/$mode.out" || fail "$mode: built without optimisation (no build type)";; esac
  if [ $mode != find_package ]; then
    # the consumer gets the library alone: no supermat CLI or test targets, no C++ enabled, no install rules
    grep -q '^CMAKE_CXX_COMPILER:' "$work/$mode/CMakeCache.txt" && fail "$mode: C++ enabled in a C consumer"
    grep -q 'SUPERMAT_UV_TESTS\|SUPERMAT_EMBREE' "$work/$mode/CMakeCache.txt" && fail "$mode: test options/dependencies configured"
    targets=$(cmake --build "$work/$mode" --target help)
    echo "$targets" | grep -Eq '^\.\.\. (supermat|test_[a-z_]+)$' && fail "$mode: tool or test targets in the consumer build: $(echo "$targets" | grep -E 'supermat|test_')"
    cmake --install "$work/$mode" --prefix "$work/$mode-inst" >/dev/null
    [ -e "$work/$mode-inst/include/supermat.h" ] && fail "$mode: supermat's install rules ran in the consumer (SUPERMAT_INSTALL defaults off there)"
  fi
done

echo "== pkg-config"
pc="$work/prefix/share/pkgconfig"
cflags=$(PKG_CONFIG_PATH="$pc" pkg-config --cflags supermat)
libs=$(PKG_CONFIG_PATH="$pc" pkg-config --libs supermat)
[ "$(PKG_CONFIG_PATH="$pc" pkg-config --modversion supermat)" = "$(sed -n 's/^Version: //p' "$pc/supermat.pc" | head -1)" ] || fail "pkg-config version"
echo "pkg-config: $cflags $libs"
modeldir=$(PKG_CONFIG_PATH="$pc" pkg-config --variable=modeldir supermat)
[ -f "$modeldir/supermat_default.safetensors" ] || fail "pkg-config modeldir '$modeldir' has no supermat_default.safetensors"
[ "$(cd "$modeldir" && pwd -P)" = "$(cd "$work/prefix/share/supermat" && pwd -P)" ] || fail "pkg-config modeldir '$modeldir' is not the installed folder"
# shellcheck disable=SC2086
$CC -std=c99 -Wall -Wextra -pedantic -Werror $cflags -o "$work/pc_consumer" "$src"/tests/consumer/{main,impl,static_a,static_b}.c $libs \
  || fail "pkg-config compile"
"$work/pc_consumer" || fail "pkg-config consumer"
echo "ok"
