/* bench/harness.c - the evaluation harness of `supermat bench --image`: each mode (one speed / memory lever:
 * weights, Winograd, compute, kernel, tiles, branches, resolution, multi-view attention) runs on the same real
 * input; its float maps are compared with the f32 mode's (PSNR over all pixels and the foreground, max abs
 * error) and, with --truth-*, with ground truth (gt_psnr, on the maps quantised as `supermat image` writes
 * them); the table is printed and, with --json, written as a JSON list.
 * Depends on supermat.h's public API only, bench/peak.c (the FMA peak for %peak) and the CLI's shared
 * helpers (cli/io.c: pictures, cameras, checked outputs), beside which cli/bench.c includes it (one
 * translation unit). The options come in a cli_bench_opts, the state of a run in its own structs: nothing
 * at file scope changes.
 */

/* >>benchimage */
/* `supermat bench --image`: each mode (one speed / memory lever) runs on the same real input; the f32
   mode is the reference every other mode's float maps are compared with. */
enum {
    CLI_MODE_F32, CLI_MODE_F16, CLI_MODE_BF16, CLI_MODE_INT8, CLI_MODE_WINOGRAD_F2, CLI_MODE_WINOGRAD_F4,
    CLI_MODE_TILED_VAE, CLI_MODE_FOREGROUND, CLI_MODE_BRANCH_ALBEDO, CLI_MODE_BRANCH_RM, CLI_MODE_RES256,
    CLI_MODE_RES384, CLI_MODE_RES512, CLI_MODE_RES768, CLI_MODE_MV_WINDOW_OWN, CLI_MODE_MV_WINDOW_STRIDE4,
    CLI_MODE_BF16_COMPUTE, CLI_MODE_KERNEL_AVX2, CLI_MODE_BF16_AMX, CLI_MODE_BF16_AMX_WF4,
    CLI_MODE_INT8_COMPUTE, CLI_MODE_INT8_COMPUTE_WF4, CLI_MODE_INT8_COMPUTE_AVX2,
    CLI_MODE_COUNT
};
/* the model kinds a mode applies to */
#define CLI_KS 1u  /* supermat */
#define CLI_KMV 2u /* supermat-mv */
#define CLI_KUV 4u /* uv-refine */
static const struct { const char *name; unsigned kinds; } cli_modes[CLI_MODE_COUNT] = {
    {"f32", CLI_KS | CLI_KMV | CLI_KUV},         {"f16", CLI_KS | CLI_KMV | CLI_KUV},
    {"bf16", CLI_KS | CLI_KMV | CLI_KUV},        {"int8", CLI_KS | CLI_KMV | CLI_KUV},
    {"winograd_f2", CLI_KS | CLI_KMV | CLI_KUV}, {"winograd_f4", CLI_KS | CLI_KMV | CLI_KUV},
    {"tiled_vae", CLI_KS | CLI_KMV | CLI_KUV},   {"foreground", CLI_KS | CLI_KMV | CLI_KUV},
    {"branch_albedo", CLI_KS | CLI_KMV},         {"branch_rm", CLI_KS | CLI_KMV},
    {"res256", CLI_KS | CLI_KMV},                {"res384", CLI_KS | CLI_KMV},
    {"res512", CLI_KUV},                         {"res768", CLI_KUV},
    {"mv_window_own", CLI_KMV},                  {"mv_window_stride4", CLI_KMV},
    {"bf16_compute", CLI_KS | CLI_KMV | CLI_KUV}, {"kernel_avx2", CLI_KS | CLI_KMV | CLI_KUV},
    {"bf16_amx", CLI_KS | CLI_KMV | CLI_KUV},     {"bf16_amx_wf4", CLI_KS | CLI_KMV | CLI_KUV},
    {"int8_compute", CLI_KS | CLI_KMV | CLI_KUV}, {"int8_compute_wf4", CLI_KS | CLI_KMV | CLI_KUV},
    {"int8_compute_avx2", CLI_KS | CLI_KMV | CLI_KUV},
};
/* what a mode asks of the model: set by cli_mode_setup, read by cli_bi_model */
typedef struct cli_bi_mode {
    supermat_weights weights;
    supermat_conv conv;
    supermat_compute compute;
    int kernel; /* a supermat_kernel, or -1: the run's own kernel */
} cli_bi_mode;

static unsigned cli_kind_bit(supermat_model_kind k) {
    return k == SUPERMAT_KIND_SUPERMAT ? CLI_KS : k == SUPERMAT_KIND_SUPERMAT_MV ? CLI_KMV : k == SUPERMAT_KIND_UV_REFINE ? CLI_KUV : 0u;
}

/* --modes: "all" (*n = 0 and *all = 1) or a comma list of names, in the order given, without repeats */
static int cli_parse_modes(const char *cmd, const char *s, int *list, int *n, int *all) {
    const char *p = s;
    int seen[CLI_MODE_COUNT], k;
    memset(seen, 0, sizeof seen);
    *n = 0; *all = 0;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == 3 && !strncmp(p, "all", 3)) *all = 1;
        else if (len != 0) {
            for (k = 0; k < CLI_MODE_COUNT; k++)
                if (strlen(cli_modes[k].name) == len && !strncmp(p, cli_modes[k].name, len)) break;
            if (k == CLI_MODE_COUNT) {
                char names[1000];
                size_t used = 0;
                int j;
                names[0] = 0;
                for (j = 0; j < CLI_MODE_COUNT && used < sizeof names; j++)
                    used += (size_t)snprintf(names + used, sizeof names - used, "%s%s", j ? ", " : "", cli_modes[j].name);
                cli_usage_error(cmd, "--modes: unknown mode '%.*s' (all, or a comma list of: %s)", (int)len, p, names);
                return -1;
            }
            if (!seen[k]) { seen[k] = 1; list[(*n)++] = k; }
        }
        p += len;
        if (*p == ',') p++;
    }
    if (!*all && !*n) { cli_usage_error(cmd, "--modes: empty list"); return -1; }
    return 0;
}

