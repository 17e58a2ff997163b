/* Tests of the model converter (convert/sm_convert.c): the torch.save reader (zip, zip64, pickle), the CLIP
   text encoder, the output file, and every error path (truncated / corrupted files must fail cleanly).
   usage: test_convert DATA_DIR [TWIN_DIR]
     DATA_DIR  tests/data (uses DATA_DIR/tiny), or a folder holding supermat.pth, supermat_mv.pth,
               uv_refine_bc.pth and base/ directly (e.g. the reference harness's models_tiny)
     TWIN_DIR  optional: a folder with <checkpoint>.safetensors copies made by the reference harness; the
               converted tensors are then compared with those too (else with this reader's own values)
   Scratch files go to ./test_convert_tmp (removed at the end). */
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "supermat.h"
#include "sm_convert.h"
#include "test_util.h"

#include <stdint.h>
#include <time.h>
#ifdef _WIN32
#include <direct.h>
#define tc_mkdir(p) _mkdir(p)
#define tc_rmdir(p) _rmdir(p)
#else
#include <sys/stat.h>
#include <unistd.h>
#define tc_mkdir(p) mkdir(p, 0755)
#define tc_rmdir(p) rmdir(p)
#endif

#define TMP "test_convert_tmp"

/* ---- small utilities ------------------------------------------------------------------------- */
static int tc_exists(const char *p) {
    FILE *f = fopen(p, "rb");
    if (!f) return 0;
    fclose(f);
    return 1;
}

static int tc_write(const char *path, const void *data, size_t n) {
    FILE *f = fopen(path, "wb");
    size_t w;
    if (!f) return -1;
    w = fwrite(data, 1, n, f);
    return (fclose(f) == 0 && w == n) ? 0 : -1;
}

static int tc_copy(const char *src, const char *dst) {
    size_t n = 0;
    unsigned char *b = tu_load(src, &n);
    int r;
    if (!b) return -1;
    r = tc_write(dst, b, n);
    free(b);
    return r;
}

/* scratch files, removed at exit (deepest first) */
static char tc_made[512][700];
static int tc_nmade;
static void tc_track(const char *p) {
    if (tc_nmade < 512) snprintf(tc_made[tc_nmade++], sizeof tc_made[0], "%s", p);
}
static void tc_mkdir_tracked(const char *p) {
    tc_mkdir(p);
    tc_track(p);
}
static void tc_cleanup(void) {
    int i;
    for (i = tc_nmade - 1; i >= 0; i--)
        if (remove(tc_made[i]) != 0) tc_rmdir(tc_made[i]);
}

static uint32_t tc_crc32(const unsigned char *p, size_t n) { /* bitwise, independent of the converter's */
    uint32_t c = 0xFFFFFFFFu;
    size_t i;
    int k;
    for (i = 0; i < n; i++) {
        c ^= p[i];
        for (k = 0; k < 8; k++) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return ~c;
}

static uint32_t tc_rand_state = 12345;
static uint32_t tc_rand(void) {
    tc_rand_state = tc_rand_state * 1664525u + 1013904223u;
    return tc_rand_state >> 8;
}

static uint16_t tc_rd16(const unsigned char *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t tc_rd32(const unsigned char *p) { return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24); }
static void tc_wr32(unsigned char *p, uint32_t v) { p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8); p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24); }

/* ---- reference F16 / BF16 rounding (nearest, ties to even), written independently -------------- */
static double tc_f16_value(unsigned h) {
    unsigned e = (h >> 10) & 31, m = h & 1023;
    double v = e ? ldexp(1024.0 + m, (int)e - 25) : ldexp((double)m, -24);
    return (h & 0x8000) ? -v : v;
}
static uint16_t tc_ref_f16(float f) {
    double a = fabs((double)f);
    unsigned lo = 0, hi = 0x7bff, s = f < 0 ? 0x8000u : 0u;
    if (a >= 65520.0) return (uint16_t)(s | 0x7c00u);
    while (hi - lo > 1) { /* the last code with value <= a */
        unsigned mid = (lo + hi) / 2;
        if (tc_f16_value(mid) <= a) lo = mid;
        else hi = mid;
    }
    if (tc_f16_value(hi) <= a) lo = hi;
    if (lo < 0x7bff) {
        double d0 = a - tc_f16_value(lo), d1 = tc_f16_value(lo + 1) - a;
        if (d1 < d0 || (d1 == d0 && (lo & 1))) lo++;
    }
    return (uint16_t)(s | lo);
}
static double tc_bf16_value(unsigned h) {
    uint32_t u = (uint32_t)h << 16;
    float f;
    memcpy(&f, &u, 4);
    return f;
}
static uint16_t tc_ref_bf16(float f) {
    uint32_t u;
    unsigned t;
    double d0, d1, a = f;
    memcpy(&u, &f, 4);
    t = u >> 16;
    d0 = fabs(a - tc_bf16_value(t));
    d1 = fabs(tc_bf16_value(t + 1) - a);
    if (d1 < d0 || (d1 == d0 && (t & 1))) t++;
    return (uint16_t)t;
}

/* ---- a byte buffer --------------------------------------------------------------------------- */
typedef struct tc_buf { unsigned char *p; size_t n, cap; } tc_buf;
static void tc_put(tc_buf *b, const void *d, size_t n) {
    if (b->n + n > b->cap) {
        size_t nc = b->cap ? b->cap : 1024;
        while (nc < b->n + n) nc *= 2;
        b->p = (unsigned char *)realloc(b->p, nc);
        b->cap = nc;
    }
    if (n) memcpy(b->p + b->n, d, n);
    b->n += n;
}
static void tc_u8(tc_buf *b, unsigned v) { unsigned char c = (unsigned char)v; tc_put(b, &c, 1); }
static void tc_u16(tc_buf *b, unsigned v) { tc_u8(b, v & 255); tc_u8(b, (v >> 8) & 255); }
static void tc_u32(tc_buf *b, uint32_t v) { tc_u16(b, v & 0xFFFF); tc_u16(b, v >> 16); }
static void tc_u64(tc_buf *b, uint64_t v) { tc_u32(b, (uint32_t)v); tc_u32(b, (uint32_t)(v >> 32)); }
static void tc_str(tc_buf *b, const char *s) { tc_put(b, s, strlen(s)); }

/* ---- a miniature torch.save: the same zip layout and pickle opcodes PyTorch writes -------------- */
typedef struct tw_storage { const void *data; long long numel; int dt; } tw_storage; /* dt: 0 F32, 1 F16, 2 BF16, 3 I64 */
typedef struct tw_tensor { const char *name; int storage, ndim; long long offset, shape[4], stride[4]; } tw_tensor;
typedef struct tw_opts { int zip64, wrap, compressed, no_descriptor, drop_storage, param, proto4; } tw_opts;
static const char *const tw_cls[4] = {"FloatStorage", "HalfStorage", "BFloat16Storage", "LongStorage"};
static const int tw_size[4] = {4, 2, 2, 8};

static void tw_unicode(tc_buf *b, const char *s, int proto4) {
    if (proto4 && strlen(s) < 256) { tc_u8(b, 0x8c); tc_u8(b, (unsigned)strlen(s)); }
    else { tc_u8(b, 'X'); tc_u32(b, (uint32_t)strlen(s)); }
    tc_str(b, s);
}
static void tw_int(tc_buf *b, long long v) {
    if (v >= 0 && v < 256) { tc_u8(b, 'K'); tc_u8(b, (unsigned)v); }
    else if (v >= INT32_MIN && v <= INT32_MAX) { tc_u8(b, 'J'); tc_u32(b, (uint32_t)v); }
    else { tc_u8(b, 0x8a); tc_u8(b, 8); tc_u64(b, (uint64_t)v); }
}
static void tw_global(tc_buf *b, const char *mod, const char *name, int proto4) {
    if (proto4) { tw_unicode(b, mod, 1); tw_unicode(b, name, 1); tc_u8(b, 0x93); tc_u8(b, 0x94); }
    else { tc_u8(b, 'c'); tc_str(b, mod); tc_u8(b, '\n'); tc_str(b, name); tc_u8(b, '\n'); }
}

static void tw_pickle(tc_buf *b, const tw_tensor *t, int nt, const tw_storage *s, const tw_opts *o) {
    int i, k, p4 = o->proto4;
    char key[16];
    (void)s;
    tc_u8(b, 0x80); tc_u8(b, p4 ? 4 : 2);
    if (p4) { tc_u8(b, 0x95); tc_u64(b, 0); } /* a FRAME header (its length is not used by the reader) */
    if (o->wrap) { tc_u8(b, '}'); tc_u8(b, '('); tw_unicode(b, "epoch", p4); tw_int(b, 7); tw_unicode(b, "state_dict", p4); }
    tw_global(b, "collections", "OrderedDict", p4);
    tc_u8(b, ')'); tc_u8(b, 'R');
    tc_u8(b, 'q'); tc_u8(b, 1); /* BINPUT 1 */
    tc_u8(b, '(');
    for (i = 0; i < nt; i++) {
        tw_unicode(b, t[i].name, p4);
        if (o->param) tw_global(b, "torch._utils", "_rebuild_parameter", p4);
        if (o->param) tc_u8(b, '(');
        tw_global(b, "torch._utils", "_rebuild_tensor_v2", p4);
        tc_u8(b, '(');
        tc_u8(b, '('); /* the persistent id */
        tw_unicode(b, "storage", p4);
        tw_global(b, "torch", tw_cls[s[t[i].storage].dt], p4);
        snprintf(key, sizeof key, "%d", t[i].storage);
        tw_unicode(b, key, p4);
        tw_unicode(b, "cpu", p4);
        tw_int(b, s[t[i].storage].numel);
        tc_u8(b, 't');
        tc_u8(b, 'Q');
        tw_int(b, t[i].offset);
        tc_u8(b, '(');
        for (k = 0; k < t[i].ndim; k++) tw_int(b, t[i].shape[k]);
        tc_u8(b, 't');
        tc_u8(b, '(');
        for (k = 0; k < t[i].ndim; k++) tw_int(b, t[i].stride[k]);
        tc_u8(b, 't');
        tc_u8(b, 0x89);
        tw_global(b, "collections", "OrderedDict", p4);
        tc_u8(b, ')'); tc_u8(b, 'R');
        tc_u8(b, 't');
        tc_u8(b, 'R');
        if (o->param) { tc_u8(b, 0x89); tc_u8(b, 'h'); tc_u8(b, 1); tc_u8(b, 't'); tc_u8(b, 'R'); } /* (data, False, <memo 1>) */
    }
    tc_u8(b, 'u');
    if (o->wrap) tc_u8(b, 'u');
    tc_u8(b, '.');
}

typedef struct tw_entry { char name[64]; uint64_t lho, size; uint32_t crc; } tw_entry;

static void tw_add(tc_buf *z, tw_entry *e, const char *name, const void *data, size_t n, const tw_opts *o, int method) {
    size_t nl = strlen(name), pad, base;
    int desc = !o->no_descriptor;
    snprintf(e->name, sizeof e->name, "%s", name);
    e->lho = z->n;
    e->size = n;
    e->crc = tc_crc32((const unsigned char *)data, n);
    tc_u32(z, 0x04034b50u);
    tc_u16(z, o->zip64 ? 45 : 20);
    tc_u16(z, desc ? 0x0808 : 0x0800);
    tc_u16(z, (unsigned)method);
    tc_u16(z, 0); tc_u16(z, 0x21); /* time, date */
    tc_u32(z, desc ? 0 : e->crc);
    tc_u32(z, desc ? 0 : (uint32_t)n);
    tc_u32(z, desc ? 0 : (uint32_t)n);
    tc_u16(z, (unsigned)nl);
    /* torch pads the local extra field so that the data starts on a 64-byte boundary */
    base = z->n + 2 + nl + 4;
    pad = (64 - base % 64) % 64;
    tc_u16(z, (unsigned)(4 + pad));
    tc_put(z, name, nl);
    tc_u16(z, 0x4246); tc_u16(z, (unsigned)pad); /* "FB" */
    while (pad--) tc_u8(z, 'Z');
    tc_put(z, data, n);
    if (desc) {
        tc_u32(z, 0x08074b50u);
        tc_u32(z, e->crc);
        if (o->zip64) { tc_u64(z, n); tc_u64(z, n); }
        else { tc_u32(z, (uint32_t)n); tc_u32(z, (uint32_t)n); }
    }
}

