/* sm_convert.c - the SuperMat model converter: see sm_convert.h.
 *
 * Sections (search for the marker):
 *   >>platform   includes, 64-bit file offsets, error messages
 *   >>io         a byte source over a FILE or a memory image
 *   >>crc        CRC-32 (zip), slice-by-8
 *   >>zip        central directory reader (zip64 aware, STORED entries only)
 *   >>pickle     the pickle VM for the subset torch.save emits
 *   >>pth        sm_pth_*: checkpoint files (.pth zip, and .safetensors through supermat.h)
 *   >>json       config files
 *   >>half       F32 <-> F16 / BF16, round to nearest even
 *   >>clip       the CLIP text encoder, once, for the empty prompt
 *   >>writer     the safetensors writer and the model metadata
 *   >>convert    sm_convert
 *   >>pipeline   sm_pipeline_header: a converted file's pipeline.* metadata rewritten
 *   >>main       the stand-alone tool (SM_CONVERT_MAIN)
 */

/* >>platform */
#if !defined(_WIN32)
#ifndef _FILE_OFFSET_BITS
#define _FILE_OFFSET_BITS 64
#endif
#if !defined(_POSIX_C_SOURCE) && !defined(__APPLE__)
#define _POSIX_C_SOURCE 200809L
#endif
#if !defined(_XOPEN_SOURCE) && !defined(__APPLE__)
#define _XOPEN_SOURCE 700 /* cli/smio.h: realpath */
#endif
#endif

#ifdef SM_CONVERT_MAIN
#define SUPERMAT_IMPLEMENTATION
#endif
#include "sm_convert.h"

#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#if !defined(_WIN32)
#include <fcntl.h>
#include <unistd.h>
#include "cli/smio.h" /* the temporary file's name (and its host tag), as the CLI's outputs */
#endif

/* opens an input for reading only when it is a regular file (a FIFO or a device in a --base folder or given
   as a checkpoint is refused at once, never waited on); NULL with errno (EINVAL: not a regular file) */
static FILE *sm__fopen_read(const char *path) {
#if defined(_WIN32)
    return fopen(path, "rb");
#else
    char why[128];
    FILE *f;
    int fd = smio_open_regular(path, 0, why, sizeof why); /* cli/smio.h: the CLI's rule for every input */
    if (fd < 0) return NULL;
    if (!(f = fdopen(fd, "rb"))) close(fd);
    return f;
#endif
}

#if !defined(SM_CONVERT_NO_PTHREADS) && (defined(__unix__) || defined(__APPLE__))
#define SM__HAS_PTHREADS 1
#include <pthread.h>
#else
#define SM__HAS_PTHREADS 0
#endif

#ifdef __cplusplus
#define SM__RESTRICT __restrict
#else
#define SM__RESTRICT restrict
#endif

#if defined(_WIN32)
typedef __int64 sm__off;
#define sm__fseek _fseeki64
#define sm__ftell _ftelli64
#else
typedef off_t sm__off;
#define sm__fseek fseeko
#define sm__ftell ftello
#endif

#define SM__MIN(a, b) ((a) < (b) ? (a) : (b))
#define SM__CURVE_TEXT 600 /* a metadata value: 33 knots "%.9g," (supermat.h reads up to 1023 bytes) */
#define SM__MAX(a, b) ((a) > (b) ? (a) : (b))
#define SM__CHUNK ((size_t)4 << 20)      /* streaming buffer */
#define SM__MAX_PICKLE ((uint64_t)256 << 20) /* a state dict's data.pkl is ~200 bytes per tensor */
#define SM__MAX_JSON ((uint64_t)256 << 20)
#define SM__NAME_CAP 160                  /* supermat_tensor_info.name */

static int sm__err(char *err, size_t cap, int code, const char *fmt, ...) {
    if (err && cap) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, cap, fmt, ap);
        va_end(ap);
    }
    return code;
}

static const char *sm__basename(const char *p) {
    const char *s = p, *q;
    for (q = p; *q; q++)
        if (*q == '/' || *q == '\\') s = q + 1;
    return s;
}

