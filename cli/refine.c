/* cli/refine.c - `supermat refine`.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>refine */
/* an 8-bit gray image as PIL's convert("L"): gray as is, colour as (19595 R + 38470 G + 7471 B + 32768) >> 16
   (0.299/0.587/0.114), alpha dropped. Free with stbi_image_free. */
static unsigned char *cli_load_gray(const char *path, int *w, int *h) {
    int c = 0;
    unsigned char *p = cli_load(path, w, h, &c, 0);
    size_t n, i;
    if (!p || c == 1) return p;
    n = (size_t)*w * (size_t)*h;
    for (i = 0; i < n; i++) { /* in place: pixel i is read before anything at or after it is written */
        const unsigned char *s = p + i * (size_t)c;
        p[i] = c <= 2 ? s[0] : (unsigned char)(((uint32_t)s[0] * 19595u + (uint32_t)s[1] * 38470u + (uint32_t)s[2] * 7471u + 0x8000u) >> 16);
    }
    return p;
}

/* `supermat refine`: its options and --help */
enum { CLI_REFINE_MODEL = 1, CLI_REFINE_MAP, CLI_REFINE_MASK, CLI_REFINE_POSITION, CLI_REFINE_OUT };
static const cli_optdef cli_opts_refine[] = {
    CLI_TEXT("usage: supermat refine --model FILE --map MAP --mask MASK --position POS --out DIR [options]\n"
             "\n"
             "Runs the UV refinement network (a uv-refine model) on a partial UV texture map: it fills in and\n"
             "cleans up the map, guided by the observation mask and the surface position of each texel, and\n"
             "writes\n"
             "  DIR/<stem>_refined.png      RGB, 8-bit\n"
             "where <stem> is the --map file's name without its folder and extension. Use uv_refine_bc for a\n"
             "base colour (albedo) map, uv_refine_rm for a roughness/metallic map (R 0, G roughness, B metallic).\n"
             "\n"
             "The map and the position map are read as 8-bit RGB (alpha is dropped), the mask as 8-bit gray\n"
             "(colour converted as 0.299 R + 0.587 G + 0.114 B, alpha dropped), as the official script does.\n"
             "All three must have the same size (any; with --native multiples of 8); they run at the model's\n"
             "work size (1024x1024 as the official script) and the refined map comes back at their size.\n"),
    CLI_OPTS(cli_opts_work),
    {CLI_O_DETAIL, "--detail", "off", "as `supermat image --detail`, off only: a UV map has no picture to keep detail from", NULL, NULL},
    {CLI_O_CHROMA, "--chroma", "off", "as `supermat image --chroma`, off only: a UV map has no picture to take colour from", NULL, NULL},
    CLI_TEXT("\noptions:\n"),
    {CLI_REFINE_MODEL, "--model", "FILE|NAME", "a uv-refine model file made by `supermat convert`, or\n"
                                                 "official-refine-albedo / official-refine-rm (`supermat download official`)\n"
                                                 "(required)", NULL, NULL},
    {CLI_REFINE_MAP, "--map", "FILE", "the partial UV map (required)", NULL, NULL},
    {CLI_REFINE_MASK, "--mask", "FILE", "the mask: where the map was observed (required)", NULL, NULL},
    {CLI_REFINE_POSITION, "--position", "FILE", "the position map (required)", NULL, NULL},
    {CLI_REFINE_OUT, "--out", "DIR", "the output folder, created if missing (required)", NULL, NULL},
    {CLI_O_FLOAT, "--float", NULL, "also write the map before 8-bit quantisation as <stem>_refined.pfm (PF, RGB,\nfloat32, little endian)", NULL, NULL},
    CLI_OPTS(cli_opts_machine),
    CLI_TEXT("\nProgress is printed on stderr when it is a terminal.\n"),
    CLI_END};

