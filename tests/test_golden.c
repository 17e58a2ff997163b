/* Stage-by-stage comparison of the C pipeline with goldens made by the official code (tests/data/golden).
   usage: test_golden MODEL.safetensors GOLDEN_DIR [scalar|avx2] [threads] */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include "test_util.h"

typedef struct golden_ctx { const char *dir; double tol; int checked, inject; char first_drift[64]; } golden_ctx;

/* the goldens are NCHW with the batch = branches for x0; the runtime gives NHWC */
static void inspect(void *user, supermat_stage stage, int branch, float *d, int n, int h, int w, int c) {
    golden_ctx *g = (golden_ctx *)user;
    const char *file = NULL;
    char path[512], name[64];
    tu_npy ref;
    float *nchw;
    size_t i, per = (size_t)h * w * c, batch_off = 0;
    int x, y, ch;
    double e;
    switch (stage) {
    case SUPERMAT_STAGE_INPUT: return;
    case SUPERMAT_STAGE_LATENT: file = "image_latent.npy"; snprintf(name, sizeof name, "latent"); break;
    case SUPERMAT_STAGE_UNET_OUT: snprintf(name, sizeof name, "unet_out_b%d", branch); file = name; break;
    case SUPERMAT_STAGE_X0: file = "x0_latents.npy"; batch_off = (size_t)branch; snprintf(name, sizeof name, "x0_b%d", branch); break;
    case SUPERMAT_STAGE_DECODED: snprintf(name, sizeof name, "vae_decoded_b%d", branch); file = name; break;
    default: return;
    }
    if (file == name) { snprintf(path, sizeof path, "%s/%s.npy", g->dir, name); }
    else snprintf(path, sizeof path, "%s/%s", g->dir, file);
    if (tu_npy_load(path, &ref)) { TU_CHECK(0, "cannot read %s", path); return; }
    TU_CHECK(ref.n >= (batch_off + 1) * per * n, "%s: golden has %zu values, runtime %zu", name, ref.n, per * n);
    if (ref.n < (batch_off + 1) * per * n) { free(ref.data); return; }
    nchw = (float *)malloc(per * n * sizeof(float));
    for (i = 0; i < (size_t)n; i++)
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++)
                for (ch = 0; ch < c; ch++) nchw[i * per + ((size_t)ch * h + y) * w + x] = d[i * per + ((size_t)y * w + x) * c + ch];
    e = tu_rel_l2(nchw, ref.data + batch_off * per * n, per * n);
    printf("  %-16s rel L2 %.3g\n", name, e);
    if (e > g->tol && !g->first_drift[0]) snprintf(g->first_drift, sizeof g->first_drift, "%s", name);
    TU_CHECK(e <= g->tol, "stage %s drifts: relative L2 %.3g > %.1g", name, e, g->tol);
    g->checked++;
    if (g->inject) /* continue from the golden values: the next stage is then checked on its own */
        for (i = 0; i < (size_t)n; i++)
            for (y = 0; y < h; y++)
                for (x = 0; x < w; x++)
                    for (ch = 0; ch < c; ch++) d[i * per + ((size_t)y * w + x) * c + ch] = ref.data[batch_off * per * n + i * per + ((size_t)ch * h + y) * w + x];
    free(nchw);
    free(ref.data);
}

