/* supermat_uv.h - v0.1 - public domain / MIT - from a textured mesh to PBR UV textures with SuperMat
 *
 * The mesh side of SuperMat (paper section 3.3), beside supermat.h as cgltf_write.h stands beside
 * cgltf.h: give it a triangle mesh with UVs and its base-colour texture, get back a complete albedo
 * (glTF baseColor) texture and a glTF metallicRoughness texture in the mesh's own UV layout.
 *
 * ONE FILE DEFINES THE IMPLEMENTATION
 *     #define SUPERMAT_IMPLEMENTATION      // supermat.h's, unless another file already has it
 *     #define SUPERMAT_UV_IMPLEMENTATION
 *     #include "supermat_uv.h"             // includes "supermat.h"
 * in exactly one C or C++ file; every other file includes it without the defines.
 *
 * QUICK START (compiled by the test suite)
 *
 *     supermat_uv_part part; memset(&part, 0, sizeof part);
 *     part.positions = xyz; part.uvs = uv; part.vertex_count = nv;      // Z up, see FRAMES
 *     part.indices = idx; part.index_count = ni;                         // NULL = triangle list
 *     part.base_color.pixels = rgba8; part.base_color.width = tw; part.base_color.height = th;
 *     part.base_color.channels = 4;                                      // 8-bit = sRGB
 *     supermat_uv_bake_desc bd; memset(&bd, 0, sizeof bd);
 *     bd.parts = &part; bd.part_count = 1;
 *     bd.mv_model = mv; bd.albedo_refine_model = bc; bd.rm_refine_model = rm;  // supermat_model_create
 *     supermat_uv_output out; memset(&out, 0, sizeof out);
 *     out.base_color.pixels = albedo_rgba8;       out.base_color.channels = 4;          // 1024x1024
 *     out.metallic_roughness.pixels = mr_rgb8;    out.metallic_roughness.channels = 3;
 *     supermat_error err;
 *     if (supermat_uv_bake(&bd, &out, NULL, &err) != SUPERMAT_SUCCESS) puts(err.message);
 *
 * THE API (the declarations below)
 *   supermat_uv_bake                      a textured mesh -> albedo and metallicRoughness UV textures
 *   supermat_uv_bake_memory               the bake's peak bytes for a desc, without allocating
 *   supermat_uv_cameras                   the 6 official camera-to-world matrices the views are rendered with
 *   Descriptors (bake desc, parts) are cleared with memset or = {0} before use: 0 is every field's default,
 *   and one that was not cleared is refused (_start_canary / _end_canary). Models come from supermat.h.
 *
 * THE MODELS' PIPELINE
 *   Every field left 0 is what the model files record (supermat_model_info): the networks run at their
 *   work sizes (view_work_size, refine_work_size) and the albedo gets the view model's detail step, so
 *   the quick start bakes what `supermat mesh` bakes with the same models. SUPERMAT_WORK_NATIVE and
 *   SUPERMAT_OFF override a file's value with none.
 *
 * THE PIPELINE (one call, supermat_uv_bake)
 *   1. Validate and normalise the mesh (see FRAMES). Zero-area triangles are skipped and counted.
 *   2. Render the 6 official orthographic views (SuperMatMV's training cameras, supermat_uv_cameras())
 *      of the *unlit* textured mesh: RGBA, straight alpha, background RGB 0.5 / alpha 0, antialiased
 *      by `supersample` x `supersample` samples per pixel (default 4x4: alpha is the covered fraction,
 *      RGB the mean colour of the covered samples, so edges never mix with the background), plus a
 *      depth buffer sampled at pixel centres (used for visibility).
 *      Texture sampling is bilinear with the part's wrap mode (repeat by default). Colours are
 *      sRGB-encoded throughout, as an unlit render shows them: 8-bit textures as stored, float
 *      textures encoded, baseColorFactor applied in linear. The `debug` callback receives every
 *      intermediate image (views, depth, predictions, partial maps, mask, position, seen views).
 *   3. Run SuperMatMV (supermat.h) on the 6 views with their camera-to-world matrices, or, with
 *      `passthrough`, use the rendered colour as the albedo prediction and a constant RM (roughness 0.5,
 *      metallic 0): no network at all, which tests the geometry of the whole path.
 *   4. Back-project by per-texel gather: every texel centre covered by a triangle in UV space gives a
 *      surface point; it is projected into each view and depth-tested against the view's depth buffer
 *      (see VISIBILITY); the prediction is sampled bilinearly from the pixels that pass. Blend
 *      C = sum_i M_i C_i / (sum_i M_i + 1e-8) with M_i = 1 (default, the paper's plain average) or
 *      |cos|^k; the mask is min(number of views that saw the texel, 3) / 3 as in the official example,
 *      the partial maps are exactly 0 where it is 0, and the position map is (p + 1) / 2 in the
 *      position frame, 127/255 gray outside the charts (as the official example).
 *   5. Refine albedo and RM with the two UV-refine networks at the texture size (1024x1024 default).
 *      A NULL refine model (or passthrough) skips that refinement.
 *   5b. With a detail step (`detail_sigma`; left 0, the one the view model's file records: 1/32 for the
 *      multi-view default, none for an official file; see DETAIL), the albedo keeps the input texture's
 *      detail: input colour x low-pass(albedo) / low-pass(input colour), the input's detail bounded
 *      (`detail_limit`).
 *   6. Gutter fill and output: texels that hold no value (outside the charts, or unseen when nothing
 *      was refined) take the value of a nearest valid texel, up to `gutter` texels away (default 16:
 *      enough for a 1024 texture's mip chain down to 64x64), then the mean of the valid texels.
 *      baseColor: 8-bit sRGB, or float linear. metallicRoughness: R = 1, G roughness, B metallic,
 *      alpha 1, linear (R = 1 so the texture is harmless if also bound as an occlusion/ORM map).
 *
 * DETAIL (not in the official pipeline; `detail_sigma`)
 *   A network run at a small size (the default model's 128x128, a 16x16 latent) predicts an albedo
 *   whose level and colour may be right but whose detail is gone, while the input texture (lighting
 *   baked in) has all of it. With detail_sigma = f > 0, at every chart texel, per channel in linear
 *   light: albedo = L~ x clamp(G(w A) / G(w L), 1/4, 4) x clamp(L / L~, 1/k, k), with L~ = G(w L) / G(w)
 *   the input's own low-pass, k = detail_limit (default SUPERMAT_UV_DETAIL_LIMIT, 4), L the input base
 *   colour sampled at the texel centre (the part's texture, wrap mode and factor, as the views are
 *   rendered), A the albedo
 *   of steps 4-5, w 1 where A holds a value (seen texels; all chart texels when the albedo was
 *   refined) and 0 elsewhere, and G a low-pass of sigma = f x max(texture width, height) texels: three
 *   passes of a box filter of width 2r + 1, r = round((sqrt(4 sigma^2 + 1) - 1) / 2) (the variance of
 *   a Gaussian of that sigma), rows then columns, zero outside the texture. So the lighting is assumed
 *   smooth at that scale: the network sets the level and colour, the input the detail. Where G(w L) is
 *   below 1e-6 the ratio falls back to the texture's sum(w A) / sum(w L) (1 when either is 0); where
 *   G(w) is, L~ is sum(w L) / sum(w), and the detail ratio is 1 where L~ is below 1e-6. The detail ratio's
 *   bound k keeps what a path tracer bakes into a texture and the network took out (contact shadows,
 *   occlusion, a metal's reflections of its surroundings: ratios far from 1) from coming back whole;
 *   detail_limit = SUPERMAT_OFF drops that bound (L x clamp(G(w A) / G(w L), 1/4, 4), the form before
 *   2026-12-08). The albedo then holds a value at every chart texel, seen or not. Roughness / metallic
 *   are not touched. Measured (docs/mesh.md; the default model, view by view): f = 1/32 chosen on five
 *   validation assets, where it adds 0.39 dB of albedo PSNR over f = 0, then 1.37 dB on the five held-out
 *   ones; k = 4 on six validation assets lit-baked by both the project's renderer and Blender's Cycles
 *   (within 0.01 dB of the best k there), +2.18 dB on the Cycles-baked held-out four (docs/mesh.md).
 *
 * FRAMES (what the official example inputs show: examples/bag_rendered_6views, examples/axe_uv)
 *   World: positions as given (node transforms already applied), **Z up**, the front of the object
 *   facing -Y (Blender's convention, which the official cameras use). glTF is Y up facing +Z: convert
 *   with (x, y, z)_glTF -> (x, -z, y), as Blender's importer does (cli/mesh.cpp does it).
 *   View frame (rendering): q = (p - c) * s with c the bounding-box centre and s = 1 / max |p - c|
 *   over all coordinates, so the object lies in [-1, 1]^3 touching it on its largest axis; the
 *   orthographic views cover [-1.1, 1.1] (`ortho_half_width`), so the largest extent fills 1/1.1 of
 *   the frame. Why: the official 6-view example (1024 px) is centred to the pixel in every view and its
 *   largest extent spans 930-931 px = 1024 / 1.1.
 *   Position frame (the UV position map, default SUPERMAT_UV_POSITION_OFFICIAL): p' = p / max |p|,
 *   *not* re-centred. Why: the official axe position map spans z in [-1, 0.52], y in [-0.48, 0.21]:
 *   its object was scaled so that its largest coordinate magnitude is 1 about its own origin, and the
 *   UV-refine network was trained on such maps. SUPERMAT_UV_POSITION_CENTERED uses the view frame
 *   instead (for assets whose origin is far from the object, where the official frame degenerates).
 *   Both frames are computed in double and are invariant to a uniform scale of the input, so 1e-6 or
 *   1e6 sized objects give the same textures. supermat_uv_stats returns c, s and the position frame.
 *   Images: row 0 is the top row. UVs follow glTF (u right, v = 0 at the first row of the image);
 *   `uv_origin_bottom_left` selects the OpenGL convention (v = 0 at the last row) for input and output.
 *
 * VISIBILITY
 *   A texel's surface point is projected into a view (continuous pixel coordinates and depth). Each of
 *   the 4 pixels of its bilinear footprint is accepted if the depth buffer there holds a surface within
 *   depth_tolerance (default 2) pixel sizes, plus the plane's depth slope over one pixel (at most 4
 *   pixel sizes), of the texel's tangent plane extrapolated to that pixel centre. The slope-scaled bias
 *   keeps curved surfaces visible up to their silhouettes; the cap keeps occluders a few pixels behind
 *   a grazing surface out. The sample is the bilinear mix of the accepted pixels, renormalised.
 *   Also never sampled:
 *   - points seen more edge-on than 88.85 degrees (cos < 0.02 with the triangle's normal), or than
 *     `max_angle_deg` when that is smaller;
 *   - antialiased pixels whose samples lie on two surfaces (a sample more than 4 x depth_tolerance
 *     pixel sizes off the plane of the triangle at the pixel centre): occlusion boundaries, where the
 *     colour mixes both surfaces (`keep_mixed` keeps them). Silhouettes against the background are
 *     fine: the views have straight alpha, so their colour is the surface's alone;
 *   - with `edge_reject` = N, pixels closer than N pixels to a silhouette or to a depth discontinuity
 *     (where the network's predictions are least reliable).
 *   Rendering is two-sided (no back-face culling, as Blender renders). Back-projection is one-sided for
 *   parts with normals: a view sees a texel only from the side the vertex normals point to (the
 *   triangle's geometric normal, flipped to agree with them); without normals it is two-sided (closed
 *   meshes still hide their back faces by depth, except within the tolerance at silhouettes).
 *
 * SEVERAL TRIANGLES ON ONE TEXEL, SEAMS AND WRAPPING
 *   UV rasterisation samples texel centres with a watertight edge rule: triangles of one chart never
 *   both claim a texel and leave no hole. Where charts overlap (mirrored or stacked UVs), every
 *   triangle covering the texel contributes its observations to the blend (an occluded copy is filled
 *   by a visible one); the position map holds the point of the first covering triangle (part order,
 *   then index order). UVs outside [0, 1] wrap as the part's sampler says: repeat (default) and
 *   mirror fold them into the texture, clamp drops texels outside it. A triangle whose UV footprint
 *   exceeds 4 texture areas is not baked (counted in stats). The gutter fill wraps around the texture
 *   edges too (repeat sampling). Degenerate UV triangles (zero UV area) render but bake nothing.
 *
 * WHAT IT DOES NOT DO
 *   No file I/O, no image decoding, no glTF: cli/mesh.cpp shows all of that with tinygltf.
 *   No lighting, no alpha blending/masking (texture alpha is ignored: surfaces are opaque), no UV
 *   unwrapping (the mesh must have UVs).
 *
 * CONFIGURATION
 *   The macros of supermat.h (SUPERMAT_STATIC, SUPERMAT_API, SUPERMAT_NO_PTHREADS, ...) apply here too.
 *
 * MEMORY, THREADS, ERRORS
 *   Every byte comes from the caller's allocator (default malloc/free); supermat_uv_bake_memory()
 *   tells the peak (mesh copy, views, maps and the networks' sessions; not the models) before anything
 *   is allocated. At the defaults the bake's own peak is 173 MB for a small mesh (6 views of 512^2:
 *   71 MB; 4x4 samples: 34 MB of sample buffers reused view by view; a 1024^2 texture: about 100 MB
 *   of maps, per output texture 20 MB kept until the end), plus 44 bytes per vertex and 16 per
 *   triangle. The networks' sessions come on top (supermat_session_memory), one at a time, each
 *   freed after its run; the models are the caller's. Measuring allocates nothing. A cap
 *   (`max_memory`) makes the bake measure first and fail with OUT_OF_MEMORY, the planned size in
 *   the message, before its first allocation.
 *   Threads: `threading` (a caller's parallel-for) or `threads` (0 all cores, 1 none: a supermat.h
 *   pool made for the call) serves rendering (bands of pixel rows), back-projection (bands of texel
 *   rows) and the networks; scratch memory does not grow with the thread count. Every pixel and texel
 *   is computed by one task in a fixed order, so results are identical for any thread count.
 *   Errors: a supermat_result and an optional
 *   supermat_error with a message (vertex, triangle, part concerned). NaN/Inf positions, UVs or normals,
 *   out-of-range indices, no triangles, no UVs, bad images, wrong model kinds and cancellation through
 *   the progress callback are reported; on error no output pixel is written.
 *
 * LICENSE: see the end of the file (MIT or public domain, your choice).
 */
