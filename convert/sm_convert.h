/* sm_convert.h - the SuperMat model converter (official checkpoint + Stable Diffusion base -> one model file)
 *
 * Turns the official SuperMat checkpoints (`supermat.pth`, `supermat_mv.pth`, `uv_refine_*.pth`, made by
 * `torch.save(state_dict)`) plus a Stable Diffusion 2.1 folder in diffusers layout into the single
 * safetensors file that `supermat.h` loads (format version 1, see the MODEL FILE section of supermat.h).
 * No Python: the converter reads PyTorch's zip/pickle format itself and runs the CLIP text encoder once,
 * in float32, to store the empty-prompt context.
 *
 *     sm_convert_desc d;
 *     char err[512];
 *     memset(&d, 0, sizeof d);
 *     d.kind = "supermat";                 // or "supermat-mv", "uv-refine"; NULL = detect
 *     d.checkpoint = "supermat.pth";
 *     d.base_dir = "stable-diffusion-2-1";  // unet/config.json, vae/, text_encoder/, scheduler/, [tokenizer/]
 *     d.output = "supermat.safetensors";
 *     if (sm_convert(&d, err, sizeof err) != 0) fprintf(stderr, "%s\n", err);
 *
 * Build: compile convert/sm_convert.c with supermat.h on the include path, and define
 * SUPERMAT_IMPLEMENTATION in exactly one translation unit of the program (sm_convert.c does not: it
 * only uses supermat.h's JSON tokenizer and safetensors header parser). `-DSM_CONVERT_MAIN` turns
 * sm_convert.c into a stand-alone command-line tool that includes the implementation itself.
 * POSIX threads are used for the text encoder unless SM_CONVERT_NO_PTHREADS is defined.
 *
 * Memory: bounded independently of the checkpoint size. Tensors are streamed from the input files to
 * the output through a 4 MiB buffer; the text encoder holds one layer at a time (about 50 MB for
 * SD 2.1) plus three rows of the token embedding. Files are read with 64-bit offsets (zip64 aware).
 *
 * Errors: every function returns 0 (SUPERMAT_SUCCESS) or a negative supermat_result and writes a
 * message naming the file and the tensor concerned into `err` (may be NULL). Nothing is left behind
 * on failure: the output is written to `<output>.tmp` and renamed at the end.
 */
#ifndef SM_CONVERT_H
#define SM_CONVERT_H

#include <stddef.h>
#include <stdint.h>
#include "supermat.h" /* supermat_dtype, supermat_tensor_info, supermat_result */