static uint16_t sm__u16(const unsigned char *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t sm__u32(const unsigned char *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static uint64_t sm__u64(const unsigned char *p) { return (uint64_t)sm__u32(p) | ((uint64_t)sm__u32(p + 4) << 32); }

/* >>io : a byte source (a FILE opened by us, or a borrowed memory image) */
typedef struct sm__src {
    FILE *f;
    const unsigned char *mem;
    uint64_t size;
    uint64_t pos; /* FILE position, to skip needless seeks */
} sm__src;

static int sm__src_open(sm__src *s, const char *path) {
    sm__off end;
    memset(s, 0, sizeof *s);
    s->f = sm__fopen_read(path);
    if (!s->f) return -1;
    if (sm__fseek(s->f, 0, SEEK_END) != 0 || (end = sm__ftell(s->f)) < 0) {
        fclose(s->f);
        s->f = NULL;
        return -1;
    }
    s->size = (uint64_t)end;
    s->pos = UINT64_MAX;
    return 0;
}

static void sm__src_close(sm__src *s) {
    if (s->f) fclose(s->f);
    s->f = NULL;
}

/* 0 ok, -1 out of range or I/O error */
static int sm__src_read(sm__src *s, uint64_t off, void *dst, size_t n) {
    if (off > s->size || (uint64_t)n > s->size - off) return -1;
    if (n == 0) return 0;
    if (s->mem) {
        memcpy(dst, s->mem + off, n);
        return 0;
    }
    if (s->pos != off) {
        if ((uint64_t)(sm__off)off != off || sm__fseek(s->f, (sm__off)off, SEEK_SET) != 0) {
            s->pos = UINT64_MAX;
            return -1;
        }
    }
    if (fread(dst, 1, n, s->f) != n) {
        s->pos = UINT64_MAX;
        return -1;
    }
    s->pos = off + n;
    return 0;
}

/* >>crc : CRC-32 (IEEE, reflected), slice-by-8 */
typedef struct sm__crc { uint32_t t[8][256]; } sm__crc;

static void sm__crc_init(sm__crc *c) {
    uint32_t i, k, r;
    for (i = 0; i < 256; i++) {
        r = i;
        for (k = 0; k < 8; k++) r = (r >> 1) ^ (0xEDB88320u & (0u - (r & 1u)));
        c->t[0][i] = r;
    }
    for (i = 0; i < 256; i++)
        for (k = 1; k < 8; k++) c->t[k][i] = (c->t[k - 1][i] >> 8) ^ c->t[0][c->t[k - 1][i] & 255];
}

/* running value: start with 0 */
static uint32_t sm__crc_update(const sm__crc *c, uint32_t crc, const unsigned char *p, size_t n) {
    crc = ~crc;
    while (n >= 8) {
        uint32_t a = crc ^ sm__u32(p), b = sm__u32(p + 4);
        crc = c->t[7][a & 255] ^ c->t[6][(a >> 8) & 255] ^ c->t[5][(a >> 16) & 255] ^ c->t[4][a >> 24] ^
              c->t[3][b & 255] ^ c->t[2][(b >> 8) & 255] ^ c->t[1][(b >> 16) & 255] ^ c->t[0][b >> 24];
        p += 8;
        n -= 8;
    }
    while (n--) crc = (crc >> 8) ^ c->t[0][(crc ^ *p++) & 255];
    return ~crc;
}

/* >>zip : central directory reader. PyTorch writes STORED entries aligned to 64 bytes (padding in the
   local extra field, so local and central extra lengths differ) with data descriptors (flag bit 3),
   and zip64 structures once the archive passes 4 GiB. */
typedef struct sm__zentry {
    const char *name; /* into the central directory copy; not NUL-terminated */
    int name_len;
    int method, flags;
    uint32_t crc;
    uint64_t csize, usize, lho;
    uint64_t data; /* resolved data offset, UINT64_MAX until the local header was checked */
} sm__zentry;

typedef struct sm__zip {
    sm__src *src;
    const char *file; /* for messages */
    unsigned char *cd;
    sm__zentry *e;
    int n;
    int *sorted; /* entry indices sorted by name */
    uint64_t cd_off;
} sm__zip;

static void sm__zip_free(sm__zip *z) {
    free(z->cd);
    free(z->e);
    free(z->sorted);
    z->cd = NULL;
    z->e = NULL;
    z->sorted = NULL;
    z->n = 0;
}

static int sm__zname_cmp(const char *a, int na, const char *b, int nb) {
    int c = memcmp(a, b, (size_t)SM__MIN(na, nb));
    return c ? c : (na < nb ? -1 : na > nb);
}

/* entry indices sorted by name (merge sort: qsort would need a global context) */
static void sm__zip_sort(sm__zip *z) {
    int n = z->n, w, i, j, k, lo, mid, hi;
    int *a = z->sorted, *b = (int *)malloc(sizeof(int) * (size_t)(n ? n : 1));
    for (i = 0; i < n; i++) a[i] = i;
    if (!b) { /* fall back to insertion sort */
        for (i = 1; i < n; i++) {
            int x = a[i];
            for (j = i - 1; j >= 0 && sm__zname_cmp(z->e[a[j]].name, z->e[a[j]].name_len, z->e[x].name, z->e[x].name_len) > 0; j--)
                a[j + 1] = a[j];
            a[j + 1] = x;
        }
        return;
    }
    for (w = 1; w < n; w *= 2) {
        for (lo = 0; lo < n; lo += 2 * w) {
            mid = SM__MIN(lo + w, n);
            hi = SM__MIN(lo + 2 * w, n);
            i = lo; j = mid; k = lo;
            while (i < mid && j < hi)
                b[k++] = sm__zname_cmp(z->e[a[i]].name, z->e[a[i]].name_len, z->e[a[j]].name, z->e[a[j]].name_len) <= 0 ? a[i++] : a[j++];
            while (i < mid) b[k++] = a[i++];
            while (j < hi) b[k++] = a[j++];
        }
        memcpy(a, b, sizeof(int) * (size_t)n);
    }
    free(b);
}

static int sm__zip_find(const sm__zip *z, const char *name, int len) {
    int lo = 0, hi = z->n - 1;
    while (lo <= hi) {
        int mid = lo + (hi - lo) / 2, e = z->sorted[mid];
        int c = sm__zname_cmp(z->e[e].name, z->e[e].name_len, name, len);
        if (c == 0) return e;
        if (c < 0) lo = mid + 1;
        else hi = mid - 1;
    }
    return -1;
}

static int sm__zip_open(sm__zip *z, sm__src *src, const char *file, char *err, size_t cap) {
    unsigned char tail[22 + 65535 + 20], *p, buf[56];
    uint64_t size = src->size, tail_off, eocd = 0, n_total, cd_size, cd_off, pos;
    size_t tail_len;
    int found = 0, i;
    long k;
    memset(z, 0, sizeof *z);
    z->src = src;
    z->file = file;
    tail_len = (size_t)SM__MIN(size, (uint64_t)sizeof tail);
    tail_off = size - tail_len;
    if (sm__src_read(src, tail_off, tail, tail_len)) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: read error", file);
    for (k = (long)tail_len - 22; k >= 0; k--) {
        p = tail + k;
        if (sm__u32(p) == 0x06054b50u && (size_t)k + 22 + sm__u16(p + 20) <= tail_len) {
            eocd = tail_off + (uint64_t)k;
            found = 1;
            break;
        }
    }
    if (!found) {
        unsigned char head[2] = {0, 0};
        sm__src_read(src, 0, head, 2);
        if (head[0] == 0x80 && head[1] <= 5)
            return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: legacy torch.save format (PyTorch < 1.6 or _use_new_zipfile_serialization=False); re-save it with a recent torch", file);
        if (head[0] == 'P' && head[1] == 'K')
            return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: zip archive without an end-of-central-directory record (truncated?)", file);
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: not a zip archive (torch.save format), or truncated (%llu bytes)", file, (unsigned long long)size);
    }
    p = tail + (size_t)(eocd - tail_off);
    if (sm__u16(p + 4) != 0 || sm__u16(p + 6) != 0)
        return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: multi-disk zip archives are not supported", file);
    n_total = sm__u16(p + 10);
    cd_size = sm__u32(p + 12);
    cd_off = sm__u32(p + 16);
    pos = eocd; /* the central directory must end before this */
    if (eocd >= 20 && sm__src_read(src, eocd - 20, buf, 20) == 0 && sm__u32(buf) == 0x07064b50u) {
        uint64_t z64 = sm__u64(buf + 8);
        if (z64 > eocd - 20 || eocd - 20 - z64 < 56 || sm__src_read(src, z64, buf, 56) || sm__u32(buf) != 0x06064b50u)
            return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: bad zip64 end-of-central-directory record", file);
        if (sm__u32(buf + 16) != 0 || sm__u32(buf + 20) != 0)
            return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: multi-disk zip archives are not supported", file);
        n_total = sm__u64(buf + 32);
        cd_size = sm__u64(buf + 40);
        cd_off = sm__u64(buf + 48);
        pos = z64;
    }
    if (cd_off > pos || cd_size > pos - cd_off)
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: central directory [%llu, +%llu) outside the file (truncated?)", file, (unsigned long long)cd_off, (unsigned long long)cd_size);
    if (n_total > cd_size / 46 || n_total > (uint64_t)INT_MAX / 2)
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: %llu zip entries cannot fit a %llu-byte central directory", file, (unsigned long long)n_total, (unsigned long long)cd_size);
    if ((uint64_t)(size_t)cd_size != cd_size) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: central directory too large", file);
    z->cd = (unsigned char *)malloc((size_t)cd_size + 1);
    z->e = (sm__zentry *)malloc(sizeof(sm__zentry) * (size_t)(n_total + 1));
    z->sorted = (int *)malloc(sizeof(int) * (size_t)(n_total + 1));
    if (!z->cd || !z->e || !z->sorted) {
        sm__zip_free(z);
        return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory for the zip central directory", file);
    }
    z->cd_off = cd_off;
    if (sm__src_read(src, cd_off, z->cd, (size_t)cd_size)) {
        sm__zip_free(z);
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: cannot read the central directory", file);
    }
    pos = 0;
    for (i = 0; i < (int)n_total; i++) {
        sm__zentry *e = &z->e[i];
        uint64_t nl, xl, cl, x, xend;
        if (cd_size - pos < 46 || sm__u32(z->cd + pos) != 0x02014b50u) goto bad_cd;
        p = z->cd + pos;
        e->flags = sm__u16(p + 8);
        e->method = sm__u16(p + 10);
        e->crc = sm__u32(p + 16);
        e->csize = sm__u32(p + 20);
        e->usize = sm__u32(p + 24);
        nl = sm__u16(p + 28);
        xl = sm__u16(p + 30);
        cl = sm__u16(p + 32);
        e->lho = sm__u32(p + 42);
        e->data = UINT64_MAX;
        if (cd_size - pos - 46 < nl + xl + cl) goto bad_cd;
        e->name = (const char *)p + 46;
        e->name_len = (int)nl;
        /* zip64 extended information: the 64-bit values of the fields saturated at 0xFFFFFFFF, in order */
        x = 46 + nl;
        xend = x + xl;
        while (xend - x >= 4) {
            unsigned id = sm__u16(p + x), sz = sm__u16(p + x + 2);
            uint64_t q = x + 4;
            if (xend - q < sz) goto bad_cd;
            if (id == 1) {
                uint64_t qe = q + sz;
                if (e->usize == 0xFFFFFFFFu) { if (qe - q < 8) goto bad_cd; e->usize = sm__u64(p + q); q += 8; }
                if (e->csize == 0xFFFFFFFFu) { if (qe - q < 8) goto bad_cd; e->csize = sm__u64(p + q); q += 8; }
                if (e->lho == 0xFFFFFFFFu) { if (qe - q < 8) goto bad_cd; e->lho = sm__u64(p + q); }
            }
            x += 4 + (uint64_t)sz;
        }
        pos += 46 + nl + xl + cl;
    }
    z->n = (int)n_total;
    sm__zip_sort(z);
    return 0;
bad_cd:
    sm__zip_free(z);
    return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: corrupt zip central directory (entry %d)", file, i);
}

/* Checks entry i's local header and that it is a readable STORED entry; sets e->data. */
static int sm__zip_resolve(sm__zip *z, int i, char *err, size_t cap) {
    sm__zentry *e = &z->e[i];
    unsigned char h[30];
    uint64_t data;
    char nm[96];
    int nlen = SM__MIN(e->name_len, (int)sizeof nm - 1);
    memcpy(nm, e->name, (size_t)nlen);
    nm[nlen] = 0;
    if (e->data != UINT64_MAX) return 0;
    if (e->flags & 1) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: zip entry '%s' is encrypted", z->file, nm);
    if (e->method != 0)
        return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: zip entry '%s' is compressed (method %d); only STORED entries (as torch.save writes them) are supported: re-save the checkpoint with torch.save", z->file, nm, e->method);
    if (e->csize != e->usize) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: stored zip entry '%s' has different compressed and uncompressed sizes", z->file, nm);
    if (e->lho > z->cd_off || z->cd_off - e->lho < 30 || sm__src_read(z->src, e->lho, h, 30) || sm__u32(h) != 0x04034b50u)
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: bad local header for zip entry '%s' (truncated or corrupt file)", z->file, nm);
    if (sm__u16(h + 26) != (unsigned)e->name_len || sm__u16(h + 8) != (unsigned)e->method)
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: local header of zip entry '%s' disagrees with the central directory", z->file, nm);
    data = e->lho + 30 + (uint64_t)sm__u16(h + 26) + (uint64_t)sm__u16(h + 28);
    if (data > z->cd_off || e->csize > z->cd_off - data)
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: zip entry '%s' runs past the central directory (truncated or corrupt file)", z->file, nm);
    {
        /* the name in the local header must match */
        char lname[256];
        int k, cmpn = SM__MIN(e->name_len, (int)sizeof lname);
        if (sm__src_read(z->src, e->lho + 30, lname, (size_t)cmpn)) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: read error", z->file);
        for (k = 0; k < cmpn; k++)
            if (lname[k] != e->name[k]) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: local header name of zip entry '%s' differs from the central directory", z->file, nm);
    }
    e->data = data;
    return 0;
}

/* >>pickle : a stack machine for the opcodes torch.save uses (protocol 2, plus the protocol 4 framing
   and a few neighbours). No recursion; every container, the stack, the marks and the memo grow
   dynamically and are bounded by the size of the pickle. */
enum {
    SM__DT_F32 = 0, SM__DT_F16, SM__DT_BF16, SM__DT_F64, SM__DT_I64, SM__DT_I32, SM__DT_I16, SM__DT_I8, SM__DT_U8,
    SM__DT_BOOL, SM__DT_UNTYPED, SM__DT_COUNT
};
static const struct { const char *storage, *dtype, *label; int size; } sm__dts[SM__DT_COUNT] = {
    {"FloatStorage", "float32", "F32", 4},  {"HalfStorage", "float16", "F16", 2},  {"BFloat16Storage", "bfloat16", "BF16", 2},
    {"DoubleStorage", "float64", "F64", 8}, {"LongStorage", "int64", "I64", 8},    {"IntStorage", "int32", "I32", 4},
    {"ShortStorage", "int16", "I16", 2},    {"CharStorage", "int8", "I8", 1},      {"ByteStorage", "uint8", "U8", 1},
    {"BoolStorage", "bool", "BOOL", 1},     {"UntypedStorage", "", "untyped", 1}};

enum { SM__O_NONE = 0, SM__O_BOOL, SM__O_INT, SM__O_FLOAT, SM__O_STR, SM__O_BYTES, SM__O_TUPLE, SM__O_LIST, SM__O_DICT,
       SM__O_GLOBAL, SM__O_STORAGE, SM__O_TENSOR, SM__O_OTHER };
enum { SM__G_UNKNOWN = 0, SM__G_ODICT, SM__G_REBUILD_V2, SM__G_REBUILD_PARAM, SM__G_STORAGE, SM__G_DTYPE };

typedef struct sm__pobj {
    int type;
    int n, cap;     /* container: elements (a dict stores key, value, key, value, ...) */
    int *items;
    int64_t iv;     /* INT / BOOL value; GLOBAL: kind * 256 + dtype; STORAGE / TENSOR: record index */
    uint64_t off, len; /* STR / BYTES: byte range in the pickle */
} sm__pobj;

typedef struct sm__pstorage {
    int dt;
    uint64_t key_off, key_len; /* in the pickle */
    int64_t numel;
} sm__pstorage;

typedef struct sm__ptensor {
    int storage, dt, ndim;
    int64_t shape[8];
    uint64_t byte_off, nbytes;
    char bad[112]; /* why it cannot be used ("" = fine) */
} sm__ptensor;

typedef struct sm__pvm {
    const unsigned char *pk;
    uint64_t len;
    sm__pobj *o; int no, co;
    int *stack; int ns, cs;
    int *marks; int nm, cm;
    int *memo; int nmemo, nset; /* memo[i] = object or -1; nmemo = capacity; nset = entries set */
    sm__pstorage *st; int nst, cst;
    sm__ptensor *t; int nt, ct;
    int root;
} sm__pvm;

static void sm__pvm_free(sm__pvm *m) {
    int i;
    for (i = 0; i < m->no; i++) free(m->o[i].items);
    free(m->o); free(m->stack); free(m->marks); free(m->memo); free(m->st); free(m->t);
    memset(m, 0, sizeof *m);
}

/* grows *p (elements of `size` bytes) to hold at least need; 0 ok */
static int sm__grow(void **p, int *cap, int need, size_t size) {
    int nc;
    void *q;
    if (need <= *cap) return 0;
    if (need > INT_MAX / 2 - 16) return -1;
    nc = SM__MAX(need, *cap * 2);
    nc = SM__MAX(nc, 16);
    if ((size_t)nc > SIZE_MAX / size) return -1;
    q = realloc(*p, (size_t)nc * size);
    if (!q) return -1;
    *p = q;
    *cap = nc;
    return 0;
}

static int sm__pnew(sm__pvm *m, int type) {
    sm__pobj *o;
    if (sm__grow((void **)&m->o, &m->co, m->no + 1, sizeof(sm__pobj))) return -1;
    o = &m->o[m->no];
    memset(o, 0, sizeof *o);
    o->type = type;
    return m->no++;
}

static int sm__ppush(sm__pvm *m, int obj) {
    if (obj < 0 || sm__grow((void **)&m->stack, &m->cs, m->ns + 1, sizeof(int))) return -1;
    m->stack[m->ns++] = obj;
    return 0;
}

static int sm__padd(sm__pvm *m, int container, int item) {
    sm__pobj *c = &m->o[container];
    if (sm__grow((void **)&c->items, &c->cap, c->n + 1, sizeof(int))) return -1;
    c->items[c->n++] = item;
    return 0;
}

static int sm__pstr_eq(const sm__pvm *m, int obj, const char *s) {
    size_t n = strlen(s);
    const sm__pobj *o = &m->o[obj];
    return o->type == SM__O_STR && o->len == n && memcmp(m->pk + o->off, s, n) == 0;
}

static int sm__span_eq(const unsigned char *p, uint64_t n, const char *s) {
    size_t k = strlen(s);
    return n == k && memcmp(p, s, k) == 0;
}

static int64_t sm__pglobal(const unsigned char *mod, uint64_t nmod, const unsigned char *name, uint64_t nname) {
    int d;
    if (sm__span_eq(mod, nmod, "collections") && sm__span_eq(name, nname, "OrderedDict")) return SM__G_ODICT * 256;
    if ((sm__span_eq(mod, nmod, "builtins") || sm__span_eq(mod, nmod, "__builtin__")) && sm__span_eq(name, nname, "dict"))
        return SM__G_ODICT * 256;
    if (sm__span_eq(mod, nmod, "torch._utils")) {
        if (sm__span_eq(name, nname, "_rebuild_tensor_v2")) return SM__G_REBUILD_V2 * 256;
        if (sm__span_eq(name, nname, "_rebuild_parameter")) return SM__G_REBUILD_PARAM * 256;
    }
    if (sm__span_eq(mod, nmod, "torch") || sm__span_eq(mod, nmod, "torch.storage")) {
        for (d = 0; d < SM__DT_COUNT; d++) {
            if (sm__span_eq(name, nname, sm__dts[d].storage)) return SM__G_STORAGE * 256 + d;
            if (sm__dts[d].dtype[0] && sm__span_eq(name, nname, sm__dts[d].dtype)) return SM__G_DTYPE * 256 + d;
        }
        if (sm__span_eq(name, nname, "half")) return SM__G_DTYPE * 256 + SM__DT_F16;
        if (sm__span_eq(name, nname, "float")) return SM__G_DTYPE * 256 + SM__DT_F32;
    }
    return SM__G_UNKNOWN * 256;
}

static void sm__tensor_bad(sm__ptensor *t, const char *fmt, ...) {
    va_list ap;
    if (t->bad[0]) return;
    va_start(ap, fmt);
    vsnprintf(t->bad, sizeof t->bad, fmt, ap);
    va_end(ap);
}

/* _rebuild_tensor_v2(storage, storage_offset, size, stride, requires_grad, backward_hooks[, metadata]) */
static int sm__pbuild_tensor(sm__pvm *m, int args) {
    sm__ptensor *t;
    const sm__pobj *a = &m->o[args];
    int obj, k, dt;
    int64_t numel = 1, expect = 1, off;
    if (sm__grow((void **)&m->t, &m->ct, m->nt + 1, sizeof(sm__ptensor))) return -1;
    t = &m->t[m->nt];
    memset(t, 0, sizeof *t);
    t->storage = -1;
    obj = sm__pnew(m, SM__O_TENSOR);
    if (obj < 0) return -1;
    a = &m->o[args];
    m->o[obj].iv = m->nt++;
    if (a->type != SM__O_TUPLE || a->n < 4) { sm__tensor_bad(t, "_rebuild_tensor_v2 with %d arguments", a->n); return obj; }
    if (m->o[a->items[0]].type != SM__O_STORAGE) { sm__tensor_bad(t, "its storage is not a persistent storage"); return obj; }
    t->storage = (int)m->o[a->items[0]].iv;
    dt = m->st[t->storage].dt;
    if (dt == SM__DT_UNTYPED) { /* the element type then comes as a torch.<dtype> argument */
        for (k = 4; k < a->n; k++)
            if (m->o[a->items[k]].type == SM__O_GLOBAL && m->o[a->items[k]].iv / 256 == SM__G_DTYPE) dt = (int)(m->o[a->items[k]].iv % 256);
        if (dt == SM__DT_UNTYPED) { sm__tensor_bad(t, "untyped storage without a dtype"); return obj; }
    }
    t->dt = dt;
    if (m->o[a->items[1]].type != SM__O_INT || m->o[a->items[1]].iv < 0) { sm__tensor_bad(t, "bad storage offset"); return obj; }
    off = m->o[a->items[1]].iv;
    {
        const sm__pobj *sz = &m->o[a->items[2]], *sd = &m->o[a->items[3]];
        if (sz->type != SM__O_TUPLE || sd->type != SM__O_TUPLE || sz->n != sd->n) { sm__tensor_bad(t, "bad size/stride"); return obj; }
        if (sz->n > 8) { sm__tensor_bad(t, "%d dimensions (at most 8)", sz->n); return obj; }
        t->ndim = sz->n;
        for (k = 0; k < sz->n; k++) {
            const sm__pobj *d = &m->o[sz->items[k]];
            if (d->type != SM__O_INT || d->iv < 0 || d->iv > ((int64_t)1 << 48)) { sm__tensor_bad(t, "bad size"); return obj; }
            t->shape[k] = d->iv;
            if (d->iv && numel > INT64_MAX / 16 / d->iv) { sm__tensor_bad(t, "size overflows"); return obj; }
            numel *= d->iv;
        }
        for (k = sz->n - 1; k >= 0; k--) { /* row-major contiguity (size-1 dimensions may have any stride) */
            const sm__pobj *s = &m->o[sd->items[k]];
            if (s->type != SM__O_INT) { sm__tensor_bad(t, "bad stride"); return obj; }
            if (t->shape[k] > 1 && s->iv != expect) {
                sm__tensor_bad(t, "is not contiguous (stride %lld at dimension %d, expected %lld); save tensor.contiguous()",
                               (long long)s->iv, k, (long long)expect);
                return obj;
            }
            expect *= t->shape[k] ? t->shape[k] : 1;
        }
    }
    if (m->st[t->storage].dt == SM__DT_UNTYPED) { /* numel counts bytes */
        if (off > INT64_MAX / 16 || numel > (m->st[t->storage].numel - off * sm__dts[dt].size) / sm__dts[dt].size + (numel == 0)) {
            sm__tensor_bad(t, "extends past its storage");
            return obj;
        }
    } else if (numel > 0 && (off > m->st[t->storage].numel || numel > m->st[t->storage].numel - off)) {
        sm__tensor_bad(t, "elements [%lld, +%lld) extend past its storage of %lld", (long long)off, (long long)numel,
                       (long long)m->st[t->storage].numel);
        return obj;
    }
    t->byte_off = (uint64_t)off * (uint64_t)sm__dts[dt].size;
    t->nbytes = (uint64_t)numel * (uint64_t)sm__dts[dt].size;
    if (dt != SM__DT_F32 && dt != SM__DT_F16 && dt != SM__DT_BF16) sm__tensor_bad(t, "has dtype %s (F32, F16 and BF16 are supported)", sm__dts[dt].label);
    return obj;
}

static int sm__pvm_fail(char *err, size_t cap, uint64_t at, int op, const char *what) {
    return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "data.pkl: %s at byte %llu (opcode 0x%02x)", what, (unsigned long long)at, op);
}

/* Runs the pickle; on success m->root is the unpickled object. */
static int sm__pvm_run(sm__pvm *m, const unsigned char *pk, uint64_t len, char *err, size_t cap) {
    uint64_t i = 0, at = 0, n;
    int op = 0, a, b, c, k, obj;
    memset(m, 0, sizeof *m);
    m->pk = pk;
    m->len = len;
    m->root = -1;
    if (len > SM__MAX_PICKLE) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "data.pkl: %llu bytes is too large", (unsigned long long)len);
#define SM__NEED(k_) do { if (len - i < (uint64_t)(k_)) return sm__pvm_fail(err, cap, at, op, "truncated pickle"); } while (0)
#define SM__POP(v_) do { if (m->ns <= (m->nm ? m->marks[m->nm - 1] : 0)) return sm__pvm_fail(err, cap, at, op, "stack underflow"); (v_) = m->stack[--m->ns]; } while (0)
#define SM__PUSH(v_) do { if (sm__ppush(m, (v_))) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory"); } while (0)
#define SM__NEW(v_, t_) do { (v_) = sm__pnew(m, (t_)); if ((v_) < 0) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory"); } while (0)
    for (;;) {
        if (i >= len) return sm__pvm_fail(err, cap, i, 0, "pickle ends without STOP");
        at = i;
        op = pk[i++];
        switch (op) {
        case 0x80: /* PROTO */
            SM__NEED(1);
            if (pk[i] > 5) return sm__pvm_fail(err, cap, at, op, "unsupported pickle protocol");
            i++;
            break;
        case 0x95: /* FRAME: frames are transparent */
            SM__NEED(8);
            i += 8;
            break;
        case '}': SM__NEW(obj, SM__O_DICT); SM__PUSH(obj); break;
        case ']': SM__NEW(obj, SM__O_LIST); SM__PUSH(obj); break;
        case ')': SM__NEW(obj, SM__O_TUPLE); SM__PUSH(obj); break;
        case '(': /* MARK */
            if (sm__grow((void **)&m->marks, &m->cm, m->nm + 1, sizeof(int))) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            m->marks[m->nm++] = m->ns;
            break;
        case 't': /* TUPLE: everything above the last mark */
            if (!m->nm) return sm__pvm_fail(err, cap, at, op, "TUPLE without MARK");
            SM__NEW(obj, SM__O_TUPLE);
            for (k = m->marks[m->nm - 1]; k < m->ns; k++)
                if (sm__padd(m, obj, m->stack[k])) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            m->ns = m->marks[--m->nm];
            SM__PUSH(obj);
            break;
        case 0x85: case 0x86: case 0x87: { /* TUPLE1/2/3 */
            int cnt = op - 0x84, base;
            base = m->nm ? m->marks[m->nm - 1] : 0;
            if (m->ns - base < cnt) return sm__pvm_fail(err, cap, at, op, "stack underflow");
            SM__NEW(obj, SM__O_TUPLE);
            for (k = m->ns - cnt; k < m->ns; k++)
                if (sm__padd(m, obj, m->stack[k])) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            m->ns -= cnt;
            SM__PUSH(obj);
            break;
        }
        case 'X': case 0x8c: case 0x8d: case 'B': case 'C': case 0x8e: case 'T': case 'U': { /* strings and bytes */
            int w = (op == 0x8c || op == 'C' || op == 'U') ? 1 : (op == 0x8d || op == 0x8e) ? 8 : 4;
            SM__NEED(w);
            n = w == 1 ? pk[i] : w == 4 ? sm__u32(pk + i) : sm__u64(pk + i);
            if (op == 'T' && n > 0x7FFFFFFFu) return sm__pvm_fail(err, cap, at, op, "negative string length");
            i += (uint64_t)w;
            SM__NEED(n);
            SM__NEW(obj, (op == 'B' || op == 'C' || op == 0x8e) ? SM__O_BYTES : SM__O_STR);
            m->o[obj].off = i;
            m->o[obj].len = n;
            i += n;
            SM__PUSH(obj);
            break;
        }
        case 'c': { /* GLOBAL module\nname\n */
            uint64_t s0 = i, e0, s1, e1;
            while (i < len && pk[i] != '\n') i++;
            if (i >= len) return sm__pvm_fail(err, cap, at, op, "truncated GLOBAL");
            e0 = i++;
            s1 = i;
            while (i < len && pk[i] != '\n') i++;
            if (i >= len) return sm__pvm_fail(err, cap, at, op, "truncated GLOBAL");
            e1 = i++;
            SM__NEW(obj, SM__O_GLOBAL);
            m->o[obj].iv = sm__pglobal(pk + s0, e0 - s0, pk + s1, e1 - s1);
            SM__PUSH(obj);
            break;
        }
        case 0x93: /* STACK_GLOBAL */
            SM__POP(b);
            SM__POP(a);
            if (m->o[a].type != SM__O_STR || m->o[b].type != SM__O_STR) return sm__pvm_fail(err, cap, at, op, "STACK_GLOBAL needs two strings");
            SM__NEW(obj, SM__O_GLOBAL);
            m->o[obj].iv = sm__pglobal(pk + m->o[a].off, m->o[a].len, pk + m->o[b].off, m->o[b].len);
            SM__PUSH(obj);
            break;
        case 'Q': { /* BINPERSID: ('storage', torch.<T>Storage, key, location, numel) */
            const sm__pobj *pid;
            sm__pstorage *s;
            SM__POP(a);
            pid = &m->o[a];
            if (pid->type != SM__O_TUPLE || pid->n < 5 || !sm__pstr_eq(m, pid->items[0], "storage") ||
                m->o[pid->items[1]].type != SM__O_GLOBAL || m->o[pid->items[1]].iv / 256 != SM__G_STORAGE ||
                m->o[pid->items[2]].type != SM__O_STR || m->o[pid->items[4]].type != SM__O_INT || m->o[pid->items[4]].iv < 0)
                return sm__pvm_fail(err, cap, at, op, "unsupported persistent id (expected a torch storage)");
            if (sm__grow((void **)&m->st, &m->cst, m->nst + 1, sizeof(sm__pstorage))) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            s = &m->st[m->nst];
            s->dt = (int)(m->o[pid->items[1]].iv % 256);
            s->key_off = m->o[pid->items[2]].off;
            s->key_len = m->o[pid->items[2]].len;
            s->numel = m->o[pid->items[4]].iv;
            if (s->key_len == 0 || s->key_len > 200) return sm__pvm_fail(err, cap, at, op, "bad storage key");
            SM__NEW(obj, SM__O_STORAGE);
            m->o[obj].iv = m->nst++;
            SM__PUSH(obj);
            break;
        }
        case 'R': case 0x81: { /* REDUCE callable args / NEWOBJ cls args */
            int64_t g;
            SM__POP(b);
            SM__POP(a);
            if (m->o[b].type != SM__O_TUPLE) return sm__pvm_fail(err, cap, at, op, "REDUCE arguments are not a tuple");
            g = m->o[a].type == SM__O_GLOBAL ? m->o[a].iv / 256 : (int64_t)SM__G_UNKNOWN;
            if (g == SM__G_ODICT && m->o[b].n == 0) {
                SM__NEW(obj, SM__O_DICT);
            } else if (g == SM__G_REBUILD_V2 && op == 'R') {
                obj = sm__pbuild_tensor(m, b);
                if (obj < 0) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            } else if (g == SM__G_REBUILD_PARAM && op == 'R' && m->o[b].n >= 1) {
                obj = m->o[b].items[0]; /* Parameter(data) -> data */
            } else {
                SM__NEW(obj, SM__O_OTHER);
            }
            SM__PUSH(obj);
            break;
        }
        case 'b': /* BUILD: set state (ignored: OrderedDict._metadata, hooks) */
            SM__POP(a);
            SM__POP(b);
            SM__PUSH(b);
            break;
        case 'J': SM__NEED(4); SM__NEW(obj, SM__O_INT); m->o[obj].iv = (int32_t)sm__u32(pk + i); i += 4; SM__PUSH(obj); break;
        case 'K': SM__NEED(1); SM__NEW(obj, SM__O_INT); m->o[obj].iv = pk[i]; i += 1; SM__PUSH(obj); break;
        case 'M': SM__NEED(2); SM__NEW(obj, SM__O_INT); m->o[obj].iv = sm__u16(pk + i); i += 2; SM__PUSH(obj); break;
        case 0x8a: case 0x8b: { /* LONG1 / LONG4: little-endian two's complement */
            uint64_t v = 0;
            int w = op == 0x8a ? 1 : 4;
            SM__NEED(w);
            n = w == 1 ? pk[i] : sm__u32(pk + i);
            i += (uint64_t)w;
            SM__NEED(n);
            if (n > 8) return sm__pvm_fail(err, cap, at, op, "integer wider than 64 bits");
            for (k = (int)n - 1; k >= 0; k--) v = (v << 8) | pk[i + (uint64_t)k];
            if (n > 0 && n < 8 && (pk[i + n - 1] & 0x80)) v |= ~(uint64_t)0 << (8 * n);
            i += n;
            SM__NEW(obj, SM__O_INT);
            m->o[obj].iv = (int64_t)v;
            SM__PUSH(obj);
            break;
        }
        case 'G': SM__NEED(8); i += 8; SM__NEW(obj, SM__O_FLOAT); SM__PUSH(obj); break;
        case 'N': SM__NEW(obj, SM__O_NONE); SM__PUSH(obj); break;
        case 0x88: case 0x89: SM__NEW(obj, SM__O_BOOL); m->o[obj].iv = op == 0x88; SM__PUSH(obj); break;
        case 'q': case 'r': case 0x94: { /* BINPUT / LONG_BINPUT / MEMOIZE */
            uint64_t idx;
            if (op == 'q') { SM__NEED(1); idx = pk[i]; i += 1; }
            else if (op == 'r') { SM__NEED(4); idx = sm__u32(pk + i); i += 4; }
            else idx = (uint64_t)m->nset; /* MEMOIZE: memo[len(memo)] */
            if (m->ns <= (m->nm ? m->marks[m->nm - 1] : 0)) return sm__pvm_fail(err, cap, at, op, "memo of an empty stack");
            if (idx > len + 256) return sm__pvm_fail(err, cap, at, op, "memo index out of range");
            if ((int)idx >= m->nmemo) {
                int old = m->nmemo, cmemo = m->nmemo;
                if (sm__grow((void **)&m->memo, &cmemo, (int)idx + 1, sizeof(int))) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
                m->nmemo = cmemo;
                for (k = old; k < m->nmemo; k++) m->memo[k] = -1;
            }
            if (m->memo[idx] < 0) m->nset++;
            m->memo[idx] = m->stack[m->ns - 1];
            break;
        }
        case 'h': case 'j': { /* BINGET / LONG_BINGET */
            uint64_t idx;
            if (op == 'h') { SM__NEED(1); idx = pk[i]; i += 1; }
            else { SM__NEED(4); idx = sm__u32(pk + i); i += 4; }
            if (idx >= (uint64_t)m->nmemo || m->memo[idx] < 0) return sm__pvm_fail(err, cap, at, op, "memo key not found");
            SM__PUSH(m->memo[idx]);
            break;
        }
        case 's': /* SETITEM */
            SM__POP(c);
            SM__POP(b);
            SM__POP(a);
            if (m->o[a].type == SM__O_DICT) {
                if (sm__padd(m, a, b) || sm__padd(m, a, c)) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            } else if (m->o[a].type != SM__O_OTHER) return sm__pvm_fail(err, cap, at, op, "SETITEM on a non-dict");
            SM__PUSH(a);
            break;
        case 'u': case 'e': { /* SETITEMS / APPENDS: target below the mark */
            int base, target;
            if (!m->nm) return sm__pvm_fail(err, cap, at, op, "SETITEMS/APPENDS without MARK");
            base = m->marks[m->nm - 1];
            if (base < 1 || base <= (m->nm > 1 ? m->marks[m->nm - 2] : 0)) return sm__pvm_fail(err, cap, at, op, "stack underflow");
            target = m->stack[base - 1];
            if (op == 'u' && ((m->ns - base) & 1)) return sm__pvm_fail(err, cap, at, op, "odd number of SETITEMS items");
            if (m->o[target].type == (op == 'u' ? SM__O_DICT : SM__O_LIST)) {
                for (k = base; k < m->ns; k++)
                    if (sm__padd(m, target, m->stack[k])) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            } else if (m->o[target].type != SM__O_OTHER) return sm__pvm_fail(err, cap, at, op, op == 'u' ? "SETITEMS on a non-dict" : "APPENDS on a non-list");
            m->ns = base;
            m->nm--;
            break;
        }
        case 'a': /* APPEND */
            SM__POP(b);
            SM__POP(a);
            if (m->o[a].type == SM__O_LIST) {
                if (sm__padd(m, a, b)) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "data.pkl: out of memory");
            } else if (m->o[a].type != SM__O_OTHER) return sm__pvm_fail(err, cap, at, op, "APPEND on a non-list");
            SM__PUSH(a);
            break;
        case '0': SM__POP(a); (void)a; break; /* POP */
        case '1': /* POP_MARK */
            if (!m->nm) return sm__pvm_fail(err, cap, at, op, "POP_MARK without MARK");
            m->ns = m->marks[--m->nm];
            break;
        case '2': /* DUP */
            SM__POP(a);
            SM__PUSH(a);
            SM__PUSH(a);
            break;
        case '.': /* STOP */
            if (m->nm) return sm__pvm_fail(err, cap, at, op, "STOP inside a MARK");
            if (m->ns != 1) return sm__pvm_fail(err, cap, at, op, "STOP with a stack not holding exactly one object");
            m->root = m->stack[0];
            return 0;
        default:
            return sm__pvm_fail(err, cap, at, op, "unsupported pickle opcode");
        }
    }