#ifndef SUPERMAT_UV_H
#define SUPERMAT_UV_H

#include "supermat.h"

#define SUPERMAT_UV_VERSION_MAJOR 0
#define SUPERMAT_UV_VERSION_MINOR 2
#define SUPERMAT_UV_VERSION_PATCH 0
#define SUPERMAT_UV_VERSION ((SUPERMAT_UV_VERSION_MAJOR << 16) | (SUPERMAT_UV_VERSION_MINOR << 8) | SUPERMAT_UV_VERSION_PATCH)

#define SUPERMAT_UV_VIEWS 6 /* front (-Y), right (+X), back (+Y), left (-X), top (+Z), bottom (-Z) */
#define SUPERMAT_UV_DETAIL_LIMIT 4.0f /* supermat_uv_bake_desc.detail_limit's default (DETAIL) */

#ifdef __cplusplus
extern "C" {
#endif

typedef enum supermat_uv_wrap {
    SUPERMAT_UV_WRAP_REPEAT = 0, /* glTF's default */
    SUPERMAT_UV_WRAP_CLAMP,
    SUPERMAT_UV_WRAP_MIRROR,
    SUPERMAT_UV_WRAP_COUNT
} supermat_uv_wrap;

typedef enum supermat_uv_weight {
    SUPERMAT_UV_WEIGHT_AVERAGE = 0, /* every view that sees the texel counts 1 (the paper's) */
    SUPERMAT_UV_WEIGHT_COS_POWER,   /* |cos(view angle)|^cos_power */
    SUPERMAT_UV_WEIGHT_COUNT
} supermat_uv_weight;

typedef enum supermat_uv_position_frame {
    SUPERMAT_UV_POSITION_OFFICIAL = 0, /* p / max|p|, not re-centred (the official example) */
    SUPERMAT_UV_POSITION_CENTERED,     /* the view frame: (p - bbox centre) / max|p - centre| */
    SUPERMAT_UV_POSITION_COUNT
} supermat_uv_position_frame;

/* One primitive: borrowed arrays with strides in bytes. */
typedef struct supermat_uv_part {
    uint32_t _start_canary;     /* leave 0, as _end_canary: a part not cleared (memset 0) is refused */
    const float *positions;     size_t position_stride; /* xyz, world (Z up); stride 0 = 12 */
    const float *uvs;           size_t uv_stride;       /* uv; stride 0 = 8; required */
    const float *normals;       size_t normal_stride;   /* optional xyz: the outer side, and cos^k weights */
    uint32_t vertex_count;
    const uint32_t *indices;    size_t index_stride;    /* NULL = a plain triangle list; stride 0 = 4 */
    uint32_t index_count;       /* a multiple of 3; without indices 0 means vertex_count */
    supermat_image base_color;  /* 1-4 channels (gray, gray+alpha, RGB, RGBA; alpha ignored), 8-bit =
                                   sRGB, float = linear; pixels NULL = the factor alone */
    const float *base_color_factor; /* linear RGBA multiplier (glTF baseColorFactor); NULL = 1 */
    supermat_uv_wrap wrap_u, wrap_v;
    int output;                 /* the output texture this part's UVs address, 0 .. output_count-1 */
    uint32_t _end_canary;
} supermat_uv_part;

typedef enum supermat_uv_debug_kind {
    SUPERMAT_UV_DEBUG_VIEW = 0,       /* index = view: RGBA straight alpha, view size */
    SUPERMAT_UV_DEBUG_VIEW_DEPTH,     /* index = view: 1 ch, depth in the view frame, +inf = nothing */
    SUPERMAT_UV_DEBUG_PRED_ALBEDO,    /* index = view: RGB, the albedo prediction (sRGB-encoded) */
    SUPERMAT_UV_DEBUG_PRED_RM,        /* index = view: RGB = (0, roughness, metallic) */
    SUPERMAT_UV_DEBUG_PARTIAL_ALBEDO, /* index = output: RGB, the blended back-projection, 0 unseen */
    SUPERMAT_UV_DEBUG_PARTIAL_RM,     /* index = output: RGB = (0, roughness, metallic), 0 unseen */
    SUPERMAT_UV_DEBUG_MASK,           /* index = output: 1 ch, min(views that saw it, 3) / 3 */
    SUPERMAT_UV_DEBUG_POSITION,       /* index = output: RGB, (p' + 1) / 2, 127/255 off the charts */
    SUPERMAT_UV_DEBUG_SEEN,           /* index = output: 1 ch, bit v set if view v saw the texel */
    SUPERMAT_UV_DEBUG_CHART,          /* index = output: 1 ch, 1 where a triangle covers the texel */
    SUPERMAT_UV_DEBUG_REFINED_ALBEDO, /* index = output: RGB, the UV-refine network's raw output */
    SUPERMAT_UV_DEBUG_REFINED_RM,     /* index = output: RGB */
    SUPERMAT_UV_DEBUG_INPUT_COLOR,    /* index = output: RGB, the input base colour at each chart texel
                                         (sRGB-encoded), 0 elsewhere; only with detail_sigma > 0 */
    SUPERMAT_UV_DEBUG_COUNT
} supermat_uv_debug_kind;

typedef struct supermat_uv_bake_desc {
    uint32_t _start_canary;      /* leave 0, as _end_canary: a desc not cleared (memset 0) is refused */
    const supermat_uv_part *parts;
    int part_count;
    int output_count;            /* output textures (one per material); 0 = 1 */
    int texture_width, texture_height; /* output size: 0 = 1024; multiples of 8 */
    int view_size;               /* rendered views: 0 = 512 (the networks' size); a multiple of 8 */
    int view_work_size;          /* the view model's network size: the views are resampled to it and the maps
                                    back (supermat_session_desc.work_width/height). 0 = the size its file
                                    records (supermat_model_info.work_size: 512 official, 128 the multi-view
                                    default; the view size for a file that records none);
                                    SUPERMAT_WORK_NATIVE = the view size */
    int refine_work_size;        /* likewise for the UV-refine models and the texture size (0: each refine
                                    model's own, official 1024, the defaults 256) */
    int supersample;             /* samples per pixel per axis: 0 = 4 (16 samples), 1 .. 8 */
    float ortho_half_width;      /* half the view width in the view frame: 0 = 1.1 */
    int uv_origin_bottom_left;   /* 0: glTF UVs; 1: OpenGL UVs (v = 0 at the last row) */
    supermat_uv_position_frame position_frame;
    int passthrough;             /* no networks: albedo = rendered colour, roughness 0.5, metallic 0 */
    const supermat_model *mv_model;            /* kind supermat-mv (required unless passthrough), or a
                                                  single-view supermat model: run view by view, no
                                                  cross-view attention (the paper's ablation) */
    const supermat_model *albedo_refine_model; /* kind uv-refine, NULL = no albedo refinement */
    const supermat_model *rm_refine_model;     /* kind uv-refine, NULL = no RM refinement */
    int keep_observed;           /* refined maps only fill unseen texels (default: refined everywhere) */
    supermat_uv_weight weight;
    float cos_power;             /* SUPERMAT_UV_WEIGHT_COS_POWER exponent: 0 = 2 */
    float max_angle_deg;         /* views at a larger angle to the normal are not used: 0 = 88.85 */
    float depth_tolerance;       /* in view pixel sizes: 0 = 2 (see VISIBILITY) */
    int edge_reject;             /* pixels: 0 = keep pixels next to silhouettes and depth edges */
    int keep_mixed;              /* also sample pixels whose samples lie on two surfaces (see VISIBILITY) */
    int gutter;                  /* texels filled around the valid texels: 0 = 16; < 0 = the whole texture */
    int threads;                 /* 0 = all cores, 1 = the calling thread only */
    supermat_threading threading;/* a caller's parallel-for: overrides `threads` */
    supermat_allocator allocator;
    size_t max_memory;           /* 0 = no limit; else a bake whose peak (supermat_uv_bake_memory: mesh copy,
                                    views, maps and the networks' sessions; not the models) would pass it
                                    fails with OUT_OF_MEMORY before anything is allocated */
    int (*progress)(void *user, float fraction, const char *what); /* nonzero = cancel */
    void *progress_user;
    /* intermediate images as float32 (row-major, interleaved, row 0 at the top); valid during the call */
    void (*debug)(void *user, supermat_uv_debug_kind kind, int index, const float *data, int width, int height,
                  int channels);
    void *debug_user;
    float detail_sigma;          /* > 0: the albedo keeps the input texture's detail (see DETAIL), low-pass
                                    sigma as a fraction of the texture's larger side, at most 1. 0 = the view
                                    model's (supermat_model_info.bake_detail_sigma: the multi-view default
                                    records 1/32, an official file none; none with passthrough);
                                    SUPERMAT_OFF (negative) = off (the official pipeline) */
    float detail_limit;          /* how far the input texture's detail may move the albedo (see DETAIL): at
                                    most this ratio above or below its low-pass, 1 < limit <= 1e6; 0 =
                                    SUPERMAT_UV_DETAIL_LIMIT; SUPERMAT_OFF (negative) = unbounded, the form
                                    before 2026-12-08: L x clamp(G(w A) / G(w L), 1/4, 4) */
    uint32_t _end_canary;
} supermat_uv_bake_desc;

/* One output texture's images (pixels NULL = not wanted; width/height 0 = the texture size, else equal). */
typedef struct supermat_uv_output {
    supermat_image base_color;         /* 3 or 4 channels (alpha 1); 8-bit sRGB or float linear */
    supermat_image metallic_roughness; /* 3 or 4 channels: R 1, G roughness, B metallic, A 1; linear */
} supermat_uv_output;

typedef struct supermat_uv_stats {
    uint32_t triangles;              /* triangles baked */
    uint32_t triangles_degenerate;   /* zero area in 3D (< 1e-12 in the view frame): skipped */
    uint32_t triangles_uv_degenerate;/* zero UV area: rendered, cover no texel */
    uint32_t triangles_uv_too_large; /* UV footprint over 4 texture areas: rendered, not baked */
    double view_center[3], view_scale;         /* view frame q = (p - view_center) * view_scale */
    double position_center[3], position_scale; /* position frame p' = (p - position_center) * position_scale */
    uint64_t texels_chart;           /* texels covered by a triangle (all outputs) */
    uint64_t texels_seen;            /* of those, seen by at least one view */
    uint64_t texels_overlap;         /* covered by more than one triangle */
} supermat_uv_stats;

/* The 6 official camera-to-world matrices (meta.json of the official example), row-major, 16 floats
   each, in view order: exactly what SuperMatMV receives. */
SUPERMAT_API void supermat_uv_cameras(float matrices[SUPERMAT_UV_VIEWS * 16]);
/* Peak bytes supermat_uv_bake would allocate with this desc (mesh, views, maps and the networks'
   sessions), without allocating. The desc is checked as by supermat_uv_bake, not the mesh arrays. */
SUPERMAT_API supermat_result supermat_uv_bake_memory(const supermat_uv_bake_desc *desc, size_t *bytes,
                                                     supermat_error *err);
/* Runs the whole pipeline; outputs[0 .. output_count-1] receive the textures. stats may be NULL. */
SUPERMAT_API supermat_result supermat_uv_bake(const supermat_uv_bake_desc *desc, const supermat_uv_output *outputs,
                                              supermat_uv_stats *stats, supermat_error *err);

/* ======================================== the API ends here ==================================== */
#ifdef __cplusplus
}
#endif
#endif /* SUPERMAT_UV_H */

/* ============================================================================================== */
/*                                       IMPLEMENTATION                                           */
/* ============================================================================================== */
#ifdef SUPERMAT_UV_IMPLEMENTATION
#ifndef SUPERMAT_UV_IMPLEMENTATION_DONE
#define SUPERMAT_UV_IMPLEMENTATION_DONE

/* >>uv-platform */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef SUPERMAT_STATIC
#if defined(__GNUC__) || defined(__clang__)
#define SUPERMAT_UV__DEF static __attribute__((unused))
#else
#define SUPERMAT_UV__DEF static
#endif
#else
#define SUPERMAT_UV__DEF
#endif
#if !defined(SUPERMAT_NO_PTHREADS) && (defined(__unix__) || defined(__APPLE__))
#define SUPERMAT_UV__HAS_POOL 1
#else
#define SUPERMAT_UV__HAS_POOL 0
#endif

#define SUPERMAT_UV__NONE 0xFFFFFFFFu
#define SUPERMAT_UV__MAXBLOCKS 640
#define SUPERMAT_UV__MIN_COS 0.02     /* ~88.85 degrees */
#define SUPERMAT_UV__OFF_CHART (127.0f / 255.0f)
#define SUPERMAT_UV__SLOPE_CAP 4.0    /* the slope-scaled depth bias, at most this many pixel sizes */
#define SUPERMAT_UV__BAND 16          /* texture rows per back-projection task */

/* the official cameras (meta.json of examples/bag_rendered_6views, float32 values printed as doubles) */
static const double supermat_uv__cam[SUPERMAT_UV_VIEWS][16] = {
    {1.0, 0.0, 6.123233601181349e-17, 6.123234262925839e-17, 6.123233601181349e-17, 3.422854177870249e-08, -0.9999999403953552, -1.0, 0.0, 0.9999999403953552, 3.422854177870249e-08, 0.0, 0.0, 0.0, 0.0, 1.0},
    {1.1920928244535389e-07, 0.0, 0.9999998807907104, 1.0, 0.9999998807907104, 1.1920928244535389e-07, 0.0, 0.0, 0.0, 0.9999998807907104, 1.1920928244535389e-07, 0.0, 0.0, 0.0, 0.0, 1.0},
    {-0.9999999403953552, 8.742277657347586e-08, 0.0, 6.123234262925839e-17, 0.0, 3.4228538225988814e-08, 0.9999999403953552, 1.0, 8.742277657347586e-08, 0.9999999403953552, 3.4228538225988814e-08, 0.0, 0.0, 0.0, 0.0, 1.0},
    {5.9604641222676946e-08, 0.0, -0.9999999403953552, -1.0, -0.9999999403953552, 1.1920928244535389e-07, 0.0, 1.2246468525851679e-16, 5.9604641222676946e-08, 0.9999999403953552, 5.9604641222676946e-08, 0.0, 0.0, 0.0, 0.0, 1.0},
    {-1.0000001192092896, 8.742277657347586e-08, 1.5258152380459578e-11, 1.0687059615292178e-20, -8.742277657347586e-08, -1.0, -0.0003490658418741077, -0.00017453292093705386, -1.5258152380459578e-11, -0.0003490658418741077, 0.9999999403953552, 1.0, 0.0, 0.0, 0.0, 1.0},
    {-1.0000001192092896, -8.742277657347586e-08, 1.526579557209473e-11, 1.0687059615292178e-20, -8.742277657347586e-08, 0.9999999403953552, -0.00034915326978079975, -0.00017453292093705386, 1.5258152380459578e-11, -0.00034915326978079975, -1.0, -1.0, 0.0, 0.0, 0.0, 1.0},
};

