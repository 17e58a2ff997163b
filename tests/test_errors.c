/* Bad input and failure paths: truncated and corrupted model files, wrong shapes, missing tensors, NaN
   weights and pixels, bad sizes, an allocator that fails at the N-th call, cancellation, and results that
   are bit-identical for any thread count. Every case must return a clear error, never crash, never leak
   (this test runs under ASan/UBSan in CI) and never write an output on failure.
   usage: test_errors MODEL.safetensors [MV_MODEL UV_MODEL] */
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "../supermat.h"
#include "test_util.h"


static unsigned char *model_data;
static size_t model_size;

static supermat_result create(const unsigned char *data, size_t size, supermat_model **m, supermat_error *err) {
    supermat_model_desc md;
    memset(&md, 0, sizeof md);
    md.data = data; md.size = size;
    return supermat_model_create(&md, m, err);
}

/* header text helpers: the tensor entry of `name` */
static char *header_find(unsigned char *data, const char *needle) {
    uint64_t hl = 0;
    int i;
    char *h, *p;
    for (i = 7; i >= 0; i--) hl = (hl << 8) | data[i];
    h = (char *)data + 8;
    p = h;
    while ((size_t)(p - h) + strlen(needle) <= hl) { if (!memcmp(p, needle, strlen(needle))) return p; p++; }
    return NULL;
}

static void test_truncated(void) {
    size_t cut, step, header_end;
    uint64_t hl = 0;
    int i, errors = 0, crashes_would_show = 0;
    for (i = 7; i >= 0; i--) hl = (hl << 8) | model_data[i];
    header_end = 8 + (size_t)hl;
    /* every byte through the header, then a stride through the data */
    for (cut = 0; cut < model_size; cut += step) {
        supermat_model *m = NULL;
        supermat_error err;
        unsigned char *copy = (unsigned char *)malloc(cut + 1);
        supermat_result r;
        step = cut < header_end + 64 ? (cut < 64 ? 1 : 97) : model_size / 40 + 1;
        memcpy(copy, model_data, cut);
        r = create(copy, cut, &m, &err);
        if (r == SUPERMAT_SUCCESS) { TU_CHECK(0, "a model truncated at %zu of %zu bytes was accepted", cut, model_size); supermat_model_destroy(m); }
        else { errors++; if (!err.message[0]) TU_CHECK(0, "empty message at cut %zu", cut); }
        free(copy);
    }
    (void)crashes_would_show;
    TU_CHECK(errors > 100, "truncation sweep: %d errors", errors);
    printf("truncation sweep: %d truncated files rejected\n", errors);
}

static void test_corrupted(void) {
    /* flip bytes of the header: success or a clean error, never a crash; count outcomes */
    uint64_t hl = 0;
    int i, k, ok = 0, bad = 0;
    for (i = 7; i >= 0; i--) hl = (hl << 8) | model_data[i];
    for (k = 0; k < 400; k++) {
        unsigned char *copy = (unsigned char *)malloc(model_size);
        supermat_model *m = NULL;
        supermat_error err;
        size_t pos = 8 + (size_t)(((unsigned long long)k * 2654435761ull) % hl);
        memcpy(copy, model_data, model_size);
        copy[pos] ^= (unsigned char)(1 + k % 255);
        if (k % 50 == 0) copy[k % 8] ^= 0x40; /* the length field too */
        if (create(copy, model_size, &m, &err) == SUPERMAT_SUCCESS) { ok++; supermat_model_destroy(m); }
        else { bad++; TU_CHECK(err.message[0] != 0, "corruption %d: empty message", k); }
        free(copy);
    }
    printf("header corruption: %d rejected, %d still valid (e.g. a flipped metadata digit)\n", bad, ok);
    TU_CHECK(bad > 200, "only %d of 400 corrupted headers rejected", bad);
}

static void expect(const char *what, unsigned char *copy, supermat_result want, const char *tensor) {
    supermat_model *m = NULL;
    supermat_error err;
    supermat_result r = create(copy, model_size, &m, &err);
    TU_CHECK(r == want, "%s: got %s (%s), want %s", what, supermat_result_string(r), err.message, supermat_result_string(want));
    if (tensor) TU_CHECK(!strcmp(err.tensor, tensor), "%s: error names tensor '%s', want '%s' (%s)", what, err.tensor, tensor, err.message);
    if (r == want) printf("  %-28s -> %s: %s\n", what, supermat_result_string(r), err.message);
    supermat_model_destroy(m);
}

