/* cli/views.c - `supermat views`: meta.json cameras, the multi-view run.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>views */
#define CLI_MAX_VIEWS 64
#define CLI_MAX_INDEX 999999999L
#define CLI_MAX_CAMERAS 4096

typedef struct cli_camera { long index; float m[16]; } cli_camera;

/* decimal digits (leading zeros allowed) as an index; -1 if not all digits or too large */
static long cli_digits_index(const char *s, size_t n) {
    long v = 0;
    size_t i;
    if (n == 0) return -1;
    for (i = 0; i < n; i++) {
        int d = s[i] - '0';
        if (d < 0 || d > 9 || v > (CLI_MAX_INDEX - d) / 10) return -1;
        v = v * 10 + d;
    }
    return v;
}

/* the number that ends a file stem (color_0003 -> 3), or -1 */
static long cli_stem_index(const char *stem) {
    size_t n = strlen(stem), i = n;
    while (i > 0 && stem[i - 1] >= '0' && stem[i - 1] <= '9') i--;
    return cli_digits_index(stem + i, n - i);
}

/* a JSON token's text, shortened, for messages */
static void cli_tok_text(const char *js, const supermat_json_tok *t, char *buf, size_t cap) {
    int n = t->end - t->start;
    if (t->type == SUPERMAT_JSON_OBJECT) { snprintf(buf, cap, "an object"); return; }
    if (t->type == SUPERMAT_JSON_ARRAY) { snprintf(buf, cap, "an array"); return; }
    if (n > 24) snprintf(buf, cap, "%s%.24s...%s", t->type == SUPERMAT_JSON_STRING ? "\"" : "", js + t->start,
                         t->type == SUPERMAT_JSON_STRING ? "\"" : "");
    else snprintf(buf, cap, "%s%.*s%s", t->type == SUPERMAT_JSON_STRING ? "\"" : "", n, js + t->start,
                  t->type == SUPERMAT_JSON_STRING ? "\"" : "");
}

/* one matrix element: CLI_OK, else an error naming the file, the location and the element */
static int cli_camera_number(const char *path, int loc, const char *js, const supermat_json_tok *t, const char *elem, float *out) {
    double d;
    char txt[40];
    int i, bad = supermat_json_number(js, t, &d) != 0;
    if (!bad && (!(d - d == 0.0) || fabs(d) > (double)FLT_MAX)) { /* 1e999, -Infinity (Python's json writes it) */
        cli_tok_text(js, t, txt, sizeof txt);
        cli_error("cameras '%s': locations[%d]: transform_matrix%s is not a finite float32 number (%s)", path, loc, elem, txt);
        return CLI_FAIL;
    }
    for (i = t->start; i < t->end && !bad; i++) bad = !strchr("0123456789+-.eE", js[i]); /* JSON numbers only: no 0x10 */
    if (bad) {
        cli_tok_text(js, t, txt, sizeof txt);
        cli_error("cameras '%s': locations[%d]: transform_matrix%s is not a number (%s)", path, loc, elem, txt);
        return CLI_FAIL;
    }
    *out = (float)d;
    return CLI_OK;
}

