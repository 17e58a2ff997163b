/* supermat_uv.h compiled as C99 (and, copied to a .cpp by CMake, as C++): the header's quick start,
   a passthrough bake of a textured quad and the stats it reports. No libraries beyond libc/libm.
   Sweeps (ufbx-style), passthrough and, given TINY_MV TINY_UV, with the networks (multi-view + both UV
   refines inside the bake): the N-th allocation fails for every N (OUT_OF_MEMORY, nothing leaked, no
   output pixel written), the progress callback cancels at every call in turn (CANCELLED, nothing leaked,
   outputs untouched), and the bake afterwards gives the same bytes as before.

   Given TINY too: the single-view model as mv_model (view by view), its predictions bit for bit those of
   supermat_run on each view alone, and the same sweeps.

   Given DEFAULT_MV (the multi-view default, which records a work size and a bake detail step): a bake
   with those fields 0 gives the bytes of one with the recorded values set explicitly; SUPERMAT_OFF and any
   negative detail_sigma are the same "off", and differ from it; SUPERMAT_WORK_NATIVE differs from 0.

   The descriptor guards: a bake desc or a part filled with garbage (never cleared), or with one canary
   set, is refused with INVALID_ARGUMENT naming the struct, before anything is allocated or written.

   usage: test_uv_c [TINY_MV TINY_UV [TINY [DEFAULT_MV]]] */
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200112L
#endif
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"
#include "test_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int fails = 0, passes = 0;
#define CHECK(c, msg)                                                          \
    do {                                                                       \
        if (c) passes++;                                                       \
        else { fails++; printf("FAIL %s:%d: %s\n", __FILE__, __LINE__, msg); } \
    } while (0)

/* the header's quick start, as printed there (models may be NULL here: then it reports an error) */
static supermat_result quick_start(const float *xyz, const float *uv, uint32_t nv, const uint32_t *idx, uint32_t ni,
                                   const unsigned char *rgba8, int tw, int th, const supermat_model *mv,
                                   const supermat_model *bc, const supermat_model *rm, unsigned char *albedo_rgba8,
                                   unsigned char *mr_rgb8) {
    supermat_uv_part part; memset(&part, 0, sizeof part);
    part.positions = xyz; part.uvs = uv; part.vertex_count = nv;      /* Z up, see FRAMES */
    part.indices = idx; part.index_count = ni;                         /* NULL = triangle list */
    part.base_color.pixels = (void *)rgba8; part.base_color.width = tw; part.base_color.height = th;
    part.base_color.channels = 4;                                      /* 8-bit = sRGB */
    supermat_uv_bake_desc bd; memset(&bd, 0, sizeof bd);
    bd.parts = &part; bd.part_count = 1;
    bd.mv_model = mv; bd.albedo_refine_model = bc; bd.rm_refine_model = rm;  /* supermat_model_create */
    supermat_uv_output out; memset(&out, 0, sizeof out);
    out.base_color.pixels = albedo_rgba8;       out.base_color.channels = 4;          /* 1024x1024 */
    out.metallic_roughness.pixels = mr_rgb8;    out.metallic_roughness.channels = 3;
    supermat_error err;
    supermat_result r = supermat_uv_bake(&bd, &out, NULL, &err);
    if (r != SUPERMAT_SUCCESS) puts(err.message);
    return r;
}

/* ---- sweeps ---- */
static int cancel_at, progress_calls;
static int progress_cancel(void *user, float f, const char *what) { (void)user; (void)f; (void)what; return ++progress_calls >= cancel_at; }

static int untouched(const unsigned char *p, size_t n) {
    size_t i;
    for (i = 0; i < n; i++) if (p[i] != 0xCD) return 0;
    return 1;
}

/* tu_count_alloc that also records the most bytes held at once */
static tu_counting *peak_watch;
static size_t peak_seen;
static void *peak_alloc(void *user, size_t size, size_t align) {
    void *p = tu_count_alloc(user, size, align);
    if (p && peak_watch && peak_watch->bytes > peak_seen) peak_seen = peak_watch->bytes;
    return p;
}

