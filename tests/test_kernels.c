/* Every kernel against a float64 reference (_ref, written here) on random shapes including odd sizes,
   with the scalar, AVX2 and AVX-512 paths (those the CPU has; the others are skipped, and said so), and 1
   and 3 threads; the AVX-512 kernel must also give the AVX2 kernel's bits. Errors are normalised:
   max |fast - ref| / (max |ref| + tiny), bounds stated per kernel. Winograd convolutions included. */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include "test_util.h"

static unsigned long long rng_state = 88172645463325252ull;
static double rnd(void) { /* xorshift, uniform in [-1, 1) */
    rng_state ^= rng_state << 13; rng_state ^= rng_state >> 7; rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0 * 2.0 - 1.0;
}
static int irand(int lo, int hi) { return lo + (int)((rnd() * 0.5 + 0.5) * (hi - lo + 1)) % (hi - lo + 1); }
static float *rvec(size_t n, double scale) { float *p = (float *)malloc(n * sizeof(float) + 4); size_t i; for (i = 0; i < n; i++) p[i] = (float)(rnd() * scale); return p; }

typedef struct kctx { supermat__ctx X; supermat_pool *pool; float *mem; } kctx;
/* kernel modes: 0 scalar, 1 AVX2, 2 AVX-512 (over AVX2), 3 NEON (over scalar) */
#define NMODES 4
static const char *KN(int mode) { return mode == 3 ? "neon" : mode == 2 ? "avx512" : mode ? "avx2" : "scalar"; }
static int mode_ok(int mode) {
    return mode == 0 || (mode == 1 ? supermat_cpu().avx2 : mode == 2 ? supermat_cpu().avx512 : supermat_cpu().neon);
}
static void kctx_init(kctx *k, int avx2, int threads) {
    int i, nt;
    memset(k, 0, sizeof *k);
    if (threads > 1) supermat_pool_create(threads, NULL, &k->pool, &k->X.thr);
    nt = k->X.thr.parallel_for ? k->X.thr.max_threads : 1;
    k->X.avx2 = avx2 == 1 || avx2 == 2;
    k->X.avx512 = avx2 == 2;
    k->X.neon = avx2 == 3;
    supermat__select_kernels(&k->X);
    k->X.scratch_floats = 64 * 1024;
    k->mem = (float *)malloc(sizeof(float) * k->X.scratch_floats * nt);
    k->X.scratch = (float **)malloc(sizeof(float *) * nt);
    for (i = 0; i < nt; i++) k->X.scratch[i] = k->mem + (size_t)i * k->X.scratch_floats;
    k->X.gn_cap = 4096;
    k->X.gn_stats = (double *)malloc(sizeof(double) * 2 * k->X.gn_cap);
    k->X.cap = (size_t)32 << 20; /* an arena for the temporaries the kernels take */
    k->X.base = (char *)malloc(k->X.cap);
}
static void kctx_free(kctx *k) {
    if (k->pool) supermat_pool_destroy(k->pool);
    TU_CHECK(k->X.nblk == 0, "%d arena blocks left", k->X.nblk);
    free(k->mem); free(k->X.scratch); free(k->X.gn_stats); free(k->X.base);
}
/* pack W [N][Cin][k][k] into panels the way the loader does */
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
static double maxerr(const float *a, const double *ref, size_t n) {
    double m = 0, r = 1e-30;
    size_t i;
    for (i = 0; i < n; i++) { double d = fabs(a[i] - ref[i]); if (!(d <= m)) m = d; if (fabs(ref[i]) > r) r = fabs(ref[i]); } /* NaN wins */
    return m / r;
}
/* the f32 GEMMs' bound against float64 (relative to the largest |result|): 2e-6 up to K = 600, then growing
   like sqrt(K), as the rounding error of an f32 sum of K random-sign products does */
static double gemm_tol(int K) { return K <= 600 ? 2e-6 : 2e-6 * sqrt(K / 600.0); }
static int nan_free(const float *a, size_t n) { size_t i; for (i = 0; i < n; i++) if (a[i] != a[i]) return 0; return 1; }

/* conv2d_ref: NHWC input virtually resized (nearest, PyTorch rule) to uh x uw, padding, stride; in float64 */
static void conv2d_ref(const float *x, int n, int h, int w, int cin, int uh, int uw, const float *wt, const float *b, int cout, int k,
                       int stride, int pt, int pl, int pb, int pr, const float *R, double *out, int *oh_, int *ow_) {
    int oh = (uh + pt + pb - k) / stride + 1, ow = (uw + pl + pr - k) / stride + 1, i, oy, ox, co, ci, ky, kx;
    for (i = 0; i < n; i++)
        for (oy = 0; oy < oh; oy++)
            for (ox = 0; ox < ow; ox++)
                for (co = 0; co < cout; co++) {
                    size_t o = (((size_t)i * oh + oy) * ow + ox) * cout + co;
                    double s = b ? b[co] : 0.0;
                    for (ky = 0; ky < k; ky++)
                        for (kx = 0; kx < k; kx++) {
                            int vy = oy * stride - pt + ky, vx = ox * stride - pl + kx, sy, sx;
                            if (vy < 0 || vy >= uh || vx < 0 || vx >= uw) continue;
                            sy = supermat__nearest(vy, h, uh); sx = supermat__nearest(vx, w, uw);
                            for (ci = 0; ci < cin; ci++)
                                s += (double)x[(((size_t)i * h + sy) * w + sx) * cin + ci] * wt[(((size_t)co * cin + ci) * k + ky) * k + kx];
                        }
                    if (R) s += R[o];
                    out[o] = s;
                }
    *oh_ = oh; *ow_ = ow;
}

static void test_gemm_conv(int avx2, int threads) {
    kctx k;
    int it;
    kctx_init(&k, avx2, threads);
    for (it = 0; it < 40; it++) {
        int n = irand(1, 2), h = irand(1, 13), w = irand(1, 13), cin = irand(1, 70), cout = irand(1, 40);
        int kk = (it % 3 == 0) ? 1 : 3, stride = (kk == 3 && it % 4 == 1) ? 2 : 1, pad_mode = (stride == 2 && it % 8 == 1) ? 1 : 0;
        int uh = h, uw = w, oh, ow, use_r = it % 2, use_b = it % 5 != 0;
        float *x, *wt, *b, *R = NULL;
        double *ref;
        supermat__conv cv;
        supermat__t in, out;
        size_t no;
        if (it % 5 == 3) cin = irand(64, 100);                  /* direct: rows read in place, K blocks within a tap */
        if (it % 6 == 2) { uh = 2 * h; uw = 2 * w; }           /* fused nearest x2 */
        if (it % 6 == 4) { uh = h + irand(1, 5); uw = w + irand(0, 7); } /* size forwarded from a skip */
        if (pad_mode == 1 && (uh < 2 || uw < 2)) pad_mode = 0;
        x = rvec((size_t)n * h * w * cin, 1.0); wt = rvec((size_t)cout * cin * kk * kk, 0.3); b = rvec((size_t)cout, 1.0);
        ref = (double *)malloc(sizeof(double) * (size_t)n * (uh + 2) * (uw + 2) * cout);
        memset(&cv, 0, sizeof cv);
        cv.k = kk; cv.stride = stride; cv.cin = cin; cv.cout = cout;
        pack_w(&cv.w, wt, use_b ? b : NULL, cout, cin, kk);
        {
            int pt = pad_mode ? 0 : kk / 2, pb = pad_mode ? 1 : kk / 2;
            oh = (uh + pt + pb - kk) / stride + 1; ow = (uw + pt + pb - kk) / stride + 1;
            no = (size_t)n * oh * ow * cout;
            if (use_r) R = rvec(no, 1.0);
            conv2d_ref(x, n, h, w, cin, uh, uw, wt, use_b ? b : NULL, cout, kk, stride, pt, pt, pb, pb, R, ref, &oh, &ow);
        }
        in.d = x; in.n = n; in.h = h; in.w = w; in.c = cin;
        out.n = n; out.h = oh; out.w = ow; out.c = cout; out.d = (float *)malloc(no * sizeof(float));
        if (R) memcpy(out.d, R, no * sizeof(float));
        k.X.status = SUPERMAT_SUCCESS;
        /* residual in place (R == out), as the resnets do */
        supermat__conv2d(&k.X, &in, uh, uw, &cv, pad_mode, &out, NULL, R ? out.d : NULL);
        TU_CHECK(k.X.status == SUPERMAT_SUCCESS && nan_free(out.d, no) && maxerr(out.d, ref, no) < 2e-6,
                 "conv %s t%d: n%d %dx%d->%dx%d cin %d cout %d k%d s%d pad%d: err %.3g", KN(avx2), threads, n, h, w, uh, uw, cin, cout, kk, stride, pad_mode, maxerr(out.d, ref, no));
        free(x); free(wt); free(b); free(R); free(ref); free(out.d); free(cv.w.p); free(cv.w.bias);
    }
    /* dense GEMM with K across several KC blocks */
    for (it = 0; it < 12; it++) {
        int M = irand(1, 150), N = irand(1, 70), K = irand(1, 700), i, j, kq;
        float *a = rvec((size_t)M * K, 1.0), *wt = rvec((size_t)N * K, 0.1), *c = (float *)malloc(sizeof(float) * M * N);
        double *ref = (double *)malloc(sizeof(double) * M * N);
        supermat__pw pw;
        pack_w(&pw, wt, NULL, N, K, 1);
        for (i = 0; i < M; i++) for (j = 0; j < N; j++) { double s = 0; for (kq = 0; kq < K; kq++) s += (double)a[(size_t)i * K + kq] * wt[(size_t)j * K + kq]; ref[(size_t)i * N + j] = s; }
        k.X.status = SUPERMAT_SUCCESS;
        supermat__linear(&k.X, a, (size_t)K, M, &pw, c, (size_t)N, NULL, 0);
        TU_CHECK(maxerr(c, ref, (size_t)M * N) < gemm_tol(K), "gemm %s M%d N%d K%d err %.3g", KN(avx2), M, N, K, maxerr(c, ref, (size_t)M * N));
        free(a); free(wt); free(c); free(ref); free(pw.p);
    }
    kctx_free(&k);
}