#undef SM__NEED
#undef SM__POP
#undef SM__PUSH
#undef SM__NEW
}

/* The state dict: the root dict if its values are all tensors, else its "state_dict" / "model" dict.
   Returns the dict object, or an error naming the offending entry. */
static int sm__pvm_state_dict(const sm__pvm *m, int *dict_out, char *err, size_t cap) {
    int d = m->root, k, tries;
    static const char *const wrap[2] = {"state_dict", "model"};
    if (m->o[d].type != SM__O_DICT) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "data.pkl: the saved object is not a dict (a state dict was expected)");
    for (tries = 0; tries < 2; tries++) {
        int all = 1, w;
        const sm__pobj *o = &m->o[d];
        for (k = 0; k + 1 < o->n; k += 2)
            if (m->o[o->items[k + 1]].type != SM__O_TENSOR) all = 0;
        if (all) {
            *dict_out = d;
            return 0;
        }
        if (tries) break;
        for (w = 0; w < 2; w++) {
            for (k = 0; k + 1 < o->n; k += 2)
                if (sm__pstr_eq(m, o->items[k], wrap[w]) && m->o[o->items[k + 1]].type == SM__O_DICT) break;
            if (k + 1 < o->n) break;
        }
        if (w == 2) break;
        d = o->items[k + 1];
    }
    {
        const sm__pobj *o = &m->o[d];
        for (k = 0; k + 1 < o->n; k += 2) {
            if (m->o[o->items[k + 1]].type != SM__O_TENSOR) {
                const sm__pobj *key = &m->o[o->items[k]];
                if (key->type == SM__O_STR)
                    return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "data.pkl: state dict entry '%.*s' is not a tensor", (int)SM__MIN(key->len, 120), (const char *)m->pk + key->off);
                return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "data.pkl: state dict entry %d is not a tensor", k / 2);
            }
        }
    }
    return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "data.pkl: no state dict");
}

static int sm__name_cmp_idx(const supermat_tensor_info *t, const int *idx, int a, int b) {
    return strcmp(t[idx[a]].name, t[idx[b]].name);
}

/* 0 if all names are distinct; else the index of a duplicate + 1 (merge sort of indices, no globals) */
static int sm__find_duplicate(const supermat_tensor_info *t, int n, int *dup) {
    int *a, *b, w, lo, mid, hi, i, j, k;
    *dup = -1;
    if (n < 2) return 0;
    a = (int *)malloc(sizeof(int) * (size_t)n);
    b = (int *)malloc(sizeof(int) * (size_t)n);
    if (!a || !b) { free(a); free(b); return -1; }
    for (i = 0; i < n; i++) a[i] = i;
    for (w = 1; w < n; w *= 2) {
        for (lo = 0; lo < n; lo += 2 * w) {
            mid = SM__MIN(lo + w, n);
            hi = SM__MIN(lo + 2 * w, n);
            i = lo; j = mid; k = lo;
            while (i < mid && j < hi) b[k++] = sm__name_cmp_idx(t, a, i, j) <= 0 ? a[i++] : a[j++];
            while (i < mid) b[k++] = a[i++];
            while (j < hi) b[k++] = a[j++];
        }
        memcpy(a, b, sizeof(int) * (size_t)n);
    }
    for (i = 1; i < n; i++)
        if (!strcmp(t[a[i]].name, t[a[i - 1]].name)) { *dup = a[i]; break; }
    free(a);
    free(b);
    return 0;
}

/* >>pth : checkpoint files. A torch.save zip, or (same interface) a .safetensors file. */
struct sm_pth {
    sm__src src;
    char file[256];
    int is_zip;
    sm__zip zip;
    supermat_tensor_info *t;
    int n;
    int *entry;        /* zip entry of each tensor's storage, or -1 */
    uint32_t *crc;     /* the entry's CRC-32 when the tensor spans the whole entry */
    unsigned char *whole;
    sm__crc crct;
};

void sm_pth_close(sm_pth *p) {
    if (!p) return;
    sm__src_close(&p->src);
    sm__zip_free(&p->zip);
    free(p->t);
    free(p->entry);
    free(p->crc);
    free(p->whole);
    free(p);
}

int sm_pth_count(const sm_pth *p) { return p ? p->n : 0; }
const supermat_tensor_info *sm_pth_tensor(const sm_pth *p, int i) { return p && i >= 0 && i < p->n ? &p->t[i] : NULL; }

int sm_pth_find(const sm_pth *p, const char *name) {
    int i;
    if (!p || !name) return -1;
    for (i = 0; i < p->n; i++)
        if (!strcmp(p->t[i].name, name)) return i;
    return -1;
}

static int sm__pth_alloc(sm_pth *p, int n) {
    size_t k = (size_t)(n > 0 ? n : 1);
    p->t = (supermat_tensor_info *)calloc(k, sizeof(supermat_tensor_info));
    p->entry = (int *)calloc(k, sizeof(int));
    p->crc = (uint32_t *)calloc(k, sizeof(uint32_t));
    p->whole = (unsigned char *)calloc(k, 1);
    return p->t && p->entry && p->crc && p->whole ? 0 : -1;
}

static int sm__pth_check_names(sm_pth *p, char *err, size_t cap) {
    int dup;
    if (sm__find_duplicate(p->t, p->n, &dup)) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory", p->file);
    if (dup >= 0) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: tensor name '%s' appears twice", p->file, p->t[dup].name);
    return 0;
}

/* safetensors through supermat.h's header parser; skip_unsupported drops e.g. int64 position_ids */
static int sm__pth_open_st(sm_pth *p, uint64_t hlen, int skip_unsupported, char *err, size_t cap) {
    unsigned char *hdr;
    int n = 0, i, r;
    supermat_error se;
    if ((uint64_t)(size_t)(hlen + 8) != hlen + 8) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: header too large", p->file);
    hdr = (unsigned char *)malloc((size_t)hlen + 8);
    if (!hdr) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory for a %llu-byte header", p->file, (unsigned long long)hlen);
    memset(&se, 0, sizeof se);
    if (sm__src_read(&p->src, 0, hdr, (size_t)hlen + 8)) {
        free(hdr);
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: read error", p->file);
    }
    r = supermat_safetensors_count(hdr, (size_t)hlen + 8, p->src.size, &n, &se);
    if (r || n < 0) {
        free(hdr);
        return sm__err(err, cap, r ? r : SUPERMAT_ERROR_MALFORMED_FILE, "%s: %s", p->file, se.message);
    }
    if (sm__pth_alloc(p, n)) {
        free(hdr);
        return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory", p->file);
    }
    for (i = 0; i < n; i++) {
        r = supermat_safetensors_tensor(hdr, (size_t)hlen + 8, p->src.size, i, &p->t[p->n], &se);
        if (r == SUPERMAT_ERROR_UNSUPPORTED && skip_unsupported) continue;
        if (r) {
            free(hdr);
            return sm__err(err, cap, r, "%s: %s", p->file, se.message);
        }
        if (p->t[p->n].dtype == SUPERMAT_DTYPE_I8) { /* quantized input: its scales live in another tensor */
            if (skip_unsupported) continue;
            free(hdr);
            return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor '%s' is I8: convert from the F32, F16 or BF16 checkpoint", p->file, p->t[p->n].name);
        }
        p->entry[p->n] = -1;
        p->n++;
    }
    free(hdr);
    return sm__pth_check_names(p, err, cap);
}

static int sm__pth_open_zip(sm_pth *p, int skip_unsupported, char *err, size_t cap) {
    sm__zip *z = &p->zip;
    sm__pvm m;
    int r, i, pk = -1, dict, k;
    unsigned char *pkl = NULL;
    char ename[512];
    size_t plen = 0;
    const sm__pobj *d;
    r = sm__zip_open(z, &p->src, p->file, err, cap);
    if (r) return r;
    for (i = 0; i < z->n; i++) { /* "<archive>/data.pkl" (the archive folder is any name) */
        const sm__zentry *e = &z->e[i];
        int slash = -1, k2;
        if (e->name_len < 8 || memcmp(e->name + e->name_len - 8, "data.pkl", 8)) continue;
        for (k2 = 0; k2 < e->name_len - 8; k2++)
            if (e->name[k2] == '/') slash = k2;
        if (e->name_len == 8 || (slash == e->name_len - 9 && memchr(e->name, '/', (size_t)slash) == NULL)) { pk = i; break; }
    }
    if (pk < 0) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: a zip archive without <archive>/data.pkl: not a torch.save file", p->file);
    plen = (size_t)z->e[pk].name_len - 8;
    if (plen > 200) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: archive name too long", p->file);
    memcpy(ename, z->e[pk].name, plen);
    /* byte order (torch >= 2.1 writes it; older files are little-endian) */
    memcpy(ename + plen, "byteorder", 9);
    k = sm__zip_find(z, ename, (int)plen + 9);
    if (k >= 0) {
        char bo[8];
        r = sm__zip_resolve(z, k, err, cap);
        if (r) return r;
        if (z->e[k].usize > 7 || sm__src_read(&p->src, z->e[k].data, bo, (size_t)z->e[k].usize))
            return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: bad byteorder entry", p->file);
        bo[z->e[k].usize] = 0;
        if (strcmp(bo, "little")) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: byte order '%s' (only little-endian checkpoints are supported)", p->file, bo);
    }
    r = sm__zip_resolve(z, pk, err, cap);
    if (r) return r;
    if (z->e[pk].usize > SM__MAX_PICKLE) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: data.pkl is %llu bytes, too large", p->file, (unsigned long long)z->e[pk].usize);
    pkl = (unsigned char *)malloc((size_t)z->e[pk].usize + 1);
    if (!pkl) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory", p->file);
    if (sm__src_read(&p->src, z->e[pk].data, pkl, (size_t)z->e[pk].usize)) {
        free(pkl);
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: cannot read data.pkl", p->file);
    }
    if (sm__crc_update(&p->crct, 0, pkl, (size_t)z->e[pk].usize) != z->e[pk].crc) {
        free(pkl);
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: CRC-32 mismatch in data.pkl (corrupt file)", p->file);
    }
    r = sm__pvm_run(&m, pkl, z->e[pk].usize, err, cap);
    if (!r) r = sm__pvm_state_dict(&m, &dict, err, cap);
    if (r) {
        char tmp[300];
        snprintf(tmp, sizeof tmp, "%s", err ? err : "");
        sm__err(err, cap, r, "%s: %s", p->file, tmp);
        sm__pvm_free(&m);
        free(pkl);
        return r;
    }
    d = &m.o[dict];
    if (sm__pth_alloc(p, d->n / 2)) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory", p->file); goto done; }
    for (k = 0; k + 1 < d->n; k += 2) {
        const sm__pobj *key = &m.o[d->items[k]];
        const sm__ptensor *t = &m.t[m.o[d->items[k + 1]].iv];
        supermat_tensor_info *o = &p->t[p->n];
        const sm__pstorage *s;
        sm__zentry *e;
        uint64_t sbytes;
        int ei;
        if (key->type != SM__O_STR) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: state dict key %d is not a string", p->file, k / 2); goto done; }
        if (key->len >= SM__NAME_CAP || memchr(pkl + key->off, 0, (size_t)key->len)) {
            r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor name '%.60s...' is longer than %d bytes", p->file, (const char *)pkl + key->off, SM__NAME_CAP - 1);
            goto done;
        }
        memset(o, 0, sizeof *o);
        memcpy(o->name, pkl + key->off, (size_t)key->len);
        if (t->bad[0]) {
            if (skip_unsupported && t->storage >= 0 && strstr(t->bad, "has dtype")) continue;
            r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor '%s' %s", p->file, o->name, t->bad);
            goto done;
        }
        s = &m.st[t->storage];
        if (plen + 5 + s->key_len >= sizeof ename) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: bad storage key", p->file); goto done; }
        memcpy(ename + plen, "data/", 5);
        memcpy(ename + plen + 5, pkl + s->key_off, (size_t)s->key_len);
        ei = sm__zip_find(z, ename, (int)(plen + 5 + s->key_len));
        if (ei < 0) {
            r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: tensor '%s': storage entry '%.*s' is missing from the archive", p->file, o->name, (int)(plen + 5 + s->key_len), ename);
            goto done;
        }
        r = sm__zip_resolve(z, ei, err, cap);
        if (r) goto done;
        e = &z->e[ei];
        if ((uint64_t)s->numel > UINT64_MAX / 8) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: tensor '%s': bad storage size", p->file, o->name); goto done; }
        sbytes = (uint64_t)s->numel * (uint64_t)sm__dts[s->dt].size;
        if (sbytes > e->usize || t->byte_off > e->usize || t->nbytes > e->usize - t->byte_off) {
            r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: tensor '%s': storage of %llu bytes but zip entry '%.*s' holds %llu (truncated or corrupt file)",
                        p->file, o->name, (unsigned long long)sbytes, e->name_len, e->name, (unsigned long long)e->usize);
            goto done;
        }
        o->dtype = t->dt == SM__DT_F32 ? SUPERMAT_DTYPE_F32 : t->dt == SM__DT_F16 ? SUPERMAT_DTYPE_F16 : SUPERMAT_DTYPE_BF16;
        o->ndim = t->ndim;
        memcpy(o->shape, t->shape, sizeof o->shape);
        o->offset = e->data + t->byte_off;
        o->nbytes = t->nbytes;
        p->entry[p->n] = ei;
        p->whole[p->n] = (unsigned char)(t->byte_off == 0 && t->nbytes == e->usize);
        p->crc[p->n] = e->crc;
        p->n++;
    }
    r = sm__pth_check_names(p, err, cap);
done:
    sm__pvm_free(&m);
    free(pkl);
    return r;
}

static int sm__pth_open(const char *path, const void *mem, size_t size, int skip_unsupported, sm_pth **out, char *err, size_t cap) {
    sm_pth *p;
    unsigned char h[9];
    int r;
    *out = NULL;
    p = (sm_pth *)calloc(1, sizeof *p);
    if (!p) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory");
    snprintf(p->file, sizeof p->file, "%s", path ? path : "<memory>");
    sm__crc_init(&p->crct);
    if (path) {
        if (sm__src_open(&p->src, path)) {
            free(p);
            return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: cannot open (%s)", path,
                           errno == EINVAL ? "not a regular file" : strerror(errno));
        }
    } else {
        p->src.mem = (const unsigned char *)mem;
        p->src.size = size;
    }
    if (sm__src_read(&p->src, 0, h, 9) == 0 && h[8] == '{' && sm__u64(h) >= 2 && sm__u64(h) <= p->src.size - 8)
        r = sm__pth_open_st(p, sm__u64(h), skip_unsupported, err, cap);
    else {
        p->is_zip = 1;
        r = sm__pth_open_zip(p, skip_unsupported, err, cap);
    }
    if (r) {
        sm_pth_close(p);
        return r;
    }
    *out = p;
    return 0;
}

