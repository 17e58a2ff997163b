/* cli/image.c - `supermat image` (and what `views` and `refine` share with it).
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>image */
typedef struct cli_progress {
    const char *name;
    int pct;
    char what[32];
    int shown;
} cli_progress;

static int cli_progress_cb(void *user, float fraction, const char *what) {
    cli_progress *p = (cli_progress *)user;
    int pct = (int)(fraction * 100.0f);
    if (pct < 0) pct = 0;
    if (pct > 100) pct = 100;
    if (!what) what = "";
    if (p->shown && pct == p->pct && !strncmp(what, p->what, sizeof p->what - 1)) return 0;
    p->pct = pct;
    snprintf(p->what, sizeof p->what, "%s", what);
    fprintf(stderr, "\r%s %3d%% %-16s", p->name, pct, p->what);
    fflush(stderr);
    p->shown = 1;
    return 0;
}

static const char *const cli_map_suffixes[3] = {"_albedo", "_roughness", "_metallic"};
static const int cli_map_channels[3] = {3, 1, 1};

/* the output stems of n inputs; two inputs with one stem would overwrite each other's maps (a usage
   error). *stems is allocated (free with cli_free_stems) even on error. */
static int cli_make_stems(const char *cmd, const char *const *inputs, int n, char ***stems) {
    int i, j;
    *stems = (char **)calloc((size_t)(n > 0 ? n : 1), sizeof(char *));
    if (!*stems) { cli_error("out of memory"); return CLI_FAIL; }
    for (i = 0; i < n; i++) {
        char *s = (*stems)[i] = cli_stem(inputs[i]);
        if (!s) { cli_error("out of memory"); return CLI_FAIL; }
        if (!s[0]) return cli_usage_error(cmd, "'%s' has no file name", inputs[i]);
        for (j = 0; j < i; j++)
            if (!strcmp(s, (*stems)[j])) return cli_usage_error(cmd, "'%s' and '%s' would write the same files (%s_*)", inputs[j], inputs[i], s);
    }
    return CLI_OK;
}
static void cli_free_stems(char **stems, int n) {
    int i;
    if (stems) for (i = 0; i < n; i++) free(stems[i]);
    free(stems);
}

/* What every picture of an `image` run (or of a batch) shares: the model, the options, and one session,
   kept while pictures have its size and released when the size changes (memory stays that of one size). */
typedef struct cli_image_ctx {
    supermat_model *model;
    unsigned outputs;
    int want_float, threads, ws, tty;
    supermat_session *sess;
    int sw, sh;
    unsigned souts;       /* the outputs the session was made for */
    const char *prefix;   /* "[i/N] " before the progress line (batch), or "" */
    cli_levers lv;        /* the model and session options of the command line */
} cli_image_ctx;

static void cli_image_ctx_release(cli_image_ctx *X) {
    supermat_session_destroy(X->sess);
    X->sess = NULL;
    X->sw = X->sh = 0;
}

/* one picture -> its maps in out_dir as <stem>_*.png (+ .pfm): CLI_OK, CLI_SKIPPED (--skip-existing kept
   them) or CLI_FAIL with the message printed (cli_last_error holds it) */
