/* Pre-packed models (supermat_model_write_packed): for every model kind (single view, multi-view, UV refine)
   and every packing option (f32, f16, bf16, int8 weights, int8 files, Winograd F2 / F4, bf16 compute where
   the CPU has it), the model created from the pre-packed file runs to the very bits of the model created
   from the original file, holds its panels in place (model_bytes a fraction of the original's) or, with
   copy_data, in its own memory; the options it was packed for are enforced; a buffer that is not 64-byte
   aligned is copied (as with copy_data); a failing write callback gives SUPERMAT_ERROR_IO; failing allocations
   give OUT_OF_MEMORY without a leak; truncated files and corrupted index records are refused, never
   crash (this test also runs under ASan / UBSan).

   usage: test_packed TINY TINY_MV TINY_UV TINY_I8 */
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200112L
#endif
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "supermat.h"
#include "test_util.h"
#include <stdint.h>


/* a copy of n bytes at a 64-byte aligned address (+ shift) */
typedef struct aligned { void *base; unsigned char *p; } aligned;
static aligned aligned_copy(const unsigned char *src, size_t n, size_t shift) {
    aligned a;
    a.base = NULL; a.p = NULL;
    if (posix_memalign(&a.base, 64, n + 64)) return a;
    a.p = (unsigned char *)a.base + shift;
    memcpy(a.p, src, n);
    return a;
}

enum { S = 32, V = 6, U = 32 };

/* runs model m on fixed inputs; out gets every float output (albedo, roughness, metallic or refined) */
static int run_kind(supermat_model *m, float *out, size_t *nout) {
    static unsigned char px[V][S * S * 4];
    static float uvmap[U * U * 3], mask[U * U], pos[U * U * 3];
    supermat_model_info info;
    supermat_session_desc sd;
    supermat_session *s;
    supermat_run_desc rd;
    supermat_error err;
    int r, i;
    memset(&info, 0, sizeof info);
    supermat_model_get_info(m, &info);
    memset(&sd, 0, sizeof sd);
    memset(&rd, 0, sizeof rd);
    sd.model = m; sd.threads = 2;
    if (info.kind == SUPERMAT_KIND_SUPERMAT) {
        sd.width = sd.height = S;
        tu_disc_rgba(px[0], S, S, 14, 15, 11);
        rd.input.pixels = px[0]; rd.input.width = rd.input.height = S; rd.input.channels = 4;
        rd.albedo.pixels = out; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
        rd.roughness.pixels = out + S * S * 3; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
        rd.metallic.pixels = out + S * S * 4; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
        *nout = S * S * 5;
    } else if (info.kind == SUPERMAT_KIND_SUPERMAT_MV) {
        static supermat_image in[V], ov[V];
        static float cams[V * 16];
        sd.width = sd.height = S; sd.views = V; sd.outputs = SUPERMAT_OUTPUT_ALBEDO;
        tu_mv_views(V, S, px[0], in, ov, out, cams);
        rd.input_views = in; rd.albedo_views = ov; rd.cameras = cams;
        *nout = (size_t)V * S * S * 3;
    } else {
        sd.width = sd.height = U;
        for (i = 0; i < U * U; i++) {
            int x = i % U, y = i / U;
            uvmap[3 * i] = (float)x / U; uvmap[3 * i + 1] = (float)y / U; uvmap[3 * i + 2] = 0.3f;
            mask[i] = y < U / 2 ? 1.0f : 0.0f;
            pos[3 * i] = 0.2f + 0.5f * (float)x / U; pos[3 * i + 1] = 0.7f; pos[3 * i + 2] = 0.1f + 0.6f * (float)y / U;
        }
        rd.input.pixels = uvmap; rd.input.width = rd.input.height = U; rd.input.channels = 3; rd.input.format = SUPERMAT_FORMAT_F32;
        rd.mask = rd.input; rd.mask.pixels = mask; rd.mask.channels = 1;
        rd.position = rd.input; rd.position.pixels = pos;
        rd.refined.pixels = out; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
        *nout = U * U * 3;
    }
    if ((r = supermat_session_create(&sd, &s, &err))) { TU_CHECK(0, "session: %s", err.message); return r; }
    r = supermat_run(s, &rd, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "run: %s", err.message);
    supermat_session_destroy(s);
    return r;
}

static float out_a[V * S * S * 5], out_b[V * S * S * 5];

typedef struct opts { const char *name; supermat_weights weights; supermat_conv conv; supermat_compute compute; } opts;

