/* The model file's pipeline and the 0.2 API around it, through the public API:
   - supermat_model_info reports the pipeline a file records (pipeline.work_size / detail_sigma /
     chroma_weight): the default model 256 / 1/64 / 1, the tiny converted model none.
   - A session's zero fields are the model's: all-zero is bit-identical to the same values set
     explicitly; SUPERMAT_OFF and any other negative value are the same "off" (identical bytes) and
     change the albedo.
   - Any picture size runs when the network has a work size (finite maps in [0, 1], written at the
     picture's size); at the picture's own size (SUPERMAT_WORK_NATIVE, or a model that records no work
     size) a side that is not a multiple of 8 is BAD_IMAGE with a message; a work size below
     SUPERMAT_WORK_NATIVE is INVALID_ARGUMENT.
   - The descriptor guards: model_desc, session_desc and run_desc filled with 0xA5 (never cleared), or
     with one canary set, are refused with INVALID_ARGUMENT naming the struct, before anything is read or
     written; supermat_model_write_packed too.
   - A pre-packed file created with conv / compute 0 takes the options it was packed for and runs to the
     bits of the unpacked model created with them.
   - Roughness / metallic outputs of 2 channels are gray + the input's alpha, of 4 channels gray RGB +
     the input's alpha; an RGB input gives alpha 255.
   - pipeline.bake_detail_sigma (the bake detail of supermat_uv.h): reported in model_info.bake_detail_sigma
     (the multi-view default beside DEFAULT_MODEL 1/32, the default and the tiny model none, the tiny model
     with the key added 1/32, 1, 0); out of [0, 1] or not a number MALFORMED_FILE naming the key; a value
     > 0 on a uv-refine file MALFORMED_FILE, 0 accepted.
   - pipeline.roughness_curve / session_desc.roughness_knots: the default model records a 9-knot curve, the
     tiny model none; a run puts the roughness through it: against the float64 curve of the same run with
     SUPERMAT_CURVE_OFF within 1e-6 on every pixel of alpha > 0, unchanged where alpha is 0, albedo and
     metallic bit-identical; the model's curve given explicitly is bit-identical to 0; a caller's curve
     (constant 0.3, identity) does what it says; on the tiny multi-view model with the curve added, every
     view. Malformed curves in the file (too few / many knots, falling, out of [0, 1], NaN, not numbers,
     not a string, longer than the reader takes, on a uv-refine file) are MALFORMED_FILE naming the key;
     in a session desc INVALID_ARGUMENT; supermat_parse_curve reads what the file reader reads.
   - pipeline.metallic_curve / session_desc.metallic_knots: the same checks for the metallic map (the default
     model with a 5-knot curve added to its file: roughness, with the file's roughness curve, and albedo
     bit-identical to the run without it), each file also reporting no curve for the other map.
   usage: test_pipeline DEFAULT_MODEL TINY_MODEL [TINY_UV_MODEL]
   (TINY_UV_MODEL: default tiny_uv_refine_bc.safetensors beside TINY_MODEL, as the tiny fixture writes it;
   the multi-view default: supermat_mv_default.safetensors beside DEFAULT_MODEL, skipped where absent) */
#define SUPERMAT_IMPLEMENTATION
#include "supermat.h"
#include "test_util.h"

#define PW 97  /* the odd picture: not a multiple of 8 either way */
#define PH 131
#define BW 1000 /* the large picture */
#define BH 750
#define Q 64   /* the small square picture (pre-packed, alpha outputs, guards) */

static unsigned char *load(const char *path, size_t *size) {
    unsigned char *d = tu_load(path, size);
    TU_CHECK(d != NULL, "cannot read %s", path);
    return d;
}

static supermat_model *create(const unsigned char *data, size_t size, supermat_conv conv, const char *what) {
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    if (!data) return NULL;
    memset(&md, 0, sizeof md);
    md.data = data; md.size = size; md.conv = conv;
    if (supermat_model_create(&md, &m, &err)) { TU_CHECK(0, "%s: %s", what, err.message); return NULL; }
    return m;
}

/* the session fields under test */
typedef struct fields { int ww, wh; float detail, chroma; int rk; const float *rc; } fields; /* rk, rc: roughness_knots / curve
                                                                                          (metallic_knots / curve: g_curve_map) */
static int g_curve_map; /* the map fields.rk / rc are for: 0 roughness, 1 metallic */

/* float maps of one run: albedo RGBA, roughness and metallic 1 channel (width x height of the picture) */
typedef struct maps { float *albedo, *rough, *metal; size_t n; } maps;
static maps maps_new(int w, int h) {
    maps o;
    size_t i;
    o.n = (size_t)w * h;
    o.albedo = (float *)malloc(o.n * 4 * sizeof(float));
    o.rough = (float *)malloc(o.n * sizeof(float));
    o.metal = (float *)malloc(o.n * sizeof(float));
    for (i = 0; i < o.n * 4; i++) o.albedo[i] = -1.0f; /* unwritten values fail the range check */
    for (i = 0; i < o.n; i++) { o.rough[i] = -1.0f; o.metal[i] = -1.0f; }
    return o;
}
static void maps_free(maps *o) { free(o->albedo); free(o->rough); free(o->metal); memset(o, 0, sizeof *o); }
static int maps_same(const maps *a, const maps *b) {
    return a->n == b->n && !memcmp(a->albedo, b->albedo, a->n * 4 * sizeof(float)) && !memcmp(a->rough, b->rough, a->n * sizeof(float)) &&
           !memcmp(a->metal, b->metal, a->n * sizeof(float));
}
/* every value finite and in [0, 1] */
static int in01(const float *v, size_t n) {
    size_t i;
    for (i = 0; i < n; i++) if (!(v[i] >= 0.0f && v[i] <= 1.0f)) return 0;
    return 1;
}
static int maps_in01(const maps *o) { return in01(o->albedo, o->n * 4) && in01(o->rough, o->n) && in01(o->metal, o->n); }

/* one session + run of m on px (w x h, ch channels) with the fields of p; float outputs into o */
static supermat_result run_f32(const supermat_model *m, const fields *p, int w, int h, const unsigned char *px, int ch, maps *o, supermat_error *err) {
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_result r;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = w; sd.height = h;
    sd.work_width = p->ww; sd.work_height = p->wh; sd.detail_sigma = p->detail; sd.chroma_weight = p->chroma;
    if (g_curve_map) { sd.metallic_knots = p->rk; sd.metallic_curve = p->rc; }
    else { sd.roughness_knots = p->rk; sd.roughness_curve = p->rc; }
    if ((r = supermat_session_create(&sd, &s, err))) return r;
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = (void *)px; rd.input.width = w; rd.input.height = h; rd.input.channels = ch;
    rd.albedo.pixels = o->albedo; rd.albedo.channels = 4; rd.albedo.format = SUPERMAT_FORMAT_F32;
    rd.roughness.pixels = o->rough; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
    rd.metallic.pixels = o->metal; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
    r = supermat_run(s, &rd, err);
    supermat_session_destroy(s);
    return r;
}