static unsigned char *tw_save(const tw_tensor *t, int nt, const tw_storage *s, int ns, const tw_opts *o, size_t *size) {
    tc_buf z, pk;
    tw_entry e[40];
    int ne = 0, i;
    uint64_t cd_off, cd_size, z64_off;
    memset(&z, 0, sizeof z);
    memset(&pk, 0, sizeof pk);
    tw_pickle(&pk, t, nt, s, o);
    tw_add(&z, &e[ne++], "archive/data.pkl", pk.p, pk.n, o, o->compressed ? 8 : 0);
    tw_add(&z, &e[ne++], "archive/byteorder", "little", 6, o, 0);
    for (i = 0; i < ns && ne < 38; i++) {
        char nm[64];
        if (o->drop_storage && i == ns - 1) continue;
        snprintf(nm, sizeof nm, "archive/data/%d", i);
        tw_add(&z, &e[ne++], nm, s[i].data, (size_t)(s[i].numel * tw_size[s[i].dt]), o, 0);
    }
    tw_add(&z, &e[ne++], "archive/version", "3\n", 2, o, 0);
    cd_off = z.n;
    for (i = 0; i < ne; i++) {
        size_t nl = strlen(e[i].name);
        tc_u32(&z, 0x02014b50u);
        tc_u16(&z, o->zip64 ? 45 : 20); tc_u16(&z, o->zip64 ? 45 : 20);
        tc_u16(&z, o->no_descriptor ? 0x0800 : 0x0808);
        tc_u16(&z, (unsigned)(o->compressed && i == 0 ? 8 : 0));
        tc_u16(&z, 0); tc_u16(&z, 0x21);
        tc_u32(&z, e[i].crc);
        tc_u32(&z, o->zip64 ? 0xFFFFFFFFu : (uint32_t)e[i].size);
        tc_u32(&z, o->zip64 ? 0xFFFFFFFFu : (uint32_t)e[i].size);
        tc_u16(&z, (unsigned)nl);
        tc_u16(&z, o->zip64 ? 28 : 0);
        tc_u16(&z, 0); tc_u16(&z, 0); tc_u16(&z, 0); tc_u32(&z, 0);
        tc_u32(&z, o->zip64 ? 0xFFFFFFFFu : (uint32_t)e[i].lho);
        tc_put(&z, e[i].name, nl);
        if (o->zip64) { tc_u16(&z, 1); tc_u16(&z, 24); tc_u64(&z, e[i].size); tc_u64(&z, e[i].size); tc_u64(&z, e[i].lho); }
    }
    cd_size = z.n - cd_off;
    if (o->zip64) {
        z64_off = z.n;
        tc_u32(&z, 0x06064b50u); tc_u64(&z, 44); tc_u16(&z, 45); tc_u16(&z, 45); tc_u32(&z, 0); tc_u32(&z, 0);
        tc_u64(&z, (uint64_t)ne); tc_u64(&z, (uint64_t)ne); tc_u64(&z, cd_size); tc_u64(&z, cd_off);
        tc_u32(&z, 0x07064b50u); tc_u32(&z, 0); tc_u64(&z, z64_off); tc_u32(&z, 1);
    }
    tc_u32(&z, 0x06054b50u); tc_u16(&z, 0); tc_u16(&z, 0);
    tc_u16(&z, o->zip64 ? 0xFFFF : (unsigned)ne); tc_u16(&z, o->zip64 ? 0xFFFF : (unsigned)ne);
    tc_u32(&z, o->zip64 ? 0xFFFFFFFFu : (uint32_t)cd_size);
    tc_u32(&z, o->zip64 ? 0xFFFFFFFFu : (uint32_t)cd_off);
    tc_u16(&z, 0);
    free(pk.p);
    *size = z.n;
    return z.p;
}

static void tw_contig(tw_tensor *t, const char *name, int storage, long long off, int ndim, const long long *shape) {
    int k;
    long long st = 1;
    memset(t, 0, sizeof *t);
    t->name = name;
    t->storage = storage;
    t->offset = off;
    t->ndim = ndim;
    for (k = ndim - 1; k >= 0; k--) {
        t->shape[k] = shape[k];
        t->stride[k] = st;
        st *= shape[k];
    }
}

/* ---- 1. the reader on hand-made checkpoints -------------------------------------------------- */
static void test_reader_small(void) {
    float a[24], c[3];
    uint16_t h[10], bf[6];
    long long i64[4] = {1, 2, 3, 4};
    tw_storage s[4];
    tw_tensor t[6];
    long long sh_a[2] = {4, 6}, sh_v[1] = {5}, sh_h[2] = {2, 5}, sh_bf[1] = {6}, sh_e[2] = {0, 3};
    int i, v, r;
    char err[512];
    for (i = 0; i < 24; i++) a[i] = (float)i * 0.25f - 3.0f;
    for (i = 0; i < 10; i++) h[i] = (uint16_t)(0x3c00 + i);
    for (i = 0; i < 6; i++) bf[i] = (uint16_t)(0x3f80 + 3 * i);
    c[0] = c[1] = c[2] = 1.5f;
    s[0].data = a; s[0].numel = 24; s[0].dt = 0;
    s[1].data = h; s[1].numel = 10; s[1].dt = 1;
    s[2].data = bf; s[2].numel = 6; s[2].dt = 2;
    s[3].data = c; s[3].numel = 3; s[3].dt = 0;
    tw_contig(&t[0], "a.weight", 0, 0, 2, sh_a);
    tw_contig(&t[1], "a.view", 0, 7, 1, sh_v);    /* shares storage 0 from element 7 */
    tw_contig(&t[2], "h", 1, 0, 2, sh_h);
    tw_contig(&t[3], "bf", 2, 0, 1, sh_bf);
    tw_contig(&t[4], "scalar", 3, 2, 0, NULL);    /* 0-d tensor at element 2 */
    tw_contig(&t[5], "empty", 3, 0, 2, sh_e);
    for (v = 0; v < 16; v++) {
        tw_opts o;
        size_t n;
        unsigned char *f;
        sm_pth *p = NULL;
        memset(&o, 0, sizeof o);
        o.zip64 = v & 1;
        o.wrap = (v >> 1) & 1;
        o.no_descriptor = (v >> 2) & 1;
        o.proto4 = (v >> 3) & 1;
        o.param = v == 6;
        f = tw_save(t, 6, s, 4, &o, &n);
        r = sm_pth_open_memory(f, n, &p, err, sizeof err);
        TU_CHECK(r == 0, "variant %d (zip64 %d wrap %d proto4 %d): %s", v, o.zip64, o.wrap, o.proto4, err);
        if (!r) {
            unsigned char buf[128];
            const supermat_tensor_info *ti;
            TU_CHECK(sm_pth_count(p) == 6, "variant %d: %d tensors", v, sm_pth_count(p));
            ti = sm_pth_tensor(p, 0);
            TU_CHECK(ti && !strcmp(ti->name, "a.weight") && ti->dtype == SUPERMAT_DTYPE_F32 && ti->ndim == 2 && ti->shape[0] == 4 && ti->shape[1] == 6 && ti->nbytes == 96, "a.weight info");
            TU_CHECK(sm_pth_read(p, 0, buf, err, sizeof err) == 0 && !memcmp(buf, a, 96), "a.weight bytes: %s", err);
            i = sm_pth_find(p, "a.view");
            TU_CHECK(i == 1 && sm_pth_read(p, i, buf, err, sizeof err) == 0 && !memcmp(buf, a + 7, 20), "shared-storage view");
            i = sm_pth_find(p, "h");
            ti = sm_pth_tensor(p, i);
            TU_CHECK(ti && ti->dtype == SUPERMAT_DTYPE_F16 && sm_pth_read(p, i, buf, err, sizeof err) == 0 && !memcmp(buf, h, 20), "F16 tensor");
            i = sm_pth_find(p, "bf");
            ti = sm_pth_tensor(p, i);
            TU_CHECK(ti && ti->dtype == SUPERMAT_DTYPE_BF16 && sm_pth_read(p, i, buf, err, sizeof err) == 0 && !memcmp(buf, bf, 12), "BF16 tensor");
            i = sm_pth_find(p, "scalar");
            ti = sm_pth_tensor(p, i);
            TU_CHECK(ti && ti->ndim == 0 && ti->nbytes == 4 && sm_pth_read(p, i, buf, err, sizeof err) == 0 && !memcmp(buf, c + 2, 4), "0-d tensor");
            ti = sm_pth_tensor(p, sm_pth_find(p, "empty"));
            TU_CHECK(ti && ti->nbytes == 0 && ti->ndim == 2 && ti->shape[0] == 0, "empty tensor");
            TU_CHECK(sm_pth_find(p, "nope") == -1 && sm_pth_tensor(p, 6) == NULL, "lookups");
            sm_pth_close(p);
        }
        free(f);
    }
    /* files the reader must refuse, with a message saying why */
    {
        static const struct { const char *what, *expect; } cases[] = {
            {"non-contiguous", "contiguous"}, {"int64", "I64"},        {"missing storage", "missing"},
            {"past storage", "past its storage"}, {"compressed", "compressed"}, {"legacy", "legacy"},
            {"crc", "CRC"},                 {"not a dict", "not a dict"},
        };
        int cse;
        for (cse = 0; cse < (int)(sizeof cases / sizeof cases[0]); cse++) {
            tw_opts o;
            tw_tensor tt[2];
            tw_storage ss[2];
            long long sh[2] = {4, 6};
            size_t n = 0;
            unsigned char *f = NULL;
            sm_pth *p = NULL;
            memset(&o, 0, sizeof o);
            ss[0] = s[0];
            ss[1] = s[3];
            tw_contig(&tt[0], "x", 0, 0, 2, sh);
            tw_contig(&tt[1], "y", 1, 0, 1, sh_v);
            tt[1].shape[0] = 3;
            if (cse == 0) { tt[0].stride[0] = 1; tt[0].stride[1] = 4; }
            if (cse == 1) { ss[1].data = i64; ss[1].numel = 4; ss[1].dt = 3; }
            if (cse == 2) o.drop_storage = 1;
            if (cse == 3) tt[1].offset = 1;
            if (cse == 4) o.compressed = 1;
            if (cse == 5) {
                static const unsigned char legacy[] = {0x80, 0x02, 0x8a, 0x0a, 0x6c, 0xfc, 0x9c, 0x46, 0xf9, 0x20, 0x6a, 0xa8, 0x50, 0x19, 0x2e};
                f = (unsigned char *)malloc(sizeof legacy);
                memcpy(f, legacy, sizeof legacy);
                n = sizeof legacy;
            } else f = tw_save(tt, 2, ss, 2, &o, &n);
            if (cse == 6) f[200] ^= 1; /* inside data.pkl */
            if (cse == 7) { /* replace the pickle by a list: find data.pkl's data (it is 64-aligned, first) */
                static const unsigned char lst[] = {0x80, 0x02, ']', 'q', 0, '.'};
                size_t k;
                for (k = 64; k + 6 < n; k++)
                    if (f[k] == 0x80 && f[k + 1] == 2) { memcpy(f + k, lst, sizeof lst); break; }
                /* fix the CRC so that the pickle VM itself sees it */
                for (k = 0; k + 46 < n; k++)
                    if (tc_rd32(f + k) == 0x02014b50u && !memcmp(f + k + 46, "archive/data.pkl", 16)) {
                        uint32_t len = tc_rd32(f + k + 24);
                        unsigned char *d = f + 64;
                        while (d[0] != 0x80) d++;
                        tc_wr32(f + k + 16, tc_crc32(d, len));
                        break;
                    }
            }
            r = sm_pth_open_memory(f, n, &p, err, sizeof err);
            TU_CHECK(r != 0 && p == NULL && strstr(err, cases[cse].expect) != NULL, "%s: expected an error mentioning '%s', got %d '%s'", cases[cse].what, cases[cse].expect, r, err);
            free(f);
        }
    }
    {
        sm_pth *none = NULL;
        TU_CHECK(sm_pth_open("does/not/exist.pth", &none, err, sizeof err) != 0 && none == NULL && strstr(err, "exist.pth"), "missing file: %s", err);
    }
    {   /* an already quantized safetensors input (I8): refused, naming the tensor */
        static const char hdr[] = "{\"w\":{\"dtype\":\"I8\",\"shape\":[2,3],\"data_offsets\":[0,6]}}";
        unsigned char f[8 + sizeof hdr - 1 + 6];
        size_t hl = sizeof hdr - 1;
        sm_pth *q = NULL;
        memset(f, 0, sizeof f);
        for (i = 0; i < 8; i++) f[i] = (unsigned char)(hl >> (8 * i));
        memcpy(f + 8, hdr, hl);
        r = sm_pth_open_memory(f, sizeof f, &q, err, sizeof err);
        TU_CHECK(r == SUPERMAT_ERROR_UNSUPPORTED && q == NULL && strstr(err, "'w' is I8"), "I8 safetensors input: %d '%s'", r, err);
        if (q) sm_pth_close(q);
    }
}

/* ---- 2. robustness: truncation and corruption sweeps (run under ASan/UBSan in CI) ------------ */
static const unsigned char *tc_find_pickle(const unsigned char *f, size_t n, size_t *len, size_t *cd_entry) {
    size_t k;
    for (k = 0; k + 46 < n; k++)
        if (tc_rd32(f + k) == 0x02014b50u) {
            unsigned nl = tc_rd16(f + k + 28);
            if (nl >= 8 && k + 46 + nl <= n && !memcmp(f + k + 46 + nl - 8, "data.pkl", 8)) {
                uint32_t lho = tc_rd32(f + k + 42);
                *len = tc_rd32(f + k + 24);
                *cd_entry = k;
                return f + lho + 30 + tc_rd16(f + lho + 26) + tc_rd16(f + lho + 28);
            }
        }
    return NULL;
}