static int cli_refine(int argc, char **argv) {
    const char *cmd = "refine", *v, *model_arg = NULL, *model_path, *out_dir = NULL, *paths[3] = {NULL, NULL, NULL};
    static const char *const opts[3] = {"--map", "--mask", "--position"}, *const what[3] = {"the map", "the mask", "the position map"};
    int want_float = 0, threads = 0, i, m, rc = CLI_OK, tty = isatty(2), w = 0, h = 0, work_opt = -1;
    cli_model_ref mref;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    char *stem = NULL;
    unsigned char *px[3] = {NULL, NULL, NULL}, *file = NULL, *tmp = NULL;
    float *refined = NULL;
    size_t file_size = 0;
    supermat_model *model = NULL;
    supermat_session *sess = NULL;
    cli_levers lv;
    cli_argp P;

    cli_levers_init(&lv);
    cli_argp_init(&P, cmd, cli_opts_refine, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, cli_opts_refine); return CLI_OK; }
        if (m == CLI_ARG_ERROR) return CLI_USAGE;
        if (m == CLI_ARG_OPERAND) return cli_usage_error(cmd, "unexpected argument '%s' (the inputs are given with --map, --mask and --position)", v);
        if (m >= CLI_REFINE_MAP && m <= CLI_REFINE_POSITION) paths[m - CLI_REFINE_MAP] = v;
        else if (m == CLI_REFINE_MODEL) model_arg = v;
        else if (m == CLI_REFINE_OUT) out_dir = v;
        else if (cli_run_value(cmd, m, v, &want_float, &work_opt, &threads, &kernel, &lv) < 0) return CLI_USAGE;
    }
    if (lv.detail > 0.0f) return cli_usage_error(cmd, "--detail: a UV map has no picture to keep detail from (image and views take it)");
    if (lv.chroma > 0.0f) return cli_usage_error(cmd, "--chroma: a UV map has no picture to take colour from (image and views take it)");
    if ((rc = cli_model_path(cmd, model_arg, 0, &mref)) != CLI_OK) return rc;
    model_path = mref.path;
    for (i = 0; i < 3; i++) if (!paths[i]) return cli_usage_error(cmd, "%s FILE is required", opts[i]);
    if (!out_dir) return cli_usage_error(cmd, "--out DIR is required");
    stem = cli_stem(paths[0]);
    if (!stem) { cli_error("out of memory"); return CLI_FAIL; }
    if (!stem[0]) { free(stem); return cli_usage_error(cmd, "--map '%s' has no file name", paths[0]); }

    /* the three sizes before the (slow) model load */
    for (i = 0; i < 3 && rc == CLI_OK; i++) {
        int iw, ih, c;
        if (!cli_pic_info(paths[i], what[i], &iw, &ih, &c, lv.max_memory, NULL)) { rc = CLI_FAIL; break; }
        if (i == 0) { w = iw; h = ih; }
        if (iw != w || ih != h) {
            cli_error("%s '%s' is %dx%d but the map '%s' is %dx%d: the map, the mask and the position map must have the same "
                      "size (supermat does not resize)", what[i], paths[i], iw, ih, paths[0], w, h);
            rc = CLI_FAIL;
        } else if (work_opt == 0 && (w % 8 || h % 8)) {
            cli_error("the map '%s' is %dx%d: --native runs the network at the maps' own size, which needs multiples of 8 "
                      "(without --native they are resampled to the model's work size)", paths[0], w, h);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &lv, &file, &file_size, &model, NULL);
    if (rc == CLI_OK) rc = cli_require_kind(cmd, model_path, model, SUPERMAT_KIND_UV_REFINE);
    if (rc == CLI_OK) {
        supermat_session_desc sd;
        supermat_error err;
        supermat_result r;
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = w; sd.height = h; sd.threads = threads;
        sd.max_memory = cli_session_budget(model, lv.max_memory);
        cli_session_opts(&sd, work_opt, &lv);
        r = supermat_session_create(&sd, &sess, &err);
        if (r != SUPERMAT_SUCCESS) {
            char msg[64];
            snprintf(msg, sizeof msg, "session (%dx%d)", w, h);
            cli_lib_error(msg, r, &err);
            cli_budget_note(model, r, lv.max_memory);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) rc = cli_mkdirs(out_dir);
    for (i = 0; i < 3 && rc == CLI_OK; i++) {
        int iw = 0, ih = 0, c = 0;
        px[i] = i == 1 ? cli_load_gray(paths[i], &iw, &ih) : cli_load(paths[i], &iw, &ih, &c, 3);
        if (!px[i]) { cli_error("cannot read %s '%s': %s", what[i], paths[i], cli_stbi_reason()); rc = CLI_FAIL; break; }
        if (iw != w || ih != h) { cli_error("%s '%s' is %dx%d, not %dx%d as before (did it change?)", what[i], paths[i], iw, ih, w, h); rc = CLI_FAIL; break; }
    }
    if (rc == CLI_OK) {
        refined = (float *)malloc((size_t)w * (size_t)h * 3 * sizeof(float));
        tmp = (unsigned char *)malloc((size_t)w * (size_t)h * 3);
        if (!refined || !tmp) { cli_error("out of memory for a %dx%d map", w, h); rc = CLI_FAIL; }
    }
    if (rc == CLI_OK) {
        supermat_run_desc rd;
        supermat_error err;
        supermat_result r;
        cli_progress prog;
        double t0 = cli_now();
        memset(&rd, 0, sizeof rd);
        rd.input.pixels = px[0]; rd.input.width = w; rd.input.height = h; rd.input.channels = 3;
        rd.mask.pixels = px[1]; rd.mask.width = w; rd.mask.height = h; rd.mask.channels = 1;
        rd.position.pixels = px[2]; rd.position.width = w; rd.position.height = h; rd.position.channels = 3;
        rd.refined.pixels = refined; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
        memset(&prog, 0, sizeof prog);
        prog.name = paths[0];
        if (tty) { rd.progress = cli_progress_cb; rd.progress_user = &prog; }
        r = supermat_run(sess, &rd, &err);
        if (tty && prog.shown) {
            if (r == SUPERMAT_SUCCESS) fprintf(stderr, "\r%s 100%% done (%.2f s)%*s\n", paths[0], cli_now() - t0, 8, "");
            else fputc('\n', stderr);
        }
        if (r != SUPERMAT_SUCCESS) {
            char msg[600];
            snprintf(msg, sizeof msg, "'%s'", paths[0]);
            cli_lib_error(msg, r, &err);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) {
        static const char *const suffix[1] = {"_refined"};
        static const int channels[1] = {3};
        rc = cli_write_maps(out_dir, stem, 1, suffix, &refined, channels, w, h, want_float, tmp);
    }

    for (i = 0; i < 3; i++) if (px[i]) stbi_image_free(px[i]);
    free(refined); free(tmp); free(stem);
    supermat_session_destroy(sess);
    supermat_model_destroy(model);
    cli_free_file(file);
    return rc;
}