/* >>uv-errors */
static supermat_result supermat_uv__fail(supermat_error *err, supermat_result r, const char *fmt, ...) {
    if (err) {
        va_list ap;
        memset(err, 0, sizeof *err);
        err->result = r;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return r;
}

/* >>uv-memory */
static void *supermat_uv__malloc(void *user, size_t size, size_t align) { (void)user; (void)align; return malloc(size); }
static void supermat_uv__mfree(void *user, void *p, size_t size) { (void)user; (void)size; free(p); }

typedef struct supermat_uv__view {
    double X[3], Y[3], Z[3], T[3]; /* camera axes (columns of camera-to-world) and position */
    float *rgba;                   /* W x H x 4 */
    float *depth;                  /* W x H, +inf = background */
    float *albedo;                 /* W x H x 3: prediction */
    float *rm;                     /* W x H x 3: (0, roughness, metallic) */
    unsigned char *edge;           /* W x H or NULL */
    unsigned char *mixed;          /* W x H: the samples of the pixel lie on more than one surface */
} supermat_uv__view;

typedef struct supermat_uv__tex {
    const unsigned char *px;
    int w, h, ch, f32, has;
    size_t stride;
    supermat_uv_wrap wu, wv;
    int use_factor;
    float factor[3];
    float constant[3]; /* sRGB-encoded colour when there is no texture */
} supermat_uv__tex;

typedef struct supermat_uv__ctx {
    supermat_uv_bake_desc d; /* with defaults resolved */
    supermat_error *err;
    supermat_allocator al;
    void *blk[SUPERMAT_UV__MAXBLOCKS];
    size_t blk_size[SUPERMAT_UV__MAXBLOCKS];
    int nblk;
    size_t bytes_now, bytes_peak;
    int measure;             /* 1: count bytes, allocate nothing */
    supermat_threading thr;
    /* mesh (all parts concatenated) */
    uint32_t nv, nt;
    float *vq;               /* nv x 3: view frame */
    float *vp;               /* nv x 3: position frame */
    float *vuv;              /* nv x 2: UV (v flipped to glTF's convention) */
    float *vn;               /* nv x 3: shading normals (unit, view frame), NULL if no part has any */
    uint32_t *tri;           /* nt x 3 */
    int *tri_part;
    supermat_uv__tex *tex;   /* per part */
    unsigned char *part_has_n;
    supermat_uv__view view[SUPERMAT_UV_VIEWS];
    int W, H, S;
    double hw, ps;           /* ortho half width, pixel size in the view frame */
    /* scratch for rendering one view */
    int cur_view;
    float *proj, *projs;     /* nv x 3: pixel coordinates and depth; the same in sample units */
    float *sdepth;           /* W S x H S */
    uint32_t *sid;           /* W S x H S */
    uint32_t *cid;           /* W x H: the triangle at each pixel centre */
    /* progress */
    float prog_base, prog_span;
    int cancelled;
    supermat_uv_stats st;
} supermat_uv__ctx;

static void *supermat_uv__alloc(supermat_uv__ctx *C, size_t n) {
    void *p;
    if (n == 0) n = 16;
    if (C->nblk >= SUPERMAT_UV__MAXBLOCKS) return NULL;
    C->bytes_now += n;
    if (C->bytes_now > C->bytes_peak) C->bytes_peak = C->bytes_now;
    if (C->measure) p = (void *)&C->blk; /* a non-NULL token, never dereferenced */
    else {
        p = C->al.alloc(C->al.user, n, 64);
        if (!p) { C->bytes_now -= n; return NULL; }
        memset(p, 0, n);
    }
    C->blk[C->nblk] = p;
    C->blk_size[C->nblk] = n;
    C->nblk++;
    return p;
}

/* frees the most recent blocks down to `mark` (a stack discipline keeps the peak count honest) */
static void supermat_uv__release(supermat_uv__ctx *C, int mark) {
    while (C->nblk > mark) {
        C->nblk--;
        C->bytes_now -= C->blk_size[C->nblk];
        if (!C->measure) C->al.free(C->al.user, C->blk[C->nblk], C->blk_size[C->nblk]);
    }
}

/* sizes in elements, with overflow checks: 0 on overflow */
static size_t supermat_uv__mul(size_t a, size_t b, size_t c) {
    if (a && b > (size_t)-1 / a) return 0;
    a *= b;
    if (a && c > (size_t)-1 / a) return 0;
    return a * c;
}

#define SUPERMAT_UV__ALLOC(C, ptr, type, count)                                                          \
    do {                                                                                                 \
        size_t n_ = (size_t)(count);                                                                     \
        if (n_ > (size_t)-1 / sizeof(type)) return supermat_uv__fail((C)->err, SUPERMAT_ERROR_OUT_OF_MEMORY, "size overflow"); \
        (ptr) = (type *)supermat_uv__alloc((C), n_ * sizeof(type));                                      \
        if (!(ptr)) return supermat_uv__fail((C)->err, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory (%llu bytes)", (unsigned long long)(n_ * sizeof(type))); \
    } while (0)

/* >>uv-threads */
static void supermat_uv__parallel(supermat_uv__ctx *C, int count, supermat_task_fn fn, void *user) {
    int i;
    if (C->thr.parallel_for && count > 1) C->thr.parallel_for(C->thr.user, count, fn, user);
    else for (i = 0; i < count; i++) fn(user, i, 0);
}

static int supermat_uv__progress(supermat_uv__ctx *C, float f, const char *what) {
    if (C->measure) return 0;
    if (C->cancelled) return 1;
    if (C->d.progress && C->d.progress(C->d.progress_user, f, what)) C->cancelled = 1;
    return C->cancelled;
}
static int supermat_uv__net_progress(void *user, float f, const char *what) {
    supermat_uv__ctx *C = (supermat_uv__ctx *)user;
    return supermat_uv__progress(C, C->prog_base + C->prog_span * f, what);
}

static void supermat_uv__debug(supermat_uv__ctx *C, supermat_uv_debug_kind k, int index, const float *data, int w,
                               int h, int c) {
    if (C->d.debug && !C->measure) C->d.debug(C->d.debug_user, k, index, data, w, h, c);
}

/* >>uv-color */
/* supermat.h's sRGB transfer (clamped to [0, 1], NaN -> 0), to float */
static float supermat_uv__to_linear(float s) { return (float)supermat_srgb_to_linear(s); }
static float supermat_uv__to_srgb(float l) { return (float)supermat_linear_to_srgb(l); }

/* >>uv-texture */
/* folds a texture coordinate (in [0,1] units) by the wrap mode */
static double supermat_uv__fold(double u, supermat_uv_wrap w) {
    if (w == SUPERMAT_UV_WRAP_CLAMP) return u < 0.0 ? 0.0 : u > 1.0 ? 1.0 : u;
    if (w == SUPERMAT_UV_WRAP_MIRROR) {
        double m = u - 2.0 * floor(u * 0.5); /* [0, 2) */
        return m > 1.0 ? 2.0 - m : m;
    }
    return u - floor(u);
}
static int supermat_uv__wrap_index(int i, int n, supermat_uv_wrap w) {
    if (w == SUPERMAT_UV_WRAP_CLAMP) return i < 0 ? 0 : i >= n ? n - 1 : i;
    if (w == SUPERMAT_UV_WRAP_MIRROR) {
        int m = i % (2 * n);
        if (m < 0) m += 2 * n;
        return m >= n ? 2 * n - 1 - m : m;
    }
    i %= n;
    return i < 0 ? i + n : i;
}
static void supermat_uv__texel(const supermat_uv__tex *t, int x, int y, float out[3]) {
    const unsigned char *row = t->px + (size_t)y * t->stride;
    int c;
    if (t->f32) {
        float v[4];
        memcpy(v, row + (size_t)x * t->ch * 4, (size_t)t->ch * 4);
        for (c = 0; c < 3; c++) out[c] = t->ch < 3 ? v[0] : v[c];
    } else {
        const unsigned char *p = row + (size_t)x * t->ch;
        for (c = 0; c < 3; c++) out[c] = (t->ch < 3 ? p[0] : p[c]) * (1.0f / 255.0f);
    }
}
/* bilinear sample at (u, v) in glTF UV convention; returns sRGB-encoded RGB */
static void supermat_uv__sample_tex(const supermat_uv__tex *t, double u, double v, float out[3]) {
    double x, y, fx, fy;
    int x0, y0, xa, xb, ya, yb, c;
    float a[3], b[3], cc[3], d[3];
    if (!t->has) { out[0] = t->constant[0]; out[1] = t->constant[1]; out[2] = t->constant[2]; return; }
    x = supermat_uv__fold(u, t->wu) * t->w - 0.5;
    y = supermat_uv__fold(v, t->wv) * t->h - 0.5;
    x0 = (int)floor(x); y0 = (int)floor(y);
    fx = x - x0; fy = y - y0;
    xa = supermat_uv__wrap_index(x0, t->w, t->wu); xb = supermat_uv__wrap_index(x0 + 1, t->w, t->wu);
    ya = supermat_uv__wrap_index(y0, t->h, t->wv); yb = supermat_uv__wrap_index(y0 + 1, t->h, t->wv);
    supermat_uv__texel(t, xa, ya, a); supermat_uv__texel(t, xb, ya, b);
    supermat_uv__texel(t, xa, yb, cc); supermat_uv__texel(t, xb, yb, d);
    for (c = 0; c < 3; c++) {
        double top = a[c] + (b[c] - a[c]) * fx, bot = cc[c] + (d[c] - cc[c]) * fx;
        out[c] = (float)(top + (bot - top) * fy);
        if (t->f32) out[c] = supermat_uv__to_srgb(out[c]);
        if (t->use_factor) out[c] = supermat_uv__to_srgb(supermat_uv__to_linear(out[c]) * t->factor[c]);
    }
}

/* >>uv-raster */
/* Edge function of (a, b) at p, computed with the endpoints in a canonical order so that the shared
   edge of two triangles gives exactly opposite values: the watertight half of the fill rule. */
static double supermat_uv__edge(const float *a, const float *b, double px, double py) {
    double ax = a[0], ay = a[1], bx = b[0], by = b[1];
    if (ax > bx || (ax == bx && ay > by)) return -((ax - bx) * (py - by) - (ay - by) * (px - bx));
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}
/* the other half: a sample exactly on an edge belongs to the triangle for which the edge runs "down"
   (or "left" when horizontal); of two triangles sharing the edge exactly one has it that way */
static int supermat_uv__owns(const float *a, const float *b) {
    double dx = (double)b[0] - a[0], dy = (double)b[1] - a[1];
    return dy > 0.0 || (dy == 0.0 && dx < 0.0);
}
/* inside test of sample (px, py) for a positively oriented triangle; fills the 3 edge values */
static int supermat_uv__inside(const float *v0, const float *v1, const float *v2, double px, double py, double e[3]) {
    e[0] = supermat_uv__edge(v1, v2, px, py);
    if (e[0] < 0.0 || (e[0] == 0.0 && !supermat_uv__owns(v1, v2))) return 0;
    e[1] = supermat_uv__edge(v2, v0, px, py);
    if (e[1] < 0.0 || (e[1] == 0.0 && !supermat_uv__owns(v2, v0))) return 0;
    e[2] = supermat_uv__edge(v0, v1, px, py);
    if (e[2] < 0.0 || (e[2] == 0.0 && !supermat_uv__owns(v0, v1))) return 0;
    return e[0] + e[1] + e[2] > 0.0;
}
/* orients (v0, v1, v2) positively (swapping v1 and v2); returns 0 for a zero-area triangle */
static int supermat_uv__orient(const float **v0, const float **v1, const float **v2) {
    double a = supermat_uv__edge(*v0, *v1, (*v2)[0], (*v2)[1]);
    if (a == 0.0 || a != a) return 0;
    if (a < 0.0) { const float *t = *v1; *v1 = *v2; *v2 = t; }
    return 1;
}

/* z-buffered rasterisation into the rows [row_lo, row_hi) of a w-wide sample grid (sample (i, j) at
   (i + .5, j + .5)): the nearest surface wins, ties go to the first triangle drawn */
static void supermat_uv__raster(const float *v0, const float *v1, const float *v2, int w, int row_lo, int row_hi,
                                float *depth, uint32_t *ids, uint32_t id) {
    double mnx, mxx, mny, mxy, e[3];
    int i0, i1, j0, j1, i, j;
    if (!supermat_uv__orient(&v0, &v1, &v2)) return;
    mnx = v0[0] < v1[0] ? v0[0] : v1[0]; mnx = v2[0] < mnx ? v2[0] : mnx;
    mxx = v0[0] > v1[0] ? v0[0] : v1[0]; mxx = v2[0] > mxx ? v2[0] : mxx;
    mny = v0[1] < v1[1] ? v0[1] : v1[1]; mny = v2[1] < mny ? v2[1] : mny;
    mxy = v0[1] > v1[1] ? v0[1] : v1[1]; mxy = v2[1] > mxy ? v2[1] : mxy;
    mnx = ceil(mnx - 0.5); mxx = floor(mxx - 0.5); mny = ceil(mny - 0.5); mxy = floor(mxy - 0.5);
    if (mnx < 0) mnx = 0;
    if (mny < row_lo) mny = row_lo;
    if (mxx > w - 1) mxx = w - 1;
    if (mxy > row_hi - 1) mxy = row_hi - 1;
    if (mnx > mxx || mny > mxy) return;
    i0 = (int)mnx; i1 = (int)mxx; j0 = (int)mny; j1 = (int)mxy;
    for (j = j0; j <= j1; j++) {
        double py = j + 0.5;
        for (i = i0; i <= i1; i++) {
            double z;
            size_t k;
            if (!supermat_uv__inside(v0, v1, v2, i + 0.5, py, e)) continue;
            z = (e[0] * v0[2] + e[1] * v1[2] + e[2] * v2[2]) / (e[0] + e[1] + e[2]);
            k = (size_t)j * w + i;
            if ((float)z < depth[k]) { depth[k] = (float)z; if (ids) ids[k] = id; }
        }
    }
}

/* >>uv-views */
static void supermat_uv__project(const supermat_uv__ctx *C, const supermat_uv__view *V, const double q[3], double *fx,
                                 double *fy, double *d) {
    double r[3], xc, yc;
    r[0] = q[0] - V->T[0]; r[1] = q[1] - V->T[1]; r[2] = q[2] - V->T[2];
    xc = V->X[0] * r[0] + V->X[1] * r[1] + V->X[2] * r[2];
    yc = V->Y[0] * r[0] + V->Y[1] * r[1] + V->Y[2] * r[2];
    *d = -(V->Z[0] * r[0] + V->Z[1] * r[1] + V->Z[2] * r[2]);
    *fx = (xc / C->hw + 1.0) * 0.5 * C->W;
    *fy = (1.0 - yc / C->hw) * 0.5 * C->H;
}

/* one band of pixel rows of view C->cur_view: the depth at pixel centres (visibility), then the colour
   at S x S samples per pixel (a visibility buffer and a resolve); bands write disjoint rows */
static void supermat_uv__render_band(void *user, int band, int thread) {
    supermat_uv__ctx *C = (supermat_uv__ctx *)user;
    supermat_uv__view *V = &C->view[C->cur_view];
    int W = C->W, H = C->H, S = C->S, WS = W * S, x, y, sx, sy;
    int y0 = band * SUPERMAT_UV__BAND, y1 = y0 + SUPERMAT_UV__BAND > H ? H : y0 + SUPERMAT_UV__BAND;
    const float *proj = C->proj, *projs = C->projs;
    float *sd = C->sdepth;
    uint32_t *sid = C->sid, *cid = C->cid, t;
    size_t k, n;
    double jump = 4.0 * C->d.depth_tolerance * C->ps;
    (void)thread;
    for (k = (size_t)y0 * W, n = (size_t)y1 * W; k < n; k++) { V->depth[k] = HUGE_VALF; cid[k] = SUPERMAT_UV__NONE; }
    for (t = 0; t < C->nt; t++)
        supermat_uv__raster(proj + 3 * C->tri[3 * t], proj + 3 * C->tri[3 * t + 1], proj + 3 * C->tri[3 * t + 2], W, y0, y1,
                            V->depth, cid, t);
    for (k = (size_t)y0 * S * WS, n = (size_t)y1 * S * WS; k < n; k++) { sd[k] = HUGE_VALF; sid[k] = SUPERMAT_UV__NONE; }
    for (t = 0; t < C->nt; t++)
        supermat_uv__raster(projs + 3 * C->tri[3 * t], projs + 3 * C->tri[3 * t + 1], projs + 3 * C->tri[3 * t + 2], WS,
                            y0 * S, y1 * S, sd, sid, t);
    for (y = y0; y < y1; y++)
        for (x = 0; x < W; x++) {
            double acc[3] = {0, 0, 0};
            int cnt = 0, mixed = 0;
            uint32_t tc = cid[(size_t)y * W + x];
            float *o = V->rgba + ((size_t)y * W + x) * 4;
            for (sy = 0; sy < S; sy++)
                for (sx = 0; sx < S; sx++) {
                    size_t ks = (size_t)(y * S + sy) * WS + (size_t)x * S + sx;
                    uint32_t id = sid[ks];
                    const float *p0, *p1, *p2;
                    const uint32_t *tv;
                    double e[3], px = x * S + sx + 0.5, py = y * S + sy + 0.5, u, vv, sum;
                    float col[3];
                    int j0 = 0, j1 = 1, j2 = 2;
                    if (id == SUPERMAT_UV__NONE) continue;
                    if (tc != SUPERMAT_UV__NONE && id != tc && !mixed) { /* off the centre triangle's plane? */
                        const float *c0 = projs + 3 * C->tri[3 * (size_t)tc], *c1 = projs + 3 * C->tri[3 * (size_t)tc + 1],
                                    *c2 = projs + 3 * C->tri[3 * (size_t)tc + 2];
                        double f0 = supermat_uv__edge(c1, c2, px, py), f1 = supermat_uv__edge(c2, c0, px, py),
                               f2 = supermat_uv__edge(c0, c1, px, py), fs = f0 + f1 + f2;
                        if (fs != 0.0 && fabs(sd[ks] - (f0 * c0[2] + f1 * c1[2] + f2 * c2[2]) / fs) > jump) mixed = 1;
                    }
                    tv = C->tri + 3 * (size_t)id;
                    p0 = projs + 3 * tv[0]; p1 = projs + 3 * tv[1]; p2 = projs + 3 * tv[2];
                    if (supermat_uv__edge(p0, p1, p2[0], p2[1]) < 0.0) { const float *tp = p1; p1 = p2; p2 = tp; j1 = 2; j2 = 1; }
                    e[0] = supermat_uv__edge(p1, p2, px, py);
                    e[1] = supermat_uv__edge(p2, p0, px, py);
                    e[2] = supermat_uv__edge(p0, p1, px, py);
                    sum = e[0] + e[1] + e[2];
                    if (!(sum > 0.0)) { e[0] = e[1] = e[2] = 1.0; sum = 3.0; }
                    u = (e[0] * C->vuv[2 * tv[j0]] + e[1] * C->vuv[2 * tv[j1]] + e[2] * C->vuv[2 * tv[j2]]) / sum;
                    vv = (e[0] * C->vuv[2 * tv[j0] + 1] + e[1] * C->vuv[2 * tv[j1] + 1] + e[2] * C->vuv[2 * tv[j2] + 1]) / sum;
                    supermat_uv__sample_tex(&C->tex[C->tri_part[id]], u, vv, col);
                    acc[0] += col[0]; acc[1] += col[1]; acc[2] += col[2];
                    cnt++;
                }
            V->mixed[(size_t)y * W + x] = (unsigned char)mixed;
            if (cnt) {
                o[0] = (float)(acc[0] / cnt); o[1] = (float)(acc[1] / cnt); o[2] = (float)(acc[2] / cnt);
                o[3] = (float)cnt / (float)(S * S);
            } else {
                o[0] = o[1] = o[2] = 0.5f; o[3] = 0.0f;
            }
        }
}

static void supermat_uv__render(supermat_uv__ctx *C, int v) {
    uint32_t i;
    for (i = 0; i < C->nv; i++) {
        double q[3], fx, fy, d;
        q[0] = C->vq[3 * i]; q[1] = C->vq[3 * i + 1]; q[2] = C->vq[3 * i + 2];
        supermat_uv__project(C, &C->view[v], q, &fx, &fy, &d);
        C->proj[3 * i] = (float)fx; C->proj[3 * i + 1] = (float)fy; C->proj[3 * i + 2] = (float)d;
        C->projs[3 * i] = (float)fx * (float)C->S; C->projs[3 * i + 1] = (float)fy * (float)C->S; C->projs[3 * i + 2] = (float)d;
    }
    C->cur_view = v;
    supermat_uv__parallel(C, (C->H + SUPERMAT_UV__BAND - 1) / SUPERMAT_UV__BAND, supermat_uv__render_band, C);
}

/* pixels closer than n pixels to a silhouette or a depth discontinuity */
static void supermat_uv__edges(supermat_uv__ctx *C, supermat_uv__view *V, int n) {
    int W = C->W, H = C->H, x, y, k, dx, dy;
    double jump = 4.0 * C->d.depth_tolerance * C->ps;
    unsigned char *e = V->edge;
    for (y = 0; y < H; y++)
        for (x = 0; x < W; x++) {
            float z = V->depth[(size_t)y * W + x];
            int edge = 0;
            if (!(z < HUGE_VALF)) continue;
            for (k = 0; k < 4 && !edge; k++) {
                int nx = x + (k == 0) - (k == 1), ny = y + (k == 2) - (k == 3);
                float zn;
                if (nx < 0 || ny < 0 || nx >= W || ny >= H) { edge = 1; break; }
                zn = V->depth[(size_t)ny * W + nx];
                if (!(zn < HUGE_VALF) || fabs((double)zn - z) > jump) edge = 1;
            }
            e[(size_t)y * W + x] = (unsigned char)edge;
        }
    for (k = 1; k < n; k++) { /* grow by one pixel (Chebyshev) per pass: mark 2 = new */
        for (y = 0; y < H; y++)
            for (x = 0; x < W; x++) {
                if (e[(size_t)y * W + x]) continue;
                for (dy = -1; dy <= 1; dy++)
                    for (dx = -1; dx <= 1; dx++) {
                        int nx = x + dx, ny = y + dy;
                        if (nx >= 0 && ny >= 0 && nx < W && ny < H && e[(size_t)ny * W + nx] == 1) e[(size_t)y * W + x] = 2;
                    }
            }
        for (y = 0; y < W * H; y++) if (e[y]) e[y] = 1;
    }
}

/* >>uv-backproject */
typedef struct supermat_uv__bp {
    supermat_uv__ctx *C;
    int out, tw, th;
    const uint32_t *list; /* triangles of this output */
    uint32_t count;
    double min_cos;
    /* per texel */
    float *acc;           /* tw x th x 6: albedo RGB, roughness, metallic, weight */
    unsigned char *seen;  /* view bits */
    unsigned char *layers;/* covering triangles (saturating) */
    float *pos;           /* tw x th x 3 */
    float *lit;           /* tw x th x 3: the input colour at chart texels (detail_sigma > 0), else NULL */
} supermat_uv__bp;

static void supermat_uv__gather(const supermat_uv__bp *B, const double q[3], const double nrm[3], const double *cosg,
                                const double *gx, const double *gy, size_t texel) {
    const supermat_uv__ctx *C = B->C;
    int v, k;
    float *acc = B->acc + texel * 6;
    double tol0 = C->d.depth_tolerance * C->ps;
    for (v = 0; v < SUPERMAT_UV_VIEWS; v++) {
        const supermat_uv__view *V = &C->view[v];
        double fx, fy, d, X, Y, a, b, wsum = 0, s[5] = {0, 0, 0, 0, 0}, tol, M;
        int i0, j0;
        if ((nrm ? cosg[v] : fabs(cosg[v])) < B->min_cos) continue;
        supermat_uv__project(C, V, q, &fx, &fy, &d);
        X = fx - 0.5; Y = fy - 0.5;
        if (!(X > -1.0 && Y > -1.0 && X < C->W && Y < C->H)) continue;
        i0 = (int)floor(X); j0 = (int)floor(Y);
        a = X - i0; b = Y - j0;
        tol = sqrt(gx[v] * gx[v] + gy[v] * gy[v]);
        tol = tol0 + (tol < SUPERMAT_UV__SLOPE_CAP * C->ps ? tol : SUPERMAT_UV__SLOPE_CAP * C->ps);
        for (k = 0; k < 4; k++) {
            int i = i0 + (k & 1), j = j0 + (k >> 1);
            double w = ((k & 1) ? a : 1.0 - a) * ((k >> 1) ? b : 1.0 - b), z, e;
            size_t p;
            if (w <= 0.0 || i < 0 || j < 0 || i >= C->W || j >= C->H) continue;
            p = (size_t)j * C->W + i;
            z = V->depth[p];
            if (!(z < HUGE_VALF)) continue;
            if ((V->edge && V->edge[p]) || (!C->d.keep_mixed && V->mixed[p])) continue;
            e = d + gx[v] * (i + 0.5 - fx) + gy[v] * (j + 0.5 - fy);
            if (fabs(z - e) > tol) continue;
            wsum += w;
            s[0] += w * V->albedo[p * 3]; s[1] += w * V->albedo[p * 3 + 1]; s[2] += w * V->albedo[p * 3 + 2];
            s[3] += w * V->rm[p * 3 + 1]; s[4] += w * V->rm[p * 3 + 2];
        }
        if (!(wsum > 0.0)) continue;
        if (C->d.weight == SUPERMAT_UV_WEIGHT_COS_POWER) {
            double c = nrm ? nrm[0] * V->Z[0] + nrm[1] * V->Z[1] + nrm[2] * V->Z[2] : fabs(cosg[v]);
            if (c < 0.0) c = 0.0;
            M = pow(c, C->d.cos_power);
            if (M < 1e-30) M = 1e-30; /* a large power must not underflow the blend to zero (black) */
        } else M = 1.0;
        for (k = 0; k < 5; k++) acc[k] += (float)(M * s[k] / wsum);
        acc[5] += (float)M;
        B->seen[texel] |= (unsigned char)(1u << v);
    }
}

static void supermat_uv__bp_task(void *user, int band, int thread) {
    const supermat_uv__bp *B = (const supermat_uv__bp *)user;
    const supermat_uv__ctx *C = B->C;
    int lo = band * SUPERMAT_UV__BAND, hi = lo + SUPERMAT_UV__BAND, tw = B->tw, th = B->th;
    uint32_t n;
    (void)thread;
    if (hi > th) hi = th;
    for (n = 0; n < B->count; n++) {
        uint32_t t = B->list[n];
        const uint32_t *tv = C->tri + 3 * (size_t)t;
        const supermat_uv__tex *tx = &C->tex[C->tri_part[t]];
        float uv[3][2];
        const float *v0 = uv[0], *v1 = uv[1], *v2 = uv[2];
        uint32_t ix[3];
        double mnx, mxx, mny, mxy, ng[3], ea[3], eb[3], len, cosg[SUPERMAT_UV_VIEWS], gx[SUPERMAT_UV_VIEWS],
            gy[SUPERMAT_UV_VIEWS];
        long long i, j;
        int k, v, first = 1, has_n = C->part_has_n[C->tri_part[t]];
        for (k = 0; k < 3; k++) {
            uv[k][0] = C->vuv[2 * tv[k]] * (float)tw;
            uv[k][1] = C->vuv[2 * tv[k] + 1] * (float)th;
        }
        if (!supermat_uv__orient(&v0, &v1, &v2)) continue;
        ix[0] = tv[(v0 - uv[0]) / 2]; ix[1] = tv[(v1 - uv[0]) / 2]; ix[2] = tv[(v2 - uv[0]) / 2];
        mnx = v0[0] < v1[0] ? v0[0] : v1[0]; mnx = v2[0] < mnx ? v2[0] : mnx;
        mxx = v0[0] > v1[0] ? v0[0] : v1[0]; mxx = v2[0] > mxx ? v2[0] : mxx;
        mny = v0[1] < v1[1] ? v0[1] : v1[1]; mny = v2[1] < mny ? v2[1] : mny;
        mxy = v0[1] > v1[1] ? v0[1] : v1[1]; mxy = v2[1] > mxy ? v2[1] : mxy;
        mnx = ceil(mnx - 0.5); mxx = floor(mxx - 0.5); mny = ceil(mny - 0.5); mxy = floor(mxy - 0.5);
        if (mnx > mxx || mny > mxy) continue;
        for (j = (long long)mny; j <= (long long)mxy; j++) {
            int jw;
            if (tx->wv == SUPERMAT_UV_WRAP_CLAMP) { if (j < 0 || j >= th) continue; jw = (int)j; }
            else jw = supermat_uv__wrap_index((int)(j % (2LL * th)), th, tx->wv);
            if (jw < lo || jw >= hi) continue;
            for (i = (long long)mnx; i <= (long long)mxx; i++) {
                double e[3], sum, b0, b1, b2, q[3], nn[3];
                int iw;
                size_t texel;
                if (tx->wu == SUPERMAT_UV_WRAP_CLAMP) { if (i < 0 || i >= tw) continue; iw = (int)i; }
                else iw = supermat_uv__wrap_index((int)(i % (2LL * tw)), tw, tx->wu);
                if (!supermat_uv__inside(v0, v1, v2, i + 0.5, j + 0.5, e)) continue;
                if (first) { /* geometric normal, per-view cosine and depth slope (pixels) */
                    const float *a = C->vq + 3 * ix[0], *b = C->vq + 3 * ix[1], *c = C->vq + 3 * ix[2];
                    first = 0;
                    for (k = 0; k < 3; k++) { ea[k] = (double)b[k] - a[k]; eb[k] = (double)c[k] - a[k]; }
                    ng[0] = ea[1] * eb[2] - ea[2] * eb[1]; ng[1] = ea[2] * eb[0] - ea[0] * eb[2]; ng[2] = ea[0] * eb[1] - ea[1] * eb[0];
                    len = sqrt(ng[0] * ng[0] + ng[1] * ng[1] + ng[2] * ng[2]);
                    if (len > 0) { ng[0] /= len; ng[1] /= len; ng[2] /= len; }
                    if (has_n) { /* one-sided: the normal points to the side the vertex normals say */
                        double dot = 0;
                        for (k = 0; k < 3; k++)
                            dot += ng[k] * ((double)C->vn[3 * ix[0] + k] + C->vn[3 * ix[1] + k] + C->vn[3 * ix[2] + k]);
                        if (dot < 0) { ng[0] = -ng[0]; ng[1] = -ng[1]; ng[2] = -ng[2]; }
                    }
                    for (v = 0; v < SUPERMAT_UV_VIEWS; v++) {
                        const supermat_uv__view *V = &C->view[v];
                        double nx = ng[0] * V->X[0] + ng[1] * V->X[1] + ng[2] * V->X[2];
                        double ny = ng[0] * V->Y[0] + ng[1] * V->Y[1] + ng[2] * V->Y[2];
                        double nz = ng[0] * V->Z[0] + ng[1] * V->Z[1] + ng[2] * V->Z[2];
                        cosg[v] = nz;
                        if (fabs(nz) < 1e-12) nz = nz < 0 ? -1e-12 : 1e-12;
                        gx[v] = nx / nz * C->ps;
                        gy[v] = -ny / nz * C->ps;
                    }
                }
                sum = e[0] + e[1] + e[2];
                b0 = e[0] / sum; b1 = e[1] / sum; b2 = e[2] / sum;
                for (k = 0; k < 3; k++)
                    q[k] = b0 * C->vq[3 * ix[0] + k] + b1 * C->vq[3 * ix[1] + k] + b2 * C->vq[3 * ix[2] + k];
                if (has_n) {
                    double l;
                    for (k = 0; k < 3; k++)
                        nn[k] = b0 * C->vn[3 * ix[0] + k] + b1 * C->vn[3 * ix[1] + k] + b2 * C->vn[3 * ix[2] + k];
                    l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
                    if (l > 0) { nn[0] /= l; nn[1] /= l; nn[2] /= l; }
                }
                texel = (size_t)jw * tw + iw;
                if (B->layers[texel] == 0) {
                    float *P = B->pos + texel * 3;
                    for (k = 0; k < 3; k++) {
                        double p = b0 * C->vp[3 * ix[0] + k] + b1 * C->vp[3 * ix[1] + k] + b2 * C->vp[3 * ix[2] + k];
                        p = (p + 1.0) * 0.5;
                        P[k] = (float)(p < 0.0 ? 0.0 : p > 1.0 ? 1.0 : p);
                    }
                    if (B->lit) supermat_uv__sample_tex(tx, (i + 0.5) / tw, (j + 0.5) / th, B->lit + texel * 3);
                }
                if (B->layers[texel] < 255) B->layers[texel]++;
                supermat_uv__gather(B, q, has_n ? nn : NULL, cosg, gx, gy, texel);
            }
        }
    }
}

/* >>uv-post */
/* DETAIL: supermat.h's detail step (supermat_detail, the code a run's detail_sigma runs) on the texture:
   the picture is the input colour at the chart texels (`lit`, sRGB-encoded), the weight `valid` (255 where
   A holds a value, else 0), the region the chart texels (`layers`): albedo = L x clamp(G(w A) / G(w L), 1/4, 4)
   at every chart texel (in place, sRGB-encoded in and out). In the measure pass only the scratch is planned:
   `tmp` (tmp_bytes, free at this point) when it is large enough, else a block of its own. */
static supermat_result supermat_uv__detail(supermat_uv__ctx *C, int tw, int th, const unsigned char *layers, const unsigned char *valid,
                                           const float *lit, float *albedo, void *tmp, size_t tmp_bytes) {
    supermat_detail_desc dd;
    supermat_result r;
    size_t need = 0;
    memset(&dd, 0, sizeof dd);
    dd.sigma = C->d.detail_sigma;
    dd.limit = C->d.detail_limit;
    dd.picture.pixels = (void *)lit; dd.picture.width = tw; dd.picture.height = th; dd.picture.channels = 3; dd.picture.format = SUPERMAT_FORMAT_F32;
    dd.albedo.pixels = albedo; dd.albedo.channels = 3; dd.albedo.format = SUPERMAT_FORMAT_F32;
    dd.weight.pixels = (void *)valid; dd.weight.width = tw; dd.weight.height = th; dd.weight.channels = 1;
    dd.region.pixels = (void *)layers; dd.region.width = tw; dd.region.height = th; dd.region.channels = 1;
    dd.threading = C->thr;
    dd.allocator = C->al;
    if ((r = supermat_detail_memory(&dd, &need, C->err))) return r;
    if (need > tmp_bytes) {
        SUPERMAT_UV__ALLOC(C, tmp, unsigned char, need);
        tmp_bytes = need;
    }
    if (C->measure) return SUPERMAT_SUCCESS;
    dd.scratch = tmp; dd.scratch_size = tmp_bytes;
    return supermat_detail(&dd, C->err);
}

/* Fills texels where valid == 0 with the value of a nearest valid texel: a breadth-first search over
   8-neighbours (so ring k is at Chebyshev distance k) from the valid texels in index order, neighbours
   in a fixed order, wrapping around the texture edges, up to n rings (n < 0: until full); what is
   left gets the mean of the valid texels (or `fallback` when there is none). Deterministic. */
static void supermat_uv__dilate(int w, int h, int n, const unsigned char *valid, int32_t *src, int32_t *queue, uint16_t *gen,
                                float *val, int ch, const float *fallback) {
    static const int ox[8] = {-1, 1, 0, 0, -1, 1, -1, 1}, oy[8] = {0, 0, -1, 1, -1, -1, 1, 1};
    size_t N = (size_t)w * h, i, head = 0, tail = 0;
    double mean[4] = {0, 0, 0, 0};
    size_t nvalid = 0;
    int c;
    for (i = 0; i < N; i++) {
        src[i] = -1;
        gen[i] = 0;
        if (valid[i]) {
            src[i] = (int32_t)i;
            queue[tail++] = (int32_t)i;
            nvalid++;
            for (c = 0; c < ch; c++) mean[c] += val[i * ch + c];
        }
    }
    while (head < tail) {
        int32_t t = queue[head++];
        int x = (int)(t % w), y = (int)(t / w), k;
        if (n >= 0 && gen[t] >= n) continue;
        for (k = 0; k < 8; k++) {
            int nx = x + ox[k], ny = y + oy[k];
            size_t u;
            nx = nx < 0 ? nx + w : nx >= w ? nx - w : nx;
            ny = ny < 0 ? ny + h : ny >= h ? ny - h : ny;
            u = (size_t)ny * w + nx;
            if (src[u] >= 0) continue;
            src[u] = src[t];
            gen[u] = (uint16_t)(gen[t] < 65535 ? gen[t] + 1 : 65535);
            queue[tail++] = (int32_t)u;
        }
    }
    for (c = 0; c < ch; c++) mean[c] = nvalid ? mean[c] / (double)nvalid : fallback[c];
    for (i = 0; i < N; i++) {
        if (valid[i]) continue;
        for (c = 0; c < ch; c++) val[i * ch + c] = src[i] >= 0 ? val[(size_t)src[i] * ch + c] : (float)mean[c];
    }
}

static void supermat_uv__write(const supermat_image *o, int w, int h, const float *val, int kind) {
    size_t es = o->format == SUPERMAT_FORMAT_F32 ? 4 : 1, stride = o->stride ? o->stride : (size_t)w * o->channels * es;
    int x, y, c;
    for (y = 0; y < h; y++) {
        unsigned char *row = (unsigned char *)o->pixels + (size_t)y * stride;
        for (x = 0; x < w; x++) {
            const float *p = val + ((size_t)y * w + x) * (kind == 0 ? 3 : 2);
            for (c = 0; c < o->channels; c++) {
                float v;
                if (c == 3) v = 1.0f;
                else if (kind == 0) v = p[c]; /* sRGB-encoded albedo */
                else v = c == 0 ? 1.0f : p[c - 1];
                v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
                if (o->format == SUPERMAT_FORMAT_F32) {
                    if (kind == 0 && c < 3) v = supermat_uv__to_linear(v);
                    memcpy(row + ((size_t)x * o->channels + c) * 4, &v, 4);
                } else row[(size_t)x * o->channels + c] = (unsigned char)(v * 255.0f + 0.5f);
            }
        }
    }
}

/* >>uv-validate */
static const float *supermat_uv__at(const float *base, size_t stride, size_t dflt, uint32_t i) {
    return (const float *)((const unsigned char *)base + (size_t)i * (stride ? stride : dflt));
}
static uint32_t supermat_uv__index(const supermat_uv_part *P, uint32_t k) {
    if (!P->indices) return k;
    return *(const uint32_t *)((const unsigned char *)P->indices + (size_t)k * (P->index_stride ? P->index_stride : 4));
}
static uint32_t supermat_uv__index_count(const supermat_uv_part *P) {
    return P->indices ? P->index_count : (P->index_count ? P->index_count : P->vertex_count);
}

static supermat_result supermat_uv__check_image(supermat_error *err, const supermat_image *im, const char *what, int part,
                                                int w, int h, int input) {
    size_t es;
    if ((unsigned)im->format >= SUPERMAT_FORMAT_COUNT)
        return supermat_uv__fail(err, SUPERMAT_ERROR_BAD_IMAGE, "%s %d: unknown pixel format %d", what, part, (int)im->format);
    es = im->format == SUPERMAT_FORMAT_F32 ? 4 : 1;
    if (input) {
        if (im->width <= 0 || im->height <= 0 || im->channels < 1 || im->channels > 4)
            return supermat_uv__fail(err, SUPERMAT_ERROR_BAD_IMAGE, "%s %d: bad size %dx%d or channel count %d (1 to 4)", what, part, im->width, im->height, im->channels);
        w = im->width;
    } else {
        if ((im->width && im->width != w) || (im->height && im->height != h))
            return supermat_uv__fail(err, SUPERMAT_ERROR_BAD_IMAGE, "%s %d is %dx%d, the texture size is %dx%d", what, part, im->width, im->height, w, h);
        if (im->channels < 3 || im->channels > 4)
            return supermat_uv__fail(err, SUPERMAT_ERROR_BAD_IMAGE, "%s %d has %d channels (3 or 4)", what, part, im->channels);
    }
    if (input) h = im->height;
    if ((size_t)w > (size_t)PTRDIFF_MAX / 16 || /* rows x stride past 2^63 (2^31 where size_t has 32 bits) */
        (im->stride ? im->stride : (size_t)w * im->channels * es) > (size_t)PTRDIFF_MAX / (size_t)(h > 0 ? h : 1))
        return supermat_uv__fail(err, SUPERMAT_ERROR_BAD_IMAGE, "%s %d: %dx%d (stride %llu) is larger than the address space", what, part,
                                 w, h, (unsigned long long)im->stride);
    if (im->stride && im->stride < (size_t)w * im->channels * es)
        return supermat_uv__fail(err, SUPERMAT_ERROR_BAD_IMAGE, "%s %d: stride %llu is smaller than a row", what, part, (unsigned long long)im->stride);
    return SUPERMAT_SUCCESS;
}

/* defaults and every check that does not read the mesh arrays */
static supermat_result supermat_uv__resolve(const supermat_uv_bake_desc *in, supermat_uv_bake_desc *d, supermat_error *err) {
    int i;
    if (!in) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "the bake desc is NULL");
    if (in->_start_canary || in->_end_canary)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "supermat_uv_bake_desc: _start_canary / _end_canary are 0x%x / 0x%x, not 0: "
                                 "clear the struct (memset to 0, or = {0}) before setting its fields", (unsigned)in->_start_canary, (unsigned)in->_end_canary);
    *d = *in;
    if (!d->output_count) d->output_count = 1;
    if (!d->texture_width) d->texture_width = 1024;
    if (!d->texture_height) d->texture_height = 1024;
    if (!d->view_size) d->view_size = 512;
    if (!d->supersample) d->supersample = 4;
    if (d->ortho_half_width == 0.0f) d->ortho_half_width = 1.1f;
    if (d->cos_power == 0.0f) d->cos_power = 2.0f;
    if (d->depth_tolerance == 0.0f) d->depth_tolerance = 2.0f;
    if (!d->gutter) d->gutter = 16;
    if (!d->parts || d->part_count <= 0)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "the mesh has no parts (parts NULL or part_count %d)", d->part_count);
    if (d->output_count < 0 || d->output_count > 256)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "output_count %d is out of range", d->output_count);
    if (d->texture_width < 8 || d->texture_height < 8 || d->texture_width % 8 || d->texture_height % 8 ||
        d->texture_width > 16384 || d->texture_height > 16384)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "texture size %dx%d: multiples of 8 from 8 to 16384", d->texture_width, d->texture_height);
    if (d->view_size < 8 || d->view_size % 8 || d->view_size > 8192)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "view size %d: a multiple of 8 from 8 to 8192", d->view_size);
    if (d->view_work_size < SUPERMAT_WORK_NATIVE || (d->view_work_size > 0 && d->view_work_size % 8) || d->view_work_size > 16384 ||
        d->refine_work_size < SUPERMAT_WORK_NATIVE || (d->refine_work_size > 0 && d->refine_work_size % 8) || d->refine_work_size > 16384)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "view_work_size %d / refine_work_size %d: 0 (the model's), SUPERMAT_WORK_NATIVE or a multiple of 8 up to 16384",
                                 d->view_work_size, d->refine_work_size);
    if (d->supersample < 1 || d->supersample > 8 || (long)d->view_size * d->supersample > 16384)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "supersample %d: 1 to 8 (and view size x supersample <= 16384)", d->supersample);
    if (!(d->ortho_half_width > 0.0f && d->ortho_half_width < 1e6f))
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "ortho_half_width %g must be positive", (double)d->ortho_half_width);
    if ((unsigned)d->weight >= SUPERMAT_UV_WEIGHT_COUNT || !(d->cos_power > 0.0f && d->cos_power < 1e3f))
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "bad weight mode %d or cos_power %g", (int)d->weight, (double)d->cos_power);
    if ((unsigned)d->position_frame >= SUPERMAT_UV_POSITION_COUNT)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "bad position frame %d", (int)d->position_frame);
    if (!(d->max_angle_deg >= 0.0f && d->max_angle_deg <= 90.0f) || !(d->depth_tolerance > 0.0f && d->depth_tolerance < 1e6f) ||
        d->edge_reject < 0 || d->edge_reject > 64)
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "bad max_angle_deg %g, depth_tolerance %g or edge_reject %d",
                                 (double)d->max_angle_deg, (double)d->depth_tolerance, d->edge_reject);
    if (d->threads < 0) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "threads %d < 0", d->threads);
    if (!(d->detail_sigma <= 1.0f)) /* NaN too */
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "detail_sigma %g: at most 1 (0 = the view model's, SUPERMAT_OFF = off)", (double)d->detail_sigma);
    if (!(d->detail_limit <= 0.0f || (d->detail_limit > 1.0f && d->detail_limit <= 1e6f))) /* NaN too */
        return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "detail_limit %g: above 1, at most 1e6 (0 = %g, SUPERMAT_OFF = unbounded)",
                                 (double)d->detail_limit, (double)SUPERMAT_UV_DETAIL_LIMIT);
    if (d->detail_limit == 0.0f) d->detail_limit = SUPERMAT_UV_DETAIL_LIMIT;
    if (d->detail_limit < 0.0f) d->detail_limit = 0.0f; /* SUPERMAT_OFF: supermat_detail's run form */
    if (!d->passthrough) {
        supermat_model_info info;
        if (!d->mv_model) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "mv_model is NULL (give a SuperMatMV model, or set passthrough)");
        supermat_model_get_info(d->mv_model, &info);
        if (info.kind != SUPERMAT_KIND_SUPERMAT_MV && info.kind != SUPERMAT_KIND_SUPERMAT)
            return supermat_uv__fail(err, SUPERMAT_ERROR_UNSUPPORTED, "mv_model is neither a supermat-mv nor a single-view supermat model");
        if (d->detail_sigma == 0.0f) d->detail_sigma = info.bake_detail_sigma; /* the view model's recorded step */
        if (d->albedo_refine_model) {
            supermat_model_get_info(d->albedo_refine_model, &info);
            if (info.kind != SUPERMAT_KIND_UV_REFINE) return supermat_uv__fail(err, SUPERMAT_ERROR_UNSUPPORTED, "albedo_refine_model is not a uv-refine model");
        }
        if (d->rm_refine_model) {
            supermat_model_get_info(d->rm_refine_model, &info);
            if (info.kind != SUPERMAT_KIND_UV_REFINE) return supermat_uv__fail(err, SUPERMAT_ERROR_UNSUPPORTED, "rm_refine_model is not a uv-refine model");
        }
    } else {
        d->mv_model = NULL; d->albedo_refine_model = NULL; d->rm_refine_model = NULL;
    }
    if (d->detail_sigma < 0.0f) d->detail_sigma = 0.0f; /* SUPERMAT_OFF */
    for (i = 0; i < d->part_count; i++) {
        const supermat_uv_part *P = &d->parts[i];
        uint32_t ni = supermat_uv__index_count(P);
        supermat_result r;
        if (P->_start_canary || P->_end_canary)
            return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d (supermat_uv_part): _start_canary / _end_canary are 0x%x / 0x%x, not 0: "
                                     "clear the struct (memset to 0, or = {0}) before setting its fields", i, (unsigned)P->_start_canary, (unsigned)P->_end_canary);
        if (!P->positions) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d has no positions", i);
        if (!P->uvs) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d has no UVs: the mesh needs texture coordinates (unwrap it first)", i);
        if ((P->position_stride && P->position_stride < 12) || (P->uv_stride && P->uv_stride < 8) ||
            (P->normal_stride && P->normal_stride < 12) || (P->index_stride && P->index_stride < 4))
            return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d: a stride is smaller than its element", i);
        if (ni % 3) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d: %u indices is not a whole number of triangles", i, ni);
        if (P->output < 0 || P->output >= d->output_count)
            return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d addresses output %d (output_count %d)", i, P->output, d->output_count);
        if ((unsigned)P->wrap_u >= SUPERMAT_UV_WRAP_COUNT || (unsigned)P->wrap_v >= SUPERMAT_UV_WRAP_COUNT)
            return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d: bad wrap mode", i);
        if (P->base_color.pixels) {
            r = supermat_uv__check_image(err, &P->base_color, "the base colour texture of part", i, 0, 0, 1);
            if (r) return r;
        }
    }
    return SUPERMAT_SUCCESS;
}