static void test_semantic(void) {
    unsigned char *copy = (unsigned char *)malloc(model_size);
    char *p;
    supermat_tensor_info ti;
    supermat_error err;
    int n, i;
    /* wrong shape, same element count: conv_in.weight [C,4,3,3] -> [C,4,9,1] */
    memcpy(copy, model_data, model_size);
    p = header_find(copy, "\"conv_in.weight\"");
    TU_CHECK(p != NULL, "conv_in.weight in the header");
    if (p && (p = strstr(p, "3, 3]")) != NULL) { memcpy(p, "9, 1]", 5); expect("wrong shape", copy, SUPERMAT_ERROR_SHAPE_MISMATCH, "conv_in.weight"); }
    else if (p == NULL || 1) {
        memcpy(copy, model_data, model_size);
        p = header_find(copy, "\"conv_in.weight\"");
        if (p && (p = strstr(p, "3,3]")) != NULL) { memcpy(p, "9,1]", 4); expect("wrong shape", copy, SUPERMAT_ERROR_SHAPE_MISMATCH, "conv_in.weight"); }
    }
    /* a missing tensor (renamed) */
    memcpy(copy, model_data, model_size);
    p = header_find(copy, "\"vae.decoder.conv_out.bias\"");
    TU_CHECK(p != NULL, "vae.decoder.conv_out.bias in the header");
    if (p) { p[strlen("\"vae.decoder.conv_out.bias") - 1] = 'X'; expect("missing tensor", copy, SUPERMAT_ERROR_MISSING_TENSOR, "vae.decoder.conv_out.bias"); }
    /* an unsupported dtype */
    memcpy(copy, model_data, model_size);
    p = header_find(copy, "\"F32\"");
    if (p) { memcpy(p, "\"I32\"", 5); expect("integer dtype", copy, SUPERMAT_ERROR_UNSUPPORTED, NULL); }
    /* unknown kind / version */
    memcpy(copy, model_data, model_size);
    p = header_find(copy, "\"supermat.format_version\"");
    if (p && (p = strstr(p + 26, "\"1\"")) != NULL) { p[1] = '7'; expect("format version 7", copy, SUPERMAT_ERROR_UNSUPPORTED, NULL); }
    memcpy(copy, model_data, model_size);
    p = header_find(copy, "\"unet.block_out_channels\"");
    if (p && (p = strchr(p + 26, '"')) != NULL) { p[1] = 'x'; expect("bad metadata number", copy, SUPERMAT_ERROR_MALFORMED_FILE, NULL); }
    /* NaN and Inf in weights */
    supermat_safetensors_count(model_data, model_size, model_size, &n, &err);
    for (i = 0; i < n; i++) {
        supermat_safetensors_tensor(model_data, model_size, model_size, i, &ti, &err);
        if (!strcmp(ti.name, "down_blocks.1.resnets.0.conv1.weight") || !strcmp(ti.name, "vae.encoder.conv_in.bias")) {
            float nan = NAN, inf = INFINITY;
            memcpy(copy, model_data, model_size);
            memcpy(copy + ti.offset + 4 * 7, ti.name[0] == 'v' ? &inf : &nan, 4);
            expect(ti.name[0] == 'v' ? "Inf in a bias" : "NaN in a weight", copy, SUPERMAT_ERROR_NONFINITE, ti.name);
        }
    }
    /* not safetensors at all */
    memcpy(copy, "PK\003\004not a model", 15);
    expect("a zip file", copy, SUPERMAT_ERROR_MALFORMED_FILE, NULL);
    free(copy);
}

static void test_allocator(void) {
    long n;
    int done = 0;
    for (n = 0; n < 100000 && !done; n += (n < 50 ? 1 : 37)) {
        tu_counting c;
        supermat_model_desc md;
        supermat_model *m = NULL;
        supermat_error err;
        memset(&c, 0, sizeof c);
        c.fail_at = n;
        memset(&md, 0, sizeof md);
        md.data = model_data; md.size = model_size;
        md.allocator.alloc = tu_count_alloc; md.allocator.free = tu_count_free; md.allocator.user = &c;
        if (supermat_model_create(&md, &m, &err) == SUPERMAT_SUCCESS) {
            /* now the session, failing at each of its allocations */
            long k;
            for (k = 0; k < 64; k++) {
                tu_counting cs;
                supermat_session_desc sd;
                supermat_session *s = NULL;
                supermat_result r;
                memset(&cs, 0, sizeof cs);
                cs.fail_at = k;
                memset(&sd, 0, sizeof sd);
                sd.model = m; sd.width = 16; sd.height = 16; sd.threads = 2;
                sd.allocator.alloc = tu_count_alloc; sd.allocator.free = tu_count_free; sd.allocator.user = &cs;
                r = supermat_session_create(&sd, &s, &err);
                if (r == SUPERMAT_SUCCESS) { supermat_session_destroy(s); TU_CHECK(cs.live == 0, "session leak: %ld blocks", cs.live); break; }
                TU_CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY, "session alloc failure %ld: %s", k, supermat_result_string(r));
                TU_CHECK(cs.live == 0, "session alloc failure %ld leaks %ld blocks", k, cs.live);
            }
            supermat_model_destroy(m);
            TU_CHECK(c.live == 0, "model leak after success: %ld blocks", c.live);
            printf("allocator: model creation succeeds after %ld allocations; every earlier failure reported OUT_OF_MEMORY without a leak\n", c.calls);
            done = 1;
        } else {
            TU_CHECK(err.result == SUPERMAT_ERROR_OUT_OF_MEMORY, "alloc failure %ld: %s (%s)", n, supermat_result_string(err.result), err.message);
            TU_CHECK(c.live == 0, "alloc failure %ld leaks %ld blocks", n, c.live);
        }
    }
    TU_CHECK(done, "model creation never succeeded");
}

static int cancel_at, progress_calls;
static int progress_cancel(void *user, float f, const char *what) { (void)user; (void)f; (void)what; return ++progress_calls >= cancel_at; }

/* a caller's parallel-for that runs tasks in reverse order, claiming 5 threads */
static void reverse_for(void *user, int count, supermat_task_fn task, void *task_user) {
    int i;
    (void)user;
    for (i = count - 1; i >= 0; i--) task(task_user, i, i % 5);
}

