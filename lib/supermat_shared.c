/* lib/supermat_shared.c - supermat.h and supermat_uv.h as one shared library (libsupermat.so), for bindings
 * that load a library rather than compile a header: the Python module python/supermat (ctypes). C and C++
 * programs include the headers instead (README.md, "Embedding in C").
 *
 * Every public function of both headers is exported and nothing else: SUPERMAT_API gives them default
 * visibility and CMake compiles this file with -fvisibility=hidden (a build without that flag exports the
 * private functions too, harmless). Built as CMake's target supermat_shared (CMakeLists.txt, "the shared
 * library for bindings").
 *
 * Beside the headers' API it exports supermat_shared_version and supermat_shared_layout: a binding that
 * mirrors the structs field by field (ctypes) asks the library it loaded for each struct's size and each
 * field's offset, and refuses a library built from another supermat.h instead of passing it a struct of the
 * wrong shape. */
#if defined(_WIN32)
#define SUPERMAT_API extern __declspec(dllexport)
#elif defined(__GNUC__) || defined(__clang__)
#define SUPERMAT_API extern __attribute__((visibility("default")))
#endif
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "../supermat_uv.h"

#include <string.h>

/* SUPERMAT_VERSION of the supermat.h this library was built from: (major << 16) | (minor << 8) | patch */
SUPERMAT_API int supermat_shared_version(void);
/* "struct" -> sizeof(struct), "struct.field" -> offsetof(struct, field), for the structs of the public API
   a binding fills or reads; -1 for a name not in the table (a field the header does not have) */
SUPERMAT_API long long supermat_shared_layout(const char *name);

int supermat_shared_version(void) { return SUPERMAT_VERSION; }