static supermat_result supermat_uv__check_outputs(const supermat_uv_bake_desc *d, const supermat_uv_output *outputs,
                                                  supermat_error *err) {
    int o;
    if (!outputs) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "outputs is NULL");
    for (o = 0; o < d->output_count; o++) {
        supermat_result r = SUPERMAT_SUCCESS;
        if (outputs[o].base_color.pixels)
            r = supermat_uv__check_image(err, &outputs[o].base_color, "base colour output", o, d->texture_width, d->texture_height, 0);
        if (!r && outputs[o].metallic_roughness.pixels)
            r = supermat_uv__check_image(err, &outputs[o].metallic_roughness, "metallic-roughness output", o, d->texture_width, d->texture_height, 0);
        if (r) return r;
    }
    return SUPERMAT_SUCCESS;
}

/* reads, validates and normalises the mesh into C (measure mode: only counts) */
static supermat_result supermat_uv__load_mesh(supermat_uv__ctx *C) {
    const supermat_uv_bake_desc *d = &C->d;
    supermat_error *err = C->err;
    uint64_t nv = 0, nt = 0;
    double mn[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, mx[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX}, amax = 0, r = 0, s;
    int i, k, any_n = 0;
    uint32_t base = 0, t = 0;
    for (i = 0; i < d->part_count; i++) {
        nv += d->parts[i].vertex_count;
        nt += supermat_uv__index_count(&d->parts[i]) / 3;
        if (d->parts[i].normals) any_n = 1;
    }
    if (nt == 0) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "the mesh has no triangles");
    if (nv >= 0xFFFFFFF0u || nt >= 0x7FFFFFF0u) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "the mesh is too large (%llu vertices, %llu triangles)", (unsigned long long)nv, (unsigned long long)nt);
    C->nv = (uint32_t)nv;
    SUPERMAT_UV__ALLOC(C, C->vq, float, (size_t)nv * 3);
    SUPERMAT_UV__ALLOC(C, C->vp, float, (size_t)nv * 3);
    SUPERMAT_UV__ALLOC(C, C->vuv, float, (size_t)nv * 2);
    if (any_n) SUPERMAT_UV__ALLOC(C, C->vn, float, (size_t)nv * 3);
    SUPERMAT_UV__ALLOC(C, C->tri, uint32_t, (size_t)nt * 3);
    SUPERMAT_UV__ALLOC(C, C->tri_part, int, (size_t)nt);
    SUPERMAT_UV__ALLOC(C, C->tex, supermat_uv__tex, (size_t)d->part_count);
    SUPERMAT_UV__ALLOC(C, C->part_has_n, unsigned char, (size_t)d->part_count);
    if (C->measure) { C->nt = (uint32_t)nt; return SUPERMAT_SUCCESS; }
    /* pass 1: indices, finiteness, bounds of the referenced vertices */
    for (i = 0; i < d->part_count; i++) {
        const supermat_uv_part *P = &d->parts[i];
        uint32_t ni = supermat_uv__index_count(P), j;
        if (!P->indices && ni > P->vertex_count)
            return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d: %u vertices, fewer than index_count %u", i, P->vertex_count, ni);
        for (j = 0; j < ni; j++) {
            uint32_t v = supermat_uv__index(P, j);
            const float *p, *uv;
            if (v >= P->vertex_count)
                return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "part %d: index %u of triangle %u is %u, out of range (vertex_count %u)", i, j, j / 3, v, P->vertex_count);
            p = supermat_uv__at(P->positions, P->position_stride, 12, v);
            uv = supermat_uv__at(P->uvs, P->uv_stride, 8, v);
            for (k = 0; k < 3; k++) {
                double x = p[k];
                if (!(x - x == 0.0)) return supermat_uv__fail(err, SUPERMAT_ERROR_NONFINITE, "part %d: the position of vertex %u is NaN or Inf", i, v);
                if (x < mn[k]) mn[k] = x;
                if (x > mx[k]) mx[k] = x;
                if (fabs(x) > amax) amax = fabs(x);
            }
            if (!((double)uv[0] - uv[0] == 0.0 && (double)uv[1] - uv[1] == 0.0))
                return supermat_uv__fail(err, SUPERMAT_ERROR_NONFINITE, "part %d: the UV of vertex %u is NaN or Inf", i, v);
            if (P->normals) {
                const float *n = supermat_uv__at(P->normals, P->normal_stride, 12, v);
                if (!((double)n[0] - n[0] == 0.0 && (double)n[1] - n[1] == 0.0 && (double)n[2] - n[2] == 0.0))
                    return supermat_uv__fail(err, SUPERMAT_ERROR_NONFINITE, "part %d: the normal of vertex %u is NaN or Inf", i, v);
            }
        }
        if (P->base_color.pixels && P->base_color.format == SUPERMAT_FORMAT_F32) {
            const supermat_image *im = &P->base_color;
            size_t stride = im->stride ? im->stride : (size_t)im->width * im->channels * 4;
            int x, y;
            for (y = 0; y < im->height; y++)
                for (x = 0; x < im->width * im->channels; x++) {
                    float f;
                    memcpy(&f, (const unsigned char *)im->pixels + (size_t)y * stride + (size_t)x * 4, 4);
                    if (!(f - f == 0.0f)) return supermat_uv__fail(err, SUPERMAT_ERROR_NONFINITE, "part %d: base colour texel (%d, %d) is NaN or Inf", i, x / im->channels, y);
                }
        }
    }
    for (k = 0; k < 3; k++) {
        double c = 0.5 * (mn[k] + mx[k]);
        C->st.view_center[k] = c;
        if (mx[k] - c > r) r = mx[k] - c;
        if (c - mn[k] > r) r = c - mn[k];
    }
    if (!(r > 0.0)) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "the mesh has no extent (every vertex at one point)");
    C->st.view_scale = s = 1.0 / r;
    if (d->position_frame == SUPERMAT_UV_POSITION_CENTERED) {
        for (k = 0; k < 3; k++) C->st.position_center[k] = C->st.view_center[k];
        C->st.position_scale = s;
    } else {
        C->st.position_scale = 1.0 / amax;
    }
    /* pass 2: the vertex arrays and the triangle list */
    for (i = 0; i < d->part_count; i++) {
        const supermat_uv_part *P = &d->parts[i];
        uint32_t ni = supermat_uv__index_count(P), j;
        supermat_uv__tex *tx = &C->tex[i];
        for (j = 0; j < P->vertex_count; j++) {
            const float *p = supermat_uv__at(P->positions, P->position_stride, 12, j);
            const float *uv = supermat_uv__at(P->uvs, P->uv_stride, 8, j);
            float *q = C->vq + 3 * (size_t)(base + j), *pp = C->vp + 3 * (size_t)(base + j);
            for (k = 0; k < 3; k++) {
                double x = p[k];
                if (!(x - x == 0.0)) x = C->st.view_center[k]; /* an unreferenced vertex */
                q[k] = (float)((x - C->st.view_center[k]) * s);
                pp[k] = (float)((x - C->st.position_center[k]) * C->st.position_scale);
            }
            C->vuv[2 * (size_t)(base + j)] = uv[0];
            C->vuv[2 * (size_t)(base + j) + 1] = d->uv_origin_bottom_left ? 1.0f - uv[1] : uv[1];
            if (P->normals) {
                const float *n = supermat_uv__at(P->normals, P->normal_stride, 12, j);
                double l = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
                for (k = 0; k < 3; k++) C->vn[3 * (size_t)(base + j) + k] = l > 0 && l == l && l < HUGE_VAL ? (float)(n[k] / l) : 0.0f;
            }
        }
        C->part_has_n[i] = P->normals != NULL;
        for (j = 0; j + 2 < ni; j += 3) {
            uint32_t a = base + supermat_uv__index(P, j), b = base + supermat_uv__index(P, j + 1), c = base + supermat_uv__index(P, j + 2);
            double e1[3], e2[3], cr[3], area2;
            for (k = 0; k < 3; k++) { e1[k] = (double)C->vq[3 * b + k] - C->vq[3 * a + k]; e2[k] = (double)C->vq[3 * c + k] - C->vq[3 * a + k]; }
            cr[0] = e1[1] * e2[2] - e1[2] * e2[1]; cr[1] = e1[2] * e2[0] - e1[0] * e2[2]; cr[2] = e1[0] * e2[1] - e1[1] * e2[0];
            area2 = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
            if (!(area2 > 2e-12)) { C->st.triangles_degenerate++; continue; }
            C->tri[3 * (size_t)t] = a; C->tri[3 * (size_t)t + 1] = b; C->tri[3 * (size_t)t + 2] = c;
            C->tri_part[t] = i;
            t++;
        }
        /* the texture */
        tx->has = P->base_color.pixels != NULL;
        if (tx->has) {
            tx->px = (const unsigned char *)P->base_color.pixels;
            tx->w = P->base_color.width; tx->h = P->base_color.height; tx->ch = P->base_color.channels;
            tx->f32 = P->base_color.format == SUPERMAT_FORMAT_F32;
            tx->stride = P->base_color.stride ? P->base_color.stride : (size_t)tx->w * tx->ch * (tx->f32 ? 4 : 1);
        }
        tx->wu = P->wrap_u; tx->wv = P->wrap_v;
        for (k = 0; k < 3; k++) {
            float f = P->base_color_factor ? P->base_color_factor[k] : 1.0f;
            if (!(f - f == 0.0f)) return supermat_uv__fail(err, SUPERMAT_ERROR_NONFINITE, "part %d: base_color_factor is NaN or Inf", i);
            tx->factor[k] = f;
            if (f != 1.0f) tx->use_factor = 1;
            tx->constant[k] = supermat_uv__to_srgb(f);
        }
        base += P->vertex_count;
    }
    C->nt = t;
    C->st.triangles = t;
    if (t == 0) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "every triangle of the mesh has zero area (%u skipped)", C->st.triangles_degenerate);
    return SUPERMAT_SUCCESS;
}

