/* The CI quality floor (a regression guard for the default model): runs a model on an evaluation slice
   and checks the mean masked PSNR of each map against a committed floor.

   usage: test_quality MODEL.safetensors SLICE_DIR FLOOR.txt [DETAIL_SIGMA [CHROMA_WEIGHT [WORK_SIZE [ROUGH_CURVE]]]]
   (each `model` when absent: the session field left 0, the model file's pipeline; `off` / `native`: none)

   SLICE_DIR/index.txt   one stem per line (blank lines and lines starting with # are skipped)
   SLICE_DIR/<stem>.png            the input picture, RGBA (straight alpha)
   SLICE_DIR/<stem>_albedo.png     the true albedo, sRGB RGB 8-bit
   SLICE_DIR/<stem>_roughness.png  the true roughness, gray 8-bit
   SLICE_DIR/<stem>_metallic.png   the true metallic, gray 8-bit
   FLOOR.txt             one line per map: "albedo 21.3", "roughness 17.0", "metallic 15.2" (dB); # starts
                         a comment; all three maps are required

   For each stem the model computes all three maps (DETAIL_SIGMA: session_desc.detail_sigma; CHROMA_WEIGHT:
   session_desc.chroma_weight; WORK_SIZE N: the network at N x N, session_desc.work_width / work_height, the
   maps resampled back to the picture's size; ROUGH_CURVE off: SUPERMAT_CURVE_OFF for the roughness and the metallic curve; all four `model`: what the
   quick start and `supermat image` run); they are quantised to 8 bits
   exactly as `supermat image` writes its PNGs (rintf(clamp(v) * 255)), so the comparison is the one a
   user gets from the files. PSNR per map = 10 log10(1 / MSE), MSE over the pixels whose input alpha is
   >= 128 and over their channels, values in [0, 1] (v / 255), capped at 100 dB. The table lists each
   stem and the mean per map (the mean of the stems' dB values); the test passes when every mean is at
   least its floor. An empty slice, a missing or unreadable file, a size mismatch, a stem without any
   pixel of alpha >= 128 or a bad floor file is a failure of its own. Exit status 0 pass, 1 fail,
   2 usage. */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#endif
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "../supermat.h"
#include "test_util.h"
#include <ctype.h>
#include <time.h>

#if defined(__GNUC__) || defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpragmas"
#pragma GCC diagnostic ignored "-Wunknown-warning-option"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wzero-as-null-pointer-constant"
#endif
#define STB_IMAGE_IMPLEMENTATION
#define STBI_FAILURE_USERMSG
#define STBI_ONLY_PNG
#include <stb/stb_image.h>
#if defined(__GNUC__) || defined(__clang__)
#pragma GCC diagnostic pop
#endif

#define Q_MAPS 3
#define Q_PSNR_CAP 100.0
#define Q_PATH 4096
static const char *const q_map_names[Q_MAPS] = {"albedo", "roughness", "metallic"};
static const int q_map_channels[Q_MAPS] = {3, 1, 1};

/* FLOOR.txt -> floors[3]; 0 on success, else a message and -1 */
static int q_read_floor(const char *path, double *floors) {
    FILE *f = fopen(path, "r");
    char line[512];
    int have[Q_MAPS] = {0, 0, 0}, lineno = 0, k, bad = 0;
    if (!f) { printf("FAIL: cannot open the floor file '%s'\n", path); return -1; }
    while (fgets(line, sizeof line, f)) {
        char name[64], extra[8], *hash = strchr(line, '#');
        double v;
        int n;
        lineno++;
        if (hash) *hash = 0;
        line[strcspn(line, "\r\n")] = 0;
        n = sscanf(line, "%63s %lf %7s", name, &v, extra);
        if (n <= 0) {
            /* a blank or comment-only line, unless sscanf saw something it could not read */
            const char *p = line;
            while (*p && isspace((unsigned char)*p)) p++;
            if (!*p) continue;
        }
        if (n != 2) { printf("FAIL: %s:%d: expected 'MAP DB' (e.g. 'albedo 21.3'), got '%s'\n", path, lineno, line); bad = 1; continue; }
        for (k = 0; k < Q_MAPS && strcmp(name, q_map_names[k]); k++) {}
        if (k == Q_MAPS) { printf("FAIL: %s:%d: unknown map '%s' (albedo, roughness, metallic)\n", path, lineno, name); bad = 1; continue; }
        if (have[k]) { printf("FAIL: %s:%d: a second floor for %s\n", path, lineno, name); bad = 1; continue; }
        if (!(v == v) || v < 0.0 || v > Q_PSNR_CAP) { printf("FAIL: %s:%d: %s floor %g is not in [0, %g]\n", path, lineno, name, v, Q_PSNR_CAP); bad = 1; continue; }
        have[k] = 1;
        floors[k] = v;
    }
    fclose(f);
    for (k = 0; k < Q_MAPS; k++)
        if (!have[k]) { printf("FAIL: %s: no floor for %s\n", path, q_map_names[k]); bad = 1; }
    return bad ? -1 : 0;
}

