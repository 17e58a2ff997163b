/* int8 model files (`supermat convert --precision int8`) against the format's definition and the
   runtime's own quantization at load (tiny official-architecture models):
   - every GEMM weight of the int8 file is I8 with an F32 `<name>_scale` [rows][taps][ceil(cin/64)];
     recomputed here from the f32 file: each scale is max |w| / 127 of its group (output channel, kernel
     tap, 64 input channels), |w - q s| <= s / 2 (1 + 1e-4: float rounding of s and w 127 / max), |q| <= 127; every other tensor (1-D, the cross-attention
     keys / values) keeps the f32 file's bytes.
   - the int8 file loads to the same model bytes and bit-identical maps (single view, multi-view, UV
     refine) as the f32 file loaded with weights = int8, and as the int8 file loaded with weights = f32
     (its dequantized values are the very products the int8 kernels widen to).
   - malformed int8 files fail with clear errors: a missing scale tensor, a scale of the wrong shape,
     NaN or negative scales, an I8 tensor of the wrong rank.
   usage: test_int8 F32_MODEL I8_MODEL [F32_MV I8_MV F32_UV I8_UV] */
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "../supermat.h"
#include "test_util.h"

typedef struct file { unsigned char *data; size_t size; supermat_tensor_info *ti; int n; } file;

static int index_file(file *f) {
    supermat_error err;
    int i;
    if (supermat_safetensors_count(f->data, f->size, f->size, &f->n, &err)) { TU_CHECK(0, "%s", err.message); return -1; }
    f->ti = (supermat_tensor_info *)malloc(sizeof *f->ti * (size_t)(f->n + 1));
    for (i = 0; i < f->n; i++)
        if (supermat_safetensors_tensor(f->data, f->size, f->size, i, &f->ti[i], &err)) { TU_CHECK(0, "%s", err.message); return -1; }
    return 0;
}
static int tensor(const file *f, const char *name, supermat_tensor_info *ti) {
    int i;
    for (i = 0; i < f->n; i++)
        if (!strcmp(f->ti[i].name, name)) { *ti = f->ti[i]; return i; }
    return -1;
}

/* the int8 file's tensors against the f32 file's */
static void test_format(const file *f32, const file *i8, const char *what) {
    int i, quantized = 0, kept = 0, bad_scale = 0, bad_round = 0, bad_kept = 0, bad_q = 0;
    double worst = 0;
    supermat_tensor_info ti, tf, ts;
    for (i = 0; i < i8->n; i++) {
        size_t len;
        ti = i8->ti[i];
        len = strlen(ti.name);
        if (len > 6 && !strcmp(ti.name + len - 6, "_scale")) continue;
        if (tensor(f32, ti.name, &tf) < 0) { TU_CHECK(0, "%s: tensor '%s' is not in the f32 file", what, ti.name); continue; }
        if (ti.dtype != SUPERMAT_DTYPE_I8) { /* kept: the same bytes */
            kept++;
            if (ti.dtype != tf.dtype || ti.nbytes != tf.nbytes || memcmp(i8->data + ti.offset, f32->data + tf.offset, (size_t)ti.nbytes)) bad_kept++;
            /* a GEMM weight must have been quantized: only the folded cross-attention keys / values stay */
            if ((ti.ndim == 2 || ti.ndim == 4) && len > 7 && !strcmp(ti.name + len - 7, ".weight") && !strstr(ti.name, ".attn2.to_k.") && !strstr(ti.name, ".attn2.to_v."))
                TU_CHECK(0, "%s: weight '%s' was not quantized", what, ti.name);
            continue;
        }
        quantized++;
        {
            char sn[200];
            int64_t rows = ti.shape[0], cin = ti.shape[1], taps = ti.ndim == 4 ? ti.shape[2] * ti.shape[3] : 1, ng = (cin + 63) / 64, r, t, g, c;
            const signed char *q = (const signed char *)(i8->data + ti.offset);
            snprintf(sn, sizeof sn, "%s_scale", ti.name);
            if (tensor(i8, sn, &ts) < 0 || ts.dtype != SUPERMAT_DTYPE_F32 || ts.ndim != 3 || ts.shape[0] != rows || ts.shape[1] != taps || ts.shape[2] != ng ||
                tf.dtype != SUPERMAT_DTYPE_F32 || tf.nbytes != ti.nbytes * 4) {
                TU_CHECK(0, "%s: '%s': no F32 scale [%lld, %lld, %lld] or no F32 source", what, ti.name, (long long)rows, (long long)taps, (long long)ng);
                continue;
            }
            for (r = 0; r < rows; r++)
                for (t = 0; t < taps; t++)
                    for (g = 0; g < ng; g++) {
                        float s, mx = 0.0f;
                        memcpy(&s, i8->data + ts.offset + 4 * (size_t)((r * taps + t) * ng + g), 4);
                        for (c = g * 64; c < cin && c < g * 64 + 64; c++) {
                            float w;
                            memcpy(&w, f32->data + tf.offset + 4 * (size_t)((r * cin + c) * taps + t), 4);
                            if (fabsf(w) > mx) mx = fabsf(w);
                        }
                        if (s != mx / 127.0f) bad_scale++;
                        for (c = g * 64; c < cin && c < g * 64 + 64; c++) {
                            size_t o = (size_t)((r * cin + c) * taps + t);
                            float w;
                            double e;
                            memcpy(&w, f32->data + tf.offset + 4 * o, 4);
                            if (q[o] < -127) bad_q++;
                            e = fabs((double)w - (double)q[o] * s);
                            if (s > 0 && e / (0.5 * s) > worst) worst = e / (0.5 * s);
                            if (e > 0.5 * s * (1 + 1e-4)) bad_round++; /* + the float rounding of s and of w * 127 / max */
                        }
                    }
        }
    }
    printf("%s: %d tensors quantized, %d kept (same bytes); worst |w - q s| = %.6f s/2; file %.2f MiB vs f32 %.2f MiB (%.3fx)\n", what, quantized, kept,
           worst, i8->size / 1048576.0, f32->size / 1048576.0, (double)i8->size / (double)f32->size);
    TU_CHECK(quantized > 20, "%s: only %d tensors quantized", what, quantized);
    TU_CHECK(bad_scale == 0 && bad_round == 0 && bad_q == 0, "%s: %d scales differ from max|w|/127, %d values off by more than s/2, %d q = -128", what, bad_scale,
             bad_round, bad_q);
    TU_CHECK(bad_kept == 0, "%s: %d kept tensors changed", what, bad_kept);
}

