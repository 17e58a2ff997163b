/* Small helpers shared by the tests: file loading, .npy reading, relative L2, pass/fail counting. */
#ifndef SUPERMAT_TEST_UTIL_H
#define SUPERMAT_TEST_UTIL_H
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int tu_pass, tu_fail;

/* an allocator (supermat_allocator's alloc / free with a tu_counting as user) that counts the calls and the
   live blocks and fails the call numbered fail_at (from 0; -1 = never) */
typedef struct tu_counting { long calls, fail_at, live; size_t bytes; } tu_counting;
static inline void *tu_count_alloc(void *user, size_t size, size_t align) {
    tu_counting *c = (tu_counting *)user;
    unsigned char *raw, *p;
    if (c->fail_at >= 0 && c->calls++ == c->fail_at) return NULL;
    if (align < sizeof(void *)) align = sizeof(void *);
    raw = (unsigned char *)malloc(size + align + sizeof(void *)); /* aligned by hand (C99 has no aligned malloc) */
    if (!raw) return NULL;
    p = raw + sizeof(void *);
    p += (align - (size_t)((uintptr_t)p % align)) % align;
    memcpy(p - sizeof(void *), &raw, sizeof raw);
    c->live++; c->bytes += size;
    return p;
}
static inline void tu_count_free(void *user, void *p, size_t size) {
    tu_counting *c = (tu_counting *)user;
    void *raw;
    if (!p) return;
    memcpy(&raw, (unsigned char *)p - sizeof(void *), sizeof raw);
    c->live--; c->bytes -= size;
    free(raw);
}
/* a growing memory file for supermat_write_fn (supermat_model_write_packed); fail_at >= 0 makes that write
   call fail (from 0; -1 = never: set it, a zeroed tu_membuf fails its first write) */
typedef struct tu_membuf { unsigned char *p; size_t n, cap; long calls, fail_at; } tu_membuf;
static inline int tu_mem_write(void *user, const void *data, size_t size) {
    tu_membuf *b = (tu_membuf *)user;
    if (b->fail_at >= 0 && b->calls++ == b->fail_at) return -1;
    if (b->n + size > b->cap) {
        size_t nc = b->cap ? b->cap : (size_t)1 << 16;
        unsigned char *np;
        while (nc < b->n + size) nc *= 2;
        np = (unsigned char *)realloc(b->p, nc);
        if (!np) return -1;
        b->p = np; b->cap = nc;
    }
    memcpy(b->p + b->n, data, size);
    b->n += size;
    return 0;
}

#define TU_CHECK(cond, ...) do { if (cond) tu_pass++; else { tu_fail++; printf("FAIL %s:%d: ", __FILE__, __LINE__); printf(__VA_ARGS__); printf("\n"); } } while (0)

static inline int tu_finish(const char *name) {
    printf("%s: %d passed, %d failed\n", name, tu_pass, tu_fail);
    return tu_fail ? 1 : 0;
}

static inline unsigned char *tu_load(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    unsigned char *buf;
    long n;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = (unsigned char *)malloc(n > 0 ? (size_t)n : 1);
    if (buf && n > 0 && fread(buf, 1, (size_t)n, f) != (size_t)n) { free(buf); buf = NULL; }
    fclose(f);
    if (buf) *size = (size_t)n;
    return buf;
}

/* A little-endian float32 or uint8 C-order .npy: returns floats, fills shape. */
typedef struct tu_npy { float *data; int ndim; long shape[8]; size_t n; } tu_npy;
static inline int tu_npy_load(const char *path, tu_npy *out) {
    size_t size = 0, i, hl, off;
    unsigned char *b = tu_load(path, &size);
    const char *h, *p;
    int f32, u8;
    memset(out, 0, sizeof *out);
    if (!b) return -1;
    if (size < 12 || memcmp(b, "\x93NUMPY", 6)) { free(b); return -1; }
    if (b[6] == 1) { hl = b[8] | (b[9] << 8); off = 10; } else { hl = b[8] | (b[9] << 8) | ((size_t)b[10] << 16) | ((size_t)b[11] << 24); off = 12; }
    h = (const char *)b + off;
    f32 = strstr(h, "'<f4'") != NULL;
    u8 = strstr(h, "'|u1'") != NULL;
    if ((!f32 && !u8) || strstr(h, "'fortran_order': True")) { free(b); return -1; }
    p = strstr(h, "'shape': (");
    if (!p) { free(b); return -1; }
    p += 10;
    out->n = 1;
    while (*p && *p != ')') {
        char *e;
        long v = strtol(p, &e, 10);
        if (e == p) break;
        out->shape[out->ndim++] = v;
        out->n *= (size_t)v;
        p = e;
        while (*p == ',' || *p == ' ') p++;
    }
    off += hl;
    if (size < off + out->n * (f32 ? 4 : 1)) { free(b); return -1; }
    out->data = (float *)malloc(out->n * sizeof(float) + 1);
    for (i = 0; i < out->n; i++) {
        if (f32) memcpy(&out->data[i], b + off + 4 * i, 4);
        else out->data[i] = (float)b[off + i];
    }
    free(b);
    return 0;
}

/* relative L2 of a vs reference b */
static inline double tu_rel_l2(const float *a, const float *b, size_t n) {
    double num = 0, den = 0;
    size_t i;
    for (i = 0; i < n; i++) { double d = (double)a[i] - b[i]; num += d * d; den += (double)b[i] * b[i]; }
    return den > 0 ? sqrt(num / den) : sqrt(num);
}

#ifdef SUPERMAT_H
/* An RGBA test object: a shaded disc centred at (cx, cy) (alpha 1 inside, a soft edge, 0 outside). */
static inline void tu_disc_rgba(unsigned char *rgba, int w, int h, int cx, int cy, int r) {
    int x, y;
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++) {
            double d = sqrt((double)(x - cx) * (x - cx) + (double)(y - cy) * (y - cy)), a = r + 0.5 - d;
            unsigned char *p = rgba + ((size_t)y * w + x) * 4;
            p[0] = (unsigned char)(40 + (x * 197) % 200); p[1] = (unsigned char)(30 + (y * 89) % 210); p[2] = (unsigned char)((x * y) % 256);
            p[3] = (unsigned char)(a >= 1.0 ? 255 : a <= 0.0 ? 0 : (int)(a * 255.0));
        }
}
/* nv multi-view test views of m x m pixels: discs moving across the views (px: nv * m * m * 4 bytes),
   float RGB outputs into out (nv * m * m * 3), and distinct translated cameras (nv * 16 floats). */
static inline void tu_mv_views(int nv, int m, unsigned char *px, supermat_image *in, supermat_image *ov, float *out, float *cams) {
    int v, i;
    for (v = 0; v < nv; v++) {
        unsigned char *pv = px + (size_t)v * m * m * 4;
        tu_disc_rgba(pv, m, m, 10 + 4 * v, 14, 9);
        memset(&in[v], 0, sizeof in[v]); in[v].pixels = pv; in[v].width = m; in[v].height = m; in[v].channels = 4;
        memset(&ov[v], 0, sizeof ov[v]); ov[v].pixels = out + (size_t)v * m * m * 3; ov[v].channels = 3; ov[v].format = SUPERMAT_FORMAT_F32;
        for (i = 0; i < 16; i++) cams[v * 16 + i] = (i % 5 == 0) ? 1.0f : 0.0f;
        cams[v * 16 + 3] = (float)v * 0.7f; cams[v * 16 + 11] = 1.5f - (float)v;
    }
}
#endif
#endif
