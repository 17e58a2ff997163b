/* tests/test_msvc.sh compiles this with clang-cl in MSVC mode (C and C++): both headers' implementations,
   and a check that the preprocessor took the branches MSVC takes: no GCC target attributes, __cpuidex and
   _xgetbv for the CPU, every x86-64 kernel (AVX2, AVX-512 F / BF16 / VNNI, AVX-VNNI) compiled and
   dispatched at run time, AMX off, the Win32 thread pool. */
#define SUPERMAT_IMPLEMENTATION
#include "../../supermat.h"
#define SUPERMAT_UV_IMPLEMENTATION
#include "../../supermat_uv.h"

#if !defined(_MSC_VER) || !defined(_WIN32) || !defined(_M_X64)
#error "not compiled as MSVC x64"
#endif
#if SUPERMAT__GNU_SIMD
#error "the GCC / clang branch (target attributes, <cpuid.h>) was taken, not MSVC's"
#endif
#if !SUPERMAT__HAS_AVX2 || !SUPERMAT__HAS_AVX512 || !SUPERMAT__HAS_AVXVNNI || SUPERMAT__HAS_AMX || SUPERMAT__HAS_NEON
#error "the MSVC branch does not have every x86-64 kernel (or has AMX / NEON)"
#endif
#if !SUPERMAT__HAS_WINTHREADS || SUPERMAT__HAS_PTHREADS
#error "not the Win32 thread pool"
#endif

/* the kernels are reached from here too (the run-time dispatch picks them by supermat_cpu()) */
int msvc_probe(void);
int msvc_probe(void) {
    supermat_cpu_info c = supermat_cpu();
    return c.avx2 + 2 * c.avx512 + 4 * c.avx512_bf16 + 8 * c.avx512_vnni + 16 * c.avx_vnni + 32 * c.amx_bf16;
}
