/* The speed / memory levers of a session against independent references (tiny official-architecture
   models):
   - VAE tiles: the tiled encode / decode equals, to float rounding, encoding / decoding every tile
     alone in a session of the tile's size (the stage injected through the inspect hook) and blending
     the tiles with this file's own float64 linear ramps; a tile larger than the image is bit-identical
     to no tiling; the layout covers every size with the asked overlap.
   - Background skipping: foreground pixels bit-identical to tiling without skipping, background
     pixels of skipped tiles 0.5, decode FLOPs = the decoded tiles' share (counted here), all-alpha-0
     decodes nothing, images without alpha skip nothing; UV charts (given, or from the mask and the
     off-chart position gray) keep every chart texel, seen or not.
   - Work size: the network input equals this file's float64 triangle-filter resampling of the
     composited image; the work size equal to the image size is bit-identical to the default.
   - Resized back: a 70x300 picture's maps (work size 32) against this file's float64 resampling of the
     decode (the DECODED stage, at the work size), and its detail step (streamed in rows) against the
     float64 detail reference; the session plan for 8000x8000 under 4 bytes a pixel.
   - Restricted multi-view attention: a key stride of 1 (every key, gathered per view) equals the full
     attention; own view and stride 2 change the maps, stay in range, and do not depend on threads.
   - Detail (detail_sigma): the albedo against a float64 reference of the documented formula from the
     same session's albedo without it; alpha-0 pixels and roughness / metallic untouched.
   - Invalid option combinations fail with clear errors.
   usage: test_levers MODEL MV_MODEL UV_MODEL */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include "test_util.h"

#define S 64 /* image size of the pipeline checks (latent 8x8) */

static supermat_model *load(const char *path, unsigned char **data) {
    size_t size = 0;
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    *data = tu_load(path, &size);
    if (!*data) { TU_CHECK(0, "cannot read %s", path); return NULL; }
    memset(&md, 0, sizeof md); md.data = *data; md.size = size;
    if (supermat_model_create(&md, &m, &err)) { TU_CHECK(0, "%s: %s", path, err.message); return NULL; }
    return m;
}

/* ---- stage capture / injection through the inspect hook ---- */
typedef struct cap {
    supermat_stage want;     /* captured */
    float *got[2]; int n, h, w, c;
    supermat_stage inject;   /* overwritten (COUNT = none) */
    const float *src[2];
} cap;
static void cap_fn(void *user, supermat_stage st, int b, float *d, int n, int h, int w, int c) {
    cap *k = (cap *)user;
    size_t sz = (size_t)n * h * w * c;
    if (b > 1) return;
    if (st == k->inject && k->src[b]) memcpy(d, k->src[b], sizeof(float) * sz);
    if (st == k->want) {
        free(k->got[b]);
        k->got[b] = (float *)malloc(sizeof(float) * sz);
        memcpy(k->got[b], d, sizeof(float) * sz);
        k->n = n; k->h = h; k->w = w; k->c = c;
    }
}

typedef struct opts { int tile, overlap, skip, ww, wh, mv_att, stride, threads; unsigned outputs; float detail, chroma; } opts;

/* one single-view run: fills albedo (RGB) / orm (RGB) float outputs and the capture */
static int run1(supermat_model *m, const opts *o, int w, int h, const unsigned char *px, int ch, float *albedo, float *orm,
                cap *k, supermat_flops *fl, supermat_flops *last) {
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_error err;
    int r;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = w; sd.height = h; sd.threads = o->threads ? o->threads : 2; sd.outputs = o->outputs;
    sd.vae_tile = o->tile; sd.vae_overlap = o->overlap; sd.skip_background = o->skip; sd.work_width = o->ww; sd.work_height = o->wh;
    sd.detail_sigma = o->detail;
    sd.chroma_weight = o->chroma;
    if (supermat_session_create(&sd, &s, &err)) { TU_CHECK(0, "session: %s", err.message); return -1; }
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = (void *)px; rd.input.width = w; rd.input.height = h; rd.input.channels = ch;
    if (albedo) { rd.albedo.pixels = albedo; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32; }
    if (orm) { rd.orm.pixels = orm; rd.orm.channels = 3; rd.orm.format = SUPERMAT_FORMAT_F32; }
    if (k) { rd.inspect = cap_fn; rd.inspect_user = k; }
    r = supermat_run(s, &rd, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "run: %s", err.message);
    if (fl) supermat_session_flops(s, fl);
    if (last) supermat_session_last_flops(s, last);
    supermat_session_destroy(s);
    return r;
}

static int same(const float *a, const float *b, size_t n) { return memcmp(a, b, n * sizeof(float)) == 0; }

/* ---- layout and blending, float64, written independently of the library ---- */
static double ramp64(int x, const int *st, int n, int i, int t) {
    double w = 1.0;
    if (i > 0 && x < st[i - 1] + t) { double v = (x - st[i] + 0.5) / (st[i - 1] + t - st[i]); if (v < w) w = v; }
    if (i + 1 < n && x >= st[i + 1]) { double v = (st[i] + t - x - 0.5) / (st[i] + t - st[i + 1]); if (v < w) w = v; }
    return w;
}

static void test_layout(void) {
    int len, t, ov, bad = 0, badsum = 0;
    for (len = 1; len <= 90; len++)
        for (t = 2; t <= 12; t++)
            for (ov = 0; ov < t; ov++) {
                int st[256], n = supermat__tiles(len, t, ov, st, 256), i, x;
                if (t >= len) { if (n != 1 || st[0] != 0) bad++; continue; }
                if (st[0] != 0 || st[n - 1] + t != len) bad++;
                for (i = 1; i < n; i++) if (st[i] <= st[i - 1] || st[i - 1] + t - st[i] < ov || st[i] > st[i - 1] + t) bad++;
                for (x = 0; x < len; x++) { /* where exactly two tiles meet, the ramps sum to 1 */
                    int cover = 0, j;
                    double sum = 0.0;
                    for (j = 0; j < n; j++) if (x >= st[j] && x < st[j] + t) { cover++; sum += supermat__ramp(x, st[j], t, j > 0, j > 0 ? st[j - 1] + t : 0, j + 1 < n, j + 1 < n ? st[j + 1] : 0); }
                    if (cover == 0 || sum <= 0.0 || (cover == 2 && fabs(sum - 1.0) > 1e-6)) badsum++;
                }
            }
    TU_CHECK(bad == 0, "tile layout: %d bad layouts (coverage, order, overlap)", bad);
    TU_CHECK(badsum == 0, "tile blend weights: %d positions uncovered or not summing to 1", badsum);
}

