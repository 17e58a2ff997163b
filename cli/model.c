/* cli/model.c - the default model: where a command without --model finds it; loading a model for any command.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>model */
/* The default model: what `image`, `info` and `bench` run without --model. Its places are compiled in:
   CMake defines SUPERMAT_CLI_DATADIR (the installed data folder, GNUInstallDirs' DATADIR/supermat),
   SUPERMAT_CLI_DATADIR_FROM_BIN (the same relative to the installed executable's folder, for an install
   that was moved) and SUPERMAT_CLI_SOURCE_DIR (the source tree, for a build that was not installed). */
#ifndef SUPERMAT_CLI_DATADIR
#define SUPERMAT_CLI_DATADIR "/usr/local/share/supermat"
#endif
#ifndef SUPERMAT_CLI_DATADIR_FROM_BIN
#define SUPERMAT_CLI_DATADIR_FROM_BIN "../share/supermat"
#endif
#define CLI_DEFAULT_MODEL "supermat_default.safetensors"
#define CLI_PATH_CAP 4096

/* The named models (`--model official`): the four files `supermat download official` writes, in the model
   folder: $SUPERMAT_MODEL_DIR when set and not empty, else the user's data folder ($XDG_DATA_HOME/supermat,
   else ~/.local/share/supermat; macOS ~/Library/Application Support/supermat; Windows
   %LOCALAPPDATA%\supermat). */
#define CLI_OFFICIAL_SV "supermat_official.safetensors"
#define CLI_OFFICIAL_MV "supermat_mv_official.safetensors"
#define CLI_OFFICIAL_BC "supermat_refine_albedo_official.safetensors"
#define CLI_OFFICIAL_RM "supermat_refine_rm_official.safetensors"

/* the model folder, malloc'ed (no trailing '/'), and where it came from; NULL when no variable says
   (HOME unset) or out of memory */
static char *cli_model_dir(const char **from) {
    const char *e = getenv("SUPERMAT_MODEL_DIR"), *x = getenv("XDG_DATA_HOME"), *h = getenv("HOME");
    char *d = NULL;
    size_t n;
    *from = NULL;
    if (e && *e) { d = cli_join(e, "", ""); *from = "$SUPERMAT_MODEL_DIR"; }
#ifdef _WIN32
    else if ((x = getenv("LOCALAPPDATA")) != NULL && *x) { d = cli_join(x, "supermat", ""); *from = "%LOCALAPPDATA%\\supermat"; }
#else
    else if (x && x[0] == '/') { d = cli_join(x, "supermat", ""); *from = "$XDG_DATA_HOME/supermat"; }
#ifdef __APPLE__
    else if (h && *h) { d = cli_join(h, "Library/Application Support/supermat", ""); *from = "~/Library/Application Support/supermat"; }
#else
    else if (h && *h) { d = cli_join(h, ".local/share/supermat", ""); *from = "~/.local/share/supermat"; }
#endif
#endif
    (void)h;
    if (d && (n = strlen(d)) > 1 && d[n - 1] == '/') d[n - 1] = 0;
    return d;
}

/* the names --model (and `supermat info`) take besides files: each a file of the model folder. `official` is
   the single-view network, and the multi-view one for `supermat views` (and `supermat mesh`, cli/mesh.cpp) */
typedef struct cli_named_model {
    const char *name, *file, *what;
} cli_named_model;
#define CLI_NNAMED 4
static const cli_named_model cli_named_models[CLI_NNAMED] = {
    {"official", CLI_OFFICIAL_SV, "the official single-view network"},
    {"official-mv", CLI_OFFICIAL_MV, "the official multi-view network (SuperMatMV)"},
    {"official-refine-albedo", CLI_OFFICIAL_BC, "the official UV-refine network, albedo"},
    {"official-refine-rm", CLI_OFFICIAL_RM, "the official UV-refine network, roughness / metallic"}};

typedef struct cli_model_ref {
    char path[CLI_PATH_CAP];
    const char *from; /* "--model", "$SUPERMAT_MODEL", "installed", ... */
} cli_model_ref;

/* "<folder of this executable>/<rel>/<name>" with the leading ../ of rel taken off that folder;
   0 when this system does not say where the executable is (/proc/self/exe is Linux's) */
