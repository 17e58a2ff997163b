/* libFuzzer harness: the mesh arrays handed to supermat_uv.h. The input is read as a little header
   (vertex count, index count, strides, flags, a 1-3 channel base-colour texture size) and then raw
   float positions / UVs / normals (NaN, Inf, huge values as they come), uint32 indices (out of range as
   they come) and texture bytes; supermat_uv_bake runs in passthrough mode at 16x16 (views 16x16).
   It must return an error or finish, never read or write outside the arrays.
     clang -g -O1 -fsanitize=fuzzer,address,undefined -I.. fuzz_uv.c -o fuzz_uv -lm -lpthread
   Seeds: corpus/uv (a cube, a degenerate strip). */
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "../supermat_uv.h"
#include <stdlib.h>
#include <string.h>

static size_t take(const uint8_t **p, size_t *left, void *dst, size_t n) {
    size_t k = n < *left ? n : *left;
    memset(dst, 0, n);
    memcpy(dst, *p, k);
    *p += k; *left -= k;
    return k;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const uint8_t *p = data;
    size_t left = size;
    uint16_t hdr[6];
    uint32_t nv, ni, tw, th, tch, flags;
    float *pos, *uv, *nrm;
    uint32_t *idx;
    unsigned char *tex, out_bc[16 * 16 * 4], out_mr[16 * 16 * 3];
    supermat_uv_part part;
    supermat_uv_bake_desc bd;
    supermat_uv_output out;
    supermat_error err;
    take(&p, &left, hdr, sizeof hdr);
    nv = hdr[0] % 512; ni = hdr[1] % 1537; tw = hdr[2] % 9; th = hdr[3] % 9; tch = 1 + hdr[4] % 4; flags = hdr[5];
    pos = (float *)malloc(sizeof(float) * 3 * (nv + 1));
    uv = (float *)malloc(sizeof(float) * 2 * (nv + 1));
    nrm = (float *)malloc(sizeof(float) * 3 * (nv + 1));
    idx = (uint32_t *)malloc(sizeof(uint32_t) * (ni + 1));
    tex = (unsigned char *)malloc((size_t)tw * th * tch + 1);
    if (!pos || !uv || !nrm || !idx || !tex) goto done;
    take(&p, &left, pos, sizeof(float) * 3 * nv);
    take(&p, &left, uv, sizeof(float) * 2 * nv);
    take(&p, &left, nrm, sizeof(float) * 3 * nv);
    take(&p, &left, idx, sizeof(uint32_t) * ni);
    take(&p, &left, tex, (size_t)tw * th * tch);
    memset(&part, 0, sizeof part);
    part.positions = pos; part.uvs = uv; part.normals = (flags & 1) ? nrm : NULL;
    part.vertex_count = nv;
    part.indices = (flags & 2) ? NULL : idx;
    part.index_count = ni;
    if (tw && th) { part.base_color.pixels = tex; part.base_color.width = (int)tw; part.base_color.height = (int)th; part.base_color.channels = (int)tch; }
    part.wrap_u = (supermat_uv_wrap)((flags >> 2) % 3); part.wrap_v = (supermat_uv_wrap)((flags >> 4) % 3);
    memset(&bd, 0, sizeof bd);
    bd.parts = &part; bd.part_count = 1;
    bd.texture_width = bd.texture_height = 16;
    bd.view_size = 16;
    bd.supersample = 1 + (flags >> 6) % 2;
    bd.passthrough = 1;
    bd.threads = 1;
    bd.gutter = (flags >> 7) & 1 ? -1 : 2;
    bd.uv_origin_bottom_left = (flags >> 8) & 1;
    memset(&out, 0, sizeof out);
    out.base_color.pixels = out_bc; out.base_color.channels = (flags >> 9) & 1 ? 4 : 3;
    out.metallic_roughness.pixels = out_mr; out.metallic_roughness.channels = 3;
    supermat_uv_bake(&bd, &out, NULL, &err);
done:
    free(pos); free(uv); free(nrm); free(idx); free(tex);
    return 0;
}
