/* cli/convert.c - `supermat convert`.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>convert */
/* `supermat convert --from MODEL.safetensors [--work-size N|native] [--detail F|off] [--chroma W|off]
   [--bake-detail F|off] --out FILE`:
   the same model file with other recorded pipeline keys (sm_pipeline_header), the tensors and the other
   metadata copied byte for byte; the file written is loaded once (as FILE.tmp, before the rename), which
   checks the input's tensors too */
static int cli_convert_from(const char *from, const char *outp, const sm_pipeline_edit *pe) {
    const char *cmd = "convert";
    unsigned char *file = NULL, *hdr = NULL, *nf = NULL;
    size_t size = 0, hsize = 0, off = 0, nsize = 0;
    supermat_model_desc md;
    supermat_model *model = NULL;
    supermat_error e;
    supermat_result sr;
    char err[1024], what[CLI_PATH_CAP + 64];
    cli_out o;
    char *tmp_path = NULL;
    int r, rc, ok = 0;
    if (!strcmp(from, outp)) { cli_error("%s: --out '%s' is the --from file itself: write the new file beside it", cmd, outp); return CLI_FAIL; }
    if (cli_read_file(from, &file, &size)) return CLI_FAIL;
    if ((r = sm_pipeline_header(file, size, pe, &hdr, &hsize, &off, err, sizeof err)) != 0) {
        cli_error("convert: '%s': %s [%s]", from, err, supermat_result_string((supermat_result)r));
        cli_free_file(file);
        return CLI_FAIL;
    }
    if (cli_out_open(&o, outp) != CLI_OK) { free(hdr); cli_free_file(file); return CLI_FAIL; }
    if (o.skip) { free(hdr); cli_free_file(file); return cli_out_close(&o, 1); }
    cli_out_write(&o, hdr, hsize);
    cli_out_write(&o, file + off, size - off);
    free(hdr);
    cli_free_file(file);
    if (o.err == 0 && fflush(o.f) != 0) o.err = errno ? errno : -1;
    tmp_path = o.err == 0 ? cli_out_tmp_path(&o) : NULL;
    if (o.err == 0 && !tmp_path) cli_error("out of memory");
    if (tmp_path && cli_read_file(tmp_path, &nf, &nsize) == CLI_OK) {
        snprintf(what, sizeof what, "model '%s' (written again as '%s')", from, outp);
        memset(&md, 0, sizeof md);
        md.data = nf; md.size = nsize;
        md.copy_data = ((uintptr_t)nf % 64) != 0; /* a file under 1 MiB is read into malloc'ed memory: a pre-packed one needs 64-byte alignment */
        if ((sr = supermat_model_create(&md, &model, &e)) != SUPERMAT_SUCCESS) cli_lib_error(what, sr, &e);
        else ok = 1;
        supermat_model_destroy(model);
        cli_free_file(nf);
    }
    free(tmp_path);
    rc = cli_out_close(&o, ok || o.err); /* a failed write: cli_out_close says why */
    if (!ok && rc == CLI_OK) rc = CLI_FAIL;
    if (rc == CLI_OK) { /* what changed, in the file's order */
        char ws[80] = "", ds[48] = "", cs[48] = "", bs[48] = "", rs[32] = "", ms[32] = "", all[320];
        if (pe->work_size < 0) snprintf(ws, sizeof ws, ", no work size (each picture at its own size)");
        else if (pe->work_size > 0) snprintf(ws, sizeof ws, ", work size %dx%d", pe->work_size, pe->work_size);
        if (pe->detail_sigma == 0.0f) snprintf(ds, sizeof ds, ", detail off");
        else if (pe->detail_sigma > 0.0f) snprintf(ds, sizeof ds, ", detail %.9g", (double)pe->detail_sigma);
        if (pe->chroma_weight == 0.0f) snprintf(cs, sizeof cs, ", colour off");
        else if (pe->chroma_weight > 0.0f) snprintf(cs, sizeof cs, ", colour %.9g", (double)pe->chroma_weight);
        if (pe->bake_detail_sigma == 0.0f) snprintf(bs, sizeof bs, ", bake detail off");
        else if (pe->bake_detail_sigma > 0.0f) snprintf(bs, sizeof bs, ", bake detail %.9g", (double)pe->bake_detail_sigma);
        if (pe->roughness_curve) snprintf(rs, sizeof rs, ", roughness curve %s", pe->roughness_curve[0] ? "set" : "off");
        if (pe->metallic_curve) snprintf(ms, sizeof ms, ", metallic curve %s", pe->metallic_curve[0] ? "set" : "off");
        snprintf(all, sizeof all, "%s%s%s%s%s%s", ws, ds, cs, bs, rs, ms); /* ", a, b": the first comma left out */
        printf("wrote %s (%.1f MiB): %s with%s\n", outp, cli_mib((double)nsize), from, all + 1);
    }
    return rc;
}