/* attention_ref: per group g, head h: softmax(q k^T * scale) v, float64 */
/* f16 / bf16 / int8 weight panels: the kernels against a float64 GEMM on the dequantized weights
   (the kernel's own error), and the quantisation error itself against the f32 weights */
static void test_quantized(int avx2, int threads) {
    kctx k;
    int it, fmt;
    kctx_init(&k, avx2, threads);
    supermat__select_kernels(&k.X);
    for (fmt = 1; fmt <= 3; fmt++)
        for (it = 0; it < 8; it++) {
            /* K = taps x cin as in a conv: int8 groups are 64 input channels of one tap */
            int M = irand(1, 100), N = irand(1, 50), taps = irand(1, 9), cin = irand(1, 200), K = taps * cin, i, j, kq, np = (N + 15) / 16;
            int ng = (cin + 63) / 64, nq = taps * ng;
            float *a = rvec((size_t)M * K, 1.0), *wt = rvec((size_t)N * K, 0.1), *c = (float *)malloc(sizeof(float) * M * N), *cf = (float *)malloc(sizeof(float) * M * N);
            double *ref = (double *)malloc(sizeof(double) * M * N), qerr = 0, qmax = 0;
            size_t total = (size_t)np * 16 * K, bad;
            supermat__pw pw, pq;
            pack_w(&pw, wt, NULL, N, K, 1);
            pq = pw;
            pq.q = malloc(total * 2); pq.qs = (float *)malloc(sizeof(float) * nq * np * 16); pq.fmt = fmt; pq.p = NULL; pq.qcin = cin;
            TU_CHECK(supermat__qgroups(K, cin) == nq, "int8 groups %d, expected %d", supermat__qgroups(K, cin), nq);
            TU_CHECK(supermat__quantize_panels(pw.p, total, K, N, cin, fmt, pq.q, pq.qs, &bad) == 0, "quantize fmt %d", fmt);
            for (i = 0; i < M; i++)
                for (j = 0; j < N; j++) {
                    double s = 0;
                    for (kq = 0; kq < K; kq++) {
                        size_t o = ((size_t)(j / 16) * K + kq) * 16 + j % 16;
                        double w = fmt == 1 ? supermat__f16_to_f32(((uint16_t *)pq.q)[o]) : fmt == 2 ? supermat__bf16_to_f32(((uint16_t *)pq.q)[o])
                                 : (double)((signed char *)pq.q)[o] * pq.qs[(size_t)((kq / cin) * ng + (kq % cin) / 64) * np * 16 + j];
                        s += (double)a[(size_t)i * K + kq] * w;
                    }
                    ref[(size_t)i * N + j] = s;
                }
            if (fmt == 3) { /* the format's definition: |w - q s| <= s / 2 (+ float rounding) and s = max |w| / 127 per column, tap, 64 channels */
                double worst = 0;
                int g, bad_s = 0;
                for (j = 0; j < N; j++)
                    for (g = 0; g < nq; g++) {
                        int tap = g / ng, c0 = (g % ng) * 64, c1 = c0 + 64 < cin ? c0 + 64 : cin;
                        float sc = pq.qs[(size_t)g * np * 16 + j], mx = 0;
                        for (kq = tap * cin + c0; kq < tap * cin + c1; kq++) {
                            size_t o = ((size_t)(j / 16) * K + kq) * 16 + j % 16;
                            double e = fabs((double)wt[(size_t)j * K + kq] - (double)((signed char *)pq.q)[o] * sc) / (0.5 * sc);
                            if (e > worst) worst = e;
                            if (fabsf(wt[(size_t)j * K + kq]) > mx) mx = fabsf(wt[(size_t)j * K + kq]);
                        }
                        if (sc != mx / 127.0f) bad_s++;
                    }
                TU_CHECK(worst <= 1.0 + 1e-4 && bad_s == 0, "int8 rounding: worst |w - q s| = %.6f s/2, %d wrong scales", worst, bad_s);
            }
            k.X.status = SUPERMAT_SUCCESS;
            supermat__linear(&k.X, a, (size_t)K, M, &pq, c, (size_t)N, NULL, 0);
            TU_CHECK(k.X.status == SUPERMAT_SUCCESS && maxerr(c, ref, (size_t)M * N) < gemm_tol(K), "gemm fmt %d %s M%d N%d K%d err %.3g", fmt, KN(avx2), M, N, K, maxerr(c, ref, (size_t)M * N));
            supermat__linear(&k.X, a, (size_t)K, M, &pw, cf, (size_t)N, NULL, 0);
            for (i = 0; i < M * N; i++) { qerr += (double)(c[i] - cf[i]) * (c[i] - cf[i]); qmax += (double)cf[i] * cf[i]; }
            qerr = sqrt(qerr / (qmax + 1e-30));
            /* relative L2 of the product: f16 ~ 2^-11, bf16 ~ 2^-8, int8 ~ 1/127/sqrt(3) */
            TU_CHECK(qerr < (fmt == 1 ? 1e-3 : fmt == 2 ? 5e-3 : 1.5e-2), "fmt %d quantisation error %.3g", fmt, qerr);
            free(a); free(wt); free(c); free(cf); free(ref); free(pw.p); free(pq.q); free(pq.qs);
        }
    kctx_free(&k);
}

static void test_attention(int avx2, int threads) {
    kctx k;
    int it;
    kctx_init(&k, avx2, threads);
    for (it = 0; it < 24; it++) {
        int heads = irand(1, 3), d = (it % 4 == 0) ? irand(1, 40) : 16 * irand(1, 4), C = heads * d, qg = irand(1, 3);
        int mq = irand(1, 130), shared = it % 3 == 0, kvg = shared ? 1 : qg, mk = shared ? qg * mq : irand(1, 150);
        float scale = (float)(1.0 / sqrt((double)d)) * (it % 5 == 0 ? 40.0f : 1.0f); /* large logits too */
        float *q = rvec((size_t)qg * mq * C, 1.0), *kk = rvec((size_t)kvg * mk * C, 1.0), *v = rvec((size_t)kvg * mk * C, 1.0);
        float *kp = (float *)malloc(sizeof(float) * kvg * heads * supermat__attn_kp_floats(mk, d));
        float *vp = (float *)malloc(sizeof(float) * kvg * heads * supermat__attn_vp_floats(mk, d));
        float *o = (float *)malloc(sizeof(float) * qg * mq * C);
        double *ref = (double *)malloc(sizeof(double) * qg * mq * C), *s = (double *)malloc(sizeof(double) * mk);
        int g, h, i, j, c;
        if (shared) { free(kk); free(v); kk = (float *)malloc(sizeof(float) * mk * C); v = (float *)malloc(sizeof(float) * mk * C); memcpy(kk, q, sizeof(float) * mk * C); for (i = 0; i < mk * C; i++) v[i] = (float)rnd(); }
        for (g = 0; g < qg; g++)
            for (h = 0; h < heads; h++)
                for (i = 0; i < mq; i++) {
                    const float *qi = q + ((size_t)g * mq + i) * C + h * d;
                    const float *kb = kk + (size_t)(shared ? 0 : g) * mk * C + h * d, *vb = v + (size_t)(shared ? 0 : g) * mk * C + h * d;
                    double mx = -1e300, sum = 0;
                    for (j = 0; j < mk; j++) { double t = 0; for (c = 0; c < d; c++) t += (double)qi[c] * kb[(size_t)j * C + c]; s[j] = t * scale; if (s[j] > mx) mx = s[j]; }
                    for (j = 0; j < mk; j++) { s[j] = exp(s[j] - mx); sum += s[j]; }
                    for (c = 0; c < d; c++) { double t = 0; for (j = 0; j < mk; j++) t += s[j] * vb[(size_t)j * C + c]; ref[((size_t)g * mq + i) * C + h * d + c] = t / sum; }
                }
        k.X.status = SUPERMAT_SUCCESS;
        supermat__attn_pack(&k.X, kk, (size_t)C, v, (size_t)C, mk, kvg, heads, d, kp, vp);
        supermat__attention(&k.X, q, (size_t)C, mq, qg, kp, vp, mk, kvg, heads, d, scale, o, (size_t)C);
        /* float32 logits carry ~1e-7 relative error, which exp turns into 1e-7 x |logit| in the weights */
        TU_CHECK(nan_free(o, (size_t)qg * mq * C) && maxerr(o, ref, (size_t)qg * mq * C) < (it % 5 == 0 ? 3e-5 : 3e-6), "attention %s heads %d d %d qg %d mq %d mk %d shared %d scale %g: err %.3g",
                 KN(avx2), heads, d, qg, mq, mk, shared, scale, maxerr(o, ref, (size_t)qg * mq * C));
        free(q); free(kk); free(v); free(kp); free(vp); free(o); free(ref); free(s);
    }
    kctx_free(&k);
}

