/* Stability at the extremes (tiny official-architecture model): every intermediate tensor and output
   must be finite, outputs in [0, 1], for all-black, all-white and saturated images, alpha 0 and alpha 1
   everywhere, a one-pixel object, the smallest input (8x8), denormal inputs, degenerate cameras; the
   memory plan of a 2048x2048 session and (--large) a 2048x2048 run with VAE tiles; the same images with
   f16 weights, and an f16-weight GEMM whose outputs (1e9) overflow f16 against float64; softmax with
   logits of +-1e4 against a float64 reference.
   Denormals: the library never changes the FPU mode (no flush-to-zero) on any path.
   usage: test_extremes MODEL MV_MODEL */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include "test_util.h"

typedef struct finite_ctx { int bad, stages; supermat_stage where; } finite_ctx;
static void check_finite(void *user, supermat_stage stage, int branch, float *d, int n, int h, int w, int c) {
    finite_ctx *f = (finite_ctx *)user;
    size_t i, total = (size_t)n * h * w * c;
    (void)branch;
    f->stages++;
    for (i = 0; i < total; i++) if (!(d[i] - d[i] == 0.0f)) { if (!f->bad) f->where = stage; f->bad++; break; }
}

static int large_tile; /* vae_tile of run_image */
static int run_image(supermat_model *m, int W, int H, const void *px, int channels, supermat_format fmt, const char *what) {
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_error err;
    finite_ctx f;
    float *alb = (float *)malloc(sizeof(float) * 3 * W * H), *rou = (float *)malloc(sizeof(float) * W * H);
    int i, ok = 1;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = W; sd.height = H; sd.threads = 2; sd.vae_tile = large_tile; sd.vae_overlap = large_tile ? 64 : 0;
    if (supermat_session_create(&sd, &s, &err) != SUPERMAT_SUCCESS) { TU_CHECK(0, "%s: session: %s", what, err.message); free(alb); free(rou); return 0; }
    memset(&rd, 0, sizeof rd);
    memset(&f, 0, sizeof f);
    rd.input.pixels = (void *)px; rd.input.width = W; rd.input.height = H; rd.input.channels = channels; rd.input.format = fmt;
    rd.albedo.pixels = alb; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
    rd.roughness.pixels = rou; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
    rd.inspect = check_finite; rd.inspect_user = &f;
    TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "%s: run: %s", what, err.message);
    TU_CHECK(f.bad == 0 && f.stages >= 7, "%s: non-finite values at stage %d (%d stages seen)", what, (int)f.where, f.stages);
    for (i = 0; i < 3 * W * H; i++) if (!(alb[i] >= 0.0f && alb[i] <= 1.0f)) { ok = 0; break; }
    for (i = 0; i < W * H; i++) if (!(rou[i] >= 0.0f && rou[i] <= 1.0f)) { ok = 0; break; }
    TU_CHECK(ok, "%s: outputs outside [0, 1]", what);
    supermat_session_destroy(s);
    free(alb); free(rou);
    printf("  %-36s finite, in [0,1]: %s\n", what, ok && !f.bad ? "yes" : "NO");
    return ok && !f.bad;
}