/* ---- 1. the pipeline a file records ---- */
static void test_info(const supermat_model *def, const supermat_model *tiny) {
    supermat_model_info a, b;
    if (!def || !tiny) return;
    supermat_model_get_info(def, &a);
    supermat_model_get_info(tiny, &b);
    TU_CHECK(a.work_size == 256 && a.detail_sigma == 0.015625f && a.chroma_weight == 1.0f,
             "default model: work %d detail %.9g chroma %.9g, want 256 / 0.015625 / 1", a.work_size, (double)a.detail_sigma, (double)a.chroma_weight);
    TU_CHECK(b.work_size == 0 && b.detail_sigma == 0.0f && b.chroma_weight == 0.0f,
             "tiny model: work %d detail %.9g chroma %.9g, want none", b.work_size, (double)b.detail_sigma, (double)b.chroma_weight);
    printf("model_info: default work %d, detail %g, chroma %g; tiny %d / %g / %g\n", a.work_size, (double)a.detail_sigma,
           (double)a.chroma_weight, b.work_size, (double)b.detail_sigma, (double)b.chroma_weight);
}

/* ---- 2. zero fields are the model's; SUPERMAT_OFF and another negative value are the same off ---- */
static void test_zero_is_model(const supermat_model *def, const unsigned char *img, maps *zero) {
    static const fields p0 = {0, 0, 0.0f, 0.0f, 0, NULL}, pe = {256, 256, 0.015625f, 1.0f, 0, NULL}, poff = {0, 0, SUPERMAT_OFF, SUPERMAT_OFF, 0, NULL},
                      pneg = {256, 256, -0.25f, -0.25f, 0, NULL};
    maps e = maps_new(PW, PH), off = maps_new(PW, PH), neg = maps_new(PW, PH);
    supermat_error err;
    supermat_result r;
    int albedo_differs;
    r = run_f32(def, &p0, PW, PH, img, 4, zero, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%dx%d, fields 0: %s", PW, PH, err.message);
    r = run_f32(def, &pe, PW, PH, img, 4, &e, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%dx%d, work 256 detail 1/64 chroma 1: %s", PW, PH, err.message);
    TU_CHECK(maps_same(zero, &e), "fields 0 and the model's values set explicitly (256x256, 0.015625, 1): not bit-identical");
    r = run_f32(def, &poff, PW, PH, img, 4, &off, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "detail / chroma SUPERMAT_OFF: %s", err.message);
    r = run_f32(def, &pneg, PW, PH, img, 4, &neg, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "work 256, detail / chroma -0.25: %s", err.message);
    albedo_differs = memcmp(zero->albedo, off.albedo, zero->n * 4 * sizeof(float)) != 0;
    TU_CHECK(albedo_differs, "SUPERMAT_OFF for both steps: albedo identical to the model's steps (the steps did nothing)");
    TU_CHECK(!memcmp(zero->rough, off.rough, zero->n * sizeof(float)) && !memcmp(zero->metal, off.metal, zero->n * sizeof(float)),
             "SUPERMAT_OFF: roughness / metallic changed (the steps touch the albedo only)");
    TU_CHECK(maps_same(&off, &neg), "SUPERMAT_OFF (work 0) and -0.25 (work 256 explicit): not bit-identical");
    printf("zero = model's: %dx%d fields 0 %s explicit 256/0.015625/1; SUPERMAT_OFF %s; OFF %s -0.25\n", PW, PH,
           maps_same(zero, &e) ? "==" : "!=", albedo_differs ? "changes the albedo" : "CHANGES NOTHING", maps_same(&off, &neg) ? "==" : "!=");
    maps_free(&e); maps_free(&off); maps_free(&neg);
}

/* ---- 3. any picture size with a work size; the picture's own size needs multiples of 8 ---- */
static void test_sizes(const supermat_model *def, const supermat_model *tiny, const unsigned char *img, const maps *odd) {
    static const fields p0 = {0, 0, 0.0f, 0.0f, 0, NULL}, pnat = {SUPERMAT_WORK_NATIVE, SUPERMAT_WORK_NATIVE, 0.0f, 0.0f, 0, NULL}, p64 = {64, 64, 0.0f, 0.0f, 0, NULL},
                      pbad = {-2, 0, 0.0f, 0.0f, 0, NULL};
    static const unsigned char one[4] = {200, 120, 60, 128};
    unsigned char *big = (unsigned char *)malloc((size_t)BW * BH * 4);
    maps m1 = maps_new(1, 1), mb = maps_new(BW, BH), mt = maps_new(PW, PH);
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_error err;
    supermat_result r;
    size_t i, alpha_bad = 0;
    if (!big) { TU_CHECK(0, "out of memory"); return; }
    tu_disc_rgba(big, BW, BH, BW / 2 - 30, BH / 2 + 20, 300);
    r = run_f32(def, &p0, 1, 1, one, 4, &m1, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && maps_in01(&m1), "1x1, fields 0: %s (maps in [0, 1]: %d)", err.message, maps_in01(&m1));
    TU_CHECK(odd->n == (size_t)PW * PH && maps_in01(odd), "%dx%d, fields 0: maps not all finite in [0, 1]", PW, PH);
    r = run_f32(def, &p0, BW, BH, big, 4, &mb, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && maps_in01(&mb), "%dx%d, fields 0: %s (maps in [0, 1]: %d)", BW, BH, err.message, maps_in01(&mb));
    for (i = 0; i < mb.n; i++) alpha_bad += mb.albedo[i * 4 + 3] != (float)big[i * 4 + 3] / 255.0f;
    TU_CHECK(r == SUPERMAT_SUCCESS && alpha_bad == 0, "%dx%d: %lu albedo alpha values not the input's", BW, BH, (unsigned long)alpha_bad);

    /* the picture's own size */
    memset(&sd, 0, sizeof sd);
    sd.model = def; sd.width = PW; sd.height = PH; sd.work_width = pnat.ww; sd.work_height = pnat.wh;
    err.message[0] = 0;
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_ERROR_BAD_IMAGE && strstr(err.message, "multiples of 8") && !s,
             "%dx%d, SUPERMAT_WORK_NATIVE: %s (%s), want BAD_IMAGE naming multiples of 8", PW, PH, supermat_result_string(r), err.message);
    supermat_session_destroy(s); s = NULL;
    if (tiny) {
        sd.model = tiny; sd.work_width = 0; sd.work_height = 0;
        err.message[0] = 0;
        r = supermat_session_create(&sd, &s, &err);
        TU_CHECK(r == SUPERMAT_ERROR_BAD_IMAGE && strstr(err.message, "multiples of 8") && !s,
                 "tiny (no work size) %dx%d, fields 0: %s (%s), want BAD_IMAGE", PW, PH, supermat_result_string(r), err.message);
        supermat_session_destroy(s); s = NULL;
        r = run_f32(tiny, &p64, PW, PH, img, 4, &mt, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS && maps_in01(&mt), "tiny %dx%d at work 64x64: %s (maps in [0, 1]: %d)", PW, PH, err.message, maps_in01(&mt));
    }
    sd.model = def; sd.work_width = pbad.ww; sd.work_height = pbad.wh;
    err.message[0] = 0;
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && !s, "work_width -2: %s (%s), want INVALID_ARGUMENT", supermat_result_string(r), err.message);
    supermat_session_destroy(s); s = NULL;
    r = supermat_session_memory(&sd, &i, &err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT, "supermat_session_memory, work_width -2: %s, want INVALID_ARGUMENT", supermat_result_string(r));
    sd.width = Q; sd.height = Q; sd.work_width = -2; sd.work_height = -2; /* would be the picture's own size if taken as native */
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && !s, "%dx%d, work -2 x -2: %s (%s), want INVALID_ARGUMENT", Q, Q, supermat_result_string(r), err.message);
    supermat_session_destroy(s); s = NULL;
    printf("any size: 1x1, %dx%d, %dx%d on the default model's work size in [0, 1]; own size %dx%d refused (BAD_IMAGE), tiny at work 64 runs, work -2 refused\n",
           PW, PH, BW, BH, PW, PH);
    maps_free(&m1); maps_free(&mb); maps_free(&mt);
    free(big);
}