/* what one mode changes: the model (weights, conv), the outputs and the session levers. Returns 0,
   or 1 if the mode does not apply to this image (a resolution not below the image's), with `why`. */
static int cli_mode_setup(int mode, int w, int h, cli_bi_mode *bm, unsigned *outputs, supermat_session_desc *sd, char *why,
                          size_t why_cap) {
    int S = w > h ? w : h, t, R = 0;
    supermat_weights *weights = &bm->weights;
    supermat_conv *conv = &bm->conv;
    *weights = SUPERMAT_WEIGHTS_F32;
    *conv = SUPERMAT_CONV_DIRECT;
    *outputs = SUPERMAT_OUTPUT_ALL;
    bm->compute = SUPERMAT_COMPUTE_F32;
    bm->kernel = -1;
    switch (mode) {
    case CLI_MODE_BF16_COMPUTE: /* vdpbf16ps on the AVX-512 kernel */
        if (!supermat_cpu().avx512_bf16) { snprintf(why, why_cap, "this CPU (or build) has no AVX512_BF16"); return 1; }
        bm->compute = SUPERMAT_COMPUTE_BF16;
        bm->kernel = SUPERMAT_KERNEL_AVX512;
        break;
    case CLI_MODE_BF16_AMX_WF4: /* AMX for the GEMMs of bf16 weights, Winograd F4 (f32) for the 3x3 convolutions */
        *conv = SUPERMAT_CONV_WINOGRAD_F4;
        /* fall through */
    case CLI_MODE_BF16_AMX:
        if (!supermat_cpu().amx_bf16) { snprintf(why, why_cap, "this CPU (OS or build) has no AMX-BF16"); return 1; }
        bm->compute = SUPERMAT_COMPUTE_BF16;
        bm->kernel = SUPERMAT_KERNEL_AMX;
        break;
    case CLI_MODE_INT8_COMPUTE_WF4: /* int8 compute for the GEMMs, Winograd F4 (f32) for the 3x3 convolutions */
        *conv = SUPERMAT_CONV_WINOGRAD_F4;
        /* fall through */
    case CLI_MODE_INT8_COMPUTE: /* vpdpbusd on the AVX-512 kernel (AVX512_VNNI), else on the AVX2 one (AVX-VNNI) */
        if (!supermat_cpu().avx512_vnni && !supermat_cpu().avx_vnni) {
            snprintf(why, why_cap, "this CPU (or build) has neither AVX512_VNNI nor AVX-VNNI");
            return 1;
        }
        bm->compute = SUPERMAT_COMPUTE_INT8;
        bm->kernel = supermat_cpu().avx512_vnni ? SUPERMAT_KERNEL_AVX512 : SUPERMAT_KERNEL_AVX2;
        break;
    case CLI_MODE_INT8_COMPUTE_AVX2: /* beside int8_compute on AVX512_VNNI: the 256-bit AVX-VNNI kernel, the same bits */
        if (!supermat_cpu().avx_vnni) { snprintf(why, why_cap, "this CPU (or build) has no AVX-VNNI"); return 1; }
        if (!supermat_cpu().avx512_vnni) { snprintf(why, why_cap, "int8_compute already runs the AVX-VNNI kernel"); return 1; }
        bm->compute = SUPERMAT_COMPUTE_INT8;
        bm->kernel = SUPERMAT_KERNEL_AVX2;
        break;
    case CLI_MODE_KERNEL_AVX2: /* beside the f32 row's AVX-512 kernel: the same bits, the time of the narrower one */
        if (!supermat_cpu().avx512) { snprintf(why, why_cap, "the f32 row already runs the AVX2 (or scalar) kernel"); return 1; }
        bm->kernel = SUPERMAT_KERNEL_AVX2;
        break;
    case CLI_MODE_F16: *weights = SUPERMAT_WEIGHTS_F16; break;
    case CLI_MODE_BF16: *weights = SUPERMAT_WEIGHTS_BF16; break;
    case CLI_MODE_INT8: *weights = SUPERMAT_WEIGHTS_I8; break;
    case CLI_MODE_WINOGRAD_F2: *conv = SUPERMAT_CONV_WINOGRAD_F2; break;
    case CLI_MODE_WINOGRAD_F4: *conv = SUPERMAT_CONV_WINOGRAD_F4; break;
    case CLI_MODE_TILED_VAE: /* 2x2 tiles */
        t = ((S / 8 + 4) / 2) * 8;
        sd->vae_tile = t < 40 ? 40 : t; /* larger than the overlap */
        sd->vae_overlap = 32;
        break;
    case CLI_MODE_FOREGROUND:
        t = (S / 4 + 16 + 7) / 8 * 8;
        sd->vae_tile = t < 32 ? 32 : t;
        sd->vae_overlap = 16;
        sd->skip_background = 1;
        break;
    case CLI_MODE_BRANCH_ALBEDO: *outputs = SUPERMAT_OUTPUT_ALBEDO; break;
    case CLI_MODE_BRANCH_RM: *outputs = SUPERMAT_OUTPUT_ROUGHNESS | SUPERMAT_OUTPUT_METALLIC; break;
    case CLI_MODE_RES256: R = 256; break;
    case CLI_MODE_RES384: R = 384; break;
    case CLI_MODE_RES512: R = 512; break;
    case CLI_MODE_RES768: R = 768; break;
    case CLI_MODE_MV_WINDOW_OWN: sd->mv_attention = SUPERMAT_MV_ATTENTION_OWN_VIEW; break;
    case CLI_MODE_MV_WINDOW_STRIDE4: sd->mv_attention = SUPERMAT_MV_ATTENTION_STRIDED; sd->mv_key_stride = 4; break;
    default: break;
    }
    if (R) {
        int ww, hh;
        if (R >= S) {
            snprintf(why, why_cap, "the network size %d is not below the image's %dx%d", R, w, h);
            return 1;
        }
        /* the longer side R, the other in proportion, both multiples of 8 */
        ww = (int)floor((double)w * R / S / 8.0 + 0.5) * 8;
        hh = (int)floor((double)h * R / S / 8.0 + 0.5) * 8;
        sd->work_width = ww < 8 ? 8 : ww;
        sd->work_height = hh < 8 ? 8 : hh;
    }
    return 0;
}