static void test_norms(int avx2, int threads) {
    kctx k;
    int it;
    kctx_init(&k, avx2, threads);
    for (it = 0; it < 16; it++) {
        int n = irand(1, 3), h = irand(1, 20), w = irand(1, 20), groups = irand(1, 8), C = groups * irand(1, 9), silu = it % 2, i, g, c;
        int constant = it % 7 == 3; /* zero variance */
        size_t hw = (size_t)h * w, p, total = (size_t)n * hw * C;
        float *x = rvec(total, 3.0), *gm = rvec((size_t)C, 1.0), *bt = rvec((size_t)C, 1.0), *y = (float *)malloc(sizeof(float) * total);
        double *ref = (double *)malloc(sizeof(double) * total);
        supermat__norm nm;
        supermat__t in, out;
        if (constant) for (p = 0; p < total; p++) x[p] = 0.75f;
        for (i = 0; i < n; i++)
            for (g = 0; g < groups; g++) {
                int cg = C / groups;
                double s = 0, ss = 0, mean, rstd;
                for (p = 0; p < hw; p++) for (c = g * cg; c < (g + 1) * cg; c++) s += x[((size_t)i * hw + p) * C + c];
                mean = s / (hw * cg);
                for (p = 0; p < hw; p++) for (c = g * cg; c < (g + 1) * cg; c++) { double dd = x[((size_t)i * hw + p) * C + c] - mean; ss += dd * dd; }
                rstd = 1.0 / sqrt(ss / (hw * cg) + 1e-5);
                for (p = 0; p < hw; p++) for (c = g * cg; c < (g + 1) * cg; c++) {
                    size_t o = ((size_t)i * hw + p) * C + c;
                    double v = (x[o] - mean) * rstd * gm[c] + bt[c];
                    ref[o] = silu ? v / (1.0 + exp(-v)) : v;
                }
            }
        nm.g = gm; nm.b = bt; nm.c = C; nm.eps = 1e-5f;
        in.d = x; in.n = n; in.h = h; in.w = w; in.c = C; out = in; out.d = y;
        k.X.status = SUPERMAT_SUCCESS;
        supermat__groupnorm(&k.X, &in, &out, &nm, groups, silu);
        TU_CHECK(nan_free(y, total) && maxerr(y, ref, total) < 2e-6, "groupnorm %s silu %d const %d: err %.3g", KN(avx2), silu, constant, maxerr(y, ref, total));
        /* layer norm over rows of C */
        {
            int M = n * h * w;
            for (i = 0; i < M; i++) {
                double s = 0, ss = 0, mean, rstd;
                for (c = 0; c < C; c++) s += x[(size_t)i * C + c];
                mean = s / C;
                for (c = 0; c < C; c++) { double dd = x[(size_t)i * C + c] - mean; ss += dd * dd; }
                rstd = 1.0 / sqrt(ss / C + 1e-5);
                for (c = 0; c < C; c++) ref[(size_t)i * C + c] = (x[(size_t)i * C + c] - mean) * rstd * gm[c] + bt[c];
            }
            supermat__layernorm(&k.X, x, y, M, &nm);
            TU_CHECK(nan_free(y, total) && maxerr(y, ref, total) < 2e-6, "layernorm %s const %d: err %.3g", KN(avx2), constant, maxerr(y, ref, total));
        }
        free(x); free(gm); free(bt); free(y); free(ref);
    }
    { /* GEGLU and SiLU over a wide range, including values that overflow exp */
        int M = 37, H = 29, i, j;
        float *hh = rvec((size_t)M * 2 * H, 12.0), *y = (float *)malloc(sizeof(float) * M * H);
        double *ref = (double *)malloc(sizeof(double) * M * H);
        hh[0] = 120.0f; hh[H] = -120.0f; hh[1] = -95.0f; hh[H + 1] = 95.0f;
        for (i = 0; i < M; i++) for (j = 0; j < H; j++) { double g = hh[(size_t)i * 2 * H + H + j]; ref[(size_t)i * H + j] = hh[(size_t)i * 2 * H + j] * 0.5 * g * (1.0 + erf(g / sqrt(2.0))); }
        k.X.status = SUPERMAT_SUCCESS;
        supermat__geglu(&k.X, hh, y, M, H);
        TU_CHECK(maxerr(y, ref, (size_t)M * H) < 1e-6, "geglu err %.3g", maxerr(y, ref, (size_t)M * H));
        for (i = 0; i < M * H; i++) { double v = hh[i]; ref[i] = v / (1.0 + exp(-v)); }
        supermat__silu(&k.X, y, hh, M * H);
        TU_CHECK(nan_free(y, (size_t)M * H) && maxerr(y, ref, (size_t)M * H) < 1e-6, "silu %s err %.3g", KN(avx2), maxerr(y, ref, (size_t)M * H));
        free(hh); free(y); free(ref);
    }
    kctx_free(&k);
}

#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static void exp_row_avx2(float *x, int n) {
    int i;
    for (i = 0; i + 8 <= n; i += 8) _mm256_storeu_ps(x + i, supermat__exp_avx2(_mm256_loadu_ps(x + i)));
}
#endif
/* >>winograd: F(2x2,3x3) / F(4x4,3x3) against the float64 direct convolution: channels 3..128, sizes
   1x1 to 16x16 incl. partial tiles, 2 images, the fused 2x upsample, bias and residual (in place, as
   the resnets pass it), 1 and 3 threads bit-identical; planning makes the same arena calls and FLOPs. */
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
    TU_CHECK(supermat__wino_transform(pw->p, cin, cout, m, dst) == 0, "transform");
}
static void free_wino(supermat__wino *wg) { int xi; for (xi = 0; xi < wg->a * wg->a; xi++) free(wg->u[xi].p); }

/* 1 where this build fuses a * b + c into an FMA in code compiled for AVX2 + FMA (gcc's C++ default), which
   changes the last bits of the auto-vectorised AVX2 Winograd transforms, not of the AVX-512 intrinsics */
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static float contract_probe(volatile float *v) { float a = v[0], b = v[1]; return a * a + b; }
static int fp_contracts(void) {
    volatile float v[2];
    v[0] = 1.0f + 1.0f / 4096; v[1] = -(1.0f + 2.0f / 4096); /* a * a = 1 + 2^-11 + 2^-24: 0 unless fused */
    return supermat_cpu().avx2 && contract_probe(v) != 0.0f;
}
#else
static int fp_contracts(void) { return 0; }
#endif

static kctx WK[NMODES][2]; /* [mode][threads 1, 3] */
static double worst[2];

static void wino_case(int n, int h, int w, int cin, int cout, int up, int use_b, int use_r) {
    int uh = up ? 2 * h : h, uw = up ? 2 * w : w, mi, av, th;
    size_t no = (size_t)n * uh * uw * cout;
    float *x = rvec((size_t)n * h * w * cin, 1.0), *wt = rvec((size_t)cout * cin * 9, 0.3), *b = rvec((size_t)cout, 1.0);
    float *R = use_r ? rvec(no, 1.0) : NULL, *res[2], *avx2_out = NULL;
    double *ref = (double *)malloc(sizeof(double) * no), e[2] = {0, 0};
    supermat__pw pw;
    supermat__t in, out;
    pack_w(&pw, wt, use_b ? b : NULL, cout, cin, 3);
    { int oh, ow; conv2d_ref(x, n, h, w, cin, uh, uw, wt, use_b ? b : NULL, cout, 3, 1, 1, 1, 1, 1, R, ref, &oh, &ow); }
    in.d = x; in.n = n; in.h = h; in.w = w; in.c = cin;
    out.n = n; out.h = uh; out.w = uw; out.c = cout;
    res[0] = (float *)malloc(no * sizeof(float)); res[1] = (float *)malloc(no * sizeof(float));
    for (mi = 0; mi < 2; mi++) {
        supermat__wino wg;
        make_wino(&wg, &pw, cin, cout, mi ? 4 : 2);
        for (av = 0; av < NMODES; av++) {
            if (!mode_ok(av)) continue;
            for (th = 0; th < 2; th++) {
                supermat__ctx *X = &WK[av][th].X;
                float *o = res[th];
                double err;
                if (R) memcpy(o, R, no * sizeof(float)); else memset(o, 0xff, no * sizeof(float)); /* NaN: unwritten shows */
                out.d = o;
                X->status = SUPERMAT_SUCCESS;
                /* in-place residual (R == out), as the resnets do */
                supermat__conv3x3_wino(X, &in, uh, uw, &wg, &out, use_b ? pw.bias : NULL, R ? o : NULL);
                err = maxerr(o, ref, no);
                TU_CHECK(X->status == SUPERMAT_SUCCESS && err < (mi ? 5e-4 : 2e-5), "F%d %s t%d n%d %dx%d->%dx%d %d->%d: err %.3g",
                      mi ? 4 : 2, KN(av), th ? 3 : 1, n, h, w, uh, uw, cin, cout, err);
                if (err > e[mi]) e[mi] = err;
            }
            TU_CHECK(!memcmp(res[0], res[1], no * sizeof(float)), "F%d %s: 1 and 3 threads differ", mi ? 4 : 2, KN(av));
            if (av == 1) { avx2_out = (float *)malloc(no * sizeof(float)); memcpy(avx2_out, res[0], no * sizeof(float)); }
            /* the AVX-512 tile transforms (F4) do the AVX2 path's operations in its order: the same bits,
               unless the compiler fused multiply-adds in the AVX2 path (then float64 alone judges) */
            if (av == 2 && avx2_out && !fp_contracts()) TU_CHECK(!memcmp(res[0], avx2_out, no * sizeof(float)), "F%d: AVX-512 and AVX2 bits differ", mi ? 4 : 2);
        }
        free(avx2_out);
        avx2_out = NULL;
        free_wino(&wg);
    }
    printf("  n%d %2dx%-2d%s cin %2d cout %2d bias %d R %d: F2 %.2e  F4 %.2e\n", n, h, w, up ? " up2" : "    ", cin, cout, use_b, use_r, e[0], e[1]);
    if (e[0] > worst[0]) worst[0] = e[0];
    if (e[1] > worst[1]) worst[1] = e[1];
    free(x); free(wt); free(b); free(R); free(ref); free(res[0]); free(res[1]); free(pw.p); free(pw.bias);
}

/* planning walks the same get/put and gemm calls: same flops, same peak */
static void wino_plan(int m, int n, int h, int w, int cin, int cout) {
    kctx k;
    supermat__pw pw;
    supermat__wino wg;
    supermat__t in, out;
    float *x = rvec((size_t)n * h * w * cin, 1.0), *wt = rvec((size_t)cout * cin * 9, 0.3);
    double fl_plan;
    size_t peak_plan;
    pack_w(&pw, wt, NULL, cout, cin, 3);
    make_wino(&wg, &pw, cin, cout, m);
    kctx_init(&k, 0, 1);
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
        TU_CHECK(k.X.status == SUPERMAT_SUCCESS && fl_plan == k.X.flops && fl_plan == want && peak_plan == k.X.peak && peak_plan > 0,
              "plan F%d: flops %.0f / %.0f (want %.0f), peak %zu / %zu", m, fl_plan, k.X.flops, want, peak_plan, k.X.peak);
        printf("  plan F%d n%d %dx%d %d->%d: flops %.4g (direct %.4g), peak %zu bytes (live %zu)\n", m, n, h, w, cin, cout, fl_plan,
               2.0 * n * h * w * 9.0 * cin * cout, peak_plan, k.X.peak);
    }
    kctx_free(&k);
    free(x); free(wt); free(pw.p); free(out.d); free_wino(&wg);
}