/* ---- 4. descriptor guards ---- */
/* refused with INVALID_ARGUMENT and a message naming `name` */
static int refused(supermat_result r, const supermat_error *err, const char *name) {
    return r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err->message, name) != NULL;
}

static void test_guards(const unsigned char *tdata, size_t tsize, const unsigned char *img) {
    static unsigned char alb[Q * Q * 3], rgh[Q * Q], met[Q * Q];
    supermat_model_desc md;
    supermat_session_desc sd;
    supermat_run_desc rd;
    supermat_model *m = NULL;
    supermat_session *s = NULL;
    supermat_error err;
    supermat_result r;
    tu_membuf b;
    size_t bytes = 0, i, touched = 0;
    int k, cases = 0;
    if (!tdata) return;
    memset(&b, 0, sizeof b);
    b.fail_at = -1;

    /* model_desc: never cleared, then each canary alone */
    for (k = 0; k < 3; k++) {
        if (k == 0) memset(&md, 0xA5, sizeof md);
        else memset(&md, 0, sizeof md);
        md.data = tdata; md.size = tsize;
        if (k == 1) md._start_canary = 1;
        if (k == 2) md._end_canary = 1;
        r = supermat_model_create(&md, &m, &err);
        TU_CHECK(refused(r, &err, "supermat_model_desc") && !m, "model_desc case %d: %s (%s)", k, supermat_result_string(r), err.message);
        supermat_model_destroy(m); m = NULL;
        b.n = 0;
        r = supermat_model_write_packed(&md, tu_mem_write, &b, NULL, &err);
        TU_CHECK(refused(r, &err, "supermat_model_desc") && b.n == 0, "write_packed, model_desc case %d: %s (%s), %lu bytes written",
                 k, supermat_result_string(r), err.message, (unsigned long)b.n);
        cases++;
    }
    memset(&md, 0, sizeof md);
    md.data = tdata; md.size = tsize;
    b.n = 0;
    r = supermat_model_write_packed(&md, tu_mem_write, &b, NULL, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && b.n > 0, "write_packed, canaries 0: %s", err.message);
    r = supermat_model_create(&md, &m, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && m, "model_desc, canaries 0: %s", err.message);
    free(b.p);
    if (!m) return;

    /* session_desc */
    for (k = 0; k < 3; k++) {
        if (k == 0) memset(&sd, 0xA5, sizeof sd);
        else memset(&sd, 0, sizeof sd);
        sd.model = m; sd.width = Q; sd.height = Q;
        if (k == 1) sd._start_canary = 1;
        if (k == 2) sd._end_canary = 1;
        r = supermat_session_create(&sd, &s, &err);
        TU_CHECK(refused(r, &err, "supermat_session_desc") && !s, "session_desc case %d: %s (%s)", k, supermat_result_string(r), err.message);
        supermat_session_destroy(s); s = NULL;
        r = supermat_session_memory(&sd, &bytes, &err);
        TU_CHECK(refused(r, &err, "supermat_session_desc"), "session_memory, session_desc case %d: %s (%s)", k, supermat_result_string(r), err.message);
        cases++;
    }
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = Q; sd.height = Q;
    r = supermat_session_create(&sd, &s, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && s, "session_desc, canaries 0: %s", err.message);
    if (!s) { supermat_model_destroy(m); return; }

    /* run_desc: refused before any output is written */
    for (k = 0; k < 3; k++) {
        if (k == 0) memset(&rd, 0xA5, sizeof rd);
        else memset(&rd, 0, sizeof rd);
        rd.input.pixels = (void *)img; rd.input.width = Q; rd.input.height = Q; rd.input.channels = 4;
        rd.albedo.pixels = alb; rd.albedo.channels = 3;
        rd.roughness.pixels = rgh; rd.roughness.channels = 1;
        rd.metallic.pixels = met; rd.metallic.channels = 1;
        if (k == 1) rd._start_canary = 1;
        if (k == 2) rd._end_canary = 1;
        memset(alb, 0x5A, sizeof alb); memset(rgh, 0x5A, sizeof rgh); memset(met, 0x5A, sizeof met);
        r = supermat_run(s, &rd, &err);
        for (i = 0; i < sizeof alb; i++) touched += alb[i] != 0x5A;
        for (i = 0; i < sizeof rgh; i++) touched += (rgh[i] != 0x5A) + (met[i] != 0x5A);
        TU_CHECK(refused(r, &err, "supermat_run_desc"), "run_desc case %d: %s (%s)", k, supermat_result_string(r), err.message);
        cases++;
    }
    TU_CHECK(touched == 0, "refused runs wrote %lu output bytes", (unsigned long)touched);
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = (void *)img; rd.input.width = Q; rd.input.height = Q; rd.input.channels = 4;
    rd.albedo.pixels = alb; rd.albedo.channels = 3;
    rd.roughness.pixels = rgh; rd.roughness.channels = 1;
    rd.metallic.pixels = met; rd.metallic.channels = 1;
    r = supermat_run(s, &rd, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "run_desc, canaries 0: %s", err.message);
    printf("guards: %d uncleared / canary descriptors refused naming their struct (model, write_packed, session, session_memory, run); cleared ones run\n", cases);
    supermat_session_destroy(s);
    supermat_model_destroy(m);
}

