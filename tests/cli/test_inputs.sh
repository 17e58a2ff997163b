#!/usr/bin/env bash
# tests/cli/test_inputs.sh - pictures as users have them, and bad ones, given to `supermat image`.
#
#   bash tests/cli/test_inputs.sh BUILD/supermat tests/data
#
# A 16-bit PNG (the maps of its 8-bit twin; refused where 8 bits are read, by refine); PNG headers claiming
# more than 16384 pixels a side, refused from the header; --max-memory against the decoded size of 8- and
# 16-bit pictures, from the header; hostile pictures from fuzz/corpus/picture (JPEG
# Huffman tables of more than 256 codes, refused before decoding, in image, sheet and a mesh's texture; a
# BMP of negative width; GIF/HDR/PPM refused by their signature) while the corpus' valid pictures still read;
# an EXIF-rotated JPEG processed upright; a folder; WebP with or without libwebp. Bad input: an image that is
# not a multiple of 8 (alone or among good ones: exit 1 before any work), a missing model, a PNG as the model,
# a missing image, two images with one stem (exit 2).
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

setup_tiny

# ---- inputs as users have them ------------------------------------------------------------------
# max |a - b| over two PFMs of the same size (header skipped, floats as od prints them)
pfm_maxdiff() {
    paste <(od -An -v -f -j "$(head -3 "$1" | wc -c)" "$1" | tr -s ' ' '\n' | grep -v '^$') \
          <(od -An -v -f -j "$(head -3 "$2" | wc -c)" "$2" | tr -s ' ' '\n' | grep -v '^$') |
        awk 'BEGIN { m = 0; n = 0 } { d = $1 - $2; if (d < 0) d = -d; if (d > m) m = d; n++ } END { if (n == 0) print "nan"; else print m }'
}
# a 16-bit PNG (the 8-bit sphere x 257): read at full precision as float input, so the same maps as the 8-bit file
run image --model "$MODEL" --out "$T/in16" "$DATA/img/sphere_64_16bit.png" "$SPHERE"
check "a 16-bit PNG exits 0" [ $RC -eq 0 ]
check "a 16-bit PNG: the maps of its 8-bit twin" cmp -s "$T/in16/sphere_64_16bit_albedo.png" "$T/in16/sphere_64_albedo.png"
run refine --model "$MODEL" --map "$DATA/img/sphere_64_16bit.png" --mask "$DATA/img/uv/uv_mask.png" --position "$DATA/img/uv/uv_position.png" --out "$T/in16r"
check "a 16-bit PNG where 8 bits are read (refine) exits 1" [ $RC -eq 1 ]
check "a 16-bit PNG where 8 bits are read: said so" grep -q "has 16 bits per channel" "$T/err"
# a PNG header claiming 16400 x 16400 pixels (a few hundred bytes; decoding would take 800 MB): refused from the header
printf '\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x40\x10\x00\x00\x40\x10\x08\x02\x00\x00\x00\x02\xd2\x04\xa0\x00\x00\x00\x00IEND\xae\x42\x60\x82' > "$T/huge.png"
run image --model "$MODEL" --out "$T/huge" "$T/huge.png"
check "a picture claiming 16400x16400: exit 1" [ $RC -eq 1 ]
check "a picture claiming 16400x16400: refused from its header" grep -q "16400x16400: at most 16384 pixels a side" "$T/err"
# 20000 x 20000: stb_image refuses the claim with the last decoder's "unknown type" message; the size is said instead
printf '\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x4e\x20\x00\x00\x4e\x20\x08\x02\x00\x00\x00\x02\xd2\x04\xa0\x00\x00\x00\x00IEND\xae\x42\x60\x82' > "$T/huge2.png"
run image --model "$MODEL" --out "$T/huge" "$T/huge2.png"
check "a PNG claiming 20000x20000: exit 1" [ $RC -eq 1 ]
check "a PNG claiming 20000x20000: says its size and the limit" grep -q "20000x20000: at most 16384 pixels a side" "$T/err"
# --max-memory against the decoded picture, from the header: an 8-bit RGBA 4000x4000 is 61 MiB decoded (the check
# counted the 16-bit cost, 6 times that, for every picture), a 16-bit one 366 MiB with its float copy
printf '\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x0f\xa0\x00\x00\x0f\xa0\x08\x06\x00\x00\x00\x02\xd2\x04\xa0\x00\x00\x00\x00IEND\xae\x42\x60\x82' > "$T/big8.png"
printf '\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x0f\xa0\x00\x00\x0f\xa0\x10\x06\x00\x00\x00\x02\xd2\x04\xa0\x00\x00\x00\x00IEND\xae\x42\x60\x82' > "$T/big16.png"
run image --model "$MODEL" --max-memory 100M --out "$T/bigmm" "$T/big8.png"
check "an 8-bit 4000x4000 under --max-memory 100M: not refused for its decoded size (61 MiB)" [ $RC -eq 1 ]
check "an 8-bit 4000x4000 under --max-memory 100M: not refused for its decoded size (61 MiB) (2)" not grep -q "decoded, more than" "$T/err"
run image --model "$MODEL" --max-memory 100M --out "$T/bigmm" "$T/big16.png"
check "a 16-bit 4000x4000 under --max-memory 100M: refused for its decoded size (366 MiB)" [ $RC -eq 1 ]
check "a 16-bit 4000x4000 under --max-memory 100M: refused for its decoded size (366 MiB) (2)" grep -q "needs 366.2 MiB decoded, more than --max-memory 100.0 MiB" "$T/err"
# hostile pictures from fuzz/fuzz_picture.c (fuzz/corpus/picture/regress_*): Debian's stb_image 2.27 writes past a
# Huffman table for a JPEG table of more than 256 codes (also behind leading fill bytes, or cut off by the end of
# the file: stb_image counts zeros there); a BMP's negative width
# came back from the header as it was; formats the CLI does not document are refused by their signature
FZ="$DATA/../../fuzz/corpus/picture"
for f in regress_dht_over_256.jpg regress_dht_after_fill.jpg regress_dht_past_end.jpg; do
    run image --model "$MODEL" --out "$T/hostile" "$FZ/$f"
    check "$f: exit 1" [ $RC -eq 1 ]
    check "$f: refused before decoding" grep -q "is a corrupt JPEG (a Huffman table of more than 256 codes)" "$T/err"
    absent "$T/hostile/${f%.jpg}_albedo.png"