int sm_pth_open(const char *path, sm_pth **out, char *err, size_t err_cap) {
    if (!out) return sm__err(err, err_cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pth_open: out is NULL");
    if (!path) { *out = NULL; return sm__err(err, err_cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pth_open: path is NULL"); }
    return sm__pth_open(path, NULL, 0, 0, out, err, err_cap);
}

int sm_pth_open_memory(const void *data, size_t size, sm_pth **out, char *err, size_t err_cap) {
    if (!out) return sm__err(err, err_cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pth_open_memory: out is NULL");
    if (!data && size) { *out = NULL; return sm__err(err, err_cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pth_open_memory: data is NULL"); }
    return sm__pth_open(NULL, data ? data : "", size, 0, out, err, err_cap);
}

/* Reads bytes [off, off + n) of tensor i, updating *crc when the tensor is checked. */
static int sm__pth_read_part(sm_pth *p, int i, uint64_t off, void *dst, size_t n, uint32_t *crc, char *err, size_t cap) {
    const supermat_tensor_info *t = &p->t[i];
    if (off > t->nbytes || n > t->nbytes - off) return sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "read past tensor '%s'", t->name);
    if (sm__src_read(&p->src, t->offset + off, dst, n))
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: cannot read tensor '%s' (truncated file?)", p->file, t->name);
    if (p->whole[i] && crc) *crc = sm__crc_update(&p->crct, *crc, (const unsigned char *)dst, n);
    return 0;
}

static int sm__pth_crc_done(const sm_pth *p, int i, uint32_t crc, char *err, size_t cap) {
    if (p->whole[i] && crc != p->crc[i])
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: CRC-32 mismatch in the data of tensor '%s' (corrupt file)", p->file, p->t[i].name);
    return 0;
}

int sm_pth_read(sm_pth *p, int i, void *dst, char *err, size_t err_cap) {
    uint32_t crc = 0;
    int r;
    if (!p || i < 0 || i >= p->n || (!dst && p->t[i].nbytes)) return sm__err(err, err_cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pth_read: bad arguments");
    if ((uint64_t)(size_t)p->t[i].nbytes != p->t[i].nbytes) return sm__err(err, err_cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "tensor too large");
    r = sm__pth_read_part(p, i, 0, dst, (size_t)p->t[i].nbytes, &crc, err, err_cap);
    return r ? r : sm__pth_crc_done(p, i, crc, err, err_cap);
}

int sm_pickle_check(const void *pkl, size_t size, int *n_tensors, char *err, size_t err_cap) {
    sm__pvm m;
    int r, dict, k, n = 0;
    if (!pkl && size) return sm__err(err, err_cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pickle_check: NULL data");
    r = sm__pvm_run(&m, (const unsigned char *)(pkl ? pkl : ""), size, err, err_cap);
    if (!r) r = sm__pvm_state_dict(&m, &dict, err, err_cap);
    if (!r) {
        const sm__pobj *d = &m.o[dict];
        for (k = 0; k + 1 < d->n; k += 2) {
            const sm__ptensor *t = &m.t[m.o[d->items[k + 1]].iv];
            if (m.o[d->items[k]].type != SM__O_STR) { r = sm__err(err, err_cap, SUPERMAT_ERROR_MALFORMED_FILE, "data.pkl: key %d is not a string", k / 2); break; }
            if (t->bad[0]) { r = sm__err(err, err_cap, SUPERMAT_ERROR_UNSUPPORTED, "data.pkl: tensor %d %s", k / 2, t->bad); break; }
            n++;
        }
    }
    if (!r && n_tensors) *n_tensors = n;
    sm__pvm_free(&m);
    return r;
}

/* >>json : diffusers / transformers config files through supermat.h's tokenizer */
typedef struct sm__json {
    char *text;
    size_t len;
    supermat_json_tok *tok;
    int n;
    char file[320];
} sm__json;

static void sm__json_free(sm__json *j) {
    free(j->text);
    free(j->tok);
    j->text = NULL;
    j->tok = NULL;
    j->n = 0;
}

static int sm__file_exists(const char *path) {
    FILE *f = sm__fopen_read(path);
    if (!f) return 0;
    fclose(f);
    return 1;
}

/* 0 ok; 1 if optional and absent; negative on error */
static int sm__json_load(sm__json *j, const char *dir, const char *rel, int optional, char *err, size_t cap) {
    sm__src s;
    int n;
    memset(j, 0, sizeof *j);
    snprintf(j->file, sizeof j->file, "%s/%s", dir, rel);
    if (sm__src_open(&s, j->file)) {
        if (optional && errno == ENOENT) return 1;
        return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: %s", j->file,
                       errno == ENOENT ? "missing (cannot open)" : errno == EINVAL ? "not a regular file" : strerror(errno));
    }
    if (s.size > SM__MAX_JSON) {
        sm__src_close(&s);
        return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: too large for a config file", j->file);
    }
    j->len = (size_t)s.size;
    j->text = (char *)malloc(j->len + 1);
    if (!j->text) {
        sm__src_close(&s);
        return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory", j->file);
    }
    if (sm__src_read(&s, 0, j->text, j->len)) {
        sm__src_close(&s);
        sm__json_free(j);
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: read error", j->file);
    }
    sm__src_close(&s);
    j->text[j->len] = 0;
    n = supermat_json_parse(j->text, j->len, NULL, 0);
    if (n > 0) {
        j->tok = (supermat_json_tok *)malloc(sizeof(supermat_json_tok) * (size_t)n);
        if (!j->tok) {
            sm__json_free(j);
            return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "%s: out of memory", j->file);
        }
        n = supermat_json_parse(j->text, j->len, j->tok, n);
    }
    if (n <= 0 || j->tok[0].type != SUPERMAT_JSON_OBJECT) {
        sm__json_free(j);
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: not a JSON object", j->file);
    }
    j->n = n;
    return 0;
}

static int sm__jfind(const sm__json *j, const char *key) { return supermat_json_find(j->text, j->tok, 0, key); }

static int sm__jnull(const sm__json *j, int t) {
    return t < 0 || (j->tok[t].type == SUPERMAT_JSON_PRIMITIVE && j->tok[t].end - j->tok[t].start == 4 && !memcmp(j->text + j->tok[t].start, "null", 4));
}

/* number `key` (default `def` when absent or null unless required) */
static int sm__jnum(const sm__json *j, const char *key, int required, double def, double *out, char *err, size_t cap) {
    int t = sm__jfind(j, key);
    if (sm__jnull(j, t)) {
        if (required) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is missing", j->file, key);
        *out = def;
        return 0;
    }
    if (supermat_json_number(j->text, &j->tok[t], out) || !(*out == *out))
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is not a number", j->file, key);
    return 0;
}

static int sm__jint(const sm__json *j, const char *key, int required, int def, int lo, int hi, int *out, char *err, size_t cap) {
    double v;
    int r = sm__jnum(j, key, required, def, &v, err, cap);
    if (r) return r;
    if (v != floor(v) || v < lo || v > hi) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" = %g is not an integer in [%d, %d]", j->file, key, v, lo, hi);
    *out = (int)v;
    return 0;
}

static int sm__jbool(const sm__json *j, const char *key, int def, int *out, char *err, size_t cap) {
    int t = sm__jfind(j, key);
    const char *s;
    int n;
    if (sm__jnull(j, t)) { *out = def; return 0; }
    s = j->text + j->tok[t].start;
    n = j->tok[t].end - j->tok[t].start;
    if (j->tok[t].type == SUPERMAT_JSON_PRIMITIVE && n == 4 && !memcmp(s, "true", 4)) *out = 1;
    else if (j->tok[t].type == SUPERMAT_JSON_PRIMITIVE && n == 5 && !memcmp(s, "false", 5)) *out = 0;
    else return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is not true or false", j->file, key);
    return 0;
}

/* the string value of token t, also accepting {"content": "..."} (transformers' AddedToken) */
static int sm__jstr_tok(const sm__json *j, int t, char *buf, size_t bufcap) {
    if (t < 0) return -1;
    if (j->tok[t].type == SUPERMAT_JSON_OBJECT) t = supermat_json_find(j->text, j->tok, t, "content");
    if (t < 0 || j->tok[t].type != SUPERMAT_JSON_STRING) return -1;
    return supermat_json_string(j->text, &j->tok[t], buf, bufcap) < 0 ? -1 : 0;
}

static int sm__jstr(const sm__json *j, const char *key, const char *def, char *buf, size_t bufcap, char *err, size_t cap) {
    int t = sm__jfind(j, key);
    if (sm__jnull(j, t)) {
        if (!def) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is missing", j->file, key);
        snprintf(buf, bufcap, "%s", def);
        return 0;
    }
    if (j->tok[t].type != SUPERMAT_JSON_STRING || supermat_json_string(j->text, &j->tok[t], buf, bufcap) < 0 || strchr(buf, ','))
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is not a (short, comma-free) string", j->file, key);
    return 0;
}

/* An int or a list of ints, written as a comma list; *count = elements (1 for a plain int). When the value
   is a plain int and `expand` > 0 it is repeated `expand` times. */
static int sm__jints(const sm__json *j, const char *key, int expand, char *buf, size_t bufcap, int *vals, int maxv, int *count,
                     char *err, size_t cap) {
    int t = sm__jfind(j, key), k, n, pos = 0;
    double v;
    if (sm__jnull(j, t)) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is missing", j->file, key);
    if (j->tok[t].type == SUPERMAT_JSON_ARRAY) {
        n = j->tok[t].size;
        for (k = 0; k < n; k++) {
            if (supermat_json_number(j->text, &j->tok[t + 1 + k], &v) || v != floor(v) || v < 0 || v > 1e9 || k >= maxv)
                return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is not a short list of non-negative integers", j->file, key);
            vals[k] = (int)v;
        }
    } else {
        if (supermat_json_number(j->text, &j->tok[t], &v) || v != floor(v) || v < 0 || v > 1e9)
            return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is not an integer or a list of integers", j->file, key);
        n = expand > 0 ? expand : 1;
        if (n > maxv) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\": too many blocks", j->file, key);
        for (k = 0; k < n; k++) vals[k] = (int)v;
    }
    if (n == 0) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is empty", j->file, key);
    buf[0] = 0;
    for (k = 0; k < n; k++) {
        int w = snprintf(buf + pos, bufcap - (size_t)pos, k ? ",%d" : "%d", vals[k]);
        if (w < 0 || (size_t)(pos + w) >= bufcap) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" too long", j->file, key);
        pos += w;
    }
    *count = n;
    return 0;
}

/* a list of strings as a comma list */
static int sm__jstrs(const sm__json *j, const char *key, char *buf, size_t bufcap, int *count, char *err, size_t cap) {
    int t = sm__jfind(j, key), k, pos = 0;
    char s[128];
    if (t < 0 || j->tok[t].type != SUPERMAT_JSON_ARRAY || j->tok[t].size == 0)
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is missing or not a list of strings", j->file, key);
    buf[0] = 0;
    for (k = 0; k < j->tok[t].size; k++) {
        int w;
        if (j->tok[t + 1 + k].type != SUPERMAT_JSON_STRING || supermat_json_string(j->text, &j->tok[t + 1 + k], s, sizeof s) < 0 || strchr(s, ','))
            return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" is not a list of names", j->file, key);
        w = snprintf(buf + pos, bufcap - (size_t)pos, k ? ",%s" : "%s", s);
        if (w < 0 || (size_t)(pos + w) >= bufcap) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: \"%s\" too long", j->file, key);
        pos += w;
    }
    *count = j->tok[t].size;
    return 0;
}

/* >>half : conversions, round to nearest even; NaN stays NaN (quiet), overflow goes to Inf */
static uint16_t sm__f32_to_f16(float f) {
    const uint32_t f32infty = 255u << 23, f16max = (127u + 16u) << 23, magic = ((127u - 15u) + (23u - 10u) + 1u) << 23;
    uint32_t x, sign;
    uint16_t o;
    memcpy(&x, &f, 4);
    sign = x & 0x80000000u;
    x ^= sign;
    if (x >= f16max) o = (uint16_t)(x > f32infty ? 0x7e00 : 0x7c00);
    else if (x < (113u << 23)) { /* subnormal or zero: let the FPU round (the default mode is nearest even) */
        float fx, fm;
        memcpy(&fx, &x, 4);
        memcpy(&fm, &magic, 4);
        fx += fm;
        memcpy(&x, &fx, 4);
        o = (uint16_t)(x - magic);
    } else {
        uint32_t odd = (x >> 13) & 1u;
        x += ((uint32_t)(15 - 127) << 23) + 0xfffu;
        x += odd;
        o = (uint16_t)(x >> 13);
    }
    return (uint16_t)(o | (sign >> 16));
}

static uint16_t sm__f32_to_bf16(float f) {
    uint32_t x;
    memcpy(&x, &f, 4);
    if ((x & 0x7fffffffu) > 0x7f800000u) return (uint16_t)((x >> 16) | 0x40u);
    x += 0x7fffu + ((x >> 16) & 1u);
    return (uint16_t)(x >> 16);
}

static float sm__f16_to_f32(uint16_t h) {
    uint32_t s = (uint32_t)(h >> 15) << 31, e = (h >> 10) & 31u, m = h & 1023u, bits;
    float f;
    if (e == 0) {
        f = (float)m * (1.0f / 16777216.0f);
        return s ? -f : f;
    }
    bits = e == 31 ? (s | 0x7f800000u | (m << 13)) : (s | ((e + 112u) << 23) | (m << 13));
    memcpy(&f, &bits, 4);
    return f;
}

static float sm__bf16_to_f32(uint16_t h) {
    uint32_t bits = (uint32_t)h << 16;
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

static size_t sm__dt_size(supermat_dtype d) { return d == SUPERMAT_DTYPE_F32 ? 4 : d == SUPERMAT_DTYPE_I8 ? 1 : 2; }
static const char *sm__dt_name(supermat_dtype d) {
    return d == SUPERMAT_DTYPE_F32 ? "F32" : d == SUPERMAT_DTYPE_F16 ? "F16" : d == SUPERMAT_DTYPE_I8 ? "I8" : "BF16";
}

/* Converts n elements (src and dst may not overlap). Returns the index of the first non-finite output
   value, or -1. `overflow` is set when a finite input became Inf. */
static long sm__convert_elems(const unsigned char *src, supermat_dtype sd, unsigned char *dst, supermat_dtype dd, size_t n, int *overflow) {
    size_t i;
    long bad = -1;
    *overflow = 0;
    for (i = 0; i < n; i++) {
        float f;
        uint16_t h;
        uint32_t u;
        if (sd == SUPERMAT_DTYPE_F32) memcpy(&f, src + 4 * i, 4);
        else {
            memcpy(&h, src + 2 * i, 2);
            f = sd == SUPERMAT_DTYPE_F16 ? sm__f16_to_f32(h) : sm__bf16_to_f32(h);
        }
        memcpy(&u, &f, 4);
        if ((u & 0x7f800000u) == 0x7f800000u) {
            if (bad < 0) bad = (long)i;
        }
        if (dd == SUPERMAT_DTYPE_F32) memcpy(dst + 4 * i, &f, 4);
        else {
            h = dd == SUPERMAT_DTYPE_F16 ? sm__f32_to_f16(f) : sm__f32_to_bf16(f);
            memcpy(dst + 2 * i, &h, 2);
            if (((dd == SUPERMAT_DTYPE_F16 && (h & 0x7c00u) == 0x7c00u) || (dd == SUPERMAT_DTYPE_BF16 && (h & 0x7f80u) == 0x7f80u)) && bad < 0) {
                bad = (long)i;
                *overflow = 1;
            }
        }
    }
    return bad;
}

/* index of the first non-finite element of a raw buffer, or -1 */
static long sm__first_nonfinite(const unsigned char *p, supermat_dtype d, size_t n) {
    size_t i;
    if (d == SUPERMAT_DTYPE_F32) {
        for (i = 0; i < n; i++) {
            uint32_t u;
            memcpy(&u, p + 4 * i, 4);
            if ((u & 0x7f800000u) == 0x7f800000u) return (long)i;
        }
    } else {
        uint16_t mask = d == SUPERMAT_DTYPE_F16 ? 0x7c00u : 0x7f80u;
        for (i = 0; i < n; i++) {
            uint16_t h;
            memcpy(&h, p + 2 * i, 2);
            if ((h & mask) == mask) return (long)i;
        }
    }
    return -1;
}

/* >>clip : transformers' CLIPTextModel, float32, for the empty prompt only.
   h = tok_emb[ids] + pos_emb; per layer (pre-LN): h += out(attn(LN1 h)) with a causal mask and scale
   head_dim^-0.5; h += fc2(act(fc1(LN2 h))); final LayerNorm. Linear layers keep float accumulation in
   input order (as a plain BLAS would); LayerNorm statistics, attention scores and softmax use double. */
enum { SM__ACT_GELU = 0, SM__ACT_QUICK_GELU, SM__ACT_GELU_TANH };

typedef struct sm__lin {
    const float *xt; /* the input transposed, [K][Mp] (Mp = M rounded up to 8, zero padded) */
    const float *w;  /* the torch weight, [N][K] */
    const float *b;  /* [N] or NULL */
    float *y;        /* [M][N] */
    int M, Mp, K, N;
} sm__lin;

/* y[i][n] = b[n] + sum_k x[i][k] w[n][k], k ascending; vectorised over i, four outputs n at a time. */
#define SM__IB 64
static void sm__lin_cols(const sm__lin *L, int n0, int n1) {
    const int K = L->K, N = L->N, Mp = L->Mp;
    int i, k, r, i0, n;
    float acc[4][SM__IB];
    for (i0 = 0; i0 < Mp; i0 += SM__IB) {
        int ib = SM__MIN(SM__IB, Mp - i0), iv = SM__MIN(ib, L->M - i0);
        for (n = n0; n < n1; n += 4) {
            int rows = SM__MIN(4, n1 - n);
            for (r = 0; r < 4; r++)
                for (i = 0; i < SM__IB; i++) acc[r][i] = (L->b && r < rows) ? L->b[n + r] : 0.0f;
            if (rows == 4 && ib == SM__IB) {
                const float *w0 = L->w + (size_t)n * K, *w1 = w0 + K, *w2 = w1 + K, *w3 = w2 + K;
                for (k = 0; k < K; k++) {
                    const float *SM__RESTRICT x = L->xt + (size_t)k * Mp + i0;
                    const float a0 = w0[k], a1 = w1[k], a2 = w2[k], a3 = w3[k];
                    for (i = 0; i < SM__IB; i++) {
                        acc[0][i] += x[i] * a0;
                        acc[1][i] += x[i] * a1;
                        acc[2][i] += x[i] * a2;
                        acc[3][i] += x[i] * a3;
                    }
                }
            } else {
                for (r = 0; r < rows; r++) {
                    const float *wr = L->w + (size_t)(n + r) * K;
                    for (k = 0; k < K; k++) {
                        const float *x = L->xt + (size_t)k * Mp + i0;
                        const float a = wr[k];
                        for (i = 0; i < ib; i++) acc[r][i] += x[i] * a;
                    }
                }
            }
            for (r = 0; r < rows; r++)
                for (i = 0; i < iv; i++) L->y[(size_t)(i0 + i) * N + n + r] = acc[r][i];
        }
    }
}

typedef struct sm__lin_job { const sm__lin *L; int n0, n1; } sm__lin_job;

#if SM__HAS_PTHREADS
static void *sm__lin_thread(void *p) {
    const sm__lin_job *j = (const sm__lin_job *)p;
    sm__lin_cols(j->L, j->n0, j->n1);
    return NULL;
}
#endif

/* y = x W^T + b for x [M][K]; xt is scratch of K * Mp floats. Outputs are split over threads; each is
   computed by one thread in the same order, so the result does not depend on the thread count. */
static void sm__linear(const float *x, int M, int K, const float *w, const float *b, int N, float *y, float *xt, int threads) {
    sm__lin L;
    int i, k;
    L.M = M;
    L.Mp = (M + 7) & ~7;
    L.K = K;
    L.N = N;
    L.w = w;
    L.b = b;
    L.y = y;
    L.xt = xt;
    for (k = 0; k < K; k++) {
        for (i = 0; i < M; i++) xt[(size_t)k * L.Mp + i] = x[(size_t)i * K + k];
        for (; i < L.Mp; i++) xt[(size_t)k * L.Mp + i] = 0.0f;
    }
#if SM__HAS_PTHREADS
    {
        pthread_t th[8];
        sm__lin_job jobs[8];
        int t, started[8];
        if (threads > 8) threads = 8;
        if (threads > N / 4) threads = N / 4;
        if (threads > 1) {
            for (t = 0; t < threads; t++) {
                jobs[t].L = &L;
                jobs[t].n0 = (int)(((long)N * t / threads) & ~3L);
                jobs[t].n1 = t + 1 == threads ? N : (int)(((long)N * (t + 1) / threads) & ~3L);
            }
            for (t = 1; t < threads; t++) started[t] = pthread_create(&th[t], NULL, sm__lin_thread, &jobs[t]) == 0;
            sm__lin_cols(&L, jobs[0].n0, jobs[0].n1);
            for (t = 1; t < threads; t++) {
                if (started[t]) pthread_join(th[t], NULL);
                else sm__lin_cols(&L, jobs[t].n0, jobs[t].n1);
            }
            return;
        }
    }
#else
    (void)threads;
#endif
    sm__lin_cols(&L, 0, N);
}

static void sm__layernorm(const float *x, float *y, int M, int C, const float *w, const float *b, double eps) {
    int i, c;
    for (i = 0; i < M; i++) {
        const float *xr = x + (size_t)i * C;
        float *yr = y + (size_t)i * C;
        double mean = 0, var = 0, inv;
        for (c = 0; c < C; c++) mean += xr[c];
        mean /= C;
        for (c = 0; c < C; c++) var += (xr[c] - mean) * (xr[c] - mean);
        var /= C;
        inv = 1.0 / sqrt(var + eps);
        for (c = 0; c < C; c++) yr[c] = (float)((xr[c] - mean) * inv * w[c] + b[c]);
    }
}

/* causal multi-head attention of q, k, v [T][C] into o [T][C] */
static void sm__attention(const float *q, const float *k, const float *v, float *o, int T, int C, int H, double *s) {
    int hd = C / H, h, i, j, d;
    double scale = 1.0 / sqrt((double)hd);
    for (h = 0; h < H; h++) {
        for (i = 0; i < T; i++) {
            const float *qi = q + (size_t)i * C + h * hd;
            double mx = -HUGE_VAL, sum = 0;
            for (j = 0; j <= i; j++) {
                const float *kj = k + (size_t)j * C + h * hd;
                double dot = 0;
                for (d = 0; d < hd; d++) dot += (double)qi[d] * kj[d];
                s[j] = dot * scale;
                if (s[j] > mx) mx = s[j];
            }
            for (j = 0; j <= i; j++) {
                s[j] = exp(s[j] - mx);
                sum += s[j];
            }
            for (d = 0; d < hd; d++) {
                double acc = 0;
                for (j = 0; j <= i; j++) acc += s[j] * v[(size_t)j * C + h * hd + d];
                o[(size_t)i * C + h * hd + d] = (float)(acc / sum);
            }
        }
    }
}

static void sm__activation(float *x, size_t n, int act) {
    size_t i;
    for (i = 0; i < n; i++) {
        double t = x[i];
        if (act == SM__ACT_GELU) t = 0.5 * t * (1.0 + erf(t * 0.70710678118654752440));
        else if (act == SM__ACT_QUICK_GELU) t = t / (1.0 + exp(-1.702 * t));
        else t = 0.5 * t * (1.0 + tanh(0.79788456080286535588 * (t + 0.044715 * t * t * t)));
        x[i] = (float)t;
    }
}

/* Reads tensor `name` as float32 into dst, checking its shape. rows >= 0: only rows [row0, row0+rows) of
   a 2-D tensor. */
static int sm__load_f32(sm_pth *p, const char *name, int ndim, int64_t d0, int64_t d1, int64_t row0, int64_t rows, float *dst,
                        char *err, size_t cap) {
    int i = sm_pth_find(p, name);
    const supermat_tensor_info *t;
    size_t es, n, k;
    uint64_t off = 0;
    uint32_t crc = 0;
    unsigned char *raw;
    int r;
    if (i < 0) return sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: tensor '%s' is missing", p->file, name);
    t = &p->t[i];
    if (t->ndim != ndim || t->shape[0] != d0 || (ndim == 2 && t->shape[1] != d1))
        return sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor '%s' has shape [%lld%s%lld], expected [%lld%s%lld] (from the config)", p->file, name,
                       (long long)t->shape[0], t->ndim > 1 ? ", " : "", (long long)(t->ndim > 1 ? t->shape[1] : 0), (long long)d0,
                       ndim > 1 ? ", " : "", (long long)(ndim > 1 ? d1 : 0));
    es = sm__dt_size(t->dtype);
    n = (size_t)d0 * (size_t)(ndim == 2 ? d1 : 1);
    if (rows >= 0) {
        off = (uint64_t)row0 * (uint64_t)d1 * es;
        n = (size_t)rows * (size_t)d1;
    }
    raw = (unsigned char *)dst + n * (4 - es); /* narrow types are read into the back half and widened forwards */
    r = sm__pth_read_part(p, i, off, raw, n * es, rows >= 0 ? NULL : &crc, err, cap);
    if (!r && rows < 0) r = sm__pth_crc_done(p, i, crc, err, cap);
    if (r) return r;
    if (t->dtype != SUPERMAT_DTYPE_F32)
        for (k = 0; k < n; k++) {
            uint16_t h;
            memcpy(&h, raw + 2 * k, 2);
            dst[k] = t->dtype == SUPERMAT_DTYPE_F16 ? sm__f16_to_f32(h) : sm__bf16_to_f32(h);
        }
    for (k = 0; k < n; k++)
        if (!(dst[k] - dst[k] == 0.0f)) return sm__err(err, cap, SUPERMAT_ERROR_NONFINITE, "%s: tensor '%s' holds NaN or Inf", p->file, name);
    return 0;
}

