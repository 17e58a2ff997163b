/* cli/args.c - `supermat --help`, and the value parsers the commands share (--weights, --kernel, --outputs, sizes).
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>args */
#include "opt_table.h" /* the option tables: parsing and --help from one table per command */

static const char cli_usage_main[] =
    "supermat - SuperMat PBR material estimation on the CPU (albedo, roughness, metallic)\n"
    "\n"
    "usage: supermat COMMAND [OPTIONS] [ARGS]\n"
    "\n"
    "commands:\n"
    "  convert   official checkpoint (.pth) + Stable Diffusion 2.1 folder -> one model file\n"
    "  download  `download official`: the official networks from the Hugging Face hub, converted\n"
    "  pack      a model file -> its pre-packed form: created in milliseconds, shared by processes\n"
    "  image     albedo / roughness / metallic maps for images (a supermat model)\n"
    "  views     the same for the views of one object with their cameras (a supermat-mv model)\n"
    "  refine    complete a partial UV texture map (a uv-refine model)\n"
    "  info      describe a model file: architecture, parameters, dtypes, memory\n"
    "  sheet     a contact sheet: rows of pictures and maps side by side in one PNG, with labels\n"
    "  mesh      a textured glTF mesh -> complete albedo + metallicRoughness UV textures (supermat_uv.h)\n"
    "  batch     `image` over an asset library: folders, lists, a resumable journal, shards, workers\n"
    "  bench     this machine's FMA peak, the pipeline per stage, AVX2 vs scalar GEMM; with --image\n"
    "            a speed / accuracy table of the speed and memory levers on a real input\n"
    "\n"
    "image, info and bench run the default model when --model is not given (the file $SUPERMAT_MODEL\n"
    "names, else the installed or the source tree's supermat_default.safetensors: `supermat image --help`).\n"
    "\n"
    "  supermat COMMAND --help   the options of a command\n"
    "  supermat --version        the version\n"
    "\n"
    "outputs, every command: a file that exists and was not written by this run is not replaced (exit 1,\n"
    "before any work on that input), symbolic links included; each file is written to a new temporary\n"
    "file beside it and renamed (linked) into place when complete, so a failed write leaves the old file\n"
    "or none; no write follows a symbolic link (docs/security.md). A folder named by --out DIR is\n"
    "created when missing; the folder of an output FILE (convert, pack, sheet, mesh) must exist, and is\n"
    "checked before any work.\n"; /* then the global options (cli_opts_global, io.c) and the exit status: main.c's cli_help_main */

static int cli_parse_int(const char *cmd, const char *opt, const char *s, int lo, int hi, int *out) {
    char *end;
    long v;
    errno = 0;
    v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        cli_usage_error(cmd, "%s: '%s' is not an integer in [%d, %d]", opt, s, lo, hi);
        return -1;
    }
    *out = (int)v;
    return 0;
}

/* The options the commands that run a model share (image, views, refine, info, pack, bench, batch image):
   each command parses them into its own cli_levers (cli_levers_init first), so nothing carries over from
   one command to the next in one process (batch, the fuzz harnesses). */
typedef struct cli_levers {
    supermat_weights weights; /* --weights: the storage of the GEMM weights (a speed / accuracy lever, docs/levers.md) */
    supermat_compute compute; /* --compute */
    int compute_given;        /* --compute was on the command line (else a pre-packed file's own) */
    supermat_conv conv;       /* --conv: how the 3x3 convolutions run (Winograd, docs/levers.md) */
    int conv_given;           /* --conv was on the command line */
    size_t max_memory;        /* --max-memory, 0 = none */
    float detail;             /* --detail: -1 = the command's default (image 1/64, views off) */
    float chroma;             /* --chroma: -1 = the command's default (image 1, views off) */
    int knots[2];             /* --roughness-curve, --metallic-curve: 0 = not given (the model's), SUPERMAT_CURVE_OFF
                                 = off, else the knots in curve[] */
    float curve[2][SUPERMAT_CURVE_MAX_KNOTS];
} cli_levers;
static void cli_levers_init(cli_levers *lv) {
    memset(lv, 0, sizeof *lv);
    lv->weights = SUPERMAT_WEIGHTS_DEFAULT;
    lv->compute = SUPERMAT_COMPUTE_F32;
    lv->conv = SUPERMAT_CONV_DIRECT;
    lv->detail = -1.0f;
    lv->chroma = -1.0f;
}
/* 'off' (0), or a number or a fraction A/B ("1/64") from 0 to 1 (--detail, --chroma); what: what the number
   is, for the message */