done
run sheet --out "$T/hostile_sheet.png" "$FZ/regress_dht_over_256.jpg"
check "a hostile JPEG in a contact sheet: exit 1" [ $RC -eq 1 ]
check "a hostile JPEG in a contact sheet: refused" grep -q "is a corrupt JPEG" "$T/err"
absent "$T/hostile_sheet.png"
run image --model "$MODEL" --out "$T/hostile" "$FZ/regress_bmp_negative_width.bmp"
check "a BMP of negative width: exit 1" [ $RC -eq 1 ]
check "a BMP of negative width: said so" grep -q "claims a size of -2147483632x8 pixels: a corrupt picture" "$T/err"
for f in a.gif a.hdr a.ppm; do
    run image --model "$MODEL" --out "$T/hostile" "$FZ/$f"
    check "$f: exit 1" [ $RC -eq 1 ]
    check "$f: refused by its signature" grep -q "which supermat does not read (PNG, JPEG, BMP, TGA or WebP)" "$T/err"
done
if "$BIN" --version | grep -q "built with:.* mesh"; then   # the same JPEG as a glTF's base colour texture
    run mesh --passthrough --force "$DATA/../../fuzz/corpus/gltf/regress_dht_texture.gltf" "$T/hostile_mesh.gltf"
    check "a hostile JPEG texture: the bake goes on (exit 0)" [ $RC -eq 0 ]
    check "a hostile JPEG texture: refused before decoding, its factor used" grep -q "material 0 is a corrupt JPEG (a Huffman table of more than 256 codes)" "$T/err"