static supermat_model *load(const file *f, supermat_weights w, supermat_model_info *info) {
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    memset(&md, 0, sizeof md);
    md.data = f->data; md.size = f->size; md.weights = w;
    if (supermat_model_create(&md, &m, &err)) { TU_CHECK(0, "load: %s", err.message); return NULL; }
    supermat_model_get_info(m, info);
    return m;
}

enum { S = 64, V = 3, M = 32 };
#define OUT_FLOATS (S * S * 6 > V * M * M * 3 ? S * S * 6 : V * M * M * 3)

/* one run of any kind; float outputs into out */
static int run(supermat_model *m, const supermat_model_info *info, float *out) {
    static unsigned char px[V][S * S * 4];
    static float map[S * S * 3], mask[S * S], pos[S * S * 3];
    supermat_image in[V], ov[V];
    float cams[V * 16];
    supermat_session_desc sd;
    supermat_session *s;
    supermat_run_desc rd;
    supermat_error err;
    int i, r;
    memset(&sd, 0, sizeof sd);
    memset(&rd, 0, sizeof rd);
    sd.model = m; sd.threads = 2;
    if (info->kind == SUPERMAT_KIND_SUPERMAT_MV) {
        tu_mv_views(V, M, px[0], in, ov, out, cams);
        sd.width = M; sd.height = M; sd.views = V; sd.outputs = SUPERMAT_OUTPUT_ALBEDO;
        rd.input_views = in; rd.albedo_views = ov; rd.cameras = cams;
    } else if (info->kind == SUPERMAT_KIND_UV_REFINE) {
        for (i = 0; i < S * S; i++) {
            int x = i % S, y = i / S, c = x < 40 && y < 50;
            mask[i] = (c && y < 30) ? 1.0f : 0.0f;
            map[i * 3] = (float)(x % 17) / 16.0f; map[i * 3 + 1] = (float)(y % 13) / 12.0f; map[i * 3 + 2] = 0.5f;
            pos[i * 3] = c ? (float)x / S : 127.0f / 255.0f; pos[i * 3 + 1] = c ? (float)y / S : 127.0f / 255.0f; pos[i * 3 + 2] = c ? 0.25f : 127.0f / 255.0f;
        }
        sd.width = S; sd.height = S;
        rd.input.pixels = map; rd.input.width = S; rd.input.height = S; rd.input.channels = 3; rd.input.format = SUPERMAT_FORMAT_F32;
        rd.mask = rd.input; rd.mask.pixels = mask; rd.mask.channels = 1;
        rd.position = rd.input; rd.position.pixels = pos;
        rd.refined.pixels = out; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
    } else {
        tu_disc_rgba(px[0], S, S, 30, 28, 20);
        sd.width = S; sd.height = S;
        rd.input.pixels = px[0]; rd.input.width = S; rd.input.height = S; rd.input.channels = 4;
        rd.albedo.pixels = out; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
        rd.orm.pixels = out + S * S * 3; rd.orm.channels = 3; rd.orm.format = SUPERMAT_FORMAT_F32;
    }
    if (supermat_session_create(&sd, &s, &err)) { TU_CHECK(0, "session: %s", err.message); return -1; }
    r = supermat_run(s, &rd, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "run: %s", err.message);
    supermat_session_destroy(s);
    return r;
}