/* >>uv-networks */
static supermat_result supermat_uv__session(supermat_uv__ctx *C, const supermat_model *m, int w, int h, int views,
                                            int work, supermat_session **s) {
    supermat_session_desc sd;
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = w; sd.height = h; sd.views = views;
    /* view_work_size / refine_work_size: 0 the model's recorded size (as the session's 0), SUPERMAT_WORK_NATIVE
       or N; the bake's detail step is its own (in UV space), so the file's steps for single pictures are off */
    if (work > 0 && (work != w || work != h)) sd.work_width = sd.work_height = work;
    else if (work != 0) sd.work_width = sd.work_height = SUPERMAT_WORK_NATIVE;
    sd.detail_sigma = sd.chroma_weight = SUPERMAT_OFF;
    sd.threads = C->thr.parallel_for ? 0 : 1;
    sd.threading = C->thr;
    sd.allocator = C->al;
    if (C->measure) {
        size_t b = 0;
        supermat_result r = supermat_session_memory(&sd, &b, C->err);
        if (r) return r;
        if (C->bytes_now + b > C->bytes_peak) C->bytes_peak = C->bytes_now + b;
        *s = NULL;
        return SUPERMAT_SUCCESS;
    }
    return supermat_session_create(&sd, s, C->err);
}

static supermat_result supermat_uv__run_mv(supermat_uv__ctx *C) {
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_image in[SUPERMAT_UV_VIEWS], alb[SUPERMAT_UV_VIEWS], orm[SUPERMAT_UV_VIEWS];
    float cams[SUPERMAT_UV_VIEWS * 16];
    supermat_result r;
    int v, single;
    size_t k, n = (size_t)C->W * C->H;
    supermat_model_info info;
    memset(&info, 0, sizeof info);
    supermat_model_get_info(C->d.mv_model, &info);
    single = info.kind == SUPERMAT_KIND_SUPERMAT; /* a single-view model: view by view, no cross-view attention */
    r = supermat_uv__session(C, C->d.mv_model, C->W, C->H, single ? 1 : SUPERMAT_UV_VIEWS, C->d.view_work_size, &s);
    if (r || C->measure) return r;
    supermat_uv_cameras(cams);
    memset(&rd, 0, sizeof rd);
    for (v = 0; v < SUPERMAT_UV_VIEWS; v++) {
        memset(&in[v], 0, sizeof in[v]); memset(&alb[v], 0, sizeof alb[v]); memset(&orm[v], 0, sizeof orm[v]);
        in[v].pixels = C->view[v].rgba; in[v].width = C->W; in[v].height = C->H; in[v].channels = 4; in[v].format = SUPERMAT_FORMAT_F32;
        alb[v].pixels = C->view[v].albedo; alb[v].channels = 3; alb[v].format = SUPERMAT_FORMAT_F32;
        orm[v].pixels = C->view[v].rm; orm[v].channels = 3; orm[v].format = SUPERMAT_FORMAT_F32;
    }
    rd.progress = supermat_uv__net_progress; rd.progress_user = C;
    if (single) {
        float base = C->prog_base, span = C->prog_span;
        C->prog_span = span / SUPERMAT_UV_VIEWS;
        for (v = 0, r = SUPERMAT_SUCCESS; v < SUPERMAT_UV_VIEWS && !r; v++) {
            C->prog_base = base + span * (float)v / SUPERMAT_UV_VIEWS;
            rd.input = in[v]; rd.albedo = alb[v]; rd.orm = orm[v];
            r = supermat_run(s, &rd, C->err);
        }
        C->prog_base = base; C->prog_span = span;
    } else {
        rd.input_views = in; rd.cameras = cams; rd.albedo_views = alb; rd.orm_views = orm;
        r = supermat_run(s, &rd, C->err);
    }
    supermat_session_destroy(s);
    if (r) return C->cancelled ? supermat_uv__fail(C->err, SUPERMAT_ERROR_CANCELLED, "cancelled by the progress callback") : r;
    for (v = 0; v < SUPERMAT_UV_VIEWS; v++)
        for (k = 0; k < n; k++) C->view[v].rm[k * 3] = 0.0f; /* the RM maps' R is 0, as the UV-refine inputs */
    return SUPERMAT_SUCCESS;
}

