# tests/cli/lib.sh - what the end-to-end tests of the `supermat` tool share (sourced by tests/cli/test_*.sh).
#
#   bash tests/cli/test_TOPIC.sh BUILD/supermat tests/data
#
# Sets BIN (the tool), DATA (tests/data), T (a temporary folder, removed at exit), the pictures SPHERE and
# RING and the model path MODEL; defines the counters and checks (ok, bad, check, absent, check_png,
# check_pfm), the ways to run the tool (run, run_env, run_limited: stdout in $T/out, stderr in $T/err, the
# exit code in RC), the setup helpers (setup_tiny and its kin convert the tiny official-format checkpoints
# of tests/data/tiny in a tenth of a second each; make_bad_png; golden_setup / golden: PFMs against the
# official goldens with tests/pfm_npy_diff.c) and summary, the last line of every test: "N passed, M
# failed", exit status 1 when any failed.
# Needs bash, coreutils, od, awk and a C compiler for the golden comparisons (skipped without one).
# shellcheck shell=bash disable=SC2034   # the variables are for the tests that source this file
set -eu

if [ $# -ne 2 ]; then
    echo "usage: $0 PATH/TO/supermat TESTS_DATA_DIR" >&2
    exit 2
fi
BIN=$1
DATA=$2
T=$(mktemp -d "${TMPDIR:-/tmp}/supermat_$(basename "$0" .sh).XXXXXX")
trap 'rm -rf "$T"' EXIT
# tests/ (pfm_npy_diff.c)
TESTS_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

PASS=0
FAIL=0
ok() { PASS=$((PASS + 1)); }
bad() { FAIL=$((FAIL + 1)); echo "FAIL: $*"; }
not() { ! "$@"; } # check "..." not grep -q ...: passes when the command fails
check() { # check "description" command...
    local what=$1
    shift
    if "$@"; then ok; else bad "$what"; fi
}
# the last line of every test: the counts, and the exit status
summary() {
    echo "$PASS passed, $FAIL failed"
    [ "$FAIL" -eq 0 ]
}

# runs the tool, keeping stdout, stderr and the exit code; a sanitizer report (ASan exits 1 too, like
# an expected error) is a failure of its own. SUPERMAT_MODEL (the default model) is removed from the
# environment: only run_env sets it.
run() { run_env -- "$@"; }
# run_env [VAR=VALUE...] -- ARGS: the same with these variables set
run_env() {
    local vars=()
    while [ "$1" != "--" ]; do vars+=("$1"); shift; done
    shift
    set +e
    env -u SUPERMAT_MODEL ${vars[@]+"${vars[@]}"} "$BIN" "$@" >"$T/out" 2>"$T/err"
    RC=$?
    set -e
    if grep -Eq 'Sanitizer|runtime error:' "$T/err"; then
        bad "sanitizer report from: supermat $*"
        cat "$T/err"
    fi
}
# a write that fails (a 4 KiB file size limit with SIGXFSZ ignored: write() fails with EFBIG)
run_limited() {
    set +e
    (trap '' XFSZ; ulimit -f 4; exec env -u SUPERMAT_MODEL "$BIN" "$@") >"$T/out" 2>"$T/err"
    RC=$?
    set -e
}

# PNG width, height, bit depth, colour type from the IHDR chunk (bytes 16..25)
png_ihdr() {
    local b
    read -r -a b <<<"$(od -An -v -tu1 -j16 -N10 "$1")"
    [ ${#b[@]} -eq 10 ] || { echo "0 0 0 0"; return; }
    echo "$(((b[0] << 24) | (b[1] << 16) | (b[2] << 8) | b[3])) $(((b[4] << 24) | (b[5] << 16) | (b[6] << 8) | b[7])) ${b[8]} ${b[9]}"
}
is_png() { [ "$(od -An -v -tx1 -N8 "$1" | tr -d ' \n')" = "89504e470d0a1a0a" ]; }
# check_png FILE W H COLOURTYPE (0 gray, 2 RGB)
check_png() {
    if [ ! -f "$1" ]; then bad "$1 missing"; return; fi
    if ! is_png "$1"; then bad "$1 is not a PNG"; return; fi
    local got
    got=$(png_ihdr "$1")
    if [ "$got" = "$2 $3 8 $4" ]; then ok; else bad "$1: IHDR '$got', expected '$2 $3 8 $4'"; fi
}
# check_pfm FILE W H CHANNELS
check_pfm() {
    if [ ! -f "$1" ]; then bad "$1 missing"; return; fi
    local magic=Pf hdr size want
    [ "$4" -eq 3 ] && magic=PF
    hdr=$(head -n 3 "$1" | tr '\n' '|')
    if [ "$hdr" = "$magic|$2 $3|-1.0|" ]; then ok; else bad "$1: header '$hdr', expected '$magic|$2 $3|-1.0|'"; fi
    size=$(wc -c <"$1")
    want=$((${#magic} + 1 + ${#2} + 1 + ${#3} + 1 + 5 + $2 * $3 * $4 * 4))
    if [ "$size" -eq "$want" ]; then ok; else bad "$1: $size bytes, expected $want"; fi
}
absent() { if [ -e "$1" ]; then bad "$1 should not exist"; else ok; fi; }

SPHERE=$DATA/img/sphere_64.png   # 64 x 64
RING=$DATA/img/ring_48x72.png    # 72 wide, 48 high
MODEL=$T/tiny.safetensors
MV=$T/tiny_mv.safetensors
UV=$T/tiny_uv.safetensors
MVIMG=$DATA/img/mv
UVIMG=$DATA/img/uv

# setup (not checks; a failure is one): the tiny models as test_convert.sh and test_views.sh /
# test_refine.sh convert them and check that conversion. MODEL and the MV / UV models record no work size
# (--work-size native: the pictures run at their own size, as the goldens were made); F16 (an f16 copy,
# converted without --work-size) records the official 512.
setup_convert() { # setup_convert OUT CONVERT-ARGS...
    local out=$1
    shift
    run convert "$@" --base "$DATA/tiny/base" --out "$out"
    [ $RC -eq 0 ] || { bad "setup: cannot convert $out"; cat "$T/err"; }
}
setup_tiny() { setup_convert "$MODEL" --kind supermat --unet "$DATA/tiny/supermat.pth" --work-size native; }
setup_tiny_f16() { F16=$T/tiny_f16.safetensors; setup_convert "$F16" --unet "$DATA/tiny/supermat.pth" --dtype f16; }
setup_tiny_mv() { setup_convert "$MV" --kind supermat-mv --unet "$DATA/tiny/supermat_mv.pth" --work-size native; }
setup_tiny_uv() { setup_convert "$UV" --kind uv-refine --unet "$DATA/tiny/uv_refine_bc.pth" --work-size native; }

# BAD: a valid 30x30 8-bit gray PNG (zlib stream and CRCs included), a size that is not a multiple of 8
make_bad_png() {
    BAD=$T/bad_30x30.png
    printf '\211\120\116\107\015\012\032\012\000\000\000\015\111\110\104\122\000\000\000\036\000\000\000\036\010\000\000\000\000\036\133\361\176\000\000\000\025\111\104\101\124\170\332\143\150\300\013\030\106\245\107\245\107\245\007\122\032\000\225\201\302\020\354\122\050\077\000\000\000\000\111\105\116\104\256\102\140\202' >"$BAD"
}

# the golden comparison tool (max abs error of PFMs against a float32 NCHW .npy)
golden_setup() {
    DIFF=""
    if command -v "${CC:-cc}" >/dev/null 2>&1; then
        if ${CC:-cc} -std=c99 -O2 -o "$T/pfm_npy_diff" "$TESTS_DIR/pfm_npy_diff.c" -lm 2>"$T/cc_err"; then DIFF=$T/pfm_npy_diff
        else bad "cannot compile tests/pfm_npy_diff.c"; cat "$T/cc_err"; fi
    else
        echo "SKIP: no C compiler (${CC:-cc}): the PFM vs golden comparisons do not run"
    fi
}
golden() { # golden "description" [--channel C] REF.npy PFM...
    local what=$1
    shift
    [ -n "$DIFF" ] || return 0
    local ch=()
    if [ "$1" = "--channel" ]; then ch=(--channel "$2"); shift 2; fi
    if "$DIFF" ${ch[@]+"${ch[@]}"} 1e-4 "$@" >"$T/diff_out" 2>&1; then
        ok
        echo "$what: $(cat "$T/diff_out")"
    else
        bad "$what: $(cat "$T/diff_out")"
    fi
}
