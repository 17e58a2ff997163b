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

/* the output stems of n inputs: each input's file name without its extension, or with it ("a_png", see
   cli_stem_with_ext) for inputs that share a stem (a.png, a.jpg); two inputs that would still write the
   same files (one picture named twice, a.png next to a_png.jpg) are a usage error. *stems is allocated
   (free with cli_free_stems) even on error. */
static int cli_make_stems(const char *cmd, const char *const *inputs, int n, char ***stems) {
    int i, j;
    char *shared;
    *stems = (char **)calloc((size_t)(n > 0 ? n : 1), sizeof(char *));
    shared = (char *)calloc((size_t)(n > 0 ? n : 1), 1);
    if (!*stems || !shared) { free(shared); cli_error("out of memory"); return CLI_FAIL; }
    for (i = 0; i < n; i++) {
        char *s = (*stems)[i] = cli_stem(inputs[i]);
        if (!s) { free(shared); cli_error("out of memory"); return CLI_FAIL; }
        if (!s[0]) { free(shared); return cli_usage_error(cmd, "'%s' has no file name", inputs[i]); }
        for (j = 0; j < i; j++)
            if (!strcmp(s, (*stems)[j])) {
                if (!strcmp(inputs[i], inputs[j])) { free(shared); return cli_usage_error(cmd, "'%s' and '%s' would write the same files (%s_*)", inputs[j], inputs[i], s); }
                shared[i] = shared[j] = 1;
            }
    }
    for (i = 0; i < n; i++)
        if (shared[i]) {
            char *e = cli_stem_with_ext(inputs[i]);
            if (!e) { free(shared); cli_error("out of memory"); return CLI_FAIL; }
            free((*stems)[i]);
            (*stems)[i] = e;
        }
    free(shared);
    for (i = 0; i < n; i++)
        for (j = 0; j < i; j++)
            if (!strcmp((*stems)[i], (*stems)[j])) return cli_usage_error(cmd, "'%s' and '%s' would write the same files (%s_*)", inputs[j], inputs[i], (*stems)[i]);
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
    int want_float, threads, work_opt, tty; /* work_opt: -1 none, 0 --native, N --work-size N */
    supermat_session *sess;
    int sw, sh;
    unsigned souts;       /* the outputs the session was made for */
    const char *prefix;   /* "[i/N] " before the progress line (batch), or "" */
    int alpha_drop;       /* --alpha drop: maps without the picture's alpha (0, the default: keep it) */
    cli_levers lv;        /* the model and session options of the command line */
} cli_image_ctx;

/* --alpha keep | drop */
static int cli_parse_alpha(const char *cmd, const char *v, int *drop) {
    if (!strcmp(v, "keep")) *drop = 0;
    else if (!strcmp(v, "drop")) *drop = 1;
    else { cli_usage_error(cmd, "--alpha: '%s' is not keep or drop", v); return -1; }
    return 0;
}
/* a picture's alpha at pixel i as the 8-bit PNGs store it (px: 8-bit RGBA, else fin: a 16-bit picture's
   float RGBA, v / 65535, quantised as the maps are) */
static unsigned char cli_alpha_at(const unsigned char *px, const float *fin, size_t i) {
    return px ? px[i * 4 + 3] : cli_quantize(fin[i * 4 + 3]);
}
/* does the picture (its file has `channels` channels) have a pixel that is not opaque? */
static int cli_has_alpha(const unsigned char *px, const float *fin, size_t np, int channels) {
    size_t i;
    if (channels != 2 && channels != 4) return 0;
    for (i = 0; i < np; i++)
        if (cli_alpha_at(px, fin, i) != 255) return 1;
    return 0;
}

static void cli_image_ctx_release(cli_image_ctx *X) {
    supermat_session_destroy(X->sess);
    X->sess = NULL;
    X->sw = X->sh = 0;
}

/* one picture -> its maps in out_dir as <stem>_*.png (+ .pfm): CLI_OK, CLI_SKIPPED (--skip-existing kept
   them) or CLI_FAIL with the message printed (cli_last_error holds it) */