static void test_images(supermat_model *m) {
    enum { W = 32, H = 24 };
    static unsigned char u8[W * H * 4];
    static float f32[W * H * 4];
    int i, n = 0;
    memset(u8, 0, sizeof u8); for (i = 0; i < W * H; i++) u8[i * 4 + 3] = 255;
    n += run_image(m, W, H, u8, 4, SUPERMAT_FORMAT_U8, "all black, alpha 1");
    memset(u8, 255, sizeof u8);
    n += run_image(m, W, H, u8, 4, SUPERMAT_FORMAT_U8, "all white, alpha 1");
    for (i = 0; i < W * H; i++) { u8[i * 4] = (unsigned char)(i % 3 == 0 ? 255 : 0); u8[i * 4 + 1] = (unsigned char)(i % 3 == 1 ? 255 : 0); u8[i * 4 + 2] = (unsigned char)(i % 3 == 2 ? 255 : 0); u8[i * 4 + 3] = 255; }
    n += run_image(m, W, H, u8, 4, SUPERMAT_FORMAT_U8, "saturated primaries");
    for (i = 0; i < W * H; i++) { u8[i * 4] = (unsigned char)(i * 37); u8[i * 4 + 1] = (unsigned char)(i * 11); u8[i * 4 + 2] = (unsigned char)(i * 7); u8[i * 4 + 3] = 0; }
    n += run_image(m, W, H, u8, 4, SUPERMAT_FORMAT_U8, "alpha 0 everywhere (garbage RGB)");
    { /* alpha 0 everywhere must equal a plain gray 0.5 image: the RGB under alpha 0 cannot matter */
        supermat_session_desc sd; supermat_session *s = NULL; supermat_run_desc rd; supermat_error err;
        static unsigned char a0[W * H * 3], a1[W * H * 3];
        static float gray[W * H * 3];
        for (i = 0; i < W * H * 3; i++) gray[i] = 0.5f;
        memset(&sd, 0, sizeof sd); sd.model = m; sd.width = W; sd.height = H; sd.threads = 1;
        if (supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS) {
            memset(&rd, 0, sizeof rd);
            rd.input.pixels = u8; rd.input.width = W; rd.input.height = H; rd.input.channels = 4;
            rd.albedo.pixels = a0; rd.albedo.channels = 3;
            supermat_run(s, &rd, &err);
            rd.input.pixels = gray; rd.input.channels = 3; rd.input.format = SUPERMAT_FORMAT_F32;
            rd.albedo.pixels = a1;
            supermat_run(s, &rd, &err);
            TU_CHECK(!memcmp(a0, a1, sizeof a0), "alpha 0 with garbage RGB differs from a gray image");
            supermat_session_destroy(s);
        }
    }
    memset(u8, 0, sizeof u8);
    u8[(H / 2 * W + W / 2) * 4 + 0] = 200; u8[(H / 2 * W + W / 2) * 4 + 3] = 255;
    n += run_image(m, W, H, u8, 4, SUPERMAT_FORMAT_U8, "a one-pixel object");
    for (i = 0; i < W * H * 4; i++) f32[i] = (i % 4 == 3) ? 1.0f : 1e-40f; /* denormal colours */
    n += run_image(m, W, H, f32, 4, SUPERMAT_FORMAT_F32, "denormal inputs");
    for (i = 0; i < W * H * 4; i++) f32[i] = (i % 4 == 3) ? 1e-41f : 5.0f; /* out-of-range colour, denormal alpha */
    n += run_image(m, W, H, f32, 4, SUPERMAT_FORMAT_F32, "out-of-range floats, denormal alpha");
    for (i = 0; i < 8 * 8 * 4; i++) u8[i] = (unsigned char)(i * 5);
    n += run_image(m, 8, 8, u8, 4, SUPERMAT_FORMAT_U8, "the smallest input, 8x8");
    printf("extreme images: %d of 8 finite within [0, 1] at every stage\n", n);
}

static void test_large_plan(supermat_model *m) {
    supermat_session_desc sd;
    supermat_error err;
    size_t b512 = 0, b2048 = 0;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = 512; sd.height = 512; sd.threads = 2;
    TU_CHECK(supermat_session_memory(&sd, &b512, &err) == SUPERMAT_SUCCESS, "plan 512: %s", err.message);
    sd.width = sd.height = 2048;
    TU_CHECK(supermat_session_memory(&sd, &b2048, &err) == SUPERMAT_SUCCESS, "plan 2048: %s", err.message);
    /* activations grow with the pixels: 16x the pixels needs 10x..17x the arena */
    TU_CHECK(b2048 > 10 * (b512 / 2) && b2048 < 17 * b512, "2048 plan %zu bytes vs 512 plan %zu", b2048, b512);
    printf("memory plan: 512x512 %.1f MiB, 2048x2048 %.1f MiB (tiny model)\n", b512 / 1048576.0, b2048 / 1048576.0);
    sd.width = sd.height = 16384 + 8;
    TU_CHECK(supermat_session_memory(&sd, &b2048, &err) == SUPERMAT_ERROR_BAD_IMAGE, "16392 px refused: %s", err.message);
}

static void test_softmax_extremes(void) {
    /* logits of +-1e4: one key dominates each query; the output must be that key's value */
    supermat__ctx X;
    float q[6 * 16], k[5 * 16], v[5 * 16], o[6 * 16], kp[16 * 16 * 4], vp[16 * 16 * 4];
    float *scratch;
    int i, j, avx2;
    for (avx2 = 0; avx2 <= supermat_cpu().avx2; avx2++) {
        memset(&X, 0, sizeof X);
        X.avx2 = avx2;
        supermat__select_kernels(&X);
        X.scratch_floats = 32768;
        scratch = (float *)malloc(sizeof(float) * X.scratch_floats);
        X.scratch = &scratch;
        for (i = 0; i < 5 * 16; i++) { k[i] = 0.0f; v[i] = (float)(i / 16) + 0.25f * (float)(i % 16); }
        for (i = 0; i < 5; i++) k[i * 16] = (float)(i - 2) * 50.0f; /* logits q.k = +-1e4 with q = +-100 */
        for (i = 0; i < 6; i++) for (j = 0; j < 16; j++) q[i * 16 + j] = j == 0 ? (i % 2 ? -100.0f : 100.0f) * (float)(1 + i / 2) : 0.0f;
        supermat__attn_pack(&X, k, 16, v, 16, 5, 1, 1, 16, kp, vp);
        supermat__attention(&X, q, 16, 6, 1, kp, vp, 5, 1, 1, 16, 1.0f, o, 16);
        for (i = 0; i < 6; i++) {
            int winner = (i % 2) ? 0 : 4, ok = 1; /* q > 0 picks the largest k, q < 0 the smallest */
            for (j = 0; j < 16; j++) if (!(fabsf(o[i * 16 + j] - v[winner * 16 + j]) <= 1e-6f)) ok = 0;
            TU_CHECK(ok, "%s softmax at logits +-1e4: query %d is not key %d's value (%g vs %g)", avx2 ? "avx2" : "scalar", i, winner, o[i * 16], v[winner * 16]);
        }
        free(scratch);
    }
}

