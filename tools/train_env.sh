# Sourced by tools/train_default.sh, train_mv_default.sh and train_refine_default.sh (not run on its own): from the
# repository root, the variables they read (MIRROR_DIR, HARNESS_DEPS, WORK required; THREADS, AMP,
# SUPERMAT_REFERENCE), the Debian packages training needs (OpenBLAS: without it torch's Linear layers run on the
# reference BLAS, many times slower) and those a script names in TRAIN_PACKAGES before sourcing this, and the CC0
# Poly Haven maps of github pmndrs/drei-assets extracted to $WORK/hdri (the only lighting).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
: "${MIRROR_DIR:?set MIRROR_DIR to the folder holding pmndrs+drei-assets/repo}"
: "${HARNESS_DEPS:?set HARNESS_DEPS to the reference harness dependency folder}"
: "${WORK:?set WORK to a scratch folder outside the repository}"
export HARNESS_DEPS
# the reference harness' import shims (the training scripts import harness_env.py from it): checked here, before
# any data is rendered, not when the first training phase starts
REF="${SUPERMAT_REFERENCE:-$PWD/../shared/reference}"
[ -f "$REF/harness_env.py" ] || { echo "train_env.sh: no $REF/harness_env.py: set SUPERMAT_REFERENCE to the" \
  "reference harness folder (../shared/reference beside the repository)" >&2; exit 2; }
export SUPERMAT_REFERENCE="$REF"
THREADS="${THREADS:-$(nproc 2>/dev/null || echo 2)}"
# bf16 autocast for the fine-tuning where the CPU has AMX or AVX512_BF16 (the shipped model's ft phases ran so;
# an e2e step: 1.56 s on AMX; 3.7 s with AVX512_BF16 but no AMX, where float32 takes 4.25 s), else float32
AMP="${AMP:-$(grep -qwE 'amx_bf16|avx512_bf16' /proc/cpuinfo 2>/dev/null && echo bf16 || echo off)}"
PY=/usr/bin/python3

need=()
# shellcheck disable=SC2086   # TRAIN_PACKAGES: more packages a script needs, set before sourcing this file
for p in python3-torch python3-numpy python3-pil libopenblas0-pthread cmake make gcc g++ libstb-dev ${TRAIN_PACKAGES:-}; do
  dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" != 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi

mkdir -p "$WORK/hdri"
git --git-dir="$MIRROR_DIR/pmndrs+drei-assets/repo" archive HEAD hdri | tar -x -C "$WORK"
