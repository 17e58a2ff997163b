#!/usr/bin/env bash
# The test command (README, .ci/run): installs what the tests need from Debian when it is missing,
# builds, and runs the tests through ctest in three builds: gcc Release (-Werror) runs every test; a clang
# build (C and C++, -Werror) and gcc with AddressSanitizer + UndefinedBehaviorSanitizer run all but the
# labels python and quality (the Python package's scripts and the trained models' floors, which a second
# compiler or the sanitizers do not change, and a fifth of those two builds' test time). A build that
# fails (configure, compile or tests) does not stop the others: a summary line per build at the end
# ("gcc: 100/100 passed (12 of them skipped)", "clang: FAILED (ctest exit 8): ..."), exit status 1 if any failed.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
need=()
for p in cmake make gcc g++ clang libstb-dev libembree-dev libopenimageio-dev libtinygltf-dev nlohmann-json3-dev pkg-config libwebp-dev zlib1g-dev parallel procps slurmctld slurmd slurm-client munge afl++ gcc-aarch64-linux-gnu qemu-user-static file python3-numpy python3-scipy python3-pil python3-pytest strace curl; do
  dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq "${need[@]}" >/dev/null
fi
# the Windows build of the library (ctest mingw): MinGW-w64 and wine64; Blender's Cycles renders the independent
# evaluation set (ctest eval_cycles renders a sphere with it); both without their recommends
need=()
for p in gcc-mingw-w64-x86-64 wine64 blender; do dpkg -s "$p" >/dev/null 2>&1 || need+=("$p"); done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi
# node + the Khronos glTF-Validator (npm) check every glTF `supermat mesh` writes (ctest uv_gltf_corpus)
if ! command -v npm >/dev/null 2>&1; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq nodejs npm >/dev/null
fi
if [ ! -f build-npm/node_modules/gltf-validator/package.json ]; then
  mkdir -p build-npm
  npm install --prefix build-npm --no-audit --no-fund --loglevel=error gltf-validator@2.0.0-dev.3.10 >/dev/null
fi
jobs=$(nproc 2>/dev/null || echo 2)
# `bash scripts/test.sh` runs every test; `bash scripts/test.sh LABEL` only the tests with that ctest label
# in each build (a regular expression: golden, unit, cli, mesh, python, quality, fuzz, 'unit|golden'; tests/README.md)
label_args=()
[ $# -gt 0 ] && label_args=(-L "$1")

# Each build runs to its end even when another failed (configure, compile or a test): a summary line per
# build at the end, and the exit status is 1 when any of them failed.
summary=()
status=0
# run_build NAME DIR CTEST_ENV EXCLUDE CONFIGURE-COMMAND...: configures (the command), builds DIR and runs its
# ctest but the labels EXCLUDE (a ctest label expression, may be empty), which it leaves to the gcc Release build
run_build() {
  local name=$1 dir=$2 ctest_env=$3 exclude=$4 rc=0 line total failed skipped
  local ex=()
  shift 4
  [ -n "$exclude" ] && ex=(-LE "$exclude")
  "$@" >/dev/null || rc=$?
  if [ "$rc" != 0 ]; then
    summary+=("$name: FAILED (cmake configure exit $rc)"); status=1; return 0
  fi
  cmake --build "$dir" -j"$jobs" || rc=$?
  if [ "$rc" != 0 ]; then
    summary+=("$name: FAILED (build exit $rc)"); status=1; return 0
  fi
  # ctest's output also goes to DIR/ctest-output.log, for the counts below
  (cd "$dir" && env $ctest_env ctest --output-on-failure -j"$jobs" "${label_args[@]}" "${ex[@]}") 2>&1 | tee "$dir/ctest-output.log" || rc=$?
  # "97% tests passed, 3 tests failed out of 100"; skipped tests (exit 77) count as passed there
  line=$(grep -E '^[0-9]+% tests passed, [0-9]+ tests? failed out of [0-9]+' "$dir/ctest-output.log" | tail -n 1 || true)
  skipped=$(grep -cE '^[[:space:]]*[0-9]+ - .* \(Skipped\)$' "$dir/ctest-output.log" || true)
  if [ -n "$line" ]; then
    total=$(echo "$line" | sed -E 's/.* out of ([0-9]+).*/\1/')
    failed=$(echo "$line" | sed -E 's/.*, ([0-9]+) tests? failed.*/\1/')
    line="$((total - failed))/$total passed ($skipped of them skipped)"
  else
    line="no ctest summary"
  fi
  if [ "$rc" != 0 ]; then
    summary+=("$name: FAILED (ctest exit $rc): $line"); status=1
  else
    summary+=("$name: $line")
  fi
}

echo "== gcc, Release, -Werror"
# UV tests on explicitly: `bash scripts/demo.sh` configures the same build/ folder with them off
run_build "gcc" build "" "" \
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_WERROR=ON -DSUPERMAT_UV_TESTS=ON -DSUPERMAT_NEON_TESTS=ON -DSUPERMAT_MINGW_TESTS=ON

echo "== clang, Release, -Werror"
run_build "clang" build-clang "" "python|quality" \
  env CC=clang CXX=clang++ cmake -S . -B build-clang -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_WERROR=ON

echo "== gcc, AddressSanitizer + UndefinedBehaviorSanitizer"
run_build "asan" build-asan "ASAN_OPTIONS=detect_leaks=1" "python|quality" \
  cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSUPERMAT_SANITIZE=ON

echo "== summary"
printf '%s\n' "${summary[@]}"
exit "$status"
