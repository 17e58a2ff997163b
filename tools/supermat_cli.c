/* supermat_cli.c - the `supermat` command-line tool (built as build/supermat)
 *
 *     supermat convert --kind supermat --unet supermat.pth --base stable-diffusion-2-1 --out supermat.safetensors
 *     supermat image --model supermat.safetensors --out maps/ photo.png
 *     supermat image --out maps/ photo.png                       (the default model, see >>model)
 *     supermat views --model supermat_mv.safetensors --cameras meta.json --out maps/ color_000*.png
 *     supermat refine --model uv_refine_bc.safetensors --map uv_bc.png --mask uv_mask.png --position uv_position.png --out maps/
 *     supermat info supermat.safetensors
 *     supermat bench --model supermat.safetensors --size 512
 *     supermat bench --model supermat.safetensors --image photo.png --modes all --json table.json
 *     supermat sheet --out sheet.png --labels input,albedo photo.png,maps/photo_albedo.png
 *
 * One translation unit: it defines SUPERMAT_IMPLEMENTATION (and so may use the header's private
 * `supermat__*` GEMM for the benchmark) and links with tools/sm_convert.c. Images are read and written
 * with stb_image / stb_image_write (Debian: libstb-dev).
 *
 * Build:  gcc -std=c99 -O2 -I. -Itools tools/supermat_cli.c tools/sm_convert.c -o supermat -lm -lpthread
 *
 * Sections (search for the marker):
 *   >>platform   includes, stb, timing, small helpers
 *   >>args       option parsing, usage texts
 *   >>files      reading a whole file, creating directories, PNG / PFM writers (FILE.tmp, then renamed)
 *   >>model      the default model: where a command without --model finds it ($SUPERMAT_MODEL, the
 *                installed data folder, the source tree's models/), one function for every command
 *   >>convert    `supermat convert`
 *   >>image      `supermat image` (and what `views` and `refine` share with it)
 *   >>views      `supermat views`: meta.json cameras, the multi-view run
 *   >>refine     `supermat refine`
 *   >>info       `supermat info`
 *   >>bench      `supermat bench`: FMA peak, the pipeline per stage, AVX2 vs scalar GEMM
 *   >>benchimage `supermat bench --image`: the speed / memory levers (modes) on a real input, a table
 *                of seconds, speed-up, memory, FLOPs and PSNR / max error against the f32 mode, and
 *                with --truth-albedo/-roughness/-metallic the PSNR of every mode against ground truth
 *   >>sheet      `supermat sheet`: a contact sheet of pictures and maps (resampling, a 5x8 bitmap font)
 *   >>main
 *
 * Exit status: 0 ok, 1 runtime error, 2 usage error.
 */

/* >>platform */
#if !defined(_WIN32)
#ifndef _FILE_OFFSET_BITS
#define _FILE_OFFSET_BITS 64
#endif
#if !defined(_POSIX_C_SOURCE) && !defined(__APPLE__)
#define _POSIX_C_SOURCE 200809L
#endif
#endif

#define SUPERMAT_IMPLEMENTATION
#include "supermat.h"
#include "sm_convert.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/mman.h>
#include <sys/types.h>
#include <unistd.h>

/* stb: their warnings are not ours */
#if defined(__GNUC__) || defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpragmas"
#pragma GCC diagnostic ignored "-Wunknown-warning-option"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wcast-qual"
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#pragma GCC diagnostic ignored "-Wzero-as-null-pointer-constant"
#pragma GCC diagnostic ignored "-Wcomma"
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#endif
#define STB_IMAGE_IMPLEMENTATION
#define STBI_FAILURE_USERMSG
#include <stb/stb_image.h>
#ifdef SUPERMAT_CLI_WEBP
#include <webp/decode.h>
#endif
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#if defined(__GNUC__) || defined(__clang__)
#pragma GCC diagnostic pop
#endif

#if defined(__GNUC__) || defined(__clang__)
#define CLI_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define CLI_PRINTF(f, a)
#endif

#define CLI_OK 0
#define CLI_FAIL 1
#define CLI_USAGE 2

static double cli_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static double cli_mib(double bytes) { return bytes / (1024.0 * 1024.0); }

static void cli_error(const char *fmt, ...) CLI_PRINTF(1, 2);
static void cli_error(const char *fmt, ...) {
    va_list ap;
    fputs("supermat: error: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}

/* the library's message, the tensor concerned and the result name */
static void cli_lib_error(const char *what, supermat_result r, const supermat_error *e) {
    const char *msg = e && e->message[0] ? e->message : supermat_result_string(r);
    if (e && e->tensor[0]) cli_error("%s: %s (tensor '%s') [%s]", what, msg, e->tensor, supermat_result_string(r));
    else cli_error("%s: %s [%s]", what, msg, supermat_result_string(r));
}

static const char *cli_kind_name(supermat_model_kind k) {
    switch (k) {
    case SUPERMAT_KIND_SUPERMAT: return "supermat";
    case SUPERMAT_KIND_SUPERMAT_MV: return "supermat-mv";
    case SUPERMAT_KIND_UV_REFINE: return "uv-refine";
    default: return "unknown";
    }
}
static const char *cli_kernel_name(supermat_kernel k) {
    switch (k) {
    case SUPERMAT_KERNEL_SCALAR: return "scalar";
    case SUPERMAT_KERNEL_AVX2: return "avx2";
    default: return "auto";
    }
}
static const char *cli_dtype_name(supermat_dtype d) {
    switch (d) {
    case SUPERMAT_DTYPE_F32: return "F32";
    case SUPERMAT_DTYPE_F16: return "F16";
    case SUPERMAT_DTYPE_BF16: return "BF16";
    case SUPERMAT_DTYPE_I8: return "I8";
    default: return "?";
    }
}
static void cli_outputs_string(unsigned outputs, char *buf, size_t cap) {
    buf[0] = 0;
    if (outputs & SUPERMAT_OUTPUT_ALBEDO) snprintf(buf + strlen(buf), cap - strlen(buf), "albedo");
    if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) snprintf(buf + strlen(buf), cap - strlen(buf), "%sroughness", buf[0] ? "," : "");
    if (outputs & SUPERMAT_OUTPUT_METALLIC) snprintf(buf + strlen(buf), cap - strlen(buf), "%smetallic", buf[0] ? "," : "");
}

/* >>args */
static const char cli_usage_main[] =
    "supermat - SuperMat PBR material estimation on the CPU (albedo, roughness, metallic)\n"
    "\n"
    "usage: supermat COMMAND [OPTIONS] [ARGS]\n"
    "\n"
    "commands:\n"
    "  convert   official checkpoint (.pth) + Stable Diffusion 2.1 folder -> one model file\n"
    "  image     albedo / roughness / metallic maps for images (a supermat model)\n"
    "  views     the same for the views of one object with their cameras (a supermat-mv model)\n"
    "  refine    complete a partial UV texture map (a uv-refine model)\n"
    "  info      describe a model file: architecture, parameters, dtypes, memory\n"
    "  sheet     a contact sheet: rows of pictures and maps side by side in one PNG, with labels\n"
    "  mesh      a textured glTF mesh -> complete albedo + metallicRoughness UV textures (supermat_uv.h)\n"
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
    "before any work on that input), symbolic links included; each file is written as FILE.tmp and\n"
    "renamed (linked) into place when complete, so a failed write leaves the old file or none.\n"
    "  --force                replace existing files (a symbolic link itself, not its target)\n"
    "  --skip-existing        keep existing files and go on (an input whose maps all exist is not run)\n"
    "\n"
    "exit status: 0 ok, 1 runtime error, 2 usage error\n";

static const char cli_usage_convert[] =
    "usage: supermat convert --unet FILE.pth --base DIR --out FILE.safetensors [options]\n"
    "\n"
    "Turns an official SuperMat checkpoint (torch.save format) plus a Stable Diffusion 2.1 folder in\n"
    "diffusers layout (unet/config.json, vae/, text_encoder/, scheduler/) into the one model file that\n"
    "`supermat image` loads. No Python is needed. The output is written to FILE.tmp, then renamed.\n"
    "\n"
    "options:\n"
    "  --kind K          supermat | supermat-mv | uv-refine (default: detected from the checkpoint)\n"
    "  --unet FILE       the official checkpoint, e.g. supermat.pth (required)\n"
    "  --base DIR        the Stable Diffusion 2.1 folder (required)\n"
    "  --out FILE        the model file to write (required)\n"
    "  --dtype D         f32 | f16 | bf16 | int8: convert the weights (f16 / bf16: round to nearest\n"
    "  --precision D     even; int8: the GEMM weights as int8 with a scale per output channel, kernel\n"
    "                    tap and 64 input channels, the rest as stored; loads to the same bits as\n"
    "                    --weights int8 on an f32 file). Default: keep every tensor's stored dtype\n"
    "  --threads N       text encoder threads (default 0 = 2, 1 = none)\n"
    "\n"
    "Progress is printed on stderr when it is a terminal.\n";

static const char cli_usage_image[] =
    "usage: supermat image [--model FILE] --out DIR [options] IMAGE...\n"
    "\n"
    "Runs the single-view SuperMat pipeline (a supermat model) on each image, at the image's own\n"
    "size, and writes\n"
    "  DIR/<stem>_albedo.png       RGB, 8-bit\n"
    "  DIR/<stem>_roughness.png    gray, 8-bit\n"
    "  DIR/<stem>_metallic.png     gray, 8-bit\n"
    "where <stem> is the image's file name without its folder and extension.\n"
    "\n"
    "Images are read with stb_image (PNG, JPEG, BMP, TGA, ...) as 8-bit RGBA with straight alpha\n"
    "(16-bit PNGs at full precision; JPEGs turned upright by their EXIF orientation; WebP is refused);\n"
    "transparent pixels are composited over gray 0.5. Width and height must both be multiples of 8.\n"
    "Images are NOT resized: resize them first if needed (the official scripts use 512x512).\n"
    "\n"
    "options:\n"
    "  --model FILE      a model file made by `supermat convert` (default: the default model,\n"
    "                    see DEFAULT MODEL below)\n"
    "  --out DIR         the output folder, created if missing (required)\n"
    "  --outputs LIST    comma list of albedo,roughness,metallic (default: all three);\n"
    "                    only what is asked for is computed\n"
    "  --float           also write the maps before 8-bit quantisation as PFM files (float32,\n"
    "                    little endian): <stem>_albedo.pfm (PF, RGB), <stem>_roughness.pfm and\n"
    "                    <stem>_metallic.pfm (Pf, gray)\n"
    "  --threads N       threads (default 0 = all cores, 1 = the calling thread only)\n"
    "  --kernel K        auto | scalar | avx2 (default auto: the best this CPU has)\n"
    "  --weights W       default | f32 | f16 | bf16 | int8: GEMM weight storage (default: as the file stores it)\n"
    "\n"
    "Each file is written as FILE.tmp and renamed when complete. Progress (and the default model's\n"
    "path) is printed on stderr when it is a terminal. For a supermat-mv model use `supermat views`,\n"
    "for a uv-refine model `supermat refine`. `supermat sheet` puts inputs and maps side by side.\n";

static const char cli_usage_views[] =
    "usage: supermat views --model FILE --cameras meta.json --out DIR [options] VIEW...\n"
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
    "all have the same size, width and height multiples of 8; they are NOT resized (the official\n"
    "script uses 512x512). 1 to 64 views (the official model is trained on 6 orthogonal views).\n"
    "\n"
    "options:\n"
    "  --model FILE      a supermat-mv model file made by `supermat convert` (required)\n"
    "  --cameras FILE    the meta.json with the views' cameras (required)\n"
    "  --out DIR         the output folder, created if missing (required)\n"
    "  --outputs LIST    comma list of albedo,roughness,metallic (default: all three);\n"
    "                    only what is asked for is computed\n"
    "  --float           also write the maps before 8-bit quantisation as PFM files (float32,\n"
    "                    little endian): <stem>_albedo.pfm (PF, RGB), <stem>_roughness.pfm and\n"
    "                    <stem>_metallic.pfm (Pf, gray)\n"
    "  --threads N       threads (default 0 = all cores, 1 = the calling thread only)\n"
    "  --kernel K        auto | scalar | avx2 (default auto: the best this CPU has)\n"
    "  --weights W       default | f32 | f16 | bf16 | int8: GEMM weight storage (default: as the file stores it)\n"
    "\n"
    "Progress is printed on stderr when it is a terminal.\n";

static const char cli_usage_refine[] =
    "usage: supermat refine --model FILE --map MAP --mask MASK --position POS --out DIR [options]\n"
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
    "All three must have the same size, width and height multiples of 8; they are NOT resized (the\n"
    "official script uses 1024x1024).\n"
    "\n"
    "options:\n"
    "  --model FILE      a uv-refine model file made by `supermat convert` (required)\n"
    "  --map FILE        the partial UV map (required)\n"
    "  --mask FILE       the mask: where the map was observed (required)\n"
    "  --position FILE   the position map (required)\n"
    "  --out DIR         the output folder, created if missing (required)\n"
    "  --float           also write the map before 8-bit quantisation as <stem>_refined.pfm (PF, RGB,\n"
    "                    float32, little endian)\n"
    "  --threads N       threads (default 0 = all cores, 1 = the calling thread only)\n"
    "  --kernel K        auto | scalar | avx2 (default auto: the best this CPU has)\n"
    "  --weights W       default | f32 | f16 | bf16 | int8: GEMM weight storage (default: as the file stores it)\n"
    "\n"
    "Progress is printed on stderr when it is a terminal.\n";

static const char cli_usage_info[] =
    "usage: supermat info [options] [FILE]\n"
    "\n"
    "Prints a model file's kind and architecture (with the camera embedding of a supermat-mv model\n"
    "and the input channels of a uv-refine model), its parameter counts (UNet trunk, per branch,\n"
    "VAE), the tensor dtypes it stores, its size, the memory the loaded model holds and the memory a\n"
    "512x512 session plans (all outputs and albedo only; 6 views for supermat-mv). Without FILE: the\n"
    "default model (below), after a line saying which file that is.\n"
    "\n"
    "options:\n"
    "  --threads N       thread count the session memory is planned for (default 0 = all cores)\n"
    "  --kernel K        auto | scalar | avx2 (default auto)\n"
    "  --weights W       default | f32 | f16 | bf16 | int8: GEMM weight storage (default: as the file stores it)\n";

static const char cli_usage_bench[] =
    "usage: supermat bench [--model FILE] [options]\n"
    "       supermat bench [--model FILE] --image IMAGE [--modes all|LIST] [--json FILE] [options]\n"
    "\n"
    "Without --image, measures in one run: (a) this machine's AVX2 FMA peak on every thread; (b) the\n"
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
    "  --kernel K        auto | scalar | avx2: the pipeline's kernels (default auto)\n"
    "  --weights W       default | f32 | f16 | bf16 | int8: GEMM weight storage (default: as the file stores it)\n"
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

static int cli_usage_error(const char *cmd, const char *fmt, ...) CLI_PRINTF(2, 3);
static int cli_usage_error(const char *cmd, const char *fmt, ...) {
    va_list ap;
    fprintf(stderr, "supermat%s%s: ", cmd ? " " : "", cmd ? cmd : "");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\nTry 'supermat%s%s --help'.\n", cmd ? " " : "", cmd ? cmd : "");
    return CLI_USAGE;
}

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

/* --weights: the storage of the GEMM weights (a speed / accuracy lever, see README) */
static supermat_weights cli_weights = SUPERMAT_WEIGHTS_DEFAULT;
static int cli_parse_weights(const char *cmd, const char *s) {
    if (!strcmp(s, "default")) cli_weights = SUPERMAT_WEIGHTS_DEFAULT;
    else if (!strcmp(s, "f32")) cli_weights = SUPERMAT_WEIGHTS_F32;
    else if (!strcmp(s, "f16")) cli_weights = SUPERMAT_WEIGHTS_F16;
    else if (!strcmp(s, "bf16")) cli_weights = SUPERMAT_WEIGHTS_BF16;
    else if (!strcmp(s, "int8") || !strcmp(s, "i8")) cli_weights = SUPERMAT_WEIGHTS_I8;
    else { cli_usage_error(cmd, "--weights: '%s' is not default, f32, f16, bf16 or int8", s); return -1; }
    return 0;
}

static int cli_parse_kernel(const char *cmd, const char *s, supermat_kernel *out) {
    if (!strcmp(s, "auto")) *out = SUPERMAT_KERNEL_AUTO;
    else if (!strcmp(s, "scalar")) *out = SUPERMAT_KERNEL_SCALAR;
    else if (!strcmp(s, "avx2")) *out = SUPERMAT_KERNEL_AVX2;
    else { cli_usage_error(cmd, "--kernel: '%s' is not auto, scalar or avx2", s); return -1; }
    return 0;
}

static int cli_parse_outputs(const char *cmd, const char *s, unsigned *out) {
    unsigned bits = 0;
    const char *p = s;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t n = e ? (size_t)(e - p) : strlen(p);
        if (n == 6 && !strncmp(p, "albedo", 6)) bits |= SUPERMAT_OUTPUT_ALBEDO;
        else if (n == 9 && !strncmp(p, "roughness", 9)) bits |= SUPERMAT_OUTPUT_ROUGHNESS;
        else if (n == 8 && !strncmp(p, "metallic", 8)) bits |= SUPERMAT_OUTPUT_METALLIC;
        else if (n == 3 && !strncmp(p, "all", 3)) bits |= SUPERMAT_OUTPUT_ALL;
        else if (n != 0) {
            cli_usage_error(cmd, "--outputs: unknown output '%.*s' (albedo, roughness, metallic)", (int)n, p);
            return -1;
        }
        p += n;
        if (*p == ',') p++;
    }
    if (!bits) { cli_usage_error(cmd, "--outputs: empty list"); return -1; }
    *out = bits;
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

/* >>files */
/* Big files (model files) are mapped read-only instead of read: no copy, and no page zeroing for
   gigabytes of buffer; the library only reads them. cli_free_file() releases either kind. */
static struct { void *p; size_t n; } cli_maps[8];
static void cli_free_file(void *p) {
    int i;
    if (!p) return;
    for (i = 0; i < 8; i++)
        if (cli_maps[i].p == p) { munmap(p, cli_maps[i].n); cli_maps[i].p = NULL; return; }
    free(p);
}

/* Reads (or maps) a whole file (64-bit sizes). 0 on success, else prints an error and returns CLI_FAIL. */
static int cli_read_file(const char *path, unsigned char **data, size_t *size) {
    FILE *f = fopen(path, "rb");
    struct stat st;
    unsigned char *buf;
    size_t n, got = 0;
    *data = NULL; *size = 0;
    if (!f) { cli_error("cannot open '%s': %s", path, strerror(errno)); return CLI_FAIL; }
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        cli_error("'%s' is not a regular file", path);
        fclose(f);
        return CLI_FAIL;
    }
    if (st.st_size < 0 || (uint64_t)st.st_size > (uint64_t)(SIZE_MAX - 64)) {
        cli_error("'%s' is too large for this machine's address space", path);
        fclose(f);
        return CLI_FAIL;
    }
    n = (size_t)st.st_size;
    if (n >= ((size_t)1 << 20)) {
        int i;
        for (i = 0; i < 8 && cli_maps[i].p; i++) {}
        if (i < 8) {
            void *m = mmap(NULL, n, PROT_READ, MAP_PRIVATE, fileno(f), 0);
            if (m != MAP_FAILED) {
                cli_maps[i].p = m; cli_maps[i].n = n;
                fclose(f);
                *data = (unsigned char *)m; *size = n;
                return CLI_OK;
            }
        }
    }
    buf = (unsigned char *)malloc(n ? n : 1);
    if (!buf) { cli_error("out of memory reading '%s' (%.1f MiB)", path, cli_mib((double)n)); fclose(f); return CLI_FAIL; }
    while (got < n) {
        size_t chunk = n - got > ((size_t)1 << 30) ? ((size_t)1 << 30) : n - got, r = fread(buf + got, 1, chunk, f);
        if (r == 0) break;
        got += r;
    }
    if (got != n || ferror(f)) {
        cli_error("cannot read '%s': %s", path, ferror(f) ? strerror(errno) : "the file got shorter while reading");
        free(buf);
        fclose(f);
        return CLI_FAIL;
    }
    fclose(f);
    *data = buf; *size = n;
    return CLI_OK;
}

/* mkdir -p */
static int cli_mkdirs(const char *dir) {
    size_t n = strlen(dir), i;
    char *p = (char *)malloc(n + 1);
    struct stat st;
    if (!p) { cli_error("out of memory"); return CLI_FAIL; }
    memcpy(p, dir, n + 1);
    for (i = 1; i <= n; i++) {
        if (p[i] == '/' || p[i] == 0) {
            char c = p[i];
            p[i] = 0;
            if (mkdir(p, 0777) != 0 && errno != EEXIST) {
                cli_error("cannot create folder '%s': %s", p, strerror(errno));
                free(p);
                return CLI_FAIL;
            }
            p[i] = c;
        }
    }
    free(p);
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) { cli_error("'%s' is not a folder", dir); return CLI_FAIL; }
    return CLI_OK;
}

