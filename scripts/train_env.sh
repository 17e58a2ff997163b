# Sourced by scripts/train_default.sh, train_mv_default.sh and train_refine_default.sh (not run on its own): from the
# repository root, the variables they read (MIRROR_DIR, WORK required; THREADS, AMP, HARNESS_DEPS), the Debian
# packages training needs (OpenBLAS: without it torch's Linear layers run on the
# reference BLAS, many times slower) and those a script names in TRAIN_PACKAGES before sourcing this, and the CC0
# Poly Haven maps of github pmndrs/drei-assets extracted to $WORK/hdri (the only lighting).
# Python packages: diffusers 0.27 or newer (checked with 0.31.0), transformers (CLIPTextModel, CLIPTokenizer) and
# safetensors from the ordinary Python path (pip install diffusers==0.31.0 transformers safetensors, or PYTHONPATH);
# the SuperMat classes are the project's own (supermat_tools.supermat_adapters).  HARNESS_DEPS (optional): a folder
# whose site/ holds extracted package sources, put first on PYTHONPATH here (a stand-in for pip); python/ follows.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
: "${MIRROR_DIR:?set MIRROR_DIR to the folder holding pmndrs+drei-assets/repo}"
: "${WORK:?set WORK to a scratch folder outside the repository}"
if [ -n "${HARNESS_DEPS:-}" ]; then export HARNESS_DEPS; fi
THREADS="${THREADS:-$(nproc 2>/dev/null || echo 2)}"
# bf16 autocast for the fine-tuning where the CPU has AMX or AVX512_BF16 (the shipped model's ft phases ran so;
# an e2e step: 1.56 s on AMX; 3.7 s with AVX512_BF16 but no AMX, where float32 takes 4.25 s), else float32
AMP="${AMP:-$(grep -qwE 'amx_bf16|avx512_bf16' /proc/cpuinfo 2>/dev/null && echo bf16 || echo off)}"
PY=/usr/bin/python3
export PYTHONPATH="${HARNESS_DEPS:+$HARNESS_DEPS/site:}$PWD/python${PYTHONPATH:+:$PYTHONPATH}"

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

# the Python packages, checked here, before any data is rendered, not when the first training phase starts
"$PY" - <<'EOF' || { echo "train_env.sh: training needs diffusers (0.27 or newer; checked with 0.31.0), transformers" \
  "and safetensors on the Python path (pip, PYTHONPATH, or HARNESS_DEPS=<folder with site/>)" >&2; exit 2; }
from supermat_tools import supermat_adapters  # noqa: F401  (imports diffusers)
import safetensors.torch, transformers  # noqa: F401,E401
EOF

mkdir -p "$WORK/hdri"
git --git-dir="$MIRROR_DIR/pmndrs+drei-assets/repo" archive HEAD hdri | tar -x -C "$WORK"
