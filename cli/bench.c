/* cli/bench.c - `supermat bench`: its options (one table: parsing and --help), (b) the pipeline per stage, (c) the conv GEMM per micro-kernel (supermat.h testing hook supermat_bench_conv_*); (a) the peaks are bench/peak.c, `bench --image` is bench/harness.c (both included here).
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>bench */
#include "../bench/peak.c" /* (a) the FMA and dot-instruction peaks */

static void cli_serial_for(void *user, int count, supermat_task_fn task, void *task_user) {
    int i;
    (void)user;
    for (i = 0; i < count; i++) task(task_user, i, 0);
}

/* (b) the pipeline, timed between the run's inspection points */
#define CLI_MAX_EVENTS 64
typedef struct cli_event { double t; supermat_stage stage; int branch; } cli_event;
typedef struct cli_events { cli_event ev[CLI_MAX_EVENTS]; int n; } cli_events;

static void cli_inspect_cb(void *user, supermat_stage stage, int branch, float *data, int n, int h, int w, int c) {
    cli_events *e = (cli_events *)user;
    (void)data; (void)n; (void)h; (void)w; (void)c;
    if (e->n < CLI_MAX_EVENTS) {
        e->ev[e->n].t = cli_now();
        e->ev[e->n].stage = stage;
        e->ev[e->n].branch = branch;
        e->n++;
    }
}

#define CLI_MAX_ROWS 12
typedef struct cli_row { char name[48]; double seconds, flops; } cli_row;

static const char *cli_branch_name(const supermat_model_info *mi, int branch) {
    if (mi->kind == SUPERMAT_KIND_UV_REFINE) return "refined";
    if (mi->branches < 2) return "output";
    return branch == 0 ? "albedo" : branch == 1 ? "roughness/metallic" : "branch";
}

/* stage rows from one run's events: t0 = before supermat_run, t1 = after. Each row ends at an event.
   The UNet is the trunk (ends at TRUNK) and one tail per wanted branch (ends at its UNET_OUT); the
   branch's X0 event follows at once (x0 = coefficient x output, no time), so it ends no row. */
static int cli_rows(const cli_events *e, double t0, double t1, const supermat_flops *fl, const supermat_model_info *mi, cli_row *rows) {
    int n = 0, i, ndec = 0, nbranch = 0;
    double prev = t0;
    for (i = 0; i < e->n; i++) {
        if (e->ev[i].stage == SUPERMAT_STAGE_DECODED) ndec++;
        if (e->ev[i].stage == SUPERMAT_STAGE_UNET_OUT) nbranch++;
    }
    for (i = 0; i < e->n && n < CLI_MAX_ROWS - 1; i++) {
        const cli_event *v = &e->ev[i];
        cli_row *r = &rows[n];
        r->flops = 0.0;
        switch (v->stage) {
        case SUPERMAT_STAGE_INPUT: snprintf(r->name, sizeof r->name, "input (plan walk, to [-1,1])"); break;
        case SUPERMAT_STAGE_LATENT: snprintf(r->name, sizeof r->name, "vae encode"); r->flops = fl->encode; break;
        case SUPERMAT_STAGE_UNET_IN: snprintf(r->name, sizeof r->name, "unet input (mask, position)"); break;
        case SUPERMAT_STAGE_TRUNK: snprintf(r->name, sizeof r->name, "unet trunk"); r->flops = fl->trunk; break;
        case SUPERMAT_STAGE_UNET_OUT:
            snprintf(r->name, sizeof r->name, "unet branch %s", cli_branch_name(mi, v->branch));
            r->flops = nbranch ? fl->branch / nbranch : 0.0; /* the tails have one architecture */
            break;
        case SUPERMAT_STAGE_DECODED:
            snprintf(r->name, sizeof r->name, "vae decode %s", cli_branch_name(mi, v->branch));
            r->flops = ndec ? fl->decode / ndec : 0.0;
            break;
        default: continue; /* X0 */
        }
        r->seconds = v->t - prev;
        prev = v->t;
        n++;
    }
    snprintf(rows[n].name, sizeof rows[n].name, "write outputs");
    rows[n].seconds = t1 - prev; rows[n].flops = 0.0; n++;
    return n;
}

/* (c) one 3x3 convolution GEMM on packed weights, with each micro-kernel: supermat.h's testing hook
   supermat_bench_conv_* (a fixed pseudo-random input and weights), timed here */
#define CLI_GEMM_HW 64
#define CLI_GEMM_C 320

static uint32_t cli_rand(uint32_t *s) { *s = *s * 1664525u + 1013904223u; return *s >> 8; }

/* best seconds of a few runs (at least one, more while under `budget` seconds); -1 when the kernel
   cannot run here. copy: the output, nout floats */
static double cli_gemm_time(supermat_bench_conv *g, supermat_kernel kernel, const supermat_threading *hook, double budget,
                            float *copy, size_t nout) {
    double best = 1e30, spent = 0.0;
    int runs = 0;
    while (runs < 1 || (spent < budget && runs < 10)) {
        double t = cli_now();
        supermat_result r = supermat_bench_conv_run(g, kernel, hook, NULL);
        t = cli_now() - t;
        if (r != SUPERMAT_SUCCESS) return -1.0;
        if (t < best) best = t;
        spent += t;
        runs++;
    }
    if (copy) memcpy(copy, supermat_bench_conv_output(g), sizeof(float) * nout);
    return best;
}