/* token ids of the empty prompt: [bos, eos, pad...]; from tokenizer/ when present */
static int sm__token_ids(const char *base, int vocab, int *bos, int *eos, int *pad, int *max_len, char *err, size_t cap) {
    sm__json voc, spec, tcfg;
    static const char *const keys[3] = {"bos_token", "eos_token", "pad_token"};
    static const char *const defs[3] = {"<|startoftext|>", "<|endoftext|>", "<|endoftext|>"};
    int *ids[3];
    int r, k, have_spec, have_tcfg;
    char tok[256];
    ids[0] = bos; ids[1] = eos; ids[2] = pad;
    *bos = 49406; *eos = 49407; *pad = 0; /* Stable Diffusion 2.x: pad with "!" */
    r = sm__json_load(&voc, base, "tokenizer/vocab.json", 1, err, cap);
    if (r < 0) return r;
    if (r == 1) return 0;
    have_spec = sm__json_load(&spec, base, "tokenizer/special_tokens_map.json", 1, err, cap);
    if (have_spec < 0) { sm__json_free(&voc); return have_spec; }
    have_tcfg = sm__json_load(&tcfg, base, "tokenizer/tokenizer_config.json", 1, err, cap);
    if (have_tcfg < 0) { sm__json_free(&voc); if (!have_spec) sm__json_free(&spec); return have_tcfg; }
    r = 0;
    for (k = 0; k < 3 && !r; k++) {
        int t = -1;
        double v;
        const char *src = "default";
        snprintf(tok, sizeof tok, "%s", defs[k]);
        if (have_spec == 0 && sm__jstr_tok(&spec, sm__jfind(&spec, keys[k]), tok, sizeof tok) == 0) src = "tokenizer/special_tokens_map.json";
        else if (have_tcfg == 0 && sm__jstr_tok(&tcfg, sm__jfind(&tcfg, keys[k]), tok, sizeof tok) == 0) src = "tokenizer/tokenizer_config.json";
        t = sm__jfind(&voc, tok);
        if (t < 0 || supermat_json_number(voc.text, &voc.tok[t], &v) || v != floor(v) || v < 0 || v >= vocab)
            r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: %s '%s' (from %s) has no valid id below the text encoder's vocab_size %d",
                        voc.file, keys[k], tok, src, vocab);
        else *ids[k] = (int)v;
    }
    if (!r && have_tcfg == 0) {
        double ml;
        int t = sm__jfind(&tcfg, "model_max_length");
        if (!sm__jnull(&tcfg, t) && supermat_json_number(tcfg.text, &tcfg.tok[t], &ml) == 0 && ml >= 2 && ml < *max_len) *max_len = (int)ml;
    }
    if (!r && *bos == *eos) r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: bos and eos tokens have the same id %d", voc.file, *bos);
    sm__json_free(&voc);
    if (have_spec == 0) sm__json_free(&spec);
    if (have_tcfg == 0) sm__json_free(&tcfg);
    return r;
}

/* A Git LFS pointer instead of the file (a clone without `git lfs pull`): a small text file starting so */
static int sm__lfs_pointer(const char *path, char *err, size_t cap) {
    char b[64];
    size_t n;
    FILE *f = sm__fopen_read(path);
    if (!f) return 0;
    n = fread(b, 1, sizeof b - 1, f);
    fclose(f);
    b[n] = 0;
    if (n >= 20 && !strncmp(b, "version https://git-lfs", 23)) {
        sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s is a Git LFS pointer, not the weights: fetch the file itself (`git lfs pull` in that repository)", path);
        return 1;
    }
    return 0;
}

/* The first of `names` that exists under base/dir (diffusers' preference: full-precision non-variant
   files first, safetensors before .bin, then the fp16 variants); says which on stderr. When none exists,
   the message lists every name tried. */
static int sm__open_weights(const char *base, const char *dir, const char *const *names, int skip_unsupported, sm_pth **out,
                            char *path, size_t path_cap, char *err, size_t cap) {
    int k;
    char tried[600];
    size_t t = 0;
    *out = NULL;
    tried[0] = 0;
    for (k = 0; names[k]; k++) {
        snprintf(path, path_cap, "%s/%s/%s", base, dir, names[k]);
        if (sm__file_exists(path)) {
            if (sm__lfs_pointer(path, err, cap)) return SUPERMAT_ERROR_MALFORMED_FILE;
            fprintf(stderr, "sm_convert: %s: %s\n", dir, path);
            return sm__pth_open(path, NULL, 0, skip_unsupported, out, err, cap);
        }
        if (k && t < sizeof tried) t += (size_t)snprintf(tried + t, sizeof tried - t, "%s%s", k > 1 ? ", " : "", names[k]);
    }
    tried[t < sizeof tried ? t : sizeof tried - 1] = 0;
    snprintf(path, path_cap, "%s/%s/%s", base, dir, names[0]);
    return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: missing (cannot open; also tried %s in that folder)", path, tried);
}

int sm_text_encode_empty(const char *base, int threads, int progress, float **out, int *tokens_out, int *dim_out, char *err, size_t cap) {
    static const char *const files[] = {"model.safetensors", "pytorch_model.bin", "model.fp16.safetensors", "pytorch_model.fp16.bin", NULL};
    sm__json cfg;
    sm_pth *p = NULL;
    char path[600], name[160], act_s[64];
    int C, L, H, F, T, V, ntok, bos, eos, pad, act = SM__ACT_GELU, l, i, r;
    double eps;
    float *h = NULL, *x = NULL, *q = NULL, *k = NULL, *v = NULL, *a = NULL, *m = NULL, *pos = NULL, *w = NULL, *xt = NULL, *wq, *wk, *wv, *wo, *w1, *w2;
    float *bq, *bk, *bv, *bo, *b1, *b2, *ln1w, *ln1b, *ln2w, *ln2b, *row;
    double *s = NULL;
    size_t CC, FC;
    if (out) *out = NULL;
    if (!base || !out || !tokens_out || !dim_out) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_text_encode_empty: NULL argument");
    if (threads <= 0) threads = 2;
    r = sm__json_load(&cfg, base, "text_encoder/config.json", 0, err, cap);
    if (r) return r;
    if ((r = sm__jint(&cfg, "hidden_size", 1, 0, 1, 1 << 16, &C, err, cap)) || (r = sm__jint(&cfg, "num_hidden_layers", 1, 0, 0, 1000, &L, err, cap)) ||
        (r = sm__jint(&cfg, "num_attention_heads", 1, 0, 1, 1 << 16, &H, err, cap)) ||
        (r = sm__jint(&cfg, "intermediate_size", 1, 0, 1, 1 << 18, &F, err, cap)) ||
        (r = sm__jint(&cfg, "max_position_embeddings", 0, 77, 2, 1 << 16, &T, err, cap)) ||
        (r = sm__jint(&cfg, "vocab_size", 0, 49408, 1, 1 << 24, &V, err, cap)) || (r = sm__jnum(&cfg, "layer_norm_eps", 0, 1e-5, &eps, err, cap)) ||
        (r = sm__jstr(&cfg, "hidden_act", "quick_gelu", act_s, sizeof act_s, err, cap))) {
        sm__json_free(&cfg);
        return r;
    }
    if (C % H) r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: hidden_size %d is not a multiple of num_attention_heads %d", cfg.file, C, H);
    else if (!(eps > 0 && eps < 1)) r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: bad layer_norm_eps", cfg.file);
    if (!strcmp(act_s, "gelu")) act = SM__ACT_GELU;
    else if (!strcmp(act_s, "quick_gelu")) act = SM__ACT_QUICK_GELU;
    else if (!strcmp(act_s, "gelu_new") || !strcmp(act_s, "gelu_pytorch_tanh")) act = SM__ACT_GELU_TANH;
    else if (!r) r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: hidden_act '%s' is not supported (gelu, quick_gelu, gelu_new)", cfg.file, act_s);
    sm__json_free(&cfg);
    if (r) return r;
    ntok = T;
    r = sm__token_ids(base, V, &bos, &eos, &pad, &ntok, err, cap);
    if (r) return r;
    r = sm__open_weights(base, "text_encoder", files, 1, &p, path, sizeof path, err, cap);
    if (r) return r;
    if (progress) fprintf(stderr, "sm_convert: text encoder %d layers x %d wide, tokens [%d, %d, %d x %d]\n", L, C, bos, eos, pad, ntok - 2);
    CC = (size_t)C * C;
    FC = (size_t)F * C;
    h = (float *)malloc(sizeof(float) * (size_t)ntok * C);
    x = (float *)malloc(sizeof(float) * (size_t)ntok * C);
    q = (float *)malloc(sizeof(float) * (size_t)ntok * C);
    k = (float *)malloc(sizeof(float) * (size_t)ntok * C);
    v = (float *)malloc(sizeof(float) * (size_t)ntok * C);
    a = (float *)malloc(sizeof(float) * (size_t)ntok * C);
    m = (float *)malloc(sizeof(float) * (size_t)ntok * F);
    pos = (float *)malloc(sizeof(float) * (size_t)T * C);
    w = (float *)malloc(sizeof(float) * (4 * CC + 2 * FC + 2 * (size_t)F + 8 * (size_t)C));
    xt = (float *)malloc(sizeof(float) * (size_t)SM__MAX(C, F) * (size_t)((ntok + 7) & ~7));
    s = (double *)malloc(sizeof(double) * (size_t)ntok);
    if (!h || !x || !q || !k || !v || !a || !m || !pos || !w || !xt || !s) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "text encoder: out of memory"); goto done; }
    wq = w; wk = wq + CC; wv = wk + CC; wo = wv + CC; w1 = wo + CC; w2 = w1 + FC;
    b1 = w2 + FC; bq = b1 + F; bk = bq + C; bv = bk + C; bo = bv + C; b2 = bo + C; ln1w = b2 + C; ln1b = ln1w + C; ln2w = ln1b + C; ln2b = ln2w + C;
    (void)ln2b;
    /* embeddings: only the three distinct token rows are read */
    r = sm__load_f32(p, "text_model.embeddings.position_embedding.weight", 2, T, C, 0, -1, pos, err, cap);
    for (i = 0; i < ntok && !r; i++) {
        int id = i == 0 ? bos : i == 1 ? eos : pad;
        row = h + (size_t)i * C;
        if (i > 2) memcpy(row, h + (size_t)2 * C, sizeof(float) * (size_t)C);
        else r = sm__load_f32(p, "text_model.embeddings.token_embedding.weight", 2, V, C, id, 1, row, err, cap);
    }
    if (r) goto done;
    for (i = 0; i < ntok * C; i++) h[i] += pos[i];
    for (l = 0; l < L; l++) {
        static const char *const lin_names[6] = {"self_attn.q_proj", "self_attn.k_proj", "self_attn.v_proj", "self_attn.out_proj", "mlp.fc1", "mlp.fc2"};
        float *wts[6], *bs[6];
        int outs[6], ins[6], j;
        wts[0] = wq; wts[1] = wk; wts[2] = wv; wts[3] = wo; wts[4] = w1; wts[5] = w2;
        bs[0] = bq; bs[1] = bk; bs[2] = bv; bs[3] = bo; bs[4] = b1; bs[5] = b2;
        for (j = 0; j < 6; j++) { outs[j] = j == 4 ? F : C; ins[j] = j == 5 ? F : C; }
        for (j = 0; j < 6 && !r; j++) {
            snprintf(name, sizeof name, "text_model.encoder.layers.%d.%s.weight", l, lin_names[j]);
            r = sm__load_f32(p, name, 2, outs[j], ins[j], 0, -1, wts[j], err, cap);
            if (r) break;
            snprintf(name, sizeof name, "text_model.encoder.layers.%d.%s.bias", l, lin_names[j]);
            r = sm__load_f32(p, name, 1, outs[j], 0, 0, -1, bs[j], err, cap);
        }
        for (j = 0; j < 4 && !r; j++) {
            snprintf(name, sizeof name, "text_model.encoder.layers.%d.layer_norm%d.%s", l, 1 + j / 2, j & 1 ? "bias" : "weight");
            r = sm__load_f32(p, name, 1, C, 0, 0, -1, ln1w + (size_t)j * C, err, cap);
        }
        if (r) goto done;
        sm__layernorm(h, x, ntok, C, ln1w, ln1b, eps);
        sm__linear(x, ntok, C, wq, bq, C, q, xt, threads);
        sm__linear(x, ntok, C, wk, bk, C, k, xt, threads);
        sm__linear(x, ntok, C, wv, bv, C, v, xt, threads);
        sm__attention(q, k, v, a, ntok, C, H, s);
        sm__linear(a, ntok, C, wo, bo, C, x, xt, threads);
        for (i = 0; i < ntok * C; i++) h[i] += x[i];
        sm__layernorm(h, x, ntok, C, ln2w, ln2w + C, eps);
        sm__linear(x, ntok, C, w1, b1, F, m, xt, threads);
        sm__activation(m, (size_t)ntok * F, act);
        sm__linear(m, ntok, F, w2, b2, C, x, xt, threads);
        for (i = 0; i < ntok * C; i++) h[i] += x[i];
        if (progress) fprintf(stderr, "sm_convert: text encoder layer %d/%d\n", l + 1, L);
    }
    r = sm__load_f32(p, "text_model.final_layer_norm.weight", 1, C, 0, 0, -1, ln1w, err, cap);
    if (!r) r = sm__load_f32(p, "text_model.final_layer_norm.bias", 1, C, 0, 0, -1, ln1b, err, cap);
    if (r) goto done;
    sm__layernorm(h, x, ntok, C, ln1w, ln1b, eps);
    for (i = 0; i < ntok * C; i++)
        if (!(x[i] - x[i] == 0.0f)) { r = sm__err(err, cap, SUPERMAT_ERROR_NONFINITE, "%s: the text encoder output holds NaN or Inf", path); goto done; }
    *out = x;
    x = NULL;
    *tokens_out = ntok;
    *dim_out = C;
done:
    free(h); free(x); free(q); free(k); free(v); free(a); free(m); free(pos); free(w); free(xt); free(s);
    sm_pth_close(p);
    return r;
}

/* >>writer : safetensors output. Header: {"__metadata__": {...}, "<name>": {"dtype", "shape",
   "data_offsets"}, ...} in data order, padded with spaces to a multiple of 8 bytes; tensors back to back. */
typedef struct sm__sbuf {
    char *p;
    size_t n, cap;
    int oom;
} sm__sbuf;