typedef struct supermat_shared_entry {
    const char *name;
    size_t value;
} supermat_shared_entry;
#define SM_S(T) {#T, sizeof(T)}
#define SM_F(T, f) {#T "." #f, offsetof(T, f)}
static const supermat_shared_entry supermat_shared_table[] = {
    SM_S(supermat_error), SM_F(supermat_error, result), SM_F(supermat_error, message), SM_F(supermat_error, tensor),
    SM_S(supermat_allocator), SM_F(supermat_allocator, alloc), SM_F(supermat_allocator, free), SM_F(supermat_allocator, user),
    SM_S(supermat_threading), SM_F(supermat_threading, parallel_for), SM_F(supermat_threading, user),
    SM_F(supermat_threading, max_threads),
    SM_S(supermat_model_desc), SM_F(supermat_model_desc, _start_canary), SM_F(supermat_model_desc, data),
    SM_F(supermat_model_desc, size), SM_F(supermat_model_desc, copy_data), SM_F(supermat_model_desc, kernel),
    SM_F(supermat_model_desc, weights), SM_F(supermat_model_desc, conv), SM_F(supermat_model_desc, allocator),
    SM_F(supermat_model_desc, compute), SM_F(supermat_model_desc, max_memory), SM_F(supermat_model_desc, _end_canary),
    SM_S(supermat_model_info), SM_F(supermat_model_info, kind), SM_F(supermat_model_info, kernel),
    SM_F(supermat_model_info, weights), SM_F(supermat_model_info, conv), SM_F(supermat_model_info, compute),
    SM_F(supermat_model_info, unet_in_channels), SM_F(supermat_model_info, unet_out_channels),
    SM_F(supermat_model_info, unet_levels), SM_F(supermat_model_info, layers_per_block),
    SM_F(supermat_model_info, norm_groups), SM_F(supermat_model_info, block_channels),
    SM_F(supermat_model_info, num_heads), SM_F(supermat_model_info, cross_attention_dim),
    SM_F(supermat_model_info, context_tokens), SM_F(supermat_model_info, branches),
    SM_F(supermat_model_info, class_embed_in), SM_F(supermat_model_info, vae_block_channels),
    SM_F(supermat_model_info, vae_levels), SM_F(supermat_model_info, latent_channels),
    SM_F(supermat_model_info, scaling_factor), SM_F(supermat_model_info, timestep),
    SM_F(supermat_model_info, alphas_cumprod), SM_F(supermat_model_info, v_prediction),
    SM_F(supermat_model_info, unet_params), SM_F(supermat_model_info, branch_params),
    SM_F(supermat_model_info, vae_params), SM_F(supermat_model_info, model_bytes),
    SM_F(supermat_model_info, prepacked), SM_F(supermat_model_info, prepacked_bytes),
    SM_F(supermat_model_info, work_size), SM_F(supermat_model_info, detail_sigma),
    SM_F(supermat_model_info, chroma_weight), SM_F(supermat_model_info, bake_detail_sigma),
    SM_F(supermat_model_info, roughness_knots), SM_F(supermat_model_info, roughness_curve),
    SM_F(supermat_model_info, metallic_knots), SM_F(supermat_model_info, metallic_curve),
    SM_S(supermat_session_desc), SM_F(supermat_session_desc, _start_canary), SM_F(supermat_session_desc, model),
    SM_F(supermat_session_desc, width), SM_F(supermat_session_desc, height), SM_F(supermat_session_desc, outputs),
    SM_F(supermat_session_desc, views), SM_F(supermat_session_desc, threads), SM_F(supermat_session_desc, threading),
    SM_F(supermat_session_desc, allocator), SM_F(supermat_session_desc, work_width),
    SM_F(supermat_session_desc, work_height), SM_F(supermat_session_desc, vae_tile),
    SM_F(supermat_session_desc, vae_overlap), SM_F(supermat_session_desc, skip_background),
    SM_F(supermat_session_desc, mv_attention), SM_F(supermat_session_desc, mv_key_stride),
    SM_F(supermat_session_desc, max_memory), SM_F(supermat_session_desc, detail_sigma),
    SM_F(supermat_session_desc, chroma_weight), SM_F(supermat_session_desc, roughness_knots),
    SM_F(supermat_session_desc, roughness_curve), SM_F(supermat_session_desc, metallic_knots),
    SM_F(supermat_session_desc, metallic_curve), SM_F(supermat_session_desc, _end_canary),
    SM_S(supermat_image), SM_F(supermat_image, pixels), SM_F(supermat_image, width), SM_F(supermat_image, height),
    SM_F(supermat_image, channels), SM_F(supermat_image, stride), SM_F(supermat_image, format),
    SM_S(supermat_run_desc), SM_F(supermat_run_desc, _start_canary), SM_F(supermat_run_desc, input),
    SM_F(supermat_run_desc, albedo), SM_F(supermat_run_desc, roughness), SM_F(supermat_run_desc, metallic),
    SM_F(supermat_run_desc, orm), SM_F(supermat_run_desc, input_views), SM_F(supermat_run_desc, cameras),
    SM_F(supermat_run_desc, albedo_views), SM_F(supermat_run_desc, roughness_views),
    SM_F(supermat_run_desc, metallic_views), SM_F(supermat_run_desc, orm_views), SM_F(supermat_run_desc, mask),
    SM_F(supermat_run_desc, position), SM_F(supermat_run_desc, refined), SM_F(supermat_run_desc, chart),
    SM_F(supermat_run_desc, progress), SM_F(supermat_run_desc, progress_user), SM_F(supermat_run_desc, inspect),
    SM_F(supermat_run_desc, inspect_user), SM_F(supermat_run_desc, _end_canary),
    SM_S(supermat_uv_part), SM_F(supermat_uv_part, _start_canary), SM_F(supermat_uv_part, positions),
    SM_F(supermat_uv_part, position_stride), SM_F(supermat_uv_part, uvs), SM_F(supermat_uv_part, uv_stride),
    SM_F(supermat_uv_part, normals), SM_F(supermat_uv_part, normal_stride), SM_F(supermat_uv_part, vertex_count),
    SM_F(supermat_uv_part, indices), SM_F(supermat_uv_part, index_stride), SM_F(supermat_uv_part, index_count),
    SM_F(supermat_uv_part, base_color), SM_F(supermat_uv_part, base_color_factor), SM_F(supermat_uv_part, wrap_u),
    SM_F(supermat_uv_part, wrap_v), SM_F(supermat_uv_part, output), SM_F(supermat_uv_part, _end_canary),
    SM_S(supermat_uv_bake_desc), SM_F(supermat_uv_bake_desc, _start_canary), SM_F(supermat_uv_bake_desc, parts),
    SM_F(supermat_uv_bake_desc, part_count), SM_F(supermat_uv_bake_desc, output_count),
    SM_F(supermat_uv_bake_desc, texture_width), SM_F(supermat_uv_bake_desc, texture_height),
    SM_F(supermat_uv_bake_desc, view_size), SM_F(supermat_uv_bake_desc, view_work_size),
    SM_F(supermat_uv_bake_desc, refine_work_size), SM_F(supermat_uv_bake_desc, supersample),
    SM_F(supermat_uv_bake_desc, ortho_half_width), SM_F(supermat_uv_bake_desc, uv_origin_bottom_left),
    SM_F(supermat_uv_bake_desc, position_frame), SM_F(supermat_uv_bake_desc, passthrough),
    SM_F(supermat_uv_bake_desc, mv_model), SM_F(supermat_uv_bake_desc, albedo_refine_model),
    SM_F(supermat_uv_bake_desc, rm_refine_model), SM_F(supermat_uv_bake_desc, keep_observed),
    SM_F(supermat_uv_bake_desc, weight), SM_F(supermat_uv_bake_desc, cos_power),
    SM_F(supermat_uv_bake_desc, max_angle_deg), SM_F(supermat_uv_bake_desc, depth_tolerance),
    SM_F(supermat_uv_bake_desc, edge_reject), SM_F(supermat_uv_bake_desc, keep_mixed),
    SM_F(supermat_uv_bake_desc, gutter), SM_F(supermat_uv_bake_desc, threads), SM_F(supermat_uv_bake_desc, threading),
    SM_F(supermat_uv_bake_desc, allocator), SM_F(supermat_uv_bake_desc, max_memory),
    SM_F(supermat_uv_bake_desc, progress), SM_F(supermat_uv_bake_desc, progress_user),
    SM_F(supermat_uv_bake_desc, debug), SM_F(supermat_uv_bake_desc, debug_user),
    SM_F(supermat_uv_bake_desc, detail_sigma), SM_F(supermat_uv_bake_desc, detail_limit),
    SM_F(supermat_uv_bake_desc, _end_canary),
    SM_S(supermat_uv_output), SM_F(supermat_uv_output, base_color), SM_F(supermat_uv_output, metallic_roughness),
    SM_S(supermat_uv_stats), SM_F(supermat_uv_stats, triangles), SM_F(supermat_uv_stats, triangles_degenerate),
    SM_F(supermat_uv_stats, triangles_uv_degenerate), SM_F(supermat_uv_stats, triangles_uv_too_large),
    SM_F(supermat_uv_stats, view_center), SM_F(supermat_uv_stats, view_scale),
    SM_F(supermat_uv_stats, position_center), SM_F(supermat_uv_stats, position_scale),
    SM_F(supermat_uv_stats, texels_chart), SM_F(supermat_uv_stats, texels_seen), SM_F(supermat_uv_stats, texels_overlap)};
#undef SM_S
#undef SM_F

long long supermat_shared_layout(const char *name) {
    size_t i;
    if (!name) return -1;
    for (i = 0; i < sizeof supermat_shared_table / sizeof supermat_shared_table[0]; i++)
        if (!strcmp(supermat_shared_table[i].name, name)) return (long long)supermat_shared_table[i].value;
    return -1;
}