/* float64 triangle filter (PIL BILINEAR semantics) along both axes */
static void resample64(const float *src, int sh, int sw, int c, double *dst, int dh, int dw) {
    double *tmp = (double *)calloc((size_t)sh * dw * c, sizeof(double));
    int pass;
    for (pass = 0; pass < 2; pass++) {
        int lin = pass ? sh : sw, lout = pass ? dh : dw, lines = pass ? dw : sh, o, l, ch, i;
        double scale = (double)lin / lout, sup = scale > 1 ? scale : 1;
        for (o = 0; o < lout; o++) {
            double ctr = (o + 0.5) * scale, ws = 0;
            for (i = 0; i < lin; i++) { double wt = 1 - fabs((i + 0.5 - ctr) / sup); if (wt > 0) ws += wt; }
            for (l = 0; l < lines; l++)
                for (ch = 0; ch < c; ch++) {
                    double acc = 0;
                    for (i = 0; i < lin; i++) {
                        double wt = 1 - fabs((i + 0.5 - ctr) / sup), v;
                        if (wt <= 0) continue;
                        v = pass ? tmp[((size_t)i * dw + l) * c + ch] : (double)src[((size_t)l * sw + i) * c + ch];
                        acc += wt * v;
                    }
                    if (pass) dst[((size_t)o * dw + l) * c + ch] = acc / ws;
                    else tmp[((size_t)l * dw + o) * c + ch] = acc / ws;
                }
        }
    }
    free(tmp);
}

static void test_resample_props(void) {
    float src[16 * 3], dst[8 * 3], up[32 * 3];
    int i;
    for (i = 0; i < 16 * 3; i++) src[i] = 0.25f;
    supermat__resample_axis(src, 16, 8, 0, 8, 3, 3, 1, 16 * 3, 8 * 3, 3, dst);
    for (i = 0; i < 8 * 3; i++) TU_CHECK(fabsf(dst[i] - 0.25f) < 1e-7f, "constant through a 2x reduction: %g", (double)dst[i]);
    for (i = 0; i < 16; i++) src[i * 3] = src[i * 3 + 1] = src[i * 3 + 2] = (float)(i * i % 7);
    supermat__resample_axis(src, 16, 8, 0, 8, 3, 3, 1, 16 * 3, 8 * 3, 3, dst); /* interior taps 1/8, 3/8, 3/8, 1/8 */
    for (i = 1; i < 7; i++) {
        double want = (src[(2 * i - 1) * 3] + 3.0 * src[2 * i * 3] + 3.0 * src[(2 * i + 1) * 3] + src[(2 * i + 2) * 3]) / 8.0;
        TU_CHECK(fabs(dst[i * 3] - want) < 1e-5, "2x reduction tap weights at %d: %g vs %g", i, (double)dst[i * 3], want);
    }
    supermat__resample_axis(src, 16, 32, 0, 32, 3, 3, 1, 16 * 3, 32 * 3, 3, up); /* bilinear enlargement: 0.75 / 0.25 */
    for (i = 1; i < 31; i++) {
        int a = (i - 1) / 2, b = a + 1;
        double want = (i % 2) ? 0.75 * src[a * 3] + 0.25 * src[b * 3] : 0.25 * src[a * 3] + 0.75 * src[b * 3];
        if (i % 2 == 0) { a = i / 2 - 1; b = i / 2; want = 0.25 * src[a * 3] + 0.75 * src[b * 3]; }
        TU_CHECK(fabs(up[i * 3] - want) < 1e-5, "2x enlargement at %d: %g vs %g", i, (double)up[i * 3], want);
    }
}