static int cli_exe_relative(const char *rel, const char *name, char *out, size_t cap) {
#if defined(__linux__)
    char dir[CLI_PATH_CAP], *slash;
    ssize_t n = readlink("/proc/self/exe", dir, sizeof dir - 1);
    int len;
    if (n <= 0 || (size_t)n >= sizeof dir - 1) return 0;
    dir[n] = 0;
    if (!(slash = strrchr(dir, '/'))) return 0;
    *slash = 0;
    while (!strncmp(rel, "../", 3) || !strcmp(rel, "..")) {
        if (!(slash = strrchr(dir, '/'))) return 0;
        *slash = 0;
        rel += rel[2] ? 3 : 2;
    }
    len = snprintf(out, cap, "%s/%s%s%s", dir, rel, rel[0] ? "/" : "", name);
    return len > 0 && (size_t)len < cap;
#else
    (void)rel; (void)name; (void)out; (void)cap;
    return 0;
#endif
}

/* the places of steps 2 and 3, in order; returns how many (at most 3) */
static int cli_default_places(char places[3][CLI_PATH_CAP], const char *what[3]) {
    int n = 0, len;
    if (cli_exe_relative(SUPERMAT_CLI_DATADIR_FROM_BIN, CLI_DEFAULT_MODEL, places[n], CLI_PATH_CAP))
        what[n++] = "installed, beside this executable";
    len = snprintf(places[n], CLI_PATH_CAP, "%s/%s", SUPERMAT_CLI_DATADIR, CLI_DEFAULT_MODEL);
    if (len > 0 && len < CLI_PATH_CAP && (n == 0 || strcmp(places[0], places[n]))) what[n++] = "installed";
#ifdef SUPERMAT_CLI_SOURCE_DIR
    len = snprintf(places[n], CLI_PATH_CAP, "%s/models/%s", SUPERMAT_CLI_SOURCE_DIR, CLI_DEFAULT_MODEL);
    if (len > 0 && len < CLI_PATH_CAP) what[n++] = "source tree";
#endif
    return n;
}