static void test_winograd(void) {
    static const int chans[4] = {3, 16, 37, 64};
    static const int sizes[4][2] = {{8, 8}, {7, 9}, {1, 1}, {2, 3}};
    int i, j, s, av, th;
    for (av = 0; av < NMODES; av++) for (th = 0; th < 2; th++) kctx_init(&WK[av][th], mode_ok(av) ? av : 0, th ? 3 : 1);
    printf("accuracy (max |err| / max |ref|):\n");
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++)
            for (s = 0; s < 4; s++) {
                int variant = (i * 4 + j + s) % 4;
                wino_case(variant == 1 ? 2 : 1, sizes[s][0], sizes[s][1], chans[i], chans[j], variant == 2, variant != 3, variant != 0);
            }
    /* explicit: n = 2 with the fused upsample, bias and residual; a wider case */
    wino_case(2, 7, 9, 37, 64, 1, 1, 1);
    wino_case(2, 5, 3, 64, 37, 1, 1, 1);
    wino_case(1, 16, 16, 64, 64, 0, 1, 1);
    wino_case(2, 13, 11, 128, 40, 0, 1, 1);
    /* several chunks of tiles (F4: 169 tiles in chunks of at most 144; F2: 676 in chunks of 292), each
       chunk's 36 / 16 GEMMs in one parallel-for: 1 and 3 threads the same bits, float64 as everywhere */
    wino_case(1, 52, 52, 128, 96, 0, 1, 1);
    printf("worst: F2 %.3g, F4 %.3g\n", worst[0], worst[1]);
    for (av = 0; av < NMODES; av++) for (th = 0; th < 2; th++) kctx_free(&WK[av][th]);
    wino_plan(2, 2, 9, 7, 16, 37);
    wino_plan(4, 2, 9, 7, 16, 37);
    wino_plan(4, 1, 128, 128, 128, 128); /* several chunks */
    wino_plan(2, 1, 256, 256, 128, 128);
}

static void test_exp(void) {
#if SUPERMAT__HAS_AVX2
    if (supermat_cpu().avx2) {
        float x[8], y[8];
        double worst = 0;
        int i, j;
        for (i = 0; i < 20000; i++) {
            for (j = 0; j < 8; j++) x[j] = (float)(-87.0 + 175.0 * (i * 8 + j) / 160000.0);
            memcpy(y, x, sizeof x); exp_row_avx2(y, 8);
            for (j = 0; j < 8; j++) { double r = exp((double)x[j]), e = fabs(y[j] - r) / r; if (e > worst) worst = e; }
        }
        TU_CHECK(worst < 4e-7, "AVX2 exp max relative error %.3g on [-87, 88]", worst);
        x[0] = -1000.0f; x[1] = 1000.0f; x[2] = -INFINITY; x[3] = 0; x[4] = -87.5f; x[5] = 1e-30f; x[6] = -1e-30f; x[7] = 88.0f;
        memcpy(y, x, sizeof x); exp_row_avx2(y, 8);
        TU_CHECK(y[0] >= 0 && y[0] < 1e-37 && y[1] > 1e38 && y[2] >= 0 && y[2] < 1e-37 && y[3] == 1.0f && y[5] == 1.0f && y[6] == 1.0f && nan_free(y, 8),
                 "AVX2 exp at the extremes: %g %g %g %g %g", y[0], y[1], y[2], y[3], y[4]);
    }
#endif
}

/* LayerNorm gives the same bits on every kernel this CPU has (the sums' lanes and order are fixed; tails of
   C mod 8 scalar on all), and each within 2e-6 of float64; rows of 77 and 320 channels, one of them constant */
static void test_layernorm_bits(void) {
    static const int Cs[2] = {77, 320};
    int ci, mode, i;
    for (ci = 0; ci < 2; ci++) {
        int C = Cs[ci], M = 19;
        size_t total = (size_t)M * C;
        float *x = rvec(total, 3.0), *g = rvec((size_t)C, 1.0), *b = rvec((size_t)C, 1.0), *y0 = (float *)malloc(sizeof(float) * total), *y = (float *)malloc(sizeof(float) * total);
        double worst = 0;
        supermat__norm nm;
        nm.g = g; nm.b = b; nm.c = C; nm.eps = 1e-5f;
        for (i = 0; i < C; i++) x[i] = 0.75f; /* row 0 constant */
        for (i = 0; i < (int)total; i++) x[i] += 40.0f; /* an offset the mean must take out */
        for (mode = 0; mode < NMODES; mode++) {
            kctx k;
            int r;
            if (!mode_ok(mode)) continue;
            kctx_init(&k, mode, 1);
            supermat__layernorm(&k.X, x, mode ? y : y0, M, &nm);
            if (mode) TU_CHECK(memcmp(y, y0, sizeof(float) * total) == 0, "LayerNorm C %d: kernel %s differs from scalar", C, KN(mode));
            for (r = 0; r < M && !mode; r++) {
                double s = 0, ss = 0, mean, rstd;
                int c;
                for (c = 0; c < C; c++) s += x[(size_t)r * C + c];
                mean = s / C;
                for (c = 0; c < C; c++) { double d = x[(size_t)r * C + c] - mean; ss += d * d; }
                rstd = 1.0 / sqrt(ss / C + 1e-5);
                for (c = 0; c < C; c++) {
                    double e = fabs(y0[(size_t)r * C + c] - ((x[(size_t)r * C + c] - mean) * rstd * g[c] + b[c]));
                    if (e > worst) worst = e;
                }
            }
            kctx_free(&k);
        }
        TU_CHECK(worst < 2e-6, "LayerNorm C %d vs float64: %.3g", C, worst);
        printf("LayerNorm, %d channels: every kernel here the scalar bits, within %.2g of float64\n", C, worst);
        free(x); free(g); free(b); free(y0); free(y);
    }
}

/* GEGLU on each kernel against float64 (h x g/2 (1 + erf(g / sqrt 2))): g over [-14, 14] (past the point where
   1 + erf underflows), rows whose width leaves SIMD tails, and the extremes (0, +-1e-30, +-Inf, NaN, +-1e30);
   error measured relative to |h| max(|g|, 1e-30), the scale of the product; 1 and 3 threads the same bits */
static void test_geglu(int mode) {
    enum { M = 37, H = 203 };
    kctx k1, k3;
    float *h = rvec((size_t)M * 2 * H, 1.0), *y1 = (float *)malloc(sizeof(float) * M * H), *y3 = (float *)malloc(sizeof(float) * M * H);
    double worst = 0;
    int m, j, bad = 0;
    static const float ext[10] = {0.0f, 1e-30f, -1e-30f, INFINITY, -INFINITY, NAN, 1e30f, -1e30f, 87.5f, -87.5f};
    for (m = 0; m < M; m++)
        for (j = 0; j < H; j++) {
            float *g = h + (size_t)m * 2 * H + H + j;
            *g = m == 0 && j < 10 ? ext[j] : (float)(-14.0 + 28.0 * (m * H + j) / (double)(M * H));
        }
    kctx_init(&k1, mode, 1); kctx_init(&k3, mode, 3);
    supermat__geglu(&k1.X, h, y1, M, H);
    supermat__geglu(&k3.X, h, y3, M, H);
    TU_CHECK(memcmp(y1, y3, sizeof(float) * M * H) == 0, "%s GEGLU: 1 and 3 threads differ", KN(mode));
    for (m = 0; m < M; m++)
        for (j = 0; j < H; j++) {
            double a = h[(size_t)m * 2 * H + j], g = h[(size_t)m * 2 * H + H + j], got = y1[(size_t)m * H + j];
            double ref = a * 0.5 * g * (1.0 + erf(g * 0.70710678118654752));
            if (ref != ref || isinf(ref)) { /* NaN, 0 x Inf and -Inf: the same class as erff's */
                if (!(ref != ref ? got != got : got == ref)) { bad++; printf("%s GEGLU: gelu(%g) x %g = %g, float64 %g\n", KN(mode), g, a, got, ref); }
                continue;
            }
            if (got != got) { bad++; continue; }
            {
                double sc = fabs(a) * (fabs(g) > 1e-30 ? fabs(g) : 1e-30), e = fabs(got - ref) / (sc > 0 ? sc : 1.0);
                if (e > worst) worst = e;
            }
        }
    TU_CHECK(bad == 0 && worst < 4e-7, "%s GEGLU vs float64: %d wrong classes, worst %.3g", KN(mode), bad, worst);
    printf("kernel %s: GEGLU within %.2g of float64 (relative to |h g|), extremes as erff's\n", KN(mode), worst);
    kctx_free(&k1); kctx_free(&k3);
    free(h); free(y1); free(y3);
}

/* the sRGB transfer of the detail and colour steps (supermat__xfer_n) against float64 (supermat_srgb_to_linear /
   _linear_to_srgb): 2^20 values over [-0.05, 1.05], every float within 4 ulp of both knees, subnormals, 0, 1 and
   the non-finite ones (NaN and -Inf -> 0, +Inf -> 1, as the float64 functions clamp); a length of 2^20 + 3 so the
   SIMD rows' tails are taken too */