/* malloc'ed "dir/stem suffix" */
static char *cli_join(const char *dir, const char *stem, const char *suffix) {
    size_t a = strlen(dir), b = strlen(stem), c = strlen(suffix);
    char *p = (char *)malloc(a + b + c + 2);
    if (!p) return NULL;
    memcpy(p, dir, a);
    if (a && dir[a - 1] != '/') p[a++] = '/';
    memcpy(p + a, stem, b);
    memcpy(p + a + b, suffix, c + 1);
    return p;
}

/* malloc'ed file name without folder and last extension */
static char *cli_stem(const char *path) {
    const char *b = strrchr(path, '/'), *dot;
    size_t n;
    char *s;
    b = b ? b + 1 : path;
    dot = strrchr(b, '.');
    n = dot && dot != b ? (size_t)(dot - b) : strlen(b);
    s = (char *)malloc(n + 1);
    if (!s) return NULL;
    memcpy(s, b, n);
    s[n] = 0;
    return s;
}

/* The overwrite policy of every output file (main() takes --force / --skip-existing before any command
   sees its options): by default a path that exists -- a file, a symbolic link (live or dangling), anything
   -- and that this run did not write is refused before anything is written, and the final step links
   PATH.tmp to PATH without replacing anything (link(): atomic, so a file that appears meanwhile is not
   clobbered either). --force replaces it (a symbolic link itself is replaced, its target untouched);
   --skip-existing keeps it and goes on. A path this run wrote itself may be written again. */
enum { CLI_POLICY_REFUSE = 0, CLI_POLICY_FORCE, CLI_POLICY_SKIP };
static int cli_policy = CLI_POLICY_REFUSE;
static char **cli_written;
static size_t cli_nwritten, cli_capwritten;
#define CLI_SKIPPED 3 /* cli_out_allowed: keep the existing file (not an exit status) */

static int cli_wrote(const char *path) {
    size_t i;
    for (i = 0; i < cli_nwritten; i++) if (!strcmp(cli_written[i], path)) return 1;
    return 0;
}

static void cli_note_written(const char *path) {
    size_t n = strlen(path) + 1;
    char *c;
    if (cli_wrote(path)) return;
    if (cli_nwritten == cli_capwritten) {
        size_t cap = cli_capwritten ? 2 * cli_capwritten : 64;
        char **w = (char **)realloc(cli_written, cap * sizeof *w);
        if (!w) return; /* only loses the right to rewrite it in this run */
        cli_written = w;
        cli_capwritten = cap;
    }
    if ((c = (char *)malloc(n)) != NULL) { memcpy(c, path, n); cli_written[cli_nwritten++] = c; }
}

/* CLI_OK: write PATH; CLI_SKIPPED: keep it (--skip-existing); CLI_FAIL: refused, with the message */
static int cli_out_allowed(const char *path) {
    struct stat st;
    if (lstat(path, &st) != 0 || cli_wrote(path) || cli_policy == CLI_POLICY_FORCE) return CLI_OK;
    if (cli_policy == CLI_POLICY_SKIP) return CLI_SKIPPED;
    cli_error("'%s' exists%s and was not written by this run: --force replaces it, --skip-existing keeps it",
              path, S_ISLNK(st.st_mode) ? " (a symbolic link)" : S_ISDIR(st.st_mode) ? " (a folder)" : "");
    return CLI_FAIL;
}

/* Output files are written to PATH.tmp and renamed to PATH once complete and closed without error:
   a failed write leaves neither a half-written PATH nor PATH.tmp (and keeps an older PATH as it was). */
typedef struct cli_out {
    FILE *f;
    char *tmp;       /* PATH.tmp */
    const char *path;
    int err;         /* the first errno of a failed write, or -1; 0 while all is well */
    int skip;        /* --skip-existing and PATH exists: nothing is written */
    int replace;     /* PATH may be replaced (--force, or written by this run) */
} cli_out;

static int cli_out_open(cli_out *o, const char *path) {
    size_t n = strlen(path);
    int a;
    memset(o, 0, sizeof *o);
    o->path = path;
    a = cli_out_allowed(path);
    if (a == CLI_FAIL) return CLI_FAIL;
    if (a == CLI_SKIPPED) { o->skip = 1; return CLI_OK; }
    o->replace = cli_policy == CLI_POLICY_FORCE || cli_wrote(path);
    o->tmp = (char *)malloc(n + 5);
    if (!o->tmp) { cli_error("out of memory"); return CLI_FAIL; }
    memcpy(o->tmp, path, n);
    memcpy(o->tmp + n, ".tmp", 5);
    o->f = fopen(o->tmp, "wb");
    if (!o->f) {
        cli_error("cannot write '%s': %s", o->tmp, strerror(errno));
        free(o->tmp);
        o->tmp = NULL;
        return CLI_FAIL;
    }
    return CLI_OK;
}

static void cli_out_write(cli_out *o, const void *data, size_t n) {
    if (o->skip || o->err || !n) return;
    errno = 0;
    if (fwrite(data, 1, n, o->f) != n) o->err = errno ? errno : -1;
}

/* stb_image_write's callback */
static void cli_out_stbi(void *ctx, void *data, int n) {
    if (n > 0) cli_out_write((cli_out *)ctx, data, (size_t)n);
}

/* ok = the caller's part succeeded: closes, then renames PATH.tmp to PATH, or removes PATH.tmp
   (with a message unless the caller failed and has said why) */
static int cli_out_close(cli_out *o, int ok) {
    int rc = CLI_OK, exists = 0;
    if (o->skip) {
        if (ok) fprintf(stderr, "kept '%s' (it exists; --skip-existing)\n", o->path);
        return ok ? CLI_OK : CLI_FAIL;
    }
    if (!o->f) return CLI_FAIL;
    errno = 0;
    if (fflush(o->f) != 0 && !o->err) o->err = errno ? errno : -1;
    errno = 0;
    if (fclose(o->f) != 0 && !o->err) o->err = errno ? errno : -1;
    o->f = NULL;
    errno = 0;
    if (ok && !o->err) {
        if (o->replace) {
            if (rename(o->tmp, o->path) != 0) o->err = errno ? errno : -1;
        } else if (link(o->tmp, o->path) == 0) {
            remove(o->tmp);                    /* PATH is the new file; only the .tmp name goes */
        } else if (errno == EEXIST) {
            exists = 1;                        /* it appeared while we computed */
        } else {                               /* a file system without hard links: check, then rename */
            struct stat st;
            if (lstat(o->path, &st) == 0) exists = 1;
            else if (rename(o->tmp, o->path) != 0) o->err = errno ? errno : -1;
        }
    }
    if (exists) {
        cli_error("'%s' appeared while it was being written, and was not written by this run: kept it (--force replaces it)", o->path);
        remove(o->tmp);
        rc = CLI_FAIL;
    } else if (!ok || o->err) {
        if (ok) cli_error("cannot write '%s': %s", o->path, o->err > 0 ? strerror(o->err) : "write error");
        remove(o->tmp);
        rc = CLI_FAIL;
    } else {
        cli_note_written(o->path);
    }
    free(o->tmp);
    o->tmp = NULL;
    return rc;
}

/* A text output built in memory (open_memstream), then written like every output: the overwrite policy,
   FILE.tmp, rename. cli_mem_open checks the policy first (before the work that fills it). */
typedef struct cli_mem {
    FILE *f;
    char *buf;
    size_t len;
} cli_mem;

static FILE *cli_mem_open(cli_mem *m, const char *path) {
    memset(m, 0, sizeof *m);
    if (cli_out_allowed(path) != CLI_OK) { /* refused; --skip-existing does not apply to a report */
        if (cli_policy == CLI_POLICY_SKIP) cli_error("'%s' exists: --skip-existing keeps files, --force replaces this report", path);
        return NULL;
    }
    m->f = open_memstream(&m->buf, &m->len);
    if (!m->f) cli_error("out of memory");
    return m->f;
}

/* closes the stream m->f (already closed when closed = 1) and writes its bytes to path; ok = 0: discards */
static int cli_mem_commit(cli_mem *m, const char *path, int ok, int closed) {
    int rc = CLI_FAIL;
    cli_out o;
    if (!closed && m->f && fclose(m->f) != 0) ok = 0;
    m->f = NULL;
    if (ok && m->buf && cli_out_open(&o, path) == CLI_OK) {
        cli_out_write(&o, m->buf, m->len);
        rc = cli_out_close(&o, 1);
    }
    free(m->buf);
    m->buf = NULL;
    return rc;
}

/* PFM: "PF" (RGB) or "Pf" (gray), scale -1.0 = little endian, rows bottom to top */
static int cli_write_pfm(const char *path, const float *px, int w, int h, int channels) {
    cli_out o;
    unsigned char *row;
    char hdr[64];
    size_t rn = (size_t)w * (size_t)channels, i;
    int y, n;
    row = (unsigned char *)malloc(rn * 4);
    if (!row) { cli_error("out of memory"); return CLI_FAIL; }
    if (cli_out_open(&o, path) != CLI_OK) { free(row); return CLI_FAIL; }
    n = snprintf(hdr, sizeof hdr, "%s\n%d %d\n-1.0\n", channels == 3 ? "PF" : "Pf", w, h);
    cli_out_write(&o, hdr, (size_t)n);
    for (y = h - 1; y >= 0 && !o.err; y--) {
        const float *src = px + (size_t)y * rn;
        for (i = 0; i < rn; i++) {
            uint32_t u;
            memcpy(&u, &src[i], 4);
            row[4 * i] = (unsigned char)(u & 255u);
            row[4 * i + 1] = (unsigned char)((u >> 8) & 255u);
            row[4 * i + 2] = (unsigned char)((u >> 16) & 255u);
            row[4 * i + 3] = (unsigned char)(u >> 24);
        }
        cli_out_write(&o, row, rn * 4);
    }
    free(row);
    return cli_out_close(&o, 1);
}

/* an 8-bit PNG of w x h pixels of `channels` bytes (1 gray, 3 RGB, 4 RGBA), rows top to bottom */
static int cli_write_png_u8(const char *path, const unsigned char *px, int w, int h, int channels) {
    cli_out o;
    int ok;
    if (cli_out_open(&o, path) != CLI_OK) return CLI_FAIL;
    ok = stbi_write_png_to_func(cli_out_stbi, &o, w, h, channels, px, w * channels);
    if (!ok) cli_error("cannot write '%s': PNG encoding failed (out of memory?)", path);
    return cli_out_close(&o, ok);
}

/* one map value in [0, 1] as the 8-bit PNGs store it, exactly as the library's 8-bit path (rintf(v * 255));
   also what `bench --image` compares with the truth files */
static unsigned char cli_quantize(float v) {
    v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v; /* the library already clamps: a no-op */
    return (unsigned char)rintf(v * 255.0f);
}

/* 8-bit PNG from floats in [0, 1], quantised by cli_quantize() */
static int cli_write_png(const char *path, const float *px, int w, int h, int channels, unsigned char *tmp) {
    size_t n = (size_t)w * (size_t)h * (size_t)channels, i;
    for (i = 0; i < n; i++) tmp[i] = cli_quantize(px[i]);
    return cli_write_png_u8(path, tmp, w, h, channels);
}

/* loads the model file and creates the model; the buffer is borrowed by the model (free it after) */
static int cli_load_model(const char *path, supermat_kernel kernel, unsigned char **buf, size_t *size,
                          supermat_model **model, double *create_seconds) {
    supermat_model_desc md;
    supermat_error err;
    supermat_result r;
    double t0;
    char what[600];
    *model = NULL;
    if (cli_read_file(path, buf, size)) return CLI_FAIL;
    memset(&md, 0, sizeof md);
    md.data = *buf; md.size = *size; md.kernel = kernel; md.weights = cli_weights;
    t0 = cli_now();
    r = supermat_model_create(&md, model, &err);
    if (create_seconds) *create_seconds = cli_now() - t0;
    if (r != SUPERMAT_SUCCESS) {
        snprintf(what, sizeof what, "model '%s'", path);
        cli_lib_error(what, r, &err);
        cli_free_file(*buf); *buf = NULL;
        return CLI_FAIL;
    }
    return CLI_OK;
}

/* the command that runs a model of this kind */
static const char *cli_kind_command(supermat_model_kind k) {
    switch (k) {
    case SUPERMAT_KIND_SUPERMAT: return "`supermat image` (one image at a time)";
    case SUPERMAT_KIND_SUPERMAT_MV: return "`supermat views` (several views of one object with a meta.json of cameras)";
    case SUPERMAT_KIND_UV_REFINE: return "`supermat refine` (a partial UV map with its mask and position map)";
    default: return "none of the commands";
    }
}

/* CLI_OK if the model is of kind `want`, else a message saying which command runs it */
static int cli_require_kind(const char *cmd, const char *path, const supermat_model *model, supermat_model_kind want) {
    supermat_model_info mi;
    memset(&mi, 0, sizeof mi);
    supermat_model_get_info(model, &mi);
    if (mi.kind == want) return CLI_OK;
    cli_error("model '%s' is a %s model, `supermat %s` runs %s models: use %s", path, cli_kind_name(mi.kind), cmd,
              cli_kind_name(want), cli_kind_command(mi.kind));
    return CLI_FAIL;
}

/* Before any work on an input: may its maps be written? CLI_OK, CLI_SKIPPED (--skip-existing and every
   one of them exists: nothing to do for this input) or CLI_FAIL (one exists and would be refused). */
static int cli_maps_allowed(const char *dir, const char *stem, int n, const char *const *suffixes, const int *wanted,
                            int want_float) {
    int k, f, all = 1, any = 0;
    for (k = 0; k < n; k++) {
        if (!wanted[k]) continue;
        for (f = 0; f <= want_float; f++) {
            char suffix[64], *path;
            int a;
            snprintf(suffix, sizeof suffix, "%s.%s", suffixes[k], f ? "pfm" : "png");
            path = cli_join(dir, stem, suffix);
            if (!path) { cli_error("out of memory"); return CLI_FAIL; }
            a = cli_out_allowed(path);
            free(path);
            if (a == CLI_FAIL) return CLI_FAIL;
            any = 1;
            if (a != CLI_SKIPPED) all = 0;
        }
    }
    return any && all ? CLI_SKIPPED : CLI_OK;
}

/* DIR/<stem><suffix>.png for each map that is not NULL (and .pfm with want_float); tmp holds w*h*3 bytes */
static int cli_write_maps(const char *dir, const char *stem, int n, const char *const *suffixes, float *const *maps,
                          const int *channels, int w, int h, int want_float, unsigned char *tmp) {
    int k, rc = CLI_OK;
    for (k = 0; k < n && rc == CLI_OK; k++) {
        char suffix[64], *path;
        if (!maps[k]) continue;
        snprintf(suffix, sizeof suffix, "%s.png", suffixes[k]);
        path = cli_join(dir, stem, suffix);
        if (!path) { cli_error("out of memory"); return CLI_FAIL; }
        rc = cli_write_png(path, maps[k], w, h, channels[k], tmp);
        free(path);
        if (rc == CLI_OK && want_float) {
            snprintf(suffix, sizeof suffix, "%s.pfm", suffixes[k]);
            path = cli_join(dir, stem, suffix);
            if (!path) { cli_error("out of memory"); return CLI_FAIL; }
            rc = cli_write_pfm(path, maps[k], w, h, channels[k]);
            free(path);
        }
    }
    return rc;
}

/* >>inputs: pictures as users have them */
/* Every picture goes through cli_pic_info / cli_load (stb_image underneath):
   - a folder, a missing file: named as such (stb_image says "can't fopen" / "unknown image type");
   - WebP (the official example pictures): decoded by libwebp when the build has it (SUPERMAT_CLI_WEBP:
     CMake finds libwebp-dev), else recognised and refused with what to do;
   - 16-bit PNG: `image` reads it at full precision (cli_accept16: float input, v / 65535, the same sRGB
     encoding); the other commands refuse it instead of cutting it to 8 bits silently;
   - JPEG EXIF orientation (tag 0x0112, 2..8): applied, so the picture is processed upright as viewers
     show it, and sizes are reported after it (5..8 swap width and height). */
static int cli_accept16;

/* the EXIF orientation of a JPEG file (1..8), 1 when absent / not a JPEG / unreadable */
static int cli_exif_orientation(const char *path) {
    unsigned char b[65536 + 4];
    size_t n, pos = 2;
    FILE *f = fopen(path, "rb");
    int o = 1;
    if (!f) return 1;
    n = fread(b, 1, sizeof b, f);
    fclose(f);
    if (n < 4 || b[0] != 0xFF || b[1] != 0xD8) return 1;
    while (pos + 4 <= n && b[pos] == 0xFF) {
        unsigned marker = b[pos + 1];
        size_t len = ((size_t)b[pos + 2] << 8) | b[pos + 3], t;
        if (marker == 0xDA || marker == 0xD9 || len < 2) break;          /* image data: no EXIF before it */
        if (marker == 0xE1 && pos + 4 + len <= n + 2 && len >= 16 && !memcmp(b + pos + 4, "Exif\0\0", 6)) {
            const unsigned char *t0 = b + pos + 10;                      /* TIFF header */
            size_t tl = len - 8, ifd, k, cnt;
            int le = t0[0] == 'I';
#define CLI_RD16(p) (le ? (unsigned)((p)[0] | ((p)[1] << 8)) : (unsigned)(((p)[0] << 8) | (p)[1]))
#define CLI_RD32(p) (le ? ((size_t)(p)[0] | ((size_t)(p)[1] << 8) | ((size_t)(p)[2] << 16) | ((size_t)(p)[3] << 24)) \
                        : (((size_t)(p)[0] << 24) | ((size_t)(p)[1] << 16) | ((size_t)(p)[2] << 8) | (size_t)(p)[3]))
            if ((t0[0] != 'I' && t0[0] != 'M') || t0[1] != t0[0]) break;
            ifd = CLI_RD32(t0 + 4);
            if (ifd + 2 > tl) break;
            cnt = CLI_RD16(t0 + ifd);
            for (k = 0; k < cnt; k++) {
                t = ifd + 2 + 12 * k;
                if (t + 12 > tl) break;
                if (CLI_RD16(t0 + t) == 0x0112) {
                    unsigned v = CLI_RD16(t0 + t + 8);
                    if (v >= 1 && v <= 8) o = (int)v;
                    break;
                }
            }
#undef CLI_RD16
#undef CLI_RD32
            break;
        }
        pos += 2 + len;
    }
    return o;
}

/* the same pixels turned upright for EXIF orientation o (2..8); a new buffer, or NULL (out of memory) */
static unsigned char *cli_orient(const unsigned char *px, int w, int h, int ch, int o, int *ow, int *oh) {
    int tw = o >= 5 ? h : w, th = o >= 5 ? w : h, x, y;
    unsigned char *out = (unsigned char *)malloc((size_t)tw * th * ch);
    if (!out) return NULL;
    for (y = 0; y < th; y++)
        for (x = 0; x < tw; x++) {
            int sx, sy; /* the stored pixel shown at (x, y) */
            switch (o) {
            case 2: sx = w - 1 - x; sy = y; break;                 /* mirrored */
            case 3: sx = w - 1 - x; sy = h - 1 - y; break;         /* 180 */
            case 4: sx = x; sy = h - 1 - y; break;                 /* mirrored vertically */
            case 5: sx = y; sy = x; break;                         /* transposed */
            case 6: sx = y; sy = h - 1 - x; break;                 /* 90 clockwise to view */
            case 7: sx = w - 1 - y; sy = h - 1 - x; break;         /* transverse */
            case 8: sx = w - 1 - y; sy = x; break;                 /* 90 counter-clockwise to view */
            default: sx = x; sy = y; break;
            }
            memcpy(out + ((size_t)y * tw + x) * ch, px + ((size_t)sy * w + sx) * ch, (size_t)ch);
        }
    *ow = tw;
    *oh = th;
    return out;
}

static int cli_is_webp(const char *path) {
    unsigned char b[12];
    FILE *f = fopen(path, "rb");
    size_t n = f ? fread(b, 1, sizeof b, f) : 0;
    if (f) fclose(f);
    return n == 12 && !memcmp(b, "RIFF", 4) && !memcmp(b + 8, "WEBP", 4);
}

#ifdef SUPERMAT_CLI_WEBP
/* a WebP file as `want` channels (0 = 4), like stbi_load (1 gray, 2 gray + alpha, 3 RGB, 4 RGBA; gray as
   stb computes it); *c = 4 (3 without alpha). NULL and a message when it cannot be decoded. */
