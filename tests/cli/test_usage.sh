#!/usr/bin/env bash
# tests/cli/test_usage.sh - the command line of the `supermat` tool: help, version, usage errors, and the overwrite policy.
#
#   bash tests/cli/test_usage.sh BUILD/supermat tests/data
#
# `--version`, `--help` and every command's `--help` (image's states the preprocessing, multiples of 8 and
# the default model's search order); usage errors exit 2 (no command, an unknown command or option, which is
# named, image without --out, views without --model, bad --outputs, an option without its value, bench --size
# 30, convert --dtype f8). The overwrite policy (every command): existing outputs (files, live and dangling
# symbolic links) refused before any work with exit 1 and a message naming the file and the options,
# --skip-existing keeps them (and runs a picture with a map missing), --force replaces them (a link is
# replaced, its target untouched), both together exit 2; `sheet` and `convert` likewise.
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# ---- help, version, usage errors ----------------------------------------------------------------
run --version
check "--version exits 0" [ $RC -eq 0 ]
check "--version prints the version" grep -Eq '^supermat [0-9]+\.[0-9]+\.[0-9]+$' "$T/out"
run --help
check "--help exits 0" [ $RC -eq 0 ]
check "--help lists the commands" grep -q 'convert' "$T/out"
for c in convert image views refine info bench sheet; do
    run "$c" --help
    check "$c --help exits 0" [ $RC -eq 0 ]
    check "$c --help prints usage" grep -q "usage: supermat $c" "$T/out"
done
run image --help
check "image --help states the preprocessing (work size, --native)" grep -q 'resized to the model.s work size' "$T/out"
check "image --help says multiples of 8" grep -q 'multiples of 8' "$T/out"
check "image --help: the default model's search order" grep -q 'SUPERMAT_MODEL' "$T/out"
check "image --help: the installed default model" grep -q 'share/supermat/supermat_default.safetensors' "$T/out"
check "image --help: the source tree's default model" grep -q 'models/supermat_default.safetensors' "$T/out"
run
check "no command exits 2" [ $RC -eq 2 ]
run frobnicate
check "unknown command exits 2" [ $RC -eq 2 ]
run image --model x --out "$T/o" --no-such-option "$SPHERE"
check "unknown option exits 2" [ $RC -eq 2 ]
check "unknown option is named" grep -q 'no-such-option' "$T/err"
run image --model x "$SPHERE"
check "image without --out exits 2" [ $RC -eq 2 ]
run views --cameras x --out "$T/o" "$SPHERE"
check "views without --model exits 2 (no default model for views)" [ $RC -eq 2 ]
run image --model x --out "$T/o" --outputs albedo,shininess "$SPHERE"
check "bad --outputs exits 2" [ $RC -eq 2 ]
run image --model x --out "$T/o" --threads
check "option without value exits 2" [ $RC -eq 2 ]
run bench --model x --size 30
check "bench --size 30 exits 2" [ $RC -eq 2 ]
run convert --unet x.pth --base x --out y --dtype f8
check "convert bad --dtype exits 2" [ $RC -eq 2 ]

# the tiny model (tests/cli/lib.sh) for the overwrite policy
setup_tiny

# ---- the overwrite policy (every command): refuse / --force / --skip-existing -------------------
OW=$T/overwrite
run image --model "$MODEL" --out "$OW" "$SPHERE"
check "image into a new folder exits 0" [ $RC -eq 0 ]
printf 'mine\n' >"$OW/sphere_64_roughness.png"
cp "$OW/sphere_64_albedo.png" "$T/ow_albedo_before.png"
run image --model "$MODEL" --out "$OW" "$SPHERE"
check "image over existing maps exits 1" [ $RC -eq 1 ]
check "image over existing maps: the message names the file and the options" grep -q "sphere_64_albedo.png' exists and was not written by this run: --force replaces it, --skip-existing keeps it" "$T/err"
check "image over existing maps: a user's file is untouched" grep -q mine "$OW/sphere_64_roughness.png"
check "image over existing maps: the maps are untouched" cmp -s "$OW/sphere_64_albedo.png" "$T/ow_albedo_before.png"
absent "$OW/sphere_64_albedo.png.tmp"
run image --model "$MODEL" --out "$OW" --skip-existing "$SPHERE"
check "--skip-existing exits 0" [ $RC -eq 0 ]
check "--skip-existing: the picture is not run" grep -q "kept the maps of '.*sphere_64.png'" "$T/err"
check "--skip-existing: a user's file is kept" grep -q mine "$OW/sphere_64_roughness.png"
rm "$OW/sphere_64_metallic.png"
run image --model "$MODEL" --out "$OW" --skip-existing "$SPHERE"
check "--skip-existing with one map missing exits 0" [ $RC -eq 0 ]
check_png "$OW/sphere_64_metallic.png" 64 64 4
check "--skip-existing with one map missing: the others are kept" grep -q mine "$OW/sphere_64_roughness.png"
run image --model "$MODEL" --out "$OW" "$SPHERE" --force
check "--force exits 0" [ $RC -eq 0 ]
check_png "$OW/sphere_64_roughness.png" 64 64 4
run image --model "$MODEL" --out "$OW" --force --skip-existing "$SPHERE"
check "--force with --skip-existing exits 2" [ $RC -eq 2 ]
# symbolic links, live or dangling: refused; --force replaces the link itself, never its target
printf 'target\n' >"$T/ow_target"
rm "$OW/sphere_64_albedo.png"
ln -s "$T/ow_target" "$OW/sphere_64_albedo.png"
run image --model "$MODEL" --out "$OW" "$SPHERE"
check "a symbolic link among the outputs exits 1" [ $RC -eq 1 ]
check "a symbolic link among the outputs: said so" grep -q "sphere_64_albedo.png' exists (a symbolic link)" "$T/err"
check "a symbolic link among the outputs: its target is untouched" grep -qx target "$T/ow_target"
run image --model "$MODEL" --out "$OW" --force "$SPHERE"
check "--force over a symbolic link exits 0" [ $RC -eq 0 ]
check "--force over a symbolic link: the link is now the file" [ ! -L "$OW/sphere_64_albedo.png" ]
check_png "$OW/sphere_64_albedo.png" 64 64 6
check "--force over a symbolic link: its target is untouched" grep -qx target "$T/ow_target"
ln -s "$T/ow_nowhere.png" "$T/ow_dangling.png"
run sheet --out "$T/ow_dangling.png" "$SPHERE"
check "sheet over a dangling symbolic link exits 1" [ $RC -eq 1 ]
absent "$T/ow_nowhere.png"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$MODEL"
check "convert over an existing model exits 1" [ $RC -eq 1 ]
check "convert over an existing model: the message names it" grep -q "tiny.safetensors' exists" "$T/err"
run convert --kind supermat --unet "$DATA/tiny/supermat.pth" --base "$DATA/tiny/base" --out "$MODEL" --skip-existing
check "convert --skip-existing over an existing model exits 0" [ $RC -eq 0 ]

summary