static void test_sweeps(const char *pth) {
    size_t n = 0, plen = 0, cde = 0, cut, k, step;
    unsigned char *f = tu_load(pth, &n), *g;
    const unsigned char *pk;
    int cuts = 0, flips = 0, ok_after_flip = 0, crashes_would_show = 0, r, nt = -1, nt0 = -1;
    char err[512];
    sm_pth *p = NULL;
    TU_CHECK(f != NULL, "cannot read %s", pth);
    if (!f) return;
    pk = tc_find_pickle(f, n, &plen, &cde);
    TU_CHECK(pk != NULL && plen > 0, "data.pkl not found in %s", pth);
    if (!pk) { free(f); return; }
    TU_CHECK(sm_pickle_check(pk, plen, &nt0, err, sizeof err) == 0 && nt0 > 0, "pickle check: %s", err);
    /* the pickle alone: truncated at every byte of the first 4 KiB, then a stride; each must fail */
    step = plen > 4096 ? (plen - 4096) / 200 + 1 : 1;
    for (cut = 0; cut < plen; cut += cut < 4096 ? 1 : step) {
        r = sm_pickle_check(pk, cut, &nt, err, sizeof err);
        if (r == 0) { TU_CHECK(0, "pickle truncated to %lu bytes was accepted", (unsigned long)cut); break; }
        cuts++;
    }
    /* the file, truncated: a stride over the whole file, plus the last 100 bytes one by one */
    g = (unsigned char *)malloc(n);
    memcpy(g, f, n);
    step = n / 300 + 1;
    for (cut = 0; cut < n; cut += cut + 100 >= n ? 1 : step) {
        r = sm_pth_open_memory(g, cut, &p, err, sizeof err);
        if (r == 0) { TU_CHECK(0, "file truncated to %lu bytes was accepted", (unsigned long)cut); sm_pth_close(p); break; }
        cuts++;
    }
    /* truncated inside the tensors but with the central directory kept: zero a range before it */
    memcpy(g, f, n);
    {
        uint32_t cd_off = 0;
        for (k = n - 22; k > 0; k--)
            if (tc_rd32(f + k) == 0x06054b50u) { cd_off = tc_rd32(f + k + 16); break; }
        TU_CHECK(cd_off > 0 && cd_off < n, "EOCD");
        for (k = 0; k < 40 && cd_off; k++) {
            size_t from = (size_t)cd_off - (size_t)cd_off * (k + 1) / 41;
            memset(g + from, 0, (size_t)cd_off - from);
            p = NULL;
            r = sm_pth_open_memory(g, n, &p, err, sizeof err);
            if (r == 0) { /* the headers may survive; the data CRC must then catch it on read */
                int i, bad = 0;
                unsigned char *buf;
                for (i = 0; i < sm_pth_count(p); i++) {
                    const supermat_tensor_info *t = sm_pth_tensor(p, i);
                    buf = (unsigned char *)malloc((size_t)t->nbytes + 1);
                    if (sm_pth_read(p, i, buf, err, sizeof err) != 0) bad++;
                    free(buf);
                }
                TU_CHECK(bad > 0, "zeroed [%lu, %lu) went unnoticed", (unsigned long)from, (unsigned long)cd_off);
                sm_pth_close(p);
            }
            memcpy(g + from, f + from, (size_t)cd_off - from);
            cuts++;
        }
    }
    /* flipped bytes in data.pkl: refused through the CRC; and, with the CRC fixed up, the pickle VM must
       not crash (it may accept a flip inside a name or a number) */
    for (k = 0; k < 300; k++) {
        size_t at = tc_rand() % plen, off = (size_t)(pk - f) + at;
        unsigned char nv = (unsigned char)(tc_rand() & 255);
        if (nv == f[off]) nv ^= 0x5a;
        g[off] = nv;
        p = NULL;
        r = sm_pth_open_memory(g, n, &p, err, sizeof err);
        if (r == 0) { TU_CHECK(0, "flipped data.pkl byte %lu accepted", (unsigned long)at); sm_pth_close(p); }
        TU_CHECK(r != 0 && strstr(err, "CRC"), "flip %lu: %s", (unsigned long)at, err);
        tc_wr32(g + cde + 16, tc_crc32(g + (pk - f), plen));
        p = NULL;
        r = sm_pth_open_memory(g, n, &p, err, sizeof err);
        if (r == 0) { ok_after_flip++; sm_pth_close(p); }
        r = sm_pickle_check(g + (pk - f), plen, &nt, err, sizeof err);
        g[off] = f[off];
        memcpy(g + cde + 16, f + cde + 16, 4);
        flips++;
    }
    /* random bytes anywhere in the pickle, several at once, and the central directory */
    for (k = 0; k < 300; k++) {
        int j;
        size_t at[4];
        for (j = 0; j < 4; j++) g[at[j] = (size_t)(pk - f) + tc_rand() % plen] = (unsigned char)tc_rand();
        sm_pickle_check(g + (pk - f), plen, &nt, err, sizeof err);
        for (j = 3; j >= 0; j--) g[at[j]] = f[at[j]];
        for (j = 0; j < 3; j++) g[at[j] = cde + tc_rand() % (n - cde)] = (unsigned char)tc_rand();
        p = NULL;
        if (sm_pth_open_memory(g, n, &p, err, sizeof err) == 0) sm_pth_close(p);
        for (j = 2; j >= 0; j--) g[at[j]] = f[at[j]];
        flips++;
    }
    /* random programs over the opcodes the VM knows (and a few it does not) */
    {
        static const unsigned char ops[] = {0x80, 0x95, '}', ']', ')', '(', 't', 0x85, 0x86, 0x87, 'X', 0x8c, 0x8d, 'B', 'C', 'T', 'U', 'c',
                                            0x93, 'Q', 'R', 0x81, 'b', 'J', 'K', 'M', 0x8a, 0x8b, 'G', 'N', 0x88, 0x89, 'q', 'r', 0x94, 'h',
                                            'j', 's', 'u', 'e', 'a', '0', '1', '2', '.', 'I', 'p', 0xff};
        unsigned char prog[256];
        for (k = 0; k < 3000; k++) {
            size_t len = 1 + tc_rand() % sizeof prog, j;
            for (j = 0; j < len; j++) {
                uint32_t x = tc_rand();
                prog[j] = (x & 3) ? ops[(x >> 2) % sizeof ops] : (unsigned char)(x >> 8); /* small arguments too */
            }
            if (k & 1) { prog[0] = 0x80; prog[1] = 2; }
            sm_pickle_check(prog, len, &nt, err, sizeof err);
        }
        flips += 3000;
    }
    (void)crashes_would_show;
    printf("  sweeps: %d truncations refused, %d corruptions survived (%d single flips accepted once the CRC was fixed)\n", cuts, flips, ok_after_flip);
    free(g);
    free(f);
}

/* ---- 3. converting the tiny models ----------------------------------------------------------- */
typedef struct tc_st { /* a safetensors file read by the test's own header walk */
    unsigned char *b;
    size_t n;
    uint64_t hl;
    supermat_json_tok *tok;
    int ntok;
} tc_st;

static int tc_st_load(tc_st *s, const char *path) {
    int i;
    memset(s, 0, sizeof *s);
    s->b = tu_load(path, &s->n);
    if (!s->b || s->n < 8) return -1;
    for (i = 7; i >= 0; i--) s->hl = (s->hl << 8) | s->b[i];
    if (s->hl > s->n - 8) return -1;
    s->ntok = supermat_json_parse((const char *)s->b + 8, (size_t)s->hl, NULL, 0);
    if (s->ntok <= 0) return -1;
    s->tok = (supermat_json_tok *)malloc(sizeof(supermat_json_tok) * (size_t)s->ntok);
    return supermat_json_parse((const char *)s->b + 8, (size_t)s->hl, s->tok, s->ntok) == s->ntok ? 0 : -1;
}
static void tc_st_free(tc_st *s) { free(s->b); free(s->tok); }

/* tensor `name`: dtype string, shape, data pointer, byte count; 0 if found */
static int tc_st_get(const tc_st *s, const char *name, char *dt, long long *shape, int *ndim, const unsigned char **data, size_t *nbytes) {
    const char *js = (const char *)s->b + 8;
    int v = supermat_json_find(js, s->tok, 0, name), d, sh, off, k;
    double x = 0, b0 = 0, b1 = 0;
    if (v < 0) return -1;
    d = supermat_json_find(js, s->tok, v, "dtype");
    sh = supermat_json_find(js, s->tok, v, "shape");
    off = supermat_json_find(js, s->tok, v, "data_offsets");
    if (d < 0 || sh < 0 || off < 0) return -1;
    supermat_json_string(js, &s->tok[d], dt, 8);
    *ndim = s->tok[sh].size;
    for (k = 0; k < *ndim && k < 8; k++) {
        supermat_json_number(js, &s->tok[sh + 1 + k], &x);
        shape[k] = (long long)x;
    }
    supermat_json_number(js, &s->tok[off + 1], &b0);
    supermat_json_number(js, &s->tok[off + 2], &b1);
    *data = s->b + 8 + s->hl + (size_t)b0;
    *nbytes = (size_t)(b1 - b0);
    return 0;
}

static void tc_expect_meta(const tc_st *s, const char *key, const char *want) {
    char v[400];
    int r = supermat_safetensors_metadata(s->b, s->n, key, v, sizeof v);
    TU_CHECK(r == 0 && !strcmp(v, want), "metadata %s = '%s', expected '%s'", key, r == 0 ? v : "(absent)", want);
}

/* A few values of the tiny checkpoints read with torch (independent of this reader):
   name, element count, first element, sum over all elements (float64). */
typedef struct tc_known { const char *file, *name; long long numel; double first, sum; } tc_known;
static const tc_known tc_known_values[] = {
    {"supermat.pth", "conv_in.weight", 1152, 0.0858772025, 0.4196256804279983},
    {"supermat.pth", "up_blocks.1.resnets.2.conv_shortcut.weight", 8192, -0.0152353588, -10.126492618818702},
    {"supermat.pth", "rep_conv_out.1.bias", 4, 0.047363773, 0.0051604975014925003},
    {"supermat.pth", "rep_conv_out.1.weight", 1152, 0.0140415458, 1.7124194596462985},
    {"supermat_mv.pth", "conv_in.weight", 1152, -0.0476974249, 0.54423384682741016},
    {"supermat_mv.pth", "up_blocks.1.resnets.2.conv2.weight", 36864, 0.0376929939, -0.21033806812488365},
    {"supermat_mv.pth", "rep_conv_out.1.bias", 4, 0.0264414288, 0.021334579214453697},
    {"supermat_mv.pth", "class_embedding.linear_1.weight", 2048, 0.0573475361, -10.608817547559738},
    {"uv_refine_bc.pth", "time_embedding.linear_1.weight", 4096, -0.0531131625, -3.1131097887482611},
    {"uv_refine_bc.pth", "up_blocks.2.attentions.0.transformer_blocks.0.attn2.to_k.weight", 2048, 0.0882288441, -1.8684160880657146},
    {"uv_refine_bc.pth", "rep_conv_out.0.bias", 4, 0.0397641063, 0.010477527976036072},
    {"uv_refine_bc.pth", "rep_conv_in.0.weight", 2304, -0.0431065336, 2.9966987903644622},
    {"uv_refine_bc.pth", "first_down_blocks.0.resnets.0.conv1.weight", 9216, -0.0145620527, 0.16576154001799637},
};

static void test_known_values(const char *dir) {
    int i, j;
    char path[600], err[512];
    for (i = 0; i < (int)(sizeof tc_known_values / sizeof tc_known_values[0]); i++) {
        const tc_known *k = &tc_known_values[i];
        sm_pth *p = NULL;
        int idx;
        snprintf(path, sizeof path, "%s/%s", dir, k->file);
        if (sm_pth_open(path, &p, err, sizeof err)) { TU_CHECK(0, "%s", err); continue; }
        idx = sm_pth_find(p, k->name);
        TU_CHECK(idx >= 0, "%s: %s missing", k->file, k->name);
        if (idx >= 0) {
            const supermat_tensor_info *t = sm_pth_tensor(p, idx);
            float *x = (float *)malloc((size_t)t->nbytes + 4);
            double sum = 0;
            TU_CHECK((long long)(t->nbytes / 4) == k->numel && t->dtype == SUPERMAT_DTYPE_F32, "%s: %lld elements", k->name, (long long)(t->nbytes / 4));
            if ((long long)(t->nbytes / 4) == k->numel && sm_pth_read(p, idx, x, err, sizeof err) == 0) {
                for (j = 0; j < k->numel; j++) sum += x[j];
                TU_CHECK(x[0] == (float)k->first && fabs(sum - k->sum) <= 1e-9 * (1 + fabs(k->sum)) + 1e-6,
                         "%s/%s: first %.9g sum %.12g, torch says %.9g %.12g", k->file, k->name, x[0], sum, k->first, k->sum);
            }
            free(x);
        }
        sm_pth_close(p);
    }
}

static int tc_convert(const char *kind, const char *ckpt, const char *base, const char *out, supermat_dtype dt, char *err, size_t cap) {
    sm_convert_desc d;
    memset(&d, 0, sizeof d);
    d.kind = kind;
    d.checkpoint = ckpt;
    d.base_dir = base;
    d.output = out;
    d.dtype = dt;
    d.threads = 2;
    return sm_convert(&d, err, cap);
}