/* ---- 5. a pre-packed file's options are the defaults ---- */
static void test_prepacked(const unsigned char *ddata, size_t dsize, const unsigned char *img) {
    static const fields p0 = {0, 0, 0.0f, 0.0f, 0, NULL};
    supermat_model_desc md;
    supermat_model_info info;
    supermat_model *pm = NULL, *um = NULL;
    supermat_error err;
    supermat_result r;
    tu_membuf b;
    unsigned char *raw, *al;
    maps a = maps_new(Q, Q), u = maps_new(Q, Q);
    uint64_t bytes = 0;
    if (!ddata) return;
    memset(&b, 0, sizeof b);
    b.fail_at = -1;
    memset(&md, 0, sizeof md);
    md.data = ddata; md.size = dsize; md.conv = SUPERMAT_CONV_WINOGRAD_F2;
    r = supermat_model_write_packed(&md, tu_mem_write, &b, &bytes, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && bytes == b.n, "write_packed (Winograd F2): %s", err.message);
    if (r) { free(b.p); maps_free(&a); maps_free(&u); return; }
    raw = (unsigned char *)malloc(b.n + 64); /* a 64-byte aligned copy, by hand */
    al = raw + (64 - (size_t)((uintptr_t)raw % 64)) % 64;
    memcpy(al, b.p, b.n);
    free(b.p);
    memset(&md, 0, sizeof md);
    md.data = al; md.size = (size_t)bytes;
    r = supermat_model_create(&md, &pm, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && pm, "pre-packed, conv / compute 0: %s", err.message);
    if (pm) {
        supermat_model_get_info(pm, &info);
        TU_CHECK(info.prepacked == 1 && info.conv == SUPERMAT_CONV_WINOGRAD_F2 && info.compute == SUPERMAT_COMPUTE_F32,
                 "pre-packed info: prepacked %d conv %d compute %d, want 1 / WINOGRAD_F2 / F32", info.prepacked, (int)info.conv, (int)info.compute);
        TU_CHECK(info.work_size == 256 && info.detail_sigma == 0.015625f && info.chroma_weight == 1.0f,
                 "pre-packed info: pipeline %d / %g / %g, want the original's 256 / 0.015625 / 1", info.work_size, (double)info.detail_sigma, (double)info.chroma_weight);
        um = create(ddata, dsize, SUPERMAT_CONV_WINOGRAD_F2, "default model, Winograd F2");
        if (um) {
            r = run_f32(pm, &p0, Q, Q, img, 4, &a, &err);
            TU_CHECK(r == SUPERMAT_SUCCESS, "pre-packed run: %s", err.message);
            r = run_f32(um, &p0, Q, Q, img, 4, &u, &err);
            TU_CHECK(r == SUPERMAT_SUCCESS, "unpacked Winograd F2 run: %s", err.message);
            TU_CHECK(maps_same(&a, &u) && maps_in01(&a), "pre-packed (options 0) and unpacked Winograd F2: maps not bit-identical");
            printf("pre-packed: %lu bytes, created with options 0: prepacked %d, conv %d; %dx%d maps %s the unpacked Winograd F2 model's\n",
                   (unsigned long)bytes, info.prepacked, (int)info.conv, Q, Q, maps_same(&a, &u) ? "==" : "!=");
        }
    }
    supermat_model_destroy(pm); supermat_model_destroy(um);
    free(raw);
    maps_free(&a); maps_free(&u);
}

/* ---- 6. alpha in roughness / metallic outputs ---- */
/* U8 outputs of one run (fields 0): roughness with rc channels, metallic with mc, orm with 4 (NULL = not wanted) */
static supermat_result run_u8(const supermat_model *m, int w, int h, const unsigned char *px, int ch, unsigned char *rough, int rc,
                              unsigned char *metal, int mc, unsigned char *orm4, supermat_error *err) {
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_result r;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = w; sd.height = h;
    if ((r = supermat_session_create(&sd, &s, err))) return r;
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = (void *)px; rd.input.width = w; rd.input.height = h; rd.input.channels = ch;
    rd.roughness.pixels = rough; rd.roughness.channels = rc;
    rd.metallic.pixels = metal; rd.metallic.channels = mc;
    rd.orm.pixels = orm4; rd.orm.channels = 4;
    r = supermat_run(s, &rd, err);
    supermat_session_destroy(s);
    return r;
}