static void test_cameras(const char *mv_path) {
    size_t size = 0;
    unsigned char *data = tu_load(mv_path, &size);
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_error err;
    static unsigned char rgba[2][16 * 16 * 4];
    static float out[2][16 * 16 * 3];
    supermat_image views[2], outs[2];
    float cams[2 * 16];
    finite_ctx f;
    int i, t;
    if (!data) { TU_CHECK(0, "cannot read %s", mv_path); return; }
    memset(&md, 0, sizeof md); md.data = data; md.size = size;
    if (supermat_model_create(&md, &m, &err)) { TU_CHECK(0, "MV model: %s", err.message); free(data); return; }
    memset(&sd, 0, sizeof sd); sd.model = m; sd.width = 16; sd.height = 16; sd.views = 2; sd.threads = 2;
    if (supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS) {
        memset(views, 0, sizeof views); memset(outs, 0, sizeof outs);
        for (i = 0; i < 2; i++) {
            int k;
            for (k = 0; k < 16 * 16 * 4; k++) rgba[i][k] = (unsigned char)(k * (i + 5));
            views[i].pixels = rgba[i]; views[i].width = 16; views[i].height = 16; views[i].channels = 4;
            outs[i].pixels = out[i]; outs[i].channels = 3; outs[i].format = SUPERMAT_FORMAT_F32;
        }
        for (t = 0; t < 3; t++) {
            const char *what = t == 0 ? "all-zero cameras" : t == 1 ? "identical cameras" : "huge translation (1e6)";
            for (i = 0; i < 32; i++) cams[i] = t == 0 ? 0.0f : (i % 5 == 0 ? 1.0f : 0.0f);
            if (t == 2) { cams[3] = 1e6f; cams[16 + 7] = -1e6f; }
            memset(&rd, 0, sizeof rd); memset(&f, 0, sizeof f);
            rd.input_views = views; rd.albedo_views = outs; rd.cameras = cams;
            rd.inspect = check_finite; rd.inspect_user = &f;
            TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "%s: %s", what, err.message);
            TU_CHECK(f.bad == 0, "%s: non-finite values at stage %d", what, (int)f.where);
            for (i = 0; i < 2 * 16 * 16 * 3; i++) if (!(out[i / 768][i % 768] >= 0.0f && out[i / 768][i % 768] <= 1.0f)) { TU_CHECK(0, "%s: output outside [0,1]", what); break; }
        }
        supermat_session_destroy(s);
    }
    supermat_model_destroy(m);
    free(data);
}

/* f16 weights with activations whose products and sums overflow f16 (|y| ~ 1e9): weights are widened to
   f32 before the multiply, so the GEMM matches a float64 reference on the dequantized weights */