/* `supermat convert`: its options and --help */
enum { CLI_CONV_KIND = 1, CLI_CONV_UNET, CLI_CONV_BASE, CLI_CONV_OUT, CLI_CONV_WEIGHTS, CLI_CONV_PACKED, CLI_CONV_THREADS,
       CLI_CONV_WORK_SIZE, CLI_CONV_DETAIL, CLI_CONV_CHROMA, CLI_CONV_BAKE_DETAIL, CLI_CONV_ROUGH_CURVE, CLI_CONV_METAL_CURVE,
       CLI_CONV_FROM };
static const cli_optdef cli_opts_convert[] = {
    CLI_TEXT("usage: supermat convert --unet FILE.pth --base DIR --out FILE.safetensors [options]\n"
             "       supermat convert --from MODEL.safetensors [--work-size N|native] [--detail F|off] [--chroma W|off]\n"
             "                        [--bake-detail F|off] [--roughness-curve LIST|off] [--metallic-curve LIST|off]\n"
             "                        --out FILE.safetensors\n"
             "\n"
             "Turns an official SuperMat checkpoint (torch.save format) plus a Stable Diffusion 2.1 folder in\n"
             "diffusers layout (unet/config.json, vae/, text_encoder/, scheduler/) into the one model file that\n"
             "`supermat image` loads. No Python is needed. The output is written to a temporary file, then renamed.\n"
             "\n"
             "options:\n"),
    {CLI_CONV_KIND, "--kind", "K", "supermat | supermat-mv | uv-refine (default: detected from the checkpoint)", NULL, NULL},
    {CLI_CONV_UNET, "--unet", "FILE", "the official checkpoint, e.g. supermat.pth (required)", NULL, NULL},
    {CLI_CONV_BASE, "--base", "DIR", "the Stable Diffusion 2.1 folder (required)", NULL, NULL},
    {CLI_CONV_OUT, "--out", "FILE", "the model file to write (required)", NULL, NULL},
    {CLI_CONV_WEIGHTS, "--weights", "W", "f32 | f16 | bf16 | int8: the weights' storage in the file (f16 / bf16: round to\n"
                                         "nearest even; int8: the GEMM weights as int8 with a scale per output channel,\n"
                                         "kernel tap and 64 input channels, the rest as stored; loads to the same bits as\n"
                                         "`--weights int8` of the other commands on an f32 file). Default: keep every\n"
                                         "tensor's stored dtype", "--precision --dtype", NULL},
    {CLI_CONV_PACKED, "--packed", NULL, "write the pre-packed form (`supermat pack` with its default options: the GEMM\n"
                                        "panels used in place where the file is mapped, shared by processes)", NULL, NULL},
    {CLI_CONV_THREADS, "--threads", "N", "text encoder threads (default 0 = 2, 1 = none)", NULL, NULL},
    {CLI_CONV_WORK_SIZE, "--work-size", "N", "the square size `image`, `views` and `refine` resize pictures to by default, as\n"
                                             "the official scripts do (default: theirs, 512; uv-refine 1024); `native` = none:\n"
                                             "each picture at its own size (for a model trained at one size, give that size)", NULL, NULL},
    {CLI_CONV_DETAIL, "--detail", "F|off", "record the detail step that `image` and `views` apply by default (their --detail):\n"
                                           "the albedo keeps the picture's detail, the lighting taken as smooth over F x the\n"
                                           "picture's larger side, F from 0 to 1 (0.015625 or 1/64 in the default model).\n"
                                           "Default: none recorded (off), as the official scripts; not for uv-refine", NULL, NULL},
    {CLI_CONV_CHROMA, "--chroma", "W|off", "record the colour step that `image` and `views` apply by default (their --chroma):\n"
                                           "the albedo takes the picture's colour with weight W from 0 to 1 (1 in the default\n"
                                           "model). Default: none recorded (off), as the official scripts; not for uv-refine", NULL, NULL},
    {CLI_CONV_BAKE_DETAIL, "--bake-detail", "F|off", "record the detail step that `mesh` applies by default to the textures it bakes\n"
                                                     "from this model's views (its --detail): the albedo keeps the input texture's\n"
                                                     "detail, the lighting taken as smooth over F x the texture's larger side, F from\n"
                                                     "0 to 1 (0.03125 or 1/32 in the multi-view default model). Default: none\n"
                                                     "recorded (off); not for uv-refine", NULL, NULL},
    {CLI_CONV_ROUGH_CURVE, "--roughness-curve", "LIST|off", "record the calibration curve that `image` and `views` put the roughness map\n"
                                                         "through by default (their --roughness-curve): K0,...,Kn-1 the values at 0,\n"
                                                         "1/(n-1), ..., 1, 2 to 33 knots in [0, 1], never falling. Default: none recorded;\n"
                                                         "not for uv-refine", NULL, NULL},
    {CLI_CONV_METAL_CURVE, "--metallic-curve", "LIST|off", "the same for the metallic map (their --metallic-curve)", NULL, NULL},
    {CLI_CONV_FROM, "--from", "MODEL", "instead of a checkpoint: an already converted model file (pre-packed or not),\n"
                                       "written again with the --work-size, --detail, --chroma, --bake-detail,\n"
                                       "--roughness-curve and --metallic-curve given\n"
                                       "(at least one; `off` removes that step's key) and nothing else changed (its\n"
                                       "tensors and other metadata byte for byte; the file written is checked to load)", NULL, NULL},
    CLI_TEXT("\nProgress is printed on stderr when it is a terminal.\n"),
    CLI_END};