/* transform_matrix (token t) of locations[loc]: 4 rows of 4 numbers, or 16 numbers; row-major */
static int cli_camera_matrix(const char *path, int loc, const char *js, const supermat_json_tok *toks, int t, float *m) {
    int r, c, k;
    char elem[32];
    if (toks[t].type != SUPERMAT_JSON_ARRAY || toks[t].size < 1) {
        cli_error("cameras '%s': locations[%d]: transform_matrix is not a 4x4 matrix (4 rows of 4 numbers)", path, loc);
        return CLI_FAIL;
    }
    if (toks[t + 1].type == SUPERMAT_JSON_ARRAY) { /* [[...], [...], [...], [...]] */
        if (toks[t].size != 4) {
            cli_error("cameras '%s': locations[%d]: transform_matrix has %d row%s, not 4 (a 4x4 camera-to-world matrix)", path, loc,
                      toks[t].size, toks[t].size == 1 ? "" : "s");
            return CLI_FAIL;
        }
        for (r = 0, k = t + 1; r < 4; r++, k = toks[k].next) {
            if (toks[k].type != SUPERMAT_JSON_ARRAY || toks[k].size != 4) {
                if (toks[k].type == SUPERMAT_JSON_ARRAY)
                    cli_error("cameras '%s': locations[%d]: transform_matrix row %d has %d number%s, not 4", path, loc, r, toks[k].size,
                              toks[k].size == 1 ? "" : "s");
                else cli_error("cameras '%s': locations[%d]: transform_matrix row %d is not a list of 4 numbers", path, loc, r);
                return CLI_FAIL;
            }
            for (c = 0; c < 4; c++) {
                snprintf(elem, sizeof elem, "[%d][%d]", r, c);
                if (cli_camera_number(path, loc, js, &toks[k + 1 + c], elem, &m[r * 4 + c])) return CLI_FAIL;
            }
        }
        return CLI_OK;
    }
    if (toks[t].size != 16) { /* flat */
        cli_error("cameras '%s': locations[%d]: transform_matrix has %d number%s, not 16 (4 rows of 4)", path, loc, toks[t].size,
                  toks[t].size == 1 ? "" : "s");
        return CLI_FAIL;
    }
    for (k = 0; k < 16; k++) {
        snprintf(elem, sizeof elem, "[%d]", k);
        if (cli_camera_number(path, loc, js, &toks[t + 1 + k], elem, &m[k])) return CLI_FAIL;
    }
    return CLI_OK;
}

/* Reads meta.json ({"locations": [{"index": "0000" or 0, "transform_matrix": 4x4}, ...]}): every
   location's index and camera-to-world matrix; unique indices. CLI_OK, or an error naming the file. */
static int cli_read_cameras(const char *path, cli_camera **out, int *count) {
    unsigned char *buf = NULL;
    size_t size = 0;
    supermat_json_tok *toks = NULL;
    cli_camera *cams = NULL;
    const char *js;
    int ntok, loc, i, j, k, n = 0, rc = CLI_FAIL;
    char txt[40];
    *out = NULL; *count = 0;
    if (cli_read_file(path, &buf, &size)) return CLI_FAIL;
    js = (const char *)buf;
    ntok = supermat_json_parse(js, size, NULL, 0);
    if (ntok == SUPERMAT_ERROR_OUT_OF_MEMORY) { cli_error("out of memory reading cameras '%s'", path); goto done; }
    if (ntok <= 0) { cli_error("cameras '%s' is not valid JSON", path); goto done; }
    toks = (supermat_json_tok *)malloc(sizeof(supermat_json_tok) * (size_t)ntok);
    if (!toks) { cli_error("out of memory reading cameras '%s'", path); goto done; }
    if (supermat_json_parse(js, size, toks, ntok) != ntok) { cli_error("cameras '%s' is not valid JSON", path); goto done; }
    loc = toks[0].type == SUPERMAT_JSON_OBJECT ? supermat_json_find(js, toks, 0, "locations") : -1;
    if (loc < 0 || toks[loc].type != SUPERMAT_JSON_ARRAY) {
        cli_error("cameras '%s' has no \"locations\" list (expected {\"locations\": [{\"index\": \"0000\", \"transform_matrix\": "
                  "[[...], [...], [...], [...]]}, ...]})", path);
        goto done;
    }
    if (toks[loc].size > CLI_MAX_CAMERAS) { /* the duplicate check is quadratic: a hostile file must not make it hang */
        cli_error("cameras '%s' lists %d locations; at most %d are read (SuperMatMV takes up to 64 views)", path, toks[loc].size, CLI_MAX_CAMERAS);
        goto done;
    }
    cams = (cli_camera *)calloc((size_t)(toks[loc].size > 0 ? toks[loc].size : 1), sizeof *cams);
    if (!cams) { cli_error("out of memory reading cameras '%s'", path); goto done; }
    for (i = 0, k = loc + 1; i < toks[loc].size; i++, k = toks[k].next) {
        int it, tm;
        long index = -1;
        if (toks[k].type != SUPERMAT_JSON_OBJECT) { cli_error("cameras '%s': locations[%d] is not an object", path, i); goto done; }
        it = supermat_json_find(js, toks, k, "index");
        tm = supermat_json_find(js, toks, k, "transform_matrix");
        if (it < 0) { cli_error("cameras '%s': locations[%d] has no \"index\"", path, i); goto done; }
        if (toks[it].type == SUPERMAT_JSON_STRING) {
            index = cli_digits_index(js + toks[it].start, (size_t)(toks[it].end - toks[it].start));
        } else {
            double d;
            if (supermat_json_number(js, &toks[it], &d) == 0 && d >= 0.0 && d <= (double)CLI_MAX_INDEX && d == floor(d)) index = (long)d;
        }
        if (index < 0) {
            cli_tok_text(js, &toks[it], txt, sizeof txt);
            cli_error("cameras '%s': locations[%d]: index %s is not a whole number from 0 to %ld (e.g. \"0003\" or 3)", path, i, txt, CLI_MAX_INDEX);
            goto done;
        }
        if (tm < 0) { cli_error("cameras '%s': locations[%d] (index %ld) has no \"transform_matrix\"", path, i, index); goto done; }
        if (cli_camera_matrix(path, i, js, toks, tm, cams[n].m)) goto done;
        for (j = 0; j < n; j++)
            if (cams[j].index == index) {
                cli_error("cameras '%s': index %ld appears twice (locations[%d] and locations[%d])", path, index, j, i);
                goto done;
            }
        cams[n++].index = index;
    }
    rc = CLI_OK;
done:
    free(toks);
    cli_free_file(buf);
    if (rc != CLI_OK) { free(cams); return rc; }
    *out = cams;
    *count = n;
    return CLI_OK;
}