static void sm__sb_put(sm__sbuf *b, const char *s, size_t n) {
    if (b->oom) return;
    if (n + 1 > b->cap - b->n || !b->p) {
        size_t nc = b->cap ? b->cap : 4096;
        char *q;
        while (nc - b->n < n + 1) {
            if (nc > SIZE_MAX / 2) { b->oom = 1; return; }
            nc *= 2;
        }
        q = (char *)realloc(b->p, nc);
        if (!q) { b->oom = 1; return; }
        b->p = q;
        b->cap = nc;
    }
    memcpy(b->p + b->n, s, n);
    b->n += n;
    b->p[b->n] = 0;
}
static void sm__sb_str(sm__sbuf *b, const char *s) { sm__sb_put(b, s, strlen(s)); }
static void sm__sb_printf(sm__sbuf *b, const char *fmt, ...) {
    char tmp[256];
    int n;
    va_list ap;
    va_start(ap, fmt);
    n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof tmp) { b->oom = 1; return; }
    sm__sb_put(b, tmp, (size_t)n);
}
static void sm__sb_json_str(sm__sbuf *b, const char *s) {
    sm__sb_put(b, "\"", 1);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') { sm__sb_put(b, "\\", 1); sm__sb_put(b, s, 1); }
        else if (c < 0x20) sm__sb_printf(b, "\\u%04x", c);
        else sm__sb_put(b, s, 1);
    }
    sm__sb_put(b, "\"", 1);
}

typedef struct sm__meta { char key[48]; char val[SM__CURVE_TEXT]; } sm__meta;
typedef struct sm__metas { sm__meta m[64]; int n; } sm__metas;

static void sm__meta_add(sm__metas *ms, const char *key, const char *fmt, ...) {
    va_list ap;
    if (ms->n >= (int)(sizeof ms->m / sizeof ms->m[0])) return;
    snprintf(ms->m[ms->n].key, sizeof ms->m[ms->n].key, "%s", key);
    va_start(ap, fmt);
    vsnprintf(ms->m[ms->n].val, sizeof ms->m[ms->n].val, fmt, ap);
    va_end(ap);
    ms->n++;
}

/* pipeline.detail_sigma / pipeline.chroma_weight / pipeline.bake_detail_sigma: 0 (off) to 1, and off for a
   uv-refine model (it has no input picture to keep detail or take colour from, and no views to bake:
   supermat.h refuses the steps for it) */
static int sm__pipeline_step_check(const char *key, float v, int uv, char *err, size_t cap) {
    if (!(v >= 0.0f && v <= 1.0f)) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "pipeline.%s %g: from 0 (off) to 1", key, (double)v);
    if (v > 0.0f && uv)
        return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "pipeline.%s: a uv-refine model has no input picture for the %s step",
                       key, key[0] == 'd' ? "detail" : key[0] == 'b' ? "bake detail" : "colour");
    return 0;
}

/* pipeline.roughness_curve / metallic_curve (key): the knots of `text` (supermat_parse_curve) written "K0,K1,..."
   into out, each the shortest "%.Ng" (N = 6 to 9) that reads back as the same float; 0 or an error */
static int sm__curve_text(const char *key, const char *text, char *out, size_t out_cap, char *err, size_t cap) {
    float k[SUPERMAT_CURVE_MAX_KNOTS];
    supermat_error e;
    size_t len = 0;
    int n, i;
    if (supermat_parse_curve(text, k, &n, &e) != SUPERMAT_SUCCESS) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: %s", key, e.message);
    out[0] = 0;
    for (i = 0; i < n && len < out_cap; i++) { /* the shortest text that reads back as the same float */
        char t[32];
        int p = 6;
        do snprintf(t, sizeof t, "%.*g", p++, (double)k[i]); while (p <= 9 && strtof(t, NULL) != k[i]);
        len += (size_t)snprintf(out + len, out_cap - len, "%s%s", i ? "," : "", t);
    }
    return 0;
}

typedef struct sm__otensor {
    char name[SM__NAME_CAP];
    int src; /* 0 checkpoint, 1 VAE, 2 context */
    int index;
    int q;   /* 1: an int8 weight, 2: its scales (the next tensor, written with it) */
    supermat_dtype in_dt, out_dt;
    int ndim;
    int64_t shape[8];
    uint64_t in_bytes, out_bytes, out_off;
} sm__otensor;

/* Streams one tensor from its file to f, converting the dtype if asked. */
static int sm__write_tensor(FILE *f, sm_pth *p, const sm__otensor *o, unsigned char *inb, unsigned char *outb, const char *outpath,
                            char *err, size_t cap) {
    size_t esi = sm__dt_size(o->in_dt), eso = sm__dt_size(o->out_dt);
    uint64_t done = 0;
    uint32_t crc = 0;
    int r;
    while (done < o->in_bytes) {
        size_t n = (size_t)SM__MIN((uint64_t)SM__CHUNK, o->in_bytes - done), ne = n / esi;
        long bad;
        int ovf = 0;
        const unsigned char *w = inb;
        r = sm__pth_read_part(p, o->index, done, inb, n, &crc, err, cap);
        if (r) return r;
        if (o->in_dt == o->out_dt) bad = sm__first_nonfinite(inb, o->in_dt, ne);
        else {
            bad = sm__convert_elems(inb, o->in_dt, outb, o->out_dt, ne, &ovf);
            w = outb;
        }
        if (bad >= 0) {
            unsigned long long at = (unsigned long long)(done / esi) + (unsigned long long)bad;
            if (ovf) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor '%s': element %llu is too large for %s", p->file, o->name, at, sm__dt_name(o->out_dt));
            return sm__err(err, cap, SUPERMAT_ERROR_NONFINITE, "%s: tensor '%s' holds NaN or Inf (element %llu)", p->file, o->name, at);
        }
        if (fwrite(w, 1, ne * eso, f) != ne * eso) return sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: write error (disk full?)", outpath);
        done += n;
    }
    return sm__pth_crc_done(p, o->index, crc, err, cap);
}

/* int8 weights, the format of supermat.h's INT8 WEIGHTS: per row, kernel tap and 64 input channels a
   scale max |w| / 127 and q = round-to-nearest-even(w * (127 / max)), in the very float operations the
   runtime uses when it quantizes at load (so both give the same bits). Reads the whole tensor. */
static int sm__write_i8(FILE *f, sm_pth *p, const sm__otensor *o, const sm__otensor *so, unsigned char *inb, const char *outpath,
                        char *err, size_t cap) {
    size_t esi = sm__dt_size(o->in_dt), ne = (size_t)(o->in_bytes / esi), rows = (size_t)o->shape[0], cin = (size_t)o->shape[1];
    size_t taps = o->ndim == 4 ? (size_t)(o->shape[2] * o->shape[3]) : 1, ng = (size_t)so->shape[2], row, tap, g, c;
    float *w = (float *)malloc(sizeof(float) * (ne ? ne : 1)), *sc = (float *)malloc((size_t)so->out_bytes ? (size_t)so->out_bytes : 4);
    signed char *q = (signed char *)malloc(ne ? ne : 1);
    uint64_t done = 0;
    uint32_t crc = 0;
    int r = 0, ovf;
    if (!w || !sc || !q) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory for tensor '%s' (%llu elements)", o->name, (unsigned long long)ne); goto done; }
    while (done < o->in_bytes) {
        size_t n = (size_t)SM__MIN((uint64_t)SM__CHUNK, o->in_bytes - done);
        long bad;
        if ((r = sm__pth_read_part(p, o->index, done, inb, n, &crc, err, cap))) goto done;
        bad = sm__convert_elems(inb, o->in_dt, (unsigned char *)(w + done / esi), SUPERMAT_DTYPE_F32, n / esi, &ovf);
        if (bad >= 0) { r = sm__err(err, cap, SUPERMAT_ERROR_NONFINITE, "%s: tensor '%s' holds NaN or Inf (element %llu)", p->file, o->name, (unsigned long long)(done / esi) + (unsigned long long)bad); goto done; }
        done += n;
    }
    if ((r = sm__pth_crc_done(p, o->index, crc, err, cap))) goto done;
    for (row = 0; row < rows; row++)
        for (tap = 0; tap < taps; tap++)
            for (g = 0; g < ng; g++) {
                size_t c1 = SM__MIN(cin, (g + 1) * 64);
                float mx = 0.0f, inv;
                for (c = g * 64; c < c1; c++) { float v = fabsf(w[(row * cin + c) * taps + tap]); if (v > mx) mx = v; }
                inv = mx > 0.0f ? 127.0f / mx : 0.0f;
                sc[(row * taps + tap) * ng + g] = mx / 127.0f;
                for (c = g * 64; c < c1; c++) {
                    size_t i = (row * cin + c) * taps + tap;
                    float v = rintf(w[i] * inv);
                    q[i] = (signed char)(v > 127.0f ? 127 : v < -127.0f ? -127 : (int)v);
                }
            }
    if (fwrite(q, 1, ne, f) != ne || fwrite(sc, 1, (size_t)so->out_bytes, f) != (size_t)so->out_bytes)
        r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: write error (disk full?)", outpath);
done:
    free(w); free(sc); free(q);
    return r;
}


/* The written file through the runtime's own loader before it is renamed into place: every tensor the
   architecture needs is there with its shape (today's check of the complete key set). The official
   code loads the Stable Diffusion UNet first and the checkpoint over it with strict=False, so a key
   the checkpoint lacks silently keeps the base weight there; supermat refuses instead, naming the key. */
static int sm__validate_output(const char *path, char *err, size_t cap) {
    FILE *f = sm__fopen_read(path);
    unsigned char *buf = NULL;
    long n = -1;
    int r = 0;
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error e;
    if (f && fseek(f, 0, SEEK_END) == 0) n = ftell(f);
    if (f && n > 0 && fseek(f, 0, SEEK_SET) == 0 && (buf = (unsigned char *)malloc((size_t)n)) != NULL &&
        fread(buf, 1, (size_t)n, f) == (size_t)n) {
        memset(&md, 0, sizeof md);
        md.data = buf;
        md.size = (size_t)n;
        r = supermat_model_create(&md, &m, &e);
        if (r == SUPERMAT_ERROR_MISSING_TENSOR && !strncmp(e.tensor, "unet.", 5))
            r = sm__err(err, cap, r, "the checkpoint lacks '%s' (%s). The official code would keep the base UNet's weight there "
                        "(load_state_dict strict=False); supermat refuses: give a complete checkpoint", e.tensor + 5, e.message);
        else if (r == SUPERMAT_ERROR_MISSING_TENSOR && !strncmp(e.tensor, "vae.", 4))
            r = sm__err(err, cap, r, "the base folder's VAE lacks '%s' (%s)", e.tensor + 4, e.message);
        else if (r)
            r = sm__err(err, cap, r, "the converted model does not load: %s%s%s", e.message, e.tensor[0] ? " -- tensor " : "", e.tensor);
        if (m) supermat_model_destroy(m);
    } else {
        r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: cannot read back the written file", path);
    }
    free(buf);
    if (f) fclose(f);
    return r;
}