/* ---- tiled VAE vs tiles run alone ---- */
static void test_tiles(supermat_model *m, const unsigned char *img) {
    static float a0[S * S * 3], a1[S * S * 3], o0[S * S * 3], o1[S * S * 3];
    opts o;
    cap full, ref;
    int tl = 40, ov = 16, st[8], n, ty, tx, b, y, x, c, enc;
    double *acc[2], *wsum;
    /* a tile larger than the image: no tiling at all, bit for bit */
    memset(&o, 0, sizeof o);
    run1(m, &o, S, S, img, 4, a0, o0, NULL, NULL, NULL);
    o.tile = 128; o.overlap = 16;
    run1(m, &o, S, S, img, 4, a1, o1, NULL, NULL, NULL);
    TU_CHECK(same(a0, a1, S * S * 3) && same(o0, o1, S * S * 3), "a tile covering the image changed the maps");
    /* 2x2 tiles of 40 pixels (5 latents) */
    n = supermat__tiles(S / 8, tl / 8, ov / 8, st, 8);
    TU_CHECK(n == 2 && st[1] == 3, "layout of 64 px in 40 px tiles: n %d, start %d", n, st[1]);
    for (enc = 0; enc < 2; enc++) {
        int lat = !enc, unit = enc ? 1 : 8, big = enc ? S / 8 : S, oc;
        memset(&full, 0, sizeof full);
        full.want = enc ? SUPERMAT_STAGE_LATENT : SUPERMAT_STAGE_DECODED; full.inject = SUPERMAT_STAGE_COUNT;
        o.tile = tl; o.overlap = ov;
        /* the tiled run, also capturing the stage input the reference needs */
        {
            cap in;
            memset(&in, 0, sizeof in);
            in.want = enc ? SUPERMAT_STAGE_INPUT : SUPERMAT_STAGE_X0; in.inject = SUPERMAT_STAGE_COUNT;
            run1(m, &o, S, S, img, 4, a1, o1, &in, NULL, NULL);
            memset(&o, 0, sizeof o); o.tile = tl; o.overlap = ov;
            run1(m, &o, S, S, img, 4, a1, o1, &full, NULL, NULL);
            oc = full.c;
            acc[0] = (double *)calloc((size_t)big * big * oc, sizeof(double));
            acc[1] = (double *)calloc((size_t)big * big * oc, sizeof(double));
            wsum = (double *)calloc((size_t)big * big, sizeof(double));
            for (ty = 0; ty < n; ty++)
                for (tx = 0; tx < n; tx++) {
                    /* the tile alone: a session of the tile's size with the stage input injected */
                    int ih = enc ? tl : tl / 8, ic = in.c, bb;
                    float *crop[2];
                    memset(&ref, 0, sizeof ref);
                    ref.want = full.want; ref.inject = in.want;
                    for (bb = 0; bb < (enc ? 1 : 2); bb++) {
                        int f = enc ? 8 : 1;
                        crop[bb] = (float *)malloc(sizeof(float) * (size_t)ih * ih * ic);
                        for (y = 0; y < ih; y++)
                            memcpy(crop[bb] + (size_t)y * ih * ic, in.got[bb] + ((size_t)(st[ty] * f + y) * in.w + (size_t)st[tx] * f) * ic, sizeof(float) * (size_t)ih * ic);
                        ref.src[bb] = crop[bb];
                    }
                    memset(&o, 0, sizeof o);
                    run1(m, &o, tl, tl, img, 4, NULL, NULL, &ref, NULL, NULL);
                    for (b = 0; b < (enc ? 1 : 2); b++) {
                        int th = tl / 8 * (lat ? 8 : 1);
                        for (y = 0; y < th; y++)
                            for (x = 0; x < th; x++) {
                                int gy = st[ty] * unit + y, gx = st[tx] * unit + x;
                                int sts[8], k;
                                double w;
                                for (k = 0; k < n; k++) sts[k] = st[k] * unit;
                                w = ramp64(gy, sts, n, ty, th) * ramp64(gx, sts, n, tx, th);
                                for (c = 0; c < oc; c++) acc[b][((size_t)gy * big + gx) * oc + c] += w * ref.got[b][((size_t)y * th + x) * oc + c];
                                if (b == 0) wsum[(size_t)gy * big + gx] += w;
                            }
                    }
                    for (bb = 0; bb < (enc ? 1 : 2); bb++) { free(crop[bb]); free(ref.got[bb]); }
                }
            for (b = 0; b < (enc ? 1 : 2); b++) {
                size_t i, np = (size_t)big * big * oc;
                float *r = (float *)malloc(sizeof(float) * np);
                for (i = 0; i < np; i++) r[i] = (float)(acc[b][i] / wsum[i / oc]);
                {
                    double e = tu_rel_l2(full.got[b], r, np);
                    printf("tiled %s branch %d vs tiles alone + float64 blend: rel L2 %.3g\n", enc ? "encode" : "decode", b, e);
                    TU_CHECK(e < 1e-5, "tiled %s branch %d: rel L2 %g vs the tiles alone", enc ? "encode" : "decode", b, e);
                }
                free(r);
            }
            for (b = 0; b < 2; b++) { free(acc[b]); free(in.got[b]); free(full.got[b]); }
            free(wsum);
            memset(&o, 0, sizeof o);
        }
    }
}

/* ---- background skipping ---- */
static void test_skip(supermat_model *m, const unsigned char *img) {
    static float a0[S * S * 3], a1[S * S * 3], o0[S * S * 3], o1[S * S * 3];
    static unsigned char rgb[S * S * 3], clear[S * S * 4];
    opts o;
    supermat_flops fl, last;
    static unsigned char covered[S * S];
    int tile = 32, ov = 16, st[16], n, ty, tx, k = 0, x, y, i, fgdiff = 0, bgbad = 0;
    n = supermat__tiles(S / 8, tile / 8, ov / 8, st, 16);
    memset(covered, 0, sizeof covered);
    for (ty = 0; ty < n; ty++)
        for (tx = 0; tx < n; tx++) {
            int any = 0;
            for (y = st[ty] * 8; y < st[ty] * 8 + tile; y++)
                for (x = st[tx] * 8; x < st[tx] * 8 + tile; x++) any |= img[((size_t)y * S + x) * 4 + 3] > 0;
            k += any;
            if (any)
                for (y = st[ty] * 8; y < st[ty] * 8 + tile; y++)
                    for (x = st[tx] * 8; x < st[tx] * 8 + tile; x++) covered[y * S + x] = 1;
        }
    memset(&o, 0, sizeof o); o.tile = tile; o.overlap = ov;
    run1(m, &o, S, S, img, 4, a0, o0, NULL, NULL, NULL);
    o.skip = 1;
    run1(m, &o, S, S, img, 4, a1, o1, NULL, &fl, &last);
    for (i = 0; i < S * S; i++) {
        int c;
        for (c = 0; c < 3; c++) {
            if (img[i * 4 + 3] > 0 && (a0[i * 3 + c] != a1[i * 3 + c] || o0[i * 3 + c] != o1[i * 3 + c])) fgdiff++;
            if (!covered[i] && (a1[i * 3 + c] != 0.5f || o1[i * 3 + c] != 0.5f)) bgbad++;
        }
    }
    TU_CHECK(k > 0 && k < n * n, "test image: %d of %d tiles hold foreground", k, n * n);
    TU_CHECK(fgdiff == 0, "skipping changed %d foreground values", fgdiff);
    TU_CHECK(bgbad == 0, "%d values outside every decoded tile are not 0.5", bgbad);
    printf("skip: %d of %d decode tiles, decode GFLOP %.4f of %.4f\n", k, n * n, last.decode / 1e9, fl.decode / 1e9);
    TU_CHECK(fabs(last.decode - fl.decode * k / (n * n)) <= 1e-9 * fl.decode, "decode FLOPs %g, expected %g (%d of %d tiles)", last.decode, fl.decode * k / (n * n), k, n * n);
    TU_CHECK(last.encode == fl.encode && last.trunk == fl.trunk, "encode / UNet FLOPs changed by skipping");
    /* nothing visible: nothing decoded, every value 0.5 */
    for (i = 0; i < S * S * 4; i++) clear[i] = (unsigned char)(i % 4 == 3 ? 0 : i * 7);
    run1(m, &o, S, S, clear, 4, a1, o1, NULL, NULL, &last);
    TU_CHECK(last.decode == 0.0, "alpha 0 everywhere: %g decode FLOPs", last.decode);
    for (i = 0; i < S * S * 3; i++) if (a1[i] != 0.5f || (i % 3 && o1[i] != 0.5f)) { TU_CHECK(0, "alpha 0 everywhere: value %g at %d", (double)a1[i], i); break; }
    /* no alpha channel: everything is foreground */
    for (i = 0; i < S * S; i++) memcpy(rgb + i * 3, img + i * 4, 3);
    o.skip = 0;
    run1(m, &o, S, S, rgb, 3, a0, o0, NULL, NULL, NULL);
    o.skip = 1;
    run1(m, &o, S, S, rgb, 3, a1, o1, NULL, &fl, &last);
    TU_CHECK(same(a0, a1, S * S * 3) && same(o0, o1, S * S * 3) && last.decode == fl.decode, "RGB input: skipping changed something");
}

