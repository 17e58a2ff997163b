/* supermat_detail, the detail step alone (the code a run's detail_sigma and supermat_uv.h's bake both run),
   through the public API, against a float64 reference written here from the formula in supermat.h:
   per channel in linear light, A' = I x clamp(G(w A) / G(w I), 1/4, 4), G three box passes of half-width
   r = round((sqrt(4 s^2 + 1) - 1) / 2), s = sigma x max(w, h), rows then columns, zero outside; where
   G(w I) < 1e-6 the ratio is sum(w A) / sum(w I); and the bounded form (limit > 1, the UV bake's):
   A' = I~ x clamp(G(w A) / G(w I), 1/4, 4) x clamp(I / I~, 1/limit, limit), I~ = G(w I) / G(w) (the weighted
   mean over the picture where G(w) < 1e-6), the last ratio 1 where I~ < 1e-6, A' = I without any weight.
   Tolerance: 2e-5 on the sRGB-encoded result (the
   implementation keeps the planes in float, ~6e-8 relative a step, and sums in double).
   - pictures of 8-bit RGBA (w = alpha), float RGB (w = 1), an explicit weight, a region (every region
     pixel written, w 0 outside it), an odd size and a padded albedo stride, a tall picture whose low-pass
     is streamed in rows (its scratch: fewer bytes than the whole plane; at 8000x8000 under 3 a pixel); ratios clipped both ways;
   - pixels outside the written set keep their exact bytes; the threaded run (a pool) gives the serial
     bytes; a caller's scratch gives the allocated run's bytes and allocates nothing;
   - the bounded form at limits 1.5, 2 and 1e6 (where it is the first form: the same values), streamed and
     threaded, and with a weight that is 0 everywhere;
   - errors: garbage-filled desc / one canary (INVALID_ARGUMENT naming the struct), sigma 0 / > 1 / NaN, limit
     1 / -1 / NaN / 2e6, a U8
     or 4-channel albedo, a size mismatch, a NaN in the picture or the albedo (NONFINITE), a scratch too
     small or misaligned, an allocator that fails (OUT_OF_MEMORY); each leaves the albedo untouched.
   usage: test_detail */
#define SUPERMAT_IMPLEMENTATION
#include "supermat.h"
#include "test_util.h"

static double lin(double v) { v = v < 0 ? 0 : v > 1 ? 1 : v; return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }
static double enc(double v) { v = v < 0 ? 0 : v > 1 ? 1 : v; return v <= 0.0031308 ? v * 12.92 : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }

static unsigned rng = 12345u;
static float frand(void) { rng = rng * 1664525u + 1013904223u; return (float)((rng >> 8) & 0xFFFF) / 65535.0f; }

/* reads channel c of pixel (x, y) of an image as supermat does (8-bit / 255) */
static double px(const supermat_image *im, int x, int y, int c) {
    size_t es = im->format == SUPERMAT_FORMAT_F32 ? 4 : 1, st = im->stride ? im->stride : (size_t)im->width * im->channels * es;
    const unsigned char *p = (const unsigned char *)im->pixels + (size_t)y * st + ((size_t)x * im->channels + c) * es;
    float v;
    if (es == 4) { memcpy(&v, p, 4); return v; }
    return *p / 255.0;
}

/* the float64 reference: out = the albedo after the step (w x h x 3), written[] = 1 where it writes;
   ref_clipped: the ratios its clamp changed */