static int sm__write_model(const char *outpath, const sm__metas *ms, const sm__otensor *ot, int nt, sm_pth *ck, sm_pth *vae, const float *ctx,
                           int progress, char *err, size_t cap) {
    sm__sbuf hb;
    char *tmp = NULL;
    FILE *f = NULL;
    unsigned char *inb = NULL, *outb = NULL, len8[8];
    uint64_t total = 0, hl, written = 0, next_report = 0;
    int i, k, r = 0;
    size_t plen = strlen(outpath);
    memset(&hb, 0, sizeof hb);
    sm__sb_str(&hb, "{\"__metadata__\":{");
    for (i = 0; i < ms->n; i++) {
        if (i) sm__sb_str(&hb, ",");
        sm__sb_json_str(&hb, ms->m[i].key);
        sm__sb_str(&hb, ":");
        sm__sb_json_str(&hb, ms->m[i].val);
    }
    sm__sb_str(&hb, "}");
    for (i = 0; i < nt; i++) {
        sm__sb_str(&hb, ",");
        sm__sb_json_str(&hb, ot[i].name);
        sm__sb_printf(&hb, ":{\"dtype\":\"%s\",\"shape\":[", sm__dt_name(ot[i].out_dt));
        for (k = 0; k < ot[i].ndim; k++) sm__sb_printf(&hb, k ? ",%lld" : "%lld", (long long)ot[i].shape[k]);
        sm__sb_printf(&hb, "],\"data_offsets\":[%llu,%llu]}", (unsigned long long)ot[i].out_off, (unsigned long long)(ot[i].out_off + ot[i].out_bytes));
        total = ot[i].out_off + ot[i].out_bytes;
    }
    sm__sb_str(&hb, "}");
    while (!hb.oom && (hb.n & 7)) sm__sb_str(&hb, " ");
    if (hb.oom) { free(hb.p); return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory for the output header"); }
    hl = hb.n;
    for (k = 0; k < 8; k++) len8[k] = (unsigned char)(hl >> (8 * k));
    tmp = (char *)malloc(plen + 64);
    inb = (unsigned char *)malloc(SM__CHUNK);
    outb = (unsigned char *)malloc(SM__CHUNK * 2);
    if (!tmp || !inb || !outb) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory"); goto done; }
#if defined(_WIN32)
    memcpy(tmp, outpath, plen);
    memcpy(tmp + plen, ".tmp", 5);
    f = fopen(tmp, "wb");
#else
    { /* a new temporary file beside OUT, never an existing file or a planted link (O_EXCL | O_NOFOLLOW): the name
         cli/smio.h gives its temporary files, so a killed run's file is removed by a later one */
        const char *slash = strrchr(outpath, '/');
        size_t dl = slash ? (size_t)(slash - outpath) + 1 : 0;
        int fd = -1, k;
        for (k = 0; k < 100 && fd < 0; k++) {
            memcpy(tmp, outpath, dl);
            snprintf(tmp + dl, plen + 64 - dl, ".%.180s.%ld-%x-%08lx" SMIO_TMP_SUFFIX, outpath + dl, (long)getpid(), (unsigned)(rand() & 0xffffff),
                     smio_host_tag());
            fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW, 0666);
            if (fd < 0 && errno != EEXIST) break;
        }
        f = fd >= 0 ? fdopen(fd, "wb") : NULL;
        if (!f && fd >= 0) { close(fd); remove(tmp); }
    }
#endif
    if (!f) { r = sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: cannot create", tmp); goto done; }
    if (fwrite(len8, 1, 8, f) != 8 || fwrite(hb.p, 1, hb.n, f) != hb.n) { r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: write error", tmp); goto done; }
    for (i = 0; i < nt && !r; i++) {
        if (ot[i].src == 2) {
            if (fwrite(ctx, 1, (size_t)ot[i].out_bytes, f) != (size_t)ot[i].out_bytes) r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: write error", tmp);
        } else if (ot[i].q == 1) r = sm__write_i8(f, ot[i].src == 0 ? ck : vae, &ot[i], &ot[i + 1], inb, tmp, err, cap);
        else if (ot[i].q != 2) r = sm__write_tensor(f, ot[i].src == 0 ? ck : vae, &ot[i], inb, outb, tmp, err, cap);
        written += ot[i].out_bytes;
        if (progress && (written >= next_report || i + 1 == nt)) {
            fprintf(stderr, "sm_convert: writing %3d%% (%.2f of %.2f GB)\n", total ? (int)(100.0 * (double)written / (double)total) : 100, written / 1e9, total / 1e9);
            next_report = written + total / 10;
        }
    }
    if (!r && (fflush(f) != 0 || ferror(f))) r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: write error (disk full?)", tmp);
#if !defined(_WIN32)
    if (!r && fsync(fileno(f)) != 0 && errno != EINVAL) r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: write error (disk full?)", tmp);
#endif
    if (fclose(f) != 0 && !r) r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "%s: write error (disk full?)", tmp);
    f = NULL;
    if (!r) r = sm__validate_output(tmp, err, cap);
    if (!r) {
#ifdef _WIN32
        remove(outpath);
#endif
        if (rename(tmp, outpath) != 0) r = sm__err(err, cap, SUPERMAT_ERROR_INTERNAL, "cannot rename %s to %s", tmp, outpath);
    }
    if (r) remove(tmp);
done:
    if (f) {
        fclose(f);
        remove(tmp);
    }
    free(tmp);
    free(inb);
    free(outb);
    free(hb.p);
    return r;
}

/* >>convert */
enum { SM__KIND_NONE = 0, SM__KIND_SUPERMAT, SM__KIND_MV, SM__KIND_UV };
static const char *const sm__kind_names[4] = {"?", "supermat", "supermat-mv", "uv-refine"};

static int sm__has_prefix(const sm_pth *p, const char *prefix, char *first, size_t cap) {
    int i;
    size_t n = strlen(prefix);
    for (i = 0; i < p->n; i++)
        if (!strncmp(p->t[i].name, prefix, n)) {
            if (first) snprintf(first, cap, "%s", p->t[i].name);
            return 1;
        }
    return 0;
}

static int sm__branches(const sm_pth *p) {
    char nm[64];
    int b = 0;
    for (;;) {
        snprintf(nm, sizeof nm, "rep_conv_out.%d.weight", b);
        if (sm_pth_find(p, nm) < 0) return b;
        b++;
    }
}

/* What the checkpoint is, and whether it matches the requested kind (0 = detect). */
static int sm__check_kind(const sm_pth *p, int want, int *kind, char *err, size_t cap) {
    char cls[SM__NAME_CAP], tmp[SM__NAME_CAP];
    int has_cls = sm__has_prefix(p, "class_embedding.", cls, sizeof cls);
    int has_rep_in = sm_pth_find(p, "rep_conv_in.0.weight") >= 0;
    int has_first = sm__has_prefix(p, "first_down_blocks.0.", NULL, 0);
    int has_last = sm__has_prefix(p, "last_up_blocks.", NULL, 0);
    int nb = sm__branches(p), got = SM__KIND_NONE;
    if (has_rep_in && has_first && !has_cls) got = SM__KIND_UV;
    else if (nb >= 2 && has_last && !has_rep_in) got = has_cls ? SM__KIND_MV : SM__KIND_SUPERMAT;
    if (want == SM__KIND_NONE) {
        if (got == SM__KIND_NONE)
            return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: not a SuperMat checkpoint (expected rep_conv_out.0/1.weight and last_up_blocks.*, or rep_conv_in.0.weight and first_down_blocks.0.*)", p->file);
        *kind = got;
        return 0;
    }
    *kind = want;
    if (want == SM__KIND_UV) {
        if (!has_rep_in) return sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: kind uv-refine needs tensor 'rep_conv_in.0.weight', absent%s%s", p->file, got ? ": this looks like a " : "", got ? sm__kind_names[got] : "");
        if (!has_first) return sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: kind uv-refine needs tensors 'first_down_blocks.0.*', absent", p->file);
        if (has_cls) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor '%s' is not expected in a uv-refine checkpoint", p->file, cls);
        if (nb < 1) return sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: tensor 'rep_conv_out.0.weight' is missing", p->file);
        return 0;
    }
    if (has_rep_in)
        return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor 'rep_conv_in.0.weight' belongs to a uv-refine checkpoint, but kind %s was requested", p->file, sm__kind_names[want]);
    if (nb < 2) {
        snprintf(tmp, sizeof tmp, "rep_conv_out.%d.weight", nb);
        return sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: kind %s needs tensor '%s' (two branches), absent", p->file, sm__kind_names[want], tmp);
    }
    if (!has_last) return sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: kind %s needs tensors 'last_up_blocks.*', absent", p->file, sm__kind_names[want]);
    if (want == SM__KIND_SUPERMAT && has_cls)
        return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor '%s' means a SuperMatMV checkpoint, but kind supermat was requested (use supermat-mv)", p->file, cls);
    if (want == SM__KIND_MV && sm_pth_find(p, "class_embedding.linear_1.weight") < 0)
        return sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: kind supermat-mv needs tensor 'class_embedding.linear_1.weight' (the camera embedding), absent: a single-view checkpoint? (use supermat)", p->file);
    return 0;
}

static const supermat_tensor_info *sm__need(const sm_pth *p, const char *name, int ndim, char *err, size_t cap, int *r) {
    int i = sm_pth_find(p, name);
    if (i < 0) { *r = sm__err(err, cap, SUPERMAT_ERROR_MISSING_TENSOR, "%s: tensor '%s' is missing", p->file, name); return NULL; }
    if (p->t[i].ndim != ndim) { *r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor '%s' has %d dimensions, expected %d", p->file, name, p->t[i].ndim, ndim); return NULL; }
    return &p->t[i];
}

/* diffusers' pre-0.14 VAE attention names -> the current ones */
static void sm__vae_name(const char *in, char *out, size_t cap, int *renamed) {
    static const char *const from[4] = {".query.", ".key.", ".value.", ".proj_attn."};
    static const char *const to[4] = {".to_q.", ".to_k.", ".to_v.", ".to_out.0."};
    const char *a = strstr(in, ".attentions.");
    int k;
    *renamed = 0;
    if (a) {
        const char *seg = strchr(a + 12, '.'); /* after the attention index */
        for (k = 0; seg && k < 4; k++) {
            size_t n = strlen(from[k]);
            if (!strncmp(seg, from[k], n) && strchr(seg + n, '.') == NULL) {
                snprintf(out, cap, "vae.%.*s%s%s", (int)(seg - in), in, to[k], seg + n);
                *renamed = 1;
                return;
            }
        }
    }
    snprintf(out, cap, "vae.%s", in);
}

/* int8 output: the weights the runtime multiplies in its GEMMs. The cross-attention keys and values are
   not: they are folded with the constant context at load, so they keep their precision. */
static int sm__int8_weight(const char *name, int ndim) {
    size_t n = strlen(name);
    if ((ndim != 2 && ndim != 4) || n < 7 || strcmp(name + n - 7, ".weight")) return 0;
    return !strstr(name, ".attn2.to_k.weight") && !strstr(name, ".attn2.to_v.weight");
}

static int sm__add_outputs(sm__otensor *ot, int *nt, sm_pth *p, int src, supermat_dtype dt, uint64_t *off, char *err, size_t cap) {
    int i, renamed;
    for (i = 0; i < p->n; i++) {
        sm__otensor *o = &ot[*nt];
        const supermat_tensor_info *t = &p->t[i];
        uint64_t ne = t->nbytes / sm__dt_size(t->dtype);
        memset(o, 0, sizeof *o);
        if (src == 1) {
            char nm[SM__NAME_CAP + 8];
            sm__vae_name(t->name, nm, sizeof nm, &renamed);
            if (strlen(nm) >= SM__NAME_CAP) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor name 'vae.%s' is too long", p->file, t->name);
            memcpy(o->name, nm, strlen(nm) + 1);
        } else {
            renamed = 0;
            if (!strncmp(t->name, "vae.", 4) || !strcmp(t->name, "context"))
                return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor name '%s' collides with the model file's own names", p->file, t->name);
            memcpy(o->name, t->name, sizeof o->name);
        }
        o->src = src;
        o->index = i;
        o->in_dt = t->dtype;
        o->out_dt = dt == SUPERMAT_DTYPE_DEFAULT ? t->dtype : dt;
        o->ndim = t->ndim;
        memcpy(o->shape, t->shape, sizeof o->shape);
        if (renamed && o->ndim == 4 && o->shape[2] == 1 && o->shape[3] == 1) o->ndim = 2; /* 1x1 conv -> linear */
        o->in_bytes = t->nbytes;
        if (dt == SUPERMAT_DTYPE_I8) {
            o->q = sm__int8_weight(o->name, o->ndim) && o->shape[0] > 0 && o->shape[1] > 0;
            o->out_dt = o->q ? SUPERMAT_DTYPE_I8 : t->dtype;
        }
        o->out_bytes = ne * sm__dt_size(o->out_dt);
        o->out_off = *off;
        *off += o->out_bytes;
        (*nt)++;
        if (o->q) { /* the scales: [rows][kernel taps][ceil(cin / 64)] */
            sm__otensor *s = &ot[*nt];
            size_t n = strlen(o->name);
            if (n + 7 > SM__NAME_CAP) return sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: tensor name '%s_scale' is too long", p->file, o->name);
            memset(s, 0, sizeof *s);
            memcpy(s->name, o->name, n);
            memcpy(s->name + n, "_scale", 7);
            s->src = src; s->index = i; s->q = 2;
            s->in_dt = s->out_dt = SUPERMAT_DTYPE_F32;
            s->ndim = 3;
            s->shape[0] = o->shape[0];
            s->shape[1] = o->ndim == 4 ? o->shape[2] * o->shape[3] : 1;
            s->shape[2] = (o->shape[1] + 63) / 64;
            s->out_bytes = (uint64_t)s->shape[0] * (uint64_t)s->shape[1] * (uint64_t)s->shape[2] * 4;
            s->out_off = *off;
            *off += s->out_bytes;
            (*nt)++;
        }
    }
    return 0;
}

/* stable merge sort of p's tensors by file offset (the VAE is streamed in file order) */
static int sm__sort_by_offset(sm_pth *p) {
    int n = p->n, w, lo, mid, hi, i, j, k;
    supermat_tensor_info *a = p->t, *b;
    int *ea = p->entry, *eb;
    uint32_t *ca = p->crc, *cb;
    unsigned char *wa = p->whole, *wb;
    if (n < 2) return 0;
    b = (supermat_tensor_info *)malloc(sizeof *b * (size_t)n);
    eb = (int *)malloc(sizeof(int) * (size_t)n);
    cb = (uint32_t *)malloc(sizeof(uint32_t) * (size_t)n);
    wb = (unsigned char *)malloc((size_t)n);
    if (!b || !eb || !cb || !wb) { free(b); free(eb); free(cb); free(wb); return -1; }
    for (w = 1; w < n; w *= 2) {
        for (lo = 0; lo < n; lo += 2 * w) {
            mid = SM__MIN(lo + w, n);
            hi = SM__MIN(lo + 2 * w, n);
            i = lo; j = mid; k = lo;
            while (i < mid || j < hi) {
                int s = (j >= hi || (i < mid && a[i].offset <= a[j].offset)) ? i++ : j++;
                b[k] = a[s]; eb[k] = ea[s]; cb[k] = ca[s]; wb[k] = wa[s];
                k++;
            }
        }
        memcpy(a, b, sizeof *b * (size_t)n);
        memcpy(ea, eb, sizeof(int) * (size_t)n);
        memcpy(ca, cb, sizeof(uint32_t) * (size_t)n);
        memcpy(wa, wb, (size_t)n);
    }
    free(b); free(eb); free(cb); free(wb);
    return 0;
}

int sm_convert(const sm_convert_desc *d, char *err, size_t cap) {
    static const char *const vae_files[] = {"diffusion_pytorch_model.safetensors", "diffusion_pytorch_model.bin",
                                            "diffusion_pytorch_model.fp16.safetensors", "diffusion_pytorch_model.fp16.bin", NULL};
    sm_pth *ck = NULL, *vae = NULL;
    sm__json uc, vc, sc;
    sm__metas *ms = NULL;
    sm__otensor *ot = NULL;
    float *ctx = NULL;
    char buf[400], path[600], tmp[SM__NAME_CAP];
    int want = SM__KIND_NONE, kind = SM__KIND_NONE, r, nb, ints[16], cnt = 0, nblocks = 0, i, tokens = 0, dim = 0, nt = 0, v, have_u = 0, have_v = 0, have_s = 0;
    int in_ch, out_ch, boc0 = 0, cross, class_in = 0, vin, vout, vlat, vboc[16];
    double x;
    const supermat_tensor_info *t;
    uint64_t off = 0;
    if (err && cap) err[0] = 0;
    if (!d || !d->checkpoint || !d->base_dir || !d->output) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_convert: checkpoint, base_dir and output are required");
    if ((int)d->dtype < 0 || (int)d->dtype >= (int)SUPERMAT_DTYPE_COUNT) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_convert: bad dtype %d", (int)d->dtype);
    if (d->kind && d->kind[0]) {
        for (want = 1; want < 4; want++)
            if (!strcmp(d->kind, sm__kind_names[want])) break;
        if (want == 4) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_convert: unknown kind '%s' (supermat, supermat-mv, uv-refine)", d->kind);
    }
    ms = (sm__metas *)calloc(1, sizeof *ms);
    if (!ms) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory");

    /* the base folder: a diffusers folder, not a single-file Stable Diffusion checkpoint */
    {
        struct stat st;
        size_t bl = strlen(d->base_dir);
        if (stat(d->base_dir, &st) == 0 && !S_ISDIR(st.st_mode)) {
            free(ms);
            return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s is a file%s; --base takes the Stable Diffusion 2.1 folder in diffusers layout (unet/config.json, vae/, text_encoder/, tokenizer/, scheduler/), as in the repository stabilityai/stable-diffusion-2-1",
                           d->base_dir, bl > 12 && (!strcmp(d->base_dir + bl - 12, ".safetensors") || !strcmp(d->base_dir + bl - 5, ".ckpt")) ? " (a single-file checkpoint)" : "");
        }
    }
    /* the checkpoint */
    if (sm__lfs_pointer(d->checkpoint, err, cap)) { free(ms); return SUPERMAT_ERROR_MALFORMED_FILE; }
    if (d->progress) fprintf(stderr, "sm_convert: reading %s\n", d->checkpoint);
    r = sm_pth_open(d->checkpoint, &ck, err, cap);
    if (r) goto done;
    r = sm__check_kind(ck, want, &kind, err, cap);
    if (r) goto done;
    nb = sm__branches(ck);
    if (d->progress) fprintf(stderr, "sm_convert: %d tensors, kind %s, %d branch%s\n", ck->n, sm__kind_names[kind], nb, nb == 1 ? "" : "es");
    sm__meta_add(ms, "supermat.format_version", "1");
    sm__meta_add(ms, "supermat.kind", "%s", sm__kind_names[kind]);
    sm__meta_add(ms, "supermat.source", "%s", sm__basename(d->checkpoint));
    if (d->work_size > 0 && (d->work_size % 8 || d->work_size > 16384)) {
        r = sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "work size %d: a multiple of 8 up to 16384", d->work_size);
        goto done;
    }
    sm__meta_add(ms, "pipeline.work_size", "%d", d->work_size < 0 ? 0 : d->work_size ? d->work_size : kind == SM__KIND_UV ? 1024 : 512);
    if ((r = sm__pipeline_step_check("detail_sigma", d->detail_sigma, kind == SM__KIND_UV, err, cap)) != 0 ||
        (r = sm__pipeline_step_check("chroma_weight", d->chroma_weight, kind == SM__KIND_UV, err, cap)) != 0 ||
        (r = sm__pipeline_step_check("bake_detail_sigma", d->bake_detail_sigma, kind == SM__KIND_UV, err, cap)) != 0)
        goto done;
    /* recorded only when on: a conversion without them writes the file it always wrote */
    if (d->detail_sigma > 0.0f) sm__meta_add(ms, "pipeline.detail_sigma", "%.9g", (double)d->detail_sigma);
    if (d->chroma_weight > 0.0f) sm__meta_add(ms, "pipeline.chroma_weight", "%.9g", (double)d->chroma_weight);
    if (d->bake_detail_sigma > 0.0f) sm__meta_add(ms, "pipeline.bake_detail_sigma", "%.9g", (double)d->bake_detail_sigma);
    for (i = 0; i < 2; i++) {
        static const char *const key[2] = {"pipeline.roughness_curve", "pipeline.metallic_curve"};
        const char *curve = i ? d->metallic_curve : d->roughness_curve;
        char ct[SM__CURVE_TEXT];
        if (!curve || !curve[0]) continue;
        if (kind == SM__KIND_UV) { r = sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: a uv-refine model makes no %s map", key[i], i ? "metallic" : "roughness"); goto done; }
        if ((r = sm__curve_text(key[i], curve, ct, sizeof ct, err, cap)) != 0) goto done;
        sm__meta_add(ms, key[i], "%s", ct);
    }

    /* UNet config, checked against the checkpoint */
    r = sm__json_load(&uc, d->base_dir, "unet/config.json", 0, err, cap);
    if (r) goto done;
    have_u = 1;
    t = sm__need(ck, kind == SM__KIND_UV ? "rep_conv_in.0.weight" : "conv_in.weight", 4, err, cap, &r);
    if (!t) goto done;
    in_ch = (int)t->shape[1];
    if ((r = sm__jint(&uc, "in_channels", 1, 0, 1, 4096, &v, err, cap))) goto done;
    if (kind != SM__KIND_UV && v != in_ch) {
        r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor 'conv_in.weight' takes %d channels but %s says in_channels %d", ck->file, in_ch, uc.file, v);
        goto done;
    }
    if ((r = sm__jint(&uc, "out_channels", 1, 0, 1, 4096, &out_ch, err, cap))) goto done;
    for (i = 0; i < nb; i++) {
        snprintf(tmp, sizeof tmp, "rep_conv_out.%d.weight", i);
        if (!(t = sm__need(ck, tmp, 4, err, cap, &r))) goto done;
        if (t->shape[0] != out_ch) {
            r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor '%s' has %lld outputs but %s says out_channels %d", ck->file, tmp, (long long)t->shape[0], uc.file, out_ch);
            goto done;
        }
    }
    sm__meta_add(ms, "unet.in_channels", "%d", in_ch);
    sm__meta_add(ms, "unet.out_channels", "%d", out_ch);
    if ((r = sm__jints(&uc, "block_out_channels", 0, buf, sizeof buf, ints, 16, &nblocks, err, cap))) goto done;
    boc0 = ints[0];
    t = &ck->t[sm_pth_find(ck, kind == SM__KIND_UV ? "rep_conv_in.0.weight" : "conv_in.weight")];
    if (t->shape[0] != boc0) {
        r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor '%s' has %lld outputs but %s says block_out_channels[0] = %d", ck->file, t->name, (long long)t->shape[0], uc.file, boc0);
        goto done;
    }
    sm__meta_add(ms, "unet.block_out_channels", "%s", buf);
    if (!sm__jnull(&uc, sm__jfind(&uc, "num_attention_heads"))) r = sm__jints(&uc, "num_attention_heads", nblocks, buf, sizeof buf, ints, 16, &cnt, err, cap);
    else r = sm__jints(&uc, "attention_head_dim", nblocks, buf, sizeof buf, ints, 16, &cnt, err, cap);
    if (r) goto done;
    if (cnt != nblocks) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: %d head counts for %d blocks", uc.file, cnt, nblocks); goto done; }
    sm__meta_add(ms, "unet.num_heads", "%s", buf);
    if (sm__jnull(&uc, sm__jfind(&uc, "layers_per_block"))) sm__meta_add(ms, "unet.layers_per_block", "2");
    else {
        if ((r = sm__jints(&uc, "layers_per_block", 0, buf, sizeof buf, ints, 16, &cnt, err, cap))) goto done;
        sm__meta_add(ms, "unet.layers_per_block", "%s", buf);
    }
    if ((r = sm__jint(&uc, "norm_num_groups", 0, 32, 1, 4096, &v, err, cap))) goto done;
    sm__meta_add(ms, "unet.norm_num_groups", "%d", v);
    if ((r = sm__jnum(&uc, "norm_eps", 0, 1e-5, &x, err, cap))) goto done;
    sm__meta_add(ms, "unet.norm_eps", "%.9g", x);
    if ((r = sm__jint(&uc, "cross_attention_dim", 1, 0, 1, 1 << 16, &cross, err, cap))) goto done;
    sm__meta_add(ms, "unet.cross_attention_dim", "%d", cross);
    for (i = 0; i < ck->n; i++) { /* the checkpoint's cross-attention keys must take the config's width */
        size_t n = strlen(ck->t[i].name);
        if (n >= 17 && !strcmp(ck->t[i].name + n - 17, "attn2.to_k.weight") && ck->t[i].ndim == 2 && ck->t[i].shape[1] != cross) {
            r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor '%s' takes %lld inputs but %s says cross_attention_dim %d", ck->file, ck->t[i].name, (long long)ck->t[i].shape[1], uc.file, cross);
            goto done;
        }
    }
    if ((r = sm__jstrs(&uc, "down_block_types", buf, sizeof buf, &cnt, err, cap))) goto done;
    if (cnt != nblocks) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: %d down blocks for %d block_out_channels", uc.file, cnt, nblocks); goto done; }
    sm__meta_add(ms, "unet.down_block_types", "%s", buf);
    if ((r = sm__jstrs(&uc, "up_block_types", buf, sizeof buf, &cnt, err, cap))) goto done;
    if (cnt != nblocks) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s: %d up blocks for %d block_out_channels", uc.file, cnt, nblocks); goto done; }
    sm__meta_add(ms, "unet.up_block_types", "%s", buf);
    if ((r = sm__jbool(&uc, "flip_sin_to_cos", 1, &v, err, cap))) goto done;
    sm__meta_add(ms, "unet.flip_sin_to_cos", "%d", v);
    if ((r = sm__jint(&uc, "freq_shift", 0, 0, -1000000, 1000000, &v, err, cap))) goto done;
    sm__meta_add(ms, "unet.freq_shift", "%d", v);
    if ((r = sm__jbool(&uc, "upcast_attention", 0, &v, err, cap))) goto done;
    sm__meta_add(ms, "unet.upcast_attention", "%d", v);
    if ((r = sm__jbool(&uc, "use_linear_projection", 0, &v, err, cap))) goto done;
    sm__meta_add(ms, "unet.use_linear_projection", "%d", v);
    if ((r = sm__jstr(&uc, "act_fn", "silu", buf, sizeof buf, err, cap))) goto done;
    sm__meta_add(ms, "unet.act_fn", "%s", buf);
    if (sm__jnull(&uc, sm__jfind(&uc, "transformer_layers_per_block"))) sm__meta_add(ms, "unet.transformer_layers_per_block", "1");
    else {
        if ((r = sm__jints(&uc, "transformer_layers_per_block", 0, buf, sizeof buf, ints, 16, &cnt, err, cap))) goto done;
        sm__meta_add(ms, "unet.transformer_layers_per_block", "%s", buf);
    }
    sm__meta_add(ms, "unet.branches", "%d", nb);
    if (kind == SM__KIND_MV) {
        if (!(t = sm__need(ck, "class_embedding.linear_1.weight", 2, err, cap, &r))) goto done;
        class_in = (int)t->shape[1];
    }
    sm__meta_add(ms, "unet.class_embed_in", "%d", class_in);

    /* VAE */
    r = sm__json_load(&vc, d->base_dir, "vae/config.json", 0, err, cap);
    if (r) goto done;
    have_v = 1;
    if ((r = sm__jint(&vc, "in_channels", 0, 3, 1, 4096, &vin, err, cap)) || (r = sm__jint(&vc, "out_channels", 0, 3, 1, 4096, &vout, err, cap)) ||
        (r = sm__jint(&vc, "latent_channels", 0, 4, 1, 4096, &vlat, err, cap)))
        goto done;
    sm__meta_add(ms, "vae.in_channels", "%d", vin);
    sm__meta_add(ms, "vae.out_channels", "%d", vout);
    sm__meta_add(ms, "vae.latent_channels", "%d", vlat);
    if (vlat != out_ch) { r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: latent_channels %d but the UNet outputs %d channels", vc.file, vlat, out_ch); goto done; }
    if ((r = sm__jints(&vc, "block_out_channels", 0, buf, sizeof buf, vboc, 16, &cnt, err, cap))) goto done;
    sm__meta_add(ms, "vae.block_out_channels", "%s", buf);
    if ((r = sm__jint(&vc, "layers_per_block", 0, 1, 1, 64, &v, err, cap))) goto done;
    sm__meta_add(ms, "vae.layers_per_block", "%d", v);
    if ((r = sm__jint(&vc, "norm_num_groups", 0, 32, 1, 4096, &v, err, cap))) goto done;
    sm__meta_add(ms, "vae.norm_num_groups", "%d", v);
    if ((r = sm__jnum(&vc, "scaling_factor", 0, 0.18215, &x, err, cap))) goto done;
    sm__meta_add(ms, "vae.scaling_factor", "%.9g", x);
    if ((r = sm__jstr(&vc, "act_fn", "silu", buf, sizeof buf, err, cap))) goto done;
    sm__meta_add(ms, "vae.act_fn", "%s", buf);
    r = sm__open_weights(d->base_dir, "vae", vae_files, 0, &vae, path, sizeof path, err, cap);
    if (r) goto done;
    if (sm__sort_by_offset(vae)) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory"); goto done; }
    if (!(t = sm__need(vae, "encoder.conv_in.weight", 4, err, cap, &r))) goto done;
    if (t->shape[0] != vboc[0] || t->shape[1] != vin) {
        r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor 'encoder.conv_in.weight' is [%lld, %lld, ...] but %s says [%d, %d, ...]", vae->file, (long long)t->shape[0], (long long)t->shape[1], vc.file, vboc[0], vin);
        goto done;
    }
    if (!(t = sm__need(vae, "decoder.conv_out.weight", 4, err, cap, &r))) goto done;
    if (t->shape[0] != vout) { r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor 'decoder.conv_out.weight' has %lld outputs but %s says out_channels %d", vae->file, (long long)t->shape[0], vc.file, vout); goto done; }
    if (!(t = sm__need(vae, "quant_conv.weight", 4, err, cap, &r))) goto done;
    if (t->shape[0] != 2 * vlat) { r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor 'quant_conv.weight' has %lld outputs but latent_channels is %d", vae->file, (long long)t->shape[0], vlat); goto done; }
    if (!(t = sm__need(vae, "post_quant_conv.weight", 4, err, cap, &r))) goto done;
    if (t->shape[1] != vlat) { r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s: tensor 'post_quant_conv.weight' takes %lld inputs but latent_channels is %d", vae->file, (long long)t->shape[1], vlat); goto done; }

    /* scheduler */
    r = sm__json_load(&sc, d->base_dir, "scheduler/scheduler_config.json", 0, err, cap);
    if (r) goto done;
    have_s = 1;
    if (!sm__jnull(&sc, sm__jfind(&sc, "trained_betas"))) { r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: trained_betas are not supported", sc.file); goto done; }
    if ((r = sm__jint(&sc, "num_train_timesteps", 0, 1000, 1, 1000000, &v, err, cap))) goto done;
    sm__meta_add(ms, "sched.num_train_timesteps", "%d", v);
    if ((r = sm__jnum(&sc, "beta_start", 0, 0.0001, &x, err, cap))) goto done;
    sm__meta_add(ms, "sched.beta_start", "%.9g", x);
    if ((r = sm__jnum(&sc, "beta_end", 0, 0.02, &x, err, cap))) goto done;
    sm__meta_add(ms, "sched.beta_end", "%.9g", x);
    if ((r = sm__jstr(&sc, "beta_schedule", "linear", buf, sizeof buf, err, cap))) goto done;
    sm__meta_add(ms, "sched.beta_schedule", "%s", buf);
    /* SuperMat was trained (and is run) as v-prediction at the trailing timestep 999: an epsilon base
     * (Stable Diffusion 2.1-base, diffusers' default when the key is absent) would convert into maps off
     * by up to 0.95, so refuse it, and the options that would change the one DDIM step */
    if ((r = sm__jstr(&sc, "prediction_type", "epsilon", buf, sizeof buf, err, cap))) goto done;
    if (strcmp(buf, "v_prediction")) {
        r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: prediction_type is \"%s\"%s, but SuperMat is fine-tuned from a v_prediction model (Stable Diffusion 2.1, 768): the base folder is the wrong model (2.1-base?)",
                    sc.file, buf, sm__jnull(&sc, sm__jfind(&sc, "prediction_type")) ? " (absent: diffusers' default)" : "");
        goto done;
    }
    sm__meta_add(ms, "sched.prediction_type", "%s", buf);
    {
        static const char *const off[] = {"clip_sample", "thresholding", "rescale_betas_zero_snr"};
        int k;
        for (k = 0; k < 3; k++) {
            if ((r = sm__jbool(&sc, off[k], 0, &v, err, cap))) goto done;
            if (v) {
                r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "%s: \"%s\" is true; SuperMat's one DDIM step runs without it (the runtime has no such option)", sc.file, off[k]);
                goto done;
            }
        }
    }
    if ((r = sm__jint(&sc, "steps_offset", 0, 0, 0, 1000000, &v, err, cap))) goto done;
    sm__meta_add(ms, "sched.steps_offset", "%d", v);
    if ((r = sm__jbool(&sc, "set_alpha_to_one", 1, &v, err, cap))) goto done;
    sm__meta_add(ms, "sched.set_alpha_to_one", "%d", v);
    sm__meta_add(ms, "sched.timestep_spacing", "trailing");

    /* the context */
    r = sm_text_encode_empty(d->base_dir, d->threads, d->progress, &ctx, &tokens, &dim, err, cap);
    if (r) goto done;
    if (dim != cross) {
        r = sm__err(err, cap, SUPERMAT_ERROR_SHAPE_MISMATCH, "%s/text_encoder: hidden_size %d differs from the UNet's cross_attention_dim %d (wrong base model?)", d->base_dir, dim, cross);
        goto done;
    }
    sm__meta_add(ms, "context.tokens", "%d", tokens);
    sm__meta_add(ms, "context.dim", "%d", dim);

    /* the output */
    ot = (sm__otensor *)malloc(sizeof(sm__otensor) * (2 * ((size_t)ck->n + (size_t)vae->n) + 1)); /* int8: + scales */
    if (!ot) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory"); goto done; }
    if ((r = sm__add_outputs(ot, &nt, ck, 0, d->dtype, &off, err, cap)) || (r = sm__add_outputs(ot, &nt, vae, 1, d->dtype, &off, err, cap))) goto done;
    {
        sm__otensor *o = &ot[nt++];
        memset(o, 0, sizeof *o);
        memcpy(o->name, "context", 8);
        o->src = 2;
        o->in_dt = o->out_dt = SUPERMAT_DTYPE_F32;
        o->ndim = 2;
        o->shape[0] = tokens;
        o->shape[1] = dim;
        o->in_bytes = o->out_bytes = (uint64_t)tokens * (uint64_t)dim * 4;
        o->out_off = off;
        off += o->out_bytes;
    }
    {
        supermat_tensor_info *names = (supermat_tensor_info *)malloc(sizeof(supermat_tensor_info) * (size_t)nt);
        int dup = -1;
        if (!names) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory"); goto done; }
        for (i = 0; i < nt; i++) memcpy(names[i].name, ot[i].name, sizeof names[i].name);
        r = sm__find_duplicate(names, nt, &dup);
        free(names);
        if (r) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory"); goto done; }
        if (dup >= 0) { r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "two output tensors are named '%s'", ot[dup].name); goto done; }
    }
    if (d->progress) fprintf(stderr, "sm_convert: writing %s: %d tensors, %.2f GB\n", d->output, nt, off / 1e9);
    r = sm__write_model(d->output, ms, ot, nt, ck, vae, ctx, d->progress, err, cap);
    if (!r && d->progress) fprintf(stderr, "sm_convert: done\n");
done:
    if (have_u) sm__json_free(&uc);
    if (have_v) sm__json_free(&vc);
    if (have_s) sm__json_free(&sc);
    sm_pth_close(ck);
    sm_pth_close(vae);
    free(ctx);
    free(ot);
    free(ms);
    return r;
}

/* >>pipeline : a converted model file's pipeline.* metadata (work size, detail, colour and bake detail steps), rewritten
   without the checkpoint */
static int sm__tok_is(const char *js, const supermat_json_tok *t, const char *s) {
    size_t n = strlen(s);
    return t->type == SUPERMAT_JSON_STRING && (size_t)(t->end - t->start) == n && memcmp(js + t->start, s, n) == 0;
}
/* the end (exclusive) of the text of an object member's value, from its key's token */
static int sm__member_end(const supermat_json_tok *tok, int key) {
    return tok[key + 1].end + (tok[key + 1].type == SUPERMAT_JSON_STRING);
}
int sm_pipeline_header(const void *file, size_t size, const sm_pipeline_edit *edit, unsigned char **header,
                       size_t *header_size, size_t *data_offset, char *err, size_t cap) {
#define SM__PK 6 /* the pipeline keys, in the converter's order */
    static const char *const keys[SM__PK] = {"pipeline.work_size", "pipeline.detail_sigma", "pipeline.chroma_weight",
                                             "pipeline.bake_detail_sigma", "pipeline.roughness_curve", "pipeline.metallic_curve"};
    const unsigned char *f = (const unsigned char *)file;
    const char *js;
    supermat_json_tok *tok = NULL;
    int *mk = NULL; /* the metadata's members: the token of each key */
    sm__sbuf b;
    uint64_t hlen, nlen;
    int nt, meta, n, i, k, p, r = 0, last = -1, any = 0;
    int op[SM__PK];      /* 0: kept, 1: set to val[k], -1: removed */
    int at[SM__PK];      /* the member holding key k, or -1 */
    int pos[SM__PK];     /* an added key goes before member pos[k] (n: after the last) */
    char val[SM__PK][SM__CURVE_TEXT];
    memset(&b, 0, sizeof b);
    if (header) *header = NULL;
    if (!f || !edit || !header || !header_size || !data_offset)
        return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pipeline_header: NULL argument");
    /* what changes */
    op[0] = edit->work_size != 0;
    if (edit->work_size < -1 || edit->work_size > 16384 || (edit->work_size > 0 && edit->work_size % 8))
        return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "work size %d: a multiple of 8 up to 16384, or -1 (none)", edit->work_size);
    snprintf(val[0], sizeof val[0], "%d", edit->work_size < 0 ? 0 : edit->work_size);
    for (k = 4; k < SM__PK; k++) {
        const char *curve = k == 4 ? edit->roughness_curve : edit->metallic_curve;
        op[k] = 0;
        if (!curve) continue;
        op[k] = curve[0] ? 1 : -1;
        if (op[k] > 0 && (r = sm__curve_text(keys[k], curve, val[k], sizeof val[k], err, cap)) != 0) return r;
    }
    for (k = 1; k < 4; k++) {
        float v = k == 1 ? edit->detail_sigma : k == 2 ? edit->chroma_weight : edit->bake_detail_sigma;
        if (v < 0.0f) { op[k] = 0; continue; }
        if (!(v <= 1.0f)) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s %g: from 0 (off) to 1, or negative (kept)", keys[k], (double)v);
        op[k] = v > 0.0f ? 1 : -1;
        snprintf(val[k], sizeof val[k], "%.9g", (double)v);
    }
    if (!op[0] && !op[1] && !op[2] && !op[3] && !op[4] && !op[5]) return sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "sm_pipeline_header: no key to rewrite");
    /* the header */
    if (size < 8) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%zu bytes: too short for a safetensors file", size);
    hlen = sm__u64(f);
    if (hlen < 2 || hlen > size - 8 || hlen > (uint64_t)INT32_MAX / 2)
        return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "header length %llu does not fit the %zu-byte file",
                       (unsigned long long)hlen, size);
    js = (const char *)f + 8;
    nt = supermat_json_parse(js, (size_t)hlen, NULL, 0);
    if (nt < 1) return sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "the header is not valid JSON");
    tok = (supermat_json_tok *)malloc(sizeof *tok * (size_t)nt);
    if (!tok) return sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory (%d header tokens)", nt);
    if (supermat_json_parse(js, (size_t)hlen, tok, nt) != nt || tok[0].type != SUPERMAT_JSON_OBJECT) {
        r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "the header is not a JSON object");
        goto done;
    }
    meta = supermat_json_find(js, tok, 0, "__metadata__");
    if (meta < 0 || tok[meta].type != SUPERMAT_JSON_OBJECT || supermat_json_find(js, tok, meta, "supermat.format_version") < 0) {
        r = sm__err(err, cap, SUPERMAT_ERROR_UNSUPPORTED, "not a supermat model file (no supermat.format_version in its metadata)");
        goto done;
    }
    if (op[1] > 0 || op[2] > 0 || op[3] > 0 || op[4] > 0 || op[5] > 0) { /* supermat.h refuses the detail, colour and bake detail steps and the curves for a uv-refine model */
        static const char *const step[SM__PK] = {"", "detail", "colour", "bake detail", "roughness curve", "metallic curve"};
        char kind[32];
        i = supermat_json_find(js, tok, meta, "supermat.kind");
        if (i >= 0 && supermat_json_string(js, &tok[i], kind, sizeof kind) >= 0 && !strcmp(kind, "uv-refine")) {
            k = op[1] > 0 ? 1 : op[2] > 0 ? 2 : op[3] > 0 ? 3 : op[4] > 0 ? 4 : 5;
            if (k >= 4) r = sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: a uv-refine model makes no %s map for the %s", keys[k], k == 4 ? "roughness" : "metallic", step[k]);
            else r = sm__err(err, cap, SUPERMAT_ERROR_INVALID_ARGUMENT, "%s: a uv-refine model has no input picture for the %s step", keys[k], step[k]);
            goto done;
        }
    }
    n = tok[meta].size; /* >= 1: format_version */
    mk = (int *)malloc(sizeof *mk * (size_t)n);
    if (!mk) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory (%d metadata keys)", n); goto done; }
    for (k = 0; k < SM__PK; k++) at[k] = -1;
    for (i = 0, p = meta + 1; i < n; i++, p = tok[p].next) {
        mk[i] = p;
        for (k = 0; k < SM__PK; k++) {
            if (!sm__tok_is(js, &tok[p], keys[k])) continue;
            if (at[k] >= 0) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s appears twice in the metadata", keys[k]); goto done; }
            if (op[k] && tok[p + 1].type != SUPERMAT_JSON_STRING) { r = sm__err(err, cap, SUPERMAT_ERROR_MALFORMED_FILE, "%s is not a string", keys[k]); goto done; }
            at[k] = i;
        }
    }
    /* where an added key goes: after the pipeline key before it that stays, else before the one after it that
       stays, else first (keys added at one place in the converter's order) */
    for (k = 0; k < SM__PK; k++) {
        int j;
        pos[k] = -1;
        if (op[k] <= 0 || at[k] >= 0) continue;
        for (j = k - 1; j >= 0 && pos[k] < 0; j--) if (at[j] >= 0 && op[j] >= 0) pos[k] = at[j] + 1;
        for (j = k + 1; j < SM__PK && pos[k] < 0; j++) if (at[j] >= 0 && op[j] >= 0) pos[k] = at[j];
        if (pos[k] < 0) pos[k] = 0;
    }
    /* the new text: the members in their order (their bytes, and the bytes between them, as they are) with the
       changed values, the added keys, without the removed ones */
    sm__sb_put(&b, js, (size_t)tok[meta].start + 1);                                              /* ... "__metadata__":{ */
    sm__sb_put(&b, js + tok[meta].start + 1, (size_t)(tok[mk[0]].start - 1 - tok[meta].start - 1)); /* the space before the first key */
    for (p = 0; p <= n; p++) {
        for (k = 0; k < SM__PK; k++) {
            if (pos[k] != p) continue;
            if (any) sm__sb_str(&b, ",");
            sm__sb_str(&b, "\"");
            sm__sb_str(&b, keys[k]);
            sm__sb_str(&b, "\":\"");
            sm__sb_str(&b, val[k]);
            sm__sb_str(&b, "\"");
            any = 1;
            last = -1;
        }
        if (p == n) break;
        for (k = 0; k < SM__PK && at[k] != p; k++) {}
        if (k < SM__PK && op[k] < 0) continue; /* removed */
        if (any) { /* the bytes after the member emitted last and before its next one (its comma), else a comma */
            if (last >= 0 && last + 1 < n) sm__sb_put(&b, js + sm__member_end(tok, mk[last]), (size_t)(tok[mk[last + 1]].start - 1 - sm__member_end(tok, mk[last])));
            else sm__sb_str(&b, ",");
        }
        if (k < SM__PK && op[k] > 0) { /* the value's text, quotes included, replaced */
            sm__sb_put(&b, js + tok[mk[p]].start - 1, (size_t)(tok[mk[p] + 1].start - 1 - (tok[mk[p]].start - 1)));
            sm__sb_str(&b, "\"");
            sm__sb_str(&b, val[k]);
            sm__sb_str(&b, "\"");
        } else
            sm__sb_put(&b, js + tok[mk[p]].start - 1, (size_t)(sm__member_end(tok, mk[p]) - (tok[mk[p]].start - 1)));
        any = 1;
        last = p;
    }
    i = sm__member_end(tok, mk[n - 1]);                                                      /* the space after the last member, */
    sm__sb_put(&b, js + i, (size_t)hlen - (size_t)i);                                        /* the closing brace and the rest */
    /* the tensors' offsets count from the end of the header: the data is copied as it is, and the header
       keeps its length or grows by 64 bytes at a time, so every tensor keeps its alignment in the file
       (a pre-packed file's 64-byte panels too); padded with spaces */
    while (b.n > 0 && (b.p[b.n - 1] == ' ' || b.p[b.n - 1] == '\n' || b.p[b.n - 1] == '\t' || b.p[b.n - 1] == '\r')) b.n--; /* old padding reused */
    nlen = hlen;
    while (nlen < b.n) nlen += 64;
    while (!b.oom && b.n < nlen) sm__sb_put(&b, " ", 1);
    if (b.oom) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory (header of %llu bytes)", (unsigned long long)nlen); goto done; }
    *header = (unsigned char *)malloc((size_t)nlen + 8);
    if (!*header) { r = sm__err(err, cap, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory (header of %llu bytes)", (unsigned long long)nlen); goto done; }
    for (i = 0; i < 8; i++) (*header)[i] = (unsigned char)(nlen >> (8 * i));
    memcpy(*header + 8, b.p, (size_t)nlen);
    *header_size = (size_t)nlen + 8;
    *data_offset = (size_t)hlen + 8;
done:
    free(mk);
    free(tok);
    free(b.p);
    return r;
#undef SM__PK
}

/* >>main : `cc -DSM_CONVERT_MAIN -I. convert/sm_convert.c -lm -lpthread -o sm_convert` */
#ifdef SM_CONVERT_MAIN
int main(int argc, char **argv) {
    sm_convert_desc d;
    char err[1024];
    int i, r;
    memset(&d, 0, sizeof d);
    d.progress = 1;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--kind") && i + 1 < argc) d.kind = argv[++i];
        else if (!strcmp(a, "--checkpoint") && i + 1 < argc) d.checkpoint = argv[++i];
        else if (!strcmp(a, "--base") && i + 1 < argc) d.base_dir = argv[++i];
        else if ((!strcmp(a, "--out") || !strcmp(a, "-o")) && i + 1 < argc) d.output = argv[++i];
        else if (!strcmp(a, "--threads") && i + 1 < argc) d.threads = atoi(argv[++i]);
        else if (!strcmp(a, "--dtype") && i + 1 < argc) {
            const char *t = argv[++i];
            d.dtype = !strcmp(t, "f32") ? SUPERMAT_DTYPE_F32 : !strcmp(t, "f16") ? SUPERMAT_DTYPE_F16 : !strcmp(t, "bf16") ? SUPERMAT_DTYPE_BF16
                    : !strcmp(t, "int8") ? SUPERMAT_DTYPE_I8 : SUPERMAT_DTYPE_COUNT;
        } else if (!strcmp(a, "--quiet")) d.progress = 0;
        else {
            fprintf(stderr, "usage: %s --checkpoint supermat.pth --base sd21_dir --out model.safetensors [--kind supermat|supermat-mv|uv-refine]\n"
                            "          [--dtype f32|f16|bf16|int8] [--threads N] [--quiet]\n", argv[0]);
            return 2;
        }
    }
    r = sm_convert(&d, err, sizeof err);
    if (r) {
        fprintf(stderr, "sm_convert: error: %s\n", err);
        return 1;
    }
    return 0;
}
#endif