static unsigned char *cli_load_webp(const char *path, int *w, int *h, int *c, int want) {
    unsigned char *data = NULL, *rgba, *out;
    size_t size = 0, n, i;
    WebPBitstreamFeatures ft;
    int k;
    if (cli_read_file(path, &data, &size)) return NULL;
    if (WebPGetFeatures(data, size, &ft) != VP8_STATUS_OK || !(rgba = WebPDecodeRGBA(data, size, w, h))) {
        cli_free_file(data);
        cli_error("cannot decode the WebP picture '%s' (libwebp)", path);
        return NULL;
    }
    cli_free_file(data);
    *c = ft.has_alpha ? 4 : 3;
    k = want ? want : 4;
    n = (size_t)*w * (size_t)*h;
    out = (unsigned char *)malloc(n * (size_t)k);
    if (out)
        for (i = 0; i < n; i++) {
            const unsigned char *p = rgba + 4 * i;
            unsigned char *q = out + (size_t)k * i;
            if (k >= 3) { q[0] = p[0]; q[1] = p[1]; q[2] = p[2]; if (k == 4) q[3] = p[3]; }
            else { q[0] = (unsigned char)((p[0] * 77 + p[1] * 150 + 29 * p[2]) >> 8); if (k == 2) q[1] = p[3]; }
        }
    WebPFree(rgba);
    if (!out) cli_error("out of memory decoding '%s'", path);
    return out;
}
#endif

/* stbi_info with the cases above; 0 (and the message, with `what`) when it cannot be read */
static int cli_pic_info(const char *path, const char *what, int *w, int *h, int *c) {
    struct stat st;
    if (stat(path, &st) != 0) { cli_error("cannot read %s '%s': %s", what, path, strerror(errno)); return 0; }
    if (S_ISDIR(st.st_mode)) { cli_error("%s '%s' is a folder: give the picture files (e.g. '%s/*.png')", what, path, path); return 0; }
    if (cli_is_webp(path)) {
#ifdef SUPERMAT_CLI_WEBP
        unsigned char *data = NULL;
        size_t size = 0;
        WebPBitstreamFeatures ft;
        int ok;
        if (cli_read_file(path, &data, &size)) return 0;
        ok = WebPGetFeatures(data, size, &ft) == VP8_STATUS_OK;
        cli_free_file(data);
        if (!ok) { cli_error("cannot read %s '%s': not a valid WebP file (libwebp)", what, path); return 0; }
        *w = ft.width; *h = ft.height; *c = ft.has_alpha ? 4 : 3;
        return 1;
#else
        cli_error("%s '%s' is WebP, which this build does not read (built without libwebp-dev): convert it to PNG first (e.g. `dwebp '%s' -o picture.png`, Debian's webp package) or rebuild with libwebp-dev", what, path, path);
        return 0;
#endif
    }
    if (!stbi_info(path, w, h, c)) {
        cli_error("cannot read %s '%s': %s", what, path, stbi_failure_reason());
        return 0;
    }
    if (stbi_is_16_bit(path) && !cli_accept16) {
        cli_error("%s '%s' has 16 bits per channel, which this command does not read (it would lose 8 of them): "
                  "give an 8-bit PNG (`supermat image` reads 16-bit pictures)", what, path);
        return 0;
    }
    if (cli_exif_orientation(path) >= 5) { int t = *w; *w = *h; *h = t; }
    return 1;
}

/* a 16-bit picture as RGBA floats v / 65535 (same encoding as 8-bit: sRGB, straight alpha), upright;
   free with free() */
static float *cli_load16f(const char *path, int *w, int *h) {
    int c = 0;
    unsigned short *p = stbi_load_16(path, w, h, &c, 4);
    float *f;
    size_t n, i;
    if (!p) return NULL;
    n = (size_t)*w * (size_t)*h * 4;
    f = (float *)malloc(n * sizeof *f);
    if (f) for (i = 0; i < n; i++) f[i] = (float)p[i] / 65535.0f;
    stbi_image_free(p);
    return f;
}

/* stbi_load, turned upright by the EXIF orientation (JPEG); free with stbi_image_free */
static unsigned char *cli_load(const char *path, int *w, int *h, int *c, int want) {
    unsigned char *px;
#ifdef SUPERMAT_CLI_WEBP
    if (cli_is_webp(path)) return cli_load_webp(path, w, h, c, want);
#endif
    px = stbi_load(path, w, h, c, want);
    int o = px ? cli_exif_orientation(path) : 1;
    if (px && o > 1) {
        int ow, oh;
        unsigned char *up = cli_orient(px, *w, *h, want ? want : *c, o, &ow, &oh);
        if (!up) { stbi_image_free(px); return NULL; }
        /* stbi_image_free is free() (Debian's libstb uses the default allocator) */
        stbi_image_free(px);
        px = up;
        *w = ow;
        *h = oh;
    }
    return px;
}

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
    printf("`supermat info` without a FILE shows the default model.\n");
}

static int cli_is_file(const char *path) {
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
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

/* >>convert */
static int cli_convert(int argc, char **argv) {
    const char *cmd = "convert", *v;
    sm_convert_desc d;
    char err[1024];
    int i, m, r;
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
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--base", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            d.base_dir = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--out", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            d.output = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--dtype", &v)) != 0 || (m = cli_opt(cmd, argc, argv, &i, "--precision", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            if (!strcmp(v, "f32")) d.dtype = SUPERMAT_DTYPE_F32;
            else if (!strcmp(v, "f16")) d.dtype = SUPERMAT_DTYPE_F16;
            else if (!strcmp(v, "bf16")) d.dtype = SUPERMAT_DTYPE_BF16;
            else if (!strcmp(v, "int8") || !strcmp(v, "i8")) d.dtype = SUPERMAT_DTYPE_I8;
            else return cli_usage_error(cmd, "--dtype/--precision: '%s' is not f32, f16, bf16 or int8", v);
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 1024, &d.threads)) return CLI_USAGE;
        } else if (a[0] == '-') {
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            return cli_usage_error(cmd, "unexpected argument '%s'", a);
        }
    }
    if (!d.checkpoint) return cli_usage_error(cmd, "--unet FILE.pth is required");
    if (!d.base_dir) return cli_usage_error(cmd, "--base DIR is required");
    if (!d.output) return cli_usage_error(cmd, "--out FILE is required");
    d.progress = isatty(2);
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
    if (stat(d.output, &st) == 0) printf("wrote %s (%.1f MiB)\n", d.output, cli_mib((double)st.st_size));
    return CLI_OK;
}

/* >>image */
typedef struct cli_progress {
    const char *name;
    int pct;
    char what[32];
    int shown;
} cli_progress;

static int cli_progress_cb(void *user, float fraction, const char *what) {
    cli_progress *p = (cli_progress *)user;
    int pct = (int)(fraction * 100.0f);
    if (pct < 0) pct = 0;
    if (pct > 100) pct = 100;
    if (!what) what = "";
    if (p->shown && pct == p->pct && !strncmp(what, p->what, sizeof p->what - 1)) return 0;
    p->pct = pct;
    snprintf(p->what, sizeof p->what, "%s", what);
    fprintf(stderr, "\r%s %3d%% %-16s", p->name, pct, p->what);
    fflush(stderr);
    p->shown = 1;
    return 0;
}

static const char *const cli_map_suffixes[3] = {"_albedo", "_roughness", "_metallic"};
static const int cli_map_channels[3] = {3, 1, 1};

/* the output stems of n inputs; two inputs with one stem would overwrite each other's maps (a usage
   error). *stems is allocated (free with cli_free_stems) even on error. */
static int cli_make_stems(const char *cmd, const char *const *inputs, int n, char ***stems) {
    int i, j;
    *stems = (char **)calloc((size_t)(n > 0 ? n : 1), sizeof(char *));
    if (!*stems) { cli_error("out of memory"); return CLI_FAIL; }
    for (i = 0; i < n; i++) {
        char *s = (*stems)[i] = cli_stem(inputs[i]);
        if (!s) { cli_error("out of memory"); return CLI_FAIL; }
        if (!s[0]) return cli_usage_error(cmd, "'%s' has no file name", inputs[i]);
        for (j = 0; j < i; j++)
            if (!strcmp(s, (*stems)[j])) return cli_usage_error(cmd, "'%s' and '%s' would write the same files (%s_*)", inputs[j], inputs[i], s);
    }
    return CLI_OK;
}
static void cli_free_stems(char **stems, int n) {
    int i;
    if (stems) for (i = 0; i < n; i++) free(stems[i]);
    free(stems);
}

typedef struct cli_session_slot { int w, h; supermat_session *s; } cli_session_slot;

static int cli_image(int argc, char **argv) {
    const char *cmd = "image", *v, *model_arg = NULL, *model_path = NULL, *out_dir = NULL;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    int want_float = 0, threads = 0, i, m, nimg = 0, rc = CLI_OK, tty = isatty(2);
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    const char **imgs;
    char **stems = NULL;
    unsigned char *file = NULL;
    size_t file_size = 0;
    supermat_model *model = NULL;
    cli_session_slot *slots = NULL;
    int nslots = 0;
    cli_model_ref mref;

    imgs = (const char **)malloc(sizeof(char *) * (size_t)(argc > 0 ? argc : 1));
    if (!imgs) { cli_error("out of memory"); return CLI_FAIL; }
    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_image, stdout); cli_print_default_model_help(); free(imgs); return CLI_OK; }
        if (!strcmp(a, "--")) { for (i++; i < argc; i++) imgs[nimg++] = argv[i]; break; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--model", &v)) != 0) {
            if (m < 0) { free(imgs); return CLI_USAGE; }
            model_arg = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--out", &v)) != 0) {
            if (m < 0) { free(imgs); return CLI_USAGE; }
            out_dir = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--outputs", &v)) != 0) {
            if (m < 0 || cli_parse_outputs(cmd, v, &outputs)) { free(imgs); return CLI_USAGE; }
        } else if (!strcmp(a, "--float")) {
            want_float = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 1024, &threads)) { free(imgs); return CLI_USAGE; }
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--kernel", &v)) != 0) {
            if (m < 0 || cli_parse_kernel(cmd, v, &kernel)) { free(imgs); return CLI_USAGE; }
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0) {
            if (m < 0 || cli_parse_weights(cmd, v)) { free(imgs); return CLI_USAGE; }
        } else if (a[0] == '-' && a[1]) {
            free(imgs);
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            imgs[nimg++] = a;
        }
    }
    if (!out_dir) { free(imgs); return cli_usage_error(cmd, "--out DIR is required"); }
    if (!nimg) { free(imgs); return cli_usage_error(cmd, "no input image"); }

    rc = cli_make_stems(cmd, imgs, nimg, &stems);
    if (rc == CLI_OK) rc = cli_model_path(cmd, model_arg, 1, &mref);
    if (rc == CLI_OK) {
        model_path = mref.path;
        if (tty && !model_arg) fprintf(stderr, "model %s (the default model: %s)\n", model_path, mref.from);
    }
    /* check every image before the (slow) model load */
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        int w, h, c;
        if (!cli_pic_info(imgs[i], "image", &w, &h, &c)) { rc = CLI_FAIL; break; }
        if (w % 8 || h % 8) {
            cli_error("image '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                      "resize it first, e.g. to 512x512)", imgs[i], w, h);
            rc = CLI_FAIL;
            break;
        }
    }
    if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &file, &file_size, &model, NULL);
    if (rc == CLI_OK) rc = cli_require_kind(cmd, model_path, model, SUPERMAT_KIND_SUPERMAT);
    if (rc == CLI_OK) rc = cli_mkdirs(out_dir);
    if (rc == CLI_OK) {
        slots = (cli_session_slot *)calloc((size_t)nimg, sizeof *slots);
        if (!slots) { cli_error("out of memory"); rc = CLI_FAIL; }
    }

    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        int w = 0, h = 0, c = 0, s;
        unsigned char *px = NULL;
        float *fa = NULL, *fr = NULL, *fm = NULL, *fin = NULL;
        unsigned char *tmp = NULL;
        supermat_session *sess = NULL;
        supermat_run_desc rd;
        supermat_error err;
        supermat_result r;
        cli_progress prog;
        double t0 = cli_now();
        size_t np;
        {
            int wanted[3], a;
            wanted[0] = (outputs & SUPERMAT_OUTPUT_ALBEDO) != 0;
            wanted[1] = (outputs & SUPERMAT_OUTPUT_ROUGHNESS) != 0;
            wanted[2] = (outputs & SUPERMAT_OUTPUT_METALLIC) != 0;
            a = cli_maps_allowed(out_dir, stems[i], 3, cli_map_suffixes, wanted, want_float);
            if (a == CLI_FAIL) { rc = CLI_FAIL; break; }
            if (a == CLI_SKIPPED) { fprintf(stderr, "kept the maps of '%s' (they exist; --skip-existing)\n", imgs[i]); continue; }
        }
        if (stbi_is_16_bit(imgs[i])) fin = cli_load16f(imgs[i], &w, &h);   /* full precision, float input */
        else px = cli_load(imgs[i], &w, &h, &c, 4);
        if (!px && !fin) { cli_error("cannot read image '%s': %s", imgs[i], stbi_failure_reason()); rc = CLI_FAIL; break; }
        if (w % 8 || h % 8) {
            cli_error("image '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize)", imgs[i], w, h);
            stbi_image_free(px); free(fin);
            rc = CLI_FAIL;
            break;
        }
        for (s = 0; s < nslots; s++) if (slots[s].w == w && slots[s].h == h) sess = slots[s].s;
        if (!sess) {
            supermat_session_desc sd;
            memset(&sd, 0, sizeof sd);
            sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.threads = threads;
            r = supermat_session_create(&sd, &sess, &err);
            if (r != SUPERMAT_SUCCESS) {
                char what[600];
                snprintf(what, sizeof what, "session for '%s' (%dx%d)", imgs[i], w, h);
                cli_lib_error(what, r, &err);
                stbi_image_free(px); free(fin);
                rc = CLI_FAIL;
                break;
            }
            slots[nslots].w = w; slots[nslots].h = h; slots[nslots].s = sess; nslots++;
        }
        np = (size_t)w * (size_t)h;
        if (outputs & SUPERMAT_OUTPUT_ALBEDO) fa = (float *)malloc(np * 3 * sizeof(float));
        if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) fr = (float *)malloc(np * sizeof(float));
        if (outputs & SUPERMAT_OUTPUT_METALLIC) fm = (float *)malloc(np * sizeof(float));
        tmp = (unsigned char *)malloc(np * 3);
        if (!tmp || ((outputs & SUPERMAT_OUTPUT_ALBEDO) && !fa) || ((outputs & SUPERMAT_OUTPUT_ROUGHNESS) && !fr) ||
            ((outputs & SUPERMAT_OUTPUT_METALLIC) && !fm)) {
            cli_error("out of memory for the maps of '%s'", imgs[i]);
            rc = CLI_FAIL;
        }
        if (rc == CLI_OK) {
            memset(&rd, 0, sizeof rd);
            rd.input.pixels = fin ? (void *)fin : (void *)px; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
            rd.input.format = fin ? SUPERMAT_FORMAT_F32 : SUPERMAT_FORMAT_U8;
            rd.albedo.pixels = fa; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
            rd.roughness.pixels = fr; rd.roughness.channels = 1; rd.roughness.format = SUPERMAT_FORMAT_F32;
            rd.metallic.pixels = fm; rd.metallic.channels = 1; rd.metallic.format = SUPERMAT_FORMAT_F32;
            memset(&prog, 0, sizeof prog);
            prog.name = imgs[i];
            if (tty) { rd.progress = cli_progress_cb; rd.progress_user = &prog; }
            r = supermat_run(sess, &rd, &err);
            if (tty && prog.shown) {
                if (r == SUPERMAT_SUCCESS) fprintf(stderr, "\r%s 100%% done (%.2f s)%*s\n", imgs[i], cli_now() - t0, 8, "");
                else fputc('\n', stderr);
            }
            if (r != SUPERMAT_SUCCESS) {
                char what[600];
                snprintf(what, sizeof what, "'%s'", imgs[i]);
                cli_lib_error(what, r, &err);
                rc = CLI_FAIL;
            }
        }
        if (rc == CLI_OK) {
            float *maps[3];
            maps[0] = fa; maps[1] = fr; maps[2] = fm;
            rc = cli_write_maps(out_dir, stems[i], 3, cli_map_suffixes, maps, cli_map_channels, w, h, want_float, tmp);
        }
        free(fa); free(fr); free(fm); free(tmp);
        stbi_image_free(px); free(fin);
    }

    for (i = 0; i < nslots; i++) supermat_session_destroy(slots[i].s);
    free(slots);
    supermat_model_destroy(model);
    cli_free_file(file);
    cli_free_stems(stems, nimg);
    free(imgs);
    return rc;
}

/* >>views */
#define CLI_MAX_VIEWS 64
#define CLI_MAX_INDEX 999999999L

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

