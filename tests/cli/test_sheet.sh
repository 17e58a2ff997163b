#!/usr/bin/env bash
# tests/cli/test_sheet.sh - `supermat sheet`: a contact sheet of pictures.
#
#   bash tests/cli/test_sheet.sh BUILD/supermat tests/data
#
# The PNG size of a 2-row sheet with labels and of one without; FILE:r / :g (one channel as gray); its
# errors (a missing input or a file that is not a picture: exit 1, nothing written, an older sheet untouched;
# no such channel; bad rows, --cell and --labels, no --out: exit 2; a missing folder: exit 1); a PNG write
# that fails (a file size limit) exits 1 and leaves no file.
set -eu
# shellcheck source=tests/cli/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# ---- sheet: a contact sheet ---------------------------------------------------------------------
# 2 rows x 3 columns of 64-pixel cells with labels: 4 + 3 * (64 + 4) = 208 wide,
# 4 + (8 + 4) + 2 * (64 + 4) = 152 high (RGBA, RGB and gray inputs, non-square, an empty cell)
SH=$T/sheets/sheet.png
mkdir -p "$T/sheets"
run sheet --out "$SH" --cell 64 --labels "input,ring (72x48),box_40" "$SPHERE,$RING,$DATA/img/box_40.png" "$DATA/img/uv/uv_bc.png,-,$DATA/img/uv/uv_mask.png"
check "sheet exits 0" [ $RC -eq 0 ]
[ $RC -eq 0 ] || cat "$T/err"
check_png "$SH" 208 152 2
absent "$SH.tmp"
run sheet --out "$T/sheets/plain.png" "$SPHERE,$RING" "$DATA/img/box_40.png"
check "sheet without labels, default cell exits 0" [ $RC -eq 0 ]
check_png "$T/sheets/plain.png" 268 268 2
cp "$SH" "$T/sheets/before.png"
run sheet --force --out "$SH" "$SPHERE,$T/no_such_picture.png"
check "sheet with a missing input exits 1" [ $RC -eq 1 ]
check "sheet with a missing input: the message names it" grep -q 'no_such_picture.png' "$T/err"
check "sheet with a missing input: the old sheet is untouched" cmp -s "$SH" "$T/sheets/before.png"
absent "$SH.tmp"
printf 'not a picture\n' >"$T/sheets/text.png"
run sheet --out "$T/sheets/never.png" "$SPHERE,$T/sheets/text.png"
check "sheet with a file that is not an image exits 1" [ $RC -eq 1 ]
absent "$T/sheets/never.png"
absent "$T/sheets/never.png.tmp"
# FILE:r/:g/:b/:a: one channel as gray: a gray image's :r is the image; a colour image's :g is not
run sheet --out "$T/sheets/m.png" --cell 32 "$DATA/img/uv/uv_mask.png"
run sheet --out "$T/sheets/m_r.png" --cell 32 "$DATA/img/uv/uv_mask.png:r"
check "sheet FILE:r of a gray image = the image" cmp -s "$T/sheets/m.png" "$T/sheets/m_r.png"
run sheet --out "$T/sheets/c.png" --cell 32 "$DATA/img/uv/uv_bc.png"
run sheet --out "$T/sheets/c_g.png" --cell 32 "$DATA/img/uv/uv_bc.png:g"
check "sheet FILE:g of a colour image: exit 0" [ $RC -eq 0 ]
check "sheet FILE:g of a colour image: another sheet than the image's" [ "$(cmp -s "$T/sheets/c.png" "$T/sheets/c_g.png"; echo $?)" = 1 ]
run sheet --out "$T/sheets/never.png" "$DATA/img/uv/uv_bc.png:x"
check "sheet FILE:x (no such channel, no such file) exits 1" [ $RC -eq 1 ]
run sheet --out "$T/sheets/never.png"
check "sheet without rows exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" --cell 7 "$SPHERE"
check "sheet --cell 7 exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" --cell x "$SPHERE"
check "sheet --cell x exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" "$SPHERE,,$RING"
check "sheet with an empty entry exits 2" [ $RC -eq 2 ]
run sheet --out "$T/sheets/never.png" --labels a,b,c "$SPHERE,$RING"
check "sheet with more labels than columns exits 2" [ $RC -eq 2 ]
run sheet "$SPHERE"
check "sheet without --out exits 2" [ $RC -eq 2 ]
absent "$T/sheets/never.png"
run sheet --out "$T/no_such_dir/sheet.png" "$SPHERE"
check "sheet into a missing folder exits 1" [ $RC -eq 1 ]

# a write that fails (a 4 KiB file size limit with SIGXFSZ ignored: write() fails with EFBIG): exit 1,
# a message, and no file left, neither the PNG nor its .tmp (the sheet is ~95 KB)
run_limited sheet --out "$T/sheets/limited.png" --cell 256 "$SPHERE,$RING"
check "sheet whose write fails exits 1" [ $RC -eq 1 ]
check "sheet whose write fails: the message names the file" grep -q "cannot write '.*limited.png'" "$T/err"
absent "$T/sheets/limited.png"
absent "$T/sheets/limited.png.tmp"

summary
