/* cli/args.c - option parsing, the usage texts of every command.
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

static const char cli_usage_bench[] =
    "usage: supermat bench [--model FILE] [options]\n"
    "       supermat bench [--model FILE] --image IMAGE [--modes all|LIST] [--json FILE] [options]\n"
    "\n"
    "Without --image, measures in one run: (a) this machine's FMA peak on every thread (AVX2, or\n"
    "AVX-512 where the AVX-512 kernel runs) and, with --compute bf16 / int8, the peak of the instruction\n"
    "those GEMMs multiply with (vdpbf16ps, vpdpbusd: the % dot column; CPUs differ more here); (b) the\n"
    "full pipeline on synthetic input, seconds / GFLOP / GFLOP/s / % of the peak per stage (VAE encode,\n"
    "UNet trunk, each branch tail, each VAE decode), model creation time and peak memory; (c) one 3x3\n"
    "convolution GEMM (M=4096, K=9*320, N=320, the first UNet level at 512x512) with the AVX2 and\n"
    "the scalar micro-kernel, and their ratio.\n"
    "\n"
    "Every model kind: supermat (one RGBA image), supermat-mv (--views RGBA views with cameras on a\n"
    "circle around the object) and uv-refine (a UV map, its mask and position map).\n"
    "\n"
    "options:\n"
    "  --model FILE      a model file made by `supermat convert` (default: the default model,\n"
    "                    see DEFAULT MODEL at the end)\n"
    "  --size S          image size: S (square) or WxH, multiples of 8 (default 512)\n"
    "  --views N         supermat-mv: views processed together, 1 to 64 (default 6)\n"
    "  --threads N       threads (default 0 = all cores)\n"
    "  --repeats R       pipeline runs; the fastest is reported (default 1)\n"
    "  --pipeline-only   skip (a) and (c): no FMA peak (no % of peak), no GEMM comparison\n"
    "  --outputs LIST    comma list of albedo,roughness,metallic (default: all three; uv-refine\n"
    "                    makes its one refined map)\n"
    "  --kernel K        auto | scalar | avx2 | avx512 | neon | amx: the pipeline's kernels (default auto)\n"
    "  --weights W       default | f32 | f16 | bf16 | int8: GEMM weight storage (default: as the file stores it)\n"
    "  --compute C       f32 | bf16 | int8: what the GEMMs multiply (bf16: AVX512_BF16 CPUs, int8:\n"
    "                    AVX512_VNNI or AVX-VNNI CPUs; default f32)\n"
    "  --conv C          direct | winograd-f2 | winograd-f4: how 3x3 convolutions run (default direct;\n"
    "                    Winograd: fewer multiplies, maps within ~1e-4 of direct; docs/levers.md)\n"
    "  --json FILE       also write the numbers as JSON\n";

/* (the rest of `bench --help`: one string literal would be longer than C99 promises) */
static const char cli_usage_bench_image[] =
    "\n"
    "SPEED / ACCURACY TABLE (--image)\n"
    "With --image, runs each selected mode (a speed or memory lever) on that real input and prints one\n"
    "row per mode: seconds (supermat_run only, best of --repeats; model and session creation are not\n"
    "timed), speed-up over the f32 mode, peak MiB (the model's memory + the session's planned arena),\n"
    "the FLOPs the run performed and GFLOP/s, and per map (albedo, roughness, metallic; uv-refine: the\n"
    "refined map) against the f32 mode's float outputs: psnr = 10 log10(1 / MSE) in dB over all\n"
    "pixels and channels (200 = identical, the cap), psnr_fg the same over the foreground pixels only\n"
    "(input alpha > 0; uv-refine: mask > 0.5), and max_abs, the largest absolute difference (maps in\n"
    "[0, 1]). A map a mode does not compute is shown as - (null in JSON).\n"
    "  supermat      --image IMAGE (RGBA, straight alpha)\n"
    "  supermat-mv   --image VIEW once per view with --cameras meta.json (as `supermat views` matches\n"
    "                them), or one --image and no cameras: that image as every one of --views N views\n"
    "                (default 6) with cameras on a circle\n"
    "  uv-refine     --image MAP --mask MASK --position POS\n"
    "Images are not resized: width and height must be multiples of 8.\n"
    "\n"
    ;