static int cli_views(int argc, char **argv) {
    const char *cmd = "views", *v, *model_arg = NULL, *model_path, *cam_path = NULL, *out_dir = NULL;
    cli_model_ref mref;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    int want_float = 0, threads = 0, i, m, nimg = 0, rc = CLI_OK, tty = isatty(2), w = 0, h = 0, ncam = 0;
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

    imgs = (const char **)malloc(sizeof(char *) * (size_t)(argc > 0 ? argc : 1));
    if (!imgs) { cli_error("out of memory"); return CLI_FAIL; }
    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_views, stdout); free(imgs); return CLI_OK; }
        if (!strcmp(a, "--")) { for (i++; i < argc; i++) imgs[nimg++] = argv[i]; break; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--model", &v)) != 0) {
            if (m < 0) { free(imgs); return CLI_USAGE; }
            model_arg = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--cameras", &v)) != 0) {
            if (m < 0) { free(imgs); return CLI_USAGE; }
            cam_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--out", &v)) != 0) {
            if (m < 0) { free(imgs); return CLI_USAGE; }
            out_dir = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--outputs", &v)) != 0) {
            if (m < 0 || cli_parse_outputs(cmd, v, &outputs)) { free(imgs); return CLI_USAGE; }
        } else if (!strcmp(a, "--float")) {
            want_float = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 1024, &threads)) { free(imgs); return CLI_USAGE; }
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--kernel", &v)) != 0) {
            if (m < 0 || cli_parse_kernel(cmd, v, &kernel)) { free(imgs); return CLI_USAGE; }
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0) {
            if (m < 0 || cli_parse_weights(cmd, v)) { free(imgs); return CLI_USAGE; }
        } else if (a[0] == '-' && a[1]) {
            free(imgs);
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            imgs[nimg++] = a;
        }
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
        if (!cli_pic_info(imgs[i], "view", &iw, &ih, &c)) { rc = CLI_FAIL; break; }
        if (i == 0) { w = iw; h = ih; }
        if (iw != w || ih != h) {
            cli_error("view '%s' is %dx%d but view '%s' is %dx%d: all views must have the same size (supermat does not resize)",
                      imgs[i], iw, ih, imgs[0], w, h);
            rc = CLI_FAIL;
        } else if (w % 8 || h % 8) {
            cli_error("view '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                      "resize the views first, e.g. to 512x512)", imgs[i], w, h);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) rc = cli_read_cameras(cam_path, &cams, &ncam);
    for (i = 0; i < nimg && rc == CLI_OK; i++) {
        const cli_camera *c = cli_find_camera(cams, ncam, index[i], imgs[i], cam_path);
        if (!c) rc = CLI_FAIL;
        else memcpy(c2w + 16 * i, c->m, sizeof c->m);
    }

    if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &file, &file_size, &model, NULL);
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
        r = supermat_session_create(&sd, &sess, &err);
        if (r != SUPERMAT_SUCCESS) {
            char what[64];
            snprintf(what, sizeof what, "session (%d view%s, %dx%d)", nimg, nimg == 1 ? "" : "s", w, h);
            cli_lib_error(what, r, &err);
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
        if (!px[i]) { cli_error("cannot read view '%s': %s", imgs[i], stbi_failure_reason()); rc = CLI_FAIL; break; }
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

static int cli_refine(int argc, char **argv) {
    const char *cmd = "refine", *v, *model_arg = NULL, *model_path, *out_dir = NULL, *paths[3] = {NULL, NULL, NULL};
    static const char *const opts[3] = {"--map", "--mask", "--position"}, *const what[3] = {"the map", "the mask", "the position map"};
    int want_float = 0, threads = 0, i, m, rc = CLI_OK, tty = isatty(2), w = 0, h = 0;
    cli_model_ref mref;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    char *stem = NULL;
    unsigned char *px[3] = {NULL, NULL, NULL}, *file = NULL, *tmp = NULL;
    float *refined = NULL;
    size_t file_size = 0;
    supermat_model *model = NULL;
    supermat_session *sess = NULL;

    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        int k, hit = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_refine, stdout); return CLI_OK; }
        for (k = 0; k < 3 && !hit; k++)
            if ((m = cli_opt(cmd, argc, argv, &i, opts[k], &v)) != 0) {
                if (m < 0) return CLI_USAGE;
                paths[k] = v;
                hit = 1;
            }
        if (hit) continue;
        if ((m = cli_opt(cmd, argc, argv, &i, "--model", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            model_arg = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--out", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            out_dir = v;
        } else if (!strcmp(a, "--float")) {
            want_float = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 1024, &threads)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--kernel", &v)) != 0) {
            if (m < 0 || cli_parse_kernel(cmd, v, &kernel)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0) {
            if (m < 0 || cli_parse_weights(cmd, v)) return CLI_USAGE;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            return cli_usage_error(cmd, "unexpected argument '%s' (the inputs are given with --map, --mask and --position)", a);
        }
    }
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
        if (!cli_pic_info(paths[i], what[i], &iw, &ih, &c)) { rc = CLI_FAIL; break; }
        if (i == 0) { w = iw; h = ih; }
        if (iw != w || ih != h) {
            cli_error("%s '%s' is %dx%d but the map '%s' is %dx%d: the map, the mask and the position map must have the same "
                      "size (supermat does not resize)", what[i], paths[i], iw, ih, paths[0], w, h);
            rc = CLI_FAIL;
        } else if (w % 8 || h % 8) {
            cli_error("the map '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                      "resize the three maps first, e.g. to 1024x1024)", paths[0], w, h);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &file, &file_size, &model, NULL);
    if (rc == CLI_OK) rc = cli_require_kind(cmd, model_path, model, SUPERMAT_KIND_UV_REFINE);
    if (rc == CLI_OK) {
        supermat_session_desc sd;
        supermat_error err;
        supermat_result r;
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = w; sd.height = h; sd.threads = threads;
        r = supermat_session_create(&sd, &sess, &err);
        if (r != SUPERMAT_SUCCESS) {
            char msg[64];
            snprintf(msg, sizeof msg, "session (%dx%d)", w, h);
            cli_lib_error(msg, r, &err);
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) rc = cli_mkdirs(out_dir);
    for (i = 0; i < 3 && rc == CLI_OK; i++) {
        int iw = 0, ih = 0, c = 0;
        px[i] = i == 1 ? cli_load_gray(paths[i], &iw, &ih) : cli_load(paths[i], &iw, &ih, &c, 3);
        if (!px[i]) { cli_error("cannot read %s '%s': %s", what[i], paths[i], stbi_failure_reason()); rc = CLI_FAIL; break; }
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

/* >>info */
static void cli_print_list(const int *v, int n) {
    int i;
    for (i = 0; i < n; i++) printf("%s%d", i ? "," : "", v[i]);
}

static void cli_print_count(const char *label, uint64_t n) {
    printf("%s%llu (%.2f M)", label, (unsigned long long)n, (double)n / 1e6);
}

static int cli_info(int argc, char **argv) {
    const char *cmd = "info", *v, *path = NULL;
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
    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_info, stdout); cli_print_default_model_help(); return CLI_OK; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 1024, &threads)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--kernel", &v)) != 0) {
            if (m < 0 || cli_parse_kernel(cmd, v, &kernel)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0) {
            if (m < 0 || cli_parse_weights(cmd, v)) return CLI_USAGE;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else if (path) {
            return cli_usage_error(cmd, "one model file at a time ('%s' and '%s')", path, a);
        } else {
            path = a;
        }
    }
    if ((m = cli_model_path(cmd, path, 1, &mref)) != CLI_OK) return m;
    if (!path) printf("default       %s (the default model: %s)\n", mref.path, mref.from);
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
    md.data = file; md.size = size; md.kernel = kernel; md.weights = cli_weights;
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
    supermat_model_get_info(model, &mi);
    printf("kernel        %s\n", cli_kernel_name(mi.kernel));
    {
        static const char *wn[] = {"default", "f32", "f16", "bf16", "int8"};
        printf("weights       %s (GEMM weight storage; %.1f MiB held by the model)\n", (unsigned)mi.weights < 5 ? wn[mi.weights] : "?", (double)mi.model_bytes / 1048576.0);
    }
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
    {
        supermat_session_desc sd;
        size_t all = 0, alb = 0;
        int nthreads;
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = 512; sd.height = 512; sd.threads = threads;
        sd.views = mi.kind == SUPERMAT_KIND_SUPERMAT_MV ? 6 : 1;
        nthreads = supermat__threads_for(&sd);
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

/* >>bench */
/* (a) the FMA peak: independent chains of _mm256_fmadd_ps, 12 per iteration (2 FMA ports x 4 cycles of
   latency need 8 in flight), on every thread of the pool */
#define CLI_FMA_CHAINS 12
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static float cli_fma_loop(long iters, float seed) {
    const __m256 mul = _mm256_set1_ps(0.99999f), add = _mm256_set1_ps(1e-6f);
    __m256 a0 = _mm256_set1_ps(seed + 0.10f), a1 = _mm256_set1_ps(seed + 0.11f), a2 = _mm256_set1_ps(seed + 0.12f);
    __m256 a3 = _mm256_set1_ps(seed + 0.13f), a4 = _mm256_set1_ps(seed + 0.14f), a5 = _mm256_set1_ps(seed + 0.15f);
    __m256 a6 = _mm256_set1_ps(seed + 0.16f), a7 = _mm256_set1_ps(seed + 0.17f), a8 = _mm256_set1_ps(seed + 0.18f);
    __m256 a9 = _mm256_set1_ps(seed + 0.19f), a10 = _mm256_set1_ps(seed + 0.20f), a11 = _mm256_set1_ps(seed + 0.21f);
    float out[8];
    long i;
    for (i = 0; i < iters; i++) {
        a0 = _mm256_fmadd_ps(a0, mul, add); a1 = _mm256_fmadd_ps(a1, mul, add); a2 = _mm256_fmadd_ps(a2, mul, add);
        a3 = _mm256_fmadd_ps(a3, mul, add); a4 = _mm256_fmadd_ps(a4, mul, add); a5 = _mm256_fmadd_ps(a5, mul, add);
        a6 = _mm256_fmadd_ps(a6, mul, add); a7 = _mm256_fmadd_ps(a7, mul, add); a8 = _mm256_fmadd_ps(a8, mul, add);
        a9 = _mm256_fmadd_ps(a9, mul, add); a10 = _mm256_fmadd_ps(a10, mul, add); a11 = _mm256_fmadd_ps(a11, mul, add);
    }
    a0 = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(a0, a1), _mm256_add_ps(a2, a3)), _mm256_add_ps(_mm256_add_ps(a4, a5), _mm256_add_ps(a6, a7)));
    a0 = _mm256_add_ps(a0, _mm256_add_ps(_mm256_add_ps(a8, a9), _mm256_add_ps(a10, a11)));
    _mm256_storeu_ps(out, a0);
    return out[0] + out[1] + out[2] + out[3] + out[4] + out[5] + out[6] + out[7];
}
#endif

typedef struct cli_fma_job { long iters; float *sink; } cli_fma_job;

static void cli_fma_task(void *user, int index, int thread) {
    cli_fma_job *j = (cli_fma_job *)user;
    (void)thread;
#if SUPERMAT__HAS_AVX2
    j->sink[index] = cli_fma_loop(j->iters, (float)index * 1e-3f);
#else
    j->sink[index] = 0.0f;
#endif
}

static void cli_serial_for(void *user, int count, supermat_task_fn task, void *task_user) {
    int i;
    (void)user;
    for (i = 0; i < count; i++) task(task_user, i, 0);
}

/* GFLOP/s, best of `reps` runs of about 0.2 s each (0 without AVX2): with hook NULL on the calling
   thread alone, else on every thread of the pool. *iters_per_task calibrates on the first call. */
static double cli_fma_peak(const supermat_threading *hook, int reps, long *iters_per_task) {
    cli_fma_job job;
    int tasks = hook ? 8 * hook->max_threads : 8, rep;
    double best = 0.0, t;
    float sink[8 * 64];
    if (!supermat_cpu_has_avx2()) return 0.0;
    job.sink = sink;
    if (*iters_per_task <= 0) { /* about 0.2 s per run for one thread doing all 8 x max_threads tasks / max_threads */
        job.iters = 1000000;
        t = cli_now();
        cli_fma_task(&job, 0, 0);
        t = cli_now() - t;
        *iters_per_task = (long)((t > 0 ? (double)job.iters / t : 1e9) * 0.2 / 8.0);
        if (*iters_per_task < 10000) *iters_per_task = 10000;
    }
    job.iters = *iters_per_task;
    for (rep = 0; rep < reps; rep++) {
        double gf;
        int i;
        t = cli_now();
        if (hook) hook->parallel_for(hook->user, tasks, cli_fma_task, &job);
        else for (i = 0; i < tasks; i++) cli_fma_task(&job, i, 0);
        t = cli_now() - t;
        gf = (double)tasks * (double)job.iters * CLI_FMA_CHAINS * 16.0 / t / 1e9;
        if (gf > best) best = gf;
    }
    return best;
}

/* (b) the pipeline, timed between the run's inspection points */
#define CLI_MAX_EVENTS 64
typedef struct cli_event { double t; supermat_stage stage; int branch; } cli_event;
typedef struct cli_events { cli_event ev[CLI_MAX_EVENTS]; int n; } cli_events;

static void cli_inspect_cb(void *user, supermat_stage stage, int branch, float *data, int n, int h, int w, int c) {
    cli_events *e = (cli_events *)user;
    (void)data; (void)n; (void)h; (void)w; (void)c;
    if (e->n < CLI_MAX_EVENTS) {
        e->ev[e->n].t = cli_now();
        e->ev[e->n].stage = stage;
        e->ev[e->n].branch = branch;
        e->n++;
    }
}

#define CLI_MAX_ROWS 12
typedef struct cli_row { char name[48]; double seconds, flops; } cli_row;

static const char *cli_branch_name(const supermat_model_info *mi, int branch) {
    if (mi->kind == SUPERMAT_KIND_UV_REFINE) return "refined";
    if (mi->branches < 2) return "output";
    return branch == 0 ? "albedo" : branch == 1 ? "roughness/metallic" : "branch";
}

/* stage rows from one run's events: t0 = before supermat_run, t1 = after. Each row ends at an event.
   The UNet is the trunk (ends at TRUNK) and one tail per wanted branch (ends at its UNET_OUT); the
   branch's X0 event follows at once (x0 = coefficient x output, no time), so it ends no row. */
static int cli_rows(const cli_events *e, double t0, double t1, const supermat_flops *fl, const supermat_model_info *mi, cli_row *rows) {
    int n = 0, i, ndec = 0, nbranch = 0;
    double prev = t0;
    for (i = 0; i < e->n; i++) {
        if (e->ev[i].stage == SUPERMAT_STAGE_DECODED) ndec++;
        if (e->ev[i].stage == SUPERMAT_STAGE_UNET_OUT) nbranch++;
    }
    for (i = 0; i < e->n && n < CLI_MAX_ROWS - 1; i++) {
        const cli_event *v = &e->ev[i];
        cli_row *r = &rows[n];
        r->flops = 0.0;
        switch (v->stage) {
        case SUPERMAT_STAGE_INPUT: snprintf(r->name, sizeof r->name, "input (plan walk, to [-1,1])"); break;
        case SUPERMAT_STAGE_LATENT: snprintf(r->name, sizeof r->name, "vae encode"); r->flops = fl->encode; break;
        case SUPERMAT_STAGE_UNET_IN: snprintf(r->name, sizeof r->name, "unet input (mask, position)"); break;
        case SUPERMAT_STAGE_TRUNK: snprintf(r->name, sizeof r->name, "unet trunk"); r->flops = fl->trunk; break;
        case SUPERMAT_STAGE_UNET_OUT:
            snprintf(r->name, sizeof r->name, "unet branch %s", cli_branch_name(mi, v->branch));
            r->flops = nbranch ? fl->branch / nbranch : 0.0; /* the tails have one architecture */
            break;
        case SUPERMAT_STAGE_DECODED:
            snprintf(r->name, sizeof r->name, "vae decode %s", cli_branch_name(mi, v->branch));
            r->flops = ndec ? fl->decode / ndec : 0.0;
            break;
        default: continue; /* X0 */
        }
        r->seconds = v->t - prev;
        prev = v->t;
        n++;
    }
    snprintf(rows[n].name, sizeof rows[n].name, "write outputs");
    rows[n].seconds = t1 - prev; rows[n].flops = 0.0; n++;
    return n;
}

/* (c) one 3x3 convolution GEMM through the header's private supermat__conv2d on packed weights */
#define CLI_GEMM_HW 64
#define CLI_GEMM_C 320
typedef struct cli_gemm {
    supermat__conv cv;
    supermat__t in, out;
    float **scratch;
    float *scratch_mem;
    int threads;
} cli_gemm;

static uint32_t cli_rand(uint32_t *s) { *s = *s * 1664525u + 1013904223u; return *s >> 8; }

static int cli_gemm_init(cli_gemm *g, int threads) {
    int K = 9 * CLI_GEMM_C, N = CLI_GEMM_C, np = (N + SUPERMAT__NR - 1) / SUPERMAT__NR, n, k, i;
    size_t nin = (size_t)CLI_GEMM_HW * CLI_GEMM_HW * CLI_GEMM_C, sf = (size_t)SUPERMAT__MC * SUPERMAT__KC;
    uint32_t seed = 12345u;
    memset(g, 0, sizeof *g);
    g->threads = threads;
    g->cv.k = 3; g->cv.stride = 1; g->cv.cin = CLI_GEMM_C; g->cv.cout = CLI_GEMM_C;
    g->cv.w.K = K; g->cv.w.N = N;
    g->cv.w.p = (float *)calloc((size_t)np * SUPERMAT__NR * (size_t)K, sizeof(float));
    g->cv.w.bias = (float *)calloc((size_t)np * SUPERMAT__NR, sizeof(float));
    g->in.d = (float *)malloc(nin * sizeof(float));
    g->out.d = (float *)malloc(nin * sizeof(float));
    g->scratch = (float **)malloc(sizeof(float *) * (size_t)threads);
    g->scratch_mem = (float *)malloc(sizeof(float) * sf * (size_t)threads);
    if (!g->cv.w.p || !g->cv.w.bias || !g->in.d || !g->out.d || !g->scratch || !g->scratch_mem) return CLI_FAIL;
    for (i = 0; i < threads; i++) g->scratch[i] = g->scratch_mem + sf * (size_t)i;
    /* W[n][k] packed as panel n/16, row k, column n%16 (K = (ky*3 + kx)*Cin + ci, the model's order) */
    for (n = 0; n < N; n++) {
        g->cv.w.bias[n] = (float)(cli_rand(&seed) % 2001u) * 1e-4f - 0.1f;
        for (k = 0; k < K; k++)
            g->cv.w.p[((size_t)(n / SUPERMAT__NR) * K + k) * SUPERMAT__NR + n % SUPERMAT__NR] = (float)(cli_rand(&seed) % 2001u) * 1e-5f - 0.01f;
    }
    for (i = 0; i < (int)nin; i++) g->in.d[i] = (float)(cli_rand(&seed) % 2001u) * 1e-3f - 1.0f;
    g->in.n = g->out.n = 1;
    g->in.h = g->out.h = CLI_GEMM_HW;
    g->in.w = g->out.w = CLI_GEMM_HW;
    g->in.c = g->out.c = CLI_GEMM_C;
    return CLI_OK;
}

static void cli_gemm_free(cli_gemm *g) {
    free(g->cv.w.p); free(g->cv.w.bias); free(g->in.d); free(g->out.d); free(g->scratch); free(g->scratch_mem);
}

/* best seconds of a few runs (at least one, more while under `budget` seconds) */
static double cli_gemm_time(cli_gemm *g, supermat__ukr_fn ukr, const supermat_threading *hook, double budget, float *copy) {
    supermat__ctx X;
    double best = 1e30, spent = 0.0;
    int runs = 0;
    memset(&X, 0, sizeof X);
    X.ukr = ukr;
    X.thr = *hook;
    X.scratch = g->scratch;
    X.scratch_floats = (size_t)SUPERMAT__MC * SUPERMAT__KC;
    while (runs < 1 || (spent < budget && runs < 10)) {
        double t = cli_now();
        X.status = SUPERMAT_SUCCESS;
        supermat__conv2d(&X, &g->in, g->in.h, g->in.w, &g->cv, 0, &g->out, NULL, NULL);
        t = cli_now() - t;
        if (X.status != SUPERMAT_SUCCESS) return -1.0;
        if (t < best) best = t;
        spent += t;
        runs++;
    }
    if (copy) memcpy(copy, g->out.d, sizeof(float) * (size_t)g->out.h * g->out.w * g->out.c);
    return best;
}

static void cli_json_string(FILE *f, const char *s) {
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') fprintf(f, "\\%c", c);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

static size_t cli_peak_rss(void) {
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
#ifdef __APPLE__
    return (size_t)ru.ru_maxrss;
#else
    return (size_t)ru.ru_maxrss * 1024u;
#endif
}

/* >>benchimage */
/* `supermat bench --image`: each mode (one speed / memory lever) runs on the same real input; the f32
   mode is the reference every other mode's float maps are compared with. */
enum {
    CLI_MODE_F32, CLI_MODE_F16, CLI_MODE_BF16, CLI_MODE_INT8, CLI_MODE_WINOGRAD_F2, CLI_MODE_WINOGRAD_F4,
    CLI_MODE_TILED_VAE, CLI_MODE_FOREGROUND, CLI_MODE_BRANCH_ALBEDO, CLI_MODE_BRANCH_RM, CLI_MODE_RES256,
    CLI_MODE_RES384, CLI_MODE_RES512, CLI_MODE_RES768, CLI_MODE_MV_WINDOW_OWN, CLI_MODE_MV_WINDOW_STRIDE4,
    CLI_MODE_COUNT
};
/* the model kinds a mode applies to */
#define CLI_KS 1u  /* supermat */
#define CLI_KMV 2u /* supermat-mv */
#define CLI_KUV 4u /* uv-refine */
static const struct { const char *name; unsigned kinds; } cli_modes[CLI_MODE_COUNT] = {
    {"f32", CLI_KS | CLI_KMV | CLI_KUV},         {"f16", CLI_KS | CLI_KMV | CLI_KUV},
    {"bf16", CLI_KS | CLI_KMV | CLI_KUV},        {"int8", CLI_KS | CLI_KMV | CLI_KUV},
    {"winograd_f2", CLI_KS | CLI_KMV | CLI_KUV}, {"winograd_f4", CLI_KS | CLI_KMV | CLI_KUV},
    {"tiled_vae", CLI_KS | CLI_KMV | CLI_KUV},   {"foreground", CLI_KS | CLI_KMV | CLI_KUV},
    {"branch_albedo", CLI_KS | CLI_KMV},         {"branch_rm", CLI_KS | CLI_KMV},
    {"res256", CLI_KS | CLI_KMV},                {"res384", CLI_KS | CLI_KMV},
    {"res512", CLI_KUV},                         {"res768", CLI_KUV},
    {"mv_window_own", CLI_KMV},                  {"mv_window_stride4", CLI_KMV},
};

static unsigned cli_kind_bit(supermat_model_kind k) {
    return k == SUPERMAT_KIND_SUPERMAT ? CLI_KS : k == SUPERMAT_KIND_SUPERMAT_MV ? CLI_KMV : k == SUPERMAT_KIND_UV_REFINE ? CLI_KUV : 0u;
}

/* --modes: "all" (*n = 0 and *all = 1) or a comma list of names, in the order given, without repeats */
static int cli_parse_modes(const char *cmd, const char *s, int *list, int *n, int *all) {
    const char *p = s;
    int seen[CLI_MODE_COUNT], k;
    memset(seen, 0, sizeof seen);
    *n = 0; *all = 0;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == 3 && !strncmp(p, "all", 3)) *all = 1;
        else if (len != 0) {
            for (k = 0; k < CLI_MODE_COUNT; k++)
                if (strlen(cli_modes[k].name) == len && !strncmp(p, cli_modes[k].name, len)) break;
            if (k == CLI_MODE_COUNT) {
                char names[400];
                size_t used = 0;
                int j;
                names[0] = 0;
                for (j = 0; j < CLI_MODE_COUNT; j++)
                    used += (size_t)snprintf(names + used, sizeof names - used, "%s%s", j ? ", " : "", cli_modes[j].name);
                cli_usage_error(cmd, "--modes: unknown mode '%.*s' (all, or a comma list of: %s)", (int)len, p, names);
                return -1;
            }
            if (!seen[k]) { seen[k] = 1; list[(*n)++] = k; }
        }
        p += len;
        if (*p == ',') p++;
    }
    if (!*all && !*n) { cli_usage_error(cmd, "--modes: empty list"); return -1; }
    return 0;
}

/* what one mode changes: the model (weights, conv), the outputs and the session levers. Returns 0,
   or 1 if the mode does not apply to this image (a resolution not below the image's), with `why`. */
static int cli_mode_setup(int mode, int w, int h, supermat_weights *weights, supermat_conv *conv, unsigned *outputs,
                          supermat_session_desc *sd, char *why, size_t why_cap) {
    int S = w > h ? w : h, t, R = 0;
    *weights = SUPERMAT_WEIGHTS_F32;
    *conv = SUPERMAT_CONV_DIRECT;
    *outputs = SUPERMAT_OUTPUT_ALL;
    switch (mode) {
    case CLI_MODE_F16: *weights = SUPERMAT_WEIGHTS_F16; break;
    case CLI_MODE_BF16: *weights = SUPERMAT_WEIGHTS_BF16; break;
    case CLI_MODE_INT8: *weights = SUPERMAT_WEIGHTS_I8; break;
    case CLI_MODE_WINOGRAD_F2: *conv = SUPERMAT_CONV_WINOGRAD_F2; break;
    case CLI_MODE_WINOGRAD_F4: *conv = SUPERMAT_CONV_WINOGRAD_F4; break;
    case CLI_MODE_TILED_VAE: /* 2x2 tiles */
        t = ((S / 8 + 4) / 2) * 8;
        sd->vae_tile = t < 40 ? 40 : t; /* larger than the overlap */
        sd->vae_overlap = 32;
        break;
    case CLI_MODE_FOREGROUND:
        t = (S / 4 + 16 + 7) / 8 * 8;
        sd->vae_tile = t < 32 ? 32 : t;
        sd->vae_overlap = 16;
        sd->skip_background = 1;
        break;
    case CLI_MODE_BRANCH_ALBEDO: *outputs = SUPERMAT_OUTPUT_ALBEDO; break;
    case CLI_MODE_BRANCH_RM: *outputs = SUPERMAT_OUTPUT_ROUGHNESS | SUPERMAT_OUTPUT_METALLIC; break;
    case CLI_MODE_RES256: R = 256; break;
    case CLI_MODE_RES384: R = 384; break;
    case CLI_MODE_RES512: R = 512; break;
    case CLI_MODE_RES768: R = 768; break;
    case CLI_MODE_MV_WINDOW_OWN: sd->mv_attention = SUPERMAT_MV_ATTENTION_OWN_VIEW; break;
    case CLI_MODE_MV_WINDOW_STRIDE4: sd->mv_attention = SUPERMAT_MV_ATTENTION_STRIDED; sd->mv_key_stride = 4; break;
    default: break;
    }
    if (R) {
        int ww, hh;
        if (R >= S) {
            snprintf(why, why_cap, "the network size %d is not below the image's %dx%d", R, w, h);
            return 1;
        }
        /* the longer side R, the other in proportion, both multiples of 8 */
        ww = (int)floor((double)w * R / S / 8.0 + 0.5) * 8;
        hh = (int)floor((double)h * R / S / 8.0 + 0.5) * 8;
        sd->work_width = ww < 8 ? 8 : ww;
        sd->work_height = hh < 8 ? 8 : hh;
    }
    return 0;
}

/* this machine's CPU name (Linux /proc/cpuinfo), or "" */
static void cli_cpu_name(char *buf, size_t cap) {
    FILE *f = fopen("/proc/cpuinfo", "r");
    char line[512];
    buf[0] = 0;
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        if (!strncmp(line, "model name", 10)) {
            char *c = strchr(line, ':'), *e;
            if (c) {
                c++;
                while (*c == ' ' || *c == '\t') c++;
                e = c + strlen(c);
                while (e > c && (e[-1] == '\n' || e[-1] == '\r' || e[-1] == ' ')) *--e = 0;
                snprintf(buf, cap, "%s", c);
            }
            break;
        }
    }
    fclose(f);
}