/* checks the converted file against its sources; returns the number of tensors */
static void tc_check_output(const char *out, const char *ckpt, const char *twin, const char *base, const char *kind, supermat_dtype dt,
                            const char *in_ch, const char *branches, const char *class_in) {
    tc_st o, tw;
    sm_pth *ck = NULL, *vae = NULL;
    char path[600], err[512], dts[8];
    int i, r, nt = 0, have_twin = 0, bad_bytes = 0, bad_twin = 0, bad_vae = 0, ndim, prev_end_ok = 1;
    long long shape[8];
    const unsigned char *data;
    size_t nbytes;
    uint64_t expect_off = 0;
    supermat_error se;
    tu_npy ref;
    if (tc_st_load(&o, out)) { TU_CHECK(0, "%s: cannot parse the output", out); tc_st_free(&o); return; }
    TU_CHECK(sm_pth_open(ckpt, &ck, err, sizeof err) == 0, "%s", err);
    snprintf(path, sizeof path, "%s/vae/diffusion_pytorch_model.safetensors", base);
    TU_CHECK(sm_pth_open(path, &vae, err, sizeof err) == 0, "%s", err);
    if (!ck || !vae) goto done;
    if (twin && tc_st_load(&tw, twin) == 0) have_twin = 1;
    else if (twin) tc_st_free(&tw);
    TU_CHECK(o.hl % 8 == 0, "header length %llu is not a multiple of 8", (unsigned long long)o.hl);
    TU_CHECK(supermat_safetensors_count(o.b, o.n, o.n, &nt, &se) == SUPERMAT_SUCCESS, "supermat.h rejects the output: %s", se.message);
    TU_CHECK(nt == sm_pth_count(ck) + sm_pth_count(vae) + 1, "%d tensors, expected %d + %d + 1", nt, sm_pth_count(ck), sm_pth_count(vae));
    /* order and layout: checkpoint tensors, then VAE, then context, back to back */
    {
        const char *js = (const char *)o.b + 8;
        int k = 1, m, idx = 0;
        for (m = 0; m < o.tok[0].size; m++, k = o.tok[k].next) {
            char name[200];
            int v = k + 1, off;
            double b0 = 0, b1 = 0;
            supermat_json_string(js, &o.tok[k], name, sizeof name);
            if (!strcmp(name, "__metadata__")) continue;
            off = supermat_json_find(js, o.tok, v, "data_offsets");
            supermat_json_number(js, &o.tok[off + 1], &b0);
            supermat_json_number(js, &o.tok[off + 2], &b1);
            if ((uint64_t)b0 != expect_off) prev_end_ok = 0;
            expect_off = (uint64_t)b1;
            if (idx < sm_pth_count(ck)) { if (strcmp(name, sm_pth_tensor(ck, idx)->name)) prev_end_ok = 0; }
            else if (idx < nt - 1) { if (strncmp(name, "vae.", 4)) prev_end_ok = 0; }
            else if (strcmp(name, "context")) prev_end_ok = 0;
            idx++;
        }
        TU_CHECK(prev_end_ok && 8 + o.hl + expect_off == o.n, "tensors are not in checkpoint, VAE, context order back to back");
    }
    for (i = 0; i < sm_pth_count(ck); i++) {
        const supermat_tensor_info *t = sm_pth_tensor(ck, i);
        unsigned char *src = (unsigned char *)malloc((size_t)t->nbytes + 4);
        size_t ne = t->nbytes / 4, j;
        if (tc_st_get(&o, t->name, dts, shape, &ndim, &data, &nbytes) || sm_pth_read(ck, i, src, err, sizeof err)) { bad_bytes++; free(src); continue; }
        if (ndim != t->ndim || (ndim && shape[0] != t->shape[0])) bad_bytes++;
        if (dt == SUPERMAT_DTYPE_DEFAULT || dt == SUPERMAT_DTYPE_F32) {
            if (strcmp(dts, "F32") || nbytes != t->nbytes || memcmp(data, src, nbytes)) bad_bytes++;
        } else {
            const char *want = dt == SUPERMAT_DTYPE_F16 ? "F16" : "BF16";
            if (strcmp(dts, want) || nbytes != ne * 2) bad_bytes++;
            else
                for (j = 0; j < ne; j++) {
                    float f;
                    uint16_t h, e;
                    memcpy(&f, src + 4 * j, 4);
                    memcpy(&h, data + 2 * j, 2);
                    e = dt == SUPERMAT_DTYPE_F16 ? tc_ref_f16(f) : tc_ref_bf16(f);
                    if (h != e) { bad_bytes++; break; }
                }
        }
        if (have_twin) {
            char dt2[8];
            long long sh2[8];
            int nd2;
            const unsigned char *d2;
            size_t n2;
            if (tc_st_get(&tw, t->name, dt2, sh2, &nd2, &d2, &n2) || n2 != t->nbytes || memcmp(d2, src, n2)) bad_twin++;
        }
        free(src);
    }
    TU_CHECK(bad_bytes == 0, "%s: %d checkpoint tensors differ from the source", out, bad_bytes);
    if (have_twin) {
        TU_CHECK(bad_twin == 0 && sm_pth_count(ck) == (int)(tw.tok[0].size - (supermat_json_find((const char *)tw.b + 8, tw.tok, 0, "__metadata__") >= 0)),
                 "%s: %d tensors differ from the harness's safetensors twin", ckpt, bad_twin);
        printf("  %s: all %d checkpoint tensors equal the safetensors twin\n", kind, sm_pth_count(ck));
    }
    for (i = 0; i < sm_pth_count(vae); i++) {
        const supermat_tensor_info *t = sm_pth_tensor(vae, i);
        unsigned char *src = (unsigned char *)malloc((size_t)t->nbytes + 4);
        char nm[200];
        snprintf(nm, sizeof nm, "vae.%s", t->name);
        if (tc_st_get(&o, nm, dts, shape, &ndim, &data, &nbytes) || sm_pth_read(vae, i, src, err, sizeof err)) bad_vae++;
        else if (dt == SUPERMAT_DTYPE_DEFAULT && (nbytes != t->nbytes || memcmp(data, src, nbytes))) bad_vae++;
        else if (dt == SUPERMAT_DTYPE_F16 && (strcmp(dts, "F16") || nbytes * 2 != t->nbytes)) bad_vae++;
        free(src);
    }
    TU_CHECK(bad_vae == 0, "%s: %d VAE tensors differ", out, bad_vae);
    /* the context */
    snprintf(path, sizeof path, "%s/empty_prompt_embeds.npy", base);
    if (tu_npy_load(path, &ref) == 0) {
        r = tc_st_get(&o, "context", dts, shape, &ndim, &data, &nbytes);
        TU_CHECK(r == 0 && !strcmp(dts, "F32") && ndim == 2 && (size_t)(shape[0] * shape[1]) == ref.n && nbytes == ref.n * 4, "context tensor shape");
        if (r == 0 && nbytes == ref.n * 4) {
            float *c = (float *)malloc(nbytes);
            double e;
            memcpy(c, data, nbytes);
            e = tu_rel_l2(c, ref.data, ref.n);
            TU_CHECK(e <= 1e-5, "context relative L2 %.3g > 1e-5", e);
            printf("  %s: context [%lld, %lld] relative L2 vs empty_prompt_embeds.npy %.3g\n", kind, shape[0], shape[1], e);
            free(c);
        }
        free(ref.data);
    } else TU_CHECK(0, "cannot read %s", path);
    /* metadata */
    tc_expect_meta(&o, "supermat.format_version", "1");
    tc_expect_meta(&o, "supermat.kind", kind);
    tc_expect_meta(&o, "unet.in_channels", in_ch);
    tc_expect_meta(&o, "unet.branches", branches);
    tc_expect_meta(&o, "unet.class_embed_in", class_in);
    tc_expect_meta(&o, "unet.out_channels", "4");
    tc_expect_meta(&o, "unet.block_out_channels", "32,64,64,64");
    tc_expect_meta(&o, "unet.num_heads", "2,4,4,4");
    tc_expect_meta(&o, "unet.layers_per_block", "2");
    tc_expect_meta(&o, "unet.norm_num_groups", "16");
    tc_expect_meta(&o, "unet.norm_eps", "1e-05");
    tc_expect_meta(&o, "unet.cross_attention_dim", "32");
    tc_expect_meta(&o, "unet.down_block_types", "CrossAttnDownBlock2D,CrossAttnDownBlock2D,CrossAttnDownBlock2D,DownBlock2D");
    tc_expect_meta(&o, "unet.up_block_types", "UpBlock2D,CrossAttnUpBlock2D,CrossAttnUpBlock2D,CrossAttnUpBlock2D");
    tc_expect_meta(&o, "unet.flip_sin_to_cos", "1");
    tc_expect_meta(&o, "unet.freq_shift", "0");
    tc_expect_meta(&o, "unet.upcast_attention", "1");
    tc_expect_meta(&o, "unet.use_linear_projection", "1");
    tc_expect_meta(&o, "unet.act_fn", "silu");
    tc_expect_meta(&o, "unet.transformer_layers_per_block", "1");
    tc_expect_meta(&o, "vae.in_channels", "3");
    tc_expect_meta(&o, "vae.out_channels", "3");
    tc_expect_meta(&o, "vae.latent_channels", "4");
    tc_expect_meta(&o, "vae.block_out_channels", "32,64,64,64");
    tc_expect_meta(&o, "vae.layers_per_block", "2");
    tc_expect_meta(&o, "vae.norm_num_groups", "16");
    tc_expect_meta(&o, "vae.scaling_factor", "0.18215");
    tc_expect_meta(&o, "vae.act_fn", "silu");
    tc_expect_meta(&o, "sched.num_train_timesteps", "1000");
    tc_expect_meta(&o, "sched.beta_start", "0.00085");
    tc_expect_meta(&o, "sched.beta_end", "0.012");
    tc_expect_meta(&o, "sched.beta_schedule", "scaled_linear");
    tc_expect_meta(&o, "sched.prediction_type", "v_prediction");
    tc_expect_meta(&o, "sched.steps_offset", "1");
    tc_expect_meta(&o, "sched.set_alpha_to_one", "0");
    tc_expect_meta(&o, "sched.timestep_spacing", "trailing");
    tc_expect_meta(&o, "context.tokens", "77");
    tc_expect_meta(&o, "context.dim", "32");
    { /* an official conversion (no --detail, --chroma) records neither step */
        char v[64];
        TU_CHECK(supermat_safetensors_metadata(o.b, o.n, "pipeline.detail_sigma", v, sizeof v) < 0 &&
                 supermat_safetensors_metadata(o.b, o.n, "pipeline.chroma_weight", v, sizeof v) < 0, "%s: a pipeline step recorded", kind);
    }
    {
        char src[300];
        snprintf(src, sizeof src, "%s", ckpt);
        tc_expect_meta(&o, "supermat.source", strrchr(src, '/') ? strrchr(src, '/') + 1 : src);
    }
done:
    if (have_twin) tc_st_free(&tw);
    sm_pth_close(ck);
    sm_pth_close(vae);
    tc_st_free(&o);
}

/* the whole tiny checkpoint re-encoded as F16 into a zip64 archive by the miniature torch.save */
static void test_f16_zip64(const char *ckpt, const char *base) {
    sm_pth *p = NULL;
    char err[512], out[300], pth[300];
    int i, n, r;
    tw_storage *s;
    tw_tensor *t;
    uint16_t **h;
    size_t size;
    unsigned char *f;
    tw_opts o;
    tc_st st;
    if (sm_pth_open(ckpt, &p, err, sizeof err)) { TU_CHECK(0, "%s", err); return; }
    n = sm_pth_count(p);
    s = (tw_storage *)calloc((size_t)n, sizeof *s);
    t = (tw_tensor *)calloc((size_t)n, sizeof *t);
    h = (uint16_t **)calloc((size_t)n, sizeof *h);
    for (i = 0; i < n; i++) {
        const supermat_tensor_info *ti = sm_pth_tensor(p, i);
        size_t ne = ti->nbytes / 4, j;
        float *x = (float *)malloc(ti->nbytes + 4);
        long long sh[8];
        int k;
        sm_pth_read(p, i, x, err, sizeof err);
        h[i] = (uint16_t *)malloc(ne * 2 + 2);
        for (j = 0; j < ne; j++) h[i][j] = tc_ref_f16(x[j]);
        free(x);
        s[i].data = h[i];
        s[i].numel = (long long)ne;
        s[i].dt = 1;
        for (k = 0; k < ti->ndim; k++) sh[k] = ti->shape[k];
        tw_contig(&t[i], ti->name, i, 0, ti->ndim, sh);
    }
    memset(&o, 0, sizeof o);
    o.zip64 = 1;
    /* tw_save keeps up to 38 entries: write in a loop of our own instead for the full checkpoint */
    {
        tc_buf z, pk;
        tw_entry *e = (tw_entry *)calloc((size_t)n + 3, sizeof *e);
        int ne = 0;
        uint64_t cd_off, cd_size, z64_off;
        memset(&z, 0, sizeof z);
        memset(&pk, 0, sizeof pk);
        tw_pickle(&pk, t, n, s, &o);
        tw_add(&z, &e[ne++], "archive/data.pkl", pk.p, pk.n, &o, 0);
        for (i = 0; i < n; i++) {
            char nm[64];
            snprintf(nm, sizeof nm, "archive/data/%d", i);
            tw_add(&z, &e[ne++], nm, s[i].data, (size_t)s[i].numel * 2, &o, 0);
        }
        cd_off = z.n;
        for (i = 0; i < ne; i++) {
            size_t nl = strlen(e[i].name);
            tc_u32(&z, 0x02014b50u); tc_u16(&z, 45); tc_u16(&z, 45); tc_u16(&z, 0x0808); tc_u16(&z, 0); tc_u16(&z, 0); tc_u16(&z, 0x21);
            tc_u32(&z, e[i].crc); tc_u32(&z, 0xFFFFFFFFu); tc_u32(&z, 0xFFFFFFFFu); tc_u16(&z, (unsigned)nl); tc_u16(&z, 28);
            tc_u16(&z, 0); tc_u16(&z, 0); tc_u16(&z, 0); tc_u32(&z, 0); tc_u32(&z, 0xFFFFFFFFu);
            tc_put(&z, e[i].name, nl);
            tc_u16(&z, 1); tc_u16(&z, 24); tc_u64(&z, e[i].size); tc_u64(&z, e[i].size); tc_u64(&z, e[i].lho);
        }
        cd_size = z.n - cd_off;
        z64_off = z.n;
        tc_u32(&z, 0x06064b50u); tc_u64(&z, 44); tc_u16(&z, 45); tc_u16(&z, 45); tc_u32(&z, 0); tc_u32(&z, 0);
        tc_u64(&z, (uint64_t)ne); tc_u64(&z, (uint64_t)ne); tc_u64(&z, cd_size); tc_u64(&z, cd_off);
        tc_u32(&z, 0x07064b50u); tc_u32(&z, 0); tc_u64(&z, z64_off); tc_u32(&z, 1);
        tc_u32(&z, 0x06054b50u); tc_u16(&z, 0); tc_u16(&z, 0); tc_u16(&z, 0xFFFF); tc_u16(&z, 0xFFFF);
        tc_u32(&z, 0xFFFFFFFFu); tc_u32(&z, 0xFFFFFFFFu); tc_u16(&z, 0);
        f = z.p;
        size = z.n;
        free(pk.p);
        free(e);
    }
    snprintf(pth, sizeof pth, TMP "/supermat_f16_zip64.pth");
    snprintf(out, sizeof out, TMP "/from_f16.safetensors");
    TU_CHECK(tc_write(pth, f, size) == 0, "write %s", pth);
    tc_track(pth);
    free(f);
    r = tc_convert("supermat", pth, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r == 0, "F16 zip64 checkpoint: %s", err);
    tc_track(out);
    if (r == 0 && tc_st_load(&st, out) == 0) {
        int bad = 0;
        for (i = 0; i < n; i++) {
            char dt[8];
            long long sh[8];
            int nd;
            const unsigned char *d;
            size_t nb;
            if (tc_st_get(&st, t[i].name, dt, sh, &nd, &d, &nb) || strcmp(dt, "F16") || nb != (size_t)s[i].numel * 2 || memcmp(d, h[i], nb)) bad++;
        }
        TU_CHECK(bad == 0, "F16 zip64 checkpoint: %d tensors differ", bad);
        tc_st_free(&st);
    }
    /* and widened back to F32 */
    r = tc_convert("supermat", pth, base, out, SUPERMAT_DTYPE_F32, err, sizeof err);
    TU_CHECK(r == 0, "F16 -> F32: %s", err);
    if (r == 0 && tc_st_load(&st, out) == 0) {
        int bad = 0;
        for (i = 0; i < n; i++) {
            char dt[8];
            long long sh[8], j;
            int nd;
            const unsigned char *d;
            size_t nb;
            if (tc_st_get(&st, t[i].name, dt, sh, &nd, &d, &nb) || strcmp(dt, "F32") || nb != (size_t)s[i].numel * 4) { bad++; continue; }
            for (j = 0; j < s[i].numel; j++) {
                float fv;
                memcpy(&fv, d + 4 * j, 4);
                if ((double)fv != tc_f16_value(h[i][j])) { bad++; break; }
            }
        }
        TU_CHECK(bad == 0, "F16 -> F32: %d tensors differ", bad);
        tc_st_free(&st);
    }
    for (i = 0; i < n; i++) free(h[i]);
    free(h);
    free(s);
    free(t);
    sm_pth_close(p);
    printf("  an F16, zip64 re-save of the checkpoint converts (kept F16, and widened to F32)\n");
}

