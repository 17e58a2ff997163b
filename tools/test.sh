#!/usr/bin/env bash
# The test command (README, .ci/run): installs what the tests need from Debian when it is missing,
# builds, and runs every test through ctest three times: gcc Release (-Werror), gcc with
# AddressSanitizer + UndefinedBehaviorSanitizer, and a clang build (C and C++, -Werror).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
need=()
for p in cmake make gcc g++ clang libstb-dev libembree-dev libopenimageio-dev libtinygltf-dev nlohmann-json3-dev pkg-config libwebp-dev parallel procps slurmctld slurmd slurm-client munge afl++ gcc-aarch64-linux-gnu qemu-user-static file python3-numpy python3-scipy python3-pil strace; do
  dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq "${need[@]}" >/dev/null
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

echo "== gcc, Release, -Werror"
# UV tests on explicitly: `bash tools/demo.sh` configures the same build/ folder with them off
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_WERROR=ON -DSUPERMAT_UV_TESTS=ON -DSUPERMAT_NEON_TESTS=ON >/dev/null
cmake --build build -j"$jobs"
(cd build && ctest --output-on-failure -j"$jobs")

echo "== clang, Release, -Werror"
CC=clang CXX=clang++ cmake -S . -B build-clang -DCMAKE_BUILD_TYPE=Release -DSUPERMAT_WERROR=ON >/dev/null
cmake --build build-clang -j"$jobs"
(cd build-clang && ctest --output-on-failure -j"$jobs")

echo "== gcc, AddressSanitizer + UndefinedBehaviorSanitizer"
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSUPERMAT_SANITIZE=ON >/dev/null
cmake --build build-asan -j"$jobs"
(cd build-asan && ASAN_OPTIONS=detect_leaks=1 ctest --output-on-failure -j"$jobs")
