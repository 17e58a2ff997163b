/* image_to_pbr.c - the smallest useful supermat program: one picture in, three PBR maps out.
 *
 *   cc -O2 -I.. image_to_pbr.c -o image_to_pbr -lm -lpthread      (needs Debian's libstb-dev)
 *   ./image_to_pbr model.safetensors picture.png out_prefix
 *
 * writes out_prefix_albedo.png, out_prefix_roughness.png, out_prefix_metallic.png. The picture must
 * be a multiple of 8 pixels in both sizes (the official model was trained at 512x512). */
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
    supermat_model_desc md;
    supermat_session_desc sd;
    supermat_run_desc rd;
    supermat_model *model = NULL;
    supermat_session *session = NULL;
    supermat_error err;
    unsigned char *rgba, *albedo, *rough, *metal;
    size_t size = 0;
    void *file;
    int w, h, n, ok = 0;
    char path[1024];
    if (argc != 4) { fprintf(stderr, "usage: %s model.safetensors picture.png out_prefix\n", argv[0]); return 2; }
    file = read_file(argv[1], &size);
    rgba = stbi_load(argv[2], &w, &h, &n, 4);
    if (!file || !rgba) { fprintf(stderr, "cannot read %s\n", file ? argv[2] : argv[1]); return 1; }
    memset(&md, 0, sizeof md);
    md.data = file; md.size = size;
    if (supermat_model_create(&md, &model, &err) != SUPERMAT_SUCCESS) { fprintf(stderr, "model: %s\n", err.message); return 1; }
    memset(&sd, 0, sizeof sd);
    sd.model = model; sd.width = w; sd.height = h;
    if (supermat_session_create(&sd, &session, &err) != SUPERMAT_SUCCESS) { fprintf(stderr, "session: %s\n", err.message); return 1; }
    albedo = (unsigned char *)malloc((size_t)w * h * 3);
    rough = (unsigned char *)malloc((size_t)w * h);
    metal = (unsigned char *)malloc((size_t)w * h);
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = rgba; rd.input.width = w; rd.input.height = h; rd.input.channels = 4;
    rd.albedo.pixels = albedo; rd.albedo.channels = 3;
    rd.roughness.pixels = rough; rd.roughness.channels = 1;
    rd.metallic.pixels = metal; rd.metallic.channels = 1;
    if (supermat_run(session, &rd, &err) != SUPERMAT_SUCCESS) fprintf(stderr, "run: %s\n", err.message);
    else {
        snprintf(path, sizeof path, "%s_albedo.png", argv[3]);
        ok = stbi_write_png(path, w, h, 3, albedo, w * 3);
        snprintf(path, sizeof path, "%s_roughness.png", argv[3]);
        ok = ok && stbi_write_png(path, w, h, 1, rough, w);
        snprintf(path, sizeof path, "%s_metallic.png", argv[3]);
        ok = ok && stbi_write_png(path, w, h, 1, metal, w);
        if (!ok) fprintf(stderr, "cannot write %s\n", path);
    }
    supermat_session_destroy(session);
    supermat_model_destroy(model);
    free(albedo); free(rough); free(metal); free(file);
    stbi_image_free(rgba);
    return ok ? 0 : 1;
}