static void test_skip_uv(supermat_model *m) {
    enum { U = 128 };
    static float map[U * U * 3], mask[U * U], pos[U * U * 3], chart[U * U], r0[U * U * 3], r1[U * U * 3], r2[U * U * 3];
    supermat_session_desc sd;
    supermat_session *s;
    supermat_run_desc rd;
    supermat_error err;
    supermat_flops fl, last;
    double dec[3] = {0, 0, 0};
    int i, pass, diff = 0, diff2 = 0;
    memset(&fl, 0, sizeof fl); memset(&last, 0, sizeof last);
    /* a chart in x < 40, y < 60 (position != the off-chart gray), seen (mask > 0) only where y < 30:
       the unseen chart texels must be decoded too */
    for (i = 0; i < U * U; i++) {
        int x = i % U, y = i / U, in = x < 40 && y < 60;
        mask[i] = (in && y < 30) ? 1.0f : 0.0f;
        chart[i] = in ? 1.0f : 0.0f;
        map[i * 3] = (float)(x % 17) / 16.0f; map[i * 3 + 1] = (float)(y % 13) / 12.0f; map[i * 3 + 2] = 0.5f;
        pos[i * 3] = in ? (float)x / U : 127.0f / 255.0f; pos[i * 3 + 1] = in ? (float)y / U : 127.0f / 255.0f; pos[i * 3 + 2] = in ? 0.25f : 127.0f / 255.0f;
    }
    for (pass = 0; pass < 3; pass++) { /* 0 tiles, 1 skipping (chart from mask + position), 2 skipping with `chart` */
        memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = U; sd.height = U; sd.threads = 2; sd.vae_tile = 48; sd.vae_overlap = 16; sd.skip_background = pass > 0;
        if (supermat_session_create(&sd, &s, &err)) { TU_CHECK(0, "UV session: %s", err.message); return; }
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = map; rd.input.width = U; rd.input.height = U; rd.input.channels = 3; rd.input.format = SUPERMAT_FORMAT_F32;
        rd.mask = rd.input; rd.mask.pixels = mask; rd.mask.channels = 1;
        rd.position = rd.input; rd.position.pixels = pos;
        if (pass == 2) { rd.chart = rd.mask; rd.chart.pixels = chart; }
        rd.refined.pixels = pass == 0 ? r0 : pass == 1 ? r1 : r2; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "UV run: %s", err.message);
        supermat_session_flops(s, &fl); supermat_session_last_flops(s, &last);
        dec[pass] = last.decode;
        supermat_session_destroy(s);
    }
    for (i = 0; i < U * U * 3; i++) if (chart[i / 3] > 0.0f && r0[i] != r1[i]) diff++;
    for (i = 0; i < U * U * 3; i++) if (chart[i / 3] > 0.0f && r0[i] != r2[i]) diff2++;
    TU_CHECK(diff == 0 && diff2 == 0, "UV: skipping changed %d / %d chart values (seen or not)", diff, diff2);
    printf("UV skip: decode GFLOP %.4f (chart from mask + position), %.4f (chart given) of %.4f\n", dec[1] / 1e9, dec[2] / 1e9, dec[0] / 1e9);
    TU_CHECK(dec[1] > 0.0 && dec[1] < 0.6 * dec[0] && dec[2] == dec[1], "UV: decode FLOPs %g / %g of %g", dec[1], dec[2], dec[0]);
}