/* the camera with this index, or NULL after a message that lists the indices there are */
static const cli_camera *cli_find_camera(const cli_camera *cams, int n, long index, const char *view, const char *path) {
    char list[160];
    size_t len = 0;
    int i;
    for (i = 0; i < n; i++) if (cams[i].index == index) return &cams[i];
    list[0] = 0;
    for (i = 0; i < n && len < sizeof list - 24; i++) len += (size_t)snprintf(list + len, sizeof list - len, "%s%ld", i ? ", " : "", cams[i].index);
    if (i < n) snprintf(list + len, sizeof list - len, ", ...");
    cli_error("view '%s' has index %ld (the number its file name ends with), but cameras '%s' has no location with index %ld "
              "(%s%s)", view, index, path, index, n ? "it has " : "it has no locations", list);
    return NULL;
}

/* equally spaced cameras on a circle around the origin, looking at it (bench input) */
static void cli_ring_cameras(int views, float *c2w) {
    int v;
    for (v = 0; v < views; v++) {
        double a = 2.0 * 3.14159265358979323846 * v / views, s = sin(a), c = cos(a);
        float *m = c2w + 16 * v;
        memset(m, 0, 16 * sizeof(float));
        m[0] = (float)c;  m[2] = (float)s;  m[3] = (float)(2.0 * s);
        m[5] = 1.0f;
        m[8] = (float)-s; m[10] = (float)c; m[11] = (float)(2.0 * c);
        m[15] = 1.0f;
    }
}

