/* Winograd F(2x2,3x3) / F(4x4,3x3) convolutions against a float64 direct convolution: channel counts
   3..128, sizes 1x1 to 16x16 incl. partial tiles, 2 images, the fused 2x nearest upsample, bias and
   residual, scalar and AVX2 kernels, 1 and 3 threads (bit-identical); planning mode makes the same
   arena calls and counts the same FLOPs as the run. (Speed: `supermat bench --modes winograd_f2,...`.) */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"

static int fails;
#define CHECK(c, ...) do { if (!(c)) { fails++; printf("FAIL %d: ", __LINE__); printf(__VA_ARGS__); printf("\n"); } } while (0)

static unsigned long long rs = 88172645463325252ull;
static double rnd(void) { rs ^= rs << 13; rs ^= rs >> 7; rs ^= rs << 17; return (double)(rs >> 11) / 9007199254740992.0 * 2.0 - 1.0; }
static float *rvec(size_t n, double s) { float *p = (float *)malloc(n * sizeof(float) + 4); size_t i; for (i = 0; i < n; i++) p[i] = (float)(rnd() * s); return p; }

typedef struct kctx { supermat__ctx X; supermat_pool *pool; float *mem; } kctx;
static void kctx_init(kctx *k, int avx2, int threads, size_t arena) {
    int i, nt;
    memset(k, 0, sizeof *k);
    if (threads > 1) supermat_pool_create(threads, NULL, &k->pool, &k->X.thr);
    nt = k->X.thr.parallel_for ? k->X.thr.max_threads : 1;
    k->X.avx2 = avx2;
    supermat__select_kernels(&k->X);
    k->X.scratch_floats = 64 * 1024;
    k->mem = (float *)malloc(sizeof(float) * k->X.scratch_floats * nt);
    k->X.scratch = (float **)malloc(sizeof(float *) * nt);
    for (i = 0; i < nt; i++) k->X.scratch[i] = k->mem + (size_t)i * k->X.scratch_floats;
    k->X.cap = arena;
    k->X.base = (char *)malloc(arena);
}
static void kctx_free(kctx *k) {
    if (k->pool) supermat_pool_destroy(k->pool);
    CHECK(k->X.nblk == 0, "%d arena blocks left", k->X.nblk);
    free(k->mem); free(k->X.scratch); free(k->X.base);
}
static void pack_w(supermat__pw *pw, const float *w, const float *b, int N, int cin, int k) {
    int K = cin * k * k, np = (N + 15) / 16, n, ci, ky, kx;
    memset(pw, 0, sizeof *pw);
    pw->K = K; pw->N = N;
    pw->p = (float *)calloc((size_t)np * 16 * K, sizeof(float));
    pw->bias = b ? (float *)calloc((size_t)np * 16, sizeof(float)) : NULL;
    for (n = 0; n < N; n++) {
        if (b) pw->bias[n] = b[n];
        for (ci = 0; ci < cin; ci++)
            for (ky = 0; ky < k; ky++)
                for (kx = 0; kx < k; kx++)
                    pw->p[(size_t)(n / 16) * K * 16 + ((size_t)(ky * k + kx) * cin + ci) * 16 + n % 16] = w[(((size_t)n * cin + ci) * k + ky) * k + kx];
    }
}
/* the Winograd weights from the direct packed ones, as the loader would make them */
static void make_wino(supermat__wino *wg, const supermat__pw *pw, int cin, int cout, int m) {
    int xi, a = m + 2, np = (cout + 15) / 16;
    float *dst[36];
    memset(wg, 0, sizeof *wg);
    wg->m = m; wg->a = a;
    for (xi = 0; xi < a * a; xi++) {
        supermat__pw *u = &wg->u[xi];
        u->K = cin; u->N = cout;
        u->p = dst[xi] = (float *)malloc(sizeof(float) * (size_t)np * 16 * cin);
    }
    CHECK(supermat__wino_transform(pw->p, cin, cout, m, dst) == 0, "transform");
}
static void free_wino(supermat__wino *wg) { int xi; for (xi = 0; xi < wg->a * wg->a; xi++) free(wg->u[xi].p); }

