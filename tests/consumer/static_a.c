/* a private SUPERMAT_STATIC copy of both headers (must compile without warnings beside another one) */
#define SUPERMAT_STATIC
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"
int static_a(void) { return supermat_default_threads(); }