static int cli_image_one(cli_image_ctx *X, const char *input, const char *out_dir, const char *stem) {
    int w = 0, h = 0, c = 0, rc = CLI_OK, tty = X->tty;
    unsigned outputs = X->outputs;
    unsigned char *px = NULL;
    float *fa = NULL, *fr = NULL, *fm = NULL, *fin = NULL;
    unsigned char *tmp = NULL;
    supermat_run_desc rd;
    supermat_error err;
    supermat_result r;
    cli_progress prog;
    char name[700];
    double t0 = cli_now();
    size_t np;
    {
        int wanted[3], a;
        wanted[0] = (outputs & SUPERMAT_OUTPUT_ALBEDO) != 0;
        wanted[1] = (outputs & SUPERMAT_OUTPUT_ROUGHNESS) != 0;
        wanted[2] = (outputs & SUPERMAT_OUTPUT_METALLIC) != 0;
        a = cli_maps_allowed(out_dir, stem, 3, cli_map_suffixes, wanted, X->want_float);
        if (a == CLI_FAIL) return CLI_FAIL;
        if (a == CLI_SKIPPED) { fprintf(stderr, "kept the maps of '%s' (they exist; --skip-existing)\n", input); return CLI_SKIPPED; }
    }
    if (!cli_pic_info(input, "image", &w, &h, &c, X->lv.max_memory)) return CLI_FAIL;
    if (cli_pic_is16) fin = cli_load16f(input, &w, &h);   /* full precision, float input */
    else px = cli_load(input, &w, &h, &c, 4);
    if (!px && !fin) { cli_error("cannot read image '%s': %s", input, cli_stbi_reason()); return CLI_FAIL; }
    if (w % 8 || h % 8) {
        cli_error("image '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                  "resize it first, e.g. to 512x512)", input, w, h);
        stbi_image_free(px); free(fin);
        return CLI_FAIL;
    }
    if (X->sess && (X->sw != w || X->sh != h || X->souts != outputs)) cli_image_ctx_release(X);
    if (!X->sess) {
        supermat_session_desc sd;
        memset(&sd, 0, sizeof sd);
        sd.model = X->model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.threads = X->threads;
        sd.max_memory = cli_session_budget(X->model, X->lv.max_memory);
        cli_set_work(&sd, X->ws, w, h);
        sd.detail_sigma = X->lv.detail >= 0.0f ? X->lv.detail : 1.0f / 64.0f;
        sd.chroma_weight = X->lv.chroma >= 0.0f ? X->lv.chroma : 1.0f;
        r = supermat_session_create(&sd, &X->sess, &err);
        if (r != SUPERMAT_SUCCESS) {
            char what[600];
            snprintf(what, sizeof what, "session for '%s' (%dx%d)", input, w, h);
            cli_lib_error(what, r, &err);
            cli_budget_note(X->model, r, X->lv.max_memory);
            stbi_image_free(px); free(fin);
            X->sess = NULL;
            return CLI_FAIL;
        }
        X->sw = w; X->sh = h; X->souts = outputs;
    }
    np = (size_t)w * (size_t)h;
    if (outputs & SUPERMAT_OUTPUT_ALBEDO) fa = (float *)malloc(np * 3 * sizeof(float));
    if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) fr = (float *)malloc(np * sizeof(float));
    if (outputs & SUPERMAT_OUTPUT_METALLIC) fm = (float *)malloc(np * sizeof(float));
    tmp = (unsigned char *)malloc(np * 3);
    if (!tmp || ((outputs & SUPERMAT_OUTPUT_ALBEDO) && !fa) || ((outputs & SUPERMAT_OUTPUT_ROUGHNESS) && !fr) ||
        ((outputs & SUPERMAT_OUTPUT_METALLIC) && !fm)) {
        cli_error("out of memory for the maps of '%s'", input);
        rc = CLI_FAIL;
    }
    if (rc == CLI_OK) {
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = fin ? (void *)fin : (void *)px; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
        rd.input.format = fin ? SUPERMAT_FORMAT_F32 : SUPERMAT_FORMAT_U8;
        rd.albedo.pixels = fa; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
        rd.roughness.pixels = fr; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
        rd.metallic.pixels = fm; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
        memset(&prog, 0, sizeof prog);
        snprintf(name, sizeof name, "%s%s", X->prefix ? X->prefix : "", input);
        prog.name = name;
        if (tty) { rd.progress = cli_progress_cb; rd.progress_user = &prog; }
        r = supermat_run(X->sess, &rd, &err);
        if (tty && prog.shown) {
            if (r == SUPERMAT_SUCCESS) fprintf(stderr, "\r%s 100%% done (%.2f s)%*s\n", name, cli_now() - t0, 8, "");
            else fputc('\n', stderr);
        }
        if (r != SUPERMAT_SUCCESS) {
            char what[600];
            snprintf(what, sizeof what, "'%s'", input);
            cli_lib_error(what, r, &err);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) {
        float *maps[3];
        maps[0] = fa; maps[1] = fr; maps[2] = fm;
        rc = cli_write_maps(out_dir, stem, 3, cli_map_suffixes, maps, cli_map_channels, w, h, X->want_float, tmp);
    }
    free(fa); free(fr); free(fm); free(tmp);
    stbi_image_free(px); free(fin);
    return rc;
}