/* ---- work size ---- */
static void test_work_size(supermat_model *m, const unsigned char *img) {
    static float a0[S * S * 3], a1[S * S * 3], o0[S * S * 3], o1[S * S * 3], comp[S * S * 3];
    double ref[32 * 32 * 3];
    opts o;
    cap k;
    int i, c;
    memset(&o, 0, sizeof o);
    run1(m, &o, S, S, img, 4, a0, o0, NULL, NULL, NULL);
    o.ww = S; o.wh = S;
    run1(m, &o, S, S, img, 4, a1, o1, NULL, NULL, NULL);
    TU_CHECK(same(a0, a1, S * S * 3) && same(o0, o1, S * S * 3), "work size = image size changed the maps");
    for (i = 0; i < S * S; i++)
        for (c = 0; c < 3; c++) {
            double a = img[i * 4 + 3] / 255.0, v = img[i * 4 + c] / 255.0;
            comp[i * 3 + c] = (float)((v * a + 0.5 * (1.0 - a)) * 2.0 - 1.0);
        }
    resample64(comp, S, S, 3, ref, 32, 32);
    memset(&k, 0, sizeof k); k.want = SUPERMAT_STAGE_INPUT; k.inject = SUPERMAT_STAGE_COUNT;
    o.ww = 32; o.wh = 32;
    run1(m, &o, S, S, img, 4, a1, o1, &k, NULL, NULL);
    TU_CHECK(k.got[0] && k.h == 32 && k.w == 32, "work size 32: the network input is %dx%d", k.w, k.h);
    if (k.got[0]) {
        double e = 0;
        for (i = 0; i < 32 * 32 * 3; i++) if (fabs(k.got[0][i] - ref[i]) > e) e = fabs(k.got[0][i] - ref[i]);
        printf("work size 32 of 64: input vs float64 resampling max abs %.3g; albedo vs full size rel L2 %.3g\n", e, tu_rel_l2(a1, a0, S * S * 3));
        TU_CHECK(e < 1e-5, "work size input vs float64 resampling: max abs %g", e);
    }
    for (i = 0; i < S * S * 3; i++) if (!(a1[i] >= 0.0f && a1[i] <= 1.0f && o1[i] >= 0.0f && o1[i] <= 1.0f)) { TU_CHECK(0, "work size: output %d out of [0,1]", i); break; }
    free(k.got[0]);
    {   /* a reduction by 8 (17-tap filters) against float64 */
        double r8[8 * 8 * 3], e = 0;
        memset(&k, 0, sizeof k); k.want = SUPERMAT_STAGE_INPUT; k.inject = SUPERMAT_STAGE_COUNT;
        o.ww = 8; o.wh = 8;
        run1(m, &o, S, S, img, 4, a1, o1, &k, NULL, NULL);
        resample64(comp, S, S, 3, r8, 8, 8);
        for (i = 0; k.got[0] && i < 8 * 8 * 3; i++) if (fabs(k.got[0][i] - r8[i]) > e) e = fabs(k.got[0][i] - r8[i]);
        TU_CHECK(k.got[0] && e < 1e-5, "work size 8 of 64: input vs float64 resampling max abs %g", e);
        free(k.got[0]);
    }
    o.ww = 40; o.wh = 24; /* a non-uniform scale works too */
    TU_CHECK(run1(m, &o, S, S, img, 4, a1, o1, NULL, NULL, NULL) == SUPERMAT_SUCCESS, "work size 40x24");
}

/* ---- restricted multi-view attention ---- */
static int run_mv(supermat_model *m, int att, int stride, int threads, float *out) {
    enum { V = 3, M = 32 };
    static unsigned char px[V][M * M * 4];
    supermat_image in[V], ov[V];
    float cams[V * 16];
    supermat_session_desc sd;
    supermat_session *s;
    supermat_run_desc rd;
    supermat_error err;
    int r;
    tu_mv_views(V, M, px[0], in, ov, out, cams);
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = M; sd.height = M; sd.views = V; sd.threads = threads; sd.outputs = SUPERMAT_OUTPUT_ALBEDO;
    sd.mv_attention = (supermat_mv_attention)att; sd.mv_key_stride = stride;
    if (supermat_session_create(&sd, &s, &err)) { TU_CHECK(0, "MV session: %s", err.message); return -1; }
    memset(&rd, 0, sizeof rd);
    rd.input_views = in; rd.albedo_views = ov; rd.cameras = cams;
    r = supermat_run(s, &rd, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "MV run: %s", err.message);
    supermat_session_destroy(s);
    return r;
}

static void test_mv_window(supermat_model *m) {
    enum { N = 3 * 32 * 32 * 3 };
    static float full[N], own[N], st2[N], st2b[N], st1[N];
    double e_own, e_st, e1;
    int i, s;
    run_mv(m, SUPERMAT_MV_ATTENTION_FULL, 0, 2, full);
    run_mv(m, SUPERMAT_MV_ATTENTION_STRIDED, 1, 2, st1); /* every key, gathered per view: the full attention */
    e1 = tu_rel_l2(st1, full, N);
    TU_CHECK(e1 < 1e-5, "stride 1 vs the full attention: rel L2 %g", e1);
    for (s = 2; s <= 16; s *= 2) { run_mv(m, SUPERMAT_MV_ATTENTION_STRIDED, s, 2, st2); printf("  stride %d: rel L2 %.3g\n", s, tu_rel_l2(st2, full, N)); }
    run_mv(m, SUPERMAT_MV_ATTENTION_OWN_VIEW, 0, 2, own);
    run_mv(m, SUPERMAT_MV_ATTENTION_STRIDED, 2, 2, st2);
    run_mv(m, SUPERMAT_MV_ATTENTION_STRIDED, 2, 3, st2b);
    e_own = tu_rel_l2(own, full, N); e_st = tu_rel_l2(st2, full, N);
    printf("MV window: own view rel L2 %.3g, key stride 2 %.3g (vs full attention)\n", e_own, e_st);
    for (i = 0; i < N; i++) if (!(own[i] >= 0.0f && own[i] <= 1.0f && st2[i] >= 0.0f && st2[i] <= 1.0f)) { TU_CHECK(0, "MV window: value out of [0,1]"); break; }
    TU_CHECK(e_own > 0.0 && e_st > 0.0, "restricted attention changed nothing (own %g, strided %g)", e_own, e_st);
    TU_CHECK(same(st2, st2b, N), "strided attention differs between 2 and 3 threads");
}

