/* cli/pack.c - `supermat pack`: a model file -> its pre-packed form (supermat_model_write_packed).
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>pack */
static int cli_pack_write(void *user, const void *data, size_t size) {
    cli_out *o = (cli_out *)user;
    cli_out_write(o, data, size);
    return o->err ? -1 : 0;
}

static int cli_pack(int argc, char **argv) {
    const char *cmd = "pack", *v, *model = NULL, *outp = NULL;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    supermat_model_desc md;
    supermat_error err;
    supermat_result r;
    cli_model_ref mref;
    cli_out o;
    unsigned char *file = NULL;
    size_t size = 0;
    uint64_t bytes = 0;
    double t0;
    int i, m, rc;
    cli_levers lv;
    cli_levers_init(&lv);
    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_pack, stdout); return CLI_OK; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--model", &v)) != 0) { if (m < 0) return CLI_USAGE; model = v; }
        else if ((m = cli_opt(cmd, argc, argv, &i, "--out", &v)) != 0) { if (m < 0) return CLI_USAGE; outp = v; }
        else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0) { if (m < 0 || cli_parse_weights(cmd, v, &lv)) return CLI_USAGE; }
        else if ((m = cli_opt(cmd, argc, argv, &i, "--compute", &v)) != 0) { if (m < 0 || cli_parse_compute(cmd, v, &lv)) return CLI_USAGE; }
        else if ((m = cli_opt(cmd, argc, argv, &i, "--kernel", &v)) != 0) { if (m < 0 || cli_parse_kernel(cmd, v, &kernel)) return CLI_USAGE; }
        else if ((m = cli_opt(cmd, argc, argv, &i, "--conv", &v)) != 0) { if (m < 0 || cli_parse_conv(cmd, v, &lv)) return CLI_USAGE; }
        else if (a[0] == '-') return cli_usage_error(cmd, "unknown option '%s'", a);
        else return cli_usage_error(cmd, "unexpected argument '%s'", a);
    }
    if (!outp) return cli_usage_error(cmd, "--out FILE is required");
    if ((m = cli_model_path(cmd, model, 1, &mref)) != CLI_OK) return m;
    if (!strcmp(mref.path, outp)) { cli_error("--out '%s' is the model file itself: write the pre-packed file beside it", outp); return CLI_FAIL; }
    if (cli_out_open(&o, outp) != CLI_OK) return CLI_FAIL;
    if (o.skip) return cli_out_close(&o, 1);
    if (cli_read_file(mref.path, &file, &size)) { cli_out_close(&o, 0); return CLI_FAIL; }
    memset(&md, 0, sizeof md);
    md.data = file; md.size = size; md.kernel = kernel; md.weights = lv.weights; md.conv = lv.conv; md.compute = lv.compute;
    t0 = cli_now();
    r = supermat_model_write_packed(&md, cli_pack_write, &o, &bytes, &err);
    if (r != SUPERMAT_SUCCESS) {
        char what[CLI_PATH_CAP + 64];
        if (r == SUPERMAT_ERROR_IO) { rc = cli_out_close(&o, 1); cli_free_file(file); return CLI_FAIL; } /* says why */
        snprintf(what, sizeof what, "model '%s'", mref.path);
        cli_lib_error(what, r, &err);
        cli_out_close(&o, 0);
        cli_free_file(file);
        return CLI_FAIL;
    }
    cli_free_file(file);
    rc = cli_out_close(&o, 1);
    if (rc == CLI_OK)
        printf("wrote %s (%.1f MiB, pre-packed from %s in %.1f s)\n", outp, cli_mib((double)bytes), mref.path, cli_now() - t0);
    return rc;
}
