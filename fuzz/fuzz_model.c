/* libFuzzer harness: model files. Any input must give a model or a clean error, never a crash or a leak.
     clang -g -O1 -fsanitize=fuzzer,address,undefined -I.. fuzz_model.c -o fuzz_model -lm -lpthread
     ./fuzz_model corpus/          (seed: the header of a converted tiny model, e.g. head -c 200000) */
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c (CMakeLists.txt) */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "../supermat.h"
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    supermat_model_desc md;
    supermat_model *m = NULL;
    supermat_error err;
    memset(&md, 0, sizeof md);
    md.data = data; md.size = size;
    if (supermat_model_create(&md, &m, &err) == SUPERMAT_SUCCESS) supermat_model_destroy(m);
    return 0;
}