static void test_f16_overflow(void) {
    enum { M = 13, K = 300, N = 37 };
    supermat__ctx X;
    supermat__pw W;
    supermat__asrc A;
    static float a[M * K], w[N * K], p[3 * K * 16], y[M * N], scale[2 * 3 * 16];
    static uint16_t q[3 * K * 16];
    float *scratch;
    size_t bad = 0;
    int i, j, k, avx2;
    for (i = 0; i < M * K; i++) a[i] = (float)((i * 7919) % 2001 - 1000) * 100.0f;  /* up to 1e5 */
    for (i = 0; i < N * K; i++) w[i] = (float)((i * 104729) % 2001 - 1000) * 60.0f;   /* up to 6e4, f16 range */
    memset(p, 0, sizeof p);
    for (j = 0; j < N; j++) for (k = 0; k < K; k++) p[((size_t)(j / 16) * K + k) * 16 + j % 16] = w[j * K + k];
    TU_CHECK(supermat__quantize_panels(p, sizeof p / sizeof p[0], K, N, K, 1, q, scale, &bad) == 0, "f16 panels");
    for (avx2 = 0; avx2 <= supermat_cpu().avx2; avx2++) {
        double worst = 0.0, ymax = 0.0;
        memset(&X, 0, sizeof X);
        X.avx2 = avx2;
        supermat__select_kernels(&X);
        X.scratch_floats = SUPERMAT__MC * SUPERMAT__KC + SUPERMAT__KC * SUPERMAT__NR;
        scratch = (float *)malloc(sizeof(float) * X.scratch_floats);
        X.scratch = &scratch;
        memset(&W, 0, sizeof W); W.q = q; W.K = K; W.N = N; W.fmt = 1;
        memset(&A, 0, sizeof A); A.a = a; A.lda = K;
        supermat__gemm(&X, &A, M, &W, y, N, NULL, NULL, 0);
        for (i = 0; i < M; i++)
            for (j = 0; j < N; j++) {
                double ref = 0.0;
                for (k = 0; k < K; k++) ref += (double)a[i * K + k] * supermat__f16_to_f32(q[((size_t)(j / 16) * K + k) * 16 + j % 16]);
                if (fabs(ref) > ymax) ymax = fabs(ref);
                if (!(y[i * N + j] - y[i * N + j] == 0.0f)) worst = HUGE_VAL;
                else if (fabs(y[i * N + j] - ref) > worst) worst = fabs(y[i * N + j] - ref);
            }
        printf("f16 weights, outputs up to %.3g (f16 max 65504): %s max error %.3g relative to the largest\n", ymax, avx2 ? "avx2" : "scalar", worst / ymax);
        TU_CHECK(ymax > 1e8 && worst <= 1e-5 * ymax, "f16 weights with overflowing activations (%s): error %g of %g", avx2 ? "avx2" : "scalar", worst, ymax);
        free(scratch);
    }
}

/* a 2048x2048 run of the tiny model (VAE in 512-pixel tiles): finite, in [0, 1], and the tiled VAE
   bounds the arena */
static void test_large_run(supermat_model *m) {
    enum { W = 2048 };
    unsigned char *px = (unsigned char *)malloc((size_t)W * W * 4);
    size_t i, whole = 0, tiled = 0;
    supermat_session_desc sd;
    supermat_error err;
    for (i = 0; i < (size_t)W * W; i++) {
        int x = (int)(i % W), y = (int)(i / W), dx = x - W / 2, dy = y - W / 2;
        px[i * 4] = (unsigned char)(x * 255 / W); px[i * 4 + 1] = (unsigned char)(y * 255 / W); px[i * 4 + 2] = (unsigned char)((x ^ y) & 255);
        px[i * 4 + 3] = (unsigned char)((long)dx * dx + (long)dy * dy < (long)(W / 3) * (W / 3) ? 255 : 0);
    }
    memset(&sd, 0, sizeof sd); sd.model = m; sd.width = W; sd.height = W; sd.threads = 2;
    supermat_session_memory(&sd, &whole, &err);
    sd.vae_tile = 512; sd.vae_overlap = 64;
    supermat_session_memory(&sd, &tiled, &err);
    printf("2048x2048 session: %.1f MiB whole, %.1f MiB with 512-pixel VAE tiles\n", whole / 1048576.0, tiled / 1048576.0);
    TU_CHECK(tiled < whole / 2, "2048 tiled plan %zu vs whole %zu", tiled, whole);
    large_tile = 512;
    run_image(m, W, W, px, 4, SUPERMAT_FORMAT_U8, "2048x2048, VAE tiles of 512");
    large_tile = 0;
    free(px);
}

int main(int argc, char **argv) {
    size_t size = 0;
    unsigned char *data;
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    if (argc < 3) { fprintf(stderr, "usage: %s MODEL MV_MODEL [--large]\n", argv[0]); return 2; }
    data = tu_load(argv[1], &size);
    if (!data) { printf("cannot read %s\n", argv[1]); return 1; }
    memset(&md, 0, sizeof md); md.data = data; md.size = size;
    TU_CHECK(supermat_model_create(&md, &m, &err) == SUPERMAT_SUCCESS, "model: %s", err.message);
    if (argc > 3 && !strcmp(argv[3], "--large")) { /* its own ctest: 2-5 minutes on 2 cores */
        if (m) test_large_run(m);
        supermat_model_destroy(m);
        free(data);
        return tu_finish("extremes 2048");
    }
    if (m) { test_images(m); test_large_plan(m); }
    supermat_model_destroy(m);
    /* the same images with f16 weights */
    md.weights = SUPERMAT_WEIGHTS_F16;
    m = NULL;
    TU_CHECK(supermat_model_create(&md, &m, &err) == SUPERMAT_SUCCESS, "f16 model: %s", err.message);
    if (m) { printf("f16 weights:\n"); test_images(m); }
    supermat_model_destroy(m);
    test_f16_overflow();
    test_softmax_extremes();
    test_cameras(argv[2]);
    free(data);
    return tu_finish("extremes");
}