static void test_errors(supermat_model *m, supermat_model *mv) {
    supermat_session_desc sd;
    size_t bytes;
    supermat_error err;
    int i;
    struct { int tile, overlap, skip, ww, wh, att, stride; supermat_model *mm; const char *what; } bad[] = {
        {20, 0, 0, 0, 0, 0, 0, NULL, "tile 20"}, {36, 0, 0, 0, 0, 0, 0, NULL, "tile not a multiple of 8"},
        {64, 64, 0, 0, 0, 0, 0, NULL, "overlap = tile"}, {64, 12, 0, 0, 0, 0, 0, NULL, "overlap not a multiple of 8"},
        {0, 0, 1, 0, 0, 0, 0, NULL, "skip without tiles"}, {0, 0, 0, 30, 32, 0, 0, NULL, "work width 30"},
        {0, 0, 0, 32, 20000, 0, 0, NULL, "work height 20000"}, {0, 0, 0, 0, 0, 1, 0, NULL, "mv_attention on a single-view model"},
        {0, 0, 0, 0, 0, 2, 0, (supermat_model *)1, "stride 0"}, {0, 0, 0, 0, 0, 7, 0, (supermat_model *)1, "unknown mv_attention"},
        {32, 24, 0, 0, 0, 0, 0, NULL, "too many tiles"}};
    for (i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++) {
        memset(&sd, 0, sizeof sd);
        sd.model = bad[i].mm ? mv : m; sd.width = i == 10 ? 16384 : 64; sd.height = 64; sd.threads = 1;
        sd.vae_tile = bad[i].tile; sd.vae_overlap = bad[i].overlap; sd.skip_background = bad[i].skip;
        sd.work_width = bad[i].ww; sd.work_height = bad[i].wh; sd.mv_attention = (supermat_mv_attention)bad[i].att; sd.mv_key_stride = bad[i].stride;
        TU_CHECK(supermat_session_memory(&sd, &bytes, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT && err.message[0], "%s accepted", bad[i].what);
    }
    {   /* tiles bound the VAE's memory */
        size_t whole, tiled;
        memset(&sd, 0, sizeof sd); sd.model = m; sd.width = 1024; sd.height = 1024; sd.threads = 1;
        supermat_session_memory(&sd, &whole, &err);
        sd.vae_tile = 256; sd.vae_overlap = 32;
        supermat_session_memory(&sd, &tiled, &err);
        printf("1024x1024 session: %.1f MB whole, %.1f MB with 256-pixel VAE tiles\n", whole / 1e6, tiled / 1e6);
        TU_CHECK(tiled < whole, "tiles did not reduce memory: %zu vs %zu", tiled, whole);
    }
}

/* detail_sigma (chroma 0) or chroma_weight (chroma 1): out-of-range and NaN values, and any value > 0 with a
   UV-refine model (no picture), are INVALID_ARGUMENT naming the field */
static void refused_values(supermat_model *m, supermat_model *uv, int chroma) {
    static const float bad[3] = {1.0001f, 1.5f, (float)NAN}; /* negative values are SUPERMAT_OFF */
    const char *name = chroma ? "chroma_weight" : "detail_sigma";
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_error err;
    int k;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = S; sd.height = S;
    for (k = 0; k < 4; k++) {
        float v = k < 3 ? bad[k] : chroma ? 1.0f : 0.1f;
        if (k == 3) { if (!uv) break; sd.model = uv; }
        if (chroma) sd.chroma_weight = v; else sd.detail_sigma = v;
        TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, name),
                 "%s %g%s: INVALID_ARGUMENT", name, (double)v, k == 3 ? " with a UV-refine model" : "");
    }
}

/* ---- detail_sigma: the albedo with it against this file's float64 reference of the documented formula,
   computed from the same session's albedo without it; roughness / metallic untouched; alpha-0 pixels as
   decoded; RGB input (no alpha) weighs every pixel ---- */
static double dl_lin(double v) { v = v < 0 ? 0 : v > 1 ? 1 : v; return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }
static double dl_srgb(double v) { v = v < 0 ? 0 : v > 1 ? 1 : v; return v <= 0.0031308 ? v * 12.92 : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }
/* the float64 reference of detail_sigma: the albedo a0 (x/2+0.5, w x h x 3) after the step on picture img (ch
   channels, 8-bit; w = alpha with 4): three box passes of half-width r over rows then columns, zero outside;
   ref gets it where the picture's alpha is > 0 (elsewhere a0); returns r, *clipped the ratios clipped */
static int detail64(const float *a0, const unsigned char *img, int ch, int w, int h, double sigma, double *ref, int *clipped) {
    size_t n = (size_t)w * h, i;
    double *g = (double *)malloc(n * 6 * sizeof(double)), *t = (double *)malloc(n * 6 * sizeof(double)), sum[6] = {0, 0, 0, 0, 0, 0};
    double sg = sigma * (w > h ? w : h);
    int r = (int)floor((sqrt(4.0 * sg * sg + 1.0) - 1.0) * 0.5 + 0.5), pass, x, y, c;
    if (r < 1) r = 1;
    *clipped = 0;
    for (i = 0; i < n; i++) {
        double wt = ch == 4 ? img[i * 4 + 3] / 255.0 : 1.0;
        for (c = 0; c < 3; c++) {
            g[i * 6 + c] = wt * dl_lin(a0[i * 3 + c]);
            g[i * 6 + 3 + c] = wt * dl_lin(img[i * ch + c] / 255.0);
            sum[c] += g[i * 6 + c]; sum[3 + c] += g[i * 6 + 3 + c];
        }
    }
    for (pass = 0; pass < 6; pass++) { /* rows, columns, x3: direct window sums */
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++)
                for (c = 0; c < 6; c++) {
                    double a = 0;
                    int d;
                    for (d = -r; d <= r; d++) {
                        int xx = pass % 2 ? x : x + d, yy = pass % 2 ? y + d : y;
                        if (xx >= 0 && xx < w && yy >= 0 && yy < h) a += g[((size_t)yy * w + xx) * 6 + c];
                    }
                    t[((size_t)y * w + x) * 6 + c] = a;
                }
        memcpy(g, t, n * 6 * sizeof(double));
    }
    for (i = 0; i < n; i++)
        for (c = 0; c < 3; c++) {
            double q;
            if (ch == 4 && img[i * 4 + 3] == 0) { ref[i * 3 + c] = a0[i * 3 + c]; continue; }
            q = g[i * 6 + 3 + c] > 1e-6 ? g[i * 6 + c] / g[i * 6 + 3 + c] : (sum[c] > 0 && sum[3 + c] > 0 ? sum[c] / sum[3 + c] : 1.0);
            if (q < 0.25 || q > 4.0) (*clipped)++;
            q = q < 0.25 ? 0.25 : q > 4.0 ? 4.0 : q;
            ref[i * 3 + c] = dl_srgb(dl_lin(img[i * ch + c] / 255.0) * q);
        }
    free(g); free(t);
    return r;
}

