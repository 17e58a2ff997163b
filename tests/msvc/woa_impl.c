/* tests/test_msvc.sh compiles this for Windows on ARM (clang --target=aarch64-w64-mingw32, C and C++, MinGW-w64's
   headers): both headers' implementations, and a check that the preprocessor took the branches such a build
   takes: the NEON passes and the Win32 thread pool, no x86-64 kernel. cl.exe for ARM64 is not covered: the NEON
   passes need gcc or clang there (clang-cl included), cl.exe builds the scalar path. */
#define SUPERMAT_IMPLEMENTATION
#include "../../supermat.h"
#define SUPERMAT_UV_IMPLEMENTATION
#include "../../supermat_uv.h"

#if !defined(_WIN32) || !defined(__aarch64__)
#error "not compiled for Windows on ARM64"
#endif
#if !SUPERMAT__HAS_NEON || SUPERMAT__HAS_AVX2
#error "Windows on ARM64 without the NEON passes (or with an x86-64 kernel)"
#endif
#if !SUPERMAT__HAS_WINTHREADS || SUPERMAT__HAS_PTHREADS
#error "not the Win32 thread pool"
#endif

int woa_probe(void);
int woa_probe(void) { return supermat_cpu().neon + 2 * supermat_default_threads(); }