static void test_run(void) {
    supermat_model *m = NULL;
    supermat_error err;
    int W = 24, H = 16, i, t;
    unsigned char rgba[24 * 16 * 4], out[5][24 * 16 * 3];
    float frgb[24 * 16 * 3];
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_result r;
    size_t mem = 0;
    if (create(model_data, model_size, &m, &err)) { TU_CHECK(0, "model: %s", err.message); return; }
    for (i = 0; i < W * H * 4; i++) rgba[i] = (unsigned char)((i * 37 + (i >> 5) * 11) & 255);
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = 0; sd.height = 16;
    TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_ERROR_BAD_IMAGE, "zero width: %s", err.message);
    sd.width = 20;
    TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_ERROR_BAD_IMAGE, "width 20 (not a multiple of 8): %s", err.message);
    sd.width = 8; sd.height = 8;
    TU_CHECK(supermat_session_memory(&sd, &mem, &err) == SUPERMAT_SUCCESS && mem > 0, "memory query 8x8");
    sd.width = W; sd.height = H; sd.threads = 2;
    TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS, "session: %s", err.message);
    if (!s) { supermat_model_destroy(m); return; }
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = rgba; rd.input.width = W; rd.input.height = H; rd.input.channels = 4;
    rd.albedo.pixels = out[0]; rd.albedo.channels = 3;
    rd.roughness.pixels = out[1]; rd.roughness.channels = 1;
    rd.metallic.pixels = out[2]; rd.metallic.channels = 1;
    /* wrong input size */
    rd.input.width = 16;
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_BAD_IMAGE, "input size mismatch: %s", err.message);
    rd.input.width = W;
    rd.input.channels = 2;
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_BAD_IMAGE, "2-channel input: %s", err.message);
    rd.input.channels = 4;
    /* NaN / Inf pixels */
    for (i = 0; i < W * H * 3; i++) frgb[i] = 0.5f;
    frgb[W * 3 * 5 + 7] = NAN;
    rd.input.pixels = frgb; rd.input.channels = 3; rd.input.format = SUPERMAT_FORMAT_F32;
    memset(out, 0xAB, sizeof out);
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_NONFINITE, "NaN pixel: %s", err.message);
    frgb[W * 3 * 5 + 7] = -INFINITY;
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_NONFINITE, "Inf pixel: %s", err.message);
    TU_CHECK(out[0][0] == 0xAB && out[1][10] == 0xAB, "outputs untouched after a rejected input");
    rd.input.pixels = rgba; rd.input.channels = 4; rd.input.format = SUPERMAT_FORMAT_U8;
    /* cancellation at every progress call: outputs untouched */
    progress_calls = 0; cancel_at = 1 << 30;
    rd.progress = progress_cancel;
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "run: %s", err.message);
    memcpy(out[3], out[0], sizeof out[0]);
    {
        int total = progress_calls, k, cancelled = 0;
        for (k = 1; k <= total; k += (k < 5 ? 1 : 7)) {
            memset(out[0], 0xCD, sizeof out[0]);
            progress_calls = 0; cancel_at = k;
            r = supermat_run(s, &rd, &err);
            cancelled += r == SUPERMAT_ERROR_CANCELLED;
            TU_CHECK(r == SUPERMAT_ERROR_CANCELLED, "cancel at call %d: %s", k, supermat_result_string(r));
            TU_CHECK(out[0][0] == 0xCD && out[0][sizeof out[0] - 1] == 0xCD, "cancel at %d wrote an output", k);
        }
        printf("cancellation: %d progress calls per run, cancelled cleanly at %d points\n", total, cancelled);
    }
    rd.progress = NULL;
    /* the same result after cancellations, and for 1, 2, 3 threads and a reverse-order caller hook */
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS && !memcmp(out[0], out[3], sizeof out[0]), "a run after cancellations gives the same albedo");
    supermat_session_destroy(s);
    for (t = 0; t < 4; t++) {
        float f1[24 * 16 * 3], f2[24 * 16];
        static float ref1[24 * 16 * 3], ref2[24 * 16];
        memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = W; sd.height = H; sd.threads = t + 1;
        if (t == 3) { sd.threading.parallel_for = reverse_for; sd.threading.max_threads = 5; }
        s = NULL;
        TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS, "session %d: %s", t, err.message);
        if (!s) continue;
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = rgba; rd.input.width = W; rd.input.height = H; rd.input.channels = 4;
        rd.albedo.pixels = f1; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
        rd.metallic.pixels = f2; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "run %d: %s", t, err.message);
        if (t == 0) { memcpy(ref1, f1, sizeof f1); memcpy(ref2, f2, sizeof f2); }
        else TU_CHECK(!memcmp(ref1, f1, sizeof f1) && !memcmp(ref2, f2, sizeof f2), "results differ between 1 thread and config %d", t);
        supermat_session_destroy(s);
    }
    /* strides: a padded input and padded outputs give the same pixels and leave the padding alone */
    {
        static unsigned char pin[16 * 100], pout[16 * 120], ref[24 * 16 * 3];
        static float pf[16 * 40];
        int x, y, c;
        memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = W; sd.height = H; sd.threads = 2;
        s = NULL;
        if (supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS) {
            memset(&rd, 0, sizeof rd);
            rd.input.pixels = rgba; rd.input.width = W; rd.input.height = H; rd.input.channels = 4;
            rd.albedo.pixels = ref; rd.albedo.channels = 3;
            TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "packed run: %s", err.message);
            memset(pin, 0x5A, sizeof pin);
            for (y = 0; y < H; y++) memcpy(pin + (size_t)y * 100, rgba + (size_t)y * W * 4, (size_t)W * 4);
            memset(pout, 0x77, sizeof pout);
            for (i = 0; i < 16 * 40; i++) pf[i] = -7.0f;
            rd.input.pixels = pin; rd.input.stride = 100;
            rd.albedo.pixels = pout; rd.albedo.stride = 120;
            rd.roughness.pixels = pf; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32; rd.roughness.stride = 40 * sizeof(float);
            TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "strided run: %s", err.message);
            for (y = 0; y < H; y++) {
                TU_CHECK(!memcmp(pout + (size_t)y * 120, ref + (size_t)y * W * 3, (size_t)W * 3), "strided albedo row %d differs", y);
                for (x = W * 3; x < 120; x++) if (pout[(size_t)y * 120 + x] != 0x77) { TU_CHECK(0, "albedo padding written at row %d", y); break; }
                for (c = W; c < 40; c++) if (pf[(size_t)y * 40 + c] != -7.0f) { TU_CHECK(0, "roughness padding written at row %d", y); break; }
                for (c = 0; c < W; c++) if (!(pf[(size_t)y * 40 + c] >= 0.0f && pf[(size_t)y * 40 + c] <= 1.0f)) { TU_CHECK(0, "roughness out of [0,1]"); break; }
            }
            rd.albedo.stride = 10; /* smaller than a row */
            TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_BAD_IMAGE, "stride smaller than a row: %s", err.message);
            supermat_session_destroy(s);
        }
    }
    /* an output that was not requested */
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = W; sd.height = H; sd.threads = 1; sd.outputs = SUPERMAT_OUTPUT_ALBEDO;
    if (supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS) {
        size_t m_all = 0, m_alb = 0;
        supermat_session_desc sd2 = sd;
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = rgba; rd.input.width = W; rd.input.height = H; rd.input.channels = 4;
        rd.albedo.pixels = out[0]; rd.albedo.channels = 3;
        rd.metallic.pixels = out[2]; rd.metallic.channels = 1;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT, "metallic from an albedo-only session: %s", err.message);
        rd.metallic.pixels = NULL;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS && !memcmp(out[0], out[3], sizeof out[0]), "albedo-only session gives the same albedo");
        supermat_session_memory(&sd2, &m_alb, &err);
        sd2.outputs = 0;
        supermat_session_memory(&sd2, &m_all, &err);
        printf("session memory %dx%d: all outputs %zu bytes, albedo only %zu bytes\n", W, H, m_all, m_alb);
        supermat_session_destroy(s);
    }
    supermat_model_destroy(m);
}