static void test_srgb(int mode) {
    enum { N = (1 << 20) + 3 };
    static const float ext[] = {0.0f, -0.0f, 1.0f, 1e-45f, 1e-39f, -1e-39f, 1e-30f, 1e-7f, 0.5f, 2.0f, -1.0f, INFINITY, -INFINITY, NAN};
    float *v = (float *)malloc(sizeof(float) * N), *o = (float *)malloc(sizeof(float) * N);
    kctx k;
    int enc, i, bad = 0;
    kctx_init(&k, mode, 1);
    for (enc = 0; enc < 2; enc++) {
        double worst = 0;
        float knee = enc ? 0.0031308f : 0.04045f;
        int ne = (int)(sizeof ext / sizeof ext[0]);
        for (i = 0; i < N; i++) v[i] = (float)(-0.05 + 1.1 * i / (double)(N - 1));
        for (i = 0; i < ne; i++) v[i] = ext[i];
        {
            float lo = knee, hi = knee;
            v[ne] = knee;
            for (i = 0; i < 4; i++) { lo = nextafterf(lo, 0.0f); hi = nextafterf(hi, 1.0f); v[ne + 1 + 2 * i] = lo; v[ne + 2 + 2 * i] = hi; }
        }
        memcpy(o, v, sizeof(float) * N);
        supermat__xfer_n(&k.X, enc, o, N);
        for (i = 0; i < N; i++) {
            double ref = enc ? supermat_linear_to_srgb(v[i]) : supermat_srgb_to_linear(v[i]), e;
            if (v[i] != v[i]) ref = 0.0;
            e = fabs(o[i] - ref) / (ref > 1e-30 ? ref : 1e-30);
            if (!(o[i] >= 0.0f && o[i] <= 1.0f) || (ref == 0.0 && o[i] != 0.0f)) { bad++; if (bad < 5) printf("%s sRGB %s(%g) = %g, float64 %g\n", KN(mode), enc ? "encode" : "decode", v[i], o[i], ref); continue; }
            if (ref > 0.0 && e > worst) worst = e;
        }
        TU_CHECK(bad == 0 && worst < 8e-7, "%s sRGB %s vs float64: %d out of range, worst %.3g", KN(mode), enc ? "encode" : "decode", bad, worst);
        printf("kernel %s: sRGB %s within %.2g of float64 (relative), extremes clamped\n", KN(mode), enc ? "encode" : "decode", worst);
    }
    kctx_free(&k);
    free(v); free(o);
}

#if SUPERMAT__HAS_NEON
/* the detail step's streamed low-pass with a synthetic source (6 floats a pixel) and a sink that keeps the rows */
typedef struct dst_io { int w; float *out; } dst_io;
static void dst_src(void *user, int y, float *row, int thread) {
    const dst_io *io = (const dst_io *)user;
    int i;
    (void)thread;
    for (i = 0; i < io->w * SUPERMAT__DC; i++) row[i] = (float)((y * 131 + i * 71) % 997) / 997.0f;
}
static void dst_sink(void *user, int y, float *row, int thread) {
    const dst_io *io = (const dst_io *)user;
    (void)thread;
    memcpy(io->out + (size_t)y * io->w * SUPERMAT__DC, row, sizeof(float) * (size_t)io->w * SUPERMAT__DC);
}
#endif
/* the NEON passes against their scalar twins (aarch64 only; run under qemu by ctest neon): panel widening
   (f16 and bf16 with subnormals, infinities and NaNs; int8 times its scales) bit for bit, NaN for NaN; exp against
   float64 on [-87, 88] and at the extremes; SiLU against the scalar expf form; one online-softmax block
   against the scalar form; GroupNorm (+SiLU) in both modes: the same means bit for bit (the sums run in
   the same order), the outputs within 2e-6; the detail step's streamed low-pass: the same bits */
static void test_neon_twins(void) {
#if SUPERMAT__HAS_NEON
    kctx ks, kn;
    int i, j, fmt, kc = 37, n = kc * 16;
    uint16_t *h = (uint16_t *)malloc(sizeof(uint16_t) * (size_t)n);
    signed char *q = (signed char *)malloc((size_t)n);
    float *a = (float *)malloc(sizeof(float) * (size_t)n), *b = (float *)malloc(sizeof(float) * (size_t)n), sc[16];
    double worst = 0;
    if (!supermat_cpu().neon) { printf("SKIP: no NEON: the NEON twins were not tested\n"); free(h); free(q); free(a); free(b); return; }
    for (i = 0; i < n; i++) { h[i] = (uint16_t)(rnd() * 32768.0 + 32768.0); q[i] = (signed char)(rnd() * 127.0); }
    h[0] = 0x0001; h[1] = 0x7C00; h[2] = 0xFC00; h[3] = 0x7E01; h[4] = 0x8000; h[5] = 0x03FF; /* f16 subnormals, +-Inf, NaN, -0 */
    for (i = 0; i < 16; i++) sc[i] = (float)(0.01 + 0.003 * i);
    for (fmt = 1; fmt <= 3; fmt++) {
        const void *src = fmt == 3 ? (const void *)q : (const void *)h;
        supermat__widen_scalar(src, fmt, sc, kc, a);
        supermat__widen_neon(src, fmt, sc, kc, b);
        for (i = 0, j = 0; i < n; i++) /* the same bits, NaN for NaN (a signalling NaN comes out quiet from NEON) */
            if (a[i] == a[i] ? memcmp(a + i, b + i, 4) != 0 : b[i] == b[i]) j++;
        TU_CHECK(j == 0, "NEON widening, format %d: %d values not the scalar bits", fmt, j);
    }
    printf("neon twins: f16 / bf16 / int8 panel widening bit-identical to scalar (%d values each)\n", n);
    for (i = 0; i < 40000; i++) {
        float x[4], y[4];
        for (j = 0; j < 4; j++) x[j] = (float)(-87.0 + 175.0 * (i * 4 + j) / 160000.0);
        vst1q_f32(y, supermat__exp_neon(vld1q_f32(x)));
        for (j = 0; j < 4; j++) { double r = exp((double)x[j]), e = fabs(y[j] - r) / r; if (e > worst) worst = e; }
    }
    TU_CHECK(worst < 4e-7, "NEON exp max relative error %.3g on [-87, 88]", worst);
    {
        float x[8] = {-1000.0f, 1000.0f, -INFINITY, 0.0f, -87.5f, 1e-30f, -1e-30f, 88.0f}, y[8];
        vst1q_f32(y, supermat__exp_neon(vld1q_f32(x))); vst1q_f32(y + 4, supermat__exp_neon(vld1q_f32(x + 4)));
        TU_CHECK(y[0] >= 0 && y[0] < 1e-37 && y[1] > 1e38 && y[2] >= 0 && y[2] < 1e-37 && y[3] == 1.0f && y[5] == 1.0f && y[6] == 1.0f && nan_free(y, 8),
                 "NEON exp at the extremes: %g %g %g %g %g", y[0], y[1], y[2], y[3], y[4]);
    }
    printf("neon twins: exp within %.2g (relative) of float64 on [-87, 88], clamped at the extremes\n", worst);
    kctx_init(&ks, 0, 1); kctx_init(&kn, 3, 1);
    { /* SiLU over a wide range (and past exp's range), the scalar twin is x / (1 + expf(-x)) */
        int m = 1001;
        float *x = rvec((size_t)m, 40.0), *ys = (float *)malloc(sizeof(float) * (size_t)m), *yn = (float *)malloc(sizeof(float) * (size_t)m);
        double e = 0;
        x[0] = 120.0f; x[1] = -120.0f; x[2] = 0.0f;
        supermat__silu(&ks.X, ys, x, m); supermat__silu(&kn.X, yn, x, m);
        for (i = 0; i < m; i++) { double d = fabs((double)yn[i] - ys[i]) / (fabs(ys[i]) > 1e-3 ? fabs(ys[i]) : 1e-3); if (d > e) e = d; }
        TU_CHECK(nan_free(yn, (size_t)m) && e < 2e-6, "NEON SiLU vs scalar: %.3g", e);
        printf("neon twins: SiLU within %.2g of the scalar twin (relative, 1001 values in [-120, 120])\n", e);
        free(x); free(ys); free(yn);
    }
    { /* one online-softmax block, twice (the running max and sum carried over) */
        int m = 203, pass;
        float *s0 = rvec((size_t)m, 30.0), *s1 = (float *)malloc(sizeof(float) * (size_t)m), ms = -INFINITY, ls = 0, mn = -INFINITY, ln = 0;
        double e = 0;
        for (pass = 0; pass < 2; pass++) {
            float mx = -INFINITY, sum = 0.0f, corr_s, corr_n, mnew;
            int c;
            memcpy(s1, s0, sizeof(float) * (size_t)m);
            corr_n = supermat__softmax_block_neon(s1, m, 0.125f, &mn, &ln);
            for (c = 0; c < m; c++) { s0[c] *= 0.125f; if (s0[c] > mx) mx = s0[c]; } /* the scalar twin, as in the attention */
            mnew = ms > mx ? ms : mx;
            corr_s = ms == -INFINITY ? 0.0f : expf(ms - mnew);
            for (c = 0; c < m; c++) { s0[c] = expf(s0[c] - mnew); sum += s0[c]; }
            ls = ls * corr_s + sum; ms = mnew;
            for (c = 0; c < m; c++) { double d = fabs((double)s1[c] - s0[c]); if (d > e) e = d; }
            TU_CHECK(mn == ms && fabs((double)ln - ls) <= 1e-5 * ls && fabs((double)corr_n - corr_s) <= 1e-6, "NEON softmax block %d: max %g / %g, sum %g / %g", pass, mn, ms, ln, ls);
            for (c = 0; c < m; c++) s0[c] = (float)(rnd() * 30.0);
        }
        TU_CHECK(e < 1e-6, "NEON softmax block vs scalar: %.3g", e);
        printf("neon twins: online softmax block within %.2g of the scalar twin\n", e);
        free(s0); free(s1);
    }
    { /* GroupNorm (+SiLU): 72 channels in 8 groups (9 a group: blocks of 8 and a scalar tail), 300 pixels (two chunks) */
        int C = 72, groups = 8, pix = 300, silu;
        size_t total = (size_t)pix * C;
        float *x = rvec(total, 4.0), *gm = rvec((size_t)C, 1.0), *bt = rvec((size_t)C, 1.0), *ys = (float *)malloc(sizeof(float) * total), *yn = (float *)malloc(sizeof(float) * total);
        supermat__norm nm;
        supermat__t in, out;
        for (silu = 0; silu < 2; silu++) {
            double e = 0;
            size_t p;
            nm.g = gm; nm.b = bt; nm.c = C; nm.eps = 1e-5f;
            in.d = x; in.n = 1; in.h = 15; in.w = 20; in.c = C; out = in;
            out.d = ys; ks.X.status = SUPERMAT_SUCCESS; supermat__groupnorm(&ks.X, &in, &out, &nm, groups, silu);
            out.d = yn; kn.X.status = SUPERMAT_SUCCESS; supermat__groupnorm(&kn.X, &in, &out, &nm, groups, silu);
            for (p = 0; p < total; p++) { double d = fabs((double)yn[p] - ys[p]); if (d > e) e = d; }
            for (i = 0; i < groups; i++) TU_CHECK(ks.X.gn_stats[i] == kn.X.gn_stats[i], "NEON GroupNorm group %d: mean %.17g vs scalar %.17g", i, kn.X.gn_stats[i], ks.X.gn_stats[i]); /* means first, then 1/std */
            TU_CHECK(nan_free(yn, total) && e < 2e-6, "NEON GroupNorm (silu %d) vs scalar: %.3g", silu, e);
            printf("neon twins: GroupNorm%s within %.2g of the scalar twin, the same means\n", silu ? " + SiLU" : "", e);
        }
        free(x); free(gm); free(bt); free(ys); free(yn);
    }
    { /* the detail step's low-pass streamed in rows (37 x 150, r 3: rings of 24 rows): NEON sums = scalar bits */
        enum { DW = 37, DH = 150 };
        static float o0[DW * DH * SUPERMAT__DC], o1[DW * DH * SUPERMAT__DC];
        supermat__dstream D;
        dst_io io;
        int mode;
        for (mode = 0; mode < 2; mode++) {
            kctx *kk = mode ? &kn : &ks;
            supermat__dstream_get(&kk->X, &D, DW, DH, 0.02f);
            TU_CHECK(!D.whole && D.r == 3, "the streamed low-pass: whole %d, r %d", D.whole, D.r);
            io.w = DW; io.out = mode ? o1 : o0;
            D.src = dst_src; D.sink = dst_sink; D.user = &io;
            supermat__dstream_run(&D);
            supermat__dstream_put(&kk->X, &D);
        }
        TU_CHECK(!memcmp(o0, o1, sizeof o0), "NEON streamed low-pass: not the scalar bits");
        printf("neon twins: the detail step's streamed low-pass (37x150, r 3) bit-identical to scalar\n");
    }
    kctx_free(&ks); kctx_free(&kn);
    free(h); free(q); free(a); free(b);
#endif
}