/* the alpha checks on one model and picture (w x h RGBA img) */
static void alpha_case(const supermat_model *m, const char *what, int w, int h, const unsigned char *img) {
    size_t n = (size_t)w * h, i;
    unsigned char *r1 = (unsigned char *)malloc(n), *m1 = (unsigned char *)malloc(n), *r2 = (unsigned char *)malloc(n * 2),
                  *m4 = (unsigned char *)malloc(n * 4), *r4 = (unsigned char *)malloc(n * 4), *m2 = (unsigned char *)malloc(n * 2),
                  *orm = (unsigned char *)malloc(n * 4), *rgb = (unsigned char *)malloc(n * 3);
    long bad_gray = 0, bad_alpha = 0, bad_rgb = 0, bad_orm = 0, soft = 0;
    supermat_error err;
    supermat_result r;
    for (i = 0; i < n; i++) { memcpy(rgb + i * 3, img + i * 4, 3); soft += img[i * 4 + 3] > 0 && img[i * 4 + 3] < 255; }
    r = run_u8(m, w, h, img, 4, r1, 1, m1, 1, NULL, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%s: 1-channel roughness / metallic: %s", what, err.message);
    r = run_u8(m, w, h, img, 4, r2, 2, m4, 4, orm, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%s: 2-channel roughness, 4-channel metallic: %s", what, err.message);
    r = run_u8(m, w, h, img, 4, r4, 4, m2, 2, NULL, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%s: 4-channel roughness, 2-channel metallic: %s", what, err.message);
    for (i = 0; i < n; i++) {
        unsigned char a = img[i * 4 + 3];
        bad_gray += (r2[i * 2] != r1[i]) + (m2[i * 2] != m1[i]);
        bad_gray += (r4[i * 4] != r1[i]) + (r4[i * 4 + 1] != r1[i]) + (r4[i * 4 + 2] != r1[i]);
        bad_gray += (m4[i * 4] != m1[i]) + (m4[i * 4 + 1] != m1[i]) + (m4[i * 4 + 2] != m1[i]);
        bad_alpha += (r2[i * 2 + 1] != a) + (m2[i * 2 + 1] != a) + (r4[i * 4 + 3] != a) + (m4[i * 4 + 3] != a);
        bad_orm += orm[i * 4 + 3] != 255;
    }
    TU_CHECK(bad_gray == 0, "%s: %ld gray values of the 2 / 4-channel outputs differ from the 1-channel output", what, bad_gray);
    TU_CHECK(bad_alpha == 0 && soft > 0, "%s: %ld alpha values not the input's (%ld soft-alpha pixels)", what, bad_alpha, soft);
    TU_CHECK(bad_orm == 0, "%s: %ld orm 4th-channel values not 255", what, bad_orm);
    /* an RGB input: alpha 255 */
    r = run_u8(m, w, h, rgb, 3, r2, 2, m4, 4, NULL, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "%s: RGB input: %s", what, err.message);
    for (i = 0; i < n; i++) bad_rgb += (r2[i * 2 + 1] != 255) + (m4[i * 4 + 3] != 255);
    TU_CHECK(bad_rgb == 0, "%s: RGB input: %ld alpha values not 255", what, bad_rgb);
    printf("alpha outputs (%s, %dx%d): 2-channel = gray + input alpha, 4-channel = gray RGB + input alpha, orm alpha 255, RGB input alpha 255 (%ld soft-alpha pixels)\n",
           what, w, h, soft);
    free(r1); free(m1); free(r2); free(m4); free(r4); free(m2); free(orm); free(rgb);
}

/* the default model at the odd size (the maps resampled from the work size): one run with 2-channel roughness and
   4-channel metallic against the float 1-channel maps of test_zero_is_model's run (the same fields) */
static void alpha_default(const supermat_model *m, const unsigned char *img, const maps *odd) {
    size_t n = (size_t)PW * PH, i;
    unsigned char *r2 = (unsigned char *)malloc(n * 2), *m4 = (unsigned char *)malloc(n * 4);
    long bad_gray = 0, bad_alpha = 0;
    supermat_error err;
    supermat_result r = run_u8(m, PW, PH, img, 4, r2, 2, m4, 4, NULL, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "default %dx%d: 2-channel roughness, 4-channel metallic: %s", PW, PH, err.message);
    for (i = 0; i < n && r == SUPERMAT_SUCCESS; i++) {
        unsigned char a = img[i * 4 + 3], rg = (unsigned char)rintf(odd->rough[i] * 255.0f), mt = (unsigned char)rintf(odd->metal[i] * 255.0f);
        bad_gray += (r2[i * 2] != rg) + (m4[i * 4] != mt) + (m4[i * 4 + 1] != mt) + (m4[i * 4 + 2] != mt);
        bad_alpha += (r2[i * 2 + 1] != a) + (m4[i * 4 + 3] != a);
    }
    TU_CHECK(r == SUPERMAT_SUCCESS && bad_gray == 0, "default %dx%d: %ld gray values differ from the 1-channel float maps (8-bit)", PW, PH, bad_gray);
    TU_CHECK(r == SUPERMAT_SUCCESS && bad_alpha == 0, "default %dx%d: %ld alpha values not the input's", PW, PH, bad_alpha);
    printf("alpha outputs (default, %dx%d from work 256): 2-channel roughness = gray + input alpha, 4-channel metallic = gray RGB + input alpha\n", PW, PH);
    free(r2); free(m4);
}

/* ---- pipeline.bake_detail_sigma ---------------------------------------------------------------------- */
/* `path` with its last component replaced by `name` */
static void sibling(char *out, size_t cap, const char *path, const char *name) {
    const char *sl = strrchr(path, '/');
    if (sl) snprintf(out, cap, "%.*s/%s", (int)(sl - path), path, name);
    else snprintf(out, cap, "%s", name);
}
/* the file `data` with `members` ("\"key\":\"value\"") put first in its metadata; the header grows by a
   multiple of 64 bytes (padded with spaces), so the tensors keep their alignment. NULL when the file has no
   metadata object */
static unsigned char *with_meta(const unsigned char *data, size_t size, const char *members, size_t *out_size) {
    static const char mk[] = "\"__metadata__\":{";
    size_t hl, at, ml = strlen(members) + 1, nl, i;
    unsigned char *o;
    const char *h;
    if (size < 8) return NULL;
    for (hl = 0, i = 0; i < 8; i++) hl |= (size_t)data[i] << (8 * i);
    if (hl > size - 8) return NULL;
    h = (const char *)data + 8;
    for (at = 0; at + sizeof mk - 1 <= hl && memcmp(h + at, mk, sizeof mk - 1); at++) {}
    if (at + sizeof mk - 1 > hl) return NULL;
    at += sizeof mk - 1;
    nl = hl + (ml + 63) / 64 * 64;
    o = (unsigned char *)malloc(8 + nl + (size - 8 - hl));
    if (!o) return NULL;
    for (i = 0; i < 8; i++) o[i] = (unsigned char)(nl >> (8 * i));
    memcpy(o + 8, h, at);
    memcpy(o + 8 + at, members, ml - 1);
    o[8 + at + ml - 1] = ',';
    memcpy(o + 8 + at + ml, h + at, hl - at);
    memset(o + 8 + hl + ml, ' ', nl - hl - ml);
    memcpy(o + 8 + nl, data + 8 + hl, size - 8 - hl);
    *out_size = 8 + nl + (size - 8 - hl);
    return o;
}
/* creates the model of `data` with `members` added to its metadata: its result, the bake detail reported */
static supermat_result create_with(const unsigned char *data, size_t size, const char *members, float *bake, supermat_error *err) {
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_model_info info;
    supermat_result r;
    size_t n = 0;
    unsigned char *f = with_meta(data, size, members, &n);
    *bake = -1.0f;
    memset(err, 0, sizeof *err);
    if (!f) { TU_CHECK(0, "cannot add %s to the file", members); return SUPERMAT_ERROR_INVALID_ARGUMENT; }
    memset(&md, 0, sizeof md);
    md.data = f; md.size = n;
    r = supermat_model_create(&md, &m, err);
    memset(&info, 0, sizeof info);
    if (r == SUPERMAT_SUCCESS) { supermat_model_get_info(m, &info); *bake = info.bake_detail_sigma; }
    supermat_model_destroy(m);
    free(f);
    return r;
}
static void test_bake_detail(const supermat_model *def, const supermat_model *tiny, const unsigned char *tdata, size_t tsize,
                             const char *default_path, const char *uv_path) {
    static const struct { const char *v; float want; } ok[] = {{"0.03125", 0.03125f}, {"1", 1.0f}, {"0", 0.0f}, {"1e-3", 0.001f}};
    static const char *const bad[] = {"1.5", "-0.25", "abc", "", "0.5x", "nan", "1/32"};
    char path[1024], members[128];
    unsigned char *uv = NULL, *mv = NULL;
    size_t uvsize = 0, mvsize = 0, i;
    supermat_model_info info;
    supermat_error err;
    supermat_result r;
    float bake;
    int cases = 0;
    if (def) { supermat_model_get_info(def, &info); TU_CHECK(info.bake_detail_sigma == 0.0f, "default model: bake detail %g, want none", (double)info.bake_detail_sigma); }
    if (tiny) { supermat_model_get_info(tiny, &info); TU_CHECK(info.bake_detail_sigma == 0.0f, "tiny model: bake detail %g, want none", (double)info.bake_detail_sigma); }
    sibling(path, sizeof path, default_path, "supermat_mv_default.safetensors");
    if ((mv = tu_load(path, &mvsize)) != NULL) {
        supermat_model *m = create(mv, mvsize, SUPERMAT_CONV_DIRECT, path);
        if (m) {
            supermat_model_get_info(m, &info);
            TU_CHECK(info.kind == SUPERMAT_KIND_SUPERMAT_MV && info.bake_detail_sigma == 0.03125f,
                     "the multi-view default: kind %d bake detail %.9g, want supermat-mv / 0.03125", (int)info.kind, (double)info.bake_detail_sigma);
            supermat_model_destroy(m);
        }
        free(mv);
    } else printf("(no %s: its bake detail not checked)\n", path);
    if (!tdata) return;
    for (i = 0; i < sizeof ok / sizeof ok[0]; i++, cases++) {
        snprintf(members, sizeof members, "\"pipeline.bake_detail_sigma\":\"%s\"", ok[i].v);
        r = create_with(tdata, tsize, members, &bake, &err);
        TU_CHECK(r == SUPERMAT_SUCCESS && bake == ok[i].want, "tiny + bake detail '%s': %s, reported %.9g, want %.9g (%s)", ok[i].v,
                 supermat_result_string(r), (double)bake, (double)ok[i].want, err.message);
    }
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++, cases++) {
        snprintf(members, sizeof members, "\"pipeline.bake_detail_sigma\":\"%s\"", bad[i]);
        r = create_with(tdata, tsize, members, &bake, &err);
        TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE && strstr(err.message, "pipeline.bake_detail_sigma"),
                 "tiny + bake detail '%s': %s (%s), want MALFORMED_FILE naming the key", bad[i], supermat_result_string(r), err.message);
    }
    /* with the other steps: each reported as recorded */
    {
        supermat_model_desc md;
        supermat_model *m = NULL;
        size_t n = 0;
        unsigned char *f = with_meta(tdata, tsize, "\"pipeline.detail_sigma\":\"0.015625\",\"pipeline.chroma_weight\":\"1\","
                                                   "\"pipeline.bake_detail_sigma\":\"0.03125\"", &n);
        memset(&md, 0, sizeof md);
        md.data = f; md.size = n;
        TU_CHECK(f && supermat_model_create(&md, &m, &err) == SUPERMAT_SUCCESS, "tiny + all three steps: %s", f ? err.message : "no file");
        if (m) {
            supermat_model_get_info(m, &info);
            TU_CHECK(info.detail_sigma == 0.015625f && info.chroma_weight == 1.0f && info.bake_detail_sigma == 0.03125f,
                     "tiny + all three steps: %g / %g / %g, want 0.015625 / 1 / 0.03125", (double)info.detail_sigma, (double)info.chroma_weight,
                     (double)info.bake_detail_sigma);
        }
        supermat_model_destroy(m);
        free(f);
        cases++;
    }
    /* a uv-refine file: no views to bake, so no bake detail (0 is none, accepted) */
    if ((uv = tu_load(uv_path, &uvsize)) == NULL) { TU_CHECK(0, "cannot read the tiny uv-refine model %s", uv_path); return; }
    r = create_with(uv, uvsize, "\"supermat.x\":\"1\"", &bake, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "uv-refine + an unknown key: %s (%s), want the file to load", supermat_result_string(r), err.message);
    r = create_with(uv, uvsize, "\"pipeline.bake_detail_sigma\":\"0.03125\"", &bake, &err);
    TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE && strstr(err.message, "bake_detail_sigma") && strstr(err.message, "uv-refine"),
             "uv-refine + bake detail 0.03125: %s (%s), want MALFORMED_FILE naming the key and the kind", supermat_result_string(r), err.message);
    r = create_with(uv, uvsize, "\"pipeline.bake_detail_sigma\":\"0\"", &bake, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS && bake == 0.0f, "uv-refine + bake detail 0 (none): %s (%s)", supermat_result_string(r), err.message);
    cases += 3;
    free(uv);
    printf("bake detail: reported as recorded (%d tiny / uv-refine files), out of [0, 1] or not a number MALFORMED_FILE, > 0 on uv-refine MALFORMED_FILE%s\n",
           cases, mvsize ? "; the multi-view default records 1/32" : "");
}

