/* libFuzzer harness: the converter's PyTorch checkpoint reader (convert/sm_convert.h): the zip directory
   (zip64 records included), the pickle VM over data.pkl, the storages it names, and each tensor's read
   (CRC-32 checked); then the pickle VM alone on the same bytes (sm_pickle_check).
     clang -g -O1 -fsanitize=fuzzer,address,undefined -I.. -I../convert fuzz_pth.c ../convert/sm_convert.c -o fuzz_pth -lm -lpthread
   Seeds: corpus/pth (a small torch.save state dict), corpus/pickle (its data.pkl). */
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c (CMakeLists.txt) */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "../supermat.h"
#include "sm_convert.h"
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    sm_pth *pth = NULL;
    char err[256];
    int n = 0, i;
    if (sm_pth_open_memory(data, size, &pth, err, sizeof err) == 0) {
        n = sm_pth_count(pth);
        for (i = 0; i < n && i < 16; i++) {
            const supermat_tensor_info *ti = sm_pth_tensor(pth, i);
            void *dst;
            if (!ti || ti->nbytes > (1u << 20)) continue;
            dst = malloc(ti->nbytes ? (size_t)ti->nbytes : 1);
            if (dst) { sm_pth_read(pth, i, dst, err, sizeof err); free(dst); }
        }
        if (n > 0) (void)sm_pth_find(pth, sm_pth_tensor(pth, 0)->name);
        sm_pth_close(pth);
    }
    sm_pickle_check(data, size, &n, err, sizeof err);
    return 0;
}