/* ---- 4. the text encoder --------------------------------------------------------------------- */
static void test_text_encoder(const char *base) {
    float *c1 = NULL, *c2 = NULL;
    int t1, d1, t2, d2, r1, r2;
    char err[512];
    r1 = sm_text_encode_empty(base, 1, 0, &c1, &t1, &d1, err, sizeof err);
    TU_CHECK(r1 == 0, "text encoder: %s", err);
    r2 = sm_text_encode_empty(base, 2, 0, &c2, &t2, &d2, err, sizeof err);
    TU_CHECK(r2 == 0, "text encoder (2 threads): %s", err);
    if (!r1 && !r2) TU_CHECK(t1 == t2 && d1 == d2 && !memcmp(c1, c2, sizeof(float) * (size_t)t1 * d1), "1 and 2 threads differ");
    free(c1);
    free(c2);
}

/* a base folder copy under TMP, optionally without one file and with an edited UNet config */
static const char *const tc_base_files[] = {"unet/config.json", "vae/config.json", "vae/diffusion_pytorch_model.safetensors", "text_encoder/config.json",
                                            "text_encoder/model.safetensors", "scheduler/scheduler_config.json", "empty_prompt_embeds.npy", NULL};
static void tc_make_base(const char *base, const char *dst, const char *skip) {
    static const char *const dirs[] = {"unet", "vae", "text_encoder", "scheduler", "tokenizer", NULL};
    char a[600], b[600];
    int i;
    tc_mkdir_tracked(dst);
    for (i = 0; dirs[i]; i++) {
        snprintf(b, sizeof b, "%s/%s", dst, dirs[i]);
        tc_mkdir_tracked(b);
    }
    for (i = 0; tc_base_files[i]; i++) {
        if (skip && !strcmp(skip, tc_base_files[i])) continue;
        snprintf(a, sizeof a, "%s/%s", base, tc_base_files[i]);
        snprintf(b, sizeof b, "%s/%s", dst, tc_base_files[i]);
        tc_copy(a, b);
        tc_track(b);
    }
}

static void tc_write_text(const char *path, const char *text) {
    tc_write(path, text, strlen(text));
    tc_track(path);
}

