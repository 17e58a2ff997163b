/* libFuzzer harness: the JSON tokenizer and the safetensors header readers.
     clang -g -O1 -fsanitize=fuzzer,address,undefined -I.. fuzz_json.c -o fuzz_json -lm -lpthread */
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c (CMakeLists.txt) */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "../supermat.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    supermat_json_tok toks[256];
    int n = supermat_json_parse((const char *)data, size, toks, 256), i, count = 0;
    supermat_error err;
    char buf[64];
    if (n > 0 && toks[0].type == SUPERMAT_JSON_OBJECT) {
        int v = supermat_json_find((const char *)data, toks, 0, "a");
        double x;
        if (v >= 0) { supermat_json_string((const char *)data, &toks[v], buf, sizeof buf); supermat_json_number((const char *)data, &toks[v], &x); }
    }
    if (supermat_safetensors_count(data, size, size, &count, &err) == SUPERMAT_SUCCESS)
        for (i = 0; i < count && i < 64; i++) { supermat_tensor_info ti; supermat_safetensors_tensor(data, size, size, i, &ti, &err); }
    supermat_safetensors_metadata(data, size, "supermat.kind", buf, sizeof buf);
    return 0;
}