/* this machine's CPU name (Linux /proc/cpuinfo), or "" */
static void cli_cpu_name(char *buf, size_t cap) {
    FILE *f = fopen("/proc/cpuinfo", "r");
    char line[512];
    buf[0] = 0;
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        if (!strncmp(line, "model name", 10)) {
            char *c = strchr(line, ':'), *e;
            if (c) {
                c++;
                while (*c == ' ' || *c == '\t') c++;
                e = c + strlen(c);
                while (e > c && (e[-1] == '\n' || e[-1] == '\r' || e[-1] == ' ')) *--e = 0;
                snprintf(buf, cap, "%s", c);
            }
            break;
        }
    }
    fclose(f);
}

/* the input of every mode */
typedef struct cli_bi_input {
    supermat_model_kind kind;
    int w, h, nviews, nmaps;         /* nmaps: 3 (albedo, roughness, metallic) or 1 (refined) */
    size_t np;                       /* pixels per view */
    supermat_image *in;              /* nviews inputs (one buffer repeated for synthetic views) */
    const float *c2w;                /* supermat-mv: nviews x 16 */
    unsigned char *mask, *pos;       /* uv-refine */
    unsigned char *fg;               /* nviews x np: 1 = foreground (alpha > 0; uv-refine: mask > 0.5) */
    supermat_image *ov[3];           /* supermat-mv: per-view output images, pointed at the buffers per run */
    unsigned char *truth[3];         /* supermat: the --truth-* maps (8-bit, np x 3 / np x 1), NULL = not given */
    unsigned char *gt_mask;          /* with a truth: 1 = an object pixel (input alpha >= 128) */
    size_t gt_n;                     /* object pixels */
    int any_truth;
    double peak;                     /* this machine's FMA peak (GFLOP/s) measured at the start, 0 = unknown */
} cli_bi_input;

static const char *const cli_bi_map_names[3] = {"albedo", "roughness", "metallic"};
static int cli_bi_channels(const cli_bi_input *in, int k) { return in->nmaps == 1 ? 3 : cli_map_channels[k]; }
static const char *cli_bi_map_name(const cli_bi_input *in, int k) { return in->nmaps == 1 ? "refined" : cli_bi_map_names[k]; }
static int cli_bi_wants(const cli_bi_input *in, unsigned outputs, int k) {
    return in->nmaps == 1 ? 1 : (outputs & (1u << k)) != 0; /* SUPERMAT_OUTPUT_ALBEDO = 1, ROUGHNESS = 2, METALLIC = 4 */
}

/* one run into maps[k] (float32, views one after the other), maps[k] NULL = not wanted */
static supermat_result cli_bi_run(supermat_session *s, const cli_bi_input *in, float *const *maps, supermat_error *err) {
    supermat_run_desc rd;
    int k, v;
    memset(&rd, 0, sizeof rd);
    rd.input = in->in[0];
    if (in->kind == SUPERMAT_KIND_UV_REFINE) {
        rd.mask.pixels = in->mask; rd.mask.width = in->w; rd.mask.height = in->h; rd.mask.channels = 1;
        rd.position.pixels = in->pos; rd.position.width = in->w; rd.position.height = in->h; rd.position.channels = 3;
        rd.refined.pixels = maps[0]; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
    } else if (in->kind == SUPERMAT_KIND_SUPERMAT_MV) {
        rd.input_views = in->in;
        rd.cameras = in->c2w;
        for (k = 0; k < 3; k++) {
            if (!maps[k]) continue;
            for (v = 0; v < in->nviews; v++) {
                supermat_image *o = &in->ov[k][v];
                memset(o, 0, sizeof *o);
                o->pixels = maps[k] + in->np * (size_t)cli_map_channels[k] * (size_t)v;
                o->channels = cli_map_channels[k];
                o->format = SUPERMAT_FORMAT_F32;
            }
        }
        rd.albedo_views = maps[0] ? in->ov[0] : NULL;
        rd.roughness_views = maps[1] ? in->ov[1] : NULL;
        rd.metallic_views = maps[2] ? in->ov[2] : NULL;
    } else {
        supermat_image *o[3];
        o[0] = &rd.albedo; o[1] = &rd.roughness; o[2] = &rd.metallic;
        for (k = 0; k < 3; k++) {
            if (!maps[k]) continue;
            o[k]->pixels = maps[k]; o[k]->channels = cli_map_channels[k]; o[k]->format = SUPERMAT_FORMAT_F32;
        }
    }
    return supermat_run(s, &rd, err);
}

#define CLI_PSNR_CAP 200.0
typedef struct cli_bi_row {
    int mode, done;
    double seconds, speedup, flops;
    size_t peak_bytes;
    int has[3], has_fg[3], has_gt[3];
    double psnr[3], psnr_fg[3], max_abs[3], gt_psnr[3];
} cli_bi_row;

static double cli_psnr(double sse, double n) {
    double mse = sse / n, p;
    if (mse != mse) return mse; /* NaN: shown as nan, written as null */
    if (!(mse > 0.0)) return CLI_PSNR_CAP;
    p = 10.0 * log10(1.0 / mse);
    return p > CLI_PSNR_CAP ? CLI_PSNR_CAP : p;
}