static int cli_is_file(const char *path) {
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* the DEFAULT MODEL part of `image`, `info` and `bench --help` */
static void cli_print_default_model_help(void) {
    char places[3][CLI_PATH_CAP];
    const char *what[3];
    int n = cli_default_places(places, what), i;
    printf("\nDEFAULT MODEL\n"
           "Without --model, the default model is used: the first of these that exists.\n"
           "  1. the file the environment variable SUPERMAT_MODEL names, when it is set and not empty\n"
           "     (a file that does not exist is an error: no fallback to 2 and 3)\n"
           "  2. the installed model: <folder of this executable>/%s/%s\n"
           "     (an install that was moved), then %s/%s\n"
           "  3. the source tree's models/%s (a build that was not installed)\n"
           "Here:\n", SUPERMAT_CLI_DATADIR_FROM_BIN, CLI_DEFAULT_MODEL, SUPERMAT_CLI_DATADIR, CLI_DEFAULT_MODEL, CLI_DEFAULT_MODEL);
    for (i = 0; i < n; i++) printf("  %s (%s)\n", places[i], what[i]);
    { /* the one that is used, and the work size it records: the size pictures are resized to by default */
        const char *env = getenv("SUPERMAT_MODEL"), *used = env && env[0] ? env : NULL;
        for (i = 0; !used && i < n; i++)
            if (cli_is_file(places[i])) used = places[i];
        if (used) {
            unsigned char *file = NULL;
            size_t size = 0;
            char v[32];
            if (cli_is_file(used) && cli_read_file(used, &file, &size) == 0 &&
                supermat_safetensors_metadata(file, size, "pipeline.work_size", v, sizeof v) == 0)
                printf("  used: %s, work size %sx%s (what pictures are resized to by default)\n", used, v, v);
            else
                printf("  used: %s\n", used);
            cli_free_file(file);
        } else
            printf("  none of them exists\n");
    }
    printf("`supermat info` without a FILE shows the default model.\n");
    {
        const char *from = NULL;
        char *dir = cli_model_dir(&from);
        int k;
        printf("\nNAMED MODELS\n"
               "--model also takes a name: `default` (the default model above) or one of the files that\n"
               "`supermat download official` writes into the model folder:\n");
        for (k = 0; k < CLI_NNAMED; k++) printf("  %-24s %s (%s)\n", cli_named_models[k].name, cli_named_models[k].file, cli_named_models[k].what);
        printf("(`official` is the multi-view one for `supermat views`; a file of such a name: ./official).\n"
               "The model folder: $SUPERMAT_MODEL_DIR when set, else $XDG_DATA_HOME/supermat, else\n"
               "~/.local/share/supermat.\nHere:\n  %s%s%s%s\n", dir ? dir : "none (HOME is not set)", from ? " (" : "", from ? from : "", from ? ")" : "");
        free(dir);
    }
}

/* named model k's file in the model folder: CLI_OK and *ref when it is there, else a message and CLI_FAIL */
static int cli_named_path(int k, cli_model_ref *ref) {
    const char *from = NULL;
    char *dir = cli_model_dir(&from), *p;
    const cli_named_model *m = &cli_named_models[k];
    if (!dir) { cli_error("--model %s: no model folder: neither SUPERMAT_MODEL_DIR nor HOME is set", m->name); return CLI_FAIL; }
    p = cli_join(dir, m->file, "");
    if (!p || strlen(p) >= sizeof ref->path) {
        cli_error(p ? "--model %s: the path is longer than %d bytes" : "out of memory", m->name, CLI_PATH_CAP - 1);
        free(p); free(dir);
        return CLI_FAIL;
    }
    if (!cli_is_file(p)) {
        cli_error("--model %s (%s): %s is not there (the model folder %s, from %s).\n"
                  "  `supermat download official` downloads and converts the official networks into it; or set\n"
                  "  SUPERMAT_MODEL_DIR to a folder that has them", m->name, m->what, p, dir, from);
        free(p); free(dir);
        return CLI_FAIL;
    }
    strcpy(ref->path, p);
    ref->from = m->what;
    free(p);
    free(dir);
    return CLI_OK;
}

/* The model file a command runs: --model's (given) when there is one; else, when allow_default, the
   default model (see cli_print_default_model_help). CLI_OK and *ref, or a message and CLI_FAIL
   (SUPERMAT_MODEL names a missing file, or no default model is found) or CLI_USAGE (no --model and
   !allow_default). One function for every command. */
static int cli_model_path(const char *cmd, const char *given, int allow_default, cli_model_ref *ref) {
    char places[3][CLI_PATH_CAP];
    const char *what[3], *env;
    int n, i;
    ref->path[0] = 0;
    ref->from = NULL;
    if (given && !strcmp(given, "default")) { /* the name of what no --model runs */
        if (!allow_default) return cli_usage_error(cmd, "--model default: `supermat %s` has no default model; give a file or a name (official...)", cmd);
        given = NULL;
    }
    if (given) { /* a name: official, official-mv, ... */
        int k;
        for (k = 0; k < CLI_NNAMED; k++)
            if (!strcmp(given, cli_named_models[k].name)) return cli_named_path(!strcmp(cmd, "views") && k == 0 ? 1 : k, ref);
    }
    if (given) {
        if (strlen(given) >= sizeof ref->path) { cli_error("--model: the path is longer than %d bytes", CLI_PATH_CAP - 1); return CLI_FAIL; }
        strcpy(ref->path, given);
        ref->from = "--model";
        return CLI_OK;
    }
    if (!allow_default) return cli_usage_error(cmd, "--model FILE is required (the default model is a supermat model, for `supermat image`)");
    env = getenv("SUPERMAT_MODEL");
    if (env && env[0]) {
        struct stat st;
        if (stat(env, &st) != 0) {
            cli_error("SUPERMAT_MODEL is set to '%s': %s (give --model FILE, or unset SUPERMAT_MODEL for the default model)", env,
                      strerror(errno));
            return CLI_FAIL;
        }
        if (strlen(env) >= sizeof ref->path) { cli_error("SUPERMAT_MODEL: the path is longer than %d bytes", CLI_PATH_CAP - 1); return CLI_FAIL; }
        strcpy(ref->path, env);
        ref->from = "$SUPERMAT_MODEL";
        return CLI_OK;
    }
    n = cli_default_places(places, what);
    for (i = 0; i < n; i++)
        if (cli_is_file(places[i])) {
            strcpy(ref->path, places[i]);
            ref->from = what[i];
            return CLI_OK;
        }
    cli_error("no model: --model FILE was not given and there is no default model. Looked at, in order:");
    fprintf(stderr, "  1. $SUPERMAT_MODEL: not set\n");
    for (i = 0; i < n; i++)
        fprintf(stderr, "  %s %s (%s): not found\n", !strcmp(what[i], "source tree") ? "3." : i == 0 ? "2." : "  ", places[i], what[i]);
    fprintf(stderr, "Give --model FILE (a model file made by `supermat convert`) or set SUPERMAT_MODEL to one.\n");
    return CLI_FAIL;
}

/* `supermat info` without FILE: the models this tool finds, and where. Each line: what, the file, whether it
   is there (its size). */
static void cli_print_models(void) {
    char places[3][CLI_PATH_CAP], *dir;
    const char *what[3], *env = getenv("SUPERMAT_MODEL"), *from = NULL, *used = NULL, *used_from = NULL;
    int n = cli_default_places(places, what), i, k;
    struct stat st;
    printf("models\n");
    if (env && env[0]) { used = env; used_from = "$SUPERMAT_MODEL"; }
    for (i = 0; !used && i < n; i++)
        if (cli_is_file(places[i])) { used = places[i]; used_from = what[i]; }
    if (used) {
        const char *slash = strrchr(used, '/');
        static const char *const mesh[3][2] = {{"mesh view model", "supermat_mv_default.safetensors"},
                                               {"mesh refine albedo", "supermat_refine_albedo_default.safetensors"},
                                               {"mesh refine r/m", "supermat_refine_rm_default.safetensors"}};
        printf("  %-24s %s (%s)%s\n", "default", used, used_from, cli_is_file(used) ? "" : ": not there");
        for (k = 0; k < 3; k++) { /* the mesh defaults: beside the default model (cli/mesh.cpp) */
            char p[CLI_PATH_CAP];
            int len = snprintf(p, sizeof p, "%.*s%s", slash ? (int)(slash - used + 1) : 0, used, mesh[k][1]);
            if (len > 0 && (size_t)len < sizeof p) printf("  %-24s %s%s\n", mesh[k][0], p, cli_is_file(p) ? "" : ": not there");
        }
    } else
        printf("  %-24s none found (`supermat image --help`, DEFAULT MODEL, says where it is looked for)\n", "default");
    dir = cli_model_dir(&from);
    if (!dir) { printf("  model folder: none (neither SUPERMAT_MODEL_DIR nor HOME is set)\n"); return; }
    printf("  %-24s %s (%s)%s\n", "model folder", dir, from, stat(dir, &st) == 0 && S_ISDIR(st.st_mode) ? "" : ": does not exist yet");
    for (k = 0; k < CLI_NNAMED; k++) {
        char *p = cli_join(dir, cli_named_models[k].file, "");
        if (!p) break;
        if (stat(p, &st) == 0 && S_ISREG(st.st_mode))
            printf("  %-24s %s (%.1f MiB)\n", cli_named_models[k].name, p, cli_mib((double)st.st_size));
        else
            printf("  %-24s %s: not downloaded (`supermat download official`)\n", cli_named_models[k].name, p);
        free(p);
    }
    free(dir);
}

/* For cli/mesh.cpp (another translation unit): the default model's path, as `supermat image` finds
   it without --model; 0 after cli_model_path's message when there is none. */
int supermat_cli_default_model(char *path, size_t cap, const char **from);
/* For cli/mesh.cpp: the file of a named model (name as --model takes it: official-mv, ...); 0 after a
   message when it is not there */
int supermat_cli_named_model(const char *name, char *path, size_t cap);
int supermat_cli_named_model(const char *name, char *path, size_t cap) {
    cli_model_ref ref;
    int k;
    for (k = 0; k < CLI_NNAMED; k++)
        if (!strcmp(name, cli_named_models[k].name)) break;
    if (k == CLI_NNAMED) { cli_error("'%s' is not a model name", name); return 0; }
    if (cli_named_path(k, &ref) != CLI_OK) return 0;
    if (strlen(ref.path) >= cap) { cli_error("the path of %s is longer than %d bytes", name, (int)cap - 1); return 0; }
    strcpy(path, ref.path);
    return 1;
}

int supermat_cli_default_model(char *path, size_t cap, const char **from) {
    cli_model_ref ref;
    if (cli_model_path("mesh", NULL, 1, &ref) != CLI_OK) return 0;
    if (strlen(ref.path) >= cap) { cli_error("the default model's path is longer than %d bytes", (int)cap - 1); return 0; }
    strcpy(path, ref.path);
    *from = ref.from;
    return 1;
}

/* The network size of image, views and refine. The official scripts resize every picture to a square
   (512x512, UV maps 1024x1024; Pillow bilinear, aspect squashed) before the network: the CLI does the
   same by default through the library's work_width/height (maps come back at the picture's size), at the
   size the model file records (pipeline.work_size: 512 from `supermat convert`, 256 for the default
   model, 0 = none), the official one for a file that records none.
   --native runs each picture at its own size, --work-size N at N x N. */

/* The options the commands that run a model share: their ids (a command's own options count from 1),
   their tables (spliced into each command's with CLI_OPTS) and cli_run_value, which reads their values. */
enum {
    CLI_O_FLOAT = 100, CLI_O_NATIVE, CLI_O_WORK_SIZE, CLI_O_DETAIL, CLI_O_CHROMA, CLI_O_ROUGH_CURVE, CLI_O_METAL_CURVE,
    CLI_O_THREADS, CLI_O_KERNEL, CLI_O_MAX_MEMORY, CLI_O_WEIGHTS, CLI_O_COMPUTE, CLI_O_CONV
};
#define CLI_KERNEL_VALUES "auto | scalar | avx2 | avx512 | neon | amx"
#define CLI_HELP_THREADS "threads (default 0 = all cores, 1 = the calling thread only)"
#define CLI_HELP_KERNEL CLI_KERNEL_VALUES " (default auto: the best this CPU has)"
#define CLI_HELP_MAX_MEMORY "refuse a model + session that would need more memory than SIZE (512M, 4G),\nbefore allocating it; the message says how much it needs"
#define CLI_HELP_FLOAT3 "also write the maps before 8-bit quantisation as PFM files (float32,\nlittle endian): <stem>_albedo.pfm (PF, RGB), <stem>_roughness.pfm and\n<stem>_metallic.pfm (Pf, gray)"
/* --weights, --compute, --conv: the speed / accuracy levers (docs/levers.md) */
static const cli_optdef cli_opts_levers[] = {
    {CLI_O_WEIGHTS, "--weights", "W", "default | f32 | f16 | bf16 | int8: GEMM weight storage (default: as the file stores it)", NULL, NULL},
    {CLI_O_COMPUTE, "--compute", "C", "f32 | bf16 | int8: what the GEMMs multiply (bf16: AVX512_BF16 CPUs, int8:\nAVX512_VNNI or AVX-VNNI CPUs; default f32)", NULL, NULL},
    {CLI_O_CONV, "--conv", "C", "direct | winograd-f2 | winograd-f4: how 3x3 convolutions run (default direct;\nWinograd: fewer multiplies, maps within ~1e-4 of direct; docs/levers.md)", NULL, NULL},
    CLI_END};
/* --threads, --kernel, --max-memory and the levers, as image, views and refine take them */
static const cli_optdef cli_opts_machine[] = {
    {CLI_O_THREADS, "--threads", "N", CLI_HELP_THREADS, NULL, NULL},
    {CLI_O_KERNEL, "--kernel", "K", CLI_HELP_KERNEL, NULL, NULL},
    {CLI_O_MAX_MEMORY, "--max-memory", "SIZE", CLI_HELP_MAX_MEMORY, NULL, NULL},
    CLI_OPTS(cli_opts_levers),
    CLI_END};
/* --native and --work-size: the network's size (cli_work) */
static const cli_optdef cli_opts_work[] = {
    {CLI_O_NATIVE, "--native", NULL, "run each picture at its own size instead", NULL, NULL},
    {CLI_O_WORK_SIZE, "--work-size", "N", "at N x N (a multiple of 8)", NULL, NULL},
    CLI_END};

/* --roughness-curve (c 0) / --metallic-curve (c 1) off|K0,K1,...: the knots as supermat_parse_curve reads them */
static int cli_parse_curve(const char *cmd, int c, const char *v, cli_levers *lv) {
    supermat_error e;
    if (!strcmp(v, "off")) { lv->knots[c] = SUPERMAT_CURVE_OFF; return 0; }
    if (supermat_parse_curve(v, lv->curve[c], &lv->knots[c], &e) != SUPERMAT_SUCCESS) {
        cli_usage_error(cmd, "--%s-curve: 'off' or a list of knots (0.2,0.5,0.8): %s", c ? "metallic" : "roughness", e.message);
        return -1;
    }
    return 0;
}
#define CLI_HELP_ROUGH_CURVE "the roughness map through a calibration curve: K0,...,Kn-1 the values at\n" \
    "0, 1/(n-1), ..., 1 (2 to 33 knots in [0, 1], never falling), piecewise linear;\n" \
    "off: the network's roughness (default: the model file's curve, `supermat info`\n" \
    "shows it: the default model has one, an official one none; supermat.h,\n" \
    "session_desc.roughness_knots)"
#define CLI_HELP_METAL_CURVE "the metallic map through a calibration curve, as --roughness-curve\n" \
    "(default: the model file's; supermat.h, session_desc.metallic_knots)"

/* the value of a shared option (id, v): 1 when id is one, -1 after a usage message, 0 when it is none.
   A NULL pointer: the command does not take that option (its table does not list it). */
static int cli_run_value(const char *cmd, int id, const char *v, int *want_float, int *work_opt, int *threads,
                         supermat_kernel *kernel, cli_levers *lv) {
    switch (id) {
    case CLI_O_FLOAT: *want_float = 1; return 1;
    case CLI_O_NATIVE: *work_opt = 0; return 1;
    case CLI_O_WORK_SIZE:
        if (cli_parse_int(cmd, "--work-size", v, 8, 16384, work_opt)) return -1;
        if (*work_opt % 8) { cli_usage_error(cmd, "--work-size %d: a multiple of 8", *work_opt); return -1; }
        return 1;
    case CLI_O_DETAIL: return cli_parse_unit(cmd, "--detail", v, "a fraction of the picture's size", &lv->detail) ? -1 : 1;
    case CLI_O_CHROMA: return cli_parse_unit(cmd, "--chroma", v, "a weight", &lv->chroma) ? -1 : 1;
    case CLI_O_ROUGH_CURVE: return cli_parse_curve(cmd, 0, v, lv) ? -1 : 1;
    case CLI_O_METAL_CURVE: return cli_parse_curve(cmd, 1, v, lv) ? -1 : 1;
    case CLI_O_THREADS: return cli_parse_int(cmd, "--threads", v, 0, 1024, threads) ? -1 : 1;
    case CLI_O_KERNEL: return cli_parse_kernel(cmd, v, kernel) ? -1 : 1;
    case CLI_O_WEIGHTS: return cli_parse_weights(cmd, v, lv) ? -1 : 1;
    case CLI_O_COMPUTE: return cli_parse_compute(cmd, v, lv) ? -1 : 1;
    case CLI_O_CONV: return cli_parse_conv(cmd, v, lv) ? -1 : 1;
    case CLI_O_MAX_MEMORY: return cli_parse_bytes(cmd, "--max-memory", v, &lv->max_memory) ? -1 : 1;
    default: return 0;
    }
}

/* --max-memory: what is left of it for a session once the model holds its part (1 when nothing is) */
static size_t cli_session_budget(const supermat_model *model, size_t max_memory) {
    supermat_model_info mi;
    if (!max_memory) return 0;
    memset(&mi, 0, sizeof mi);
    supermat_model_get_info(model, &mi);
    return max_memory > mi.model_bytes ? max_memory - mi.model_bytes : 1;
}
/* after a session refused for its memory: how --max-memory was shared */
static void cli_budget_note(const supermat_model *model, supermat_result r, size_t max_memory) {
    supermat_model_info mi;
    if (!max_memory || r != SUPERMAT_ERROR_OUT_OF_MEMORY) return;
    memset(&mi, 0, sizeof mi);
    supermat_model_get_info(model, &mi);
    fprintf(stderr, "  (--max-memory %.1f MiB: the model holds %.1f MiB, which leaves the session the rest)\n", cli_mib((double)max_memory), cli_mib((double)mi.model_bytes));
}

/* The options as the library takes them: what the command line did not say stays 0, which the library reads
   as the model file's pipeline (work size, detail, colour); the CLI sets nothing of its own.
   work: -1 (no option) -> 0, 0 (--native) -> SUPERMAT_WORK_NATIVE, N -> N */
static int cli_work(int opt) { return opt < 0 ? 0 : opt == 0 ? SUPERMAT_WORK_NATIVE : opt; }
/* --detail / --chroma (cli_levers): -1 (not given) -> 0, 0 (off) -> SUPERMAT_OFF, v -> v */
static float cli_step(float v) { return v < 0.0f ? 0.0f : v == 0.0f ? SUPERMAT_OFF : v; }
/* the session fields of the shared options */
static void cli_session_opts(supermat_session_desc *sd, int work_opt, const cli_levers *lv) {
    sd->work_width = sd->work_height = cli_work(work_opt);
    sd->detail_sigma = cli_step(lv->detail);
    sd->chroma_weight = cli_step(lv->chroma);
    sd->roughness_knots = lv->knots[0];
    sd->roughness_curve = lv->knots[0] > 0 ? lv->curve[0] : NULL;
    sd->metallic_knots = lv->knots[1];
    sd->metallic_curve = lv->knots[1] > 0 ? lv->curve[1] : NULL;
}
