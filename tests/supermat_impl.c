/* supermat.h's implementation, compiled once per build for the tests (and fuzz harnesses) that use only its API
   (CMakeLists.txt: supermat_impl_test, supermat_fuzz_impl). Each of them still compiles alone, defining
   SUPERMAT_IMPLEMENTATION itself as a user's single file would; the build defines SUPERMAT_TEST_LINKED_IMPL
   for them, so that each build compiles the header's implementation once for all of them (20-60 s a copy). */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