/* the scheduler: what SuperMat was trained with, or a refusal naming scheduler_config.json */
static void test_scheduler(const char *dir, const char *base) {
    static const struct { const char *json, *needle; } bad[] = {
        {"{\"num_train_timesteps\": 1000, \"beta_schedule\": \"scaled_linear\", \"beta_start\": 0.00085, \"beta_end\": 0.012, \"prediction_type\": \"epsilon\"}", "epsilon"},
        {"{\"num_train_timesteps\": 1000, \"beta_schedule\": \"scaled_linear\", \"beta_start\": 0.00085, \"beta_end\": 0.012}", "absent"},
        {"{\"prediction_type\": \"sample\"}", "sample"},
        {"{\"prediction_type\": \"v_prediction\", \"clip_sample\": true}", "clip_sample"},
        {"{\"prediction_type\": \"v_prediction\", \"thresholding\": true}", "thresholding"},
        {"{\"prediction_type\": \"v_prediction\", \"rescale_betas_zero_snr\": true}", "rescale_betas_zero_snr"},
        {"{\"prediction_type\": \"v_prediction\", \"clip_sample\": 1}", "clip_sample"},
    };
    char dst[300], p[400], ck[700], out[300], err[512];
    int i, r;
    snprintf(dst, sizeof dst, TMP "/base_sched");
    tc_make_base(base, dst, NULL);
    snprintf(ck, sizeof ck, "%s/supermat.pth", dir);
    snprintf(p, sizeof p, "%s/scheduler/scheduler_config.json", dst);
    snprintf(out, sizeof out, TMP "/sched.safetensors");
    for (i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++) {
        tc_write_text(p, bad[i].json);
        remove(out);
        r = tc_convert("supermat", ck, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
        TU_CHECK(r != 0 && strstr(err, bad[i].needle) && strstr(err, "scheduler_config.json") && !tc_exists(out),
                 "scheduler %d (%s): r=%d '%s'", i, bad[i].needle, r, r ? err : "converted");
    }
    /* false flags and another timestep_spacing (the pipeline overrides it with trailing) convert */
    tc_write_text(p, "{\"prediction_type\": \"v_prediction\", \"clip_sample\": false, \"thresholding\": false, "
                     "\"rescale_betas_zero_snr\": false, \"timestep_spacing\": \"leading\", \"beta_schedule\": \"scaled_linear\", "
                     "\"beta_start\": 0.00085, \"beta_end\": 0.012, \"steps_offset\": 1, \"set_alpha_to_one\": false}");
    r = tc_convert("supermat", ck, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r == 0, "v_prediction scheduler: %s", err);
    tc_track(out);
}

/* weight file names as the Stable Diffusion 2.1 repository ships them, Git LFS pointers, a file as --base */
static void test_base_files(const char *dir, const char *base) {
    char dst[300], a[600], b[600], ck[700], out[300], err[512];
    int r;
    snprintf(ck, sizeof ck, "%s/supermat.pth", dir);
    snprintf(out, sizeof out, TMP "/files.safetensors");
    /* the VAE only as the fp16 variant diffusion_pytorch_model.fp16.safetensors: converts */
    snprintf(dst, sizeof dst, TMP "/base_fp16");
    tc_make_base(base, dst, "vae/diffusion_pytorch_model.safetensors");
    snprintf(a, sizeof a, "%s/vae/diffusion_pytorch_model.safetensors", base);
    snprintf(b, sizeof b, "%s/vae/diffusion_pytorch_model.fp16.safetensors", dst);
    tc_copy(a, b);
    tc_track(b);
    remove(out);
    r = tc_convert("supermat", ck, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r == 0, "VAE as diffusion_pytorch_model.fp16.safetensors only: %s", err);
    tc_track(out);
    /* both: the full-precision non-variant file is the one read (the variant here is not even a model) */
    snprintf(b, sizeof b, "%s/vae/diffusion_pytorch_model.fp16.safetensors", dst);
    tc_write_text(b, "not a model");
    snprintf(b, sizeof b, "%s/vae/diffusion_pytorch_model.safetensors", dst);
    tc_copy(a, b);
    tc_track(b);
    remove(out);
    r = tc_convert("supermat", ck, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r == 0, "non-variant preferred over the fp16 variant: %s", err);
    /* none: the message lists every name tried */
    remove(b);
    snprintf(b, sizeof b, "%s/vae/diffusion_pytorch_model.fp16.safetensors", dst);
    remove(b);
    remove(out);
    r = tc_convert("supermat", ck, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r != 0 && strstr(err, "diffusion_pytorch_model.safetensors") && strstr(err, "diffusion_pytorch_model.bin") &&
             strstr(err, "diffusion_pytorch_model.fp16.safetensors") && strstr(err, "diffusion_pytorch_model.fp16.bin"),
             "no VAE weights: r=%d '%s'", r, err);
    /* a Git LFS pointer where the weights should be, and as the checkpoint */
    snprintf(b, sizeof b, "%s/vae/diffusion_pytorch_model.safetensors", dst);
    tc_write_text(b, "version https://git-lfs.github.com/spec/v1\noid sha256:0123\nsize 334643276\n");
    r = tc_convert("supermat", ck, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r != 0 && strstr(err, "Git LFS pointer") && strstr(err, "diffusion_pytorch_model.safetensors"), "LFS VAE: r=%d '%s'", r, err);
    snprintf(b, sizeof b, TMP "/lfs.pth");
    tc_write_text(b, "version https://git-lfs.github.com/spec/v1\noid sha256:0123\nsize 3455\n");
    r = tc_convert("supermat", b, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r != 0 && strstr(err, "Git LFS pointer") && strstr(err, "lfs.pth"), "LFS checkpoint: r=%d '%s'", r, err);
    /* a VAE without one tensor the architecture needs: refused at convert time, naming it (the
       runtime's loader reads the written file back before it is renamed into place) */
    {
        size_t n = 0, hl, k0, k1;
        unsigned char *v;
        char *h, *key;
        snprintf(a, sizeof a, "%s/vae/diffusion_pytorch_model.safetensors", base);
        v = tu_load(a, &n);
        TU_CHECK(v && n > 8, "cannot read %s", a);
        if (v && n > 8) {
            hl = (size_t)v[0] | ((size_t)v[1] << 8) | ((size_t)v[2] << 16) | ((size_t)v[3] << 24);
            h = (char *)malloc(hl + 1);
            memcpy(h, v + 8, hl);
            h[hl] = 0;
            key = strstr(h, "\"decoder.mid_block.attentions.0.to_q.weight\"");
            TU_CHECK(key != NULL, "the tiny VAE has no decoder.mid_block.attentions.0.to_q.weight");
            if (key) {  /* cut the entry  "name":{...},  and pad the header with spaces to its old length */
                k0 = (size_t)(key - h);
                k1 = (size_t)(strchr(key, '}') - h) + 1;
                if (h[k1] == ',') k1++;
                else if (k0 > 0 && h[k0 - 1] == ',') k0--;
                memmove(h + k0, h + k1, hl + 1 - k1);
                memset(h + hl - (k1 - k0), ' ', k1 - k0);
                memcpy(v + 8, h, hl);
                snprintf(b, sizeof b, "%s/vae/diffusion_pytorch_model.safetensors", dst);
                tc_write(b, v, n);
                tc_track(b);
                remove(out);
                r = tc_convert("supermat", ck, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
                TU_CHECK(r != 0 && strstr(err, "decoder.mid_block.attentions.0.to_q.weight") && !tc_exists(out),
                         "a VAE without a tensor: r=%d '%s'", r, err);
                snprintf(b, sizeof b, "%s.tmp", out);
                TU_CHECK(!tc_exists(b), "a refused conversion left %s", b);
            }
            free(h);
        }
        free(v);
    }
    /* a single-file checkpoint given as --base */
    snprintf(b, sizeof b, TMP "/v2-1_768-ema-pruned.safetensors");
    tc_write_text(b, "x");
    r = tc_convert("supermat", ck, b, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r != 0 && strstr(err, "single-file checkpoint") && strstr(err, "diffusers layout"), "--base a file: r=%d '%s'", r, err);
    TU_CHECK(!tc_exists(out), "a failed conversion left %s", out);
}

static void test_tokenizer(const char *base) {
    char dst[300], p[400], err[512];
    float *c0 = NULL, *c = NULL;
    int t, d, r;
    snprintf(dst, sizeof dst, TMP "/base_tok");
    tc_make_base(base, dst, NULL);
    r = sm_text_encode_empty(base, 1, 0, &c0, &t, &d, err, sizeof err);
    TU_CHECK(r == 0, "%s", err);
    snprintf(p, sizeof p, "%s/tokenizer/vocab.json", dst);
    tc_write_text(p, "{\"!\": 0, \"\\\"\": 1, \"<|startoftext|>\": 49406, \"<|endoftext|>\": 49407}");
    snprintf(p, sizeof p, "%s/tokenizer/special_tokens_map.json", dst);
    tc_write_text(p, "{\"bos_token\": \"<|startoftext|>\", \"eos_token\": {\"content\": \"<|endoftext|>\", \"lstrip\": false}, \"pad_token\": \"!\"}");
    r = sm_text_encode_empty(dst, 1, 0, &c, &t, &d, err, sizeof err);
    TU_CHECK(r == 0 && c0 && c && !memcmp(c, c0, sizeof(float) * (size_t)t * d), "tokenizer/ with the SD 2.1 ids: %s", r ? err : "different context");
    free(c);
    c = NULL;
    /* the Stable Diffusion 2.1 repository's own conflict: special_tokens_map.json says pad "!", its
       tokenizer_config.json says pad "<|endoftext|>"; transformers lets special_tokens_map.json win */
    {
        char q[400];
        snprintf(q, sizeof q, "%s/tokenizer/tokenizer_config.json", dst);
        tc_write_text(q, "{\"bos_token\": {\"content\": \"<|startoftext|>\"}, \"eos_token\": {\"content\": \"<|endoftext|>\"}, "
                         "\"pad_token\": \"<|endoftext|>\", \"model_max_length\": 77}");
        r = sm_text_encode_empty(dst, 1, 0, &c, &t, &d, err, sizeof err);
        TU_CHECK(r == 0 && c0 && c && !memcmp(c, c0, sizeof(float) * (size_t)t * d),
                 "pad '!' in special_tokens_map.json over '<|endoftext|>' in tokenizer_config.json: %s", r ? err : "the eos-padded context");
        free(c);
        c = NULL;
        remove(q);
    }
    /* pad = eos (the Stable Diffusion 1.x tokenizer): a different context */
    tc_write_text(p, "{\"bos_token\": \"<|startoftext|>\", \"eos_token\": \"<|endoftext|>\", \"pad_token\": \"<|endoftext|>\"}");
    r = sm_text_encode_empty(dst, 1, 0, &c, &t, &d, err, sizeof err);
    TU_CHECK(r == 0 && c0 && c && memcmp(c + 2 * d, c0 + 2 * d, sizeof(float) * (size_t)d) != 0, "pad = eos: %s", r ? err : "same context");
    free(c);
    c = NULL;
    /* a pad token that is not in the vocabulary */
    tc_write_text(p, "{\"pad_token\": \"<pad>\"}");
    r = sm_text_encode_empty(dst, 1, 0, &c, &t, &d, err, sizeof err);
    TU_CHECK(r != 0 && c == NULL && strstr(err, "<pad>") && strstr(err, "vocab.json"), "unknown pad token: %d %s", r, err);
    free(c0);
}

/* ---- 5. error paths of sm_convert ------------------------------------------------------------ */
static void tc_expect_fail(int r, const char *err, const char *out, const char *what, const char *needle) {
    char tmp[400];
    snprintf(tmp, sizeof tmp, "%s.tmp", out);
    TU_CHECK(r != 0, "%s: conversion succeeded", what);
    TU_CHECK(!needle || strstr(err, needle), "%s: message '%s' does not mention '%s'", what, err, needle);
    TU_CHECK(!tc_exists(out) && !tc_exists(tmp), "%s: output or .tmp left behind", what);
}

static void test_errors(const char *dir, const char *base) {
    char err[512], s[512], mv[512], uv[512], out[300], dst[300], p[400];
    int r, i;
    size_t n;
    unsigned char *f;
    snprintf(s, sizeof s, "%s/supermat.pth", dir);
    snprintf(mv, sizeof mv, "%s/supermat_mv.pth", dir);
    snprintf(uv, sizeof uv, "%s/uv_refine_bc.pth", dir);
    snprintf(out, sizeof out, TMP "/bad.safetensors");
    remove(out);
    /* wrong kinds */
    r = tc_convert("supermat", mv, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    tc_expect_fail(r, err, out, "MV checkpoint as supermat", "class_embedding");
    r = tc_convert("supermat-mv", s, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    tc_expect_fail(r, err, out, "single-view checkpoint as supermat-mv", "class_embedding.linear_1.weight");
    r = tc_convert("uv-refine", s, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    tc_expect_fail(r, err, out, "supermat as uv-refine", "rep_conv_in.0.weight");
    r = tc_convert("supermat", uv, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    tc_expect_fail(r, err, out, "uv-refine as supermat", "rep_conv_in.0.weight");
    r = tc_convert("supermat-v2", s, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    tc_expect_fail(r, err, out, "unknown kind", "supermat-v2");
    r = tc_convert("supermat", s, base, out, (supermat_dtype)7, err, sizeof err);
    tc_expect_fail(r, err, out, "bad dtype", "dtype");
    r = sm_convert(NULL, err, sizeof err);
    TU_CHECK(r != 0, "NULL desc");
    /* a base file missing, one at a time */
    for (i = 0; tc_base_files[i]; i++) {
        if (!strcmp(tc_base_files[i], "empty_prompt_embeds.npy")) continue;
        snprintf(dst, sizeof dst, TMP "/base_missing%d", i);
        tc_make_base(base, dst, tc_base_files[i]);
        r = tc_convert("supermat", s, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
        snprintf(p, sizeof p, "missing %s", tc_base_files[i]);
        tc_expect_fail(r, err, out, p, tc_base_files[i]);
    }
    /* a base whose UNet config disagrees with the checkpoint */
    snprintf(dst, sizeof dst, TMP "/base_cross");
    tc_make_base(base, dst, NULL);
    snprintf(p, sizeof p, "%s/unet/config.json", dst);
    f = tu_load(p, &n);
    if (f) {
        char *txt = (char *)malloc(n + 1), *q;
        memcpy(txt, f, n);
        txt[n] = 0;
        q = strstr(txt, "\"cross_attention_dim\": 32");
        TU_CHECK(q != NULL, "unet config layout");
        if (q) {
            q[23] = '6'; q[24] = '4'; /* 64 */
            tc_write(p, txt, n);
            r = tc_convert("supermat", s, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
            tc_expect_fail(r, err, out, "cross_attention_dim mismatch", "attn2.to_k.weight");
            q[23] = '3'; q[24] = '2';
            q = strstr(txt, "\"in_channels\": 4");
            if (q) {
                q[15] = '9';
                tc_write(p, txt, n);
                r = tc_convert("supermat", s, dst, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
                tc_expect_fail(r, err, out, "in_channels mismatch", "conv_in.weight");
            }
        }
        free(txt);
        free(f);
    }
    /* truncated and corrupted checkpoints through the whole conversion */
    f = tu_load(s, &n);
    if (f) {
        static const double at[] = {0.0, 0.001, 0.3, 0.9, 0.995, 0.9999};
        char bad[300];
        snprintf(bad, sizeof bad, TMP "/broken.pth");
        tc_track(bad);
        for (i = 0; i < (int)(sizeof at / sizeof at[0]); i++) {
            tc_write(bad, f, (size_t)(at[i] * (double)n));
            r = tc_convert("supermat", bad, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
            tc_expect_fail(r, err, out, "truncated checkpoint", "broken.pth");
        }
        /* a flipped bit in the last tensor's data: found by the CRC while streaming, nothing left behind */
        {
            size_t k = n;
            while (k > 4 && tc_rd32(f + k - 4) != 0x06054b50u) k--;
            /* the last storage entry ends shortly before the central directory */
            k = tc_rd32(f + k - 4 + 16);
            f[k - 200] ^= 0x10;
            tc_write(bad, f, n);
            r = tc_convert("supermat", bad, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
            tc_expect_fail(r, err, out, "corrupt tensor data", "CRC");
            f[k - 200] ^= 0x10;
        }
        free(f);
    }
    /* an output folder that does not exist */
    r = tc_convert("supermat", s, base, TMP "/no/such/dir/x.safetensors", SUPERMAT_DTYPE_DEFAULT, err, sizeof err);
    TU_CHECK(r != 0 && strstr(err, "no/such/dir"), "unwritable output: %s", err);
}

/* sm_pipeline_header's work size on hand-made files (tc_ws_header): the value replaced, added where absent, the header kept at its length
   or grown by 64 bytes, the data offset, and every malformed header refused with a message */
static int tc_has(const unsigned char *p, size_t n, const char *s) { /* s in p[0..n), p not NUL-terminated */
    size_t k = strlen(s), i;
    for (i = 0; i + k <= n; i++) if (!memcmp(p + i, s, k)) return 1;
    return 0;
}
static void tc_ws_file(tc_buf *b, const char *json, size_t pad_to, const char *data) {
    size_t n = strlen(json);
    b->n = 0;
    tc_u64(b, (uint64_t)(n > pad_to ? n : pad_to));
    tc_str(b, json);
    while (n++ < pad_to) tc_u8(b, ' ');
    tc_str(b, data);
}
/* sm_pipeline_header with the work size alone (the other keys kept) */
static int tc_ws_header(const void *f, size_t n, int ws, unsigned char **h, size_t *hs, size_t *off, char *err, size_t cap) {
    sm_pipeline_edit e;
    e.work_size = ws;
    e.detail_sigma = e.chroma_weight = e.bake_detail_sigma = -1.0f;
    e.roughness_curve = e.metallic_curve = NULL;
    return sm_pipeline_header(f, n, &e, h, hs, off, err, cap);
}
static void test_work_size_header(void) {
    static const char *const meta = "{\"__metadata__\":{\"supermat.format_version\":\"1\",\"pipeline.work_size\":\"128\"},"
                                    "\"t\":{\"dtype\":\"F32\",\"shape\":[1],\"data_offsets\":[0,4]}}";
    static const char *const nokey = "{\"__metadata__\":{\"supermat.format_version\":\"1\"},"
                                     "\"t\":{\"dtype\":\"F32\",\"shape\":[1],\"data_offsets\":[0,4]}}";
    tc_buf b;
    unsigned char *h = NULL;
    size_t hs = 0, off = 0, len;
    char err[512], v[32];
    int r, i;
    memset(&b, 0, sizeof b);
    tc_ws_file(&b, meta, 128, "DATA");
    len = b.n;
    r = tc_ws_header(b.p, b.n, 256, &h, &hs, &off, err, sizeof err);
    TU_CHECK(r == 0 && hs == 136 && off == 136, "same-length value: r %d, header %zu bytes, data at %zu: %s", r, hs, off, err);
    if (!r) {
        tc_buf o;
        memset(&o, 0, sizeof o);
        tc_put(&o, h, hs);
        tc_put(&o, b.p + off, len - off);
        TU_CHECK(supermat_safetensors_metadata(o.p, o.n, "pipeline.work_size", v, sizeof v) >= 0 && !strcmp(v, "256"), "value read back: '%s'", v);
        TU_CHECK(supermat_safetensors_metadata(o.p, o.n, "supermat.format_version", v, sizeof v) >= 0 && !strcmp(v, "1"), "other metadata kept");
        TU_CHECK(memcmp(o.p + o.n - 4, "DATA", 4) == 0, "the data after the header as it was");
        free(o.p);
    }
    free(h); h = NULL;
    r = tc_ws_header(b.p, b.n, 8, &h, &hs, &off, err, sizeof err); /* shorter: padded back to the same length */
    TU_CHECK(r == 0 && hs == 136 && h && h[8 + 127] == ' ', "shorter value: r %d, header %zu bytes", r, hs);
    free(h); h = NULL;
    r = tc_ws_header(b.p, b.n, -1, &h, &hs, &off, err, sizeof err); /* none: recorded as 0 */
    TU_CHECK(r == 0 && h && tc_has(h + 8, hs - 8, "\"pipeline.work_size\":\"0\""), "native records 0: %s", err);
    free(h); h = NULL;
    tc_ws_file(&b, meta, strlen(meta), "DATA"); /* no padding: a longer value grows the header by 64 bytes */
    r = tc_ws_header(b.p, b.n, 16384, &h, &hs, &off, err, sizeof err);
    TU_CHECK(r == 0 && hs == strlen(meta) + 64 + 8 && off == strlen(meta) + 8, "longer value: r %d, header %zu bytes (want %zu)", r, hs, strlen(meta) + 72);
    free(h); h = NULL;
    tc_ws_file(&b, nokey, 0, "DATA"); /* the key absent and no padding: added, the header grown by 64 bytes */
    r = tc_ws_header(b.p, b.n, 256, &h, &hs, &off, err, sizeof err);
    TU_CHECK(r == 0 && hs == 8 + strlen(nokey) + 64 && off == 8 + strlen(nokey), "key added, grown: r %d, header %zu bytes: %s", r, hs, err);
    free(h); h = NULL;
    tc_ws_file(&b, nokey, 128, "DATA"); /* with 27 bytes of padding: the 27 bytes of the key take its place */
    r = tc_ws_header(b.p, b.n, 256, &h, &hs, &off, err, sizeof err);
    TU_CHECK(r == 0 && hs == 8 + 128 && off == 136, "key added in the padding: r %d, header %zu bytes: %s", r, hs, err);
    if (!r) {
        tc_buf o;
        memset(&o, 0, sizeof o);
        tc_put(&o, h, hs);
        tc_put(&o, b.p + off, b.n - off);
        TU_CHECK(supermat_safetensors_metadata(o.p, o.n, "pipeline.work_size", v, sizeof v) >= 0 && !strcmp(v, "256"), "added value read back: '%s'", v);
        TU_CHECK(supermat_safetensors_metadata(o.p, o.n, "supermat.format_version", v, sizeof v) >= 0 && !strcmp(v, "1"), "format_version kept after the added key");
        free(o.p);
    }
    free(h); h = NULL;
    {   /* refusals: each returns an error, a message, and no header */
        static const char *const bad[] = {
            "{\"__metadata__\":{\"pipeline.work_size\":\"128\"}}",                                  /* not a supermat file */
            "{\"t\":{\"dtype\":\"F32\",\"shape\":[1],\"data_offsets\":[0,4]}}",                      /* no metadata */
            "{\"__metadata__\":{\"supermat.format_version\":\"1\",\"pipeline.work_size\":128}}",     /* not a string */
            "{\"__metadata__\":{\"supermat.format_version\":\"1\"",                                 /* cut JSON */
            "[1,2,3]",                                                                               /* not an object */
            "{\"__metadata__\":[]}",
        };
        for (i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++) {
            tc_ws_file(&b, bad[i], 0, "DATA");
            err[0] = 0;
            r = tc_ws_header(b.p, b.n, 256, &h, &hs, &off, err, sizeof err);
            TU_CHECK(r < 0 && err[0] && !h, "bad header %d refused: r %d, '%s'", i, r, err);
            free(h); h = NULL;
        }
        tc_ws_file(&b, meta, 128, "DATA");
        for (i = 0; i < 3; i++) {  /* bad work sizes */
            static const int ws[3] = {0, 12, 16392};
            r = tc_ws_header(b.p, b.n, ws[i], &h, &hs, &off, err, sizeof err);
            TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && !h, "work size %d refused: r %d", ws[i], r);
            free(h); h = NULL;
        }
        for (len = 0; len < 8 + 128; len += 7) { /* every cut inside the length or the header */
            r = tc_ws_header(b.p, len, 256, &h, &hs, &off, err, sizeof err);
            TU_CHECK(r < 0 && !h, "a file cut at %zu bytes refused: r %d", len, r);
            free(h); h = NULL;
        }
        b.p[7] = 0x7f; /* a length beyond the file */
        r = tc_ws_header(b.p, b.n, 256, &h, &hs, &off, err, sizeof err);
        TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE && !h, "a length beyond the file refused: r %d", r);
        free(h); h = NULL;
    }
    free(b.p);
}

/* sm_pipeline_header's detail, colour and bake detail keys on hand-made files: set, replaced, added in the
   converter's order, removed (with one comma), every other byte of the header kept (spaces between members
   too), and the refusals. tc_peb: `in` (the metadata members) padded to `pad` bytes, rewritten; `want` the
   members expected, NULL = refused; tc_pe: the bake detail kept */
#define TC_PE_HEAD "{\"__metadata__\":{"
#define TC_PE_TAIL "},\"t\":{\"dtype\":\"F32\",\"shape\":[1],\"data_offsets\":[0,4]}}"
static const char *tc_pe_curve, *tc_pe_mcurve; /* sm_pipeline_edit.roughness_curve / metallic_curve of the tc_peb cases (NULL: kept) */
static void tc_peb(const char *what, const char *in, size_t pad, int ws, float det, float chr, float bake, const char *want) {
    tc_buf b;
    sm_pipeline_edit e;
    unsigned char *h = NULL;
    size_t hs = 0, off = 0, jl, inl;
    char js[1024], wj[1024], err[512];
    int r;
    memset(&b, 0, sizeof b);
    snprintf(js, sizeof js, TC_PE_HEAD "%s" TC_PE_TAIL, in);
    inl = strlen(js);
    tc_ws_file(&b, js, pad, "DATA");
    e.work_size = ws;
    e.detail_sigma = det;
    e.chroma_weight = chr;
    e.bake_detail_sigma = bake;
    e.roughness_curve = tc_pe_curve;
    e.metallic_curve = tc_pe_mcurve;
    err[0] = 0;
    r = sm_pipeline_header(b.p, b.n, &e, &h, &hs, &off, err, sizeof err);
    if (!want) {
        TU_CHECK(r < 0 && err[0] && !h, "%s: refused with a message: r %d, '%s'", what, r, err);
    } else if (r != 0 || !h) {
        TU_CHECK(0, "%s: r %d, '%s'", what, r, err);
    } else {
        snprintf(wj, sizeof wj, TC_PE_HEAD "%s" TC_PE_TAIL, want);
        jl = hs - 8;
        while (jl > 0 && h[8 + jl - 1] == ' ') jl--;
        TU_CHECK(jl == strlen(wj) && !memcmp(h + 8, wj, jl), "%s: header\n  %.*s\nexpected\n  %s", what, (int)jl, (const char *)h + 8, wj);
        TU_CHECK(off == 8 + (inl > pad ? inl : pad), "%s: the data at %zu", what, off);
        TU_CHECK(hs >= off && (hs - off) % 64 == 0 && (hs - off <= 64 || hs - off < strlen(wj) - inl + 64), "%s: the header kept at its length or grown by 64 bytes (%zu -> %zu)", what, off, hs);
        if (!memcmp(h + 8, wj, jl < strlen(wj) ? jl : strlen(wj))) { /* the file written reads back */
            tc_buf o;
            char v[64];
            memset(&o, 0, sizeof o);
            tc_put(&o, h, hs);
            tc_put(&o, b.p + off, b.n - off);
            TU_CHECK(supermat_safetensors_metadata(o.p, o.n, "supermat.format_version", v, sizeof v) == 0 && !strcmp(v, "1") &&
                     memcmp(o.p + o.n - 4, "DATA", 4) == 0, "%s: the file written reads back", what);
            free(o.p);
        }
    }
    free(h);
    free(b.p);
}
static void tc_pe(const char *what, const char *in, size_t pad, int ws, float det, float chr, const char *want) {
    tc_peb(what, in, pad, ws, det, chr, -1.0f, want);
}
static void test_pipeline_header(void) {
#define FV "\"supermat.format_version\":\"1\""
#define KD "\"supermat.kind\":\"supermat\""
#define WS "\"pipeline.work_size\":\"256\""
#define DS "\"pipeline.detail_sigma\":\"0.015625\""
#define CW "\"pipeline.chroma_weight\":\"1\""
#define BD "\"pipeline.bake_detail_sigma\":\"0.03125\""
#define UX "\"unet.x\":\"1\""
    static const char *const base = FV "," KD "," WS "," UX, *both = FV "," KD "," WS "," DS "," CW "," UX;
    const float kept = -1.0f;
    tc_pe("detail added after the work size", base, 256, 0, 1.0f / 64, kept, FV "," KD "," WS "," DS "," UX);
    tc_pe("both added in the converter's order", base, 256, 0, 1.0f / 64, 1.0f, both);
    tc_pe("both added, no padding: grown by 64 bytes", base, 0, 0, 1.0f / 64, 1.0f, both);
    tc_pe("colour added after the work size", base, 256, 0, kept, 1.0f, FV "," KD "," WS "," CW "," UX);
    tc_pe("both removed: the original bytes", both, 256, 0, 0.0f, 0.0f, base);
    tc_pe("detail removed", both, 256, 0, 0.0f, kept, FV "," KD "," WS "," CW "," UX);
    tc_pe("colour removed", both, 256, 0, kept, 0.0f, FV "," KD "," WS "," DS "," UX);
    tc_pe("the work size alone: the steps kept", both, 256, 512, kept, kept, FV "," KD ",\"pipeline.work_size\":\"512\"," DS "," CW "," UX);
    tc_pe("detail replaced in place", both, 256, 0, 0.5f, kept, FV "," KD "," WS ",\"pipeline.detail_sigma\":\"0.5\"," CW "," UX);
    tc_pe("all three at once", both, 256, -1, 0.25f, 0.0f, FV "," KD ",\"pipeline.work_size\":\"0\",\"pipeline.detail_sigma\":\"0.25\"," UX);
    tc_pe("a value as printf %.9g of the float", base, 256, 0, 1.0f / 3, kept, FV "," KD "," WS ",\"pipeline.detail_sigma\":\"0.333333343\"," UX);
    tc_pe("removing an absent key changes nothing", base, 256, 0, 0.0f, 0.0f, base);
    tc_pe("no pipeline key: added first", FV ",\"x\":\"2\"", 256, 0, kept, 1.0f, CW "," FV ",\"x\":\"2\"");
    tc_pe("added before the colour key", FV "," CW ",\"x\":\"2\"", 256, 64, 0.25f, kept,
          FV ",\"pipeline.work_size\":\"64\",\"pipeline.detail_sigma\":\"0.25\"," CW ",\"x\":\"2\"");
    tc_pe("the spaces between the members kept", " " FV " ,  \"pipeline.detail_sigma\" : \"0.5\" , \"x\" : \"2\" ", 256, 0, 0.0f, kept,
          " " FV " ,  \"x\" : \"2\" ");
    tc_pe("the spaces around a replaced value kept", FV ", \"pipeline.detail_sigma\" :  \"0.5\"", 256, 0, 1.0f, kept,
          FV ", \"pipeline.detail_sigma\" :  \"1\"");
    tc_pe("the first member removed", CW ", " FV, 256, 0, kept, 0.0f, FV);
    tc_pe("the last member removed", FV "," CW, 256, 0, kept, 0.0f, FV);
    tc_pe("an object value kept", FV ",\"o\":{\"a\":[1,2]}," DS, 256, 0, 0.0f, kept, FV ",\"o\":{\"a\":[1,2]}");
    tc_pe("a uv-refine file: no detail step", FV ",\"supermat.kind\":\"uv-refine\"", 256, 0, 0.5f, kept, NULL);
    tc_pe("a uv-refine file: no colour step", FV ",\"supermat.kind\":\"uv-refine\"", 256, 0, kept, 1.0f, NULL);
    tc_pe("a uv-refine file: a step removed", FV ",\"supermat.kind\":\"uv-refine\"," CW, 256, 0, kept, 0.0f, FV ",\"supermat.kind\":\"uv-refine\"");
    tc_pe("detail 2 refused", base, 256, 0, 2.0f, kept, NULL);
    tc_pe("colour 1.5 refused", base, 256, 0, kept, 1.5f, NULL);
    tc_pe("a NaN refused", base, 256, 0, (float)(0.0 * HUGE_VAL), kept, NULL);
    tc_pe("nothing to rewrite refused", base, 256, 0, kept, kept, NULL);
    tc_pe("a key twice refused", FV "," DS "," DS, 256, 0, 0.5f, kept, NULL);
    tc_pe("a number, not a string, refused", FV ",\"pipeline.detail_sigma\":0.5", 256, 0, 0.25f, kept, NULL);
    tc_pe("a number in a key not rewritten kept", FV ",\"pipeline.detail_sigma\":0.5", 256, 64, kept, kept, FV ",\"pipeline.work_size\":\"64\",\"pipeline.detail_sigma\":0.5");
    tc_pe("not a supermat file", "\"x\":\"1\"", 256, 0, 0.5f, kept, NULL);
    /* the bake detail: last in the converter's order */
    tc_peb("bake detail added after the colour", both, 256, 0, kept, kept, 1.0f / 32, FV "," KD "," WS "," DS "," CW "," BD "," UX);
    tc_peb("bake detail added after the work size", base, 256, 0, kept, kept, 1.0f / 32, FV "," KD "," WS "," BD "," UX);
    tc_peb("all four added in the converter's order", base, 0, 0, 1.0f / 64, 1.0f, 1.0f / 32, FV "," KD "," WS "," DS "," CW "," BD "," UX);
    tc_peb("bake detail replaced in place", FV "," KD "," WS "," BD "," UX, 256, 0, kept, kept, 0.25f,
           FV "," KD "," WS ",\"pipeline.bake_detail_sigma\":\"0.25\"," UX);
    tc_peb("bake detail removed", FV "," KD "," WS "," DS "," BD "," UX, 256, 0, kept, kept, 0.0f, FV "," KD "," WS "," DS "," UX);
    tc_peb("bake detail kept when the others change", FV "," KD "," WS "," BD "," UX, 256, 64, 0.5f, kept, kept,
           FV "," KD ",\"pipeline.work_size\":\"64\",\"pipeline.detail_sigma\":\"0.5\"," BD "," UX);
    tc_peb("bake detail alone is something to rewrite", base, 256, 0, kept, kept, 0.0f, base);
    tc_peb("a uv-refine file: no bake detail step", FV ",\"supermat.kind\":\"uv-refine\"", 256, 0, kept, kept, 1.0f / 32, NULL);
    tc_peb("bake detail 1.5 refused", base, 256, 0, kept, kept, 1.5f, NULL);
    tc_peb("a bake detail NaN refused", base, 256, 0, kept, kept, (float)(0.0 * HUGE_VAL), NULL);
    /* the roughness curve: last in the converter's order, written as the shortest text of each knot */
#define RC "\"pipeline.roughness_curve\":\"0.1,0.5,0.9\""
    tc_pe_curve = " 0.1, 0.50,0.9";
    tc_peb("roughness curve added after the bake detail", FV "," KD "," WS "," DS "," CW "," BD "," UX, 256, 0, kept, kept, kept,
           FV "," KD "," WS "," DS "," CW "," BD "," RC "," UX);
    tc_peb("roughness curve added after the work size", base, 256, 0, kept, kept, kept, FV "," KD "," WS "," RC "," UX);
    tc_peb("roughness curve replaced in place", FV "," KD "," WS ",\"pipeline.roughness_curve\":\"0,1\"," UX, 256, 0, kept, kept, kept,
           FV "," KD "," WS "," RC "," UX);
    tc_peb("a uv-refine file: no roughness curve", FV ",\"supermat.kind\":\"uv-refine\"", 256, 0, kept, kept, kept, NULL);
    tc_pe_curve = "";
    tc_peb("roughness curve removed", FV "," KD "," WS "," RC "," UX, 256, 0, kept, kept, kept, FV "," KD "," WS "," UX);
    tc_pe_curve = "0.9,0.1";
    tc_peb("a falling roughness curve refused", base, 256, 0, kept, kept, kept, NULL);
    tc_pe_curve = "0.5";
    tc_peb("a roughness curve of one knot refused", base, 256, 0, kept, kept, kept, NULL);
    tc_pe_curve = NULL;
    /* the metallic curve: after the roughness curve */
#define MC "\"pipeline.metallic_curve\":\"0,0.25,1\""
#define MC0 "\"pipeline.metallic_curve\":\"0,1\""
    tc_pe_mcurve = "0, 0.25 ,1.0";
    tc_peb("metallic curve added after the roughness curve", FV "," KD "," WS "," RC "," UX, 256, 0, kept, kept, kept,
           FV "," KD "," WS "," RC "," MC "," UX);
    tc_peb("metallic curve added after the bake detail", FV "," KD "," WS "," BD "," UX, 256, 0, kept, kept, kept,
           FV "," KD "," WS "," BD "," MC "," UX);
    tc_peb("metallic curve added right after the roughness curve, wherever it is", FV "," KD "," WS "," UX "," RC, 256, 0, kept, kept, kept,
           FV "," KD "," WS "," UX "," RC "," MC);
    tc_peb("metallic curve replaced in place", FV "," KD "," MC0 "," WS "," UX, 256, 0, kept, kept, kept, FV "," KD "," MC "," WS "," UX);
    tc_peb("a uv-refine file: no metallic curve", FV ",\"supermat.kind\":\"uv-refine\"", 256, 0, kept, kept, kept, NULL);
    tc_pe_curve = " 0.1, 0.50,0.9";
    tc_peb("both curves added in the converter's order", base, 256, 0, kept, kept, kept, FV "," KD "," WS "," RC "," MC "," UX);
    tc_pe_curve = "";
    tc_peb("roughness curve removed, metallic curve set", FV "," KD "," WS "," RC "," MC0 "," UX, 256, 0, kept, kept, kept, FV "," KD "," WS "," MC "," UX);
    tc_pe_curve = NULL;
    tc_pe_mcurve = "";
    tc_peb("metallic curve removed", FV "," KD "," WS "," RC "," MC "," UX, 256, 0, kept, kept, kept, FV "," KD "," WS "," RC "," UX);
    tc_peb("metallic curve removed alone is something to rewrite", base, 256, 0, kept, kept, kept, base);
    tc_pe_mcurve = "0.9,0.1";
    tc_peb("a falling metallic curve refused", base, 256, 0, kept, kept, kept, NULL);
    tc_pe_mcurve = "0,2";
    tc_peb("a metallic curve above 1 refused", base, 256, 0, kept, kept, kept, NULL);
    tc_pe_mcurve = NULL;
#undef MC
#undef MC0
#undef RC
#undef FV
#undef KD
#undef WS
#undef DS
#undef CW
#undef BD
#undef UX
}

/* the converter records pipeline.detail_sigma, pipeline.chroma_weight and pipeline.bake_detail_sigma only when
   they are on: without them the file has none of the keys, and its header is the one written with them less the
   three keys (every other byte, the tensors' too, the same); out of range, and a step for a uv-refine model,
   refused with nothing written */
static void test_convert_pipeline(const char *dir, const char *base) {
    sm_convert_desc d;
    tc_st w, o;
    char ck[600], err[512], v[64];
    const char *with = TMP "/pipe_with.safetensors", *without = TMP "/pipe_without.safetensors", *never = TMP "/pipe_never.safetensors";
    int r;
    snprintf(ck, sizeof ck, "%s/supermat.pth", dir);
    memset(&d, 0, sizeof d);
    d.kind = "supermat"; d.checkpoint = ck; d.base_dir = base; d.threads = 2;
    d.output = with; d.detail_sigma = 1.0f / 64; d.chroma_weight = 1.0f; d.bake_detail_sigma = 1.0f / 32;
    r = sm_convert(&d, err, sizeof err);
    TU_CHECK(r == 0, "convert with the detail and colour steps: %s", err);
    tc_track(with);
    d.output = without; d.detail_sigma = 0.0f; d.chroma_weight = 0.0f; d.bake_detail_sigma = 0.0f;
    r = sm_convert(&d, err, sizeof err);
    TU_CHECK(r == 0, "convert without them: %s", err);
    tc_track(without);
    if (tc_st_load(&w, with) == 0 && tc_st_load(&o, without) == 0) {
        static const char *const keys[3] = {",\"pipeline.detail_sigma\":\"0.015625\"", ",\"pipeline.chroma_weight\":\"1\"",
                                            ",\"pipeline.bake_detail_sigma\":\"0.03125\""};
        char *t = (char *)malloc((size_t)w.hl + 1), *p;
        size_t n, k, on = (size_t)o.hl;
        tc_expect_meta(&w, "pipeline.detail_sigma", "0.015625");
        tc_expect_meta(&w, "pipeline.chroma_weight", "1");
        tc_expect_meta(&w, "pipeline.bake_detail_sigma", "0.03125");
        tc_expect_meta(&w, "pipeline.work_size", "512");
        TU_CHECK(supermat_safetensors_metadata(o.b, o.n, "pipeline.detail_sigma", v, sizeof v) < 0, "without the options: no pipeline.detail_sigma");
        TU_CHECK(supermat_safetensors_metadata(o.b, o.n, "pipeline.chroma_weight", v, sizeof v) < 0, "without the options: no pipeline.chroma_weight");
        TU_CHECK(supermat_safetensors_metadata(o.b, o.n, "pipeline.bake_detail_sigma", v, sizeof v) < 0, "without the options: no pipeline.bake_detail_sigma");
        memcpy(t, w.b + 8, (size_t)w.hl);
        t[w.hl] = 0;
        for (k = 0; k < 3; k++) /* the three keys taken out of the text */
            if ((p = strstr(t, keys[k])) != NULL) memmove(p, p + strlen(keys[k]), strlen(p + strlen(keys[k])) + 1);
            else TU_CHECK(0, "the header with the steps lacks %s", keys[k]);
        n = strlen(t);
        while (n > 0 && t[n - 1] == ' ') n--;
        while (on > 0 && o.b[8 + on - 1] == ' ') on--;
        TU_CHECK(n == on && !memcmp(t, o.b + 8, n), "the header without the steps is the one with them less the three keys");
        TU_CHECK(w.n - 8 - w.hl == o.n - 8 - o.hl && !memcmp(w.b + 8 + w.hl, o.b + 8 + o.hl, (size_t)(o.n - 8 - o.hl)), "the tensor bytes the same with and without the steps");
        free(t);
    } else TU_CHECK(0, "cannot read %s and %s", with, without);
    tc_st_free(&w);
    tc_st_free(&o);
    /* refusals */
    d.output = never; d.detail_sigma = 2.0f; d.chroma_weight = 0.0f; d.bake_detail_sigma = 0.0f;
    err[0] = 0;
    r = sm_convert(&d, err, sizeof err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err, "detail_sigma") && !tc_exists(never), "detail 2 refused: r %d, '%s'", r, err);
    d.detail_sigma = 0.0f; d.chroma_weight = -1.0f;
    r = sm_convert(&d, err, sizeof err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err, "chroma_weight") && !tc_exists(never), "colour -1 refused: r %d, '%s'", r, err);
    d.chroma_weight = 0.0f; d.bake_detail_sigma = 1.5f;
    r = sm_convert(&d, err, sizeof err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err, "bake_detail_sigma") && !tc_exists(never), "bake detail 1.5 refused: r %d, '%s'", r, err);
    d.bake_detail_sigma = 0.0f;
    snprintf(ck, sizeof ck, "%s/uv_refine_bc.pth", dir);
    d.kind = NULL; d.checkpoint = ck; d.detail_sigma = 1.0f / 64; d.chroma_weight = 0.0f;
    r = sm_convert(&d, err, sizeof err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err, "uv-refine") && !tc_exists(never), "a detail step for uv-refine refused: r %d, '%s'", r, err);
    d.detail_sigma = 0.0f; d.bake_detail_sigma = 1.0f / 32;
    r = sm_convert(&d, err, sizeof err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err, "uv-refine") && strstr(err, "bake_detail_sigma") && !tc_exists(never),
             "a bake detail step for uv-refine refused: r %d, '%s'", r, err);
    tc_track(never);
}

int main(int argc, char **argv) {
    const char *data = argc > 1 ? argv[1] : "tests/data", *twins = argc > 2 ? argv[2] : NULL;
    char dir[400], base[450], ck[500], twin[500], out[300], err[512];
    static const struct { const char *kind, *file, *in_ch, *branches, *class_in; } kinds[3] = {
        {"supermat", "supermat", "4", "2", "0"}, {"supermat-mv", "supermat_mv", "4", "2", "16"}, {"uv-refine", "uv_refine_bc", "8", "1", "0"}};
    int k, r;
    clock_t t0;
    snprintf(dir, sizeof dir, "%s/tiny", data);
    snprintf(ck, sizeof ck, "%s/supermat.pth", dir);
    if (!tc_exists(ck)) snprintf(dir, sizeof dir, "%s", data);
    snprintf(base, sizeof base, "%s/base", dir);
    snprintf(ck, sizeof ck, "%s/supermat.pth", dir);
    if (!tc_exists(ck)) {
        printf("test_convert: no tiny models under %s\n", data);
        return 1;
    }
    tc_mkdir_tracked(TMP);

    printf("reader on hand-made checkpoints\n");
    test_reader_small();
    printf("work size rewritten (sm_pipeline_header)\n");
    test_work_size_header();
    printf("detail, colour and bake detail keys rewritten (sm_pipeline_header)\n");
    test_pipeline_header();
    printf("values against torch\n");
    test_known_values(dir);
    printf("truncation and corruption sweeps\n");
    test_sweeps(ck);
    printf("text encoder\n");
    test_text_encoder(base);
    test_tokenizer(base);
    printf("scheduler\n");
    test_scheduler(dir, base);
    printf("base folder files\n");
    test_base_files(dir, base);
    printf("conversions\n");
    for (k = 0; k < 3; k++) {
        double secs;
        snprintf(ck, sizeof ck, "%s/%s.pth", dir, kinds[k].file);
        snprintf(out, sizeof out, TMP "/%s.safetensors", kinds[k].file);
        t0 = clock();
        r = tc_convert(k == 1 ? NULL : kinds[k].kind, ck, base, out, SUPERMAT_DTYPE_DEFAULT, err, sizeof err); /* MV: kind detected */
        secs = (double)(clock() - t0) / CLOCKS_PER_SEC;
        TU_CHECK(r == 0, "%s: %s", kinds[k].kind, err);
        tc_track(out);
        if (r) continue;
        printf("  %s: converted in %.3f s CPU\n", kinds[k].kind, secs);
        snprintf(twin, sizeof twin, "%s/%s.safetensors", twins ? twins : dir, kinds[k].file);
        tc_check_output(out, ck, tc_exists(twin) ? twin : NULL, base, kinds[k].kind, SUPERMAT_DTYPE_DEFAULT, kinds[k].in_ch, kinds[k].branches, kinds[k].class_in);
        if (k == 0) { /* the model loads in the runtime */
            size_t n = 0;
            unsigned char *b = tu_load(out, &n);
            supermat_model_desc md;
            supermat_model *m = NULL;
            supermat_error e;
            memset(&md, 0, sizeof md);
            md.data = b;
            md.size = n;
            r = b ? supermat_model_create(&md, &m, &e) : -1;
            TU_CHECK(r == SUPERMAT_SUCCESS, "supermat_model_create on the converted file: %s", b ? e.message : "unreadable");
            if (m) supermat_model_destroy(m);
            free(b);
        }
    }
    printf("dtype conversion\n");
    for (k = 0; k < 2; k++) {
        supermat_dtype dt = k ? SUPERMAT_DTYPE_BF16 : SUPERMAT_DTYPE_F16;
        snprintf(ck, sizeof ck, "%s/supermat.pth", dir);
        snprintf(out, sizeof out, TMP "/supermat_%s.safetensors", k ? "bf16" : "f16");
        r = tc_convert("supermat", ck, base, out, dt, err, sizeof err);
        TU_CHECK(r == 0, "dtype %d: %s", (int)dt, err);
        tc_track(out);
        if (!r) tc_check_output(out, ck, NULL, base, "supermat", dt, "4", "2", "0");
    }
    snprintf(ck, sizeof ck, "%s/supermat.pth", dir);
    test_f16_zip64(ck, base);
    printf("pipeline keys recorded (detail, colour)\n");
    test_convert_pipeline(dir, base);
    printf("error paths\n");
    test_errors(dir, base);
    tc_cleanup();
    return tu_finish("test_convert");
}