/* runs a UV-refine model: partial (3 ch), mask, position -> out (3 ch) */
static supermat_result supermat_uv__refine(supermat_uv__ctx *C, const supermat_model *m, const float *partial,
                                           const float *mask, const float *pos, float *out) {
    supermat_session *s = NULL;
    supermat_run_desc rd;
    supermat_result r;
    int w = C->d.texture_width, h = C->d.texture_height;
    r = supermat_uv__session(C, m, w, h, 1, C->d.refine_work_size, &s);
    if (r || C->measure) return r;
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = (void *)partial; rd.input.width = w; rd.input.height = h; rd.input.channels = 3; rd.input.format = SUPERMAT_FORMAT_F32;
    rd.mask.pixels = (void *)mask; rd.mask.width = w; rd.mask.height = h; rd.mask.channels = 1; rd.mask.format = SUPERMAT_FORMAT_F32;
    rd.position.pixels = (void *)pos; rd.position.width = w; rd.position.height = h; rd.position.channels = 3; rd.position.format = SUPERMAT_FORMAT_F32;
    rd.refined.pixels = out; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
    rd.progress = supermat_uv__net_progress; rd.progress_user = C;
    r = supermat_run(s, &rd, C->err);
    supermat_session_destroy(s);
    if (r) return C->cancelled ? supermat_uv__fail(C->err, SUPERMAT_ERROR_CANCELLED, "cancelled by the progress callback") : r;
    return SUPERMAT_SUCCESS;
}