static void conv_ref(const float *x, int n, int h, int w, int cin, int uh, int uw, const float *wt, const float *b, int cout,
                     const float *R, double *out) {
    int i, oy, ox, co, ci, ky, kx;
    for (i = 0; i < n; i++)
        for (oy = 0; oy < uh; oy++)
            for (ox = 0; ox < uw; ox++)
                for (co = 0; co < cout; co++) {
                    size_t o = (((size_t)i * uh + oy) * uw + ox) * cout + co;
                    double s = b ? b[co] : 0.0;
                    for (ky = 0; ky < 3; ky++)
                        for (kx = 0; kx < 3; kx++) {
                            int vy = oy - 1 + ky, vx = ox - 1 + kx, sy, sx;
                            if (vy < 0 || vy >= uh || vx < 0 || vx >= uw) continue;
                            sy = supermat__nearest(vy, h, uh); sx = supermat__nearest(vx, w, uw);
                            for (ci = 0; ci < cin; ci++)
                                s += (double)x[(((size_t)i * h + sy) * w + sx) * cin + ci] * wt[(((size_t)co * cin + ci) * 3 + ky) * 3 + kx];
                        }
                    out[o] = s + (R ? R[o] : 0.0);
                }
}
static double maxerr(const float *a, const double *ref, size_t n) {
    double m = 0, r = 1e-30;
    size_t i;
    for (i = 0; i < n; i++) { double d = fabs(a[i] - ref[i]); if (!(d <= m)) m = d; if (fabs(ref[i]) > r) r = fabs(ref[i]); }
    return m / r;
}

static kctx K[2][2]; /* [avx2][threads 1, 3] */
static double worst[2];

static void test_case(int n, int h, int w, int cin, int cout, int up, int use_b, int use_r) {
    int uh = up ? 2 * h : h, uw = up ? 2 * w : w, mi, av, th;
    size_t no = (size_t)n * uh * uw * cout;
    float *x = rvec((size_t)n * h * w * cin, 1.0), *wt = rvec((size_t)cout * cin * 9, 0.3), *b = rvec((size_t)cout, 1.0);
    float *R = use_r ? rvec(no, 1.0) : NULL, *res[2];
    double *ref = (double *)malloc(sizeof(double) * no), e[2] = {0, 0};
    supermat__pw pw;
    supermat__t in, out;
    pack_w(&pw, wt, use_b ? b : NULL, cout, cin, 3);
    conv_ref(x, n, h, w, cin, uh, uw, wt, use_b ? b : NULL, cout, R, ref);
    in.d = x; in.n = n; in.h = h; in.w = w; in.c = cin;
    out.n = n; out.h = uh; out.w = uw; out.c = cout;
    res[0] = (float *)malloc(no * sizeof(float)); res[1] = (float *)malloc(no * sizeof(float));
    for (mi = 0; mi < 2; mi++) {
        supermat__wino wg;
        make_wino(&wg, &pw, cin, cout, mi ? 4 : 2);
        for (av = 0; av < 2; av++) {
            if (av && !supermat_cpu_has_avx2()) continue;
            for (th = 0; th < 2; th++) {
                supermat__ctx *X = &K[av][th].X;
                float *o = res[th];
                double err;
                if (R) memcpy(o, R, no * sizeof(float)); else memset(o, 0xff, no * sizeof(float)); /* NaN: unwritten shows */
                out.d = o;
                X->status = SUPERMAT_SUCCESS;
                /* in-place residual (R == out), as the resnets do */
                supermat__conv3x3_wino(X, &in, uh, uw, &wg, &out, use_b ? pw.bias : NULL, R ? o : NULL);
                err = maxerr(o, ref, no);
                CHECK(X->status == SUPERMAT_SUCCESS && err < (mi ? 5e-4 : 2e-5), "F%d %s t%d n%d %dx%d->%dx%d %d->%d: err %.3g",
                      mi ? 4 : 2, av ? "avx2" : "scalar", th ? 3 : 1, n, h, w, uh, uw, cin, cout, err);
                if (err > e[mi]) e[mi] = err;
            }
            CHECK(!memcmp(res[0], res[1], no * sizeof(float)), "F%d %s: 1 and 3 threads differ", mi ? 4 : 2, av ? "avx2" : "scalar");
        }
        free_wino(&wg);
    }
    printf("  n%d %2dx%-2d%s cin %2d cout %2d bias %d R %d: F2 %.2e  F4 %.2e\n", n, h, w, up ? " up2" : "    ", cin, cout, use_b, use_r, e[0], e[1]);
    if (e[0] > worst[0]) worst[0] = e[0];
    if (e[1] > worst[1]) worst[1] = e[1];
    free(x); free(wt); free(b); free(R); free(ref); free(res[0]); free(res[1]); free(pw.p); free(pw.bias);
}

