/* libFuzzer harness: the CLI's picture reader, as `supermat image` reads every input (cli_pic_info: the
   header, WebP / 16-bit / EXIF handling and the size cap; then cli_load16f for 16-bit pictures, else
   cli_load: stb_image's decoders and the EXIF orientation). The CLI is included whole (fuzz_cli.h),
   each input written to a file as the reader takes it. Pictures over
   4 M pixels are checked from the header only (the decoders are the same; the CLI takes up to 16384²).

   Built for memory errors only (ASan, and UBSan's array bounds, which sees an index past an array inside a
   struct): stb_image 2.27 has undefined arithmetic that touches no memory (NULL + 0 and memcpy(NULL, p, 0) for a
   PNG's empty first IDAT chunk, a shift by 32 in a progressive JPEG's bit buffer), which the full UBSan stops
   every run at; the CLI's own code is under the full UBSan in fuzz_cameras and fuzz_config.

     clang -g -O1 -fsanitize=fuzzer,address -fsanitize=bounds -I.. -I../convert -I../cli fuzz_picture.c \
         ../convert/sm_convert.c -o fuzz_picture -lm -lpthread [-DSUPERMAT_CLI_WEBP -lwebp]
     ./fuzz_picture -max_total_time=3600 work corpus/picture */
#include "fuzz_cli.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const char *path = fuzz_cli_file(data, size, "picture");
    int w = 0, h = 0, c = 0, lw = 0, lh = 0, lc = 0, is16 = 0;
    if (!path) return 0;
    if (!cli_pic_info(path, "image", &w, &h, &c, 0, &is16)) return 0; /* as `supermat image`: 16-bit read too */
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384) __builtin_trap(); /* cli_pic_info's promise */
    if ((size_t)w * (size_t)h > ((size_t)1 << 22)) return 0;
    if (is16) {
        float *p = cli_load16f(path, &lw, &lh);
        if (p) {
            volatile float s = 0.0f;
            size_t i, n = (size_t)lw * (size_t)lh * 4;
            for (i = 0; i < n; i += 997) s += p[i]; /* every part of the buffer is there */
            (void)s;
            free(p);
        }
    } else {
        unsigned char *p = cli_load(path, &lw, &lh, &lc, 4);
        if (p) {
            volatile unsigned s = 0;
            size_t i, n = (size_t)lw * (size_t)lh * 4;
            if (n) s += p[n - 1];
            for (i = 0; i < n; i += 997) s += p[i];
            (void)s;
            stbi_image_free(p);
        }
    }
    return 0;
}
