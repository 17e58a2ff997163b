/* cli/convert.c - `supermat convert`.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>convert */
/* `supermat convert --from MODEL.safetensors --work-size N|native --out FILE`: the same model file with another
   recorded work size (sm_work_size_header), the tensors copied byte for byte; the file written is loaded once
   (as FILE.tmp, before the rename), which checks the input's tensors too */
static int cli_convert_from(const char *from, const char *outp, int work_size) {
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
    if ((r = sm_work_size_header(file, size, work_size, &hdr, &hsize, &off, err, sizeof err)) != 0) {
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
    if (rc == CLI_OK) {
        if (work_size < 0) printf("wrote %s (%.1f MiB): %s with no work size (each picture at its own size)\n", outp, cli_mib((double)nsize), from);
        else printf("wrote %s (%.1f MiB): %s with work size %dx%d\n", outp, cli_mib((double)nsize), from, work_size, work_size);
    }
    return rc;
}

static int cli_convert(int argc, char **argv) {
    const char *cmd = "convert", *v, *from = NULL;
    sm_convert_desc d;
    char err[1024];
    int i, m, r, packed = 0;
    struct stat st;
    memset(&d, 0, sizeof d);
    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_convert, stdout); return CLI_OK; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--kind", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            if (strcmp(v, "supermat") && strcmp(v, "supermat-mv") && strcmp(v, "uv-refine"))
                return cli_usage_error(cmd, "--kind: '%s' is not supermat, supermat-mv or uv-refine", v);
            d.kind = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--unet", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            d.checkpoint = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--from", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            from = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--base", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            d.base_dir = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--out", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            d.output = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0 || (m = cli_opt(cmd, argc, argv, &i, "--precision", &v)) != 0 ||
                   (m = cli_opt(cmd, argc, argv, &i, "--dtype", &v)) != 0) {   /* --precision, --dtype: until the next release */
            if (m < 0) return CLI_USAGE;
            if (!strcmp(v, "f32")) d.dtype = SUPERMAT_DTYPE_F32;
            else if (!strcmp(v, "f16")) d.dtype = SUPERMAT_DTYPE_F16;
            else if (!strcmp(v, "bf16")) d.dtype = SUPERMAT_DTYPE_BF16;
            else if (!strcmp(v, "int8") || !strcmp(v, "i8")) d.dtype = SUPERMAT_DTYPE_I8;
            else return cli_usage_error(cmd, "--weights: '%s' is not f32, f16, bf16 or int8", v);
        } else if (!strcmp(a, "--packed")) {
            packed = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 1024, &d.threads)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--work-size", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            if (!strcmp(v, "native")) d.work_size = -1;
            else if (cli_parse_int(cmd, "--work-size", v, 8, 16384, &d.work_size)) return CLI_USAGE;
            else if (d.work_size % 8) return cli_usage_error(cmd, "--work-size %d: a multiple of 8", d.work_size);
        } else if (a[0] == '-') {
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            return cli_usage_error(cmd, "unexpected argument '%s'", a);
        }
    }
    if (from) {
        if (d.checkpoint || d.base_dir || d.kind || d.dtype || packed || d.threads)
            return cli_usage_error(cmd, "--from rewrites a model file's work size only: --unet, --base, --kind, --weights, --packed and --threads are for a checkpoint");
        if (!d.work_size) return cli_usage_error(cmd, "--from needs --work-size N|native");
        if (!d.output) return cli_usage_error(cmd, "--out FILE is required");
        return cli_convert_from(from, d.output, d.work_size);
    }
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