/* AVX-512 (12 x 16 and 12 x 32) and AVX2 micro-kernels sum every output element in the same order: the
   same bits, for GEMMs with bias, residual and several K blocks, convolutions and attention */
static void test_same_bits(void) {
    kctx k[2];
    int t, mode;
    if (!supermat_cpu().avx512) { printf("SKIP: no AVX-512F: AVX-512 vs AVX2 bits not compared\n"); return; }
    kctx_init(&k[0], 1, 1);
    kctx_init(&k[1], 2, 3);
    for (t = 0; t < 24; t++) {
        int M = irand(1, 130), N = irand(1, 100), K = irand(1, 600);
        float *a = rvec((size_t)M * K, 1.0), *w = rvec((size_t)N * K, 1.0), *b = rvec((size_t)N, 1.0), *R = rvec((size_t)M * N, 1.0), *c[2];
        supermat__pw pw;
        pack_w(&pw, w, t % 2 ? b : NULL, N, K, 1);
        for (mode = 0; mode < 2; mode++) {
            c[mode] = (float *)malloc(sizeof(float) * (size_t)M * N);
            supermat__linear(&k[mode].X, a, (size_t)K, M, &pw, c[mode], (size_t)N, t % 3 ? R : NULL, (size_t)N);
        }
        TU_CHECK(!memcmp(c[0], c[1], sizeof(float) * (size_t)M * N), "gemm M%d N%d K%d: AVX-512 and AVX2 bits differ", M, N, K);
        free(a); free(w); free(b); free(R); free(c[0]); free(c[1]); free(pw.p); free(pw.bias);
    }
    for (t = 0; t < 8; t++) {
        /* the last two: enough rows for whole 96-row blocks (no column split), K over several 256 blocks,
           64+ input channels (the direct path: rows read in place), column panels all in pairs and not */
        int n = 1, h = t < 6 ? irand(3, 17) : 29 + t, wd = t < 6 ? irand(3, 17) : 31, cin = t < 6 ? irand(1, 40) : 61 + t, cout = t < 6 ? irand(1, 72) : (t == 6 ? 64 : 80), oh = h, ow = wd;
        size_t no = (size_t)n * oh * ow * cout;
        float *x = rvec((size_t)n * h * wd * cin, 1.0), *wt = rvec((size_t)cout * cin * 9, 0.3), *b = rvec((size_t)cout, 1.0), *o[2];
        supermat__conv cv;
        supermat__t in, out;
        memset(&cv, 0, sizeof cv);
        cv.k = 3; cv.stride = 1; cv.cin = cin; cv.cout = cout;
        pack_w(&cv.w, wt, b, cout, cin, 3);
        in.d = x; in.n = n; in.h = h; in.w = wd; in.c = cin;
        for (mode = 0; mode < 2; mode++) {
            o[mode] = (float *)malloc(no * sizeof(float));
            out.d = o[mode]; out.n = n; out.h = oh; out.w = ow; out.c = cout;
            supermat__conv2d(&k[mode].X, &in, h, wd, &cv, 0, &out, cv.w.bias, NULL);
        }
        TU_CHECK(k[0].X.status == SUPERMAT_SUCCESS && k[1].X.status == SUPERMAT_SUCCESS && !memcmp(o[0], o[1], no * sizeof(float)),
                 "conv %dx%d %d->%d: AVX-512 and AVX2 bits differ", h, wd, cin, cout);
        free(x); free(wt); free(b); free(o[0]); free(o[1]); free(cv.w.p); free(cv.w.bias);
    }
    for (t = 0; t < 8; t++) { /* attention: the 12 x 32 kernel over key and value panel pairs */
        int heads = irand(1, 3), d = t % 2 ? irand(1, 70) : 16 * irand(1, 5), C = heads * d, mq = irand(1, 130), mk = irand(1, 300);
        float *q = rvec((size_t)mq * C, 1.0), *kk = rvec((size_t)mk * C, 1.0), *v = rvec((size_t)mk * C, 1.0), *o[2];
        float *kp = (float *)malloc(sizeof(float) * heads * supermat__attn_kp_floats(mk, d));
        float *vp = (float *)malloc(sizeof(float) * heads * supermat__attn_vp_floats(mk, d));
        for (mode = 0; mode < 2; mode++) {
            o[mode] = (float *)malloc(sizeof(float) * (size_t)mq * C);
            supermat__attn_pack(&k[mode].X, kk, (size_t)C, v, (size_t)C, mk, 1, heads, d, kp, vp);
            supermat__attention(&k[mode].X, q, (size_t)C, mq, 1, kp, vp, mk, 1, heads, d, (float)(1.0 / sqrt((double)d)), o[mode], (size_t)C);
        }
        TU_CHECK(!memcmp(o[0], o[1], sizeof(float) * (size_t)mq * C), "attention heads %d d %d mq %d mk %d: AVX-512 and AVX2 bits differ", heads, d, mq, mk);
        free(q); free(kk); free(v); free(kp); free(vp); free(o[0]); free(o[1]);
    }
    for (t = 0; t < 6; t++) { /* group norm: the per-channel double sums, 32 / 16 channels a vector block and the tail */
        kctx ks;
        int C = t == 0 ? 512 : t == 1 ? 48 : 8 * irand(1, 40) + (t % 2) * irand(1, 7), groups = t < 2 ? 16 : 1;
        int h = irand(1, 40), wd = t == 0 ? 300 : irand(1, 40); /* t 0: several 256-pixel chunks */
        size_t total = (size_t)h * wd * C;
        float *x = rvec(total, 3.0), *gm = rvec((size_t)C, 1.0), *bt = rvec((size_t)C, 1.0), *o[3];
        double st[3][2 * 16];
        supermat__norm nm;
        supermat__t in, out;
        size_t i;
        for (i = 0; i < total; i++) x[i] += 5.0f; /* an offset: the variance pass is not the plain sum of squares */
        kctx_init(&ks, 0, 1);
        nm.g = gm; nm.b = bt; nm.c = C; nm.eps = 1e-5f;
        in.d = x; in.n = 1; in.h = h; in.w = wd; in.c = C;
        for (mode = 0; mode < 3; mode++) {
            o[mode] = (float *)malloc(sizeof(float) * total);
            out = in; out.d = o[mode];
            supermat__groupnorm(mode == 2 ? &ks.X : &k[mode].X, &in, &out, &nm, groups, t % 2);
            memcpy(st[mode], (mode == 2 ? &ks.X : &k[mode].X)->gn_stats, sizeof(double) * 2 * groups); /* mean, 1/std */
        }
        TU_CHECK(!memcmp(o[0], o[1], sizeof(float) * total), "groupnorm C %d %dx%d: AVX-512 and AVX2 bits differ", C, h, wd);
        /* statistics: AVX2 = AVX-512 bit for bit (explicit FMAs); the scalar sums round each square apart */
        TU_CHECK(!memcmp(st[0], st[1], sizeof(double) * 2 * groups), "groupnorm C %d %dx%d: AVX2 and AVX-512 statistics differ", C, h, wd);
        {
            int g;
            double worst_rel = 0;
            for (g = 0; g < 2 * groups; g++) {
                double rel = fabs(st[2][g] - st[0][g]) / fmax(fabs(st[0][g]), 1e-30);
                if (rel > worst_rel) worst_rel = rel;
            }
            TU_CHECK(worst_rel < 1e-12, "groupnorm C %d %dx%d: scalar statistics %.3g from AVX2's (relative)", C, h, wd, worst_rel);
        }
        kctx_free(&ks);
        free(x); free(gm); free(bt); free(o[0]); free(o[1]); free(o[2]);
    }
    kctx_free(&k[0]);
    kctx_free(&k[1]);
    printf("AVX-512 = AVX2 bits: 24 GEMMs, 8 convolutions, 8 attentions, 6 group norms\n");
}