/* >>uv-bake */
#define SUPERMAT_UV__TRY(x) do { supermat_result r_ = (x); if (r_) return r_; } while (0)
#define SUPERMAT_UV__CANCEL(C, f, what) \
    do { if (supermat_uv__progress((C), (f), (what))) return supermat_uv__fail((C)->err, SUPERMAT_ERROR_CANCELLED, "cancelled by the progress callback"); } while (0)

/* one output texture: back-projection, refinement, gutter fill -> final albedo (3) and RM (2) */
static supermat_result supermat_uv__bake_output(supermat_uv__ctx *C, int o, float *final_albedo, float *final_rm) {
    const supermat_uv_bake_desc *d = &C->d;
    int tw = d->texture_width, th = d->texture_height, mark = C->nblk, refine_a, refine_rm, c;
    size_t N = (size_t)tw * th, i;
    supermat_uv__bp B;
    uint32_t t, *list, count = 0;
    float *partial_a, *partial_rm, *mask, *seenf, *chart, *refined = NULL;
    unsigned char *valid;
    int32_t *src, *queue;
    uint16_t *gen;
    float f0 = 0.5f + 0.45f * (float)o / (float)d->output_count, f1 = 0.5f + 0.45f * (float)(o + 1) / (float)d->output_count;
    static const float fallback_a[3] = {0.5f, 0.5f, 0.5f}, fallback_rm[2] = {0.5f, 0.0f};
    memset(&B, 0, sizeof B);
    B.C = C; B.out = o; B.tw = tw; B.th = th;
    B.min_cos = SUPERMAT_UV__MIN_COS;
    if (d->max_angle_deg > 0.0f) {
        double c2 = cos(d->max_angle_deg * 3.14159265358979323846 / 180.0);
        if (c2 > B.min_cos) B.min_cos = c2;
    }
    SUPERMAT_UV__ALLOC(C, list, uint32_t, C->nt ? C->nt : 1);
    SUPERMAT_UV__ALLOC(C, B.acc, float, N * 6);
    SUPERMAT_UV__ALLOC(C, B.seen, unsigned char, N);
    SUPERMAT_UV__ALLOC(C, B.layers, unsigned char, N);
    SUPERMAT_UV__ALLOC(C, B.pos, float, N * 3);
    SUPERMAT_UV__ALLOC(C, partial_a, float, N * 3);
    SUPERMAT_UV__ALLOC(C, partial_rm, float, N * 3);
    SUPERMAT_UV__ALLOC(C, mask, float, N);
    refine_a = d->albedo_refine_model != NULL;
    refine_rm = d->rm_refine_model != NULL;
    if (refine_a || refine_rm) SUPERMAT_UV__ALLOC(C, refined, float, N * 3);
    if (d->detail_sigma > 0.0f) SUPERMAT_UV__ALLOC(C, B.lit, float, N * 3);
    if (!C->measure) {
        for (t = 0; t < C->nt; t++) {
            const uint32_t *tv = C->tri + 3 * (size_t)t;
            double a, mnx, mxx, mny, mxy;
            float uv[3][2];
            int k;
            if (d->parts[C->tri_part[t]].output != o) continue;
            for (k = 0; k < 3; k++) { uv[k][0] = C->vuv[2 * tv[k]] * (float)tw; uv[k][1] = C->vuv[2 * tv[k] + 1] * (float)th; }
            a = supermat_uv__edge(uv[0], uv[1], uv[2][0], uv[2][1]);
            if (a == 0.0) { C->st.triangles_uv_degenerate++; continue; }
            mnx = uv[0][0] < uv[1][0] ? uv[0][0] : uv[1][0]; mnx = uv[2][0] < mnx ? uv[2][0] : mnx;
            mxx = uv[0][0] > uv[1][0] ? uv[0][0] : uv[1][0]; mxx = uv[2][0] > mxx ? uv[2][0] : mxx;
            mny = uv[0][1] < uv[1][1] ? uv[0][1] : uv[1][1]; mny = uv[2][1] < mny ? uv[2][1] : mny;
            mxy = uv[0][1] > uv[1][1] ? uv[0][1] : uv[1][1]; mxy = uv[2][1] > mxy ? uv[2][1] : mxy;
            if ((mxx - mnx + 1.0) * (mxy - mny + 1.0) > 4.0 * (double)N || mxx - mnx > 1e8 || mxy - mny > 1e8 ||
                fabs(mnx) > 1e9 || fabs(mxx) > 1e9 || fabs(mny) > 1e9 || fabs(mxy) > 1e9) {
                C->st.triangles_uv_too_large++;
                continue;
            }
            list[count++] = t;
        }
        B.list = list; B.count = count;
        for (i = 0; i < N; i++) B.pos[i * 3] = B.pos[i * 3 + 1] = B.pos[i * 3 + 2] = SUPERMAT_UV__OFF_CHART;
        if (B.lit) memset(B.lit, 0, N * 3 * sizeof(float));
        supermat_uv__parallel(C, (th + SUPERMAT_UV__BAND - 1) / SUPERMAT_UV__BAND, supermat_uv__bp_task, &B);
        for (i = 0; i < N; i++) {
            const float *a = B.acc + i * 6;
            int nseen = 0;
            unsigned s = B.seen[i];
            while (s) { nseen += (int)(s & 1u); s >>= 1; }
            if (B.layers[i]) C->st.texels_chart++;
            if (B.layers[i] > 1) C->st.texels_overlap++;
            if (nseen) {
                float inv = a[5] > 0.0f ? 1.0f / a[5] : 0.0f; /* >= 1e-30 when seen */
                C->st.texels_seen++;
                for (c = 0; c < 3; c++) partial_a[i * 3 + c] = a[c] * inv;
                partial_rm[i * 3] = 0.0f; partial_rm[i * 3 + 1] = a[3] * inv; partial_rm[i * 3 + 2] = a[4] * inv;
            }
            mask[i] = (float)(nseen > 3 ? 3 : nseen) / 3.0f;
        }
        supermat_uv__debug(C, SUPERMAT_UV_DEBUG_PARTIAL_ALBEDO, o, partial_a, tw, th, 3);
        supermat_uv__debug(C, SUPERMAT_UV_DEBUG_PARTIAL_RM, o, partial_rm, tw, th, 3);
        supermat_uv__debug(C, SUPERMAT_UV_DEBUG_MASK, o, mask, tw, th, 1);
        supermat_uv__debug(C, SUPERMAT_UV_DEBUG_POSITION, o, B.pos, tw, th, 3);
        if (B.lit) supermat_uv__debug(C, SUPERMAT_UV_DEBUG_INPUT_COLOR, o, B.lit, tw, th, 3);
        if (d->debug) { /* seen bits and the chart as float images, in the acc buffer (no longer needed) */
            seenf = B.acc; chart = B.acc + N;
            for (i = 0; i < N; i++) { seenf[i] = (float)B.seen[i]; chart[i] = B.layers[i] ? 1.0f : 0.0f; }
            supermat_uv__debug(C, SUPERMAT_UV_DEBUG_SEEN, o, seenf, tw, th, 1);
            supermat_uv__debug(C, SUPERMAT_UV_DEBUG_CHART, o, chart, tw, th, 1);
        }
    }
    SUPERMAT_UV__CANCEL(C, f0 + 0.1f * (f1 - f0), "back-projection");
    /* refinement */
    for (c = 0; c < 2; c++) {
        const supermat_model *m = c == 0 ? d->albedo_refine_model : d->rm_refine_model;
        if (!m) continue;
        C->prog_base = f0 + (0.1f + 0.4f * c) * (f1 - f0); C->prog_span = 0.4f * (f1 - f0);
        SUPERMAT_UV__TRY(supermat_uv__refine(C, m, c == 0 ? partial_a : partial_rm, mask, B.pos, refined));
        if (C->measure) continue;
        supermat_uv__debug(C, c == 0 ? SUPERMAT_UV_DEBUG_REFINED_ALBEDO : SUPERMAT_UV_DEBUG_REFINED_RM, o, refined, tw, th, 3);
        for (i = 0; i < N; i++) {
            int keep = d->keep_observed && B.seen[i];
            if (!B.layers[i]) continue;
            if (c == 0) { if (!keep) { partial_a[i * 3] = refined[i * 3]; partial_a[i * 3 + 1] = refined[i * 3 + 1]; partial_a[i * 3 + 2] = refined[i * 3 + 2]; } }
            else if (!keep) { partial_rm[i * 3 + 1] = refined[i * 3 + 1]; partial_rm[i * 3 + 2] = refined[i * 3 + 2]; }
        }
    }
    /* gutter fill into the final buffers */
    SUPERMAT_UV__ALLOC(C, valid, unsigned char, N);
    SUPERMAT_UV__ALLOC(C, src, int32_t, N);
    SUPERMAT_UV__ALLOC(C, queue, int32_t, N);
    SUPERMAT_UV__ALLOC(C, gen, uint16_t, N);
    if (B.lit) { /* the detail step, its scratch in B.acc (N x 6 floats, free again) when that is enough */
        if (!C->measure) for (i = 0; i < N; i++) valid[i] = (unsigned char)((refine_a ? B.layers[i] != 0 : B.seen[i] != 0) ? 255 : 0);
        SUPERMAT_UV__TRY(supermat_uv__detail(C, tw, th, B.layers, valid, B.lit, partial_a, B.acc, N * 6 * sizeof(float)));
    }
    if (!C->measure) {
        for (c = 0; c < 2; c++) {
            int refined_map = c == 0 ? (refine_a || B.lit != NULL) : refine_rm;
            for (i = 0; i < N; i++) valid[i] = (unsigned char)(refined_map ? B.layers[i] != 0 : B.seen[i] != 0);
            if (c == 0) {
                memcpy(final_albedo, partial_a, N * 3 * sizeof(float));
                supermat_uv__dilate(tw, th, d->gutter, valid, src, queue, gen, final_albedo, 3, fallback_a);
            } else {
                for (i = 0; i < N; i++) { final_rm[i * 2] = partial_rm[i * 3 + 1]; final_rm[i * 2 + 1] = partial_rm[i * 3 + 2]; }
                supermat_uv__dilate(tw, th, d->gutter, valid, src, queue, gen, final_rm, 2, fallback_rm);
            }
        }
    }
    supermat_uv__release(C, mark);
    SUPERMAT_UV__CANCEL(C, f1, "gutter fill");
    return SUPERMAT_SUCCESS;
}