/* `supermat views`: its options and --help */
enum { CLI_VIEWS_MODEL = 1, CLI_VIEWS_CAMERAS, CLI_VIEWS_OUT, CLI_VIEWS_OUTPUTS };
static const cli_optdef cli_opts_views[] = {
    CLI_TEXT("usage: supermat views --model FILE --cameras meta.json --out DIR [options] VIEW...\n"
             "\n"
             "Runs the multi-view SuperMatMV pipeline (a supermat-mv model) on all the views of one object\n"
             "together (they attend to each other, each with its camera) and writes, for each view,\n"
             "  DIR/<stem>_albedo.png       RGB, 8-bit\n"
             "  DIR/<stem>_roughness.png    gray, 8-bit\n"
             "  DIR/<stem>_metallic.png     gray, 8-bit\n"
             "where <stem> is the view's file name without its folder and extension.\n"
             "\n"
             "Cameras come from a meta.json in the official example format:\n"
             "  {\"locations\": [{\"index\": \"0000\", \"transform_matrix\": [[4 numbers], x4]}, ...]}\n"
             "(the 4x4 camera-to-world matrix, row by row; a flat list of 16 numbers is also read). A view's\n"
             "camera is the location whose index (\"0003\" or 3) equals the number that ends the view's file\n"
             "name: color_0003.png -> 3. Every view needs one; indices must be unique.\n"
             "\n"
             "Views are read like `image` reads images (8-bit RGBA, straight alpha, over gray 0.5). They must\n"
             "all have the same size (any; with --native multiples of 8); they run at the model's work size\n"
             "(512x512 as the official script), the maps come back at the views' size. 1 to 64 views (the\n"
             "official model is trained on 6 orthogonal views).\n"),
    CLI_OPTS(cli_opts_work),
    {CLI_O_DETAIL, "--detail", "F|off", "each view's albedo keeps that view's detail, as `supermat image --detail`\n(default: the model's; off for\nthe official and default models)", NULL, NULL},
    {CLI_O_CHROMA, "--chroma", "W|off", "each view's albedo takes that view's colour, as `supermat image --chroma`\n(default: the model's; off for the official and default models)", NULL, NULL},
    {CLI_O_ROUGH_CURVE, "--roughness-curve", "LIST|off", "each view's roughness through the curve, as `supermat image --roughness-curve`\n(default: the model's; none for the official and default models)", NULL, NULL},
    {CLI_O_METAL_CURVE, "--metallic-curve", "LIST|off", "each view's metallic through the curve, as `supermat image --metallic-curve`\n(default: the model's; none for the official and default models)", NULL, NULL},
    CLI_TEXT("\noptions:\n"),
    {CLI_VIEWS_MODEL, "--model", "FILE|NAME", "a supermat-mv model file made by `supermat convert`, or official (the\n"
                                                "official SuperMatMV, `supermat download official`) (required)", NULL, NULL},
    {CLI_VIEWS_CAMERAS, "--cameras", "FILE", "the meta.json with the views' cameras (required)", NULL, NULL},
    {CLI_VIEWS_OUT, "--out", "DIR", "the output folder, created if missing (required)", NULL, NULL},
    {CLI_VIEWS_OUTPUTS, "--outputs", "LIST", CLI_HELP_OUTPUTS, NULL, NULL},
    {CLI_O_FLOAT, "--float", NULL, CLI_HELP_FLOAT3, NULL, NULL},
    CLI_OPTS(cli_opts_machine),
    CLI_TEXT("\nProgress is printed on stderr when it is a terminal.\n"),
    CLI_END};