/* f16 / bf16 / int8 storage. "Q(U)": the transformed weights quantized (as a loader would do it);
   "U(Q)": the direct weights quantized and dequantized, then transformed, U kept f32. Errors against
   the f32 float64 reference, next to the direct convolution with the same storage. */

/* planning walks the same get/put and gemm calls: same flops, same peak */
static void test_plan(int m, int n, int h, int w, int cin, int cout) {
    kctx k;
    supermat__pw pw;
    supermat__wino wg;
    supermat__t in, out;
    float *x = rvec((size_t)n * h * w * cin, 1.0), *wt = rvec((size_t)cout * cin * 9, 0.3);
    double fl_plan;
    size_t peak_plan;
    pack_w(&pw, wt, NULL, cout, cin, 3);
    make_wino(&wg, &pw, cin, cout, m);
    kctx_init(&k, 0, 1, 64);
    in.d = x; in.n = n; in.h = h; in.w = w; in.c = cin;
    out.n = n; out.h = h; out.w = w; out.c = cout; out.d = NULL;
    k.X.plan = 1;
    free(k.X.base); k.X.base = NULL; k.X.cap = 0;
    supermat__conv3x3_wino(&k.X, &in, h, w, &wg, &out, NULL, NULL);
    fl_plan = k.X.flops; peak_plan = k.X.peak;
    k.X.plan = 0; k.X.flops = 0; k.X.peak = 0; k.X.cap = peak_plan; k.X.base = (char *)malloc(peak_plan);
    out.d = (float *)malloc(sizeof(float) * (size_t)n * h * w * cout);
    supermat__conv3x3_wino(&k.X, &in, h, w, &wg, &out, NULL, NULL);
    {
        int tiles = n * ((h + m - 1) / m) * ((w + m - 1) / m);
        double want = 2.0 * (m + 2) * (m + 2) * (double)tiles * cin * cout;
        CHECK(k.X.status == SUPERMAT_SUCCESS && fl_plan == k.X.flops && fl_plan == want && peak_plan == k.X.peak && peak_plan > 0,
              "plan F%d: flops %.0f / %.0f (want %.0f), peak %zu / %zu", m, fl_plan, k.X.flops, want, peak_plan, k.X.peak);
        printf("  plan F%d n%d %dx%d %d->%d: flops %.4g (direct %.4g), peak %zu bytes (live %zu)\n", m, n, h, w, cin, cout, fl_plan,
               2.0 * n * h * w * 9.0 * cin * cout, peak_plan, k.X.peak);
    }
    kctx_free(&k);
    free(x); free(wt); free(pw.p); free(out.d); free_wino(&wg);
}


int main(void) {
    static const int chans[4] = {3, 16, 37, 64};
    static const int sizes[4][2] = {{8, 8}, {7, 9}, {1, 1}, {2, 3}};
    int i, j, s, av, th;
    for (av = 0; av < 2; av++) for (th = 0; th < 2; th++) kctx_init(&K[av][th], av, th ? 3 : 1, (size_t)80 << 20);
    printf("accuracy (max |err| / max |ref|):\n");
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++)
            for (s = 0; s < 4; s++) {
                int variant = (i * 4 + j + s) % 4;
                test_case(variant == 1 ? 2 : 1, sizes[s][0], sizes[s][1], chans[i], chans[j], variant == 2, variant != 3, variant != 0);
            }
    /* explicit: n = 2 with the fused upsample, bias and residual; a wider case */
    test_case(2, 7, 9, 37, 64, 1, 1, 1);
    test_case(2, 5, 3, 64, 37, 1, 1, 1);
    test_case(1, 16, 16, 64, 64, 0, 1, 1);
    test_case(2, 13, 11, 128, 40, 0, 1, 1);
    printf("worst: F2 %.3g, F4 %.3g\n", worst[0], worst[1]);
    for (av = 0; av < 2; av++) for (th = 0; th < 2; th++) kctx_free(&K[av][th]);
    test_plan(2, 2, 9, 7, 16, 37);
    test_plan(4, 2, 9, 7, 16, 37);
    test_plan(4, 1, 128, 128, 128, 128); /* several chunks */
    test_plan(2, 1, 256, 256, 128, 128);
    printf("%s (%d failures)\n", fails ? "FAILED" : "OK", fails);
    return fails != 0;
}
