/* supermat.h - v0.1 - public domain / MIT - SuperMat PBR material estimation on the CPU
 *
 * A single-header C99 runtime for the SuperMat one-step UNet (a Stable Diffusion 2.1 fine-tune with
 * albedo and roughness/metallic "expert branches") and the Stable Diffusion VAE. It turns a picture
 * of an object into an albedo map, a roughness map and a metallic map, with no Python, no GPU and no
 * framework: libc, libm and (optionally) pthreads.
 *
 * ONE FILE DEFINES THE IMPLEMENTATION
 *     #define SUPERMAT_IMPLEMENTATION
 *     #include "supermat.h"
 * in exactly one C or C++ file; every other file includes it without the define.
 *
 * QUICK START (compiled by the test suite)
 *
 *     supermat_model_desc md; memset(&md, 0, sizeof md);
 *     md.data = file_bytes; md.size = file_size;          // a model file made by `supermat convert`
 *     supermat_model *model; supermat_error err;
 *     if (supermat_model_create(&md, &model, &err) != SUPERMAT_SUCCESS) { puts(err.message); return 1; }
 *     supermat_session_desc sd; memset(&sd, 0, sizeof sd);
 *     sd.model = model; sd.width = w; sd.height = h;       // the picture's size, any
 *     supermat_session *s;                                 // (the model's pipeline: work size, detail, colour)
 *     if (supermat_session_create(&sd, &s, &err) != SUPERMAT_SUCCESS) { ... }
 *     supermat_run_desc rd; memset(&rd, 0, sizeof rd);
 *     rd.input.pixels = rgba; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
 *     rd.albedo.pixels = albedo_rgb8;    rd.albedo.channels = 3;      // format 0 = 8-bit
 *     rd.roughness.pixels = rough8;      rd.roughness.channels = 1;
 *     rd.metallic.pixels = metal8;       rd.metallic.channels = 1;
 *     supermat_run(s, &rd, &err);
 *     supermat_session_destroy(s); supermat_model_destroy(model);
 *
 * THE API (the declarations below, in this order)
 *   supermat_model_create / _destroy      load a model file from memory (validated; weights packed once)
 *   supermat_model_get_info               its architecture, options, memory and recorded pipeline
 *   supermat_model_write_packed           write a file whose weights are already packed (fast loads, mmap)
 *   supermat_session_create / _destroy    plan and allocate everything one picture size needs
 *   supermat_session_memory               what a session would allocate, without allocating
 *   supermat_run                          one picture (or SuperMatMV's views, or a UV map) -> maps
 *   supermat_detail / _memory             the detail step alone, on an albedo made elsewhere (UV bakes)
 *   supermat_parse_curve                  a calibration curve from its text (model files, command lines)
 *   supermat_srgb_to_linear / _linear_to_srgb  the sRGB transfer every step of both headers uses
 *   supermat_result_string                the name of a result code
 *   supermat_pool_create / _destroy       the built-in thread pool, to share between sessions
 *   Tools (the project's CLI and tests use them; an application running models needs none):
 *   supermat_json_*, supermat_safetensors_*   read a model file's header and metadata
 *   supermat_default_threads, supermat_session_desc_threads, supermat_build_optimized, supermat_cpu,
 *   supermat_session_flops / _last_flops  what a run will use and do
 *   supermat_bench_conv_*                 one convolution with a chosen micro-kernel (benchmarks)
 *   Descriptors (model, session, run, detail) are cleared with memset or = {0} before use: 0 is every field's
 *   default, and a descriptor that was not cleared is refused (_start_canary / _end_canary).
 *
 * WHAT IT DOES
 *   - Loads a model from a caller-supplied memory buffer: a safetensors file (F32, F16, BF16, I8) whose
 *     `__metadata__` describes the architecture (see MODEL FILE below). Everything is validated first.
 *   - SuperMat (single view): RGBA (straight alpha) over gray 0.5, [-1, 1], VAE encode (mode x scaling
 *     factor), UNet trunk once, each requested expert branch on the same trunk output and skips, the
 *     one-step trailing-DDIM x0 (v- or epsilon-prediction), VAE decode per branch, x/2 + 0.5 clamped.
 *   - SuperMatMV: the same for a batch of views (session `views`, 6 by default) with each view's
 *     camera-to-world matrix through the camera MLP, and self-attention over the keys of all views in
 *     exactly the layers where the official code installs it (every attn1 outside down_blocks.0).
 *   - UV refine: the partial UV map's latent, the mask and the position map (bilinearly resized to the
 *     latent size as PyTorch does) -> one refined map (albedo or roughness/metallic, by checkpoint).
 *   - Any picture size: the network runs at the model's work size (its file records it) and the maps come
 *     back at the picture's size, made a row at a time into the caller's images: at the picture's size
 *     the session holds no full-size plane (about 2.7 bytes a pixel at 8000x8000 with the default
 *     model's detail step, rings of rows; the rest is the network at the work size). At a picture's own
 *     size (no work size) the sides must be multiples of
 *     8, square or not: where the latent is not a multiple of 8, each upsampler resizes to its skip
 *     tensor's size (nearest), exactly as diffusers does.
 *   - Computes only what was asked: a branch nobody wants is neither run nor decoded.
 *
 * SPEED <-> ACCURACY LEVERS (all off by default = the official computation; `supermat bench --image`
 * measures each against the f32 maps on your input)
 *   model_desc.weights      f32 | f16 | bf16 | int8 GEMM weights (memory /2, /2, /4)
 *   model_desc.conv         Winograd F(2x2,3x3) / F(4x4,3x3) for the 3x3 convolutions (<= 640 channels)
 *   model_desc.compute      bf16 (AVX512_BF16, AMX) or int8 (AVX512_VNNI, AVX-VNNI) products in the GEMMs
 *   session_desc.outputs    only the maps you need (a branch and its decode are skipped)
 *   session_desc.work_*     run the network smaller (or larger) than the model's work size
 *   session_desc.vae_tile   VAE in blended tiles (bounded memory); skip_background: decode only the
 *                           tiles with foreground / UV charts (supermat_session_last_flops tells the work)
 *   session_desc.mv_attention  own-view or strided keys at the highest resolution (SuperMatMV)
 *   session_desc.detail_sigma  not a speed lever and not official: the albedo keeps the picture's own
 *                           detail (picture x low-pass(albedo) / low-pass(picture)); for small networks
 *   session_desc.chroma_weight  not a speed lever and not official: the albedo takes the picture's
 *                           chromaticity at the network's luminance; for small networks
 *   session_desc.roughness_knots  not a speed lever and not official: the roughness map through a
 *                           monotone calibration curve; for networks whose roughness is too narrow
 *   session_desc.metallic_knots  not a speed lever and not official: the metallic map through one; for
 *                           networks that leave a floor of metal on dielectrics
 *
 * WHAT IT DOES NOT DO
 *   - No file I/O, no image decoding: give it pixels; it resamples them to the model's work size (the
 *     official scripts resize to 512x512) and the maps back.
 *   - No text encoder: the empty-prompt context is a constant stored in the model file by the converter.
 *
 * COLOUR SPACES (as the official pipeline, which feeds the network PIL's 8-bit values / 255)
 *   input     RGB is sRGB-encoded, not linear: 8-bit values are used as v / 255, float values (format
 *             F32) as given, the same encoding scaled to 0..1 (values outside 0..1 are not clamped; NaN
 *             and Inf are refused). A linear HDR picture must be tone mapped and sRGB-encoded first.
 *             Alpha is straight (not premultiplied) coverage in 0..1; the picture is composited over
 *             gray 0.5 on the encoded values.
 *   albedo    sRGB-encoded, the glTF baseColor convention (a metal's albedo is its F0 colour): store
 *             it as an sRGB texture as is.
 *   roughness, metallic  linear values in 0..1, the glTF metallicRoughness convention (G and B of a
 *             linear, non-sRGB texture).
 *   refined   (UV refine) the encoding of the map it refines: sRGB albedo, or the linear
 *             roughness / metallic channels.
 *   8-bit outputs are round(v * 255) of the float values, which are clamped to 0..1.
 *
 * CONFIGURATION MACROS (define before including the implementation)
 *   SUPERMAT_CONFIG_HEADER "file.h"  included first, to set the macros below in one place
 *   SUPERMAT_STATIC                   make every function static (private copy per translation unit;
 *                                     marked unused for gcc/clang: no warning for the ones a file skips)
 *   SUPERMAT_API                      decoration for public functions (default extern / static)
 *   SUPERMAT_NO_PTHREADS              leave out the built-in thread pool (pthreads, or Win32 threads on
 *                                     Windows: supply your own parallel-for)
 *   SUPERMAT_NO_AVX2                  leave out the x86-64 AVX2/FMA/F16C kernels (scalar only; also
 *                                     leaves out AVX-512)
 *   SUPERMAT_NO_AVX512                leave out the AVX-512F GEMM micro-kernel (the rest stays AVX2;
 *                                     also leaves out int8 compute, which needs AVX512_VNNI or AVX-VNNI)
 *   SUPERMAT_NO_AVXVNNI               leave out int8 compute on AVX-VNNI (the AVX2 kernel)
 *                                     (the x86-64 kernels build with gcc, clang, MinGW-w64, clang-cl and
 *                                     MSVC x64 without /arch flags, chosen at run time by CPUID / XGETBV;
 *                                     AMX on Linux only)
 *   SUPERMAT_ASSERT(x)                internal assertions (default: none)
 *   SUPERMAT_NO_MADVISE               Linux: do not ask for transparent huge pages on the default
 *                                     allocator's big blocks (weights, arenas)
 *
 * MEMORY
 *   Every byte comes from the caller's allocator (default malloc/free). A model holds the packed
 *   weights (one copy, created once; f32, or f16 / bf16 / int8 with `supermat_model_desc.weights`) and borrows the caller's file buffer for small tensors unless
 *   `copy_data` is set. A session holds one arena planned before anything runs
 *   (`supermat_session_memory` answers its size without allocating); `supermat_run` allocates nothing.
 *   Caps: `model_desc.max_memory` fails model creation (OUT_OF_MEMORY) before the allocation that would
 *   take it past the cap; `session_desc.max_memory` refuses a session whose plan needs more, before any
 *   allocation, with the planned size in the message. A pre-packed model (PRE-PACKED MODELS) holds
 *   almost nothing: its panels stay in the caller's (mapped) buffer.
 *
 * THREADS
 *   A model is immutable and can be shared by any number of sessions on any threads. A session is used
 *   by one thread at a time. Work is spread through a caller's blocking parallel-for hook; without one,
 *   a small built-in pool is created per session (pthreads; Win32 threads, SRW lock and condition
 *   variables on Windows, MSVC and MinGW alike; threads = 0 means all cores the process may use:
 *   affinity, cgroup quota or job-object CPU rate, Apple silicon's performance cores, see
 *   supermat_default_threads; 1 means none).
 *   Work is split over outputs and every sum runs in a fixed order, so results are bit-identical for
 *   any thread count.
 *
 * ERRORS
 *   Every function returns a supermat_result; when given a supermat_error it also fills a message and,
 *   for model files, the tensor concerned. NaN/Inf pixels, wrong shapes, malformed or truncated files,
 *   an allocator returning NULL and cancellation through the progress callback are all reported.
 *   On error no output buffer is written.
 *
 * DETERMINISM AND NUMERICS
 *   All arithmetic is float32 with float64 statistics in the normalisations. The AVX2 and scalar kernels
 *   differ by rounding only (FMA); each is deterministic. The AVX-512 kernel (picked by SUPERMAT_KERNEL_AUTO
 *   where the CPU has AVX-512F) gives the AVX2 kernel's bits: every output element sums the same products
 *   in the same order with FMA, 16 columns per register instead of 8. On aarch64 the NEON kernel (AUTO
 *   there) runs the GEMMs with fmla (fused, like AVX2) and the rest in scalar C. bf16 compute rounds each
 *   GEMM's inputs to bf16 and sums in f32: with vdpbf16ps (`kernel` AVX512) or on AMX tiles (AUTO where
 *   the CPU and Linux grant them), which sum in another order; both stay within 1e-5 (relative) of the
 *   float64 sums of the rounded operands. int8 compute sums exact int32 products of the quantized operands
 *   per 64 rows of K and those chunks in float32 (1e-5 relative of the float64 sums of the same quantized
 *   operands); its error against f32 is the quantization's; its two kernels (AVX512_VNNI on the AVX-512
 *   kernel, AVX-VNNI on the AVX2 one) give the same bits. Denormals are not flushed.
 *   Compile the implementation with -ffp-contract=off (gcc and clang; MSVC's default /fp:precise does not
 *   fuse): gcc in C++ and in its GNU C modes, and clang in every language, fuse a * b + c in plain C into FMAs
 *   where they see fit, which moves the last bits (an 8-bit map by 1 in a few pixels). The project's tools,
 *   examples and tests build that way, so the same flag gives their bytes.
 *
 * MODEL FILE (format version 1)
 *   A safetensors file. Tensors: the official checkpoint's names for the UNet (`conv_in.weight`, ...,
 *   `last_up_blocks.<i>.*`, `rep_conv_out.<i>.*`), `vae.` + the diffusers AutoencoderKL names, and
 *   `context` [tokens, dim] (the CLIP output for the empty prompt). `__metadata__` keys (strings):
 *   supermat.format_version, supermat.kind (supermat | supermat-mv | uv-refine), unet.in_channels,
 *   unet.out_channels, unet.block_out_channels (comma list), unet.num_heads (comma list),
 *   unet.layers_per_block, unet.norm_num_groups, unet.norm_eps, unet.cross_attention_dim,
 *   unet.down_block_types, unet.up_block_types, unet.flip_sin_to_cos, unet.freq_shift, unet.branches,
 *   unet.class_embed_in, vae.in_channels, vae.out_channels, vae.latent_channels,
 *   vae.block_out_channels, vae.layers_per_block, vae.norm_num_groups, vae.scaling_factor,
 *   sched.num_train_timesteps, sched.beta_start, sched.beta_end, sched.beta_schedule,
 *   sched.prediction_type, sched.steps_offset, sched.set_alpha_to_one, sched.timestep_spacing,
 *   context.tokens, context.dim. `supermat convert` writes them from the official files.
 *   The pipeline, optional (absent = 0), applied by sessions whose fields are left 0 (supermat_model_info
 *   reports them): pipeline.work_size, the square the network runs at (`supermat convert` records the
 *   official scripts' 512, UV refine 1024; 0 = the picture's own size); pipeline.detail_sigma and
 *   pipeline.chroma_weight, the detail and colour steps (session_desc.detail_sigma / chroma_weight;
 *   the default model records 1/64 and 1, an official conversion neither); pipeline.bake_detail_sigma
 *   (supermat / supermat-mv), the detail step supermat_uv.h's bake applies to textures baked from this
 *   model's views (supermat_uv_bake_desc.detail_sigma; the multi-view default records 1/32);
 *   pipeline.roughness_curve and pipeline.metallic_curve (supermat / supermat-mv), the calibration curves a run
 *   puts the roughness and metallic maps through (session_desc.roughness_knots / metallic_knots; comma lists as
 *   supermat_parse_curve reads them). So the shortest
 *   program runs the model as it was measured, and `supermat image` / `mesh` set nothing more.
 *
 * PRE-PACKED MODELS (supermat_model_write_packed, `supermat pack`)
 *   A model file in which the GEMM weights are already the runtime's packed panels (16 columns per
 *   panel; f32 / f16 / bf16 / int8, bf16 pairs for bf16 compute, int8 quads with per-64-row scales for
 *   int8 compute, Winograd-transformed 3x3 convolutions)
 *   and each cross-attention's keys and values of the context are precomputed, for one set of options
 *   (weights, conv, compute; the kernel does not matter). It is a safetensors file: the U8 tensors
 *   `supermat.packed.data` (the panels, 64-byte aligned in the file) and `supermat.packed.index`, the
 *   metadata keys supermat.packed ("1"), supermat.packed.weights / .conv / .compute (the enum values),
 *   and every tensor of the original file except those only the packing read. supermat_model_create
 *   uses its panels in place from desc->data when they are 64-byte aligned (a mapped file, or an aligned
 *   allocation; it must then outlive the model); otherwise, or with copy_data, the whole model is copied
 *   into its own memory (supermat_model_info.prepacked_bytes is 0 then). conv and compute left 0 are
 *   the ones it was packed for; other options than it was packed for (weights may be DEFAULT) are
 *   UNSUPPORTED. Every offset and size in the index is checked against
 *   the architecture and the blob; the panel values themselves are used as the file gives them (no
 *   NaN scan, which would read every page: pack only files you trust, or run them once).
 *
 * INT8 WEIGHTS (`supermat convert --precision int8`, or any file with `weights = SUPERMAT_WEIGHTS_I8`)
 *   A weight W [rows][cin] or [rows][cin][kh][kw] stored as I8 q comes with the F32 tensor
 *   `<name>_scale` [rows][kh*kw][ceil(cin/64)] (a linear weight: kh*kw = 1), and
 *   W[r][c][y][x] = q[r][c][y][x] * scale[r][y*kw + x][c / 64]. One scale per output channel, per
 *   kernel tap, per 64 input channels; symmetric (scale = max |W| / 127 over its group, q in
 *   [-127, 127], q = round-to-nearest-even(W * (127 / max))). Why: output channels differ in range by
 *   orders of magnitude; groups of 64 keep one outlier from flattening a whole row (the rounding
 *   error of a group is bounded by its own maximum); a group never spans two taps, so it is the same
 *   group in PyTorch's [c][y][x] order and in the runtime's packed [(y, x)][c] order, and a file
 *   made by the converter loads to the very bits that quantizing an f32 file at load gives; no zero
 *   point, since weights are centred on 0. The scales cost 4 bytes per 64 weights (+6 %). The panels
 *   are widened to f32 once per block of rows, so the arithmetic stays f32 (int8 saves memory and
 *   bandwidth, not FLOPs). An I8 file loads as int8 unless `weights` asks for another format.
 *
 * LICENSE: see the end of the file (MIT or public domain, your choice).
 */
#ifndef SUPERMAT_H
#define SUPERMAT_H

#ifdef SUPERMAT_CONFIG_HEADER
#include SUPERMAT_CONFIG_HEADER
#endif

#define SUPERMAT_VERSION_MAJOR 0
#define SUPERMAT_VERSION_MINOR 2
#define SUPERMAT_VERSION_PATCH 0
#define SUPERMAT_VERSION ((SUPERMAT_VERSION_MAJOR << 16) | (SUPERMAT_VERSION_MINOR << 8) | SUPERMAT_VERSION_PATCH)

#ifndef SUPERMAT_API
#ifdef SUPERMAT_STATIC
/* a private copy per translation unit: functions a file does not call are not worth a warning */
#if defined(__GNUC__) || defined(__clang__)
#define SUPERMAT_API static __attribute__((unused))
#else
#define SUPERMAT_API static
#endif
#else
#define SUPERMAT_API extern
#endif
#endif

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- results and errors ---------------------------------------------------------------------- */
typedef enum supermat_result {
    SUPERMAT_SUCCESS = 0,
    SUPERMAT_ERROR_INVALID_ARGUMENT = -1, /* a NULL pointer, a bad size, a bad option */
    SUPERMAT_ERROR_OUT_OF_MEMORY = -2,    /* the allocator returned NULL */
    SUPERMAT_ERROR_MALFORMED_FILE = -3,   /* the model file is truncated or not valid safetensors */
    SUPERMAT_ERROR_UNSUPPORTED = -4,      /* a valid file this version cannot run (kind, dtype, version) */
    SUPERMAT_ERROR_MISSING_TENSOR = -5,   /* a tensor the architecture needs is absent */
    SUPERMAT_ERROR_SHAPE_MISMATCH = -6,   /* a tensor has the wrong shape for the architecture */
    SUPERMAT_ERROR_NONFINITE = -7,        /* NaN or Inf in an input (pixels, weights) */
    SUPERMAT_ERROR_CANCELLED = -8,        /* the progress callback asked to stop */
    SUPERMAT_ERROR_BAD_IMAGE = -9,        /* image size or layout does not match the session */
    SUPERMAT_ERROR_INTERNAL = -10,
    SUPERMAT_ERROR_IO = -11,              /* the caller's write callback failed (supermat_model_write_packed) */
    SUPERMAT_RESULT_COUNT_ = 12
} supermat_result;

typedef struct supermat_error {
    supermat_result result;
    char message[256];
    char tensor[160]; /* the tensor concerned, or "" */
} supermat_error;

SUPERMAT_API const char *supermat_result_string(supermat_result r);

/* ---- memory and threads ---------------------------------------------------------------------- */
typedef struct supermat_allocator {
    void *(*alloc)(void *user, size_t size, size_t align); /* NULL on failure */
    void (*free)(void *user, void *ptr, size_t size);
    void *user;
} supermat_allocator; /* all NULL = malloc/free */

/* A blocking parallel-for: call task(task_user, i, thread) for every i in [0, count), each exactly
   once, with `thread` in [0, max_threads) unique among the calls running at the same time. */
typedef void (*supermat_task_fn)(void *task_user, int index, int thread);
typedef struct supermat_threading {
    void (*parallel_for)(void *user, int count, supermat_task_fn task, void *task_user);
    void *user;
    int max_threads; /* how many distinct `thread` values parallel_for may pass (>= 1) */
} supermat_threading;

/* ---- model ----------------------------------------------------------------------------------- */
typedef enum supermat_kernel {
    SUPERMAT_KERNEL_AUTO = 0, /* best available on this CPU */
    SUPERMAT_KERNEL_SCALAR,   /* portable C, always available */
    SUPERMAT_KERNEL_AVX2,     /* x86-64 AVX2 + FMA + F16C (fails with UNSUPPORTED if the CPU lacks it) */
    SUPERMAT_KERNEL_AVX512,   /* AVX-512F GEMM micro-kernels (12 x 32 and 12 x 16 tiles in 32 registers), group-norm sums
                                 and Winograd F4 transforms over the AVX2 rest; the same bits as AVX2 (every output element
                                 sums in the same order; Winograd F4 only where the compiler does not fuse a * b + c) */
    SUPERMAT_KERNEL_NEON,     /* aarch64 Advanced SIMD GEMM micro-kernel (6 x 16 tile, fmla) over the scalar
                                 rest; picked by AUTO on aarch64 builds, UNSUPPORTED elsewhere */
    SUPERMAT_KERNEL_AMX,      /* bf16 compute only: the GEMMs on Intel AMX tiles (tdpbf16ps) over the AVX-512
                                 rest; AUTO picks it for SUPERMAT_COMPUTE_BF16 where the CPU and OS allow AMX */
    SUPERMAT_KERNEL_COUNT
} supermat_kernel;

typedef enum supermat_model_kind {
    SUPERMAT_KIND_UNKNOWN = 0, SUPERMAT_KIND_SUPERMAT, SUPERMAT_KIND_SUPERMAT_MV, SUPERMAT_KIND_UV_REFINE,
    SUPERMAT_KIND_COUNT
} supermat_model_kind;

/* What the GEMMs (convolutions, linears) multiply in. BF16: the weights are stored as bf16 and each GEMM
   rounds its activations to bf16 at its input, then multiplies pairs with AVX512_BF16 (vdpbf16ps: two
   products per lane, float32 accumulation); norms, softmax, attention scores, residuals and everything else
   stay float32. Needs a CPU with AVX512_BF16 (UNSUPPORTED otherwise) and float weights (not I8); the 3x3
   convolutions that Winograd computes stay float32. Its error is measured by `supermat bench --image`.
   INT8: the weights are stored as int8 with one scale per output channel per 64 rows of K (the rows
   k in [64 j, 64 j + 64), whatever the kernel taps), and each GEMM quantizes its activations on the fly
   with one scale per row per 64 of K (max |a| / 127, round to nearest even); vpdpbusd (four u8 x s8
   products per lane, int32 sums) multiplies them, and each 64-row chunk's int32 sum is scaled to float32
   and added. Runs on the AVX-512 kernel with AVX512_VNNI (12 rows x 16 columns) or on the AVX2 kernel with
   AVX-VNNI (the 256-bit form of CPUs without AVX-512: 6 x 16), the same bits on both; kernel AUTO picks the
   first the CPU has, UNSUPPORTED with neither (AVX-VNNI needs gcc >= 11 or clang >= 12 at build time;
   SUPERMAT_NO_AVXVNNI leaves it out); weights may come from F32/F16/BF16 or I8
   tensors (requantized to the 64-row chunks). Like BF16 it leaves everything but the GEMMs float32 and the
   Winograd convolutions float32. */
typedef enum supermat_compute {
    SUPERMAT_COMPUTE_F32 = 0,   /* the reference */
    SUPERMAT_COMPUTE_BF16,      /* bf16 x bf16 products, f32 sums */
    SUPERMAT_COMPUTE_INT8,      /* u8 x s8 products (dynamic activation scales), int32 sums per 64 of K */
    SUPERMAT_COMPUTE_COUNT
} supermat_compute;

typedef enum supermat_weights {
    SUPERMAT_WEIGHTS_DEFAULT = 0, /* as stored in the file: F32 -> f32, F16 -> f16, BF16 -> bf16 */
    SUPERMAT_WEIGHTS_F32,         /* the reference */
    SUPERMAT_WEIGHTS_F16,         /* half the memory; widened with F16C in the micro-kernel */
    SUPERMAT_WEIGHTS_BF16,        /* half the memory; widened with a shift */
    SUPERMAT_WEIGHTS_I8,          /* a quarter: symmetric int8, one scale per output channel per 256 of K */
    SUPERMAT_WEIGHTS_COUNT
} supermat_weights;

/* How the 3x3 stride-1 convolutions are computed. Winograd transforms the weights once at model
   creation and replaces 9 multiply-adds per output by 4 (F2) or 2.25 (F4), with more rounding. It is
   applied to the convolutions of at most 640 output channels (the whole VAE, the UNet levels of 320
   and 640 channels); the 1280-channel ones run at 1/16 and 1/64 of the pixels, where tiles are few,
   and stay direct. The transformed weights are kept in f32 whatever `weights` says (F2: 16/9 of the
   f32 weights they replace, F4: 36/9): quantizing F4's transformed weights multiplies the error by
   20-40. */
typedef enum supermat_conv {
    SUPERMAT_CONV_DIRECT = 0,  /* implicit GEMM: the reference */
    SUPERMAT_CONV_WINOGRAD_F2, /* F(2x2, 3x3) */
    SUPERMAT_CONV_WINOGRAD_F4, /* F(4x4, 3x3) */
    SUPERMAT_CONV_COUNT
} supermat_conv;

typedef struct supermat_model_desc {
    uint32_t _start_canary; /* leave 0 (memset the struct, or = {0}): a nonzero value is refused, which catches
                               a descriptor that was never cleared; likewise _end_canary */
    const void *data;   /* the model file in memory (8-byte alignment recommended) */
    size_t size;
    int copy_data;      /* nonzero: nothing is borrowed, `data` may be freed after create */
    supermat_kernel kernel;
    supermat_weights weights; /* storage of the GEMM weights (convolutions, linears); activations,
                                 norms, biases and softmax stay float32 */
    supermat_conv conv;       /* 3x3 convolution algorithm (DIRECT = the reference; a pre-packed file: 0 = the
                                 algorithm it was packed for) */
    supermat_allocator allocator;
    supermat_compute compute; /* F32 (0) or BF16 products in the GEMMs (see supermat_compute; a pre-packed file:
                                 0 = what it was packed for) */
    size_t max_memory;        /* 0 = no limit; else creation fails with OUT_OF_MEMORY, before the allocation
                                 that would take the model's memory (model_bytes) past it */
    uint32_t _end_canary;
} supermat_model_desc;

/* the most knots a calibration curve has (pipeline.roughness_curve / metallic_curve, session_desc.roughness_knots /
   metallic_knots) */
#define SUPERMAT_CURVE_MAX_KNOTS 33

typedef struct supermat_model_info {
    supermat_model_kind kind;
    supermat_kernel kernel;        /* the kernel set chosen */
    supermat_weights weights;      /* DEFAULT resolved: the storage of the first GEMM weight */
    supermat_conv conv;            /* the 3x3 convolution algorithm */
    supermat_compute compute;      /* what the GEMMs multiply in */
    int unet_in_channels, unet_out_channels, unet_levels, layers_per_block, norm_groups;
    int block_channels[8], num_heads[8];
    int cross_attention_dim, context_tokens, branches, class_embed_in;
    int vae_block_channels[8], vae_levels, latent_channels;
    float scaling_factor;
    int timestep;                  /* the one-step DDIM timestep (999 for SD 2.1) */
    float alphas_cumprod;          /* at that timestep, float32 as diffusers computes it */
    int v_prediction;              /* 1 v-prediction, 0 epsilon */
    uint64_t unet_params, branch_params, vae_params;
    size_t model_bytes;            /* memory held by the model (packed weights etc.) */
    int prepacked;                 /* created from a pre-packed file (supermat_model_write_packed) */
    size_t prepacked_bytes;        /* of it: the panels used in place from the caller's buffer (not in
                                      model_bytes; with copy_data they are copied and counted there) */
    /* The pipeline the file records (MODEL FILE: pipeline.*), what a session's zero fields stand for. */
    int work_size;                 /* pipeline.work_size: the square the network runs at; 0 = the picture's size */
    float detail_sigma;            /* pipeline.detail_sigma: 0 = no detail step */
    float chroma_weight;           /* pipeline.chroma_weight: 0 = no colour step */
    float bake_detail_sigma;       /* pipeline.bake_detail_sigma: supermat_uv.h's detail step for textures baked
                                      from this model's views; 0 = none */
    int roughness_knots;           /* pipeline.roughness_curve: its knots (session_desc.roughness_knots); 0 = none */
    float roughness_curve[SUPERMAT_CURVE_MAX_KNOTS];
    int metallic_knots;            /* pipeline.metallic_curve: its knots (session_desc.metallic_knots); 0 = none */
    float metallic_curve[SUPERMAT_CURVE_MAX_KNOTS];
} supermat_model_info;

typedef struct supermat_model supermat_model;
typedef struct supermat_session supermat_session;

SUPERMAT_API supermat_result supermat_model_create(const supermat_model_desc *desc, supermat_model **out,
                                                   supermat_error *err);
SUPERMAT_API void supermat_model_get_info(const supermat_model *model, supermat_model_info *info);
SUPERMAT_API void supermat_model_destroy(supermat_model *model);

/* Writes the pre-packed form of the model file desc->data (see PRE-PACKED MODELS in the manual): the
   same safetensors file with its GEMM weights replaced by the runtime's packed panels for desc's weights,
   conv and compute options. `write` gets the new file front to back in pieces and returns 0 when a piece
   was written (anything else stops the writing: SUPERMAT_ERROR_IO). *bytes (may be NULL) gets the size. */
typedef int (*supermat_write_fn)(void *user, const void *data, size_t size);
SUPERMAT_API supermat_result supermat_model_write_packed(const supermat_model_desc *desc, supermat_write_fn write,
                                                         void *user, uint64_t *bytes, supermat_error *err);

/* ---- session --------------------------------------------------------------------------------- */
enum {
    SUPERMAT_OUTPUT_ALBEDO = 1,
    SUPERMAT_OUTPUT_ROUGHNESS = 2,
    SUPERMAT_OUTPUT_METALLIC = 4,
    SUPERMAT_OUTPUT_ALL = 7
};

typedef enum supermat_mv_attention {
    SUPERMAT_MV_ATTENTION_FULL = 0, /* every view attends to all views' keys (official) */
    SUPERMAT_MV_ATTENTION_OWN_VIEW, /* highest resolution: each view attends to its own keys only */
    SUPERMAT_MV_ATTENTION_STRIDED,  /* highest resolution: own keys + every mv_key_stride-th key of the others */
    SUPERMAT_MV_ATTENTION_COUNT
} supermat_mv_attention;

/* session_desc.work_width / work_height: run the network at the picture's own size, whatever the model
   file records (0 stands for the file's pipeline.work_size) */
#define SUPERMAT_WORK_NATIVE (-1)
/* session_desc.detail_sigma / chroma_weight: no such step, whatever the model file records (0 stands for
   the file's pipeline.detail_sigma / chroma_weight); any negative value means the same */
#define SUPERMAT_OFF (-1.0f)

typedef struct supermat_session_desc {
    uint32_t _start_canary;      /* leave 0 (see supermat_model_desc) */
    const supermat_model *model;
    int width, height;           /* the picture size, 1 to 16384 each; when the network runs at the picture's
                                    own size (no work size, below): multiples of 8, >= 8 */
    unsigned outputs;            /* SUPERMAT_OUTPUT_* bits; 0 = all */
    int views;                   /* images processed together: SuperMatMV views (0 = 6 for MV models,
                                    1 otherwise); other kinds take 1 */
    int threads;                 /* built-in pool: 0 = all cores, 1 = run on the calling thread */
    supermat_threading threading;/* a caller's parallel-for; overrides `threads` when set */
    supermat_allocator allocator;
    /* ---- the pipeline and the speed / memory levers; all zero = what the model file records (for an
       official file, the official computation) ---- */
    /* Network size: the images (width x height) are resampled to work_width x work_height (multiples
       of 8), the network runs there and the maps are resampled back (bilinear, antialiased when
       reducing). 0 = the model's work size (supermat_model_info.work_size: the size its file records,
       512 for an official SuperMat, the picture's own size for a file that records none);
       SUPERMAT_WORK_NATIVE = the picture's own size. */
    int work_width, work_height;
    /* VAE in tiles of vae_tile x vae_tile pixels (a multiple of 8, >= 32; 0 = the whole image at
       once), laid out evenly with at least vae_overlap pixels of overlap (multiple of 8; 0 = 32),
       blended linearly. Bounds the VAE's activation memory; GroupNorm statistics and the VAE's
       attention become per tile, so the maps change slightly. */
    int vae_tile, vae_overlap;
    /* Decode only the tiles that hold foreground: a pixel with alpha > 0 (supermat, supermat-mv;
       images without alpha are all foreground) or a texel in a UV chart (uv-refine, see
       supermat_run_desc.chart). Pixels no decoded tile covers are written as decoded 0 (0.5 gray).
       Needs vae_tile; foreground pixels get exactly the tiled result. */
    int skip_background;
    /* SuperMatMV only: approximate the multi-view attention at the highest resolution. */
    supermat_mv_attention mv_attention;
    int mv_key_stride;           /* SUPERMAT_MV_ATTENTION_STRIDED: keep every n-th key of the other views (1 = all) */
    size_t max_memory;           /* 0 = no limit; else a session whose plan (supermat_session_memory) needs more
                                    fails with OUT_OF_MEMORY before anything is allocated */
    /* supermat / supermat-mv, not in the official computation: the albedo keeps the input picture's
       detail. Per channel in linear light, albedo = I x clamp(G(w A) / G(w I), 1/4, 4), I the input
       colour (sRGB-encoded as given), A the network's albedo, w the input's alpha (1 without alpha), G
       three passes of a box filter of width 2r + 1, r = round((sqrt(4 s^2 + 1) - 1) / 2), s =
       detail_sigma x max(width, height), rows then columns, zero outside the image (where G(w I) < 1e-6:
       the image's sum(w A) / sum(w I)); pixels of alpha 0 are left as decoded. The lighting is assumed
       smooth at that scale: the network sets the level and colour, the picture the detail (`supermat
       image` uses 1/64, chosen on validation assets: docs/quality.md). At most 1; 0 = the model's
       (supermat_model_info.detail_sigma: the default model's file records 1/64, an official one none);
       SUPERMAT_OFF (negative) = off. */
    float detail_sigma;
    /* supermat / supermat-mv, not in the official computation, after detail_sigma: the albedo takes the
       input picture's chromaticity and keeps the network's luminance. Per pixel of alpha > 0 (every
       pixel without alpha), in linear light, with A the albedo, I the input colour (sRGB-encoded as
       given), L(x) = 0.2126 r + 0.7152 g + 0.0722 b and k = chroma_weight:
           A' = (1 - k) A + k (L(A) I + e A) / (L(I) + e),  e = 0.002,
       each channel clamped to [0, 1]; at k = 1 and L(I) >> e, A' = L(A) I / L(I): the picture's colour
       at the network's brightness (e hands near-black picture pixels the network's own colour). For
       networks whose colours are washed out (the small default model's are: docs/quality.md); it also brings
       the lighting's colour cast and coloured reflections into the albedo. Chosen on validation assets:
       1. At most 1; 0 = the model's (supermat_model_info.chroma_weight: the default model's file
       records 1, an official one none); SUPERMAT_OFF (negative) = off. */
    float chroma_weight;
    /* supermat / supermat-mv, not in the official computation: the roughness map r (in [0, 1]) through a
       calibration curve, per pixel of alpha > 0 (every pixel without alpha), after the network and the
       resampling: the piecewise-linear curve through (i / (n - 1), roughness_curve[i]), i = 0 .. n - 1.
       The n knots are in [0, 1] and non-decreasing (a rougher prediction never comes out smoother), n from 2
       to SUPERMAT_CURVE_MAX_KNOTS; the session keeps a copy. For a network whose roughness is right in
       order but too narrow (the small default model's: docs/quality.md; fitted with
       `python3 -m supermat_tools.eval_cycles --fit` on renders of known materials). roughness_knots 0 = the
       model's (supermat_model_info.roughness_knots / roughness_curve: the default model's file records one,
       an official one none); SUPERMAT_CURVE_OFF = none. */
    int roughness_knots;
    const float *roughness_curve;
    /* supermat / supermat-mv, not in the official computation: the metallic map through a calibration curve,
       as the roughness above (the same knots' rules, the same pixels, after the roughness's). For a network
       that leaves a floor of metal on dielectrics, or whose metal is too faint (fitted as above). 0 = the
       model's (supermat_model_info.metallic_knots / metallic_curve); SUPERMAT_CURVE_OFF = none. */
    int metallic_knots;
    const float *metallic_curve;
    uint32_t _end_canary;
} supermat_session_desc;

/* session_desc.roughness_knots / metallic_knots: no curve, whatever the model file records */
#define SUPERMAT_CURVE_OFF (-1)

/* Arena bytes a session with this desc would allocate (the whole run), without allocating. */
SUPERMAT_API supermat_result supermat_session_memory(const supermat_session_desc *desc, size_t *bytes,
                                                     supermat_error *err);
SUPERMAT_API supermat_result supermat_session_create(const supermat_session_desc *desc, supermat_session **out,
                                                     supermat_error *err);
SUPERMAT_API void supermat_session_destroy(supermat_session *session);

/* ---- run ------------------------------------------------------------------------------------- */
typedef enum supermat_format {
    SUPERMAT_FORMAT_U8 = 0,  /* 8-bit, 0..255 */
    SUPERMAT_FORMAT_F32,     /* float, 0..1 */
    SUPERMAT_FORMAT_COUNT
} supermat_format;

typedef struct supermat_image {
    void *pixels;            /* input: read only */
    int width, height;
    int channels;            /* input: 3 (RGB) or 4 (RGBA, straight alpha); outputs: see supermat_run_desc */
    size_t stride;           /* bytes between rows; 0 = tightly packed */
    supermat_format format;
} supermat_image;

typedef enum supermat_stage {
    SUPERMAT_STAGE_INPUT = 0, /* [-1,1] image, 3 channels */
    SUPERMAT_STAGE_LATENT,    /* VAE encoder mode x scaling factor */
    SUPERMAT_STAGE_UNET_OUT,  /* per branch: the UNet output (v or epsilon) */
    SUPERMAT_STAGE_X0,        /* per branch: the one-step x0 latent */
    SUPERMAT_STAGE_DECODED,   /* per branch: raw VAE decode, before x/2+0.5 (at the work size: a resized
                                 run resizes it back a row at a time after this stage) */
    SUPERMAT_STAGE_TRUNK,     /* the shared UNet trunk's output (input of every branch tail) */
    SUPERMAT_STAGE_UNET_IN,   /* UV refine: [latent, mask, position] at the latent size */
    SUPERMAT_STAGE_COUNT
} supermat_stage;

typedef struct supermat_run_desc {
    uint32_t _start_canary;  /* leave 0 (see supermat_model_desc) */
    supermat_image input;
    /* Outputs (pixels NULL = not wanted; width/height 0 = the session size). albedo: 3 or 4 channels
       (alpha copied from the input, 1 without); roughness and metallic: 1 channel, 2 (gray + the
       input's alpha) or 3/4 to fill gray RGB(A) (alpha the input's). The glTF-style ORM image (R 1,
       G roughness, B metallic; a 4th channel 1) is `orm`. */
    supermat_image albedo, roughness, metallic, orm;
    /* SuperMatMV: the session's `views` images in input_views[] (then `input` is ignored), their
       camera-to-world matrices (views x 16 floats, row-major, as meta.json's transform_matrix), and
       per-view outputs in the *_views arrays (an array, or a pixels pointer in it, NULL = not wanted). */
    const supermat_image *input_views;
    const float *cameras;
    supermat_image *albedo_views, *roughness_views, *metallic_views, *orm_views;
    /* UV refine: `input` is the partial UV map (RGB in [0,1]; a 4th channel is ignored), `mask`
       (1 channel; of more, the first is used) and `position` (RGB) are at the same size; the refined
       map is written to `refined` (3 or 4 channels, alpha 1, or 1 channel = the first). */
    supermat_image mask, position, refined;
    /* UV refine with skip_background: the texels that belong to a UV chart (1 channel, > 0 = in a
       chart; optional). Without it, a texel is in a chart when its mask is > 0 or its position is not
       the official off-chart gray (127/255 in all three channels): charts' unseen texels (mask 0) are
       what the network fills in, so they are decoded. */
    supermat_image chart;
    /* Progress between layers: return nonzero to cancel (the run then fails with CANCELLED). */
    int (*progress)(void *user, float fraction, const char *what);
    void *progress_user;
    /* Inspection of intermediate tensors (debugging, tests): data is NHWC float32, n images. The
       callback may also overwrite the data (e.g. to inject a reference and test one stage alone). */
    void (*inspect)(void *user, supermat_stage stage, int branch, float *data, int n, int h, int w, int c);
    void *inspect_user;
    uint32_t _end_canary;
} supermat_run_desc;

SUPERMAT_API supermat_result supermat_run(supermat_session *session, const supermat_run_desc *desc,
                                          supermat_error *err);

/* ---- the detail step alone -------------------------------------------------------------------- */
/* What session_desc.detail_sigma does to a run's albedo, for an albedo made elsewhere: supermat_uv.h's bake
   runs it in UV space, on its texture, in the bounded form (`limit`); a run's own step is this same code with
   limit 0. Per colour channel, in linear
   light, albedo = I x clamp(G(w A) / G(w I), 1/4, 4), with I, A, G and the fallback where G(w I) < 1e-6
   as session_desc.detail_sigma says and s = sigma x max(width, height). The weight w is `weight`'s first
   channel (clamped to [0, 1]) or, without one, the picture's alpha (1 without alpha), and 0 outside
   `region` when one is given. Written: every pixel of `region` (first channel > 0), or without a region
   the pixels of w > 0; the others keep their value. */
typedef struct supermat_detail_desc {
    uint32_t _start_canary;      /* leave 0 (see supermat_model_desc) */
    float sigma;                 /* the low-pass's sigma as a fraction of max(width, height): (0, 1] */
    float limit;                 /* 0: the formula above (a run's step). > 1 (at most 1e6): the bounded form,
                                    the picture's detail held within that ratio: with I~ = G(w I) / G(w), the
                                    picture's low-pass, albedo = I~ x clamp(G(w A) / G(w I), 1/4, 4) x
                                    clamp(I / I~, 1/limit, limit), I~ the weighted mean of I over the picture
                                    where G(w) < 1e-6 and the last ratio 1 where I~ < 1e-6 (without its last
                                    clamp, the formula above): a shadow, highlight or reflection in the
                                    picture moves the albedo by at most that ratio (the UV bake's form:
                                    supermat_uv.h DETAIL). The albedo's floats hold the gain between the two
                                    passes; without any weight the albedo becomes the picture */
    supermat_image picture;      /* I: 3 or 4 channels, sRGB-encoded (8-bit, or float in [0, 1]), finite */
    supermat_image albedo;       /* A, read and written: F32, 3 channels, sRGB-encoded in [0, 1] (out: clamped),
                                    the picture's size (width / height 0 = it); finite */
    supermat_image weight;       /* optional (pixels NULL = none): the picture's size, 1 to 4 channels */
    supermat_image region;       /* optional (pixels NULL = none): the picture's size, 1 to 4 channels */
    supermat_threading threading;/* a parallel-for (a pool's hook); none = the calling thread */
    supermat_allocator allocator;
    void *scratch;               /* optional: supermat_detail_memory() bytes, 16-byte aligned, used instead of */
    size_t scratch_size;         /* allocating (then nothing is allocated) */
    uint32_t _end_canary;
} supermat_detail_desc;
/* The scratch bytes supermat_detail needs for this desc (the low-pass runs on rows: three rings of 2r + 18
   rows of 24 bytes a pixel, r = sigma x the larger side, or one plane of 24 bytes a pixel where that is
   smaller; about 2.5 bytes a pixel at 8000x8000 and sigma 1/64); the desc is checked as by
   supermat_detail, its pixels are not read. */
SUPERMAT_API supermat_result supermat_detail_memory(const supermat_detail_desc *desc, size_t *bytes, supermat_error *err);
SUPERMAT_API supermat_result supermat_detail(const supermat_detail_desc *desc, supermat_error *err);
/* A calibration curve as text (metadata pipeline.roughness_curve / metallic_curve, the tool's --roughness-curve /
   --metallic-curve): 2 to
   SUPERMAT_CURVE_MAX_KNOTS numbers separated by commas (spaces around them allowed), each in [0, 1], each
   >= the one before. *count gets the number (knots: room for SUPERMAT_CURVE_MAX_KNOTS); else
   INVALID_ARGUMENT with what is wrong. */
SUPERMAT_API supermat_result supermat_parse_curve(const char *text, float *knots, int *count, supermat_error *err);
/* The sRGB transfer (IEC 61966-2-1) the steps above and supermat_uv.h use: the value clamped to [0, 1] first
   (NaN -> 0), in double. */
SUPERMAT_API double supermat_srgb_to_linear(double v);
SUPERMAT_API double supermat_linear_to_srgb(double v);

/* ---- built-in thread pool (pthreads or Win32; absent with SUPERMAT_NO_PTHREADS) ---------------- */
typedef struct supermat_pool supermat_pool;
/* threads = 0: all cores. Fills *hook with the pool's parallel-for. */
SUPERMAT_API supermat_result supermat_pool_create(int threads, const supermat_allocator *allocator,
                                                  supermat_pool **out, supermat_threading *hook);
SUPERMAT_API void supermat_pool_destroy(supermat_pool *pool);

/* ================================ TOOLS: an application running models needs none of this ====== */
/* ---- small readers the tools share (JSON tokenizer, safetensors header) ----------------------- */
typedef enum supermat_json_type {
    SUPERMAT_JSON_UNDEFINED = 0, SUPERMAT_JSON_OBJECT, SUPERMAT_JSON_ARRAY, SUPERMAT_JSON_STRING,
    SUPERMAT_JSON_PRIMITIVE, SUPERMAT_JSON_TYPE_COUNT
} supermat_json_type;
typedef struct supermat_json_tok {
    supermat_json_type type;
    int start, end; /* byte range in the text (strings without their quotes) */
    int size;       /* object: members; array: elements; key string: 1; otherwise 0 */
    int next;       /* index of the first token after this token's subtree */
} supermat_json_tok;
/* Returns the number of tokens (toks may be NULL to count), or a negative supermat_result. */
SUPERMAT_API int supermat_json_parse(const char *js, size_t len, supermat_json_tok *toks, int max_toks);
/* Index of the value of `key` in object token `obj`, or -1. */
SUPERMAT_API int supermat_json_find(const char *js, const supermat_json_tok *toks, int obj, const char *key);
/* Unescaped, NUL-terminated copy of a string token; -1 if it does not fit or is not a string. */
SUPERMAT_API int supermat_json_string(const char *js, const supermat_json_tok *tok, char *buf, size_t cap);
/* 0 and *out for a number token, -1 otherwise. */
SUPERMAT_API int supermat_json_number(const char *js, const supermat_json_tok *tok, double *out);

typedef enum supermat_dtype {
    SUPERMAT_DTYPE_DEFAULT = 0, SUPERMAT_DTYPE_F32, SUPERMAT_DTYPE_F16, SUPERMAT_DTYPE_BF16,
    SUPERMAT_DTYPE_I8, /* int8 GEMM weights: the F32 tensor NAME_scale beside tensor NAME holds their scales
                          (see INT8 WEIGHTS in the manual) */
    SUPERMAT_DTYPE_U8, /* raw bytes: a pre-packed model's panels and index (PRE-PACKED MODELS) */
    SUPERMAT_DTYPE_COUNT
} supermat_dtype;
typedef struct supermat_tensor_info {
    char name[160];
    supermat_dtype dtype;
    int ndim;
    int64_t shape[8];
    uint64_t offset; /* from the start of the file */
    uint64_t nbytes;
} supermat_tensor_info;
/* Safetensors header access. `buf` holds at least the first 8 + header-length bytes of a file of
   `file_size` bytes (all offsets are validated against file_size). */
SUPERMAT_API supermat_result supermat_safetensors_count(const void *buf, size_t buf_size, uint64_t file_size,
                                                        int *n_tensors, supermat_error *err);
SUPERMAT_API supermat_result supermat_safetensors_tensor(const void *buf, size_t buf_size, uint64_t file_size,
                                                         int index, supermat_tensor_info *out, supermat_error *err);
/* 0 (and value) if `key` is in __metadata__, -1 otherwise. */
SUPERMAT_API int supermat_safetensors_metadata(const void *buf, size_t buf_size, const char *key, char *value,
                                               size_t cap);

/* ---- introspection for tools and benchmarks --------------------------------------------------- */
/* The thread count that threads = 0 stands for: the online cores, fewer when the process's CPU
 * affinity mask (Linux: Cpus_allowed_list of /proc/self/status, as `taskset` sets it) or its cgroup CPU
 * quota (cgroup v2 cpu.max along the process's cgroup path, v1 cpu.cfs_quota_us / cpu.cfs_period_us,
 * rounded up: a container limited to 1.5 CPUs gets 2) allows fewer; Windows: the process affinity mask
 * (its processor group) and a hard CPU-rate cap of its job object, rounded up the same way; macOS: the
 * performance cores where the system reports them (sysctl hw.perflevel0.logicalcpu: Apple silicon, macOS 12
 * and later), else every online core; at most 64, at least 1; 1 without the built-in threads
 * (SUPERMAT_NO_PTHREADS). */
SUPERMAT_API int supermat_default_threads(void);
/* 1 when this implementation was compiled with optimisation (GCC and Clang define __OPTIMIZE__ at -O1 and
 * above), 0 when without (-O0, a build type left empty: about 10x slower), -1 where the compiler does not
 * say (MSVC). Tools print a warning on 0, so nobody measures a debug build by accident. */
SUPERMAT_API int supermat_build_optimized(void);
/* What this CPU, OS and build can run: each kernel and compute mode needs its flag (UNSUPPORTED otherwise). */
typedef struct supermat_cpu_info {
    int avx2;        /* AVX2 + FMA + F16C with the OS saving YMM state (SUPERMAT_KERNEL_AVX2) */
    int avx512;      /* AVX-512F with the OS saving ZMM state, and AVX2 (SUPERMAT_KERNEL_AVX512) */
    int avx512_bf16; /* and AVX512_BF16 (SUPERMAT_COMPUTE_BF16) */
    int avx512_vnni; /* AVX-512F + BW + AVX512_VNNI (SUPERMAT_COMPUTE_INT8 on the AVX-512 kernel) */
    int avx_vnni;    /* AVX2 + AVX-VNNI (SUPERMAT_COMPUTE_INT8 on the AVX2 kernel) */
    int neon;        /* an aarch64 build (Advanced SIMD is part of the base ISA: SUPERMAT_KERNEL_NEON) */
    int amx_bf16;    /* AMX-TILE + AMX-BF16, enabled by the OS for this process (SUPERMAT_KERNEL_AMX) */
} supermat_cpu_info;
SUPERMAT_API supermat_cpu_info supermat_cpu(void);
/* FLOPs (multiply-add = 2) one run of this session performs, per stage (encode, unet trunk, branch
   tails, decode), excluding norms and activations. */
typedef struct supermat_flops { double encode, trunk, branch, decode, total; } supermat_flops;
SUPERMAT_API void supermat_session_flops(const supermat_session *session, supermat_flops *out);
/* FLOPs the last successful supermat_run performed (less than the session's when background tiles
   were skipped); zeros before the first run. */
SUPERMAT_API void supermat_session_last_flops(const supermat_session *session, supermat_flops *out);
/* The threads a session created with this desc runs on: threading.max_threads when a caller's hook is
 * given, else `threads` (0: supermat_default_threads()), at most 64; 1 without the built-in threads. What
 * supermat_session_memory plans the per-thread scratch for (`supermat info` prints it). */
SUPERMAT_API int supermat_session_desc_threads(const supermat_session_desc *desc);

/* ---- testing hooks: for benchmarks and tests; an application running models needs none ---------- */
/* One 3x3 convolution (stride 1, zero padding 1, bias) of a size x size x cin input (NHWC) to cout
 * channels, as the UNet's convolutions run: one GEMM of M = size^2, K = 9 cin, N = cout over packed f32
 * weights, with the micro-kernel of one kernel set. Weights, bias and input are a fixed pseudo-random
 * pattern (the same values on every machine and every call), so kernels and machines can be compared:
 * `supermat bench` part (c) times it (size 64, 320 -> 320 channels, the first UNet level at 512x512).
 *   supermat_bench_conv_create   allocates everything (default allocator) for runs on up to `threads`
 *                                threads (a threading hook's max_threads); size, cin, cout 1 to 4096
 *   supermat_bench_conv_run      one convolution with `kernel`'s GEMM micro-kernel: SCALAR, AVX2, AVX512,
 *                                NEON, or AUTO (the widest this CPU and build have), on `threading` (NULL:
 *                                the calling thread). Allocates nothing, so that a caller can time it.
 *                                UNSUPPORTED for a kernel this CPU or build lacks, and for AMX (a bf16
 *                                compute kernel, not an f32 micro-kernel). AVX512 gives AVX2's bits; the
 *                                scalar kernel differs from them by rounding (no FMA).
 *   supermat_bench_conv_output   the last successful run's output, size x size x cout floats (NHWC);
 *                                NULL before one */
typedef struct supermat_bench_conv supermat_bench_conv;
SUPERMAT_API supermat_result supermat_bench_conv_create(int size, int cin, int cout, int threads, supermat_bench_conv **out,
                                                        supermat_error *err);
SUPERMAT_API supermat_result supermat_bench_conv_run(supermat_bench_conv *bench, supermat_kernel kernel,
                                                     const supermat_threading *threading, supermat_error *err);
SUPERMAT_API const float *supermat_bench_conv_output(const supermat_bench_conv *bench);
SUPERMAT_API void supermat_bench_conv_destroy(supermat_bench_conv *bench);

/* ======================================== the API ends here ==================================== */
#ifdef __cplusplus
}
#endif
#endif /* SUPERMAT_H */

/* ============================================================================================== */
/*                                       IMPLEMENTATION                                           */
/* ============================================================================================== */
#ifdef SUPERMAT_IMPLEMENTATION
#ifndef SUPERMAT_IMPLEMENTATION_DONE
#define SUPERMAT_IMPLEMENTATION_DONE

/* >>platform */
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef SUPERMAT_STATIC
#if defined(__GNUC__) || defined(__clang__)
#define SUPERMAT__DEF static __attribute__((unused))
#else
#define SUPERMAT__DEF static
#endif
#else
#define SUPERMAT__DEF
#endif
#ifndef SUPERMAT_ASSERT
#define SUPERMAT_ASSERT(x) ((void)0)
#endif

/* x86-64 SIMD. Each kernel has one source; only these macros differ by compiler. gcc and clang (MinGW-w64
   and clang-cl too) compile each kernel for its ISA with a target attribute and read the CPU through
   <cpuid.h>; MSVC (cl.exe) needs no attribute to use any intrinsic and has __cpuidex / _xgetbv in
   <intrin.h>. SUPERMAT__FORCE_MSVC_PATHS (tests only: tests/test_msvc.sh) takes the MSVC branch with
   clang-cl or gcc, whose -m flags then enable the ISAs as MSVC does without them. */
#if (defined(__GNUC__) || defined(__clang__)) && !defined(SUPERMAT__FORCE_MSVC_PATHS)
#define SUPERMAT__GNU_SIMD 1
#else
#define SUPERMAT__GNU_SIMD 0
#endif
#if !defined(SUPERMAT_NO_AVX2) && (defined(__x86_64__) || defined(_M_X64)) && !defined(_M_ARM64EC) && \
    (SUPERMAT__GNU_SIMD || defined(_MSC_VER) || defined(SUPERMAT__FORCE_MSVC_PATHS))
#define SUPERMAT__HAS_AVX2 1
#include <immintrin.h>
#if SUPERMAT__GNU_SIMD
#include <cpuid.h>
#if defined(_MSC_VER) && defined(__clang__)
/* clang-cl: its immintrin.h (clang 14 at least) declares only the ISAs of the /arch or -m flags; the rest
   for the target attributes */
#include <smmintrin.h>
#include <avxintrin.h>
#include <avx2intrin.h>
#include <f16cintrin.h>
#include <fmaintrin.h>
#include <avx512fintrin.h>
#include <avx512bwintrin.h>
#include <avx512vnniintrin.h>
#include <avx512bf16intrin.h>
#if __clang_major__ >= 12
#include <avxvnniintrin.h>
#endif
#endif
#define SUPERMAT__AVX2 __attribute__((target("avx2,fma,f16c")))
#else
#include <intrin.h> /* __cpuidex, _xgetbv */
#define SUPERMAT__AVX2
#endif
#else
#define SUPERMAT__HAS_AVX2 0
#endif
#if SUPERMAT__HAS_AVX2 && !defined(SUPERMAT_NO_AVX512)
#define SUPERMAT__HAS_AVX512 1
#if SUPERMAT__GNU_SIMD
#define SUPERMAT__AVX512 __attribute__((target("avx512f,avx2,fma,f16c")))
#define SUPERMAT__AVX512BF16 __attribute__((target("avx512f,avx512bf16,avx2,fma,f16c")))
#define SUPERMAT__AVX512VNNI __attribute__((target("avx512f,avx512bw,avx512vnni,avx2,fma,f16c")))
#else
#define SUPERMAT__AVX512
#define SUPERMAT__AVX512BF16
#define SUPERMAT__AVX512VNNI
#endif
#else
#define SUPERMAT__HAS_AVX512 0
#endif
/* AVX-VNNI (the 256-bit, VEX-encoded vpdpbusd of Alder Lake and later) needs gcc >= 11 / clang >= 12 (MSVC:
   _mm256_dpbusd_avx_epi32, recent Visual Studio; SUPERMAT_NO_AVXVNNI for an older one) */
#if SUPERMAT__HAS_AVX512 && !defined(SUPERMAT_NO_AVXVNNI) && \
    (!SUPERMAT__GNU_SIMD || (defined(__clang__) && __clang_major__ >= 12) || (!defined(__clang__) && defined(__GNUC__) && __GNUC__ >= 11))
#define SUPERMAT__HAS_AVXVNNI 1
#if SUPERMAT__GNU_SIMD
#define SUPERMAT__AVXVNNI __attribute__((target("avxvnni,avx2,fma,f16c")))
#else
#define SUPERMAT__AVXVNNI
#endif
#else
#define SUPERMAT__HAS_AVXVNNI 0
#endif
/* AMX needs gcc >= 11 / clang >= 12 for the intrinsics, and Linux to grant the tile state. Off on Windows:
   there the OS would have to enable XTILECFG / XTILEDATA in XCR0 (bits 17-18, read with _xgetbv), as
   Windows 11 does where the CPU has AMX, and the kernels would need the tile intrinsics without target
   attributes; not built or tested here, so Windows runs bf16 compute on vdpbf16ps */
#if SUPERMAT__HAS_AVX512 && SUPERMAT__GNU_SIMD && !defined(SUPERMAT_NO_AMX) && defined(__linux__) && defined(__x86_64__) && \
    ((defined(__clang__) && __clang_major__ >= 12) || (!defined(__clang__) && defined(__GNUC__) && __GNUC__ >= 11))
#define SUPERMAT__HAS_AMX 1
#define SUPERMAT__AMX __attribute__((target("amx-tile,amx-bf16,avx512f,avx512bf16,avx2,fma,f16c")))
#else
#define SUPERMAT__HAS_AMX 0
#endif
/* spellings the kernels need: forced / prevented inlining; __m512bh from / to __m512i, a cast between GCC
   vectors with gcc and clang, nothing with MSVC, whose headers make it a typedef of __m512i (clang-cl on
   the MSVC branch: an implicit conversion between integer vectors of one size) */
#if defined(_MSC_VER) && !SUPERMAT__GNU_SIMD
#define SUPERMAT__FORCEINLINE __forceinline
#define SUPERMAT__NOINLINE __declspec(noinline)
#define SUPERMAT__BH512(v) (v)
#define SUPERMAT__BH512_BITS(v) (v)
#else
#if defined(__GNUC__) || defined(__clang__)
#define SUPERMAT__FORCEINLINE __attribute__((always_inline)) inline
#define SUPERMAT__NOINLINE __attribute__((noinline))
#else
#define SUPERMAT__FORCEINLINE inline
#define SUPERMAT__NOINLINE
#endif
#define SUPERMAT__BH512(v) ((__m512bh)(v))
#define SUPERMAT__BH512_BITS(v) ((__m512i)(v))
#endif
#if !defined(SUPERMAT_NO_NEON) && defined(__aarch64__) && (defined(__GNUC__) || defined(__clang__))
#define SUPERMAT__HAS_NEON 1
#include <arm_neon.h>
#else
#define SUPERMAT__HAS_NEON 0
#endif

#if defined(__linux__) && !defined(SUPERMAT_NO_MADVISE)
#include <sys/mman.h> /* madvise(MADV_HUGEPAGE) for the big default allocations */
#endif

#if !defined(SUPERMAT_NO_PTHREADS) && (defined(__unix__) || defined(__APPLE__))
#define SUPERMAT__HAS_PTHREADS 1
#include <pthread.h>
#include <unistd.h>
/* macOS: the default thread count asks sysctlbyname for the performance cores. SUPERMAT__TEST_SYSCTL (tests
   only: tests/test_threads_sysctl.c) compiles that query elsewhere, against the test's own sysctlbyname. */
#if defined(__APPLE__) && !defined(SUPERMAT__TEST_SYSCTL)
#include <sys/sysctl.h>
#define SUPERMAT__SYSCTL 1
#elif defined(SUPERMAT__TEST_SYSCTL)
#define SUPERMAT__SYSCTL 1
#endif
#else
#define SUPERMAT__HAS_PTHREADS 0
#endif
/* Windows (MSVC, MinGW-w64): the pool on Win32 threads, an SRW lock and condition variables (Vista and
   later); <windows.h> without its min / max macros and rarely used parts, unless the includer asked */
#if !defined(SUPERMAT_NO_PTHREADS) && !SUPERMAT__HAS_PTHREADS && defined(_WIN32)
#define SUPERMAT__HAS_WINTHREADS 1
#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#define SUPERMAT__UNDEF_LEAN
#endif
#ifndef NOMINMAX
#define NOMINMAX
#define SUPERMAT__UNDEF_NOMINMAX
#endif
#include <windows.h>
#ifdef SUPERMAT__UNDEF_LEAN
#undef WIN32_LEAN_AND_MEAN
#undef SUPERMAT__UNDEF_LEAN
#endif
#ifdef SUPERMAT__UNDEF_NOMINMAX
#undef NOMINMAX
#undef SUPERMAT__UNDEF_NOMINMAX
#endif
#else
#define SUPERMAT__HAS_WINTHREADS 0
#endif
#define SUPERMAT__HAS_THREADS (SUPERMAT__HAS_PTHREADS || SUPERMAT__HAS_WINTHREADS)

#define SUPERMAT__MIN(a, b) ((a) < (b) ? (a) : (b))
#define SUPERMAT__MAX(a, b) ((a) > (b) ? (a) : (b))

/* >>cpus: the default thread count */
#if SUPERMAT__HAS_PTHREADS && defined(__linux__)
/* "0-3,8,10-11" -> 7; -1 when the text is not a CPU list */
static int supermat__cpu_list_count(const char *s) {
    int n = 0;
    while (*s == ' ' || *s == '\t') s++;
    while (*s >= '0' && *s <= '9') {
        long a = strtol(s, (char **)&s, 10), b = a;
        if (*s == '-') {
            s++;
            if (*s < '0' || *s > '9') return -1;
            b = strtol(s, (char **)&s, 10);
        }
        if (b < a || b - a > 1 << 20) return -1;
        n += (int)(b - a + 1);
        if (*s != ',') break;
        s++;
    }
    while (*s == ' ' || *s == '\t' || *s == '\n' || *s == '\r') s++;
    return (n > 0 && *s == 0) ? n : -1;
}

/* cgroup v2 "max 100000" -> 0 (no limit), "150000 100000" -> 2 (rounded up); v1 gives quota and period
 * as two texts; -1 when unreadable */
static int supermat__cpu_quota(const char *quota, const char *period) {
    double q, p;
    char *e;
    while (*quota == ' ') quota++;
    if (!strncmp(quota, "max", 3)) return 0;
    q = strtod(quota, &e);
    if (e == quota) return -1;
    if (!period) period = e;
    p = strtod(period, &e);
    if (e == period) return -1;
    if (q <= 0) return 0; /* v1: -1 = no limit */
    if (p <= 0) return -1;
    q = ceil(q / p);
    return q < 1 ? 1 : q > 4096 ? 4096 : (int)q;
}

static int supermat__read_small(const char *path, char *buf, size_t cap) {
    FILE *f = fopen(path, "r");
    size_t n;
    if (!f) return 0;
    n = fread(buf, 1, cap - 1, f);
    fclose(f);
    buf[n] = 0;
    return n > 0;
}
#endif

static int supermat__cpu_count(void) {
    long n = 1;
#if SUPERMAT__HAS_PTHREADS
    n = sysconf(_SC_NPROCESSORS_ONLN);
    if (n < 1) n = 1;
#if defined(SUPERMAT__SYSCTL)
    {   /* Apple silicon: the performance cores (hw.perflevel0, macOS 12 and later). Each parallel section ends
           with its last task, and a task on an efficiency core takes several times as long. Intel Macs and
           older systems have no perflevel0: all online cores. */
        int p = 0;
        size_t len = sizeof p;
        if (sysctlbyname("hw.perflevel0.logicalcpu", &p, &len, NULL, 0) == 0 && len == sizeof p && p > 0 && p < n) n = p;
    }
#endif
#if defined(__linux__)
    {
        char buf[4096], path[1024];
        const char *line;
        int k;
        if (supermat__read_small("/proc/self/status", buf, sizeof buf) && (line = strstr(buf, "Cpus_allowed_list:"))) {
            char list[1024];
            size_t i = 0;
            line += 18;
            while (line[i] && line[i] != '\n' && i + 1 < sizeof list) { list[i] = line[i]; i++; }
            list[i] = 0;
            k = supermat__cpu_list_count(list);
            if (k > 0 && k < n) n = k;
        }
        /* cgroup v2: "0::/path" in /proc/self/cgroup; the limit is the smallest along the path */
        if (supermat__read_small("/proc/self/cgroup", buf, sizeof buf) && (line = strstr(buf, "0::/"))) {
            size_t len = 0;
            line += 3;
            while (line[len] && line[len] != '\n') len++;
            if (len < sizeof path - 40) {
                char q[128];
                for (;;) {
                    snprintf(path, sizeof path, "/sys/fs/cgroup%.*s%scpu.max", (int)len, line,
                             len > 0 && line[len - 1] == '/' ? "" : "/");
                    if (supermat__read_small(path, q, sizeof q) && (k = supermat__cpu_quota(q, NULL)) > 0 && k < n) n = k;
                    if (len <= 1) break;
                    while (len > 1 && line[len - 1] != '/') len--;  /* the parent */
                    if (len > 1) len--;
                }
            }
        }
        {   /* cgroup v1 */
            static const char *dirs[] = {"/sys/fs/cgroup/cpu,cpuacct/", "/sys/fs/cgroup/cpu/"};
            int d;
            for (d = 0; d < 2; d++) {
                char q[64], p[64];
                snprintf(path, sizeof path, "%scpu.cfs_quota_us", dirs[d]);
                if (!supermat__read_small(path, q, sizeof q)) continue;
                snprintf(path, sizeof path, "%scpu.cfs_period_us", dirs[d]);
                if (!supermat__read_small(path, p, sizeof p)) continue;
                if ((k = supermat__cpu_quota(q, p)) > 0 && k < n) n = k;
                break;
            }
        }
    }
#endif
#elif SUPERMAT__HAS_WINTHREADS
    {
        SYSTEM_INFO si;
        DWORD_PTR pm = 0, sm = 0;
        int total, k;
        GetSystemInfo(&si);
        total = (int)si.dwNumberOfProcessors;
        n = total > 0 ? total : 1;
        if (GetProcessAffinityMask(GetCurrentProcess(), &pm, &sm) && pm) { /* the process's processor group */
            for (k = 0; pm; pm &= pm - 1) k++;
            if (k < n) n = k;
        }
#ifdef JOB_OBJECT_CPU_RATE_CONTROL_HARD_CAP
        {   /* a job object's hard cap: CpuRate cycles per 10000 of all processors' */
            JOBOBJECT_CPU_RATE_CONTROL_INFORMATION ci;
            memset(&ci, 0, sizeof ci);
            if (QueryInformationJobObject(NULL, JobObjectCpuRateControlInformation, &ci, sizeof ci, NULL) &&
                (ci.ControlFlags & JOB_OBJECT_CPU_RATE_CONTROL_ENABLE) && (ci.ControlFlags & JOB_OBJECT_CPU_RATE_CONTROL_HARD_CAP) &&
                !(ci.ControlFlags & JOB_OBJECT_CPU_RATE_CONTROL_WEIGHT_BASED) && ci.CpuRate > 0) {
                k = (int)(((unsigned long long)ci.CpuRate * (unsigned)total + 9999u) / 10000u);
                if (k >= 1 && k < n) n = k;
            }
        }
#endif
    }
#endif
    return (int)SUPERMAT__MIN(n, 64);
}

SUPERMAT__DEF int supermat_default_threads(void) { return supermat__cpu_count(); }

SUPERMAT__DEF int supermat_build_optimized(void) {
#if defined(__OPTIMIZE__)
    return 1;
#elif defined(__GNUC__) || defined(__clang__)
    return 0;
#else
    return -1;
#endif
}

/* >>errors */
SUPERMAT__DEF const char *supermat_result_string(supermat_result r) {
    switch (r) {
    case SUPERMAT_SUCCESS: return "success";
    case SUPERMAT_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case SUPERMAT_ERROR_OUT_OF_MEMORY: return "out of memory";
    case SUPERMAT_ERROR_MALFORMED_FILE: return "malformed model file";
    case SUPERMAT_ERROR_UNSUPPORTED: return "unsupported";
    case SUPERMAT_ERROR_MISSING_TENSOR: return "missing tensor";
    case SUPERMAT_ERROR_SHAPE_MISMATCH: return "tensor shape mismatch";
    case SUPERMAT_ERROR_NONFINITE: return "NaN or Inf in input";
    case SUPERMAT_ERROR_CANCELLED: return "cancelled";
    case SUPERMAT_ERROR_BAD_IMAGE: return "bad image";
    case SUPERMAT_ERROR_INTERNAL: return "internal error";
    case SUPERMAT_ERROR_IO: return "write failed";
    default: return "unknown result";
    }
}

#if defined(__GNUC__) || defined(__clang__)
static supermat_result supermat__fail(supermat_error *err, supermat_result r, const char *tensor, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
#endif
static supermat_result supermat__fail(supermat_error *err, supermat_result r, const char *tensor, const char *fmt, ...) {
    if (err) {
        va_list ap;
        err->result = r;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
        err->tensor[0] = 0;
        if (tensor) {
            size_t n = strlen(tensor);
            if (n >= sizeof err->tensor) n = sizeof err->tensor - 1;
            memcpy(err->tensor, tensor, n);
            err->tensor[n] = 0;
        }
    }
    return r;
}

/* formats a tensor name; names longer than the buffer are cut (and then simply not found) */
#if defined(__GNUC__) || defined(__clang__)
static int supermat__name(char *buf, size_t cap, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
#endif
static int supermat__name(char *buf, size_t cap, const char *fmt, ...) {
    va_list ap;
    int n;
    va_start(ap, fmt);
    n = vsnprintf(buf, cap, fmt, ap);
    va_end(ap);
    return n;
}

static void supermat__ok(supermat_error *err) {
    if (err) { err->result = SUPERMAT_SUCCESS; err->message[0] = 0; err->tensor[0] = 0; }
}

/* >>memory */
static void *supermat__default_alloc(void *user, size_t size, size_t align) {
    void *raw, **p;
    (void)user;
    if (align < sizeof(void *)) align = sizeof(void *);
#if defined(__linux__) && defined(MADV_HUGEPAGE) && !defined(SUPERMAT_NO_MADVISE)
    if (size >= ((size_t)8 << 20)) align = (size_t)2 << 20; /* whole huge pages for weights and arenas */
#endif
    if (size > SIZE_MAX - align - sizeof(void *)) return NULL;
    raw = malloc(size + align + sizeof(void *));
    if (!raw) return NULL;
    p = (void **)(((uintptr_t)raw + sizeof(void *) + align - 1) & ~(uintptr_t)(align - 1));
    p[-1] = raw;
#if defined(__linux__) && defined(MADV_HUGEPAGE) && !defined(SUPERMAT_NO_MADVISE)
    if (size >= ((size_t)8 << 20)) madvise(p, size & ~(((size_t)2 << 20) - 1), MADV_HUGEPAGE); /* a hint: failure is harmless */
#endif
    return p;
}
static void supermat__default_free(void *user, void *ptr, size_t size) {
    (void)user; (void)size;
    if (ptr) free(((void **)ptr)[-1]);
}
static supermat_allocator supermat__resolve_allocator(const supermat_allocator *a) {
    supermat_allocator r;
    if (a && a->alloc && a->free) return *a;
    r.alloc = supermat__default_alloc; r.free = supermat__default_free; r.user = NULL;
    return r;
}
static void *supermat__alloc(const supermat_allocator *a, size_t size) {
    void *p;
    if (size == 0) size = 1;
    p = a->alloc(a->user, size, 64);
    SUPERMAT_ASSERT(((uintptr_t)p & 63) == 0);
    return p;
}
static void supermat__free(const supermat_allocator *a, void *p, size_t size) {
    if (p) a->free(a->user, p, size);
}
/* overflow-checked size arithmetic */
static int supermat__mul_ok(size_t a, size_t b, size_t *out) {
    if (a && b > SIZE_MAX / a) return 0;
    *out = a * b;
    return 1;
}

/* >>json : a jsmn-style tokenizer (strict enough for safetensors headers and diffusers configs) */
typedef struct supermat__jp {
    const char *js; size_t len, i; supermat_json_tok *toks; int max, n;
} supermat__jp;

static void supermat__jp_ws(supermat__jp *p) {
    while (p->i < p->len && (p->js[p->i] == ' ' || p->js[p->i] == '\t' || p->js[p->i] == '\n' || p->js[p->i] == '\r')) p->i++;
}
static int supermat__jp_tok(supermat__jp *p, supermat_json_type t, size_t s, size_t e) {
    if (p->toks) {
        if (p->n >= p->max) return -1;
        p->toks[p->n].type = t; p->toks[p->n].start = (int)s; p->toks[p->n].end = (int)e;
        p->toks[p->n].size = 0; p->toks[p->n].next = p->n + 1;
    }
    return p->n++;
}
static int supermat__jp_string(supermat__jp *p) { /* at '"' */
    size_t s = ++p->i;
    while (p->i < p->len && p->js[p->i] != '"') {
        unsigned char c = (unsigned char)p->js[p->i];
        if (c < 0x20) return SUPERMAT_ERROR_MALFORMED_FILE;
        if (c == '\\') {
            p->i++;
            if (p->i >= p->len) return SUPERMAT_ERROR_MALFORMED_FILE;
            if (p->js[p->i] == 'u') {
                int k;
                for (k = 1; k <= 4; k++) {
                    char h = p->i + k < p->len ? p->js[p->i + k] : 0;
                    if (!((h >= '0' && h <= '9') || (h >= 'a' && h <= 'f') || (h >= 'A' && h <= 'F'))) return SUPERMAT_ERROR_MALFORMED_FILE;
                }
                p->i += 4;
            } else if (!strchr("\"\\/bfnrt", p->js[p->i]) || p->js[p->i] == 0) return SUPERMAT_ERROR_MALFORMED_FILE;
        }
        p->i++;
    }
    if (p->i >= p->len) return SUPERMAT_ERROR_MALFORMED_FILE;
    p->i++;
    return supermat__jp_tok(p, SUPERMAT_JSON_STRING, s, p->i - 1) < 0 ? SUPERMAT_ERROR_OUT_OF_MEMORY : SUPERMAT_SUCCESS;
}
static int supermat__jp_value(supermat__jp *p, int depth) {
    char c;
    int t, r;
    supermat__jp_ws(p);
    if (p->i >= p->len) return SUPERMAT_ERROR_MALFORMED_FILE;
    c = p->js[p->i];
    if (c == '"') return supermat__jp_string(p);
    if (c == '{' || c == '[') {
        int obj = c == '{';
        if (depth >= 64) return SUPERMAT_ERROR_MALFORMED_FILE;
        t = supermat__jp_tok(p, obj ? SUPERMAT_JSON_OBJECT : SUPERMAT_JSON_ARRAY, p->i, p->i);
        if (t < 0) return SUPERMAT_ERROR_OUT_OF_MEMORY;
        p->i++;
        supermat__jp_ws(p);
        if (p->i < p->len && p->js[p->i] == (obj ? '}' : ']')) {
            p->i++;
        } else {
            for (;;) {
                int key = -1;
                supermat__jp_ws(p);
                if (obj) {
                    if (p->i >= p->len || p->js[p->i] != '"') return SUPERMAT_ERROR_MALFORMED_FILE;
                    key = p->n;
                    if ((r = supermat__jp_string(p)) != 0) return r;
                    supermat__jp_ws(p);
                    if (p->i >= p->len || p->js[p->i] != ':') return SUPERMAT_ERROR_MALFORMED_FILE;
                    p->i++;
                }
                if ((r = supermat__jp_value(p, depth + 1)) != 0) return r;
                if (p->toks) {
                    p->toks[t].size++;
                    if (key >= 0) { p->toks[key].size = 1; p->toks[key].next = p->n; }
                }
                supermat__jp_ws(p);
                if (p->i >= p->len) return SUPERMAT_ERROR_MALFORMED_FILE;
                if (p->js[p->i] == ',') { p->i++; continue; }
                if (p->js[p->i] == (obj ? '}' : ']')) { p->i++; break; }
                return SUPERMAT_ERROR_MALFORMED_FILE;
            }
        }
        if (p->toks) { p->toks[t].end = (int)p->i; p->toks[t].next = p->n; }
        return SUPERMAT_SUCCESS;
    }
    if (c == '-' || (c >= '0' && c <= '9') || c == 't' || c == 'f' || c == 'n') {
        size_t s = p->i;
        while (p->i < p->len && !strchr(" \t\r\n,:]}", p->js[p->i])) {
            if ((unsigned char)p->js[p->i] < 0x20 || p->js[p->i] == '"' || p->js[p->i] == '{' || p->js[p->i] == '[') return SUPERMAT_ERROR_MALFORMED_FILE;
            p->i++;
        }
        return supermat__jp_tok(p, SUPERMAT_JSON_PRIMITIVE, s, p->i) < 0 ? SUPERMAT_ERROR_OUT_OF_MEMORY : SUPERMAT_SUCCESS;
    }
    return SUPERMAT_ERROR_MALFORMED_FILE;
}

SUPERMAT__DEF int supermat_json_parse(const char *js, size_t len, supermat_json_tok *toks, int max_toks) {
    supermat__jp p;
    int r;
    if (!js || len > (size_t)INT_MAX - 2) return SUPERMAT_ERROR_INVALID_ARGUMENT;
    p.js = js; p.len = len; p.i = 0; p.toks = toks; p.max = max_toks; p.n = 0;
    r = supermat__jp_value(&p, 0);
    if (r != 0) return r;
    supermat__jp_ws(&p);
    if (p.i != len) return SUPERMAT_ERROR_MALFORMED_FILE;
    return p.n;
}

static int supermat__json_eq(const char *js, const supermat_json_tok *t, const char *s) {
    size_t n = strlen(s);
    return t->type == SUPERMAT_JSON_STRING && (size_t)(t->end - t->start) == n && memcmp(js + t->start, s, n) == 0;
}

SUPERMAT__DEF int supermat_json_find(const char *js, const supermat_json_tok *toks, int obj, const char *key) {
    int i, k, n;
    if (!js || !toks || obj < 0 || toks[obj].type != SUPERMAT_JSON_OBJECT) return -1;
    n = toks[obj].size;
    k = obj + 1;
    for (i = 0; i < n; i++) {
        if (supermat__json_eq(js, &toks[k], key)) return k + 1;
        k = toks[k].next; /* skip key and its value subtree */
    }
    return -1;
}

SUPERMAT__DEF int supermat_json_string(const char *js, const supermat_json_tok *tok, char *buf, size_t cap) {
    int i;
    size_t o = 0;
    if (!tok || tok->type != SUPERMAT_JSON_STRING || !buf || cap == 0) return -1;
    for (i = tok->start; i < tok->end; i++) {
        unsigned cp = (unsigned char)js[i];
        if (cp == '\\') {
            char e = js[++i];
            switch (e) {
            case 'b': cp = 8; break; case 'f': cp = 12; break; case 'n': cp = 10; break;
            case 'r': cp = 13; break; case 't': cp = 9; break;
            case 'u': {
                int k; cp = 0;
                for (k = 1; k <= 4; k++) {
                    char h = js[i + k];
                    cp = cp * 16 + (unsigned)(h <= '9' ? h - '0' : (h | 32) - 'a' + 10);
                }
                i += 4;
                break;
            }
            default: cp = (unsigned char)e; break;
            }
            if (cp >= 0x80) { /* UTF-8 encode (surrogates passed through as-is) */
                if (cp < 0x800) {
                    if (o + 2 >= cap) return -1;
                    buf[o++] = (char)(0xC0 | (cp >> 6)); buf[o++] = (char)(0x80 | (cp & 63));
                } else {
                    if (o + 3 >= cap) return -1;
                    buf[o++] = (char)(0xE0 | (cp >> 12)); buf[o++] = (char)(0x80 | ((cp >> 6) & 63)); buf[o++] = (char)(0x80 | (cp & 63));
                }
                continue;
            }
        }
        if (o + 1 >= cap) return -1;
        buf[o++] = (char)cp;
    }
    buf[o] = 0;
    return (int)o;
}

SUPERMAT__DEF int supermat_json_number(const char *js, const supermat_json_tok *tok, double *out) {
    char tmp[64], *end;
    int n;
    if (!tok || tok->type != SUPERMAT_JSON_PRIMITIVE) return -1;
    n = tok->end - tok->start;
    if (n <= 0 || n >= (int)sizeof tmp) return -1;
    memcpy(tmp, js + tok->start, (size_t)n);
    tmp[n] = 0;
    if (!(tmp[0] == '-' || (tmp[0] >= '0' && tmp[0] <= '9'))) return -1;
    *out = strtod(tmp, &end);
    return *end == 0 ? 0 : -1;
}

/* >>safetensors */
static supermat_result supermat__st_header(const void *buf, size_t buf_size, uint64_t file_size, uint64_t *hlen,
                                           supermat_error *err) {
    const unsigned char *b = (const unsigned char *)buf;
    uint64_t n = 0;
    int i;
    if (!buf || buf_size < 8 || file_size < 8)
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "file is %llu bytes, too short for a safetensors header", (unsigned long long)file_size);
    for (i = 7; i >= 0; i--) n = (n << 8) | b[i];
    if (n < 2 || n > 100u * 1024u * 1024u || n > file_size - 8)
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "safetensors header length %llu does not fit a file of %llu bytes", (unsigned long long)n, (unsigned long long)file_size);
    if (n > buf_size - 8)
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "buffer of %llu bytes does not hold the %llu-byte header", (unsigned long long)buf_size, (unsigned long long)n);
    *hlen = n;
    return SUPERMAT_SUCCESS;
}

/* Parses the header JSON into a token array allocated with `a`. */
static supermat_result supermat__st_tokens(const void *buf, size_t buf_size, uint64_t file_size, const supermat_allocator *a,
                                           supermat_json_tok **toks_out, int *ntok_out, supermat_error *err) {
    uint64_t hlen;
    int ntok;
    supermat_json_tok *toks;
    const char *js = (const char *)buf + 8;
    supermat_result r;
    hlen = 0;
    r = supermat__st_header(buf, buf_size, file_size, &hlen, err);
    if (r) return r;
    ntok = supermat_json_parse(js, (size_t)hlen, NULL, 0);
    if (ntok < 0)
        return supermat__fail(err, ntok == SUPERMAT_ERROR_OUT_OF_MEMORY ? SUPERMAT_ERROR_OUT_OF_MEMORY : SUPERMAT_ERROR_MALFORMED_FILE, NULL, "safetensors header is not valid JSON");
    toks = (supermat_json_tok *)supermat__alloc(a, sizeof(supermat_json_tok) * (size_t)ntok);
    if (!toks) return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory for %d JSON tokens", ntok);
    if (supermat_json_parse(js, (size_t)hlen, toks, ntok) != ntok || toks[0].type != SUPERMAT_JSON_OBJECT) {
        supermat__free(a, toks, sizeof(supermat_json_tok) * (size_t)ntok);
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "safetensors header is not a JSON object");
    }
    *toks_out = toks;
    *ntok_out = ntok;
    return SUPERMAT_SUCCESS;
}

static supermat_result supermat__st_entry(const char *js, const supermat_json_tok *toks, int key, uint64_t data_start,
                                          uint64_t file_size, supermat_tensor_info *o, supermat_error *err) {
    int v = key + 1, d, s, off, k;
    char dt[16];
    double x;
    uint64_t elems = 1, esz, b0, b1;
    memset(o, 0, sizeof *o);
    if (supermat_json_string(js, &toks[key], o->name, sizeof o->name) < 0)
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "tensor name too long");
    if (toks[v].type != SUPERMAT_JSON_OBJECT)
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, o->name, "tensor entry '%s' is not an object", o->name);
    d = supermat_json_find(js, toks, v, "dtype");
    s = supermat_json_find(js, toks, v, "shape");
    off = supermat_json_find(js, toks, v, "data_offsets");
    if (d < 0 || s < 0 || off < 0 || supermat_json_string(js, &toks[d], dt, sizeof dt) < 0 ||
        toks[s].type != SUPERMAT_JSON_ARRAY || toks[off].type != SUPERMAT_JSON_ARRAY || toks[off].size != 2)
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, o->name, "tensor '%s' lacks dtype, shape or data_offsets", o->name);
    if (!strcmp(dt, "F32")) { o->dtype = SUPERMAT_DTYPE_F32; esz = 4; }
    else if (!strcmp(dt, "F16")) { o->dtype = SUPERMAT_DTYPE_F16; esz = 2; }
    else if (!strcmp(dt, "BF16")) { o->dtype = SUPERMAT_DTYPE_BF16; esz = 2; }
    else if (!strcmp(dt, "I8")) { o->dtype = SUPERMAT_DTYPE_I8; esz = 1; }
    else if (!strcmp(dt, "U8")) { o->dtype = SUPERMAT_DTYPE_U8; esz = 1; }
    else return supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, o->name, "tensor '%s' has dtype %s (F32, F16, BF16, I8 and U8 are supported)", o->name, dt);
    if (toks[s].size > 8) return supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, o->name, "tensor '%s' has %d dimensions", o->name, toks[s].size);
    o->ndim = toks[s].size;
    for (k = 0; k < o->ndim; k++) {
        if (supermat_json_number(js, &toks[s + 1 + k], &x) || x < 0 || x > 4e12 || x != floor(x))
            return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, o->name, "tensor '%s' has a bad shape", o->name);
        o->shape[k] = (int64_t)x;
        if (o->shape[k] && elems > UINT64_MAX / (uint64_t)o->shape[k]) return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, o->name, "tensor '%s' shape overflows", o->name);
        elems *= (uint64_t)o->shape[k];
    }
    if (supermat_json_number(js, &toks[off + 1], &x) || x < 0 || x > 1.8e19 || x != floor(x)) goto bad_off;
    b0 = (uint64_t)x;
    if (supermat_json_number(js, &toks[off + 2], &x) || x < 0 || x > 1.8e19 || x != floor(x)) goto bad_off;
    b1 = (uint64_t)x;
    if (elems > UINT64_MAX / esz || b1 < b0 || b1 - b0 != elems * esz)
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, o->name, "tensor '%s': data_offsets [%llu, %llu] do not match its shape and dtype", o->name, (unsigned long long)b0, (unsigned long long)b1);
    if (b1 > file_size - data_start)
        return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, o->name, "tensor '%s' ends at byte %llu, past the end of the %llu-byte file (truncated?)", o->name, (unsigned long long)(data_start + b1), (unsigned long long)file_size);
    o->offset = data_start + b0;
    o->nbytes = b1 - b0;
    return SUPERMAT_SUCCESS;
bad_off:
    return supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, o->name, "tensor '%s' has bad data_offsets", o->name);
}

SUPERMAT__DEF supermat_result supermat_safetensors_count(const void *buf, size_t buf_size, uint64_t file_size, int *n_tensors,
                                                         supermat_error *err) {
    supermat_allocator a = supermat__resolve_allocator(NULL);
    supermat_json_tok *toks;
    int ntok, k, n = 0, i;
    const char *js = (const char *)buf + 8;
    supermat_result r;
    if (!n_tensors) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "n_tensors is NULL");
    r = supermat__st_tokens(buf, buf_size, file_size, &a, &toks, &ntok, err);
    if (r) return r;
    for (i = 0, k = 1; i < toks[0].size; i++, k = toks[k].next)
        if (!supermat__json_eq(js, &toks[k], "__metadata__")) n++;
    supermat__free(&a, toks, sizeof(supermat_json_tok) * (size_t)ntok);
    *n_tensors = n;
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF supermat_result supermat_safetensors_tensor(const void *buf, size_t buf_size, uint64_t file_size, int index,
                                                          supermat_tensor_info *out, supermat_error *err) {
    supermat_allocator a = supermat__resolve_allocator(NULL);
    supermat_json_tok *toks;
    int ntok, k, n = 0, i;
    uint64_t hlen = 0;
    const char *js = (const char *)buf + 8;
    supermat_result r;
    if (!out) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "out is NULL");
    r = supermat__st_tokens(buf, buf_size, file_size, &a, &toks, &ntok, err);
    if (r) return r;
    supermat__st_header(buf, buf_size, file_size, &hlen, NULL);
    r = supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "tensor index %d out of range", index);
    for (i = 0, k = 1; i < toks[0].size; i++, k = toks[k].next) {
        if (supermat__json_eq(js, &toks[k], "__metadata__")) continue;
        if (n++ == index) { r = supermat__st_entry(js, toks, k, 8 + hlen, file_size, out, err); break; }
    }
    supermat__free(&a, toks, sizeof(supermat_json_tok) * (size_t)ntok);
    if (!r) supermat__ok(err);
    return r;
}

/* 0 and the value of `key` in a tokenized header's __metadata__, -1 when it has none (or it does not fit) */
static int supermat__meta_value(const char *js, const supermat_json_tok *toks, const char *key, char *value, size_t cap) {
    int m = supermat_json_find(js, toks, 0, "__metadata__"), v;
    return m >= 0 && (v = supermat_json_find(js, toks, m, key)) >= 0 && supermat_json_string(js, &toks[v], value, cap) >= 0 ? 0 : -1;
}

SUPERMAT__DEF int supermat_safetensors_metadata(const void *buf, size_t buf_size, const char *key, char *value, size_t cap) {
    supermat_allocator a = supermat__resolve_allocator(NULL);
    supermat_json_tok *toks;
    int ntok, res;
    const char *js = (const char *)buf + 8;
    uint64_t hlen = 0;
    if (!buf || buf_size < 8 || !key) return -1;
    if (supermat__st_header(buf, buf_size, buf_size, &hlen, NULL)) return -1;
    if (supermat__st_tokens(buf, buf_size, 8 + hlen, &a, &toks, &ntok, NULL)) return -1;
    res = supermat__meta_value(js, toks, key, value, cap);
    supermat__free(&a, toks, sizeof(supermat_json_tok) * (size_t)ntok);
    return res;
}

/* >>cpu */
#if SUPERMAT__HAS_AVX2
/* CPUID leaf / sub-leaf into r = eax, ebx, ecx, edx; 0 where the CPU has no such leaf. XCR0 (XGETBV 0): which
   register state the OS saves (bits 1-2 XMM / YMM, 5-7 AVX-512, 17-18 AMX tiles) */
static int supermat__cpuid(unsigned leaf, unsigned sub, unsigned r[4]) {
#if SUPERMAT__GNU_SIMD
    return __get_cpuid_count(leaf, sub, &r[0], &r[1], &r[2], &r[3]);
#else
    int v[4];
    __cpuidex(v, 0, 0);
    if ((unsigned)v[0] < leaf) return 0;
    __cpuidex(v, (int)leaf, (int)sub);
    r[0] = (unsigned)v[0]; r[1] = (unsigned)v[1]; r[2] = (unsigned)v[2]; r[3] = (unsigned)v[3];
    return 1;
#endif
}
static unsigned supermat__xcr0(void) {
#if SUPERMAT__GNU_SIMD
    unsigned lo, hi;
    __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
    (void)hi;
    return lo;
#else
    return (unsigned)_xgetbv(0);
#endif
}
#endif

static int supermat__cpu_has_avx2(void) {
#if SUPERMAT__HAS_AVX2
    static int cached = -1;
    unsigned r[4];
    int ok = 0;
    if (cached >= 0) return cached;
    if (supermat__cpuid(1, 0, r)) {
        unsigned c = r[2];
        int osxsave = (c >> 27) & 1, avx = (c >> 28) & 1, fma = (c >> 12) & 1, f16c = (c >> 29) & 1;
        if (osxsave && avx && fma && f16c && (supermat__xcr0() & 6) == 6 && supermat__cpuid(7, 0, r)) ok = (r[1] >> 5) & 1;
    }
    cached = ok;
    return ok;
#else
    return 0;
#endif
}

static int supermat__cpu_has_avx512(void) {
#if SUPERMAT__HAS_AVX512
    static int cached = -1;
    unsigned r[4];
    int ok = 0;
    if (cached >= 0) return cached;
    if (supermat__cpu_has_avx2() && supermat__cpuid(7, 0, r) && ((r[1] >> 16) & 1))
        ok = (supermat__xcr0() & 0xE6) == 0xE6; /* XMM, YMM, opmask, ZMM_Hi256, Hi16_ZMM state enabled */
    cached = ok;
    return ok;
#else
    return 0;
#endif
}

static int supermat__cpu_has_avx512_bf16(void) {
#if SUPERMAT__HAS_AVX512
    unsigned r[4];
    return supermat__cpu_has_avx512() && supermat__cpuid(7, 1, r) && ((r[0] >> 5) & 1);
#else
    return 0;
#endif
}

static int supermat__cpu_has_avx512_vnni(void) {
#if SUPERMAT__HAS_AVX512
    unsigned r[4];
    return supermat__cpu_has_avx512() && supermat__cpuid(7, 0, r) && ((r[1] >> 30) & 1) && ((r[2] >> 11) & 1);
#else
    return 0;
#endif
}

static int supermat__cpu_has_avx_vnni(void) {
#if SUPERMAT__HAS_AVXVNNI
    unsigned r[4];
    return supermat__cpu_has_avx2() && supermat__cpuid(7, 1, r) && ((r[0] >> 4) & 1);
#else
    return 0;
#endif
}

static int supermat__cpu_has_neon(void) { return SUPERMAT__HAS_NEON; }

#if SUPERMAT__HAS_AMX
long syscall(long number, ...); /* <unistd.h> declares it only outside strict C99 */
#endif
static int supermat__cpu_has_amx_bf16(void) {
#if SUPERMAT__HAS_AMX
    static int cached = -1;
    unsigned r[4];
    int ok = 0;
    if (cached >= 0) return cached;
    /* Linux hands out the 8 KB tile state on request (arch_prctl ARCH_REQ_XCOMP_PERM = 0x1023,
       XFEATURE_XTILEDATA = 18; syscall 158 on x86-64); XCR0 bits 17-18 say the OS manages it */
    if (supermat__cpu_has_avx512_bf16() && supermat__cpuid(7, 0, r) && ((r[3] >> 24) & 1) && ((r[3] >> 22) & 1) &&
        syscall(158, 0x1023L, 18L) == 0)
        ok = (supermat__xcr0() & 0x60000u) == 0x60000u;
    cached = ok;
    return ok;
#else
    return 0;
#endif
}

SUPERMAT__DEF supermat_cpu_info supermat_cpu(void) {
    supermat_cpu_info c;
    c.avx2 = supermat__cpu_has_avx2();
    c.avx512 = supermat__cpu_has_avx512();
    c.avx512_bf16 = supermat__cpu_has_avx512_bf16();
    c.avx512_vnni = supermat__cpu_has_avx512_vnni();
    c.avx_vnni = supermat__cpu_has_avx_vnni();
    c.neon = supermat__cpu_has_neon();
    c.amx_bf16 = supermat__cpu_has_amx_bf16();
    return c;
}

/* >>convert : f16 / bf16 to f32 (scalar, exact) */
static float supermat__f16_to_f32(uint16_t h) {
    uint32_t s = (uint32_t)(h >> 15) << 31, e = (h >> 10) & 31, m = h & 1023, bits;
    float f;
    if (e == 0) {
        f = (float)m * (1.0f / 16777216.0f); /* subnormal: m * 2^-24 */
        return s ? -f : f;
    }
    if (e == 31) bits = s | 0x7F800000u | (m << 13);
    else bits = s | ((e + 112) << 23) | (m << 13);
    memcpy(&f, &bits, 4);
    return f;
}
static float supermat__bf16_to_f32(uint16_t h) {
    uint32_t bits = (uint32_t)h << 16;
    float f;
    memcpy(&f, &bits, 4);
    return f;
}
static uint16_t supermat__f32_to_f16(float f) { /* round to nearest even; caller checks the range */
    uint32_t x, sign, e, m;
    memcpy(&x, &f, 4);
    sign = (x >> 16) & 0x8000u; e = (x >> 23) & 255; m = x & 0x7FFFFFu;
    if (e >= 143) return (uint16_t)(sign | 0x7C00u);                 /* overflow -> inf */
    if (e < 113) {                                                    /* subnormal half or zero */
        uint32_t shift, hm, rem, half;
        if (e < 102) return (uint16_t)sign;
        m |= 0x800000u; shift = 126 - e; hm = m >> shift; rem = m & ((1u << shift) - 1); half = 1u << (shift - 1);
        if (rem > half || (rem == half && (hm & 1))) hm++;
        return (uint16_t)(sign | hm);
    }
    {
        uint32_t h = ((e - 112) << 10) | (m >> 13), rem = m & 0x1FFFu;
        if (rem > 0x1000u || (rem == 0x1000u && (h & 1))) h++;        /* may carry into the exponent: correct */
        return (uint16_t)(sign | h);
    }
}
static uint16_t supermat__f32_to_bf16(float f) {
    uint32_t x;
    memcpy(&x, &f, 4);
    x += 0x7FFFu + ((x >> 16) & 1u);
    return (uint16_t)(x >> 16);
}
static float supermat__load_elem(const unsigned char *p, supermat_dtype dt, size_t i) {
    uint16_t h;
    float f;
    if (dt == SUPERMAT_DTYPE_F32) { memcpy(&f, p + 4 * i, 4); return f; }
    memcpy(&h, p + 2 * i, 2);
    return dt == SUPERMAT_DTYPE_F16 ? supermat__f16_to_f32(h) : supermat__bf16_to_f32(h);
}

/* >>gemm
   C[m, n] = init + sum_k A[m, k] * B[k, n], with B packed in panels of NR=16 columns (K x 16 each,
   zero-padded past N) and A given by row pointers (dense) or read from an NHWC image (conv: in place, K
   blocks within one tap, from 64 channels up with f32 / widened weights; else gathered into rows).
   init = bias[n] (+ R[m, n]) on the first K block, the running C afterwards. Each output element is
   computed by exactly one task with the same K order, so any thread count gives the same bits. */
#define SUPERMAT__MR 6     /* rows of the scalar and AVX2 micro-kernels */
#define SUPERMAT__MRMAX 12 /* the most rows a micro-kernel takes (AVX-512): row pointer arrays have this many */
#define SUPERMAT__NR 16
#define SUPERMAT__KC 256
#define SUPERMAT__MC 96

typedef struct supermat__pw { /* a packed weight: y = x W^T + b, W [N][K] */
    float *p;      /* ceil(N/16) panels of K x 16 (f32 weights) */
    void *q;       /* the same panels in f16 / bf16 / int8 when fmt != 0 (then p is NULL) */
    float *qs;     /* int8: a scale per column per group of K rows: [groups][ceil(N/16)*16]; int8 compute
                      (fmt 5): [ceil(K/64)][ceil(N/16)*16] scales, then as many int32: 128 x the column sums */
    float *bias;   /* padded to a multiple of 16, or NULL */
    int K, N, fmt; /* fmt: 0 f32, 1 f16, 2 bf16, 3 int8, 4 bf16 pairs, 5 int8 quads (int8 compute) */
    int qcin;      /* int8: K rows come in taps of qcin rows (a conv's input channels; K for a linear) */
} supermat__pw;

/* int8 scale groups: each tap's qcin rows in runs of SUPERMAT__QG (the last run of a tap may be short) */
#define SUPERMAT__QG 64
static int supermat__qgroups(int K, int qcin) { return K / qcin * ((qcin + SUPERMAT__QG - 1) / SUPERMAT__QG); }
/* the group of row k, and the row where that group ends */
static int supermat__qgroup(int k, int qcin, int *end) {
    int tap = k / qcin, ci = k - tap * qcin, g = ci / SUPERMAT__QG, e = (g + 1) * SUPERMAT__QG;
    *end = tap * qcin + (e < qcin ? e : qcin);
    return tap * ((qcin + SUPERMAT__QG - 1) / SUPERMAT__QG) + g;
}

/* f16 / bf16 / int8 panels are widened to f32 a K block of one panel at a time (once per MC rows) */
typedef void (*supermat__widen_fn)(const void *src, int fmt, const float *scale, int kc, float *dst);

typedef void (*supermat__ukr_fn)(int kc, const float *const *a, const float *b, float *c, size_t ldc, int mr, int nr,
                                 const float *bias, const float *r, size_t ldr, int accumulate);

/* the tile a 6 x 16 micro-kernel starts from: the running C (accumulate), or bias (+ R); zero past mr x nr */
static void supermat__ukr_start(float *tile, const float *c, size_t ldc, int mr, int nr, const float *bias, const float *r,
                                size_t ldr, int accumulate) {
    int i, j;
    for (i = 0; i < SUPERMAT__MR; i++)
        for (j = 0; j < SUPERMAT__NR; j++) {
            float v = 0.0f;
            if (i < mr && j < nr) {
                if (accumulate) v = c[(size_t)i * ldc + j];
                else {
                    if (bias) v = bias[j];
                    if (r) v += r[(size_t)i * ldr + j];
                }
            }
            tile[i * SUPERMAT__NR + j] = v;
        }
}

static void supermat__ukr_scalar(int kc, const float *const *a, const float *b, float *c, size_t ldc, int mr, int nr,
                                 const float *bias, const float *r, size_t ldr, int accumulate) {
    float acc[SUPERMAT__MR * SUPERMAT__NR];
    int i, j, k;
    supermat__ukr_start(acc, c, ldc, mr, nr, bias, r, ldr, accumulate);
    for (k = 0; k < kc; k++) {
        const float *bk = b + (size_t)k * SUPERMAT__NR;
        for (i = 0; i < SUPERMAT__MR; i++) {
            float av = a[i][k];
            for (j = 0; j < SUPERMAT__NR; j++) acc[i * SUPERMAT__NR + j] += av * bk[j];
        }
    }
    for (i = 0; i < mr; i++)
        for (j = 0; j < nr; j++) c[(size_t)i * ldc + j] = acc[i * SUPERMAT__NR + j];
}

#if SUPERMAT__HAS_NEON
/* aarch64: 6 rows x 16 columns = 24 accumulators of 4 lanes, 4 for the B row, 1 for A: 29 of the 32
   vector registers; one fmla by a scalar lane per accumulator and k */
static void supermat__ukr_neon(int kc, const float *const *a, const float *b, float *c, size_t ldc, int mr, int nr,
                               const float *bias, const float *r, size_t ldr, int accumulate) {
    float tile[SUPERMAT__MR * SUPERMAT__NR];
    const float *a0 = a[0], *a1 = a[1], *a2 = a[2], *a3 = a[3], *a4 = a[4], *a5 = a[5];
    int i, j, k;
    supermat__ukr_start(tile, c, ldc, mr, nr, bias, r, ldr, accumulate);
    {
#define SUPERMAT__NLD(i) float32x4_t c##i##0 = vld1q_f32(tile + (i) * 16), c##i##1 = vld1q_f32(tile + (i) * 16 + 4), \
                                     c##i##2 = vld1q_f32(tile + (i) * 16 + 8), c##i##3 = vld1q_f32(tile + (i) * 16 + 12);
        SUPERMAT__NLD(0) SUPERMAT__NLD(1) SUPERMAT__NLD(2) SUPERMAT__NLD(3) SUPERMAT__NLD(4) SUPERMAT__NLD(5)
#undef SUPERMAT__NLD
        for (k = 0; k < kc; k++) {
            float32x4_t b0 = vld1q_f32(b), b1 = vld1q_f32(b + 4), b2 = vld1q_f32(b + 8), b3 = vld1q_f32(b + 12);
            b += SUPERMAT__NR;
#define SUPERMAT__NFMA(i) { float av_ = a##i[k]; c##i##0 = vfmaq_n_f32(c##i##0, b0, av_); c##i##1 = vfmaq_n_f32(c##i##1, b1, av_); \
                            c##i##2 = vfmaq_n_f32(c##i##2, b2, av_); c##i##3 = vfmaq_n_f32(c##i##3, b3, av_); }
            SUPERMAT__NFMA(0) SUPERMAT__NFMA(1) SUPERMAT__NFMA(2) SUPERMAT__NFMA(3) SUPERMAT__NFMA(4) SUPERMAT__NFMA(5)
#undef SUPERMAT__NFMA
        }
#define SUPERMAT__NST(i) vst1q_f32(tile + (i) * 16, c##i##0); vst1q_f32(tile + (i) * 16 + 4, c##i##1); \
                         vst1q_f32(tile + (i) * 16 + 8, c##i##2); vst1q_f32(tile + (i) * 16 + 12, c##i##3);
        SUPERMAT__NST(0) SUPERMAT__NST(1) SUPERMAT__NST(2) SUPERMAT__NST(3) SUPERMAT__NST(4) SUPERMAT__NST(5)
#undef SUPERMAT__NST
    }
    for (i = 0; i < mr; i++)
        for (j = 0; j < nr; j++) c[(size_t)i * ldc + j] = tile[i * SUPERMAT__NR + j];
}
#endif


static void supermat__widen_scalar(const void *src, int fmt, const float *scale, int kc, float *dst) {
    size_t i, n = (size_t)kc * SUPERMAT__NR;
    const uint16_t *h = (const uint16_t *)src;
    const signed char *q = (const signed char *)src;
    for (i = 0; i < n; i++)
        dst[i] = fmt == 1 ? supermat__f16_to_f32(h[i]) : fmt == 2 ? supermat__bf16_to_f32(h[i]) : (float)q[i] * scale[i % SUPERMAT__NR];
}

#if SUPERMAT__HAS_NEON
/* supermat__widen_scalar's values, 4 lanes at a time (every conversion is exact; int8 times its column scale
   is one rounding, as there) */
static void supermat__widen_neon(const void *src, int fmt, const float *scale, int kc, float *dst) {
    size_t i, n = (size_t)kc * SUPERMAT__NR;
    int k;
    if (fmt == 1) {
        const float16_t *h = (const float16_t *)src;
        for (i = 0; i < n; i += 4) vst1q_f32(dst + i, vcvt_f32_f16(vld1_f16(h + i)));
    } else if (fmt == 2) {
        const uint16_t *h = (const uint16_t *)src;
        for (i = 0; i < n; i += 4) vst1q_f32(dst + i, vreinterpretq_f32_u32(vshll_n_u16(vld1_u16(h + i), 16)));
    } else {
        const int8_t *q = (const int8_t *)src;
        float32x4_t s0 = vld1q_f32(scale), s1 = vld1q_f32(scale + 4), s2 = vld1q_f32(scale + 8), s3 = vld1q_f32(scale + 12);
        for (k = 0; k < kc; k++) {
            int8x16_t v = vld1q_s8(q + 16 * (size_t)k);
            int16x8_t lo = vmovl_s8(vget_low_s8(v)), hi = vmovl_high_s8(v);
            float *d = dst + 16 * (size_t)k;
            vst1q_f32(d, vmulq_f32(vcvtq_f32_s32(vmovl_s16(vget_low_s16(lo))), s0));
            vst1q_f32(d + 4, vmulq_f32(vcvtq_f32_s32(vmovl_high_s16(lo)), s1));
            vst1q_f32(d + 8, vmulq_f32(vcvtq_f32_s32(vmovl_s16(vget_low_s16(hi))), s2));
            vst1q_f32(d + 12, vmulq_f32(vcvtq_f32_s32(vmovl_high_s16(hi)), s3));
        }
    }
}
#endif

#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static void supermat__ukr_avx2(int kc, const float *const *a, const float *b, float *c, size_t ldc, int mr,
                                              int nr, const float *bias, const float *r, size_t ldr, int accumulate) {
    __m256 c00, c01, c10, c11, c20, c21, c30, c31, c40, c41, c50, c51;
    const float *a0 = a[0], *a1 = a[1], *a2 = a[2], *a3 = a[3], *a4 = a[4], *a5 = a[5];
    float tile[SUPERMAT__MR * SUPERMAT__NR];
    int full = (mr == SUPERMAT__MR && nr == SUPERMAT__NR), k, i, j;
    const float *src = c;
    size_t lds = ldc;
    if (!accumulate) {
        __m256 b0 = bias ? _mm256_loadu_ps(bias) : _mm256_setzero_ps();
        __m256 b1 = bias ? _mm256_loadu_ps(bias + 8) : _mm256_setzero_ps();
        c00 = c10 = c20 = c30 = c40 = c50 = b0;
        c01 = c11 = c21 = c31 = c41 = c51 = b1;
        if (r) {
            if (!full) {
                for (i = 0; i < SUPERMAT__MR; i++)
                    for (j = 0; j < SUPERMAT__NR; j++) tile[i * SUPERMAT__NR + j] = (i < mr && j < nr) ? r[(size_t)i * ldr + j] : 0.0f;
                src = tile; lds = SUPERMAT__NR;
            } else { src = r; lds = ldr; }
#define SUPERMAT__LR(ci0, ci1, row) ci0 = _mm256_add_ps(ci0, _mm256_loadu_ps(src + (size_t)(row) * lds)); ci1 = _mm256_add_ps(ci1, _mm256_loadu_ps(src + (size_t)(row) * lds + 8));
            SUPERMAT__LR(c00, c01, 0) SUPERMAT__LR(c10, c11, 1) SUPERMAT__LR(c20, c21, 2)
            SUPERMAT__LR(c30, c31, 3) SUPERMAT__LR(c40, c41, 4) SUPERMAT__LR(c50, c51, 5)
#undef SUPERMAT__LR
        }
    } else {
        if (!full) {
            for (i = 0; i < SUPERMAT__MR; i++)
                for (j = 0; j < SUPERMAT__NR; j++) tile[i * SUPERMAT__NR + j] = (i < mr && j < nr) ? c[(size_t)i * ldc + j] : 0.0f;
            src = tile; lds = SUPERMAT__NR;
        }
        c00 = _mm256_loadu_ps(src); c01 = _mm256_loadu_ps(src + 8);
        c10 = _mm256_loadu_ps(src + lds); c11 = _mm256_loadu_ps(src + lds + 8);
        c20 = _mm256_loadu_ps(src + 2 * lds); c21 = _mm256_loadu_ps(src + 2 * lds + 8);
        c30 = _mm256_loadu_ps(src + 3 * lds); c31 = _mm256_loadu_ps(src + 3 * lds + 8);
        c40 = _mm256_loadu_ps(src + 4 * lds); c41 = _mm256_loadu_ps(src + 4 * lds + 8);
        c50 = _mm256_loadu_ps(src + 5 * lds); c51 = _mm256_loadu_ps(src + 5 * lds + 8);
    }
    for (k = 0; k < kc; k++) {
        __m256 b0 = _mm256_loadu_ps(b), b1 = _mm256_loadu_ps(b + 8), av;
        b += SUPERMAT__NR;
        av = _mm256_broadcast_ss(a0 + k); c00 = _mm256_fmadd_ps(av, b0, c00); c01 = _mm256_fmadd_ps(av, b1, c01);
        av = _mm256_broadcast_ss(a1 + k); c10 = _mm256_fmadd_ps(av, b0, c10); c11 = _mm256_fmadd_ps(av, b1, c11);
        av = _mm256_broadcast_ss(a2 + k); c20 = _mm256_fmadd_ps(av, b0, c20); c21 = _mm256_fmadd_ps(av, b1, c21);
        av = _mm256_broadcast_ss(a3 + k); c30 = _mm256_fmadd_ps(av, b0, c30); c31 = _mm256_fmadd_ps(av, b1, c31);
        av = _mm256_broadcast_ss(a4 + k); c40 = _mm256_fmadd_ps(av, b0, c40); c41 = _mm256_fmadd_ps(av, b1, c41);
        av = _mm256_broadcast_ss(a5 + k); c50 = _mm256_fmadd_ps(av, b0, c50); c51 = _mm256_fmadd_ps(av, b1, c51);
    }
    if (full) {
        _mm256_storeu_ps(c, c00); _mm256_storeu_ps(c + 8, c01);
        _mm256_storeu_ps(c + ldc, c10); _mm256_storeu_ps(c + ldc + 8, c11);
        _mm256_storeu_ps(c + 2 * ldc, c20); _mm256_storeu_ps(c + 2 * ldc + 8, c21);
        _mm256_storeu_ps(c + 3 * ldc, c30); _mm256_storeu_ps(c + 3 * ldc + 8, c31);
        _mm256_storeu_ps(c + 4 * ldc, c40); _mm256_storeu_ps(c + 4 * ldc + 8, c41);
        _mm256_storeu_ps(c + 5 * ldc, c50); _mm256_storeu_ps(c + 5 * ldc + 8, c51);
        return;
    }
    _mm256_storeu_ps(tile, c00); _mm256_storeu_ps(tile + 8, c01);
    _mm256_storeu_ps(tile + 16, c10); _mm256_storeu_ps(tile + 24, c11);
    _mm256_storeu_ps(tile + 32, c20); _mm256_storeu_ps(tile + 40, c21);
    _mm256_storeu_ps(tile + 48, c30); _mm256_storeu_ps(tile + 56, c31);
    _mm256_storeu_ps(tile + 64, c40); _mm256_storeu_ps(tile + 72, c41);
    _mm256_storeu_ps(tile + 80, c50); _mm256_storeu_ps(tile + 88, c51);
    for (i = 0; i < mr; i++)
        for (j = 0; j < nr; j++) c[(size_t)i * ldc + j] = tile[i * SUPERMAT__NR + j];
}
/* widens kc rows of a 16-column f16 / bf16 / int8 panel slice to f32 (int8: times the column scales) */
SUPERMAT__AVX2 static void supermat__widen_avx2(const void *src, int fmt, const float *scale, int kc, float *dst) {
    int k;
    if (fmt == 1) {
        const __m128i *p = (const __m128i *)src;
        for (k = 0; k < kc; k++) { _mm256_storeu_ps(dst + 16 * k, _mm256_cvtph_ps(_mm_loadu_si128(p + 2 * k))); _mm256_storeu_ps(dst + 16 * k + 8, _mm256_cvtph_ps(_mm_loadu_si128(p + 2 * k + 1))); }
    } else if (fmt == 2) {
        const __m128i *p = (const __m128i *)src;
        for (k = 0; k < kc; k++) {
            _mm256_storeu_ps(dst + 16 * k, _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_cvtepu16_epi32(_mm_loadu_si128(p + 2 * k)), 16)));
            _mm256_storeu_ps(dst + 16 * k + 8, _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_cvtepu16_epi32(_mm_loadu_si128(p + 2 * k + 1)), 16)));
        }
    } else {
        __m256 s0 = _mm256_loadu_ps(scale), s1 = _mm256_loadu_ps(scale + 8);
        for (k = 0; k < kc; k++) {
            __m128i q = _mm_loadu_si128((const __m128i *)((const signed char *)src + 16 * (size_t)k));
            _mm256_storeu_ps(dst + 16 * k, _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(q)), s0));
            _mm256_storeu_ps(dst + 16 * k + 8, _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(_mm_srli_si128(q, 8))), s1));
        }
    }
}
#endif

#if SUPERMAT__HAS_AVX512
/* 12 x 16: one ZMM accumulator per row (12 of the 32 registers), the B row loaded once per k and each A
   element broadcast from memory into its FMA. Per output element the same fma chain as the other kernels. */
#define SUPERMAT__MR512 12
/* the accumulators of the 512-bit kernels: C (accumulate) or bias + R on the first K block; rows past mr
   are never stored, so they start at 0 */
SUPERMAT__AVX512 static SUPERMAT__FORCEINLINE void supermat__acc512_init(__m512 *acc, int mr, __mmask16 mask, const float *c, size_t ldc,
                                                                                       const float *bias, const float *r, size_t ldr, int accumulate) {
    int i;
    for (i = 0; i < SUPERMAT__MR512; i++) {
        __m512 v = _mm512_setzero_ps();
        if (i < mr) {
            if (accumulate) v = _mm512_maskz_loadu_ps(mask, c + (size_t)i * ldc);
            else {
                if (bias) v = _mm512_loadu_ps(bias); /* bias is padded to 16 */
                if (r) v = _mm512_add_ps(v, _mm512_maskz_loadu_ps(mask, r + (size_t)i * ldr));
            }
        }
        acc[i] = v;
    }
}
SUPERMAT__AVX512 static void supermat__ukr_avx512(int kc, const float *const *a, const float *b, float *c, size_t ldc, int mr,
                                                  int nr, const float *bias, const float *r, size_t ldr, int accumulate) {
    __m512 acc[SUPERMAT__MR512];
    const float *ap[SUPERMAT__MR512];
    __mmask16 mask = (__mmask16)(nr >= 16 ? 0xFFFF : (1u << nr) - 1u);
    int i, k;
    for (i = 0; i < SUPERMAT__MR512; i++) ap[i] = a[i];
    supermat__acc512_init(acc, mr, mask, c, ldc, bias, r, ldr, accumulate);
    for (k = 0; k < kc; k++) {
        __m512 bv = _mm512_loadu_ps(b + (size_t)k * SUPERMAT__NR);
        acc[0] = _mm512_fmadd_ps(_mm512_set1_ps(ap[0][k]), bv, acc[0]);
        acc[1] = _mm512_fmadd_ps(_mm512_set1_ps(ap[1][k]), bv, acc[1]);
        acc[2] = _mm512_fmadd_ps(_mm512_set1_ps(ap[2][k]), bv, acc[2]);
        acc[3] = _mm512_fmadd_ps(_mm512_set1_ps(ap[3][k]), bv, acc[3]);
        acc[4] = _mm512_fmadd_ps(_mm512_set1_ps(ap[4][k]), bv, acc[4]);
        acc[5] = _mm512_fmadd_ps(_mm512_set1_ps(ap[5][k]), bv, acc[5]);
        acc[6] = _mm512_fmadd_ps(_mm512_set1_ps(ap[6][k]), bv, acc[6]);
        acc[7] = _mm512_fmadd_ps(_mm512_set1_ps(ap[7][k]), bv, acc[7]);
        acc[8] = _mm512_fmadd_ps(_mm512_set1_ps(ap[8][k]), bv, acc[8]);
        acc[9] = _mm512_fmadd_ps(_mm512_set1_ps(ap[9][k]), bv, acc[9]);
        acc[10] = _mm512_fmadd_ps(_mm512_set1_ps(ap[10][k]), bv, acc[10]);
        acc[11] = _mm512_fmadd_ps(_mm512_set1_ps(ap[11][k]), bv, acc[11]);
    }
    for (i = 0; i < mr; i++) _mm512_mask_storeu_ps(c + (size_t)i * ldc, mask, acc[i]);
}

/* 12 x 32: two neighbouring panels at once, two ZMM accumulators per row (24 of the 32 registers). Each
   broadcast A element feeds two FMAs: a k step is 12 broadcasts + 2 B loads for 24 FMAs, where the 12 x 16
   kernel's 12 + 1 loads for 12 FMAs keep the load ports, not the FMA units, busy. nr: columns of the
   pair (17..32; the first panel is whole). Per output element the same fma chain as every other kernel. */
#define SUPERMAT__UKR2_ROW(i)                                          \
    do {                                                               \
        __m512 a_ = _mm512_set1_ps(ap[i][k]);                          \
        acc0[i] = _mm512_fmadd_ps(a_, bv0, acc0[i]);                   \
        acc1[i] = _mm512_fmadd_ps(a_, bv1, acc1[i]);                   \
    } while (0)
#define SUPERMAT__UKR2_STEP                                                                                                    \
    do {                                                                                                                       \
        __m512 bv0 = _mm512_loadu_ps(b0 + (size_t)k * SUPERMAT__NR), bv1 = _mm512_loadu_ps(b1 + (size_t)k * SUPERMAT__NR);       \
        SUPERMAT__UKR2_ROW(0); SUPERMAT__UKR2_ROW(1); SUPERMAT__UKR2_ROW(2); SUPERMAT__UKR2_ROW(3);                            \
        SUPERMAT__UKR2_ROW(4); SUPERMAT__UKR2_ROW(5); SUPERMAT__UKR2_ROW(6); SUPERMAT__UKR2_ROW(7);                            \
        SUPERMAT__UKR2_ROW(8); SUPERMAT__UKR2_ROW(9); SUPERMAT__UKR2_ROW(10); SUPERMAT__UKR2_ROW(11);                           \
    } while (0)
/* pf (or NULL): kc / 4 cache lines from there are prefetched into L2, one every 4 k steps (the callers point
   it at a share of the next panel pair, which would otherwise come from L3 or memory on first use) */
SUPERMAT__AVX512 static void supermat__ukr2_avx512(int kc, const float *const *a, const float *b0, const float *b1, float *c, size_t ldc,
                                                   int mr, int nr, const float *bias, const float *r, size_t ldr, int accumulate,
                                                   const char *pf) {
    __m512 acc0[SUPERMAT__MR512], acc1[SUPERMAT__MR512];
    const float *ap[SUPERMAT__MR512];
    __mmask16 mask1 = (__mmask16)(nr >= 32 ? 0xFFFF : (1u << (nr - 16)) - 1u);
    int i, k = 0;
    for (i = 0; i < SUPERMAT__MR512; i++) ap[i] = a[i];
    supermat__acc512_init(acc0, mr, (__mmask16)0xFFFF, c, ldc, bias, r, ldr, accumulate);
    supermat__acc512_init(acc1, mr, mask1, c + 16, ldc, bias ? bias + 16 : NULL, r ? r + 16 : NULL, ldr, accumulate);
    if (pf)
        for (; k + 4 <= kc; pf += 64) {
            _mm_prefetch(pf, _MM_HINT_T1);
            SUPERMAT__UKR2_STEP; k++; SUPERMAT__UKR2_STEP; k++; SUPERMAT__UKR2_STEP; k++; SUPERMAT__UKR2_STEP; k++;
        }
    for (; k < kc; k++) SUPERMAT__UKR2_STEP;
    for (i = 0; i < mr; i++) {
        _mm512_storeu_ps(c + (size_t)i * ldc, acc0[i]);
        _mm512_mask_storeu_ps(c + (size_t)i * ldc + 16, mask1, acc1[i]);
    }
}
#undef SUPERMAT__UKR2_STEP
#undef SUPERMAT__UKR2_ROW

/* bf16 compute: B panels as bf16 pairs [K/2][16][2] (one ZMM per pair of rows), A rows as bf16 pairs
   (uint32); acc += a[2j] b[2j] + a[2j+1] b[2j+1] per lane with vdpbf16ps */
SUPERMAT__AVX512BF16 static void supermat__ukr_bf16(int kc2, const uint32_t *const *a, const uint16_t *b, float *c, size_t ldc, int mr,
                                                    int nr, const float *bias, const float *r, size_t ldr, int accumulate) {
    __m512 acc[SUPERMAT__MR512];
    const uint32_t *ap[SUPERMAT__MR512];
    __mmask16 mask = (__mmask16)(nr >= 16 ? 0xFFFF : (1u << nr) - 1u);
    int i, k;
    for (i = 0; i < SUPERMAT__MR512; i++) ap[i] = a[i];
    supermat__acc512_init(acc, mr, mask, c, ldc, bias, r, ldr, accumulate);
    for (k = 0; k < kc2; k++) {
        __m512bh bv = SUPERMAT__BH512(_mm512_loadu_si512((const void *)(b + (size_t)k * 32)));
        for (i = 0; i < SUPERMAT__MR512; i++) acc[i] = _mm512_dpbf16_ps(acc[i], SUPERMAT__BH512(_mm512_set1_epi32((int)ap[i][k])), bv);
    }
    for (i = 0; i < mr; i++) _mm512_mask_storeu_ps(c + (size_t)i * ldc, mask, acc[i]);
}
/* 12 x 32 with bf16 pairs: panels p and p + 1 at once, as supermat__ukr2_avx512 does for f32 (each broadcast
   pair of A feeds two vdpbf16ps: 12 broadcasts + 2 B loads for 24 products, where the 12 x 16 kernel's 12 + 1
   loads for 12 kept Zen 5's load ports, not its dot units, busy). nr: columns of the pair (17..32; the first
   panel is whole). Per output element the same vdpbf16ps chain as supermat__ukr_bf16: the same bits. */
#define SUPERMAT__UKR2BF_ROW(i)                                                      \
    do {                                                                             \
        __m512bh a_ = SUPERMAT__BH512(_mm512_set1_epi32((int)ap[i][k]));                    \
        acc0[i] = _mm512_dpbf16_ps(acc0[i], a_, bv0);                                \
        acc1[i] = _mm512_dpbf16_ps(acc1[i], a_, bv1);                                \
    } while (0)
SUPERMAT__AVX512BF16 static void supermat__ukr2_bf16(int kc2, const uint32_t *const *a, const uint16_t *b0, const uint16_t *b1, float *c,
                                                     size_t ldc, int mr, int nr, const float *bias, const float *r, size_t ldr, int accumulate) {
    __m512 acc0[SUPERMAT__MR512], acc1[SUPERMAT__MR512];
    const uint32_t *ap[SUPERMAT__MR512];
    __mmask16 mask1 = (__mmask16)(nr >= 32 ? 0xFFFF : (1u << (nr - 16)) - 1u);
    int i, k;
    for (i = 0; i < SUPERMAT__MR512; i++) ap[i] = a[i];
    supermat__acc512_init(acc0, mr, (__mmask16)0xFFFF, c, ldc, bias, r, ldr, accumulate);
    supermat__acc512_init(acc1, mr, mask1, c + 16, ldc, bias ? bias + 16 : NULL, r ? r + 16 : NULL, ldr, accumulate);
    for (k = 0; k < kc2; k++) {
        __m512bh bv0 = SUPERMAT__BH512(_mm512_loadu_si512((const void *)(b0 + (size_t)k * 32)));
        __m512bh bv1 = SUPERMAT__BH512(_mm512_loadu_si512((const void *)(b1 + (size_t)k * 32)));
        SUPERMAT__UKR2BF_ROW(0); SUPERMAT__UKR2BF_ROW(1); SUPERMAT__UKR2BF_ROW(2); SUPERMAT__UKR2BF_ROW(3);
        SUPERMAT__UKR2BF_ROW(4); SUPERMAT__UKR2BF_ROW(5); SUPERMAT__UKR2BF_ROW(6); SUPERMAT__UKR2BF_ROW(7);
        SUPERMAT__UKR2BF_ROW(8); SUPERMAT__UKR2BF_ROW(9); SUPERMAT__UKR2BF_ROW(10); SUPERMAT__UKR2BF_ROW(11);
    }
    for (i = 0; i < mr; i++) {
        _mm512_storeu_ps(c + (size_t)i * ldc, acc0[i]);
        _mm512_mask_storeu_ps(c + (size_t)i * ldc + 16, mask1, acc1[i]);
    }
}
#undef SUPERMAT__UKR2BF_ROW
/* n floats -> n/2 bf16 pairs (round to nearest even; an odd tail pairs with 0) */
SUPERMAT__AVX512BF16 static void supermat__to_bf16_pairs(const float *x, int n, uint32_t *out) {
    int i = 0;
    for (; i + 32 <= n; i += 32)
        _mm512_storeu_si512((void *)(out + i / 2), SUPERMAT__BH512_BITS(_mm512_cvtne2ps_pbh(_mm512_loadu_ps(x + i + 16), _mm512_loadu_ps(x + i))));
    for (; i < n; i += 2) {
        uint32_t lo = supermat__f32_to_bf16(x[i]), hi = i + 1 < n ? supermat__f32_to_bf16(x[i + 1]) : 0;
        out[i / 2] = lo | hi << 16;
    }
}

/* int8 compute: a row of kc activations -> u8 q + 128, q = rint(a / s), s = max |a| / 127 per 64 of K
   (the scales in s[ceil(kc / 64)]), padded with 128 (a zero) to a multiple of 4 bytes */
SUPERMAT__AVX512VNNI static void supermat__quant_row_u8(const float *x, int kc, unsigned char *out, float *s) {
    int j, i, nch = (kc + 63) / 64;
    for (j = 0; j < nch; j++) {
        int k0 = j * 64, n = SUPERMAT__MIN(64, kc - k0);
        __m512 mx = _mm512_setzero_ps(), inv;
        float m;
        for (i = 0; i < n; i += 16) {
            __mmask16 mk = (__mmask16)(n - i >= 16 ? 0xFFFF : (1u << (n - i)) - 1u);
            __m512 v = _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(_mm512_maskz_loadu_ps(mk, x + k0 + i)), _mm512_set1_epi32(0x7fffffff)));
            mx = _mm512_maskz_max_ps(0xFFFF, mx, v); /* (g++ warns of _mm512_max_ps's undefined pass-through) */
        }
        {   /* the largest lane (_mm512_reduce_max_ps trips g++'s uninitialized warning) */
            float l[16];
            _mm512_storeu_ps(l, mx);
            m = l[0];
            for (i = 1; i < 16; i++) m = l[i] > m ? l[i] : m;
        }
        s[j] = m / 127.0f;
        inv = _mm512_set1_ps(m > 0.0f ? 127.0f / m : 0.0f);
        for (i = 0; i < n; i += 16) {
            __mmask16 mk = (__mmask16)(n - i >= 16 ? 0xFFFF : (1u << (n - i)) - 1u);
            __m512i q = _mm512_maskz_cvtps_epi32(mk, _mm512_mul_ps(_mm512_maskz_loadu_ps(mk, x + k0 + i), inv)); /* nearest even */
            _mm512_mask_cvtusepi32_storeu_epi8(out + k0 + i, mk, _mm512_add_epi32(q, _mm512_set1_epi32(128)));
        }
    }
    for (i = kc; i % 4; i++) out[i] = 128;
}
static uint32_t supermat__ld32(const unsigned char *p) { uint32_t v; memcpy(&v, p, 4); return v; }
/* the int32 sums of one 64-row chunk, a function of their own: inlined beside the 12 float32 accumulators,
   gcc 12 copied every sum to another register on every step */
SUPERMAT__AVX512VNNI static SUPERMAT__NOINLINE void supermat__i8_chunk(int q0, int q1, const unsigned char *const *a, const signed char *b,
                                                                              __m512i *out) {
    __m512i s0 = _mm512_setzero_si512(), s1 = s0, s2 = s0, s3 = s0, s4 = s0, s5 = s0, s6 = s0, s7 = s0, s8 = s0, s9 = s0, s10 = s0, s11 = s0;
    int q;
    for (q = q0; q < q1; q++) {
        __m512i bv = _mm512_loadu_si512((const void *)(b + (size_t)q * 64));
#define SUPERMAT__I8_ROW(i, s) s = _mm512_dpbusd_epi32(s, _mm512_set1_epi32((int)supermat__ld32(a[i] + 4 * (size_t)q)), bv)
        SUPERMAT__I8_ROW(0, s0); SUPERMAT__I8_ROW(1, s1); SUPERMAT__I8_ROW(2, s2); SUPERMAT__I8_ROW(3, s3);
        SUPERMAT__I8_ROW(4, s4); SUPERMAT__I8_ROW(5, s5); SUPERMAT__I8_ROW(6, s6); SUPERMAT__I8_ROW(7, s7);
        SUPERMAT__I8_ROW(8, s8); SUPERMAT__I8_ROW(9, s9); SUPERMAT__I8_ROW(10, s10); SUPERMAT__I8_ROW(11, s11);
#undef SUPERMAT__I8_ROW
    }
    out[0] = s0; out[1] = s1; out[2] = s2; out[3] = s3; out[4] = s4; out[5] = s5;
    out[6] = s6; out[7] = s7; out[8] = s8; out[9] = s9; out[10] = s10; out[11] = s11;
}
/* int8 compute: B panels as s8 quads [K/4][16][4] (one ZMM per 4 rows of K), A rows as u8 quads; per
   64-row chunk j of the block: int32 sums by vpdpbusd (exact: at most 64 x 255 x 127), minus the u8
   offset (128 x the chunk's column sums, cor), converted to float32 (exact below 2^24) and added times
   the row's scale x the column's */
SUPERMAT__AVX512VNNI static void supermat__ukr_i8(int kc4, const unsigned char *const *a, const float *const *as, const signed char *b,
                                                  const float *ws, const int32_t *cor, size_t cst, float *c, size_t ldc, int mr, int nr,
                                                  const float *bias, const float *r, size_t ldr, int accumulate) {
    __m512 acc[SUPERMAT__MR512];
    __m512i sum[SUPERMAT__MR512];
    __mmask16 mask = (__mmask16)(nr >= 16 ? 0xFFFF : (1u << nr) - 1u);
    int i, j;
    supermat__acc512_init(acc, mr, mask, c, ldc, bias, r, ldr, accumulate);
    for (j = 0; 16 * j < kc4; j++) {
        int q1 = SUPERMAT__MIN(kc4, 16 * j + 16);
        __m512 wv = _mm512_loadu_ps(ws + (size_t)j * cst);
        __m512i cv = _mm512_loadu_si512((const void *)(cor + (size_t)j * cst));
        supermat__i8_chunk(16 * j, q1, a, b, sum);
        for (i = 0; i < SUPERMAT__MR512; i++)
            acc[i] = _mm512_fmadd_ps(_mm512_maskz_cvtepi32_ps(0xFFFF, _mm512_sub_epi32(sum[i], cv)), _mm512_mul_ps(wv, _mm512_set1_ps(as[i][j])), acc[i]);
    }
    for (i = 0; i < mr; i++) _mm512_mask_storeu_ps(c + (size_t)i * ldc, mask, acc[i]);
}
/* 12 x 32 int8: panels p and p + 1 at once, as supermat__ukr2_avx512 / supermat__ukr2_bf16 do (12 broadcasts
   + 2 B loads for 24 vpdpbusd, where the 12 x 16 kernel's 12 + 1 loads for 12 keep the load ports, not the dot
   units, busy). The chunk's 24 int32 sums in a function of their own (see supermat__i8_chunk), then per output
   element the same operations in the same order as supermat__ukr_i8: the same bits. nr: columns of the pair
   (17..32; the first panel is whole). */
#define SUPERMAT__I8_2ROW(i, s, t)                                                       \
    do {                                                                                 \
        __m512i a_ = _mm512_set1_epi32((int)supermat__ld32(a[i] + 4 * (size_t)q));       \
        s = _mm512_dpbusd_epi32(s, a_, bv0);                                             \
        t = _mm512_dpbusd_epi32(t, a_, bv1);                                             \
    } while (0)
SUPERMAT__AVX512VNNI static SUPERMAT__NOINLINE void supermat__i8_chunk2(int q0, int q1, const unsigned char *const *a, const signed char *b0,
                                                                               const signed char *b1, __m512i *out) {
    __m512i s0 = _mm512_setzero_si512(), s1 = s0, s2 = s0, s3 = s0, s4 = s0, s5 = s0, s6 = s0, s7 = s0, s8 = s0, s9 = s0, s10 = s0, s11 = s0;
    __m512i t0 = s0, t1 = s0, t2 = s0, t3 = s0, t4 = s0, t5 = s0, t6 = s0, t7 = s0, t8 = s0, t9 = s0, t10 = s0, t11 = s0;
    int q;
    for (q = q0; q < q1; q++) {
        __m512i bv0 = _mm512_loadu_si512((const void *)(b0 + (size_t)q * 64)), bv1 = _mm512_loadu_si512((const void *)(b1 + (size_t)q * 64));
        SUPERMAT__I8_2ROW(0, s0, t0); SUPERMAT__I8_2ROW(1, s1, t1); SUPERMAT__I8_2ROW(2, s2, t2); SUPERMAT__I8_2ROW(3, s3, t3);
        SUPERMAT__I8_2ROW(4, s4, t4); SUPERMAT__I8_2ROW(5, s5, t5); SUPERMAT__I8_2ROW(6, s6, t6); SUPERMAT__I8_2ROW(7, s7, t7);
        SUPERMAT__I8_2ROW(8, s8, t8); SUPERMAT__I8_2ROW(9, s9, t9); SUPERMAT__I8_2ROW(10, s10, t10); SUPERMAT__I8_2ROW(11, s11, t11);
    }
    out[0] = s0; out[1] = s1; out[2] = s2; out[3] = s3; out[4] = s4; out[5] = s5;
    out[6] = s6; out[7] = s7; out[8] = s8; out[9] = s9; out[10] = s10; out[11] = s11;
    out[12] = t0; out[13] = t1; out[14] = t2; out[15] = t3; out[16] = t4; out[17] = t5;
    out[18] = t6; out[19] = t7; out[20] = t8; out[21] = t9; out[22] = t10; out[23] = t11;
}
#undef SUPERMAT__I8_2ROW
SUPERMAT__AVX512VNNI static void supermat__ukr2_i8(int kc4, const unsigned char *const *a, const float *const *as, const signed char *b0,
                                                   const signed char *b1, const float *ws, const int32_t *cor, size_t cst, float *c, size_t ldc,
                                                   int mr, int nr, const float *bias, const float *r, size_t ldr, int accumulate) {
    __m512 acc0[SUPERMAT__MR512], acc1[SUPERMAT__MR512];
    __m512i sum[2 * SUPERMAT__MR512];
    __mmask16 mask1 = (__mmask16)(nr >= 32 ? 0xFFFF : (1u << (nr - 16)) - 1u);
    int i, j;
    supermat__acc512_init(acc0, mr, (__mmask16)0xFFFF, c, ldc, bias, r, ldr, accumulate);
    supermat__acc512_init(acc1, mr, mask1, c + 16, ldc, bias ? bias + 16 : NULL, r ? r + 16 : NULL, ldr, accumulate);
    for (j = 0; 16 * j < kc4; j++) {
        int q1 = SUPERMAT__MIN(kc4, 16 * j + 16);
        __m512 wv0 = _mm512_loadu_ps(ws + (size_t)j * cst), wv1 = _mm512_loadu_ps(ws + (size_t)j * cst + 16);
        __m512i cv0 = _mm512_loadu_si512((const void *)(cor + (size_t)j * cst)), cv1 = _mm512_loadu_si512((const void *)(cor + (size_t)j * cst + 16));
        supermat__i8_chunk2(16 * j, q1, a, b0, b1, sum);
        for (i = 0; i < SUPERMAT__MR512; i++) {
            __m512 s_ = _mm512_set1_ps(as[i][j]);
            acc0[i] = _mm512_fmadd_ps(_mm512_maskz_cvtepi32_ps(0xFFFF, _mm512_sub_epi32(sum[i], cv0)), _mm512_mul_ps(wv0, s_), acc0[i]);
            acc1[i] = _mm512_fmadd_ps(_mm512_maskz_cvtepi32_ps(0xFFFF, _mm512_sub_epi32(sum[SUPERMAT__MR512 + i], cv1)), _mm512_mul_ps(wv1, s_), acc1[i]);
        }
    }
    for (i = 0; i < mr; i++) {
        _mm512_storeu_ps(c + (size_t)i * ldc, acc0[i]);
        _mm512_mask_storeu_ps(c + (size_t)i * ldc + 16, mask1, acc1[i]);
    }
}
#if SUPERMAT__HAS_AVXVNNI
/* int8 compute on AVX-VNNI (the 256-bit vpdpbusd of CPUs without AVX-512: Alder Lake and later clients).
   supermat__quant_row_u8 in 256-bit vectors: the same bytes and scales (a chunk's tail is read from a
   zero-padded copy, its bytes stored as far as the chunk goes) */
SUPERMAT__AVXVNNI static void supermat__quant_row_u8_avx2(const float *x, int kc, unsigned char *out, float *s) {
    const __m256 absm = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256i perm = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7), off = _mm256_set1_epi32(128);
    int j, i, h, nch = (kc + 63) / 64;
    for (j = 0; j < nch; j++) {
        int k0 = j * 64, n = SUPERMAT__MIN(64, kc - k0);
        float t[64], l[8], m;
        const float *src = x + k0;
        __m256 mx = _mm256_setzero_ps(), inv;
        if (n < 64) {
            memcpy(t, src, sizeof(float) * (size_t)n);
            memset(t + n, 0, sizeof(float) * (size_t)(64 - n));
            src = t;
        }
        for (i = 0; i < 64; i += 8) mx = _mm256_max_ps(mx, _mm256_and_ps(_mm256_loadu_ps(src + i), absm));
        _mm256_storeu_ps(l, mx);
        m = l[0];
        for (i = 1; i < 8; i++) m = l[i] > m ? l[i] : m;
        s[j] = m / 127.0f;
        inv = _mm256_set1_ps(m > 0.0f ? 127.0f / m : 0.0f);
        for (i = 0; i < n; i += 32) {
            __m256i q[4], p;
            for (h = 0; h < 4; h++) /* nearest even, + 128: 1..255 */
                q[h] = _mm256_add_epi32(_mm256_cvtps_epi32(_mm256_mul_ps(_mm256_loadu_ps(src + i + 8 * h), inv)), off);
            /* 32 int32 -> 32 bytes: the packs interleave 128-bit lanes, the permutation puts them back in order */
            p = _mm256_permutevar8x32_epi32(_mm256_packus_epi16(_mm256_packus_epi32(q[0], q[1]), _mm256_packus_epi32(q[2], q[3])), perm);
            if (n - i >= 32) _mm256_storeu_si256((__m256i *)(void *)(out + k0 + i), p);
            else {
                unsigned char b[32];
                _mm256_storeu_si256((__m256i *)(void *)b, p);
                memcpy(out + k0 + i, b, (size_t)(n - i));
            }
        }
    }
    for (i = kc; i % 4; i++) out[i] = 128;
}
/* the AVX-VNNI micro-kernel: SUPERMAT__MRVNNI rows x 16 columns (two YMM halves of each 64-byte quad row
   of the panel); per output element the same operations in the same order as supermat__ukr_i8 (the same
   bits). The int32 sums of one 64-row chunk are a function of their own: inlined beside the 12 float32
   accumulators, gcc 12 moved every sum through memory on every step (the AVX-VNNI path ran 0.68x as fast) */
#define SUPERMAT__MRVNNI 6
SUPERMAT__AVXVNNI static SUPERMAT__NOINLINE void supermat__i8avx_chunk(int q0, int q1, const unsigned char *const *a, const signed char *b,
                                                                           __m256i *out) {
    __m256i s00 = _mm256_setzero_si256(), s01 = s00, s10 = s00, s11 = s00, s20 = s00, s21 = s00;
    __m256i s30 = s00, s31 = s00, s40 = s00, s41 = s00, s50 = s00, s51 = s00;
    int q;
    for (q = q0; q < q1; q++) {
        const signed char *bq = b + (size_t)q * 64;
        __m256i b0 = _mm256_loadu_si256((const __m256i *)(const void *)bq), b1 = _mm256_loadu_si256((const __m256i *)(const void *)(bq + 32)), av;
#define SUPERMAT__I8AVX_ROW(i, lo, hi)                                     \
    av = _mm256_set1_epi32((int)supermat__ld32(a[i] + 4 * (size_t)q)); \
    lo = _mm256_dpbusd_avx_epi32(lo, av, b0);                          \
    hi = _mm256_dpbusd_avx_epi32(hi, av, b1)
        SUPERMAT__I8AVX_ROW(0, s00, s01); SUPERMAT__I8AVX_ROW(1, s10, s11); SUPERMAT__I8AVX_ROW(2, s20, s21);
        SUPERMAT__I8AVX_ROW(3, s30, s31); SUPERMAT__I8AVX_ROW(4, s40, s41); SUPERMAT__I8AVX_ROW(5, s50, s51);
#undef SUPERMAT__I8AVX_ROW
    }
    _mm256_storeu_si256(out + 0, s00); _mm256_storeu_si256(out + 1, s01); _mm256_storeu_si256(out + 2, s10); _mm256_storeu_si256(out + 3, s11);
    _mm256_storeu_si256(out + 4, s20); _mm256_storeu_si256(out + 5, s21); _mm256_storeu_si256(out + 6, s30); _mm256_storeu_si256(out + 7, s31);
    _mm256_storeu_si256(out + 8, s40); _mm256_storeu_si256(out + 9, s41); _mm256_storeu_si256(out + 10, s50); _mm256_storeu_si256(out + 11, s51);
}
SUPERMAT__AVXVNNI static void supermat__ukr_i8_avx(int kc4, const unsigned char *const *a, const float *const *as, const signed char *b,
                                                  const float *ws, const int32_t *cor, size_t cst, float *c, size_t ldc, int mr, int nr,
                                                  const float *bias, const float *r, size_t ldr, int accumulate) {
    __m256 acc[SUPERMAT__MRVNNI][2];
    __m256i sum[SUPERMAT__MRVNNI * 2], mk[2];
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    int i, j, h;
    for (h = 0; h < 2; h++) mk[h] = _mm256_cmpgt_epi32(_mm256_set1_epi32(nr - 8 * h), lane);
    for (i = 0; i < SUPERMAT__MRVNNI; i++)
        for (h = 0; h < 2; h++) {
            __m256 v = _mm256_setzero_ps();
            if (i < mr) {
                if (accumulate) v = _mm256_maskload_ps(c + (size_t)i * ldc + 8 * h, mk[h]);
                else {
                    if (bias) v = _mm256_loadu_ps(bias + 8 * h); /* bias is padded to 16 */
                    if (r) v = _mm256_add_ps(v, _mm256_maskload_ps(r + (size_t)i * ldr + 8 * h, mk[h]));
                }
            }
            acc[i][h] = v;
        }
    for (j = 0; 16 * j < kc4; j++) {
        supermat__i8avx_chunk(16 * j, SUPERMAT__MIN(kc4, 16 * j + 16), a, b, sum);
        for (h = 0; h < 2; h++) {
            __m256 wv = _mm256_loadu_ps(ws + (size_t)j * cst + 8 * h);
            __m256i cv = _mm256_loadu_si256((const __m256i *)(const void *)(cor + (size_t)j * cst + 8 * h));
            for (i = 0; i < SUPERMAT__MRVNNI; i++)
                acc[i][h] = _mm256_fmadd_ps(_mm256_cvtepi32_ps(_mm256_sub_epi32(sum[2 * i + h], cv)), _mm256_mul_ps(wv, _mm256_set1_ps(as[i][j])), acc[i][h]);
        }
    }
    for (i = 0; i < mr; i++)
        for (h = 0; h < 2; h++) _mm256_maskstore_ps(c + (size_t)i * ldc + 8 * h, mk[h], acc[i][h]);
}
#endif
#endif

/* A operand of a GEMM */
typedef struct supermat__asrc {
    const float *a; size_t lda;           /* dense rows (conv == 0) */
    int conv;                             /* gather from an NHWC image */
    const float *x; int n, h, w, c;       /* the image: n x h x w x c */
    int uh, uw;                           /* virtual nearest-resized size the conv reads (== h, w if none) */
    int kh, kw, stride, pad_t, pad_l;
    int oh, ow;                           /* output size */
} supermat__asrc;

/* PyTorch's nearest index (upsample_nearest2d, no scale given) */
static int supermat__nearest(int dst, int in, int out) {
    float scale;
    int s;
    if (in == out) return dst;
    if (out == 2 * in) return dst >> 1;
    scale = (float)in / (float)out;
    s = (int)floorf((float)dst * scale);
    return s < in - 1 ? s : in - 1;
}

/* what a direct convolution reads in the padding */
static const float supermat__zero_row[SUPERMAT__KC] = {0.0f};

/* gather rows [m0, m0+mr) x K range [k0, k0+kc) of the implicit im2col matrix into buf (row stride kc) */
static void supermat__gather(const supermat__asrc *s, int m0, int mr, int k0, int kc, float *buf) {
    int i;
    for (i = 0; i < mr; i++) {
        int m = m0 + i, ox = m % s->ow, oy = (m / s->ow) % s->oh, img = m / (s->ow * s->oh);
        float *dst = buf + (size_t)i * kc;
        int k = k0, kend = k0 + kc;
        while (k < kend) {
            int tap = k / s->c, ci = k - tap * s->c, ky = tap / s->kw, kx = tap - ky * s->kw;
            int run = SUPERMAT__MIN(s->c - ci, kend - k);
            int vy = oy * s->stride - s->pad_t + ky, vx = ox * s->stride - s->pad_l + kx;
            if (vy < 0 || vy >= s->uh || vx < 0 || vx >= s->uw) {
                memset(dst, 0, sizeof(float) * (size_t)run);
            } else {
                int sy = supermat__nearest(vy, s->h, s->uh), sx = supermat__nearest(vx, s->w, s->uw);
                memcpy(dst, s->x + (((size_t)img * s->h + sy) * s->w + sx) * s->c + ci, sizeof(float) * (size_t)run);
            }
            dst += run;
            k += run;
        }
    }
}

typedef struct supermat__gemm_args {
    supermat__ukr_fn ukr;
    int mr;                     /* the micro-kernel's rows */
    supermat__widen_fn widen;   /* for fmt != 0 */
    const void *Bq;            /* f16 / bf16 / int8 panels */
    const float *qs;           /* int8 scales [groups][np * 16] */
    int fmt, np, qcin;
    int M, N, K;
    const supermat__asrc *A;
    const float *B;        /* packed panels (K x 16 each) */
    const float *bias;     /* padded, or NULL */
    float *C; size_t ldc;
    const float *R; size_t ldr;
    int mblocks, nchunks, panels_per_chunk;
    float **scratch;       /* per thread: MC x KC floats */
    int amx;               /* bf16 compute on AMX tiles */
    int vnni256;           /* int8 compute on AVX-VNNI (the AVX2 kernel) */
    int wide;              /* f32 panels two at a time (the AVX-512 12 x 32 kernel) */
} supermat__gemm_args;

#if SUPERMAT__HAS_AMX
/* bf16 compute on AMX: one K block (kc2 pairs) of rows [m0, m0 + rows_n) of A, already bf16 pairs in ab
   (row stride kc2), times panels [p0, p1) (bf16 pairs [K/2][16][2]: a 64-byte tile row per pair of K).
   Tiles: 0-3 C (16 x 16 f32: 2 row blocks x 2 panels), 4-5 A (16 rows x 16 pairs), 6-7 B (16 pairs x 16
   columns): 4 tile loads per 4 tdpbf16ps. Rows past rows_n read stale scratch (within its MC rows) into C
   rows that are never stored; a K tail short of 16 pairs goes through zero-padded copies. */
typedef struct supermat__tilecfg { unsigned char palette, start_row, reserved[14]; unsigned short colsb[16]; unsigned char rows[16]; } supermat__tilecfg;
/* the start of C tile T (row block RB, panel PB of the pass): straight from memory where the tile is whole,
   else through ct[T] (bias + R, or the running C, zero past the edges) */
#define SUPERMAT__AMX_CSTART(T, RB, PB)                                                                            \
    do {                                                                                                           \
        int m_ = m0 + mb + 16 * (RB), mr_ = SUPERMAT__MIN(16, m0 + rows_n - m_), n0_ = (p + (PB)) * SUPERMAT__NR;  \
        int nr_ = SUPERMAT__MIN(SUPERMAT__NR, g->N - n0_), i_, j_, whole_ = mr_ == 16 && nr_ == 16;               \
        float *c_ = g->C + (size_t)m_ * g->ldc + n0_;                                                              \
        const float *r_ = (g->R && k0 == 0) ? g->R + (size_t)m_ * g->ldr + n0_ : NULL;                            \
        const float *b_ = g->bias ? g->bias + n0_ : NULL;                                                          \
        if (k0 > 0 && whole_) _tile_loadd(T, c_, (long)(g->ldc * sizeof(float)));                                 \
        else if (k0 == 0 && !r_ && b_) _tile_loadd(T, b_, 0); /* stride 0: the bias in every row */               \
        else if (k0 == 0 && !r_) _tile_zero(T);                                                                    \
        else if (k0 == 0 && !b_ && whole_) _tile_loadd(T, r_, (long)(g->ldr * sizeof(float)));                    \
        else {                                                                                                     \
            for (i_ = 0; i_ < 16; i_++)                                                                            \
                for (j_ = 0; j_ < 16; j_++) {                                                                      \
                    float v_ = 0.0f;                                                                               \
                    if (i_ < mr_ && j_ < nr_) {                                                                    \
                        if (k0 > 0) v_ = c_[(size_t)i_ * g->ldc + j_];                                             \
                        else {                                                                                     \
                            if (b_) v_ = b_[j_];                                                                   \
                            if (r_) v_ += r_[(size_t)i_ * g->ldr + j_];                                            \
                        }                                                                                          \
                    }                                                                                              \
                    ct[T][i_ * 16 + j_] = v_;                                                                      \
                }                                                                                                  \
            _tile_loadd(T, ct[T], 64);                                                                             \
        }                                                                                                          \
    } while (0)
#define SUPERMAT__AMX_CSTORE(T, RB, PB)                                                                            \
    do {                                                                                                           \
        int m_ = m0 + mb + 16 * (RB), mr_ = SUPERMAT__MIN(16, m0 + rows_n - m_), n0_ = (p + (PB)) * SUPERMAT__NR;  \
        int nr_ = SUPERMAT__MIN(SUPERMAT__NR, g->N - n0_), i_;                                                     \
        float *c_ = g->C + (size_t)m_ * g->ldc + n0_;                                                              \
        if (mr_ == 16 && nr_ == 16) _tile_stored(T, c_, (long)(g->ldc * sizeof(float)));                          \
        else {                                                                                                     \
            _tile_stored(T, ct[T], 64);                                                                            \
            for (i_ = 0; i_ < mr_; i_++) memcpy(c_ + (size_t)i_ * g->ldc, ct[T] + i_ * 16, sizeof(float) * (size_t)nr_); \
        }                                                                                                          \
    } while (0)
SUPERMAT__AMX static void supermat__amx_block(const supermat__gemm_args *g, const uint32_t *ab, int kc2, int rows_n, int k0, int p0, int p1, int m0) {
    supermat__tilecfg cfg;
    float ct[4][16 * 16];
    uint32_t at[2][16 * 16], bt[2][16 * 16];
    int K2 = (g->K + 1) / 2, p, mb, t, i, kk;
    memset(&cfg, 0, sizeof cfg);
    cfg.palette = 1;
    for (t = 0; t < 8; t++) { cfg.rows[t] = 16; cfg.colsb[t] = 64; }
    _tile_loadconfig(&cfg);
    for (p = p0; p < p1; p += 2) {
        int two = p + 1 < p1; /* panels in this pass */
        const uint16_t *bq0 = (const uint16_t *)g->Bq + ((size_t)p * K2 + (size_t)k0 / 2) * 32, *bq1 = bq0 + (size_t)K2 * 32;
        for (mb = 0; mb < rows_n; mb += 32) {
            int nb = rows_n - mb > 16 ? 2 : 1; /* row blocks of 16 in this pass */
            SUPERMAT__AMX_CSTART(0, 0, 0);
            if (two) SUPERMAT__AMX_CSTART(1, 0, 1);
            if (nb > 1) SUPERMAT__AMX_CSTART(2, 1, 0);
            if (nb > 1 && two) SUPERMAT__AMX_CSTART(3, 1, 1);
            for (kk = 0; kk < kc2; kk += 16) {
                int nk = SUPERMAT__MIN(16, kc2 - kk);
                const uint32_t *a0 = ab + (size_t)mb * kc2 + kk;
                if (nk == 16) {
                    _tile_loadd(6, bq0 + (size_t)kk * 32, 64);
                    if (two) _tile_loadd(7, bq1 + (size_t)kk * 32, 64);
                    _tile_loadd(4, a0, (long)kc2 * 4);
                    if (nb > 1) _tile_loadd(5, a0 + (size_t)16 * kc2, (long)kc2 * 4);
                } else { /* the K tail: zero pairs past it in A and B */
                    memset(bt, 0, sizeof bt);
                    memcpy(bt[0], bq0 + (size_t)kk * 32, (size_t)nk * 64);
                    if (two) memcpy(bt[1], bq1 + (size_t)kk * 32, (size_t)nk * 64);
                    for (t = 0; t < nb; t++) {
                        memset(at[t], 0, sizeof at[t]);
                        for (i = 0; i < 16; i++) memcpy(at[t] + i * 16, a0 + (size_t)(16 * t + i) * kc2, (size_t)nk * 4);
                    }
                    _tile_loadd(6, bt[0], 64);
                    if (two) _tile_loadd(7, bt[1], 64);
                    _tile_loadd(4, at[0], 64);
                    if (nb > 1) _tile_loadd(5, at[1], 64);
                }
                _tile_dpbf16ps(0, 4, 6);
                if (two) _tile_dpbf16ps(1, 4, 7);
                if (nb > 1) _tile_dpbf16ps(2, 5, 6);
                if (nb > 1 && two) _tile_dpbf16ps(3, 5, 7);
            }
            SUPERMAT__AMX_CSTORE(0, 0, 0);
            if (two) SUPERMAT__AMX_CSTORE(1, 0, 1);
            if (nb > 1) SUPERMAT__AMX_CSTORE(2, 1, 0);
            if (nb > 1 && two) SUPERMAT__AMX_CSTORE(3, 1, 1);
        }
    }
    _tile_release();
}
#undef SUPERMAT__AMX_CSTART
#undef SUPERMAT__AMX_CSTORE
#endif

static void supermat__gemm_task(void *user, int index, int thread) {
    const supermat__gemm_args *g = (const supermat__gemm_args *)user;
    int mb = index / g->nchunks, nc = index % g->nchunks;
    int m0 = mb * SUPERMAT__MC, m1 = SUPERMAT__MIN(g->M, m0 + SUPERMAT__MC);
    int npanels = (g->N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    int p0 = nc * g->panels_per_chunk, p1 = SUPERMAT__MIN(npanels, p0 + g->panels_per_chunk);
    int k0, p, m, kc;
    const supermat__asrc *A = g->A;
    float *buf = g->scratch[thread];
    /* direct convolution: no gather; each K block within one tap, every row read where it lies in the image
       (rp: its first element; the zero row in the padding). For f32 and the widened weight formats, from 64
       channels up (fewer would make K blocks too short); the K order per output element is unchanged. */
    const float *rp[SUPERMAT__MC];
    const int direct = A->conv && g->fmt < 4 && A->c >= 64;
    for (k0 = 0; k0 < g->K; k0 += kc) {
        const float *abase;
        size_t lda;
        kc = SUPERMAT__MIN(SUPERMAT__KC, g->K - k0);
        if (direct) {
            int tap = k0 / A->c, ci = k0 - tap * A->c, ky = tap / A->kw, kx = tap - ky * A->kw, i;
            kc = SUPERMAT__MIN(kc, A->c - ci);
            for (i = 0; i < m1 - m0; i++) {
                int mm = m0 + i, ox = mm % A->ow, oy = (mm / A->ow) % A->oh, img = mm / (A->ow * A->oh);
                int vy = oy * A->stride - A->pad_t + ky, vx = ox * A->stride - A->pad_l + kx;
                if (vy < 0 || vy >= A->uh || vx < 0 || vx >= A->uw) rp[i] = supermat__zero_row;
                else rp[i] = A->x + (((size_t)img * A->h + supermat__nearest(vy, A->h, A->uh)) * A->w + supermat__nearest(vx, A->w, A->uw)) * A->c + ci;
            }
            abase = NULL; lda = 0;
        } else if (A->conv) {
            supermat__gather(A, m0, m1 - m0, k0, kc, buf);
            abase = buf; lda = (size_t)kc;
        } else {
            abase = A->a + (size_t)m0 * A->lda + k0; lda = A->lda;
        }
#if SUPERMAT__HAS_AVX512
        if (g->fmt == 4) { /* bf16 compute: this block of A as bf16 pairs once, then every panel */
            int kc2 = (kc + 1) / 2, K2 = (g->K + 1) / 2, rows_n = m1 - m0, r;
            uint32_t *ab = (uint32_t *)(buf + (size_t)SUPERMAT__MC * SUPERMAT__KC + (size_t)SUPERMAT__KC * SUPERMAT__NR);
            for (r = 0; r < rows_n; r++) supermat__to_bf16_pairs(abase + (size_t)r * lda, kc, ab + (size_t)r * kc2);
#if SUPERMAT__HAS_AMX
            if (g->amx) { supermat__amx_block(g, ab, kc2, rows_n, k0, p0, p1, m0); continue; }
#endif
            for (p = p0; p < p1; p++) {
                const uint16_t *bq = (const uint16_t *)g->Bq + ((size_t)p * K2 + (size_t)k0 / 2) * 32;
                int n0 = p * SUPERMAT__NR, nr = SUPERMAT__MIN(SUPERMAT__NR, g->N - n0);
                const int two = p + 1 < p1; /* panels p and p + 1 together (p is whole: not the last) */
                for (m = m0; m < m1; m += SUPERMAT__MR512) {
                    const uint32_t *rows[SUPERMAT__MR512];
                    float *cm = g->C + (size_t)m * g->ldc + n0;
                    const float *bias = g->bias ? g->bias + n0 : NULL, *res = (g->R && k0 == 0) ? g->R + (size_t)m * g->ldr + n0 : NULL;
                    int mr = SUPERMAT__MIN(SUPERMAT__MR512, m1 - m), i;
                    for (i = 0; i < SUPERMAT__MR512; i++) rows[i] = ab + (size_t)(i < mr ? m - m0 + i : m - m0) * kc2;
                    if (two)
                        supermat__ukr2_bf16(kc2, rows, bq, bq + (size_t)K2 * 32, cm, g->ldc, mr, SUPERMAT__MIN(2 * SUPERMAT__NR, g->N - n0), bias, res,
                                            g->ldr, k0 > 0);
                    else supermat__ukr_bf16(kc2, rows, bq, cm, g->ldc, mr, nr, bias, res, g->ldr, k0 > 0);
                }
                p += two;
            }
            continue;
        }
        if (g->fmt == 5) { /* int8 compute: this block of A as u8 quads + row scales once, then every panel */
            int kc4 = (kc + 3) / 4, K4 = (g->K + 3) / 4, rows_n = m1 - m0, r;
            size_t cst = (size_t)g->np * SUPERMAT__NR, j0 = (size_t)k0 / 64;
            unsigned char *a8 = (unsigned char *)(buf + (size_t)SUPERMAT__MC * SUPERMAT__KC + (size_t)SUPERMAT__KC * SUPERMAT__NR);
            float *asc = buf + (size_t)SUPERMAT__MC * SUPERMAT__KC + (size_t)SUPERMAT__KC * SUPERMAT__NR + (size_t)SUPERMAT__MC * SUPERMAT__KC / 4;
            const int32_t *cor = (const int32_t *)(g->qs + (size_t)((g->K + 63) / 64) * cst);
#if SUPERMAT__HAS_AVXVNNI
            const int step = g->vnni256 ? SUPERMAT__MRVNNI : SUPERMAT__MR512;
            if (g->vnni256)
                for (r = 0; r < rows_n; r++) supermat__quant_row_u8_avx2(abase + (size_t)r * lda, kc, a8 + (size_t)r * kc4 * 4, asc + (size_t)r * (SUPERMAT__KC / 64));
            else
#else
            const int step = SUPERMAT__MR512;
#endif
            for (r = 0; r < rows_n; r++) supermat__quant_row_u8(abase + (size_t)r * lda, kc, a8 + (size_t)r * kc4 * 4, asc + (size_t)r * (SUPERMAT__KC / 64));
            for (p = p0; p < p1; p++) {
                const signed char *bq = (const signed char *)g->Bq + ((size_t)p * K4 + (size_t)k0 / 4) * 64;
                int n0 = p * SUPERMAT__NR, nr = SUPERMAT__MIN(SUPERMAT__NR, g->N - n0);
                const int two = step == SUPERMAT__MR512 && p + 1 < p1; /* AVX512_VNNI: panels p and p + 1 together (p is whole) */
                for (m = m0; m < m1; m += step) {
                    const unsigned char *rows[SUPERMAT__MR512];
                    const float *rs[SUPERMAT__MR512];
                    const float *ws = g->qs + j0 * cst + (size_t)n0, *bias = g->bias ? g->bias + n0 : NULL;
                    const float *res = (g->R && k0 == 0) ? g->R + (size_t)m * g->ldr + n0 : NULL;
                    const int32_t *cr = cor + j0 * cst + (size_t)n0;
                    float *cm = g->C + (size_t)m * g->ldc + n0;
                    int mr = SUPERMAT__MIN(step, m1 - m), i;
                    for (i = 0; i < SUPERMAT__MR512; i++) {
                        int rr = i < mr ? m - m0 + i : m - m0;
                        rows[i] = a8 + (size_t)rr * kc4 * 4;
                        rs[i] = asc + (size_t)rr * (SUPERMAT__KC / 64);
                    }
                    if (two)
                        supermat__ukr2_i8(kc4, rows, rs, bq, bq + (size_t)K4 * 64, ws, cr, cst, cm, g->ldc, mr, SUPERMAT__MIN(2 * SUPERMAT__NR, g->N - n0),
                                          bias, res, g->ldr, k0 > 0);
#if SUPERMAT__HAS_AVXVNNI
                    else if (g->vnni256) supermat__ukr_i8_avx(kc4, rows, rs, bq, ws, cr, cst, cm, g->ldc, mr, nr, bias, res, g->ldr, k0 > 0);
#endif
                    else supermat__ukr_i8(kc4, rows, rs, bq, ws, cr, cst, cm, g->ldc, mr, nr, bias, res, g->ldr, k0 > 0);
                }
                p += two;
            }
            continue;
        }
#endif
        for (p = p0; p < p1; p++) {
            size_t boff = ((size_t)p * g->K + k0) * SUPERMAT__NR;
            const float *bp = g->fmt ? NULL : g->B + boff; /* packed f32 panels; the widened formats set it below (g->B is NULL for them) */
            int n0 = p * SUPERMAT__NR, nr = SUPERMAT__MIN(SUPERMAT__NR, g->N - n0);
            if (g->fmt == 3) { /* widen this panel's K block once for all the rows of the task, a scale group at a time */
                float *wb = buf + (size_t)SUPERMAT__MC * SUPERMAT__KC;
                int k = k0, end, grp;
                while (k < k0 + kc) {
                    grp = supermat__qgroup(k, g->qcin, &end);
                    if (end > k0 + kc) end = k0 + kc;
                    g->widen((const signed char *)g->Bq + boff + (size_t)(k - k0) * SUPERMAT__NR, 3,
                             g->qs + (size_t)grp * g->np * SUPERMAT__NR + (size_t)p * SUPERMAT__NR, end - k, wb + (size_t)(k - k0) * SUPERMAT__NR);
                    k = end;
                }
                bp = wb;
            } else if (g->fmt) {
                float *wb = buf + (size_t)SUPERMAT__MC * SUPERMAT__KC;
                g->widen((const char *)g->Bq + boff * 2, g->fmt, NULL, kc, wb);
                bp = wb;
            }
#if SUPERMAT__HAS_AVX512
            if (g->wide && !g->fmt && p + 1 < p1) { /* f32 panels p and p + 1 together */
                const float *bp1 = g->B + boff + (size_t)g->K * SUPERMAT__NR;
                int nr2 = SUPERMAT__MIN(2 * SUPERMAT__NR, g->N - n0), t;
                /* the next pair in this loop's order (the same K block's next panels, else the next K block's
                   first ones): row tile t prefetches the t-th quarter of its first panel's block (t < 4) or
                   of its second's (with this K block's kc, which the next one's may differ from: only a hint) */
                size_t nx = p + 3 < p1 ? boff + (size_t)2 * g->K * SUPERMAT__NR : ((size_t)p0 * g->K + (size_t)(k0 + kc)) * SUPERMAT__NR;
                const size_t nb = (size_t)g->np * g->K * SUPERMAT__NR; /* floats of the weights: no pointer past them */
                for (m = m0, t = 0; m < m1; m += SUPERMAT__MR512, t++) {
                    const float *rows[SUPERMAT__MR512];
                    int mr = SUPERMAT__MIN(SUPERMAT__MR512, m1 - m), i;
                    size_t q = nx + (t >= 4 ? (size_t)g->K * SUPERMAT__NR : 0) + (size_t)(t & 3) * kc * 4; /* in floats */
                    const char *pf = t < 8 && q + (size_t)kc * 4 <= nb ? (const char *)(g->B + q) : NULL;
                    for (i = 0; i < SUPERMAT__MR512; i++) {
                        int rr = i < mr ? m - m0 + i : m - m0;
                        rows[i] = direct ? rp[rr] : abase + (size_t)rr * lda;
                    }
                    supermat__ukr2_avx512(kc, rows, bp, bp1, g->C + (size_t)m * g->ldc + n0, g->ldc, mr, nr2, g->bias ? g->bias + n0 : NULL,
                                          (g->R && k0 == 0) ? g->R + (size_t)m * g->ldr + n0 : NULL, g->ldr, k0 > 0, pf);
                }
                p++;
                continue;
            }
#endif
            for (m = m0; m < m1; m += g->mr) {
                const float *rows[SUPERMAT__MRMAX];
                int mr = SUPERMAT__MIN(g->mr, m1 - m), i;
                for (i = 0; i < g->mr; i++) {
                    int rr = i < mr ? m - m0 + i : m - m0;
                    rows[i] = direct ? rp[rr] : abase + (size_t)rr * lda;
                }
                g->ukr(kc, rows, bp, g->C + (size_t)m * g->ldc + n0, g->ldc, mr, nr,
                           g->bias ? g->bias + n0 : NULL, (g->R && k0 == 0) ? g->R + (size_t)m * g->ldr + n0 : NULL, g->ldr,
                           k0 > 0);
            }
        }
    }
}

/* >>threads : a small pool behind the parallel-for hook: pthreads, or Win32 threads with an SRW lock and
   condition variables; one pool code over the few calls below */
#if SUPERMAT__HAS_PTHREADS
typedef pthread_mutex_t supermat__mutex;
typedef pthread_cond_t supermat__cond;
typedef pthread_t supermat__thread;
#define supermat__mutex_init(m) pthread_mutex_init(m, NULL)
#define supermat__mutex_destroy(m) pthread_mutex_destroy(m)
#define supermat__lock(m) pthread_mutex_lock(m)
#define supermat__unlock(m) pthread_mutex_unlock(m)
#define supermat__cond_init(c) pthread_cond_init(c, NULL)
#define supermat__cond_destroy(c) pthread_cond_destroy(c)
#define supermat__cond_wait(c, m) pthread_cond_wait(c, m)
#define supermat__cond_broadcast(c) pthread_cond_broadcast(c)
#elif SUPERMAT__HAS_WINTHREADS
typedef SRWLOCK supermat__mutex;
typedef CONDITION_VARIABLE supermat__cond;
typedef HANDLE supermat__thread;
#define supermat__mutex_init(m) InitializeSRWLock(m)
#define supermat__mutex_destroy(m) ((void)(m)) /* an SRW lock holds no resources */
#define supermat__lock(m) AcquireSRWLockExclusive(m)
#define supermat__unlock(m) ReleaseSRWLockExclusive(m)
#define supermat__cond_init(c) InitializeConditionVariable(c)
#define supermat__cond_destroy(c) ((void)(c))
#define supermat__cond_wait(c, m) SleepConditionVariableSRW(c, m, INFINITE, 0)
#define supermat__cond_broadcast(c) WakeAllConditionVariable(c)
#endif

#if SUPERMAT__HAS_THREADS
struct supermat_pool {
    supermat_allocator alloc;
    supermat__thread *threads;
    int nthreads;            /* workers, not counting the caller */
    supermat__mutex mu;
    supermat__cond cv_work, cv_done;
    supermat_task_fn task;
    void *task_user;
    int count, next, done, generation, quit;
    int cap;                 /* threads asked for (sizes of the allocations) */
};

static void supermat__pool_work(supermat_pool *p, int thread) {
    for (;;) {
        int i;
        supermat__lock(&p->mu);
        i = p->next < p->count ? p->next++ : -1;
        supermat__unlock(&p->mu);
        if (i < 0) return;
        p->task(p->task_user, i, thread);
        supermat__lock(&p->mu);
        if (++p->done == p->count) supermat__cond_broadcast(&p->cv_done);
        supermat__unlock(&p->mu);
    }
}

typedef struct supermat__pool_arg { supermat_pool *p; int id; } supermat__pool_arg;

/* a worker: waits for each new generation of work until the pool quits */
static void supermat__pool_loop(supermat__pool_arg *arg) {
    supermat_pool *p = arg->p;
    int id = arg->id, seen = 0;
    for (;;) {
        supermat__lock(&p->mu);
        while (!p->quit && p->generation == seen) supermat__cond_wait(&p->cv_work, &p->mu);
        if (p->quit) { supermat__unlock(&p->mu); return; }
        seen = p->generation;
        supermat__unlock(&p->mu);
        supermat__pool_work(p, id);
    }
}
#if SUPERMAT__HAS_PTHREADS
static void *supermat__pool_main(void *arg) { supermat__pool_loop((supermat__pool_arg *)arg); return NULL; }
static int supermat__thread_start(supermat__thread *t, supermat__pool_arg *arg) { return pthread_create(t, NULL, supermat__pool_main, arg) == 0; }
static void supermat__thread_join(supermat__thread t) { pthread_join(t, NULL); }
#else
static DWORD WINAPI supermat__pool_main(LPVOID arg) { supermat__pool_loop((supermat__pool_arg *)arg); return 0; }
static int supermat__thread_start(supermat__thread *t, supermat__pool_arg *arg) {
    *t = CreateThread(NULL, 0, supermat__pool_main, arg, 0, NULL);
    return *t != NULL;
}
static void supermat__thread_join(supermat__thread t) { WaitForSingleObject(t, INFINITE); CloseHandle(t); }
#endif

static void supermat__pool_for(void *user, int count, supermat_task_fn task, void *task_user) {
    supermat_pool *p = (supermat_pool *)user;
    if (count <= 0) return;
    if (p->nthreads == 0 || count == 1) {
        int i;
        for (i = 0; i < count; i++) task(task_user, i, 0);
        return;
    }
    supermat__lock(&p->mu);
    p->task = task; p->task_user = task_user; p->count = count; p->next = 0; p->done = 0; p->generation++;
    supermat__cond_broadcast(&p->cv_work);
    supermat__unlock(&p->mu);
    supermat__pool_work(p, 0);
    supermat__lock(&p->mu);
    while (p->done < p->count) supermat__cond_wait(&p->cv_done, &p->mu);
    p->count = 0;
    supermat__unlock(&p->mu);
}

SUPERMAT__DEF supermat_result supermat_pool_create(int threads, const supermat_allocator *allocator, supermat_pool **out,
                                                   supermat_threading *hook) {
    supermat_allocator a = supermat__resolve_allocator(allocator);
    supermat_pool *p;
    supermat__pool_arg *args;
    int i;
    if (!out || !hook) return SUPERMAT_ERROR_INVALID_ARGUMENT;
    *out = NULL;
    if (threads <= 0) threads = supermat__cpu_count();
    if (threads > 64) threads = 64;
    p = (supermat_pool *)supermat__alloc(&a, sizeof *p + sizeof(supermat__pool_arg) * (size_t)threads);
    if (!p) return SUPERMAT_ERROR_OUT_OF_MEMORY;
    memset(p, 0, sizeof *p);
    p->alloc = a;
    p->cap = threads;
    args = (supermat__pool_arg *)(p + 1);
    p->threads = (supermat__thread *)supermat__alloc(&a, sizeof(supermat__thread) * (size_t)threads);
    if (!p->threads) { supermat__free(&a, p, sizeof *p); return SUPERMAT_ERROR_OUT_OF_MEMORY; }
    supermat__mutex_init(&p->mu);
    supermat__cond_init(&p->cv_work);
    supermat__cond_init(&p->cv_done);
    for (i = 1; i < threads; i++) {
        args[i].p = p; args[i].id = i;
        if (!supermat__thread_start(&p->threads[p->nthreads], &args[i])) break;
        p->nthreads++;
    }
    hook->parallel_for = supermat__pool_for;
    hook->user = p;
    hook->max_threads = p->nthreads + 1;
    *out = p;
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF void supermat_pool_destroy(supermat_pool *p) {
    int i, n;
    supermat_allocator a;
    if (!p) return;
    supermat__lock(&p->mu);
    p->quit = 1;
    supermat__cond_broadcast(&p->cv_work);
    supermat__unlock(&p->mu);
    for (i = 0; i < p->nthreads; i++) supermat__thread_join(p->threads[i]);
    supermat__mutex_destroy(&p->mu);
    supermat__cond_destroy(&p->cv_work);
    supermat__cond_destroy(&p->cv_done);
    a = p->alloc;
    n = p->cap;
    supermat__free(&a, p->threads, sizeof(supermat__thread) * (size_t)n);
    supermat__free(&a, p, sizeof *p + sizeof(supermat__pool_arg) * (size_t)n);
}
#endif

/* >>context : what every operation of a run sees (kernels, threads, arena, status) */
#define SUPERMAT__MAXBLK 96
typedef struct supermat__ctx {
    int plan;                   /* 1: walk the network only to plan memory */
    supermat_result status;     /* first failure (cancellation); operations become no-ops after it */
    supermat_error *err;
    char *base;                 /* arena (NULL while planning) */
    size_t cap, peak;
    size_t boff[SUPERMAT__MAXBLK], bsize[SUPERMAT__MAXBLK];
    int nblk;
    supermat__ukr_fn ukr;
    int mr;                     /* rows of ukr (0 = SUPERMAT__MR) */
    supermat__widen_fn widen;   /* f16, bf16, int8 panels to f32 */
    int avx2;                   /* AVX2 kernels (also under AVX-512, whose ukr is the only AVX-512 part) */
    int avx512;
    int neon;                   /* the aarch64 GEMM micro-kernel (over the scalar rest) */
    int amx;                    /* bf16-compute GEMMs on AMX tiles (over the AVX-512 rest) */
    int vnni256;                /* int8-compute GEMMs on AVX-VNNI (over the AVX2 rest) */
    supermat_threading thr;
    float **scratch;            /* per thread: MC x KC floats for the conv gather / attention tiles */
    size_t scratch_floats;
    double *gn_stats;           /* 2 x gn_cap doubles */
    size_t gn_cap;
    int (*progress)(void *user, float fraction, const char *what);
    void *progress_user;
    double work_done, work_total;
    double flops;               /* FLOPs counted while planning */
    int mv_att, mv_stride, mv_top; /* restricted multi-view attention in layers of mv_top tokens per view */
} supermat__ctx;

typedef struct supermat__t { float *d; int n, h, w, c; } supermat__t; /* NHWC */

static size_t supermat__numel(const supermat__t *t) { return (size_t)t->n * t->h * t->w * t->c; }

/* >>arena : first-fit over planned offsets; the same call sequence while planning and running gives
   the same offsets, so the run fits exactly the planned peak and never allocates. */
static float *supermat__get(supermat__ctx *X, size_t nfloats) {
    size_t size = (nfloats * sizeof(float) + 63) & ~(size_t)63, off = 0;
    int i, at;
    if (size == 0) size = 64;
    if (X->nblk >= SUPERMAT__MAXBLK) { X->status = SUPERMAT_ERROR_INTERNAL; return NULL; }
    for (at = 0; at < X->nblk; at++) {
        if (X->boff[at] >= off + size) break;
        off = X->boff[at] + X->bsize[at];
    }
    for (i = X->nblk; i > at; i--) { X->boff[i] = X->boff[i - 1]; X->bsize[i] = X->bsize[i - 1]; }
    X->boff[at] = off; X->bsize[at] = size; X->nblk++;
    if (off + size > X->peak) X->peak = off + size;
    if (X->plan) return (float *)(uintptr_t)(64 + off);
    if (off + size > X->cap) { X->status = SUPERMAT_ERROR_INTERNAL; return (float *)(uintptr_t)(64 + off); }
    return (float *)(X->base + off);
}
static void supermat__put(supermat__ctx *X, const void *p) {
    size_t off;
    int i;
    if (!p) return;
    off = X->plan ? (size_t)((uintptr_t)p - 64) : (size_t)((const char *)p - X->base);
    if (!X->plan && (uintptr_t)p < (uintptr_t)X->base) off = (size_t)((uintptr_t)p - 64);
    for (i = 0; i < X->nblk; i++)
        if (X->boff[i] == off) {
            for (; i + 1 < X->nblk; i++) { X->boff[i] = X->boff[i + 1]; X->bsize[i] = X->bsize[i + 1]; }
            X->nblk--;
            return;
        }
    X->status = SUPERMAT_ERROR_INTERNAL;
}
static supermat__t supermat__tensor(supermat__ctx *X, int n, int h, int w, int c) {
    supermat__t t;
    t.n = n; t.h = h; t.w = w; t.c = c;
    t.d = supermat__get(X, (size_t)n * h * w * c);
    return t;
}
static void supermat__drop(supermat__ctx *X, supermat__t *t) { supermat__put(X, t->d); t->d = NULL; }
static int supermat__live(const supermat__ctx *X) { return !X->plan && X->status == SUPERMAT_SUCCESS; }

static void supermat__par(supermat__ctx *X, int count, supermat_task_fn fn, void *user) {
    if (count <= 0) return;
    if (X->thr.parallel_for && X->thr.max_threads > 1 && count > 1) X->thr.parallel_for(X->thr.user, count, fn, user);
    else { int i; for (i = 0; i < count; i++) fn(user, i, 0); }
}

static void supermat__step(supermat__ctx *X, double work, const char *what) {
    X->work_done += work;
    if (X->plan) { X->work_total += work; return; }
    if (X->status == SUPERMAT_SUCCESS && X->progress &&
        X->progress(X->progress_user, X->work_total > 0 ? (float)(X->work_done / X->work_total) : 0.0f, what))
        X->status = supermat__fail(X->err, SUPERMAT_ERROR_CANCELLED, NULL, "cancelled by the progress callback at %s", what);
}

/* >>ops : GEMM-based layers */
/* fills g for C = A W^T (+ bias) (+ R) and returns its task count (0: nothing to run, the status set on an
   error). whole_n: every task takes all the columns (callers that batch several GEMMs into one parallel-for
   have tasks enough); else a few row blocks split the columns too. */
static int supermat__gemm_setup(supermat__ctx *X, supermat__gemm_args *gp, const supermat__asrc *A, int M, const supermat__pw *W,
                                float *C, size_t ldc, const float *bias, const float *R, size_t ldr, int whole_n) {
    supermat__gemm_args g;
    int npanels, tasks_m;
    X->flops += 2.0 * M * (double)W->N * W->K;
    if (!supermat__live(X) || M <= 0) return 0;
    memset(&g, 0, sizeof g);
    g.ukr = X->ukr; g.mr = X->mr > 0 ? X->mr : SUPERMAT__MR; g.M = M; g.N = W->N; g.K = W->K; g.A = A; g.B = W->p; g.bias = bias;
    g.fmt = W->fmt; g.Bq = W->q; g.qs = W->qs; g.qcin = W->qcin > 0 ? W->qcin : W->K; g.np = (W->N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    g.widen = X->widen;
    g.amx = X->amx;
    g.vnni256 = X->vnni256;
#if SUPERMAT__HAS_AVX512
    g.wide = X->ukr == supermat__ukr_avx512;
#endif
    if (W->fmt && W->fmt < 4 && (!g.widen || g.B)) { X->status = SUPERMAT_ERROR_INTERNAL; return 0; }
#if SUPERMAT__HAS_AVX512
    if (W->fmt >= 4 && (!(X->avx512 || (W->fmt == 5 && X->vnni256 && SUPERMAT__HAS_AVXVNNI)) || !W->q || (W->fmt == 5 && !W->qs) ||
                        X->scratch_floats < (size_t)SUPERMAT__MC * SUPERMAT__KC * 3 / 2 + (size_t)SUPERMAT__KC * SUPERMAT__NR)) {
        X->status = SUPERMAT_ERROR_INTERNAL;
        return 0;
    }
#else
    if (W->fmt >= 4) { X->status = SUPERMAT_ERROR_INTERNAL; return 0; }
#endif
    g.C = C; g.ldc = ldc; g.R = R; g.ldr = ldr; g.scratch = X->scratch;
    npanels = (W->N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    tasks_m = (M + SUPERMAT__MC - 1) / SUPERMAT__MC;
    g.nchunks = 1;
    if (tasks_m < 8 && !whole_n) { /* few row blocks: split the columns too (fixed by shape, not by thread count) */
        g.nchunks = SUPERMAT__MIN(npanels, (4 * 8 + tasks_m - 1) / tasks_m);
        if (g.nchunks < 1) g.nchunks = 1;
    }
    g.panels_per_chunk = (npanels + g.nchunks - 1) / g.nchunks;
    g.nchunks = (npanels + g.panels_per_chunk - 1) / g.panels_per_chunk;
    g.mblocks = tasks_m;
    *gp = g;
    return tasks_m * g.nchunks;
}
static void supermat__gemm(supermat__ctx *X, const supermat__asrc *A, int M, const supermat__pw *W, float *C, size_t ldc,
                           const float *bias, const float *R, size_t ldr) {
    supermat__gemm_args g;
    int n = supermat__gemm_setup(X, &g, A, M, W, C, ldc, bias, R, ldr, 0);
    if (n > 0) supermat__par(X, n, supermat__gemm_task, &g);
}

/* y[M, N] = x[M, K] W^T + b (+ R) */
static void supermat__linear(supermat__ctx *X, const float *x, size_t ldx, int M, const supermat__pw *W, float *y, size_t ldy,
                             const float *R, size_t ldr) {
    supermat__asrc A;
    memset(&A, 0, sizeof A);
    A.a = x; A.lda = ldx;
    supermat__gemm(X, &A, M, W, y, ldy, W->bias, R, ldr);
}

/* >>winograd : F(2x2,3x3) and F(4x4,3x3) for the 3x3 stride-1 pad-1 convolutions (Lavin & Gray).
   The kernel is transformed once (U = G g G^T, in float64) into a*a packed weights of K = Cin. Per chunk
   of tiles (over all images): V = B^T d B of the zero-padded input tiles, a*a GEMMs M[xi] = V[xi] U[xi]^T,
   then Y = A^T M A + bias (+ R). Each tile is transformed by one task: the bits do not depend on threads. */
typedef struct supermat__wino { int m, a; supermat__pw u[36]; } supermat__wino; /* a = m + 2 */

/* direct f32 panels (K = 9*cin, k = (ky*3 + kx)*cin + ci) -> a*a f32 panel arrays dst[xi] (K = cin) */
static int supermat__wino_transform(const float *p, int cin, int cout, int m, float *const *dst) {
    static const double G2[4][3] = {{1, 0, 0}, {.5, .5, .5}, {.5, -.5, .5}, {0, 0, 1}};
    static const double G4[6][3] = {{1.0 / 4, 0, 0}, {-1.0 / 6, -1.0 / 6, -1.0 / 6}, {-1.0 / 6, 1.0 / 6, -1.0 / 6},
                                    {1.0 / 24, 1.0 / 12, 1.0 / 6}, {1.0 / 24, -1.0 / 12, 1.0 / 6}, {0, 0, 1}};
    int a = m + 2, np = (cout + SUPERMAT__NR - 1) / SUPERMAT__NR, co, ci, i, j, k;
    size_t K = (size_t)9 * cin;
    if ((m != 2 && m != 4) || cin <= 0 || cout <= 0) return -1;
    for (co = 0; co < np * SUPERMAT__NR; co++)
        for (ci = 0; ci < cin; ci++) {
            double g[9], t[6][3];
            size_t pn = (size_t)(co / SUPERMAT__NR), o = (pn * cin + ci) * SUPERMAT__NR + co % SUPERMAT__NR;
            for (k = 0; k < 9; k++) g[k] = co < cout ? p[(pn * K + (size_t)k * cin + ci) * SUPERMAT__NR + co % SUPERMAT__NR] : 0.0;
            for (i = 0; i < a; i++) { /* t = G g */
                const double *G = m == 2 ? G2[i] : G4[i];
                for (j = 0; j < 3; j++) t[i][j] = G[0] * g[j] + G[1] * g[3 + j] + G[2] * g[6 + j];
            }
            for (i = 0; i < a; i++) /* U = t G^T */
                for (j = 0; j < a; j++) {
                    const double *G = m == 2 ? G2[j] : G4[j];
                    dst[i * a + j][o] = (float)(t[i][0] * G[0] + t[i][1] * G[1] + t[i][2] * G[2]);
                }
        }
    return 0;
}

/* tiles per chunk: V + Mo about SUPERMAT__WINO_CHUNK floats (cache-sized), but at least MINTILES tiles
   (GEMM rows per pass over the a*a weights, which matters with many channels) and at most 8M floats */
#ifndef SUPERMAT__WINO_CHUNK
#define SUPERMAT__WINO_CHUNK (1 << 20)
#endif
#ifndef SUPERMAT__WINO_MINTILES
#define SUPERMAT__WINO_MINTILES 144
#endif
typedef struct supermat__wino_job {
    const float *x; int h, w, c, uh, uw;    /* input, read as if resized to uh x uw (nearest) */
    float *y; const float *bias, *R; int oc; /* output n x uh x uw x oc */
    int m, tx, ty, t0, tb, TB, per;          /* tiles per image tx x ty; chunk [t0, t0 + tb); tiles per task */
    float *V, *Mo;                           /* [a*a][TB][c], [a*a][TB][oc] */
    int avx2, avx512;
} supermat__wino_job;

#define SUPERMAT__WINO_INLINE SUPERMAT__FORCEINLINE
/* 1-D transforms on 8 channels at once: o[k*os][j] from s[k*ss][j], k along the transformed axis */
#define SUPERMAT__WINO_BT(o, os, s, ss) for (j = 0; j < 8; j++) { \
    if (m == 4) { \
        float d0 = s[0][j], d1 = s[ss][j], d2 = s[2 * ss][j], d3 = s[3 * ss][j], d4 = s[4 * ss][j], d5 = s[5 * ss][j]; \
        float t1 = d4 - 4.0f * d2, t2 = d3 - 4.0f * d1, t3 = d4 - d2, t4 = 2.0f * (d3 - d1); \
        o[0][j] = 4.0f * d0 - 5.0f * d2 + d4; o[os][j] = t1 + t2; o[2 * os][j] = t1 - t2; \
        o[3 * os][j] = t3 + t4; o[4 * os][j] = t3 - t4; o[5 * os][j] = 4.0f * d1 - 5.0f * d3 + d5; \
    } else { \
        float d0 = s[0][j], d1 = s[ss][j], d2 = s[2 * ss][j], d3 = s[3 * ss][j]; \
        o[0][j] = d0 - d2; o[os][j] = d1 + d2; o[2 * os][j] = d2 - d1; o[3 * os][j] = d1 - d3; \
    } }
#define SUPERMAT__WINO_AT(o, os, s, ss) for (j = 0; j < 8; j++) { \
    if (m == 4) { \
        float s12 = s[ss][j] + s[2 * ss][j], d12 = s[ss][j] - s[2 * ss][j]; \
        float s34 = s[3 * ss][j] + s[4 * ss][j], d34 = s[3 * ss][j] - s[4 * ss][j]; \
        o[0][j] = s[0][j] + s12 + s34; o[os][j] = d12 + 2.0f * d34; o[2 * os][j] = s12 + 4.0f * s34; \
        o[3 * os][j] = d12 + 8.0f * d34 + s[5 * ss][j]; \
    } else { \
        o[0][j] = s[0][j] + s[ss][j] + s[2 * ss][j]; o[os][j] = s[ss][j] - s[2 * ss][j] - s[3 * ss][j]; \
    } }

/* input tile t of the chunk -> V[xi][t][:]. The column pass reads memory directly (a copy to a local array
   first costs store-forwarding stalls), the row pass writes a local array (stores through several
   pointers that might overlap would not vectorise); partial channel blocks go through tmp. */
static SUPERMAT__WINO_INLINE void supermat__wino_in_tile(const supermat__wino_job *J, int t, int m) {
    static const float zero[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    int a = m + 2, T = J->t0 + t, img = T / (J->tx * J->ty), by = T / J->tx % J->ty, bx = T % J->tx, i, j, xi, c0;
    const float *src[36], *p[36];
    float *q[36], d[36][8], e[36][8], tmp[36][8];
    for (i = 0; i < a; i++) {
        int vy = by * m - 1 + i, sy = vy >= 0 && vy < J->uh ? supermat__nearest(vy, J->h, J->uh) : -1;
        for (j = 0; j < a; j++) {
            int vx = bx * m - 1 + j;
            src[i * a + j] = sy >= 0 && vx >= 0 && vx < J->uw
                                 ? J->x + (((size_t)img * J->h + sy) * J->w + supermat__nearest(vx, J->w, J->uw)) * J->c : NULL;
        }
    }
    for (c0 = 0; c0 < J->c; c0 += 8) {
        int cb = SUPERMAT__MIN(8, J->c - c0);
        for (xi = 0; xi < a * a; xi++) {
            p[xi] = src[xi] ? src[xi] + c0 : zero;
            q[xi] = J->V + ((size_t)xi * J->TB + t) * J->c + c0;
        }
        if (cb < 8)
            for (xi = 0; xi < a * a; xi++) {
                for (j = 0; j < 8; j++) tmp[xi][j] = j < cb ? p[xi][j] : 0.0f;
                p[xi] = tmp[xi];
            }
        for (i = 0; i < a; i++) SUPERMAT__WINO_BT((e + i), a, (p + i), a)         /* columns */
        for (i = 0; i < a; i++) SUPERMAT__WINO_BT((d + i * a), 1, (e + i * a), 1) /* rows */
        for (xi = 0; xi < a * a; xi++) {
            if (cb == 8) for (j = 0; j < 8; j++) q[xi][j] = d[xi][j];
            else for (j = 0; j < cb; j++) q[xi][j] = d[xi][j];
        }
    }
}

/* Mo[xi][t][:] -> the valid outputs of tile t, + bias (+ R; R may be the output itself) */
static SUPERMAT__WINO_INLINE void supermat__wino_out_tile(const supermat__wino_job *J, int t, int m) {
    int a = m + 2, T = J->t0 + t, img = T / (J->tx * J->ty), by = T / J->tx % J->ty, bx = T % J->tx, i, j, xi, c0, oc = J->oc;
    const float *p[36];
    float e[24][8], r[16][8], tmp[36][8], o[8];
    for (c0 = 0; c0 < oc; c0 += 8) {
        int cb = SUPERMAT__MIN(8, oc - c0);
        for (xi = 0; xi < a * a; xi++) p[xi] = J->Mo + ((size_t)xi * J->TB + t) * oc + c0;
        if (cb < 8)
            for (xi = 0; xi < a * a; xi++) {
                for (j = 0; j < 8; j++) tmp[xi][j] = j < cb ? p[xi][j] : 0.0f;
                p[xi] = tmp[xi];
            }
        for (i = 0; i < a; i++) SUPERMAT__WINO_AT((e + i), a, (p + i), a)         /* columns: e[y*a + i], y < m */
        for (i = 0; i < m; i++) SUPERMAT__WINO_AT((r + i * m), 1, (e + i * a), 1) /* rows: r[y*m + x] */
        for (xi = 0; xi < m * m; xi++) {
            int oy = by * m + xi / m, ox = bx * m + xi % m;
            size_t off;
            if (oy >= J->uh || ox >= J->uw) continue;
            off = (((size_t)img * J->uh + oy) * J->uw + ox) * oc + c0;
            if (J->bias) for (j = 0; j < 8; j++) o[j] = r[xi][j] + J->bias[c0 + j]; /* bias is padded to 16 */
            else for (j = 0; j < 8; j++) o[j] = r[xi][j];
            if (cb == 8) {
                if (J->R) for (j = 0; j < 8; j++) o[j] += J->R[off + j];
                for (j = 0; j < 8; j++) J->y[off + j] = o[j];
            } else {
                if (J->R) for (j = 0; j < cb; j++) o[j] += J->R[off + j];
                for (j = 0; j < cb; j++) J->y[off + j] = o[j];
            }
        }
    }
}
#undef SUPERMAT__WINO_BT
#undef SUPERMAT__WINO_AT

/* the same bodies compiled for the baseline ISA and for AVX2 (the 8-channel loops vectorise) */
static void supermat__wino_tiles_scalar(const supermat__wino_job *J, int t0, int t1, int out) {
    int t;
    for (t = t0; t < t1; t++) {
        if (out) { if (J->m == 4) supermat__wino_out_tile(J, t, 4); else supermat__wino_out_tile(J, t, 2); }
        else { if (J->m == 4) supermat__wino_in_tile(J, t, 4); else supermat__wino_in_tile(J, t, 2); }
    }
}
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static void supermat__wino_tiles_avx2(const supermat__wino_job *J, int t0, int t1, int out) {
    int t;
    for (t = t0; t < t1; t++) {
        if (out) { if (J->m == 4) supermat__wino_out_tile(J, t, 4); else supermat__wino_out_tile(J, t, 2); }
        else { if (J->m == 4) supermat__wino_in_tile(J, t, 4); else supermat__wino_in_tile(J, t, 2); }
    }
}
#endif
#if SUPERMAT__HAS_AVX512
/* F(4x4, 3x3) tiles with AVX-512: 16 channels a vector, the partial block by masks. The same operations in
   the same order as the bodies above (separate multiplies and adds), so the same bits as the AVX2 path where
   the compiler does not fuse multiply-adds (C99 with gcc / clang defaults); where it does (-ffp-contract=fast,
   gcc's default for C++) the two may differ in the last bits. */
#define SUPERMAT__W4BT(o0, o1, o2, o3, o4, o5, d0, d1, d2, d3, d4, d5) do {                                        \
        __m512 t1_ = _mm512_sub_ps(d4, _mm512_mul_ps(four, d2)), t2_ = _mm512_sub_ps(d3, _mm512_mul_ps(four, d1)); \
        __m512 t3_ = _mm512_sub_ps(d4, d2), t4_ = _mm512_mul_ps(two, _mm512_sub_ps(d3, d1));                       \
        o0 = _mm512_add_ps(_mm512_sub_ps(_mm512_mul_ps(four, d0), _mm512_mul_ps(five, d2)), d4);                   \
        o5 = _mm512_add_ps(_mm512_sub_ps(_mm512_mul_ps(four, d1), _mm512_mul_ps(five, d3)), d5);                   \
        o1 = _mm512_add_ps(t1_, t2_); o2 = _mm512_sub_ps(t1_, t2_);                                                \
        o3 = _mm512_add_ps(t3_, t4_); o4 = _mm512_sub_ps(t3_, t4_);                                                \
    } while (0)
#define SUPERMAT__W4AT(o0, o1, o2, o3, s0, s1, s2, s3, s4, s5) do {                                                \
        __m512 s12_ = _mm512_add_ps(s1, s2), d12_ = _mm512_sub_ps(s1, s2);                                         \
        __m512 s34_ = _mm512_add_ps(s3, s4), d34_ = _mm512_sub_ps(s3, s4);                                         \
        o0 = _mm512_add_ps(_mm512_add_ps(s0, s12_), s34_);                                                         \
        o1 = _mm512_add_ps(d12_, _mm512_mul_ps(two, d34_));                                                        \
        o2 = _mm512_add_ps(s12_, _mm512_mul_ps(four, s34_));                                                       \
        o3 = _mm512_add_ps(_mm512_add_ps(d12_, _mm512_mul_ps(eight, d34_)), s5);                                   \
    } while (0)
SUPERMAT__AVX512 static void supermat__wino4_in_avx512(const supermat__wino_job *J, int t) {
    const __m512 two = _mm512_set1_ps(2.0f), four = _mm512_set1_ps(4.0f), five = _mm512_set1_ps(5.0f);
    int T = J->t0 + t, img = T / (J->tx * J->ty), by = T / J->tx % J->ty, bx = T % J->tx, i, j, c0;
    const float *src[36];
    __m512 e[36];
    for (i = 0; i < 6; i++) {
        int vy = by * 4 - 1 + i, sy = vy >= 0 && vy < J->uh ? supermat__nearest(vy, J->h, J->uh) : -1;
        for (j = 0; j < 6; j++) {
            int vx = bx * 4 - 1 + j;
            src[i * 6 + j] = sy >= 0 && vx >= 0 && vx < J->uw
                                 ? J->x + (((size_t)img * J->h + sy) * J->w + supermat__nearest(vx, J->w, J->uw)) * J->c : NULL;
        }
    }
    for (c0 = 0; c0 < J->c; c0 += 16) {
        __mmask16 k = J->c - c0 >= 16 ? (__mmask16)0xFFFF : (__mmask16)((1u << (J->c - c0)) - 1);
        float *q = J->V + (size_t)t * J->c + c0;
        size_t xs = (size_t)J->TB * J->c; /* from one xi to the next in V */
        for (i = 0; i < 6; i++) { /* columns: e[k*6 + i] from the input column i */
            __m512 d[6];
            for (j = 0; j < 6; j++) d[j] = src[j * 6 + i] ? _mm512_maskz_loadu_ps(k, src[j * 6 + i] + c0) : _mm512_setzero_ps();
            SUPERMAT__W4BT(e[i], e[6 + i], e[12 + i], e[18 + i], e[24 + i], e[30 + i], d[0], d[1], d[2], d[3], d[4], d[5]);
        }
        for (i = 0; i < 6; i++) { /* rows */
            __m512 o[6];
            SUPERMAT__W4BT(o[0], o[1], o[2], o[3], o[4], o[5], e[i * 6], e[i * 6 + 1], e[i * 6 + 2], e[i * 6 + 3], e[i * 6 + 4], e[i * 6 + 5]);
            for (j = 0; j < 6; j++) _mm512_mask_storeu_ps(q + (size_t)(i * 6 + j) * xs, k, o[j]);
        }
    }
}
SUPERMAT__AVX512 static void supermat__wino4_out_avx512(const supermat__wino_job *J, int t) {
    const __m512 two = _mm512_set1_ps(2.0f), four = _mm512_set1_ps(4.0f), eight = _mm512_set1_ps(8.0f);
    int T = J->t0 + t, img = T / (J->tx * J->ty), by = T / J->tx % J->ty, bx = T % J->tx, i, j, c0, oc = J->oc;
    size_t xs = (size_t)J->TB * oc;
    for (c0 = 0; c0 < oc; c0 += 16) {
        __mmask16 k = oc - c0 >= 16 ? (__mmask16)0xFFFF : (__mmask16)((1u << (oc - c0)) - 1);
        const float *p = J->Mo + (size_t)t * oc + c0;
        __m512 e[24], bias = J->bias ? _mm512_maskz_loadu_ps(k, J->bias + c0) : _mm512_setzero_ps();
        for (i = 0; i < 6; i++) { /* columns: e[y*6 + i], y < 4 */
            __m512 s[6];
            for (j = 0; j < 6; j++) s[j] = _mm512_maskz_loadu_ps(k, p + (size_t)(j * 6 + i) * xs);
            SUPERMAT__W4AT(e[i], e[6 + i], e[12 + i], e[18 + i], s[0], s[1], s[2], s[3], s[4], s[5]);
        }
        for (i = 0; i < 4; i++) { /* rows: output row by*4 + i */
            __m512 o[4];
            int oy = by * 4 + i;
            SUPERMAT__W4AT(o[0], o[1], o[2], o[3], e[i * 6], e[i * 6 + 1], e[i * 6 + 2], e[i * 6 + 3], e[i * 6 + 4], e[i * 6 + 5]);
            if (oy >= J->uh) break;
            for (j = 0; j < 4; j++) {
                int ox = bx * 4 + j;
                size_t off;
                __m512 v = o[j];
                if (ox >= J->uw) break;
                off = (((size_t)img * J->uh + oy) * J->uw + ox) * oc + c0;
                if (J->bias) v = _mm512_add_ps(v, bias);
                if (J->R) v = _mm512_add_ps(v, _mm512_maskz_loadu_ps(k, J->R + off));
                _mm512_mask_storeu_ps(J->y + off, k, v);
            }
        }
    }
}
#undef SUPERMAT__W4BT
#undef SUPERMAT__W4AT
#endif
static void supermat__wino_task(const supermat__wino_job *J, int index, int out) {
    int t0 = index * J->per, t1 = SUPERMAT__MIN(J->tb, t0 + J->per);
#if SUPERMAT__HAS_AVX512
    if (J->avx512 && J->m == 4) {
        int t;
        for (t = t0; t < t1; t++) { if (out) supermat__wino4_out_avx512(J, t); else supermat__wino4_in_avx512(J, t); }
        return;
    }
#endif
#if SUPERMAT__HAS_AVX2
    if (J->avx2) { supermat__wino_tiles_avx2(J, t0, t1, out); return; }
#endif
    supermat__wino_tiles_scalar(J, t0, t1, out);
}
static void supermat__wino_in_task(void *user, int index, int thread) { (void)thread; supermat__wino_task((const supermat__wino_job *)user, index, 0); }
static void supermat__wino_out_task(void *user, int index, int thread) { (void)thread; supermat__wino_task((const supermat__wino_job *)user, index, 1); }

/* the a*a GEMMs of a chunk of tiles: the same shape each, n tasks each */
typedef struct supermat__wino_gemms { supermat__gemm_args g[36]; supermat__asrc a[36]; int n; } supermat__wino_gemms; /* g[i].A = &a[i] */
static void supermat__wino_gemm_task(void *user, int index, int thread) {
    const supermat__wino_gemms *G = (const supermat__wino_gemms *)user;
    supermat__gemm_task((void *)&G->g[index / G->n], index % G->n, thread);
}

/* out = conv3x3(in resized to (uh, uw) by nearest, padding 1) + bias (padded, or NULL) (+ R) */
static void supermat__conv3x3_wino(supermat__ctx *X, const supermat__t *in, int uh, int uw, const supermat__wino *wg,
                                   supermat__t *out, const float *bias, const float *R) {
    supermat__wino_job J;
    supermat__wino_gemms G;
    supermat__asrc A;
    int m = wg->m, aa = (m + 2) * (m + 2), cin = in->c, cout = wg->u[0].N, T, nch, ch, xi, ntask;
    size_t cap, per_tile;
    if ((m != 2 && m != 4) || wg->a != m + 2 || wg->u[0].K != cin || out->c != cout || out->h != uh || out->w != uw || out->n != in->n) {
        X->status = SUPERMAT_ERROR_INTERNAL;
        return;
    }
    memset(&J, 0, sizeof J);
    J.x = in->d; J.h = in->h; J.w = in->w; J.c = cin; J.uh = uh; J.uw = uw;
    J.y = out->d; J.bias = bias; J.R = R; J.oc = cout; J.m = m; J.avx2 = X->avx2; J.avx512 = X->avx512;
    J.tx = (uw + m - 1) / m; J.ty = (uh + m - 1) / m;
    T = in->n * J.tx * J.ty;
    if (T <= 0) return;
    /* chunk size (see SUPERMAT__WINO_CHUNK; at least 6 tiles), evened out over the chunks */
    per_tile = (size_t)aa * (size_t)(cin + cout);
    cap = SUPERMAT__MAX((size_t)SUPERMAT__WINO_CHUNK / per_tile, (size_t)SUPERMAT__WINO_MINTILES);
    cap = SUPERMAT__MAX(SUPERMAT__MIN(cap, ((size_t)8 << 20) / per_tile), (size_t)6);
    J.TB = (int)SUPERMAT__MIN((size_t)T, cap);
    nch = (T + J.TB - 1) / J.TB;
    J.TB = (T + nch - 1) / nch;
    J.per = SUPERMAT__MAX(1, 16384 / (aa * SUPERMAT__MAX(cin, cout)));
    J.V = supermat__get(X, (size_t)aa * J.TB * cin);
    J.Mo = supermat__get(X, (size_t)aa * J.TB * cout);
    memset(&A, 0, sizeof A);
    A.lda = (size_t)cin;
    for (ch = 0; ch < nch; ch++) {
        J.t0 = ch * J.TB; J.tb = SUPERMAT__MIN(J.TB, T - J.t0);
        ntask = (J.tb + J.per - 1) / J.per;
        if (supermat__live(X)) supermat__par(X, ntask, supermat__wino_in_task, &J);
        /* the a*a GEMMs in one parallel-for (each task takes all the columns of one row block of one of
           them: the two-panel kernel, one dispatch instead of a*a); planning counts the FLOPs only */
        for (xi = 0, G.n = 0; xi < aa; xi++) {
            G.a[xi] = A;
            G.a[xi].a = J.V ? J.V + (size_t)xi * J.TB * cin : NULL;
            G.n = supermat__gemm_setup(X, &G.g[xi], &G.a[xi], J.tb, &wg->u[xi], J.Mo ? J.Mo + (size_t)xi * J.TB * cout : NULL, (size_t)cout, NULL, NULL, 0, 1);
        }
        if (G.n > 0 && supermat__live(X)) supermat__par(X, aa * G.n, supermat__wino_gemm_task, &G);
        if (supermat__live(X)) supermat__par(X, ntask, supermat__wino_out_task, &J);
    }
    supermat__put(X, J.Mo);
    supermat__put(X, J.V);
}

typedef struct supermat__conv { supermat__pw w; int k, stride, cin, cout; const supermat__wino *wino; /* or NULL */ } supermat__conv;

/* out = conv(in resized to (uh, uw) by nearest) + bias (+ R); pad: k/2 on all sides, or (0,1,0,1) with pad_mode 1 */
static void supermat__conv2d(supermat__ctx *X, const supermat__t *in, int uh, int uw, const supermat__conv *cv, int pad_mode,
                             supermat__t *out, const float *bias, const float *R) {
    supermat__asrc A;
    int pt, pl, pb, pr;
    memset(&A, 0, sizeof A);
    if (pad_mode == 0) { pt = pl = pb = pr = cv->k / 2; } else { pt = pl = 0; pb = pr = 1; }
    A.conv = cv->k != 1 || cv->stride != 1 || uh != in->h || uw != in->w;
    A.x = in->d; A.n = in->n; A.h = in->h; A.w = in->w; A.c = in->c; A.uh = uh; A.uw = uw;
    A.kh = A.kw = cv->k; A.stride = cv->stride; A.pad_t = pt; A.pad_l = pl;
    A.oh = (uh + pt + pb - cv->k) / cv->stride + 1;
    A.ow = (uw + pl + pr - cv->k) / cv->stride + 1;
    A.a = in->d; A.lda = (size_t)in->c;
    if (out->h != A.oh || out->w != A.ow || out->c != cv->cout || in->c != cv->cin) { X->status = SUPERMAT_ERROR_INTERNAL; return; }
    if (cv->wino && pad_mode == 0) { /* set on 3x3 stride-1 convolutions only */
        supermat__conv3x3_wino(X, in, uh, uw, cv->wino, out, bias ? bias : cv->w.bias, R);
        return;
    }
    supermat__gemm(X, &A, in->n * A.oh * A.ow, &cv->w, out->d, (size_t)out->c, bias ? bias : cv->w.bias, R, (size_t)out->c);
}

/* >>vector : exp, SiLU and GELU on arrays (AVX2 with scalar tails, and scalar) */
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static __m256 supermat__exp_avx2(__m256 x) {
    /* Cody-Waite range reduction + Cephes polynomial; max rel. error ~2 ulp on [-87, 88] */
    __m256 fx, y, z, p;
    __m256i e;
    x = _mm256_min_ps(x, _mm256_set1_ps(88.3762626647949f));
    x = _mm256_max_ps(x, _mm256_set1_ps(-87.3365447505531f));
    fx = _mm256_round_ps(_mm256_mul_ps(x, _mm256_set1_ps(1.44269504088896341f)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    x = _mm256_fnmadd_ps(fx, _mm256_set1_ps(0.693359375f), x);
    x = _mm256_fnmadd_ps(fx, _mm256_set1_ps(-2.12194440e-4f), x);
    z = _mm256_mul_ps(x, x);
    p = _mm256_set1_ps(1.9875691500E-4f);
    p = _mm256_fmadd_ps(p, x, _mm256_set1_ps(1.3981999507E-3f));
    p = _mm256_fmadd_ps(p, x, _mm256_set1_ps(8.3334519073E-3f));
    p = _mm256_fmadd_ps(p, x, _mm256_set1_ps(4.1665795894E-2f));
    p = _mm256_fmadd_ps(p, x, _mm256_set1_ps(1.6666665459E-1f));
    p = _mm256_fmadd_ps(p, x, _mm256_set1_ps(5.0000001201E-1f));
    y = _mm256_fmadd_ps(p, z, _mm256_add_ps(x, _mm256_set1_ps(1.0f)));
    e = _mm256_slli_epi32(_mm256_add_epi32(_mm256_cvtps_epi32(fx), _mm256_set1_epi32(127)), 23);
    return _mm256_mul_ps(y, _mm256_castsi256_ps(e));
}
SUPERMAT__AVX2 static void supermat__silu_avx2(float *y, const float *x, int n) {
    int i = 0;
    for (; i + 8 <= n; i += 8) {
        __m256 v = _mm256_loadu_ps(x + i);
        __m256 e = supermat__exp_avx2(_mm256_sub_ps(_mm256_setzero_ps(), v));
        _mm256_storeu_ps(y + i, _mm256_div_ps(v, _mm256_add_ps(_mm256_set1_ps(1.0f), e)));
    }
    for (; i < n; i++) {
        __m256 v = _mm256_set1_ps(x[i]);
        __m256 e = supermat__exp_avx2(_mm256_sub_ps(_mm256_setzero_ps(), v));
        y[i] = _mm256_cvtss_f32(_mm256_div_ps(v, _mm256_add_ps(_mm256_set1_ps(1.0f), e)));
    }
}
/* one row of the online softmax: s *= scale, new running max, s = exp(s - max), running sum;
   returns the factor that rescales the previous partial output */
SUPERMAT__AVX2 static float supermat__softmax_block_avx2(float *s, int n, float scale, float *mrow, float *lrow) {
    __m256 vs = _mm256_set1_ps(scale), vmax = _mm256_set1_ps(-INFINITY), vsum = _mm256_setzero_ps();
    float mx, mnew, corr, sum, tmp[8];
    int c = 0, i;
    for (; c + 8 <= n; c += 8) {
        __m256 v = _mm256_mul_ps(_mm256_loadu_ps(s + c), vs);
        _mm256_storeu_ps(s + c, v);
        vmax = _mm256_max_ps(vmax, v);
    }
    _mm256_storeu_ps(tmp, vmax);
    mx = tmp[0];
    for (i = 1; i < 8; i++) mx = tmp[i] > mx ? tmp[i] : mx;
    for (; c < n; c++) { s[c] *= scale; if (s[c] > mx) mx = s[c]; }
    mnew = *mrow > mx ? *mrow : mx;
    corr = *mrow == -INFINITY ? 0.0f : expf(*mrow - mnew);
    {
        __m256 vm = _mm256_set1_ps(mnew);
        for (c = 0; c + 8 <= n; c += 8) {
            __m256 e = supermat__exp_avx2(_mm256_sub_ps(_mm256_loadu_ps(s + c), vm));
            _mm256_storeu_ps(s + c, e);
            vsum = _mm256_add_ps(vsum, e);
        }
        _mm256_storeu_ps(tmp, vsum);
        sum = ((tmp[0] + tmp[4]) + (tmp[1] + tmp[5])) + ((tmp[2] + tmp[6]) + (tmp[3] + tmp[7]));
        for (; c < n; c++) {
            s[c] = _mm256_cvtss_f32(supermat__exp_avx2(_mm256_set1_ps(s[c] - mnew)));
            sum += s[c];
        }
    }
    *lrow = *lrow * corr + sum;
    *mrow = mnew;
    return corr;
}
#endif
#if SUPERMAT__HAS_NEON
/* the AVX2 functions above on 4 lanes: the same range reduction, polynomial and clamps */
static float32x4_t supermat__exp_neon(float32x4_t x) {
    float32x4_t fx, y, z, p;
    int32x4_t e;
    x = vminq_f32(x, vdupq_n_f32(88.3762626647949f));
    x = vmaxq_f32(x, vdupq_n_f32(-87.3365447505531f));
    fx = vrndnq_f32(vmulq_f32(x, vdupq_n_f32(1.44269504088896341f)));
    x = vfmsq_f32(x, fx, vdupq_n_f32(0.693359375f));
    x = vfmsq_f32(x, fx, vdupq_n_f32(-2.12194440e-4f));
    z = vmulq_f32(x, x);
    p = vdupq_n_f32(1.9875691500E-4f);
    p = vfmaq_f32(vdupq_n_f32(1.3981999507E-3f), p, x);
    p = vfmaq_f32(vdupq_n_f32(8.3334519073E-3f), p, x);
    p = vfmaq_f32(vdupq_n_f32(4.1665795894E-2f), p, x);
    p = vfmaq_f32(vdupq_n_f32(1.6666665459E-1f), p, x);
    p = vfmaq_f32(vdupq_n_f32(5.0000001201E-1f), p, x);
    y = vfmaq_f32(vaddq_f32(x, vdupq_n_f32(1.0f)), p, z);
    e = vshlq_n_s32(vaddq_s32(vcvtnq_s32_f32(fx), vdupq_n_s32(127)), 23);
    return vmulq_f32(y, vreinterpretq_f32_s32(e));
}
static void supermat__silu_neon(float *y, const float *x, int n) {
    int i = 0;
    for (; i + 4 <= n; i += 4) {
        float32x4_t v = vld1q_f32(x + i);
        vst1q_f32(y + i, vdivq_f32(v, vaddq_f32(vdupq_n_f32(1.0f), supermat__exp_neon(vnegq_f32(v)))));
    }
    for (; i < n; i++) {
        float32x4_t v = vdupq_n_f32(x[i]);
        y[i] = vgetq_lane_f32(vdivq_f32(v, vaddq_f32(vdupq_n_f32(1.0f), supermat__exp_neon(vnegq_f32(v)))), 0);
    }
}
static float supermat__softmax_block_neon(float *s, int n, float scale, float *mrow, float *lrow) {
    float32x4_t vs = vdupq_n_f32(scale), vmax = vdupq_n_f32(-INFINITY), vsum = vdupq_n_f32(0.0f);
    float mx, mnew, corr, sum;
    int c = 0;
    for (; c + 4 <= n; c += 4) {
        float32x4_t v = vmulq_f32(vld1q_f32(s + c), vs);
        vst1q_f32(s + c, v);
        vmax = vmaxq_f32(vmax, v);
    }
    mx = vmaxvq_f32(vmax);
    for (; c < n; c++) { s[c] *= scale; if (s[c] > mx) mx = s[c]; }
    mnew = *mrow > mx ? *mrow : mx;
    corr = *mrow == -INFINITY ? 0.0f : expf(*mrow - mnew);
    {
        float32x4_t vm = vdupq_n_f32(mnew);
        for (c = 0; c + 4 <= n; c += 4) {
            float32x4_t e = supermat__exp_neon(vsubq_f32(vld1q_f32(s + c), vm));
            vst1q_f32(s + c, e);
            vsum = vaddq_f32(vsum, e);
        }
        sum = (vgetq_lane_f32(vsum, 0) + vgetq_lane_f32(vsum, 2)) + (vgetq_lane_f32(vsum, 1) + vgetq_lane_f32(vsum, 3));
        for (; c < n; c++) {
            s[c] = vgetq_lane_f32(supermat__exp_neon(vdupq_n_f32(s[c] - mnew)), 0);
            sum += s[c];
        }
    }
    *lrow = *lrow * corr + sum;
    *mrow = mnew;
    return corr;
}
#endif
static void supermat__silu(const supermat__ctx *X, float *y, const float *x, int n) {
    int i;
#if SUPERMAT__HAS_AVX2
    if (X->avx2) { supermat__silu_avx2(y, x, n); return; }
#endif
#if SUPERMAT__HAS_NEON
    if (X->neon) { supermat__silu_neon(y, x, n); return; }
#endif
    (void)X;
    for (i = 0; i < n; i++) y[i] = x[i] / (1.0f + expf(-x[i]));
}
static float supermat__gelu(float x) { return 0.5f * x * (1.0f + erff(x * 0.70710678118654752f)); }

/* >>norm : GroupNorm (+SiLU) and LayerNorm, statistics in float64 */
typedef struct supermat__norm { const float *g, *b; int c; float eps; } supermat__norm;

/* GroupNorm statistics in two passes (mean, then squared deviations), each over fixed chunks of pixels
   read contiguously with per-channel float64 sums; the chunks are reduced in a fixed order, so the
   result does not depend on the thread count. */
#define SUPERMAT__GN_CHUNK 256
typedef struct supermat__gn_args {
    const supermat__ctx *X;
    const supermat__t *in; supermat__t *out;
    const supermat__norm *nm; int groups, silu, pass, cpi; /* chunks per image */
    double *part;             /* n x cpi x C partial sums */
    double *mean, *rstd;      /* n x groups */
    int rows_per_task;        /* pixel rows per apply task */
} supermat__gn_args;

/* Per-channel sums over the pixel rows [p0, p1) of x (C floats a row) into acc[C], in double: of x when mc is
   NULL, else of (x - mc[c])^2. Each channel is summed in row order; the vector versions (across channels) add
   the squares with explicit FMAs, so AVX2 and AVX-512 give the same bits whatever the compiler's contraction
   setting; the scalar one rounds square and sum apart (unless the compiler fuses them), a last-bit difference. */
static void supermat__gn_sum_scalar(const float *x, size_t p0, size_t p1, int C, int c0, const double *mc, double *acc) {
    size_t p;
    int c;
    for (c = c0; c < C; c++) acc[c] = 0.0;
    for (p = p0; p < p1; p++) { /* rows outside, channels inside: the memory in order */
        const float *r = x + p * C;
        if (!mc) for (c = c0; c < C; c++) acc[c] += (double)r[c];
        else for (c = c0; c < C; c++) { double d = (double)r[c] - mc[c], q = d * d; acc[c] += q; }
    }
}
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static void supermat__gn_sum_avx2(const float *x, size_t p0, size_t p1, int C, int c, const double *mc, double *acc) {
    size_t p;
    for (; c + 16 <= C; c += 16) {
        __m256d s0 = _mm256_setzero_pd(), s1 = s0, s2 = s0, s3 = s0;
        if (!mc) {
            for (p = p0; p < p1; p++) {
                const float *r = x + p * C + c;
                s0 = _mm256_add_pd(s0, _mm256_cvtps_pd(_mm_loadu_ps(r)));
                s1 = _mm256_add_pd(s1, _mm256_cvtps_pd(_mm_loadu_ps(r + 4)));
                s2 = _mm256_add_pd(s2, _mm256_cvtps_pd(_mm_loadu_ps(r + 8)));
                s3 = _mm256_add_pd(s3, _mm256_cvtps_pd(_mm_loadu_ps(r + 12)));
            }
        } else {
            __m256d m0 = _mm256_loadu_pd(mc + c), m1 = _mm256_loadu_pd(mc + c + 4), m2 = _mm256_loadu_pd(mc + c + 8),
                    m3 = _mm256_loadu_pd(mc + c + 12), d0, d1, d2, d3;
            for (p = p0; p < p1; p++) {
                const float *r = x + p * C + c;
                d0 = _mm256_sub_pd(_mm256_cvtps_pd(_mm_loadu_ps(r)), m0);
                d1 = _mm256_sub_pd(_mm256_cvtps_pd(_mm_loadu_ps(r + 4)), m1);
                d2 = _mm256_sub_pd(_mm256_cvtps_pd(_mm_loadu_ps(r + 8)), m2);
                d3 = _mm256_sub_pd(_mm256_cvtps_pd(_mm_loadu_ps(r + 12)), m3);
                s0 = _mm256_fmadd_pd(d0, d0, s0);
                s1 = _mm256_fmadd_pd(d1, d1, s1);
                s2 = _mm256_fmadd_pd(d2, d2, s2);
                s3 = _mm256_fmadd_pd(d3, d3, s3);
            }
        }
        _mm256_storeu_pd(acc + c, s0); _mm256_storeu_pd(acc + c + 4, s1);
        _mm256_storeu_pd(acc + c + 8, s2); _mm256_storeu_pd(acc + c + 12, s3);
    }
    supermat__gn_sum_scalar(x, p0, p1, C, c, mc, acc);
}
#endif
#if SUPERMAT__HAS_AVX512
/* (maskz: the plain cvtps_pd reads an undefined vector, which gcc 12 flags as maybe-uninitialized in C++) */
SUPERMAT__AVX512 static void supermat__gn_sum_avx512(const float *x, size_t p0, size_t p1, int C, const double *mc, double *acc) {
    size_t p;
    int c = 0;
    for (; c + 32 <= C; c += 32) {
        __m512d s0 = _mm512_setzero_pd(), s1 = s0, s2 = s0, s3 = s0;
        if (!mc) {
            for (p = p0; p < p1; p++) {
                const float *r = x + p * C + c;
                s0 = _mm512_add_pd(s0, _mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r)));
                s1 = _mm512_add_pd(s1, _mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r + 8)));
                s2 = _mm512_add_pd(s2, _mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r + 16)));
                s3 = _mm512_add_pd(s3, _mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r + 24)));
            }
        } else {
            __m512d m0 = _mm512_loadu_pd(mc + c), m1 = _mm512_loadu_pd(mc + c + 8), m2 = _mm512_loadu_pd(mc + c + 16),
                    m3 = _mm512_loadu_pd(mc + c + 24), d0, d1, d2, d3;
            for (p = p0; p < p1; p++) {
                const float *r = x + p * C + c;
                d0 = _mm512_sub_pd(_mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r)), m0);
                d1 = _mm512_sub_pd(_mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r + 8)), m1);
                d2 = _mm512_sub_pd(_mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r + 16)), m2);
                d3 = _mm512_sub_pd(_mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(r + 24)), m3);
                s0 = _mm512_fmadd_pd(d0, d0, s0);
                s1 = _mm512_fmadd_pd(d1, d1, s1);
                s2 = _mm512_fmadd_pd(d2, d2, s2);
                s3 = _mm512_fmadd_pd(d3, d3, s3);
            }
        }
        _mm512_storeu_pd(acc + c, s0); _mm512_storeu_pd(acc + c + 8, s1);
        _mm512_storeu_pd(acc + c + 16, s2); _mm512_storeu_pd(acc + c + 24, s3);
    }
    supermat__gn_sum_avx2(x, p0, p1, C, c, mc, acc);
}
#endif

#if SUPERMAT__HAS_NEON
/* supermat__gn_sum_avx2 on 2-lane doubles: 8 channels a block, each summed in pixel order (the squared
   deviations fused, as there), the channels past the last block by the scalar loop */
static void supermat__gn_sum_neon(const float *x, size_t p0, size_t p1, int C, const double *mc, double *acc) {
    size_t p;
    int c = 0;
    for (; c + 8 <= C; c += 8) {
        float64x2_t s0 = vdupq_n_f64(0.0), s1 = s0, s2 = s0, s3 = s0;
        if (!mc) {
            for (p = p0; p < p1; p++) {
                const float *r = x + p * C + c;
                float32x4_t a = vld1q_f32(r), b = vld1q_f32(r + 4);
                s0 = vaddq_f64(s0, vcvt_f64_f32(vget_low_f32(a)));
                s1 = vaddq_f64(s1, vcvt_high_f64_f32(a));
                s2 = vaddq_f64(s2, vcvt_f64_f32(vget_low_f32(b)));
                s3 = vaddq_f64(s3, vcvt_high_f64_f32(b));
            }
        } else {
            float64x2_t m0 = vld1q_f64(mc + c), m1 = vld1q_f64(mc + c + 2), m2 = vld1q_f64(mc + c + 4), m3 = vld1q_f64(mc + c + 6), d;
            for (p = p0; p < p1; p++) {
                const float *r = x + p * C + c;
                float32x4_t a = vld1q_f32(r), b = vld1q_f32(r + 4);
                d = vsubq_f64(vcvt_f64_f32(vget_low_f32(a)), m0); s0 = vfmaq_f64(s0, d, d);
                d = vsubq_f64(vcvt_high_f64_f32(a), m1); s1 = vfmaq_f64(s1, d, d);
                d = vsubq_f64(vcvt_f64_f32(vget_low_f32(b)), m2); s2 = vfmaq_f64(s2, d, d);
                d = vsubq_f64(vcvt_high_f64_f32(b), m3); s3 = vfmaq_f64(s3, d, d);
            }
        }
        vst1q_f64(acc + c, s0); vst1q_f64(acc + c + 2, s1); vst1q_f64(acc + c + 4, s2); vst1q_f64(acc + c + 6, s3);
    }
    supermat__gn_sum_scalar(x, p0, p1, C, c, mc, acc);
}
#endif
static void supermat__gn_stats_task(void *user, int index, int thread) {
    const supermat__gn_args *a = (const supermat__gn_args *)user;
    int img = index / a->cpi, ch = index % a->cpi, C = a->in->c, cg = C / a->groups, c;
    size_t hw = (size_t)a->in->h * a->in->w, p0 = (size_t)ch * SUPERMAT__GN_CHUNK, p1 = SUPERMAT__MIN(hw, p0 + SUPERMAT__GN_CHUNK);
    const float *x = a->in->d + (size_t)img * hw * C;
    double *acc = a->part + (size_t)index * C, *mc = NULL;
    if (a->pass == 1) { /* the group means per channel, in this thread's scratch (2 C floats, checked) */
        const double *mean = a->mean + (size_t)img * a->groups;
        mc = (double *)(void *)a->X->scratch[thread];
        for (c = 0; c < C; c++) mc[c] = mean[c / cg];
    }
#if SUPERMAT__HAS_AVX512
    if (a->X->avx512) { supermat__gn_sum_avx512(x, p0, p1, C, mc, acc); return; }
#endif
#if SUPERMAT__HAS_AVX2
    if (a->X->avx2) { supermat__gn_sum_avx2(x, p0, p1, C, 0, mc, acc); return; }
#endif
#if SUPERMAT__HAS_NEON
    if (a->X->neon) { supermat__gn_sum_neon(x, p0, p1, C, mc, acc); return; }
#endif
    supermat__gn_sum_scalar(x, p0, p1, C, 0, mc, acc);
}

static void supermat__gn_apply_task(void *user, int index, int thread) {
    const supermat__gn_args *a = (const supermat__gn_args *)user;
    int C = a->in->c, cg = C / a->groups, c;
    size_t hw = (size_t)a->in->h * a->in->w, total = hw * a->in->n;
    size_t p0 = (size_t)index * a->rows_per_task, p1 = SUPERMAT__MIN(total, p0 + (size_t)a->rows_per_task), p;
    float *scale = a->X->scratch[thread], *mean = scale + C;
    int img = -1;
    for (p = p0; p < p1; p++) {
        const float *x = a->in->d + p * C;
        float *y = a->out->d + p * C;
        if ((int)(p / hw) != img) {
            img = (int)(p / hw);
            for (c = 0; c < C; c++) {
                double m = a->mean[img * a->groups + c / cg], r = a->rstd[img * a->groups + c / cg];
                scale[c] = (float)(a->nm->g[c] * r);
                mean[c] = (float)m;
            }
        }
#if SUPERMAT__HAS_NEON
        if (a->X->neon) { /* the scalar loop's operations, 4 lanes at a time (no fused multiply-add) */
            for (c = 0; c + 4 <= C; c += 4)
                vst1q_f32(y + c, vaddq_f32(vmulq_f32(vsubq_f32(vld1q_f32(x + c), vld1q_f32(mean + c)), vld1q_f32(scale + c)), vld1q_f32(a->nm->b + c)));
            for (; c < C; c++) y[c] = (x[c] - mean[c]) * scale[c] + a->nm->b[c];
        } else
#endif
        for (c = 0; c < C; c++) y[c] = (x[c] - mean[c]) * scale[c] + a->nm->b[c];
        if (a->silu) supermat__silu(a->X, y, y, C);
    }
}

static void supermat__gn_reduce(supermat__gn_args *a, double *dst) {
    int img, g, k, c, C = a->in->c, cg = C / a->groups;
    double cnt = (double)a->in->h * a->in->w * cg;
    for (img = 0; img < a->in->n; img++)
        for (g = 0; g < a->groups; g++) {
            double s = 0.0;
            for (k = 0; k < a->cpi; k++) {
                const double *acc = a->part + ((size_t)img * a->cpi + k) * C + (size_t)g * cg;
                for (c = 0; c < cg; c++) s += acc[c];
            }
            dst[img * a->groups + g] = a->pass == 0 ? s / cnt : 1.0 / sqrt(s / cnt + (double)a->nm->eps);
        }
}

static void supermat__groupnorm(supermat__ctx *X, const supermat__t *in, supermat__t *out, const supermat__norm *nm, int groups, int silu) {
    supermat__gn_args a;
    size_t total, hw = (size_t)in->h * in->w;
    int cpi = (int)((hw + SUPERMAT__GN_CHUNK - 1) / SUPERMAT__GN_CHUNK);
    double *part = (double *)(void *)supermat__get(X, 2 * (size_t)in->n * cpi * in->c);
    if (supermat__live(X)) {
        if ((size_t)in->n * groups > X->gn_cap || in->c % groups || 2 * (size_t)in->c > X->scratch_floats) X->status = SUPERMAT_ERROR_INTERNAL;
        else {
            a.X = X; a.in = in; a.out = out; a.nm = nm; a.groups = groups; a.silu = silu; a.cpi = cpi; a.part = part;
            a.mean = X->gn_stats;
            a.rstd = a.mean + (size_t)in->n * groups;
            for (a.pass = 0; a.pass < 2; a.pass++) {
                supermat__par(X, in->n * cpi, supermat__gn_stats_task, &a);
                supermat__gn_reduce(&a, a.pass == 0 ? a.mean : a.rstd);
            }
            total = (size_t)in->n * hw;
            a.rows_per_task = 64;
            supermat__par(X, (int)((total + 63) / 64), supermat__gn_apply_task, &a);
        }
    }
    supermat__put(X, part);
}

/* LayerNorm rows: the sums in float64 over 8 interleaved lanes (channel c adds to lane c mod 8), reduced as
   ((l0 + l4) + (l1 + l5)) + ((l2 + l6) + (l3 + l7)); mean first, then the squared deviations (d d added, never
   fused); y = (float)((x - mean) rstd) g + b.  Every kernel runs these operations in this order (AVX2: two
   4-lane accumulators, NEON: four 2-lane ones, scalar: 8 doubles; the tails are scalar on all), so LayerNorm
   gives the same bits on every kernel (where the compiler fuses no scalar multiply-add: ISO C mode does not).  pass 0: the lanes of sum x; 1: of sum (x - mean)^2; 2: the output. */
static double supermat__ln_reduce(const double *l) { return ((l[0] + l[4]) + (l[1] + l[5])) + ((l[2] + l[6]) + (l[3] + l[7])); }
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static int supermat__ln_avx2(int pass, const float *x, int C, double mean, double rstd, const float *g, const float *b, float *y, double *l) {
    __m256d a0 = _mm256_setzero_pd(), a1 = _mm256_setzero_pd(), vm = _mm256_set1_pd(mean), vr = _mm256_set1_pd(rstd);
    int c = 0;
    for (; c + 8 <= C; c += 8) {
        __m256d x0 = _mm256_cvtps_pd(_mm_loadu_ps(x + c)), x1 = _mm256_cvtps_pd(_mm_loadu_ps(x + c + 4));
        if (pass == 0) { a0 = _mm256_add_pd(a0, x0); a1 = _mm256_add_pd(a1, x1); continue; }
        x0 = _mm256_sub_pd(x0, vm); x1 = _mm256_sub_pd(x1, vm);
        if (pass == 1) { a0 = _mm256_add_pd(a0, _mm256_mul_pd(x0, x0)); a1 = _mm256_add_pd(a1, _mm256_mul_pd(x1, x1)); continue; }
        {
            __m256 v = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_mul_pd(x1, vr)), _mm256_cvtpd_ps(_mm256_mul_pd(x0, vr)));
            _mm256_storeu_ps(y + c, _mm256_add_ps(_mm256_mul_ps(v, _mm256_loadu_ps(g + c)), _mm256_loadu_ps(b + c)));
        }
    }
    if (pass < 2) { _mm256_storeu_pd(l, a0); _mm256_storeu_pd(l + 4, a1); }
    return c;
}
#endif
#if SUPERMAT__HAS_NEON
static int supermat__ln_neon(int pass, const float *x, int C, double mean, double rstd, const float *g, const float *b, float *y, double *l) {
    float64x2_t a0 = vdupq_n_f64(0.0), a1 = a0, a2 = a0, a3 = a0, vm = vdupq_n_f64(mean), vr = vdupq_n_f64(rstd);
    int c = 0;
    for (; c + 8 <= C; c += 8) {
        float32x4_t f0 = vld1q_f32(x + c), f1 = vld1q_f32(x + c + 4);
        float64x2_t x0 = vcvt_f64_f32(vget_low_f32(f0)), x1 = vcvt_high_f64_f32(f0), x2 = vcvt_f64_f32(vget_low_f32(f1)), x3 = vcvt_high_f64_f32(f1);
        if (pass == 0) { a0 = vaddq_f64(a0, x0); a1 = vaddq_f64(a1, x1); a2 = vaddq_f64(a2, x2); a3 = vaddq_f64(a3, x3); continue; }
        x0 = vsubq_f64(x0, vm); x1 = vsubq_f64(x1, vm); x2 = vsubq_f64(x2, vm); x3 = vsubq_f64(x3, vm);
        if (pass == 1) {
            a0 = vaddq_f64(a0, vmulq_f64(x0, x0)); a1 = vaddq_f64(a1, vmulq_f64(x1, x1));
            a2 = vaddq_f64(a2, vmulq_f64(x2, x2)); a3 = vaddq_f64(a3, vmulq_f64(x3, x3));
            continue;
        }
        {
            float32x4_t v0 = vcvt_high_f32_f64(vcvt_f32_f64(vmulq_f64(x0, vr)), vmulq_f64(x1, vr));
            float32x4_t v1 = vcvt_high_f32_f64(vcvt_f32_f64(vmulq_f64(x2, vr)), vmulq_f64(x3, vr));
            vst1q_f32(y + c, vaddq_f32(vmulq_f32(v0, vld1q_f32(g + c)), vld1q_f32(b + c)));
            vst1q_f32(y + c + 4, vaddq_f32(vmulq_f32(v1, vld1q_f32(g + c + 4)), vld1q_f32(b + c + 4)));
        }
    }
    if (pass < 2) { vst1q_f64(l, a0); vst1q_f64(l + 2, a1); vst1q_f64(l + 4, a2); vst1q_f64(l + 6, a3); }
    return c;
}
#endif
static void supermat__ln_row(const supermat__ctx *X, const float *x, float *y, int C, float eps, const float *g, const float *b) {
    double l[8], mean = 0.0, rstd = 0.0;
    int pass, c, c0;
    for (pass = 0; pass < 3; pass++) {
        c0 = 0;
        memset(l, 0, sizeof l);
#if SUPERMAT__HAS_AVX2
        if (X->avx2) c0 = supermat__ln_avx2(pass, x, C, mean, rstd, g, b, y, l);
#endif
#if SUPERMAT__HAS_NEON
        if (X->neon) c0 = supermat__ln_neon(pass, x, C, mean, rstd, g, b, y, l);
#endif
        for (c = c0; c < C; c++) {
            double d = (double)x[c] - mean;
            if (pass == 0) l[c & 7] += x[c];
            else if (pass == 1) { double dd = d * d; l[c & 7] += dd; }
            else y[c] = (float)(d * rstd) * g[c] + b[c];
        }
        if (pass == 0) mean = supermat__ln_reduce(l) / C;
        if (pass == 1) rstd = 1.0 / sqrt(supermat__ln_reduce(l) / C + (double)eps);
    }
    (void)X;
}
typedef struct supermat__ln_args { const supermat__ctx *X; const float *x; float *y; int C; float eps; const float *g, *b; int rows, M; } supermat__ln_args;
static void supermat__ln_task(void *user, int index, int thread) {
    const supermat__ln_args *a = (const supermat__ln_args *)user;
    int r0 = index * a->rows, r1 = SUPERMAT__MIN(a->M, r0 + a->rows), r;
    (void)thread;
    for (r = r0; r < r1; r++) supermat__ln_row(a->X, a->x + (size_t)r * a->C, a->y + (size_t)r * a->C, a->C, a->eps, a->g, a->b);
}
static void supermat__layernorm(supermat__ctx *X, const float *x, float *y, int M, const supermat__norm *nm) {
    supermat__ln_args a;
    if (!supermat__live(X)) return;
    a.X = X; a.x = x; a.y = y; a.C = nm->c; a.eps = nm->eps; a.g = nm->g; a.b = nm->b; a.rows = 16; a.M = M;
    supermat__par(X, (M + 15) / 16, supermat__ln_task, &a);
}

/* GEGLU: y[m, j] = h[m, j] * gelu(h[m, H + j]) with h [M, 2H].  The SIMD rows take erf from erfc's
   Chebyshev fit (Numerical Recipes' erfcc: relative error under 1.2e-7 for every argument, so 1 + erf(x) keeps
   its relative accuracy where x is very negative): gelu(x) = x/2 (2 - E) for x >= 0, x/2 E otherwise, with
   E = erfc(|x| / sqrt 2) = t exp(-z^2 + P(t)), t = 1 / (1 + z/2); one exp, one division.  NaN stays NaN
   (t is NaN), gelu(+Inf) = +Inf, gelu(-Inf) = NaN as with erff.  The scalar rows keep libm's erff. */
#define SUPERMAT__ERFC_POLY(FMA, SET, t) \
    FMA(FMA(FMA(FMA(FMA(FMA(FMA(FMA(FMA(SET(0.17087277f), t, SET(-0.82215223f)), t, SET(1.48851587f)), t, SET(-1.13520398f)), t, \
    SET(0.27886807f)), t, SET(-0.18628806f)), t, SET(0.09678418f)), t, SET(0.37409196f)), t, SET(1.00002368f)), t, SET(-1.26551223f))
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static __m256 supermat__gelu_avx2(__m256 x) {
    __m256 z = _mm256_mul_ps(_mm256_andnot_ps(_mm256_set1_ps(-0.0f), x), _mm256_set1_ps(0.70710678118654752f));
    __m256 t = _mm256_div_ps(_mm256_set1_ps(1.0f), _mm256_fmadd_ps(z, _mm256_set1_ps(0.5f), _mm256_set1_ps(1.0f)));
    __m256 e = _mm256_mul_ps(t, supermat__exp_avx2(_mm256_fnmadd_ps(z, z, SUPERMAT__ERFC_POLY(_mm256_fmadd_ps, _mm256_set1_ps, t))));
    __m256 one_p = _mm256_blendv_ps(e, _mm256_sub_ps(_mm256_set1_ps(2.0f), e), _mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_GE_OQ));
    return _mm256_mul_ps(_mm256_mul_ps(x, _mm256_set1_ps(0.5f)), one_p);
}
SUPERMAT__AVX2 static void supermat__geglu_row_avx2(float *y, const float *h, int H) {
    int j = 0;
    for (; j + 8 <= H; j += 8) _mm256_storeu_ps(y + j, _mm256_mul_ps(_mm256_loadu_ps(h + j), supermat__gelu_avx2(_mm256_loadu_ps(h + H + j))));
    for (; j < H; j++) y[j] = h[j] * _mm256_cvtss_f32(supermat__gelu_avx2(_mm256_set1_ps(h[H + j])));
}
#endif
#if SUPERMAT__HAS_NEON
static float32x4_t supermat__fma_neon(float32x4_t a, float32x4_t b, float32x4_t c) { return vfmaq_f32(c, a, b); } /* a b + c */
static float32x4_t supermat__gelu_neon(float32x4_t x) {
    float32x4_t z = vmulq_f32(vabsq_f32(x), vdupq_n_f32(0.70710678118654752f));
    float32x4_t t = vdivq_f32(vdupq_n_f32(1.0f), vfmaq_f32(vdupq_n_f32(1.0f), z, vdupq_n_f32(0.5f)));
    float32x4_t e = vmulq_f32(t, supermat__exp_neon(vfmsq_f32(SUPERMAT__ERFC_POLY(supermat__fma_neon, vdupq_n_f32, t), z, z)));
    float32x4_t one_p = vbslq_f32(vcgeq_f32(x, vdupq_n_f32(0.0f)), vsubq_f32(vdupq_n_f32(2.0f), e), e);
    return vmulq_f32(vmulq_f32(x, vdupq_n_f32(0.5f)), one_p);
}
static void supermat__geglu_row_neon(float *y, const float *h, int H) {
    int j = 0;
    for (; j + 4 <= H; j += 4) vst1q_f32(y + j, vmulq_f32(vld1q_f32(h + j), supermat__gelu_neon(vld1q_f32(h + H + j))));
    for (; j < H; j++) y[j] = h[j] * vgetq_lane_f32(supermat__gelu_neon(vdupq_n_f32(h[H + j])), 0);
}
#endif
typedef struct supermat__geglu_args { const supermat__ctx *X; const float *h; float *y; int H, M, rows; } supermat__geglu_args;
static void supermat__geglu_task(void *user, int index, int thread) {
    const supermat__geglu_args *a = (const supermat__geglu_args *)user;
    int r0 = index * a->rows, r1 = SUPERMAT__MIN(a->M, r0 + a->rows), r, j;
    (void)thread;
    for (r = r0; r < r1; r++) {
        const float *h = a->h + (size_t)r * 2 * a->H;
        float *y = a->y + (size_t)r * a->H;
#if SUPERMAT__HAS_AVX2
        if (a->X->avx2) { supermat__geglu_row_avx2(y, h, a->H); continue; }
#endif
#if SUPERMAT__HAS_NEON
        if (a->X->neon) { supermat__geglu_row_neon(y, h, a->H); continue; }
#endif
        for (j = 0; j < a->H; j++) y[j] = h[j] * supermat__gelu(h[a->H + j]);
    }
}
static void supermat__geglu(supermat__ctx *X, const float *h, float *y, int M, int H) {
    supermat__geglu_args a;
    if (!supermat__live(X)) return;
    a.X = X; a.h = h; a.y = y; a.H = H; a.M = M; a.rows = 16;
    supermat__par(X, (M + 15) / 16, supermat__geglu_task, &a);
}

/* >>attention : tiled, online softmax (memory linear in tokens, no score matrix). K and V are packed
   per (group, head) into the GEMM panel layout: K as panels of 16 keys (d x 16), V as panels of 16
   dims (keys x 16). Queries of group g attend to key group g (kv_groups == query groups) or to the
   one shared key set (kv_groups == 1). */
#define SUPERMAT__QB 48
#define SUPERMAT__KB 128

static size_t supermat__attn_kp_floats(int mk, int d) { return (size_t)((mk + 15) / 16) * 16 * d; }
static size_t supermat__attn_vp_floats(int mk, int d) { return (size_t)((d + 15) / 16) * 16 * mk; }

typedef struct supermat__attn_pack_args { const float *k, *v; size_t ldk, ldv; int mk, heads, d; float *kp, *vp; } supermat__attn_pack_args;
static void supermat__attn_pack_task(void *user, int index, int thread) {
    const supermat__attn_pack_args *a = (const supermat__attn_pack_args *)user;
    int g = index / a->heads, h = index % a->heads, d = a->d, j, dd, c, npk = (a->mk + 15) / 16, npv = (d + 15) / 16, key;
    float *kp = a->kp + (size_t)index * supermat__attn_kp_floats(a->mk, d);
    float *vp = a->vp + (size_t)index * supermat__attn_vp_floats(a->mk, d);
    const float *k = a->k + (size_t)g * a->mk * a->ldk + (size_t)h * d, *v = a->v + (size_t)g * a->mk * a->ldv + (size_t)h * d;
    (void)thread;
    for (j = 0; j < npk; j++)
        for (dd = 0; dd < d; dd++)
            for (c = 0; c < 16; c++) {
                key = j * 16 + c;
                *kp++ = key < a->mk ? k[(size_t)key * a->ldk + dd] : 0.0f;
            }
    for (j = 0; j < npv; j++)
        for (key = 0; key < a->mk; key++)
            for (c = 0; c < 16; c++) {
                dd = j * 16 + c;
                *vp++ = dd < d ? v[(size_t)key * a->ldv + dd] : 0.0f;
            }
}
/* pack `groups` groups of mk keys each */
static void supermat__attn_pack(supermat__ctx *X, const float *k, size_t ldk, const float *v, size_t ldv, int mk, int groups,
                                int heads, int d, float *kp, float *vp) {
    supermat__attn_pack_args a;
    if (!supermat__live(X)) return;
    a.k = k; a.v = v; a.ldk = ldk; a.ldv = ldv; a.mk = mk; a.heads = heads; a.d = d; a.kp = kp; a.vp = vp;
    supermat__par(X, groups * heads, supermat__attn_pack_task, &a);
}

typedef struct supermat__attn_args {
    const supermat__ctx *X;
    const float *q; size_t ldq; int mq; /* queries per group */
    const float *kp, *vp; int mk;      /* keys per group */
    int qgroups, kvgroups, heads, d, qblocks;
    float scale;
    float *o; size_t ldo;
} supermat__attn_args;

static void supermat__attn_task(void *user, int index, int thread) {
    const supermat__attn_args *a = (const supermat__attn_args *)user;
    int qb = index % a->qblocks, gh = index / a->qblocks, h = gh % a->heads, g = gh / a->heads;
    int kvg = a->kvgroups == 1 ? 0 : g, d = a->d, dpad = (d + 15) / 16 * 16, npv = dpad / 16;
    int q0 = qb * SUPERMAT__QB, nq = SUPERMAT__MIN(SUPERMAT__QB, a->mq - q0), r, j, kb, jd;
    const float *kp = a->kp + (size_t)(kvg * a->heads + h) * supermat__attn_kp_floats(a->mk, d);
    const float *vp = a->vp + (size_t)(kvg * a->heads + h) * supermat__attn_vp_floats(a->mk, d);
    float *S = a->X->scratch[thread], *O = S + SUPERMAT__QB * SUPERMAT__KB, *mrow = O + (size_t)SUPERMAT__QB * dpad, *lrow = mrow + SUPERMAT__QB;
    const float *qrows[SUPERMAT__QB];
    supermat__ukr_fn ukr = a->X->ukr;
    const int MR = a->X->mr > 0 ? a->X->mr : SUPERMAT__MR;
#if SUPERMAT__HAS_AVX512
    const int wide = ukr == supermat__ukr_avx512;
#else
    const int wide = 0;
#endif
    for (r = 0; r < nq; r++) qrows[r] = a->q + ((size_t)g * a->mq + q0 + r) * a->ldq + (size_t)h * d;
    for (r = 0; r < nq; r++) { mrow[r] = -INFINITY; lrow[r] = 0.0f; }
    memset(O, 0, sizeof(float) * (size_t)nq * dpad);
    for (kb = 0; kb < a->mk; kb += SUPERMAT__KB) {
        int nk = SUPERMAT__MIN(SUPERMAT__KB, a->mk - kb), npk = (nk + 15) / 16;
        for (j = 0; j < npk; j++) {
            const float *bp = kp + (size_t)(kb / 16 + j) * 16 * d;
            int two = wide && j + 1 < npk; /* key panels j and j + 1 together (AVX-512 12 x 32) */
            for (r = 0; r < nq; r += MR) {
                const float *rows[SUPERMAT__MRMAX];
                int mr = SUPERMAT__MIN(MR, nq - r), i;
                for (i = 0; i < MR; i++) rows[i] = qrows[r + (i < mr ? i : 0)];
#if SUPERMAT__HAS_AVX512
                if (two) { supermat__ukr2_avx512(d, rows, bp, bp + (size_t)16 * d, S + (size_t)r * SUPERMAT__KB + j * 16, SUPERMAT__KB, mr, 32, NULL, NULL, 0, 0, NULL); continue; }
#endif
                ukr(d, rows, bp, S + (size_t)r * SUPERMAT__KB + j * 16, SUPERMAT__KB, mr, 16, NULL, NULL, 0, 0);
            }
            j += two;
        }
        /* online softmax over this block */
        for (r = 0; r < nq; r++) {
            float *s = S + (size_t)r * SUPERMAT__KB, mnew, corr;
            int c;
#if SUPERMAT__HAS_AVX2
            if (a->X->avx2) corr = supermat__softmax_block_avx2(s, nk, a->scale, &mrow[r], &lrow[r]);
            else
#endif
#if SUPERMAT__HAS_NEON
            if (a->X->neon) corr = supermat__softmax_block_neon(s, nk, a->scale, &mrow[r], &lrow[r]);
            else
#endif
            {
                float mx = -INFINITY, sum = 0.0f;
                for (c = 0; c < nk; c++) { s[c] *= a->scale; if (s[c] > mx) mx = s[c]; }
                mnew = mrow[r] > mx ? mrow[r] : mx;
                corr = mrow[r] == -INFINITY ? 0.0f : expf(mrow[r] - mnew);
                for (c = 0; c < nk; c++) { s[c] = expf(s[c] - mnew); sum += s[c]; }
                lrow[r] = lrow[r] * corr + sum;
                mrow[r] = mnew;
            }
            if (corr != 1.0f) { float *o = O + (size_t)r * dpad; for (c = 0; c < dpad; c++) o[c] *= corr; }
        }
        for (jd = 0; jd < npv; jd++) {
            const float *bp = vp + ((size_t)jd * a->mk + kb) * 16;
            int two = wide && jd + 1 < npv; /* value panels jd and jd + 1 together */
            for (r = 0; r < nq; r += MR) {
                const float *rows[SUPERMAT__MRMAX];
                int mr = SUPERMAT__MIN(MR, nq - r), i;
                for (i = 0; i < MR; i++) rows[i] = S + (size_t)(r + (i < mr ? i : 0)) * SUPERMAT__KB;
#if SUPERMAT__HAS_AVX512
                if (two) { supermat__ukr2_avx512(nk, rows, bp, bp + (size_t)a->mk * 16, O + (size_t)r * dpad + jd * 16, (size_t)dpad, mr, 32, NULL, NULL, 0, 1, NULL); continue; }
#endif
                ukr(nk, rows, bp, O + (size_t)r * dpad + jd * 16, (size_t)dpad, mr, 16, NULL, NULL, 0, 1);
            }
            jd += two;
        }
    }
    for (r = 0; r < nq; r++) {
        float inv = 1.0f / lrow[r], *o = a->o + ((size_t)g * a->mq + q0 + r) * a->ldo + (size_t)h * d;
        const float *src = O + (size_t)r * dpad;
        int c;
        for (c = 0; c < d; c++) o[c] = src[c] * inv;
    }
}

static void supermat__attention(supermat__ctx *X, const float *q, size_t ldq, int mq, int qgroups, const float *kp, const float *vp,
                                int mk, int kvgroups, int heads, int d, float scale, float *o, size_t ldo) {
    supermat__attn_args a;
    X->flops += 4.0 * (double)mq * qgroups * mk * d * heads;
    if (!supermat__live(X)) return;
    a.X = X; a.q = q; a.ldq = ldq; a.mq = mq; a.kp = kp; a.vp = vp; a.mk = mk; a.qgroups = qgroups; a.kvgroups = kvgroups;
    a.heads = heads; a.d = d; a.scale = scale; a.o = o; a.ldo = ldo;
    a.qblocks = (mq + SUPERMAT__QB - 1) / SUPERMAT__QB;
    supermat__par(X, qgroups * heads * a.qblocks, supermat__attn_task, &a);
}

/* >>model : architecture, tensor binding with validation, weight packing */
#define SUPERMAT__MAXL 6
#define SUPERMAT__MAXLAYERS 5
#define SUPERMAT__MAXBRANCH 4

typedef struct supermat__resnet { supermat__norm n1, n2; supermat__conv c1, c2, sc; int has_sc; supermat__pw temb; int cin, cout; } supermat__resnet;
typedef struct supermat__xformer {
    char name[72];      /* the module path, e.g. "down_blocks.1.attentions.0" */
    supermat__norm gn, ln1, ln2, ln3;
    supermat__pw proj_in, proj_out, qkv1, out1, q2, out2, ff1, ff2;
    float *kp2, *vp2;   /* cross-attention K/V of the constant context, packed */
    int c, heads, d, mv; /* mv: self-attention over the keys of all views */
} supermat__xformer;
typedef struct supermat__vattn { supermat__norm gn; supermat__pw qkv, out; int c; } supermat__vattn;
typedef struct supermat__level {
    supermat__resnet res[SUPERMAT__MAXLAYERS];
    supermat__xformer att[SUPERMAT__MAXLAYERS];
    int nres, has_attn, has_sampler, cout;
    supermat__conv sampler;
} supermat__level;

struct supermat_model {
    supermat_allocator alloc;
    supermat_model_info info;
    /* unet */
    int L, lpb, groups, ctx_tokens, ctx_dim, branches, class_in, temb_dim, in_ch, out_ch, cross_dim;
    int boc[SUPERMAT__MAXL], heads[SUPERMAT__MAXL], down_attn[SUPERMAT__MAXL], up_attn[SUPERMAT__MAXL];
    float eps, x0_coef;
    int flip_sin_to_cos;
    float freq_shift;
    supermat__pw time1, time2, cls1, cls2;
    supermat__conv conv_in, conv_out[SUPERMAT__MAXBRANCH];
    supermat__level down[SUPERMAT__MAXL], up[SUPERMAT__MAXL], last[SUPERMAT__MAXBRANCH];
    supermat__resnet mid_res[2];
    supermat__xformer mid_att;
    supermat__norm norm_out;
    /* vae */
    int vL, vlpb, vgroups, latent, vin, vout;
    int vboc[SUPERMAT__MAXL];
    float sf;
    supermat__conv e_conv_in, e_conv_out, quant, post_quant, d_conv_in, d_conv_out;
    supermat__level e_lv[SUPERMAT__MAXL], d_lv[SUPERMAT__MAXL];
    supermat__resnet e_mid[2], d_mid[2];
    supermat__vattn e_att, d_att;
    supermat__norm e_norm_out, d_norm_out;
    /* memory owned by the model */
    void **blocks;
    size_t *block_sizes;
    int nblocks, cap_blocks;
};

typedef struct supermat__loader {
    supermat_model *m;
    const unsigned char *data;
    size_t size;
    int copy;
    supermat_tensor_info *ti;
    unsigned char *used;
    int nt;
    const char *js;
    supermat_json_tok *toks;
    int meta;               /* token index of __metadata__ or -1 */
    supermat_error *err;
    supermat_result r;
    uint64_t params;
    size_t cap;             /* model_desc.max_memory */
    int avx2;
    int weights;            /* requested supermat_weights */
    int conv;               /* requested supermat_conv */
    int keep_f32;           /* supermat__pack leaves the f32 panels (they are transformed next) */
    int bf16c;              /* SUPERMAT_COMPUTE_BF16: GEMM weights as bf16 pairs (fmt 4) */
    int i8c;                /* SUPERMAT_COMPUTE_INT8: GEMM weights as int8 quads (fmt 5) */
    int *qsc;               /* per tensor: its scale tensor (I8) or -1 */
    /* pre-packed models (PRE-PACKED MODELS in the manual) */
    const unsigned char *pk;     /* the panels (tensor supermat.packed.data) when the file is pre-packed */
    uint64_t pk_size;
    const unsigned char *pk_idx; /* SUPERMAT__PKF int64 per record (tensor supermat.packed.index) */
    int pk_n, pk_next;
    struct supermat__pkrec *rec; /* supermat_model_write_packed: what gets packed, in order */
} supermat__loader;

/* A pre-packed model's index: one record of SUPERMAT__PKF little-endian int64 per packed weight, in the
   order model creation packs them: kind (1 panels, 2 Winograd-transformed 3x3 convolution, 3 the packed
   keys and values of the empty-prompt context in one cross-attention: K = its channels, N = the context
   tokens), K, N, the panels' format (0 f32, 1 f16, 2 bf16, 3 int8, 4 bf16 pairs), the storage format
   before bf16 pairing (kind 1) or the Winograd tile a = m + 2 (kind 2), and the byte offsets in the panel
   blob of the panels (kind 3: the keys), the int8 scales (kind 3: the values) and the bias (-1 = none).
   Offsets are multiples of 64; sizes follow from K, N and the format and are never read from the file. */
#define SUPERMAT__PKF 8
typedef struct supermat__pkitem {
    supermat__pw *pw;            /* kind 1, 2 */
    const supermat__wino *wino;  /* kind 2 */
    int sfmt;
    const float *kp, *vp;        /* kind 3: a cross-attention's packed keys and values of the context */
    size_t kpn, vpn;             /* their floats */
    int c, tokens;
} supermat__pkitem;
typedef struct supermat__pkrec {
    supermat__pkitem *items;
    int n, cap;
    int *uses, *pkuses; /* per tensor: lookups, and lookups by the packing (a tensor only packed is left out) */
    int nt;             /* tensors in the file (the length of uses and pkuses, less one) */
} supermat__pkrec;

static void *supermat__mem(supermat__loader *L, size_t bytes) {
    supermat_model *m = L->m;
    void *p;
    if (L->r) return NULL;
    if (L->cap && (bytes > L->cap || m->info.model_bytes > L->cap - bytes)) {
        L->r = supermat__fail(L->err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "the model needs more than max_memory = %llu bytes (%.1f MiB): %llu held, %llu more asked; pre-pack it (`supermat pack`) or choose smaller weights",
                              (unsigned long long)L->cap, (double)L->cap / 1048576.0, (unsigned long long)m->info.model_bytes, (unsigned long long)bytes);
        return NULL;
    }
    if (m->nblocks == m->cap_blocks) {
        int nc = m->cap_blocks ? 2 * m->cap_blocks : 256;
        void **nb = (void **)supermat__alloc(&m->alloc, sizeof(void *) * (size_t)nc);
        size_t *ns = (size_t *)supermat__alloc(&m->alloc, sizeof(size_t) * (size_t)nc);
        if (!nb || !ns) {
            supermat__free(&m->alloc, nb, sizeof(void *) * (size_t)nc);
            supermat__free(&m->alloc, ns, sizeof(size_t) * (size_t)nc);
            L->r = supermat__fail(L->err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory (model bookkeeping)");
            return NULL;
        }
        if (m->nblocks) { memcpy(nb, m->blocks, sizeof(void *) * (size_t)m->nblocks); memcpy(ns, m->block_sizes, sizeof(size_t) * (size_t)m->nblocks); }
        supermat__free(&m->alloc, m->blocks, sizeof(void *) * (size_t)m->cap_blocks);
        supermat__free(&m->alloc, m->block_sizes, sizeof(size_t) * (size_t)m->cap_blocks);
        m->blocks = nb; m->block_sizes = ns; m->cap_blocks = nc;
    }
    p = supermat__alloc(&m->alloc, bytes);
    if (!p) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory allocating %llu bytes for the model", (unsigned long long)bytes); return NULL; }
    m->blocks[m->nblocks] = p; m->block_sizes[m->nblocks] = bytes; m->nblocks++;
    m->info.model_bytes += bytes;
    return p;
}

/* metadata */
static int supermat__meta_str(supermat__loader *L, const char *key, char *buf, size_t cap, int required) {
    int v = L->meta >= 0 ? supermat_json_find(L->js, L->toks, L->meta, key) : -1;
    if (v < 0 || supermat_json_string(L->js, &L->toks[v], buf, cap) < 0) {
        /* an optional key may be absent, never unreadable: a value that is no string or too long fails */
        if (v >= 0 && !L->r)
            L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata key '%s' is not a string of at most %d bytes", key, (int)cap - 1);
        else if (required && !L->r)
            L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata key '%s' is missing or not a string (convert the model with `supermat convert`)", key);
        buf[0] = 0;
        return -1;
    }
    return 0;
}
/* >>curve: the roughness and metallic calibration curves (session_desc.roughness_knots / metallic_knots,
   pipeline.roughness_curve / metallic_curve) */
/* 0 when n knots make a curve, else -1 and why */
static int supermat__curve_ok(const float *k, int n, char *why, size_t cap) {
    int i;
    if (n < 2 || n > SUPERMAT_CURVE_MAX_KNOTS) { snprintf(why, cap, "%d knot%s: from 2 to %d", n, n == 1 ? "" : "s", SUPERMAT_CURVE_MAX_KNOTS); return -1; }
    for (i = 0; i < n; i++) {
        if (!(k[i] >= 0.0f && k[i] <= 1.0f)) { snprintf(why, cap, "knot %d is %g: each in [0, 1]", i + 1, (double)k[i]); return -1; }
        if (i && k[i] < k[i - 1]) { snprintf(why, cap, "knot %d (%g) is below knot %d (%g): the curve never falls", i + 1, (double)k[i], i, (double)k[i - 1]); return -1; }
    }
    return 0;
}
static int supermat__curve_read(const char *text, float *k, int *count, char *why, size_t cap) {
    const char *p = text;
    int n = 0;
    *count = 0;
    for (;;) {
        char *end;
        double v;
        while (*p == ' ') p++;
        if (n == SUPERMAT_CURVE_MAX_KNOTS) { snprintf(why, cap, "more than %d knots", SUPERMAT_CURVE_MAX_KNOTS); return -1; }
        v = strtod(p, &end);
        if (end == p) { snprintf(why, cap, "knot %d is not a number", n + 1); return -1; }
        k[n++] = (float)v;
        p = end;
        while (*p == ' ') p++;
        if (!*p) break;
        if (*p != ',') { snprintf(why, cap, "'%c' after knot %d: numbers separated by commas", *p, n); return -1; }
        p++;
    }
    if (supermat__curve_ok(k, n, why, cap)) return -1;
    *count = n;
    return 0;
}
SUPERMAT__DEF supermat_result supermat_parse_curve(const char *text, float *knots, int *count, supermat_error *err) {
    char why[160];
    if (count) *count = 0;
    if (!text || !knots || !count) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "supermat_parse_curve: text, knots and count must not be NULL");
    if (supermat__curve_read(text, knots, count, why, sizeof why)) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "curve '%.64s': %s", text, why);
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}
/* the curve through (i / (n - 1), k[i]) at x, x clamped to [0, 1] */
static float supermat__curve_at(const float *k, int n, float x) {
    float t;
    int i;
    x = x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f; /* NaN -> 0 */
    t = x * (float)(n - 1);
    i = (int)t;
    if (i > n - 2) i = n - 2;
    return k[i] + (k[i + 1] - k[i]) * (t - (float)i);
}

static double supermat__meta_num(supermat__loader *L, const char *key, double lo, double hi, double def, int required) {
    char buf[64], *end;
    double x;
    if (supermat__meta_str(L, key, buf, sizeof buf, required)) return def;
    x = strtod(buf, &end);
    if (end == buf || *end || !(x >= lo && x <= hi)) {
        if (!L->r) L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata '%s' = '%s' is not a number in [%g, %g]", key, buf, lo, hi);
        return def;
    }
    return x;
}
static int supermat__meta_list(supermat__loader *L, const char *key, int *out, int maxn, int lo, int hi) {
    char buf[256], *p = buf, *end;
    int n = 0;
    if (supermat__meta_str(L, key, buf, sizeof buf, 1)) return 0;
    while (*p) {
        long v = strtol(p, &end, 10);
        if (end == p || v < lo || v > hi || n >= maxn) {
            if (!L->r) L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata '%s' = '%s' is not a list of at most %d integers in [%d, %d]", key, buf, maxn, lo, hi);
            return 0;
        }
        out[n++] = (int)v;
        p = end;
        if (*p == ',') p++;
    }
    return n;
}
static int supermat__meta_types(supermat__loader *L, const char *key, int *has_attn, int maxn) {
    char buf[512], *p = buf;
    int n = 0;
    if (supermat__meta_str(L, key, buf, sizeof buf, 1)) return 0;
    while (*p && n < maxn) {
        char *e = strchr(p, ',');
        if (e) *e = 0;
        if (!strcmp(p, "CrossAttnDownBlock2D") || !strcmp(p, "CrossAttnUpBlock2D")) has_attn[n++] = 1;
        else if (!strcmp(p, "DownBlock2D") || !strcmp(p, "UpBlock2D")) has_attn[n++] = 0;
        else { if (!L->r) L->r = supermat__fail(L->err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "block type '%s' in '%s' is not supported", p, key); return 0; }
        if (!e) break;
        p = e + 1;
    }
    return n;
}

/* tensors */
static int supermat__find_tensor(supermat__loader *L, const char *name) {
    int i;
    for (i = 0; i < L->nt; i++) if (!strcmp(L->ti[i].name, name)) return i;
    return -1;
}
/* Finds `name` and checks its shape (-1 in want = any). Returns the index or -1 (error set). */
static int supermat__wtensor(supermat__loader *L, const char *name, int ndim, const int64_t *want) {
    int i, k;
    if (L->r) return -1;
    i = supermat__find_tensor(L, name);
    if (i < 0) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_MISSING_TENSOR, name, "tensor '%s' is missing from the model file", name); return -1; }
    if (L->ti[i].ndim != ndim) goto bad;
    for (k = 0; k < ndim; k++) if (want[k] >= 0 && L->ti[i].shape[k] != want[k]) goto bad;
    L->used[i] = 1;
    if (L->rec) L->rec->uses[i]++;
    return i;
bad: {
        char exp[96], got[96];
        size_t o = 0;
        exp[0] = got[0] = 0;
        for (k = 0; k < ndim && o < sizeof exp - 24; k++) o += (size_t)snprintf(exp + o, sizeof exp - o, k ? ", %lld" : "%lld", (long long)want[k]);
        o = 0;
        for (k = 0; k < L->ti[i].ndim && o < sizeof got - 24; k++) o += (size_t)snprintf(got + o, sizeof got - o, k ? ", %lld" : "%lld", (long long)L->ti[i].shape[k]);
        L->r = supermat__fail(L->err, SUPERMAT_ERROR_SHAPE_MISMATCH, name, "tensor '%s' has shape [%s], the architecture needs [%s]", name, got, exp);
        return -1;
    }
}
static float supermat__tval(const supermat__loader *L, int t, size_t i) {
    const supermat_tensor_info *ti = &L->ti[t];
    if (ti->dtype == SUPERMAT_DTYPE_I8) { /* q * scale[row][tap][c / QG] (the shapes were checked at load) */
        size_t taps = ti->ndim == 4 ? (size_t)(ti->shape[2] * ti->shape[3]) : 1, cin = (size_t)ti->shape[1], per = cin * taps;
        size_t row = i / per, rem = i % per, c = rem / taps, tap = rem % taps, ng = (cin + SUPERMAT__QG - 1) / SUPERMAT__QG;
        float sc;
        memcpy(&sc, L->data + L->ti[L->qsc[t]].offset + 4 * ((row * taps + tap) * ng + c / SUPERMAT__QG), 4);
        return (float)(signed char)L->data[ti->offset + i] * sc;
    }
    return supermat__load_elem(L->data + ti->offset, ti->dtype, i);
}
/* I8 tensors: their F32 `<name>_scale` [rows][taps][ceil(cin/QG)], finite and >= 0 (into L->qsc) */
static void supermat__check_i8(supermat__loader *L) {
    int t, k;
    for (t = 0; t < L->nt && !L->r; t++) {
        const supermat_tensor_info *ti = &L->ti[t];
        char sn[sizeof ti->name + 8];
        int s;
        size_t n, i;
        int64_t taps, ng;
        L->qsc[t] = -1;
        if (ti->dtype != SUPERMAT_DTYPE_I8) continue;
        if (ti->ndim != 2 && ti->ndim != 4) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, ti->name, "I8 tensor '%s' has %d dimensions (int8 weights are [rows][cin] or [rows][cin][kh][kw])", ti->name, ti->ndim); return; }
        for (k = 0; k < ti->ndim; k++) if (ti->shape[k] <= 0 || ti->shape[k] > 0x7fffffff) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, ti->name, "I8 tensor '%s' has an empty or huge dimension", ti->name); return; }
        taps = ti->ndim == 4 ? ti->shape[2] * ti->shape[3] : 1;
        ng = (ti->shape[1] + SUPERMAT__QG - 1) / SUPERMAT__QG;
        supermat__name(sn, sizeof sn, "%s_scale", ti->name);
        s = supermat__find_tensor(L, sn);
        if (s < 0) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_MISSING_TENSOR, sn, "I8 tensor '%s' has no scale tensor '%s'", ti->name, sn); return; }
        if (L->ti[s].dtype != SUPERMAT_DTYPE_F32 || L->ti[s].ndim != 3 || L->ti[s].shape[0] != ti->shape[0] || L->ti[s].shape[1] != taps || L->ti[s].shape[2] != ng) {
            L->r = supermat__fail(L->err, SUPERMAT_ERROR_SHAPE_MISMATCH, sn, "scale tensor '%s' must be F32 [%lld, %lld, %lld] (rows, kernel taps, input channels / %d)", sn,
                                  (long long)ti->shape[0], (long long)taps, (long long)ng, SUPERMAT__QG);
            return;
        }
        n = (size_t)(L->ti[s].nbytes / 4);
        for (i = 0; i < n; i++) {
            float v;
            memcpy(&v, L->data + L->ti[s].offset + 4 * i, 4);
            if (!(v - v == 0.0f)) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_NONFINITE, sn, "scale tensor '%s' contains NaN or Inf", sn); return; }
            if (v < 0.0f) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, sn, "scale tensor '%s' has a negative scale %g", sn, (double)v); return; }
        }
        L->qsc[t] = s;
        L->used[s] = 1;
    }
}
/* the f32 values of a 1-D tensor of c elements: borrowed when possible, else converted */
static const float *supermat__vec(supermat__loader *L, const char *name, int c, int pad16) {
    int64_t want[1];
    int t;
    size_t i, n;
    float *dst;
    want[0] = c;
    t = supermat__wtensor(L, name, 1, want);
    if (t < 0) return NULL;
    n = pad16 ? (size_t)(c + 15) / 16 * 16 : (size_t)c;
    if (!pad16 && !L->copy && L->ti[t].dtype == SUPERMAT_DTYPE_F32 && ((uintptr_t)(L->data + L->ti[t].offset) & 3) == 0) {
        const float *p = (const float *)(const void *)(L->data + L->ti[t].offset);
        for (i = 0; i < (size_t)c; i++) if (!(p[i] - p[i] == 0.0f)) goto nonfinite;
        L->params += (uint64_t)c;
        return p;
    }
    dst = (float *)supermat__mem(L, n * sizeof(float));
    if (!dst) return NULL;
    for (i = 0; i < n; i++) {
        dst[i] = i < (size_t)c ? supermat__tval(L, t, i) : 0.0f;
        if (!(dst[i] - dst[i] == 0.0f)) goto nonfinite;
    }
    L->params += (uint64_t)c;
    return dst;
nonfinite:
    L->r = supermat__fail(L->err, SUPERMAT_ERROR_NONFINITE, name, "tensor '%s' contains NaN or Inf", name);
    return NULL;
}

/* symmetric int8 of n values v[i * stride]: q[i] = rint(v / s) within +-127, s = max |v| / 127 (returned) */
static float supermat__q8_run(const float *v, size_t stride, int n, int *q) {
    float mx = 0.0f, inv;
    int i;
    for (i = 0; i < n; i++) { float a = fabsf(v[(size_t)i * stride]); if (a > mx) mx = a; }
    inv = mx > 0.0f ? 127.0f / mx : 0.0f;
    for (i = 0; i < n; i++) {
        float r = rintf(v[(size_t)i * stride] * inv);
        q[i] = r > 127.0f ? 127 : r < -127.0f ? -127 : (int)r;
    }
    return mx / 127.0f;
}
/* converts packed f32 panels (K x 16 each) to f16 / bf16 / int8 panels of the same layout; int8 takes
   one symmetric scale (max |w| / 127) per column per group of rows (supermat__qgroup). Returns -1 if a
   value does not fit f16 (first such index in *bad). */
static int supermat__quantize_panels(const float *p, size_t total, int K, int N, int qcin, int fmt, void *qv, float *qs, size_t *bad) {
    size_t i;
    int np = (N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    if (fmt == 1) {
        uint16_t *q = (uint16_t *)qv;
        for (i = 0; i < total; i++) {
            if (fabsf(p[i]) > 65504.0f) { *bad = i; return -1; }
            q[i] = supermat__f32_to_f16(p[i]);
        }
    } else if (fmt == 2) {
        uint16_t *q = (uint16_t *)qv;
        for (i = 0; i < total; i++) q[i] = supermat__f32_to_bf16(p[i]);
    } else {
        signed char *q = (signed char *)qv;
        int pnl, c, k, k0, k1, grp;
        for (pnl = 0; pnl < np; pnl++)
            for (k0 = 0; k0 < K; k0 = k1) {
                grp = supermat__qgroup(k0, qcin, &k1);
                for (c = 0; c < SUPERMAT__NR; c++) {
                    int iq[SUPERMAT__QG];
                    size_t o = ((size_t)pnl * K + k0) * SUPERMAT__NR + c;
                    qs[(size_t)grp * np * SUPERMAT__NR + (size_t)pnl * SUPERMAT__NR + c] = supermat__q8_run(p + o, SUPERMAT__NR, k1 - k0, iq);
                    for (k = k0; k < k1; k++) q[o + (size_t)(k - k0) * SUPERMAT__NR] = (signed char)iq[k - k0];
                }
            }
    }
    return 0;
}

/* frees one of the model's blocks */
static void supermat__release(supermat__loader *L, const void *p) {
    supermat_model *m = L->m;
    int i;
    for (i = m->nblocks - 1; i >= 0; i--)
        if (m->blocks[i] == p) {
            supermat__free(&m->alloc, m->blocks[i], m->block_sizes[i]);
            m->info.model_bytes -= m->block_sizes[i];
            m->blocks[i] = NULL; m->block_sizes[i] = 0;
            return;
        }
}
/* f32 panels [K][16] -> bf16 pair panels [ceil(K/2)][16][2] (round to nearest even; an odd K pads a 0) */
static void supermat__bf16_pairs(supermat__loader *L, supermat__pw *pw) {
    int np = (pw->N + SUPERMAT__NR - 1) / SUPERMAT__NR, K2 = (pw->K + 1) / 2, pnl, k, c;
    uint16_t *q = (uint16_t *)supermat__mem(L, (size_t)np * K2 * 32 * sizeof(uint16_t));
    if (L->r) return;
    for (pnl = 0; pnl < np; pnl++)
        for (k = 0; k < 2 * K2; k++)
            for (c = 0; c < SUPERMAT__NR; c++)
                q[(((size_t)pnl * K2 + k / 2) * SUPERMAT__NR + c) * 2 + (k & 1)] =
                    k < pw->K ? supermat__f32_to_bf16(pw->p[((size_t)pnl * pw->K + k) * SUPERMAT__NR + c]) : 0;
    pw->q = q;
    pw->fmt = 4;
    supermat__release(L, pw->p);
    pw->p = NULL;
}
/* one weight of f32 panels (fmt 0) or int8 panels with group scales (fmt 3), as float */
static float supermat__pw_value(const supermat__pw *pw, int pnl, int k, int c) {
    size_t o = ((size_t)pnl * pw->K + k) * SUPERMAT__NR + c;
    int end, grp;
    if (pw->fmt == 0) return pw->p[o];
    grp = supermat__qgroup(k, pw->qcin, &end);
    return (float)((const signed char *)pw->q)[o] * pw->qs[(size_t)grp * ((pw->N + SUPERMAT__NR - 1) / SUPERMAT__NR) * SUPERMAT__NR + (size_t)pnl * SUPERMAT__NR + c];
}
/* f32 or int8 panels -> int8-compute panels (fmt 5): s8 quads [ceil(K/4)][16][4] per panel (zero past K),
   a scale per column per 64 rows of K (max |w| / 127, q = rint(w / s)), then 128 x each chunk's column
   sums (int32); the old panels are released */
static void supermat__i8_quads(supermat__loader *L, supermat__pw *pw) {
    int np = (pw->N + SUPERMAT__NR - 1) / SUPERMAT__NR, K4 = (pw->K + 3) / 4, nch = (pw->K + 63) / 64, pnl, c, j, k;
    size_t cst = (size_t)np * SUPERMAT__NR;
    signed char *q = (signed char *)supermat__mem(L, (size_t)np * K4 * 64);
    float *qs = (float *)supermat__mem(L, sizeof(float) * 2 * (size_t)nch * cst);
    int32_t *cor;
    if (L->r) return;
    cor = (int32_t *)(qs + (size_t)nch * cst);
    memset(q, 0, (size_t)np * K4 * 64);
    for (pnl = 0; pnl < np; pnl++)
        for (c = 0; c < SUPERMAT__NR; c++)
            for (j = 0; j < nch; j++) {
                int k0 = 64 * j, k1 = SUPERMAT__MIN(pw->K, k0 + 64), iq[64];
                int32_t sum = 0;
                float v[64];
                for (k = k0; k < k1; k++) v[k - k0] = supermat__pw_value(pw, pnl, k, c);
                qs[(size_t)j * cst + (size_t)pnl * SUPERMAT__NR + c] = supermat__q8_run(v, 1, k1 - k0, iq);
                for (k = k0; k < k1; k++) {
                    q[(((size_t)pnl * K4 + k / 4) * SUPERMAT__NR + c) * 4 + (k & 3)] = (signed char)iq[k - k0];
                    sum += iq[k - k0];
                }
                cor[(size_t)j * cst + (size_t)pnl * SUPERMAT__NR + c] = 128 * sum;
            }
    if (pw->p) supermat__release(L, pw->p);
    if (pw->q) supermat__release(L, pw->q);
    if (pw->qs) supermat__release(L, pw->qs);
    pw->p = NULL; pw->q = q; pw->qs = qs; pw->fmt = 5;
}
/* converts a packed f32 weight to its storage format and releases the f32 copy */
static void supermat__quantize(supermat__loader *L, supermat__pw *pw, int fmt, size_t total, const char *name) {
    size_t bad = 0;
    int np = (pw->N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    pw->q = supermat__mem(L, total * (fmt == 3 ? 1 : 2));
    if (fmt == 3) pw->qs = (float *)supermat__mem(L, sizeof(float) * (size_t)supermat__qgroups(pw->K, pw->qcin) * np * SUPERMAT__NR);
    if (L->r) return;
    if (supermat__quantize_panels(pw->p, total, pw->K, pw->N, pw->qcin, fmt, pw->q, pw->qs, &bad)) {
        L->r = supermat__fail(L->err, SUPERMAT_ERROR_UNSUPPORTED, name, "tensor '%s' has a value %g beyond the f16 range", name, (double)pw->p[bad]);
        return;
    }
    pw->fmt = fmt;
    supermat__release(L, pw->p); /* the f32 panels */
    pw->p = NULL;
}

/* a weight's rows to pack: `first`/`count` rows of tensor `name` (`rows_total` rows; `bias` or NULL) */
typedef struct supermat__wpart { const char *name; const char *bias; int rows_total, first, count; } supermat__wpart;

/* ---- pre-packed models: replaying a file's packed panels (and recording them for the writer) ---- */
static int64_t supermat__pk_field(const supermat__loader *L, int rec, int f) {
    int64_t v;
    memcpy(&v, L->pk_idx + ((size_t)rec * SUPERMAT__PKF + (size_t)f) * 8, 8);
    return v;
}
/* the blob bytes [off, off + bytes), checked; used in place or (copy_data) copied into the model */
static void *supermat__pk_use(supermat__loader *L, int64_t off, uint64_t bytes, const char *name) {
    void *p;
    if (L->r) return NULL;
    if (off < 0 || (off & 63) || (uint64_t)off > L->pk_size || bytes > L->pk_size - (uint64_t)off) {
        L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, name, "pre-packed panels of '%s' at offset %lld (%llu bytes) lie outside the %llu-byte blob or are not 64-byte aligned",
                              name, (long long)off, (unsigned long long)bytes, (unsigned long long)L->pk_size);
        return NULL;
    }
    if (!L->copy) {
        L->m->info.prepacked_bytes += (size_t)bytes;
        return (void *)(uintptr_t)(L->pk + off);
    }
    p = supermat__mem(L, (size_t)bytes);
    if (p) memcpy(p, L->pk + off, (size_t)bytes);
    return p;
}
/* the next record, which must be of `kind` with these K and N (and a bias when need_bias) */
static int supermat__pk_take(supermat__loader *L, int kind, int K, int N, int need_bias, const char *name) {
    int i = L->pk_next;
    if (L->r) return -1;
    if (i >= L->pk_n) {
        L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, name, "the pre-packed index ends (%d records) before '%s'", L->pk_n, name);
        return -1;
    }
    if (supermat__pk_field(L, i, 0) != kind || supermat__pk_field(L, i, 1) != K || supermat__pk_field(L, i, 2) != N ||
        (supermat__pk_field(L, i, 7) >= 0) != (need_bias != 0)) {
        L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, name, "pre-packed record %d does not fit '%s' (kind %d, K %d, N %d): the file was not packed from this architecture",
                              i, name, kind, K, N);
        return -1;
    }
    L->pk_next++;
    return i;
}
static uint64_t supermat__pk_main_bytes(int fmt, int K, int N) {
    uint64_t np = (uint64_t)(N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    if (fmt == 4) return np * (uint64_t)((K + 1) / 2) * SUPERMAT__NR * 2 * 2;
    if (fmt == 5) return np * (uint64_t)((K + 3) / 4) * SUPERMAT__NR * 4;
    return np * SUPERMAT__NR * (uint64_t)K * (fmt == 0 ? 4u : fmt == 3 ? 1u : 2u);
}
static uint64_t supermat__pk_qs_bytes(int fmt, int K, int N, int qcin) {
    uint64_t cols = (uint64_t)((N + SUPERMAT__NR - 1) / SUPERMAT__NR) * SUPERMAT__NR;
    return fmt == 3 ? (uint64_t)supermat__qgroups(K, qcin) * cols * 4 : fmt == 5 ? (uint64_t)((K + 63) / 64) * cols * 8 : 0;
}
/* supermat__pack for a pre-packed file: the panels come from the blob */
static void supermat__pk_pw(supermat__loader *L, supermat__pw *pw, const supermat__wpart *parts, int nparts, int cin, int k, int need_bias) {
    int p, K = cin * k * k, N = 0, rec, fmt, sfmt;
    uint64_t np;
    for (p = 0; p < nparts; p++) {
        N += parts[p].count;
        L->params += (uint64_t)parts[p].rows_total * (uint64_t)K + (need_bias && parts[p].bias ? (uint64_t)parts[p].rows_total : 0);
    }
    memset(pw, 0, sizeof *pw);
    rec = supermat__pk_take(L, 1, K, N, need_bias, parts[0].name);
    if (rec < 0) return;
    fmt = (int)supermat__pk_field(L, rec, 3);
    sfmt = (int)supermat__pk_field(L, rec, 4);
    if (supermat__pk_field(L, rec, 3) < 0 || supermat__pk_field(L, rec, 3) > 5 || supermat__pk_field(L, rec, 4) < 0 ||
        supermat__pk_field(L, rec, 4) > 3 || (fmt == 4 && !L->bf16c) || (fmt == 5 && !L->i8c) || (fmt < 4 && fmt != sfmt)) {
        L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, parts[0].name, "pre-packed record %d ('%s') has a bad format", rec, parts[0].name);
        return;
    }
    np = (uint64_t)(N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    pw->K = K; pw->N = N; pw->qcin = cin; pw->fmt = fmt;
    if (fmt == 0) pw->p = (float *)supermat__pk_use(L, supermat__pk_field(L, rec, 5), supermat__pk_main_bytes(fmt, K, N), parts[0].name);
    else pw->q = supermat__pk_use(L, supermat__pk_field(L, rec, 5), supermat__pk_main_bytes(fmt, K, N), parts[0].name);
    if (fmt == 3 || fmt == 5) pw->qs = (float *)supermat__pk_use(L, supermat__pk_field(L, rec, 6), supermat__pk_qs_bytes(fmt, K, N, cin), parts[0].name);
    if (need_bias) pw->bias = (float *)supermat__pk_use(L, supermat__pk_field(L, rec, 7), np * SUPERMAT__NR * 4, parts[0].name);
}
/* the writer's record of one packed weight */
static void supermat__pk_note(supermat__loader *L, supermat__pw *pw, int sfmt) {
    supermat__pkrec *R = L->rec;
    if (L->r) return;
    if (R->n == R->cap) {
        int nc = R->cap ? 2 * R->cap : 256;
        supermat__pkitem *ni = (supermat__pkitem *)supermat__alloc(&L->m->alloc, sizeof *ni * (size_t)nc);
        if (!ni) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory (packing index)"); return; }
        if (R->n) memcpy(ni, R->items, sizeof *ni * (size_t)R->n);
        supermat__free(&L->m->alloc, R->items, sizeof *ni * (size_t)R->cap);
        R->items = ni; R->cap = nc;
    }
    memset(&R->items[R->n], 0, sizeof R->items[R->n]);
    R->items[R->n].pw = pw; R->items[R->n].sfmt = sfmt;
    R->n++;
}

/* Packs rows of one or more weight tensors [rows][K] (or convs [rows][Cin][k][k], reordered to
   K = (ky*k + kx)*Cin + ci) into GEMM panels. `first`/`count` select rows of each tensor. */

static void supermat__pack(supermat__loader *L, supermat__pw *pw, const supermat__wpart *parts, int nparts, int cin, int k,
                           int is_conv, int need_bias) {
    int p, K = cin * k * k, N = 0, n0 = 0, np, fmt, direct;
    size_t total, ngq = 0;
    if (L->r) return;
    if (L->pk) { supermat__pk_pw(L, pw, parts, nparts, cin, k, need_bias); return; }
    for (p = 0; p < nparts; p++) N += parts[p].count;
    np = (N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    if (!supermat__mul_ok((size_t)np * SUPERMAT__NR, (size_t)K, &total)) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, parts[0].name, "weight too large"); return; }
    {   /* storage format: as the file stores it, or as asked */
        int t0 = supermat__find_tensor(L, parts[0].name);
        supermat_dtype d0 = t0 < 0 ? SUPERMAT_DTYPE_F32 : L->ti[t0].dtype;
        fmt = L->weights == SUPERMAT_WEIGHTS_F16 ? 1 : L->weights == SUPERMAT_WEIGHTS_BF16 ? 2 : L->weights == SUPERMAT_WEIGHTS_I8 ? 3 : 0;
        if (L->weights == SUPERMAT_WEIGHTS_DEFAULT) fmt = d0 == SUPERMAT_DTYPE_F16 ? 1 : d0 == SUPERMAT_DTYPE_BF16 ? 2 : d0 == SUPERMAT_DTYPE_I8 ? 3 : 0;
        if (!L->m->info.weights) L->m->info.weights = (supermat_weights)(fmt + 1);
    }
    /* int8 from I8 tensors: the file's values and scales go straight into the panels (no requantizing) */
    direct = fmt == 3 && !L->keep_f32;
    for (p = 0; p < nparts && direct; p++) {
        int t = supermat__find_tensor(L, parts[p].name);
        direct = t >= 0 && L->ti[t].dtype == SUPERMAT_DTYPE_I8;
    }
    pw->K = K; pw->N = N; pw->qcin = cin;
    pw->p = NULL; pw->q = NULL; pw->qs = NULL; pw->fmt = 0;
    if (direct) {
        ngq = (size_t)supermat__qgroups(K, cin) * np * SUPERMAT__NR;
        pw->q = supermat__mem(L, total);
        pw->qs = (float *)supermat__mem(L, ngq * sizeof(float));
        if (pw->q) memset(pw->q, 0, total);
        if (pw->qs) memset(pw->qs, 0, ngq * sizeof(float));
    } else pw->p = (float *)supermat__mem(L, total * sizeof(float));
    pw->bias = NULL;
    if (need_bias) {
        pw->bias = (float *)supermat__mem(L, (size_t)np * SUPERMAT__NR * sizeof(float));
        if (pw->bias) memset(pw->bias, 0, (size_t)np * SUPERMAT__NR * sizeof(float));
    }
    if (L->r) return;
    /* zero the padding columns of the last panel */
    if (!direct && N % SUPERMAT__NR) {
        size_t kk;
        float *last = pw->p + (size_t)(np - 1) * K * SUPERMAT__NR;
        for (kk = 0; kk < (size_t)K; kk++) memset(last + kk * SUPERMAT__NR + N % SUPERMAT__NR, 0, sizeof(float) * (SUPERMAT__NR - N % SUPERMAT__NR));
    }
    for (p = 0; p < nparts; p++) {
        int64_t want[4];
        int t, r, ci, ky, kx;
        want[0] = parts[p].rows_total; want[1] = cin; want[2] = k; want[3] = k;
        t = supermat__wtensor(L, parts[p].name, is_conv ? 4 : 2, want);
        if (t < 0) return;
        if (L->rec) L->rec->pkuses[t]++;
        if (direct) {
            const signed char *raw = (const signed char *)(L->data + L->ti[t].offset);
            const unsigned char *sc = L->data + L->ti[L->qsc[t]].offset;
            int kk = k * k, ng = (cin + SUPERMAT__QG - 1) / SUPERMAT__QG, tap, gi;
            signed char *q = (signed char *)pw->q;
            for (r = 0; r < parts[p].count; r++) {
                int n = n0 + r, row = parts[p].first + r;
                signed char *dst = q + (size_t)(n / SUPERMAT__NR) * K * SUPERMAT__NR + n % SUPERMAT__NR;
                for (tap = 0; tap < kk; tap++) {
                    for (ci = 0; ci < cin; ci++) dst[((size_t)tap * cin + ci) * SUPERMAT__NR] = raw[((size_t)row * cin + ci) * kk + tap];
                    for (gi = 0; gi < ng; gi++)
                        memcpy(pw->qs + ((size_t)tap * ng + gi) * np * SUPERMAT__NR + n, sc + 4 * (((size_t)row * kk + tap) * ng + gi), 4);
                }
            }
        } else for (r = 0; r < parts[p].count; r++) {
            int n = n0 + r, row = parts[p].first + r;
            float *dst = pw->p + (size_t)(n / SUPERMAT__NR) * K * SUPERMAT__NR + n % SUPERMAT__NR;
            size_t base = (size_t)row * K;
            for (ky = 0; ky < k; ky++)
                for (kx = 0; kx < k; kx++) {
                    float *d = dst + (size_t)(ky * k + kx) * cin * SUPERMAT__NR;
                    size_t src = base + (size_t)ky * k + kx, kk = (size_t)k * k;
                    const unsigned char *raw = L->data + L->ti[t].offset;
                    int f32 = L->ti[t].dtype == SUPERMAT_DTYPE_F32;
                    for (ci = 0; ci < cin; ci++) {
                        float v;
                        if (f32) memcpy(&v, raw + 4 * (src + (size_t)ci * kk), 4);
                        else v = supermat__tval(L, t, src + (size_t)ci * kk);
                        if (!(v - v == 0.0f)) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_NONFINITE, parts[p].name, "tensor '%s' contains NaN or Inf", parts[p].name); return; }
                        d[(size_t)ci * SUPERMAT__NR] = v;
                    }
                }
        }
        L->params += (uint64_t)parts[p].rows_total * K;
        if (need_bias && parts[p].bias) {
            int64_t wb[1];
            int tb;
            wb[0] = parts[p].rows_total;
            tb = supermat__wtensor(L, parts[p].bias, 1, wb);
            if (tb < 0) return;
            if (L->rec) L->rec->pkuses[tb]++;
            for (r = 0; r < parts[p].count; r++) {
                float v = supermat__tval(L, tb, (size_t)parts[p].first + r);
                if (!(v - v == 0.0f)) { L->r = supermat__fail(L->err, SUPERMAT_ERROR_NONFINITE, parts[p].bias, "tensor '%s' contains NaN or Inf", parts[p].bias); return; }
                pw->bias[n0 + r] = v;
            }
            L->params += (uint64_t)parts[p].rows_total;
        }
        n0 += parts[p].count;
    }
    if (L->r) return;
    if (direct) pw->fmt = 3; /* as read; int8 compute requantizes it below */
    if (L->i8c && !L->keep_f32) supermat__i8_quads(L, pw);
    else if (!direct && L->bf16c && !L->keep_f32) supermat__bf16_pairs(L, pw);
    else if (!direct && fmt && !L->keep_f32) supermat__quantize(L, pw, fmt, total, parts[0].name);
    if (L->rec) supermat__pk_note(L, pw, direct ? 3 : fmt);
}

static void supermat__bind_linear(supermat__loader *L, supermat__pw *pw, const char *prefix, int out, int in, int bias) {
    char wn[200], bn[200];
    supermat__wpart part;
    supermat__name(wn, sizeof wn, "%s.weight", prefix);
    supermat__name(bn, sizeof bn, "%s.bias", prefix);
    part.name = wn; part.bias = bias ? bn : NULL; part.rows_total = out; part.first = 0; part.count = out;
    supermat__pack(L, pw, &part, 1, in, 1, 0, bias);
}
static void supermat__bind_conv(supermat__loader *L, supermat__conv *cv, const char *prefix, int cin, int cout, int k, int stride) {
    char wn[200], bn[200];
    supermat__wpart part;
    int wino = L->conv != SUPERMAT_CONV_DIRECT && k == 3 && stride == 1 && cout <= 640;
    supermat__name(wn, sizeof wn, "%s.weight", prefix);
    supermat__name(bn, sizeof bn, "%s.bias", prefix);
    part.name = wn; part.bias = bn; part.rows_total = cout; part.first = 0; part.count = cout;
    cv->k = k; cv->stride = stride; cv->cin = cin; cv->cout = cout; cv->wino = NULL;
    if (L->pk && wino) { /* pre-packed: the transformed weights come from the blob */
        int rec, a = (L->conv == SUPERMAT_CONV_WINOGRAD_F2 ? 2 : 4) + 2, xi;
        uint64_t total = (uint64_t)((cout + 15) / 16) * 16 * (uint64_t)cin;
        supermat__wino *wg;
        float *u;
        L->params += (uint64_t)cout * (uint64_t)cin * (uint64_t)(k * k) + (uint64_t)cout;
        memset(&cv->w, 0, sizeof cv->w);
        rec = supermat__pk_take(L, 2, cin * k * k, cout, 1, wn);
        if (rec < 0) return;
        if (supermat__pk_field(L, rec, 3) != 0 || supermat__pk_field(L, rec, 4) != a) {
            L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, wn, "pre-packed record %d ('%s') is not a Winograd F(%dx%d) convolution", rec, wn, a - 2, a - 2);
            return;
        }
        cv->w.K = cin * k * k; cv->w.N = cout; cv->w.qcin = cin;
        u = (float *)supermat__pk_use(L, supermat__pk_field(L, rec, 5), (uint64_t)(a * a) * total * 4, wn);
        cv->w.bias = (float *)supermat__pk_use(L, supermat__pk_field(L, rec, 7), (uint64_t)((cout + 15) / 16) * 16 * 4, wn);
        wg = (supermat__wino *)supermat__mem(L, sizeof *wg);
        if (L->r) return;
        memset(wg, 0, sizeof *wg);
        wg->m = a - 2; wg->a = a;
        for (xi = 0; xi < a * a; xi++) { wg->u[xi].K = cin; wg->u[xi].N = cout; wg->u[xi].p = u + (size_t)xi * (size_t)total; }
        cv->wino = wg;
        return;
    }
    L->keep_f32 = wino;
    supermat__pack(L, &cv->w, &part, 1, cin, k, 1, 1);
    L->keep_f32 = 0;
    if (wino && !L->r && cv->w.p) { /* Winograd: the transformed weights replace the direct ones, in f32
                                        (quantizing F4's transformed weights costs 20-40x the error) */
        int m = L->conv == SUPERMAT_CONV_WINOGRAD_F2 ? 2 : 4, xi;
        size_t total = (size_t)((cout + 15) / 16) * 16 * cin;
        supermat__wino *wg = (supermat__wino *)supermat__mem(L, sizeof *wg);
        float *dst[36];
        if (!wg) return;
        memset(wg, 0, sizeof *wg);
        wg->m = m; wg->a = m + 2;
        for (xi = 0; xi < wg->a * wg->a; xi++) {
            wg->u[xi].K = cin; wg->u[xi].N = cout;
            wg->u[xi].p = dst[xi] = (float *)supermat__mem(L, total * sizeof(float));
            if (!dst[xi]) return;
        }
        supermat__wino_transform(cv->w.p, cin, cout, m, dst);
        supermat__release(L, cv->w.p);
        cv->w.p = NULL;
        cv->wino = wg;
        if (L->rec && L->rec->n) L->rec->items[L->rec->n - 1].wino = wg;
    }
}
static void supermat__bind_norm(supermat__loader *L, supermat__norm *nm, const char *prefix, int c, float eps) {
    char n[200];
    supermat__name(n, sizeof n, "%s.weight", prefix);
    nm->g = supermat__vec(L, n, c, 0);
    supermat__name(n, sizeof n, "%s.bias", prefix);
    nm->b = supermat__vec(L, n, c, 0);
    nm->c = c; nm->eps = eps;
}

static void supermat__bind_resnet(supermat__loader *L, supermat__resnet *r, const char *pre, int cin, int cout, int temb, int groups, float eps) {
    char n[200];
    (void)groups;
    r->cin = cin; r->cout = cout;
    supermat__name(n, sizeof n, "%s.norm1", pre); supermat__bind_norm(L, &r->n1, n, cin, eps);
    supermat__name(n, sizeof n, "%s.conv1", pre); supermat__bind_conv(L, &r->c1, n, cin, cout, 3, 1);
    if (temb) { supermat__name(n, sizeof n, "%s.time_emb_proj", pre); supermat__bind_linear(L, &r->temb, n, cout, temb, 1); }
    supermat__name(n, sizeof n, "%s.norm2", pre); supermat__bind_norm(L, &r->n2, n, cout, eps);
    supermat__name(n, sizeof n, "%s.conv2", pre); supermat__bind_conv(L, &r->c2, n, cout, cout, 3, 1);
    r->has_sc = cin != cout;
    if (r->has_sc) { supermat__name(n, sizeof n, "%s.conv_shortcut", pre); supermat__bind_conv(L, &r->sc, n, cin, cout, 1, 1); }
}

static void supermat__bind_xformer(supermat__loader *L, supermat__xformer *x, const char *pre, int c, int heads, float ln_eps) {
    char n[200], b[200], q[200], k[200], v[200];
    supermat__wpart parts[3];
    supermat_model *m = L->m;
    int ctx_t, wk, wv, i, j, t;
    x->c = c; x->heads = heads; x->d = c / heads;
    supermat__name(x->name, sizeof x->name, "%s", pre);
    if (heads <= 0 || c % heads) { if (!L->r) L->r = supermat__fail(L->err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "%d channels do not split into %d heads", c, heads); return; }
    supermat__name(n, sizeof n, "%s.norm", pre); supermat__bind_norm(L, &x->gn, n, c, 1e-6f);
    supermat__name(n, sizeof n, "%s.proj_in", pre); supermat__bind_linear(L, &x->proj_in, n, c, c, 1);
    supermat__name(n, sizeof n, "%s.proj_out", pre); supermat__bind_linear(L, &x->proj_out, n, c, c, 1);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.norm1", pre); supermat__bind_norm(L, &x->ln1, n, c, ln_eps);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.norm2", pre); supermat__bind_norm(L, &x->ln2, n, c, ln_eps);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.norm3", pre); supermat__bind_norm(L, &x->ln3, n, c, ln_eps);
    supermat__name(q, sizeof q, "%s.transformer_blocks.0.attn1.to_q.weight", pre);
    supermat__name(k, sizeof k, "%s.transformer_blocks.0.attn1.to_k.weight", pre);
    supermat__name(v, sizeof v, "%s.transformer_blocks.0.attn1.to_v.weight", pre);
    parts[0].name = q; parts[1].name = k; parts[2].name = v;
    for (i = 0; i < 3; i++) { parts[i].bias = NULL; parts[i].rows_total = c; parts[i].first = 0; parts[i].count = c; }
    supermat__pack(L, &x->qkv1, parts, 3, c, 1, 0, 0);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.attn1.to_out.0", pre); supermat__bind_linear(L, &x->out1, n, c, c, 1);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.attn2.to_q", pre); supermat__bind_linear(L, &x->q2, n, c, c, 0);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.attn2.to_out.0", pre); supermat__bind_linear(L, &x->out2, n, c, c, 1);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.ff.net.0.proj", pre); supermat__bind_linear(L, &x->ff1, n, 8 * c, c, 1);
    supermat__name(n, sizeof n, "%s.transformer_blocks.0.ff.net.2", pre); supermat__bind_linear(L, &x->ff2, n, c, 4 * c, 1);
    /* cross-attention keys and values of the constant context, computed once and packed */
    if (L->pk) { /* pre-packed: from the blob */
        int rec;
        size_t kpn = (size_t)heads * supermat__attn_kp_floats(m->ctx_tokens, x->d), vpn = (size_t)heads * supermat__attn_vp_floats(m->ctx_tokens, x->d);
        L->params += 2u * (uint64_t)c * (uint64_t)m->cross_dim;
        rec = supermat__pk_take(L, 3, c, m->ctx_tokens, 0, pre);
        if (rec < 0) return;
        x->kp2 = (float *)supermat__pk_use(L, supermat__pk_field(L, rec, 5), (uint64_t)kpn * 4, pre);
        x->vp2 = (float *)supermat__pk_use(L, supermat__pk_field(L, rec, 6), (uint64_t)vpn * 4, pre);
        return;
    }
    {
        int64_t want[2];
        float *kv;
        supermat__attn_pack_args pa;
        want[0] = c; want[1] = m->cross_dim;
        supermat__name(k, sizeof k, "%s.transformer_blocks.0.attn2.to_k.weight", pre);
        supermat__name(v, sizeof v, "%s.transformer_blocks.0.attn2.to_v.weight", pre);
        wk = supermat__wtensor(L, k, 2, want);
        wv = supermat__wtensor(L, v, 2, want);
        want[0] = m->ctx_tokens; want[1] = m->cross_dim;
        ctx_t = supermat__wtensor(L, "context", 2, want);
        if (L->r) return;
        L->params += 2u * (uint64_t)c * m->cross_dim;
        kv = (float *)supermat__mem(L, sizeof(float) * 2 * (size_t)m->ctx_tokens * c);
        x->kp2 = (float *)supermat__mem(L, sizeof(float) * heads * supermat__attn_kp_floats(m->ctx_tokens, x->d));
        x->vp2 = (float *)supermat__mem(L, sizeof(float) * heads * supermat__attn_vp_floats(m->ctx_tokens, x->d));
        {   /* float64 dot products over float copies of the rows (one conversion per element) */
            size_t D = (size_t)m->cross_dim;
            float *rows = (float *)supermat__alloc(&m->alloc, sizeof(float) * ((size_t)m->ctx_tokens + 2) * D);
            float *wkr = rows + (size_t)m->ctx_tokens * D, *wvr = wkr + D;
            if (!rows) { if (!L->r) L->r = supermat__fail(L->err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory (cross-attention keys)"); return; }
            if (L->r) { supermat__free(&m->alloc, rows, sizeof(float) * ((size_t)m->ctx_tokens + 2) * D); return; }
            for (i = 0; i < (int)((size_t)m->ctx_tokens * D); i++) rows[i] = supermat__tval(L, ctx_t, (size_t)i);
            for (j = 0; j < c; j++) {
                for (i = 0; i < (int)D; i++) { wkr[i] = supermat__tval(L, wk, (size_t)j * D + i); wvr[i] = supermat__tval(L, wv, (size_t)j * D + i); }
                for (t = 0; t < m->ctx_tokens; t++) {
                    const float *cr = rows + (size_t)t * D;
                    double sk0 = 0, sk1 = 0, sk2 = 0, sk3 = 0, sv0 = 0, sv1 = 0, sv2 = 0, sv3 = 0, sk, sv;
                    for (i = 0; i + 4 <= (int)D; i += 4) {
                        sk0 += (double)cr[i] * wkr[i]; sk1 += (double)cr[i + 1] * wkr[i + 1]; sk2 += (double)cr[i + 2] * wkr[i + 2]; sk3 += (double)cr[i + 3] * wkr[i + 3];
                        sv0 += (double)cr[i] * wvr[i]; sv1 += (double)cr[i + 1] * wvr[i + 1]; sv2 += (double)cr[i + 2] * wvr[i + 2]; sv3 += (double)cr[i + 3] * wvr[i + 3];
                    }
                    for (; i < (int)D; i++) { sk0 += (double)cr[i] * wkr[i]; sv0 += (double)cr[i] * wvr[i]; }
                    sk = (sk0 + sk1) + (sk2 + sk3); sv = (sv0 + sv1) + (sv2 + sv3);
                    if (!(sk - sk == 0.0) || !(sv - sv == 0.0)) {
                        supermat__free(&m->alloc, rows, sizeof(float) * ((size_t)m->ctx_tokens + 2) * D);
                        L->r = supermat__fail(L->err, SUPERMAT_ERROR_NONFINITE, k, "cross-attention keys/values of '%s' are not finite", pre);
                        return;
                    }
                    kv[(size_t)t * c + j] = (float)sk;
                    kv[(size_t)(m->ctx_tokens + t) * c + j] = (float)sv;
                }
            }
            supermat__free(&m->alloc, rows, sizeof(float) * ((size_t)m->ctx_tokens + 2) * D);
        }
        pa.k = kv; pa.v = kv + (size_t)m->ctx_tokens * c; pa.ldk = pa.ldv = (size_t)c; pa.mk = m->ctx_tokens;
        pa.heads = heads; pa.d = x->d; pa.kp = x->kp2; pa.vp = x->vp2;
        for (i = 0; i < heads; i++) supermat__attn_pack_task(&pa, i, 0);
        if (L->rec) { /* the writer keeps these; the two weights they came from are left out */
            supermat__pk_note(L, NULL, 0);
            if (!L->r) {
                supermat__pkitem *it = &L->rec->items[L->rec->n - 1];
                it->kp = x->kp2; it->vp = x->vp2; it->c = c; it->tokens = m->ctx_tokens;
                it->kpn = (size_t)heads * supermat__attn_kp_floats(m->ctx_tokens, x->d);
                it->vpn = (size_t)heads * supermat__attn_vp_floats(m->ctx_tokens, x->d);
                L->rec->pkuses[wk]++; L->rec->pkuses[wv]++;
            }
        }
    }
    (void)b;
}

static void supermat__bind_vattn(supermat__loader *L, supermat__vattn *a, const char *pre, int c, float eps) {
    char n[200], q[200], k[200], v[200], qb[200], kb[200], vb[200];
    supermat__wpart parts[3];
    int i;
    a->c = c;
    supermat__name(n, sizeof n, "%s.group_norm", pre); supermat__bind_norm(L, &a->gn, n, c, eps);
    supermat__name(q, sizeof q, "%s.to_q.weight", pre); supermat__name(qb, sizeof qb, "%s.to_q.bias", pre);
    supermat__name(k, sizeof k, "%s.to_k.weight", pre); supermat__name(kb, sizeof kb, "%s.to_k.bias", pre);
    supermat__name(v, sizeof v, "%s.to_v.weight", pre); supermat__name(vb, sizeof vb, "%s.to_v.bias", pre);
    parts[0].name = q; parts[0].bias = qb; parts[1].name = k; parts[1].bias = kb; parts[2].name = v; parts[2].bias = vb;
    for (i = 0; i < 3; i++) { parts[i].rows_total = c; parts[i].first = 0; parts[i].count = c; }
    supermat__pack(L, &a->qkv, parts, 3, c, 1, 0, 1);
    supermat__name(n, sizeof n, "%s.to_out.0", pre); supermat__bind_linear(L, &a->out, n, c, c, 1);
}

/* diffusers' channel bookkeeping for the UNet down and up paths */
static void supermat__bind_unet(supermat__loader *L) {
    supermat_model *m = L->m;
    char n[200];
    int l, j, b, T = m->temb_dim, rb[SUPERMAT__MAXL], rh[SUPERMAT__MAXL], out_ch, prev, in_ch;
    int uv = m->info.kind == SUPERMAT_KIND_UV_REFINE, mv = m->info.kind == SUPERMAT_KIND_SUPERMAT_MV;
    char dn[64];
    uint64_t p0;
    supermat__bind_linear(L, &m->time1, "time_embedding.linear_1", T, m->boc[0], 1);
    supermat__bind_linear(L, &m->time2, "time_embedding.linear_2", T, T, 1);
    if (m->class_in) {
        supermat__bind_linear(L, &m->cls1, "class_embedding.linear_1", T, m->class_in, 1);
        supermat__bind_linear(L, &m->cls2, "class_embedding.linear_2", T, T, 1);
    }
    /* UV refine renames the head: conv_in -> rep_conv_in.0, down level 0 -> first_down_blocks.0,
       down level l -> down_blocks.(l-1) */
    supermat__bind_conv(L, &m->conv_in, uv ? "rep_conv_in.0" : "conv_in", m->in_ch, m->boc[0], 3, 1);
    out_ch = m->boc[0];
    for (l = 0; l < m->L; l++) {
        supermat__level *lv = &m->down[l];
        in_ch = out_ch; out_ch = m->boc[l];
        lv->nres = m->lpb; lv->has_attn = m->down_attn[l]; lv->cout = out_ch;
        if (uv && l == 0) supermat__name(dn, sizeof dn, "first_down_blocks.0");
        else supermat__name(dn, sizeof dn, "down_blocks.%d", uv ? l - 1 : l);
        for (j = 0; j < m->lpb; j++) {
            supermat__name(n, sizeof n, "%s.resnets.%d", dn, j);
            supermat__bind_resnet(L, &lv->res[j], n, j == 0 ? in_ch : out_ch, out_ch, T, m->groups, m->eps);
            if (lv->has_attn) {
                supermat__name(n, sizeof n, "%s.attentions.%d", dn, j);
                supermat__bind_xformer(L, &lv->att[j], n, out_ch, m->heads[l], 1e-5f);
                /* the official MV processor skips every module path containing "down_blocks.0" */
                lv->att[j].mv = mv && !strstr(n, "down_blocks.0");
            }
        }
        lv->has_sampler = l < m->L - 1;
        if (lv->has_sampler) { supermat__name(n, sizeof n, "%s.downsamplers.0.conv", dn); supermat__bind_conv(L, &lv->sampler, n, out_ch, out_ch, 3, 2); }
    }
    supermat__bind_resnet(L, &m->mid_res[0], "mid_block.resnets.0", m->boc[m->L - 1], m->boc[m->L - 1], T, m->groups, m->eps);
    supermat__bind_xformer(L, &m->mid_att, "mid_block.attentions.0", m->boc[m->L - 1], m->heads[m->L - 1], 1e-5f);
    m->mid_att.mv = mv;
    supermat__bind_resnet(L, &m->mid_res[1], "mid_block.resnets.1", m->boc[m->L - 1], m->boc[m->L - 1], T, m->groups, m->eps);
    for (l = 0; l < m->L; l++) { rb[l] = m->boc[m->L - 1 - l]; rh[l] = m->heads[m->L - 1 - l]; }
    out_ch = rb[0];
    p0 = 0;
    for (l = 0; l < m->L; l++) {
        int nb = l == m->L - 1 ? m->branches : 1;
        prev = out_ch; out_ch = rb[l]; in_ch = rb[SUPERMAT__MIN(l + 1, m->L - 1)];
        if (l == m->L - 1) p0 = L->params;
        for (b = 0; b < nb; b++) {
            supermat__level *lv = l == m->L - 1 ? &m->last[b] : &m->up[l];
            lv->nres = m->lpb + 1; lv->has_attn = m->up_attn[l]; lv->cout = out_ch;
            for (j = 0; j <= m->lpb; j++) {
                int skip = j == m->lpb ? in_ch : out_ch, rin = j == 0 ? prev : out_ch;
                if (l == m->L - 1) supermat__name(n, sizeof n, "last_up_blocks.%d.resnets.%d", b, j);
                else supermat__name(n, sizeof n, "up_blocks.%d.resnets.%d", l, j);
                supermat__bind_resnet(L, &lv->res[j], n, rin + skip, out_ch, T, m->groups, m->eps);
                if (lv->has_attn) {
                    if (l == m->L - 1) supermat__name(n, sizeof n, "last_up_blocks.%d.attentions.%d", b, j);
                    else supermat__name(n, sizeof n, "up_blocks.%d.attentions.%d", l, j);
                    supermat__bind_xformer(L, &lv->att[j], n, out_ch, rh[l], 1e-5f);
                    lv->att[j].mv = mv && !strstr(n, "down_blocks.0");
                }
            }
            lv->has_sampler = l < m->L - 1;
            if (lv->has_sampler) { supermat__name(n, sizeof n, "up_blocks.%d.upsamplers.0.conv", l); supermat__bind_conv(L, &lv->sampler, n, out_ch, out_ch, 3, 1); }
            supermat__name(n, sizeof n, "rep_conv_out.%d", b);
            if (l == m->L - 1) supermat__bind_conv(L, &m->conv_out[b], n, out_ch, m->out_ch, 3, 1);
        }
    }
    m->info.branch_params = m->branches ? (L->params - p0) / (uint64_t)m->branches : 0;
    supermat__bind_norm(L, &m->norm_out, "conv_norm_out", m->boc[0], m->eps);
}

static void supermat__bind_vae(supermat__loader *L) {
    supermat_model *m = L->m;
    char n[200];
    int l, j, out_ch, in_ch, prev, top = m->vboc[m->vL - 1];
    float e = 1e-6f;
    supermat__bind_conv(L, &m->e_conv_in, "vae.encoder.conv_in", m->vin, m->vboc[0], 3, 1);
    out_ch = m->vboc[0];
    for (l = 0; l < m->vL; l++) {
        supermat__level *lv = &m->e_lv[l];
        in_ch = out_ch; out_ch = m->vboc[l];
        lv->nres = m->vlpb; lv->cout = out_ch;
        for (j = 0; j < m->vlpb; j++) {
            supermat__name(n, sizeof n, "vae.encoder.down_blocks.%d.resnets.%d", l, j);
            supermat__bind_resnet(L, &lv->res[j], n, j == 0 ? in_ch : out_ch, out_ch, 0, m->vgroups, e);
        }
        lv->has_sampler = l < m->vL - 1;
        if (lv->has_sampler) { supermat__name(n, sizeof n, "vae.encoder.down_blocks.%d.downsamplers.0.conv", l); supermat__bind_conv(L, &lv->sampler, n, out_ch, out_ch, 3, 2); }
    }
    supermat__bind_resnet(L, &m->e_mid[0], "vae.encoder.mid_block.resnets.0", top, top, 0, m->vgroups, e);
    supermat__bind_vattn(L, &m->e_att, "vae.encoder.mid_block.attentions.0", top, e);
    supermat__bind_resnet(L, &m->e_mid[1], "vae.encoder.mid_block.resnets.1", top, top, 0, m->vgroups, e);
    supermat__bind_norm(L, &m->e_norm_out, "vae.encoder.conv_norm_out", top, e);
    supermat__bind_conv(L, &m->e_conv_out, "vae.encoder.conv_out", top, 2 * m->latent, 3, 1);
    { /* quant_conv: only the mean half of its output is used (the pipeline takes the mode) */
        supermat__wpart part;
        part.name = "vae.quant_conv.weight"; part.bias = "vae.quant_conv.bias"; part.rows_total = 2 * m->latent; part.first = 0; part.count = m->latent;
        m->quant.k = 1; m->quant.stride = 1; m->quant.cin = 2 * m->latent; m->quant.cout = m->latent;
        supermat__pack(L, &m->quant.w, &part, 1, 2 * m->latent, 1, 1, 1);
    }
    supermat__bind_conv(L, &m->post_quant, "vae.post_quant_conv", m->latent, m->latent, 1, 1);
    supermat__bind_conv(L, &m->d_conv_in, "vae.decoder.conv_in", m->latent, top, 3, 1);
    supermat__bind_resnet(L, &m->d_mid[0], "vae.decoder.mid_block.resnets.0", top, top, 0, m->vgroups, e);
    supermat__bind_vattn(L, &m->d_att, "vae.decoder.mid_block.attentions.0", top, e);
    supermat__bind_resnet(L, &m->d_mid[1], "vae.decoder.mid_block.resnets.1", top, top, 0, m->vgroups, e);
    out_ch = top;
    for (l = 0; l < m->vL; l++) {
        supermat__level *lv = &m->d_lv[l];
        prev = out_ch; out_ch = m->vboc[m->vL - 1 - l];
        lv->nres = m->vlpb + 1; lv->cout = out_ch;
        for (j = 0; j <= m->vlpb; j++) {
            supermat__name(n, sizeof n, "vae.decoder.up_blocks.%d.resnets.%d", l, j);
            supermat__bind_resnet(L, &lv->res[j], n, j == 0 ? prev : out_ch, out_ch, 0, m->vgroups, e);
        }
        lv->has_sampler = l < m->vL - 1;
        if (lv->has_sampler) { supermat__name(n, sizeof n, "vae.decoder.up_blocks.%d.upsamplers.0.conv", l); supermat__bind_conv(L, &lv->sampler, n, out_ch, out_ch, 3, 1); }
    }
    supermat__bind_norm(L, &m->d_norm_out, "vae.decoder.conv_norm_out", m->vboc[0], e);
    supermat__bind_conv(L, &m->d_conv_out, "vae.decoder.conv_out", m->vboc[0], m->vout, 3, 1);
}

/* DDIM one step, as diffusers computes it with torch on an x86-64 CPU: betas = torch.linspace(float32),
   whose AVX2 kernel (compiled with FMA contraction) fills 8 lanes as fma(k, step, base) from a base
   fma(step, i0, start) (or fma(-step, T-1-i0, end) past the middle) every 8 elements; squared for
   scaled_linear; alphas_cumprod = cumprod(1 - beta), accumulated in double by torch's CPU kernel and
   stored as float. Bit for bit with diffusers: alphas_cumprod[999] = 0.00466009602 (0x3b98b3b8). */
static float supermat__alphas_cumprod(int T, double b0, double b1, int scaled_linear, int t) {
    float start, end, step;
    double acp = 1.0;
    int i, half = T / 2;
    if (scaled_linear) { start = (float)sqrt(b0); end = (float)sqrt(b1); }
    else { start = (float)b0; end = (float)b1; }
    step = T > 1 ? (end - start) / (float)(T - 1) : 0.0f;
    for (i = 0; i <= t && i < T; i++) {
        int i0 = i - i % 8;
        float base = i0 < half ? fmaf(step, (float)i0, start) : fmaf(-step, (float)(T - i0 - 1), end);
        float v = fmaf((float)(i % 8), step, base), beta = scaled_linear ? v * v : v;
        acp *= (double)(1.0f - beta);
    }
    return (float)acp;
}

static void supermat__model_free(supermat_model *m) {
    int i;
    supermat_allocator a;
    if (!m) return;
    a = m->alloc;
    for (i = 0; i < m->nblocks; i++) supermat__free(&a, m->blocks[i], m->block_sizes[i]);
    supermat__free(&a, m->blocks, sizeof(void *) * (size_t)m->cap_blocks);
    supermat__free(&a, m->block_sizes, sizeof(size_t) * (size_t)m->cap_blocks);
    supermat__free(&a, m, sizeof *m);
}

/* The kernel / compute / weights combinations a model can be created with, in one place. SUPERMAT__COMBOS: per
   compute mode, the kernels it runs on (a bit per supermat_kernel) and the weight formats it refuses;
   SUPERMAT__NEEDS: what the CPU (and build) must have for a compute mode (kernel -1: on any kernel), a
   kernel (compute -1) or a mode on one kernel. Checked in this order: a mode's own need (refused for the
   CPU whatever the kernel), the combination (INVALID_ARGUMENT), then each need that applies (UNSUPPORTED). */
#define SUPERMAT__K(k) (1u << SUPERMAT_KERNEL_##k)
static const struct supermat__combo { unsigned kernels; const char *kernels_why; unsigned refused_weights; const char *weights_why; }
supermat__combos[SUPERMAT_COMPUTE_COUNT] = {
    /* F32 */  {SUPERMAT__K(AUTO) | SUPERMAT__K(SCALAR) | SUPERMAT__K(AVX2) | SUPERMAT__K(AVX512) | SUPERMAT__K(NEON),
                "the AMX kernel multiplies bf16: it needs bf16 compute (compute = SUPERMAT_COMPUTE_BF16)", 0, NULL},
    /* BF16 */ {SUPERMAT__K(AUTO) | SUPERMAT__K(AVX512) | SUPERMAT__K(AMX), "bf16 compute runs on the AVX-512 or AMX kernel (kernel auto, avx512 or amx)",
                1u << SUPERMAT_WEIGHTS_I8, "bf16 compute multiplies bf16 weights: not with int8 weights"},
    /* INT8 */ {SUPERMAT__K(AUTO) | SUPERMAT__K(AVX512) | SUPERMAT__K(AVX2),
                "int8 compute runs on the AVX-512 (AVX512_VNNI) or AVX2 (AVX-VNNI) kernel (kernel auto, avx512 or avx2)", 0, NULL},
};
static int supermat__cpu_has_any_vnni(void) { return supermat__cpu_has_avx512_vnni() || supermat__cpu_has_avx_vnni(); }
static const struct supermat__need { int compute, kernel; int (*has)(void); const char *lacks; } supermat__needs[] = {
    {SUPERMAT_COMPUTE_BF16, -1, supermat__cpu_has_avx512_bf16, "bf16 compute needs AVX512_BF16, which this CPU (or build) lacks"},
    {-1, SUPERMAT_KERNEL_AVX2, supermat__cpu_has_avx2, "AVX2 kernels requested but this CPU (or build) lacks AVX2/FMA/F16C"},
    {-1, SUPERMAT_KERNEL_AVX512, supermat__cpu_has_avx512, "AVX-512 kernels requested but this CPU (or build) lacks AVX-512F"},
    {-1, SUPERMAT_KERNEL_NEON, supermat__cpu_has_neon, "NEON kernels requested but this is not an aarch64 build"},
    {-1, SUPERMAT_KERNEL_AMX, supermat__cpu_has_amx_bf16, "AMX kernels requested but this CPU, OS (or build) lacks AMX-TILE + AMX-BF16"},
    {SUPERMAT_COMPUTE_INT8, SUPERMAT_KERNEL_AVX512, supermat__cpu_has_avx512_vnni,
     "int8 compute on the AVX-512 kernel needs AVX512_VNNI (and AVX-512BW), which this CPU (or build) lacks"},
    {SUPERMAT_COMPUTE_INT8, SUPERMAT_KERNEL_AVX2, supermat__cpu_has_avx_vnni,
     "int8 compute on the AVX2 kernel needs AVX-VNNI, which this CPU (or build: gcc >= 11, clang >= 12) lacks"},
    {SUPERMAT_COMPUTE_INT8, SUPERMAT_KERNEL_AUTO, supermat__cpu_has_any_vnni, "int8 compute needs AVX512_VNNI or AVX-VNNI, which this CPU (or build) lacks"},
};
#undef SUPERMAT__K
static supermat_result supermat__check_combo(supermat_kernel kernel, supermat_compute compute, supermat_weights weights, supermat_error *err) {
    const struct supermat__combo *c = &supermat__combos[compute];
    size_t i;
    for (i = 0; i < sizeof supermat__needs / sizeof supermat__needs[0]; i++) /* a mode's own need */
        if (supermat__needs[i].kernel < 0 && supermat__needs[i].compute == (int)compute && !supermat__needs[i].has())
            return supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "%s", supermat__needs[i].lacks);
    if (!(c->kernels & (1u << kernel))) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s", c->kernels_why);
    if (c->refused_weights & (1u << weights)) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s", c->weights_why);
    for (i = 0; i < sizeof supermat__needs / sizeof supermat__needs[0]; i++) {
        const struct supermat__need *n = &supermat__needs[i];
        if (n->kernel < 0 || n->kernel != (int)kernel || (n->compute >= 0 && n->compute != (int)compute)) continue;
        if (!n->has()) return supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "%s", n->lacks);
    }
    return SUPERMAT_SUCCESS;
}

static supermat_result supermat__model_create(const supermat_model_desc *desc, supermat_model **out, supermat_error *err, supermat__pkrec *rec) {
    supermat__loader L;
    supermat_model *m;
    supermat_allocator a;
    uint64_t hlen = 0;
    int ntok = 0, i, k, n;
    char buf[128];
    supermat_result r;
    if (out) *out = NULL;
    if (!desc || !out) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "desc and out must not be NULL");
    if (!desc->data) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "desc->data is NULL");
    if ((unsigned)desc->weights >= SUPERMAT_WEIGHTS_COUNT) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "unknown weight format %d", (int)desc->weights);
    if ((unsigned)desc->conv >= SUPERMAT_CONV_COUNT) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "unknown convolution algorithm %d", (int)desc->conv);
    if ((unsigned)desc->kernel >= SUPERMAT_KERNEL_COUNT) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "unknown kernel %d", (int)desc->kernel);
    if ((unsigned)desc->compute >= SUPERMAT_COMPUTE_COUNT) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "unknown compute mode %d", (int)desc->compute);
    if ((r = supermat__check_combo(desc->kernel, desc->compute, desc->weights, err))) return r;
    a = supermat__resolve_allocator(&desc->allocator);
    r = supermat__st_header(desc->data, desc->size, desc->size, &hlen, err);
    if (r) return r;
    m = (supermat_model *)supermat__alloc(&a, sizeof *m);
    if (!m) return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory for the model");
    memset(m, 0, sizeof *m);
    m->alloc = a;
    memset(&L, 0, sizeof L);
    L.m = m; L.data = (const unsigned char *)desc->data; L.size = desc->size; L.copy = desc->copy_data; L.err = err;
    L.js = (const char *)desc->data + 8; L.meta = -1;
    L.avx2 = desc->kernel == SUPERMAT_KERNEL_SCALAR ? 0 : supermat__cpu_has_avx2();
    L.weights = (int)desc->weights;
    L.cap = desc->max_memory;
    L.bf16c = desc->compute == SUPERMAT_COMPUTE_BF16;
    L.i8c = desc->compute == SUPERMAT_COMPUTE_INT8;
    m->info.compute = desc->compute;
    L.conv = (int)desc->conv;
    m->info.conv = desc->conv;
    r = supermat__st_tokens(desc->data, desc->size, desc->size, &a, &L.toks, &ntok, err);
    if (r) { supermat__model_free(m); return r; }
    /* the tensor table */
    n = 0;
    for (i = 0, k = 1; i < L.toks[0].size; i++, k = L.toks[k].next) {
        if (supermat__json_eq(L.js, &L.toks[k], "__metadata__")) { L.meta = k + 1; continue; }
        n++;
    }
    if (L.meta >= 0 && L.toks[L.meta].type != SUPERMAT_JSON_OBJECT) L.meta = -1;
    L.ti = (supermat_tensor_info *)supermat__alloc(&a, sizeof(supermat_tensor_info) * (size_t)(n + 1));
    L.used = (unsigned char *)supermat__alloc(&a, (size_t)n + 1);
    L.qsc = (int *)supermat__alloc(&a, sizeof(int) * ((size_t)n + 1));
    if (!L.ti || !L.used || !L.qsc) { L.r = supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory for the tensor table"); goto done; }
    memset(L.used, 0, (size_t)n + 1);
    if (rec) {
        rec->nt = n;
        rec->uses = (int *)supermat__alloc(&a, sizeof(int) * ((size_t)n + 1));
        rec->pkuses = (int *)supermat__alloc(&a, sizeof(int) * ((size_t)n + 1));
        if (!rec->uses || !rec->pkuses) { L.r = supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory for the packing table"); goto done; }
        memset(rec->uses, 0, sizeof(int) * ((size_t)n + 1));
        memset(rec->pkuses, 0, sizeof(int) * ((size_t)n + 1));
        rec->nt = n;
        L.rec = rec;
    }
    for (i = 0, k = 1; i < L.toks[0].size && !L.r; i++, k = L.toks[k].next) {
        if (supermat__json_eq(L.js, &L.toks[k], "__metadata__")) continue;
        L.r = supermat__st_entry(L.js, L.toks, k, 8 + hlen, desc->size, &L.ti[L.nt], err);
        if (!L.r) L.nt++;
    }
    supermat__check_i8(&L);
    if (L.r) goto done;
    /* the architecture from the metadata */
    if (L.meta < 0) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "the file has no __metadata__: it is not a supermat model (make one with `supermat convert`)"); goto done; }
    if ((int)supermat__meta_num(&L, "supermat.format_version", 0, 1e9, 0, 1) != 1 && !L.r)
        L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "model format version is not 1");
    supermat__meta_str(&L, "supermat.kind", buf, sizeof buf, 1);
    if (L.r) goto done;
    if (!strcmp(buf, "supermat")) m->info.kind = SUPERMAT_KIND_SUPERMAT;
    else if (!strcmp(buf, "supermat-mv")) m->info.kind = SUPERMAT_KIND_SUPERMAT_MV;
    else if (!strcmp(buf, "uv-refine")) m->info.kind = SUPERMAT_KIND_UV_REFINE;
    else { L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "unknown model kind '%s'", buf); goto done; }
    m->in_ch = (int)supermat__meta_num(&L, "unet.in_channels", 1, 64, 4, 1);
    m->out_ch = (int)supermat__meta_num(&L, "unet.out_channels", 1, 64, 4, 1);
    m->L = supermat__meta_list(&L, "unet.block_out_channels", m->boc, SUPERMAT__MAXL, 1, 65536);
    n = supermat__meta_list(&L, "unet.num_heads", m->heads, SUPERMAT__MAXL, 1, 4096);
    if (!L.r && n != m->L) L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "unet.num_heads has %d entries for %d blocks", n, m->L);
    m->lpb = (int)supermat__meta_num(&L, "unet.layers_per_block", 1, SUPERMAT__MAXLAYERS - 1, 2, 1);
    m->groups = (int)supermat__meta_num(&L, "unet.norm_num_groups", 1, 4096, 32, 1);
    m->eps = (float)supermat__meta_num(&L, "unet.norm_eps", 0, 1, 1e-5, 1);
    m->cross_dim = (int)supermat__meta_num(&L, "unet.cross_attention_dim", 1, 65536, 1024, 1);
    n = supermat__meta_types(&L, "unet.down_block_types", m->down_attn, SUPERMAT__MAXL);
    if (!L.r && n != m->L) L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "unet.down_block_types has %d entries for %d blocks", n, m->L);
    n = supermat__meta_types(&L, "unet.up_block_types", m->up_attn, SUPERMAT__MAXL);
    if (!L.r && n != m->L) L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "unet.up_block_types has %d entries for %d blocks", n, m->L);
    m->flip_sin_to_cos = (int)supermat__meta_num(&L, "unet.flip_sin_to_cos", 0, 1, 1, 1);
    m->freq_shift = (float)supermat__meta_num(&L, "unet.freq_shift", -1e6, 1e6, 0, 1);
    m->branches = (int)supermat__meta_num(&L, "unet.branches", 1, SUPERMAT__MAXBRANCH, 2, 1);
    m->class_in = (int)supermat__meta_num(&L, "unet.class_embed_in", 0, 4096, 0, 0);
    m->vin = (int)supermat__meta_num(&L, "vae.in_channels", 1, 16, 3, 1);
    m->vout = (int)supermat__meta_num(&L, "vae.out_channels", 1, 16, 3, 1);
    m->latent = (int)supermat__meta_num(&L, "vae.latent_channels", 1, 64, 4, 1);
    m->vL = supermat__meta_list(&L, "vae.block_out_channels", m->vboc, SUPERMAT__MAXL, 1, 65536);
    m->vlpb = (int)supermat__meta_num(&L, "vae.layers_per_block", 1, SUPERMAT__MAXLAYERS - 1, 2, 1);
    m->vgroups = (int)supermat__meta_num(&L, "vae.norm_num_groups", 1, 4096, 32, 1);
    m->sf = (float)supermat__meta_num(&L, "vae.scaling_factor", 1e-6, 1e6, 0.18215, 1);
    m->ctx_tokens = (int)supermat__meta_num(&L, "context.tokens", 1, 4096, 77, 1);
    m->ctx_dim = (int)supermat__meta_num(&L, "context.dim", 1, 65536, 1024, 1);
    {
        int T = (int)supermat__meta_num(&L, "sched.num_train_timesteps", 1, 1e6, 1000, 1);
        double b0 = supermat__meta_num(&L, "sched.beta_start", 0, 1, 0.00085, 1), b1 = supermat__meta_num(&L, "sched.beta_end", 0, 1, 0.012, 1);
        char sched[64], pred[64], spacing[64];
        int scaled;
        float acp;
        supermat__meta_str(&L, "sched.beta_schedule", sched, sizeof sched, 1);
        supermat__meta_str(&L, "sched.prediction_type", pred, sizeof pred, 1);
        supermat__meta_str(&L, "sched.timestep_spacing", spacing, sizeof spacing, 0);
        if (L.r) goto done;
        if (strcmp(sched, "scaled_linear") && strcmp(sched, "linear")) { L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "beta schedule '%s' is not supported", sched); goto done; }
        if (strcmp(pred, "v_prediction") && strcmp(pred, "epsilon")) { L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "prediction type '%s' is not supported", pred); goto done; }
        if (spacing[0] && strcmp(spacing, "trailing")) { L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "timestep spacing '%s': the one-step pipeline uses 'trailing'", spacing); goto done; }
        scaled = !strcmp(sched, "scaled_linear");
        m->info.timestep = T - 1; /* trailing spacing, one step */
        acp = supermat__alphas_cumprod(T, b0, b1, scaled, T - 1);
        m->info.alphas_cumprod = acp;
        m->info.v_prediction = !strcmp(pred, "v_prediction");
        /* x_t = 0: v-pred x0 = sqrt(a)*0 - sqrt(1-a)*v ; eps-pred x0 = (0 - sqrt(1-a)*eps)/sqrt(a) */
        m->x0_coef = m->info.v_prediction ? -sqrtf(1.0f - acp) : -sqrtf(1.0f - acp) / sqrtf(acp);
    }
    if (L.r) goto done;
    if (m->L < 2 || m->vL < 1) { L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "the UNet needs at least 2 levels"); goto done; }
    for (i = 0; i < m->L; i++)
        if (m->boc[i] % m->groups) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "%d channels do not split into %d groups", m->boc[i], m->groups); goto done; }
    for (i = 0; i < m->vL; i++)
        if (m->vboc[i] % m->vgroups) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "VAE: %d channels do not split into %d groups", m->vboc[i], m->vgroups); goto done; }
    if (m->ctx_dim != m->cross_dim) { L.r = supermat__fail(err, SUPERMAT_ERROR_SHAPE_MISMATCH, "context", "context dim %d != cross_attention_dim %d", m->ctx_dim, m->cross_dim); goto done; }
    if (m->branches < 2 && m->info.kind != SUPERMAT_KIND_UV_REFINE) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "a SuperMat model has 2 branches, the file says %d", m->branches); goto done; }
    if ((m->info.kind == SUPERMAT_KIND_SUPERMAT_MV) != (m->class_in > 0)) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "a %s model %s a camera embedding (unet.class_embed_in = %d)", buf, m->class_in ? "has" : "needs", m->class_in); goto done; }
    if (m->info.kind == SUPERMAT_KIND_UV_REFINE && m->in_ch != m->latent + 4) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "a UV-refine model takes latent + mask + position = %d input channels, the file says %d", m->latent + 4, m->in_ch); goto done; }
    if (m->info.kind != SUPERMAT_KIND_UV_REFINE && m->in_ch != m->latent) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "the UNet takes %d channels, the VAE latent has %d", m->in_ch, m->latent); goto done; }
    m->temb_dim = 4 * m->boc[0];
    {   /* the pipeline the file records: what a session's zero fields stand for */
        double ws = supermat__meta_num(&L, "pipeline.work_size", 0, 16384, 0, 0);
        m->info.detail_sigma = (float)supermat__meta_num(&L, "pipeline.detail_sigma", 0, 1, 0, 0);
        m->info.chroma_weight = (float)supermat__meta_num(&L, "pipeline.chroma_weight", 0, 1, 0, 0);
        m->info.bake_detail_sigma = (float)supermat__meta_num(&L, "pipeline.bake_detail_sigma", 0, 1, 0, 0);
        if (L.r) goto done;
        {
            static const char *const key[2] = {"pipeline.roughness_curve", "pipeline.metallic_curve"}, *const map[2] = {"roughness", "metallic"};
            char cv[1024], why[160];
            int c;
            for (c = 0; c < 2; c++) {
                float *k = c ? m->info.metallic_curve : m->info.roughness_curve;
                int *n = c ? &m->info.metallic_knots : &m->info.roughness_knots;
                if (!supermat__meta_str(&L, key[c], cv, sizeof cv, 0)) {
                    if (m->info.kind == SUPERMAT_KIND_UV_REFINE) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata %s on a uv-refine model, which makes no %s map", key[c], map[c]); goto done; }
                    if (supermat__curve_read(cv, k, n, why, sizeof why)) {
                        L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata '%s' = '%.64s': %s", key[c], cv, why);
                        goto done;
                    }
                } else if (L.r) goto done;
            }
        }
        if (ws != floor(ws) || ((int)ws % 8) || (ws > 0 && ws < 8)) { L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata 'pipeline.work_size' = %g: 0 or a multiple of 8 up to 16384", ws); goto done; }
        m->info.work_size = (int)ws;
        if (m->info.kind == SUPERMAT_KIND_UV_REFINE && (m->info.detail_sigma > 0.0f || m->info.chroma_weight > 0.0f || m->info.bake_detail_sigma > 0.0f)) {
            L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "metadata pipeline.detail_sigma / chroma_weight / bake_detail_sigma on a uv-refine model, which has no picture to take them from");
            goto done;
        }
    }
    {   /* a pre-packed file: its panels replace the packing (PRE-PACKED MODELS) */
        char pkv[32];
        if (!supermat__meta_str(&L, "supermat.packed", pkv, sizeof pkv, 0)) {
            int td = supermat__find_tensor(&L, "supermat.packed.data"), tx = supermat__find_tensor(&L, "supermat.packed.index");
            int pconv = (int)supermat__meta_num(&L, "supermat.packed.conv", 0, SUPERMAT_CONV_COUNT - 1, 0, 1);
            int pcomp = (int)supermat__meta_num(&L, "supermat.packed.compute", 0, SUPERMAT_COMPUTE_COUNT - 1, 0, 1);
            int pwts = (int)supermat__meta_num(&L, "supermat.packed.weights", 1, SUPERMAT_WEIGHTS_COUNT - 1, 1, 1);
            static const char *const wn[] = {"default", "f32", "f16", "bf16", "int8"}, *const cn[] = {"direct", "winograd-f2", "winograd-f4"}, *const xn[] = {"f32", "bf16", "int8"};
            if (L.r) goto done;
            if (strcmp(pkv, "1")) { L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "pre-packed format '%s' (this version reads 1): pack the original model file again", pkv); goto done; }
            if (rec) { L.r = supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "the model file is pre-packed already: pack the original file"); goto done; }
            if (td < 0 || tx < 0 || L.ti[td].dtype != SUPERMAT_DTYPE_U8 || L.ti[tx].dtype != SUPERMAT_DTYPE_U8 || L.ti[td].ndim != 1 || L.ti[tx].ndim != 1 ||
                L.ti[tx].nbytes % (8 * SUPERMAT__PKF) || L.ti[tx].nbytes / (8 * SUPERMAT__PKF) > 0x7fffffff) {
                L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "a pre-packed model needs the U8 tensors supermat.packed.data and supermat.packed.index (a multiple of %d bytes)", 8 * SUPERMAT__PKF);
                goto done;
            }
            if (pconv != (int)desc->conv || pcomp != (int)desc->compute || (desc->weights != SUPERMAT_WEIGHTS_DEFAULT && (int)desc->weights != pwts)) {
                L.r = supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "this file was pre-packed for weights %s, conv %s, compute %s; create the model with those (weights may be default) or pack the original file for weights %s, conv %s, compute %s",
                                     wn[pwts], cn[pconv], xn[pcomp], wn[desc->weights], cn[desc->conv], xn[desc->compute]);
                goto done;
            }
            L.pk = L.data + L.ti[td].offset;
            L.pk_size = L.ti[td].nbytes;
            L.pk_idx = L.data + L.ti[tx].offset;
            L.pk_n = (int)(L.ti[tx].nbytes / (8 * SUPERMAT__PKF));
            if ((uintptr_t)L.pk & 63) L.copy = 1; /* not 64-byte aligned (a plain malloc): copied, as with copy_data */
            m->info.weights = (supermat_weights)pwts;
            m->info.prepacked = 1;
        }
    }
    /* bind and pack everything */
    supermat__bind_unet(&L);
    m->info.unet_params = L.params;
    L.params = 0;
    supermat__bind_vae(&L);
    m->info.vae_params = L.params;
    if (L.pk && !L.r && L.pk_next != L.pk_n)
        L.r = supermat__fail(err, SUPERMAT_ERROR_MALFORMED_FILE, NULL, "the pre-packed index has %d records; this architecture packs %d", L.pk_n, L.pk_next);
done:
    if (L.ti) supermat__free(&a, L.ti, sizeof(supermat_tensor_info) * (size_t)(n + 1));
    if (L.used) supermat__free(&a, L.used, (size_t)n + 1);
    if (L.qsc) supermat__free(&a, L.qsc, sizeof(int) * ((size_t)n + 1));
    if (L.toks) supermat__free(&a, L.toks, sizeof(supermat_json_tok) * (size_t)ntok);
    if (L.r) { supermat__model_free(m); return L.r; }
    if (L.bf16c) m->info.weights = SUPERMAT_WEIGHTS_BF16;
    if (L.i8c) m->info.weights = SUPERMAT_WEIGHTS_I8;
    m->info.kernel = !L.avx2 ? (desc->kernel == SUPERMAT_KERNEL_NEON || (desc->kernel == SUPERMAT_KERNEL_AUTO && supermat__cpu_has_neon())
                                    ? SUPERMAT_KERNEL_NEON : SUPERMAT_KERNEL_SCALAR)
                   : L.bf16c && (desc->kernel == SUPERMAT_KERNEL_AMX || (desc->kernel == SUPERMAT_KERNEL_AUTO && supermat__cpu_has_amx_bf16()))
                         ? SUPERMAT_KERNEL_AMX
                   : desc->kernel == SUPERMAT_KERNEL_AVX512 ||
                             (desc->kernel == SUPERMAT_KERNEL_AUTO && supermat__cpu_has_avx512() && (!L.i8c || supermat__cpu_has_avx512_vnni()))
                         ? SUPERMAT_KERNEL_AVX512 : SUPERMAT_KERNEL_AVX2;
    m->info.unet_in_channels = m->in_ch; m->info.unet_out_channels = m->out_ch; m->info.unet_levels = m->L;
    m->info.layers_per_block = m->lpb; m->info.norm_groups = m->groups;
    for (i = 0; i < m->L; i++) { m->info.block_channels[i] = m->boc[i]; m->info.num_heads[i] = m->heads[i]; }
    for (i = 0; i < m->vL; i++) m->info.vae_block_channels[i] = m->vboc[i];
    m->info.vae_levels = m->vL; m->info.latent_channels = m->latent; m->info.scaling_factor = m->sf;
    m->info.cross_attention_dim = m->cross_dim; m->info.context_tokens = m->ctx_tokens; m->info.branches = m->branches;
    m->info.class_embed_in = m->class_in;
    *out = m;
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

/* the descriptor guard of model_desc, session_desc and run_desc (their _start_canary / _end_canary) */
static supermat_result supermat__canary(uint32_t a, uint32_t b, const char *what, supermat_error *err) {
    if (a == 0 && b == 0) return SUPERMAT_SUCCESS;
    return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s: _start_canary / _end_canary are 0x%x / 0x%x, not 0: clear the struct "
                          "(memset to 0, or = {0}) before setting its fields", what, (unsigned)a, (unsigned)b);
}

SUPERMAT__DEF supermat_result supermat_model_create(const supermat_model_desc *desc, supermat_model **out, supermat_error *err) {
    supermat_model_desc d;
    char v[32];
    supermat_result r;
    if (out) *out = NULL;
    if (!desc || !out) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "desc and out must not be NULL");
    if ((r = supermat__canary(desc->_start_canary, desc->_end_canary, "supermat_model_desc", err))) return r;
    d = *desc;
    /* a pre-packed file: conv and compute left 0 are the ones it was packed for (weights DEFAULT already are);
       a header that does not parse is left to supermat__model_create's messages */
    if (d.data && (d.conv == SUPERMAT_CONV_DIRECT || d.compute == SUPERMAT_COMPUTE_F32)) {
        supermat_allocator a = supermat__resolve_allocator(&d.allocator);
        supermat_json_tok *toks = NULL;
        uint64_t hlen = 0;
        int ntok = 0;
        const char *js = (const char *)d.data + 8;
        if (!supermat__st_header(d.data, d.size, d.size, &hlen, NULL) && !supermat__st_tokens(d.data, d.size, 8 + hlen, &a, &toks, &ntok, NULL)) {
            if (!supermat__meta_value(js, toks, "supermat.packed", v, sizeof v) && !strcmp(v, "1")) {
                /* one digit, an enum value (anything else is left to supermat__model_create's messages) */
                if (d.conv == SUPERMAT_CONV_DIRECT && !supermat__meta_value(js, toks, "supermat.packed.conv", v, sizeof v) &&
                    v[0] >= '0' && v[0] < '0' + SUPERMAT_CONV_COUNT && !v[1])
                    d.conv = (supermat_conv)(v[0] - '0');
                if (d.compute == SUPERMAT_COMPUTE_F32 && !supermat__meta_value(js, toks, "supermat.packed.compute", v, sizeof v) &&
                    v[0] >= '0' && v[0] < '0' + SUPERMAT_COMPUTE_COUNT && !v[1])
                    d.compute = (supermat_compute)(v[0] - '0');
            }
            supermat__free(&a, toks, sizeof(supermat_json_tok) * (size_t)ntok);
        }
    }
    return supermat__model_create(&d, out, err, NULL);
}

/* the growing text of a safetensors header */
typedef struct supermat__text { char *p; size_t n, cap; const supermat_allocator *a; int oom; } supermat__text;
static void supermat__text_put(supermat__text *t, const char *s, size_t n) {
    if (t->oom) return;
    if (t->n + n + 1 > t->cap) {
        size_t nc = t->cap ? t->cap : 4096;
        char *np;
        while (nc < t->n + n + 1) nc *= 2;
        np = (char *)supermat__alloc(t->a, nc);
        if (!np) { t->oom = 1; return; }
        if (t->n) memcpy(np, t->p, t->n);
        supermat__free(t->a, t->p, t->cap);
        t->p = np; t->cap = nc;
    }
    memcpy(t->p + t->n, s, n);
    t->n += n;
}
static void supermat__text_str(supermat__text *t, const char *s) { supermat__text_put(t, s, strlen(s)); }
static void supermat__text_entry(supermat__text *t, const char *js, const supermat_json_tok *key, const char *dtype,
                                 const char *name, const int64_t *shape, int ndim, uint64_t b0, uint64_t b1) {
    char num[96];
    int d;
    supermat__text_str(t, ",\"");
    if (key) supermat__text_put(t, js + key->start, (size_t)(key->end - key->start));
    else supermat__text_str(t, name);
    supermat__text_str(t, "\":{\"dtype\":\"");
    supermat__text_str(t, dtype);
    supermat__text_str(t, "\",\"shape\":[");
    for (d = 0; d < ndim; d++) { snprintf(num, sizeof num, d ? ",%lld" : "%lld", (long long)shape[d]); supermat__text_str(t, num); }
    snprintf(num, sizeof num, "],\"data_offsets\":[%llu,%llu]}", (unsigned long long)b0, (unsigned long long)b1);
    supermat__text_str(t, num);
}

static int supermat__wput(supermat_write_fn write, void *user, const void *p, uint64_t n, uint64_t *done) {
    static const unsigned char zeros[64] = {0};
    if (!n) return 0;
    if (write(user, p ? p : zeros, (size_t)n)) return -1;
    *done += n;
    return 0;
}

SUPERMAT__DEF supermat_result supermat_model_write_packed(const supermat_model_desc *desc, supermat_write_fn write, void *user,
                                                          uint64_t *bytes, supermat_error *err) {
    static const char *const dtn[] = {"", "F32", "F16", "BF16", "I8", "U8"};
    supermat__pkrec R;
    supermat_model *m = NULL;
    supermat_allocator a;
    supermat_json_tok *toks = NULL;
    supermat__text T;
    supermat_tensor_info *ti = NULL;
    unsigned char *strip = NULL;
    int64_t *idx = NULL;
    int ntok = 0, nt = 0, ntab = 0, i, k, meta = -1, pass;
    uint64_t hlen = 0, blob = 0, done = 0, off, ib;
    const char *js;
    supermat_result r;
    if (bytes) *bytes = 0;
    if (!desc || !write) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "desc and write must not be NULL");
    if ((r = supermat__canary(desc->_start_canary, desc->_end_canary, "supermat_model_desc", err))) return r;
    memset(&R, 0, sizeof R);
    memset(&T, 0, sizeof T);
    r = supermat__model_create(desc, &m, err, &R);
    a = supermat__resolve_allocator(&desc->allocator);
    T.a = &a;
    if (r) goto out;
    js = (const char *)desc->data + 8;
    supermat__st_header(desc->data, desc->size, desc->size, &hlen, NULL);
    if ((r = supermat__st_tokens(desc->data, desc->size, desc->size, &a, &toks, &ntok, err))) goto out;
    for (i = 0, k = 1; i < toks[0].size; i++, k = toks[k].next) {
        if (supermat__json_eq(js, &toks[k], "__metadata__")) meta = k + 1;
        else nt++;
    }
    ntab = nt;
    ti = (supermat_tensor_info *)supermat__alloc(&a, sizeof *ti * ((size_t)ntab + 1));
    strip = (unsigned char *)supermat__alloc(&a, (size_t)ntab + 1);
    idx = (int64_t *)supermat__alloc(&a, sizeof *idx * SUPERMAT__PKF * ((size_t)R.n + 1));
    if (!ti || !strip || !idx) { r = supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory writing the pre-packed model"); goto out; }
    for (i = 0, k = 1, nt = 0; i < toks[0].size; i++, k = toks[k].next) {
        if (k + 1 == meta) continue;
        if ((r = supermat__st_entry(js, toks, k, 8 + hlen, desc->size, &ti[nt], err))) goto out;
        strip[nt] = R.pkuses[nt] > 0 && R.pkuses[nt] == R.uses[nt]; /* only the packing reads it */
        nt++;
    }
    for (i = 0; i < nt; i++) /* an int8 weight left out takes its scales with it */
        if (strip[i] && ti[i].dtype == SUPERMAT_DTYPE_I8) {
            char sn[sizeof ti[i].name + 8];
            supermat__name(sn, sizeof sn, "%s_scale", ti[i].name);
            for (k = 0; k < nt; k++) if (!strcmp(ti[k].name, sn)) strip[k] = 1;
        }
    /* the index: where each packed weight goes in the blob (64-byte aligned pieces) */
    for (i = 0; i < R.n; i++) {
        const supermat__pw *pw = R.items[i].pw;
        int64_t *e = idx + (size_t)i * SUPERMAT__PKF;
        int np;
        uint64_t main, qs;
        if (!pw) { /* kind 3: keys, then values */
            e[0] = 3; e[1] = R.items[i].c; e[2] = R.items[i].tokens; e[3] = 0; e[4] = 0;
            e[5] = (int64_t)blob; blob += ((uint64_t)R.items[i].kpn * 4 + 63) / 64 * 64;
            e[6] = (int64_t)blob; blob += ((uint64_t)R.items[i].vpn * 4 + 63) / 64 * 64;
            e[7] = -1;
            continue;
        }
        np = (pw->N + SUPERMAT__NR - 1) / SUPERMAT__NR;
        if (R.items[i].wino) {
            const supermat__wino *wg = R.items[i].wino;
            main = (uint64_t)(wg->a * wg->a) * (uint64_t)np * SUPERMAT__NR * (uint64_t)wg->u[0].K * 4;
            e[0] = 2; e[3] = 0; e[4] = wg->a; qs = 0;
        } else {
            main = supermat__pk_main_bytes(pw->fmt, pw->K, pw->N);
            qs = supermat__pk_qs_bytes(pw->fmt, pw->K, pw->N, pw->qcin);
            e[0] = 1; e[3] = pw->fmt; e[4] = R.items[i].sfmt;
        }
        e[1] = pw->K; e[2] = pw->N;
        e[5] = (int64_t)blob; blob += (main + 63) / 64 * 64;
        e[6] = qs ? (int64_t)blob : -1; blob += (qs + 63) / 64 * 64;
        e[7] = pw->bias ? (int64_t)blob : -1; blob += pw->bias ? (uint64_t)np * SUPERMAT__NR * 4 : 0;
    }
    ib = (uint64_t)R.n * SUPERMAT__PKF * 8;
    /* the header: the metadata, the blob and index first (64-byte aligned), then the tensors kept, widest
       elements first so each stays aligned to its element size */
    supermat__text_str(&T, "{\"__metadata__\":{");
    if (meta >= 0 && toks[meta].type == SUPERMAT_JSON_OBJECT)
        for (i = 0, k = meta + 1; i < toks[meta].size; i++, k = toks[k].next) {
            const supermat_json_tok *v = &toks[k + 1];
            if (!strncmp(js + toks[k].start, "supermat.packed", 15)) continue;
            supermat__text_str(&T, "\"");
            supermat__text_put(&T, js + toks[k].start, (size_t)(toks[k].end - toks[k].start));
            supermat__text_str(&T, v->type == SUPERMAT_JSON_STRING ? "\":\"" : "\":");
            supermat__text_put(&T, js + v->start, (size_t)(v->end - v->start));
            supermat__text_str(&T, v->type == SUPERMAT_JSON_STRING ? "\"," : ",");
        }
    {
        char opt[160];
        /* the storage format the packing resolved (before bf16 compute's pairing) */
        int w = (int)m->info.weights;
        for (i = 0; i < R.n; i++) if (R.items[i].pw) { w = R.items[i].sfmt + 1; break; }
        snprintf(opt, sizeof opt, "\"supermat.packed\":\"1\",\"supermat.packed.weights\":\"%d\",\"supermat.packed.conv\":\"%d\",\"supermat.packed.compute\":\"%d\"}",
                 w, (int)desc->conv, (int)desc->compute);
        supermat__text_str(&T, opt);
    }
    {
        int64_t sh[1];
        sh[0] = (int64_t)blob;
        supermat__text_entry(&T, NULL, NULL, "U8", "supermat.packed.data", sh, 1, 0, blob);
        sh[0] = (int64_t)ib;
        supermat__text_entry(&T, NULL, NULL, "U8", "supermat.packed.index", sh, 1, blob, blob + ib);
    }
    off = blob + ib;
    for (pass = 4; pass >= 1; pass /= 2)
        for (i = 0, k = 1, nt = 0; i < toks[0].size; i++, k = toks[k].next) {
            uint64_t esz;
            if (k + 1 == meta) continue;
            esz = ti[nt].dtype == SUPERMAT_DTYPE_F32 ? 4 : ti[nt].dtype == SUPERMAT_DTYPE_F16 || ti[nt].dtype == SUPERMAT_DTYPE_BF16 ? 2 : 1;
            if (!strip[nt] && esz == (uint64_t)pass) {
                supermat__text_entry(&T, js, &toks[k], dtn[ti[nt].dtype], NULL, ti[nt].shape, ti[nt].ndim, off, off + ti[nt].nbytes);
                off += ti[nt].nbytes;
            }
            nt++;
        }
    supermat__text_str(&T, "}");
    while ((8 + T.n) % 64 && !T.oom) supermat__text_str(&T, " ");
    if (T.oom) { r = supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory writing the pre-packed model's header"); goto out; }
    {
        unsigned char h8[8];
        for (i = 0; i < 8; i++) h8[i] = (unsigned char)((uint64_t)T.n >> (8 * i));
        if (supermat__wput(write, user, h8, 8, &done) || supermat__wput(write, user, T.p, T.n, &done)) goto io;
    }
    for (i = 0; i < R.n; i++) {
        const supermat__pw *pw = R.items[i].pw;
        const int64_t *e = idx + (size_t)i * SUPERMAT__PKF;
        int np, xi;
        uint64_t main = 0, qs;
        if (!pw) {
            uint64_t kb = (uint64_t)R.items[i].kpn * 4, vb = (uint64_t)R.items[i].vpn * 4;
            if (supermat__wput(write, user, R.items[i].kp, kb, &done) || supermat__wput(write, user, NULL, (64 - kb % 64) % 64, &done) ||
                supermat__wput(write, user, R.items[i].vp, vb, &done) || supermat__wput(write, user, NULL, (64 - vb % 64) % 64, &done)) goto io;
            continue;
        }
        np = (pw->N + SUPERMAT__NR - 1) / SUPERMAT__NR;
        qs = supermat__pk_qs_bytes(e[0] == 1 ? pw->fmt : 0, pw->K, pw->N, pw->qcin);
        if (R.items[i].wino) {
            const supermat__wino *wg = R.items[i].wino;
            uint64_t one = (uint64_t)np * SUPERMAT__NR * (uint64_t)wg->u[0].K * 4;
            for (xi = 0; xi < wg->a * wg->a; xi++) if (supermat__wput(write, user, wg->u[xi].p, one, &done)) goto io;
            main = one * (uint64_t)(wg->a * wg->a);
        } else {
            main = supermat__pk_main_bytes(pw->fmt, pw->K, pw->N);
            if (supermat__wput(write, user, pw->fmt == 0 ? (const void *)pw->p : pw->q, main, &done)) goto io;
        }
        if (supermat__wput(write, user, NULL, (64 - main % 64) % 64, &done)) goto io;
        if (qs && (supermat__wput(write, user, pw->qs, qs, &done) || supermat__wput(write, user, NULL, (64 - qs % 64) % 64, &done))) goto io;
        if (pw->bias && supermat__wput(write, user, pw->bias, (uint64_t)np * SUPERMAT__NR * 4, &done)) goto io;
    }
    if (supermat__wput(write, user, idx, ib, &done)) goto io;
    for (pass = 4; pass >= 1; pass /= 2)
        for (i = 0; i < nt; i++) {
            uint64_t esz = ti[i].dtype == SUPERMAT_DTYPE_F32 ? 4 : ti[i].dtype == SUPERMAT_DTYPE_F16 || ti[i].dtype == SUPERMAT_DTYPE_BF16 ? 2 : 1;
            if (!strip[i] && esz == (uint64_t)pass && supermat__wput(write, user, (const unsigned char *)desc->data + ti[i].offset, ti[i].nbytes, &done)) goto io;
        }
    if (bytes) *bytes = done;
    supermat__ok(err);
    r = SUPERMAT_SUCCESS;
    goto out;
io:
    r = supermat__fail(err, SUPERMAT_ERROR_IO, NULL, "the write callback failed after %llu bytes", (unsigned long long)done);
out:
    if (T.p) supermat__free(&a, T.p, T.cap);
    if (toks) supermat__free(&a, toks, sizeof(supermat_json_tok) * (size_t)ntok);
    if (ti) supermat__free(&a, ti, sizeof *ti * ((size_t)ntab + 1));
    if (strip) supermat__free(&a, strip, (size_t)ntab + 1);
    if (idx) supermat__free(&a, idx, sizeof *idx * SUPERMAT__PKF * ((size_t)R.n + 1));
    if (R.items) supermat__free(&a, R.items, sizeof *R.items * (size_t)R.cap);
    if (R.uses) supermat__free(&a, R.uses, sizeof(int) * ((size_t)R.nt + 1));
    if (R.pkuses) supermat__free(&a, R.pkuses, sizeof(int) * ((size_t)R.nt + 1));
    supermat_model_destroy(m);
    return r;
}

SUPERMAT__DEF void supermat_model_get_info(const supermat_model *model, supermat_model_info *info) {
    if (model && info) *info = model->info;
}
SUPERMAT__DEF void supermat_model_destroy(supermat_model *model) { supermat__model_free(model); }

/* >>unet : forward passes. Every function allocates its output first, then its temporaries, from the
   planned arena; while planning they only allocate and count FLOPs. */
static supermat__t supermat__resnet_fwd(supermat__ctx *X, const supermat__resnet *r, const supermat__t *x, int groups,
                                        const float *semb, int nemb, int temb_dim) {
    supermat__t out = supermat__tensor(X, x->n, x->h, x->w, r->cout), t, h;
    int np = (r->cout + 15) / 16 * 16, v;
    float *bias = NULL;
    t = supermat__tensor(X, x->n, x->h, x->w, r->cin);
    supermat__groupnorm(X, x, &t, &r->n1, groups, 1);
    h = supermat__tensor(X, x->n, x->h, x->w, r->cout);
    if (semb) {
        bias = supermat__get(X, (size_t)np * nemb);
        supermat__linear(X, semb, (size_t)temb_dim, nemb, &r->temb, bias, (size_t)np, NULL, 0);
        if (supermat__live(X)) { int i, e; for (e = 0; e < nemb; e++) for (i = 0; i < np; i++) bias[(size_t)e * np + i] += r->c1.w.bias[i]; }
    }
    if (semb && nemb > 1) { /* a time/camera embedding per image: one convolution per image */
        for (v = 0; v < x->n; v++) {
            supermat__t tv = t, hv = h;
            tv.n = hv.n = 1;
            tv.d = t.d ? t.d + (size_t)v * x->h * x->w * r->cin : NULL;
            hv.d = h.d ? h.d + (size_t)v * x->h * x->w * r->cout : NULL;
            if (X->plan) { tv.d = t.d; hv.d = h.d; }
            supermat__conv2d(X, &tv, x->h, x->w, &r->c1, 0, &hv, bias + (size_t)v * np, NULL);
        }
    } else {
        supermat__conv2d(X, &t, x->h, x->w, &r->c1, 0, &h, bias, NULL);
    }
    supermat__put(X, bias);
    supermat__drop(X, &t);
    t = supermat__tensor(X, x->n, x->h, x->w, r->cout);
    supermat__groupnorm(X, &h, &t, &r->n2, groups, 1);
    supermat__drop(X, &h);
    if (r->has_sc) {
        supermat__conv2d(X, x, x->h, x->w, &r->sc, 0, &out, NULL, NULL);
        supermat__conv2d(X, &t, x->h, x->w, &r->c2, 0, &out, NULL, out.d);
    } else {
        supermat__conv2d(X, &t, x->h, x->w, &r->c2, 0, &out, NULL, x->d);
    }
    supermat__drop(X, &t);
    supermat__step(X, 1.0, "resnet");
    return out;
}

static supermat__t supermat__xformer_fwd(supermat__ctx *X, const supermat__xformer *a, const supermat__t *x, int groups, int ctx_tokens) {
    supermat__t out = supermat__tensor(X, x->n, x->h, x->w, x->c);
    int C = x->c, T = x->h * x->w, M = x->n * T, kvg = a->mv ? 1 : x->n, mk = a->mv ? M : T;
    int restrict_mv = a->mv && x->n > 1 && X->mv_att != SUPERMAT_MV_ATTENTION_FULL && T == X->mv_top;
    float scale = (float)(1.0 / sqrt((double)a->d));
    float *t = supermat__get(X, (size_t)M * C), *hs = supermat__get(X, (size_t)M * C), *qkv, *kp, *vp, *q, *ff, *g, *kv = NULL;
    supermat__t tt = *x;
    tt.d = t;
    supermat__groupnorm(X, x, &tt, &a->gn, groups, 0);
    supermat__linear(X, t, (size_t)C, M, &a->proj_in, hs, (size_t)C, NULL, 0);
    /* self-attention */
    supermat__layernorm(X, hs, t, M, &a->ln1);
    qkv = supermat__get(X, (size_t)M * 3 * C);
    supermat__linear(X, t, (size_t)C, M, &a->qkv1, qkv, (size_t)3 * C, NULL, 0);
    if (restrict_mv) { /* approximate modes: per-view key sets (own view, + strided keys of the others) */
        int s = X->mv_att == SUPERMAT_MV_ATTENTION_OWN_VIEW ? 0 : X->mv_stride, per = s ? (T + s - 1) / s : 0;
        kvg = x->n; mk = T + (x->n - 1) * per;
        if (s) {
            kv = supermat__get(X, (size_t)kvg * mk * 2 * C);
            if (supermat__live(X)) {
                int gv, ov, j;
                for (gv = 0; gv < kvg; gv++) {
                    float *dst = kv + (size_t)gv * mk * 2 * C;
                    for (j = 0; j < T; j++, dst += 2 * C) memcpy(dst, qkv + ((size_t)gv * T + j) * 3 * C + C, sizeof(float) * 2 * (size_t)C);
                    for (ov = 0; ov < x->n; ov++)
                        if (ov != gv)
                            for (j = 0; j < T; j += s, dst += 2 * C) memcpy(dst, qkv + ((size_t)ov * T + j) * 3 * C + C, sizeof(float) * 2 * (size_t)C);
                }
            }
        }
    }
    kp = supermat__get(X, (size_t)kvg * a->heads * supermat__attn_kp_floats(mk, a->d));
    vp = supermat__get(X, (size_t)kvg * a->heads * supermat__attn_vp_floats(mk, a->d));
    if (kv) supermat__attn_pack(X, kv, (size_t)2 * C, kv + C, (size_t)2 * C, mk, kvg, a->heads, a->d, kp, vp);
    else supermat__attn_pack(X, qkv + C, (size_t)3 * C, qkv + 2 * C, (size_t)3 * C, mk, kvg, a->heads, a->d, kp, vp);
    supermat__attention(X, qkv, (size_t)3 * C, T, x->n, kp, vp, mk, kvg, a->heads, a->d, scale, t, (size_t)C);
    supermat__put(X, vp); supermat__put(X, kp); supermat__put(X, kv); supermat__put(X, qkv);
    supermat__linear(X, t, (size_t)C, M, &a->out1, hs, (size_t)C, hs, (size_t)C);
    /* cross-attention on the constant context */
    supermat__layernorm(X, hs, t, M, &a->ln2);
    q = supermat__get(X, (size_t)M * C);
    supermat__linear(X, t, (size_t)C, M, &a->q2, q, (size_t)C, NULL, 0);
    supermat__attention(X, q, (size_t)C, M, 1, a->kp2, a->vp2, ctx_tokens, 1, a->heads, a->d, scale, t, (size_t)C);
    supermat__put(X, q);
    supermat__linear(X, t, (size_t)C, M, &a->out2, hs, (size_t)C, hs, (size_t)C);
    /* GEGLU feed-forward */
    supermat__layernorm(X, hs, t, M, &a->ln3);
    ff = supermat__get(X, (size_t)M * 8 * C);
    supermat__linear(X, t, (size_t)C, M, &a->ff1, ff, (size_t)8 * C, NULL, 0);
    g = supermat__get(X, (size_t)M * 4 * C);
    supermat__geglu(X, ff, g, M, 4 * C);
    supermat__put(X, ff);
    supermat__linear(X, g, (size_t)4 * C, M, &a->ff2, hs, (size_t)C, hs, (size_t)C);
    supermat__put(X, g);
    supermat__linear(X, hs, (size_t)C, M, &a->proj_out, out.d, (size_t)C, x->d, (size_t)C);
    supermat__put(X, hs);
    supermat__put(X, t);
    supermat__step(X, 1.0, "transformer");
    return out;
}

static supermat__t supermat__vattn_fwd(supermat__ctx *X, const supermat__vattn *a, const supermat__t *x, int groups) {
    supermat__t out = supermat__tensor(X, x->n, x->h, x->w, x->c), tt = *x;
    int C = x->c, T = x->h * x->w, M = x->n * T;
    float *t = supermat__get(X, (size_t)M * C), *qkv, *kp, *vp;
    tt.d = t;
    supermat__groupnorm(X, x, &tt, &a->gn, groups, 0);
    qkv = supermat__get(X, (size_t)M * 3 * C);
    supermat__linear(X, t, (size_t)C, M, &a->qkv, qkv, (size_t)3 * C, NULL, 0);
    kp = supermat__get(X, (size_t)x->n * supermat__attn_kp_floats(T, C));
    vp = supermat__get(X, (size_t)x->n * supermat__attn_vp_floats(T, C));
    supermat__attn_pack(X, qkv + C, (size_t)3 * C, qkv + 2 * C, (size_t)3 * C, T, x->n, 1, C, kp, vp);
    supermat__attention(X, qkv, (size_t)3 * C, T, x->n, kp, vp, T, x->n, 1, C, (float)(1.0 / sqrt((double)C)), t, (size_t)C);
    supermat__put(X, vp); supermat__put(X, kp); supermat__put(X, qkv);
    supermat__linear(X, t, (size_t)C, M, &a->out, out.d, (size_t)C, x->d, (size_t)C);
    supermat__put(X, t);
    supermat__step(X, 1.0, "vae attention");
    return out;
}

/* conv producing a new tensor; (uh, uw) = virtual nearest-resized input size */
static supermat__t supermat__conv_new(supermat__ctx *X, const supermat__t *x, int uh, int uw, const supermat__conv *cv, int pad_mode) {
    int pad = pad_mode ? 1 : 2 * (cv->k / 2);
    int oh = (uh + pad - cv->k) / cv->stride + 1, ow = (uw + pad - cv->k) / cv->stride + 1;
    supermat__t out = supermat__tensor(X, x->n, oh, ow, cv->cout);
    supermat__conv2d(X, x, uh, uw, cv, pad_mode, &out, NULL, NULL);
    return out;
}

static supermat__t supermat__concat(supermat__ctx *X, const supermat__t *a, const supermat__t *b) {
    supermat__t out = supermat__tensor(X, a->n, a->h, a->w, a->c + b->c);
    size_t p, np = (size_t)a->n * a->h * a->w;
    if (supermat__live(X)) {
        if (a->h != b->h || a->w != b->w) { X->status = SUPERMAT_ERROR_INTERNAL; return out; }
        for (p = 0; p < np; p++) {
            memcpy(out.d + p * out.c, a->d + p * a->c, sizeof(float) * (size_t)a->c);
            memcpy(out.d + p * out.c + a->c, b->d + p * b->c, sizeof(float) * (size_t)b->c);
        }
    }
    return out;
}

/* one up level: pops nres skips from the end of `skips` (without freeing them) */
static supermat__t supermat__up_fwd(supermat__ctx *X, const supermat_model *m, const supermat__level *lv, supermat__t h, int own_h,
                                    const supermat__t *skips, int *nskips, const float *semb, int nemb) {
    int j;
    for (j = 0; j < lv->nres; j++) {
        const supermat__t *s = &skips[--(*nskips)];
        supermat__t cat = supermat__concat(X, &h, s), r;
        if (own_h) supermat__drop(X, &h);
        r = supermat__resnet_fwd(X, &lv->res[j], &cat, m->groups, semb, nemb, m->temb_dim);
        supermat__drop(X, &cat);
        if (lv->has_attn) {
            supermat__t a = supermat__xformer_fwd(X, &lv->att[j], &r, m->groups, m->ctx_tokens);
            supermat__drop(X, &r);
            r = a;
        }
        h = r;
        own_h = 1;
    }
    if (lv->has_sampler) {
        const supermat__t *next = &skips[*nskips - 1];
        supermat__t u = supermat__conv_new(X, &h, next->h, next->w, &lv->sampler, 0);
        supermat__drop(X, &h);
        h = u;
    }
    return h;
}

/* The UNet: trunk once, then each wanted branch. v[b] receives branch b's output (allocated here,
   NULL data for branches not wanted). */
/* a branch's UNet output is ready: report it, turn it into x0 (reported too), then into the decoder's
   input x0 / scaling_factor */
static void supermat__branch_done(supermat__ctx *X, const supermat_model *m, const supermat_run_desc *rd, int b, supermat__t *v) {
    size_t i, n = supermat__numel(v);
    if (!supermat__live(X)) return;
    if (rd->inspect) rd->inspect(rd->inspect_user, SUPERMAT_STAGE_UNET_OUT, b, v->d, v->n, v->h, v->w, v->c);
    for (i = 0; i < n; i++) v->d[i] *= m->x0_coef;
    if (rd->inspect) rd->inspect(rd->inspect_user, SUPERMAT_STAGE_X0, b, v->d, v->n, v->h, v->w, v->c);
    for (i = 0; i < n; i++) v->d[i] /= m->sf;
}

static void supermat__unet_fwd(supermat__ctx *X, const supermat_model *m, const supermat__t *lat, const float *cams, int want,
                               const supermat_run_desc *rd, supermat__t *v, double *flops_trunk, double *flops_branch) {
    supermat__t skips[1 + SUPERMAT__MAXL * (SUPERMAT__MAXLAYERS + 1)], h;
    int ns = 0, l, j, b, nemb = cams ? lat->n : 1, T = m->temb_dim, half = m->boc[0] / 2, i, keep;
    float *emb0 = supermat__get(X, (size_t)m->boc[0]), *e1 = supermat__get(X, (size_t)T * nemb), *emb = supermat__get(X, (size_t)T * nemb);
    double f0 = X->flops;
    /* timestep embedding (float32, as diffusers) */
    if (supermat__live(X)) {
        float lg = (float)(-log(10000.0));
        for (i = 0; i < half; i++) {
            float ex = lg * (float)i / ((float)half - m->freq_shift);
            float arg = (float)m->info.timestep * expf(ex);
            emb0[m->flip_sin_to_cos ? half + i : i] = sinf(arg);
            emb0[m->flip_sin_to_cos ? i : half + i] = cosf(arg);
        }
    }
    supermat__linear(X, emb0, 0, 1, &m->time1, e1, (size_t)T, NULL, 0);
    if (supermat__live(X)) supermat__silu(X, e1, e1, T);
    supermat__linear(X, e1, (size_t)T, 1, &m->time2, emb, (size_t)T, NULL, 0);
    if (cams) { /* camera embedding per view, added to the time embedding */
        float *c1 = supermat__get(X, (size_t)T * nemb);
        for (i = 1; i < nemb; i++) if (supermat__live(X)) memcpy(emb + (size_t)i * T, emb, sizeof(float) * (size_t)T);
        supermat__linear(X, cams, (size_t)m->class_in, nemb, &m->cls1, c1, (size_t)T, NULL, 0);
        if (supermat__live(X)) supermat__silu(X, c1, c1, T * nemb);
        supermat__linear(X, c1, (size_t)T, nemb, &m->cls2, emb, (size_t)T, emb, (size_t)T);
        supermat__put(X, c1);
    }
    if (supermat__live(X)) supermat__silu(X, emb, emb, T * nemb); /* every resnet applies SiLU first */
    supermat__put(X, e1);
    supermat__put(X, emb0);
    /* down */
    skips[ns++] = supermat__conv_new(X, lat, lat->h, lat->w, &m->conv_in, 0);
    h = skips[0];
    for (l = 0; l < m->L; l++) {
        const supermat__level *lv = &m->down[l];
        for (j = 0; j < lv->nres; j++) {
            supermat__t r = supermat__resnet_fwd(X, &lv->res[j], &h, m->groups, emb, nemb, T);
            if (lv->has_attn) {
                supermat__t a = supermat__xformer_fwd(X, &lv->att[j], &r, m->groups, m->ctx_tokens);
                supermat__drop(X, &r);
                r = a;
            }
            skips[ns++] = h = r;
        }
        if (lv->has_sampler) skips[ns++] = h = supermat__conv_new(X, &h, h.h, h.w, &lv->sampler, 0);
    }
    /* mid */
    h = supermat__resnet_fwd(X, &m->mid_res[0], &skips[ns - 1], m->groups, emb, nemb, T);
    {
        supermat__t a = supermat__xformer_fwd(X, &m->mid_att, &h, m->groups, m->ctx_tokens);
        supermat__drop(X, &h);
        h = supermat__resnet_fwd(X, &m->mid_res[1], &a, m->groups, emb, nemb, T);
        supermat__drop(X, &a);
    }
    /* up (trunk): consumed skips are freed */
    for (l = 0; l < m->L - 1; l++) {
        int before = ns;
        h = supermat__up_fwd(X, m, &m->up[l], h, 1, skips, &ns, emb, nemb);
        for (j = ns; j < before; j++) supermat__drop(X, &skips[j]);
    }
    *flops_trunk += X->flops - f0;
    if (supermat__live(X) && rd->inspect) rd->inspect(rd->inspect_user, SUPERMAT_STAGE_TRUNK, 0, h.d, h.n, h.h, h.w, h.c);
    /* the expert branches share the trunk output and the remaining skips */
    keep = ns;
    for (b = 0; b < m->branches; b++) {
        supermat__t hb, t;
        int nsb = keep;
        v[b].d = NULL;
        if (!(want & (1 << b))) continue;
        f0 = X->flops;
        v[b] = supermat__tensor(X, lat->n, lat->h, lat->w, m->out_ch);
        hb = supermat__up_fwd(X, m, &m->last[b], h, 0, skips, &nsb, emb, nemb);
        t = supermat__tensor(X, hb.n, hb.h, hb.w, hb.c);
        supermat__groupnorm(X, &hb, &t, &m->norm_out, m->groups, 1);
        supermat__drop(X, &hb);
        supermat__conv2d(X, &t, t.h, t.w, &m->conv_out[b], 0, &v[b], NULL, NULL);
        supermat__drop(X, &t);
        *flops_branch += X->flops - f0;
        supermat__branch_done(X, m, rd, b, &v[b]);
    }
    supermat__drop(X, &h);
    for (j = 0; j < keep; j++) supermat__drop(X, &skips[j]);
    supermat__put(X, emb);
}

/* >>vae */
static supermat__t supermat__vae_encode(supermat__ctx *X, const supermat_model *m, const supermat__t *img) {
    supermat__t h = supermat__conv_new(X, img, img->h, img->w, &m->e_conv_in, 0), r, t, lat;
    int l, j;
    for (l = 0; l < m->vL; l++) {
        const supermat__level *lv = &m->e_lv[l];
        for (j = 0; j < lv->nres; j++) { r = supermat__resnet_fwd(X, &lv->res[j], &h, m->vgroups, NULL, 0, 0); supermat__drop(X, &h); h = r; }
        if (lv->has_sampler) { r = supermat__conv_new(X, &h, h.h, h.w, &lv->sampler, 1); supermat__drop(X, &h); h = r; }
    }
    r = supermat__resnet_fwd(X, &m->e_mid[0], &h, m->vgroups, NULL, 0, 0); supermat__drop(X, &h);
    h = supermat__vattn_fwd(X, &m->e_att, &r, m->vgroups); supermat__drop(X, &r);
    r = supermat__resnet_fwd(X, &m->e_mid[1], &h, m->vgroups, NULL, 0, 0); supermat__drop(X, &h);
    t = supermat__tensor(X, r.n, r.h, r.w, r.c);
    supermat__groupnorm(X, &r, &t, &m->e_norm_out, m->vgroups, 1);
    supermat__drop(X, &r);
    h = supermat__conv_new(X, &t, t.h, t.w, &m->e_conv_out, 0);
    supermat__drop(X, &t);
    lat = supermat__conv_new(X, &h, h.h, h.w, &m->quant, 0); /* the mean half: the distribution's mode */
    supermat__drop(X, &h);
    if (supermat__live(X)) { size_t i, n = supermat__numel(&lat); for (i = 0; i < n; i++) lat.d[i] *= m->sf; }
    return lat;
}

static supermat__t supermat__vae_decode(supermat__ctx *X, const supermat_model *m, const supermat__t *z) {
    supermat__t h = supermat__conv_new(X, z, z->h, z->w, &m->post_quant, 0), r, t;
    int l, j;
    r = supermat__conv_new(X, &h, h.h, h.w, &m->d_conv_in, 0); supermat__drop(X, &h);
    h = supermat__resnet_fwd(X, &m->d_mid[0], &r, m->vgroups, NULL, 0, 0); supermat__drop(X, &r);
    r = supermat__vattn_fwd(X, &m->d_att, &h, m->vgroups); supermat__drop(X, &h);
    h = supermat__resnet_fwd(X, &m->d_mid[1], &r, m->vgroups, NULL, 0, 0); supermat__drop(X, &r);
    for (l = 0; l < m->vL; l++) {
        const supermat__level *lv = &m->d_lv[l];
        for (j = 0; j < lv->nres; j++) { r = supermat__resnet_fwd(X, &lv->res[j], &h, m->vgroups, NULL, 0, 0); supermat__drop(X, &h); h = r; }
        if (lv->has_sampler) { r = supermat__conv_new(X, &h, 2 * h.h, 2 * h.w, &lv->sampler, 0); supermat__drop(X, &h); h = r; }
    }
    t = supermat__tensor(X, h.n, h.h, h.w, h.c);
    supermat__groupnorm(X, &h, &t, &m->d_norm_out, m->vgroups, 1);
    supermat__drop(X, &h);
    h = supermat__conv_new(X, &t, t.h, t.w, &m->d_conv_out, 0);
    supermat__drop(X, &t);
    return h;
}

/* >>session */
struct supermat_session {
    const supermat_model *m;
    supermat_allocator alloc;
    int w, h, views;
    unsigned outputs;
    supermat_pool *pool;
    supermat_threading thr;
    char *arena;
    size_t arena_size;
    float **scratch;
    float *scratch_mem;
    size_t scratch_floats;
    double *gn_stats;
    size_t gn_cap;
    supermat_flops flops, last_flops;
    double work_total;          /* progress steps of one run */
    size_t total_bytes;
    int ww, wh;                 /* the size the network runs at */
    int tile, overlap, skip_bg; /* VAE tiles (pixels; 0 = whole image), background skipping */
    int mv_att, mv_stride;
    float detail;               /* detail_sigma */
    float chroma;               /* chroma_weight */
    int curve_n[2];             /* the roughness and metallic curves' knots (0 = none) */
    float curve[2][SUPERMAT_CURVE_MAX_KNOTS];
};

/* the network's size along one axis of `len` pixels: `work` (0 = the model's work size, else the picture's;
   SUPERMAT_WORK_NATIVE = the picture's) */
static int supermat__work_len(const supermat_session_desc *d, int work, int len) {
    if (work == 0) work = d->model->info.work_size;
    return work > 0 ? work : len;
}
/* detail_sigma / chroma_weight: 0 = the model's, negative = off */
static float supermat__step_value(float v, float model) {
    return v == 0.0f ? model : v < 0.0f ? 0.0f : v;
}

/* the session's curve c (0 roughness, 1 metallic): the desc's n knots k, else (n 0) the model's mn knots mk */
static void supermat__session_curve(supermat_session *S, int c, int n, const float *k, int mn, const float *mk) {
    S->curve_n[c] = 0;
    if (n > 0) { S->curve_n[c] = n; memcpy(S->curve[c], k, sizeof(float) * (size_t)n); }
    else if (n == 0 && mn > 0) { S->curve_n[c] = mn; memcpy(S->curve[c], mk, sizeof(float) * (size_t)mn); }
}
static void supermat__session_options(supermat_session *S, const supermat_session_desc *d) {
    S->ww = supermat__work_len(d, d->work_width, d->width);
    S->wh = supermat__work_len(d, d->work_height, d->height);
    S->tile = d->vae_tile; S->overlap = d->vae_tile ? (d->vae_overlap ? d->vae_overlap : 32) : 0;
    S->skip_bg = d->skip_background != 0;
    S->mv_att = (int)d->mv_attention; S->mv_stride = d->mv_key_stride;
    S->detail = supermat__step_value(d->detail_sigma, d->model->info.detail_sigma);
    S->chroma = supermat__step_value(d->chroma_weight, d->model->info.chroma_weight);
    supermat__session_curve(S, 0, d->roughness_knots, d->roughness_curve, d->model->info.roughness_knots, d->model->info.roughness_curve);
    supermat__session_curve(S, 1, d->metallic_knots, d->metallic_curve, d->model->info.metallic_knots, d->model->info.metallic_curve);
}

static int supermat__views(const supermat_session_desc *d) {
    return d->views ? d->views : d->model->info.kind == SUPERMAT_KIND_SUPERMAT_MV ? 6 : 1;
}

static int supermat__branch_mask(const supermat_model *m, unsigned outputs) {
    int want = 0;
    if (m->info.kind == SUPERMAT_KIND_UV_REFINE) return 1; /* one branch: the refined map */
    if (outputs & SUPERMAT_OUTPUT_ALBEDO) want |= 1;
    if (outputs & (SUPERMAT_OUTPUT_ROUGHNESS | SUPERMAT_OUTPUT_METALLIC)) want |= 2;
    return want;
}

static size_t supermat__scratch_floats(const supermat_model *m) {
    size_t s = (size_t)SUPERMAT__MC * SUPERMAT__KC * 3 / 2 + (size_t)SUPERMAT__KC * SUPERMAT__NR, dmax = 16, cmax = 0; /* + bf16 A pairs */
    int l;
    for (l = 0; l < m->L; l++) {
        size_t d = (size_t)(m->boc[l] / m->heads[l] + 15) / 16 * 16;
        if (d > dmax) dmax = d;
        if ((size_t)m->boc[l] * 3 > cmax) cmax = (size_t)m->boc[l] * 3;
    }
    for (l = 0; l < m->vL; l++) {
        size_t d = (size_t)(m->vboc[l] + 15) / 16 * 16;
        if (d > dmax) dmax = d;
        if ((size_t)m->vboc[l] * 2 > cmax) cmax = (size_t)m->vboc[l] * 2;
    }
    s = SUPERMAT__MAX(s, (size_t)SUPERMAT__QB * (SUPERMAT__KB + dmax) + 2 * SUPERMAT__QB);
    s = SUPERMAT__MAX(s, 2 * cmax);
    return (s + 15) / 16 * 16;
}

/* pixel (x, y), channel c of a caller's image, as a float (8-bit / 255) */
static float supermat__px(const supermat_image *im, int x, int y, int c) {
    size_t es = im->format == SUPERMAT_FORMAT_F32 ? 4 : 1, stride = im->stride ? im->stride : (size_t)im->width * im->channels * es;
    const unsigned char *p = (const unsigned char *)im->pixels + (size_t)y * stride + ((size_t)x * im->channels + c) * es;
    float v;
    if (es == 4) { memcpy(&v, p, 4); return v; }
    return (float)*p / 255.0f;
}
static const supermat_image *supermat__view_in(const supermat_run_desc *rd, int v) {
    return rd->input_views ? &rd->input_views[v] : &rd->input;
}

/* PyTorch's F.interpolate(mode="bilinear", align_corners=False, antialias=False) of channel `c` of a
   caller's image to (oh, ow), into dst with channel stride `ldc` */
static void supermat__bilinear(const supermat_image *im, int c, int oh, int ow, float *dst, int ldc) {
    float sh = (float)im->height / (float)oh, sw = (float)im->width / (float)ow;
    int oy, ox;
    for (oy = 0; oy < oh; oy++) {
        float fy = sh * ((float)oy + 0.5f) - 0.5f, ly1, ly0;
        int y0, y1;
        if (fy < 0.0f) fy = 0.0f;
        y0 = (int)fy; y1 = y0 + (y0 < im->height - 1);
        ly1 = fy - (float)y0; ly0 = 1.0f - ly1;
        for (ox = 0; ox < ow; ox++) {
            float fx = sw * ((float)ox + 0.5f) - 0.5f, lx1, lx0;
            int x0, x1;
            if (fx < 0.0f) fx = 0.0f;
            x0 = (int)fx; x1 = x0 + (x0 < im->width - 1);
            lx1 = fx - (float)x0; lx0 = 1.0f - lx1;
            dst[((size_t)oy * ow + ox) * ldc] = ly0 * (lx0 * supermat__px(im, x0, y0, c) + lx1 * supermat__px(im, x1, y0, c)) +
                                                ly1 * (lx0 * supermat__px(im, x0, y1, c) + lx1 * supermat__px(im, x1, y1, c));
        }
    }
}

/* UV refine: 1 if texel (x, y) belongs to a UV chart (see supermat_run_desc.chart), else 0 */
static float supermat__in_chart(const supermat_run_desc *rd, int x, int y) {
    int c;
    if (rd->chart.pixels) return supermat__px(&rd->chart, x, y, 0) > 0.0f ? 1.0f : 0.0f;
    if (supermat__px(&rd->mask, x, y, 0) > 0.0f) return 1.0f;
    for (c = 0; c < 3; c++) if (fabsf(supermat__px(&rd->position, x, y, c) - 127.0f / 255.0f) > 0.25f / 255.0f) return 1.0f;
    return 0.0f;
}

/* Separable resampling of an n x sh x sw x c tensor to dh x dw: a triangle filter (bilinear when
   enlarging, its support widened by the factor when reducing, as PIL's BILINEAR), pixel centres
   aligned (align_corners = False). */
static void supermat__resample_axis(const float *src, int len_in, int len_out, int o0, int o1, size_t step_in, size_t step_out, int lines,
                                    size_t line_in, size_t line_out, int c, float *dst) {
    double scale = (double)len_in / len_out, support = scale > 1.0 ? scale : 1.0;
    int o, l, ch;
    for (o = o0; o < o1; o++) {
        double center = (o + 0.5) * scale, wsum = 0.0, inv;
        int lo = (int)floor(center - support + 0.5), hi = (int)floor(center + support + 0.5), i;
        if (lo < 0) lo = 0;
        if (hi > len_in) hi = len_in;
        for (i = lo; i < hi; i++) { double w = 1.0 - fabs((i + 0.5 - center) / support); if (w > 0.0) wsum += w; }
        inv = wsum > 0.0 ? 1.0 / wsum : 0.0;
        for (l = 0; l < lines; l++)
            for (ch = 0; ch < c; ch++) {
                double acc = 0.0;
                for (i = lo; i < hi; i++) {
                    double w = 1.0 - fabs((i + 0.5 - center) / support);
                    if (w > 0.0) acc += w * src[(size_t)l * line_in + (size_t)i * step_in + ch];
                }
                dst[(size_t)l * line_out + (size_t)(o - o0) * step_out + ch] = (float)(acc * inv);
            }
    }
}

/* Tile layout along one axis of `len` units: tiles of `t` starting at start[i], at least `ov` overlap. */
static int supermat__tiles(int len, int t, int ov, int *start, int maxn) {
    int n, i;
    if (t >= len) { start[0] = 0; return 1; }
    n = (len - ov + (t - ov) - 1) / (t - ov);
    if (n < 2) n = 2;
    if (n > maxn) n = maxn;
    for (i = 0; i < n; i++) start[i] = (int)(((long long)i * (len - t) * 2 + (n - 1)) / (2 * (n - 1))); /* rounded even spread */
    return n;
}
/* linear blend weight of position x in tile [s, s+t) whose neighbours start at `next` / end at `prev_end` */
static float supermat__ramp(int x, int s, int t, int has_prev, int prev_end, int has_next, int next) {
    float w = 1.0f;
    if (has_prev && x < prev_end) w = SUPERMAT__MIN(w, ((float)(x - s) + 0.5f) / (float)(prev_end - s));
    if (has_next && x >= next) w = SUPERMAT__MIN(w, ((float)(s + t - x) - 0.5f) / (float)(s + t - next));
    return w;
}

#define SUPERMAT__MAXTILES 256
/* One image through the VAE encoder (enc = 1: image -> latent) or decoder (latent -> image) in tiles
   of `tile` output... pixels (`tile`/8 latents), blended linearly. fg (decoder): a map at the output
   size; a tile without a pixel > 0 in it is not decoded. */
static supermat__t supermat__vae_tiled(supermat__ctx *X, const supermat_model *m, const supermat__t *in, int enc, int tile, int overlap,
                                       const float *fg) {
    int f = enc ? 8 : 1;               /* input units per tile unit (tiles are laid out in latents) */
    int lh = enc ? in->h / 8 : in->h, lw = enc ? in->w / 8 : in->w, tl = tile / 8, ol = overlap / 8;
    int oh = enc ? lh : 8 * lh, ow = enc ? lw : 8 * lw, os = enc ? 1 : 8, oc = enc ? m->latent : m->vout;
    int sy[SUPERMAT__MAXTILES], sx[SUPERMAT__MAXTILES], ny, nx, ty, tx, th, tw;
    supermat__t out = supermat__tensor(X, 1, oh, ow, oc);
    float *wsum = supermat__get(X, (size_t)oh * ow);
    ny = supermat__tiles(lh, tl, ol, sy, SUPERMAT__MAXTILES);
    nx = supermat__tiles(lw, tl, ol, sx, SUPERMAT__MAXTILES);
    th = SUPERMAT__MIN(tl, lh); tw = SUPERMAT__MIN(tl, lw);
    if (supermat__live(X)) { memset(out.d, 0, sizeof(float) * supermat__numel(&out)); memset(wsum, 0, sizeof(float) * (size_t)oh * ow); }
    for (ty = 0; ty < ny; ty++)
        for (tx = 0; tx < nx; tx++) {
            int y0 = sy[ty] * os, x0 = sx[tx] * os, hh = th * os, wo = tw * os, x, y;
            supermat__t crop, r;
            if (fg && supermat__live(X)) { /* skip the tiles without foreground */
                int any = 0;
                for (y = y0; y < y0 + hh && !any; y++)
                    for (x = x0; x < x0 + wo; x++) if (fg[(size_t)y * ow + x] > 0.0f) { any = 1; break; }
                if (!any) continue;
            }
            crop = supermat__tensor(X, 1, th * f, tw * f, in->c);
            if (supermat__live(X))
                for (y = 0; y < crop.h; y++)
                    memcpy(crop.d + (size_t)y * crop.w * crop.c, in->d + ((size_t)(sy[ty] * f + y) * in->w + (size_t)sx[tx] * f) * in->c,
                           sizeof(float) * (size_t)crop.w * crop.c);
            r = enc ? supermat__vae_encode(X, m, &crop) : supermat__vae_decode(X, m, &crop);
            supermat__drop(X, &crop);
            if (supermat__live(X)) {
                int pe_y = ty > 0 ? (sy[ty - 1] + th) * os : 0, nb_y = ty + 1 < ny ? sy[ty + 1] * os : 0;
                int pe_x = tx > 0 ? (sx[tx - 1] + tw) * os : 0, nb_x = tx + 1 < nx ? sx[tx + 1] * os : 0;
                for (y = 0; y < hh; y++) {
                    float wy = supermat__ramp(y0 + y, y0, hh, ty > 0, pe_y, ty + 1 < ny, nb_y);
                    for (x = 0; x < wo; x++) {
                        float w = wy * supermat__ramp(x0 + x, x0, wo, tx > 0, pe_x, tx + 1 < nx, nb_x);
                        const float *src = r.d + ((size_t)y * wo + x) * oc;
                        float *dst = out.d + ((size_t)(y0 + y) * ow + x0 + x) * oc;
                        int c;
                        for (c = 0; c < oc; c++) dst[c] += w * src[c];
                        wsum[(size_t)(y0 + y) * ow + x0 + x] += w;
                    }
                }
            }
            supermat__drop(X, &r);
        }
    if (supermat__live(X)) {
        size_t p, np = (size_t)oh * ow;
        for (p = 0; p < np; p++) {
            float inv = wsum[p] > 0.0f ? 1.0f / wsum[p] : 0.0f;
            int c;
            for (c = 0; c < oc; c++) out.d[p * oc + c] *= inv;
        }
    }
    supermat__put(X, wsum);
    return out;
}

/* detail_sigma (see supermat_session_desc), the low-pass G: three box passes of half-width r along rows, then
   columns, each a running sum in double, zero outside, over planes of SUPERMAT__DC floats a pixel (w x the
   albedo's and w x the picture's linear light, per colour channel). Each sum runs in the same order however the
   rows are grouped, so the streamed form (a ring of rows a stage) and the whole-plane form give the same floats. */
#define SUPERMAT__DC 6          /* floats a pixel of the detail planes: (w A_c, w I_c) for c = 0, 1, 2 */
#define SUPERMAT__BOX_LINES 16  /* columns a task of a column pass */
#define SUPERMAT__DB 16         /* rows a band of the streamed form */
static int supermat__detail_radius(float sigma, int w, int h) {
    double s = (double)sigma * (w > h ? w : h);
    int r = (int)floor((sqrt(4.0 * s * s + 1.0) - 1.0) * 0.5 + 0.5);
    return r < 1 ? 1 : r;
}
/* one row's box pass, in place through tmp (len x SUPERMAT__DC floats) */
static void supermat__box_row(float *d, float *tmp, int len, int r) {
    double a[SUPERMAT__DC];
    int k, j;
    memcpy(tmp, d, sizeof(float) * SUPERMAT__DC * (size_t)len);
    for (j = 0; j < SUPERMAT__DC; j++) a[j] = 0.0;
    for (k = 0; k < r && k < len; k++)
        for (j = 0; j < SUPERMAT__DC; j++) a[j] += tmp[SUPERMAT__DC * k + j];
    for (k = 0; k < len; k++) {
        if (k + r < len)
            for (j = 0; j < SUPERMAT__DC; j++) a[j] += tmp[SUPERMAT__DC * (k + r) + j];
        if (k - r - 1 >= 0)
            for (j = 0; j < SUPERMAT__DC; j++) a[j] -= tmp[SUPERMAT__DC * (k - r - 1) + j];
        for (j = 0; j < SUPERMAT__DC; j++) d[SUPERMAT__DC * k + j] = (float)a[j];
    }
}

typedef void (*supermat__row_fn)(void *user, int y, float *row, int thread);
/* The detail step's low-pass over a w x h picture, fed a row at a time by src (the row's SUPERMAT__DC floats a
   pixel) and handing each low-passed row to sink with the whole picture's ratios gr. Streamed (whole = 0): each
   of the three column passes keeps a ring of rcap = 2r + 2 + SUPERMAT__DB rows and its running sums, and src is
   called twice a row (once for the sums gr needs, once to feed the passes). Whole (when three rings would
   hold more than the plane): one w x h plane, src called once a row. */
typedef struct supermat__dstream {
    supermat__ctx *X;
    int w, h, r, rcap, whole, T;
    float *ring[3];     /* streamed: each column pass's input rows (rcap x w x DC); whole: ring[0] is the plane */
    double *acc;        /* streamed: 3 x w x DC running sums */
    float *band;        /* streamed: the last pass's rows, SUPERMAT__DB x w x DC */
    float *tmp;         /* a thread's: whole, max(w, h) x DC x SUPERMAT__BOX_LINES floats; streamed, w x DC */
    double *rs;         /* h x DC row sums */
    double gr[3];
    int empty;          /* no weight anywhere: the second plane of every channel sums to 0 */
    supermat__row_fn src, sink;
    void *user;
    int s, k0, n, dir;  /* a parallel step's pass, first row, rows, (whole) direction */
} supermat__dstream;
/* the buffers, from the context's arena (planned like every other) */
static void supermat__dstream_get(supermat__ctx *X, supermat__dstream *D, int w, int h, float sigma) {
    size_t row = (size_t)w * SUPERMAT__DC;
    int T = X->thr.max_threads > 1 ? X->thr.max_threads : 1, s;
    memset(D, 0, sizeof *D);
    D->X = X; D->w = w; D->h = h; D->T = T;
    D->r = supermat__detail_radius(sigma, w, h);
    D->rcap = 2 * D->r + 2 + SUPERMAT__DB < h ? 2 * D->r + 2 + SUPERMAT__DB : h;
    D->whole = 3 * D->rcap >= h;
    if (D->whole) {
        D->ring[0] = supermat__get(X, row * h);
        D->tmp = supermat__get(X, (size_t)SUPERMAT__MAX(w, h) * SUPERMAT__DC * SUPERMAT__BOX_LINES * T);
    } else {
        for (s = 0; s < 3; s++) D->ring[s] = supermat__get(X, row * D->rcap);
        D->acc = (double *)supermat__get(X, 3 * row * 2);
        D->band = supermat__get(X, row * SUPERMAT__DB);
        D->tmp = supermat__get(X, row * T);
    }
    D->rs = (double *)supermat__get(X, (size_t)h * SUPERMAT__DC * 2);
}
static void supermat__dstream_put(supermat__ctx *X, supermat__dstream *D) {
    int s;
    supermat__put(X, D->rs);
    supermat__put(X, D->tmp);
    supermat__put(X, D->band);
    supermat__put(X, D->acc);
    for (s = 2; s >= 0; s--) supermat__put(X, D->ring[s]);
}
static float *supermat__dstream_slot(const supermat__dstream *D, int s, int y) {
    return D->ring[s] + (size_t)(y % D->rcap) * D->w * SUPERMAT__DC;
}
/* the sums of row y (src's floats, added in order) */
static void supermat__dstream_sum_task(void *user, int y, int thread) {
    supermat__dstream *D = (supermat__dstream *)user;
    float *row = D->whole ? D->ring[0] + (size_t)y * D->w * SUPERMAT__DC : D->tmp + (size_t)thread * D->w * SUPERMAT__DC;
    double a[SUPERMAT__DC];
    int x, j;
    D->src(D->user, y, row, thread);
    for (j = 0; j < SUPERMAT__DC; j++) a[j] = 0.0;
    for (x = 0; x < D->w; x++)
        for (j = 0; j < SUPERMAT__DC; j++) a[j] += row[SUPERMAT__DC * x + j];
    for (j = 0; j < SUPERMAT__DC; j++) D->rs[(size_t)y * SUPERMAT__DC + j] = a[j];
}
/* streamed: row k0 + i fed into the first column pass (src, then its row pass) */
static void supermat__dstream_push_task(void *user, int i, int thread) {
    supermat__dstream *D = (supermat__dstream *)user;
    float *d = supermat__dstream_slot(D, 0, D->k0 + i);
    D->src(D->user, D->k0 + i, d, thread);
    supermat__box_row(d, D->tmp + (size_t)thread * D->w * SUPERMAT__DC, D->w, D->r);
}
/* a column pass's running sums: a[j] += in[j] (sub: -=) in double, the same sums on NEON (2 lanes of double) */
static void supermat__dsum(const supermat__ctx *X, double *a, const float *in, size_t n, int sub) {
    size_t j = 0;
#if SUPERMAT__HAS_NEON
    if (X->neon)
        for (; j + 4 <= n; j += 4) {
            float32x4_t v = vld1q_f32(in + j);
            float64x2_t lo = vcvt_f64_f32(vget_low_f32(v)), hi = vcvt_high_f64_f32(v), a0 = vld1q_f64(a + j), a1 = vld1q_f64(a + j + 2);
            vst1q_f64(a + j, sub ? vsubq_f64(a0, lo) : vaddq_f64(a0, lo));
            vst1q_f64(a + j + 2, sub ? vsubq_f64(a1, hi) : vaddq_f64(a1, hi));
        }
#endif
    (void)X;
    if (sub) for (; j < n; j++) a[j] -= in[j];
    else for (; j < n; j++) a[j] += in[j];
}
/* streamed: column pass s, rows k0 .. k0 + n - 1 of columns task x SUPERMAT__BOX_LINES .. */
static void supermat__dstream_col_task(void *user, int task, int thread) {
    supermat__dstream *D = (supermat__dstream *)user;
    int s = D->s, r = D->r, h = D->h, k, x0 = task * SUPERMAT__BOX_LINES;
    int x1 = x0 + SUPERMAT__BOX_LINES < D->w ? x0 + SUPERMAT__BOX_LINES : D->w;
    size_t j0 = (size_t)x0 * SUPERMAT__DC, j1 = (size_t)x1 * SUPERMAT__DC, jj;
    double *a = D->acc + (size_t)s * D->w * SUPERMAT__DC;
    (void)thread;
    if (D->k0 == 0) {
        for (jj = j0; jj < j1; jj++) a[jj] = 0.0;
        for (k = 0; k < r && k < h; k++) supermat__dsum(D->X, a + j0, supermat__dstream_slot(D, s, k) + j0, j1 - j0, 0);
    }
    for (k = D->k0; k < D->k0 + D->n; k++) {
        float *out = s < 2 ? supermat__dstream_slot(D, s + 1, k) : D->band + (size_t)(k - D->k0) * D->w * SUPERMAT__DC;
        if (k + r < h) supermat__dsum(D->X, a + j0, supermat__dstream_slot(D, s, k + r) + j0, j1 - j0, 0);
        if (k - r - 1 >= 0) supermat__dsum(D->X, a + j0, supermat__dstream_slot(D, s, k - r - 1) + j0, j1 - j0, 1);
#if SUPERMAT__HAS_NEON
        if (D->X->neon) {
            for (jj = j0; jj + 4 <= j1; jj += 4) vst1q_f32(out + jj, vcombine_f32(vcvt_f32_f64(vld1q_f64(a + jj)), vcvt_f32_f64(vld1q_f64(a + jj + 2))));
            for (; jj < j1; jj++) out[jj] = (float)a[jj];
            continue;
        }
#endif
        for (jj = j0; jj < j1; jj++) out[jj] = (float)a[jj];
    }
}
static void supermat__dstream_row_task(void *user, int i, int thread) { /* streamed: the row pass on pass s + 1's input */
    supermat__dstream *D = (supermat__dstream *)user;
    supermat__box_row(supermat__dstream_slot(D, D->s + 1, D->k0 + i), D->tmp + (size_t)thread * D->w * SUPERMAT__DC, D->w, D->r);
}
static void supermat__dstream_sink_task(void *user, int i, int thread) {
    supermat__dstream *D = (supermat__dstream *)user;
    const size_t row = (size_t)D->w * SUPERMAT__DC;
    D->sink(D->user, D->k0 + i, D->whole ? D->ring[0] + (size_t)(D->k0 + i) * row : D->band + (size_t)i * row, thread);
}
/* whole: a box pass over the plane, rows (dir 0) or columns (dir 1; SUPERMAT__BOX_LINES columns a task, their
   rows read and written whole) */
static void supermat__dstream_whole_task(void *user, int task, int thread) {
    supermat__dstream *D = (supermat__dstream *)user;
    int w = D->w, h = D->h, r = D->r, k, j;
    float *g = D->ring[0], *tmp = D->tmp + (size_t)thread * SUPERMAT__MAX(w, h) * SUPERMAT__DC * SUPERMAT__BOX_LINES;
    if (!D->dir) {
        supermat__box_row(g + (size_t)task * w * SUPERMAT__DC, tmp, w, r);
    } else {
        int l0 = task * SUPERMAT__BOX_LINES, l1 = l0 + SUPERMAT__BOX_LINES < w ? l0 + SUPERMAT__BOX_LINES : w;
        size_t rn = (size_t)(l1 - l0) * SUPERMAT__DC;
        double a[SUPERMAT__DC * SUPERMAT__BOX_LINES];
        for (k = 0; k < h; k++) memcpy(tmp + (size_t)k * rn, g + ((size_t)k * w + l0) * SUPERMAT__DC, sizeof(float) * rn);
        for (j = 0; j < (int)rn; j++) a[j] = 0.0;
        for (k = 0; k < r && k < h; k++)
            for (j = 0; j < (int)rn; j++) a[j] += tmp[(size_t)k * rn + j];
        for (k = 0; k < h; k++) {
            float *d = g + ((size_t)k * w + l0) * SUPERMAT__DC;
            if (k + r < h)
                for (j = 0; j < (int)rn; j++) a[j] += tmp[(size_t)(k + r) * rn + j];
            if (k - r - 1 >= 0)
                for (j = 0; j < (int)rn; j++) a[j] -= tmp[(size_t)(k - r - 1) * rn + j];
            for (j = 0; j < (int)rn; j++) d[j] = (float)a[j];
        }
    }
}
/* streamed: column pass s takes the rows its input has (each needs r rows below it), SUPERMAT__DB at a time,
   and hands them on */
static void supermat__dstream_flush(supermat__dstream *D, int s, int *in_n, int *out_n) {
    int cols = (D->w + SUPERMAT__BOX_LINES - 1) / SUPERMAT__BOX_LINES;
    for (;;) {
        int avail = (in_n[s] == D->h ? D->h : in_n[s] - D->r) - out_n[s], n;
        if (avail <= 0) return;
        n = avail < SUPERMAT__DB ? avail : SUPERMAT__DB;
        D->s = s; D->k0 = out_n[s]; D->n = n;
        supermat__par(D->X, cols, supermat__dstream_col_task, D);
        out_n[s] += n;
        if (s < 2) {
            D->s = s; D->k0 = out_n[s] - n;
            supermat__par(D->X, n, supermat__dstream_row_task, D);
            in_n[s + 1] += n;
            supermat__dstream_flush(D, s + 1, in_n, out_n);
        } else {
            D->k0 = out_n[s] - n;
            supermat__par(D->X, n, supermat__dstream_sink_task, D);
        }
    }
}
static void supermat__dstream_run(supermat__dstream *D) {
    int y, c, pass, in_n[3] = {0, 0, 0}, out_n[3] = {0, 0, 0};
    supermat__par(D->X, D->h, supermat__dstream_sum_task, D);
    for (c = 0; c < 3; c++) { /* rows in order: the same sums on any thread count */
        double sa = 0.0, si = 0.0;
        for (y = 0; y < D->h; y++) { sa += D->rs[(size_t)y * SUPERMAT__DC + 2 * c]; si += D->rs[(size_t)y * SUPERMAT__DC + 2 * c + 1]; }
        D->gr[c] = sa > 0.0 && si > 0.0 ? sa / si : 1.0;
        if (c == 0) D->empty = 1;
        if (si > 0.0) D->empty = 0;
    }
    if (D->whole) {
        for (pass = 0; pass < 3; pass++) {
            D->dir = 0;
            supermat__par(D->X, D->h, supermat__dstream_whole_task, D);
            D->dir = 1;
            supermat__par(D->X, (D->w + SUPERMAT__BOX_LINES - 1) / SUPERMAT__BOX_LINES, supermat__dstream_whole_task, D);
        }
        D->k0 = 0;
        supermat__par(D->X, D->h, supermat__dstream_sink_task, D);
        return;
    }
    for (y = 0; y < D->h; y += SUPERMAT__DB) {
        D->k0 = y; D->n = D->h - y < SUPERMAT__DB ? D->h - y : SUPERMAT__DB;
        supermat__par(D->X, D->n, supermat__dstream_push_task, D);
        in_n[0] += D->n;
        supermat__dstream_flush(D, 0, in_n, out_n);
    }
}
static double supermat__lin(double v) { v = v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0; /* NaN -> 0 */ return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }
static double supermat__srgb(double v) { v = v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0; return v <= 0.0031308 ? v * 12.92 : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }
SUPERMAT__DEF double supermat_srgb_to_linear(double v) { return supermat__lin(v); }
SUPERMAT__DEF double supermat_linear_to_srgb(double v) { return supermat__srgb(v); }

/* The sRGB transfer on float rows (the detail and colour steps): x^2.4 = x^2 sqrt(x) x^-0.1 and
   x^(1/2.4) = sqrt(x) x^(-1/12), so the log / exp pair carries only a small power (its error scaled by 0.1 and
   1/12). The SIMD rows take ln from Cephes' logf polynomial (the mantissa in [sqrt(1/2), sqrt 2)) and exp from
   supermat__exp_*; the scalar rows powf. Values are clamped to [0, 1] first, NaN -> 0, as supermat__lin and
   supermat__srgb (the knees where float64 has them: 0.04045f is below 0.04045, 0.0031308f above 0.0031308); within
   8e-7 of them, relative (test_kernels: float's rounding of (v + 0.055) / 1.055 raised to 2.4, and powf's). */
#define SUPERMAT__LOG_POLY(FMA, SET, f) \
    FMA(FMA(FMA(FMA(FMA(FMA(FMA(FMA(SET(7.0376836292E-2f), f, SET(-1.1514610310E-1f)), f, SET(1.1676998740E-1f)), f, SET(-1.2420140846E-1f)), f, \
    SET(1.4249322787E-1f)), f, SET(-1.6668057665E-1f)), f, SET(2.0000714765E-1f)), f, SET(-2.4999993993E-1f)), f, SET(3.3333331174E-1f))
static float supermat__lin_f(float v) { v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f); }
static float supermat__srgb_f(float v) { v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; return v < 0.0031308f ? v * 12.92f : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f; }
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static __m256 supermat__log_avx2(__m256 x) { /* x > 0 and normal */
    __m256i b = _mm256_castps_si256(x);
    __m256i e = _mm256_sub_epi32(_mm256_srli_epi32(b, 23), _mm256_set1_epi32(126));
    __m256 m = _mm256_castsi256_ps(_mm256_or_si256(_mm256_and_si256(b, _mm256_set1_epi32(0x007fffff)), _mm256_set1_epi32(0x3f000000))); /* [1/2, 1) */
    __m256 lo = _mm256_cmp_ps(m, _mm256_set1_ps(0.707106781186547524f), _CMP_LT_OQ);
    __m256 fe = _mm256_sub_ps(_mm256_cvtepi32_ps(e), _mm256_and_ps(lo, _mm256_set1_ps(1.0f)));
    __m256 f = _mm256_sub_ps(_mm256_add_ps(m, _mm256_and_ps(lo, m)), _mm256_set1_ps(1.0f));
    __m256 z = _mm256_mul_ps(f, f);
    __m256 y = _mm256_mul_ps(_mm256_mul_ps(f, z), SUPERMAT__LOG_POLY(_mm256_fmadd_ps, _mm256_set1_ps, f));
    y = _mm256_fmadd_ps(fe, _mm256_set1_ps(-2.12194440e-4f), y);
    y = _mm256_fmadd_ps(z, _mm256_set1_ps(-0.5f), y);
    return _mm256_fmadd_ps(fe, _mm256_set1_ps(0.693359375f), _mm256_add_ps(f, y));
}
SUPERMAT__AVX2 static __m256 supermat__xfer_avx2(__m256 v, int enc) {
    __m256 x, r;
    v = _mm256_min_ps(_mm256_max_ps(v, _mm256_setzero_ps()), _mm256_set1_ps(1.0f)); /* NaN -> 0 */
    if (enc) {
        r = _mm256_mul_ps(_mm256_sqrt_ps(v), supermat__exp_avx2(_mm256_mul_ps(_mm256_set1_ps(-1.0f / 12.0f), supermat__log_avx2(v))));
        r = _mm256_fmsub_ps(_mm256_set1_ps(1.055f), r, _mm256_set1_ps(0.055f));
        return _mm256_blendv_ps(r, _mm256_mul_ps(v, _mm256_set1_ps(12.92f)), _mm256_cmp_ps(v, _mm256_set1_ps(0.0031308f), _CMP_LT_OQ));
    }
    x = _mm256_div_ps(_mm256_add_ps(v, _mm256_set1_ps(0.055f)), _mm256_set1_ps(1.055f));
    r = _mm256_mul_ps(_mm256_sqrt_ps(x), supermat__exp_avx2(_mm256_mul_ps(_mm256_set1_ps(-0.1f), supermat__log_avx2(x))));
    r = _mm256_mul_ps(_mm256_mul_ps(x, x), r);
    return _mm256_blendv_ps(r, _mm256_div_ps(v, _mm256_set1_ps(12.92f)), _mm256_cmp_ps(v, _mm256_set1_ps(0.04045f), _CMP_LE_OQ));
}
SUPERMAT__AVX2 static void supermat__xfer_row_avx2(float *v, int n, int enc) {
    int i = 0;
    for (; i + 8 <= n; i += 8) _mm256_storeu_ps(v + i, supermat__xfer_avx2(_mm256_loadu_ps(v + i), enc));
    for (; i < n; i++) v[i] = _mm256_cvtss_f32(supermat__xfer_avx2(_mm256_set1_ps(v[i]), enc));
}
#endif
#if SUPERMAT__HAS_NEON
static float32x4_t supermat__log_neon(float32x4_t x) { /* x > 0 and normal */
    uint32x4_t b = vreinterpretq_u32_f32(x);
    int32x4_t e = vsubq_s32(vreinterpretq_s32_u32(vshrq_n_u32(b, 23)), vdupq_n_s32(126));
    float32x4_t m = vreinterpretq_f32_u32(vorrq_u32(vandq_u32(b, vdupq_n_u32(0x007fffffu)), vdupq_n_u32(0x3f000000u))); /* [1/2, 1) */
    uint32x4_t lo = vcltq_f32(m, vdupq_n_f32(0.707106781186547524f));
    float32x4_t fe = vsubq_f32(vcvtq_f32_s32(e), vbslq_f32(lo, vdupq_n_f32(1.0f), vdupq_n_f32(0.0f)));
    float32x4_t f = vsubq_f32(vaddq_f32(m, vbslq_f32(lo, m, vdupq_n_f32(0.0f))), vdupq_n_f32(1.0f));
    float32x4_t z = vmulq_f32(f, f);
    float32x4_t y = vmulq_f32(vmulq_f32(f, z), SUPERMAT__LOG_POLY(supermat__fma_neon, vdupq_n_f32, f));
    y = vfmaq_f32(y, fe, vdupq_n_f32(-2.12194440e-4f));
    y = vfmaq_f32(y, z, vdupq_n_f32(-0.5f));
    return vfmaq_f32(vaddq_f32(f, y), fe, vdupq_n_f32(0.693359375f));
}
static float32x4_t supermat__xfer_neon(float32x4_t v, int enc) {
    float32x4_t x, r;
    v = vbslq_f32(vcgtq_f32(v, vdupq_n_f32(0.0f)), v, vdupq_n_f32(0.0f)); /* NaN -> 0 */
    v = vminq_f32(v, vdupq_n_f32(1.0f));
    if (enc) {
        r = vmulq_f32(vsqrtq_f32(v), supermat__exp_neon(vmulq_f32(vdupq_n_f32(-1.0f / 12.0f), supermat__log_neon(v))));
        r = vsubq_f32(vmulq_f32(vdupq_n_f32(1.055f), r), vdupq_n_f32(0.055f));
        return vbslq_f32(vcltq_f32(v, vdupq_n_f32(0.0031308f)), vmulq_f32(v, vdupq_n_f32(12.92f)), r);
    }
    x = vdivq_f32(vaddq_f32(v, vdupq_n_f32(0.055f)), vdupq_n_f32(1.055f));
    r = vmulq_f32(vsqrtq_f32(x), supermat__exp_neon(vmulq_f32(vdupq_n_f32(-0.1f), supermat__log_neon(x))));
    r = vmulq_f32(vmulq_f32(x, x), r);
    return vbslq_f32(vcleq_f32(v, vdupq_n_f32(0.04045f)), vdivq_f32(v, vdupq_n_f32(12.92f)), r);
}
static void supermat__xfer_row_neon(float *v, int n, int enc) {
    int i = 0;
    for (; i + 4 <= n; i += 4) vst1q_f32(v + i, supermat__xfer_neon(vld1q_f32(v + i), enc));
    for (; i < n; i++) v[i] = vgetq_lane_f32(supermat__xfer_neon(vdupq_n_f32(v[i]), enc), 0);
}
#endif
/* n floats in place: to linear light (enc 0) or sRGB-encoded (enc 1), on the kernel X has */
static void supermat__xfer_n(const supermat__ctx *X, int enc, float *v, int n) {
    int i;
#if SUPERMAT__HAS_AVX2
    if (X->avx2) { supermat__xfer_row_avx2(v, n, enc); return; }
#endif
#if SUPERMAT__HAS_NEON
    if (X->neon) { supermat__xfer_row_neon(v, n, enc); return; }
#endif
    for (i = 0; i < n; i++) v[i] = enc ? supermat__srgb_f(v[i]) : supermat__lin_f(v[i]);
    (void)X;
}


/* The detail and colour steps on one row of albedo (3 floats a pixel). Linear light of the picture: an 8-bit
   picture's 256 values from a table made by supermat__xfer_n (so a float picture of the values v / 255 gives
   the same bits), a float picture's through supermat__xfer_n, as the albedo's, a block of SUPERMAT__PB pixels at a time. The albedo is a run's raw
   decode ([-1, 1], srgb 0) or a caller's sRGB-encoded one ([0, 1], srgb 1, supermat_detail). */
#define SUPERMAT__PB 64
typedef struct supermat__post {
    const supermat_image *in;
    const supermat_image *wt, *rg; /* detail: the weight and the region (supermat_detail_desc), or NULL */
    int srgb, w;
    float k;           /* chroma_weight */
    const float *lut;  /* 256 entries for an 8-bit picture (supermat__post_lut), else NULL */
    const supermat__ctx *X; /* its kernel flags pick the transfer's rows */
} supermat__post;
/* pixels x0 .. x0 + n - 1 of row y (n <= SUPERMAT__PB), 3 floats a pixel: the albedo's linear light (alb: the
   row), the picture's linear light, and linear values encoded back in place as the albedo is */
static void supermat__post_alin(const supermat__post *P, const float *alb, int x0, int n, float *o) {
    int i;
    for (i = 0; i < 3 * n; i++) o[i] = P->srgb ? alb[3 * x0 + i] : alb[3 * x0 + i] * 0.5f + 0.5f;
    supermat__xfer_n(P->X, 0, o, 3 * n);
}
static void supermat__post_lin(const supermat__post *P, int x0, int n, int y, float *o) {
    const supermat_image *in = P->in;
    int x, c;
    if (P->lut) {
        size_t stride = in->stride ? in->stride : (size_t)in->width * in->channels;
        const unsigned char *p = (const unsigned char *)in->pixels + (size_t)y * stride + (size_t)x0 * in->channels;
        for (x = 0; x < n; x++)
            for (c = 0; c < 3; c++) o[3 * x + c] = P->lut[p[(size_t)x * in->channels + c]];
        return;
    }
    for (x = 0; x < n; x++)
        for (c = 0; c < 3; c++) o[3 * x + c] = supermat__px(in, x0 + x, y, c);
    supermat__xfer_n(P->X, 0, o, 3 * n);
}
/* the linear light of the 256 8-bit values, as supermat__px reads them (v / 255) */
static void supermat__post_lut(const supermat__ctx *X, float *lut) {
    int i;
    for (i = 0; i < 256; i++) lut[i] = (float)i / 255.0f;
    supermat__xfer_n(X, 0, lut, 256);
}
static void supermat__post_aenc(const supermat__post *P, float *v, int n) {
    int i;
    supermat__xfer_n(P->X, 1, v, 3 * n);
    if (!P->srgb)
        for (i = 0; i < 3 * n; i++) v[i] = v[i] * 2.0f - 1.0f;
}
static float supermat__post_alpha(const supermat__post *P, int x, int y) {
    float a;
    if (P->rg && !(supermat__px(P->rg, x, y, 0) > 0.0f)) return 0.0f;
    a = P->wt ? supermat__px(P->wt, x, y, 0) : P->in->channels == 4 ? supermat__px(P->in, x, y, 3) : 1.0f;
    return a > 0.0f ? (a < 1.0f ? a : 1.0f) : 0.0f; /* NaN -> 0 */
}
/* detail: the pixels written (the region's, else those of weight > 0) */
static int supermat__post_writes(const supermat__post *P, int x, int y) {
    return P->rg ? supermat__px(P->rg, x, y, 0) > 0.0f : supermat__post_alpha(P, x, y) > 0.0f;
}
/* detail, row y of the planes, per colour channel: alpha x linear albedo, alpha x linear picture; without an
   albedo (alb NULL: the bounded form's second low-pass) alpha x linear picture, alpha */
static void supermat__detail_in(const supermat__post *P, const float *alb, int y, float *g) {
    float A[3 * SUPERMAT__PB], I[3 * SUPERMAT__PB];
    int x0, x, c, n;
    for (x0 = 0; x0 < P->w; x0 += n) {
        n = SUPERMAT__MIN(SUPERMAT__PB, P->w - x0);
        if (alb) supermat__post_alin(P, alb, x0, n, A);
        supermat__post_lin(P, x0, n, y, I);
        for (x = 0; x < n; x++) {
            float a = supermat__post_alpha(P, x0 + x, y), *gp = g + SUPERMAT__DC * (size_t)(x0 + x);
            for (c = 0; c < 3; c++) {
                float wi = a > 0.0f ? a * I[3 * x + c] : 0.0f;
                gp[2 * c] = alb ? (a > 0.0f ? a * A[3 * x + c] : 0.0f) : wi;
                gp[2 * c + 1] = alb ? wi : a;
            }
        }
    }
}
/* detail, row y: the albedo from the picture and the ratio of the low-passed planes g (gr: the whole
   picture's, where the picture's low-pass is below 1e-6) */
static void supermat__detail_out(const supermat__post *P, float *alb, int y, const float *g, const double *gr) {
    float I[3 * SUPERMAT__PB];
    int x0, x, c, n;
    for (x0 = 0; x0 < P->w; x0 += n) {
        n = SUPERMAT__MIN(SUPERMAT__PB, P->w - x0);
        supermat__post_lin(P, x0, n, y, I);
        for (x = 0; x < n; x++)
            for (c = 0; c < 3; c++) {
                const float *gp = g + SUPERMAT__DC * (size_t)(x0 + x) + 2 * c;
                double q = gp[1] > 1e-6f ? (double)gp[0] / gp[1] : gr[c];
                q = q < 0.25 ? 0.25 : q > 4.0 ? 4.0 : q;
                I[3 * x + c] = (float)(I[3 * x + c] * q);
            }
        supermat__post_aenc(P, I, n);
        for (x = 0; x < n; x++)
            if (supermat__post_writes(P, x0 + x, y))
                for (c = 0; c < 3; c++) alb[3 * (x0 + x) + c] = I[3 * x + c];
    }
}
/* supermat_detail_desc.limit, the bounded form, in two low-passes: the first over the run form's planes (w A_c,
   w I_c), whose clamped ratio q (the level's gain) it keeps in the albedo's floats as they are (not encoded);
   the second over planes (w I_c, w): the picture's low-pass I~ and the albedo I~ x q x clamp(I / I~) */
static void supermat__bdetail_gain(const supermat__post *P, float *alb, int y, const float *g, const double *gr) {
    int x, c;
    for (x = 0; x < P->w; x++)
        if (supermat__post_writes(P, x, y))
            for (c = 0; c < 3; c++) {
                const float *gp = g + SUPERMAT__DC * (size_t)x + 2 * c;
                double q = gp[1] > 1e-6f ? (double)gp[0] / gp[1] : gr[c];
                alb[3 * x + c] = (float)(q < 0.25 ? 0.25 : q > 4.0 ? 4.0 : q);
            }
}
static void supermat__bdetail_out(const supermat__post *P, float *alb, float limit, int empty, int y, const float *g,
                                  const double *gr) {
    float I[3 * SUPERMAT__PB];
    int x0, x, c, n;
    for (x0 = 0; x0 < P->w; x0 += n) {
        n = SUPERMAT__MIN(SUPERMAT__PB, P->w - x0);
        supermat__post_lin(P, x0, n, y, I);
        for (x = 0; x < n; x++) {
            if (empty || !supermat__post_writes(P, x0 + x, y)) continue; /* no weight anywhere: the picture */
            for (c = 0; c < 3; c++) {
                const float *gp = g + SUPERMAT__DC * (size_t)(x0 + x) + 2 * c;
                double low = gp[1] > 1e-6f ? (double)gp[0] / gp[1] : gr[c], q;
                q = low > 1e-6 ? I[3 * x + c] / low : 1.0;
                q = q < 1.0 / limit ? 1.0 / limit : q > limit ? limit : q;
                I[3 * x + c] = (float)(low * alb[3 * (x0 + x) + c] * q);
            }
        }
        supermat__post_aenc(P, I, n);
        for (x = 0; x < n; x++)
            if (supermat__post_writes(P, x0 + x, y))
                for (c = 0; c < 3; c++) alb[3 * (x0 + x) + c] = I[3 * x + c];
    }
}
/* chroma_weight (see supermat_session_desc), row y of a run's albedo: the picture's chromaticity with
   weight k, at the albedo's own luminance */
static void supermat__chroma_row(const supermat__post *P, float *alb, int y) {
    const double e = 0.002, kr = 0.2126, kg = 0.7152, kb = 0.0722, k = P->k;
    float A[3 * SUPERMAT__PB], I[3 * SUPERMAT__PB];
    int x0, x, c, n;
    for (x0 = 0; x0 < P->w; x0 += n) { /* a run's raw decode: P->srgb is 0 */
        n = SUPERMAT__MIN(SUPERMAT__PB, P->w - x0);
        supermat__post_alin(P, alb, x0, n, A);
        supermat__post_lin(P, x0, n, y, I);
        for (x = 0; x < n; x++) {
            float *a = A + 3 * x, *p = I + 3 * x;
            double la = kr * a[0] + kg * a[1] + kb * a[2], li = kr * p[0] + kg * p[1] + kb * p[2], v[3];
            for (c = 0; c < 3; c++) v[c] = (1.0 - k) * a[c] + k * (la * p[c] + e * a[c]) / (li + e);
            for (c = 0; c < 3; c++) a[c] = (float)v[c]; /* encoded below (the transfer clamps to [0, 1]) */
        }
        supermat__post_aenc(P, A, n);
        for (x = 0; x < n; x++)
            if (supermat__post_alpha(P, x0 + x, y) > 0.0f) /* alpha 0 or NaN: as decoded */
                for (c = 0; c < 3; c++) alb[3 * (x0 + x) + c] = A[3 * x + c];
    }
}

/* writes row y of one view's decoded image (px: w x 3 in [-1,1]) as x/2+0.5 clamped: src_channel >= 0 picks
   one channel for every output channel but alpha; alpha (4th channel) comes from `alpha_src`, or is 1 */
static void supermat__write_row(const supermat_image *o, const float *px, int src_channel, const supermat_image *alpha_src, int w, int y) {
    size_t es = o->format == SUPERMAT_FORMAT_F32 ? 4 : 1, stride = o->stride ? o->stride : (size_t)w * o->channels * es;
    unsigned char *row = (unsigned char *)o->pixels + (size_t)y * stride;
    int x, c;
    for (x = 0; x < w; x++, px += 3)
        for (c = 0; c < o->channels; c++) {
            float v;
            if (c == 3 || (c == 1 && o->channels == 2)) v = alpha_src && alpha_src->channels == 4 ? supermat__px(alpha_src, x, y, 3) : 1.0f;
            else {
                v = px[src_channel >= 0 ? src_channel : (o->channels == 1 ? 0 : c)] / 2.0f + 0.5f;
                v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
            }
            if (o->format == SUPERMAT_FORMAT_F32) memcpy(row + ((size_t)x * o->channels + c) * 4, &v, 4);
            else row[(size_t)x * o->channels + c] = (unsigned char)rintf(v * 255.0f);
        }
}

/* the caller's output image `k` (0 albedo, 1 roughness, 2 metallic, 3 orm, 4 refined) of view v, or NULL */
static const supermat_image *supermat__out(const supermat_run_desc *rd, int k, int v) {
    const supermat_image *one[5], *arr[5];
    const supermat_image *o;
    one[0] = &rd->albedo; one[1] = &rd->roughness; one[2] = &rd->metallic; one[3] = &rd->orm; one[4] = &rd->refined;
    arr[0] = rd->albedo_views; arr[1] = rd->roughness_views; arr[2] = rd->metallic_views; arr[3] = rd->orm_views; arr[4] = NULL;
    o = arr[k] ? &arr[k][v] : (v == 0 ? one[k] : NULL);
    return o && o->pixels ? o : NULL;
}

/* a view's picture at pixel (x, y) as the network takes it: RGB in [-1, 1], composited over gray 0.5 (straight
   alpha), and po[3] the foreground (alpha; for UV, in a chart) when `fg` */
static void supermat__in_pixel(const supermat_run_desc *rd, const supermat_image *in, int uv, int x, int y, float *po, int fg) {
    float px[4] = {0.0f, 0.0f, 0.0f, 1.0f};
    int c;
    for (c = 0; c < SUPERMAT__MIN(in->channels, 4); c++) px[c] = supermat__px(in, x, y, c);
    if (in->channels < 4 || uv) px[3] = 1.0f; /* UV maps: RGB as is (the official loader drops alpha) */
    for (c = 0; c < 3; c++) {
        float comp = px[c] * px[3] + 0.5f * (1.0f - px[3]); /* straight alpha over gray 0.5 */
        po[c] = comp * 2.0f - 1.0f;
    }
    if (fg) po[3] = uv ? supermat__in_chart(rd, x, y) : px[3];
}
/* resizing the picture: row y as the network takes it (a thread's line of w x 4 floats), resampled to the work
   width into rows (h x W x 4) */
typedef struct supermat__inrow { const supermat_run_desc *rd; const supermat_image *in; float *rows, *lines; int w, W, uv; } supermat__inrow;
static void supermat__in_row_task(void *user, int y, int thread) {
    const supermat__inrow *R = (const supermat__inrow *)user;
    float *line = R->lines + (size_t)thread * R->w * 4;
    int x;
    for (x = 0; x < R->w; x++) supermat__in_pixel(R->rd, R->in, R->uv, x, y, line + (size_t)x * 4, 1);
    supermat__resample_axis(line, R->w, R->W, 0, R->W, 4, 4, 1, (size_t)R->w * 4, (size_t)R->W * 4, 4, R->rows + (size_t)y * R->W * 4);
}

/* The maps of one view at the picture's size, a row at a time: each branch's decode (resized: its rows
   resampled to the picture's width first, H x w x 3, then a row of the picture's height at a time), the
   detail and colour steps, the roughness curve, written into the caller's images */
typedef struct supermat__fin {
    const supermat_session *S;
    const supermat_image *in, *out[5];
    const float *dec[SUPERMAT__MAXBRANCH]; /* resized: the rows at the work height, H x w x 3; else w x h x 3 */
    const float *src;                      /* resized, the row pass: a branch's decode, H x W x 3 */
    float *dst;                            /*   and its rows, H x w x 3 */
    int resize, W, H, chroma, curve;
    float *rows;                           /* a thread's albedo and second branch rows: w x 6 floats */
    const double *gr;                      /* detail: the whole picture's ratios */
    supermat__post P;
} supermat__fin;
static void supermat__fin_rowpass_task(void *user, int y, int thread) {
    const supermat__fin *F = (const supermat__fin *)user;
    int w = F->S->w;
    (void)thread;
    supermat__resample_axis(F->src + (size_t)y * F->W * 3, F->W, w, 0, w, 3, 3, 1, (size_t)F->W * 3, (size_t)w * 3, 3, F->dst + (size_t)y * w * 3);
}
static void supermat__fin_get(const supermat__fin *F, int b, int y, float *dst) {
    int w = F->S->w;
    if (!F->resize) memcpy(dst, F->dec[b] + (size_t)y * w * 3, sizeof(float) * 3 * (size_t)w);
    else supermat__resample_axis(F->dec[b], F->H, F->S->h, y, y + 1, (size_t)w * 3, (size_t)w * 3, w, 3, 3, 3, dst);
}
static void supermat__fin_src(void *user, int y, float *g, int thread) { /* detail: row y of its planes */
    const supermat__fin *F = (const supermat__fin *)user;
    float *alb = F->rows + (size_t)thread * F->S->w * 6;
    supermat__fin_get(F, 0, y, alb);
    supermat__detail_in(&F->P, alb, y, g);
}
static void supermat__fin_row(void *user, int y, float *g, int thread) {
    const supermat__fin *F = (const supermat__fin *)user;
    const supermat_session *S = F->S;
    static const int branch[5] = {0, 1, 1, 1, 0}, chan[5] = {-1, 1, 2, -1, -1};
    float *row[2];
    int k, x;
    row[0] = F->rows + (size_t)thread * S->w * 6; row[1] = row[0] + (size_t)S->w * 3;
    if (F->dec[0]) {
        supermat__fin_get(F, 0, y, row[0]);
        if (g) supermat__detail_out(&F->P, row[0], y, g, F->gr);
        if (F->chroma) supermat__chroma_row(&F->P, row[0], y);
    }
    if (S->m->branches > 1 && F->dec[1]) {
        supermat__fin_get(F, 1, y, row[1]);
        for (k = 0; k < 2; k++) /* the roughness and metallic curves: channels 1 and 2 of the second branch */
            if (F->curve && S->curve_n[k] > 0)
                for (x = 0; x < S->w; x++)
                    if (F->in->channels < 4 || supermat__px(F->in, x, y, 3) > 0.0f)
                        row[1][3 * x + 1 + k] = 2.0f * supermat__curve_at(S->curve[k], S->curve_n[k], row[1][3 * x + 1 + k] / 2.0f + 0.5f) - 1.0f;
    }
    for (k = 0; k < 5; k++)
        if (F->out[k]) supermat__write_row(F->out[k], row[branch[k]], chan[k], k < 3 ? F->in : NULL, S->w, y);
}
static void supermat__fin_task(void *user, int y, int thread) { supermat__fin_row(user, y, NULL, thread); }

/* The whole run. While planning (X->plan) `rd` is NULL: only memory and FLOPs are counted. */
static void supermat__forward(supermat__ctx *X, const supermat_session *S, const supermat_run_desc *rd, supermat__t *dec,
                              supermat_flops *fl) {
    const supermat_model *m = S->m;
    int V = S->views, uv = m->info.kind == SUPERMAT_KIND_UV_REFINE, mvk = m->info.kind == SUPERMAT_KIND_SUPERMAT_MV;
    int W = S->ww, H = S->wh, resize = W != S->w || H != S->h;
    supermat__t img = supermat__tensor(X, V, H, W, 3), lat, v[SUPERMAT__MAXBRANCH];
    int want = supermat__branch_mask(m, S->outputs), b, i;
    float *cams = NULL, *fg = NULL;
    double f0;
    memset(fl, 0, sizeof *fl);
    if (S->skip_bg) fg = supermat__get(X, (size_t)V * H * W); /* foreground: alpha (mask for UV) at the work size */
    { /* resized: the picture's rows at the work width (h x W x 4, a line a thread), then its columns */
        int T = X->thr.max_threads > 1 ? X->thr.max_threads : 1, k; /* the plan sets it too */
        float *rows = resize ? supermat__get(X, (size_t)S->h * W * 4) : NULL, *lines = resize ? supermat__get(X, (size_t)S->w * 4 * T) : NULL;
        for (k = 0; k < V; k++) {
            float *dst = img.d + (size_t)k * H * W * 3, *fgk = fg ? fg + (size_t)k * H * W : NULL;
            if (resize) {
                float *tmp = supermat__get(X, (size_t)H * W * 4);
                if (supermat__live(X)) {
                    supermat__inrow R;
                    size_t p2, np = (size_t)H * W;
                    R.rd = rd; R.in = supermat__view_in(rd, k); R.rows = rows; R.lines = lines; R.w = S->w; R.W = W; R.uv = uv;
                    supermat__par(X, S->h, supermat__in_row_task, &R);
                    supermat__resample_axis(rows, S->h, H, 0, H, (size_t)W * 4, (size_t)W * 4, W, 4, 4, 4, tmp);
                    for (p2 = 0; p2 < np; p2++) {
                        memcpy(dst + p2 * 3, tmp + p2 * 4, sizeof(float) * 3);
                        if (fgk) fgk[p2] = tmp[p2 * 4 + 3];
                    }
                }
                supermat__put(X, tmp);
            } else if (supermat__live(X)) {
                const supermat_image *in = supermat__view_in(rd, k);
                int x, y;
                for (y = 0; y < S->h; y++)
                    for (x = 0; x < S->w; x++) {
                        float po[4];
                        supermat__in_pixel(rd, in, uv, x, y, po, fgk != NULL);
                        memcpy(dst + ((size_t)y * S->w + x) * 3, po, sizeof(float) * 3);
                        if (fgk) fgk[(size_t)y * S->w + x] = po[3];
                    }
            }
        }
        supermat__put(X, lines);
        supermat__put(X, rows);
        if (supermat__live(X) && rd->inspect) rd->inspect(rd->inspect_user, SUPERMAT_STAGE_INPUT, 0, img.d, V, img.h, img.w, 3);
    }
    /* the VAE works view by view (bounded memory for many views; the same numbers) */
    f0 = X->flops;
    {
        int lh = H, lw = W, l;
        for (l = 0; l < m->vL - 1; l++) { lh = (lh - 2) / 2 + 1; lw = (lw - 2) / 2 + 1; }
        lat = supermat__tensor(X, V, lh, lw, m->latent);
        X->mv_top = lh * lw;
        for (i = 0; i < V; i++) {
            supermat__t one = img, l1;
            one.n = 1;
            if (one.d) one.d += (size_t)i * H * W * 3;
            l1 = S->tile ? supermat__vae_tiled(X, m, &one, 1, S->tile, S->overlap, NULL) : supermat__vae_encode(X, m, &one);
            if (supermat__live(X)) memcpy(lat.d + (size_t)i * supermat__numel(&l1), l1.d, sizeof(float) * supermat__numel(&l1));
            supermat__drop(X, &l1);
        }
    }
    fl->encode = X->flops - f0;
    supermat__drop(X, &img);
    if (supermat__live(X) && rd->inspect) rd->inspect(rd->inspect_user, SUPERMAT_STAGE_LATENT, 0, lat.d, lat.n, lat.h, lat.w, lat.c);
    if (uv) { /* [latent, bilinear(mask), bilinear(position)] */
        supermat__t u = supermat__tensor(X, 1, lat.h, lat.w, m->in_ch);
        if (supermat__live(X)) {
            size_t p, np = (size_t)lat.h * lat.w;
            for (p = 0; p < np; p++) memcpy(u.d + p * u.c, lat.d + p * lat.c, sizeof(float) * (size_t)lat.c);
            supermat__bilinear(&rd->mask, 0, lat.h, lat.w, u.d + lat.c, u.c);
            for (i = 0; i < 3; i++) supermat__bilinear(&rd->position, i, lat.h, lat.w, u.d + lat.c + 1 + i, u.c);
            if (rd->inspect) rd->inspect(rd->inspect_user, SUPERMAT_STAGE_UNET_IN, 0, u.d, u.n, u.h, u.w, u.c);
        }
        supermat__drop(X, &lat);
        lat = u;
    }
    if (mvk) {
        cams = supermat__get(X, (size_t)V * m->class_in);
        if (supermat__live(X)) memcpy(cams, rd->cameras, sizeof(float) * (size_t)V * m->class_in);
    }
    supermat__unet_fwd(X, m, &lat, cams, want, rd, v, &fl->trunk, &fl->branch);
    supermat__put(X, cams);
    supermat__drop(X, &lat);
    for (b = 0; b < m->branches; b++) {
        dec[b].d = NULL;
        if (!v[b].d) continue;
        f0 = X->flops;
        dec[b] = supermat__tensor(X, V, H, W, m->vout); /* resized back in the last step, a row at a time */
        for (i = 0; i < V; i++) {
            supermat__t z = v[b], d1;
            z.n = 1;
            if (z.d) z.d += (size_t)i * z.h * z.w * z.c;
            d1 = S->tile ? supermat__vae_tiled(X, m, &z, 0, S->tile, S->overlap, fg ? fg + (size_t)i * H * W : NULL) : supermat__vae_decode(X, m, &z);
            if (supermat__live(X)) memcpy(dec[b].d + (size_t)i * supermat__numel(&d1), d1.d, sizeof(float) * supermat__numel(&d1));
            supermat__drop(X, &d1);
        }
        fl->decode += X->flops - f0;
        if (supermat__live(X) && rd->inspect) rd->inspect(rd->inspect_user, SUPERMAT_STAGE_DECODED, b, dec[b].d, dec[b].n, dec[b].h, dec[b].w, dec[b].c);
    }
    for (b = m->branches - 1; b >= 0; b--) supermat__drop(X, &v[b]);
    supermat__put(X, fg);
    { /* the maps at the picture's size, a view and a row at a time, into the caller's images (planned too). What
         it needs is taken first: once it writes, nothing can fail, so outputs are written only by a run that
         succeeded */
        int T = X->thr.max_threads > 1 ? X->thr.max_threads : 1, detail = S->detail > 0.0f && !uv && dec[0].d;
        float *rows[SUPERMAT__MAXBRANCH] = {NULL}, *trows;
        float lut[256];
        supermat__dstream D;
        supermat__fin F;
        memset(&F, 0, sizeof F);
        for (b = 0; b < m->branches && resize; b++)
            if (dec[b].d) rows[b] = supermat__get(X, (size_t)H * S->w * 3);
        trows = supermat__get(X, (size_t)S->w * 6 * T);
        if (detail) supermat__dstream_get(X, &D, S->w, S->h, S->detail);
        if (supermat__live(X)) {
            supermat__post_lut(X, lut);
            F.S = S; F.resize = resize; F.W = W; F.H = H; F.rows = trows;
            F.chroma = S->chroma > 0.0f && !uv && dec[0].d;
            F.curve = (S->curve_n[0] > 0 || S->curve_n[1] > 0) && !uv && m->branches > 1;
            F.P.w = S->w; F.P.k = S->chroma; F.P.X = X;
            for (i = 0; i < V; i++) {
                int k;
                F.in = F.P.in = supermat__view_in(rd, i);
                F.P.lut = F.in->format == SUPERMAT_FORMAT_F32 ? NULL : lut;
                for (k = 0; k < 5; k++) F.out[k] = supermat__out(rd, k, i);
                for (b = 0; b < m->branches; b++) {
                    F.dec[b] = dec[b].d ? dec[b].d + (size_t)i * H * W * 3 : NULL;
                    if (rows[b]) { /* the rows to the picture's width */
                        F.src = F.dec[b]; F.dst = rows[b];
                        supermat__par(X, H, supermat__fin_rowpass_task, &F);
                        F.dec[b] = rows[b];
                    }
                }
                if (detail) {
                    D.src = supermat__fin_src; D.sink = supermat__fin_row; D.user = &F; F.gr = D.gr;
                    supermat__dstream_run(&D);
                } else supermat__par(X, S->h, supermat__fin_task, &F);
            }
        }
        if (detail) supermat__dstream_put(X, &D);
        supermat__put(X, trows);
        for (b = m->branches - 1; b >= 0; b--) supermat__put(X, rows[b]);
    }
    fl->total = fl->encode + fl->trunk + fl->branch + fl->decode;
}

/* the desc's curve for `map` (roughness or metallic): n knots k */
static supermat_result supermat__check_curve(const supermat_session_desc *d, const char *map, int n, const float *k, supermat_error *err) {
    char why[160];
    if (n < SUPERMAT_CURVE_OFF)
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s_knots %d: 0 (the model's curve), SUPERMAT_CURVE_OFF or 2 to %d knots", map, n, SUPERMAT_CURVE_MAX_KNOTS);
    if (n <= 0) return SUPERMAT_SUCCESS;
    if (d->model->info.kind == SUPERMAT_KIND_UV_REFINE)
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s_curve: a UV-refine model makes no %s map", map, map);
    if (!k) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s_knots %d but %s_curve is NULL", map, n, map);
    if (supermat__curve_ok(k, n, why, sizeof why)) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s_curve: %s", map, why);
    return SUPERMAT_SUCCESS;
}
static supermat_result supermat__check_session_desc(const supermat_session_desc *d, supermat_error *err) {
    supermat_result r;
    if (!d) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "session desc must not be NULL");
    if ((r = supermat__canary(d->_start_canary, d->_end_canary, "supermat_session_desc", err))) return r;
    if (!d->model) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "session desc's model must not be NULL");
    if (d->width < 1 || d->height < 1 || d->width > 16384 || d->height > 16384)
        return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "image size %dx%d: width and height from 1 to 16384", d->width, d->height);
    if (d->work_width < SUPERMAT_WORK_NATIVE || d->work_height < SUPERMAT_WORK_NATIVE)
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "work size %dx%d: multiples of 8, 0 (the model's) or SUPERMAT_WORK_NATIVE", d->work_width, d->work_height);
    if (d->outputs & ~(unsigned)SUPERMAT_OUTPUT_ALL) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "unknown output bits 0x%x", d->outputs);
    if (d->threads < 0) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "threads must be >= 0");
    if (d->threading.parallel_for && d->threading.max_threads < 1) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "threading.max_threads must be >= 1");
    if (d->views < 0 || d->views > 64) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "views = %d: between 1 and 64 (0 = default)", d->views);
    if (d->views > 1 && d->model->info.kind != SUPERMAT_KIND_SUPERMAT_MV)
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%d views: only a SuperMatMV model takes several views", d->views);
    {
        int ww = supermat__work_len(d, d->work_width, d->width), wh = supermat__work_len(d, d->work_height, d->height), tl, ol, k;
        if (ww == d->width && wh == d->height && (ww < 8 || wh < 8 || ww % 8 || wh % 8))
            return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "image size %dx%d: the network runs at the picture's own size here (work_width/height %s), "
                                  "which needs multiples of 8, at least 8: set a work size, or pad or resize the picture",
                                  d->width, d->height, d->work_width == SUPERMAT_WORK_NATIVE || d->work_height == SUPERMAT_WORK_NATIVE ? "SUPERMAT_WORK_NATIVE" : "0 and the model records no work size");
        if (ww < 8 || wh < 8 || ww % 8 || wh % 8 || ww > 16384 || wh > 16384)
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "work size %dx%d: multiples of 8 in [8, 16384]", ww, wh);
        if (d->vae_tile || d->vae_overlap) {
            if (d->vae_tile < 32 || d->vae_tile % 8 || d->vae_overlap < 0 || d->vae_overlap % 8)
                return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "vae_tile %d / vae_overlap %d: a tile of at least 32 pixels, both multiples of 8", d->vae_tile, d->vae_overlap);
            tl = d->vae_tile / 8; ol = (d->vae_overlap ? d->vae_overlap : 32) / 8;
            if (ol >= tl) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "vae_overlap %d must be smaller than vae_tile %d", ol * 8, d->vae_tile);
            for (k = 0; k < 2; k++) {
                int len = (k ? wh : ww) / 8;
                if (len > tl && (len - ol + (tl - ol) - 1) / (tl - ol) > SUPERMAT__MAXTILES)
                    return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "vae_tile %d with overlap %d needs more than %d tiles across %d pixels", d->vae_tile, ol * 8, SUPERMAT__MAXTILES, len * 8);
            }
        }
        if (d->skip_background && !d->vae_tile)
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "skip_background works on VAE tiles: set vae_tile");
        if ((unsigned)d->mv_attention >= SUPERMAT_MV_ATTENTION_COUNT)
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "unknown mv_attention %d", (int)d->mv_attention);
        if (d->mv_attention != SUPERMAT_MV_ATTENTION_FULL && d->model->info.kind != SUPERMAT_KIND_SUPERMAT_MV)
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "mv_attention: only a SuperMatMV model has multi-view attention");
        if (d->mv_attention == SUPERMAT_MV_ATTENTION_STRIDED && (d->mv_key_stride < 1 || d->mv_key_stride > 4096))
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "mv_key_stride %d: 1 to 4096 with SUPERMAT_MV_ATTENTION_STRIDED", d->mv_key_stride);
        if (!(d->detail_sigma <= 1.0f))
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail_sigma %g: at most 1 (0 = the model's, SUPERMAT_OFF = off)", (double)d->detail_sigma);
        if (d->detail_sigma > 0.0f && d->model->info.kind == SUPERMAT_KIND_UV_REFINE)
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail_sigma: a UV-refine model has no input picture to keep detail from");
        if (!(d->chroma_weight <= 1.0f))
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "chroma_weight %g: at most 1 (0 = the model's, SUPERMAT_OFF = off)", (double)d->chroma_weight);
        if (d->chroma_weight > 0.0f && d->model->info.kind == SUPERMAT_KIND_UV_REFINE)
            return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "chroma_weight: a UV-refine model has no input picture to take colour from");
        if ((r = supermat__check_curve(d, "roughness", d->roughness_knots, d->roughness_curve, err))) return r;
        if ((r = supermat__check_curve(d, "metallic", d->metallic_knots, d->metallic_curve, err))) return r;
    }
    return SUPERMAT_SUCCESS;
}

static int supermat__threads_for(const supermat_session_desc *d) {
    if (d->threading.parallel_for) return d->threading.max_threads;
#if SUPERMAT__HAS_THREADS
    if (d->threads == 0) return supermat__cpu_count();
    return SUPERMAT__MIN(d->threads, 64);
#else
    return 1;
#endif
}

/* plans the arena; fills sizes */
static supermat_result supermat__plan(supermat_session *S, int threads, supermat_error *err) {
    supermat__ctx X;
    supermat__t dec[SUPERMAT__MAXBRANCH];
    const supermat_model *m = S->m;
    int b;
    memset(&X, 0, sizeof X);
    X.plan = 1;
    X.err = err;
    X.thr.max_threads = threads; /* no parallel_for: only what a thread count sizes (the detail step's line buffers) reads it */
    X.mv_att = S->mv_att; X.mv_stride = S->mv_stride;
    supermat__forward(&X, S, NULL, dec, &S->flops);
    for (b = m->branches - 1; b >= 0; b--) if (dec[b].d) supermat__drop(&X, &dec[b]);
    S->work_total = X.work_total;
    if (X.status || X.nblk != 0) return supermat__fail(err, SUPERMAT_ERROR_INTERNAL, NULL, "memory planning failed (status %d, %d blocks left)", (int)X.status, X.nblk);
    S->arena_size = X.peak;
    S->scratch_floats = supermat__scratch_floats(m);
    S->gn_cap = (size_t)SUPERMAT__MAX(m->groups, m->vgroups) * (size_t)S->views;
    S->total_bytes = sizeof(supermat_session) + S->arena_size + (size_t)threads * (S->scratch_floats * sizeof(float) + sizeof(float *))
                   + 2 * S->gn_cap * sizeof(double);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF supermat_result supermat_session_memory(const supermat_session_desc *desc, size_t *bytes, supermat_error *err) {
    supermat_session S;
    supermat_result r = supermat__check_session_desc(desc, err);
    if (r) return r;
    if (!bytes) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "bytes is NULL");
    memset(&S, 0, sizeof S);
    S.m = desc->model; S.w = desc->width; S.h = desc->height; S.views = supermat__views(desc); S.outputs = desc->outputs ? desc->outputs : (unsigned)SUPERMAT_OUTPUT_ALL;
    supermat__session_options(&S, desc);
    r = supermat__plan(&S, supermat__threads_for(desc), err);
    if (r) return r;
    *bytes = S.total_bytes;
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF void supermat_session_destroy(supermat_session *S) {
    supermat_allocator a;
    int threads;
    if (!S) return;
    a = S->alloc;
    threads = S->thr.parallel_for ? S->thr.max_threads : 1;
#if SUPERMAT__HAS_THREADS
    if (S->pool) supermat_pool_destroy(S->pool);
#endif
    supermat__free(&a, S->arena, S->arena_size);
    supermat__free(&a, S->scratch_mem, (size_t)threads * S->scratch_floats * sizeof(float));
    supermat__free(&a, S->scratch, (size_t)threads * sizeof(float *));
    supermat__free(&a, S->gn_stats, 2 * S->gn_cap * sizeof(double));
    supermat__free(&a, S, sizeof *S);
}

SUPERMAT__DEF supermat_result supermat_session_create(const supermat_session_desc *desc, supermat_session **out, supermat_error *err) {
    supermat_session *S;
    supermat_allocator a;
    supermat_result r;
    int threads, i;
    if (out) *out = NULL;
    r = supermat__check_session_desc(desc, err);
    if (r) return r;
    if (!out) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "out is NULL");
    if (desc->max_memory) { /* the plan first, on the stack: nothing is allocated for a session that does not fit */
        size_t need = 0;
        if ((r = supermat_session_memory(desc, &need, err))) return r;
        if (need > desc->max_memory)
            return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "the session for %dx%d (%d view%s) needs %llu bytes (%.1f MiB), more than max_memory = %llu bytes (%.1f MiB): "
                                  "use VAE tiles (vae_tile), a smaller work size or fewer outputs", desc->width, desc->height, supermat__views(desc), supermat__views(desc) == 1 ? "" : "s",
                                  (unsigned long long)need, (double)need / 1048576.0, (unsigned long long)desc->max_memory, (double)desc->max_memory / 1048576.0);
    }
    a = supermat__resolve_allocator(&desc->allocator);
    S = (supermat_session *)supermat__alloc(&a, sizeof *S);
    if (!S) return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory for the session");
    memset(S, 0, sizeof *S);
    S->alloc = a; S->m = desc->model; S->w = desc->width; S->h = desc->height; S->views = supermat__views(desc);
    S->outputs = desc->outputs ? desc->outputs : (unsigned)SUPERMAT_OUTPUT_ALL;
    supermat__session_options(S, desc);
    if (desc->threading.parallel_for) S->thr = desc->threading;
#if SUPERMAT__HAS_THREADS
    else if (supermat__threads_for(desc) > 1) {
        r = supermat_pool_create(supermat__threads_for(desc), &a, &S->pool, &S->thr);
        if (r) { supermat__free(&a, S, sizeof *S); return supermat__fail(err, r, NULL, "could not create the thread pool"); }
    }
#endif
    threads = S->thr.parallel_for ? S->thr.max_threads : 1;
    r = supermat__plan(S, threads, err);
    if (r) { supermat_session_destroy(S); return r; }
    S->arena = (char *)supermat__alloc(&a, S->arena_size);
    S->scratch = (float **)supermat__alloc(&a, (size_t)threads * sizeof(float *));
    S->scratch_mem = (float *)supermat__alloc(&a, (size_t)threads * S->scratch_floats * sizeof(float));
    S->gn_stats = (double *)supermat__alloc(&a, 2 * S->gn_cap * sizeof(double));
    if (!S->arena || !S->scratch || !S->scratch_mem || !S->gn_stats) {
        size_t need = S->total_bytes;
        supermat_session_destroy(S);
        return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "out of memory: the session needs %llu bytes", (unsigned long long)need);
    }
    for (i = 0; i < threads; i++) S->scratch[i] = S->scratch_mem + (size_t)i * S->scratch_floats;
    *out = S;
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF void supermat_session_flops(const supermat_session *s, supermat_flops *out) {
    if (s && out) *out = s->flops;
}
SUPERMAT__DEF void supermat_session_last_flops(const supermat_session *s, supermat_flops *out) {
    if (s && out) *out = s->last_flops;
}

/* >>dispatch */
static void supermat__select_kernels(supermat__ctx *X) {
    X->mr = SUPERMAT__MR;
#if SUPERMAT__HAS_AVX512
    if (X->avx512) {
        X->ukr = supermat__ukr_avx512;
        X->mr = SUPERMAT__MR512;
        X->widen = supermat__widen_avx2;
        return;
    }
#endif
#if SUPERMAT__HAS_AVX2
    if (X->avx2) {
        X->ukr = supermat__ukr_avx2;
        X->widen = supermat__widen_avx2;
        return;
    }
#endif
#if SUPERMAT__HAS_NEON
    if (X->neon) {
        X->ukr = supermat__ukr_neon;
        X->widen = supermat__widen_neon;
        return;
    }
#endif
    X->ukr = supermat__ukr_scalar;
    X->widen = supermat__widen_scalar;
}

/* >>run */
static supermat_result supermat__check_image(const supermat_image *im, const char *what, int w, int h, int input, int min_ch,
                                             supermat_error *err) {
    size_t es = im->format == SUPERMAT_FORMAT_F32 ? 4 : 1;
    int iw = im->width ? im->width : (input ? 0 : w), ih = im->height ? im->height : (input ? 0 : h);
    if ((unsigned)im->format >= SUPERMAT_FORMAT_COUNT) return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "%s: unknown pixel format %d", what, (int)im->format);
    if (iw != w || ih != h) return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "%s is %dx%d, the session processes %dx%d", what, im->width, im->height, w, h);
    if (im->channels < min_ch || im->channels > 4) return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "%s has %d channels (%d to 4)", what, im->channels, min_ch);
    if (im->stride && im->stride < (size_t)w * im->channels * es) return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "%s: stride %llu is smaller than a row", what, (unsigned long long)im->stride);
    if (h > 0 && (im->stride ? im->stride : (size_t)w * im->channels * es) > (size_t)PTRDIFF_MAX / (size_t)h) /* rows x stride past 2^63 (2^31 on 32-bit) */
        return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "%s: stride %llu x %d rows is larger than the address space", what, (unsigned long long)im->stride, h);
    if (input && im->format == SUPERMAT_FORMAT_F32) { /* NaN / Inf are rejected, never propagated */
        int x, y, c;
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++)
                for (c = 0; c < im->channels; c++) {
                    float v = supermat__px(im, x, y, c);
                    if (!(v - v == 0.0f)) return supermat__fail(err, SUPERMAT_ERROR_NONFINITE, NULL, "%s: pixel (%d, %d) channel %d is NaN or Inf", what, x, y, c);
                }
    }
    return SUPERMAT_SUCCESS;
}

/* >>detail: supermat_detail, the detail step on a caller's albedo (the same supermat__detail a run applies) */
/* checks the desc (scan: the float pixels too, for NaN / Inf) and sizes the scratch: sz = plane, line buffers, row sums */
static supermat_result supermat__detail_plan(const supermat_detail_desc *d, size_t *need, int scan, supermat_error *err) {
    const supermat_image *pic;
    supermat_image alb;
    supermat_result r;
    int w, h, T;
    if (!d) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail desc must not be NULL");
    if ((r = supermat__canary(d->_start_canary, d->_end_canary, "supermat_detail_desc", err))) return r;
    if (!(d->sigma > 0.0f && d->sigma <= 1.0f))
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail sigma %g: from 0 (exclusive) to 1", (double)d->sigma);
    if (!(d->limit == 0.0f || (d->limit > 1.0f && d->limit <= 1e6f)))
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail limit %g: 0 (the run's form) or above 1, at most 1e6", (double)d->limit);
    pic = &d->picture;
    if (!pic->pixels || !d->albedo.pixels) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail: the picture and the albedo must have pixels");
    w = pic->width; h = pic->height;
    if (w < 1 || h < 1 || w > 16384 || h > 16384) return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "detail: picture size %dx%d: width and height from 1 to 16384", w, h);
    if ((r = supermat__check_image(pic, "the picture", w, h, scan, 3, err))) return r;
    alb = d->albedo;
    if (alb.format != SUPERMAT_FORMAT_F32 || alb.channels != 3) return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "detail: the albedo must be F32 with 3 channels (it is %s with %d)", alb.format == SUPERMAT_FORMAT_U8 ? "U8" : "F32", alb.channels);
    if (alb.stride % sizeof(float)) return supermat__fail(err, SUPERMAT_ERROR_BAD_IMAGE, NULL, "detail: the albedo's stride %llu is not a whole number of floats", (unsigned long long)alb.stride);
    if ((r = supermat__check_image(&alb, "the albedo", w, h, 0, 3, err))) return r;
    if (!alb.width) alb.width = w;
    if (!alb.height) alb.height = h;
    if (scan && (r = supermat__check_image(&alb, "the albedo", w, h, 1, 3, err))) return r; /* NaN / Inf */
    if (d->weight.pixels && (r = supermat__check_image(&d->weight, "the weight", w, h, scan, 1, err))) return r;
    if (d->region.pixels && (r = supermat__check_image(&d->region, "the region", w, h, scan, 1, err))) return r;
    if (d->threading.parallel_for && d->threading.max_threads < 1) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "threading.max_threads must be >= 1");
    if (d->scratch && ((uintptr_t)d->scratch % 16)) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail: scratch is not 16-byte aligned");
    T = d->threading.parallel_for ? d->threading.max_threads : 1;
    { /* the low-pass's buffers, planned as supermat_detail takes them */
        supermat__ctx X;
        supermat__dstream D;
        memset(&X, 0, sizeof X);
        X.plan = 1; X.thr.max_threads = T;
        supermat__dstream_get(&X, &D, w, h, d->sigma);
        *need = X.peak;
    }
    return SUPERMAT_SUCCESS;
}
SUPERMAT__DEF supermat_result supermat_detail_memory(const supermat_detail_desc *d, size_t *bytes, supermat_error *err) {
    size_t need = 0;
    supermat_result r = supermat__detail_plan(d, &need, 0, err);
    if (r) return r;
    if (bytes) *bytes = need;
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}
/* supermat_detail's rows: the caller's albedo, read and written in place (a row is written only once the
   low-pass has read every row it needs) */
typedef struct supermat__udet {
    supermat__post P;
    unsigned char *alb;
    size_t astride;
    const double *gr;
    const int *empty;
    float limit; /* 0: the run's form; else the bounded form, in two passes (0: the gain, 1: the albedo) */
    int pass;
} supermat__udet;
static void supermat__udet_src(void *user, int y, float *g, int thread) {
    const supermat__udet *U = (const supermat__udet *)user;
    const float *alb = (const float *)(const void *)(U->alb + (size_t)y * U->astride);
    (void)thread;
    supermat__detail_in(&U->P, U->pass ? NULL : alb, y, g);
}
static void supermat__udet_sink(void *user, int y, float *g, int thread) {
    const supermat__udet *U = (const supermat__udet *)user;
    float *alb = (float *)(void *)(U->alb + (size_t)y * U->astride);
    (void)thread;
    if (U->pass) supermat__bdetail_out(&U->P, alb, U->limit, *U->empty, y, g, U->gr);
    else if (U->limit > 0.0f) supermat__bdetail_gain(&U->P, alb, y, g, U->gr);
    else supermat__detail_out(&U->P, alb, y, g, U->gr);
}
SUPERMAT__DEF supermat_result supermat_detail(const supermat_detail_desc *d, supermat_error *err) {
    size_t need = 0;
    supermat_allocator al;
    supermat__ctx X;
    supermat__dstream D;
    supermat__udet U;
    float lut[256];
    unsigned char *mem;
    supermat_result r = supermat__detail_plan(d, &need, 1, err);
    if (r) return r;
    al = supermat__resolve_allocator(&d->allocator);
    if (d->scratch && d->scratch_size < need)
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "detail: scratch_size %llu, it needs %llu bytes (supermat_detail_memory)",
                              (unsigned long long)d->scratch_size, (unsigned long long)need);
    mem = d->scratch ? (unsigned char *)d->scratch : (unsigned char *)al.alloc(al.user, need, 64);
    if (!mem) return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "detail: out of memory (%llu bytes)", (unsigned long long)need);
    memset(&X, 0, sizeof X);
    if (d->threading.parallel_for) X.thr = d->threading;
    else X.thr.max_threads = 1;
    X.base = (char *)mem; X.cap = need;
    X.neon = supermat__cpu_has_neon(); /* the low-pass's sums on NEON where there is NEON (the same bits) */
    supermat__dstream_get(&X, &D, d->picture.width, d->picture.height, d->sigma);
    X.avx2 = supermat__cpu_has_avx2(); /* the sRGB transfer's rows (supermat__xfer_n) */
    supermat__post_lut(&X, lut);
    memset(&U, 0, sizeof U);
    U.P.in = &d->picture; U.P.wt = d->weight.pixels ? &d->weight : NULL; U.P.rg = d->region.pixels ? &d->region : NULL;
    U.P.srgb = 1; U.P.w = d->picture.width; U.P.X = &X; U.P.lut = d->picture.format == SUPERMAT_FORMAT_F32 ? NULL : lut;
    U.alb = (unsigned char *)d->albedo.pixels; U.astride = d->albedo.stride ? d->albedo.stride : (size_t)d->picture.width * 3 * sizeof(float);
    D.src = supermat__udet_src; D.sink = supermat__udet_sink; D.user = &U; U.gr = D.gr; U.empty = &D.empty;
    U.limit = d->limit;
    if (X.status == SUPERMAT_SUCCESS) supermat__dstream_run(&D);
    if (X.status == SUPERMAT_SUCCESS && d->limit > 0.0f) { /* the bounded form's second low-pass: the picture's */
        U.pass = 1; /* its sums set D.empty (no weight anywhere) before any row reaches the sink */
        supermat__dstream_run(&D);
    }
    supermat__dstream_put(&X, &D);
    if (!d->scratch) al.free(al.user, mem, need);
    if (X.status) return supermat__fail(err, SUPERMAT_ERROR_INTERNAL, NULL, "detail: internal error (scratch plan)");
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF supermat_result supermat_run(supermat_session *S, const supermat_run_desc *rd, supermat_error *err) {
    supermat__ctx X;
    supermat__t dec[SUPERMAT__MAXBRANCH];
    const char *names[5] = {"albedo", "roughness", "metallic", "orm", "refined"};
    unsigned need[5] = {SUPERMAT_OUTPUT_ALBEDO, SUPERMAT_OUTPUT_ROUGHNESS, SUPERMAT_OUTPUT_METALLIC, SUPERMAT_OUTPUT_ROUGHNESS | SUPERMAT_OUTPUT_METALLIC, 0};
    supermat_flops fl;
    supermat_result r;
    char what[64];
    int i, b, v, uv;
    if (!S || !rd) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "session and run desc must not be NULL");
    if ((r = supermat__canary(rd->_start_canary, rd->_end_canary, "supermat_run_desc", err))) return r;
    uv = S->m->info.kind == SUPERMAT_KIND_UV_REFINE;
    if (S->views > 1 && !rd->input_views) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "the session has %d views: give them in input_views", S->views);
    for (v = 0; v < S->views; v++) {
        const supermat_image *in = supermat__view_in(rd, v);
        supermat__name(what, sizeof what, S->views > 1 ? "input view %d" : "the input image", v);
        if (!in->pixels) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s: pixels is NULL", what);
        r = supermat__check_image(in, what, S->w, S->h, 1, 3, err);
        if (r) return r;
    }
    if (S->m->info.kind == SUPERMAT_KIND_SUPERMAT_MV) {
        if (!rd->cameras) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "a SuperMatMV model needs the cameras (views x 16 floats)");
        for (i = 0; i < S->views * S->m->class_in; i++)
            if (!(rd->cameras[i] - rd->cameras[i] == 0.0f))
                return supermat__fail(err, SUPERMAT_ERROR_NONFINITE, NULL, "camera %d, element %d is NaN or Inf", i / S->m->class_in, i % S->m->class_in);
    }
    if (uv) {
        if (!rd->mask.pixels || !rd->position.pixels) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "a UV-refine model needs the mask and the position map");
        r = supermat__check_image(&rd->mask, "the mask", S->w, S->h, 1, 1, err);
        if (!r) r = supermat__check_image(&rd->position, "the position map", S->w, S->h, 1, 3, err);
        if (!r && rd->chart.pixels) r = supermat__check_image(&rd->chart, "the chart mask", S->w, S->h, 1, 1, err);
        if (r) return r;
    }
    for (i = 0; i < 5; i++)
        for (v = 0; v < S->views; v++) {
            const supermat_image *o = supermat__out(rd, i, v);
            if (!o) continue;
            supermat__name(what, sizeof what, S->views > 1 ? "the %s output of view %d" : "the %s output", names[i], v);
            if ((i == 4) != uv) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s: this model does not make it", what);
            r = supermat__check_image(o, what, S->w, S->h, 0, 1, err);
            if (r) return r;
            if ((S->outputs & need[i]) != need[i])
                return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "%s was not requested when the session was created", what);
        }
    memset(&X, 0, sizeof X);
    X.err = err; X.base = S->arena; X.cap = S->arena_size;
    X.avx2 = S->m->info.kernel == SUPERMAT_KERNEL_AVX2 || S->m->info.kernel == SUPERMAT_KERNEL_AVX512 || S->m->info.kernel == SUPERMAT_KERNEL_AMX;
    X.avx512 = S->m->info.kernel == SUPERMAT_KERNEL_AVX512 || S->m->info.kernel == SUPERMAT_KERNEL_AMX;
    X.amx = S->m->info.kernel == SUPERMAT_KERNEL_AMX;
    X.vnni256 = S->m->info.kernel == SUPERMAT_KERNEL_AVX2 && S->m->info.compute == SUPERMAT_COMPUTE_INT8;
    X.neon = S->m->info.kernel == SUPERMAT_KERNEL_NEON;
    supermat__select_kernels(&X);
    X.thr = S->thr; X.scratch = S->scratch; X.scratch_floats = S->scratch_floats;
    X.gn_stats = S->gn_stats; X.gn_cap = S->gn_cap;
    X.progress = rd->progress; X.progress_user = rd->progress_user;
    X.work_total = S->work_total;
    X.mv_att = S->mv_att; X.mv_stride = S->mv_stride;
    supermat__forward(&X, S, rd, dec, &fl);
    if (X.status == SUPERMAT_SUCCESS) S->last_flops = fl; /* the outputs were written by its last step (supermat__forward) */
    for (b = S->m->branches - 1; b >= 0; b--) if (dec[b].d) supermat__drop(&X, &dec[b]);
    if (X.status) {
        if (X.status != SUPERMAT_ERROR_CANCELLED) return supermat__fail(err, X.status, NULL, "internal error during the run");
        return X.status;
    }
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF int supermat_session_desc_threads(const supermat_session_desc *desc) {
    return desc ? supermat__threads_for(desc) : 1;
}

/* >>benchhook : supermat_bench_conv_*, one 3x3 convolution GEMM with a chosen micro-kernel (testing hook) */
struct supermat_bench_conv {
    supermat_allocator alloc;
    supermat__conv cv;
    supermat__t in, out;
    float **scratch;
    float *scratch_mem;
    int threads, done;
    size_t np, nin, nout;
};

static uint32_t supermat__bench_rand(uint32_t *s) { *s = *s * 1664525u + 1013904223u; return *s >> 8; }

static void supermat__bench_serial(void *user, int count, supermat_task_fn task, void *task_user) {
    int i;
    (void)user;
    for (i = 0; i < count; i++) task(task_user, i, 0);
}

SUPERMAT__DEF void supermat_bench_conv_destroy(supermat_bench_conv *b) {
    supermat_allocator a;
    size_t K;
    if (!b) return;
    a = b->alloc;
    K = (size_t)b->cv.w.K;
    supermat__free(&a, b->cv.w.p, sizeof(float) * b->np * SUPERMAT__NR * K);
    supermat__free(&a, b->cv.w.bias, sizeof(float) * b->np * SUPERMAT__NR);
    supermat__free(&a, b->in.d, sizeof(float) * b->nin);
    supermat__free(&a, b->out.d, sizeof(float) * b->nout);
    supermat__free(&a, b->scratch, sizeof(float *) * (size_t)b->threads);
    supermat__free(&a, b->scratch_mem, sizeof(float) * (size_t)SUPERMAT__MC * SUPERMAT__KC * (size_t)b->threads);
    supermat__free(&a, b, sizeof *b);
}

SUPERMAT__DEF supermat_result supermat_bench_conv_create(int size, int cin, int cout, int threads, supermat_bench_conv **out,
                                                         supermat_error *err) {
    supermat_allocator a = supermat__resolve_allocator(NULL);
    supermat_bench_conv *b;
    size_t sf = (size_t)SUPERMAT__MC * SUPERMAT__KC, K, N, n, k, i;
    uint32_t seed = 12345u;
    if (!out) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "supermat_bench_conv_create: out is NULL");
    *out = NULL;
    if (size < 1 || size > 4096 || cin < 1 || cin > 4096 || cout < 1 || cout > 4096 || threads < 1 || threads > 1024)
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "supermat_bench_conv_create: size %d, cin %d, cout %d (1 to 4096), threads %d (1 to 1024)",
                              size, cin, cout, threads);
    b = (supermat_bench_conv *)supermat__alloc(&a, sizeof *b);
    if (!b) return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "supermat_bench_conv_create: out of memory");
    memset(b, 0, sizeof *b);
    b->alloc = a;
    b->threads = threads;
    K = (size_t)9 * (size_t)cin;
    N = (size_t)cout;
    b->np = (N + SUPERMAT__NR - 1) / SUPERMAT__NR;
    b->nin = (size_t)size * (size_t)size * (size_t)cin;
    b->nout = (size_t)size * (size_t)size * (size_t)cout;
    b->cv.k = 3; b->cv.stride = 1; b->cv.cin = cin; b->cv.cout = cout;
    b->cv.w.K = (int)K; b->cv.w.N = (int)N;
    b->cv.w.p = (float *)supermat__alloc(&a, sizeof(float) * b->np * SUPERMAT__NR * K);
    b->cv.w.bias = (float *)supermat__alloc(&a, sizeof(float) * b->np * SUPERMAT__NR);
    b->in.d = (float *)supermat__alloc(&a, sizeof(float) * b->nin);
    b->out.d = (float *)supermat__alloc(&a, sizeof(float) * b->nout);
    b->scratch = (float **)supermat__alloc(&a, sizeof(float *) * (size_t)threads);
    b->scratch_mem = (float *)supermat__alloc(&a, sizeof(float) * sf * (size_t)threads);
    if (!b->cv.w.p || !b->cv.w.bias || !b->in.d || !b->out.d || !b->scratch || !b->scratch_mem) {
        supermat_bench_conv_destroy(b);
        return supermat__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, NULL, "supermat_bench_conv_create: out of memory");
    }
    memset(b->cv.w.p, 0, sizeof(float) * b->np * SUPERMAT__NR * K);
    memset(b->cv.w.bias, 0, sizeof(float) * b->np * SUPERMAT__NR);
    for (i = 0; i < (size_t)threads; i++) b->scratch[i] = b->scratch_mem + sf * i;
    /* W[n][k] packed as panel n/16, row k, column n%16 (k = (ky*3 + kx)*cin + ci, the model's order) */
    for (n = 0; n < N; n++) {
        b->cv.w.bias[n] = (float)(supermat__bench_rand(&seed) % 2001u) * 1e-4f - 0.1f;
        for (k = 0; k < K; k++)
            b->cv.w.p[((n / SUPERMAT__NR) * K + k) * SUPERMAT__NR + n % SUPERMAT__NR] = (float)(supermat__bench_rand(&seed) % 2001u) * 1e-5f - 0.01f;
    }
    for (i = 0; i < b->nin; i++) b->in.d[i] = (float)(supermat__bench_rand(&seed) % 2001u) * 1e-3f - 1.0f;
    b->in.n = b->out.n = 1;
    b->in.h = b->out.h = size;
    b->in.w = b->out.w = size;
    b->in.c = cin;
    b->out.c = cout;
    *out = b;
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF supermat_result supermat_bench_conv_run(supermat_bench_conv *b, supermat_kernel kernel,
                                                      const supermat_threading *threading, supermat_error *err) {
    supermat__ctx X;
    if (!b) return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "supermat_bench_conv_run: bench is NULL");
    if (threading && (!threading->parallel_for || threading->max_threads < 1 || threading->max_threads > b->threads))
        return supermat__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, NULL, "supermat_bench_conv_run: a threading hook of %d threads (created for 1 to %d)",
                              threading->max_threads, b->threads);
    memset(&X, 0, sizeof X);
    X.mr = SUPERMAT__MR;
    if (kernel == SUPERMAT_KERNEL_AUTO) {
        kernel = supermat__cpu_has_avx512() ? SUPERMAT_KERNEL_AVX512 : supermat__cpu_has_avx2() ? SUPERMAT_KERNEL_AVX2
                 : supermat__cpu_has_neon() ? SUPERMAT_KERNEL_NEON : SUPERMAT_KERNEL_SCALAR;
    }
    switch (kernel) {
    case SUPERMAT_KERNEL_SCALAR: X.ukr = supermat__ukr_scalar; break;
#if SUPERMAT__HAS_AVX2
    case SUPERMAT_KERNEL_AVX2: if (supermat__cpu_has_avx2()) X.ukr = supermat__ukr_avx2; break;
#endif
#if SUPERMAT__HAS_AVX512
    case SUPERMAT_KERNEL_AVX512: if (supermat__cpu_has_avx512()) { X.ukr = supermat__ukr_avx512; X.mr = SUPERMAT__MR512; } break;
#endif
#if SUPERMAT__HAS_NEON
    case SUPERMAT_KERNEL_NEON: X.ukr = supermat__ukr_neon; break;
#endif
    default: break;
    }
    if (!X.ukr) return supermat__fail(err, SUPERMAT_ERROR_UNSUPPORTED, NULL, "supermat_bench_conv_run: kernel %d is not an f32 micro-kernel of this CPU and build", (int)kernel);
    if (threading) X.thr = *threading;
    else { X.thr.parallel_for = supermat__bench_serial; X.thr.user = NULL; X.thr.max_threads = 1; }
    X.scratch = b->scratch;
    X.scratch_floats = (size_t)SUPERMAT__MC * SUPERMAT__KC;
    X.status = SUPERMAT_SUCCESS;
    supermat__conv2d(&X, &b->in, b->in.h, b->in.w, &b->cv, 0, &b->out, NULL, NULL);
    if (X.status != SUPERMAT_SUCCESS) return supermat__fail(err, X.status, NULL, "supermat_bench_conv_run: the convolution failed");
    b->done = 1;
    supermat__ok(err);
    return SUPERMAT_SUCCESS;
}

SUPERMAT__DEF const float *supermat_bench_conv_output(const supermat_bench_conv *b) { return b && b->done ? b->out.d : NULL; }

#endif /* SUPERMAT_IMPLEMENTATION_DONE */
#endif /* SUPERMAT_IMPLEMENTATION */

/*
------------------------------------------------------------------------------
This software is available under 2 licenses -- choose whichever you prefer.
------------------------------------------------------------------------------
ALTERNATIVE A - MIT License
Copyright (c) 2026 the supermat authors
Permission is hereby granted, free of charge, to any person obtaining a copy of
this software and associated documentation files (the "Software"), to deal in
the Software without restriction, including without limitation the rights to
use, copy, modify, merge, publish, distribute, sublicense, and/or sell copies
of the Software, and to permit persons to whom the Software is furnished to do
so, subject to the following conditions:
The above copyright notice and this permission notice shall be included in all
copies or substantial portions of the Software.
THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR
IMPLIED, INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY,
FITNESS FOR A PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE
AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER
LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE
SOFTWARE.
------------------------------------------------------------------------------
ALTERNATIVE B - Public Domain (www.unlicense.org)
This is free and unencumbered software released into the public domain.
Anyone is free to copy, modify, publish, use, compile, sell, or distribute this
software, either in source code form or as a compiled binary, for any purpose,
commercial or non-commercial, and by any means.
In jurisdictions that recognize copyright laws, the author or authors of this
software dedicate any and all copyright interest in the software to the public
domain. We make this dedication in addition to any and all copyright interest
in the software under copyright law.
------------------------------------------------------------------------------
*/
