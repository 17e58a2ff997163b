/* Truncated and bit-flipped model files of every kind given (f32, f16, bf16 and int8 files; single view,
   multi-view, UV refine): the file cut at every byte of its header and at a stride through its data is
   refused with a message; a byte of the header flipped (at a stride) gives a clean error or a model; a bit
   flipped in the data (at a stride) gives a model, or NONFINITE naming the tensor, and a single-view model
   that was created runs to finite maps (or a clean error). Never a crash: this test runs under ASan/UBSan
   too. A copy of exactly the cut size is made at a stride, so that ASan sees any read past the end.

   usage: test_corrupt MODEL... */
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "supermat.h"
#include "test_util.h"
#include <stdint.h>

static supermat_result create(const unsigned char *data, size_t size, supermat_model **m, supermat_error *err) {
    supermat_model_desc md;
    memset(&md, 0, sizeof md);
    md.data = data; md.size = size;
    return supermat_model_create(&md, m, err);
}

/* a run at 32x32 with float outputs: SUCCESS with finite maps, or a clean error */
static int run_finite(const supermat_model *m, supermat_result *rr) {
    enum { S = 32 };
    static unsigned char px[S * S * 4];
    static float out[S * S * 5];
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_error err;
    int i;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = sd.height = S; sd.threads = 1;
    if ((*rr = supermat_session_create(&sd, &s, &err)) != SUPERMAT_SUCCESS) return 1;
    tu_disc_rgba(px, S, S, 14, 15, 11);
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = px; rd.input.width = rd.input.height = S; rd.input.channels = 4;
    rd.albedo.pixels = out; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
    rd.roughness.pixels = out + S * S * 3; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
    rd.metallic.pixels = out + S * S * 4; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
    *rr = supermat_run(s, &rd, &err);
    supermat_session_destroy(s);
    if (*rr != SUPERMAT_SUCCESS) return 1;
    for (i = 0; i < S * S * 5; i++) if (!(out[i] - out[i] == 0.0f)) return 0;
    return 1;
}

static void sweep(const char *path) {
    size_t size = 0, cut, header_end, pos, i;
    unsigned char *file = tu_load(path, &size), *copy;
    uint64_t hl = 0;
    int k, cuts = 0, copies = 0, hdr_bad = 0, hdr_ok = 0, data_ok = 0, data_nonfinite = 0, runs = 0;
    supermat_model *m = NULL;
    supermat_model_info mi;
    supermat_error err;
    supermat_result r;
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    if (!file || size < 8) { TU_CHECK(0, "cannot read %s", path); free(file); return; }
    for (k = 7; k >= 0; k--) hl = (hl << 8) | file[k];
    header_end = 8 + (size_t)hl;
    copy = (unsigned char *)malloc(size);
    if (!copy) { free(file); return; }
    /* truncation: every byte of the header (and the first 64 of the data), then a stride through the data */
    for (cut = 0; cut < size; cut += cut < header_end + 64 ? 1 : size / 97 + 1) {
        int exact = cut % 61 == 0 || cut >= header_end;
        const unsigned char *buf = file;
        unsigned char *c = NULL;
        if (exact) { c = (unsigned char *)malloc(cut + 1); if (c) { memcpy(c, file, cut); buf = c; copies++; } }
        r = create(buf, cut, &m, &err);
        if (r == SUPERMAT_SUCCESS) { TU_CHECK(0, "%s cut at %zu of %zu bytes was accepted", name, cut, size); supermat_model_destroy(m); }
        else if (!err.message[0]) TU_CHECK(0, "%s cut at %zu: empty message", name, cut);
        cuts++;
        free(c);
    }
    /* a byte of the header changed, at a stride */
    for (pos = 0; pos < header_end; pos += 1 + header_end / 400) {
        memcpy(copy, file, size);
        copy[pos] ^= (unsigned char)(1u << (pos % 8));
        r = create(copy, size, &m, &err);
        if (r == SUPERMAT_SUCCESS) { hdr_ok++; supermat_model_destroy(m); }
        else { hdr_bad++; TU_CHECK(err.message[0] != 0, "%s header byte %zu: empty message", name, pos); }
    }
    /* a bit of the data flipped, at a stride: a model or NONFINITE; single-view models run to finite maps */
    for (i = 0, pos = header_end; pos < size; pos += (size - header_end) / 40 + 1, i++) {
        memcpy(copy, file, size);
        copy[pos] ^= (unsigned char)(0x80u >> (i % 8)); /* sign, exponent and mantissa bits in turn */
        r = create(copy, size, &m, &err);
        if (r == SUPERMAT_ERROR_NONFINITE) { data_nonfinite++; TU_CHECK(err.tensor[0] != 0, "%s data byte %zu: NONFINITE names no tensor", name, pos); continue; }
        TU_CHECK(r == SUPERMAT_SUCCESS, "%s data byte %zu flipped: %s (%s)", name, pos, supermat_result_string(r), err.message);
        if (r) continue;
        data_ok++;
        memset(&mi, 0, sizeof mi);
        supermat_model_get_info(m, &mi);
        if (mi.kind == SUPERMAT_KIND_SUPERMAT && i % 4 == 0) {
            supermat_result rr = SUPERMAT_SUCCESS;
            TU_CHECK(run_finite(m, &rr) && (rr == SUPERMAT_SUCCESS || rr == SUPERMAT_ERROR_NONFINITE), "%s data byte %zu flipped: the run gave %s or non-finite maps",
                     name, pos, supermat_result_string(rr));
            runs++;
        }
        supermat_model_destroy(m);
    }
    printf("%-34s %8zu bytes (header %zu): %d cuts refused (%d exact-size copies); header flips %d refused, %d valid; "
           "data flips %d models (%d run, finite), %d NONFINITE\n", name, size, header_end, cuts, copies, hdr_bad, hdr_ok, data_ok, runs, data_nonfinite);
    free(copy);
    free(file);
}

int main(int argc, char **argv) {
    int i;
    if (argc < 2) { fprintf(stderr, "usage: %s MODEL...\n", argv[0]); return 2; }
    for (i = 1; i < argc; i++) sweep(argv[i]);
    return tu_finish("corrupt");
}