static const char cli_usage_bench_modes[] =
    "modes (--modes all: every mode that applies to the model; or a comma list; f32, the reference,\n"
    "always runs first):\n"
    "  f32                 f32 weights, direct convolutions, the official computation (the reference)\n"
    "  f16, bf16, int8     the GEMM weights stored as f16 / bf16 / int8 (a model of its own)\n"
    "  winograd_f2, winograd_f4\n"
    "                      3x3 convolutions by Winograd F(2x2,3x3) / F(4x4,3x3) (a model of its own)\n"
    "  tiled_vae           the VAE in 2x2 tiles: vae_tile ((S/8 + 4) / 2) * 8, overlap 32, where\n"
    "                      S = max(width, height) (272 at 512)\n"
    "  foreground          vae_tile S/4 + 16 rounded up to a multiple of 8 (144 at 512), overlap 16,\n"
    "                      background tiles not decoded (skip_background)\n"
    "  branch_albedo       supermat, supermat-mv: the albedo map only\n"
    "  branch_rm           supermat, supermat-mv: the roughness and metallic maps only\n"
    "  res256, res384      supermat, supermat-mv: the network at 256 / 384 pixels on the longer side\n"
    "                      (work_width x work_height, proportional, multiples of 8), maps resampled\n"
    "                      back; skipped when the image is not larger\n"
    "  res512, res768      uv-refine: the same at 512 / 768\n"
    "  mv_window_own       supermat-mv: highest-resolution attention within each view only\n"
    "  mv_window_stride4   supermat-mv: own view + every 4th key of the other views\n"
    "  bf16_compute        bf16 x bf16 products in the GEMMs with vdpbf16ps (AVX512_BF16; skipped\n"
    "                      without it)\n"
    "  kernel_avx2         the AVX2 micro-kernel where f32 runs the AVX-512 one (same bits; skipped\n"
    "                      without AVX-512)\n"
    "  bf16_amx            bf16 compute on AMX tiles (skipped without AMX-BF16)\n"
    "  bf16_amx_wf4        bf16_amx with Winograd F4 (f32) for the 3x3 convolutions\n"
    "  int8_compute        int8 x int8 products in the GEMMs with vpdpbusd, activations quantized per\n"
    "                      row per 64 of K (AVX512_VNNI on the AVX-512 kernel, else AVX-VNNI on the AVX2\n"
    "                      kernel; skipped with neither)\n"
    "  int8_compute_wf4    int8_compute with Winograd F4 (f32) for the 3x3 convolutions\n"
    "  int8_compute_avx2   int8_compute on the AVX2 kernel with AVX-VNNI (256-bit vpdpbusd, the same bits;\n"
    "                      only beside AVX512_VNNI: skipped where int8_compute already runs it or without)\n"
    "\n"
    "options with --image (besides --model, --threads, --repeats, --kernel, --views above):\n"
    "  --image FILE      the input (see above; repeated for the views of a supermat-mv model)\n"
    "  --mask FILE       uv-refine: the mask (8-bit gray; colour is converted)\n"
    "  --position FILE   uv-refine: the position map\n"
    "  --cameras FILE    supermat-mv: the meta.json with the views' cameras\n"
    "  --modes LIST      all, or a comma list of the modes above (default all)\n"
    "  --json FILE       also write the table as a JSON list, one object per mode:\n"
    "                    {\"mode\", \"seconds\", \"speedup\", \"peak_bytes\", \"flops\", \"fma_peak_gflops\",\n"
    "                    \"fraction_of_peak\" (FLOPs performed / s / the FMA peak measured first), \"psnr\": {\"albedo\",\n"
    "                    \"roughness\", \"metallic\"}, \"psnr_fg\": {...}, \"max_abs\": {...}, \"gt_psnr\": {...}}\n"
    "                    (uv-refine: the key \"refined\"); skipped and failed modes are left out\n"
    "--size, --outputs, --weights and --pipeline-only do not apply with --image. A mode that fails is\n"
    "reported and the others still run; the exit status is then 1.\n";

/* (and the rest of it) */
static const char cli_usage_bench_truth[] =
    "\n"
    "AGAINST GROUND TRUTH (a supermat model, one --image)\n"
    "  --truth-albedo FILE     the true albedo: an 8-bit sRGB RGB PNG (an alpha channel is ignored)\n"
    "  --truth-roughness FILE  the true roughness: an 8-bit gray PNG (an alpha channel is ignored)\n"
    "  --truth-metallic FILE   the true metallic: an 8-bit gray PNG (an alpha channel is ignored)\n"
    "Any subset; each the size of the image. Every mode (f32 included) adds a gt_psnr column per map:\n"
    "its maps quantised to 8 bits exactly as `supermat image` writes its PNGs, against the truth over\n"
    "the object's pixels (input alpha >= 128): MSE over those pixels and the map's channels of the\n"
    "8-bit values / 255, gt_psnr = 10 log10(1 / MSE) dB, capped at 200 (identical). The res* modes\n"
    "are measured on their maps resampled back to the image size. JSON: \"gt_psnr\": {\"albedo\",\n"
    "\"roughness\", \"metallic\"}, null where no truth was given or the mode does not compute the map.\n"
    "A truth file that cannot be read, is not of the image's size, is 16-bit or has the wrong colour\n"
    "type (albedo: colour; roughness, metallic: gray), or an image without object pixels, is an error\n"
    "(exit status 1) before anything runs.\n";

/* Matches argv[*i] against `--name value` or `--name=value`. Returns 1 and *val on a match, 0 if
   argv[*i] is another argument, -1 (after a usage message) if the value is missing. */
static int cli_opt(const char *cmd, int argc, char **argv, int *i, const char *name, const char **val) {
    const char *a = argv[*i];
    size_t n = strlen(name);
    if (strncmp(a, name, n) != 0) return 0;
    if (a[n] == '=') { *val = a + n + 1; return 1; }
    if (a[n] != 0) return 0;
    if (*i + 1 >= argc) { cli_usage_error(cmd, "option '%s' needs a value", name); return -1; }
    *val = argv[++*i];
    return 1;
}

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
} cli_levers;
static void cli_levers_init(cli_levers *lv) {
    memset(lv, 0, sizeof *lv);
    lv->weights = SUPERMAT_WEIGHTS_DEFAULT;
    lv->compute = SUPERMAT_COMPUTE_F32;
    lv->conv = SUPERMAT_CONV_DIRECT;
    lv->detail = -1.0f;
    lv->chroma = -1.0f;
}
/* 'off' (0) or a number from 0 to 1 (--detail, --chroma); what: what the number is, for the message */
static int cli_parse_unit(const char *cmd, const char *opt, const char *s, const char *what, float *out) {
    char *end = NULL;
    *out = strcmp(s, "off") ? strtof(s, &end) : 0.0f;
    if (strcmp(s, "off") && (!end || end == s || *end || !(*out >= 0.0f && *out <= 1.0f))) {
        cli_usage_error(cmd, "%s: 'off' or %s from 0 to 1, not '%s'", opt, what, s);
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