static int cli_image_one(cli_image_ctx *X, const char *input, const char *out_dir, const char *stem) {
    int w = 0, h = 0, c = 0, rc = CLI_OK, tty = X->tty, alpha, k, is16 = 0;
    unsigned outputs = X->outputs;
    unsigned char *px = NULL, *u8[3] = {NULL, NULL, NULL};
    float *fin = NULL, *maps[3] = {NULL, NULL, NULL};
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
    if (!cli_pic_info(input, "image", &w, &h, &c, X->lv.max_memory, &is16)) return CLI_FAIL;
    if (is16) fin = cli_load16f(input, &w, &h);   /* full precision, float input */
    else px = cli_load(input, &w, &h, &c, 4);
    if (!px && !fin) { cli_error("cannot read image '%s': %s", input, cli_stbi_reason()); return CLI_FAIL; }
    if (X->sess && (X->sw != w || X->sh != h || X->souts != outputs)) cli_image_ctx_release(X);
    if (!X->sess) {
        supermat_session_desc sd;
        memset(&sd, 0, sizeof sd);
        sd.model = X->model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.threads = X->threads;
        sd.max_memory = cli_session_budget(X->model, X->lv.max_memory);
        cli_session_opts(&sd, X->work_opt, &X->lv); /* what was not given: the model file's pipeline */
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
    alpha = !X->alpha_drop && cli_has_alpha(px, fin, np, c);
    /* the maps: 8-bit straight from the library, with the picture's alpha when it has one (RGBA albedo, gray +
       alpha; the same rounding as cli_quantize), or with --float as floats, quantised here for the PNGs
       (tmp: 4 bytes/pixel) */
    for (k = 0; k < 3; k++) {
        int ch = k ? 1 : 3;
        if (!(outputs & (k == 0 ? SUPERMAT_OUTPUT_ALBEDO : k == 1 ? SUPERMAT_OUTPUT_ROUGHNESS : SUPERMAT_OUTPUT_METALLIC))) continue;
        if (X->want_float) maps[k] = (float *)malloc(np * (size_t)ch * sizeof(float));
        else u8[k] = (unsigned char *)malloc(np * (size_t)(ch + alpha));
        if (!maps[k] && !u8[k]) rc = CLI_FAIL;
    }
    if (X->want_float) {
        tmp = (unsigned char *)malloc(np * 4);
        if (!tmp) rc = CLI_FAIL;
    }
    if (rc != CLI_OK) cli_error("out of memory for the maps of '%s'", input);
    if (rc == CLI_OK) {
        supermat_image *o[3];
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = fin ? (void *)fin : (void *)px; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
        rd.input.format = fin ? SUPERMAT_FORMAT_F32 : SUPERMAT_FORMAT_U8;
        o[0] = &rd.albedo; o[1] = &rd.roughness; o[2] = &rd.metallic;
        for (k = 0; k < 3; k++) {
            o[k]->channels = k ? 1 : 3;
            if (maps[k]) { o[k]->pixels = maps[k]; o[k]->format = SUPERMAT_FORMAT_F32; }
            else if (u8[k]) { o[k]->pixels = u8[k]; o[k]->format = SUPERMAT_FORMAT_U8; o[k]->channels += alpha; }
        }
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
    for (k = 0; k < 3 && rc == CLI_OK; k++) {
        int ch = k ? 1 : 3, pch = ch + alpha;
        const unsigned char *png = u8[k];
        char suffix[64], *path;
        size_t i;
        int c2;
        if (!maps[k] && !u8[k]) continue;
        if (maps[k]) { /* compose the PNG's bytes: quantised floats and the alpha */
            for (i = 0; i < np; i++) {
                for (c2 = 0; c2 < ch; c2++) tmp[i * pch + c2] = cli_quantize(maps[k][i * ch + c2]);
                if (alpha) tmp[i * pch + ch] = cli_alpha_at(px, fin, i);
            }
            png = tmp;
        }
        snprintf(suffix, sizeof suffix, "%s.png", cli_map_suffixes[k]);
        path = cli_join(out_dir, stem, suffix);
        if (!path) { cli_error("out of memory"); rc = CLI_FAIL; break; }
        rc = cli_write_png_u8(path, png, w, h, pch);
        free(path);
        if (rc == CLI_OK && maps[k]) {
            snprintf(suffix, sizeof suffix, "%s.pfm", cli_map_suffixes[k]);
            path = cli_join(out_dir, stem, suffix);
            if (!path) { cli_error("out of memory"); rc = CLI_FAIL; break; }
            rc = cli_write_pfm(path, maps[k], w, h, ch);
            free(path);
        }
    }
    for (k = 0; k < 3; k++) { free(maps[k]); free(u8[k]); }
    free(tmp);
    stbi_image_free(px); free(fin);
    return rc;
}

/* `supermat image`: its options and --help */
enum { CLI_IMAGE_MODEL = 1, CLI_IMAGE_OUT, CLI_IMAGE_OUTPUTS, CLI_IMAGE_ALPHA };
#define CLI_HELP_ALPHA "keep | drop: a picture with transparent pixels gives maps with its alpha: the albedo\nRGBA, roughness and metallic gray + alpha (default keep; drop: RGB and gray,\nthe background as computed over gray 0.5)"
#define CLI_HELP_OUTPUTS "comma list of albedo,roughness,metallic (default: all three);\nonly what is asked for is computed"
static const cli_optdef cli_opts_image[] = {
    CLI_TEXT("usage: supermat image [--model FILE] --out DIR [options] IMAGE...\n"
             "\n"
             "Runs the single-view SuperMat pipeline (a supermat model) on each image and writes, at the\n"
             "image's own size,\n"
             "  DIR/<stem>_albedo.png       RGB, 8-bit\n"
             "  DIR/<stem>_roughness.png    gray, 8-bit\n"
             "  DIR/<stem>_metallic.png     gray, 8-bit\n"
             "where <stem> is the image's file name without its folder and extension (with the extension for\n"
             "images that share one: a.png, a.jpg -> a_png, a_jpg). A picture with transparent pixels keeps its\n"
             "alpha in the maps (RGBA and gray + alpha PNGs; --alpha).\n"
             "\n"
             "Images are read with stb_image (PNG, JPEG, BMP, TGA, ...) as 8-bit RGBA with straight alpha\n"
             "(16-bit PNGs at full precision; JPEGs turned upright by their EXIF orientation; WebP through\n"
             "libwebp when built with it); transparent pixels are composited over gray 0.5. Any size (with\n"
             "--native: multiples of 8).\n"
             "\n"
             "PREPROCESSING, as the official scripts: each picture is resized to the model's work size, a square\n"
             "the model file records (512x512 for a converted official checkpoint; the default model's is under\n"
             "DEFAULT MODEL below; `supermat info` shows any file's), the network runs there, and the maps are\n"
             "resized back to the picture's size.\n"),
    CLI_OPTS(cli_opts_work),
    {CLI_O_DETAIL, "--detail", "F|off", "the albedo keeps the picture's detail: picture x low-pass(albedo) / low-pass\n"
                                        "(picture) in linear light, the lighting taken as smooth over F x the picture's\n"
                                        "larger side (default: the model file's, 0.015625 = 1/64 for the default model,\n"
                                        "none for an official one; off: the network's albedo as it is; supermat.h,\n"
                                        "session_desc.detail_sigma)", NULL, NULL},
    {CLI_O_CHROMA, "--chroma", "W|off", "then the albedo takes the picture's colour (chromaticity) at the network's\n"
                                        "luminance, with weight W from 0 to 1 (default: the model file's, 1 for the\n"
                                        "default model, none for an official one; off: the network's colour;\n"
                                        "supermat.h, session_desc.chroma_weight). The default model has both steps:\n"
                                        "they measured closer to ground truth on validation assets (docs/quality.md);\n"
                                        "with `--detail off --chroma off` the albedo is the network's alone", NULL, NULL},
    {CLI_O_ROUGH_CURVE, "--roughness-curve", "LIST|off", CLI_HELP_ROUGH_CURVE, NULL, NULL},
    {CLI_O_METAL_CURVE, "--metallic-curve", "LIST|off", CLI_HELP_METAL_CURVE, NULL, NULL},
    CLI_TEXT("\noptions:\n"),
    {CLI_IMAGE_MODEL, "--model", "FILE|NAME", "a model file made by `supermat convert`, or a name: official (the official\n"
                                                "network, `supermat download official`), default (see NAMED MODELS and\n"
                                                "DEFAULT MODEL below; default: the default model)", NULL, NULL},
    {CLI_IMAGE_OUT, "--out", "DIR", "the output folder, created if missing (required)", NULL, NULL},
    {CLI_IMAGE_OUTPUTS, "--outputs", "LIST", CLI_HELP_OUTPUTS, NULL, NULL},
    {CLI_IMAGE_ALPHA, "--alpha", "A", CLI_HELP_ALPHA, NULL, NULL},
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
        else if (m == CLI_IMAGE_ALPHA) { if (cli_parse_alpha(cmd, v, &X.alpha_drop)) { free(imgs); return CLI_USAGE; } }
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
        int is16;
        if (!cli_pic_info(imgs[i], "image", &w, &h, &c, X.lv.max_memory, &is16)) { rc = CLI_FAIL; break; }
    }
    if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &X.lv, &file, &file_size, &X.model, NULL);
    if (rc == CLI_OK) rc = cli_require_kind(cmd, model_path, X.model, SUPERMAT_KIND_SUPERMAT);
    if (rc == CLI_OK) { /* at the pictures' own size the sides must be multiples of 8: every picture checked before any work */
        supermat_model_info mi;
        memset(&mi, 0, sizeof mi);
        supermat_model_get_info(X.model, &mi);
        for (i = 0; i < nimg && rc == CLI_OK && (work_opt == 0 || (work_opt < 0 && !mi.work_size)); i++) {
            int w, h, c, is16;
            if (!cli_pic_info(imgs[i], "image", &w, &h, &c, X.lv.max_memory, &is16)) rc = CLI_FAIL;
            else if (w % 8 || h % 8) {
                cli_error("image '%s' is %dx%d: the network runs at the picture's own size (%s), which needs multiples of 8 "
                          "(--work-size N resamples it)", imgs[i], w, h, work_opt == 0 ? "--native" : "the model records no work size");
                rc = CLI_FAIL;
            }
        }
    }
    if (rc == CLI_OK) rc = cli_mkdirs(out_dir);
    X.outputs = outputs; X.want_float = want_float; X.threads = threads; X.tty = tty; X.prefix = ""; X.work_opt = work_opt;
    for (i = 0; i < nimg && rc == CLI_OK; i++)
        if (cli_image_one(&X, imgs[i], out_dir, stems[i]) == CLI_FAIL) rc = CLI_FAIL;

    cli_image_ctx_release(&X);
    supermat_model_destroy(X.model);
    cli_free_file(file);
    cli_free_stems(stems, nimg);
    free(imgs);
    return rc;
}
