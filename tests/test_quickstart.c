/* The quick start of supermat.h's top comment, as a program (compiled as C and as C++ in CI). */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(int argc, char **argv) {
    static unsigned char rgba[64 * 64 * 4], albedo_rgb8[64 * 64 * 3], rough8[64 * 64], metal8[64 * 64];
    unsigned char *file_bytes;
    size_t file_size;
    long n;
    int i, w = 64, h = 64;
    FILE *f = argc > 1 ? fopen(argv[1], "rb") : NULL;
    if (!f) { printf("usage: %s MODEL\n", argv[0]); return 2; }
    fseek(f, 0, SEEK_END); n = ftell(f); fseek(f, 0, SEEK_SET);
    file_size = (size_t)n;
    file_bytes = (unsigned char *)malloc(file_size);
    if (!file_bytes || fread(file_bytes, 1, file_size, f) != file_size) return 1;
    fclose(f);
    for (i = 0; i < 64 * 64 * 4; i++) rgba[i] = (unsigned char)(i * 7);
    {
        supermat_model_desc md; memset(&md, 0, sizeof md);
        md.data = file_bytes; md.size = file_size;          // a model file made by `supermat convert`
        supermat_model *model; supermat_error err;
        if (supermat_model_create(&md, &model, &err) != SUPERMAT_SUCCESS) { puts(err.message); return 1; }
        supermat_session_desc sd; memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = w; sd.height = h;       // the picture's size, any
        supermat_session *s;
        if (supermat_session_create(&sd, &s, &err) != SUPERMAT_SUCCESS) { puts(err.message); return 1; }
        supermat_run_desc rd; memset(&rd, 0, sizeof rd);
        rd.input.pixels = rgba; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
        rd.albedo.pixels = albedo_rgb8;    rd.albedo.channels = 3;      // format 0 = 8-bit
        rd.roughness.pixels = rough8;      rd.roughness.channels = 1;
        rd.metallic.pixels = metal8;       rd.metallic.channels = 1;
        if (supermat_run(s, &rd, &err) != SUPERMAT_SUCCESS) { puts(err.message); return 1; }
        supermat_session_destroy(s); supermat_model_destroy(model);
    }
    free(file_bytes);
    printf("quickstart: 1 passed, 0 failed\n");
    return 0;
}
