/* image_to_pbr.c - the smallest useful supermat program: one picture in, three PBR maps out.
 *
 *   cc -std=c99 -O2 -ffp-contract=off -I.. image_to_pbr.c -o image_to_pbr -lm -lpthread   (Debian's libstb-dev)
 *   ./image_to_pbr model.safetensors picture.png out_prefix
 *
 * writes out_prefix_albedo.png, out_prefix_roughness.png and out_prefix_metallic.png at the picture's size
 * (any size), from any model file (pre-packed by `supermat pack` too). Every session field is left 0, so the
 * model file's pipeline runs (its work size, detail and colour steps) as in `supermat image`: these are its
 * maps of an 8-bit picture, pixel for pixel (tests/cli/test_parity.sh), when built as it is: -ffp-contract=off
 * (gcc's GNU modes and clang fuse multiply-adds otherwise, which moves a few values by 1/255). A picture with
 * a transparent pixel gets an RGBA albedo and gray + alpha roughness and metallic (the library copies the
 * input's alpha into the 4th / 2nd channel), any other RGB and gray. */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#endif
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void *read_file(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    void *data = NULL;
    long n;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 && (data = malloc((size_t)n)) != NULL) {
        if (fread(data, 1, (size_t)n, f) != (size_t)n) { free(data); data = NULL; } else *size = (size_t)n;
    }
    fclose(f);
    return data;
}

int main(int argc, char **argv) {
    static const char *const names[3] = {"albedo", "roughness", "metallic"};
    supermat_model_desc md;
    supermat_session_desc sd;
    supermat_run_desc rd;
    supermat_image *out[3];
    supermat_model *model = NULL;
    supermat_session *session = NULL;
    supermat_error err;
    unsigned char *rgba = NULL, *maps[3] = {NULL, NULL, NULL};
    void *file = NULL;
    size_t size = 0, np, i;
    int w, h, n, k, alpha = 0, ok = 0;
    char path[1024];
    if (argc != 4) { fprintf(stderr, "usage: %s model.safetensors picture.png out_prefix\n", argv[0]); return 2; }
    if (!(file = read_file(argv[1], &size))) { fprintf(stderr, "cannot read %s\n", argv[1]); return 1; }
    if (!(rgba = stbi_load(argv[2], &w, &h, &n, 4))) {
        fprintf(stderr, "cannot read %s: %s\n", argv[2], stbi_failure_reason());
        free(file);
        return 1;
    }
    /* the maps keep the picture's alpha when its file has one (2 or 4 channels) that is not all opaque */
    np = (size_t)w * (size_t)h;
    if (n == 2 || n == 4)
        for (i = 0; i < np && !alpha; i++) alpha = rgba[i * 4 + 3] != 255;
    memset(&md, 0, sizeof md);
    md.data = file; md.size = size;
    md.copy_data = 1;   /* the model keeps no pointer into `file` (freed below); a pre-packed file in a buffer
                           that is not 64-byte aligned (malloc's) is refused without it */
    if (supermat_model_create(&md, &model, &err) != SUPERMAT_SUCCESS) { fprintf(stderr, "model: %s\n", err.message); goto done; }
    free(file);
    file = NULL;
    memset(&sd, 0, sizeof sd);
    sd.model = model; sd.width = w; sd.height = h;   /* the rest 0: the model file's pipeline */
    if (supermat_session_create(&sd, &session, &err) != SUPERMAT_SUCCESS) { fprintf(stderr, "session: %s\n", err.message); goto done; }
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = rgba; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
    out[0] = &rd.albedo; out[1] = &rd.roughness; out[2] = &rd.metallic;
    for (k = 0; k < 3; k++) {   /* 8-bit: RGB / gray, with alpha RGBA / gray + alpha */
        out[k]->channels = (k == 0 ? 3 : 1) + alpha;
        if (!(maps[k] = (unsigned char *)malloc(np * (size_t)out[k]->channels))) { fprintf(stderr, "out of memory\n"); goto done; }
        out[k]->pixels = maps[k];
    }
    if (supermat_run(session, &rd, &err) != SUPERMAT_SUCCESS) { fprintf(stderr, "run: %s\n", err.message); goto done; }
    for (k = 0; k < 3; k++) {
        int ch = out[k]->channels;
        if (snprintf(path, sizeof path, "%s_%s.png", argv[3], names[k]) >= (int)sizeof path) { fprintf(stderr, "%s: too long\n", argv[3]); goto done; }
        if (!stbi_write_png(path, w, h, ch, maps[k], w * ch)) { fprintf(stderr, "cannot write %s\n", path); goto done; }
    }
    ok = 1;
done:
    supermat_session_destroy(session);   /* both take NULL */
    supermat_model_destroy(model);       /* after every session of it */
    for (k = 0; k < 3; k++) free(maps[k]);
    free(file);
    stbi_image_free(rgba);
    return ok ? 0 : 1;
}
