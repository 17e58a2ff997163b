/* cli/pack.c - `supermat pack`: a model file -> its pre-packed form (supermat_model_write_packed).
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>pack */
static int cli_pack_write(void *user, const void *data, size_t size) {
    cli_out *o = (cli_out *)user;
    cli_out_write(o, data, size);
    return o->err ? -1 : 0;
}

/* `supermat pack`: its options and --help */
enum { CLI_PACK_MODEL = 1, CLI_PACK_OUT };
static const cli_optdef cli_opts_pack[] = {
    CLI_TEXT("usage: supermat pack [--model FILE] --out FILE.safetensors [--weights W] [--conv C] [--compute X]\n"
             "\n"
             "Writes the pre-packed form of a model file: the same file with its GEMM weights already in the\n"
             "runtime's packed panel layout for the chosen options. A process that loads it uses the panels where\n"
             "the file is mapped (no copy, no packing): the model is created in milliseconds and every process on\n"
             "the machine shares one copy of the weights in the page cache. Every command loads it like any model\n"
             "file, with the options it was packed for (asking for others is an error: pack again). The output is\n"
             "written to a temporary file, then renamed.\n"
             "\n"
             "options:\n"),
    {CLI_PACK_MODEL, "--model", "FILE|NAME", "the model file, or a name as `supermat image` takes (default: the default\nmodel, see `supermat image --help`)", NULL, NULL},
    {CLI_PACK_OUT, "--out", "FILE", "the pre-packed file to write (required)", NULL, NULL},
    {CLI_O_WEIGHTS, "--weights", "W", "default | f32 | f16 | bf16 | int8: the storage of the GEMM weights (default: as\nthe file stores them)", NULL, NULL},
    {CLI_O_CONV, "--conv", "C", "direct | winograd-f2 | winograd-f4: the 3x3 convolutions (default direct; the\nWinograd weights are stored transformed, in f32: 16/9 or 4x their size)", NULL, NULL},
    {CLI_O_COMPUTE, "--compute", "X", "f32 | bf16 | int8: bf16 compute (weights as bf16 pairs; needs AVX512_BF16 to\nload) or int8 compute (int8 quads; needs AVX512_VNNI or AVX-VNNI to load)", NULL, NULL},
    {CLI_O_KERNEL, "--kernel", "K", CLI_KERNEL_VALUES " (the panels are the same for every kernel)", NULL, NULL},
    CLI_END};

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
    int m, rc;
    cli_levers lv;
    cli_argp P;
    cli_levers_init(&lv);
    cli_argp_init(&P, cmd, cli_opts_pack, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, cli_opts_pack); return CLI_OK; }
        if (m == CLI_ARG_ERROR) return CLI_USAGE;
        if (m == CLI_ARG_OPERAND) return cli_usage_error(cmd, "unexpected argument '%s'", v);
        if (m == CLI_PACK_MODEL) model = v;
        else if (m == CLI_PACK_OUT) outp = v;
        else if (cli_run_value(cmd, m, v, NULL, NULL, NULL, &kernel, &lv) < 0) return CLI_USAGE;
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
