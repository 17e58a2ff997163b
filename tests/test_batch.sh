#!/usr/bin/env bash
# tests/test_batch.sh - `supermat batch` on a small asset library with the tiny model.
#
#   tests/test_batch.sh BUILD/supermat TINY_SUPERMAT_MODEL TESTS_DATA_DIR [CUBE_GLTF]
#
# 21 pictures in nested folders (three sizes) plus a corrupt one. The reference: `supermat image` on each
# folder. Checks, each against that reference (cmp of every map):
#   - a folder batch: exit 1 (the corrupt picture), the journal has 21 done records and one failed with
#     its message, the maps mirror the folders; a re-run runs nothing and appends nothing; the picture
#     repaired, --retry-failed runs it alone: exit 0;
#   - SIGKILL at random instants, 12 times, then a run to the end: every item done exactly once in the
#     journal, no FILE.tmp left, every map identical to the reference;
#   - --shard 0/3, 1/3, 2/3: disjoint, together every item; --merge writes the union, and with the inputs
#     finds nothing missing (and, with one shard's journal removed, exits 1 naming what is missing);
#   - --jobs 3: the same maps, every item done once;
#   - a manifest: plain lines and JSON Lines with per-item "outputs"; malformed lines are usage errors;
#   - GNU parallel (when installed): 3 workers, one per shard, one killed mid-run; `parallel
#     --resume-failed` finishes it; every item done exactly once, maps identical to the reference;
#   - scripts/slurm_batch.sh run as Slurm runs array tasks, then the merge; and (as root, with Debian's
#     slurmctld, slurmd, slurm-client, munge) on a real single-node Slurm cluster the test starts: the array
#     over 4 shards, one task cancelled mid-run and resubmitted alone, every item once, the merge;
#   - batch mesh (with CUBE_GLTF, a textured glTF with its .bin and texture beside it, and a supermat built
#     with mesh): 6 assets in folders and a broken one, outputs identical to `supermat mesh`, 6 SIGKILLs
#     then a run to the end: each asset done once, no staging folder left; with TINY_MV and TINY_UV,
#     networks: each process loads the two models once for 3 assets (1 and 2 workers), textures identical
#     to `supermat mesh`, pre-packed models (`supermat pack`) used in place with the same textures.
set -u
if [ $# -lt 3 ] || [ $# -gt 6 ]; then echo "usage: $0 PATH/TO/supermat TINY_MODEL TESTS_DATA_DIR [CUBE_GLTF [TINY_MV TINY_UV]]" >&2; exit 2; fi
CUBE=""
[ $# -ge 4 ] && [ -f "$4" ] && CUBE=$(realpath "$4")
TINY_MV=""; TINY_UV=""
[ $# -ge 6 ] && [ -f "$5" ] && [ -f "$6" ] && TINY_MV=$(realpath "$5") && TINY_UV=$(realpath "$6")
BIN=$(realpath "$1")
MODEL=$(realpath "$2")
DATA=$(realpath "$3")
SCRIPT=$(realpath "$(dirname "$0")/../scripts/slurm_batch.sh")
T=$(mktemp -d "${TMPDIR:-/tmp}/supermat_batch.XXXXXX")
trap 'rm -rf "$T"' EXIT
cd "$T" || exit 1
PASS=0
FAIL=0
bad() { FAIL=$((FAIL + 1)); echo "FAIL: $*"; }
check() { local what=$1; shift; if "$@"; then PASS=$((PASS + 1)); else bad "$what"; fi; }
RUN=(--model "$MODEL" --work-size 128 --threads 1)

# ---- the library ----
mkdir -p lib/props/metal lib/chars lib/empty
n=0
for d in lib lib/props lib/props/metal lib/chars; do
    for s in sphere_64 box_40 ring_48x72; do
        for k in 1 2; do
            n=$((n + 1))
            [ $n -le 21 ] && cp "$DATA/img/$s.png" "$d/${s}_$k.png"
        done
    done
done
echo "not a picture" > lib/chars/broken.png
echo "ignored" > lib/props/notes.txt
mkdir -p lib/.cache && cp "$DATA/img/sphere_64.png" lib/.cache/hidden.png
ITEMS=21

# ---- the reference: `supermat image` on each folder ----
for d in "" props props/metal chars; do
    pics=$(ls lib/$d/*.png | grep -v broken)
    # shellcheck disable=SC2086
    "$BIN" image "${RUN[@]}" --out "ref/$d" $pics 2>/dev/null || bad "reference image run in lib/$d"
done
same_as_ref() { # same_as_ref DIR: every reference map identical in DIR
    local f ok=0
    while read -r f; do
        cmp -s "ref/$f" "$1/$f" || { echo "  differs: $1/$f"; ok=1; }
    done < <(cd ref && find . -name '*.png' | sed 's|^\./||')
    return $ok
}
no_tmp() { [ -z "$(find "$1" -name '*.tmp')" ]; }
count() { local c; c=$(grep -c "$2" "$1" 2>/dev/null); echo "${c:-0}"; }
each_done_once() { # each_done_once JOURNAL...: 21 items, each with exactly one done record
    local d
    d=$(cat "$@" | grep '"status":"done"' | sed 's/^{"item":"\([^"]*\)".*/\1/' | sort | uniq -c)
    [ "$(echo "$d" | wc -l)" -eq $ITEMS ] && [ -z "$(echo "$d" | awk '$1 != 1')" ]
}

# ---- a folder batch ----
"$BIN" batch image "${RUN[@]}" --out out lib 2> log; rc=$?
check "folder batch exits 1 with a corrupt picture (got $rc)" [ $rc -eq 1 ]
check "21 done records" [ "$(count out/journal.jsonl '"status":"done"')" -eq $ITEMS ]
check "one failed record naming the picture" grep -q '"item":"chars/broken","input":"lib/chars/broken.png","status":"failed".*"error":"cannot read image' out/journal.jsonl
check "maps mirrored and identical to supermat image" same_as_ref out
check "hidden folders and other files left out" [ -z "$(grep -e hidden -e notes out/journal.jsonl)" ]
check "one line per item on stderr" grep -q '^\[22/22\] sphere_64_2 .* done' log
lines=$(wc -l < out/journal.jsonl)
"$BIN" batch image "${RUN[@]}" --out out lib 2> log; rc=$?
check "a re-run: exit 1 (still failed), nothing run" [ $rc -eq 1 ] && check "a re-run appends nothing" [ "$(wc -l < out/journal.jsonl)" -eq "$lines" ]
check "a re-run says what it skips" grep -q '21 done before, 1 failed before' log
cp "$DATA/img/sphere_64.png" lib/chars/broken.png
"$BIN" batch image "${RUN[@]}" --out out --retry-failed --json out.json lib 2> log; rc=$?
check "--retry-failed after the repair: exit 0 (got $rc)" [ $rc -eq 0 ]
check "--retry-failed runs the failed item alone" [ "$(wc -l < out/journal.jsonl)" -eq $((lines + 1)) ]
check "--json summary" grep -q '"items": 22, "done": 22, "done_this_run": 1, "failed": 0' out.json
echo "not a picture" > lib/chars/broken.png
"$BIN" batch image "${RUN[@]}" --out out2 --fail-fast lib/chars 2> log; rc=$?
check "--fail-fast stops at the first failure (exit 1)" [ $rc -eq 1 ]
check "--fail-fast: nothing after it" [ "$(count out2/journal.jsonl '"status"')" -eq 2 ]
check "--fail-fast: the last record is the failure" grep -q '"item":"broken",.*"status":"failed"' <(tail -1 out2/journal.jsonl)
rm -f lib/chars/broken.png

# ---- SIGKILL at random instants ----
RANDOM=7
for k in $(seq 12); do # each kill once the journal has 0 or 1 more items than before, plus 0-90 ms (any speed of machine)
    target=$(( $(count killed/journal.jsonl '"status":"done"') + RANDOM % 2 ))
    "$BIN" batch image "${RUN[@]}" --out killed lib 2>/dev/null &
    pid=$!
    while [ "$(count killed/journal.jsonl '"status":"done"')" -lt $target ] && kill -0 $pid 2>/dev/null; do sleep 0.01; done
    sleep "0.0$((RANDOM % 10))"
    kill -9 $pid 2>/dev/null
    wait $pid 2>/dev/null
done
partial=$(count killed/journal.jsonl '"status":"done"')
"$BIN" batch image "${RUN[@]}" --out killed lib 2> log; rc=$?
check "after 12 kills the run to the end exits 0 (got $rc; $partial done before it)" [ $rc -eq 0 ]
check "after the kills every item done exactly once" each_done_once killed/journal.jsonl
check "after the kills no FILE.tmp left" no_tmp killed
check "after the kills every map identical to the reference" same_as_ref killed
check "the kills interrupted the work ($partial of $ITEMS done before the last run)" [ "$partial" -gt 0 ]
check "the kills interrupted the work ($partial of $ITEMS done before the last run) (2)" [ "$partial" -lt $ITEMS ]

# ---- shards and merge ----
for i in 0 1 2; do "$BIN" batch image "${RUN[@]}" --out sharded --shard $i/3 lib 2>/dev/null || bad "shard $i/3"; done
check "shards: journal per shard" [ -f sharded/journal.0-of-3.jsonl ]
check "shards: journal per shard (2)" [ -f sharded/journal.2-of-3.jsonl ]
check "shards: journal per shard (3)" [ ! -f sharded/journal.jsonl ]
check "shards: 7 + 7 + 7 items" [ "$(count sharded/journal.0-of-3.jsonl done)$(count sharded/journal.1-of-3.jsonl done)$(count sharded/journal.2-of-3.jsonl done)" = 777 ]
check "shards: disjoint, every item once" each_done_once sharded/journal.*-of-3.jsonl
check "shards: maps identical to the reference" same_as_ref sharded
"$BIN" batch --merge --out sharded lib 2> log; rc=$?
check "merge with the inputs: exit 0 (got $rc)" [ $rc -eq 0 ]
check "merge: journal.jsonl has every item once" each_done_once sharded/journal.jsonl
mv sharded/journal.1-of-3.jsonl sharded/j1
"$BIN" batch --merge --out sharded --force lib 2> log; rc=$?
check "merge with a shard missing: exit 1 (got $rc)" [ $rc -eq 1 ] && check "merge names what is not done" grep -q '^not done: ' log
mv sharded/j1 sharded/journal.1-of-3.jsonl
"$BIN" batch image "${RUN[@]}" --out x --shard 3/3 lib 2>/dev/null; check "--shard 3/3 is a usage error" [ $? -eq 2 ]

# ---- workers ----
"$BIN" batch image "${RUN[@]}" --out jobs --jobs 3 lib 2> log; rc=$?
check "--jobs 3: exit 0 (got $rc)" [ $rc -eq 0 ]
check "--jobs 3: every item done once" each_done_once jobs/journal.jsonl
check "--jobs 3: maps identical to the reference" same_as_ref jobs

# ---- manifests ----
{
    echo "# a list"
    echo "lib/sphere_64_1.png"
    echo ""
    echo '{"input": "lib/props/box_40_1.png", "outputs": "albedo"}'
    echo '{"input": "lib/props/ring_48x72_1.png", "outputs": "roughness,metallic", "float": false}'
} > list.txt
"$BIN" batch image "${RUN[@]}" --out listed @list.txt 2> log; rc=$?
check "manifest: exit 0 (got $rc)" [ $rc -eq 0 ]
check "manifest: per-item outputs" [ -f listed/sphere_64_1_metallic.png ]
check "manifest: per-item outputs (2)" [ -f listed/box_40_1_albedo.png ]
check "manifest: per-item outputs (3)" [ ! -f listed/box_40_1_roughness.png ]
check "manifest: per-item outputs (4)" [ -f listed/ring_48x72_1_metallic.png ]
check "manifest: per-item outputs (5)" [ ! -f listed/ring_48x72_1_albedo.png ]
check "manifest: the maps are the reference's" cmp -s ref/props/box_40_1_albedo.png listed/box_40_1_albedo.png
echo '{"input": "lib/a.png", "colour": 1}' > badlist.txt
"$BIN" batch image "${RUN[@]}" --out listed2 @badlist.txt 2> log; rc=$?
check "manifest: an unknown key is a usage error naming the line" [ $rc -eq 2 ]
check "manifest: an unknown key is a usage error naming the line (2)" grep -q 'badlist.txt:1: unknown key "colour"' log
echo '{"input": "lib/a.png"' > badlist.txt
"$BIN" batch image "${RUN[@]}" --out listed2 @badlist.txt 2> log; rc=$?
check "manifest: malformed JSON is a usage error" [ $rc -eq 2 ]

# ---- GNU parallel: 3 workers, one killed, resumed ----
if command -v parallel >/dev/null 2>&1; then
    mkdir -p fan
    parallel --will-cite --joblog fan/joblog -j3 "$BIN" batch image "${RUN[@]}" --out fan --shard {}/3 lib ::: 0 1 2 2>/dev/null &
    ppid=$!
    killed=0
    for _ in $(seq 400); do # kill shard 1 once it has finished its first item
        if [ "$(count fan/journal.1-of-3.jsonl done)" -ge 1 ]; then
            pid=$(pgrep -f -- "--shard 1/3" | head -1)
            [ -n "$pid" ] && kill -9 "$pid" && killed=1
            break
        fi
        sleep 0.02
    done
    wait $ppid; prc=$?
    before=$(count fan/journal.1-of-3.jsonl done)
    check "parallel: one worker killed mid-run (killed=$killed, exit $prc, shard 1 had $before of 7)" [ $killed -eq 1 ]
    check "parallel: one worker killed mid-run (killed=$killed, exit $prc, shard 1 had $before of 7) (2)" [ $prc -ne 0 ]
    check "parallel: one worker killed mid-run (killed=$killed, exit $prc, shard 1 had $before of 7) (3)" [ "$before" -lt 7 ]
    parallel --will-cite --joblog fan/joblog --resume-failed -j3 "$BIN" batch image "${RUN[@]}" --out fan --shard {}/3 lib ::: 0 1 2 2>/dev/null; prc=$?
    check "parallel --resume-failed: exit 0 (got $prc)" [ $prc -eq 0 ]
    check "parallel: every item done exactly once" each_done_once fan/journal.*-of-3.jsonl
    check "parallel: maps identical to the single-process run" same_as_ref fan
    "$BIN" batch --merge --out fan lib 2>/dev/null; check "parallel: merge finds every item" [ $? -eq 0 ]
else
    echo "SKIP: GNU parallel is not installed (Debian: parallel); scripts/test.sh installs it"
fi

# ---- the Slurm array script, run as Slurm runs its tasks (no controller here: see the README) ----
for i in 0 1 2 3; do
    OUT=slurm SUPERMAT="$BIN" SUPERMAT_ARGS="${RUN[*]}" SLURM_ARRAY_TASK_ID=$i SLURM_ARRAY_TASK_COUNT=4 SLURM_CPUS_PER_TASK=1 \
        bash "$SCRIPT" lib 2>/dev/null || bad "slurm task $i"
done
OUT=slurm SUPERMAT="$BIN" SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_MAX=3 SUPERMAT_ARGS="${RUN[*]}" bash "$SCRIPT" lib 2>/dev/null
check "slurm: a resubmitted task (SLURM_ARRAY_TASK_MAX only) finds its shard done" [ $? -eq 0 ]
check "slurm: a resubmitted task (SLURM_ARRAY_TASK_MAX only) finds its shard done (2)" [ "$(count slurm/journal.1-of-4.jsonl done)" -eq 5 ]
check "slurm: 4 journals, every item once" each_done_once slurm/journal.*-of-4.jsonl
"$BIN" batch --merge --out slurm lib 2>/dev/null; check "slurm: the merge step finds every item" [ $? -eq 0 ]
check "slurm: maps identical to the reference" same_as_ref slurm

# ---- a real single-node Slurm cluster (as root, with Debian's slurmctld, slurmd, slurm-client and munge):
# the array over 4 shards, one task cancelled mid-run and resubmitted alone, the merge ----
if [ "$(id -u)" = 0 ] && command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v sbatch >/dev/null && command -v munged >/dev/null; then
    SD=$T/slurmcluster
    mkdir -p "$SD/state" "$SD/spool"
    H=$(hostname -s)
    started_munge=0
    if ! pgrep -x munged >/dev/null; then
        [ -f /etc/munge/munge.key ] || mungekey --create --keyfile /etc/munge/munge.key >/dev/null 2>&1
        mkdir -p /run/munge && chown munge:munge /run/munge /etc/munge/munge.key 2>/dev/null
        su -s /bin/sh munge -c /usr/sbin/munged 2>/dev/null || /usr/sbin/munged --force 2>/dev/null
        started_munge=1
    fi
    port=$((20000 + RANDOM % 20000))
    cat > "$SD/slurm.conf" <<EOC
ClusterName=supermattest
SlurmctldHost=$H(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
StateSaveLocation=$SD/state
SlurmdSpoolDir=$SD/spool
SlurmctldPidFile=$SD/slurmctld.pid
SlurmdPidFile=$SD/slurmd.pid
SlurmctldLogFile=$SD/ctld.log
SlurmdLogFile=$SD/d.log
ReturnToService=2
MpiDefault=none
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
SlurmctldPort=$port
SlurmdPort=$((port + 1))
NodeName=$H NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=$H Default=YES MaxTime=INFINITE State=UP
EOC
    export SLURM_CONF=$SD/slurm.conf
    slurm_down() {
        [ -f "$SD/slurmd.pid" ] && kill "$(cat "$SD/slurmd.pid")" 2>/dev/null
        [ -f "$SD/slurmctld.pid" ] && kill "$(cat "$SD/slurmctld.pid")" 2>/dev/null
        [ $started_munge = 1 ] && pkill -x munged
        unset SLURM_CONF
    }
    trap 'slurm_down; rm -rf "$T"' EXIT
    slurmctld -f "$SLURM_CONF" && slurmd -f "$SLURM_CONF"
    up=0
    for _ in $(seq 100); do [ "$(sinfo -h -o %t 2>/dev/null)" = idle ] && { up=1; break; }; sleep 0.2; done
    if [ $up -eq 0 ]; then # a machine where the daemons cannot run (no hostname, ports): say so
        echo "SKIP: the single-node Slurm cluster did not come up (sinfo: $(sinfo -h -o %t 2>&1 | head -1)); its log:"
        tail -5 "$SD/ctld.log" "$SD/d.log" 2>/dev/null
    else
        jid=$(OUT=$T/sl SHARDS=4 SUPERMAT="$BIN" SUPERMAT_ARGS="${RUN[*]}" sbatch --parsable --array=0-3 --cpus-per-task=1 \
              --chdir="$T" --output="$T/sl-%A_%a.log" "$SCRIPT" "$T/lib")
        cancelled=0
        for _ in $(seq 1500); do # cancel task 1 once it has finished an item and before it finishes all
            if [ "$(count sl/journal.1-of-4.jsonl done)" -ge 1 ]; then scancel "${jid}_1" && cancelled=1; break; fi
            sleep 0.02
        done
        for _ in $(seq 1500); do [ -z "$(squeue -h -j "$jid" 2>/dev/null)" ] && break; sleep 0.1; done
        before=$(count sl/journal.1-of-4.jsonl done)
        check "slurm cluster: task 1 cancelled mid-run (cancelled=$cancelled, it had $before of 5)" [ $cancelled -eq 1 ]
        check "slurm cluster: task 1 cancelled mid-run (cancelled=$cancelled, it had $before of 5) (2)" [ "$before" -lt 5 ]
        check "slurm cluster: the other tasks finished their shards" [ "$(count sl/journal.0-of-4.jsonl done)$(count sl/journal.2-of-4.jsonl done)$(count sl/journal.3-of-4.jsonl done)" = 655 ]
        jid2=$(OUT=$T/sl SHARDS=4 SUPERMAT="$BIN" SUPERMAT_ARGS="${RUN[*]}" sbatch --parsable --array=1 --cpus-per-task=1 \
               --chdir="$T" --output="$T/sl-%A_%a.log" "$SCRIPT" "$T/lib")
        for _ in $(seq 1500); do [ -z "$(squeue -h -j "$jid2" 2>/dev/null)" ] && break; sleep 0.1; done
        check "slurm cluster: the resubmitted task finished shard 1" [ "$(count sl/journal.1-of-4.jsonl done)" -eq 5 ]
        check "slurm cluster: every item done exactly once" each_done_once sl/journal.*-of-4.jsonl
        "$BIN" batch --merge --out sl lib 2>/dev/null; check "slurm cluster: the merge finds every item" [ $? -eq 0 ]
        check "slurm cluster: maps identical to the single-process run" same_as_ref sl
    fi
    slurm_down
    trap 'rm -rf "$T"' EXIT
else
    echo "SKIP: a real Slurm cluster (needs root and Debian's slurmctld, slurmd, slurm-client, munge; scripts/test.sh installs them)"
fi

# ---- pictures of one folder that share a stem (a.png, a.jpg): each keeps its extension in its stem ----
mkdir -p stems/sub
cp "$DATA/img/sphere_64.png" stems/a.png
cp "$DATA/img/ring_exif6.jpg" stems/a.jpg
cp "$DATA/img/box_40.png" stems/b.png
cp "$DATA/img/box_40.png" stems/sub/a.png  # another folder: no clash, its plain stem
"$BIN" image "${RUN[@]}" --out stems_ref_png stems/a.png > /dev/null 2>&1 &&
    "$BIN" image "${RUN[@]}" --out stems_ref_jpg stems/a.jpg > /dev/null 2>&1 || bad "reference image runs of stems/a.png and stems/a.jpg"
"$BIN" batch image "${RUN[@]}" --out stems_out stems > /dev/null 2> log; rc=$?
check "shared stems: exit 0, every picture done (got $rc)" [ $rc -eq 0 ]
check "shared stems: a.png's maps as a_png_*, those of \`image a.png\`" cmp -s stems_ref_png/a_albedo.png stems_out/a_png_albedo.png
check "shared stems: a.jpg's maps as a_jpg_*, those of \`image a.jpg\`" cmp -s stems_ref_jpg/a_albedo.png stems_out/a_jpg_albedo.png
check "shared stems: b (no clash) keeps its plain stem" [ -f stems_out/b_metallic.png ]
check "shared stems: b (no clash) keeps its plain stem (2)" [ ! -e stems_out/b_png_metallic.png ]
check "shared stems: sub/a.png (alone in its folder) keeps its plain stem" [ -f stems_out/sub/a_roughness.png ]
check "shared stems: the journal's items a_jpg, a_png, b, sub/a, each done" \
    [ "$(grep '"status":"done"' stems_out/journal.jsonl | sed 's/^{"item":"\([^"]*\)".*/\1/' | sort | tr '\n' ' ')" = "a_jpg a_png b sub/a " ]
"$BIN" image "${RUN[@]}" --out stems_img stems/a.jpg stems/a.png > /dev/null 2>&1; rc=$?
check "shared stems, image: exit 0 (got $rc), the same names and maps as the batch" \
    [ $rc -eq 0 ] && cmp -s stems_img/a_png_albedo.png stems_out/a_png_albedo.png && cmp -s stems_img/a_jpg_metallic.png stems_out/a_jpg_metallic.png
"$BIN" image "${RUN[@]}" --out stems_twice stems/a.png stems/a.png stems/b.png > /dev/null 2> log; rc=$?
check "image: one picture named twice is still a usage error (exit $rc), nothing written" [ $rc -eq 2 ]
check "image: one picture named twice is still a usage error (exit $rc), nothing written (2)" [ ! -e stems_twice ]
check "image: one picture named twice is still a usage error (exit $rc), nothing written (3)" grep -q "would write the same files" log
cp stems/b.png stems/a_png.jpg  # a.png -> a_png would meet a_png.jpg's own stem
"$BIN" image "${RUN[@]}" --out stems_meet stems/a.png stems/a.jpg stems/a_png.jpg > /dev/null 2> log; rc=$?
check "image: a.png, a.jpg and a_png.jpg still meet: usage error (exit $rc), nothing written" [ $rc -eq 2 ]
check "image: a.png, a.jpg and a_png.jpg still meet: usage error (exit $rc), nothing written (2)" [ ! -e stems_meet ]

# ---- a 16-bit picture: read at full precision, as `image` reads it (it was refused per item) ----
mkdir -p deep && cp "$DATA/img/sphere_64_16bit.png" deep/
"$BIN" image "${RUN[@]}" --out deep_ref deep/sphere_64_16bit.png > /dev/null 2>&1 || bad "reference image run of a 16-bit picture"
"$BIN" batch image "${RUN[@]}" --out deep_out deep > /dev/null 2>&1; rc=$?
check "batch image, a 16-bit picture: exit 0 (got $rc), the maps of \`image\`" [ $rc -eq 0 ]
check "batch image, a 16-bit picture: exit 0 (got $rc), the maps of \`image\` (2)" cmp -s deep_ref/sphere_64_16bit_albedo.png deep_out/sphere_64_16bit_albedo.png

# ---- batch mesh ----
if [ -n "$CUBE" ] && "$BIN" --version | grep -q mesh; then
    cdir=$(dirname "$CUBE")
    for d in m/a m/a/deep m/b; do
        mkdir -p "$d"
        for k in 1 2; do
            sed "s/cube_texture.png/tex_$k.png/; s/cube.bin/geo_$k.bin/" "$CUBE" > "$d/asset_$k.gltf"
            cp "$cdir/cube_texture.png" "$d/tex_$k.png"; cp "$cdir/cube.bin" "$d/geo_$k.bin"
        done
    done
    echo '{"asset": ' > m/b/broken.gltf
    MESH=(--passthrough --size 64 --views-size 64 --threads 1)
    "$BIN" mesh "${MESH[@]}" m/a/asset_1.gltf mref.gltf >/dev/null 2>&1 || bad "reference mesh run"
    "$BIN" batch mesh "${MESH[@]}" --out mout m > /dev/null 2> log; rc=$?
    check "batch mesh: exit 1 with a broken asset (got $rc)" [ $rc -eq 1 ]
    check "batch mesh: 6 done, 1 failed" [ "$(count mout/journal.jsonl '"status":"done"')$(count mout/journal.jsonl '"status":"failed"')" = 61 ]
    check "batch mesh: the asset mirrored, its textures as supermat mesh bakes them" cmp -s mref_baseColor.png mout/a/deep/asset_1_baseColor.png
    check "batch mesh: a .gltf with its buffer beside it" [ -f mout/b/asset_2.gltf ]
    check "batch mesh: a .gltf with its buffer beside it (2)" [ -f mout/b/geo_2.bin ]
    "$BIN" batch mesh --model x --out mout m 2>/dev/null; check "batch mesh: an image option is a usage error" [ $? -eq 2 ]
    # mesh's options are checked once, by mesh's own parser, before any asset or folder: a usage error
    "$BIN" batch mesh "${MESH[@]}" --work-size 7 --out mbad m > /dev/null 2> log; rc=$?
    check "batch mesh --work-size 7: a usage error before any asset (got $rc)" [ $rc -eq 2 ]
    check "batch mesh --work-size 7: mesh's message" grep -q -- "--work-size: 'native' or a multiple of 8" log
    check "batch mesh --work-size 7: no output folder, no journal" [ ! -e mbad ]
    "$BIN" batch mesh --passthrough --refine --out mbad m > /dev/null 2> log; rc=$?
    check "batch mesh --passthrough --refine: a usage error before any asset (got $rc)" [ $rc -eq 2 ]
    check "batch mesh --passthrough --refine: a usage error before any asset (got $rc) (2)" [ ! -e mbad ]
    rm -f m/b/broken.gltf
    for k in $(seq 6); do
        "$BIN" batch mesh "${MESH[@]}" --out mkill m >/dev/null 2>&1 &
        pid=$!
        sleep "0.0$((RANDOM % 10))"
        kill -9 $pid 2>/dev/null
        wait $pid 2>/dev/null
    done
    "$BIN" batch mesh "${MESH[@]}" --out mkill m >/dev/null 2>&1; rc=$?
    check "batch mesh after 6 kills: exit 0 (got $rc)" [ $rc -eq 0 ]
    check "batch mesh after the kills: each asset done once" [ "$(grep '"status":"done"' mkill/journal.jsonl | sed 's/^{"item":"\([^"]*\)".*/\1/' | sort | uniq -c | awk '$1 == 1' | wc -l)" -eq 6 ]
    check "batch mesh after the kills: no staging folder or FILE.tmp left" [ -z "$(find mkill -name '.supermat-mesh-*' -o -name '*.tmp')" ]
    check "batch mesh after the kills: textures identical" cmp -s mref_baseColor.png mkill/a/deep/asset_1_baseColor.png
    # with networks (the tiny multi-view and UV-refine models): each process loads the models once for the
    # whole batch, and the textures equal `supermat mesh`'s; pre-packed models give the same textures
    if [ -n "$TINY_MV" ] && [ -n "$TINY_UV" ]; then
        mkdir -p mm
        for k in 1 2 3; do
            sed "s/cube_texture.png/tex_$k.png/; s/cube.bin/geo_$k.bin/" "$CUBE" > "mm/asset_$k.gltf"
            cp "$cdir/cube_texture.png" "mm/tex_$k.png"; cp "$cdir/cube.bin" "mm/geo_$k.bin"
        done
        NET=(--mv-model "$TINY_MV" --albedo-refine "$TINY_UV" --rm-refine "$TINY_UV" --size 64 --views-size 64 --work-size native --threads 1)
        "$BIN" mesh "${NET[@]}" mm/asset_2.gltf mmref.gltf >/dev/null 2>&1 || bad "reference mesh run with models"
        "$BIN" batch mesh "${NET[@]}" --out mmout mm > /dev/null 2> log2; rc=$?
        check "batch mesh with models: exit 0 (got $rc)" [ $rc -eq 0 ]
        check "batch mesh with models: 3 assets, the two models loaded once ($(grep -c 'supermat mesh: loaded' log2) loads)" [ "$(grep -c 'supermat mesh: loaded' log2)" -eq 2 ]
        check "batch mesh with models: textures as supermat mesh bakes them" cmp -s mmref_baseColor.png mmout/asset_2_baseColor.png
        check "batch mesh with models: metallicRoughness as supermat mesh bakes it" cmp -s mmref_metallicRoughness.png mmout/asset_2_metallicRoughness.png
        # mesh flags without a value are passed on too (--keep-observed: the refined maps only where no view saw)
        "$BIN" mesh "${NET[@]}" --keep-observed mm/asset_2.gltf mmko.gltf >/dev/null 2>&1 || bad "reference mesh run, --keep-observed"
        "$BIN" batch mesh "${NET[@]}" --keep-observed --out mmko mm > /dev/null 2>&1; rc=$?
        ko_ok=0
        [ $rc -eq 0 ] && cmp -s mmko_baseColor.png mmko/asset_2_baseColor.png && ! cmp -s mmko_baseColor.png mmref_baseColor.png && ko_ok=1
        check "batch mesh --keep-observed: exit 0 (got $rc), textures as supermat mesh --keep-observed bakes them, not the full refinement's" [ $ko_ok -eq 1 ]
        "$BIN" pack --model "$TINY_MV" --out mv.packed.safetensors >/dev/null && "$BIN" pack --model "$TINY_UV" --out uv.packed.safetensors >/dev/null || bad "pack the tiny models"
        "$BIN" batch mesh --mv-model mv.packed.safetensors --albedo-refine uv.packed.safetensors --rm-refine uv.packed.safetensors \
            --size 64 --views-size 64 --work-size native --threads 1 --jobs 2 --out mmpk mm > /dev/null 2> log3; rc=$?
        check "batch mesh, pre-packed models, 2 workers: exit 0 (got $rc)" [ $rc -eq 0 ]
        check "batch mesh, pre-packed models: used in place" grep -q "pre-packed: panels used in place" log3
        check "batch mesh, 2 workers: each loads the two models once ($(grep -c 'supermat mesh: loaded' log3) loads)" [ "$(grep -c 'supermat mesh: loaded' log3)" -eq 4 ]
        check "batch mesh, pre-packed models: the same textures" cmp -s mmref_baseColor.png mmpk/asset_2_baseColor.png
    fi
else
    echo "SKIP: batch mesh (no CUBE_GLTF given, or supermat built without tinygltf)"
fi

echo "$PASS passed, $FAIL failed"
[ $FAIL -eq 0 ]
