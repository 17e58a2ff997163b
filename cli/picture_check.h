/* cli/picture_check.h - what the CLI checks in a picture's bytes before stb_image decodes them.
 * Part of the `supermat` CLI: included by cli/platform.c (C) and cli/mesh.cpp (C++).
 *
 * Debian 12's stb_image (v2.27) decodes more formats than the CLI documents and has known memory errors on
 * hostile input; fuzz/fuzz_picture.c found the first in seconds (a JPEG Huffman table of more than 256
 * codes writes past stbi__huffman.size[257]; upstream's v2.28 refuses it). So:
 *   - only PNG, JPEG, BMP and TGA reach stb_image (WebP goes to libwebp): GIF, PSD, PIC, PNM and Radiance
 *     HDR are refused by their signature here, and the CLI's own stb_image is built with STBI_ONLY_*;
 *   - a JPEG's marker segments are walked as stb_image may read them (below) and the file refused where a
 *     Huffman table (DHT) holds more than 256 codes.
 * supermat_cli_picture_check returns NULL when the bytes may go to stb_image, else the reason (a static
 * string) to put after the file's name. */
#ifndef SUPERMAT_CLI_PICTURE_CHECK_H
#define SUPERMAT_CLI_PICTURE_CHECK_H
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* Every chain of marker segments stb_image may follow is walked: from the start-of-image marker, and, after
   each start of scan (SOS), from every 0xFF up to the marker that ends its entropy-coded data, since
   stb_image stops decoding a scan where its MCUs end and resumes at the next 0xFF, whatever byte follows
   (in a valid file only 0x00 and restart markers do, and such a chain fails at once). Each file position
   starts a step at most once and is put on the stack at most once (a bit per byte each), and a scan of
   entropy-coded data stops where an earlier one went on from, so the walk is linear in the file's size. */
static const char *supermat_cli_jpeg_walk(const unsigned char *d, size_t n, size_t start, unsigned char *seen,
                                          unsigned char *pushed) {
    size_t top = 0, cap = 64, pos;
    size_t *stack = (size_t *)malloc(cap * sizeof *stack);
    const char *why = NULL;
    if (!stack) return "could not be checked (out of memory)";
    stack[top++] = start;                                   /* after the start-of-image marker */
    while (top) {
        pos = stack[--top];
        while (pos < n) {
            unsigned m;
            size_t len;
            if (seen[pos >> 3] & (1u << (pos & 7))) break;  /* walked from here already */
            seen[pos >> 3] |= (unsigned char)(1u << (pos & 7));
            if (d[pos] != 0xFF) { pos++; continue; }        /* stray bytes: stb_image skips them in the header */
            while (pos < n && d[pos] == 0xFF) pos++;        /* fill bytes */
            if (pos >= n) break;
            m = d[pos++];
            if (m == 0xD9) break;                            /* end of image */
            if (m == 0x00 || m == 0x01 || (m >= 0xD0 && m <= 0xD7)) continue; /* no length (stb_image fails at these) */
            if (pos + 2 > n) break;                          /* cut short: stb_image says so itself */
            len = ((size_t)d[pos] << 8) | d[pos + 1];
            if (len < 2) break;                              /* stb_image refuses it */
            if (m == 0xC4) {                                 /* DHT: its tables, as stb_image reads them */
                size_t q = pos + 2, left = len - 2;
                while (left > 0) {
                    size_t i, codes = 0;
                    if (q >= n) break;                       /* past the end stb_image reads zeros: empty tables */
                    if ((d[q] >> 4) > 1 || (d[q] & 15) > 3) break; /* stb_image refuses the table */
                    for (i = 0; i < 16 && q + 1 + i < n; i++) codes += d[q + 1 + i]; /* (zeros past the end) */
                    if (codes > 256) { why = "is a corrupt JPEG (a Huffman table of more than 256 codes)"; goto done; }
                    if (17 + codes > left) break;            /* stb_image ends the segment in error */
                    left -= 17 + codes;
                    q += 17 + codes;
                }
            }
            if (len > n - pos) break;                        /* runs past the end */
            pos += len;
            if (m == 0xDA) {                                 /* entropy-coded data: every 0xFF may resume a chain */
                size_t q;
                for (q = pos; q < n; q++) {
                    if (d[q] != 0xFF) continue;
                    if (pushed[q >> 3] & (1u << (q & 7))) break; /* scanned from here on already */
                    pushed[q >> 3] |= (unsigned char)(1u << (q & 7));
                    if (top == cap) {                        /* (at most once a position: at most n + 1) */
                        size_t *grown = (size_t *)realloc(stack, 2 * cap * sizeof *stack);
                        if (!grown) { why = "could not be checked (out of memory)"; goto done; }
                        stack = grown;
                        cap *= 2;
                    }
                    stack[top++] = q;
                    if (q + 1 < n && d[q + 1] != 0x00 && d[q + 1] != 0xFF && !(d[q + 1] >= 0xD0 && d[q + 1] <= 0xD7)) break;
                }
                break;
            }
        }
    }
done:
    free(stack);
    return why;
}

static const char *supermat_cli_jpeg_check(const unsigned char *d, size_t n, size_t start) {
    unsigned char *seen = (unsigned char *)calloc(2 * (n / 8 + 1), 1);   /* n / 4 bytes */
    const char *why = seen ? supermat_cli_jpeg_walk(d, n, start, seen, seen + n / 8 + 1) : "could not be checked (out of memory)";
    free(seen);
    return why;
}

static const char *supermat_cli_picture_check(const unsigned char *d, size_t n) {
    if (n >= 4 && !memcmp(d, "GIF8", 4)) return "is a GIF picture, which supermat does not read (PNG, JPEG, BMP, TGA or WebP)";
    if (n >= 4 && !memcmp(d, "8BPS", 4)) return "is a Photoshop file, which supermat does not read (PNG, JPEG, BMP, TGA or WebP)";
    if (n >= 4 && d[0] == 0x53 && d[1] == 0x80 && d[2] == 0xF6 && d[3] == 0x34) return "is a Softimage PIC picture, which supermat does not read (PNG, JPEG, BMP, TGA or WebP)";
    if (n >= 2 && d[0] == '#' && d[1] == '?') return "is a Radiance HDR picture, which supermat does not read (PNG, JPEG, BMP, TGA or WebP)";
    if (n >= 2 && d[0] == 'P' && (d[1] == '5' || d[1] == '6')) return "is a PNM picture, which supermat does not read (PNG, JPEG, BMP, TGA or WebP)";
    if (n >= 2 && d[0] == 0xFF) {                       /* a JPEG as stb_image finds one: 0xFF (fill 0xFF ...) 0xD8 */
        size_t i = 1;
        while (i < n && d[i] == 0xFF) i++;
        if (i < n && d[i] == 0xD8) return supermat_cli_jpeg_check(d, n, i + 1);
    }
    return NULL;
}
#endif
