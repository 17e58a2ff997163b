/* cli/info.c - `supermat info`.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>info */
static void cli_print_list(const int *v, int n) {
    int i;
    for (i = 0; i < n; i++) printf("%s%d", i ? "," : "", v[i]);
}

static void cli_print_count(const char *label, uint64_t n) {
    printf("%s%llu (%.2f M)", label, (unsigned long long)n, (double)n / 1e6);
}

/* `supermat info`: its options and --help */
static const cli_optdef cli_opts_info[] = {
    CLI_TEXT("usage: supermat info [options] [FILE]\n"
             "\n"
             "Prints a model file's kind and architecture (with the camera embedding of a supermat-mv model\n"
             "and the input channels of a uv-refine model), its parameter counts (UNet trunk, per branch,\n"
             "VAE), the tensor dtypes it stores, its size, the memory the loaded model holds and the memory a\n"
             "512x512 session plans (all outputs and albedo only; 6 views for supermat-mv). FILE may be a name\n"
             "(official, official-mv, official-refine-albedo, official-refine-rm: NAMED MODELS below). Without\n"
             "FILE: the models this tool finds and where (the default model, the mesh defaults beside it, the\n"
             "model folder and the official networks in it), then the default model.\n"
             "\n"
             "options:\n"),
    {CLI_O_THREADS, "--threads", "N", "thread count the session memory is planned for (default 0 = all cores)", NULL, NULL},
    {CLI_O_KERNEL, "--kernel", "K", CLI_KERNEL_VALUES " (default auto)", NULL, NULL},
    {CLI_O_MAX_MEMORY, "--max-memory", "SIZE", "refuse a model that needs more than SIZE (512M, 4G) while it is created", NULL, NULL},
    CLI_OPTS(cli_opts_levers),
    CLI_END};