/* bf16 compute (AVX512_BF16): the pair kernel against float64 sums of the bf16-rounded operands (the
   rounding is the mode's; what is left is float32 accumulation: 1e-5), and against the float32 operands
   (the mode's own error: 1e-2 of max |C|); bias, residual, odd K, several K blocks, 1 and 3 threads */
#if SUPERMAT__HAS_AVX512
static float bf16_round(float x) { uint16_t h = supermat__f32_to_bf16(x); return supermat__bf16_to_f32(h); }
#endif
/* bf16 compute: vdpbf16ps (variant 0) and, where the CPU and OS allow it, AMX tiles (variant 1), against
   float64 sums of the bf16-rounded operands (and of the f32 ones, loosely), 1 and 3 threads the same bits */
static void test_bf16_compute(void) {
#if SUPERMAT__HAS_AVX512
    kctx k[2][2];
    int t, th, v, nv = supermat_cpu().amx_bf16 ? 2 : 1;
    double worst_r[2] = {0, 0}, worst_x[2] = {0, 0};
    if (!supermat_cpu().avx512_bf16) { printf("SKIP: no AVX512_BF16: bf16 compute not tested\n"); return; }
    if (nv < 2) printf("SKIP: no AMX-BF16 (CPU, OS or build): the AMX kernel was not tested\n");
    for (v = 0; v < nv; v++) {
        kctx_init(&k[v][0], 2, 1);
        kctx_init(&k[v][1], 2, 3);
        k[v][0].X.amx = k[v][1].X.amx = v;
    }
    for (t = 0; t < 40; t++) {
        int M = irand(1, 140), N = irand(1, 70), K = irand(1, 700), m, n, kk, np, K2;
        float *a, *w, *b, *R, *c[2];
        double *ref_r, *ref_x;
        supermat__pw pw;
        uint16_t *q;
        int use_b = t % 2, use_r = t % 3 == 0;
        if (t == 0) { M = 96; N = 32; K = 512; } /* whole tiles and K blocks, no tails */
        if (t == 1) { M = 140; N = 70; K = 700; }
        np = (N + 15) / 16; K2 = (K + 1) / 2;
        a = rvec((size_t)M * K, 1.0); w = rvec((size_t)N * K, 1.0); b = rvec((size_t)N, 1.0); R = rvec((size_t)M * N, 1.0);
        ref_r = (double *)malloc(sizeof(double) * (size_t)M * N); ref_x = (double *)malloc(sizeof(double) * (size_t)M * N);
        q = (uint16_t *)calloc((size_t)np * K2 * 32, sizeof(uint16_t));
        pack_w(&pw, w, use_b ? b : NULL, N, K, 1);
        for (n = 0; n < np * 16; n++) /* [K/2][16][2] pairs */
            for (kk = 0; kk < K; kk++) q[(((size_t)(n / 16) * K2 + kk / 2) * 16 + n % 16) * 2 + (kk & 1)] = supermat__f32_to_bf16(pw.p[((size_t)(n / 16) * K + kk) * 16 + n % 16]);
        free(pw.p); pw.p = NULL; pw.q = q; pw.fmt = 4;
        for (m = 0; m < M; m++)
            for (n = 0; n < N; n++) {
                double sr = use_b ? b[n] : 0.0, sx = sr;
                if (use_r) { sr += R[(size_t)m * N + n]; sx += R[(size_t)m * N + n]; }
                for (kk = 0; kk < K; kk++) {
                    sr += (double)bf16_round(a[(size_t)m * K + kk]) * bf16_round(w[(size_t)n * K + kk]);
                    sx += (double)a[(size_t)m * K + kk] * w[(size_t)n * K + kk];
                }
                ref_r[(size_t)m * N + n] = sr; ref_x[(size_t)m * N + n] = sx;
            }
        for (v = 0; v < nv; v++) {
            for (th = 0; th < 2; th++) {
                double er, ex;
                c[th] = (float *)malloc(sizeof(float) * (size_t)M * N);
                k[v][th].X.status = SUPERMAT_SUCCESS;
                supermat__linear(&k[v][th].X, a, (size_t)K, M, &pw, c[th], (size_t)N, use_r ? R : NULL, (size_t)N);
                er = maxerr(c[th], ref_r, (size_t)M * N); ex = maxerr(c[th], ref_x, (size_t)M * N);
                TU_CHECK(k[v][th].X.status == SUPERMAT_SUCCESS && er < 1e-5 && ex < 1e-2, "bf16 compute %s t%d M%d N%d K%d: err %.3g vs bf16 operands, %.3g vs f32",
                         v ? "amx" : "avx512", th ? 3 : 1, M, N, K, er, ex);
                if (er > worst_r[v]) worst_r[v] = er;
                if (ex > worst_x[v]) worst_x[v] = ex;
            }
            TU_CHECK(!memcmp(c[0], c[1], sizeof(float) * (size_t)M * N), "bf16 compute %s M%d N%d K%d: 1 and 3 threads differ", v ? "amx" : "avx512", M, N, K);
            free(c[0]); free(c[1]);
        }
        free(a); free(w); free(b); free(R); free(ref_r); free(ref_x); free(q); free(pw.bias);
    }
    for (v = 0; v < nv; v++) {
        kctx_free(&k[v][0]);
        kctx_free(&k[v][1]);
        printf("bf16 compute (%s): worst %.3g vs bf16-rounded operands, %.3g vs f32 operands (40 GEMMs)\n", v ? "AMX tiles" : "vdpbf16ps",
               worst_r[v], worst_x[v]);
    }
#endif
}

/* int8 compute, on each vpdpbusd kernel this CPU has (AVX512_VNNI: 512-bit, 12 rows; AVX-VNNI: 256-bit,
   6 rows, under the AVX2 kernel): against float64 sums of the quantized operands as this test quantizes them
   (weights: max |w| / 127 per column per 64 rows of K; activations: the same per row, both rounded to nearest
   even; what is left is the float32 sum of the chunks' scaled int32 sums: 1e-5), and against the float32
   operands (the mode's own error, printed; bound 3e-2 of max |C|); bias, residual, K tails (not a multiple
   of 4 or 64), several K blocks, a zero row, a row of a wide range, 1 and 3 threads; where the CPU has both,
   the two kernels give the same bits */