static int ref_clipped;
static void reference(const supermat_detail_desc *d, const float *alb, size_t astride, double *out, unsigned char *written) {
    int w = d->picture.width, h = d->picture.height, c, pass, x, y, k;
    double s = (double)d->sigma * (w > h ? w : h);
    int r = (int)floor((sqrt(4.0 * s * s + 1.0) - 1.0) * 0.5 + 0.5);
    size_t n = (size_t)w * h, i;
    double *ga = (double *)malloc(n * sizeof(double)), *gi = (double *)malloc(n * sizeof(double)), *wt = (double *)malloc(n * sizeof(double));
    double *gw = (double *)malloc(n * sizeof(double)), lim = d->limit, sw = 0;
    double *t = (double *)malloc((size_t)(w > h ? w : h) * sizeof(double));
    if (r < 1) r = 1;
    ref_clipped = 0;
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++) {
            double a;
            int in = !d->region.pixels || px(&d->region, x, y, 0) > 0.0;
            a = d->weight.pixels ? px(&d->weight, x, y, 0) : d->picture.channels == 4 ? px(&d->picture, x, y, 3) : 1.0;
            a = a < 0 ? 0 : a > 1 ? 1 : a;
            wt[(size_t)y * w + x] = gw[(size_t)y * w + x] = in ? a : 0.0;
            sw += in ? a : 0.0;
            written[(size_t)y * w + x] = (unsigned char)(d->region.pixels ? in : a > 0.0);
        }
    for (c = 0; c < 3; c++) {
        double sa = 0, si = 0, gr;
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++) {
                i = (size_t)y * w + x;
                ga[i] = wt[i] > 0 ? wt[i] * lin(*((const float *)(const void *)((const unsigned char *)alb + y * astride) + x * 3 + c)) : 0.0;
                gi[i] = wt[i] > 0 ? wt[i] * lin(px(&d->picture, x, y, c)) : 0.0;
                sa += ga[i]; si += gi[i];
            }
        gr = sa > 0 && si > 0 ? sa / si : 1.0;
        if (c == 0) /* G(w), the bounded form's */
            for (pass = 0; pass < 3; pass++) {
                int dir, l;
                for (dir = 0; dir < 2; dir++)
                    for (l = 0; l < (dir ? w : h); l++) {
                        int len = dir ? h : w;
                        for (k = 0; k < len; k++) t[k] = dir ? gw[(size_t)k * w + l] : gw[(size_t)l * w + k];
                        for (k = 0; k < len; k++) {
                            double acc = 0;
                            int j;
                            for (j = k - r; j <= k + r; j++) if (j >= 0 && j < len) acc += t[j];
                            if (dir) gw[(size_t)k * w + l] = acc; else gw[(size_t)l * w + k] = acc;
                        }
                    }
            }
        for (pass = 0; pass < 3; pass++) {
            int dir, m;
            for (dir = 0; dir < 2; dir++)
                for (m = 0; m < 2; m++) {
                    double *g = m ? gi : ga;
                    int lines = dir ? w : h, len = dir ? h : w, l;
                    for (l = 0; l < lines; l++) {
                        for (k = 0; k < len; k++) t[k] = dir ? g[(size_t)k * w + l] : g[(size_t)l * w + k];
                        for (k = 0; k < len; k++) {
                            double acc = 0;
                            int j;
                            for (j = k - r; j <= k + r; j++) if (j >= 0 && j < len) acc += t[j];
                            if (dir) g[(size_t)k * w + l] = acc; else g[(size_t)l * w + k] = acc;
                        }
                    }
                }
        }
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++) {
                double q, a0 = *((const float *)(const void *)((const unsigned char *)alb + y * astride) + x * 3 + c);
                i = (size_t)y * w + x;
                if (!written[i]) { out[i * 3 + c] = a0; continue; }
                if (lim > 0) { /* the bounded form */
                    double li = gw[i] > 1e-6 ? gi[i] / gw[i] : sw > 0 ? si / sw : 1.0, p = lin(px(&d->picture, x, y, c)), q0, gain;
                    if (!(sw > 0)) { out[i * 3 + c] = enc(p); continue; }
                    gain = gi[i] > 1e-6 ? ga[i] / gi[i] : gr;
                    gain = gain < 0.25 ? 0.25 : gain > 4 ? 4 : gain;
                    q0 = q = li > 1e-6 ? p / li : 1.0;
                    q = q < 1.0 / lim ? 1.0 / lim : q > lim ? lim : q;
                    ref_clipped += q != q0;
                    out[i * 3 + c] = enc(li * gain * q);
                    continue;
                }
                q = gi[i] > 1e-6 ? ga[i] / gi[i] : gr;
                ref_clipped += q < 0.25 || q > 4;
                q = q < 0.25 ? 0.25 : q > 4 ? 4 : q;
                out[i * 3 + c] = enc(lin(px(&d->picture, x, y, c)) * q);
            }
    }
    free(ga); free(gi); free(wt); free(gw); free(t);
}