#ifdef __cplusplus
extern "C" {
#endif

/* ---- conversion ------------------------------------------------------------------------------- */
typedef struct sm_convert_desc {
    const char *kind;       /* "supermat", "supermat-mv" or "uv-refine"; NULL or "" = detect from the checkpoint */
    const char *checkpoint; /* the official .pth (torch.save zip format) */
    const char *base_dir;   /* Stable Diffusion 2.1 in diffusers layout */
    const char *output;     /* the model file to write */
    supermat_dtype dtype;   /* DEFAULT: keep every tensor's stored dtype; F32 / F16 / BF16: convert the
                               checkpoint and VAE tensors (round to nearest even); I8: the GEMM weights
                               as int8 + `<name>_scale` (supermat.h, INT8 WEIGHTS), the rest as stored.
                               `context` is always F32. */
    int progress;           /* nonzero: progress lines on stderr */
    int threads;            /* text encoder threads: 0 = 2, 1 = the calling thread only */
    int work_size;          /* metadata pipeline.work_size, the square size the official scripts resize a
                               picture to before the network (the CLI's default): 0 = the official one
                               for the kind (supermat, supermat-mv 512; uv-refine 1024), -1 = none:
                               0 is recorded, the CLI runs each picture at its own size, else N (a
                               multiple of 8, e.g. 128 for a model trained at 128x128) */
    float detail_sigma;     /* metadata pipeline.detail_sigma, the detail step's sigma as a fraction of the
                               picture's larger side (supermat_session_desc.detail_sigma): 0 = not recorded
                               (off), else (0, 1], recorded as printf "%.9g"; not for uv-refine */
    float chroma_weight;    /* metadata pipeline.chroma_weight, the colour step's weight
                               (supermat_session_desc.chroma_weight): 0 = not recorded (off), else (0, 1];
                               not for uv-refine */
    float bake_detail_sigma; /* metadata pipeline.bake_detail_sigma, the detail step supermat_uv.h's bake applies
                               to textures baked from this model's views, as a fraction of the texture's larger
                               side (supermat_uv_bake_desc.detail_sigma): 0 = not recorded (none), else (0, 1];
                               not for uv-refine */
    const char *roughness_curve; /* metadata pipeline.roughness_curve, the calibration curve `image` and `views` put
                               the roughness map through (supermat_session_desc.roughness_knots): NULL or "" =
                               not recorded (none), else 2 to 33 knots as supermat_parse_curve reads them
                               (each recorded as the shortest printf "%.Ng" that reads back as the same float); not for uv-refine */
    const char *metallic_curve; /* metadata pipeline.metallic_curve, the same for the metallic map
                               (supermat_session_desc.metallic_knots) */
} sm_convert_desc;

/* Converts. 0 on success, else a negative supermat_result and a message in err. Output tensors: the
   checkpoint's (names unchanged, in its order), the VAE's as "vae.<diffusers name>" (pre-0.14 attention
   names query/key/value/proj_attn are renamed to_q/to_k/to_v/to_out.0), then "context"; the metadata
   keys listed in supermat.h's MODEL FILE section (plus unet.upcast_attention, use_linear_projection,
   act_fn, transformer_layers_per_block, vae.act_fn, supermat.source). */
int sm_convert(const sm_convert_desc *desc, char *err, size_t err_cap);

/* The pipeline.* metadata of an already converted model file, rewritten without its checkpoint. */
typedef struct sm_pipeline_edit {
    int work_size;       /* pipeline.work_size (see sm_convert_desc): 0 = kept as it is, N = N (a multiple of 8
                            up to 16384), -1 = none (recorded as "0") */
    float detail_sigma;  /* pipeline.detail_sigma: < 0 = kept as it is, 0 = off (the key removed), (0, 1] = set */
    float chroma_weight; /* pipeline.chroma_weight: < 0 = kept as it is, 0 = off (the key removed), (0, 1] = set */
    float bake_detail_sigma; /* pipeline.bake_detail_sigma: < 0 = kept as it is, 0 = off (the key removed), (0, 1] = set */
    const char *roughness_curve; /* pipeline.roughness_curve: NULL = kept as it is, "" = off (the key removed), else set
                                    (as sm_convert_desc.roughness_curve) */
    const char *metallic_curve;  /* pipeline.metallic_curve: the same */
} sm_pipeline_edit;
/* `file` is the whole model file in memory (a supermat model file: its metadata has supermat.format_version);
   at least one key of `edit` must change something. A key that is set replaces its value in place; a key
   added goes after the pipeline.* key before it (work_size, detail_sigma, chroma_weight, bake_detail_sigma,
   roughness_curve, metallic_curve: the
   converter's order), else before the one after it, else first in the metadata; a key removed takes one comma
   with it. Every other byte of the header is kept (the other metadata, its order, the tensors' entries). A
   detail, colour or bake detail step or a roughness or metallic curve is refused for a uv-refine file (no input picture). Returns 0 and a malloc'ed new header
   (*header, *header_size bytes: the 8-byte length and the JSON); the new file is that header followed by
   file[*data_offset .. size), the tensor bytes as they are. The header keeps its length (padded with
   spaces) or grows by a multiple of 64 bytes, so every tensor, and a pre-packed file's panels, keeps its
   alignment. */
int sm_pipeline_header(const void *file, size_t size, const sm_pipeline_edit *edit, unsigned char **header,
                       size_t *header_size, size_t *data_offset, char *err, size_t err_cap);

/* ---- the PyTorch checkpoint reader (zip + pickle, no Python) ---------------------------------- */
typedef struct sm_pth sm_pth;

/* Opens a torch.save() file (a zip archive holding data.pkl and data/<key>, zip64 aware, STORED
   entries), runs its pickle and lists the tensors of the state dict (a top-level dict of tensors, or
   the dict under a "state_dict" or "model" key). Only F32, F16 and BF16 contiguous tensors are
   accepted. A .safetensors file is recognised by its content and opened through supermat.h's header
   parser, so either format works wherever a checkpoint is expected. */
int sm_pth_open(const char *path, sm_pth **out, char *err, size_t err_cap);
/* The same over a file image in memory (borrowed until sm_pth_close). */
int sm_pth_open_memory(const void *data, size_t size, sm_pth **out, char *err, size_t err_cap);
int sm_pth_count(const sm_pth *pth);
/* Tensor `index` in the dict's order; `offset` is the absolute file offset of its first byte. */
const supermat_tensor_info *sm_pth_tensor(const sm_pth *pth, int index);
int sm_pth_find(const sm_pth *pth, const char *name); /* index or -1 */
/* Reads tensor `index`'s nbytes raw little-endian bytes into dst, verifying the zip CRC-32 when the
   tensor spans its whole storage. */
int sm_pth_read(sm_pth *pth, int index, void *dst, char *err, size_t err_cap);
void sm_pth_close(sm_pth *pth);

/* Runs the pickle VM alone on a data.pkl image (no archive, storages not resolved): for fuzzing and
   tests. Returns 0 and the number of tensors of the state dict, or an error. */
int sm_pickle_check(const void *pkl, size_t size, int *n_tensors, char *err, size_t err_cap);

/* ---- the empty-prompt context ----------------------------------------------------------------- */
/* Runs the base folder's CLIP text encoder (text_encoder/config.json + model.safetensors, token ids
   from tokenizer/ when present) on the empty prompt "" and returns the last hidden state, float32
   [*tokens x *dim] row-major, malloc'ed (free() it). threads: 0 = 2, 1 = none. */
int sm_text_encode_empty(const char *base_dir, int threads, int progress, float **out, int *tokens, int *dim,
                         char *err, size_t err_cap);

#ifdef __cplusplus
}
#endif
#endif /* SM_CONVERT_H */