static int cli_views(int argc, char **argv) {
    const char *cmd = "views", *v, *model_arg = NULL, *model_path, *cam_path = NULL, *out_dir = NULL;
    cli_model_ref mref;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    int want_float = 0, threads = 0, i, m, nimg = 0, rc = CLI_OK, tty = isatty(2), w = 0, h = 0, ncam = 0, work_opt = -1;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    const char **imgs;
    char **stems = NULL;
    long *index = NULL;
    cli_camera *cams = NULL;
    float *c2w = NULL, *fa = NULL, *fr = NULL, *fm = NULL;
    unsigned char **px = NULL, *tmp = NULL;
    supermat_image *in = NULL, *oa = NULL, *orr = NULL, *om = NULL;
    unsigned char *file = NULL;
    size_t file_size = 0, np = 0;
    supermat_model *model = NULL;
    supermat_session *sess = NULL;
    cli_levers lv;
    cli_argp P;

    cli_levers_init(&lv);
    imgs = (const char **)malloc(sizeof(char *) * (size_t)(argc > 0 ? argc : 1));
    if (!imgs) { cli_error("out of memory"); return CLI_FAIL; }
    cli_argp_init(&P, cmd, cli_opts_views, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, cli_opts_views); free(imgs); return CLI_OK; }
        if (m == CLI_ARG_ERROR) { free(imgs); return CLI_USAGE; }
        if (m == CLI_ARG_OPERAND) imgs[nimg++] = v;
        else if (m == CLI_VIEWS_MODEL) model_arg = v;
        else if (m == CLI_VIEWS_CAMERAS) cam_path = v;
        else if (m == CLI_VIEWS_OUT) out_dir = v;
        else if (m == CLI_VIEWS_OUTPUTS) { if (cli_parse_outputs(cmd, v, &outputs)) { free(imgs); return CLI_USAGE; } }
        else if (cli_run_value(cmd, m, v, &want_float, &work_opt, &threads, &kernel, &lv) < 0) { free(imgs); return CLI_USAGE; }
    }
    if ((rc = cli_model_path(cmd, model_arg, 0, &mref)) != CLI_OK) { free(imgs); return rc; }
    model_path = mref.path;
    if (!cam_path) { free(imgs); return cli_usage_error(cmd, "--cameras meta.json is required"); }
    if (!out_dir) { free(imgs); return cli_usage_error(cmd, "--out DIR is required"); }
    if (!nimg) { free(imgs); return cli_usage_error(cmd, "no view image"); }
    if (nimg > CLI_MAX_VIEWS) { free(imgs); return cli_usage_error(cmd, "%d views: at most %d are processed together", nimg, CLI_MAX_VIEWS); }

    rc = cli_make_stems(cmd, imgs, nimg, &stems);
    /* every view's index, size and camera before the (slow) model load */
    if (rc == CLI_OK) {
        index = (long *)calloc((size_t)nimg, sizeof(long));
        c2w = (float *)calloc((size_t)nimg * 16, sizeof(float));
        if (!index || !c2w) { cli_error("out of memory"); rc = CLI_FAIL; }
    }
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        index[i] = cli_stem_index(stems[i]);
        if (index[i] < 0) {
            cli_error("view '%s': its file name does not end with a number (up to 9 digits; e.g. color_0003.png -> 3), "
                      "so it has no camera index in the meta.json", imgs[i]);
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        int iw, ih, c;
        if (!cli_pic_info(imgs[i], "view", &iw, &ih, &c, lv.max_memory, NULL)) { rc = CLI_FAIL; break; }
        if (i == 0) { w = iw; h = ih; }
        if (iw != w || ih != h) {
            cli_error("view '%s' is %dx%d but view '%s' is %dx%d: all views must have the same size (supermat does not resize)",
                      imgs[i], iw, ih, imgs[0], w, h);
            rc = CLI_FAIL;
        } else if (work_opt == 0 && (w % 8 || h % 8)) {
            cli_error("view '%s' is %dx%d: --native runs the network at the views' own size, which needs multiples of 8 "
                      "(without --native they are resampled to the model's work size)", imgs[i], w, h);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) rc = cli_read_cameras(cam_path, &cams, &ncam);
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        const cli_camera *c = cli_find_camera(cams, ncam, index[i], imgs[i], cam_path);
        if (!c) rc = CLI_FAIL;
        else memcpy(c2w + 16 * i, c->m, sizeof c->m);
    }

    if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &lv, &file, &file_size, &model, NULL);
    if (rc == CLI_OK) rc = cli_require_kind(cmd, model_path, model, SUPERMAT_KIND_SUPERMAT_MV);
    if (rc == CLI_OK) {
        supermat_model_info mi;
        memset(&mi, 0, sizeof mi);
        supermat_model_get_info(model, &mi);
        if (mi.class_embed_in != 16) {
            cli_error("model '%s' takes %d camera numbers per view; a meta.json camera is a 4x4 matrix (16)", model_path, mi.class_embed_in);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) {
        supermat_session_desc sd;
        supermat_error err;
        supermat_result r;
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.views = nimg; sd.threads = threads;
        sd.max_memory = cli_session_budget(model, lv.max_memory);
        cli_session_opts(&sd, work_opt, &lv);
        r = supermat_session_create(&sd, &sess, &err);
        if (r != SUPERMAT_SUCCESS) {
            char what[64];
            snprintf(what, sizeof what, "session (%d view%s, %dx%d)", nimg, nimg == 1 ? "" : "s", w, h);
            cli_lib_error(what, r, &err);
            cli_budget_note(model, r, lv.max_memory);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) rc = cli_mkdirs(out_dir);
    if (rc == CLI_OK) {
        np = (size_t)w * (size_t)h;
        px = (unsigned char **)calloc((size_t)nimg, sizeof *px);
        in = (supermat_image *)calloc((size_t)nimg, sizeof *in);
        oa = (supermat_image *)calloc((size_t)nimg, sizeof *oa);
        orr = (supermat_image *)calloc((size_t)nimg, sizeof *orr);
        om = (supermat_image *)calloc((size_t)nimg, sizeof *om);
        if (outputs & SUPERMAT_OUTPUT_ALBEDO) fa = (float *)malloc(np * 3 * (size_t)nimg * sizeof(float));
        if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) fr = (float *)malloc(np * (size_t)nimg * sizeof(float));
        if (outputs & SUPERMAT_OUTPUT_METALLIC) fm = (float *)malloc(np * (size_t)nimg * sizeof(float));
        tmp = (unsigned char *)malloc(np * 3);
        if (!px || !in || !oa || !orr || !om || !tmp || ((outputs & SUPERMAT_OUTPUT_ALBEDO) && !fa) ||
            ((outputs & SUPERMAT_OUTPUT_ROUGHNESS) && !fr) || ((outputs & SUPERMAT_OUTPUT_METALLIC) && !fm)) {
            cli_error("out of memory for %d views of %dx%d", nimg, w, h);
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        int iw = 0, ih = 0, c = 0;
        px[i] = cli_load(imgs[i], &iw, &ih, &c, 4);
        if (!px[i]) { cli_error("cannot read view '%s': %s", imgs[i], cli_stbi_reason()); rc = CLI_FAIL; break; }
        if (iw != w || ih != h) { cli_error("view '%s' is %dx%d, not %dx%d as before (did it change?)", imgs[i], iw, ih, w, h); rc = CLI_FAIL; break; }
        in[i].pixels = px[i]; in[i].width = w; in[i].height = h; in[i].channels = 4; in[i].format = SUPERMAT_FORMAT_U8;
        oa[i].pixels = fa ? fa + np * 3 * (size_t)i : NULL; oa[i].channels = 3; oa[i].format = SUPERMAT_FORMAT_F32;
        orr[i].pixels = fr ? fr + np * (size_t)i : NULL; orr[i].channels = 1; orr[i].format = SUPERMAT_FORMAT_F32;
        om[i].pixels = fm ? fm + np * (size_t)i : NULL; om[i].channels = 1; om[i].format = SUPERMAT_FORMAT_F32;
    }
    if (rc == CLI_OK) {
        supermat_run_desc rd;
        supermat_error err;
        supermat_result r;
        cli_progress prog;
        char name[64];
        double t0 = cli_now();
        memset(&rd, 0, sizeof rd);
        rd.input_views = in;
        rd.cameras = c2w;
        rd.albedo_views = fa ? oa : NULL;
        rd.roughness_views = fr ? orr : NULL;
        rd.metallic_views = fm ? om : NULL;
        snprintf(name, sizeof name, "%d view%s", nimg, nimg == 1 ? "" : "s");
        memset(&prog, 0, sizeof prog);
        prog.name = name;
        if (tty) { rd.progress = cli_progress_cb; rd.progress_user = &prog; }
        r = supermat_run(sess, &rd, &err);
        if (tty && prog.shown) {
            if (r == SUPERMAT_SUCCESS) fprintf(stderr, "\r%s 100%% done (%.2f s)%*s\n", name, cli_now() - t0, 8, "");
            else fputc('\n', stderr);
        }
        if (r != SUPERMAT_SUCCESS) {
            snprintf(name, sizeof name, "%d view%s", nimg, nimg == 1 ? "" : "s");
            cli_lib_error(name, r, &err);
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        float *maps[3];
        maps[0] = fa ? fa + np * 3 * (size_t)i : NULL;
        maps[1] = fr ? fr + np * (size_t)i : NULL;
        maps[2] = fm ? fm + np * (size_t)i : NULL;
        rc = cli_write_maps(out_dir, stems[i], 3, cli_map_suffixes, maps, cli_map_channels, w, h, want_float, tmp);
    }

    if (px) for (i = 0; i < nimg; i++) if (px[i]) stbi_image_free(px[i]);
    free(px); free(in); free(oa); free(orr); free(om); free(fa); free(fr); free(fm); free(tmp);
    supermat_session_destroy(sess);
    supermat_model_destroy(model);
    cli_free_file(file);
    free(cams); free(c2w); free(index);
    cli_free_stems(stems, nimg);
    free(imgs);
    return rc;
}
