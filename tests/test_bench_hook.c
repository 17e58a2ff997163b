/* supermat.h's testing hook supermat_bench_conv_* (what `supermat bench` part (c) times): argument checks,
   each micro-kernel this CPU and build have against the scalar one (AVX2 and AVX-512 within 1e-4 of max |C|,
   AVX-512 the very bits of AVX2), the same bits on 1 and 3 threads, supermat_session_desc_threads. Also built
   as C++ (test_bench_hook_cxx) and without SIMD / pthreads (test_bench_hook_noavx). */
#ifndef SUPERMAT_TEST_LINKED_IMPL
#define SUPERMAT_IMPLEMENTATION
#endif
#include "../supermat.h"
#include "test_util.h"

#define CHECK(what, cond) TU_CHECK(cond, "%s", what)

#define HW 12
#define CIN 40
#define COUT 36 /* not a multiple of 16: a partial panel */

static double rel_diff(const float *a, const float *b, size_t n) {
    double mx = 0.0, md = 0.0;
    size_t i;
    for (i = 0; i < n; i++) {
        double x = fabs((double)a[i]), d = fabs((double)a[i] - (double)b[i]);
        if (x > mx) mx = x;
        if (d > md || d != d) md = d;
    }
    return mx > 0 ? md / mx : md;
}