static void sweeps(supermat_uv_bake_desc bd, const char *what) {
    enum { S = 32 };
    static unsigned char alb[S * S * 4], mr[S * S * 3], ref_a[S * S * 4], ref_m[S * S * 3];
    supermat_uv_output out;
    supermat_error err;
    supermat_result r;
    tu_counting c;
    long n, k, total, oom = 0;
    char msg[600];
    memset(&out, 0, sizeof out);
    out.base_color.pixels = alb; out.base_color.channels = 4;
    out.metallic_roughness.pixels = mr; out.metallic_roughness.channels = 3;
    bd.texture_width = bd.texture_height = S;
    r = supermat_uv_bake(&bd, &out, NULL, &err);
    snprintf(msg, sizeof msg, "%s: reference bake: %s", what, err.message);
    CHECK(r == SUPERMAT_SUCCESS, msg);
    if (r) return;
    memcpy(ref_a, alb, sizeof alb); memcpy(ref_m, mr, sizeof mr);
    /* the memory cap: at the planned peak the bake runs (same bytes, the allocator never holds more than
       planned); one byte less is refused before any allocation, outputs untouched */
    {
        size_t need = 0, peak = 0;
        r = supermat_uv_bake_memory(&bd, &need, &err);
        CHECK(r == SUPERMAT_SUCCESS && need > 0, err.message);
        memset(&c, 0, sizeof c); c.fail_at = -1;
        bd.allocator.alloc = tu_count_alloc; bd.allocator.free = tu_count_free; bd.allocator.user = &c;
        bd.max_memory = need - 1;
        memset(alb, 0xCD, sizeof alb); memset(mr, 0xCD, sizeof mr);
        r = supermat_uv_bake(&bd, &out, NULL, &err);
        snprintf(msg, sizeof msg, "%s: max_memory one byte under the plan (%lu): %s, %ld allocations, '%s'", what, (unsigned long)need,
                 supermat_result_string(r), c.calls, err.message);
        CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY && c.calls == 0 && strstr(err.message, "max_memory") && untouched(alb, sizeof alb) &&
              untouched(mr, sizeof mr), msg);
        bd.max_memory = need;
        peak_watch = &c; peak_seen = 0;
        bd.allocator.alloc = peak_alloc;
        r = supermat_uv_bake(&bd, &out, NULL, &err);
        peak = peak_seen; peak_watch = NULL;
        snprintf(msg, sizeof msg, "%s: max_memory = the plan (%lu): %s, peak held %lu, %ld blocks live", what, (unsigned long)need,
                 supermat_result_string(r), (unsigned long)peak, c.live);
        CHECK(r == SUPERMAT_SUCCESS && peak <= need && c.live == 0 && !memcmp(alb, ref_a, sizeof alb) && !memcmp(mr, ref_m, sizeof mr), msg);
        printf("%s: plan %lu bytes, peak held %lu; a cap 1 byte under it refused with 0 allocations\n", what, (unsigned long)need, (unsigned long)peak);
        bd.max_memory = 0;
        memset(&bd.allocator, 0, sizeof bd.allocator);
    }
    /* the N-th allocation fails, for every N */
    for (n = 0;; n++) {
        memset(&c, 0, sizeof c); c.fail_at = n;
        bd.allocator.alloc = tu_count_alloc; bd.allocator.free = tu_count_free; bd.allocator.user = &c;
        memset(alb, 0xCD, sizeof alb); memset(mr, 0xCD, sizeof mr);
        r = supermat_uv_bake(&bd, &out, NULL, &err);
        if (r == SUPERMAT_SUCCESS) break;
        oom++;
        snprintf(msg, sizeof msg, "%s: allocation %ld failing: %s, %ld blocks live, outputs %s", what, n, supermat_result_string(r), c.live,
                 untouched(alb, sizeof alb) && untouched(mr, sizeof mr) ? "untouched" : "WRITTEN");
        CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY && c.live == 0 && untouched(alb, sizeof alb) && untouched(mr, sizeof mr), msg);
    }
    snprintf(msg, sizeof msg, "%s: the bake after the allocation sweep leaks %ld blocks or differs", what, c.live);
    CHECK(c.live == 0 && !memcmp(alb, ref_a, sizeof alb) && !memcmp(mr, ref_m, sizeof mr), msg);
    memset(&bd.allocator, 0, sizeof bd.allocator);
    /* cancellation at every progress call */
    progress_calls = 0; cancel_at = 1 << 30;
    bd.progress = progress_cancel;
    r = supermat_uv_bake(&bd, &out, NULL, &err);
    total = progress_calls;
    for (k = 1; k <= total; k++) {
        memset(&c, 0, sizeof c); c.fail_at = -1;
        bd.allocator.alloc = tu_count_alloc; bd.allocator.free = tu_count_free; bd.allocator.user = &c;
        progress_calls = 0; cancel_at = (int)k;
        memset(alb, 0xCD, sizeof alb); memset(mr, 0xCD, sizeof mr);
        r = supermat_uv_bake(&bd, &out, NULL, &err);
        snprintf(msg, sizeof msg, "%s: cancelled at progress call %ld of %ld: %s, %ld blocks live", what, k, total, supermat_result_string(r), c.live);
        CHECK(r == SUPERMAT_ERROR_CANCELLED && c.live == 0 && untouched(alb, sizeof alb) && untouched(mr, sizeof mr), msg);
    }
    bd.progress = NULL;
    memset(&bd.allocator, 0, sizeof bd.allocator);
    r = supermat_uv_bake(&bd, &out, NULL, &err);
    snprintf(msg, sizeof msg, "%s: a bake after the cancellations gives other bytes", what);
    CHECK(r == SUPERMAT_SUCCESS && !memcmp(alb, ref_a, sizeof alb) && !memcmp(mr, ref_m, sizeof mr), msg);
    printf("%s sweeps: %ld allocations, each failing -> OUT_OF_MEMORY; %ld progress calls, each cancelling -> CANCELLED; "
           "nothing leaked or written, the same bytes after\n", what, oom, total);
}

/* the debug images of a single-view bake: each view's picture and the per-view predictions */
enum { SV_VIEW = 16 };
static float sv_view[SUPERMAT_UV_VIEWS][SV_VIEW * SV_VIEW * 4], sv_alb[SUPERMAT_UV_VIEWS][SV_VIEW * SV_VIEW * 3],
    sv_rm[SUPERMAT_UV_VIEWS][SV_VIEW * SV_VIEW * 3];
static int sv_seen;
static void sv_debug(void *user, supermat_uv_debug_kind kind, int index, const float *data, int w, int h, int ch) {
    (void)user;
    if (index < 0 || index >= SUPERMAT_UV_VIEWS || w != SV_VIEW || h != SV_VIEW) return;
    if (kind == SUPERMAT_UV_DEBUG_VIEW && ch == 4) { memcpy(sv_view[index], data, sizeof sv_view[0]); sv_seen |= 1 << index; }
    if (kind == SUPERMAT_UV_DEBUG_PRED_ALBEDO && ch == 3) { memcpy(sv_alb[index], data, sizeof sv_alb[0]); sv_seen |= 1 << (8 + index); }
    if (kind == SUPERMAT_UV_DEBUG_PRED_RM && ch == 3) { memcpy(sv_rm[index], data, sizeof sv_rm[0]); sv_seen |= 1 << (16 + index); }
}