/* ---- pipeline.roughness_curve / metallic_curve, session_desc.roughness_knots / metallic_knots ------------ */
#define CMAP(o) (g_curve_map ? (o).metal : (o).rough)
/* the curve through (i / (n - 1), k[i]) at x, in double */
static double curve64(const float *k, int n, double x) {
    double t;
    int i;
    x = x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
    t = x * (n - 1);
    i = (int)t;
    if (i > n - 2) i = n - 2;
    return k[i] + ((double)k[i + 1] - k[i]) * (t - i);
}
/* `on` is `off` through the curve where alpha (RGBA img, 4th byte) > 0, and unchanged elsewhere: the worst
   difference, and the pixels changed by more than 1e-6 */
static double curve_err(const maps *on, const maps *off, const unsigned char *img, const float *k, int n) {
    double worst = 0.0;
    size_t i;
    for (i = 0; i < on->n; i++) {
        double want = img[i * 4 + 3] > 0 ? curve64(k, n, CMAP(*off)[i]) : CMAP(*off)[i], d = fabs(CMAP(*on)[i] - want);
        if (d > worst) worst = d;
    }
    return worst;
}
/* the curve of map c (0 roughness, 1 metallic); def: the default model (for the metallic, with a curve added to
   its file: it records none) */
static void test_curve(int c, const supermat_model *def, const supermat_model *tiny, const unsigned char *tdata, size_t tsize,
                       const char *tiny_path, const char *uv_path, const unsigned char *img, const unsigned char *sq) {
    const char *map = c ? "metallic" : "roughness";
    char key[40];
    static const char *const bad[] = {"", "0.5", "0.5,0.4", "0,x", "0,1.5", "-0.1,1", "nan,1", "0;1", "0,1,", ",0,1", "0 1"};
    static const float c03[2] = {0.3f, 0.3f}, ident[2] = {0.0f, 1.0f}, falling[3] = {0.2f, 0.5f, 0.4f};
    char members[1400], list[1200];
    supermat_model_info info;
    supermat_error err;
    supermat_result r;
    float k[SUPERMAT_CURVE_MAX_KNOTS];
    int n = 0, i, cases = 0;
    size_t p;
    g_curve_map = c;
    snprintf(key, sizeof key, "pipeline.%s_curve", map);
    if (def) { /* the default model's curve (roughness: 9 knots; metallic: the one added), never falling, and a run goes through it */
        fields p0 = {0, 0, 0.0f, 0.0f, 0, NULL}, poff = {0, 0, 0.0f, 0.0f, SUPERMAT_CURVE_OFF, NULL}, pex = {0, 0, 0.0f, 0.0f, 0, NULL},
               pc = {0, 0, 0.0f, 0.0f, 2, c03}, pid = {0, 0, 0.0f, 0.0f, 2, ident};
        maps a = maps_new(PW, PH), off = maps_new(PW, PH), ex = maps_new(PW, PH), cc = maps_new(PW, PH), id = maps_new(PW, PH);
        double e1, e2 = 0.0, e3;
        const float *kk;
        int kn;
        supermat_model_get_info(def, &info);
        kk = c ? info.metallic_curve : info.roughness_curve; kn = c ? info.metallic_knots : info.roughness_knots;
        TU_CHECK(kn == (c ? 5 : 9), "default model: %d %s knots, want %d (%s)", kn, map, c ? 5 : 9, key);
        for (i = 1; i < kn; i++) TU_CHECK(kk[i] >= kk[i - 1], "default model: the %s curve falls at knot %d", map, i + 1);
        pex.rk = kn; pex.rc = kk;
        TU_CHECK(run_f32(def, &p0, PW, PH, img, 4, &a, &err) == SUPERMAT_SUCCESS, "curve: fields 0: %s", err.message);
        TU_CHECK(run_f32(def, &poff, PW, PH, img, 4, &off, &err) == SUPERMAT_SUCCESS, "curve: SUPERMAT_CURVE_OFF: %s", err.message);
        TU_CHECK(run_f32(def, &pex, PW, PH, img, 4, &ex, &err) == SUPERMAT_SUCCESS, "curve: the model's curve explicit: %s", err.message);
        TU_CHECK(run_f32(def, &pc, PW, PH, img, 4, &cc, &err) == SUPERMAT_SUCCESS, "curve: constant 0.3: %s", err.message);
        TU_CHECK(run_f32(def, &pid, PW, PH, img, 4, &id, &err) == SUPERMAT_SUCCESS, "curve: identity: %s", err.message);
        e1 = curve_err(&a, &off, img, kk, kn);
        TU_CHECK(e1 <= 1e-6, "the model's %s curve: %.3g from the float64 curve of the CURVE_OFF run (<= 1e-6)", map, e1);
        TU_CHECK(memcmp(CMAP(a), CMAP(off), a.n * sizeof(float)) != 0, "the model's %s curve changed nothing", map);
        TU_CHECK(!memcmp(a.albedo, off.albedo, a.n * 4 * sizeof(float)) && !memcmp(c ? a.rough : a.metal, c ? off.rough : off.metal, a.n * sizeof(float)),
                 "the %s curve changed the albedo or the %s map", map, c ? "roughness" : "metallic");
        TU_CHECK(maps_same(&a, &ex), "%s_knots 0 and the model's curve given explicitly: not bit-identical", map);
        e3 = curve_err(&cc, &off, img, c03, 2);
        TU_CHECK(e3 <= 1e-6, "constant 0.3 curve: %.3g from 0.3 / the network's %s (<= 1e-6)", e3, map);
        for (p = 0; p < id.n; p++) { double d = fabs(CMAP(id)[p] - CMAP(off)[p]); if (d > e2) e2 = d; }
        TU_CHECK(e2 <= 1e-6, "identity curve: %.3g from the CURVE_OFF run (<= 1e-6)", e2);
        printf("%s curve: default model %d knots, run within %.2g of float64 (alpha > 0; alpha 0 unchanged); explicit == 0; "
               "constant %.2g, identity %.2g\n", map, kn, e1, e3, e2);
        maps_free(&a); maps_free(&off); maps_free(&ex); maps_free(&cc); maps_free(&id);
    }
    if (tiny) { supermat_model_get_info(tiny, &info); TU_CHECK((c ? info.metallic_knots : info.roughness_knots) == 0, "tiny model: %d %s knots, want none", c ? info.metallic_knots : info.roughness_knots, map); }
    /* the session desc's guards (the tiny model at Q x Q, its own size) */
    if (tiny) {
        static const struct { int knots; const float *k; const char *what; } g[] = {
            {-2, ident, "knots -2"}, {1, ident, "1 knot"}, {SUPERMAT_CURVE_MAX_KNOTS + 1, ident, "34 knots"}, {2, NULL, "NULL curve"}, {3, falling, "a falling curve"}};
        static const float nanc[2] = {0.0f, 0.0f};
        float kn[2];
        maps o = maps_new(Q, Q);
        fields f = {0, 0, 0.0f, 0.0f, 0, NULL};
        for (i = 0; i < (int)(sizeof g / sizeof g[0]); i++, cases++) {
            f.rk = g[i].knots; f.rc = g[i].k;
            r = run_f32(tiny, &f, Q, Q, sq, 4, &o, &err);
            TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && strstr(err.message, map), "session with %s (%s): %s (%s), want INVALID_ARGUMENT naming the curve",
                     g[i].what, map, supermat_result_string(r), err.message);
        }
        memcpy(kn, nanc, sizeof kn);
        kn[1] = (float)nan("");
        f.rk = 2; f.rc = kn;
        r = run_f32(tiny, &f, Q, Q, sq, 4, &o, &err);
        TU_CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT, "session with a NaN knot: %s (%s), want INVALID_ARGUMENT", supermat_result_string(r), err.message);
        cases++;
        maps_free(&o);
    }
    if (!tdata) return;
    /* the file's key: what loads, what is refused */
    for (i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++, cases++) {
        supermat_model_desc md;
        supermat_model *m = NULL;
        size_t fn = 0;
        unsigned char *f;
        snprintf(members, sizeof members, "\"%s\":\"%s\"", key, bad[i]);
        f = with_meta(tdata, tsize, members, &fn);
        memset(&md, 0, sizeof md);
        md.data = f; md.size = fn;
        r = f ? supermat_model_create(&md, &m, &err) : SUPERMAT_ERROR_INVALID_ARGUMENT;
        TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE && strstr(err.message, key),
                 "tiny + %s '%s': %s (%s), want MALFORMED_FILE naming the key", key, bad[i], supermat_result_string(r), err.message);
        TU_CHECK(supermat_parse_curve(bad[i], k, &n, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT && n == 0, "supermat_parse_curve('%s') accepted it", bad[i]);
        supermat_model_destroy(m);
        free(f);
    }
    { /* 34 knots; a value too long for the reader; not a string */
        static const char *const what[3] = {"34 knots", "1100 bytes", "a number, not a string"};
        for (i = 0, list[0] = 0; i <= SUPERMAT_CURVE_MAX_KNOTS; i++) strcat(list, i ? ",0.5" : "0.5");
        for (i = 0; i < 3; i++, cases++) {
            supermat_model_desc md;
            supermat_model *m = NULL;
            size_t fn = 0;
            unsigned char *f;
            if (i == 0) snprintf(members, sizeof members, "\"%s\":\"%s\"", key, list);
            else if (i == 1) { memset(list, ' ', 1100); list[0] = '0'; list[1098] = ','; list[1099] = '1'; list[1100] = 0;
                               snprintf(members, sizeof members, "\"%s\":\"%s\"", key, list); }
            else snprintf(members, sizeof members, "\"%s\":0.5", key);
            f = with_meta(tdata, tsize, members, &fn);
            memset(&md, 0, sizeof md);
            md.data = f; md.size = fn;
            r = f ? supermat_model_create(&md, &m, &err) : SUPERMAT_ERROR_INVALID_ARGUMENT;
            TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE && strstr(err.message, key),
                     "tiny + %s of %s: %s (%s), want MALFORMED_FILE naming the key", key, what[i], supermat_result_string(r), err.message);
            supermat_model_destroy(m);
            free(f);
        }
    }
    { /* loads: spaces, 33 knots; reported as written */
        static const struct { const char *text; int n; float first, last; } ok[] = {{"0,1", 2, 0.0f, 1.0f}, {" 0.1 , 0.2,0.2 ", 3, 0.1f, 0.2f}, {NULL, 33, 0.0f, 1.0f}};
        for (i = 0, list[0] = 0; i < SUPERMAT_CURVE_MAX_KNOTS; i++) snprintf(list + strlen(list), sizeof list - strlen(list), "%s%.9g", i ? "," : "", i / 32.0);
        for (i = 0; i < 3; i++, cases++) {
            supermat_model_desc md;
            supermat_model *m = NULL;
            size_t fn = 0;
            unsigned char *f;
            const char *t = ok[i].text ? ok[i].text : list;
            snprintf(members, sizeof members, "\"%s\":\"%s\"", key, t);
            f = with_meta(tdata, tsize, members, &fn);
            memset(&md, 0, sizeof md);
            md.data = f; md.size = fn;
            r = f ? supermat_model_create(&md, &m, &err) : SUPERMAT_ERROR_INVALID_ARGUMENT;
            const float *kk;
            int kn, kother;
            memset(&info, 0, sizeof info);
            if (m) supermat_model_get_info(m, &info);
            kk = c ? info.metallic_curve : info.roughness_curve; kn = c ? info.metallic_knots : info.roughness_knots;
            kother = c ? info.roughness_knots : info.metallic_knots;
            TU_CHECK(r == SUPERMAT_SUCCESS && kn == ok[i].n && kk[0] == ok[i].first && kk[ok[i].n - 1] == ok[i].last && kother == 0,
                     "tiny + %s '%.40s': %s (%s), %d knots %g..%g (the other curve %d), want %d %g..%g (0)", key, t, supermat_result_string(r), err.message, kn,
                     (double)kk[0], (double)kk[kn > 0 ? kn - 1 : 0], kother, ok[i].n, (double)ok[i].first, (double)ok[i].last);
            TU_CHECK(supermat_parse_curve(t, k, &n, &err) == SUPERMAT_SUCCESS && n == ok[i].n && !memcmp(k, kk, sizeof(float) * (size_t)n),
                     "supermat_parse_curve('%.40s') reads another curve than the file reader", t);
            supermat_model_destroy(m);
            free(f);
        }
    }
    { /* uv-refine: no roughness / metallic map */
        size_t uvsize = 0, fn = 0;
        unsigned char *uv = tu_load(uv_path, &uvsize), *f = NULL;
        supermat_model_desc md;
        supermat_model *m = NULL;
        snprintf(members, sizeof members, "\"%s\":\"0,1\"", key);
        if (uv) f = with_meta(uv, uvsize, members, &fn);
        memset(&md, 0, sizeof md);
        md.data = f; md.size = fn;
        r = f ? supermat_model_create(&md, &m, &err) : SUPERMAT_ERROR_INVALID_ARGUMENT;
        TU_CHECK(r == SUPERMAT_ERROR_MALFORMED_FILE && strstr(err.message, key) && strstr(err.message, "uv-refine"),
                 "uv-refine + %s: %s (%s), want MALFORMED_FILE", key, supermat_result_string(r), err.message);
        supermat_model_destroy(m);
        free(f); free(uv);
        cases++;
    }
    { /* the tiny multi-view model with a curve in its file: every view goes through it */
        char mvp[1024];
        size_t mvsize = 0, fn = 0;
        unsigned char *mv, *f = NULL;
        sibling(mvp, sizeof mvp, tiny_path, "tiny_supermat_mv.safetensors");
        if ((mv = tu_load(mvp, &mvsize)) != NULL) {
            static const float curve[3] = {0.1f, 0.8f, 0.9f};
            supermat_model *m = NULL, *m0 = NULL;
            supermat_model_desc md;
            float *rough[2][2], cams[2 * 16];
            double worst = 0.0;
            int pass, v, changed = 0;
            snprintf(members, sizeof members, "\"%s\":\"0.1,0.8,0.9\"", key);
            f = with_meta(mv, mvsize, members, &fn);
            memset(&md, 0, sizeof md);
            md.data = f; md.size = fn;
            TU_CHECK(f && supermat_model_create(&md, &m, &err) == SUPERMAT_SUCCESS, "tiny multi-view + curve: %s", err.message);
            m0 = create(mv, mvsize, SUPERMAT_CONV_DIRECT, mvp);
            for (i = 0; i < 2 * 16; i++) cams[i] = (i % 5 == 0) ? 1.0f : 0.1f * (float)(i % 7);
            for (pass = 0; pass < 2 && m && m0; pass++) {
                supermat_session_desc sd;
                supermat_session *s = NULL;
                supermat_run_desc rd;
                supermat_image in[2], ro[2];
                memset(&sd, 0, sizeof sd);
                sd.model = pass ? m0 : m; sd.width = Q; sd.height = Q; sd.views = 2;
                memset(&rd, 0, sizeof rd);
                memset(in, 0, sizeof in); memset(ro, 0, sizeof ro);
                for (v = 0; v < 2; v++) {
                    rough[pass][v] = (float *)malloc(sizeof(float) * Q * Q);
                    in[v].pixels = (void *)sq; in[v].width = Q; in[v].height = Q; in[v].channels = 4;
                    ro[v].pixels = rough[pass][v]; ro[v].channels = 1; ro[v].format = SUPERMAT_FORMAT_F32;
                }
                rd.input_views = in; rd.cameras = cams;
                if (c) rd.metallic_views = ro;
                else rd.roughness_views = ro;
                r = supermat_session_create(&sd, &s, &err);
                if (!r) r = supermat_run(s, &rd, &err);
                TU_CHECK(r == SUPERMAT_SUCCESS, "tiny multi-view run (%s): %s", pass ? "no curve" : "curve", err.message);
                supermat_session_destroy(s);
            }
            if (m && m0)
                for (v = 0; v < 2; v++)
                    for (p = 0; p < (size_t)Q * Q; p++) {
                        double want = sq[p * 4 + 3] > 0 ? curve64(curve, 3, rough[1][v][p]) : rough[1][v][p], d = fabs(rough[0][v][p] - want);
                        if (d > worst) worst = d;
                        changed += rough[0][v][p] != rough[1][v][p];
                    }
            TU_CHECK(m && m0 && worst <= 1e-6 && changed > 0, "tiny multi-view + %s: %.3g from the float64 curve of the run without (<= 1e-6), %d pixels changed", key, worst, changed);
            printf("%s curve: tiny multi-view, 2 views through the file's curve within %.2g (%d pixels changed)\n", map, worst, changed);
            if (m && m0) for (pass = 0; pass < 2; pass++) for (v = 0; v < 2; v++) free(rough[pass][v]);
            supermat_model_destroy(m); supermat_model_destroy(m0);
            free(f); free(mv);
            cases++;
        } else printf("(no %s: the multi-view curve not checked)\n", mvp);
    }
    printf("%s curve: %d file / session / parser cases refused or read as written\n", map, cases);
}

