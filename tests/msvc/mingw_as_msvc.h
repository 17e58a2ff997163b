/* Force-included (clang-cl /FI) by tests/test_msvc.sh before anything else: lets clang-cl in MSVC mode
   (_MSC_VER, no __GNUC__) read MinGW-w64's C and Windows headers, the only ones here. Without __GNUC__,
   MinGW's _mingw.h defines __attribute__ away, which breaks clang's own intrinsic headers (immintrin.h,
   intrin.h), and puts __declspec(noreturn / deprecated / nothrow) after declarators, where clang refuses
   them; those three become nothing (they change no types). Nothing of supermat is configured here. */
#include <_mingw.h>
#undef __attribute__
#undef __MINGW_ATTRIB_NORETURN
#define __MINGW_ATTRIB_NORETURN
#undef __MINGW_ATTRIB_DEPRECATED
#define __MINGW_ATTRIB_DEPRECATED
#undef __MINGW_NOTHROW
#define __MINGW_NOTHROW