/* packs `file` with `o`, checks the packed model against the original, returns the packed file (free it) */
static unsigned char *check_one(const char *what, const unsigned char *file, size_t size, const opts *o, size_t *packed_size) {
    supermat_model_desc md;
    supermat_model *m0 = NULL, *m1 = NULL, *m2 = NULL;
    supermat_model_info i0, i1, i2;
    supermat_error err;
    tu_membuf b;
    aligned al;
    uint64_t bytes = 0;
    size_t n0 = 0, n1 = 0;
    supermat_result r;
    static int calls;
    int unaligned_alone = calls++ & 1; /* every other packing: the unaligned copy without copy_data */
    memset(&md, 0, sizeof md);
    memset(&b, 0, sizeof b);
    b.fail_at = -1;
    md.data = file; md.size = size; md.weights = o->weights; md.conv = o->conv; md.compute = o->compute;
    r = supermat_model_write_packed(&md, tu_mem_write, &b, &bytes, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && bytes == b.n, "%s %s: write_packed: %s", what, o->name, err.message);
    if (r) { free(b.p); return NULL; }
    TU_CHECK(supermat_model_create(&md, &m0, &err) == SUPERMAT_SUCCESS, "%s %s: original: %s", what, o->name, err.message);
    al = aligned_copy(b.p, b.n, 0);
    md.data = al.p; md.size = b.n;
    r = supermat_model_create(&md, &m1, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%s %s: pre-packed: %s", what, o->name, err.message);
    if (m0 && m1) {
        supermat_model_get_info(m0, &i0);
        supermat_model_get_info(m1, &i1);
        TU_CHECK(i1.prepacked == 1 && !i0.prepacked, "%s %s: prepacked flag %d / %d", what, o->name, i0.prepacked, i1.prepacked);
        TU_CHECK(i1.weights == i0.weights && i1.conv == i0.conv && i1.compute == i0.compute && i1.kind == i0.kind, "%s %s: info differs (weights %d / %d)", what, o->name, (int)i0.weights, (int)i1.weights);
        TU_CHECK(i1.unet_params == i0.unet_params && i1.vae_params == i0.vae_params, "%s %s: parameter counts differ (%llu / %llu)", what, o->name,
                 (unsigned long long)i0.unet_params, (unsigned long long)i1.unet_params);
        TU_CHECK(i1.model_bytes * 4 < i0.model_bytes && i1.prepacked_bytes * 10 > i0.model_bytes * 8, "%s %s: model bytes %zu (in place %zu), original %zu", what, o->name,
                 i1.model_bytes, i1.prepacked_bytes, i0.model_bytes);
        run_kind(m0, out_a, &n0);
        run_kind(m1, out_b, &n1);
        TU_CHECK(n0 == n1 && !memcmp(out_a, out_b, n0 * sizeof(float)), "%s %s: the pre-packed model's outputs differ", what, o->name);
        /* copy_data: the panels copied into the model's memory, from an address that is not aligned */
        free(al.base);
        al = aligned_copy(b.p, b.n, 8);
        md.data = al.p;
        md.copy_data = !unaligned_alone; /* without copy_data an unaligned buffer is copied too */
        r = supermat_model_create(&md, &m2, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS, "%s %s: copy_data: %s", what, o->name, err.message);
        if (m2) {
            supermat_model_get_info(m2, &i2);
            TU_CHECK(i2.prepacked_bytes == 0 && i2.model_bytes >= i1.prepacked_bytes, "%s %s: copy_data holds %zu bytes", what, o->name, i2.model_bytes);
            memset(al.p, 0xA5, b.n); /* nothing borrowed */
            run_kind(m2, out_b, &n1);
            TU_CHECK(!memcmp(out_a, out_b, n0 * sizeof(float)), "%s %s: copy_data outputs differ", what, o->name);
        }
    }
    supermat_model_destroy(m0);
    supermat_model_destroy(m1);
    supermat_model_destroy(m2);
    free(al.base);
    printf("%s %-14s original %7.2f MiB, pre-packed file %7.2f MiB: same bits\n", what, o->name, size / 1048576.0, b.n / 1048576.0);
    *packed_size = b.n;
    return b.p;
}

static void check_refusals(const unsigned char *file, size_t size, const unsigned char *packed, size_t psize) {
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    tu_membuf b;
    aligned al = aligned_copy(packed, psize, 0);
    unsigned char *p = al.p;
    uint64_t hl = 0;
    int i, rejected = 0, accepted = 0, fails = 0;
    size_t cut;
    supermat_result r;
    memset(&md, 0, sizeof md);
    md.data = p; md.size = psize;
    /* other options than it was packed for */
    md.conv = SUPERMAT_CONV_WINOGRAD_F4;
    r = supermat_model_create(&md, &m, &err);
    TU_CHECK(r == SUPERMAT_ERROR_UNSUPPORTED && strstr(err.message, "pre-packed for"), "other conv: %s", err.message);
    md.conv = SUPERMAT_CONV_DIRECT; md.weights = SUPERMAT_WEIGHTS_I8;
    r = supermat_model_create(&md, &m, &err);
    TU_CHECK(r == SUPERMAT_ERROR_UNSUPPORTED, "other weights: %s", err.message);
    md.weights = SUPERMAT_WEIGHTS_F32;
    r = supermat_model_create(&md, &m, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "the weights it was packed for, asked explicitly: %s", err.message);
    supermat_model_destroy(m); m = NULL;
    md.weights = SUPERMAT_WEIGHTS_DEFAULT;
    /* packing a pre-packed file */
    memset(&b, 0, sizeof b); b.fail_at = -1;
    r = supermat_model_write_packed(&md, tu_mem_write, &b, NULL, &err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && b.n == 0, "packing a pre-packed file: %s", err.message);
    free(b.p);
    /* a write callback that fails at each call in turn */
    for (i = 0;; i++) {
        supermat_model_desc o;
        memset(&o, 0, sizeof o);
        o.data = file; o.size = size;
        memset(&b, 0, sizeof b); b.fail_at = i;
        r = supermat_model_write_packed(&o, tu_mem_write, &b, NULL, &err);
        free(b.p);
        if (r == SUPERMAT_SUCCESS) break;
        TU_CHECK(r == SUPERMAT_ERROR_IO, "write failure at call %d: %s", i, supermat_result_string(r));
        fails++;
    }
    printf("write callback failing at each of its %d calls: SUPERMAT_ERROR_IO\n", fails);
    /* allocation failures while packing and while creating from the packed file */
    for (i = 0;; i++) {
        tu_counting c;
        supermat_model_desc o;
        memset(&c, 0, sizeof c); c.fail_at = i;
        memset(&o, 0, sizeof o);
        o.data = file; o.size = size;
        o.allocator.alloc = tu_count_alloc; o.allocator.free = tu_count_free; o.allocator.user = &c;
        memset(&b, 0, sizeof b); b.fail_at = -1;
        r = supermat_model_write_packed(&o, tu_mem_write, &b, NULL, &err);
        free(b.p);
        TU_CHECK(c.live == 0, "packing with allocation %d failing leaks %ld blocks", i, c.live);
        if (r == SUPERMAT_SUCCESS) break;
        TU_CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY, "packing with allocation %d failing: %s", i, supermat_result_string(r));
    }
    printf("packing: every one of %d allocations failing gives OUT_OF_MEMORY without a leak\n", i);
    for (i = 0;; i++) {
        tu_counting c;
        memset(&c, 0, sizeof c); c.fail_at = i;
        md.allocator.alloc = tu_count_alloc; md.allocator.free = tu_count_free; md.allocator.user = &c;
        r = supermat_model_create(&md, &m, &err);
        if (r == SUPERMAT_SUCCESS) { supermat_model_destroy(m); m = NULL; TU_CHECK(c.live == 0, "pre-packed model leaks %ld blocks", c.live); break; }
        TU_CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY && c.live == 0, "pre-packed create with allocation %d failing: %s, %ld blocks live", i, supermat_result_string(r), c.live);
    }
    printf("pre-packed create: every one of %d allocations failing gives OUT_OF_MEMORY without a leak\n", i);
    memset(&md.allocator, 0, sizeof md.allocator);
    /* truncated copies: refused */
    for (cut = 0; cut < psize; cut += cut < 4096 ? 97 : psize / 61 + 1) {
        aligned t = aligned_copy(p, cut, 0);
        md.data = t.p; md.size = cut;
        r = supermat_model_create(&md, &m, &err);
        if (r == SUPERMAT_SUCCESS) { TU_CHECK(0, "a pre-packed file cut at %zu of %zu bytes was accepted", cut, psize); supermat_model_destroy(m); m = NULL; }
        else rejected++;
        free(t.base);
    }
    printf("truncated pre-packed files: %d refused\n", rejected);
    /* every field of every index record changed: a clean error or (a field that does not matter) success */
    for (i = 7; i >= 0; i--) hl = (hl << 8) | p[i];
    {
        const char *h = (const char *)p + 8, *e = strstr(h, "\"supermat.packed.index\"");
        unsigned long long b0 = 0, b1 = 0;
        int nrec = 0, f, k;
        e = e ? strstr(e, "data_offsets") : NULL;
        TU_CHECK(e && sscanf(e, "data_offsets\":[%llu,%llu]", &b0, &b1) == 2, "index entry not found in the header");
        nrec = (int)((b1 - b0) / 64);
        rejected = 0;
        for (k = 0; k < nrec; k += nrec / 7 + 1)
            for (f = 0; f < 8; f++) {
                static const int64_t bad[] = {1, -1, 64, (int64_t)1 << 40, -64};
                int j;
                for (j = 0; j < 5; j++) {
                    int64_t v, old;
                    unsigned char *q = p + 8 + hl + b0 + (size_t)(k * 8 + f) * 8;
                    memcpy(&old, q, 8);
                    v = old + bad[j];
                    memcpy(q, &v, 8);
                    md.data = p; md.size = psize;
                    r = supermat_model_create(&md, &m, &err);
                    if (r == SUPERMAT_SUCCESS) { size_t nb; accepted++; run_kind(m, out_b, &nb); supermat_model_destroy(m); m = NULL; }
                    else { rejected++; TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE, "record %d field %d %+lld: %s", k, f, (long long)(v - old), err.message); }
                    memcpy(q, &old, 8);
                }
            }
        printf("corrupted index records: %d refused (MALFORMED_FILE), %d accepted (an offset moved within the blob)\n", rejected, accepted);
        TU_CHECK(rejected > 100, "only %d corrupted records refused", rejected);
    }
    free(al.base);
}