int main(int argc, char **argv) {
    static unsigned char img[PW * PH * 4], sq[Q * Q * 4];
    unsigned char *ddata = NULL, *tdata = NULL;
    size_t dsize = 0, tsize = 0;
    supermat_model *def, *tiny;
    maps odd;
    char uv_path[1024];
    if (argc < 3) { fprintf(stderr, "usage: %s DEFAULT_MODEL TINY_MODEL [TINY_UV_MODEL]\n", argv[0]); return 2; }
    if (argc > 3) snprintf(uv_path, sizeof uv_path, "%s", argv[3]);
    else sibling(uv_path, sizeof uv_path, argv[2], "tiny_uv_refine_bc.safetensors");
    ddata = load(argv[1], &dsize); tdata = load(argv[2], &tsize);
    def = create(ddata, dsize, SUPERMAT_CONV_DIRECT, argv[1]);
    tiny = create(tdata, tsize, SUPERMAT_CONV_DIRECT, argv[2]);
    tu_disc_rgba(img, PW, PH, 47, 66, 41);   /* soft-edged disc: alpha 0, partial and 255 */
    tu_disc_rgba(sq, Q, Q, 30, 34, 24);
    odd = maps_new(PW, PH);
    test_info(def, tiny);
    test_bake_detail(def, tiny, tdata, tsize, argv[1], uv_path);
    test_curve(0, def, tiny, tdata, tsize, argv[2], uv_path, img, sq);
    { /* the metallic curve: the default model with one added to its file (it records none) */
        size_t fn = 0;
        unsigned char *f = ddata ? with_meta(ddata, dsize, "\"pipeline.metallic_curve\":\"0,0.02,0.3,0.8,1\"", &fn) : NULL;
        supermat_model *defm = f ? create(f, fn, SUPERMAT_CONV_DIRECT, "default model + metallic curve") : NULL;
        test_curve(1, defm, tiny, tdata, tsize, argv[2], uv_path, img, sq);
        supermat_model_destroy(defm);
        free(f);
    }
    if (def) { test_zero_is_model(def, img, &odd); test_sizes(def, tiny, img, &odd); }
    test_guards(tdata, tsize, sq);
    test_prepacked(ddata, dsize, sq);
    if (tiny) alpha_case(tiny, "tiny", Q, Q, sq);
    if (def) alpha_default(def, img, &odd);
    maps_free(&odd);
    supermat_model_destroy(def); supermat_model_destroy(tiny);
    free(ddata); free(tdata);
    return tu_finish("pipeline");
}
