/* the one file with the implementation of both headers */
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"