/* A single-view model as mv_model: the bake runs it view by view. Each view's predictions must be,
   bit for bit, what supermat_run gives for that view's picture alone; then the sweeps. */
static void single_view(supermat_uv_bake_desc bd, const supermat_model *sv, int work) {
    static unsigned char alb[32 * 32 * 4], mr[32 * 32 * 3];
    static float a[SV_VIEW * SV_VIEW * 3], o[SV_VIEW * SV_VIEW * 3];
    supermat_uv_output out;
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_error err;
    supermat_result r;
    int v, differ = 0, fg = 0;
    size_t k;
    char msg[600];
    bd.passthrough = 0; bd.view_size = SV_VIEW; bd.texture_width = bd.texture_height = 32;
    bd.mv_model = sv; bd.albedo_refine_model = NULL; bd.rm_refine_model = NULL;
    bd.debug = sv_debug; sv_seen = 0;
    bd.view_work_size = work; /* the network at work x work (0 = the view size), the maps resampled back */
    memset(&out, 0, sizeof out);
    out.base_color.pixels = alb; out.base_color.channels = 4;
    out.metallic_roughness.pixels = mr; out.metallic_roughness.channels = 3;
    r = supermat_uv_bake(&bd, &out, NULL, &err);
    snprintf(msg, sizeof msg, "single-view model as mv_model: %s (%s)", supermat_result_string(r), err.message);
    CHECK(r == SUPERMAT_SUCCESS && sv_seen == 0x3F3F3F, msg);
    memset(&sd, 0, sizeof sd);
    sd.model = sv; sd.width = SV_VIEW; sd.height = SV_VIEW; sd.views = 1; sd.threads = 1;
    sd.work_width = sd.work_height = work;
    CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS, err.message);
    for (v = 0; s && v < SUPERMAT_UV_VIEWS; v++) {
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = sv_view[v]; rd.input.width = rd.input.height = SV_VIEW; rd.input.channels = 4; rd.input.format = SUPERMAT_FORMAT_F32;
        rd.albedo.pixels = a; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
        rd.orm.pixels = o; rd.orm.channels = 3; rd.orm.format = SUPERMAT_FORMAT_F32;
        r = supermat_run(s, &rd, &err);
        CHECK(r == SUPERMAT_SUCCESS, err.message);
        for (k = 0; k < (size_t)SV_VIEW * SV_VIEW; k++) {
            fg += sv_view[v][k * 4 + 3] > 0.0f;
            differ += memcmp(&a[k * 3], &sv_alb[v][k * 3], 3 * sizeof(float)) != 0 || o[k * 3 + 1] != sv_rm[v][k * 3 + 1] ||
                      o[k * 3 + 2] != sv_rm[v][k * 3 + 2] || sv_rm[v][k * 3] != 0.0f;
        }
    }
    supermat_session_destroy(s);
    snprintf(msg, sizeof msg, "single-view bake, network at %d: %d of %d view pixels differ from supermat_run on the view alone (%d foreground)",
             work ? work : SV_VIEW, differ, SUPERMAT_UV_VIEWS * SV_VIEW * SV_VIEW, fg);
    CHECK(differ == 0 && fg > 0, msg);
    printf("%s\n", msg);
    bd.debug = NULL;
    bd.texture_width = bd.texture_height = 0;
    if (work) return;
    sweeps(bd, "single-view model, view by view");
    bd.view_work_size = 12; /* not a multiple of 8 */
    r = supermat_uv_bake(&bd, &out, NULL, &err);
    CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, "view_work_size"), "view_work_size 12: INVALID_ARGUMENT");
    bd.view_work_size = 0; bd.refine_work_size = -8;
    r = supermat_uv_bake(&bd, &out, NULL, &err);
    CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, "refine_work_size"), "refine_work_size -8: INVALID_ARGUMENT");
}

/* ---- DETAIL (detail_sigma): the bake's own intermediate images (debug) against a float64 reference of
   the documented formula, with direct window sums; the input colour against our own bilinear sample ---- */
enum { DT = 64 };
static const unsigned char *dt_tex;
static const float *dt_uvs;
static float dt_partial[DT * DT * 3], dt_seen[DT * DT], dt_chart[DT * DT], dt_input[DT * DT * 3];
static int dt_got;
static void dt_debug(void *user, supermat_uv_debug_kind kind, int index, const float *data, int w, int h, int ch) {
    (void)user;
    if (index != 0 || w != DT || h != DT) return;
    if (kind == SUPERMAT_UV_DEBUG_PARTIAL_ALBEDO && ch == 3) { memcpy(dt_partial, data, sizeof dt_partial); dt_got |= 1; }
    if (kind == SUPERMAT_UV_DEBUG_SEEN && ch == 1) { memcpy(dt_seen, data, sizeof dt_seen); dt_got |= 2; }
    if (kind == SUPERMAT_UV_DEBUG_CHART && ch == 1) { memcpy(dt_chart, data, sizeof dt_chart); dt_got |= 4; }
    if (kind == SUPERMAT_UV_DEBUG_INPUT_COLOR && ch == 3) { memcpy(dt_input, data, sizeof dt_input); dt_got |= 8; }
}
static double dt_lin(double s) { s = s < 0 ? 0 : s > 1 ? 1 : s; return s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4); }
static double dt_srgb(double l) { l = l < 0 ? 0 : l > 1 ? 1 : l; return l <= 0.0031308 ? l * 12.92 : 1.055 * pow(l, 1.0 / 2.4) - 0.055; }