/* one case: the step against the reference, untouched pixels exact; returns the worst difference */
static double check_case(supermat_detail_desc d, const char *what) {
    int w = d.picture.width, h = d.picture.height, x, y, c, changed = 0, same = 1;
    size_t astride = d.albedo.stride ? d.albedo.stride : (size_t)w * 12, n = (size_t)w * h, i;
    float *before = (float *)malloc(astride * h), *alb = (float *)d.albedo.pixels;
    double *ref = (double *)malloc(n * 3 * sizeof(double)), worst = 0;
    unsigned char *written = (unsigned char *)malloc(n);
    supermat_error err;
    supermat_result r;
    memcpy(before, alb, astride * h);
    reference(&d, before, astride, ref, written);
    r = supermat_detail(&d, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%s: %s", what, err.message);
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++)
            for (c = 0; c < 3; c++) {
                const float *a = (const float *)(const void *)((const unsigned char *)alb + y * astride) + x * 3 + c;
                const float *b = (const float *)(const void *)((const unsigned char *)before + y * astride) + x * 3 + c;
                double e;
                i = (size_t)y * w + x;
                if (!written[i]) { if (memcmp(a, b, 4)) same = 0; continue; }
                e = fabs(*a - ref[i * 3 + c]);
                if (e > worst) worst = e;
                if (*a != *b) changed++;
            }
    TU_CHECK(worst <= 2e-5, "%s: worst %.3g from the float64 reference (tolerance 2e-5)", what, worst);
    TU_CHECK(same, "%s: pixels outside the written set changed", what);
    TU_CHECK(changed > 0, "%s: the step changed nothing", what);
    if (d.albedo.stride) { /* the padding between rows is never written */
        for (y = 0; y < h; y++) if (memcmp((const unsigned char *)alb + y * astride + (size_t)w * 12, (const unsigned char *)before + y * astride + (size_t)w * 12, astride - (size_t)w * 12)) same = 0;
        TU_CHECK(same, "%s: the row padding changed", what);
    }
    printf("%s: %dx%d sigma %g limit %g, worst %.2e from the float64 reference, %d channel values changed, %d clipped ratios\n", what,
           w, h, (double)d.sigma, (double)d.limit, worst, changed, ref_clipped);
    memcpy(alb, before, astride * h);
    free(before); free(ref); free(written);
    return worst;
}