/* the input of every mode */
typedef struct cli_bi_input {
    supermat_model_kind kind;
    int w, h, nviews, nmaps;         /* nmaps: 3 (albedo, roughness, metallic) or 1 (refined) */
    size_t np;                       /* pixels per view */
    supermat_image *in;              /* nviews inputs (one buffer repeated for synthetic views) */
    const float *c2w;                /* supermat-mv: nviews x 16 */
    unsigned char *mask, *pos;       /* uv-refine */
    unsigned char *fg;               /* nviews x np: 1 = foreground (alpha > 0; uv-refine: mask > 0.5) */
    supermat_image *ov[3];           /* supermat-mv: per-view output images, pointed at the buffers per run */
    unsigned char *truth[3];         /* supermat: the --truth-* maps (8-bit, np x 3 / np x 1), NULL = not given */
    unsigned char *gt_mask;          /* with a truth: 1 = an object pixel (input alpha >= 128) */
    size_t gt_n;                     /* object pixels */
    int any_truth;
} cli_bi_input;

static const char *const cli_bi_map_names[3] = {"albedo", "roughness", "metallic"};
static int cli_bi_channels(const cli_bi_input *in, int k) { return in->nmaps == 1 ? 3 : cli_map_channels[k]; }
static const char *cli_bi_map_name(const cli_bi_input *in, int k) { return in->nmaps == 1 ? "refined" : cli_bi_map_names[k]; }
static int cli_bi_wants(const cli_bi_input *in, unsigned outputs, int k) {
    return in->nmaps == 1 ? 1 : (outputs & (1u << k)) != 0; /* SUPERMAT_OUTPUT_ALBEDO = 1, ROUGHNESS = 2, METALLIC = 4 */
}

/* one run into maps[k] (float32, views one after the other), maps[k] NULL = not wanted */
static supermat_result cli_bi_run(supermat_session *s, const cli_bi_input *in, float *const *maps, supermat_error *err) {
    supermat_run_desc rd;
    int k, v;
    memset(&rd, 0, sizeof rd);
    rd.input = in->in[0];
    if (in->kind == SUPERMAT_KIND_UV_REFINE) {
        rd.mask.pixels = in->mask; rd.mask.width = in->w; rd.mask.height = in->h; rd.mask.channels = 1;
        rd.position.pixels = in->pos; rd.position.width = in->w; rd.position.height = in->h; rd.position.channels = 3;
        rd.refined.pixels = maps[0]; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
    } else if (in->kind == SUPERMAT_KIND_SUPERMAT_MV) {
        rd.input_views = in->in;
        rd.cameras = in->c2w;
        for (k = 0; k < 3; k++) {
            if (!maps[k]) continue;
            for (v = 0; v < in->nviews; v++) {
                supermat_image *o = &in->ov[k][v];
                memset(o, 0, sizeof *o);
                o->pixels = maps[k] + in->np * (size_t)cli_map_channels[k] * (size_t)v;
                o->channels = cli_map_channels[k];
                o->format = SUPERMAT_FORMAT_F32;
            }
        }
        rd.albedo_views = maps[0] ? in->ov[0] : NULL;
        rd.roughness_views = maps[1] ? in->ov[1] : NULL;
        rd.metallic_views = maps[2] ? in->ov[2] : NULL;
    } else {
        supermat_image *o[3];
        o[0] = &rd.albedo; o[1] = &rd.roughness; o[2] = &rd.metallic;
        for (k = 0; k < 3; k++) {
            if (!maps[k]) continue;
            o[k]->pixels = maps[k]; o[k]->channels = cli_map_channels[k]; o[k]->format = SUPERMAT_FORMAT_F32;
        }
    }
    return supermat_run(s, &rd, err);
}

#define CLI_PSNR_CAP 200.0
typedef struct cli_bi_row {
    int mode, done;
    double seconds, speedup, flops;
    size_t peak_bytes;
    int has[3], has_fg[3], has_gt[3];
    double psnr[3], psnr_fg[3], max_abs[3], gt_psnr[3];
} cli_bi_row;

static double cli_psnr(double sse, double n) {
    double mse = sse / n, p;
    if (mse != mse) return mse; /* NaN: shown as nan, written as null */
    if (!(mse > 0.0)) return CLI_PSNR_CAP;
    p = 10.0 * log10(1.0 / mse);
    return p > CLI_PSNR_CAP ? CLI_PSNR_CAP : p;
}

/* PSNR (all pixels, foreground pixels) and max abs error of map k against the reference */
static void cli_bi_compare(const cli_bi_input *in, int k, const float *ref, const float *got, cli_bi_row *row) {
    int c = cli_bi_channels(in, k), j;
    size_t n = in->np * (size_t)in->nviews, p, nfg = 0;
    double sse = 0.0, sse_fg = 0.0, mx = 0.0;
    for (p = 0; p < n; p++) {
        double s = 0.0;
        for (j = 0; j < c; j++) {
            double d = (double)got[p * (size_t)c + (size_t)j] - (double)ref[p * (size_t)c + (size_t)j], a = fabs(d);
            s += d * d;
            if (a > mx || a != a) mx = a; /* a NaN shows */
        }
        sse += s;
        if (in->fg[p]) { sse_fg += s; nfg++; }
    }
    row->has[k] = 1;
    row->psnr[k] = cli_psnr(sse, (double)n * c);
    row->max_abs[k] = mx;
    row->has_fg[k] = nfg > 0;
    row->psnr_fg[k] = nfg ? cli_psnr(sse_fg, (double)nfg * c) : 0.0;
}

/* PSNR of map k against its truth file: the map quantised as `supermat image` writes it (cli_quantize),
   over the object's pixels and the map's channels, values / 255. A NaN in the map gives NaN. */
static void cli_bi_compare_truth(const cli_bi_input *in, int k, const float *got, cli_bi_row *row) {
    int c = cli_map_channels[k], j, nan = 0;
    const unsigned char *t = in->truth[k];
    size_t p;
    uint64_t sse = 0;
    for (p = 0; p < in->np; p++) {
        if (!in->gt_mask[p]) continue;
        for (j = 0; j < c; j++) {
            size_t at = p * (size_t)c + (size_t)j;
            int d;
            if (got[at] != got[at]) { nan = 1; continue; }
            d = (int)cli_quantize(got[at]) - (int)t[at];
            sse += (uint64_t)(d * d);
        }
    }
    row->has_gt[k] = 1;
    row->gt_psnr[k] = nan ? (double)NAN : cli_psnr((double)sse / (255.0 * 255.0), (double)in->gt_n * c);
}

static double cli_bi_peak; /* this machine's FMA peak (GFLOP/s) measured at the start, 0 = unknown */
static void cli_bi_print_header(const cli_bi_input *in) {
    int k;
    printf("%-18s %9s %8s %9s %9s %8s %6s", "", "", "", "", "", "", "");
    for (k = 0; k < in->nmaps; k++) printf(" | %-*s", in->any_truth ? 33 : 25, cli_bi_map_name(in, k));
    printf("\n%-18s %9s %8s %9s %9s %8s %6s", "mode", "seconds", "speedup", "peak MiB", "GFLOP", "GFLOP/s", "%peak");
    for (k = 0; k < in->nmaps; k++) {
        printf(" | %7s %7s %9s", "psnr", "psnr_fg", "max_abs");
        if (in->any_truth) printf(" %7s", "gt_psnr");
    }
    printf("\n");
}

static void cli_bi_print_row(const cli_bi_input *in, const cli_bi_row *r) {
    int k;
    double gf = r->seconds > 0 ? r->flops / r->seconds / 1e9 : 0.0;
    printf("%-18s %9.4f %7.2fx %9.1f %9.3f %8.2f", cli_modes[r->mode].name, r->seconds, r->speedup, cli_mib((double)r->peak_bytes),
           r->flops / 1e9, gf);
    if (cli_bi_peak > 0) printf(" %5.1f%%", 100.0 * gf / cli_bi_peak);
    else printf(" %6s", "-");
    for (k = 0; k < in->nmaps; k++) {
        if (!r->has[k]) printf(" | %7s %7s %9s", "-", "-", "-");
        else {
            printf(" | %7.2f", r->psnr[k]);
            if (r->has_fg[k]) printf(" %7.2f", r->psnr_fg[k]);
            else printf(" %7s", "-");
            printf(" %9.3e", r->max_abs[k]);
        }
        if (!in->any_truth) continue;
        if (r->has_gt[k]) printf(" %7.2f", r->gt_psnr[k]);
        else printf(" %7s", "-");
    }
    printf("\n");
    fflush(stdout);
}

static void cli_json_number_or_null(FILE *f, int has, double v) {
    if (has && v == v && v - v == 0.0) fprintf(f, "%.6g", v);
    else fputs("null", f);
}

/* writes and closes f (opened before the runs, so that a bad path fails at once) */
static int cli_bi_write_json(FILE *f, const char *path, const cli_bi_input *in, const cli_bi_row *rows, int nrows) {
    int i, k, q, first = 1;
    static const char *const groups[4] = {"psnr", "psnr_fg", "max_abs", "gt_psnr"};
    fputs("[\n", f);
    for (i = 0; i < nrows; i++) {
        const cli_bi_row *r = &rows[i];
        if (!r->done) continue;
        fprintf(f, "%s  {\"mode\": \"%s\", \"seconds\": %.6g, \"speedup\": %.6g, \"peak_bytes\": %llu, \"flops\": %.6g", first ? "" : ",\n",
                cli_modes[r->mode].name, r->seconds, r->speedup, (unsigned long long)r->peak_bytes, r->flops);
        fputs(", \"fma_peak_gflops\": ", f);
        cli_json_number_or_null(f, cli_bi_peak > 0, cli_bi_peak);
        fputs(", \"fraction_of_peak\": ", f);
        cli_json_number_or_null(f, cli_bi_peak > 0 && r->seconds > 0, r->seconds > 0 ? r->flops / r->seconds / 1e9 / cli_bi_peak : 0.0);
        first = 0;
        for (q = 0; q < 4; q++) {
            fprintf(f, ", \"%s\": {", groups[q]);
            for (k = 0; k < in->nmaps; k++) {
                fprintf(f, "%s\"%s\": ", k ? ", " : "", cli_bi_map_name(in, k));
                if (q == 0) cli_json_number_or_null(f, r->has[k], r->psnr[k]);
                else if (q == 1) cli_json_number_or_null(f, r->has[k] && r->has_fg[k], r->psnr_fg[k]);
                else if (q == 2) cli_json_number_or_null(f, r->has[k], r->max_abs[k]);
                else cli_json_number_or_null(f, r->has_gt[k], r->gt_psnr[k]);
            }
            fputc('}', f);
        }
        fputc('}', f);
    }
    fputs(first ? "]\n" : "\n]\n", f);
    if (ferror(f) | (fclose(f) != 0)) { cli_error("cannot write '%s'", path); return CLI_FAIL; }
    return CLI_OK;
}

typedef struct cli_bench_opts {
    const char *model_path, *json_path, *mask_path, *pos_path, *cam_path;
    const char *truth_paths[3];      /* --truth-albedo, --truth-roughness, --truth-metallic (NULL = not given) */
    const char *images[CLI_MAX_VIEWS];
    int nimg, views, threads, repeats, nmodes, modes_all;
    int modes[CLI_MODE_COUNT];
    supermat_kernel kernel;
} cli_bench_opts;

static supermat_result cli_bi_model(const unsigned char *buf, size_t size, supermat_kernel kernel, supermat_weights weights,
                                    supermat_conv conv, supermat_model **model, supermat_error *err) {
    supermat_model_desc md;
    memset(&md, 0, sizeof md);
    md.data = buf; md.size = size; md.kernel = kernel; md.weights = weights; md.conv = conv;
    return supermat_model_create(&md, model, err);
}