static void test_same(const file *f32, const file *i8, const char *what) {
    static float a[OUT_FLOATS], b[OUT_FLOATS], c[OUT_FLOATS], d[OUT_FLOATS];
    supermat_model_info ia, ib, ic, id;
    supermat_model *ma = load(i8, SUPERMAT_WEIGHTS_DEFAULT, &ia), *mb = load(f32, SUPERMAT_WEIGHTS_I8, &ib);
    supermat_model *mc = load(i8, SUPERMAT_WEIGHTS_F32, &ic), *md = load(f32, SUPERMAT_WEIGHTS_F32, &id);
    double e = 0, nrm = 0;
    size_t i;
    if (!ma || !mb || !mc || !md) goto done;
    memset(a, 0, sizeof a); memset(b, 0, sizeof b); memset(c, 0, sizeof c); memset(d, 0, sizeof d); /* MV and UV fill a part */
    TU_CHECK(ia.weights == SUPERMAT_WEIGHTS_I8 && ib.weights == SUPERMAT_WEIGHTS_I8 && ic.weights == SUPERMAT_WEIGHTS_F32, "%s: weights %d %d %d", what, (int)ia.weights,
             (int)ib.weights, (int)ic.weights);
    TU_CHECK(ia.model_bytes == ib.model_bytes, "%s: model bytes %llu (int8 file) vs %llu (f32 file, int8 at load)", what, (unsigned long long)ia.model_bytes,
             (unsigned long long)ib.model_bytes);
    if (run(ma, &ia, a) || run(mb, &ib, b) || run(mc, &ic, c) || run(md, &id, d)) goto done;
    TU_CHECK(!memcmp(a, b, sizeof a), "%s: maps of the int8 file differ from int8 made at load", what);
    TU_CHECK(!memcmp(a, c, sizeof a), "%s: maps of the int8 file as int8 and as f32 differ", what);
    for (i = 0; i < OUT_FLOATS; i++) { e += (double)(a[i] - d[i]) * (a[i] - d[i]); nrm += (double)d[i] * d[i]; }
    printf("%s: int8 file == int8 at load == int8 file as f32 (bit-identical maps); model %.2f MiB vs f32 %.2f MiB; rel L2 vs f32 maps %.3g\n", what,
           ia.model_bytes / 1048576.0, id.model_bytes / 1048576.0, sqrt(e / (nrm + 1e-30)));
    TU_CHECK(ia.model_bytes < id.model_bytes, "%s: int8 model not smaller", what);
    TU_CHECK(sqrt(e / (nrm + 1e-30)) < 0.2, "%s: int8 maps differ from f32 by rel L2 %.3g", what, sqrt(e / (nrm + 1e-30)));
done:
    supermat_model_destroy(ma); supermat_model_destroy(mb); supermat_model_destroy(mc); supermat_model_destroy(md);
}

/* ---- malformed int8 files ---- */
static char *entry(unsigned char *data, const char *name) { /* the header text after "name": */
    uint64_t hl = 0;
    int i;
    char needle[220], *h;
    size_t n;
    for (i = 7; i >= 0; i--) hl = (hl << 8) | data[i];
    snprintf(needle, sizeof needle, "\"%s\":", name);
    n = strlen(needle);
    h = (char *)data + 8;
    for (i = 0; (uint64_t)i + n <= hl; i++) if (!memcmp(h + i, needle, n)) return h + i + n;
    return NULL;
}
/* rewrites the shape array of `name` in place (same length: padded with spaces inside the brackets) */
static int set_shape(unsigned char *data, const char *name, const long long *dims, int nd) {
    char *e = entry(data, name), *s, *t, buf[96];
    size_t o = 0, len;
    int k;
    if (!e || !(s = strstr(e, "\"shape\":[")) || !(t = strchr(s, ']'))) return -1;
    s += 8;
    len = (size_t)(t - s) + 1;
    o += (size_t)snprintf(buf, sizeof buf, "[");
    for (k = 0; k < nd; k++) o += (size_t)snprintf(buf + o, sizeof buf - o, k ? ",%lld" : "%lld", dims[k]);
    if (o + 1 > len) return -1;
    while (o + 1 < len) buf[o++] = ' ';
    buf[o++] = ']';
    memcpy(s, buf, len);
    return 0;
}