static void cli_json_string(FILE *f, const char *s) {
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') fprintf(f, "\\%c", c);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

static size_t cli_peak_rss(void) {
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
#ifdef __APPLE__
    return (size_t)ru.ru_maxrss;
#else
    return (size_t)ru.ru_maxrss * 1024u;
#endif
}
#include "../bench/harness.c" /* `bench --image` */

/* `supermat bench`: its options and --help */
enum {
    CLI_BENCH_MODEL = 1, CLI_BENCH_SIZE, CLI_BENCH_VIEWS, CLI_BENCH_THREADS, CLI_BENCH_REPEATS, CLI_BENCH_PIPELINE_ONLY,
    CLI_BENCH_OUTPUTS, CLI_BENCH_JSON, CLI_BENCH_IMAGE, CLI_BENCH_MASK, CLI_BENCH_POSITION, CLI_BENCH_CAMERAS, CLI_BENCH_MODES,
    CLI_BENCH_TRUTH /* + 0, 1, 2: albedo, roughness, metallic */
};
static const cli_optdef cli_opts_bench[] = {
    CLI_TEXT("usage: supermat bench [--model FILE] [options]\n"
             "       supermat bench [--model FILE] --image IMAGE [--modes all|LIST] [--json FILE] [options]\n"
             "\n"
             "Without --image, measures in one run: (a) this machine's FMA peak on every thread (AVX2, or\n"
             "AVX-512 where the AVX-512 kernel runs) and, with --compute bf16 / int8, the peak of the instruction\n"
             "those GEMMs multiply with (vdpbf16ps, vpdpbusd: the % dot column; CPUs differ more here); (b) the\n"
             "full pipeline on synthetic input, seconds / GFLOP / GFLOP/s / % of the peak per stage (VAE encode,\n"
             "UNet trunk, each branch tail, each VAE decode), model creation time and peak memory; (c) one 3x3\n"
             "convolution GEMM (M=4096, K=9*320, N=320, the first UNet level at 512x512) with the AVX2 and\n"
             "the scalar micro-kernel, and their ratio.\n"
             "\n"
             "Every model kind: supermat (one RGBA image), supermat-mv (--views RGBA views with cameras on a\n"
             "circle around the object) and uv-refine (a UV map, its mask and position map).\n"
             "\n"
             "options:\n"),
    {CLI_BENCH_MODEL, "--model", "FILE|NAME", "a model file made by `supermat convert`, or a name (official, default:\nsee NAMED MODELS at the end; default: the default model)", NULL, NULL},
    {CLI_BENCH_SIZE, "--size", "S", "image size: S (square) or WxH, multiples of 8 (default 512)", NULL, NULL},
    {CLI_BENCH_VIEWS, "--views", "N", "supermat-mv: views processed together, 1 to 64 (default 6)", NULL, NULL},
    {CLI_BENCH_THREADS, "--threads", "N", "threads (default 0 = all cores)", NULL, NULL},
    {CLI_BENCH_REPEATS, "--repeats", "R", "pipeline runs; the fastest is reported (default 1)", NULL, NULL},
    {CLI_BENCH_PIPELINE_ONLY, "--pipeline-only", NULL, "skip (a) and (c): no FMA peak (no % of peak), no GEMM comparison", NULL, NULL},
    {CLI_BENCH_OUTPUTS, "--outputs", "LIST", "comma list of albedo,roughness,metallic (default: all three; uv-refine\nmakes its one refined map)", NULL, NULL},
    {CLI_O_KERNEL, "--kernel", "K", CLI_KERNEL_VALUES ": the pipeline's kernels (default auto)", NULL, NULL},
    CLI_OPTS(cli_opts_levers),
    {CLI_BENCH_JSON, "--json", "FILE", "also write the numbers as JSON", NULL, NULL},
    CLI_TEXT("\n"
             "SPEED / ACCURACY TABLE (--image)\n"
             "With --image, runs each selected mode (a speed or memory lever) on that real input and prints one\n"
             "row per mode: seconds (supermat_run only, best of --repeats; model and session creation are not\n"
             "timed), speed-up over the f32 mode, peak MiB (the model's memory + the session's planned arena),\n"
             "the FLOPs the run performed and GFLOP/s, and per map (albedo, roughness, metallic; uv-refine: the\n"
             "refined map) against the f32 mode's float outputs: psnr = 10 log10(1 / MSE) in dB over all\n"
             "pixels and channels (200 = identical, the cap), psnr_fg the same over the foreground pixels only\n"
             "(input alpha > 0; uv-refine: mask > 0.5), and max_abs, the largest absolute difference (maps in\n"
             "[0, 1]). A map a mode does not compute is shown as - (null in JSON).\n"
             "  supermat      --image IMAGE (RGBA, straight alpha)\n"
             "  supermat-mv   --image VIEW once per view with --cameras meta.json (as `supermat views` matches\n"
             "                them), or one --image and no cameras: that image as every one of --views N views\n"
             "                (default 6) with cameras on a circle\n"
             "  uv-refine     --image MAP --mask MASK --position POS\n"
             "Images are not resized: width and height must be multiples of 8.\n"
             "\n"),
    CLI_TEXT("modes (--modes all: every mode that applies to the model; or a comma list; f32, the reference,\n"
             "always runs first):\n"
             "  f32                 f32 weights, direct convolutions, the official computation (the reference)\n"
             "  f16, bf16, int8     the GEMM weights stored as f16 / bf16 / int8 (a model of its own)\n"
             "  winograd_f2, winograd_f4\n"
             "                      3x3 convolutions by Winograd F(2x2,3x3) / F(4x4,3x3) (a model of its own)\n"
             "  tiled_vae           the VAE in 2x2 tiles: vae_tile ((S/8 + 4) / 2) * 8, overlap 32, where\n"
             "                      S = max(width, height) (272 at 512)\n"
             "  foreground          vae_tile S/4 + 16 rounded up to a multiple of 8 (144 at 512), overlap 16,\n"
             "                      background tiles not decoded (skip_background)\n"
             "  branch_albedo       supermat, supermat-mv: the albedo map only\n"
             "  branch_rm           supermat, supermat-mv: the roughness and metallic maps only\n"
             "  res256, res384      supermat, supermat-mv: the network at 256 / 384 pixels on the longer side\n"
             "                      (work_width x work_height, proportional, multiples of 8), maps resampled\n"
             "                      back; skipped when the image is not larger\n"
             "  res512, res768      uv-refine: the same at 512 / 768\n"
             "  mv_window_own       supermat-mv: highest-resolution attention within each view only\n"
             "  mv_window_stride4   supermat-mv: own view + every 4th key of the other views\n"
             "  bf16_compute        bf16 x bf16 products in the GEMMs with vdpbf16ps (AVX512_BF16; skipped\n"
             "                      without it)\n"
             "  kernel_avx2         the AVX2 micro-kernel where f32 runs the AVX-512 one (same bits; skipped\n"
             "                      without AVX-512)\n"
             "  bf16_amx            bf16 compute on AMX tiles (skipped without AMX-BF16)\n"
             "  bf16_amx_wf4        bf16_amx with Winograd F4 (f32) for the 3x3 convolutions\n"
             "  int8_compute        int8 x int8 products in the GEMMs with vpdpbusd, activations quantized per\n"
             "                      row per 64 of K (AVX512_VNNI on the AVX-512 kernel, else AVX-VNNI on the AVX2\n"
             "                      kernel; skipped with neither)\n"
             "  int8_compute_wf4    int8_compute with Winograd F4 (f32) for the 3x3 convolutions\n"
             "  int8_compute_avx2   int8_compute on the AVX2 kernel with AVX-VNNI (256-bit vpdpbusd, the same bits;\n"
             "                      only beside AVX512_VNNI: skipped where int8_compute already runs it or without)\n"
             "\n"
             "options with --image (besides --model, --threads, --repeats, --kernel, --views above):\n"),
    {CLI_BENCH_IMAGE, "--image", "FILE", "the input (see above; repeated for the views of a supermat-mv model)", NULL, NULL},
    {CLI_BENCH_MASK, "--mask", "FILE", "uv-refine: the mask (8-bit gray; colour is converted)", NULL, NULL},
    {CLI_BENCH_POSITION, "--position", "FILE", "uv-refine: the position map", NULL, NULL},
    {CLI_BENCH_CAMERAS, "--cameras", "FILE", "supermat-mv: the meta.json with the views' cameras", NULL, NULL},
    {CLI_BENCH_MODES, "--modes", "LIST", "all, or a comma list of the modes above (default all)", NULL, NULL},
    /* the same --json as above (parsing finds that one): what it writes with --image */
    {CLI_BENCH_JSON, "--json", "FILE", "also write the table as a JSON list, one object per mode:\n"
                                       "{\"mode\", \"seconds\", \"speedup\", \"peak_bytes\", \"flops\", \"fma_peak_gflops\",\n"
                                       "\"fraction_of_peak\" (FLOPs performed / s / the FMA peak measured first), \"psnr\": {\"albedo\",\n"
                                       "\"roughness\", \"metallic\"}, \"psnr_fg\": {...}, \"max_abs\": {...}, \"gt_psnr\": {...}}\n"
                                       "(uv-refine: the key \"refined\"); skipped and failed modes are left out", NULL, NULL},
    CLI_TEXT("--size, --outputs, --weights and --pipeline-only do not apply with --image. A mode that fails is\n"
             "reported and the others still run; the exit status is then 1.\n"
             "\n"
             "AGAINST GROUND TRUTH (a supermat model, one --image)\n"),
    {CLI_BENCH_TRUTH + 0, "--truth-albedo", "FILE", "the true albedo: an 8-bit sRGB RGB PNG (an alpha channel is ignored)", NULL, NULL},
    {CLI_BENCH_TRUTH + 1, "--truth-roughness", "FILE", "the true roughness: an 8-bit gray PNG (an alpha channel is ignored)", NULL, NULL},
    {CLI_BENCH_TRUTH + 2, "--truth-metallic", "FILE", "the true metallic: an 8-bit gray PNG (an alpha channel is ignored)", NULL, NULL},
    CLI_TEXT("Any subset; each the size of the image. Every mode (f32 included) adds a gt_psnr column per map:\n"
             "its maps quantised to 8 bits exactly as `supermat image` writes its PNGs, against the truth over\n"
             "the object's pixels (input alpha >= 128): MSE over those pixels and the map's channels of the\n"
             "8-bit values / 255, gt_psnr = 10 log10(1 / MSE) dB, capped at 200 (identical). The res* modes\n"
             "are measured on their maps resampled back to the image size. JSON: \"gt_psnr\": {\"albedo\",\n"
             "\"roughness\", \"metallic\"}, null where no truth was given or the mode does not compute the map.\n"
             "A truth file that cannot be read, is not of the image's size, is 16-bit or has the wrong colour\n"
             "type (albedo: colour; roughness, metallic: gray), or an image without object pixels, is an error\n"
             "(exit status 1) before anything runs.\n"),
    CLI_END};

/* `supermat bench`: the options, then (a), (b), (c) above, or with --image cli_bench_image() */
static int cli_bench(int argc, char **argv) {
    const char *cmd = "bench", *v, *model_arg = NULL, *model_path = NULL, *json_path = NULL;
    int w = 512, h = 512, threads = 0, repeats = 1, i, m, rc = CLI_OK, nrows = 0, rep, x, y, k;
    int views = 0, nviews = 1, pipeline_only = 0;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    unsigned char *file = NULL, *rgba = NULL, *alb = NULL, *rough = NULL, *metal = NULL, *mask = NULL, *pos = NULL;
    supermat_image *in_v = NULL, *alb_v = NULL, *rough_v = NULL, *metal_v = NULL;
    float *c2w = NULL;
    size_t file_size = 0, session_bytes = 0, np = 0, rss = 0;
    bench_peak fma, dot; /* (a): the FMA peak, the compute's dot instruction */
    supermat_model *model = NULL;
    supermat_model_info mi;
    supermat_session *sess = NULL;
    supermat_session_desc sd;
    supermat_threading hook;
    supermat_flops fl;
    supermat_error err;
    supermat_result r;
    supermat_pool *pool = NULL;
    double peak = 0.0, peak1 = 0.0, dpeak = 0.0, dpeak1 = 0.0, create_s = 0.0, best_total = 1e30, sum_total = 0.0;
    double gemm_flops = 2.0 * CLI_GEMM_HW * CLI_GEMM_HW * (double)CLI_GEMM_C * 9.0 * CLI_GEMM_C;
    double t_avx2 = -1.0, t_scalar = -1.0, t_avx512 = -1.0, gemm_diff = 0.0;
    int avx512_same = 0;
    cli_row rows[CLI_MAX_ROWS];
    cli_events ev;
    char outs_s[64];
    cli_bench_opts bo;
    int size_given = 0, outputs_given = 0, weights_given = 0, modes_given = 0;
    cli_model_ref mref;
    cli_levers lv;
    cli_argp P;

    cli_levers_init(&lv);
    memset(&fma, 0, sizeof fma);
    memset(&dot, 0, sizeof dot);
    memset(&bo, 0, sizeof bo);
    bo.modes_all = 1;

    cli_argp_init(&P, cmd, cli_opts_bench, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        switch (m) {
        case CLI_ARG_HELP: cli_help_print(stdout, cli_opts_bench); cli_print_default_model_help(); return CLI_OK;
        case CLI_ARG_ERROR: return CLI_USAGE;
        case CLI_ARG_OPERAND: return cli_usage_error(cmd, "unexpected argument '%s'", v);
        case CLI_BENCH_MODEL: model_arg = v; break;
        case CLI_BENCH_SIZE:
            if (cli_parse_size(cmd, v, &w, &h)) return CLI_USAGE;
            size_given = 1;
            break;
        case CLI_BENCH_THREADS: if (cli_parse_int(cmd, "--threads", v, 0, 64, &threads)) return CLI_USAGE; break;
        case CLI_BENCH_REPEATS: if (cli_parse_int(cmd, "--repeats", v, 1, 1000, &repeats)) return CLI_USAGE; break;
        case CLI_BENCH_VIEWS: if (cli_parse_int(cmd, "--views", v, 1, CLI_MAX_VIEWS, &views)) return CLI_USAGE; break;
        case CLI_BENCH_PIPELINE_ONLY: pipeline_only = 1; break;
        case CLI_BENCH_OUTPUTS:
            if (cli_parse_outputs(cmd, v, &outputs)) return CLI_USAGE;
            outputs_given = 1;
            break;
        case CLI_BENCH_JSON: json_path = v; break;
        case CLI_BENCH_IMAGE:
            if (bo.nimg == CLI_MAX_VIEWS) return cli_usage_error(cmd, "more than %d --image views: at most %d are processed together", CLI_MAX_VIEWS, CLI_MAX_VIEWS);
            bo.images[bo.nimg++] = v;
            break;
        case CLI_BENCH_MASK: bo.mask_path = v; break;
        case CLI_BENCH_POSITION: bo.pos_path = v; break;
        case CLI_BENCH_CAMERAS: bo.cam_path = v; break;
        case CLI_BENCH_MODES:
            if (cli_parse_modes(cmd, v, bo.modes, &bo.nmodes, &bo.modes_all)) return CLI_USAGE;
            modes_given = 1;
            break;
        case CLI_BENCH_TRUTH + 0: case CLI_BENCH_TRUTH + 1: case CLI_BENCH_TRUTH + 2:
            if (!v[0]) return cli_usage_error(cmd, "%s: an empty file name", P.name);
            bo.truth_paths[m - CLI_BENCH_TRUTH] = v;
            break;
        default: /* --kernel and the levers */
            if (m == CLI_O_WEIGHTS) weights_given = 1;
            if (cli_run_value(cmd, m, v, NULL, NULL, NULL, &kernel, &lv) < 0) return CLI_USAGE;
            break;
        }
    }
    if (bo.nimg) {
        if (size_given) return cli_usage_error(cmd, "--size does not apply with --image (the image's own size is used)");
        if (outputs_given) return cli_usage_error(cmd, "--outputs does not apply with --image (the modes choose the outputs)");
        if (weights_given) return cli_usage_error(cmd, "--weights does not apply with --image (use --modes f16,bf16,int8)");
        if (lv.conv_given) return cli_usage_error(cmd, "--conv does not apply with --image (use --modes winograd_f2,winograd_f4)");
        if (pipeline_only) return cli_usage_error(cmd, "--pipeline-only does not apply with --image");
        if ((rc = cli_model_path(cmd, model_arg, 1, &mref)) != CLI_OK) return rc;
        model_path = mref.path;
        bo.model_path = model_path; bo.json_path = json_path; bo.views = views; bo.threads = threads; bo.repeats = repeats;
        bo.kernel = kernel;
        return cli_bench_image(&bo);
    }
    if (modes_given || bo.mask_path || bo.pos_path || bo.cam_path)
        return cli_usage_error(cmd, "%s needs --image", modes_given ? "--modes" : bo.mask_path ? "--mask" : bo.pos_path ? "--position" : "--cameras");
    for (k = 0; k < 3; k++)
        if (bo.truth_paths[k])
            return cli_usage_error(cmd, "--truth-%s needs --image (it is compared with the maps of --image)", cli_bi_map_names[k]);
    if ((rc = cli_model_path(cmd, model_arg, 1, &mref)) != CLI_OK) return rc;
    model_path = mref.path;
    memset(&mi, 0, sizeof mi);
    memset(&fl, 0, sizeof fl);
    if (json_path && cli_report_allowed(json_path) != CLI_OK) return CLI_FAIL; /* before measuring */

    /* one pool for everything: the FMA peak, the session and the GEMM */
#ifndef SUPERMAT_NO_PTHREADS
    if (supermat_pool_create(threads, NULL, &pool, &hook) != SUPERMAT_SUCCESS) { cli_error("cannot create the thread pool"); return CLI_FAIL; }
#else
    hook.parallel_for = cli_serial_for; hook.user = NULL; hook.max_threads = 1;
#endif
    (void)cli_serial_for;

    /* (a) here and again at the end (the best counts: a busy neighbour only lowers it); with 512-bit FMAs
       when the pipeline runs the AVX-512 kernel */
    fma.zmm = kernel == SUPERMAT_KERNEL_AVX512 || kernel == SUPERMAT_KERNEL_AMX || (kernel == SUPERMAT_KERNEL_AUTO && supermat_cpu().avx512);
    if (!pipeline_only) {
        peak1 = bench_peak_of(&fma, NULL, 3);
        peak = bench_peak_of(&fma, &hook, 3);
    }

    /* (b) */
    rc = cli_load_model(model_path, kernel, &lv, &file, &file_size, &model, &create_s);
    if (rc == CLI_OK) {
        supermat_model_get_info(model, &mi);
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) nviews = views ? views : 6;
        else if (views > 1) {
            cli_error("--views %d: model '%s' is a %s model, only a supermat-mv model takes several views", views, model_path,
                      cli_kind_name(mi.kind));
            rc = CLI_FAIL;
        }
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) outputs = SUPERMAT_OUTPUT_ALL; /* one refined map, whatever --outputs says */
    }
    if (mi.kind == SUPERMAT_KIND_UV_REFINE) snprintf(outs_s, sizeof outs_s, "refined");
    else cli_outputs_string(outputs, outs_s, sizeof outs_s);
    if (rc == CLI_OK) {
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.views = nviews; sd.threading = hook;
        r = supermat_session_memory(&sd, &session_bytes, &err);
        if (r == SUPERMAT_SUCCESS) r = supermat_session_create(&sd, &sess, &err);
        if (r != SUPERMAT_SUCCESS) { cli_lib_error("session", r, &err); rc = CLI_FAIL; }
    }
    if (rc == CLI_OK) {
        size_t nv = (size_t)nviews;
        np = (size_t)w * (size_t)h;
        rgba = (unsigned char *)malloc(np * 4 * nv);
        alb = (unsigned char *)malloc(np * 3 * nv); /* uv-refine: the refined map */
        rough = (unsigned char *)malloc(np * nv);
        metal = (unsigned char *)malloc(np * nv);
        mask = (unsigned char *)malloc(np);
        pos = (unsigned char *)malloc(np * 3);
        in_v = (supermat_image *)calloc(nv, sizeof *in_v);
        alb_v = (supermat_image *)calloc(nv, sizeof *alb_v);
        rough_v = (supermat_image *)calloc(nv, sizeof *rough_v);
        metal_v = (supermat_image *)calloc(nv, sizeof *metal_v);
        c2w = (float *)calloc(nv * 16, sizeof(float));
        if (!rgba || !alb || !rough || !metal || !mask || !pos || !in_v || !alb_v || !rough_v || !metal_v || !c2w) {
            cli_error("out of memory");
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) {
        /* a deterministic pattern per view: gradients, a checker, an opaque disk (moving from view to view) on
           transparent noise; for uv-refine the same as the map (alpha ignored), banded mask, gradient positions */
        uint32_t seed = 7u;
        for (k = 0; k < nviews; k++) {
            double cx = 0.5 + 0.05 * sin(2.0 * 3.14159265358979323846 * k / nviews);
            for (y = 0; y < h; y++)
                for (x = 0; x < w; x++) {
                    unsigned char *p = rgba + (((size_t)k * h + y) * w + x) * 4;
                    double dx = (x + 0.5) / w - cx, dy = (y + 0.5) / h - 0.5, d = sqrt(dx * dx + dy * dy);
                    int inside = d < 0.4, check = ((x / 8) + (y / 8) + k) & 1;
                    p[0] = (unsigned char)(inside ? 40 + 180 * x / w : (int)(cli_rand(&seed) & 255u));
                    p[1] = (unsigned char)(inside ? 40 + 180 * y / h : (int)(cli_rand(&seed) & 255u));
                    p[2] = (unsigned char)(inside ? (check ? 200 : 60) : (int)(cli_rand(&seed) & 255u));
                    p[3] = (unsigned char)(inside ? 255 : d < 0.41 ? 128 : 0);
                }
        }
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++) {
                size_t o = (size_t)y * w + x;
                mask[o] = (unsigned char)(85 * (((x / 16) + (y / 16)) % 4));
                pos[o * 3] = (unsigned char)(255 * x / w);
                pos[o * 3 + 1] = (unsigned char)(255 * y / h);
                pos[o * 3 + 2] = 127;
            }
        cli_ring_cameras(nviews, c2w);
        for (k = 0; k < nviews; k++) {
            in_v[k].pixels = rgba + np * 4 * (size_t)k; in_v[k].width = w; in_v[k].height = h; in_v[k].channels = 4;
            alb_v[k].pixels = alb + np * 3 * (size_t)k; alb_v[k].channels = 3;
            rough_v[k].pixels = rough + np * (size_t)k; rough_v[k].channels = 1;
            metal_v[k].pixels = metal + np * (size_t)k; metal_v[k].channels = 1;
        }
    }
    for (rep = 0; rep < repeats && rc == CLI_OK; rep++) {
        supermat_run_desc rd;
        double t0, t1;
        cli_row tmp[CLI_MAX_ROWS];
        int n;
        memset(&rd, 0, sizeof rd);
        rd.input = in_v[0];
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) {
            rd.mask.pixels = mask; rd.mask.width = w; rd.mask.height = h; rd.mask.channels = 1;
            rd.position.pixels = pos; rd.position.width = w; rd.position.height = h; rd.position.channels = 3;
            rd.refined = alb_v[0];
        } else if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            rd.input_views = in_v;
            rd.cameras = c2w;
            if (outputs & SUPERMAT_OUTPUT_ALBEDO) rd.albedo_views = alb_v;
            if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) rd.roughness_views = rough_v;
            if (outputs & SUPERMAT_OUTPUT_METALLIC) rd.metallic_views = metal_v;
        } else {
            if (outputs & SUPERMAT_OUTPUT_ALBEDO) rd.albedo = alb_v[0];
            if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) rd.roughness = rough_v[0];
            if (outputs & SUPERMAT_OUTPUT_METALLIC) rd.metallic = metal_v[0];
        }
        memset(&ev, 0, sizeof ev);
        rd.inspect = cli_inspect_cb; rd.inspect_user = &ev;
        t0 = cli_now();
        r = supermat_run(sess, &rd, &err);
        t1 = cli_now();
        if (r != SUPERMAT_SUCCESS) { cli_lib_error("run", r, &err); rc = CLI_FAIL; break; }
        supermat_session_flops(sess, &fl);
        n = cli_rows(&ev, t0, t1, &fl, &mi, tmp);
        sum_total += t1 - t0;
        if (t1 - t0 < best_total) { best_total = t1 - t0; nrows = n; memcpy(rows, tmp, sizeof(cli_row) * (size_t)n); }
    }

    rss = cli_peak_rss(); /* the pipeline's peak, before the GEMM's buffers */

    /* (c) */
    if (rc == CLI_OK && !pipeline_only) {
        supermat_bench_conv *g = NULL;
        float *ref = NULL;
        size_t nout = (size_t)CLI_GEMM_HW * CLI_GEMM_HW * CLI_GEMM_C, k;
        if (supermat_bench_conv_create(CLI_GEMM_HW, CLI_GEMM_C, CLI_GEMM_C, hook.max_threads, &g, &err) != SUPERMAT_SUCCESS ||
            !(ref = (float *)malloc(nout * sizeof(float)))) {
            cli_error("out of memory for the GEMM benchmark");
            rc = CLI_FAIL;
        } else {
            const float *out;
            if (supermat_cpu().avx2) t_avx2 = cli_gemm_time(g, SUPERMAT_KERNEL_AVX2, &hook, 0.5, ref, nout);
            if (supermat_cpu().avx512) {
                t_avx512 = cli_gemm_time(g, SUPERMAT_KERNEL_AVX512, &hook, 0.5, NULL, nout);
                avx512_same = t_avx512 > 0 && ref && !memcmp(ref, supermat_bench_conv_output(g), nout * sizeof(float));
            }
            t_scalar = cli_gemm_time(g, SUPERMAT_KERNEL_SCALAR, &hook, 1.0, NULL, nout);
            out = supermat_bench_conv_output(g);
            if (t_avx2 > 0 && out) {
                double mx = 0.0, md = 0.0;
                for (k = 0; k < nout; k++) {
                    double a = fabs((double)ref[k]), d = fabs((double)ref[k] - (double)out[k]);
                    if (a > mx) mx = a;
                    if (d > md) md = d;
                }
                gemm_diff = mx > 0 ? md / mx : md;
            }
        }
        free(ref);
        supermat_bench_conv_destroy(g);
    }

    if (rc == CLI_OK && !pipeline_only) {
        double p1 = bench_peak_of(&fma, NULL, 3), pa = bench_peak_of(&fma, &hook, 3);
        if (p1 > peak1) peak1 = p1;
        if (pa > peak) peak = pa;
        dot.dot = bench_dot_for(mi.kernel, mi.compute);
        if (dot.dot != BENCH_DOT_NONE) { /* the compute's own instruction, best of 2 x 3 runs like the FMA peak */
            int r;
            for (r = 0; r < 2; r++) {
                double d1 = bench_peak_of(&dot, NULL, 3), da = bench_peak_of(&dot, &hook, 3);
                if (d1 > dpeak1) dpeak1 = d1;
                if (da > dpeak) dpeak = da;
            }
        }
    }
    if (rc == CLI_OK) {
        size_t planned = mi.model_bytes + session_bytes;
        double total_flops = fl.total;
        FILE *jf = NULL;
        cli_mem jm;
        char vs[32];
        vs[0] = 0;
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) snprintf(vs, sizeof vs, " x %d view%s", nviews, nviews == 1 ? "" : "s");
        printf("supermat bench: %s (%s, kernel %s, %s compute, %s convolutions), %dx%d%s, outputs %s, %d thread%s\n", model_path,
               cli_kind_name(mi.kind), cli_kernel_name(mi.kernel), cli_compute_name(mi.compute),
               cli_conv_name(mi.conv), w, h, vs, outs_s, hook.max_threads, hook.max_threads == 1 ? "" : "s");
        if (pipeline_only) printf("FMA peak      skipped (--pipeline-only)\n");
        else if (peak > 0) printf("FMA peak      %.1f GFLOP/s on %d thread%s, %.1f GFLOP/s on one (%s, %d independent %s chains; best of 6)\n",
                             peak, hook.max_threads, hook.max_threads == 1 ? "" : "s", peak1, fma.zmm ? "AVX-512" : "AVX2", BENCH_CHAINS,
                             fma.zmm ? "_mm512_fmadd_ps" : "_mm256_fmadd_ps");
        else printf("FMA peak      n/a (no AVX2/FMA on this CPU or in this build)\n");
        if (dpeak > 0)
            printf("dot peak      %.1f GOP/s on %d thread%s, %.1f on one (%s, %d independent chains, %.0f ops each; best of 6): what the %s compute's GEMMs multiply with; %% dot = GFLOP/s / this\n",
                   dpeak, hook.max_threads, hook.max_threads == 1 ? "" : "s", dpeak1, bench_dot_name[dot.dot], BENCH_CHAINS,
                   bench_dot_ops[dot.dot], cli_compute_name(mi.compute));
        printf("model create  %.3f s (validation and weight packing)\n", create_s);
        printf("\n%-32s %9s %9s %9s %7s%s\n", repeats > 1 ? "stage (fastest run)" : "stage", "seconds", "GFLOP", "GFLOP/s", "% peak",
               dpeak > 0 ? "   % dot" : "");
        for (i = 0; i < nrows; i++) {
            printf("%-32s %9.4f %9.3f", rows[i].name, rows[i].seconds, rows[i].flops / 1e9);
            if (rows[i].flops > 0 && rows[i].seconds > 0) {
                double gfs = rows[i].flops / rows[i].seconds / 1e9;
                printf(" %9.2f", gfs);
                if (peak > 0) printf(" %6.1f%%", 100.0 * gfs / peak);
                else printf(" %7s", "-");
                if (dpeak > 0) printf(" %7.1f%%", 100.0 * gfs / dpeak);
            } else {
                printf(" %9s %7s", "-", "-");
                if (dpeak > 0) printf(" %8s", "-");
            }
            printf("\n");
        }
        printf("%-32s %9.4f %9.3f %9.2f", "total", best_total, total_flops / 1e9, total_flops / best_total / 1e9);
        if (peak > 0) printf(" %6.1f%%", 100.0 * total_flops / best_total / 1e9 / peak);
        else printf(" %7s", "-");
        if (dpeak > 0) printf(" %7.1f%%", 100.0 * total_flops / best_total / 1e9 / dpeak);
        printf("\n");
        if (repeats > 1) printf("(%d runs, mean total %.4f s)\n", repeats, sum_total / repeats);
        printf("\nmemory        model %.1f MiB + session %.1f MiB = %.1f MiB planned; process peak RSS %.1f MiB (getrusage, after the runs; includes the %.1f MiB file buffer)\n",
               cli_mib((double)mi.model_bytes), cli_mib((double)session_bytes), cli_mib((double)planned), cli_mib((double)rss),
               cli_mib((double)file_size));
        if (pipeline_only) printf("conv GEMM     skipped (--pipeline-only)\n");
        else printf("conv GEMM     3x3, %dx%dx%d -> %d (M=%d, K=%d, N=%d, %.2f GFLOP), packed weights, %d thread%s:\n", CLI_GEMM_HW,
               CLI_GEMM_HW, CLI_GEMM_C, CLI_GEMM_C, CLI_GEMM_HW * CLI_GEMM_HW, 9 * CLI_GEMM_C, CLI_GEMM_C, gemm_flops / 1e9,
               hook.max_threads, hook.max_threads == 1 ? "" : "s");
        if (t_avx2 > 0) printf("              avx2   %8.2f GFLOP/s (%.4f s)\n", gemm_flops / t_avx2 / 1e9, t_avx2);
        else if (!pipeline_only) printf("              avx2   n/a\n");
        if (t_avx512 > 0) printf("              avx512 %8.2f GFLOP/s (%.4f s), %.2fx avx2, %s bits as avx2\n", gemm_flops / t_avx512 / 1e9, t_avx512,
                                 t_avx2 > 0 ? t_avx2 / t_avx512 : 0.0, avx512_same ? "the same" : "NOT the same");
        else if (!pipeline_only) printf("              avx512 n/a (no AVX-512F on this CPU or in this build)\n");
        if (t_scalar > 0) printf("              scalar %8.2f GFLOP/s (%.4f s)\n", gemm_flops / t_scalar / 1e9, t_scalar);
        if (t_avx2 > 0) printf("              ratio  %.1fx (avx2 / scalar); max difference %.2g of max |C|; avx2 at %.1f%% of the FMA peak\n",
                               t_scalar / t_avx2, gemm_diff, peak > 0 ? 100.0 * gemm_flops / t_avx2 / 1e9 / peak : 0.0);
        if (t_avx512 > 0 && peak > 0) printf("              avx512 at %.1f%% of the FMA peak\n", 100.0 * gemm_flops / t_avx512 / 1e9 / peak);

        if (json_path) {
            jf = cli_mem_open(&jm, json_path);
            if (!jf) rc = CLI_FAIL;
        }
        if (jf) {
            fprintf(jf, "{\n  \"version\": \"%d.%d.%d\",\n  \"model\": ", (SUPERMAT_VERSION >> 16) & 255, (SUPERMAT_VERSION >> 8) & 255,
                    SUPERMAT_VERSION & 255);
            cli_json_string(jf, model_path);
            fprintf(jf, ",\n  \"kind\": \"%s\",\n  \"kernel\": \"%s\",\n  \"compute\": \"%s\",\n  \"conv\": \"%s\",\n  \"width\": %d,\n  \"height\": %d,\n  \"views\": %d,\n  \"outputs\": \"%s\",\n",
                    cli_kind_name(mi.kind), cli_kernel_name(mi.kernel), cli_compute_name(mi.compute), cli_conv_name(mi.conv),
                    w, h, nviews, outs_s);
            fprintf(jf, "  \"threads\": %d,\n  \"repeats\": %d,\n  \"fma_peak_gflops\": %.6g,\n  \"fma_peak_one_thread_gflops\": %.6g,\n  \"model_create_seconds\": %.6g,\n",
                    hook.max_threads, repeats, peak, peak1, create_s);
            fputs("  \"dot_peak_gops\": ", jf);
            cli_json_number_or_null(jf, dpeak > 0, dpeak);
            fputs(",\n  \"dot_peak_one_thread_gops\": ", jf);
            cli_json_number_or_null(jf, dpeak > 0, dpeak1);
            fprintf(jf, ",\n  \"dot_peak_isa\": \"%s\",\n", bench_dot_name[dpeak > 0 ? dot.dot : BENCH_DOT_NONE]);
            fprintf(jf, "  \"stages\": [\n");
            for (i = 0; i < nrows; i++) {
                double gfs = rows[i].seconds > 0 ? rows[i].flops / rows[i].seconds / 1e9 : 0.0;
                fprintf(jf, "    {\"stage\": ");
                cli_json_string(jf, rows[i].name);
                fprintf(jf, ", \"seconds\": %.6g, \"gflop\": %.6g, \"gflops\": %.6g, \"percent_of_peak\": %.6g, \"percent_of_dot_peak\": ", rows[i].seconds,
                        rows[i].flops / 1e9, gfs, peak > 0 ? 100.0 * gfs / peak : 0.0);
                cli_json_number_or_null(jf, dpeak > 0, dpeak > 0 ? 100.0 * gfs / dpeak : 0.0);
                fprintf(jf, "}%s\n", i + 1 < nrows ? "," : "");
            }
            fprintf(jf, "  ],\n  \"total\": {\"seconds\": %.6g, \"mean_seconds\": %.6g, \"gflop\": %.6g, \"gflops\": %.6g, \"percent_of_peak\": %.6g, \"percent_of_dot_peak\": ",
                    best_total, sum_total / repeats, total_flops / 1e9, total_flops / best_total / 1e9,
                    peak > 0 ? 100.0 * total_flops / best_total / 1e9 / peak : 0.0);
            cli_json_number_or_null(jf, dpeak > 0, dpeak > 0 ? 100.0 * total_flops / best_total / 1e9 / dpeak : 0.0);
            fputs("},\n", jf);
            fprintf(jf, "  \"flops\": {\"encode\": %.6g, \"trunk\": %.6g, \"branch\": %.6g, \"decode\": %.6g, \"total\": %.6g},\n",
                    fl.encode, fl.trunk, fl.branch, fl.decode, fl.total);
            fprintf(jf, "  \"memory\": {\"model_bytes\": %llu, \"session_bytes\": %llu, \"planned_bytes\": %llu, \"peak_rss_bytes\": %llu, \"file_bytes\": %llu},\n",
                    (unsigned long long)mi.model_bytes, (unsigned long long)session_bytes, (unsigned long long)planned,
                    (unsigned long long)rss, (unsigned long long)file_size);
            if (pipeline_only) fprintf(jf, "  \"gemm\": null\n}\n");
            else fprintf(jf, "  \"gemm\": {\"M\": %d, \"K\": %d, \"N\": %d, \"gflop\": %.6g, \"avx2_gflops\": %.6g, \"avx512_gflops\": %.6g, \"avx512_same_bits\": %s, \"scalar_gflops\": %.6g, \"ratio\": %.6g, \"max_rel_diff\": %.6g},\n  \"fma_peak_isa\": \"%s\"\n}\n",
                    CLI_GEMM_HW * CLI_GEMM_HW, 9 * CLI_GEMM_C, CLI_GEMM_C, gemm_flops / 1e9, t_avx2 > 0 ? gemm_flops / t_avx2 / 1e9 : 0.0,
                    t_avx512 > 0 ? gemm_flops / t_avx512 / 1e9 : 0.0, avx512_same ? "true" : "false",
                    t_scalar > 0 ? gemm_flops / t_scalar / 1e9 : 0.0, t_avx2 > 0 ? t_scalar / t_avx2 : 0.0, gemm_diff, fma.zmm ? "avx512" : "avx2");
            if (cli_mem_commit(&jm, json_path, 1, 0) != CLI_OK) rc = CLI_FAIL;
        }
    }

    free(rgba); free(alb); free(rough); free(metal); free(mask); free(pos);
    free(in_v); free(alb_v); free(rough_v); free(metal_v); free(c2w);
    supermat_session_destroy(sess);
    supermat_model_destroy(model);
    cli_free_file(file);
#ifndef SUPERMAT_NO_PTHREADS
    supermat_pool_destroy(pool);
#endif
    (void)pool;
    return rc;
}
