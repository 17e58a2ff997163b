/* libFuzzer harness: the CLI's meta.json camera reader (`supermat views --cameras`: cli_read_cameras,
   then every camera looked up by index as the views are matched). The CLI is included whole
   (fuzz_cli.h), each input written to a file as the reader takes it.

     clang -g -O1 -fsanitize=fuzzer,address,undefined -I.. -I../convert -I../cli fuzz_cameras.c \
         ../convert/sm_convert.c -o fuzz_cameras -lm -lpthread -lstb
     ./fuzz_cameras -max_total_time=3600 work corpus/cameras */
#include "fuzz_cli.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const char *path = fuzz_cli_file(data, size, "cameras.json");
    cli_camera *cams = NULL;
    int n = 0, i;
    if (!path) return 0;
    if (cli_read_cameras(path, &cams, &n) == CLI_OK) {
        for (i = 0; i < n; i++)
            if (cli_find_camera(cams, n, cams[i].index, "view", path) != &cams[i]) __builtin_trap(); /* indices are unique */
        (void)cli_find_camera(cams, n, 1000000000L, "view", path);
        free(cams);
    }
    return 0;
}