static int cli_bench_image(const cli_bench_opts *o) {
    const char *path0 = o->images[0];
    int i, k, v, rc = CLI_OK, w = 0, h = 0, nviews = 1, ncam = 0, nrows = 0, failed = 0, order[CLI_MODE_COUNT], norder = 0;
    unsigned char *file = NULL, *px[CLI_MAX_VIEWS];
    size_t file_size = 0, nout[3] = {0, 0, 0};
    supermat_model *base = NULL;
    supermat_model_info mi;
    supermat_error err;
    supermat_result r;
    supermat_pool *pool = NULL;
    supermat_threading hook;
    cli_bi_input in;
    cli_camera *cams = NULL;
    float *c2w = NULL, *ref[3] = {NULL, NULL, NULL}, *cur[3] = {NULL, NULL, NULL};
    cli_bi_row rows[CLI_MODE_COUNT];
    char skipped[CLI_MODE_COUNT][160], cpu[256];
    int nskipped = 0, skipped_mode[CLI_MODE_COUNT];
    double f32_seconds = 0.0;
    FILE *jf = NULL;
    cli_mem jm;

    memset(px, 0, sizeof px);
    memset(&in, 0, sizeof in);
    memset(&mi, 0, sizeof mi);
    memset(rows, 0, sizeof rows);
    memset(&hook, 0, sizeof hook);

    /* the images' sizes before the (slow) model load */
    for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
        int iw, ih, c;
        if (!cli_pic_info(o->images[i], "image", &iw, &ih, &c)) { rc = CLI_FAIL; break; }
        if (i == 0) { w = iw; h = ih; }
        if (iw != w || ih != h) {
            cli_error("image '%s' is %dx%d but image '%s' is %dx%d: all views must have the same size (supermat does not resize)",
                      o->images[i], iw, ih, path0, w, h);
            rc = CLI_FAIL;
        } else if (w % 8 || h % 8) {
            cli_error("image '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                      "resize it first, e.g. to 512x512)", o->images[i], w, h);
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < 2 && rc == CLI_OK; i++) {
        const char *p = i ? o->pos_path : o->mask_path, *what = i ? "the position map" : "the mask";
        int iw, ih, c;
        if (!p) continue;
        if (!cli_pic_info(p, what, &iw, &ih, &c)) { rc = CLI_FAIL; break; }
        if (iw != w || ih != h) {
            cli_error("%s '%s' is %dx%d but the map '%s' is %dx%d: the map, the mask and the position map must have the same "
                      "size (supermat does not resize)", what, p, iw, ih, path0, w, h);
            rc = CLI_FAIL;
        }
    }
    for (k = 0; k < 3 && rc == CLI_OK; k++) { /* the truth files: readable, 8-bit, the image's size, colour / gray */
        const char *p = o->truth_paths[k];
        int iw, ih, c;
        if (!p) continue;
        in.any_truth = 1;
        if (!stbi_info(p, &iw, &ih, &c)) {
            cli_error("cannot read the %s truth '%s': %s", cli_bi_map_names[k], p, stbi_failure_reason());
            rc = CLI_FAIL;
        } else if (iw != w || ih != h) {
            cli_error("the %s truth '%s' is %dx%d but the image '%s' is %dx%d: a truth map must have the image's size "
                      "(supermat does not resize)", cli_bi_map_names[k], p, iw, ih, path0, w, h);
            rc = CLI_FAIL;
        } else if (stbi_is_16_bit(p)) {
            cli_error("the %s truth '%s' has 16 bits per channel: give an 8-bit PNG (the maps are compared as "
                      "`supermat image` writes them, 8-bit)", cli_bi_map_names[k], p);
            rc = CLI_FAIL;
        } else if (k == 0 ? c < 3 : c > 2) {
            cli_error("the %s truth '%s' is %s: give an 8-bit %s PNG", cli_bi_map_names[k], p,
                      c <= 2 ? "gray" : "in colour", k == 0 ? "RGB (sRGB)" : "gray");
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK && o->json_path) {
        jf = cli_mem_open(&jm, o->json_path);
        if (!jf) rc = CLI_FAIL;
    }

    /* the reference model, and what the inputs must be for its kind */
    if (rc == CLI_OK) rc = cli_read_file(o->model_path, &file, &file_size);
    if (rc == CLI_OK) {
        r = cli_bi_model(file, file_size, o->kernel, SUPERMAT_WEIGHTS_F32, SUPERMAT_CONV_DIRECT, &base, &err);
        if (r != SUPERMAT_SUCCESS) {
            char what[600];
            snprintf(what, sizeof what, "model '%s'", o->model_path);
            cli_lib_error(what, r, &err);
            rc = CLI_FAIL;
        } else supermat_model_get_info(base, &mi);
    }
    if (rc == CLI_OK) {
        const char *kn = cli_kind_name(mi.kind);
        in.kind = mi.kind;
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) {
            if (o->nimg != 1 || !o->mask_path || !o->pos_path) {
                cli_error("model '%s' is a uv-refine model: give one --image MAP with --mask MASK and --position POS", o->model_path);
                rc = CLI_FAIL;
            }
        } else if (o->mask_path || o->pos_path) {
            cli_error("--mask and --position are for a uv-refine model; model '%s' is a %s model", o->model_path, kn);
            rc = CLI_FAIL;
        }
        if (rc == CLI_OK && in.any_truth && mi.kind != SUPERMAT_KIND_SUPERMAT) {
            cli_error("--truth-albedo, --truth-roughness and --truth-metallic are for a supermat model (one image); "
                      "model '%s' is a %s model", o->model_path, kn);
            rc = CLI_FAIL;
        }
        if (rc == CLI_OK && mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            if (o->nimg > 1 && !o->cam_path) {
                cli_error("%d views: give their cameras with --cameras meta.json (one --image without cameras is repeated as "
                          "--views views on a circle of cameras)", o->nimg);
                rc = CLI_FAIL;
            } else if (o->cam_path && o->views && o->views != o->nimg) {
                cli_error("--views %d with %d --image view%s and --cameras: the views are the images", o->views, o->nimg, o->nimg == 1 ? "" : "s");
                rc = CLI_FAIL;
            } else if (o->cam_path && mi.class_embed_in != 16) {
                cli_error("model '%s' takes %d camera numbers per view; a meta.json camera is a 4x4 matrix (16)", o->model_path, mi.class_embed_in);
                rc = CLI_FAIL;
            }
            nviews = o->cam_path ? o->nimg : o->views ? o->views : 6;
        } else if (rc == CLI_OK) {
            if (o->nimg > 1) {
                cli_error("%d --image inputs: model '%s' is a %s model, which takes one (only a supermat-mv model takes several views)",
                          o->nimg, o->model_path, kn);
                rc = CLI_FAIL;
            } else if (o->cam_path || o->views > 1) {
                cli_error("%s: model '%s' is a %s model, only a supermat-mv model takes views and cameras",
                          o->cam_path ? "--cameras" : "--views", o->model_path, kn);
                rc = CLI_FAIL;
            }
        }
    }
    /* the views' cameras (a supermat-mv model) */
    if (rc == CLI_OK && o->cam_path) {
        c2w = (float *)calloc((size_t)o->nimg * 16, sizeof(float));
        if (!c2w) { cli_error("out of memory"); rc = CLI_FAIL; }
        if (rc == CLI_OK) rc = cli_read_cameras(o->cam_path, &cams, &ncam);
        for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
            char *stem = cli_stem(o->images[i]);
            long index;
            const cli_camera *c;
            if (!stem) { cli_error("out of memory"); rc = CLI_FAIL; break; }
            index = cli_stem_index(stem);
            free(stem);
            if (index < 0) {
                cli_error("view '%s': its file name does not end with a number (up to 9 digits; e.g. color_0003.png -> 3), "
                          "so it has no camera index in the meta.json", o->images[i]);
                rc = CLI_FAIL;
                break;
            }
            c = cli_find_camera(cams, ncam, index, o->images[i], o->cam_path);
            if (!c) rc = CLI_FAIL;
            else memcpy(c2w + 16 * i, c->m, sizeof c->m);
        }
    }

    /* the modes, f32 first */
    if (rc == CLI_OK) {
        unsigned kb = cli_kind_bit(mi.kind);
        order[norder++] = CLI_MODE_F32;
        if (o->modes_all) {
            for (k = 1; k < CLI_MODE_COUNT; k++) if (cli_modes[k].kinds & kb) order[norder++] = k;
        }
        for (i = 0; i < o->nmodes && rc == CLI_OK; i++) {
            int m = o->modes[i], j, dup = 0;
            if (!(cli_modes[m].kinds & kb)) {
                cli_error("--modes: mode '%s' does not apply to model '%s', a %s model", cli_modes[m].name, o->model_path,
                          cli_kind_name(mi.kind));
                rc = CLI_FAIL;
            }
            for (j = 0; j < norder; j++) dup |= order[j] == m;
            if (!dup) order[norder++] = m;
        }
    }

    /* the input pixels */
    if (rc == CLI_OK) {
        in.w = w; in.h = h; in.nviews = nviews; in.np = (size_t)w * (size_t)h;
        in.nmaps = mi.kind == SUPERMAT_KIND_UV_REFINE ? 1 : 3;
        in.in = (supermat_image *)calloc((size_t)nviews, sizeof *in.in);
        in.fg = (unsigned char *)malloc(in.np * (size_t)nviews);
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            for (k = 0; k < 3; k++) in.ov[k] = (supermat_image *)calloc((size_t)nviews, sizeof(supermat_image));
            if (!c2w) {
                c2w = (float *)calloc((size_t)nviews * 16, sizeof(float));
                if (c2w) cli_ring_cameras(nviews, c2w);
            }
            in.c2w = c2w;
        }
        if (!in.in || !in.fg || (mi.kind == SUPERMAT_KIND_SUPERMAT_MV && (!in.ov[0] || !in.ov[1] || !in.ov[2] || !c2w))) {
            cli_error("out of memory");
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
        int iw = 0, ih = 0, c = 0, uv = mi.kind == SUPERMAT_KIND_UV_REFINE;
        px[i] = cli_load(o->images[i], &iw, &ih, &c, uv ? 3 : 4);
        if (!px[i]) { cli_error("cannot read image '%s': %s", o->images[i], stbi_failure_reason()); rc = CLI_FAIL; break; }
        if (iw != w || ih != h) { cli_error("image '%s' is %dx%d, not %dx%d as before (did it change?)", o->images[i], iw, ih, w, h); rc = CLI_FAIL; break; }
    }
    if (rc == CLI_OK && mi.kind == SUPERMAT_KIND_UV_REFINE) {
        int iw = 0, ih = 0, c = 0;
        in.mask = cli_load_gray(o->mask_path, &iw, &ih);
        if (!in.mask) { cli_error("cannot read the mask '%s': %s", o->mask_path, stbi_failure_reason()); rc = CLI_FAIL; }
        else if (iw != w || ih != h) { cli_error("the mask '%s' is %dx%d, not %dx%d as before (did it change?)", o->mask_path, iw, ih, w, h); rc = CLI_FAIL; }
        if (rc == CLI_OK) {
            in.pos = cli_load(o->pos_path, &iw, &ih, &c, 3);
            if (!in.pos) { cli_error("cannot read the position map '%s': %s", o->pos_path, stbi_failure_reason()); rc = CLI_FAIL; }
            else if (iw != w || ih != h) { cli_error("the position map '%s' is %dx%d, not %dx%d as before (did it change?)", o->pos_path, iw, ih, w, h); rc = CLI_FAIL; }
        }
    }
    if (rc == CLI_OK) {
        int uv = mi.kind == SUPERMAT_KIND_UV_REFINE;
        size_t p;
        for (v = 0; v < nviews; v++) {
            unsigned char *src = px[v < o->nimg ? v : 0];
            unsigned char *fg = in.fg + in.np * (size_t)v;
            in.in[v].pixels = src; in.in[v].width = w; in.in[v].height = h; in.in[v].channels = uv ? 3 : 4;
            in.in[v].format = SUPERMAT_FORMAT_U8;
            for (p = 0; p < in.np; p++) fg[p] = uv ? in.mask[p] >= 128 /* > 0.5 */ : src[p * 4 + 3] > 0;
        }
        if (in.any_truth) { /* a supermat model: one view */
            in.gt_mask = (unsigned char *)malloc(in.np);
            if (!in.gt_mask) { cli_error("out of memory"); rc = CLI_FAIL; }
            for (p = 0; rc == CLI_OK && p < in.np; p++) {
                in.gt_mask[p] = px[0][p * 4 + 3] >= 128;
                in.gt_n += in.gt_mask[p];
            }
            if (rc == CLI_OK && !in.gt_n) {
                cli_error("image '%s' has no object pixels (alpha >= 128): nothing to compare the truth maps with", path0);
                rc = CLI_FAIL;
            }
        }
        for (k = 0; k < 3 && rc == CLI_OK; k++) {
            const char *tp = o->truth_paths[k];
            int iw = 0, ih = 0, c = 0;
            if (!tp) continue;
            in.truth[k] = k == 0 ? cli_load(tp, &iw, &ih, &c, 3) : cli_load_gray(tp, &iw, &ih);
            if (!in.truth[k]) { cli_error("cannot read the %s truth '%s': %s", cli_bi_map_names[k], tp, stbi_failure_reason()); rc = CLI_FAIL; }
            else if (iw != w || ih != h) {
                cli_error("the %s truth '%s' is %dx%d, not %dx%d as before (did it change?)", cli_bi_map_names[k], tp, iw, ih, w, h);
                rc = CLI_FAIL;
            }
        }
        for (k = 0; k < in.nmaps && rc == CLI_OK; k++) {
            nout[k] = in.np * (size_t)nviews * (size_t)cli_bi_channels(&in, k);
            ref[k] = (float *)malloc(nout[k] * sizeof(float));
            cur[k] = (float *)malloc(nout[k] * sizeof(float));
            if (!ref[k] || !cur[k]) { cli_error("out of memory for the maps (%d view%s of %dx%d)", nviews, nviews == 1 ? "" : "s", w, h); rc = CLI_FAIL; break; }
        }
    }

    /* one pool for every session */
    if (rc == CLI_OK) {
#if SUPERMAT__HAS_PTHREADS
        if (supermat_pool_create(o->threads, NULL, &pool, &hook) != SUPERMAT_SUCCESS) { cli_error("cannot create the thread pool"); rc = CLI_FAIL; }
#else
        hook.parallel_for = cli_serial_for; hook.user = NULL; hook.max_threads = 1;
#endif
    }

    if (rc == CLI_OK) {
        char vs[48], ins[64];
        vs[0] = 0;
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV)
            snprintf(vs, sizeof vs, " x %d view%s%s", nviews, nviews == 1 ? "" : "s", o->cam_path ? "" : " (one image, cameras on a circle)");
        snprintf(ins, sizeof ins, "%s", mi.kind == SUPERMAT_KIND_UV_REFINE ? "map" : o->nimg > 1 ? "views" : "image");
        cli_cpu_name(cpu, sizeof cpu);
        printf("supermat bench: %s (%s, kernel %s)\n", o->model_path, cli_kind_name(mi.kind), cli_kernel_name(mi.kernel));
        printf("%-8s %s%s, %dx%d%s\n", ins, path0, o->nimg > 1 ? ", ..." : "", w, h, vs);
        printf("machine  %s%s%d thread%s, seconds = best of %d run%s\n", cpu, cpu[0] ? ", " : "", hook.max_threads,
               hook.max_threads == 1 ? "" : "s", o->repeats, o->repeats == 1 ? "" : "s");
        {
            long fma_iters = 0;
            cli_bi_peak = mi.kernel == SUPERMAT_KERNEL_AVX2 ? cli_fma_peak(&hook, 3, &fma_iters) : 0.0;
            if (cli_bi_peak > 0) printf("FMA peak %.1f GFLOP/s on %d thread%s (measured now; %%peak = GFLOP/s / this)\n", cli_bi_peak, hook.max_threads, hook.max_threads == 1 ? "" : "s");
        }
        if (in.any_truth) {
            printf("truth   ");
            for (k = 0; k < 3; k++) if (o->truth_paths[k]) printf(" %s %s", cli_bi_map_names[k], o->truth_paths[k]);
            printf(" (%lu object pixels)\n", (unsigned long)in.gt_n);
        }
        printf("\n");
        cli_bi_print_header(&in);
        fflush(stdout);
    }

    for (i = 0; i < norder && rc == CLI_OK; i++) {
        int mode = order[i], rep, skip;
        supermat_weights wt;
        supermat_conv conv;
        unsigned outputs;
        supermat_session_desc sd;
        supermat_model *model = base, *extra = NULL;
        supermat_session *sess = NULL;
        supermat_model_info emi;
        supermat_flops fl;
        size_t sbytes = 0;
        float *maps[3];
        double best = 1e30;
        char what[80];
        cli_bi_row *row = &rows[nrows];
        memset(&sd, 0, sizeof sd);
        skip = cli_mode_setup(mode, w, h, &wt, &conv, &outputs, &sd, skipped[nskipped], sizeof skipped[nskipped]);
        if (skip) { skipped_mode[nskipped++] = mode; continue; }
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) outputs = SUPERMAT_OUTPUT_ALL;
        row->mode = mode;
        nrows++;
        snprintf(what, sizeof what, "mode %s", cli_modes[mode].name);
        r = SUPERMAT_SUCCESS;
        if (wt != SUPERMAT_WEIGHTS_F32 || conv != SUPERMAT_CONV_DIRECT) {
            r = cli_bi_model(file, file_size, o->kernel, wt, conv, &extra, &err);
            model = extra;
        }
        memset(&emi, 0, sizeof emi);
        if (r == SUPERMAT_SUCCESS) {
            supermat_model_get_info(model, &emi);
            sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.views = nviews; sd.threading = hook;
            r = supermat_session_memory(&sd, &sbytes, &err);
        }
        if (r == SUPERMAT_SUCCESS) r = supermat_session_create(&sd, &sess, &err);
        for (k = 0; k < 3; k++) maps[k] = k < in.nmaps && cli_bi_wants(&in, outputs, k) ? (mode == CLI_MODE_F32 ? ref[k] : cur[k]) : NULL;
        for (rep = 0; rep < o->repeats && r == SUPERMAT_SUCCESS; rep++) {
            double t0 = cli_now(), t;
            r = cli_bi_run(sess, &in, maps, &err);
            t = cli_now() - t0;
            if (t < best) best = t;
        }
        if (r == SUPERMAT_SUCCESS) {
            memset(&fl, 0, sizeof fl);
            supermat_session_last_flops(sess, &fl);
            row->done = 1;
            row->seconds = best;
            if (mode == CLI_MODE_F32) f32_seconds = best;
            row->speedup = best > 0 ? f32_seconds / best : 0.0;
            row->peak_bytes = emi.model_bytes + sbytes;
            row->flops = fl.total;
            for (k = 0; k < in.nmaps; k++) if (maps[k]) cli_bi_compare(&in, k, ref[k], maps[k], row);
            for (k = 0; k < in.nmaps; k++) if (maps[k] && in.truth[k]) cli_bi_compare_truth(&in, k, maps[k], row);
            cli_bi_print_row(&in, row);
        } else {
            fflush(stdout);
            cli_lib_error(what, r, &err);
            printf("%-18s failed: %s\n", cli_modes[mode].name, err.message[0] ? err.message : supermat_result_string(r));
            fflush(stdout);
            failed++;
            if (mode == CLI_MODE_F32) rc = CLI_FAIL; /* no reference: nothing to compare with */
        }
        supermat_session_destroy(sess);
        supermat_model_destroy(extra);
    }

    if (rc == CLI_OK) {
        for (i = 0; i < nskipped; i++) printf("%-18s skipped: %s\n", cli_modes[skipped_mode[i]].name, skipped[i]);
        printf("\nseconds: supermat_run only; speedup: f32 seconds / seconds; peak MiB: model + session arena (supermat_session_memory);\n"
               "psnr, psnr_fg (dB, capped at %.0f), max_abs: against the f32 maps (float, [0, 1]), all pixels and the foreground (%s)\n",
               CLI_PSNR_CAP, mi.kind == SUPERMAT_KIND_UV_REFINE ? "mask > 0.5" : "input alpha > 0");
        if (in.any_truth)
            printf("gt_psnr (dB, capped at %.0f): against the truth files, the maps quantised to 8 bits as `supermat image` writes them,\n"
                   "over the object's pixels (input alpha >= 128); - where no truth was given or the mode does not compute the map\n",
                   CLI_PSNR_CAP);
        if (jf) {
            FILE *f = jf;
            int ok;
            jf = NULL;
            ok = cli_bi_write_json(f, o->json_path, &in, rows, nrows) == CLI_OK; /* closes f */
            if (cli_mem_commit(&jm, o->json_path, ok, 1) != CLI_OK) rc = CLI_FAIL;
        }
        if (failed) {
            cli_error("%d mode%s failed (see above)", failed, failed == 1 ? "" : "s");
            rc = CLI_FAIL;
        }
    }

    if (jf) cli_mem_commit(&jm, o->json_path, 0, 0); /* nothing measured: no file */
    for (k = 0; k < 3; k++) { free(ref[k]); free(cur[k]); free(in.ov[k]); if (in.truth[k]) stbi_image_free(in.truth[k]); }
    free(in.gt_mask);
    for (i = 0; i < o->nimg; i++) if (px[i]) stbi_image_free(px[i]);
    if (in.mask) stbi_image_free(in.mask);
    if (in.pos) stbi_image_free(in.pos);
    free(in.in); free(in.fg); free(c2w); free(cams);
    supermat_model_destroy(base);
    cli_free_file(file);
#if SUPERMAT__HAS_PTHREADS
    supermat_pool_destroy(pool);
#endif
    (void)pool;
    return rc;
}

/* `supermat bench`: the options, then (a), (b), (c) above, or with --image cli_bench_image() */
static int cli_bench(int argc, char **argv) {
    const char *cmd = "bench", *v, *model_arg = NULL, *model_path = NULL, *json_path = NULL;
    int w = 512, h = 512, threads = 0, repeats = 1, i, m, rc = CLI_OK, nrows = 0, rep, x, y, k;
    int views = 0, nviews = 1, pipeline_only = 0;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    unsigned char *file = NULL, *rgba = NULL, *alb = NULL, *rough = NULL, *metal = NULL, *mask = NULL, *pos = NULL;
    supermat_image *in_v = NULL, *alb_v = NULL, *rough_v = NULL, *metal_v = NULL;
    float *c2w = NULL;
    size_t file_size = 0, session_bytes = 0, np = 0, rss = 0;
    long fma_iters = 0;
    supermat_model *model = NULL;
    supermat_model_info mi;
    supermat_session *sess = NULL;
    supermat_session_desc sd;
    supermat_threading hook;
    supermat_flops fl;
    supermat_error err;
    supermat_result r;
    supermat_pool *pool = NULL;
    double peak = 0.0, peak1 = 0.0, create_s = 0.0, best_total = 1e30, sum_total = 0.0;
    double gemm_flops = 2.0 * CLI_GEMM_HW * CLI_GEMM_HW * (double)CLI_GEMM_C * 9.0 * CLI_GEMM_C;
    double t_avx2 = -1.0, t_scalar = -1.0, gemm_diff = 0.0;
    cli_row rows[CLI_MAX_ROWS];
    cli_events ev;
    char outs_s[64];
    cli_bench_opts bo;
    int size_given = 0, outputs_given = 0, weights_given = 0, modes_given = 0;
    cli_model_ref mref;

    memset(&bo, 0, sizeof bo);
    bo.modes_all = 1;

    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_bench, stdout); fputs(cli_usage_bench_image, stdout); fputs(cli_usage_bench_truth, stdout); cli_print_default_model_help(); return CLI_OK; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--model", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            model_arg = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--size", &v)) != 0) {
            if (m < 0 || cli_parse_size(cmd, v, &w, &h)) return CLI_USAGE;
            size_given = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 64, &threads)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--repeats", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--repeats", v, 1, 1000, &repeats)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--views", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--views", v, 1, CLI_MAX_VIEWS, &views)) return CLI_USAGE;
        } else if (!strcmp(a, "--pipeline-only")) {
            pipeline_only = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--outputs", &v)) != 0) {
            if (m < 0 || cli_parse_outputs(cmd, v, &outputs)) return CLI_USAGE;
            outputs_given = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--kernel", &v)) != 0) {
            if (m < 0 || cli_parse_kernel(cmd, v, &kernel)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0) {
            if (m < 0 || cli_parse_weights(cmd, v)) return CLI_USAGE;
            weights_given = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--json", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            json_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--image", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            if (bo.nimg == CLI_MAX_VIEWS) return cli_usage_error(cmd, "more than %d --image views: at most %d are processed together", CLI_MAX_VIEWS, CLI_MAX_VIEWS);
            bo.images[bo.nimg++] = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--mask", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            bo.mask_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--position", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            bo.pos_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--cameras", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            bo.cam_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--modes", &v)) != 0) {
            if (m < 0 || cli_parse_modes(cmd, v, bo.modes, &bo.nmodes, &bo.modes_all)) return CLI_USAGE;
            modes_given = 1;
        } else if (!strncmp(a, "--truth-", 8)) {
            static const char *const truth_opts[3] = {"--truth-albedo", "--truth-roughness", "--truth-metallic"};
            for (k = 0; k < 3; k++) if ((m = cli_opt(cmd, argc, argv, &i, truth_opts[k], &v)) != 0) break;
            if (k == 3) return cli_usage_error(cmd, "unknown option '%s' (--truth-albedo, --truth-roughness, --truth-metallic)", a);
            if (m < 0) return CLI_USAGE;
            if (!v[0]) return cli_usage_error(cmd, "%s: an empty file name", truth_opts[k]);
            bo.truth_paths[k] = v;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            return cli_usage_error(cmd, "unexpected argument '%s'", a);
        }
    }
    if (bo.nimg) {
        if (size_given) return cli_usage_error(cmd, "--size does not apply with --image (the image's own size is used)");
        if (outputs_given) return cli_usage_error(cmd, "--outputs does not apply with --image (the modes choose the outputs)");
        if (weights_given) return cli_usage_error(cmd, "--weights does not apply with --image (use --modes f16,bf16,int8)");
        if (pipeline_only) return cli_usage_error(cmd, "--pipeline-only does not apply with --image");
        if ((rc = cli_model_path(cmd, model_arg, 1, &mref)) != CLI_OK) return rc;
        model_path = mref.path;
        bo.model_path = model_path; bo.json_path = json_path; bo.views = views; bo.threads = threads; bo.repeats = repeats;
        bo.kernel = kernel;
        return cli_bench_image(&bo);
    }
    if (modes_given || bo.mask_path || bo.pos_path || bo.cam_path)
        return cli_usage_error(cmd, "%s needs --image", modes_given ? "--modes" : bo.mask_path ? "--mask" : bo.pos_path ? "--position" : "--cameras");
    for (k = 0; k < 3; k++)
        if (bo.truth_paths[k])
            return cli_usage_error(cmd, "--truth-%s needs --image (it is compared with the maps of --image)", cli_bi_map_names[k]);
    if ((rc = cli_model_path(cmd, model_arg, 1, &mref)) != CLI_OK) return rc;
    model_path = mref.path;
    memset(&mi, 0, sizeof mi);
    memset(&fl, 0, sizeof fl);
    if (json_path && cli_out_allowed(json_path) != CLI_OK) { /* the report would be refused: before measuring */
        if (cli_policy == CLI_POLICY_SKIP) cli_error("'%s' exists: --skip-existing keeps files, --force replaces this report", json_path);
        return CLI_FAIL;
    }

    /* one pool for everything: the FMA peak, the session and the GEMM */
#if SUPERMAT__HAS_PTHREADS
    if (supermat_pool_create(threads, NULL, &pool, &hook) != SUPERMAT_SUCCESS) { cli_error("cannot create the thread pool"); return CLI_FAIL; }