/* SuperMatMV cameras and UV-refine inputs */
static void test_mv_uv(const char *mv_path, const char *uv_path) {
    size_t size = 0;
    unsigned char *data = tu_load(mv_path, &size), rgba[6][16 * 16 * 4], out[6][16 * 16 * 3];
    supermat_model *m = NULL;
    supermat_error err;
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_image views[6], outs[6];
    float cams[6 * 16];
    int i;
    TU_CHECK(data && create(data, size, &m, &err) == SUPERMAT_SUCCESS, "MV model: %s", data ? err.message : mv_path);
    if (m) {
        memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = 16; sd.height = 16; sd.views = 3; sd.threads = 1;
        TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS, "MV session: %s", err.message);
        memset(&rd, 0, sizeof rd);
        memset(views, 0, sizeof views); memset(outs, 0, sizeof outs);
        for (i = 0; i < 6; i++) {
            int k;
            for (k = 0; k < 16 * 16 * 4; k++) rgba[i][k] = (unsigned char)(k * (i + 3));
            views[i].pixels = rgba[i]; views[i].width = 16; views[i].height = 16; views[i].channels = 4;
            outs[i].pixels = out[i]; outs[i].channels = 3;
        }
        for (i = 0; i < 6 * 16; i++) cams[i] = (i % 5 == 0) ? 1.0f : 0.0f;
        rd.input_views = views; rd.albedo_views = outs;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT, "MV without cameras: %s", err.message);
        printf("  %-28s -> %s\n", "MV without cameras", err.message);
        rd.cameras = cams;
        cams[16 + 3] = NAN;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_NONFINITE, "NaN camera: %s", err.message);
        printf("  %-28s -> %s\n", "NaN camera", err.message);
        cams[16 + 3] = INFINITY;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_NONFINITE, "Inf camera: %s", err.message);
        cams[16 + 3] = 0.0f;
        rd.input_views = NULL;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT, "3 views without input_views: %s", err.message);
        rd.input_views = views;
        views[2].width = 8;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_BAD_IMAGE, "a view of another size: %s", err.message);
        views[2].width = 16;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "MV run: %s", err.message);
        /* the cameras matter: another camera for view 1 changes view 1's albedo */
        memcpy(out[5], out[1], sizeof out[1]);
        cams[16 + 0] = -1.0f;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS && memcmp(out[5], out[1], sizeof out[1]) != 0, "a camera change does not change the output");
        supermat_session_destroy(s);
        sd.views = 65;
        TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT, "65 views: %s", err.message);
        supermat_model_destroy(m);
    }
    free(data);
    /* several views are for MV models only */
    m = NULL;
    if (create(model_data, model_size, &m, &err) == SUPERMAT_SUCCESS) {
        memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = 16; sd.height = 16; sd.views = 2;
        TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT, "2 views on a single-view model: %s", err.message);
        supermat_model_destroy(m);
    }
    /* UV refine: mask and position required, same size */
    data = tu_load(uv_path, &size);
    m = NULL;
    TU_CHECK(data && create(data, size, &m, &err) == SUPERMAT_SUCCESS, "UV model: %s", data ? err.message : uv_path);
    if (m) {
        static unsigned char map[32 * 32 * 3], msk[32 * 32], pos[32 * 32 * 3], res[32 * 32 * 3];
        memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = 32; sd.height = 32; sd.threads = 1;
        s = NULL;
        TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS, "UV session: %s", err.message);
        for (i = 0; i < 32 * 32 * 3; i++) { map[i] = (unsigned char)(i * 7); pos[i] = (unsigned char)(i * 3); }
        for (i = 0; i < 32 * 32; i++) msk[i] = (unsigned char)(i % 4 * 85);
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = map; rd.input.width = 32; rd.input.height = 32; rd.input.channels = 3;
        rd.refined.pixels = res; rd.refined.channels = 3;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT, "UV without mask: %s", err.message);
        printf("  %-28s -> %s\n", "UV without mask/position", err.message);
        rd.mask.pixels = msk; rd.mask.width = 32; rd.mask.height = 32; rd.mask.channels = 1;
        rd.position.pixels = pos; rd.position.width = 16; rd.position.height = 32; rd.position.channels = 3;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_BAD_IMAGE, "mismatched position size: %s", err.message);
        printf("  %-28s -> %s\n", "mismatched position size", err.message);
        rd.position.width = 32; rd.position.channels = 1;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_BAD_IMAGE, "1-channel position: %s", err.message);
        rd.position.channels = 3;
        rd.albedo.pixels = out[0]; rd.albedo.channels = 3;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT, "albedo from a UV model: %s", err.message);
        rd.albedo.pixels = NULL;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "UV run: %s", err.message);
        supermat_session_destroy(s);
        supermat_model_destroy(m);
    }
    free(data);
}