int main(void) {
    const size_t n = (size_t)HW * HW * COUT;
    supermat_bench_conv *b = NULL;
    supermat_error err;
    supermat_session_desc sd;
    float *scalar = (float *)malloc(n * sizeof(float)), *avx2 = (float *)malloc(n * sizeof(float));
    const float *out;
    int have_avx2 = 0;
    size_t i;

    /* arguments */
    CHECK("create: NULL out", supermat_bench_conv_create(HW, CIN, COUT, 1, NULL, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT);
    CHECK("create: size 0", supermat_bench_conv_create(0, CIN, COUT, 1, &b, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT && !b);
    CHECK("create: 0 threads", supermat_bench_conv_create(HW, CIN, COUT, 0, &b, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT && !b);
    CHECK("run: NULL", supermat_bench_conv_run(NULL, SUPERMAT_KERNEL_SCALAR, NULL, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT);
    CHECK("output: NULL", supermat_bench_conv_output(NULL) == NULL);
    supermat_bench_conv_destroy(NULL);

    CHECK("create", supermat_bench_conv_create(HW, CIN, COUT, 4, &b, &err) == SUPERMAT_SUCCESS && b);
    if (!b || !scalar || !avx2) { printf("cannot go on\n"); return 1; }
    CHECK("output: NULL before a run", supermat_bench_conv_output(b) == NULL);
    CHECK("run: AMX is not an f32 micro-kernel", supermat_bench_conv_run(b, SUPERMAT_KERNEL_AMX, NULL, &err) == SUPERMAT_ERROR_UNSUPPORTED);

    /* the scalar kernel: the reference */
    CHECK("run scalar", supermat_bench_conv_run(b, SUPERMAT_KERNEL_SCALAR, NULL, &err) == SUPERMAT_SUCCESS);
    out = supermat_bench_conv_output(b);
    CHECK("output after a run", out != NULL);
    if (!out) return 1;
    memcpy(scalar, out, n * sizeof(float));
    {
        int finite = 1, nonzero = 0;
        for (i = 0; i < n; i++) { finite &= scalar[i] - scalar[i] == 0.0f; nonzero |= scalar[i] != 0.0f; }
        CHECK("scalar output finite and not all zero", finite && nonzero);
    }
    /* the same data every call: a second bench gives the same bits */
    {
        supermat_bench_conv *b2 = NULL;
        CHECK("a second bench", supermat_bench_conv_create(HW, CIN, COUT, 1, &b2, &err) == SUPERMAT_SUCCESS &&
                                       supermat_bench_conv_run(b2, SUPERMAT_KERNEL_SCALAR, NULL, &err) == SUPERMAT_SUCCESS);
        CHECK("a second bench: the same bits", b2 && supermat_bench_conv_output(b2) &&
                                                      !memcmp(supermat_bench_conv_output(b2), scalar, n * sizeof(float)));
        supermat_bench_conv_destroy(b2);
    }

    /* AVX2 */
    {
        supermat_result r = supermat_bench_conv_run(b, SUPERMAT_KERNEL_AVX2, NULL, &err);
        have_avx2 = supermat_cpu().avx2 && r == SUPERMAT_SUCCESS;
        if (supermat_cpu().avx2) CHECK("run avx2", r == SUPERMAT_SUCCESS || r == SUPERMAT_ERROR_UNSUPPORTED /* SUPERMAT_NO_AVX2 */);
        else CHECK("run avx2 without AVX2: UNSUPPORTED", r == SUPERMAT_ERROR_UNSUPPORTED);
        if (have_avx2) {
            double d = rel_diff(scalar, supermat_bench_conv_output(b), n);
            memcpy(avx2, supermat_bench_conv_output(b), n * sizeof(float));
            printf("  avx2 vs scalar: %.3g of max |C|\n", d);
            CHECK("avx2 within 1e-4 of scalar", d <= 1e-4);
        }
    }
    /* AVX-512: AVX2's bits */
    {
        supermat_result r = supermat_bench_conv_run(b, SUPERMAT_KERNEL_AVX512, NULL, &err);
        if (r == SUPERMAT_SUCCESS) {
            double d = rel_diff(scalar, supermat_bench_conv_output(b), n);
            printf("  avx512 vs scalar: %.3g of max |C|\n", d);
            CHECK("avx512 within 1e-4 of scalar", d <= 1e-4);
            if (have_avx2) CHECK("avx512: the bits of avx2", !memcmp(avx2, supermat_bench_conv_output(b), n * sizeof(float)));
        } else {
            printf("  avx512: not on this CPU or build\n");
            CHECK("run avx512: UNSUPPORTED only without AVX-512", r == SUPERMAT_ERROR_UNSUPPORTED);
        }
    }
    /* AUTO runs (the widest kernel) */
    CHECK("run auto", supermat_bench_conv_run(b, SUPERMAT_KERNEL_AUTO, NULL, &err) == SUPERMAT_SUCCESS);
    CHECK("auto within 1e-4 of scalar", rel_diff(scalar, supermat_bench_conv_output(b), n) <= 1e-4);

#ifndef SUPERMAT_NO_PTHREADS
    /* the built-in pool: the same bits on 3 threads; a hook wider than created is refused */
    {
        supermat_pool *pool = NULL;
        supermat_threading hook;
        memset(&hook, 0, sizeof hook);
        CHECK("pool of 3", supermat_pool_create(3, NULL, &pool, &hook) == SUPERMAT_SUCCESS);
        if (pool) {
            CHECK("run scalar on the pool", supermat_bench_conv_run(b, SUPERMAT_KERNEL_SCALAR, &hook, &err) == SUPERMAT_SUCCESS);
            CHECK("scalar on the pool: the same bits", !memcmp(scalar, supermat_bench_conv_output(b), n * sizeof(float)));
            hook.max_threads = 5;
            CHECK("a hook of more threads than created: INVALID_ARGUMENT",
                     supermat_bench_conv_run(b, SUPERMAT_KERNEL_SCALAR, &hook, &err) == SUPERMAT_ERROR_INVALID_ARGUMENT);
            supermat_pool_destroy(pool);
        }
    }
#endif
    supermat_bench_conv_destroy(b);

    /* supermat_session_desc_threads */
    memset(&sd, 0, sizeof sd);
    sd.threads = 3;
#ifndef SUPERMAT_NO_PTHREADS
    CHECK("desc threads 3", supermat_session_desc_threads(&sd) == 3);
    sd.threads = 0;
    CHECK("desc threads 0 = the default", supermat_session_desc_threads(&sd) == supermat_default_threads());
    sd.threads = 500;
    CHECK("desc threads at most 64", supermat_session_desc_threads(&sd) == 64);
#else
    CHECK("desc threads without pthreads: 1", supermat_session_desc_threads(&sd) == 1);
#endif
    CHECK("desc threads NULL: 1", supermat_session_desc_threads(NULL) == 1);

    free(scalar);
    free(avx2);
    return tu_finish("bench_hook");
}