static void run_case(supermat_model *model, const char *dir, int inject, double tol, int threads) {
    supermat_session_desc sd;
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_error err;
    tu_npy src, ra, ro;
    golden_ctx g;
    char path[512];
    float *rgb, *albedo, *rough, *metal;
    int W, H, x, y, c;
    snprintf(path, sizeof path, "%s/inputs/source_image.npy", dir);
    if (tu_npy_load(path, &src) || src.ndim != 4) { TU_CHECK(0, "cannot read %s", path); return; }
    H = (int)src.shape[2]; W = (int)src.shape[3];
    printf("%s (%dx%d), %s, tolerance %.0e:\n", dir, W, H, inject ? "each stage from the golden input of that stage" : "chained end to end", tol);
    rgb = (float *)malloc(sizeof(float) * 3 * W * H);
    for (y = 0; y < H; y++) for (x = 0; x < W; x++) for (c = 0; c < 3; c++) rgb[(y * W + x) * 3 + c] = src.data[((size_t)c * H + y) * W + x];
    memset(&sd, 0, sizeof sd);
    sd.model = model; sd.width = W; sd.height = H; sd.threads = threads;
    TU_CHECK(supermat_session_create(&sd, &s, &err) == SUPERMAT_SUCCESS, "session_create: %s", err.message);
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = rgb; rd.input.width = W; rd.input.height = H; rd.input.channels = 3; rd.input.format = SUPERMAT_FORMAT_F32;
    albedo = (float *)malloc(sizeof(float) * 3 * W * H); rough = (float *)malloc(sizeof(float) * W * H); metal = (float *)malloc(sizeof(float) * W * H);
    rd.albedo.pixels = albedo; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
    rd.roughness.pixels = rough; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
    rd.metallic.pixels = metal; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
    memset(&g, 0, sizeof g);
    g.dir = dir; g.tol = tol; g.inject = inject;
    rd.inspect = inspect; rd.inspect_user = &g;
    if (s) {
        TU_CHECK(supermat_run(s, &rd, &err) == SUPERMAT_SUCCESS, "run: %s", err.message);
        TU_CHECK(g.checked == 7, "%d stages checked, expected 7", g.checked);
        snprintf(path, sizeof path, "%s/albedo.npy", dir);
        if (!tu_npy_load(path, &ra)) {
            float *nchw = (float *)malloc(sizeof(float) * 3 * W * H);
            double e;
            for (y = 0; y < H; y++) for (x = 0; x < W; x++) for (c = 0; c < 3; c++) nchw[((size_t)c * H + y) * W + x] = albedo[(y * W + x) * 3 + c];
            e = tu_rel_l2(nchw, ra.data, (size_t)3 * W * H);
            printf("  %-16s rel L2 %.3g\n", "albedo", e);
            TU_CHECK(e <= tol, "albedo drifts: %.3g", e);
            free(nchw); free(ra.data);
        } else TU_CHECK(0, "cannot read %s", path);
        snprintf(path, sizeof path, "%s/orm.npy", dir);
        if (!tu_npy_load(path, &ro)) {
            double e1 = tu_rel_l2(rough, ro.data + (size_t)W * H, (size_t)W * H), e2 = tu_rel_l2(metal, ro.data + (size_t)2 * W * H, (size_t)W * H);
            printf("  %-16s rel L2 %.3g\n  %-16s rel L2 %.3g\n", "roughness", e1, "metallic", e2);
            TU_CHECK(e1 <= tol && e2 <= tol, "roughness/metallic drift: %.3g %.3g", e1, e2);
            free(ro.data);
        } else TU_CHECK(0, "cannot read %s", path);
        if (g.first_drift[0]) printf("  first stage that drifts: %s\n", g.first_drift);
    }
    supermat_session_destroy(s);
    free(rgb); free(albedo); free(rough); free(metal); free(src.data);
}

int main(int argc, char **argv) {
    size_t size = 0;
    unsigned char *file;
    supermat_model_desc md;
    supermat_model *model = NULL;
    supermat_error err;
    int threads, i;
    const char *kern;
    if (argc < 4) { fprintf(stderr, "usage: %s MODEL auto|scalar|avx2 THREADS GOLDEN_DIR...\n", argv[0]); return 2; }
    kern = argv[2];
    threads = atoi(argv[3]);
    file = tu_load(argv[1], &size);
    if (!file) { printf("cannot read %s\n", argv[1]); return 1; }
    memset(&md, 0, sizeof md);
    md.data = file; md.size = size;
    if (!strcmp(kern, "scalar")) md.kernel = SUPERMAT_KERNEL_SCALAR;
    if (!strcmp(kern, "avx2")) {
        if (!supermat_cpu_has_avx2()) { printf("no AVX2 on this CPU: skipped\n0 passed, 0 failed\n"); free(file); return 0; }
        md.kernel = SUPERMAT_KERNEL_AVX2;
    }
    TU_CHECK(supermat_model_create(&md, &model, &err) == SUPERMAT_SUCCESS, "model_create: %s", err.message);
    if (model) {
        for (i = 4; i < argc; i++) {
            run_case(model, argv[i], 1, 1e-5, threads);   /* the bound, per stage */
            run_case(model, argv[i], 0, 1e-4, threads);   /* the whole chain (errors compound) */
        }
    }
    supermat_model_destroy(model);
    free(file);
    return tu_finish("golden");
}