static void test_detail(supermat_model *m, supermat_model *uv, const unsigned char *img4) {
    static unsigned char img3[S * S * 3];
    static float a0[S * S * 3], a1[S * S * 3], o0[S * S * 3], o1[S * S * 3];
    static double ref[S * S * 3];
    static const float sig[3] = {0.1f, 1.0f / 64.0f, 1.0f};
    int ch, k, i, c;
    for (i = 0; i < S * S; i++) for (c = 0; c < 3; c++) img3[i * 3 + c] = img4[i * 4 + c];
    for (ch = 3; ch <= 4; ch++) {
        const unsigned char *img = ch == 4 ? img4 : img3;
        opts o;
        memset(&o, 0, sizeof o);
        if (run1(m, &o, S, S, img, ch, a0, o0, NULL, NULL, NULL)) return;
        for (k = 0; k < 3; k++) {
            double worst = 0;
            int r, bg_same = 1, changed = 0, clipped = 0;
            o.detail = sig[k];
            if (run1(m, &o, S, S, img, ch, a1, o1, NULL, NULL, NULL)) return;
            r = detail64(a0, img, ch, S, S, sig[k], ref, &clipped);
            for (i = 0; i < S * S; i++)
                for (c = 0; c < 3; c++) {
                    double e = fabs(ref[i * 3 + c] - a1[i * 3 + c]);
                    if (ch == 4 && img[i * 4 + 3] == 0) { bg_same &= a1[i * 3 + c] == a0[i * 3 + c]; continue; }
                    if (e > worst) worst = e;
                    changed += a1[i * 3 + c] != a0[i * 3 + c];
                }
            TU_CHECK(worst < 2e-5 && changed > 0, "detail %g, %d channels: albedo worst %.3g from the float64 reference (%d values changed, %d ratios clipped)",
                     (double)sig[k], ch, worst, changed, clipped);
            TU_CHECK(bg_same, "detail %g: alpha-0 pixels as decoded", (double)sig[k]);
            TU_CHECK(!memcmp(o0, o1, sizeof o0), "detail %g: roughness / metallic untouched", (double)sig[k]);
            printf("detail %g (r %d), %d-channel input: albedo within %.2g of the float64 reference, %d values changed, %d ratios clipped\n",
                   (double)sig[k], r, ch, worst, changed, clipped);
        }
    }
    refused_values(m, uv, 0);
}

/* ---- a picture larger than the work size: the maps are resized back a row at a time and the detail step
   runs on rows (rings of 2r + 18 rows for each column pass, or the whole plane where that is smaller).
   Against float64: the run's decode at the work size (the DECODED stage) resampled here, x/2+0.5; with
   detail_sigma, detail64 of the albedo without it. The plan for an 8000x8000 picture stays under 4 bytes a
   pixel (the maps at the picture's size were 32) ---- */
static void test_resize_back(supermat_model *m) {
    enum { PW = 70, PH = 300, WK = 32 };
    static const float sig[3] = {1.0f / 64.0f, 1.0f / 8.0f, 0.5f};
    unsigned char *img = (unsigned char *)malloc((size_t)PW * PH * 4);
    float *a0 = (float *)malloc(sizeof(float) * PW * PH * 3), *o0 = (float *)malloc(sizeof(float) * PW * PH * 3);
    float *a1 = (float *)malloc(sizeof(float) * PW * PH * 3), *o1 = (float *)malloc(sizeof(float) * PW * PH * 3);
    double *ref = (double *)malloc(sizeof(double) * PW * PH * 3), worst = 0;
    size_t i, np = (size_t)PW * PH;
    int b, c, k;
    opts o;
    cap cp;
    tu_disc_rgba(img, PW, PH, 35, 160, 31);
    for (i = 0; i < np; i++) for (c = 0; c < 3; c++) img[i * 4 + c] = (unsigned char)(img[i * 4 + c] ^ (unsigned char)((i * 7 + (size_t)c * 13) % 61));
    memset(&o, 0, sizeof o); o.ww = WK; o.wh = WK;
    memset(&cp, 0, sizeof cp); cp.want = SUPERMAT_STAGE_DECODED; cp.inject = SUPERMAT_STAGE_COUNT;
    run1(m, &o, PW, PH, img, 4, a0, o0, &cp, NULL, NULL);
    TU_CHECK(cp.got[0] && cp.got[1] && cp.h == WK && cp.w == WK, "resized: the DECODED stage is at the work size (%dx%d)", cp.w, cp.h);
    for (b = 0; b < 2 && cp.got[b] && cp.h == WK; b++) {
        resample64(cp.got[b], WK, WK, 3, ref, PH, PW);
        for (i = 0; i < np; i++)
            for (c = b; c < 3; c++) { /* the albedo's 3 channels; roughness / metallic in the ORM's G and B */
                double want = ref[i * 3 + c] / 2.0 + 0.5, e;
                want = want < 0 ? 0 : want > 1 ? 1 : want;
                e = fabs(want - (b ? o0 : a0)[i * 3 + c]);
                if (e > worst) worst = e;
            }
    }
    TU_CHECK(worst < 1e-5, "resized back: maps worst %.3g from the float64 resampling of the decode", worst);
    printf("resized back (%dx%d from %d): maps within %.2g of the float64 resampling of the decode\n", PW, PH, WK, worst);
    for (b = 0; b < 2; b++) free(cp.got[b]);
    for (k = 0; k < 3; k++) {
        int r, clipped, bg_same = 1, changed = 0;
        o.detail = sig[k];
        run1(m, &o, PW, PH, img, 4, a1, o1, NULL, NULL, NULL);
        r = detail64(a0, img, 4, PW, PH, sig[k], ref, &clipped);
        worst = 0;
        for (i = 0; i < np; i++)
            for (c = 0; c < 3; c++) {
                double e = fabs(ref[i * 3 + c] - a1[i * 3 + c]);
                if (img[i * 4 + 3] == 0) { bg_same &= a1[i * 3 + c] == a0[i * 3 + c]; continue; }
                if (e > worst) worst = e;
                changed += a1[i * 3 + c] != a0[i * 3 + c];
            }
        TU_CHECK(worst < 2e-5 && changed > 0 && bg_same, "resized, detail %g: albedo worst %.3g from the float64 reference (%d changed; background %s)",
                 (double)sig[k], worst, changed, bg_same ? "as decoded" : "CHANGED");
        TU_CHECK(!memcmp(o0, o1, sizeof(float) * np * 3), "resized, detail %g: roughness / metallic untouched", (double)sig[k]);
        printf("resized %dx%d, detail %g (r %d): albedo within %.2g of the float64 reference, %d values changed, %d ratios clipped\n",
               PW, PH, (double)sig[k], r, worst, changed, clipped);
    }
    {
        supermat_session_desc sd;
        supermat_error err;
        size_t bytes = 0;
        memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = 8000; sd.height = 8000; sd.work_width = 64; sd.work_height = 64; sd.threads = 2;
        sd.detail_sigma = 1.0f / 64.0f; sd.chroma_weight = 1.0f;
        TU_CHECK(supermat_session_memory(&sd, &bytes, &err) == SUPERMAT_SUCCESS, "session memory at 8000x8000: %s", err.message);
        TU_CHECK(bytes < (size_t)4 * 8000 * 8000, "session memory at 8000x8000, work size 64, detail 1/64: %.2f bytes a pixel (want < 4)", (double)bytes / (8000.0 * 8000.0));
        printf("session memory at 8000x8000 (work size 64, detail 1/64, chroma 1, 2 threads): %.1f MiB, %.2f bytes a pixel\n",
               (double)bytes / 1048576.0, (double)bytes / (8000.0 * 8000.0));
    }
    free(img); free(a0); free(o0); free(a1); free(o1); free(ref);
}