/* bd: a quad bake whose part has a 16x16 RGBA8 texture `tex` (repeat wrap); limit: detail_limit (0 = the
   default, SUPERMAT_OFF = unbounded); what: label. Returns the worst 8-bit difference on the chart texels (-1
   on failure). */
static int detail_check(supermat_uv_bake_desc bd, const unsigned char *tex, float sigma, float limit, const char *what) {
    static unsigned char alb[DT * DT * 4], mr[DT * DT * 3], off[DT * DT * 4];
    static double g[DT * DT * 7], t[DT * DT * 7];
    double lim = limit == 0.0f ? (double)SUPERMAT_UV_DETAIL_LIMIT : limit < 0.0f ? 0.0 : limit;
    supermat_uv_output out;
    supermat_error err;
    supermat_result r;
    double sum[7] = {0, 0, 0, 0, 0, 0, 0}, worst_in = 0, sg = sigma * DT;
    int x, y, c, k, pass, worst = 0, chart = 0, unseen = 0, clipped = 0, changed = 0, rad = (int)floor((sqrt(4.0 * sg * sg + 1.0) - 1.0) * 0.5 + 0.5);
    char msg[400];
    if (rad < 1) rad = 1;
    memset(&out, 0, sizeof out);
    out.base_color.pixels = off; out.base_color.channels = 4;
    out.metallic_roughness.pixels = mr; out.metallic_roughness.channels = 3;
    bd.texture_width = bd.texture_height = DT;
    bd.detail_sigma = 0.0f; bd.debug = NULL;
    r = supermat_uv_bake(&bd, &out, NULL, &err);   /* the same bake without it, for comparison */
    CHECK(r == SUPERMAT_SUCCESS, err.message);
    out.base_color.pixels = alb;
    bd.detail_sigma = sigma; bd.detail_limit = limit; bd.debug = dt_debug; dt_got = 0;
    r = supermat_uv_bake(&bd, &out, NULL, &err);
    snprintf(msg, sizeof msg, "%s: detail bake: %s (%s), debug images %x", what, supermat_result_string(r), err.message, dt_got);
    CHECK(r == SUPERMAT_SUCCESS && dt_got == 15, msg);
    if (r || dt_got != 15) return -1;
    /* the input colour: our bilinear sample of the texture at each chart texel centre (repeat wrap) */
    for (y = 0; y < DT; y++)
        for (x = 0; x < DT; x++) {
            double u = (x + 0.5) / DT * 16 - 0.5, v = (y + 0.5) / DT * 16 - 0.5, fx, fy;
            int x0 = (int)floor(u), y0 = (int)floor(v);
            fx = u - x0; fy = v - y0;
            if (!dt_chart[y * DT + x]) continue;
            for (c = 0; c < 3; c++) {
                double a = tex[(((y0 + 16) % 16) * 16 + (x0 + 16) % 16) * 4 + c], b = tex[(((y0 + 16) % 16) * 16 + (x0 + 17) % 16) * 4 + c];
                double cc = tex[(((y0 + 17) % 16) * 16 + (x0 + 16) % 16) * 4 + c], d = tex[(((y0 + 17) % 16) * 16 + (x0 + 17) % 16) * 4 + c];
                double e = ((a + (b - a) * fx) * (1 - fy) + (cc + (d - cc) * fx) * fy) / 255.0 - dt_input[(y * DT + x) * 3 + c];
                if (fabs(e) > worst_in) worst_in = fabs(e);
            }
        }
    snprintf(msg, sizeof msg, "%s: the input colour at the chart texels, worst %.2g from a float64 bilinear sample", what, worst_in);
    CHECK(worst_in < 1e-5, msg);
    /* the reference: w = seen (nothing refined here); 3 x (rows, columns) of direct window sums of w A, w L
       and w */
    for (k = 0; k < DT * DT; k++) {
        int w = dt_seen[k] != 0.0f && dt_chart[k] != 0.0f;
        for (c = 0; c < 3; c++) {
            g[k * 7 + c] = w ? dt_lin(dt_partial[k * 3 + c]) : 0.0;
            g[k * 7 + 3 + c] = w ? dt_lin(dt_input[k * 3 + c]) : 0.0;
            sum[c] += g[k * 7 + c]; sum[3 + c] += g[k * 7 + 3 + c];
        }
        g[k * 7 + 6] = w; sum[6] += w;
    }
    for (pass = 0; pass < 6; pass++) {
        for (y = 0; y < DT; y++)
            for (x = 0; x < DT; x++)
                for (c = 0; c < 7; c++) {
                    double a = 0;
                    for (k = -rad; k <= rad; k++) {
                        int xx = pass % 2 ? x : x + k, yy = pass % 2 ? y + k : y;
                        if (xx >= 0 && xx < DT && yy >= 0 && yy < DT) a += g[(yy * DT + xx) * 7 + c];
                    }
                    t[(y * DT + x) * 7 + c] = a;
                }
        memcpy(g, t, sizeof g);
    }
    for (k = 0; k < DT * DT; k++) {
        if (!dt_chart[k]) continue;
        chart++;
        unseen += dt_seen[k] == 0.0f;
        for (c = 0; c < 3; c++) {
            double q = g[k * 7 + 3 + c] > 1e-6 ? g[k * 7 + c] / g[k * 7 + 3 + c] : sum[3 + c] > 0 && sum[c] > 0 ? sum[c] / sum[3 + c] : 1.0;
            int want, d;
            if (lim > 0.0) { /* bounded: the input's low-pass x the clamped gain x the input's detail, clamped */
                double li = g[k * 7 + 6] > 1e-6 ? g[k * 7 + 3 + c] / g[k * 7 + 6] : sum[3 + c] / sum[6];
                double p = dt_lin(dt_input[k * 3 + c]), gain = q < 0.25 ? 0.25 : q > 4.0 ? 4.0 : q;
                q = li > 1e-6 ? p / li : 1.0;
                if (q < 1.0 / lim || q > lim) clipped++;
                q = q < 1.0 / lim ? 1.0 / lim : q > lim ? lim : q;
                want = (int)(dt_srgb(li * gain * q) * 255.0 + 0.5);
            } else {
                if (q < 0.25 || q > 4.0) clipped++;
                q = q < 0.25 ? 0.25 : q > 4.0 ? 4.0 : q;
                want = (int)(dt_srgb(dt_lin(dt_input[k * 3 + c]) * q) * 255.0 + 0.5);
            }
            d = abs(want - alb[k * 4 + c]);
            if (d > worst) worst = d;
            changed += alb[k * 4 + c] != off[k * 4 + c];
        }
    }
    snprintf(msg, sizeof msg, "%s: sigma %g (r %d), limit %g: worst %d/255 from the float64 reference over %d chart texels (%d unseen, %d channels "
             "clipped, %d differ from the bake without detail)", what, (double)sigma, rad, lim, worst, chart, unseen, clipped, changed);
    CHECK(worst <= 1 && chart > 0 && unseen > 0 && changed > 0, msg);
    printf("%s\n", msg);
    return worst;
}