/* info's line for a calibration curve (map roughness or metallic, n knots k) */
static void cli_info_curve(const char *map, const float *k, int n) {
    int i;
    if (n <= 0) { printf("%-13s the network's (--%s-curve LIST: through a calibration curve)\n", map, map); return; }
    printf("%-13s through the curve", map);
    for (i = 0; i < n; i++) { /* the shortest text that reads back as the same float */
        char t[32];
        int p = 6;
        do snprintf(t, sizeof t, "%.*g", p++, (double)k[i]); while (p <= 9 && strtof(t, NULL) != k[i]);
        printf("%s%s", i ? "," : " ", t);
    }
    printf(" (values at 0 .. 1; --%s-curve off: the network's)\n", map);
}
static int cli_info(int argc, char **argv) {
    const char *cmd = "info", *path = NULL, *v;
    int i, m, threads = 0, ntens = 0, counts[SUPERMAT_DTYPE_COUNT];
    uint64_t bytes_by[SUPERMAT_DTYPE_COUNT], tensor_bytes = 0;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    unsigned char *file = NULL;
    size_t size = 0;
    supermat_error err;
    supermat_result r;
    supermat_model_desc md;
    supermat_model *model = NULL;
    supermat_model_info mi;
    char meta[128];
    double create_s;
    cli_model_ref mref;
    cli_levers lv;
    cli_argp P;
    cli_levers_init(&lv);
    cli_argp_init(&P, cmd, cli_opts_info, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, cli_opts_info); cli_print_default_model_help(); return CLI_OK; }
        if (m == CLI_ARG_ERROR) return CLI_USAGE;
        if (m == CLI_ARG_OPERAND) {
            if (path) return cli_usage_error(cmd, "one model file at a time ('%s' and '%s')", path, v);
            path = v;
        } else if (cli_run_value(cmd, m, v, NULL, NULL, &threads, &kernel, &lv) < 0) {
            return CLI_USAGE;
        }
    }
    if (!path) cli_print_models();
    if ((m = cli_model_path(cmd, path, 1, &mref)) != CLI_OK) return m;
    if (!path) printf("\ndefault       %s (the default model: %s)\n", mref.path, mref.from);
    else if (strcmp(mref.from, "--model")) printf("model         %s (%s)\n", mref.path, mref.from);
    path = mref.path;
    if (cli_read_file(path, &file, &size)) return CLI_FAIL;

    /* the file as it is: header, metadata, dtypes */
    r = supermat_safetensors_count(file, size, size, &ntens, &err);
    if (r != SUPERMAT_SUCCESS) {
        char what[CLI_PATH_CAP + 64];
        snprintf(what, sizeof what, "'%s'", path);
        cli_lib_error(what, r, &err);
        cli_free_file(file);
        return CLI_FAIL;
    }
    memset(counts, 0, sizeof counts);
    memset(bytes_by, 0, sizeof bytes_by);
    for (i = 0; i < ntens; i++) {
        supermat_tensor_info ti;
        r = supermat_safetensors_tensor(file, size, size, i, &ti, &err);
        if (r != SUPERMAT_SUCCESS) {
            char what[CLI_PATH_CAP + 64];
            snprintf(what, sizeof what, "'%s' tensor %d", path, i);
            cli_lib_error(what, r, &err);
            cli_free_file(file);
            return CLI_FAIL;
        }
        if ((unsigned)ti.dtype < SUPERMAT_DTYPE_COUNT) { counts[ti.dtype]++; bytes_by[ti.dtype] += ti.nbytes; }
        tensor_bytes += ti.nbytes;
    }
    printf("file          %s\n", path);
    printf("size          %llu bytes (%.1f MiB), %d tensors, %.1f MiB of tensor data\n", (unsigned long long)size,
           cli_mib((double)size), ntens, cli_mib((double)tensor_bytes));
    printf("dtypes       ");
    for (i = 1; i < SUPERMAT_DTYPE_COUNT; i++)
        if (counts[i]) printf(" %s: %d tensor%s (%.1f MiB)", cli_dtype_name((supermat_dtype)i), counts[i], counts[i] == 1 ? "" : "s",
                   cli_mib((double)bytes_by[i]));
    printf("\n");
    if (supermat_safetensors_metadata(file, size, "supermat.format_version", meta, sizeof meta) == 0)
        printf("format        version %s\n", meta);
    if (supermat_safetensors_metadata(file, size, "supermat.kind", meta, sizeof meta) == 0)
        printf("kind          %s\n", meta);

    /* the loaded model */
    memset(&md, 0, sizeof md);
    md.data = file; md.size = size; md.kernel = kernel; md.weights = lv.weights; md.conv = lv.conv; md.compute = lv.compute;
    md.max_memory = lv.max_memory;
    create_s = cli_now();
    r = supermat_model_create(&md, &model, &err);
    create_s = cli_now() - create_s;
    if (r != SUPERMAT_SUCCESS) {
        char what[CLI_PATH_CAP + 64];
        snprintf(what, sizeof what, "model '%s'", path);
        cli_lib_error(what, r, &err);
        cli_free_file(file);
        return CLI_FAIL;
    }
    if (cli_packed_check(path, model, &lv) != CLI_OK) { supermat_model_destroy(model); cli_free_file(file); return CLI_FAIL; }
    supermat_model_get_info(model, &mi);
    if (mi.work_size) printf("work size     %dx%d: the network runs at it and the maps come back at the picture's size, as the official scripts do (--native: its own size)\n", mi.work_size, mi.work_size);
    else printf("work size     none: the network runs at each picture's own size\n");
    if (mi.kind != SUPERMAT_KIND_UV_REFINE) {
        if (mi.detail_sigma > 0.0f) printf("detail        %g of the picture's larger side: the albedo keeps the picture's detail (--detail off: no)\n", (double)mi.detail_sigma);
        else printf("detail        none (--detail F: the albedo keeps the picture's detail)\n");
        if (mi.chroma_weight > 0.0f) printf("colour        %g: the albedo takes the picture's colour at the network's luminance (--chroma off: no)\n", (double)mi.chroma_weight);
        else printf("colour        none (--chroma W: the albedo takes the picture's colour)\n");
        if (mi.bake_detail_sigma > 0.0f) printf("bake detail   %g of the texture's larger side: `mesh` keeps the input texture's detail (--detail off: no)\n", (double)mi.bake_detail_sigma);
        else printf("bake detail   none (`mesh --detail F`: the baked albedo keeps the input texture's detail)\n");
        cli_info_curve("roughness", mi.roughness_curve, mi.roughness_knots);
        cli_info_curve("metallic", mi.metallic_curve, mi.metallic_knots);
    }
    printf("kernel        %s\n", cli_kernel_name(mi.kernel));
    printf("build         %s\n", supermat_build_optimized() == 1 ? "optimised" :
                                  supermat_build_optimized() == 0 ? "NOT optimised (-O0: about 10x slower)" : "optimisation unknown");
    {
        static const char *wn[] = {"default", "f32", "f16", "bf16", "int8"};
        printf("weights       %s (GEMM weight storage; %.1f MiB held by the model)\n", (unsigned)mi.weights < 5 ? wn[mi.weights] : "?", (double)mi.model_bytes / 1048576.0);
    }
    printf("convolutions  %s (3x3; --conv)\n", cli_conv_name(mi.conv));
    printf("compute       %s (what the GEMMs multiply; --compute)\n", cli_compute_name(mi.compute));
    printf("unet          in %d, out %d channels; %d levels: channels ", mi.unet_in_channels, mi.unet_out_channels, mi.unet_levels);
    cli_print_list(mi.block_channels, mi.unet_levels);
    printf(", heads ");
    cli_print_list(mi.num_heads, mi.unet_levels);
    printf("; %d layers per block, %d norm groups\n", mi.layers_per_block, mi.norm_groups);
    printf("              cross-attention dim %d, context %d tokens, %d branch%s\n", mi.cross_attention_dim, mi.context_tokens,
           mi.branches, mi.branches == 1 ? "" : "es");
    if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV)
        printf("multi-view    camera embedding in %d (class_embed_in: the view's 4x4 camera-to-world matrix, row-major),\n"
               "              added to the time embedding per view; views attend to each other (default 6)\n", mi.class_embed_in);
    else if (mi.kind == SUPERMAT_KIND_UV_REFINE)
        printf("uv refine     UNet input %d channels = latent %d + mask 1 + position %d; output: the refined map\n",
               mi.unet_in_channels, mi.latent_channels, mi.unet_in_channels - mi.latent_channels - 1);
    printf("vae           %d levels: channels ", mi.vae_levels);
    cli_print_list(mi.vae_block_channels, mi.vae_levels);
    printf("; latent %d channels, scaling factor %g\n", mi.latent_channels, (double)mi.scaling_factor);
    printf("scheduler     one step at timestep %d, alphas_cumprod %.9g, %s\n", mi.timestep, (double)mi.alphas_cumprod,
           mi.v_prediction ? "v-prediction" : "epsilon-prediction");
    {
        uint64_t branches = (uint64_t)(mi.branches > 0 ? mi.branches : 0), per = mi.branch_params;
        uint64_t trunk = mi.unet_params >= branches * per ? mi.unet_params - branches * per : 0;
        cli_print_count("parameters    UNet trunk ", trunk);
        cli_print_count(", per branch ", per);
        printf(" x %d", mi.branches);
        cli_print_count(", VAE ", mi.vae_params);
        cli_print_count(", total ", mi.unet_params + mi.vae_params);
        printf("\n");
    }
    printf("model memory  %llu bytes (%.1f MiB) held by the model, created in %.3f s; it also borrows the file buffer\n",
           (unsigned long long)mi.model_bytes, cli_mib((double)mi.model_bytes), create_s);
    if (mi.prepacked) {
        printf("pre-packed    yes: %.1f MiB of panels used in place from the mapped file (conv %s, compute %s; `supermat pack`)\n",
               cli_mib((double)mi.prepacked_bytes), cli_conv_name(mi.conv), cli_compute_name(mi.compute));
    }
    {
        supermat_session_desc sd;
        size_t all = 0, alb = 0;
        int nthreads;
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = 512; sd.height = 512; sd.threads = threads;
        sd.views = mi.kind == SUPERMAT_KIND_SUPERMAT_MV ? 6 : 1;
        nthreads = supermat_session_desc_threads(&sd);
        sd.outputs = SUPERMAT_OUTPUT_ALL;
        r = supermat_session_memory(&sd, &all, &err);
        if (r == SUPERMAT_SUCCESS) {
            sd.outputs = SUPERMAT_OUTPUT_ALBEDO;
            r = supermat_session_memory(&sd, &alb, &err);
        }
        if (r != SUPERMAT_SUCCESS) {
            cli_lib_error("session memory", r, &err);
            supermat_model_destroy(model);
            cli_free_file(file);
            return CLI_FAIL;
        }
        if (mi.kind == SUPERMAT_KIND_UV_REFINE)
            printf("session 512   %llu bytes (%.1f MiB), the refined map (%d thread%s)\n", (unsigned long long)all, cli_mib((double)all),
                   nthreads, nthreads == 1 ? "" : "s");
        else
            printf("session 512   %llu bytes (%.1f MiB) all outputs, %llu bytes (%.1f MiB) albedo only (%s%d thread%s)\n",
                   (unsigned long long)all, cli_mib((double)all), (unsigned long long)alb, cli_mib((double)alb),
                   mi.kind == SUPERMAT_KIND_SUPERMAT_MV ? "6 views, " : "", nthreads, nthreads == 1 ? "" : "s");
    }
    printf("command       %s\n", cli_kind_command(mi.kind));
    supermat_model_destroy(model);
    cli_free_file(file);
    return CLI_OK;
}