/* PSNR (all pixels, foreground pixels) and max abs error of map k against the reference */
static void cli_bi_compare(const cli_bi_input *in, int k, const float *ref, const float *got, cli_bi_row *row) {
    int c = cli_bi_channels(in, k), j;
    size_t n = in->np * (size_t)in->nviews, p, nfg = 0;
    double sse = 0.0, sse_fg = 0.0, mx = 0.0;
    for (p = 0; p < n; p++) {
        double s = 0.0;
        for (j = 0; j < c; j++) {
            double d = (double)got[p * (size_t)c + (size_t)j] - (double)ref[p * (size_t)c + (size_t)j], a = fabs(d);
            s += d * d;
            if (a > mx || a != a) mx = a; /* a NaN shows */
        }
        sse += s;
        if (in->fg[p]) { sse_fg += s; nfg++; }
    }
    row->has[k] = 1;
    row->psnr[k] = cli_psnr(sse, (double)n * c);
    row->max_abs[k] = mx;
    row->has_fg[k] = nfg > 0;
    row->psnr_fg[k] = nfg ? cli_psnr(sse_fg, (double)nfg * c) : 0.0;
}

/* PSNR of map k against its truth file: the map quantised as `supermat image` writes it (cli_quantize),
   over the object's pixels and the map's channels, values / 255. A NaN in the map gives NaN. */
static void cli_bi_compare_truth(const cli_bi_input *in, int k, const float *got, cli_bi_row *row) {
    int c = cli_map_channels[k], j, nan = 0;
    const unsigned char *t = in->truth[k];
    size_t p;
    uint64_t sse = 0;
    for (p = 0; p < in->np; p++) {
        if (!in->gt_mask[p]) continue;
        for (j = 0; j < c; j++) {
            size_t at = p * (size_t)c + (size_t)j;
            int d;
            if (got[at] != got[at]) { nan = 1; continue; }
            d = (int)cli_quantize(got[at]) - (int)t[at];
            sse += (uint64_t)(d * d);
        }
    }
    row->has_gt[k] = 1;
    row->gt_psnr[k] = nan ? (double)NAN : cli_psnr((double)sse / (255.0 * 255.0), (double)in->gt_n * c);
}

static void cli_bi_print_header(const cli_bi_input *in) {
    int k;
    printf("%-18s %9s %8s %9s %9s %8s %6s", "", "", "", "", "", "", "");
    for (k = 0; k < in->nmaps; k++) printf(" | %-*s", in->any_truth ? 33 : 25, cli_bi_map_name(in, k));
    printf("\n%-18s %9s %8s %9s %9s %8s %6s", "mode", "seconds", "speedup", "peak MiB", "GFLOP", "GFLOP/s", "%peak");
    for (k = 0; k < in->nmaps; k++) {
        printf(" | %7s %7s %9s", "psnr", "psnr_fg", "max_abs");
        if (in->any_truth) printf(" %7s", "gt_psnr");
    }
    printf("\n");
}

static void cli_bi_print_row(const cli_bi_input *in, const cli_bi_row *r) {
    int k;
    double gf = r->seconds > 0 ? r->flops / r->seconds / 1e9 : 0.0;
    printf("%-18s %9.4f %7.2fx %9.1f %9.3f %8.2f", cli_modes[r->mode].name, r->seconds, r->speedup, cli_mib((double)r->peak_bytes),
           r->flops / 1e9, gf);
    if (in->peak > 0) printf(" %5.1f%%", 100.0 * gf / in->peak);
    else printf(" %6s", "-");
    for (k = 0; k < in->nmaps; k++) {
        if (!r->has[k]) printf(" | %7s %7s %9s", "-", "-", "-");
        else {
            printf(" | %7.2f", r->psnr[k]);
            if (r->has_fg[k]) printf(" %7.2f", r->psnr_fg[k]);
            else printf(" %7s", "-");
            printf(" %9.3e", r->max_abs[k]);
        }
        if (!in->any_truth) continue;
        if (r->has_gt[k]) printf(" %7.2f", r->gt_psnr[k]);
        else printf(" %7s", "-");
    }
    printf("\n");
    fflush(stdout);
}

static void cli_json_number_or_null(FILE *f, int has, double v) {
    if (has && v == v && v - v == 0.0) fprintf(f, "%.6g", v);
    else fputs("null", f);
}

/* writes and closes f (opened before the runs, so that a bad path fails at once) */
static int cli_bi_write_json(FILE *f, const char *path, const cli_bi_input *in, const cli_bi_row *rows, int nrows) {
    int i, k, q, first = 1;
    static const char *const groups[4] = {"psnr", "psnr_fg", "max_abs", "gt_psnr"};
    fputs("[\n", f);
    for (i = 0; i < nrows; i++) {
        const cli_bi_row *r = &rows[i];
        if (!r->done) continue;
        fprintf(f, "%s  {\"mode\": \"%s\", \"seconds\": %.6g, \"speedup\": %.6g, \"peak_bytes\": %llu, \"flops\": %.6g", first ? "" : ",\n",
                cli_modes[r->mode].name, r->seconds, r->speedup, (unsigned long long)r->peak_bytes, r->flops);
        fputs(", \"fma_peak_gflops\": ", f);
        cli_json_number_or_null(f, in->peak > 0, in->peak);
        fputs(", \"fraction_of_peak\": ", f);
        cli_json_number_or_null(f, in->peak > 0 && r->seconds > 0, r->seconds > 0 ? r->flops / r->seconds / 1e9 / in->peak : 0.0);
        first = 0;
        for (q = 0; q < 4; q++) {
            fprintf(f, ", \"%s\": {", groups[q]);
            for (k = 0; k < in->nmaps; k++) {
                fprintf(f, "%s\"%s\": ", k ? ", " : "", cli_bi_map_name(in, k));
                if (q == 0) cli_json_number_or_null(f, r->has[k], r->psnr[k]);
                else if (q == 1) cli_json_number_or_null(f, r->has[k] && r->has_fg[k], r->psnr_fg[k]);
                else if (q == 2) cli_json_number_or_null(f, r->has[k], r->max_abs[k]);
                else cli_json_number_or_null(f, r->has_gt[k], r->gt_psnr[k]);
            }
            fputc('}', f);
        }
        fputc('}', f);
    }
    fputs(first ? "]\n" : "\n]\n", f);
    if (ferror(f) | (fclose(f) != 0)) { cli_error("cannot write '%s'", path); return CLI_FAIL; }
    return CLI_OK;
}

