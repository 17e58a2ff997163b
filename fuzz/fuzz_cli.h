/* fuzz/fuzz_cli.h - for the harnesses that drive the CLI's own readers (fuzz_cameras.c, fuzz_picture.c): the CLI
   is one translation unit, included whole here with its main renamed, and fuzz_cli_file() puts each input where
   those readers take it from, a file (in /dev/shm where there is one; messages stay in cli_last_error). */
#if defined(__clang__)
#pragma clang diagnostic ignored "-Wunneeded-internal-declaration" /* the CLI's commands a harness does not call */
#pragma clang diagnostic ignored "-Wunused-function"
#endif
#define main supermat_cli_main
#include "../cli/main.c"
#undef main

/* the input written to this process' file NAME (e.g. "cameras.json"); its path, or NULL when it cannot be written */
static const char *fuzz_cli_file(const uint8_t *data, size_t size, const char *name) {
    static char path[128];
    FILE *f;
    if (!path[0]) {
        struct stat st;
        snprintf(path, sizeof path, "%s/supermat_fuzz_%ld_%s", stat("/dev/shm", &st) == 0 ? "/dev/shm" : "/tmp", (long)getpid(), name);
        cli_quiet = 1;
    }
    f = fopen(path, "wb");
    if (!f) return NULL;
    if (size && fwrite(data, 1, size, f) != size) { fclose(f); return NULL; }
    fclose(f);
    return path;
}
