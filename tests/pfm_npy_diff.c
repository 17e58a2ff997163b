/* pfm_npy_diff.c - compares PFM images with a float32 NCHW .npy reference (used by tests/cli/test_views.sh and test_refine.sh)
 *
 *     pfm_npy_diff [--channel C] TOL REF.npy IMAGE0.pfm [IMAGE1.pfm ...]
 *
 * REF.npy: little-endian float32 ('<f4'), C order, shape [N, C, H, W] (or [C, H, W] = one image);
 * npy format 1.0 (2-byte header length) or 2.0/3.0 (4-byte), the header length read from the file.
 * The k-th PFM is compared with image k: "PF" (RGB) against all C = 3 channels, "Pf" (gray) against
 * channel --channel C (default 0). PFM rows run bottom to top; a negative scale means little endian.
 * Prints the largest absolute difference and where it is; exit 0 if it is <= TOL (NaN never is),
 * 1 if not, 2 on a usage or file error. Standalone C99: cc -std=c99 pfm_npy_diff.c -o pfm_npy_diff
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static unsigned char *read_all(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    unsigned char *buf = NULL;
    size_t cap = 0, n = 0, r;
    if (!f) { fprintf(stderr, "pfm_npy_diff: cannot open '%s'\n", path); return NULL; }
    for (;;) {
        if (n == cap) {
            unsigned char *nb;
            cap = cap ? cap * 2 : 65536;
            nb = (unsigned char *)realloc(buf, cap);
            if (!nb) { free(buf); fclose(f); fprintf(stderr, "pfm_npy_diff: out of memory\n"); return NULL; }
            buf = nb;
        }
        r = fread(buf + n, 1, cap - n, f);
        if (r == 0) break;
        n += r;
    }
    if (ferror(f)) { free(buf); fclose(f); fprintf(stderr, "pfm_npy_diff: cannot read '%s'\n", path); return NULL; }
    fclose(f);
    *size = n;
    return buf;
}

static float f32_le(const unsigned char *p) {
    uint32_t u = (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
    float v;
    memcpy(&v, &u, 4);
    return v;
}
static float f32_be(const unsigned char *p) {
    unsigned char q[4];
    q[0] = p[3]; q[1] = p[2]; q[2] = p[1]; q[3] = p[0];
    return f32_le(q);
}

typedef struct npy { unsigned char *buf; const unsigned char *data; long n, c, h, w; } npy;

static int load_npy(const char *path, npy *a) {
    size_t size = 0, hl, off;
    char *hdr;
    const char *s;
    long dims[4];
    int nd = 0;
    memset(a, 0, sizeof *a);
    a->buf = read_all(path, &size);
    if (!a->buf) return -1;
    if (size < 10 || memcmp(a->buf, "\x93NUMPY", 6) != 0) { fprintf(stderr, "pfm_npy_diff: '%s' is not a .npy file\n", path); return -1; }
    if (a->buf[6] == 1) { hl = (size_t)a->buf[8] | ((size_t)a->buf[9] << 8); off = 10; }
    else if ((a->buf[6] == 2 || a->buf[6] == 3) && size >= 12) {
        hl = (size_t)a->buf[8] | ((size_t)a->buf[9] << 8) | ((size_t)a->buf[10] << 16) | ((size_t)a->buf[11] << 24);
        off = 12;
    } else { fprintf(stderr, "pfm_npy_diff: '%s': unknown .npy version %d\n", path, a->buf[6]); return -1; }
    if (hl > size - off) { fprintf(stderr, "pfm_npy_diff: '%s': header length %lu past the end\n", path, (unsigned long)hl); return -1; }
    hdr = (char *)malloc(hl + 1);
    if (!hdr) return -1;
    memcpy(hdr, a->buf + off, hl);
    hdr[hl] = 0;
    if (!strstr(hdr, "'descr': '<f4'") || !strstr(hdr, "'fortran_order': False") || !(s = strstr(hdr, "'shape': ("))) {
        fprintf(stderr, "pfm_npy_diff: '%s': not a C-order little-endian float32 array: %s\n", path, hdr);
        free(hdr);
        return -1;
    }
    s += strlen("'shape': (");
    while (nd < 4 && *s && *s != ')') {
        char *end;
        long v = strtol(s, &end, 10);
        if (end == s || v <= 0) break;
        dims[nd++] = v;
        s = end;
        while (*s == ',' || *s == ' ') s++;
    }
    if (*s != ')' || (nd != 3 && nd != 4)) {
        fprintf(stderr, "pfm_npy_diff: '%s': shape is not [N, C, H, W] or [C, H, W]: %s\n", path, hdr);
        free(hdr);
        return -1;
    }
    free(hdr);
    if (nd == 3) { a->n = 1; a->c = dims[0]; a->h = dims[1]; a->w = dims[2]; }
    else { a->n = dims[0]; a->c = dims[1]; a->h = dims[2]; a->w = dims[3]; }
    if ((size - off - hl) / 4 != (size_t)(a->n * a->c * a->h * a->w) || (size - off - hl) % 4) {
        fprintf(stderr, "pfm_npy_diff: '%s': %lu data bytes for shape [%ld, %ld, %ld, %ld]\n", path,
                (unsigned long)(size - off - hl), a->n, a->c, a->h, a->w);
        return -1;
    }
    a->data = a->buf + off + hl;
    return 0;
}

int main(int argc, char **argv) {
    npy a;
    int arg = 1, channel = 0, k, nimg, worst_k = -1, worst_c = 0;
    long worst_x = 0, worst_y = 0;
    double tol, maxd = 0.0, sum = 0.0, count = 0.0, worst_p = 0.0, worst_r = 0.0;
    char *end;
    if (argc > 2 && !strcmp(argv[1], "--channel")) { channel = atoi(argv[2]); arg = 3; }
    if (argc - arg < 3) {
        fprintf(stderr, "usage: pfm_npy_diff [--channel C] TOL REF.npy IMAGE0.pfm [IMAGE1.pfm ...]\n");
        return 2;
    }
    tol = strtod(argv[arg], &end);
    if (*end || !(tol >= 0.0)) { fprintf(stderr, "pfm_npy_diff: bad tolerance '%s'\n", argv[arg]); return 2; }
    if (load_npy(argv[arg + 1], &a)) { free(a.buf); return 2; }
    nimg = argc - arg - 2;
    if (nimg != a.n) {
        fprintf(stderr, "pfm_npy_diff: %d PFM files for %ld reference images\n", nimg, a.n);
        free(a.buf);
        return 2;
    }
    for (k = 0; k < nimg; k++) {
        const char *path = argv[arg + 2 + k];
        size_t size = 0;
        unsigned char *p = read_all(path, &size);
        char magic[3] = {0, 0, 0};
        long w = 0, h = 0, x, y;
        int ch, c, pos = 0, le;
        double scale = 0.0;
        if (!p) { free(a.buf); return 2; }
        { /* the header, parsed from a NUL-terminated copy */
            char head[128];
            size_t hn = size < sizeof head - 1 ? size : sizeof head - 1;
            memcpy(head, p, hn);
            head[hn] = 0;
            if (sscanf(head, "%2s %ld %ld %lf%n", magic, &w, &h, &scale, &pos) != 4 || pos <= 0 || (size_t)pos >= hn ||
                (strcmp(magic, "PF") && strcmp(magic, "Pf")) || w <= 0 || h <= 0 || scale == 0.0) {
                fprintf(stderr, "pfm_npy_diff: '%s' is not a PFM file\n", path);
                free(p); free(a.buf);
                return 2;
            }
        }
        pos++; /* the single whitespace after the scale */
        ch = magic[1] == 'F' ? 3 : 1;
        le = scale < 0.0;
        if (w != a.w || h != a.h || (ch == 3 && a.c != 3) || (ch == 1 && (channel < 0 || channel >= a.c))) {
            fprintf(stderr, "pfm_npy_diff: '%s' is %ldx%ld with %d channel%s; the reference is [%ld, %ld, %ld, %ld]%s\n", path, w, h,
                    ch, ch == 1 ? "" : "s", a.n, a.c, a.h, a.w, ch == 1 ? " (or --channel is out of range)" : "");
            free(p); free(a.buf);
            return 2;
        }
        if (size - (size_t)pos != (size_t)(w * h * ch) * 4) {
            fprintf(stderr, "pfm_npy_diff: '%s': %lu data bytes, expected %ld\n", path, (unsigned long)(size - (size_t)pos), w * h * ch * 4);
            free(p); free(a.buf);
            return 2;
        }
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++)
                for (c = 0; c < ch; c++) {
                    const unsigned char *q = p + pos + (((h - 1 - y) * w + x) * ch + c) * 4;
                    int rc = ch == 3 ? c : channel;
                    double pv = le ? f32_le(q) : f32_be(q);
                    double rv = f32_le(a.data + ((((long)k * a.c + rc) * h + y) * w + x) * 4);
                    double d = fabs(pv - rv);
                    if (d != d) d = HUGE_VAL; /* NaN */
                    sum += d;
                    count += 1.0;
                    if (d > maxd || worst_k < 0) { maxd = d; worst_k = k; worst_c = rc; worst_x = x; worst_y = y; worst_p = pv; worst_r = rv; }
                }
        free(p);
    }
    printf("max abs diff %.3g (image %d, channel %d, x %ld, y %ld: %.9g vs reference %.9g), mean %.3g over %.0f values; tolerance %.3g\n",
           maxd, worst_k, worst_c, worst_x, worst_y, worst_p, worst_r, count > 0 ? sum / count : 0.0, count, tol);
    free(a.buf);
    return maxd <= tol ? 0 : 1;
}