/* the compute mode's refusals: bf16 compute without AVX512_BF16, on the scalar / AVX2 kernels, with int8
   weights, and an unknown mode; on a CPU with AVX512_BF16 the valid request gives a model that says so */
static void test_compute(void) {
    static const struct { int kernel, weights, compute; supermat_result want; const char *what; } cases[] = {
        {SUPERMAT_KERNEL_SCALAR, 0, SUPERMAT_COMPUTE_BF16, SUPERMAT_ERROR_INVALID_ARGUMENT, "bf16 compute on the scalar kernel"},
        {SUPERMAT_KERNEL_AVX2, 0, SUPERMAT_COMPUTE_BF16, SUPERMAT_ERROR_INVALID_ARGUMENT, "bf16 compute on the AVX2 kernel"},
        {SUPERMAT_KERNEL_AUTO, SUPERMAT_WEIGHTS_I8, SUPERMAT_COMPUTE_BF16, SUPERMAT_ERROR_INVALID_ARGUMENT, "bf16 compute with int8 weights"},
        {SUPERMAT_KERNEL_AUTO, 0, SUPERMAT_COMPUTE_COUNT, SUPERMAT_ERROR_INVALID_ARGUMENT, "unknown compute mode"},
        {SUPERMAT_KERNEL_AMX, 0, SUPERMAT_COMPUTE_F32, SUPERMAT_ERROR_INVALID_ARGUMENT, "the AMX kernel with f32 compute"},
        {SUPERMAT_KERNEL_COUNT, 0, SUPERMAT_COMPUTE_F32, SUPERMAT_ERROR_INVALID_ARGUMENT, "unknown kernel"},
        {SUPERMAT_KERNEL_SCALAR, 0, SUPERMAT_COMPUTE_INT8, SUPERMAT_ERROR_INVALID_ARGUMENT, "int8 compute on the scalar kernel"},
        {SUPERMAT_KERNEL_NEON, 0, SUPERMAT_COMPUTE_INT8, SUPERMAT_ERROR_INVALID_ARGUMENT, "int8 compute on the NEON kernel"},
        {SUPERMAT_KERNEL_AMX, 0, SUPERMAT_COMPUTE_INT8, SUPERMAT_ERROR_INVALID_ARGUMENT, "int8 compute on the AMX kernel"},
    };
    int i, has = supermat_cpu().avx512_bf16, has8 = supermat_cpu().avx512_vnni, has8v = supermat_cpu().avx_vnni;
    for (i = 0; i < (int)(sizeof cases / sizeof cases[0]); i++) {
        supermat_model_desc md;
        supermat_model *m = NULL;
        supermat_error err;
        supermat_result r, want = cases[i].want;
        memset(&md, 0, sizeof md);
        md.data = model_data; md.size = model_size;
        md.kernel = (supermat_kernel)cases[i].kernel; md.weights = (supermat_weights)cases[i].weights; md.compute = (supermat_compute)cases[i].compute;
        if (!has && cases[i].compute == SUPERMAT_COMPUTE_BF16) want = SUPERMAT_ERROR_UNSUPPORTED; /* refused for the CPU first */
        r = supermat_model_create(&md, &m, &err);
        TU_CHECK(r == want && !m, "%s: got %s (%s), want %s", cases[i].what, supermat_result_string(r), err.message, supermat_result_string(want));
        supermat_model_destroy(m);
    }
    {
        supermat_model_desc md;
        supermat_model *m = NULL;
        supermat_error err;
        supermat_model_info info;
        supermat_result r;
        memset(&md, 0, sizeof md);
        md.data = model_data; md.size = model_size; md.compute = SUPERMAT_COMPUTE_BF16;
        r = supermat_model_create(&md, &m, &err);
        if (!has) TU_CHECK(r == SUPERMAT_ERROR_UNSUPPORTED, "bf16 compute without AVX512_BF16: got %s", supermat_result_string(r));
        else {
            TU_CHECK(r == SUPERMAT_SUCCESS, "bf16 compute: %s", err.message);
            if (m) { /* AUTO: AMX tiles where the CPU and OS allow them, else vdpbf16ps on the AVX-512 kernel */
                supermat_kernel want_k = supermat_cpu().amx_bf16 ? SUPERMAT_KERNEL_AMX : SUPERMAT_KERNEL_AVX512;
                supermat_model_get_info(m, &info);
                TU_CHECK(info.compute == SUPERMAT_COMPUTE_BF16 && info.kernel == want_k && info.weights == SUPERMAT_WEIGHTS_BF16,
                         "bf16 compute model info: compute %d kernel %d (want %d) weights %d", (int)info.compute, (int)info.kernel, (int)want_k, (int)info.weights);
            }
            supermat_model_destroy(m);
            m = NULL;
            md.kernel = SUPERMAT_KERNEL_AVX512; /* vdpbf16ps asked for by name */
            r = supermat_model_create(&md, &m, &err);
            if (m) supermat_model_get_info(m, &info);
            TU_CHECK(r == SUPERMAT_SUCCESS && m && info.kernel == SUPERMAT_KERNEL_AVX512, "bf16 compute on the AVX-512 kernel: %s", err.message);
            supermat_model_destroy(m);
            m = NULL;
            md.kernel = SUPERMAT_KERNEL_AMX; /* AMX by name: a model, or UNSUPPORTED without it */
            r = supermat_model_create(&md, &m, &err);
            if (supermat_cpu().amx_bf16) TU_CHECK(r == SUPERMAT_SUCCESS && m, "bf16 compute on AMX: %s", err.message);
            else TU_CHECK(r == SUPERMAT_ERROR_UNSUPPORTED && !m, "AMX without AMX: got %s", supermat_result_string(r));
        }
        {   /* int8 compute, from f32 and from int8 weights: AUTO picks the AVX-512 kernel (AVX512_VNNI), else the
               AVX2 kernel (AVX-VNNI), else UNSUPPORTED; each kernel by name needs its own VNNI */
            static const supermat_weights ws[] = {SUPERMAT_WEIGHTS_DEFAULT, SUPERMAT_WEIGHTS_I8};
            static const supermat_kernel ks[] = {SUPERMAT_KERNEL_AUTO, SUPERMAT_KERNEL_AVX512, SUPERMAT_KERNEL_AVX2};
            int wi, ki;
            for (ki = 0; ki < 3; ki++)
                for (wi = 0; wi < 2; wi++) {
                    int ok = ki == 0 ? has8 || has8v : ki == 1 ? has8 : has8v;
                    supermat_kernel want_k = ki == 2 || (ki == 0 && !has8) ? SUPERMAT_KERNEL_AVX2 : SUPERMAT_KERNEL_AVX512;
                    supermat_model_destroy(m);
                    m = NULL;
                    md.kernel = ks[ki]; md.compute = SUPERMAT_COMPUTE_INT8; md.weights = ws[wi];
                    r = supermat_model_create(&md, &m, &err);
                    if (!ok) TU_CHECK(r == SUPERMAT_ERROR_UNSUPPORTED && !m, "int8 compute (kernel %d) without its VNNI: got %s", (int)ks[ki],
                                      supermat_result_string(r));
                    else {
                        if (m) supermat_model_get_info(m, &info);
                        TU_CHECK(r == SUPERMAT_SUCCESS && m && info.compute == SUPERMAT_COMPUTE_INT8 && info.kernel == want_k &&
                                 info.weights == SUPERMAT_WEIGHTS_I8, "int8 compute (kernel %d, weights %d): %s; kernel %d, want %d", (int)ks[ki],
                                 (int)ws[wi], err.message, m ? (int)info.kernel : -1, (int)want_k);
                    }
                }
            md.kernel = SUPERMAT_KERNEL_AUTO; md.compute = SUPERMAT_COMPUTE_BF16; md.weights = SUPERMAT_WEIGHTS_DEFAULT;
        }
        if (!supermat_cpu().neon) { /* the NEON kernel by name on a build without it */
            supermat_model_destroy(m);
            m = NULL;
            md.compute = SUPERMAT_COMPUTE_F32; md.kernel = SUPERMAT_KERNEL_NEON;
            r = supermat_model_create(&md, &m, &err);
            TU_CHECK(r == SUPERMAT_ERROR_UNSUPPORTED && !m, "NEON on a non-aarch64 build: got %s", supermat_result_string(r));
        }
        supermat_model_destroy(m);
        printf("  compute modes: refusals checked%s\n", has ? ", bf16 compute model created" : " (no AVX512_BF16: UNSUPPORTED)");
    }
}