static unsigned char *read_all(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    unsigned char *b = NULL;
    long sz;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (sz = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 && (b = (unsigned char *)malloc((size_t)sz)) != NULL &&
        fread(b, 1, (size_t)sz, f) != (size_t)sz) { free(b); b = NULL; }
    fclose(f);
    if (b) *n = (size_t)sz;
    return b;
}

/* ---- the descriptor guards ---- */
static void guards(const supermat_uv_bake_desc *good, const supermat_uv_part *good_part) {
    static unsigned char alb[32 * 32 * 4];
    supermat_uv_bake_desc bd;
    supermat_uv_part part;
    supermat_uv_output out;
    supermat_error err;
    supermat_result r;
    tu_counting c;
    char msg[600];
    int k;
    memset(&out, 0, sizeof out);
    out.base_color.pixels = alb; out.base_color.channels = 4;
    for (k = 0; k < 5; k++) {
        /* 0: a desc filled with garbage and then set field by field, as a program that forgot the memset;
           1, 2: one canary of the desc; 3: a part filled with garbage; 4: a part's end canary */
        bd = *good; part = *good_part;
        if (k == 0) {
            memset(&bd, 0xA5, sizeof bd);
            bd.parts = &part; bd.part_count = 1; bd.passthrough = 1; bd.texture_width = bd.texture_height = 32;
            bd.view_size = 8; bd.supersample = 1; bd.threads = 1;
        }
        if (k == 1) bd._start_canary = 1;
        if (k == 2) bd._end_canary = 0xFFFFFFFFu;
        if (k == 3) {
            memset(&part, 0xA5, sizeof part);
            part.positions = good_part->positions; part.uvs = good_part->uvs; part.vertex_count = good_part->vertex_count;
            part.indices = good_part->indices; part.index_count = good_part->index_count; part.output = 0;
        }
        if (k == 4) part._end_canary = 7;
        bd.parts = &part;
        memset(&c, 0, sizeof c); c.fail_at = -1;
        bd.allocator.alloc = tu_count_alloc; bd.allocator.free = tu_count_free; bd.allocator.user = &c;
        memset(alb, 0xCD, sizeof alb);
        memset(&err, 0, sizeof err);
        r = supermat_uv_bake(&bd, &out, NULL, &err);
        snprintf(msg, sizeof msg, "guard %d: %s (%s), %ld allocations", k, supermat_result_string(r), err.message, c.calls);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, k < 3 ? "supermat_uv_bake_desc" : "supermat_uv_part") &&
              strstr(err.message, "canary") && c.calls == 0 && untouched(alb, sizeof alb), msg);
        if (k == 1 || k == 3) {
            size_t bytes = 0;
            r = supermat_uv_bake_memory(&bd, &bytes, &err);
            CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, "canary"), "guard: supermat_uv_bake_memory refuses it too");
        }
    }
    printf("guards: %s\n", err.message);
}

/* ---- the view model's pipeline: fields left 0 are what its file records ---- */
static void model_pipeline(supermat_uv_bake_desc bd, const supermat_model *mv) {
    enum { S = 32, NB = 5 };
    static unsigned char alb[NB][S * S * 4], mr[NB][S * S * 3];
    supermat_uv_output out;
    supermat_model_info info;
    supermat_error err;
    supermat_result r;
    char msg[600];
    int k, same[NB];
    memset(&info, 0, sizeof info);
    supermat_model_get_info(mv, &info);
    CHECK(info.work_size > 0 && info.bake_detail_sigma > 0.0f, "the multi-view default records a work size and a bake detail step");
    bd.passthrough = 0; bd.mv_model = mv; bd.albedo_refine_model = NULL; bd.rm_refine_model = NULL;
    bd.texture_width = bd.texture_height = S; bd.view_size = 16; bd.supersample = 1;
    for (k = 0; k < NB; k++) {
        /* 0: all 0; 1: the recorded values set; 2: SUPERMAT_OFF; 3: another negative; 4: SUPERMAT_WORK_NATIVE */
        bd.view_work_size = k == 1 ? info.work_size : k == 4 ? SUPERMAT_WORK_NATIVE : 0;
        bd.detail_sigma = k == 1 ? info.bake_detail_sigma : k == 2 ? SUPERMAT_OFF : k == 3 ? -0.25f : 0.0f;
        memset(&out, 0, sizeof out);
        out.base_color.pixels = alb[k]; out.base_color.channels = 4;
        out.metallic_roughness.pixels = mr[k]; out.metallic_roughness.channels = 3;
        r = supermat_uv_bake(&bd, &out, NULL, &err);
        snprintf(msg, sizeof msg, "default mv model, case %d: %s", k, err.message);
        CHECK(r == SUPERMAT_SUCCESS, msg);
    }
    for (k = 1; k < NB; k++) same[k] = !memcmp(alb[0], alb[k], sizeof alb[0]) && !memcmp(mr[0], mr[k], sizeof mr[0]);
    CHECK(same[1], "fields 0 = the model's recorded work size and bake detail step (identical bytes)");
    CHECK(!same[2] && !memcmp(mr[0], mr[2], sizeof mr[0]), "SUPERMAT_OFF turns the detail step off (albedo differs, RM identical)");
    CHECK(!memcmp(alb[2], alb[3], sizeof alb[2]), "any negative detail_sigma is SUPERMAT_OFF");
    CHECK(!same[4], "SUPERMAT_WORK_NATIVE runs at the view size, not the recorded work size");
    printf("default mv model: work size %d, bake detail %g; zero = recorded %d, off differs %d, native differs %d\n",
           info.work_size, (double)info.bake_detail_sigma, same[1], !same[2], !same[4]);
}