int main(int argc, char **argv) {
    static const opts O[] = {
        {"f32", SUPERMAT_WEIGHTS_DEFAULT, SUPERMAT_CONV_DIRECT, SUPERMAT_COMPUTE_F32},
        {"f16", SUPERMAT_WEIGHTS_F16, SUPERMAT_CONV_DIRECT, SUPERMAT_COMPUTE_F32},
        {"bf16", SUPERMAT_WEIGHTS_BF16, SUPERMAT_CONV_DIRECT, SUPERMAT_COMPUTE_F32},
        {"int8", SUPERMAT_WEIGHTS_I8, SUPERMAT_CONV_DIRECT, SUPERMAT_COMPUTE_F32},
        {"winograd-f2", SUPERMAT_WEIGHTS_DEFAULT, SUPERMAT_CONV_WINOGRAD_F2, SUPERMAT_COMPUTE_F32},
        {"f16+wino-f4", SUPERMAT_WEIGHTS_F16, SUPERMAT_CONV_WINOGRAD_F4, SUPERMAT_COMPUTE_F32},
        {"bf16-compute", SUPERMAT_WEIGHTS_DEFAULT, SUPERMAT_CONV_DIRECT, SUPERMAT_COMPUTE_BF16},
        {"int8-compute+wino-f4", SUPERMAT_WEIGHTS_DEFAULT, SUPERMAT_CONV_WINOGRAD_F4, SUPERMAT_COMPUTE_INT8},
    };
    const char *names[] = {"single", "mv", "uv", "single-i8file"};
    int f, o;
    if (argc < 5) { fprintf(stderr, "usage: %s TINY TINY_MV TINY_UV TINY_I8\n", argv[0]); return 2; }
    for (f = 0; f < 4; f++) {
        size_t size = 0, psize = 0;
        unsigned char *file = tu_load(argv[1 + f], &size);
        if (!file) { printf("cannot read %s\n", argv[1 + f]); return 1; }
        for (o = 0; o < (int)(sizeof O / sizeof O[0]); o++) {
            unsigned char *packed;
            if (O[o].compute == SUPERMAT_COMPUTE_BF16 && !supermat_cpu().avx512_bf16) { printf("%s %s: skipped (no AVX512_BF16 here)\n", names[f], O[o].name); continue; }
            if (O[o].compute == SUPERMAT_COMPUTE_INT8 && !supermat_cpu().avx512_vnni) { printf("%s %s: skipped (no AVX512_VNNI here)\n", names[f], O[o].name); continue; }
            if (f == 3 && O[o].weights != SUPERMAT_WEIGHTS_DEFAULT) continue; /* the int8 file as stored */
            if (f == 3 && O[o].compute == SUPERMAT_COMPUTE_BF16) continue;
            packed = check_one(names[f], file, size, &O[o], &psize);
            if (packed && f == 0 && o == 0) check_refusals(file, size, packed, psize);
            free(packed);
        }
        free(file);
    }
    return tu_finish("packed");
}