fi
run image --model "$MODEL" --out "$T/hostile_ok" --outputs albedo "$FZ/base.jpg" "$FZ/prog.jpg" "$FZ/exif6.jpg" "$FZ/rgb.bmp" "$FZ/rle.tga" "$FZ/pal.png"
check "the corpus' valid JPEG / BMP / TGA / PNG pictures still read: exit 0" [ $RC -eq 0 ]
check_png "$T/hostile_ok/exif6_albedo.png" 8 16 2
# a JPEG with EXIF orientation 6 (stored 48 wide, 72 high, shown 72 x 48): processed upright, as a viewer
# shows it; its maps are those of the upright picture (ring_exif6_upright.png, decoded by another JPEG
# decoder: measured 0.038 apart; turned 180 degrees or mirrored they are 0.87 / 1.0 apart)
run image --model "$MODEL" --out "$T/exif" --float "$DATA/img/ring_exif6.jpg" "$DATA/img/ring_exif6_upright.png"
check "an EXIF-rotated JPEG exits 0" [ $RC -eq 0 ]
check_png "$T/exif/ring_exif6_albedo.png" 72 48 2
d=$(pfm_maxdiff "$T/exif/ring_exif6_albedo.pfm" "$T/exif/ring_exif6_upright_albedo.pfm")
check "an EXIF-rotated JPEG: the upright picture's maps (max diff $d <= 0.1)" awk -v x="$d" 'BEGIN { exit !(x ~ /^[0-9.eE+-]+$/ && x + 0 <= 0.1) }'
# a folder, a WebP file: named as such
mkdir -p "$T/a_folder"
run image --model "$MODEL" --out "$T/in_dir" "$T/a_folder"
check "a folder as a picture exits 1" [ $RC -eq 1 ]
check "a folder as a picture: said so" grep -q "a_folder' is a folder: give the picture files" "$T/err"
# WebP (the official examples' format): a lossless WebP of the sphere gives the PNG's maps when the build
# has libwebp (`supermat --version` says "built with: webp"), else it is refused saying what to do
printf 'RIFF\032\000\000\000WEBPVP8 \016\000\000\000' >"$T/pic.webp"
run image --model "$MODEL" --out "$T/in_webp" "$T/pic.webp"
check "a broken WebP picture exits 1" [ $RC -eq 1 ]
cp "$T/err" "$T/err_webp"
run --version
if grep -q '^built with:.* webp' "$T/out"; then
    check "a broken WebP picture: said so" grep -q "pic.webp': not a valid WebP file" "$T/err_webp"
    run image --model "$MODEL" --out "$T/in_webp" "$DATA/img/sphere_64.webp"
    check "a WebP picture exits 0" [ $RC -eq 0 ]
    run image --model "$MODEL" --out "$T/in_webp_png" "$SPHERE"
    check "a lossless WebP picture: the maps of its PNG" cmp -s "$T/in_webp/sphere_64_albedo.png" "$T/in_webp_png/sphere_64_albedo.png"
    check "a lossless WebP picture: the maps of its PNG (roughness)" cmp -s "$T/in_webp/sphere_64_roughness.png" "$T/in_webp_png/sphere_64_roughness.png"
else
    check "a WebP picture without libwebp: said so, with what to do" grep -q "pic.webp' is WebP, which this build does not read" "$T/err_webp"
fi

# ---- bad input --------------------------------------------------------------------------------
# a valid 30x30 8-bit gray PNG (zlib stream and CRCs included)
BAD=$T/bad_30x30.png
printf '\211\120\116\107\015\012\032\012\000\000\000\015\111\110\104\122\000\000\000\036\000\000\000\036\010\000\000\000\000\036\133\361\176\000\000\000\025\111\104\101\124\170\332\143\150\300\013\030\106\245\107\245\107\245\007\122\032\000\225\201\302\020\354\122\050\077\000\000\000\000\111\105\116\104\256\102\140\202' >"$BAD"
check_png "$BAD" 30 30 0
O6=$T/out6
run image --model "$MODEL" --out "$O6" "$BAD"
check "30x30 image exits 1" [ $RC -eq 1 ]
check "30x30 image: the message gives the size" grep -q '30x30' "$T/err"
check "30x30 image: the message says multiples of 8" grep -q 'multiples of 8' "$T/err"
absent "$O6/bad_30x30_albedo.png"
run image --model "$MODEL" --out "$O6" "$SPHERE" "$BAD"
check "a bad image among good ones exits 1 before any work" [ $RC -eq 1 ]
absent "$O6/sphere_64_albedo.png"

run image --model "$T/no_such_model.safetensors" --out "$T/out7" "$SPHERE"
check "missing model exits 1" [ $RC -eq 1 ]
check "missing model: the message names it" grep -q 'no_such_model.safetensors' "$T/err"

run image --model "$SPHERE" --out "$T/out8" "$SPHERE"
check "a PNG as the model exits 1" [ $RC -eq 1 ]
check "a PNG as the model: the library's message" grep -q 'malformed model file' "$T/err"

run image --model "$MODEL" --out "$T/out9" "$T/no_such_image.png"
check "missing image exits 1" [ $RC -eq 1 ]
check "missing image: the message names it" grep -q 'no_such_image.png' "$T/err"

run image --model "$MODEL" --out "$T/out10" "$SPHERE" "$T/sphere_64.png"
check "two images with one stem exit 2" [ $RC -eq 2 ]

summary
