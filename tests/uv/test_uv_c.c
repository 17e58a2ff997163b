/* supermat_uv.h compiled as C99 (and, copied to a .cpp by CMake, as C++): the header's quick start,
   a passthrough bake of a textured quad and the stats it reports. No libraries beyond libc/libm. */
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fails = 0, passes = 0;
#define CHECK(c, msg)                                                          \
    do {                                                                       \
        if (c) passes++;                                                       \
        else { fails++; printf("FAIL %s:%d: %s\n", __FILE__, __LINE__, msg); } \
    } while (0)

/* the header's quick start, as printed there (models may be NULL here: then it reports an error) */
static supermat_result quick_start(const float *xyz, const float *uv, uint32_t nv, const uint32_t *idx, uint32_t ni,
                                   const unsigned char *rgba8, int tw, int th, const supermat_model *mv,
                                   const supermat_model *bc, const supermat_model *rm, unsigned char *albedo_rgba8,
                                   unsigned char *mr_rgb8) {
    supermat_uv_part part; memset(&part, 0, sizeof part);
    part.positions = xyz; part.uvs = uv; part.vertex_count = nv;      /* Z up, see FRAMES */
    part.indices = idx; part.index_count = ni;                         /* NULL = triangle list */
    part.base_color.pixels = (void *)rgba8; part.base_color.width = tw; part.base_color.height = th;
    part.base_color.channels = 4;                                      /* 8-bit = sRGB */
    supermat_uv_bake_desc bd; memset(&bd, 0, sizeof bd);
    bd.parts = &part; bd.part_count = 1;
    bd.mv_model = mv; bd.albedo_refine_model = bc; bd.rm_refine_model = rm;  /* supermat_model_create */
    supermat_uv_output out; memset(&out, 0, sizeof out);
    out.base_color.pixels = albedo_rgba8;       out.base_color.channels = 4;          /* 1024x1024 */
    out.metallic_roughness.pixels = mr_rgb8;    out.metallic_roughness.channels = 3;
    supermat_error err;
    supermat_result r = supermat_uv_bake(&bd, &out, NULL, &err);
    if (r != SUPERMAT_SUCCESS) puts(err.message);
    return r;
}

int main(void) {
    /* a quad in the XZ plane facing the front camera (-Y), UVs covering [0.25, 0.75]^2 */
    static const float xyz[12] = {-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1};
    static const float uv[8] = {0.25f, 0.75f, 0.75f, 0.75f, 0.75f, 0.25f, 0.25f, 0.25f};
    static const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    unsigned char tex[16 * 16 * 4], *albedo, *mr;
    float cams[SUPERMAT_UV_VIEWS * 16];
    supermat_uv_part part;
    supermat_uv_bake_desc bd;
    supermat_uv_output out;
    supermat_uv_stats st;
    supermat_error err;
    supermat_result r;
    size_t bytes = 0;
    int i, x, y, bad = 0;
    for (i = 0; i < 16 * 16; i++) { tex[i * 4] = 200; tex[i * 4 + 1] = 100; tex[i * 4 + 2] = 50; tex[i * 4 + 3] = 255; }
    albedo = (unsigned char *)malloc(1024 * 1024 * 4);
    mr = (unsigned char *)malloc(1024 * 1024 * 3);
    if (!albedo || !mr) return 1;

    supermat_uv_cameras(cams);
    CHECK(cams[0] == 1.0f && cams[7] == -1.0f && cams[4 * 16 + 11] == 1.0f, "camera matrices");

    /* the quick start without models: a clear error, nothing written */
    memset(albedo, 7, 1024 * 1024 * 4);
    r = quick_start(xyz, uv, 4, idx, 6, tex, 16, 16, NULL, NULL, NULL, albedo, mr);
    CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && albedo[0] == 7, "quick start without a model");

    /* passthrough at a small size */
    memset(&part, 0, sizeof part);
    part.positions = xyz; part.uvs = uv; part.vertex_count = 4; part.indices = idx; part.index_count = 6;
    part.base_color.pixels = tex; part.base_color.width = 16; part.base_color.height = 16; part.base_color.channels = 4;
    memset(&bd, 0, sizeof bd);
    bd.parts = &part; bd.part_count = 1; bd.passthrough = 1;
    bd.texture_width = 64; bd.texture_height = 64; bd.view_size = 64; bd.threads = 1;
    memset(&out, 0, sizeof out);
    out.base_color.pixels = albedo; out.base_color.channels = 4;
    out.metallic_roughness.pixels = mr; out.metallic_roughness.channels = 3;
    r = supermat_uv_bake_memory(&bd, &bytes, &err);
    CHECK(r == SUPERMAT_SUCCESS && bytes > 0, "memory estimate");
    r = supermat_uv_bake(&bd, &out, &st, &err);
    CHECK(r == SUPERMAT_SUCCESS, err.message);
    /* the chart covers texels 16..47: it was seen by the front view (and the back), so every texel of
       the texture is the texture's colour (the gutter reaches the rest, beyond it the mean) */
    for (y = 0; y < 64; y++)
        for (x = 0; x < 64; x++) {
            const unsigned char *p = albedo + (y * 64 + x) * 4, *q = mr + (y * 64 + x) * 3;
            if (abs(p[0] - 200) > 1 || abs(p[1] - 100) > 1 || abs(p[2] - 50) > 1 || p[3] != 255) bad++;
            if (q[0] != 255 || q[1] != 128 || q[2] != 0) bad++;
        }
    CHECK(bad == 0, "passthrough colours");
    CHECK(st.triangles == 2 && st.texels_chart == 32 * 32 && st.texels_seen == 32 * 32, "stats");
    printf("C build: %llu chart texels, %llu seen, estimate %lu bytes\n", (unsigned long long)st.texels_chart,
           (unsigned long long)st.texels_seen, (unsigned long)bytes);
    /* the same quad turned 45 degrees about Z (seen at cos 0.707 by two views) with a cos^900 blend:
       the weights (1e-136) underflow float; the texels must still get the texture's colour */
    {
        static const float rot[12] = {-0.70710678f, -0.70710678f, -1, 0.70710678f, 0.70710678f, -1, 0.70710678f, 0.70710678f, 1, -0.70710678f, -0.70710678f, 1};
        part.positions = rot;
        bd.weight = SUPERMAT_UV_WEIGHT_COS_POWER; bd.cos_power = 900.0f;
        r = supermat_uv_bake(&bd, &out, &st, &err);
        CHECK(r == SUPERMAT_SUCCESS, err.message);
        bad = 0;
        for (i = 0; i < 64 * 64; i++) if (abs(albedo[i * 4] - 200) > 1 || abs(albedo[i * 4 + 1] - 100) > 1 || abs(albedo[i * 4 + 2] - 50) > 1) bad++;
        CHECK(bad == 0 && st.texels_seen == 32 * 32, "cos^900 blend at 45 degrees keeps the colour");
        printf("cos^900 at 45 degrees: %d texels off the colour, %llu seen\n", bad, (unsigned long long)st.texels_seen);
    }
    free(albedo);
    free(mr);
    printf("%d passed, %d failed\n", passes, fails);
    return fails ? 1 : 0;
}