static void test_int8_compute(void) {
#if SUPERMAT__HAS_AVX512
    kctx k[2][2];
    int t, th, v, has[2];
    double worst_r[2] = {0, 0}, worst_x[2] = {0, 0};
    static const char *const vname[2] = {"AVX512_VNNI", "AVX-VNNI"};
    has[0] = supermat_cpu().avx512_vnni;
    has[1] = supermat_cpu().avx_vnni;
    if (!has[0]) printf("SKIP: no AVX512_VNNI: the 512-bit int8 kernel not tested\n");
    if (!has[1]) printf("SKIP: no AVX-VNNI (or a compiler without it): the 256-bit int8 kernel not tested\n");
    if (!has[0] && !has[1]) return;
    for (v = 0; v < 2; v++)
        for (th = 0; th < 2; th++) {
            kctx_init(&k[v][th], v ? 1 : 2, th ? 3 : 1);
            k[v][th].X.vnni256 = v;
        }
    for (t = 0; t < 40; t++) {
        int M = irand(1, 140), N = irand(1, 70), K = irand(1, 700), m, n, kk, np, K4, nch, j;
        float *a, *w, *b, *R, *c[4] = {NULL, NULL, NULL, NULL}, *ws, *as;
        double *ref_r, *ref_x;
        signed char *q, *qw;
        int32_t *cor;
        supermat__pw pw;
        int use_b = t % 2, use_r = t % 3 == 0;
        if (t == 0) { M = 96; N = 32; K = 512; }
        if (t == 1) { M = 140; N = 70; K = 700; }
        if (t == 2) { M = 13; N = 17; K = 3; }
        np = (N + 15) / 16; K4 = (K + 3) / 4; nch = (K + 63) / 64;
        a = rvec((size_t)M * K, 1.0); w = rvec((size_t)N * K, 1.0); b = rvec((size_t)N, 1.0); R = rvec((size_t)M * N, 1.0);
        if (M > 2) {
            for (kk = 0; kk < K; kk++) a[(size_t)1 * K + kk] = 0.0f;                          /* a zero row: scale 0 */
            for (kk = 0; kk < K; kk++) a[(size_t)2 * K + kk] *= kk % 7 == 0 ? 1000.0f : 0.001f; /* a wide range */
        }
        ref_r = (double *)malloc(sizeof(double) * (size_t)M * N); ref_x = (double *)malloc(sizeof(double) * (size_t)M * N);
        /* the weights: quads [K/4][16][4] per panel, scales and 128 x column sums per 64 rows */
        q = (signed char *)calloc((size_t)np * K4 * 64, 1);
        qw = (signed char *)calloc((size_t)np * 16 * K, 1);
        ws = (float *)calloc((size_t)nch * np * 16 * 2, sizeof(float));
        cor = (int32_t *)(ws + (size_t)nch * np * 16);
        for (n = 0; n < N; n++)
            for (j = 0; j < nch; j++) {
                int k0 = 64 * j, k1 = K < k0 + 64 ? K : k0 + 64;
                float mx = 0.0f, inv;
                int32_t sum = 0;
                for (kk = k0; kk < k1; kk++) mx = fabsf(w[(size_t)n * K + kk]) > mx ? fabsf(w[(size_t)n * K + kk]) : mx;
                inv = mx > 0.0f ? 127.0f / mx : 0.0f;
                ws[(size_t)j * np * 16 + n] = mx / 127.0f;
                for (kk = k0; kk < k1; kk++) {
                    int v = (int)rintf(w[(size_t)n * K + kk] * inv);
                    qw[(size_t)n * K + kk] = (signed char)v;
                    q[(((size_t)(n / 16) * K4 + kk / 4) * 16 + n % 16) * 4 + (kk & 3)] = (signed char)v;
                    sum += v;
                }
                cor[(size_t)j * np * 16 + n] = 128 * sum;
            }
        memset(&pw, 0, sizeof pw);
        pw.K = K; pw.N = N; pw.qcin = K; pw.fmt = 5; pw.q = q; pw.qs = ws;
        if (use_b) { pw.bias = (float *)calloc((size_t)np * 16, sizeof(float)); memcpy(pw.bias, b, sizeof(float) * (size_t)N); }
        /* the activations, quantized per row per 64 of K */
        as = (float *)malloc(sizeof(float) * (size_t)M * nch);
        {
            int *qa = (int *)malloc(sizeof(int) * (size_t)M * K);
            for (m = 0; m < M; m++)
                for (j = 0; j < nch; j++) {
                    int k0 = 64 * j, k1 = K < k0 + 64 ? K : k0 + 64;
                    float mx = 0.0f, inv;
                    for (kk = k0; kk < k1; kk++) mx = fabsf(a[(size_t)m * K + kk]) > mx ? fabsf(a[(size_t)m * K + kk]) : mx;
                    inv = mx > 0.0f ? 127.0f / mx : 0.0f;
                    as[(size_t)m * nch + j] = mx / 127.0f;
                    for (kk = k0; kk < k1; kk++) qa[(size_t)m * K + kk] = (int)rintf(a[(size_t)m * K + kk] * inv);
                }
            for (m = 0; m < M; m++)
                for (n = 0; n < N; n++) {
                    double sr = use_b ? b[n] : 0.0, sx = sr;
                    if (use_r) { sr += R[(size_t)m * N + n]; sx += R[(size_t)m * N + n]; }
                    for (j = 0; j < nch; j++) {
                        int k0 = 64 * j, k1 = K < k0 + 64 ? K : k0 + 64;
                        long isum = 0;
                        for (kk = k0; kk < k1; kk++) isum += (long)qa[(size_t)m * K + kk] * qw[(size_t)n * K + kk];
                        sr += (double)isum * (double)(ws[(size_t)j * np * 16 + n] * as[(size_t)m * nch + j]);
                    }
                    for (kk = 0; kk < K; kk++) sx += (double)a[(size_t)m * K + kk] * w[(size_t)n * K + kk];
                    ref_r[(size_t)m * N + n] = sr; ref_x[(size_t)m * N + n] = sx;
                }
            free(qa);
        }
        for (v = 0; v < 2; v++) {
            if (!has[v]) continue;
            for (th = 0; th < 2; th++) {
                double er, ex;
                c[v * 2 + th] = (float *)malloc(sizeof(float) * (size_t)M * N);
                k[v][th].X.status = SUPERMAT_SUCCESS;
                supermat__linear(&k[v][th].X, a, (size_t)K, M, &pw, c[v * 2 + th], (size_t)N, use_r ? R : NULL, (size_t)N);
                er = maxerr(c[v * 2 + th], ref_r, (size_t)M * N); ex = maxerr(c[v * 2 + th], ref_x, (size_t)M * N);
                TU_CHECK(k[v][th].X.status == SUPERMAT_SUCCESS && er < 1e-5 && ex < 3e-2,
                         "int8 compute (%s) t%d M%d N%d K%d: err %.3g vs quantized operands, %.3g vs f32", vname[v], th ? 3 : 1, M, N, K, er, ex);
                if (er > worst_r[v]) worst_r[v] = er;
                if (ex > worst_x[v]) worst_x[v] = ex;
            }
            TU_CHECK(!memcmp(c[v * 2], c[v * 2 + 1], sizeof(float) * (size_t)M * N), "int8 compute (%s) M%d N%d K%d: 1 and 3 threads differ",
                     vname[v], M, N, K);
        }
        if (has[0] && has[1])
            TU_CHECK(!memcmp(c[0], c[2], sizeof(float) * (size_t)M * N), "int8 compute M%d N%d K%d: AVX512_VNNI and AVX-VNNI kernels differ", M, N, K);
        for (v = 0; v < 4; v++) free(c[v]);
        free(a); free(w); free(b); free(R); free(ref_r); free(ref_x); free(q); free(qw); free(ws); free(as); free(pw.bias);
    }
    for (v = 0; v < 2; v++)
        for (th = 0; th < 2; th++) kctx_free(&k[v][th]);
    for (v = 0; v < 2; v++)
        if (has[v])
            printf("int8 compute (vpdpbusd, %s): worst %.3g vs the quantized operands, %.3g vs f32 operands (40 GEMMs)%s\n", vname[v], worst_r[v],
                   worst_x[v], v && has[0] ? "; the same bits as AVX512_VNNI" : "");
#endif
}

static void test_scheduler(void) {
    float a = supermat__alphas_cumprod(1000, 0.00085, 0.012, 1, 999);
    uint32_t bits;
    memcpy(&bits, &a, 4);
    /* diffusers (float32 torch) gives 0.00466009602, bits 0x3b98b3b8 (reference/RESULTS.md 3.2b) */
    TU_CHECK(bits == 0x3b98b3b8u, "alphas_cumprod[999] = %.9g (bits %08x), diffusers has 0.00466009602 (3b98b3b8)", a, bits);
    TU_CHECK(fabsf(sqrtf(1.0f - a) - 0.997667253f) < 1e-7f, "sqrt(1 - a) = %.9g", sqrtf(1.0f - a));
    TU_CHECK(supermat__nearest(4, 3, 5) == 2 && supermat__nearest(5, 3, 6) == 2 && supermat__nearest(2, 5, 3) == 3, "nearest index rule");
    TU_CHECK(supermat__f32_to_f16(1.0f) == 0x3c00 && supermat__f32_to_f16(-2.0f) == 0xc000 && supermat__f32_to_f16(65504.0f) == 0x7bff &&
             supermat__f32_to_f16(5.9604644775390625e-08f) == 0x0001 && supermat__f32_to_f16(1e-9f) == 0 && supermat__f32_to_f16(1.00048828125f) == 0x3c00 &&
             supermat__f32_to_f16(1.00146484375f) == 0x3c02 && supermat__f32_to_bf16(1.0f) == 0x3f80 && supermat__f32_to_bf16(1.00390625f) == 0x3f80,
             "f32 -> f16 / bf16 rounding (nearest even)");
    { /* every f16 value round-trips */
        int h, ok = 1;
        for (h = 0; h < 0x7c00; h++) if (supermat__f32_to_f16(supermat__f16_to_f32((uint16_t)h)) != h) { ok = 0; break; }
        TU_CHECK(ok, "f16 round trip fails at %04x", h);
    }
    TU_CHECK(supermat__f16_to_f32(0x3c00) == 1.0f && supermat__f16_to_f32(0xc000) == -2.0f && supermat__f16_to_f32(0x0001) == 5.9604644775390625e-08f &&
             supermat__bf16_to_f32(0x3f80) == 1.0f, "f16/bf16 conversion");
}

static void test_json(void) {
    const char *ok = "{\"a\": [1, 2, {\"b\": \"x\\u00e9\\n\"}], \"c\": -3.5e1, \"d\": {}, \"e\": []}";
    const char *bad[] = {"{", "{\"a\":}", "[1,]", "{\"a\" 1}", "[1 2]", "{} x", "\"abc", "{\"a\":1,}", "[\"\\q\"]", "", "{\"a\":[1,{]}"};
    supermat_json_tok t[64];
    int n = supermat_json_parse(ok, strlen(ok), t, 64), a, b, i;
    double x = 0;
    char s[16];
    TU_CHECK(n == 14, "json token count %d", n);
    a = supermat_json_find(ok, t, 0, "a");
    TU_CHECK(a == 2 && t[a].size == 3, "json find a");
    b = supermat_json_find(ok, t, a + 3, "b");
    TU_CHECK(b > 0 && supermat_json_string(ok, &t[b], s, sizeof s) == 4 && !strcmp(s, "x\xc3\xa9\n"), "json string unescape");
    TU_CHECK(supermat_json_number(ok, &t[supermat_json_find(ok, t, 0, "c")], &x) == 0 && x == -35.0, "json number");
    TU_CHECK(supermat_json_find(ok, t, 0, "e") == 13 && supermat_json_find(ok, t, 0, "zz") == -1, "json find e");
    TU_CHECK(supermat_json_parse(ok, strlen(ok), t, 5) < 0, "json token overflow");
    for (i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++) TU_CHECK(supermat_json_parse(bad[i], strlen(bad[i]), t, 64) < 0, "bad json %d accepted", i);
    { /* deep nesting is refused, not a stack overflow */
        char deep[300];
        memset(deep, '[', 200); deep[200] = 0;
        TU_CHECK(supermat_json_parse(deep, 200, NULL, 0) < 0, "deep nesting");
    }
}

int main(void) {
    int avx2;
    test_json();
    test_scheduler();
    test_exp();
    test_layernorm_bits();
    test_neon_twins();
    test_winograd();
    test_same_bits();
    test_bf16_compute();
    test_int8_compute();
    for (avx2 = 0; avx2 < NMODES; avx2++) {
        if (!mode_ok(avx2)) {
            printf("SKIP: this CPU (or build) has no %s: that kernel was not tested\n", avx2 == 3 ? "NEON (not aarch64)" : avx2 == 2 ? "AVX-512F" : "AVX2");
            continue;
        }
        test_gemm_conv(avx2, 1);
        test_gemm_conv(avx2, 3);
        test_attention(avx2, 1);
        test_attention(avx2, 3);
        test_quantized(avx2, 2);
        test_norms(avx2, 1);
        test_norms(avx2, 2);
        test_geglu(avx2);
        test_srgb(avx2);
        printf("kernel %s: GEMMs, convolutions, attention, quantized panels and norms against float64\n", KN(avx2));
    }
    return tu_finish("kernels");
}