static void expect(const char *what, const unsigned char *data, size_t size, supermat_result want, const char *tensor_name) {
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    supermat_result r;
    memset(&md, 0, sizeof md);
    md.data = data; md.size = size;
    r = supermat_model_create(&md, &m, &err);
    TU_CHECK(r == want, "%s: got %s (%s), want %s", what, supermat_result_string(r), err.message, supermat_result_string(want));
    if (tensor_name) TU_CHECK(!strcmp(err.tensor, tensor_name), "%s: error names '%s', want '%s'", what, err.tensor, tensor_name);
    if (r == want) printf("  %-34s -> %s: %s\n", what, supermat_result_string(r), err.message);
    supermat_model_destroy(m);
}

static void test_malformed(const file *i8) {
    unsigned char *c = (unsigned char *)malloc(i8->size);
    supermat_tensor_info tw, ts;
    char *e;
    float v;
    long long d[4];
    if (!c || tensor(i8, "conv_in.weight", &tw) < 0 || tensor(i8, "conv_in.weight_scale", &ts) < 0 || tw.dtype != SUPERMAT_DTYPE_I8) {
        TU_CHECK(0, "conv_in.weight is not I8 with a scale");
        free(c);
        return;
    }
    /* the scale renamed away */
    memcpy(c, i8->data, i8->size);
    e = entry(c, "conv_in.weight_scale");
    if (e) { e[-3] = 'X'; expect("scale tensor missing", c, i8->size, SUPERMAT_ERROR_MISSING_TENSOR, "conv_in.weight_scale"); }
    /* the scale's taps and groups swapped (same element count) */
    memcpy(c, i8->data, i8->size);
    d[0] = ts.shape[0]; d[1] = ts.shape[2]; d[2] = ts.shape[1];
    TU_CHECK(ts.shape[1] != ts.shape[2] && set_shape(c, "conv_in.weight_scale", d, 3) == 0, "rewrite the scale shape");
    expect("scale of the wrong shape", c, i8->size, SUPERMAT_ERROR_SHAPE_MISMATCH, "conv_in.weight_scale");
    /* NaN and a negative scale */
    memcpy(c, i8->data, i8->size);
    v = NAN; memcpy(c + ts.offset + 4, &v, 4);
    expect("NaN scale", c, i8->size, SUPERMAT_ERROR_NONFINITE, "conv_in.weight_scale");
    memcpy(c, i8->data, i8->size);
    v = -0.5f; memcpy(c + ts.offset, &v, 4);
    expect("negative scale", c, i8->size, SUPERMAT_ERROR_MALFORMED_FILE, "conv_in.weight_scale");
    /* the weight flattened to 1-D (same element count) */
    memcpy(c, i8->data, i8->size);
    d[0] = (long long)tw.nbytes;
    TU_CHECK(set_shape(c, "conv_in.weight", d, 1) == 0, "rewrite the weight shape");
    expect("I8 tensor of rank 1", c, i8->size, SUPERMAT_ERROR_MALFORMED_FILE, "conv_in.weight");
    free(c);
}

int main(int argc, char **argv) {
    file f[6];
    int i, n = argc - 1;
    if (n != 2 && n != 6) { fprintf(stderr, "usage: %s F32_MODEL I8_MODEL [F32_MV I8_MV F32_UV I8_UV]\n", argv[0]); return 2; }
    for (i = 0; i < n; i++) {
        f[i].data = tu_load(argv[i + 1], &f[i].size);
        if (!f[i].data) { printf("cannot read %s\n", argv[i + 1]); return 1; }
        if (index_file(&f[i])) return 1;
    }
    for (i = 0; i < n; i += 2) {
        const char *what = i == 0 ? "supermat" : i == 2 ? "supermat-mv" : "uv-refine";
        test_format(&f[i], &f[i + 1], what);
        test_same(&f[i], &f[i + 1], what);
    }
    test_malformed(&f[1]);
    for (i = 0; i < n; i++) { free(f[i].data); free(f[i].ti); }
    return tu_finish("int8");
}