int main(void) {
    enum { W = 61, H = 47 };
    static unsigned char rgba[W * H * 4], wt8[W * H], reg8[W * H], scratch_buf[1 << 20];
    static float rgbf[W * H * 3], alb[W * H * 3], albp[H * (W * 3 + 5)], albcopy[W * H * 3], alb2[W * H * 3];
    supermat_detail_desc d, base;
    supermat_error err;
    supermat_result r;
    size_t bytes = 0, i;
    int x, y, k;
    for (y = 0; y < H; y++)
        for (x = 0; x < W; x++) {
            i = (size_t)y * W + x;
            /* a lit picture: a smooth light times a fine pattern; the albedo: the pattern blurred, darker on one
               side (ratios near 1/4 and 4 get clipped) */
            double light = 0.2 + 0.8 * x / (W - 1.0), pat = ((x / 3 + y / 2) & 1) ? 0.9 : 0.3;
            for (k = 0; k < 3; k++) {
                double v = enc(lin(pat * (0.6 + 0.2 * k)) * light);
                rgba[i * 4 + k] = (unsigned char)(v * 255 + 0.5);
                rgbf[i * 3 + k] = (float)v;
                alb[i * 3 + k] = (float)(y < H / 3 ? 0.02 + 0.05 * frand() : y < 2 * H / 3 ? 0.3 + 0.4 * frand() : 0.97 + 0.03 * frand());
            }
            rgba[i * 4 + 3] = (unsigned char)(x < 5 ? 0 : x < 12 ? 40 * (x - 4) % 256 : 255); /* transparent, soft, opaque */
            wt8[i] = (unsigned char)(((x + y) % 7) ? 255 : 0);
            reg8[i] = (unsigned char)(x > 8 && y > 4 && x < W - 6 ? 1 : 0);
        }
    memset(&base, 0, sizeof base);
    base.sigma = 1.0f / 16.0f;
    base.picture.pixels = rgba; base.picture.width = W; base.picture.height = H; base.picture.channels = 4;
    base.albedo.pixels = alb; base.albedo.channels = 3; base.albedo.format = SUPERMAT_FORMAT_F32;

    check_case(base, "8-bit RGBA, w = alpha");
    d = base; d.sigma = 1.0f; check_case(d, "8-bit RGBA, sigma 1");
    d = base; d.sigma = 1e-4f; check_case(d, "8-bit RGBA, sigma 1e-4 (r 1)");
    d = base; d.picture.pixels = rgbf; d.picture.channels = 3; d.picture.format = SUPERMAT_FORMAT_F32; check_case(d, "float RGB, w = 1");
    d = base; d.weight.pixels = wt8; d.weight.width = W; d.weight.height = H; d.weight.channels = 1; check_case(d, "explicit weight");
    d.region.pixels = reg8; d.region.width = W; d.region.height = H; d.region.channels = 1; check_case(d, "weight + region");
    d = base; d.picture.width = W - 4; d.picture.height = H - 2; d.picture.stride = (size_t)W * 4;
    d.albedo.pixels = albp; d.albedo.stride = (W * 3 + 5) * sizeof(float);
    for (y = 0; y < H; y++) for (x = 0; x < W * 3 + 5; x++) albp[y * (W * 3 + 5) + x] = x < W * 3 ? alb[y * W * 3 + x] : -7.0f;
    check_case(d, "odd size, strided picture and albedo");

    /* the bounded form (the UV bake's): clamps that bite both ways at 1.5, fewer at 2; at 1e6 it is the first
       form without the clamp, so where neither clamps the two agree */
    d = base; d.limit = 1.5f; check_case(d, "bounded 1.5, 8-bit RGBA, w = alpha");
    TU_CHECK(ref_clipped > 100, "bounded 1.5: %d ratios clipped (the case must exercise the clamp)", ref_clipped);
    d.weight.pixels = wt8; d.weight.width = W; d.weight.height = H; d.weight.channels = 1;
    d.region.pixels = reg8; d.region.width = W; d.region.height = H; d.region.channels = 1; d.limit = 2.0f;
    check_case(d, "bounded 2, weight + region");
    d = base; d.picture.pixels = rgbf; d.picture.channels = 3; d.picture.format = SUPERMAT_FORMAT_F32; d.limit = 1e6f;
    check_case(d, "bounded 1e6, float RGB");
    TU_CHECK(ref_clipped == 0, "bounded 1e6: %d ratios clipped", ref_clipped);
    d.limit = 0.0f; check_case(d, "float RGB, w = 1 (again: its clamped gains)"); d.limit = 1e6f;
    {
        static float a1[W * H * 3];
        int agree = 0, total = 0;
        memcpy(albcopy, alb, sizeof alb);
        r = supermat_detail(&d, &err);
        memcpy(a1, alb, sizeof alb); memcpy(alb, albcopy, sizeof alb);
        d.limit = 0.0f;
        r = r ? r : supermat_detail(&d, &err);
        for (i = 0; i < (size_t)W * H * 3; i++) { total++; agree += fabs(alb[i] - a1[i]) <= 2e-5; }
        memcpy(alb, albcopy, sizeof alb);
        TU_CHECK(r == SUPERMAT_SUCCESS && agree == total, "bounded 1e6 = the first form: %d of %d values within 2e-5 (%s)", agree, total, err.message);
        printf("bounded 1e6 against the first form (its gain clamped on %d ratios): %d of %d values within 2e-5\n", ref_clipped, agree, total);
    }
    { /* no weight anywhere: the region takes the picture */
        static unsigned char zero8[W * H];
        d = base; d.limit = 1.5f;
        d.weight.pixels = zero8; d.weight.width = W; d.weight.height = H; d.weight.channels = 1;
        d.region.pixels = reg8; d.region.width = W; d.region.height = H; d.region.channels = 1;
        check_case(d, "bounded 1.5, a weight of 0 everywhere");
    }

    /* a tall picture: the low-pass streamed in rows (three rings of 2r + 18 rows, fewer than the picture's),
       against the same reference; a pool gives the serial bytes; the scratch is less than the whole plane
       (24 bytes a pixel), and at 8000x8000 with sigma 1/64 under 3 bytes a pixel (before: 8) */
    {
        enum { TW = 23, TH = 160 };
        static unsigned char trgba[TW * TH * 4];
        static float talb[TW * TH * 3], tkeep[TW * TH * 3];
        supermat_pool *pool = NULL;
        supermat_threading hook;
        supermat_detail_desc t;
        for (y = 0; y < TH; y++)
            for (x = 0; x < TW; x++) {
                i = (size_t)y * TW + x;
                for (k = 0; k < 4; k++) trgba[i * 4 + k] = rgba[((size_t)(y % H) * W + x) * 4 + k];
                for (k = 0; k < 3; k++) talb[i * 3 + k] = alb[((size_t)(y % H) * W + x) * 3 + k];
            }
        memset(&t, 0, sizeof t);
        t.sigma = 1.0f / 32.0f;
        t.picture.pixels = trgba; t.picture.width = TW; t.picture.height = TH; t.picture.channels = 4;
        t.albedo.pixels = talb; t.albedo.channels = 3; t.albedo.format = SUPERMAT_FORMAT_F32;
        check_case(t, "tall 23x160, sigma 1/32 (streamed rows)");
        t.limit = 1.5f; check_case(t, "tall 23x160, sigma 1/32, bounded 1.5 (streamed rows)");
        {
            supermat_pool *bp = NULL;
            supermat_threading bh;
            static float bser[TW * TH * 3];
            memcpy(tkeep, talb, sizeof talb);
            r = supermat_detail(&t, &err);
            memcpy(bser, talb, sizeof talb); memcpy(talb, tkeep, sizeof talb);
            memset(&bh, 0, sizeof bh);
            if (r == SUPERMAT_SUCCESS && supermat_pool_create(3, NULL, &bp, &bh) == SUPERMAT_SUCCESS) {
                t.threading = bh;
                r = supermat_detail(&t, &err);
                TU_CHECK(r == SUPERMAT_SUCCESS && !memcmp(talb, bser, sizeof talb), "bounded, tall: a pool of 3 threads gives the serial bytes (%s)", err.message);
                memcpy(talb, tkeep, sizeof talb);
                supermat_pool_destroy(bp);
                t.threading.parallel_for = NULL; t.threading.user = NULL; t.threading.max_threads = 0;
            }
        }
        t.limit = 0.0f;
        t.sigma = 1e-4f; check_case(t, "tall 23x160, sigma 1e-4 (streamed rows, r 1)");
        t.sigma = 1.0f / 32.0f;
        r = supermat_detail_memory(&t, &bytes, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS && bytes < (size_t)TW * TH * 24, "tall picture: %lu bytes of scratch, want fewer than the whole plane's %lu", (unsigned long)bytes, (unsigned long)TW * TH * 24);
        memcpy(tkeep, talb, sizeof talb);
        r = supermat_detail(&t, &err);
        memset(&hook, 0, sizeof hook);
        if (r == SUPERMAT_SUCCESS && supermat_pool_create(3, NULL, &pool, &hook) == SUPERMAT_SUCCESS) {
            static float serial[TW * TH * 3];
            memcpy(serial, talb, sizeof talb); memcpy(talb, tkeep, sizeof talb);
            t.threading = hook;
            r = supermat_detail(&t, &err);
            TU_CHECK(r == SUPERMAT_SUCCESS && !memcmp(talb, serial, sizeof talb), "tall picture: a pool of 3 threads gives the serial bytes (%s)", err.message);
            supermat_pool_destroy(pool);
            t.threading.parallel_for = NULL; t.threading.user = NULL; t.threading.max_threads = 0;
        }
        t.picture.width = t.picture.height = 8000; t.sigma = 1.0f / 64.0f; /* sized only: the pixels are not read */
        r = supermat_detail_memory(&t, &bytes, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS && bytes < (size_t)3 * 8000 * 8000, "8000x8000, sigma 1/64: %.2f bytes a pixel of scratch (want < 3)", (double)bytes / 64e6);
        printf("scratch: 8000x8000 at sigma 1/64 %.2f bytes a pixel (the whole plane would be 24)\n", (double)bytes / 64e6);
    }

    /* the built-in pool, and a caller's scratch: the same bytes as the serial, allocating run */
    {
        supermat_pool *pool = NULL;
        supermat_threading hook;
        tu_counting cnt;
        memcpy(albcopy, alb, sizeof alb);
        d = base; d.weight.pixels = wt8; d.weight.width = W; d.weight.height = H; d.weight.channels = 1;
        r = supermat_detail(&d, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS, "serial run: %s", err.message);
        memcpy(alb2, alb, sizeof alb); memcpy(alb, albcopy, sizeof alb);
        memset(&hook, 0, sizeof hook);
        if (supermat_pool_create(4, NULL, &pool, &hook) == SUPERMAT_SUCCESS) {
            d.threading = hook;
            r = supermat_detail(&d, &err);
            TU_CHECK(r == SUPERMAT_SUCCESS && !memcmp(alb, alb2, sizeof alb), "a pool of 4 threads gives the serial bytes (%s)", err.message);
            memcpy(alb, albcopy, sizeof alb);
            r = supermat_detail_memory(&d, &bytes, &err);
            TU_CHECK(r == SUPERMAT_SUCCESS && bytes > (size_t)W * H * 8, "detail memory with 4 threads: %lu bytes", (unsigned long)bytes);
            supermat_pool_destroy(pool);
            d.threading.parallel_for = NULL; d.threading.user = NULL; d.threading.max_threads = 0;
        }
        r = supermat_detail_memory(&d, &bytes, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS && bytes >= (size_t)W * H * 8 && bytes <= sizeof scratch_buf, "detail memory: %lu bytes", (unsigned long)bytes);
        memset(&cnt, 0, sizeof cnt); cnt.fail_at = 1000; /* counts the calls (tu_count_alloc counts when fail_at >= 0) */
        d.allocator.alloc = tu_count_alloc; d.allocator.free = tu_count_free; d.allocator.user = &cnt;
        d.scratch = scratch_buf; d.scratch_size = bytes;
        r = supermat_detail(&d, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS && !memcmp(alb, alb2, sizeof alb) && cnt.calls == 0, "a caller's scratch: the same bytes, %ld allocations (%s)", cnt.calls, err.message);
        memcpy(alb, albcopy, sizeof alb);
        d.scratch = NULL; d.scratch_size = 0;
        r = supermat_detail(&d, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS && cnt.calls == 1 && cnt.live == 0, "without scratch: one allocation, freed (%ld calls, %ld live)", cnt.calls, cnt.live);
        memcpy(alb, albcopy, sizeof alb);
    }

    /* errors: each refused with its result and a message, the albedo untouched */
    memcpy(albcopy, alb, sizeof alb);
    for (k = 0; k < 20; k++) {
        supermat_result want = SUPERMAT_ERROR_INVALID_ARGUMENT;
        const char *needle = NULL;
        tu_counting cnt;
        float nanv = (float)NAN, keep = 0;
        d = base;
        memset(&cnt, 0, sizeof cnt); cnt.fail_at = -1;
        switch (k) {
        case 0: memset(&d, 0xA5, sizeof d); d.sigma = 0.1f; d.picture = base.picture; d.albedo = base.albedo; needle = "supermat_detail_desc"; break;
        case 1: d._start_canary = 1; needle = "canary"; break;
        case 2: d._end_canary = 0xFFFFFFFFu; needle = "canary"; break;
        case 3: d.sigma = 0.0f; needle = "sigma"; break;
        case 4: d.sigma = 1.5f; needle = "sigma"; break;
        case 5: d.sigma = nanv; needle = "sigma"; break;
        case 6: d.albedo.format = SUPERMAT_FORMAT_U8; want = SUPERMAT_ERROR_BAD_IMAGE; needle = "albedo"; break;
        case 7: d.albedo.channels = 4; want = SUPERMAT_ERROR_BAD_IMAGE; needle = "albedo"; break;
        case 8: d.albedo.width = W - 1; want = SUPERMAT_ERROR_BAD_IMAGE; needle = "albedo"; break;
        case 9: d.weight.pixels = wt8; d.weight.width = W; d.weight.height = H + 1; d.weight.channels = 1; want = SUPERMAT_ERROR_BAD_IMAGE; needle = "weight"; break;
        case 10: keep = alb[100]; alb[100] = nanv; want = SUPERMAT_ERROR_NONFINITE; needle = "albedo"; break;
        case 11: d.picture.pixels = rgbf; d.picture.channels = 3; d.picture.format = SUPERMAT_FORMAT_F32; keep = rgbf[7]; rgbf[7] = (float)INFINITY; want = SUPERMAT_ERROR_NONFINITE; needle = "picture"; break;
        case 12: d.scratch = scratch_buf; d.scratch_size = 64; needle = "scratch"; break;
        case 13: d.scratch = scratch_buf + 4; d.scratch_size = sizeof scratch_buf - 4; needle = "aligned"; break;
        case 14: d.allocator.alloc = tu_count_alloc; d.allocator.free = tu_count_free; d.allocator.user = &cnt; cnt.fail_at = 0; want = SUPERMAT_ERROR_OUT_OF_MEMORY; needle = "memory"; break;
        case 15: d.picture.channels = 2; want = SUPERMAT_ERROR_BAD_IMAGE; needle = "picture"; break;
        case 16: d.limit = 1.0f; needle = "limit"; break;
        case 17: d.limit = -1.0f; needle = "limit"; break;
        case 18: d.limit = nanv; needle = "limit"; break;
        case 19: d.limit = 2e6f; needle = "limit"; break;
        }
        memset(&err, 0, sizeof err);
        r = supermat_detail(&d, &err);
        if (k == 10) alb[100] = keep;
        if (k == 11) rgbf[7] = keep;
        TU_CHECK(r == want && strstr(err.message, needle) && !memcmp(alb, albcopy, sizeof alb), "error case %d: %s (%s), want %s with '%s'", k,
                 supermat_result_string(r), err.message, supermat_result_string(want), needle);
        if (k == 0) printf("garbage desc: %s\n", err.message);
    }
    r = supermat_detail(NULL, &err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT, "a NULL desc");
    return tu_finish("test_detail");
}
