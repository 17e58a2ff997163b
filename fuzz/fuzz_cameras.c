/* libFuzzer harness: the CLI's meta.json camera reader (`supermat views --cameras`: cli_read_cameras,
   then every camera looked up by index as the views are matched). The CLI is one translation unit; it is
   included whole here with its main renamed. Messages stay in cli_last_error (cli_quiet).

     clang -g -O1 -fsanitize=fuzzer,address,undefined -I.. -I../tools -I../tools/cli fuzz_cameras.c \
         ../tools/sm_convert.c -o fuzz_cameras -lm -lpthread -lstb
     ./fuzz_cameras -max_total_time=3600 work corpus/cameras */
#if defined(__clang__)
#pragma clang diagnostic ignored "-Wunneeded-internal-declaration" /* the CLI's commands this harness does not call */
#pragma clang diagnostic ignored "-Wunused-function"
#endif
#define main supermat_cli_main
#include "../tools/cli/main.c"
#undef main

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static char path[96];
    cli_camera *cams = NULL;
    int n = 0, i;
    FILE *f;
    if (!path[0]) {
        struct stat st;
        snprintf(path, sizeof path, "%s/supermat_fuzz_cameras_%ld.json", stat("/dev/shm", &st) == 0 ? "/dev/shm" : "/tmp", (long)getpid());
        cli_quiet = 1;
    }
    f = fopen(path, "wb");
    if (!f) return 0;
    if (size && fwrite(data, 1, size, f) != size) { fclose(f); return 0; }
    fclose(f);
    if (cli_read_cameras(path, &cams, &n) == CLI_OK) {
        for (i = 0; i < n; i++)
            if (cli_find_camera(cams, n, cams[i].index, "view", path) != &cams[i]) __builtin_trap(); /* indices are unique */
        (void)cli_find_camera(cams, n, 1000000000L, "view", path);
        free(cams);
    }
    return 0;
}