/* `supermat image`: its options and --help */
enum { CLI_IMAGE_MODEL = 1, CLI_IMAGE_OUT, CLI_IMAGE_OUTPUTS };
#define CLI_HELP_OUTPUTS "comma list of albedo,roughness,metallic (default: all three);\nonly what is asked for is computed"
static const cli_optdef cli_opts_image[] = {
    CLI_TEXT("usage: supermat image [--model FILE] --out DIR [options] IMAGE...\n"
             "\n"
             "Runs the single-view SuperMat pipeline (a supermat model) on each image and writes, at the\n"
             "image's own size,\n"
             "  DIR/<stem>_albedo.png       RGB, 8-bit\n"
             "  DIR/<stem>_roughness.png    gray, 8-bit\n"
             "  DIR/<stem>_metallic.png     gray, 8-bit\n"
             "where <stem> is the image's file name without its folder and extension.\n"
             "\n"
             "Images are read with stb_image (PNG, JPEG, BMP, TGA, ...) as 8-bit RGBA with straight alpha\n"
             "(16-bit PNGs at full precision; JPEGs turned upright by their EXIF orientation; WebP through\n"
             "libwebp when built with it); transparent pixels are composited over gray 0.5. Width and height\n"
             "must both be multiples of 8.\n"
             "\n"
             "PREPROCESSING, as the official scripts: each picture is resized to the model's work size, a square\n"
             "the model file records (512x512 for a converted official checkpoint; the default model's is under\n"
             "DEFAULT MODEL below; `supermat info` shows any file's), the network runs there, and the maps are\n"
             "resized back to the picture's size.\n"),
    CLI_OPTS(cli_opts_work),
    {CLI_O_DETAIL, "--detail", "F|off", "the albedo keeps the picture's detail: picture x low-pass(albedo) / low-pass\n"
                                        "(picture) in linear light, the lighting taken as smooth over F x the picture's\n"
                                        "larger side (default 1/64; off: the network's albedo as it is; supermat.h,\n"
                                        "session_desc.detail_sigma)", NULL, NULL},
    {CLI_O_CHROMA, "--chroma", "W|off", "then the albedo takes the picture's colour (chromaticity) at the network's\n"
                                        "luminance, with weight W from 0 to 1 (default 1; off: the network's colour;\n"
                                        "supermat.h, session_desc.chroma_weight). Both steps are on by default: they\n"
                                        "measured closer to ground truth on validation assets (docs/quality.md); with\n"
                                        "`--detail off --chroma off` the albedo is the network's alone", NULL, NULL},
    CLI_TEXT("\noptions:\n"),
    {CLI_IMAGE_MODEL, "--model", "FILE", "a model file made by `supermat convert` (default: the default model,\nsee DEFAULT MODEL below)", NULL, NULL},
    {CLI_IMAGE_OUT, "--out", "DIR", "the output folder, created if missing (required)", NULL, NULL},
    {CLI_IMAGE_OUTPUTS, "--outputs", "LIST", CLI_HELP_OUTPUTS, NULL, NULL},
    {CLI_O_FLOAT, "--float", NULL, CLI_HELP_FLOAT3, NULL, NULL},
    CLI_OPTS(cli_opts_machine),
    CLI_TEXT("\n"
             "Each file is written to a temporary file and renamed when complete. Progress (and the default model's\n"
             "path) is printed on stderr when it is a terminal. For a supermat-mv model use `supermat views`,\n"
             "for a uv-refine model `supermat refine`. `supermat sheet` puts inputs and maps side by side.\n"),
    CLI_END};