static int cli_parse_unit(const char *cmd, const char *opt, const char *s, const char *what, float *out) {
    char *end = NULL;
    int ok = 1;
    *out = 0.0f;
    if (strcmp(s, "off")) {
        double v = strtod(s, &end);
        *out = strtof(s, NULL); /* a number: as strtof reads it */
        ok = end != s;
        if (ok && *end == '/') { /* a fraction: its denominator, > 0 */
            const char *q = end + 1;
            double den = strtod(q, &end);
            ok = end != q && den > 0.0;
            if (ok) *out = (float)(v /= den);
        }
        ok = ok && !*end && v >= 0.0 && v <= 1.0;
    }
    if (!ok) {
        cli_usage_error(cmd, "%s: 'off' or %s from 0 to 1 (0.5, 1/64), not '%s'", opt, what, s);
        return -1;
    }
    return 0;
}
static int cli_parse_compute(const char *cmd, const char *s, cli_levers *lv) {
    lv->compute_given = 1;
    if (!strcmp(s, "f32")) lv->compute = SUPERMAT_COMPUTE_F32;
    else if (!strcmp(s, "bf16")) lv->compute = SUPERMAT_COMPUTE_BF16;
    else if (!strcmp(s, "int8")) lv->compute = SUPERMAT_COMPUTE_INT8;
    else { cli_usage_error(cmd, "--compute: '%s' is not f32, bf16 or int8", s); return -1; }
    return 0;
}
static int cli_parse_conv(const char *cmd, const char *s, cli_levers *lv) {
    lv->conv_given = 1;
    if (!strcmp(s, "direct")) lv->conv = SUPERMAT_CONV_DIRECT;
    else if (!strcmp(s, "winograd-f2") || !strcmp(s, "f2")) lv->conv = SUPERMAT_CONV_WINOGRAD_F2;
    else if (!strcmp(s, "winograd-f4") || !strcmp(s, "f4")) lv->conv = SUPERMAT_CONV_WINOGRAD_F4;
    else { cli_usage_error(cmd, "--conv: '%s' is not direct, winograd-f2 or winograd-f4", s); return -1; }
    return 0;
}
static const char *cli_compute_name(supermat_compute c) {
    return c == SUPERMAT_COMPUTE_BF16 ? "bf16" : c == SUPERMAT_COMPUTE_INT8 ? "int8" : "f32";
}
static const char *cli_conv_name(supermat_conv c) {
    return c == SUPERMAT_CONV_WINOGRAD_F2 ? "winograd-f2" : c == SUPERMAT_CONV_WINOGRAD_F4 ? "winograd-f4" : "direct";
}
static int cli_parse_weights(const char *cmd, const char *s, cli_levers *lv) {
    if (!strcmp(s, "default")) lv->weights = SUPERMAT_WEIGHTS_DEFAULT;
    else if (!strcmp(s, "f32")) lv->weights = SUPERMAT_WEIGHTS_F32;
    else if (!strcmp(s, "f16")) lv->weights = SUPERMAT_WEIGHTS_F16;
    else if (!strcmp(s, "bf16")) lv->weights = SUPERMAT_WEIGHTS_BF16;
    else if (!strcmp(s, "int8") || !strcmp(s, "i8")) lv->weights = SUPERMAT_WEIGHTS_I8;
    else { cli_usage_error(cmd, "--weights: '%s' is not default, f32, f16, bf16 or int8", s); return -1; }
    return 0;
}

