/* supermat_build_optimized() against how this file was compiled: argv[1] is what CMake compiled it with
   (1: with optimisation, 0: -O0); exit 0 when the library says the same. */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv) {
    int want = argc > 1 ? atoi(argv[1]) : -2, got = supermat_build_optimized();
    printf("supermat_build_optimized() = %d, compiled %s\n", got, want == 1 ? "optimised" : "at -O0");
    return got == want ? 0 : 1;
}