static int cli_image(int argc, char **argv) {
    const char *cmd = "image", *v, *model_arg = NULL, *model_path = NULL, *out_dir = NULL;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    int want_float = 0, threads = 0, i, m, nimg = 0, rc = CLI_OK, tty = isatty(2), work_opt = -1;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    const char **imgs;
    char **stems = NULL;
    unsigned char *file = NULL;
    size_t file_size = 0;
    cli_image_ctx X;
    cli_model_ref mref;
    cli_argp P;

    memset(&X, 0, sizeof X);
    cli_levers_init(&X.lv);
    imgs = (const char **)malloc(sizeof(char *) * (size_t)(argc > 0 ? argc : 1));
    if (!imgs) { cli_error("out of memory"); return CLI_FAIL; }
    cli_argp_init(&P, cmd, cli_opts_image, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, cli_opts_image); cli_print_default_model_help(); free(imgs); return CLI_OK; }
        if (m == CLI_ARG_ERROR) { free(imgs); return CLI_USAGE; }
        if (m == CLI_ARG_OPERAND) imgs[nimg++] = v;
        else if (m == CLI_IMAGE_MODEL) model_arg = v;
        else if (m == CLI_IMAGE_OUT) out_dir = v;
        else if (m == CLI_IMAGE_OUTPUTS) { if (cli_parse_outputs(cmd, v, &outputs)) { free(imgs); return CLI_USAGE; } }
        else if (cli_run_value(cmd, m, v, &want_float, &work_opt, &threads, &kernel, &X.lv) < 0) { free(imgs); return CLI_USAGE; }
    }
    if (!out_dir) { free(imgs); return cli_usage_error(cmd, "--out DIR is required"); }
    if (!nimg) { free(imgs); return cli_usage_error(cmd, "no input image"); }

    rc = cli_make_stems(cmd, imgs, nimg, &stems);
    if (rc == CLI_OK) rc = cli_model_path(cmd, model_arg, 1, &mref);
    if (rc == CLI_OK) {
        model_path = mref.path;
        if (tty && !model_arg) fprintf(stderr, "model %s (the default model: %s)\n", model_path, mref.from);
    }
    /* check every image before the (slow) model load */
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        int w, h, c;
        if (!cli_pic_info(imgs[i], "image", &w, &h, &c, X.lv.max_memory)) { rc = CLI_FAIL; break; }
        if (w % 8 || h % 8) {
            cli_error("image '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                      "resize it first, e.g. to 512x512)", imgs[i], w, h);
            rc = CLI_FAIL;
            break;
        }
    }
    if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &X.lv, &file, &file_size, &X.model, NULL);
    if (rc == CLI_OK) rc = cli_require_kind(cmd, model_path, X.model, SUPERMAT_KIND_SUPERMAT);
    if (rc == CLI_OK) X.ws = cli_work_size(file, file_size, X.model, work_opt);
    if (rc == CLI_OK) rc = cli_mkdirs(out_dir);
    X.outputs = outputs; X.want_float = want_float; X.threads = threads; X.tty = tty; X.prefix = "";
    for (i = 0; i < nimg && rc == CLI_OK; i++)
        if (cli_image_one(&X, imgs[i], out_dir, stems[i]) == CLI_FAIL) rc = CLI_FAIL;

    cli_image_ctx_release(&X);
    supermat_model_destroy(X.model);
    cli_free_file(file);
    cli_free_stems(stems, nimg);
    free(imgs);
    return rc;
}