/* SLICE_DIR/index.txt -> *stems (malloc'ed strings), the count; -1 with a message if unreadable */
static int q_read_index(const char *dir, char ***stems) {
    char path[Q_PATH], line[1024];
    FILE *f;
    int n = 0, cap = 0;
    *stems = NULL;
    snprintf(path, sizeof path, "%s/index.txt", dir);
    if (!(f = fopen(path, "r"))) { printf("FAIL: cannot open the slice index '%s'\n", path); return -1; }
    while (fgets(line, sizeof line, f)) {
        char *s = line, *e;
        while (*s && isspace((unsigned char)*s)) s++;
        e = s + strlen(s);
        while (e > s && isspace((unsigned char)e[-1])) *--e = 0;
        if (!*s || *s == '#') continue;
        if (n == cap) {
            char **grown = (char **)realloc(*stems, sizeof(char *) * (size_t)(cap ? cap * 2 : 16));
            if (!grown) { fclose(f); printf("FAIL: out of memory\n"); return -1; }
            *stems = grown;
            cap = cap ? cap * 2 : 16;
        }
        (*stems)[n] = (char *)malloc(strlen(s) + 1);
        if (!(*stems)[n]) { fclose(f); printf("FAIL: out of memory\n"); return -1; }
        strcpy((*stems)[n], s);
        n++;
    }
    fclose(f);
    return n;
}

/* masked PSNR of 8-bit a against 8-bit b (c channels), mask = alpha of rgba >= 128 */
static double q_psnr(const unsigned char *a, const unsigned char *b, int c, const unsigned char *rgba, size_t np, size_t *masked) {
    double sse = 0.0, mse;
    size_t i, m = 0;
    int k;
    for (i = 0; i < np; i++) {
        if (rgba[i * 4 + 3] < 128) continue;
        m++;
        for (k = 0; k < c; k++) {
            double d = ((double)a[i * c + k] - (double)b[i * c + k]) / 255.0;
            sse += d * d;
        }
    }
    *masked = m;
    if (!m) return 0.0;
    mse = sse / ((double)m * c);
    if (mse <= 0.0) return Q_PSNR_CAP;
    mse = 10.0 * log10(1.0 / mse);
    return mse > Q_PSNR_CAP ? Q_PSNR_CAP : mse;
}

static double q_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