#else
    hook.parallel_for = cli_serial_for; hook.user = NULL; hook.max_threads = 1;
#endif
    (void)cli_serial_for;

    /* (a) here and again at the end (the best counts: a busy neighbour only lowers it) */
    if (!pipeline_only) {
        peak1 = cli_fma_peak(NULL, 3, &fma_iters);
        peak = cli_fma_peak(&hook, 3, &fma_iters);
    }

    /* (b) */
    rc = cli_load_model(model_path, kernel, &file, &file_size, &model, &create_s);
    if (rc == CLI_OK) {
        supermat_model_get_info(model, &mi);
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) nviews = views ? views : 6;
        else if (views > 1) {
            cli_error("--views %d: model '%s' is a %s model, only a supermat-mv model takes several views", views, model_path,
                      cli_kind_name(mi.kind));
            rc = CLI_FAIL;
        }
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) outputs = SUPERMAT_OUTPUT_ALL; /* one refined map, whatever --outputs says */
    }
    if (mi.kind == SUPERMAT_KIND_UV_REFINE) snprintf(outs_s, sizeof outs_s, "refined");
    else cli_outputs_string(outputs, outs_s, sizeof outs_s);
    if (rc == CLI_OK) {
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.views = nviews; sd.threading = hook;
        r = supermat_session_memory(&sd, &session_bytes, &err);
        if (r == SUPERMAT_SUCCESS) r = supermat_session_create(&sd, &sess, &err);
        if (r != SUPERMAT_SUCCESS) { cli_lib_error("session", r, &err); rc = CLI_FAIL; }
    }
    if (rc == CLI_OK) {
        size_t nv = (size_t)nviews;
        np = (size_t)w * (size_t)h;
        rgba = (unsigned char *)malloc(np * 4 * nv);
        alb = (unsigned char *)malloc(np * 3 * nv); /* uv-refine: the refined map */
        rough = (unsigned char *)malloc(np * nv);
        metal = (unsigned char *)malloc(np * nv);
        mask = (unsigned char *)malloc(np);
        pos = (unsigned char *)malloc(np * 3);
        in_v = (supermat_image *)calloc(nv, sizeof *in_v);
        alb_v = (supermat_image *)calloc(nv, sizeof *alb_v);
        rough_v = (supermat_image *)calloc(nv, sizeof *rough_v);
        metal_v = (supermat_image *)calloc(nv, sizeof *metal_v);
        c2w = (float *)calloc(nv * 16, sizeof(float));
        if (!rgba || !alb || !rough || !metal || !mask || !pos || !in_v || !alb_v || !rough_v || !metal_v || !c2w) {
            cli_error("out of memory");
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) {
        /* a deterministic pattern per view: gradients, a checker, an opaque disk (moving from view to view) on
           transparent noise; for uv-refine the same as the map (alpha ignored), banded mask, gradient positions */
        uint32_t seed = 7u;
        for (k = 0; k < nviews; k++) {
            double cx = 0.5 + 0.05 * sin(2.0 * 3.14159265358979323846 * k / nviews);
            for (y = 0; y < h; y++)
                for (x = 0; x < w; x++) {
                    unsigned char *p = rgba + (((size_t)k * h + y) * w + x) * 4;
                    double dx = (x + 0.5) / w - cx, dy = (y + 0.5) / h - 0.5, d = sqrt(dx * dx + dy * dy);
                    int inside = d < 0.4, check = ((x / 8) + (y / 8) + k) & 1;
                    p[0] = (unsigned char)(inside ? 40 + 180 * x / w : (int)(cli_rand(&seed) & 255u));
                    p[1] = (unsigned char)(inside ? 40 + 180 * y / h : (int)(cli_rand(&seed) & 255u));
                    p[2] = (unsigned char)(inside ? (check ? 200 : 60) : (int)(cli_rand(&seed) & 255u));
                    p[3] = (unsigned char)(inside ? 255 : d < 0.41 ? 128 : 0);
                }
        }
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++) {
                size_t o = (size_t)y * w + x;
                mask[o] = (unsigned char)(85 * (((x / 16) + (y / 16)) % 4));
                pos[o * 3] = (unsigned char)(255 * x / w);
                pos[o * 3 + 1] = (unsigned char)(255 * y / h);
                pos[o * 3 + 2] = 127;
            }
        cli_ring_cameras(nviews, c2w);
        for (k = 0; k < nviews; k++) {
            in_v[k].pixels = rgba + np * 4 * (size_t)k; in_v[k].width = w; in_v[k].height = h; in_v[k].channels = 4;
            alb_v[k].pixels = alb + np * 3 * (size_t)k; alb_v[k].channels = 3;
            rough_v[k].pixels = rough + np * (size_t)k; rough_v[k].channels = 1;
            metal_v[k].pixels = metal + np * (size_t)k; metal_v[k].channels = 1;
        }
    }
    for (rep = 0; rep < repeats && rc == CLI_OK; rep++) {
        supermat_run_desc rd;
        double t0, t1;
        cli_row tmp[CLI_MAX_ROWS];
        int n;
        memset(&rd, 0, sizeof rd);
        rd.input = in_v[0];
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) {
            rd.mask.pixels = mask; rd.mask.width = w; rd.mask.height = h; rd.mask.channels = 1;
            rd.position.pixels = pos; rd.position.width = w; rd.position.height = h; rd.position.channels = 3;
            rd.refined = alb_v[0];
        } else if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            rd.input_views = in_v;
            rd.cameras = c2w;
            if (outputs & SUPERMAT_OUTPUT_ALBEDO) rd.albedo_views = alb_v;
            if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) rd.roughness_views = rough_v;
            if (outputs & SUPERMAT_OUTPUT_METALLIC) rd.metallic_views = metal_v;
        } else {
            if (outputs & SUPERMAT_OUTPUT_ALBEDO) rd.albedo = alb_v[0];
            if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) rd.roughness = rough_v[0];
            if (outputs & SUPERMAT_OUTPUT_METALLIC) rd.metallic = metal_v[0];
        }
        memset(&ev, 0, sizeof ev);
        rd.inspect = cli_inspect_cb; rd.inspect_user = &ev;
        t0 = cli_now();
        r = supermat_run(sess, &rd, &err);
        t1 = cli_now();
        if (r != SUPERMAT_SUCCESS) { cli_lib_error("run", r, &err); rc = CLI_FAIL; break; }
        supermat_session_flops(sess, &fl);
        n = cli_rows(&ev, t0, t1, &fl, &mi, tmp);
        sum_total += t1 - t0;
        if (t1 - t0 < best_total) { best_total = t1 - t0; nrows = n; memcpy(rows, tmp, sizeof(cli_row) * (size_t)n); }
    }

    rss = cli_peak_rss(); /* the pipeline's peak, before the GEMM's buffers */

    /* (c) */
    if (rc == CLI_OK && !pipeline_only) {
        cli_gemm g;
        float *ref = NULL;
        size_t nout = (size_t)CLI_GEMM_HW * CLI_GEMM_HW * CLI_GEMM_C, k;
        if (cli_gemm_init(&g, hook.max_threads) != CLI_OK || !(ref = (float *)malloc(nout * sizeof(float)))) {
            cli_error("out of memory for the GEMM benchmark");
            rc = CLI_FAIL;
        } else {
#if SUPERMAT__HAS_AVX2
            if (supermat_cpu_has_avx2()) t_avx2 = cli_gemm_time(&g, supermat__ukr_avx2, &hook, 0.5, ref);
#endif
            t_scalar = cli_gemm_time(&g, supermat__ukr_scalar, &hook, 1.0, NULL);
            if (t_avx2 > 0) {
                double mx = 0.0, md = 0.0;
                for (k = 0; k < nout; k++) {
                    double a = fabs((double)ref[k]), d = fabs((double)ref[k] - (double)g.out.d[k]);
                    if (a > mx) mx = a;
                    if (d > md) md = d;
                }
                gemm_diff = mx > 0 ? md / mx : md;
            }
        }
        free(ref);
        cli_gemm_free(&g);
    }

    if (rc == CLI_OK && !pipeline_only) {
        double p1 = cli_fma_peak(NULL, 3, &fma_iters), pa = cli_fma_peak(&hook, 3, &fma_iters);
        if (p1 > peak1) peak1 = p1;
        if (pa > peak) peak = pa;
    }
    if (rc == CLI_OK) {
        size_t planned = mi.model_bytes + session_bytes;
        double total_flops = fl.total;
        FILE *jf = NULL;
        cli_mem jm;
        char vs[32];
        vs[0] = 0;
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) snprintf(vs, sizeof vs, " x %d view%s", nviews, nviews == 1 ? "" : "s");
        printf("supermat bench: %s (%s, kernel %s), %dx%d%s, outputs %s, %d thread%s\n", model_path, cli_kind_name(mi.kind),
               cli_kernel_name(mi.kernel), w, h, vs, outs_s, hook.max_threads, hook.max_threads == 1 ? "" : "s");
        if (pipeline_only) printf("FMA peak      skipped (--pipeline-only)\n");
        else if (peak > 0) printf("FMA peak      %.1f GFLOP/s on %d thread%s, %.1f GFLOP/s on one (AVX2, %d independent _mm256_fmadd_ps chains; best of 6)\n",
                             peak, hook.max_threads, hook.max_threads == 1 ? "" : "s", peak1, CLI_FMA_CHAINS);
        else printf("FMA peak      n/a (no AVX2/FMA on this CPU or in this build)\n");
        printf("model create  %.3f s (validation and weight packing)\n", create_s);
        printf("\n%-32s %9s %9s %9s %7s\n", repeats > 1 ? "stage (fastest run)" : "stage", "seconds", "GFLOP", "GFLOP/s", "% peak");
        for (i = 0; i < nrows; i++) {
            printf("%-32s %9.4f %9.3f", rows[i].name, rows[i].seconds, rows[i].flops / 1e9);
            if (rows[i].flops > 0 && rows[i].seconds > 0) {
                double gfs = rows[i].flops / rows[i].seconds / 1e9;
                printf(" %9.2f", gfs);
                if (peak > 0) printf(" %6.1f%%", 100.0 * gfs / peak);
                else printf(" %7s", "-");
            } else printf(" %9s %7s", "-", "-");
            printf("\n");
        }
        printf("%-32s %9.4f %9.3f %9.2f", "total", best_total, total_flops / 1e9, total_flops / best_total / 1e9);
        if (peak > 0) printf(" %6.1f%%", 100.0 * total_flops / best_total / 1e9 / peak);
        else printf(" %7s", "-");
        printf("\n");
        if (repeats > 1) printf("(%d runs, mean total %.4f s)\n", repeats, sum_total / repeats);
        printf("\nmemory        model %.1f MiB + session %.1f MiB = %.1f MiB planned; process peak RSS %.1f MiB (getrusage, after the runs; includes the %.1f MiB file buffer)\n",
               cli_mib((double)mi.model_bytes), cli_mib((double)session_bytes), cli_mib((double)planned), cli_mib((double)rss),
               cli_mib((double)file_size));
        if (pipeline_only) printf("conv GEMM     skipped (--pipeline-only)\n");
        else printf("conv GEMM     3x3, %dx%dx%d -> %d (M=%d, K=%d, N=%d, %.2f GFLOP), packed weights, %d thread%s:\n", CLI_GEMM_HW,
               CLI_GEMM_HW, CLI_GEMM_C, CLI_GEMM_C, CLI_GEMM_HW * CLI_GEMM_HW, 9 * CLI_GEMM_C, CLI_GEMM_C, gemm_flops / 1e9,
               hook.max_threads, hook.max_threads == 1 ? "" : "s");
        if (t_avx2 > 0) printf("              avx2   %8.2f GFLOP/s (%.4f s)\n", gemm_flops / t_avx2 / 1e9, t_avx2);
        else if (!pipeline_only) printf("              avx2   n/a\n");
        if (t_scalar > 0) printf("              scalar %8.2f GFLOP/s (%.4f s)\n", gemm_flops / t_scalar / 1e9, t_scalar);
        if (t_avx2 > 0) printf("              ratio  %.1fx (avx2 / scalar); max difference %.2g of max |C|; avx2 at %.1f%% of the FMA peak\n",
                               t_scalar / t_avx2, gemm_diff, peak > 0 ? 100.0 * gemm_flops / t_avx2 / 1e9 / peak : 0.0);

        if (json_path) {
            jf = cli_mem_open(&jm, json_path);
            if (!jf) rc = CLI_FAIL;
        }
        if (jf) {
            fprintf(jf, "{\n  \"version\": \"%d.%d.%d\",\n  \"model\": ", (SUPERMAT_VERSION >> 16) & 255, (SUPERMAT_VERSION >> 8) & 255,
                    SUPERMAT_VERSION & 255);
            cli_json_string(jf, model_path);
            fprintf(jf, ",\n  \"kind\": \"%s\",\n  \"kernel\": \"%s\",\n  \"width\": %d,\n  \"height\": %d,\n  \"views\": %d,\n  \"outputs\": \"%s\",\n",
                    cli_kind_name(mi.kind), cli_kernel_name(mi.kernel), w, h, nviews, outs_s);
            fprintf(jf, "  \"threads\": %d,\n  \"repeats\": %d,\n  \"fma_peak_gflops\": %.6g,\n  \"fma_peak_one_thread_gflops\": %.6g,\n  \"model_create_seconds\": %.6g,\n",
                    hook.max_threads, repeats, peak, peak1, create_s);
            fprintf(jf, "  \"stages\": [\n");
            for (i = 0; i < nrows; i++) {
                double gfs = rows[i].seconds > 0 ? rows[i].flops / rows[i].seconds / 1e9 : 0.0;
                fprintf(jf, "    {\"stage\": ");
                cli_json_string(jf, rows[i].name);
                fprintf(jf, ", \"seconds\": %.6g, \"gflop\": %.6g, \"gflops\": %.6g, \"percent_of_peak\": %.6g}%s\n", rows[i].seconds,
                        rows[i].flops / 1e9, gfs, peak > 0 ? 100.0 * gfs / peak : 0.0, i + 1 < nrows ? "," : "");
            }
            fprintf(jf, "  ],\n  \"total\": {\"seconds\": %.6g, \"mean_seconds\": %.6g, \"gflop\": %.6g, \"gflops\": %.6g, \"percent_of_peak\": %.6g},\n",
                    best_total, sum_total / repeats, total_flops / 1e9, total_flops / best_total / 1e9,
                    peak > 0 ? 100.0 * total_flops / best_total / 1e9 / peak : 0.0);
            fprintf(jf, "  \"flops\": {\"encode\": %.6g, \"trunk\": %.6g, \"branch\": %.6g, \"decode\": %.6g, \"total\": %.6g},\n",
                    fl.encode, fl.trunk, fl.branch, fl.decode, fl.total);
            fprintf(jf, "  \"memory\": {\"model_bytes\": %llu, \"session_bytes\": %llu, \"planned_bytes\": %llu, \"peak_rss_bytes\": %llu, \"file_bytes\": %llu},\n",
                    (unsigned long long)mi.model_bytes, (unsigned long long)session_bytes, (unsigned long long)planned,
                    (unsigned long long)rss, (unsigned long long)file_size);
            if (pipeline_only) fprintf(jf, "  \"gemm\": null\n}\n");
            else fprintf(jf, "  \"gemm\": {\"M\": %d, \"K\": %d, \"N\": %d, \"gflop\": %.6g, \"avx2_gflops\": %.6g, \"scalar_gflops\": %.6g, \"ratio\": %.6g, \"max_rel_diff\": %.6g}\n}\n",
                    CLI_GEMM_HW * CLI_GEMM_HW, 9 * CLI_GEMM_C, CLI_GEMM_C, gemm_flops / 1e9, t_avx2 > 0 ? gemm_flops / t_avx2 / 1e9 : 0.0,
                    t_scalar > 0 ? gemm_flops / t_scalar / 1e9 : 0.0, t_avx2 > 0 ? t_scalar / t_avx2 : 0.0, gemm_diff);
            if (cli_mem_commit(&jm, json_path, 1, 0) != CLI_OK) rc = CLI_FAIL;
        }
    }

    free(rgba); free(alb); free(rough); free(metal); free(mask); free(pos);
    free(in_v); free(alb_v); free(rough_v); free(metal_v); free(c2w);
    supermat_session_destroy(sess);
    supermat_model_destroy(model);
    cli_free_file(file);
#if SUPERMAT__HAS_PTHREADS
    supermat_pool_destroy(pool);
#endif
    (void)pool;
    return rc;
}

/* >>sheet */
static const char cli_usage_sheet[] =
    "usage: supermat sheet --out SHEET.png [--cell N] [--labels LIST] ROW...\n"
    "\n"
    "Puts pictures side by side in one PNG, a contact sheet. Each ROW is one row of the sheet: a comma\n"
    "list of image files (read with stb_image: PNG, JPEG, BMP, TGA, ...), one per column; - leaves a\n"
    "cell empty, and a row shorter than the longest leaves its last cells empty. For a picture and its\n"
    "maps:\n"
    "  supermat sheet --out sheet.png --labels input,albedo,roughness,metallic \\\n"
    "      photo.png,out/photo_albedo.png,out/photo_roughness.png,out/photo_metallic.png\n"
    "\n"
    "Each image is resized to fit an N x N cell keeping its shape (square images fill it; a box\n"
    "filter when shrinking, bilinear when enlarging) and centred in it. Transparent pixels show a\n"
    "light checkerboard behind them; gray images are shown as gray. Cells are separated by 4-pixel\n"
    "gutters on a white background: the sheet is 4 + C * (N + 4) pixels wide and 4 + R * (N + 4)\n"
    "high for C columns and R rows, plus 8 * S + 4 rows for the labels when --labels is given\n"
    "(S = 1 + N / 256, the text scale: 1 up to N = 255). The PNG is RGB, 8-bit, written as\n"
    "SHEET.png.tmp and renamed when complete; on any error nothing is written.\n"
    "\n"
    "options:\n"
    "  --out FILE        the PNG to write (required)\n"
    "  --cell N          the cell size in pixels, 8 to 1024 (default 128)\n"
    "  --labels LIST     comma list of column titles, printed above the columns in a small bitmap\n"
    "                    font (letters, digits, space and . , _ - / ( ) : = + % ' ! ?; any other\n"
    "                    character prints as ?); a title wider than its column is cut\n";

/* 5x8 glyphs of the characters in cli_font_chars: 8 rows top to bottom (rows 0-6 above the
   baseline, row 7 below it), bit 4 = the leftmost column */