/* memory caps: model_desc.max_memory and session_desc.max_memory refuse before allocating past them */
static void test_memory_cap(void) {
    supermat_model_desc md;
    supermat_model *m = NULL, *m2 = NULL;
    supermat_model_info mi;
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_error err;
    tu_counting c;
    size_t need = 0;
    supermat_result r;
    memset(&md, 0, sizeof md);
    md.data = model_data; md.size = model_size;
    if (supermat_model_create(&md, &m, &err)) { TU_CHECK(0, "model: %s", err.message); return; }
    memset(&mi, 0, sizeof mi);
    supermat_model_get_info(m, &mi);
    /* the model: exactly its memory fits, a byte less does not, and nothing stays allocated */
    memset(&c, 0, sizeof c); c.fail_at = -1;
    md.allocator.alloc = tu_count_alloc; md.allocator.free = tu_count_free; md.allocator.user = &c;
    md.max_memory = mi.model_bytes - 1;
    r = supermat_model_create(&md, &m2, &err);
    TU_CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY && strstr(err.message, "max_memory") && c.live == 0, "model cap one byte short: %s (%s), %ld blocks live",
             supermat_result_string(r), err.message, c.live);
    md.max_memory = mi.model_bytes;
    r = supermat_model_create(&md, &m2, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "model cap = its memory: %s", err.message);
    supermat_model_destroy(m2);
    TU_CHECK(c.live == 0, "model with a cap leaks %ld blocks", c.live);
    /* the session: its plan fits or nothing is allocated */
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = sd.height = 64; sd.threads = 1;
    TU_CHECK(supermat_session_memory(&sd, &need, &err) == SUPERMAT_SUCCESS, "plan: %s", err.message);
    memset(&c, 0, sizeof c); c.fail_at = -1;
    sd.allocator.alloc = tu_count_alloc; sd.allocator.free = tu_count_free; sd.allocator.user = &c;
    sd.max_memory = need - 1;
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY && c.calls == 0 && strstr(err.message, "max_memory"), "session cap one byte short: %s (%s), %ld allocations",
             supermat_result_string(r), err.message, c.calls);
    sd.max_memory = need;
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "session cap = its plan: %s", err.message);
    supermat_session_destroy(s);
    /* the largest image a session takes, under a 1 GiB cap: refused from the plan, no allocation */
    memset(&c, 0, sizeof c); c.fail_at = -1;
    sd.width = sd.height = 16384; sd.max_memory = (size_t)1 << 30;
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY && c.calls == 0, "16384x16384 under 1 GiB: %s, %ld allocations", supermat_result_string(r), c.calls);
    printf("memory caps: %s\n", err.message);
    /* sizes past what a session takes are refused before any planning */
    sd.width = sd.height = 65536;
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_ERROR_BAD_IMAGE && c.calls == 0, "65536x65536: %s", supermat_result_string(r));
    supermat_model_destroy(m);
}