/* --max-memory SIZE: bytes, or with K, M, G, T (powers of 1024; KiB... and KB... read the same) */
static int cli_parse_bytes(const char *cmd, const char *opt, const char *s, size_t *out) {
    char *end;
    double v, mul = 1;
    errno = 0;
    v = strtod(s, &end);
    if (end != s) {
        char u = *end >= 'a' && *end <= 'z' ? (char)(*end - 32) : *end;
        if (u == 'K') mul = 1024.0; else if (u == 'M') mul = 1048576.0; else if (u == 'G') mul = 1073741824.0; else if (u == 'T') mul = 1099511627776.0;
        if (mul > 1) { end++; if (*end == 'i' || *end == 'I') end++; if (*end == 'B' || *end == 'b') end++; }
        else if (*end == 'B' || *end == 'b') end++;
    }
    if (errno || end == s || *end || !(v >= 1) || v * mul > 1.8e19) {
        cli_usage_error(cmd, "%s: '%s' is not a size (bytes, or a number with K, M, G or T: 512M, 2.5G)", opt, s);
        return -1;
    }
    *out = (size_t)(v * mul);
    return 0;
}

static int cli_parse_kernel(const char *cmd, const char *s, supermat_kernel *out) {
    if (!strcmp(s, "auto")) *out = SUPERMAT_KERNEL_AUTO;
    else if (!strcmp(s, "scalar")) *out = SUPERMAT_KERNEL_SCALAR;
    else if (!strcmp(s, "avx2")) *out = SUPERMAT_KERNEL_AVX2;
    else if (!strcmp(s, "avx512")) *out = SUPERMAT_KERNEL_AVX512;
    else if (!strcmp(s, "neon")) *out = SUPERMAT_KERNEL_NEON;
    else if (!strcmp(s, "amx")) *out = SUPERMAT_KERNEL_AMX;
    else { cli_usage_error(cmd, "--kernel: '%s' is not auto, scalar, avx2, avx512, neon or amx", s); return -1; }
    return 0;
}

/* "albedo,metallic" (or "all") -> SUPERMAT_OUTPUT_* bits; 0 = an empty list; -1 and the unknown name
   (*bad, *badn) */
static int cli_outputs_bits(const char *s, unsigned *out, const char **bad, size_t *badn) {
    unsigned bits = 0;
    const char *p = s;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t n = e ? (size_t)(e - p) : strlen(p);
        if (n == 6 && !strncmp(p, "albedo", 6)) bits |= SUPERMAT_OUTPUT_ALBEDO;
        else if (n == 9 && !strncmp(p, "roughness", 9)) bits |= SUPERMAT_OUTPUT_ROUGHNESS;
        else if (n == 8 && !strncmp(p, "metallic", 8)) bits |= SUPERMAT_OUTPUT_METALLIC;
        else if (n == 3 && !strncmp(p, "all", 3)) bits |= SUPERMAT_OUTPUT_ALL;
        else if (n != 0) { *bad = p; *badn = n; return -1; }
        p += n;
        if (*p == ',') p++;
    }
    *out = bits;
    return 0;
}
static int cli_parse_outputs(const char *cmd, const char *s, unsigned *out) {
    const char *bad = NULL;
    size_t n = 0;
    if (cli_outputs_bits(s, out, &bad, &n)) { cli_usage_error(cmd, "--outputs: unknown output '%.*s' (albedo, roughness, metallic)", (int)n, bad); return -1; }
    if (!*out) { cli_usage_error(cmd, "--outputs: empty list"); return -1; }
    return 0;
}

/* "512" or "640x480" */
static int cli_parse_size(const char *cmd, const char *s, int *w, int *h) {
    char *end;
    long a, b;
    int bad;
    errno = 0;
    a = strtol(s, &end, 10);
    b = a;
    bad = end == s;
    if (!bad && (*end == 'x' || *end == 'X')) {
        const char *t = end + 1;
        b = strtol(t, &end, 10);
        bad = end == t;
    }
    if (bad || errno || *end || a < 8 || b < 8 || a > 16384 || b > 16384 || a % 8 || b % 8) {
        cli_usage_error(cmd, "--size: '%s' is not S or WxH with multiples of 8 in [8, 16384]", s);
        return -1;
    }
    *w = (int)a; *h = (int)b;
    return 0;
}