static const char cli_font_chars[] = " !%'()+,-./0123456789:=?ABCDEFGHIJKLMNOPQRSTUVWXYZ_abcdefghijklmnopqrstuvwxyz";
static const unsigned char cli_font[][8] = {
    {0x00,0x00,0x00,0x00,0x00,0x00,0x00,0x00}, {0x04,0x04,0x04,0x04,0x04,0x00,0x04,0x00}, {0x18,0x19,0x02,0x04,0x08,0x13,0x03,0x00}, {0x04,0x04,0x08,0x00,0x00,0x00,0x00,0x00},
    {0x02,0x04,0x08,0x08,0x08,0x04,0x02,0x00}, {0x08,0x04,0x02,0x02,0x02,0x04,0x08,0x00}, {0x00,0x04,0x04,0x1f,0x04,0x04,0x00,0x00}, {0x00,0x00,0x00,0x00,0x00,0x06,0x04,0x08},
    {0x00,0x00,0x00,0x1f,0x00,0x00,0x00,0x00}, {0x00,0x00,0x00,0x00,0x00,0x0c,0x0c,0x00}, {0x01,0x02,0x02,0x04,0x08,0x08,0x10,0x00}, {0x0e,0x11,0x13,0x15,0x19,0x11,0x0e,0x00},
    {0x04,0x0c,0x04,0x04,0x04,0x04,0x0e,0x00}, {0x0e,0x11,0x01,0x02,0x04,0x08,0x1f,0x00}, {0x1f,0x02,0x04,0x02,0x01,0x11,0x0e,0x00}, {0x02,0x06,0x0a,0x12,0x1f,0x02,0x02,0x00},
    {0x1f,0x10,0x1e,0x01,0x01,0x11,0x0e,0x00}, {0x06,0x08,0x10,0x1e,0x11,0x11,0x0e,0x00}, {0x1f,0x01,0x02,0x04,0x08,0x08,0x08,0x00}, {0x0e,0x11,0x11,0x0e,0x11,0x11,0x0e,0x00},
    {0x0e,0x11,0x11,0x0f,0x01,0x02,0x0c,0x00}, {0x00,0x0c,0x0c,0x00,0x0c,0x0c,0x00,0x00}, {0x00,0x00,0x1f,0x00,0x1f,0x00,0x00,0x00}, {0x0e,0x11,0x01,0x02,0x04,0x00,0x04,0x00},
    {0x0e,0x11,0x11,0x1f,0x11,0x11,0x11,0x00}, {0x1e,0x11,0x11,0x1e,0x11,0x11,0x1e,0x00}, {0x0e,0x11,0x10,0x10,0x10,0x11,0x0e,0x00}, {0x1c,0x12,0x11,0x11,0x11,0x12,0x1c,0x00},
    {0x1f,0x10,0x10,0x1e,0x10,0x10,0x1f,0x00}, {0x1f,0x10,0x10,0x1e,0x10,0x10,0x10,0x00}, {0x0e,0x11,0x10,0x17,0x11,0x11,0x0f,0x00}, {0x11,0x11,0x11,0x1f,0x11,0x11,0x11,0x00},
    {0x0e,0x04,0x04,0x04,0x04,0x04,0x0e,0x00}, {0x07,0x02,0x02,0x02,0x02,0x12,0x0c,0x00}, {0x11,0x12,0x14,0x18,0x14,0x12,0x11,0x00}, {0x10,0x10,0x10,0x10,0x10,0x10,0x1f,0x00},
    {0x11,0x1b,0x15,0x15,0x11,0x11,0x11,0x00}, {0x11,0x11,0x19,0x15,0x13,0x11,0x11,0x00}, {0x0e,0x11,0x11,0x11,0x11,0x11,0x0e,0x00}, {0x1e,0x11,0x11,0x1e,0x10,0x10,0x10,0x00},
    {0x0e,0x11,0x11,0x11,0x15,0x12,0x0d,0x00}, {0x1e,0x11,0x11,0x1e,0x14,0x12,0x11,0x00}, {0x0f,0x10,0x10,0x0e,0x01,0x01,0x1e,0x00}, {0x1f,0x04,0x04,0x04,0x04,0x04,0x04,0x00},
    {0x11,0x11,0x11,0x11,0x11,0x11,0x0e,0x00}, {0x11,0x11,0x11,0x11,0x11,0x0a,0x04,0x00}, {0x11,0x11,0x11,0x15,0x15,0x15,0x0a,0x00}, {0x11,0x11,0x0a,0x04,0x0a,0x11,0x11,0x00},
    {0x11,0x11,0x0a,0x04,0x04,0x04,0x04,0x00}, {0x1f,0x01,0x02,0x04,0x08,0x10,0x1f,0x00}, {0x00,0x00,0x00,0x00,0x00,0x00,0x00,0x1f}, {0x00,0x00,0x0e,0x01,0x0f,0x11,0x0f,0x00},
    {0x10,0x10,0x16,0x19,0x11,0x11,0x1e,0x00}, {0x00,0x00,0x0e,0x10,0x10,0x11,0x0e,0x00}, {0x01,0x01,0x0d,0x13,0x11,0x11,0x0f,0x00}, {0x00,0x00,0x0e,0x11,0x1f,0x10,0x0e,0x00},
    {0x06,0x09,0x08,0x1c,0x08,0x08,0x08,0x00}, {0x00,0x00,0x0f,0x11,0x11,0x0f,0x01,0x0e}, {0x10,0x10,0x16,0x19,0x11,0x11,0x11,0x00}, {0x04,0x00,0x0c,0x04,0x04,0x04,0x0e,0x00},
    {0x02,0x00,0x06,0x02,0x02,0x02,0x12,0x0c}, {0x10,0x10,0x12,0x14,0x18,0x14,0x12,0x00}, {0x0c,0x04,0x04,0x04,0x04,0x04,0x0e,0x00}, {0x00,0x00,0x1a,0x15,0x15,0x11,0x11,0x00},
    {0x00,0x00,0x16,0x19,0x11,0x11,0x11,0x00}, {0x00,0x00,0x0e,0x11,0x11,0x11,0x0e,0x00}, {0x00,0x00,0x1e,0x11,0x11,0x1e,0x10,0x10}, {0x00,0x00,0x0f,0x11,0x11,0x0f,0x01,0x01},
    {0x00,0x00,0x16,0x19,0x10,0x10,0x10,0x00}, {0x00,0x00,0x0f,0x10,0x0e,0x01,0x1e,0x00}, {0x08,0x08,0x1c,0x08,0x08,0x09,0x06,0x00}, {0x00,0x00,0x11,0x11,0x11,0x13,0x0d,0x00},
    {0x00,0x00,0x11,0x11,0x11,0x0a,0x04,0x00}, {0x00,0x00,0x11,0x11,0x15,0x15,0x0a,0x00}, {0x00,0x00,0x11,0x0a,0x04,0x0a,0x11,0x00}, {0x00,0x00,0x11,0x11,0x11,0x0f,0x01,0x0e},
    {0x00,0x00,0x1f,0x02,0x04,0x08,0x1f,0x00},
};
#define CLI_SHEET_GUTTER 4
#define CLI_SHEET_INK 40

static const unsigned char *cli_glyph(char c) {
    const char *p = c ? strchr(cli_font_chars, c) : NULL;
    if (!p) p = strchr(cli_font_chars, '?');
    return cli_font[p - cli_font_chars];
}

/* text of n characters at (x, y) (its top left) in scale s, clipped to the sheet (sw x sh, RGB) */
static void cli_sheet_text(unsigned char *sheet, int sw, int sh, int x, int y, const char *text, int n, int s) {
    int i, r, c, dy, dx;
    for (i = 0; i < n; i++) {
        const unsigned char *g = cli_glyph(text[i]);
        for (r = 0; r < 8; r++)
            for (c = 0; c < 5; c++) {
                if (!(g[r] & (0x10 >> c))) continue;
                for (dy = 0; dy < s; dy++)
                    for (dx = 0; dx < s; dx++) {
                        int px = x + (i * 6 + c) * s + dx, py = y + r * s + dy;
                        unsigned char *p;
                        if (px < 0 || py < 0 || px >= sw || py >= sh) continue;
                        p = sheet + ((size_t)py * sw + px) * 3;
                        p[0] = p[1] = p[2] = CLI_SHEET_INK;
                    }
            }
    }
}

/* The source pixels and weights of each of dst outputs along one axis of src pixels: a box filter
   (each source pixel weighted by how much of it the output pixel covers) when shrinking, bilinear
   (pixel centres aligned, edges clamped) otherwise. idx and w hold dst * *taps entries. */
static int cli_resample_axis(int src, int dst, int **idx, float **w, int *taps) {
    double scale = (double)src / dst;
    int o, k, t = src > dst ? (int)ceil(scale) + 1 : 2;
    *idx = (int *)malloc(sizeof(int) * (size_t)dst * (size_t)t);
    *w = (float *)malloc(sizeof(float) * (size_t)dst * (size_t)t);
    *taps = t;
    if (!*idx || !*w) { free(*idx); free(*w); *idx = NULL; *w = NULL; return CLI_FAIL; }
    for (o = 0; o < dst; o++) {
        int *ii = *idx + (size_t)o * t;
        float *ww = *w + (size_t)o * t;
        if (src > dst) {
            double a = o * scale, b = a + scale;
            int i0 = (int)floor(a);
            for (k = 0; k < t; k++) {
                int i = i0 + k;
                double lo = a > i ? a : i, hi = b < i + 1 ? b : i + 1;
                ii[k] = i < src ? i : src - 1;
                ww[k] = hi > lo && i < src ? (float)((hi - lo) / scale) : 0.0f;
            }
        } else {
            double c = (o + 0.5) * scale - 0.5, f;
            int i0 = (int)floor(c);
            f = c - i0;
            ii[0] = i0 < 0 ? 0 : i0 > src - 1 ? src - 1 : i0;
            ii[1] = i0 + 1 < 0 ? 0 : i0 + 1 > src - 1 ? src - 1 : i0 + 1;
            ww[0] = (float)(1.0 - f);
            ww[1] = (float)f;
        }
    }
    return CLI_OK;
}

/* Draws px (w x h, RGBA 8-bit, straight alpha) resized to dw x dh with its top left at (x0, y0) of
   the sheet (sw pixels wide, RGB), over a checkerboard of q-pixel squares. Resampled with alpha
   premultiplied (no dark fringes), then composited. */
static int cli_sheet_draw(unsigned char *sheet, int sw, int x0, int y0, const unsigned char *px, int w, int h, int dw, int dh, int q) {
    int *ix = NULL, *iy = NULL, tx, ty, x, y, k, c;
    float *wx = NULL, *wy = NULL, *tmp = NULL;
    int rc = CLI_FAIL;
    if (cli_resample_axis(w, dw, &ix, &wx, &tx) != CLI_OK || cli_resample_axis(h, dh, &iy, &wy, &ty) != CLI_OK) goto done;
    tmp = (float *)malloc(sizeof(float) * 4 * (size_t)dw * (size_t)h);
    if (!tmp) goto done;
    for (y = 0; y < h; y++) /* horizontal: premultiplied RGBA in [0, 255] */
        for (x = 0; x < dw; x++) {
            float acc[4] = {0.0f, 0.0f, 0.0f, 0.0f};
            for (k = 0; k < tx; k++) {
                const unsigned char *p = px + ((size_t)y * w + ix[(size_t)x * tx + k]) * 4;
                float wt = wx[(size_t)x * tx + k], a = p[3] * (1.0f / 255.0f);
                if (wt == 0.0f) continue;
                for (c = 0; c < 3; c++) acc[c] += wt * p[c] * a;
                acc[3] += wt * p[3];
            }
            memcpy(tmp + ((size_t)y * dw + x) * 4, acc, sizeof acc);
        }
    for (y = 0; y < dh; y++) /* vertical, then over the checkerboard */
        for (x = 0; x < dw; x++) {
            float acc[4] = {0.0f, 0.0f, 0.0f, 0.0f}, a, bg;
            unsigned char *o = sheet + ((size_t)(y0 + y) * sw + (size_t)(x0 + x)) * 3;
            for (k = 0; k < ty; k++) {
                const float *p = tmp + ((size_t)iy[(size_t)y * ty + k] * dw + x) * 4;
                float wt = wy[(size_t)y * ty + k];
                for (c = 0; c < 4; c++) acc[c] += wt * p[c];
            }
            a = acc[3] * (1.0f / 255.0f);
            a = a < 0.0f ? 0.0f : a > 1.0f ? 1.0f : a;
            bg = ((x / q + y / q) & 1) ? 204.0f : 244.0f;
            for (c = 0; c < 3; c++) {
                float v = acc[c] + (1.0f - a) * bg;
                o[c] = (unsigned char)(v < 0.0f ? 0 : v > 255.0f ? 255 : (int)(v + 0.5f));
            }
        }
    rc = CLI_OK;
done:
    if (rc != CLI_OK) cli_error("out of memory resizing a %dx%d image", w, h);
    free(ix); free(wx); free(iy); free(wy); free(tmp);
    return rc;
}

/* the number of comma-separated entries of s */
static int cli_count_commas(const char *s) {
    int n = 1;
    for (; *s; s++) n += *s == ',';
    return n;
}

/* splits s (modified) at its commas into out[cli_count_commas(s)] */
static void cli_split_commas(char *s, char **out) {
    int n = 0;
    for (;;) {
        char *e = strchr(s, ',');
        out[n++] = s;
        if (!e) break;
        *e = 0;
        s = e + 1;
    }
}

static int cli_sheet(int argc, char **argv) {
    const char *cmd = "sheet", *v, *out_path = NULL, *labels_arg = NULL, **row_args;
    int cell = 128, i, m, r, c, nrows = 0, ncols = 0, nlabels = 0, rc = CLI_OK, s, label_h, sw, sh, q;
    char **row_bufs = NULL, ***cells = NULL, *labels_buf = NULL, **labels = NULL;
    int *row_len = NULL;
    unsigned char *sheet = NULL;
    size_t npx;

    row_args = (const char **)malloc(sizeof(char *) * (size_t)(argc > 0 ? argc : 1));
    if (!row_args) { cli_error("out of memory"); return CLI_FAIL; }
    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_sheet, stdout); free(row_args); return CLI_OK; }
        if (!strcmp(a, "--")) { for (i++; i < argc; i++) row_args[nrows++] = argv[i]; break; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--out", &v)) != 0) {
            if (m < 0) { free(row_args); return CLI_USAGE; }
            out_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--cell", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--cell", v, 8, 1024, &cell)) { free(row_args); return CLI_USAGE; }
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--labels", &v)) != 0) {
            if (m < 0) { free(row_args); return CLI_USAGE; }
            labels_arg = v;
        } else if (a[0] == '-' && a[1]) {
            free(row_args);
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            row_args[nrows++] = a;
        }
    }
    if (!out_path) { free(row_args); return cli_usage_error(cmd, "--out SHEET.png is required"); }
    if (!nrows) { free(row_args); return cli_usage_error(cmd, "no rows: give one or more ROWs, each a comma list of images (- for an empty cell)"); }

    /* the rows, split at commas */
    row_bufs = (char **)calloc((size_t)nrows, sizeof *row_bufs);
    cells = (char ***)calloc((size_t)nrows, sizeof *cells);
    row_len = (int *)calloc((size_t)nrows, sizeof *row_len);
    if (!row_bufs || !cells || !row_len) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
    for (r = 0; r < nrows; r++) {
        int n;
        row_bufs[r] = (char *)malloc(strlen(row_args[r]) + 1);
        if (!row_bufs[r]) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        strcpy(row_bufs[r], row_args[r]);
        n = cli_count_commas(row_bufs[r]);
        cells[r] = (char **)malloc(sizeof(char *) * (size_t)n);
        if (!cells[r]) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        cli_split_commas(row_bufs[r], cells[r]);
        row_len[r] = n;
        for (c = 0; c < n; c++)
            if (!cells[r][c][0]) {
                rc = cli_usage_error(cmd, "row %d ('%s'): entry %d is empty (use - for an empty cell)", r + 1, row_args[r], c + 1);
                goto done;
            }
        if (n > ncols) ncols = n;
    }
    if (labels_arg) {
        labels_buf = (char *)malloc(strlen(labels_arg) + 1);
        if (!labels_buf) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        strcpy(labels_buf, labels_arg);
        nlabels = cli_count_commas(labels_buf);
        if (nlabels > ncols) {
            rc = cli_usage_error(cmd, "--labels has %d titles but the sheet has %d column%s", nlabels, ncols, ncols == 1 ? "" : "s");
            goto done;
        }
        labels = (char **)malloc(sizeof(char *) * (size_t)nlabels);
        if (!labels) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        cli_split_commas(labels_buf, labels);
    }

    /* the layout */
    s = 1 + cell / 256;
    label_h = labels ? 8 * s + CLI_SHEET_GUTTER : 0;
    if ((double)ncols * (cell + CLI_SHEET_GUTTER) + CLI_SHEET_GUTTER > 65535.0 ||
        (double)nrows * (cell + CLI_SHEET_GUTTER) + CLI_SHEET_GUTTER + label_h > 65535.0 ||
        ((double)ncols * (cell + CLI_SHEET_GUTTER) * 3.0 + 16.0) * ((double)nrows * (cell + CLI_SHEET_GUTTER) + 16.0 + label_h) > 1.0e9) {
        rc = cli_usage_error(cmd, "%d rows x %d columns of %d pixels are too large for one PNG: use a smaller --cell", nrows, ncols, cell);
        goto done;
    }
    sw = CLI_SHEET_GUTTER + ncols * (cell + CLI_SHEET_GUTTER);
    sh = CLI_SHEET_GUTTER + label_h + nrows * (cell + CLI_SHEET_GUTTER);
    q = cell / 16 > 4 ? cell / 16 : 4;

    /* every image readable before any work */
    for (r = 0; r < nrows; r++)
        for (c = 0; c < row_len[r]; c++) {
            int w, h, ch;
            if (!strcmp(cells[r][c], "-")) continue;
            if (!cli_pic_info(cells[r][c], "image", &w, &h, &ch)) {
                rc = CLI_FAIL;
                goto done;
            }
        }

    npx = (size_t)sw * (size_t)sh;
    sheet = (unsigned char *)malloc(npx * 3);
    if (!sheet) { cli_error("out of memory for a %dx%d sheet", sw, sh); rc = CLI_FAIL; goto done; }
    memset(sheet, 255, npx * 3);
    for (c = 0; c < nlabels; c++) {
        int n = (int)strlen(labels[c]), fit = (cell + s) / (6 * s), tw;
        if (n > fit) n = fit;
        tw = n * 6 * s - s;
        cli_sheet_text(sheet, sw, sh, CLI_SHEET_GUTTER + c * (cell + CLI_SHEET_GUTTER) + (cell - tw) / 2, CLI_SHEET_GUTTER, labels[c], n, s);
    }
    for (r = 0; r < nrows && rc == CLI_OK; r++)
        for (c = 0; c < row_len[r] && rc == CLI_OK; c++) {
            int w = 0, h = 0, ch = 0, dw, dh, x0, y0;
            unsigned char *px;
            if (!strcmp(cells[r][c], "-")) continue;
            px = cli_load(cells[r][c], &w, &h, &ch, 4);
            if (!px) { cli_error("cannot read image '%s': %s", cells[r][c], stbi_failure_reason()); rc = CLI_FAIL; break; }
            if (w >= h) { dw = cell; dh = (int)((double)cell * h / w + 0.5); }
            else { dh = cell; dw = (int)((double)cell * w / h + 0.5); }
            if (dw < 1) dw = 1;
            if (dh < 1) dh = 1;
            x0 = CLI_SHEET_GUTTER + c * (cell + CLI_SHEET_GUTTER) + (cell - dw) / 2;
            y0 = CLI_SHEET_GUTTER + label_h + r * (cell + CLI_SHEET_GUTTER) + (cell - dh) / 2;
            rc = cli_sheet_draw(sheet, sw, x0, y0, px, w, h, dw, dh, q);
            stbi_image_free(px);
        }
    if (rc == CLI_OK) rc = cli_write_png_u8(out_path, sheet, sw, sh, 3);
    if (rc == CLI_OK) printf("wrote %s (%dx%d: %d row%s, %d column%s of %d pixels)\n", out_path, sw, sh, nrows, nrows == 1 ? "" : "s",
                             ncols, ncols == 1 ? "" : "s", cell);

done:
    if (row_bufs) for (r = 0; r < nrows; r++) free(row_bufs[r]);
    if (cells) for (r = 0; r < nrows; r++) free(cells[r]);
    free(row_bufs); free(cells); free(row_len); free(labels_buf); free(labels); free(sheet); free(row_args);
    return rc;
}

/* >>main */
#ifdef SUPERMAT_CLI_MESH
int supermat_cli_mesh(int argc, char **argv); /* tools/supermat_mesh.cpp (tinygltf), when built with it */
#endif

int main(int argc, char **argv) {
    const char *c;
    int i, j;
    /* the overwrite policy, for every command (before a "--", anywhere after the command name) */
    for (i = j = 2; i < argc; i++) {
        if (!strcmp(argv[i], "--")) { while (i < argc) argv[j++] = argv[i++]; break; }
        if (!strcmp(argv[i], "--force") || !strcmp(argv[i], "--skip-existing")) {
            int want = argv[i][2] == 'f' ? CLI_POLICY_FORCE : CLI_POLICY_SKIP;
            if (cli_policy != CLI_POLICY_REFUSE && cli_policy != want) return cli_usage_error(NULL, "--force and --skip-existing exclude each other");
            cli_policy = want;
            continue;
        }
        argv[j++] = argv[i];
    }
    if (argc > 2) { argc = j; argv[argc] = NULL; }
    if (argc < 2) { fputs(cli_usage_main, stderr); return CLI_USAGE; }
    c = argv[1];
    if (!strcmp(c, "--help") || !strcmp(c, "-h") || !strcmp(c, "help")) { fputs(cli_usage_main, stdout); return CLI_OK; }
    if (!strcmp(c, "--version") || !strcmp(c, "-V")) {
        printf("supermat %d.%d.%d\n", (SUPERMAT_VERSION >> 16) & 255, (SUPERMAT_VERSION >> 8) & 255, SUPERMAT_VERSION & 255);
        printf("built with:%s%s\n",
#ifdef SUPERMAT_CLI_WEBP
               " webp",
#else
               "",
#endif
#ifdef SUPERMAT_CLI_MESH
               " mesh"
#else
               ""
#endif
        );
        return CLI_OK;
    }
    cli_accept16 = !strcmp(c, "image") || !strcmp(c, "sheet"); /* image: float input; sheet: shown at 8 bits */
    if (!strcmp(c, "convert")) return cli_convert(argc, argv);
    if (!strcmp(c, "image")) return cli_image(argc, argv);
    if (!strcmp(c, "views")) return cli_views(argc, argv);
    if (!strcmp(c, "refine")) return cli_refine(argc, argv);
    if (!strcmp(c, "info")) return cli_info(argc, argv);
    if (!strcmp(c, "bench")) return cli_bench(argc, argv);
    if (!strcmp(c, "sheet")) return cli_sheet(argc, argv);
    if (!strcmp(c, "mesh")) {
#ifdef SUPERMAT_CLI_MESH
        if (cli_policy != CLI_POLICY_REFUSE) /* the mesh command reads the policy from its arguments */
            argv[argc++] = (char *)(cli_policy == CLI_POLICY_FORCE ? "--force" : "--skip-existing");
        return supermat_cli_mesh(argc - 1, argv + 1);
#else
        cli_error("this supermat was built without tinygltf (libtinygltf-dev): `mesh` is not available");
        return CLI_FAIL;
#endif
    }
    return cli_usage_error(NULL, "unknown command '%s'", c);
}