/* ---- chroma_weight: the albedo with it against this file's float64 reference of the documented formula,
   computed from the same session's albedo without it (and with detail_sigma on both, so that the order of
   the two steps is checked); roughness / metallic untouched; alpha-0 pixels as decoded; RGB input weighs
   every pixel ---- */
static void test_chroma(supermat_model *m, supermat_model *uv, const unsigned char *img4) {
    static unsigned char img3[S * S * 3];
    static float a0[S * S * 3], a1[S * S * 3], o0[S * S * 3], o1[S * S * 3];
    static const float wt[3] = {0.5f, 1.0f, 1.0f}, det[3] = {0.0f, 0.0f, 1.0f / 64.0f};
    int ch, k, i, c;
    for (i = 0; i < S * S; i++) for (c = 0; c < 3; c++) img3[i * 3 + c] = img4[i * 4 + c];
    for (ch = 3; ch <= 4; ch++) {
        const unsigned char *img = ch == 4 ? img4 : img3;
        for (k = 0; k < 3; k++) {
            opts o;
            double worst = 0.0, moved = 0.0;
            int bg_same = 1, changed = 0, fgn = 0;
            memset(&o, 0, sizeof o);
            o.detail = det[k];
            if (run1(m, &o, S, S, img, ch, a0, o0, NULL, NULL, NULL)) return;
            o.chroma = wt[k];
            if (run1(m, &o, S, S, img, ch, a1, o1, NULL, NULL, NULL)) return;
            for (i = 0; i < S * S; i++) {
                double A[3], I[3], la, li;
                if (ch == 4 && img[i * 4 + 3] == 0) {
                    for (c = 0; c < 3; c++) bg_same &= a1[i * 3 + c] == a0[i * 3 + c];
                    continue;
                }
                fgn++;
                for (c = 0; c < 3; c++) { A[c] = dl_lin(a0[i * 3 + c]); I[c] = dl_lin(img[i * ch + c] / 255.0); }
                la = 0.2126 * A[0] + 0.7152 * A[1] + 0.0722 * A[2];
                li = 0.2126 * I[0] + 0.7152 * I[1] + 0.0722 * I[2];
                for (c = 0; c < 3; c++) {
                    double want = dl_srgb((1.0 - wt[k]) * A[c] + wt[k] * (la * I[c] + 0.002 * A[c]) / (li + 0.002));
                    double e = fabs(want - a1[i * 3 + c]);
                    if (e > worst) worst = e;
                    moved += fabs((double)a1[i * 3 + c] - a0[i * 3 + c]);
                    changed += a1[i * 3 + c] != a0[i * 3 + c];
                }
            }
            TU_CHECK(worst < 2e-5 && changed > 0, "chroma %g (detail %g), %d channels: albedo worst %.3g from the float64 reference (%d values changed)",
                     (double)wt[k], (double)det[k], ch, worst, changed);
            TU_CHECK(bg_same, "chroma %g: alpha-0 pixels as decoded", (double)wt[k]);
            TU_CHECK(!memcmp(o0, o1, sizeof o0), "chroma %g: roughness / metallic untouched", (double)wt[k]);
            printf("chroma %g (detail %g), %d-channel input: albedo within %.2g of the float64 reference, %d values changed, mean |change| %.3f\n",
                   (double)wt[k], (double)det[k], ch, worst, changed, fgn ? moved / (3.0 * fgn) : 0.0);
        }
    }
    refused_values(m, uv, 1);
}

int main(int argc, char **argv) {
    static unsigned char img[S * S * 4];
    unsigned char *d0 = NULL, *d1 = NULL, *d2 = NULL;
    supermat_model *m, *mv, *uv;
    if (argc < 4) { fprintf(stderr, "usage: %s MODEL MV_MODEL UV_MODEL\n", argv[0]); return 2; }
    m = load(argv[1], &d0); mv = load(argv[2], &d1); uv = load(argv[3], &d2);
    test_layout();
    test_resample_props();
    tu_disc_rgba(img, S, S, 18, 20, 13);
    if (m) { test_tiles(m, img); test_skip(m, img); test_work_size(m, img); test_resize_back(m); test_detail(m, uv, img); test_chroma(m, uv, img); }
    if (uv) test_skip_uv(uv);
    if (mv) test_mv_window(mv);
    if (m && mv) test_errors(m, mv);
    supermat_model_destroy(m); supermat_model_destroy(mv); supermat_model_destroy(uv);
    free(d0); free(d1); free(d2);
    return tu_finish("levers");
}