typedef struct cli_bench_opts {
    const char *model_path, *json_path, *mask_path, *pos_path, *cam_path;
    const char *truth_paths[3];      /* --truth-albedo, --truth-roughness, --truth-metallic (NULL = not given) */
    const char *images[CLI_MAX_VIEWS];
    int nimg, views, threads, repeats, nmodes, modes_all;
    int modes[CLI_MODE_COUNT];
    supermat_kernel kernel;
} cli_bench_opts;

static supermat_result cli_bi_model(const unsigned char *buf, size_t size, supermat_kernel kernel, const cli_bi_mode *bm,
                                    supermat_model **model, supermat_error *err) {
    supermat_model_desc md;
    memset(&md, 0, sizeof md);
    md.data = buf; md.size = size; md.kernel = bm->kernel >= 0 ? (supermat_kernel)bm->kernel : kernel; md.weights = bm->weights;
    md.conv = bm->conv; md.compute = bm->compute;
    return supermat_model_create(&md, model, err);
}

static int cli_bench_image(const cli_bench_opts *o) {
    const char *path0 = o->images[0];
    int i, k, v, rc = CLI_OK, w = 0, h = 0, nviews = 1, ncam = 0, nrows = 0, failed = 0, order[CLI_MODE_COUNT], norder = 0;
    unsigned char *file = NULL, *px[CLI_MAX_VIEWS];
    size_t file_size = 0, nout[3] = {0, 0, 0};
    supermat_model *base = NULL;
    supermat_model_info mi;
    supermat_error err;
    supermat_result r;
    supermat_pool *pool = NULL;
    supermat_threading hook;
    cli_bi_input in;
    cli_camera *cams = NULL;
    float *c2w = NULL, *ref[3] = {NULL, NULL, NULL}, *cur[3] = {NULL, NULL, NULL};
    cli_bi_row rows[CLI_MODE_COUNT];
    char skipped[CLI_MODE_COUNT][160], cpu[256];
    int nskipped = 0, skipped_mode[CLI_MODE_COUNT];
    double f32_seconds = 0.0;
    FILE *jf = NULL;
    cli_mem jm;

    memset(px, 0, sizeof px);
    memset(&in, 0, sizeof in);
    memset(&mi, 0, sizeof mi);
    memset(rows, 0, sizeof rows);
    memset(&hook, 0, sizeof hook);

    /* the images' sizes before the (slow) model load */
    for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
        int iw, ih, c;
        if (!cli_pic_info(o->images[i], "image", &iw, &ih, &c, 0, NULL)) { rc = CLI_FAIL; break; }
        if (i == 0) { w = iw; h = ih; }
        if (iw != w || ih != h) {
            cli_error("image '%s' is %dx%d but image '%s' is %dx%d: all views must have the same size (supermat does not resize)",
                      o->images[i], iw, ih, path0, w, h);
            rc = CLI_FAIL;
        } else if (w % 8 || h % 8) {
            cli_error("image '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                      "resize it first, e.g. to 512x512)", o->images[i], w, h);
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < 2 && rc == CLI_OK; i++) {
        const char *p = i ? o->pos_path : o->mask_path, *what = i ? "the position map" : "the mask";
        int iw, ih, c;
        if (!p) continue;
        if (!cli_pic_info(p, what, &iw, &ih, &c, 0, NULL)) { rc = CLI_FAIL; break; }
        if (iw != w || ih != h) {
            cli_error("%s '%s' is %dx%d but the map '%s' is %dx%d: the map, the mask and the position map must have the same "
                      "size (supermat does not resize)", what, p, iw, ih, path0, w, h);
            rc = CLI_FAIL;
        }
    }
    for (k = 0; k < 3 && rc == CLI_OK; k++) { /* the truth files: readable, 8-bit, the image's size, colour / gray */
        const char *p = o->truth_paths[k];
        int iw, ih, c;
        if (!p) continue;
        in.any_truth = 1;
        char what[64];
        int ok, is16 = 0;
        snprintf(what, sizeof what, "the %s truth", cli_bi_map_names[k]);
        ok = cli_pic_info(p, what, &iw, &ih, &c, 0, &is16); /* a 16-bit truth is refused below, with its reason */
        if (!ok) {
            rc = CLI_FAIL;
        } else if (iw != w || ih != h) {
            cli_error("the %s truth '%s' is %dx%d but the image '%s' is %dx%d: a truth map must have the image's size "
                      "(supermat does not resize)", cli_bi_map_names[k], p, iw, ih, path0, w, h);
            rc = CLI_FAIL;
        } else if (is16) {
            cli_error("the %s truth '%s' has 16 bits per channel: give an 8-bit PNG (the maps are compared as "
                      "`supermat image` writes them, 8-bit)", cli_bi_map_names[k], p);
            rc = CLI_FAIL;
        } else if (k == 0 ? c < 3 : c > 2) {
            cli_error("the %s truth '%s' is %s: give an 8-bit %s PNG", cli_bi_map_names[k], p,
                      c <= 2 ? "gray" : "in colour", k == 0 ? "RGB (sRGB)" : "gray");
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK && o->json_path) {
        jf = cli_mem_open(&jm, o->json_path);
        if (!jf) rc = CLI_FAIL;
    }

    /* the reference model, and what the inputs must be for its kind */
    if (rc == CLI_OK) rc = cli_read_file(o->model_path, &file, &file_size);
    if (rc == CLI_OK) {
        cli_bi_mode f32;
        memset(&f32, 0, sizeof f32); /* f32 weights, direct convolutions, f32 compute */
        f32.kernel = -1;
        r = cli_bi_model(file, file_size, o->kernel, &f32, &base, &err);
        if (r != SUPERMAT_SUCCESS) {
            char what[600];
            snprintf(what, sizeof what, "model '%s'", o->model_path);
            cli_lib_error(what, r, &err);
            rc = CLI_FAIL;
        } else supermat_model_get_info(base, &mi);
    }
    if (rc == CLI_OK) {
        const char *kn = cli_kind_name(mi.kind);
        in.kind = mi.kind;
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) {
            if (o->nimg != 1 || !o->mask_path || !o->pos_path) {
                cli_error("model '%s' is a uv-refine model: give one --image MAP with --mask MASK and --position POS", o->model_path);
                rc = CLI_FAIL;
            }
        } else if (o->mask_path || o->pos_path) {
            cli_error("--mask and --position are for a uv-refine model; model '%s' is a %s model", o->model_path, kn);
            rc = CLI_FAIL;
        }
        if (rc == CLI_OK && in.any_truth && mi.kind != SUPERMAT_KIND_SUPERMAT) {
            cli_error("--truth-albedo, --truth-roughness and --truth-metallic are for a supermat model (one image); "
                      "model '%s' is a %s model", o->model_path, kn);
            rc = CLI_FAIL;
        }
        if (rc == CLI_OK && mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            if (o->nimg > 1 && !o->cam_path) {
                cli_error("%d views: give their cameras with --cameras meta.json (one --image without cameras is repeated as "
                          "--views views on a circle of cameras)", o->nimg);
                rc = CLI_FAIL;
            } else if (o->cam_path && o->views && o->views != o->nimg) {
                cli_error("--views %d with %d --image view%s and --cameras: the views are the images", o->views, o->nimg, o->nimg == 1 ? "" : "s");
                rc = CLI_FAIL;
            } else if (o->cam_path && mi.class_embed_in != 16) {
                cli_error("model '%s' takes %d camera numbers per view; a meta.json camera is a 4x4 matrix (16)", o->model_path, mi.class_embed_in);
                rc = CLI_FAIL;
            }
            nviews = o->cam_path ? o->nimg : o->views ? o->views : 6;
        } else if (rc == CLI_OK) {
            if (o->nimg > 1) {
                cli_error("%d --image inputs: model '%s' is a %s model, which takes one (only a supermat-mv model takes several views)",
                          o->nimg, o->model_path, kn);
                rc = CLI_FAIL;
            } else if (o->cam_path || o->views > 1) {
                cli_error("%s: model '%s' is a %s model, only a supermat-mv model takes views and cameras",
                          o->cam_path ? "--cameras" : "--views", o->model_path, kn);
                rc = CLI_FAIL;
            }
        }
    }
    /* the views' cameras (a supermat-mv model) */
    if (rc == CLI_OK && o->cam_path) {
        c2w = (float *)calloc((size_t)o->nimg * 16, sizeof(float));
        if (!c2w) { cli_error("out of memory"); rc = CLI_FAIL; }
        if (rc == CLI_OK) rc = cli_read_cameras(o->cam_path, &cams, &ncam);
        for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
            char *stem = cli_stem(o->images[i]);
            long index;
            const cli_camera *c;
            if (!stem) { cli_error("out of memory"); rc = CLI_FAIL; break; }
            index = cli_stem_index(stem);
            free(stem);
            if (index < 0) {
                cli_error("view '%s': its file name does not end with a number (up to 9 digits; e.g. color_0003.png -> 3), "
                          "so it has no camera index in the meta.json", o->images[i]);
                rc = CLI_FAIL;
                break;
            }
            c = cli_find_camera(cams, ncam, index, o->images[i], o->cam_path);
            if (!c) rc = CLI_FAIL;
            else memcpy(c2w + 16 * i, c->m, sizeof c->m);
        }
    }

    /* the modes, f32 first */
    if (rc == CLI_OK) {
        unsigned kb = cli_kind_bit(mi.kind);
        order[norder++] = CLI_MODE_F32;
        if (o->modes_all) {
            for (k = 1; k < CLI_MODE_COUNT; k++) if (cli_modes[k].kinds & kb) order[norder++] = k;
        }
        for (i = 0; i < o->nmodes && rc == CLI_OK; i++) {
            int m = o->modes[i], j, dup = 0;
            if (!(cli_modes[m].kinds & kb)) {
                cli_error("--modes: mode '%s' does not apply to model '%s', a %s model", cli_modes[m].name, o->model_path,
                          cli_kind_name(mi.kind));
                rc = CLI_FAIL;
            }
            for (j = 0; j < norder; j++) dup |= order[j] == m;
            if (!dup) order[norder++] = m;
        }
    }

    /* the input pixels */
    if (rc == CLI_OK) {
        in.w = w; in.h = h; in.nviews = nviews; in.np = (size_t)w * (size_t)h;
        in.nmaps = mi.kind == SUPERMAT_KIND_UV_REFINE ? 1 : 3;
        in.in = (supermat_image *)calloc((size_t)nviews, sizeof *in.in);
        in.fg = (unsigned char *)malloc(in.np * (size_t)nviews);
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            for (k = 0; k < 3; k++) in.ov[k] = (supermat_image *)calloc((size_t)nviews, sizeof(supermat_image));
            if (!c2w) {
                c2w = (float *)calloc((size_t)nviews * 16, sizeof(float));
                if (c2w) cli_ring_cameras(nviews, c2w);
            }
            in.c2w = c2w;
        }
        if (!in.in || !in.fg || (mi.kind == SUPERMAT_KIND_SUPERMAT_MV && (!in.ov[0] || !in.ov[1] || !in.ov[2] || !c2w))) {
            cli_error("out of memory");
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
        int iw = 0, ih = 0, c = 0, uv = mi.kind == SUPERMAT_KIND_UV_REFINE;
        px[i] = cli_load(o->images[i], &iw, &ih, &c, uv ? 3 : 4);
        if (!px[i]) { cli_error("cannot read image '%s': %s", o->images[i], cli_stbi_reason()); rc = CLI_FAIL; break; }
        if (iw != w || ih != h) { cli_error("image '%s' is %dx%d, not %dx%d as before (did it change?)", o->images[i], iw, ih, w, h); rc = CLI_FAIL; break; }
    }
    if (rc == CLI_OK && mi.kind == SUPERMAT_KIND_UV_REFINE) {
        int iw = 0, ih = 0, c = 0;
        in.mask = cli_load_gray(o->mask_path, &iw, &ih);
        if (!in.mask) { cli_error("cannot read the mask '%s': %s", o->mask_path, cli_stbi_reason()); rc = CLI_FAIL; }
        else if (iw != w || ih != h) { cli_error("the mask '%s' is %dx%d, not %dx%d as before (did it change?)", o->mask_path, iw, ih, w, h); rc = CLI_FAIL; }
        if (rc == CLI_OK) {
            in.pos = cli_load(o->pos_path, &iw, &ih, &c, 3);
            if (!in.pos) { cli_error("cannot read the position map '%s': %s", o->pos_path, cli_stbi_reason()); rc = CLI_FAIL; }
            else if (iw != w || ih != h) { cli_error("the position map '%s' is %dx%d, not %dx%d as before (did it change?)", o->pos_path, iw, ih, w, h); rc = CLI_FAIL; }
        }
    }
    if (rc == CLI_OK) {
        int uv = mi.kind == SUPERMAT_KIND_UV_REFINE;
        size_t p;
        for (v = 0; v < nviews; v++) {
            unsigned char *src = px[v < o->nimg ? v : 0];
            unsigned char *fg = in.fg + in.np * (size_t)v;
            in.in[v].pixels = src; in.in[v].width = w; in.in[v].height = h; in.in[v].channels = uv ? 3 : 4;
            in.in[v].format = SUPERMAT_FORMAT_U8;
            for (p = 0; p < in.np; p++) fg[p] = uv ? in.mask[p] >= 128 /* > 0.5 */ : src[p * 4 + 3] > 0;
        }
        if (in.any_truth) { /* a supermat model: one view */
            in.gt_mask = (unsigned char *)malloc(in.np);
            if (!in.gt_mask) { cli_error("out of memory"); rc = CLI_FAIL; }
            for (p = 0; rc == CLI_OK && p < in.np; p++) {
                in.gt_mask[p] = px[0][p * 4 + 3] >= 128;
                in.gt_n += in.gt_mask[p];
            }
            if (rc == CLI_OK && !in.gt_n) {
                cli_error("image '%s' has no object pixels (alpha >= 128): nothing to compare the truth maps with", path0);
                rc = CLI_FAIL;
            }
        }
        for (k = 0; k < 3 && rc == CLI_OK; k++) {
            const char *tp = o->truth_paths[k];
            int iw = 0, ih = 0, c = 0;
            if (!tp) continue;
            in.truth[k] = k == 0 ? cli_load(tp, &iw, &ih, &c, 3) : cli_load_gray(tp, &iw, &ih);
            if (!in.truth[k]) { cli_error("cannot read the %s truth '%s': %s", cli_bi_map_names[k], tp, cli_stbi_reason()); rc = CLI_FAIL; }
            else if (iw != w || ih != h) {
                cli_error("the %s truth '%s' is %dx%d, not %dx%d as before (did it change?)", cli_bi_map_names[k], tp, iw, ih, w, h);
                rc = CLI_FAIL;
            }
        }
        for (k = 0; k < in.nmaps && rc == CLI_OK; k++) {
            nout[k] = in.np * (size_t)nviews * (size_t)cli_bi_channels(&in, k);
            ref[k] = (float *)malloc(nout[k] * sizeof(float));
            cur[k] = (float *)malloc(nout[k] * sizeof(float));
            if (!ref[k] || !cur[k]) { cli_error("out of memory for the maps (%d view%s of %dx%d)", nviews, nviews == 1 ? "" : "s", w, h); rc = CLI_FAIL; break; }
        }
    }

    /* one pool for every session */
    if (rc == CLI_OK) {
#ifndef SUPERMAT_NO_PTHREADS
        if (supermat_pool_create(o->threads, NULL, &pool, &hook) != SUPERMAT_SUCCESS) { cli_error("cannot create the thread pool"); rc = CLI_FAIL; }
#else
        hook.parallel_for = cli_serial_for; hook.user = NULL; hook.max_threads = 1;
#endif
    }

    if (rc == CLI_OK) {
        char vs[48], ins[64];
        vs[0] = 0;
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV)
            snprintf(vs, sizeof vs, " x %d view%s%s", nviews, nviews == 1 ? "" : "s", o->cam_path ? "" : " (one image, cameras on a circle)");
        snprintf(ins, sizeof ins, "%s", mi.kind == SUPERMAT_KIND_UV_REFINE ? "map" : o->nimg > 1 ? "views" : "image");
        cli_cpu_name(cpu, sizeof cpu);
        printf("supermat bench: %s (%s, kernel %s)\n", o->model_path, cli_kind_name(mi.kind), cli_kernel_name(mi.kernel));
        printf("%-8s %s%s, %dx%d%s\n", ins, path0, o->nimg > 1 ? ", ..." : "", w, h, vs);
        printf("machine  %s%s%d thread%s, seconds = best of %d run%s\n", cpu, cpu[0] ? ", " : "", hook.max_threads,
               hook.max_threads == 1 ? "" : "s", o->repeats, o->repeats == 1 ? "" : "s");
        {
            bench_peak fma;
            memset(&fma, 0, sizeof fma);
            fma.zmm = mi.kernel == SUPERMAT_KERNEL_AVX512 || mi.kernel == SUPERMAT_KERNEL_AMX; /* AMX: % of the AVX-512 FMA peak */
            in.peak = mi.kernel == SUPERMAT_KERNEL_AVX2 || mi.kernel == SUPERMAT_KERNEL_AVX512 ? bench_peak_of(&fma, &hook, 3) : 0.0;
            if (in.peak > 0) printf("FMA peak %.1f GFLOP/s on %d thread%s (measured now; %%peak = GFLOP/s / this)\n", in.peak, hook.max_threads, hook.max_threads == 1 ? "" : "s");
        }
        if (in.any_truth) {
            printf("truth   ");
            for (k = 0; k < 3; k++) if (o->truth_paths[k]) printf(" %s %s", cli_bi_map_names[k], o->truth_paths[k]);
            printf(" (%lu object pixels)\n", (unsigned long)in.gt_n);
        }
        printf("\n");
        cli_bi_print_header(&in);
        fflush(stdout);
    }

    for (i = 0; i < norder && rc == CLI_OK; i++) {
        int mode = order[i], rep, skip;
        cli_bi_mode bm;
        unsigned outputs;
        supermat_session_desc sd;
        supermat_model *model = base, *extra = NULL;
        supermat_session *sess = NULL;
        supermat_model_info emi;
        supermat_flops fl;
        size_t sbytes = 0;
        float *maps[3];
        double best = 1e30;
        char what[80];
        cli_bi_row *row = &rows[nrows];
        memset(&sd, 0, sizeof sd);
        skip = cli_mode_setup(mode, w, h, &bm, &outputs, &sd, skipped[nskipped], sizeof skipped[nskipped]);
        if (skip) { skipped_mode[nskipped++] = mode; continue; }
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) outputs = SUPERMAT_OUTPUT_ALL;
        row->mode = mode;
        nrows++;
        snprintf(what, sizeof what, "mode %s", cli_modes[mode].name);
        r = SUPERMAT_SUCCESS;
        if (bm.weights != SUPERMAT_WEIGHTS_F32 || bm.conv != SUPERMAT_CONV_DIRECT || bm.compute != SUPERMAT_COMPUTE_F32 || bm.kernel >= 0) {
            r = cli_bi_model(file, file_size, o->kernel, &bm, &extra, &err);
            model = extra;
        }
        memset(&emi, 0, sizeof emi);
        if (r == SUPERMAT_SUCCESS) {
            supermat_model_get_info(model, &emi);
            sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.views = nviews; sd.threading = hook;
            r = supermat_session_memory(&sd, &sbytes, &err);
        }
        if (r == SUPERMAT_SUCCESS) r = supermat_session_create(&sd, &sess, &err);
        for (k = 0; k < 3; k++) maps[k] = k < in.nmaps && cli_bi_wants(&in, outputs, k) ? (mode == CLI_MODE_F32 ? ref[k] : cur[k]) : NULL;
        for (rep = 0; rep < o->repeats && r == SUPERMAT_SUCCESS; rep++) {
            double t0 = cli_now(), t;
            r = cli_bi_run(sess, &in, maps, &err);
            t = cli_now() - t0;
            if (t < best) best = t;
        }
        if (r == SUPERMAT_SUCCESS) {
            memset(&fl, 0, sizeof fl);
            supermat_session_last_flops(sess, &fl);
            row->done = 1;
            row->seconds = best;
            if (mode == CLI_MODE_F32) f32_seconds = best;
            row->speedup = best > 0 ? f32_seconds / best : 0.0;
            row->peak_bytes = emi.model_bytes + sbytes;
            row->flops = fl.total;
            for (k = 0; k < in.nmaps; k++) if (maps[k]) cli_bi_compare(&in, k, ref[k], maps[k], row);
            for (k = 0; k < in.nmaps; k++) if (maps[k] && in.truth[k]) cli_bi_compare_truth(&in, k, maps[k], row);
            cli_bi_print_row(&in, row);
        } else {
            fflush(stdout);
            cli_lib_error(what, r, &err);
            printf("%-18s failed: %s\n", cli_modes[mode].name, err.message[0] ? err.message : supermat_result_string(r));
            fflush(stdout);
            failed++;
            if (mode == CLI_MODE_F32) rc = CLI_FAIL; /* no reference: nothing to compare with */
        }
        supermat_session_destroy(sess);
        supermat_model_destroy(extra);
    }

    if (rc == CLI_OK) {
        for (i = 0; i < nskipped; i++) printf("%-18s skipped: %s\n", cli_modes[skipped_mode[i]].name, skipped[i]);
        printf("\nseconds: supermat_run only; speedup: f32 seconds / seconds; peak MiB: model + session arena (supermat_session_memory);\n"
               "psnr, psnr_fg (dB, capped at %.0f), max_abs: against the f32 maps (float, [0, 1]), all pixels and the foreground (%s)\n",
               CLI_PSNR_CAP, mi.kind == SUPERMAT_KIND_UV_REFINE ? "mask > 0.5" : "input alpha > 0");
        if (in.any_truth)
            printf("gt_psnr (dB, capped at %.0f): against the truth files, the maps quantised to 8 bits as `supermat image` writes them,\n"
                   "over the object's pixels (input alpha >= 128); - where no truth was given or the mode does not compute the map\n",
                   CLI_PSNR_CAP);
        if (jf) {
            FILE *f = jf;
            int ok;
            jf = NULL;
            ok = cli_bi_write_json(f, o->json_path, &in, rows, nrows) == CLI_OK; /* closes f */
            if (cli_mem_commit(&jm, o->json_path, ok, 1) != CLI_OK) rc = CLI_FAIL;
        }
        if (failed) {
            cli_error("%d mode%s failed (see above)", failed, failed == 1 ? "" : "s");
            rc = CLI_FAIL;
        }
    }

    if (jf) cli_mem_commit(&jm, o->json_path, 0, 0); /* nothing measured: no file */
    for (k = 0; k < 3; k++) { free(ref[k]); free(cur[k]); free(in.ov[k]); if (in.truth[k]) stbi_image_free(in.truth[k]); }
    free(in.gt_mask);
    for (i = 0; i < o->nimg; i++) if (px[i]) stbi_image_free(px[i]);
    if (in.mask) stbi_image_free(in.mask);
    if (in.pos) stbi_image_free(in.pos);
    free(in.in); free(in.fg); free(c2w); free(cams);
    supermat_model_destroy(base);
    cli_free_file(file);
#ifndef SUPERMAT_NO_PTHREADS
    supermat_pool_destroy(pool);
#endif
    (void)pool;
    return rc;
}