/* a model file read and created (checked); *file holds its bytes (free it after the model) */
static supermat_model *load_model(const char *path, unsigned char **file, const char *what) {
    size_t n = 0;
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    *file = read_all(path, &n);
    CHECK(*file != NULL, what);
    if (*file) {
        memset(&md, 0, sizeof md);
        md.data = *file; md.size = n;
        CHECK(supermat_model_create(&md, &m, &err) == SUPERMAT_SUCCESS, err.message);
    }
    return m;
}

int main(int argc, char **argv) {
    /* a quad in the XZ plane facing the front camera (-Y), UVs covering [0.25, 0.75]^2 */
    static const float xyz[12] = {-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1};
    static const float uv[8] = {0.25f, 0.75f, 0.75f, 0.75f, 0.75f, 0.25f, 0.25f, 0.25f};
    static const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    unsigned char tex[16 * 16 * 4], *albedo, *mr;
    float cams[SUPERMAT_UV_VIEWS * 16];
    supermat_uv_part part;
    supermat_uv_bake_desc bd;
    supermat_uv_output out;
    supermat_uv_stats st;
    supermat_error err;
    supermat_result r;
    size_t bytes = 0;
    int i, x, y, bad = 0;
    for (i = 0; i < 16 * 16; i++) { tex[i * 4] = 200; tex[i * 4 + 1] = 100; tex[i * 4 + 2] = 50; tex[i * 4 + 3] = 255; }
    albedo = (unsigned char *)malloc(1024 * 1024 * 4);
    mr = (unsigned char *)malloc(1024 * 1024 * 3);
    if (!albedo || !mr) return 1;

    supermat_uv_cameras(cams);
    CHECK(cams[0] == 1.0f && cams[7] == -1.0f && cams[4 * 16 + 11] == 1.0f, "camera matrices");

    /* the quick start without models: a clear error, nothing written */
    memset(albedo, 7, 1024 * 1024 * 4);
    r = quick_start(xyz, uv, 4, idx, 6, tex, 16, 16, NULL, NULL, NULL, albedo, mr);
    CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && albedo[0] == 7, "quick start without a model");

    /* passthrough at a small size */
    memset(&part, 0, sizeof part);
    part.positions = xyz; part.uvs = uv; part.vertex_count = 4; part.indices = idx; part.index_count = 6;
    part.base_color.pixels = tex; part.base_color.width = 16; part.base_color.height = 16; part.base_color.channels = 4;
    memset(&bd, 0, sizeof bd);
    bd.parts = &part; bd.part_count = 1; bd.passthrough = 1;
    bd.texture_width = 64; bd.texture_height = 64; bd.view_size = 64; bd.threads = 1;
    memset(&out, 0, sizeof out);
    out.base_color.pixels = albedo; out.base_color.channels = 4;
    out.metallic_roughness.pixels = mr; out.metallic_roughness.channels = 3;
    r = supermat_uv_bake_memory(&bd, &bytes, &err);
    CHECK(r == SUPERMAT_SUCCESS && bytes > 0, "memory estimate");
    r = supermat_uv_bake(&bd, &out, &st, &err);
    CHECK(r == SUPERMAT_SUCCESS, err.message);
    /* the chart covers texels 16..47: it was seen by the front view (and the back), so every texel of
       the texture is the texture's colour (the gutter reaches the rest, beyond it the mean) */
    for (y = 0; y < 64; y++)
        for (x = 0; x < 64; x++) {
            const unsigned char *p = albedo + (y * 64 + x) * 4, *q = mr + (y * 64 + x) * 3;
            if (abs(p[0] - 200) > 1 || abs(p[1] - 100) > 1 || abs(p[2] - 50) > 1 || p[3] != 255) bad++;
            if (q[0] != 255 || q[1] != 128 || q[2] != 0) bad++;
        }
    CHECK(bad == 0, "passthrough colours");
    CHECK(st.triangles == 2 && st.texels_chart == 32 * 32 && st.texels_seen == 32 * 32, "stats");
    printf("C build: %llu chart texels, %llu seen, estimate %lu bytes\n", (unsigned long long)st.texels_chart,
           (unsigned long long)st.texels_seen, (unsigned long)bytes);
    /* the same quad turned 45 degrees about Z (seen at cos 0.707 by two views) with a cos^900 blend:
       the weights (1e-136) underflow float; the texels must still get the texture's colour */
    {
        static const float rot[12] = {-0.70710678f, -0.70710678f, -1, 0.70710678f, 0.70710678f, -1, 0.70710678f, 0.70710678f, 1, -0.70710678f, -0.70710678f, 1};
        part.positions = rot;
        bd.weight = SUPERMAT_UV_WEIGHT_COS_POWER; bd.cos_power = 900.0f;
        r = supermat_uv_bake(&bd, &out, &st, &err);
        CHECK(r == SUPERMAT_SUCCESS, err.message);
        bad = 0;
        for (i = 0; i < 64 * 64; i++) if (abs(albedo[i * 4] - 200) > 1 || abs(albedo[i * 4 + 1] - 100) > 1 || abs(albedo[i * 4 + 2] - 50) > 1) bad++;
        CHECK(bad == 0 && st.texels_seen == 32 * 32, "cos^900 blend at 45 degrees keeps the colour");
        printf("cos^900 at 45 degrees: %d texels off the colour, %llu seen\n", bad, (unsigned long long)st.texels_seen);
    }
    /* counts at the integer boundaries: two parts of 2^31 vertices (2^32 in all), two of 2^32 - 1 indices
       (2.9e9 triangles): refused from the counts, before anything is read or allocated */
    {
        supermat_uv_part big[2];
        supermat_uv_bake_desc bb = bd;
        big[0] = part; big[1] = part;
        big[0].vertex_count = big[1].vertex_count = 0x80000000u;
        bb.parts = big; bb.part_count = 2;
        r = supermat_uv_bake(&bb, &out, &st, &err);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, "too large"), "2^32 vertices in two parts");
        big[0] = part; big[1] = part; /* 2 x (2^32 - 1) indices: 2.9e9 triangles, past 2^31 */
        big[0].index_count = big[1].index_count = 0xFFFFFFFFu;
        r = supermat_uv_bake(&bb, &out, &st, &err);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, "too large"), "2 x (2^32 - 1) indices");
        printf("counts past 2^31 / 2^32: refused (%s)\n", err.message);
    }
    /* sizes past the limits: a 65536^2 texture (2^32 texels) is refused from the desc; 256 outputs of
       16384^2 (each within the limits, 2^36 texels in all, some 1.4 TB of maps) under a 1 GiB cap are
       refused from the plan; neither allocates anything (and both answer at once) */
    {
        supermat_uv_bake_desc bb = bd;
        tu_counting cc;
        static supermat_uv_output many[256];
        char m2[700];
        clock_t t0 = clock();
        memset(&cc, 0, sizeof cc); cc.fail_at = -1;
        bb.allocator.alloc = tu_count_alloc; bb.allocator.free = tu_count_free; bb.allocator.user = &cc;
        bb.texture_width = bb.texture_height = 65536;
        r = supermat_uv_bake(&bb, &out, &st, &err);
        snprintf(m2, sizeof m2, "a 65536^2 texture: %s", err.message);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && cc.calls == 0, m2);
        for (i = 0; i < 256; i++) many[i] = out;
        bb.texture_width = bb.texture_height = 16384; bb.output_count = 256;
        bb.max_memory = (size_t)1 << 30;
        r = supermat_uv_bake(&bb, many, &st, &err);
        snprintf(m2, sizeof m2, "256 x 16384^2 under 1 GiB: %s", err.message);
        CHECK(r == SUPERMAT_ERROR_OUT_OF_MEMORY && cc.calls == 0 && strstr(err.message, "max_memory"), m2);
        printf("256 outputs of 16384^2 under a 1 GiB cap: refused in %.3f s, 0 allocations (%s)\n",
               (double)(clock() - t0) / CLOCKS_PER_SEC, err.message);
        /* a base colour texture claiming more than the address space (2^31 - 1 squared texels of 4 floats:
           2^66 bytes; 64 rows of a 2^58-byte stride: 2^64) is refused before a texel is read */
        {
            supermat_uv_part pp = part;
            static const size_t strides[2] = {0, (size_t)1 << 58};
            int k;
            bb = bd; bb.parts = &pp; bb.part_count = 1;
            for (k = 0; k < 2; k++) {
                pp.base_color.width = k ? 16 : 2147483647; pp.base_color.height = k ? 64 : 2147483647;
                pp.base_color.format = k ? SUPERMAT_FORMAT_U8 : SUPERMAT_FORMAT_F32;
                pp.base_color.stride = strides[k];
                memset(&cc, 0, sizeof cc); cc.fail_at = -1;
                bb.allocator.alloc = tu_count_alloc; bb.allocator.free = tu_count_free; bb.allocator.user = &cc;
                r = supermat_uv_bake(&bb, &out, &st, &err);
                snprintf(m2, sizeof m2, "texture %dx%d stride %llu: %s (%s)", pp.base_color.width, pp.base_color.height,
                         (unsigned long long)strides[k], supermat_result_string(r), err.message);
                CHECK(r == SUPERMAT_ERROR_BAD_IMAGE && strstr(err.message, "address space") && cc.calls == 0, m2);
            }
            printf("textures past the address space: refused (%s)\n", err.message);
        }
    }
    guards(&bd, &part);
    /* the sweeps, on the same quad, textures 32x32, views 16x16 (8x8 when passthrough) */
    part.positions = xyz;
    bd.weight = SUPERMAT_UV_WEIGHT_AVERAGE; bd.cos_power = 0.0f;
    bd.view_size = 8; bd.supersample = 1;
    sweeps(bd, "passthrough");
    /* DETAIL on a patterned texture: a quarter of the quad's UVs outside [0, 1] (repeat wrap); pixels
       within 2 of the silhouettes rejected, so the texels along the quad's edges are unseen */
    {
        static unsigned char pat[16 * 16 * 4];
        static const float uvw[8] = {-0.25f, 0.75f, 0.75f, 0.75f, 0.75f, -0.25f, -0.25f, -0.25f};
        supermat_uv_bake_desc b2 = bd;
        supermat_uv_part p2 = part;
        float bad_sigma[3];
        for (y = 0; y < 16; y++)
            for (x = 0; x < 16; x++) {
                unsigned char *q = pat + (y * 16 + x) * 4;
                q[0] = (unsigned char)(x * 16 + 8); q[1] = (unsigned char)(y * 16 + 8); q[2] = (unsigned char)(((x ^ y) & 1) ? 230 : 20); q[3] = 255;
            }
        p2.base_color.pixels = pat; p2.uvs = uvw;
        b2.parts = &p2; b2.view_size = 32; b2.supersample = 2; b2.edge_reject = 2;
        detail_check(b2, pat, 0.1f, 0.0f, "passthrough + detail");
        detail_check(b2, pat, 1.0f / 32.0f, 0.0f, "passthrough + detail");
        detail_check(b2, pat, 0.1f, 2.0f, "passthrough + detail");
        detail_check(b2, pat, 0.1f, SUPERMAT_OFF, "passthrough + detail (unbounded)");
        detail_check(b2, pat, 1.0f / 32.0f, SUPERMAT_OFF, "passthrough + detail (unbounded)");
        b2.detail_sigma = 0.1f;
        sweeps(b2, "passthrough + detail");
        bad_sigma[0] = 1.0001f; bad_sigma[1] = 1.5f; bad_sigma[2] = (float)NAN;
        for (i = 0; i < 3; i++) {
            b2.detail_sigma = bad_sigma[i];
            r = supermat_uv_bake(&b2, &out, NULL, &err);
            CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, "detail_sigma"), "a bad detail_sigma: INVALID_ARGUMENT");
        }
        b2.detail_sigma = 0.1f;
        bad_sigma[0] = 1.0f; bad_sigma[1] = 2e6f; bad_sigma[2] = (float)NAN;
        for (i = 0; i < 3; i++) {
            b2.detail_limit = bad_sigma[i];
            r = supermat_uv_bake(&b2, &out, NULL, &err);
            CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, "detail_limit"), "a bad detail_limit (1, 2e6, NaN): INVALID_ARGUMENT");
        }
        dt_tex = pat; dt_uvs = uvw;
    }
    if (argc >= 3) {
        size_t nmv = 0, nuv = 0;
        unsigned char *fmv = read_all(argv[1], &nmv), *fuv = read_all(argv[2], &nuv);
        supermat_model *mv = NULL, *uvm = NULL;
        supermat_model_desc md;
        CHECK(fmv && fuv, "read the tiny models");
        memset(&md, 0, sizeof md);
        if (fmv && fuv) {
            md.data = fmv; md.size = nmv;
            CHECK(supermat_model_create(&md, &mv, &err) == SUPERMAT_SUCCESS, err.message);
            md.data = fuv; md.size = nuv;
            CHECK(supermat_model_create(&md, &uvm, &err) == SUPERMAT_SUCCESS, err.message);
        }
        if (mv && uvm) {
            bd.passthrough = 0; bd.view_size = 16;
            bd.mv_model = mv; bd.albedo_refine_model = uvm; bd.rm_refine_model = uvm;
            sweeps(bd, "networks (multi-view + UV refine)");
        }
        if (mv && uvm) { /* wrong kinds as mv_model: a UV-refine model */
            bd.mv_model = uvm;
            r = supermat_uv_bake(&bd, &out, NULL, &err);
            CHECK(r == SUPERMAT_ERROR_UNSUPPORTED && strstr(err.message, "mv_model"), "a uv-refine model as mv_model: UNSUPPORTED");
            bd.mv_model = mv;
        }
        if (argc >= 4 && mv && uvm) { /* TINY: the single-view model, view by view */
            unsigned char *fsv = NULL;
            supermat_model *sv = load_model(argv[3], &fsv, "read the tiny single-view model");
            if (sv) { single_view(bd, sv, 0); single_view(bd, sv, 8); single_view(bd, sv, 32); }
            if (sv) { /* DETAIL with the network's predictions: ratios far from 1, some clipped */
                supermat_uv_bake_desc b2 = bd;
                supermat_uv_part p2 = part;
                p2.base_color.pixels = (void *)dt_tex; p2.uvs = dt_uvs;
                b2.parts = &p2; b2.view_size = 32; b2.supersample = 2; b2.view_work_size = 8; b2.edge_reject = 2;
                b2.mv_model = sv; b2.albedo_refine_model = NULL; b2.rm_refine_model = NULL;
                detail_check(b2, dt_tex, 0.1f, 0.0f, "single-view model + detail");
                b2.texture_width = b2.texture_height = 0; b2.detail_sigma = 0.1f; b2.view_size = 16;
                sweeps(b2, "single-view model + detail");
            }
            supermat_model_destroy(sv);
            free(fsv);
        }
        if (argc >= 5) { /* DEFAULT_MV */
            unsigned char *fd = NULL;
            supermat_model *dm = load_model(argv[4], &fd, "read the multi-view default");
            if (dm) model_pipeline(bd, dm);
            supermat_model_destroy(dm);
            free(fd);
        }
        supermat_model_destroy(mv);
        supermat_model_destroy(uvm);
        free(fmv);
        free(fuv);
    }
    free(albedo);
    free(mr);
    printf("%d passed, %d failed\n", passes, fails);
    return fails ? 1 : 0;
}
