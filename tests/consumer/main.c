/* uses the shared implementation (impl.c) and the two static copies; exit 0 when all agree */
#include <stdio.h>
#include <string.h>
#include "supermat_uv.h"

int static_a(void);
int static_b(void);

int main(void) {
    static const unsigned char junk[16] = {1, 2, 3};
    supermat_model *model = NULL;
    supermat_model_desc md;
    supermat_error err;
    float cams[SUPERMAT_UV_VIEWS * 16];
    int n = supermat_default_threads();
    supermat_result r;
    memset(&md, 0, sizeof md);
    md.data = junk;
    md.size = sizeof junk;
    r = supermat_model_create(&md, &model, &err);
    supermat_uv_cameras(cams);
    printf("supermat %d.%d.%d, %d threads; junk model: %s (%s)\n", SUPERMAT_VERSION_MAJOR, SUPERMAT_VERSION_MINOR,
           SUPERMAT_VERSION_PATCH, n, supermat_result_string(r), err.message);
    printf("optimized %d\n", supermat_build_optimized());
    if (r == SUPERMAT_SUCCESS || model || !err.message[0]) return 1;
    if (n < 1 || static_a() != n || static_b() != n) return 1;
    return 0;
}