/* sizes at the integer boundaries: tensor shapes whose element count or byte count passes 2^31, 2^32,
   2^63 and 2^64, data offsets near 2^64; each refused with MALFORMED, never wrapped */
static void test_size_overflow(void) {
    static const struct { const char *shape, *dtype, *offsets, *want; } cases[] = {
        {"[2147483648]", "F32", "[0, 8589934592]", "past the end"},              /* 2^31 elements: 8 GiB */
        {"[65536, 65536]", "F16", "[0, 8589934592]", "past the end"},            /* 2^32 elements */
        {"[3037000500, 3037000500]", "F32", "[0, 16]", "do not match"},         /* 2^63 < n, n*4 > 2^64 */
        {"[4294967296, 4294967296]", "F32", "[0, 16]", "overflows"},            /* 2^64 elements */
        {"[4294967296, 4294967296, 4]", "I8", "[0, 16]", "overflows"},
        {"[4]", "F32", "[18446744073709551600, 18446744073709551616]", "data_offsets"}, /* past 2^64 */
        {"[4]", "F32", "[16, 0]", "do not match"},                             /* end before start */
    };
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char hdr[400];
        unsigned char file[512];
        supermat_tensor_info ti;
        supermat_error err;
        supermat_result r;
        int n = snprintf(hdr, sizeof hdr, "{\"t\":{\"dtype\":\"%s\",\"shape\":%s,\"data_offsets\":%s}}", cases[i].dtype, cases[i].shape, cases[i].offsets), k;
        memset(file, 0, sizeof file);
        for (k = 0; k < 8; k++) file[k] = (unsigned char)((uint64_t)n >> (8 * k));
        memcpy(file + 8, hdr, (size_t)n);
        r = supermat_safetensors_tensor(file, 8 + (size_t)n + 16, 8 + (size_t)n + 16, 0, &ti, &err);
        TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE && strstr(err.message, cases[i].want), "shape %s %s offsets %s: %s (%s), want '%s'", cases[i].shape,
                 cases[i].dtype, cases[i].offsets, supermat_result_string(r), err.message, cases[i].want);
    }
    printf("size overflow: %d shapes / offsets past 2^31 .. 2^64 refused\n", (int)(sizeof cases / sizeof cases[0]));
}