int main(int argc, char **argv) {
    const char *model_path, *dir, *floor_path;
    double floors[Q_MAPS] = {0.0, 0.0, 0.0}, sums[Q_MAPS] = {0.0, 0.0, 0.0};
    unsigned char *file;
    size_t file_size = 0;
    char **stems = NULL;
    int nstems, s, k, counted = 0, sw = 0, sh = 0;
    supermat_model_desc md;
    supermat_model *model = NULL;
    supermat_session *sess = NULL;
    supermat_error err;
    supermat_result r;
    float detail = 0.0f, chroma = 0.0f; /* 0: the model file's (session_desc's zero), SUPERMAT_OFF: off */
    int work = 0;                        /* 0: the model file's, SUPERMAT_WORK_NATIVE: the picture's own size */
    int curve = 0;                       /* 0: the model file's roughness and metallic curves, SUPERMAT_CURVE_OFF: none */

    if (argc < 4 || argc > 8) {
        printf("usage: %s MODEL.safetensors SLICE_DIR FLOOR.txt [DETAIL_SIGMA|off|model [CHROMA_WEIGHT|off|model [WORK_SIZE|native|model [ROUGH_CURVE|off|model]]]]\n", argv[0]);
        return 2;
    }
    if (argc >= 5 && strcmp(argv[4], "model")) {
        char *end = NULL;
        detail = strcmp(argv[4], "off") ? strtof(argv[4], &end) : SUPERMAT_OFF;
        if (detail != SUPERMAT_OFF && (!end || *end || !(detail > 0.0f && detail <= 1.0f))) { printf("usage: DETAIL_SIGMA '%s': off, model or a number in (0, 1]\n", argv[4]); return 2; }
    }
    if (argc >= 6 && strcmp(argv[5], "model")) {
        char *end = NULL;
        chroma = strcmp(argv[5], "off") ? strtof(argv[5], &end) : SUPERMAT_OFF;
        if (chroma != SUPERMAT_OFF && (!end || *end || !(chroma > 0.0f && chroma <= 1.0f))) { printf("usage: CHROMA_WEIGHT '%s': off, model or a number in (0, 1]\n", argv[5]); return 2; }
    }
    if (argc == 8 && strcmp(argv[7], "model")) {
        if (strcmp(argv[7], "off")) { printf("usage: ROUGH_CURVE '%s': off or model\n", argv[7]); return 2; }
        curve = SUPERMAT_CURVE_OFF;
    }
    if (argc >= 7 && strcmp(argv[6], "model")) {
        char *end = NULL;
        long v;
        if (!strcmp(argv[6], "native")) work = SUPERMAT_WORK_NATIVE;
        else {
            v = strtol(argv[6], &end, 10);
            if (!end || *end || v < 8 || v > 16384 || v % 8) { printf("usage: WORK_SIZE '%s': native, model or a multiple of 8 up to 16384\n", argv[6]); return 2; }
            work = (int)v;
        }
    }
    model_path = argv[1];
    dir = argv[2];
    floor_path = argv[3];
    TU_CHECK(q_read_floor(floor_path, floors) == 0, "the floor file '%s' is not usable", floor_path);
    nstems = q_read_index(dir, &stems);
    TU_CHECK(nstems > 0, "the slice %s is %s", dir, nstems < 0 ? "unreadable (no index.txt)" : "empty: index.txt lists no stem");
    if (tu_fail) { for (s = 0; s < nstems; s++) free(stems[s]); free(stems); return tu_finish("quality"); }

    file = tu_load(model_path, &file_size);
    TU_CHECK(file != NULL, "cannot read the model '%s'", model_path);
    if (!file) { for (s = 0; s < nstems; s++) free(stems[s]); free(stems); return tu_finish("quality"); }
    printf("quality: model %s, slice %s, floor %s, detail_sigma %s, chroma_weight %s, work size %s, roughness curve %s (model: the file's pipeline)\n", model_path, dir,
           floor_path, argc >= 5 ? argv[4] : "model", argc >= 6 ? argv[5] : "model", argc >= 7 ? argv[6] : "model", argc >= 8 ? argv[7] : "model");
    memset(&md, 0, sizeof md);
    md.data = file;
    md.size = file_size;
    r = supermat_model_create(&md, &model, &err);
    TU_CHECK(r == SUPERMAT_SUCCESS, "model '%s': %s [%s]", model_path, err.message, supermat_result_string(r));

    printf("\n%-28s %10s %10s %10s %9s %7s\n", "stem (PSNR dB, alpha>=128)", "albedo", "roughness", "metallic", "pixels", "s");
    for (s = 0; s < nstems && model; s++) {
        char path[Q_PATH];
        unsigned char *in = NULL, *truth[Q_MAPS] = {NULL, NULL, NULL}, *got[Q_MAPS] = {NULL, NULL, NULL};
        float *maps[Q_MAPS] = {NULL, NULL, NULL};
        int w = 0, h = 0, c, ok = 1;
        double psnr[Q_MAPS], t0 = q_now();
        size_t np = 0, masked = 0, i;
        snprintf(path, sizeof path, "%s/%s.png", dir, stems[s]);
        in = stbi_load(path, &w, &h, &c, 4);
        TU_CHECK(in != NULL, "%s: cannot read the input '%s': %s", stems[s], path, stbi_failure_reason());
        if (!in) continue;
        np = (size_t)w * (size_t)h;
        for (k = 0; k < Q_MAPS; k++) {
            int tw = 0, th = 0;
            snprintf(path, sizeof path, "%s/%s_%s.png", dir, stems[s], q_map_names[k]);
            truth[k] = stbi_load(path, &tw, &th, &c, q_map_channels[k]);
            TU_CHECK(truth[k] != NULL, "%s: cannot read the true %s '%s': %s", stems[s], q_map_names[k], path, stbi_failure_reason());
            if (!truth[k]) { ok = 0; continue; }
            TU_CHECK(tw == w && th == h, "%s: the true %s is %dx%d, the input %dx%d", stems[s], q_map_names[k], tw, th, w, h);
            if (tw != w || th != h) ok = 0;
        }
        if (ok && (!sess || w != sw || h != sh)) {
            supermat_session_desc sd;
            supermat_session_destroy(sess);
            sess = NULL;
            memset(&sd, 0, sizeof sd);
            sd.model = model; sd.width = w; sd.height = h; sd.detail_sigma = detail; sd.chroma_weight = chroma;
            sd.work_width = sd.work_height = work;
            sd.roughness_knots = sd.metallic_knots = curve;
            r = supermat_session_create(&sd, &sess, &err);
            TU_CHECK(r == SUPERMAT_SUCCESS, "%s: session %dx%d: %s [%s]", stems[s], w, h, err.message, supermat_result_string(r));
            if (r != SUPERMAT_SUCCESS) { sess = NULL; ok = 0; }
            sw = w; sh = h;
        }
        for (k = 0; k < Q_MAPS && ok; k++) {
            maps[k] = (float *)malloc(sizeof(float) * np * (size_t)q_map_channels[k]);
            got[k] = (unsigned char *)malloc(np * (size_t)q_map_channels[k]);
            if (!maps[k] || !got[k]) { TU_CHECK(0, "%s: out of memory", stems[s]); ok = 0; }
        }
        if (ok) {
            supermat_run_desc rd;
            memset(&rd, 0, sizeof rd);
            rd.input.pixels = in; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
            rd.input.format = SUPERMAT_FORMAT_U8;
            rd.albedo.pixels = maps[0]; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
            rd.roughness.pixels = maps[1]; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
            rd.metallic.pixels = maps[2]; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
            r = supermat_run(sess, &rd, &err);
            TU_CHECK(r == SUPERMAT_SUCCESS, "%s: run: %s [%s]", stems[s], err.message, supermat_result_string(r));
            if (r != SUPERMAT_SUCCESS) ok = 0;
        }
        for (k = 0; k < Q_MAPS && ok; k++) {
            size_t n = np * (size_t)q_map_channels[k];
            for (i = 0; i < n; i++) { /* as `supermat image` writes its PNGs */
                float v = maps[k][i];
                v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
                got[k][i] = (unsigned char)rintf(v * 255.0f);
            }
            psnr[k] = q_psnr(got[k], truth[k], q_map_channels[k], in, np, &masked);
        }
        if (ok) {
            TU_CHECK(masked > 0, "%s: no pixel with alpha >= 128: nothing to compare", stems[s]);
            if (masked > 0) {
                printf("%-28s %10.2f %10.2f %10.2f %9lu %7.2f\n", stems[s], psnr[0], psnr[1], psnr[2], (unsigned long)masked, q_now() - t0);
                for (k = 0; k < Q_MAPS; k++) sums[k] += psnr[k];
                counted++;
            }
        }
        for (k = 0; k < Q_MAPS; k++) { free(maps[k]); free(got[k]); stbi_image_free(truth[k]); }
        stbi_image_free(in);
        fflush(stdout);
    }

    if (counted) {
        printf("%-28s", "mean");
        for (k = 0; k < Q_MAPS; k++) printf(" %10.2f", sums[k] / counted);
        printf("   (%d of %d stems)\n%-28s", counted, nstems, "floor");
        for (k = 0; k < Q_MAPS; k++) printf(" %10.2f", floors[k]);
        printf("\n\n");
        for (k = 0; k < Q_MAPS; k++) {
            double mean = sums[k] / counted;
            TU_CHECK(mean >= floors[k], "%s: mean PSNR %.2f dB is below the floor %.2f dB", q_map_names[k], mean, floors[k]);
        }
    }
    TU_CHECK(counted == nstems, "%d of %d stems could not be measured", nstems - counted, nstems);

    supermat_session_destroy(sess);
    supermat_model_destroy(model);
    free(file);
    for (s = 0; s < nstems; s++) free(stems[s]);
    free(stems);
    return tu_finish("quality");
}