static supermat_result supermat_uv__bake(supermat_uv__ctx *C, const supermat_uv_output *outputs) {
    const supermat_uv_bake_desc *d = &C->d;
    int v, o, mark, W, H, S;
    size_t n, k;
    float **finals;
    SUPERMAT_UV__TRY(supermat_uv__load_mesh(C));
    C->W = W = d->view_size; C->H = H = d->view_size; C->S = S = d->supersample;
    C->hw = d->ortho_half_width;
    C->ps = 2.0 * C->hw / W;
    n = (size_t)W * H;
    for (v = 0; v < SUPERMAT_UV_VIEWS; v++) {
        supermat_uv__view *V = &C->view[v];
        const double *m = supermat_uv__cam[v];
        for (k = 0; k < 3; k++) { V->X[k] = m[4 * k]; V->Y[k] = m[4 * k + 1]; V->Z[k] = m[4 * k + 2]; V->T[k] = m[4 * k + 3]; }
        SUPERMAT_UV__ALLOC(C, V->rgba, float, n * 4);
        SUPERMAT_UV__ALLOC(C, V->depth, float, n);
        SUPERMAT_UV__ALLOC(C, V->mixed, unsigned char, n);
        if (d->edge_reject) SUPERMAT_UV__ALLOC(C, V->edge, unsigned char, n);
    }
    /* render the views */
    mark = C->nblk;
    SUPERMAT_UV__ALLOC(C, C->proj, float, (size_t)C->nv * 3);
    SUPERMAT_UV__ALLOC(C, C->projs, float, (size_t)C->nv * 3);
    SUPERMAT_UV__ALLOC(C, C->sdepth, float, supermat_uv__mul(1, (size_t)W * S, (size_t)H * S));
    SUPERMAT_UV__ALLOC(C, C->sid, uint32_t, supermat_uv__mul(1, (size_t)W * S, (size_t)H * S));
    SUPERMAT_UV__ALLOC(C, C->cid, uint32_t, (size_t)W * H);
    SUPERMAT_UV__CANCEL(C, 0.0f, "render");
    if (!C->measure) {
        for (v = 0; v < SUPERMAT_UV_VIEWS; v++) {
            supermat_uv__render(C, v);
            supermat_uv__debug(C, SUPERMAT_UV_DEBUG_VIEW, v, C->view[v].rgba, W, H, 4);
            supermat_uv__debug(C, SUPERMAT_UV_DEBUG_VIEW_DEPTH, v, C->view[v].depth, W, H, 1);
            if (C->view[v].edge) supermat_uv__edges(C, &C->view[v], d->edge_reject);
        }
    }
    supermat_uv__release(C, mark);
    SUPERMAT_UV__CANCEL(C, 0.05f, "render");
    /* predictions */
    for (v = 0; v < SUPERMAT_UV_VIEWS; v++) {
        SUPERMAT_UV__ALLOC(C, C->view[v].albedo, float, n * 3);
        SUPERMAT_UV__ALLOC(C, C->view[v].rm, float, n * 3);
    }
    if (d->passthrough) {
        if (!C->measure)
            for (v = 0; v < SUPERMAT_UV_VIEWS; v++)
                for (k = 0; k < n; k++) {
                    supermat_uv__view *V = &C->view[v];
                    V->albedo[k * 3] = V->rgba[k * 4]; V->albedo[k * 3 + 1] = V->rgba[k * 4 + 1]; V->albedo[k * 3 + 2] = V->rgba[k * 4 + 2];
                    V->rm[k * 3] = 0.0f; V->rm[k * 3 + 1] = 0.5f; V->rm[k * 3 + 2] = 0.0f;
                }
    } else {
        C->prog_base = 0.05f; C->prog_span = 0.45f;
        SUPERMAT_UV__TRY(supermat_uv__run_mv(C));
    }
    if (!C->measure)
        for (v = 0; v < SUPERMAT_UV_VIEWS; v++) {
            supermat_uv__debug(C, SUPERMAT_UV_DEBUG_PRED_ALBEDO, v, C->view[v].albedo, W, H, 3);
            supermat_uv__debug(C, SUPERMAT_UV_DEBUG_PRED_RM, v, C->view[v].rm, W, H, 3);
        }
    SUPERMAT_UV__CANCEL(C, 0.5f, "predictions");
    /* each output texture; the results are kept until all succeeded */
    SUPERMAT_UV__ALLOC(C, finals, float *, (size_t)d->output_count * 2);
    for (o = 0; o < d->output_count; o++) {
        size_t N = (size_t)d->texture_width * d->texture_height;
        float *fa, *frm;
        SUPERMAT_UV__ALLOC(C, fa, float, N * 3);
        SUPERMAT_UV__ALLOC(C, frm, float, N * 2);
        if (!C->measure) { finals[2 * o] = fa; finals[2 * o + 1] = frm; }
        SUPERMAT_UV__TRY(supermat_uv__bake_output(C, o, fa, frm));
    }
    if (C->measure) return SUPERMAT_SUCCESS;
    /* the last progress call comes before any output pixel is written, so that it too can cancel */
    SUPERMAT_UV__CANCEL(C, 1.0f, "done");
    for (o = 0; o < d->output_count; o++) {
        if (outputs[o].base_color.pixels) supermat_uv__write(&outputs[o].base_color, d->texture_width, d->texture_height, finals[2 * o], 0);
        if (outputs[o].metallic_roughness.pixels) supermat_uv__write(&outputs[o].metallic_roughness, d->texture_width, d->texture_height, finals[2 * o + 1], 1);
    }
    return SUPERMAT_SUCCESS;
}

static supermat_result supermat_uv__run(const supermat_uv_bake_desc *desc, const supermat_uv_output *outputs,
                                        supermat_uv_stats *stats, supermat_error *err, int measure, size_t *bytes) {
    supermat_uv__ctx *C, plan; /* measuring needs no heap: its context lives on the stack (about 11 KB) */
    supermat_result r;
    supermat_allocator al;
#if SUPERMAT_UV__HAS_POOL
    supermat_pool *pool = NULL;
#endif
    supermat_uv_bake_desc d;
    if (err) memset(err, 0, sizeof *err);
    r = supermat_uv__resolve(desc, &d, err);
    if (r) return r;
    if (!measure) { r = supermat_uv__check_outputs(&d, outputs, err); if (r) return r; }
    al = d.allocator;
    if (!al.alloc || !al.free) { al.alloc = supermat_uv__malloc; al.free = supermat_uv__mfree; al.user = NULL; }
    if (!measure && d.max_memory) { /* the plan first: nothing is allocated for a bake that does not fit */
        size_t need = 0;
        r = supermat_uv__run(&d, NULL, NULL, err, 1, &need);
        if (r) return r;
        if (need > d.max_memory)
            return supermat_uv__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, "the bake (%d output%s of %dx%d, views %dx%d) needs %llu bytes (%.1f MiB), more than max_memory = %llu bytes (%.1f MiB)",
                                     d.output_count, d.output_count == 1 ? "" : "s", d.texture_width, d.texture_height, d.view_size, d.view_size,
                                     (unsigned long long)need, (double)need / 1048576.0, (unsigned long long)d.max_memory, (double)d.max_memory / 1048576.0);
    }
    C = measure ? &plan : (supermat_uv__ctx *)al.alloc(al.user, sizeof *C, 64);
    if (!C) return supermat_uv__fail(err, SUPERMAT_ERROR_OUT_OF_MEMORY, "out of memory (context)");
    memset(C, 0, sizeof *C);
    C->d = d; C->err = err; C->al = al; C->measure = measure;
    C->bytes_now = C->bytes_peak = sizeof *C;
    C->thr = d.threading;
    if (!C->thr.parallel_for && d.threads != 1) {
#if SUPERMAT_UV__HAS_POOL
        if (!measure && supermat_pool_create(d.threads, &al, &pool, &C->thr) != SUPERMAT_SUCCESS) { pool = NULL; memset(&C->thr, 0, sizeof C->thr); }
#endif
    }
    r = supermat_uv__bake(C, outputs);
    if (r == SUPERMAT_SUCCESS && err) memset(err, 0, sizeof *err);
    if (r == SUPERMAT_SUCCESS && stats) *stats = C->st;
    if (bytes) *bytes = C->bytes_peak;
    supermat_uv__release(C, 0);
#if SUPERMAT_UV__HAS_POOL
    if (pool) supermat_pool_destroy(pool);
#endif
    if (!measure) al.free(al.user, C, sizeof *C);
    return r;
}

/* >>uv-public */
SUPERMAT_UV__DEF void supermat_uv_cameras(float matrices[SUPERMAT_UV_VIEWS * 16]) {
    int v, k;
    for (v = 0; v < SUPERMAT_UV_VIEWS; v++)
        for (k = 0; k < 16; k++) matrices[v * 16 + k] = (float)supermat_uv__cam[v][k];
}

SUPERMAT_UV__DEF supermat_result supermat_uv_bake_memory(const supermat_uv_bake_desc *desc, size_t *bytes,
                                                         supermat_error *err) {
    size_t b = 0;
    supermat_result r;
    if (!bytes) return supermat_uv__fail(err, SUPERMAT_ERROR_INVALID_ARGUMENT, "bytes is NULL");
    r = supermat_uv__run(desc, NULL, NULL, err, 1, &b);
    if (!r) *bytes = b;
    return r;
}

SUPERMAT_UV__DEF supermat_result supermat_uv_bake(const supermat_uv_bake_desc *desc, const supermat_uv_output *outputs,
                                                  supermat_uv_stats *stats, supermat_error *err) {
    return supermat_uv__run(desc, outputs, stats, err, 0, NULL);
}

#endif /* SUPERMAT_UV_IMPLEMENTATION_DONE */
#endif /* SUPERMAT_UV_IMPLEMENTATION */

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