/* the arena planner and the image checks at the integer boundaries. Plans of 2048^2 .. 16384^2 (and 16384 x 8,
   8 x 16384): the largest passes 2^31 and 2^32 bytes, and each plan follows the area (the f64 ratio of the
   sizes) within 10 %: a plan computed in 32-bit products would wrap and not. Strides whose rows x stride
   pass 2^63 or 2^64 are refused (BAD_IMAGE) before a pixel is read. */
static void test_plan_boundaries(void) {
    static const int sizes[][2] = {{2048, 2048}, {4096, 4096}, {8192, 8192}, {16384, 16384}, {16384, 8}, {8, 16384}};
    supermat_model *m = NULL;
    supermat_error err;
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_result r;
    size_t b[6], fixed;
    unsigned char px[64 * 64 * 4], out[64 * 64 * 3];
    int i;
    if (create(model_data, model_size, &m, &err)) { TU_CHECK(0, "model: %s", err.message); return; }
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.threads = 1;
    sd.width = sd.height = 8;
    TU_CHECK(supermat_session_memory(&sd, &fixed, &err) == SUPERMAT_SUCCESS, "plan 8x8: %s", err.message);
    for (i = 0; i < 6; i++) {
        sd.width = sizes[i][0]; sd.height = sizes[i][1];
        r = supermat_session_memory(&sd, &b[i], &err);
        TU_CHECK(r == SUPERMAT_SUCCESS, "plan %dx%d: %s", sd.width, sd.height, err.message);
        if (r) b[i] = 0;
    }
    TU_CHECK((double)b[3] > 4294967296.0, "the 16384^2 plan (%.3f GiB) passes 2^32 bytes", (double)b[3] / 1073741824.0);
    for (i = 1; i < 4; i++) {
        double ratio = (double)(b[i] - fixed) / (double)(b[i - 1] - fixed);
        TU_CHECK(ratio > 3.6 && ratio < 4.4, "plan %d^2 / plan %d^2 = %.3f (the area: 4)", sizes[i][0], sizes[i - 1][0], ratio);
    }
    TU_CHECK(b[4] > fixed && b[4] < b[3] / 512 && b[5] > fixed && b[5] < b[3] / 512, "16384 x 8 and 8 x 16384: %llu and %llu bytes",
             (unsigned long long)b[4], (unsigned long long)b[5]);
    printf("plans: 8^2 %.1f MiB, 2048^2 %.1f MiB, 16384^2 %.2f GiB, 16384 x 8 %.1f MiB\n", (double)fixed / 1048576.0, (double)b[0] / 1048576.0,
           (double)b[3] / 1073741824.0, (double)b[4] / 1048576.0);
    /* strides past the address space: refused before a pixel is read (the buffer is 64 x 64) */
    sd.width = sd.height = 64;
    if (supermat_session_create(&sd, &s, &err)) { TU_CHECK(0, "session 64x64: %s", err.message); supermat_model_destroy(m); return; }
    memset(px, 100, sizeof px);
    for (i = 0; i < 3; i++) {
        static const size_t strides[3] = {(size_t)PTRDIFF_MAX / 64 + 1, (size_t)-1 / 64 + 1, (size_t)-1};
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = px; rd.input.width = 64; rd.input.height = 64; rd.input.channels = 4;
        rd.albedo.pixels = out; rd.albedo.channels = 3;
        rd.input.stride = strides[i];
        memset(out, 0xCD, sizeof out);
        r = supermat_run(s, &rd, &err);
        TU_CHECK(r == SUPERMAT_ERROR_BAD_IMAGE && strstr(err.message, "address space") && out[0] == 0xCD && out[sizeof out - 1] == 0xCD,
                 "input stride %llu x 64 rows: %s (%s)", (unsigned long long)strides[i], supermat_result_string(r), err.message);
        rd.input.stride = 0; rd.albedo.stride = strides[i];
        r = supermat_run(s, &rd, &err);
        TU_CHECK(r == SUPERMAT_ERROR_BAD_IMAGE && strstr(err.message, "address space") && out[0] == 0xCD,
                 "output stride %llu x 64 rows: %s (%s)", (unsigned long long)strides[i], supermat_result_string(r), err.message);
    }
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = px; rd.input.width = 64; rd.input.height = 64; rd.input.channels = 4;
    rd.albedo.pixels = out; rd.albedo.channels = 3;
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "the session runs after the refusals: %s", err.message);
    printf("strides whose 64 rows pass 2^63 / 2^64 bytes: refused, nothing read or written\n");
    supermat_session_destroy(s);
    supermat_model_destroy(m);
}

int main(int argc, char **argv) {
    if (argc < 2) { fprintf(stderr, "usage: %s MODEL [MV_MODEL UV_MODEL]\n", argv[0]); return 2; }
    model_data = tu_load(argv[1], &model_size);
    if (!model_data) { printf("cannot read %s\n", argv[1]); return 1; }
    test_semantic();
    test_compute();
    test_truncated();
    test_corrupted();
    test_allocator();
    test_memory_cap();
    test_size_overflow();
    test_plan_boundaries();
    test_run();
    if (argc > 3) test_mv_uv(argv[2], argv[3]);
    free(model_data);
    return tu_finish("errors");
}