static int cli_convert(int argc, char **argv) {
    const char *cmd = "convert", *v, *from = NULL;
    sm_convert_desc d;
    char err[1024];
    int m, r, packed = 0;
    float detail = -1.0f, chroma = -1.0f, bake = -1.0f; /* -1: not given, 0: off */
    const char *curve[2] = {NULL, NULL};                /* --roughness-curve, --metallic-curve: NULL not given, "" off */
    struct stat st;
    cli_argp P;
    memset(&d, 0, sizeof d);
    cli_argp_init(&P, cmd, cli_opts_convert, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        switch (m) {
        case CLI_ARG_HELP: cli_help_print(stdout, cli_opts_convert); return CLI_OK;
        case CLI_ARG_ERROR: return CLI_USAGE;
        case CLI_ARG_OPERAND: return cli_usage_error(cmd, "unexpected argument '%s'", v);
        case CLI_CONV_KIND:
            if (strcmp(v, "supermat") && strcmp(v, "supermat-mv") && strcmp(v, "uv-refine"))
                return cli_usage_error(cmd, "--kind: '%s' is not supermat, supermat-mv or uv-refine", v);
            d.kind = v;
            break;
        case CLI_CONV_UNET: d.checkpoint = v; break;
        case CLI_CONV_FROM: from = v; break;
        case CLI_CONV_BASE: d.base_dir = v; break;
        case CLI_CONV_OUT: d.output = v; break;
        case CLI_CONV_WEIGHTS:
            if (!strcmp(v, "f32")) d.dtype = SUPERMAT_DTYPE_F32;
            else if (!strcmp(v, "f16")) d.dtype = SUPERMAT_DTYPE_F16;
            else if (!strcmp(v, "bf16")) d.dtype = SUPERMAT_DTYPE_BF16;
            else if (!strcmp(v, "int8") || !strcmp(v, "i8")) d.dtype = SUPERMAT_DTYPE_I8;
            else return cli_usage_error(cmd, "--weights: '%s' is not f32, f16, bf16 or int8", v);
            break;
        case CLI_CONV_PACKED: packed = 1; break;
        case CLI_CONV_THREADS:
            if (cli_parse_int(cmd, "--threads", v, 0, 1024, &d.threads)) return CLI_USAGE;
            break;
        case CLI_CONV_WORK_SIZE:
            if (!strcmp(v, "native")) d.work_size = -1;
            else if (cli_parse_int(cmd, "--work-size", v, 8, 16384, &d.work_size)) return CLI_USAGE;
            else if (d.work_size % 8) return cli_usage_error(cmd, "--work-size %d: a multiple of 8", d.work_size);
            break;
        case CLI_CONV_DETAIL:
            if (cli_parse_unit(cmd, "--detail", v, "a fraction of the picture's size", &detail)) return CLI_USAGE;
            break;
        case CLI_CONV_CHROMA:
            if (cli_parse_unit(cmd, "--chroma", v, "a weight", &chroma)) return CLI_USAGE;
            break;
        case CLI_CONV_ROUGH_CURVE:
        case CLI_CONV_METAL_CURVE: {
            float k[SUPERMAT_CURVE_MAX_KNOTS];
            int n, c = m == CLI_CONV_METAL_CURVE;
            supermat_error e;
            if (!strcmp(v, "off")) { curve[c] = ""; break; }
            if (supermat_parse_curve(v, k, &n, &e) != SUPERMAT_SUCCESS)
                return cli_usage_error(cmd, "--%s-curve: 'off' or a list of knots (0.2,0.5,0.8): %s", c ? "metallic" : "roughness", e.message);
            curve[c] = v;
            break;
        }
        case CLI_CONV_BAKE_DETAIL:
            if (cli_parse_unit(cmd, "--bake-detail", v, "a fraction of the texture's size", &bake)) return CLI_USAGE;
            break;
        default: break;
        }
    }
    if (from) {
        sm_pipeline_edit pe;
        if (d.checkpoint || d.base_dir || d.kind || d.dtype || packed || d.threads)
            return cli_usage_error(cmd, "--from rewrites a model file's pipeline keys only: --unet, --base, --kind, --weights, --packed and --threads are for a checkpoint");
        if (!d.work_size && detail < 0.0f && chroma < 0.0f && bake < 0.0f && !curve[0] && !curve[1])
            return cli_usage_error(cmd, "--from needs --work-size N|native, --detail F|off, --chroma W|off, --bake-detail F|off, "
                                        "--roughness-curve LIST|off or --metallic-curve LIST|off");
        if (!d.output) return cli_usage_error(cmd, "--out FILE is required");
        pe.work_size = d.work_size;
        pe.detail_sigma = detail;
        pe.chroma_weight = chroma;
        pe.bake_detail_sigma = bake;
        pe.roughness_curve = curve[0];
        pe.metallic_curve = curve[1];
        return cli_convert_from(from, d.output, &pe);
    }
    for (m = 0; m < 2; m++)
        if (d.kind && !strcmp(d.kind, "uv-refine") && curve[m] && curve[m][0])
            return cli_usage_error(cmd, "--%s-curve: a uv-refine model makes no %s map", m ? "metallic" : "roughness", m ? "metallic" : "roughness");
    d.roughness_curve = curve[0] && curve[0][0] ? curve[0] : NULL;
    d.metallic_curve = curve[1] && curve[1][0] ? curve[1] : NULL;
    if (d.kind && !strcmp(d.kind, "uv-refine") && (detail > 0.0f || chroma > 0.0f || bake > 0.0f))
        return cli_usage_error(cmd, "--%s: a uv-refine model has no input picture for the %s step",
                               detail > 0.0f ? "detail" : chroma > 0.0f ? "chroma" : "bake-detail",
                               detail > 0.0f ? "detail" : chroma > 0.0f ? "colour" : "bake detail");
    d.detail_sigma = detail > 0.0f ? detail : 0.0f; /* off or not given: not recorded */
    d.chroma_weight = chroma > 0.0f ? chroma : 0.0f;
    d.bake_detail_sigma = bake > 0.0f ? bake : 0.0f;
    if (!d.checkpoint) return cli_usage_error(cmd, "--unet FILE.pth is required");
    if (!d.base_dir) return cli_usage_error(cmd, "--base DIR is required");
    if (!d.output) return cli_usage_error(cmd, "--out FILE is required");
    d.progress = isatty(2);
    if (cli_out_folder_ok(d.output) != CLI_OK) return CLI_FAIL; /* before the (minutes of) conversion */
    switch (cli_out_allowed(d.output)) {       /* the overwrite policy (sm_convert writes OUT.tmp, renames) */
    case CLI_FAIL: return CLI_FAIL;
    case CLI_SKIPPED: fprintf(stderr, "kept '%s' (it exists; --skip-existing)\n", d.output); return CLI_OK;
    default: break;
    }
    r = sm_convert(&d, err, sizeof err);
    if (r != 0) {
        cli_error("convert: %s [%s]", err[0] ? err : "failed", supermat_result_string((supermat_result)r));
        return CLI_FAIL;
    }
    if (packed) { /* the converted file, replaced by its pre-packed form (default options) */
        unsigned char *file = NULL;
        size_t size = 0;
        supermat_model_desc md;
        supermat_error e;
        cli_out o;
        cli_note_written(d.output);
        if (cli_read_file(d.output, &file, &size)) return CLI_FAIL;
        if (cli_out_open(&o, d.output) != CLI_OK) { cli_free_file(file); return CLI_FAIL; }
        memset(&md, 0, sizeof md);
        md.data = file; md.size = size;
        r = supermat_model_write_packed(&md, cli_pack_write, &o, NULL, &e);
        if (r != SUPERMAT_SUCCESS && r != SUPERMAT_ERROR_IO) cli_lib_error("convert --packed", (supermat_result)r, &e);
        r = cli_out_close(&o, r == SUPERMAT_SUCCESS || r == SUPERMAT_ERROR_IO);
        cli_free_file(file);
        if (r != CLI_OK) return CLI_FAIL;
    }
    if (stat(d.output, &st) == 0) printf("wrote %s (%.1f MiB%s)\n", d.output, cli_mib((double)st.st_size), packed ? ", pre-packed" : "");
    return CLI_OK;
}
