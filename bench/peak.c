/* bench/peak.c - this machine's peak for `supermat bench`: independent chains of FMAs (_mm256_fmadd_ps, or
 * _mm512_fmadd_ps where the AVX-512 kernel runs) or of the dot instruction a bf16 / int8 compute multiplies
 * with (vdpbf16ps, vpdpbusd), on the calling thread or on every thread of a supermat_threading hook.
 * A bench_peak struct holds what one probe measures and its calibration: no state between calls.
 * Depends on supermat.h's public API only (supermat_threading, supermat_cpu(), the kernel and compute
 * enums), <immintrin.h> and clock_gettime. Included by cli/bench.c (the CLI is one translation unit).
 */

/* x86-64 with GCC or Clang: the same conditions as the header's kernels (SUPERMAT_NO_* leave them out) */
#if !defined(SUPERMAT_NO_AVX2) && defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define BENCH_HAS_AVX2 1
#include <immintrin.h>
#define BENCH_AVX2 __attribute__((target("avx2,fma,f16c")))
#else
#define BENCH_HAS_AVX2 0
#endif
#if BENCH_HAS_AVX2 && !defined(SUPERMAT_NO_AVX512)
#define BENCH_HAS_AVX512 1
#define BENCH_AVX512 __attribute__((target("avx512f,avx2,fma,f16c")))
#define BENCH_AVX512BF16 __attribute__((target("avx512f,avx512bf16,avx2,fma,f16c")))
#define BENCH_AVX512VNNI __attribute__((target("avx512f,avx512bw,avx512vnni,avx2,fma,f16c")))
#else
#define BENCH_HAS_AVX512 0
#endif
/* AVX-VNNI needs gcc >= 11 / clang >= 12 */
#if BENCH_HAS_AVX512 && !defined(SUPERMAT_NO_AVXVNNI) && \
    ((defined(__clang__) && __clang_major__ >= 12) || (!defined(__clang__) && defined(__GNUC__) && __GNUC__ >= 11))
#define BENCH_HAS_AVXVNNI 1
#define BENCH_AVXVNNI __attribute__((target("avxvnni,avx2,fma,f16c")))
#else
#define BENCH_HAS_AVXVNNI 0
#endif

static double bench_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* the FMA peak: independent chains of _mm256_fmadd_ps, 12 per iteration (2 FMA ports x 4 cycles of
   latency need 8 in flight) */
#define BENCH_CHAINS 12
#if BENCH_HAS_AVX2
BENCH_AVX2 static float bench_fma_loop(long iters, float seed) {
    const __m256 mul = _mm256_set1_ps(0.99999f), add = _mm256_set1_ps(1e-6f);
    __m256 a0 = _mm256_set1_ps(seed + 0.10f), a1 = _mm256_set1_ps(seed + 0.11f), a2 = _mm256_set1_ps(seed + 0.12f);
    __m256 a3 = _mm256_set1_ps(seed + 0.13f), a4 = _mm256_set1_ps(seed + 0.14f), a5 = _mm256_set1_ps(seed + 0.15f);
    __m256 a6 = _mm256_set1_ps(seed + 0.16f), a7 = _mm256_set1_ps(seed + 0.17f), a8 = _mm256_set1_ps(seed + 0.18f);
    __m256 a9 = _mm256_set1_ps(seed + 0.19f), a10 = _mm256_set1_ps(seed + 0.20f), a11 = _mm256_set1_ps(seed + 0.21f);
    float out[8];
    long i;
    for (i = 0; i < iters; i++) {
        a0 = _mm256_fmadd_ps(a0, mul, add); a1 = _mm256_fmadd_ps(a1, mul, add); a2 = _mm256_fmadd_ps(a2, mul, add);
        a3 = _mm256_fmadd_ps(a3, mul, add); a4 = _mm256_fmadd_ps(a4, mul, add); a5 = _mm256_fmadd_ps(a5, mul, add);
        a6 = _mm256_fmadd_ps(a6, mul, add); a7 = _mm256_fmadd_ps(a7, mul, add); a8 = _mm256_fmadd_ps(a8, mul, add);
        a9 = _mm256_fmadd_ps(a9, mul, add); a10 = _mm256_fmadd_ps(a10, mul, add); a11 = _mm256_fmadd_ps(a11, mul, add);
    }
    a0 = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(a0, a1), _mm256_add_ps(a2, a3)), _mm256_add_ps(_mm256_add_ps(a4, a5), _mm256_add_ps(a6, a7)));
    a0 = _mm256_add_ps(a0, _mm256_add_ps(_mm256_add_ps(a8, a9), _mm256_add_ps(a10, a11)));
    _mm256_storeu_ps(out, a0);
    return out[0] + out[1] + out[2] + out[3] + out[4] + out[5] + out[6] + out[7];
}
#endif
#if BENCH_HAS_AVX512
/* the same with 512-bit vectors: the peak of the AVX-512 kernel */
BENCH_AVX512 static float bench_fma_loop512(long iters, float seed) {
    const __m512 mul = _mm512_set1_ps(0.99999f), add = _mm512_set1_ps(1e-6f);
    __m512 a[BENCH_CHAINS];
    long i;
    int c;
    for (c = 0; c < BENCH_CHAINS; c++) a[c] = _mm512_set1_ps(seed + 0.10f + 0.01f * (float)c);
    for (i = 0; i < iters; i++) {
        a[0] = _mm512_fmadd_ps(a[0], mul, add); a[1] = _mm512_fmadd_ps(a[1], mul, add); a[2] = _mm512_fmadd_ps(a[2], mul, add);
        a[3] = _mm512_fmadd_ps(a[3], mul, add); a[4] = _mm512_fmadd_ps(a[4], mul, add); a[5] = _mm512_fmadd_ps(a[5], mul, add);
        a[6] = _mm512_fmadd_ps(a[6], mul, add); a[7] = _mm512_fmadd_ps(a[7], mul, add); a[8] = _mm512_fmadd_ps(a[8], mul, add);
        a[9] = _mm512_fmadd_ps(a[9], mul, add); a[10] = _mm512_fmadd_ps(a[10], mul, add); a[11] = _mm512_fmadd_ps(a[11], mul, add);
    }
    for (c = 1; c < BENCH_CHAINS; c++) a[0] = _mm512_add_ps(a[0], a[c]);
    return _mm512_reduce_add_ps(a[0]);
}
#endif
/* the peak of the instruction the GEMMs multiply with when the compute is not f32: `vdpbf16ps zmm` (bf16 compute
   on the AVX-512 kernel: 16 lanes x 2 products, 64 flops), `vpdpbusd zmm` (int8 compute on the AVX-512 kernel:
   16 lanes x 4 products, 128 ops) or `vpdpbusd ymm` (int8 on the AVX2 kernel, AVX-VNNI: 64 ops); the same 12
   independent chains as the FMA peak. CPUs differ here more than in FMAs: Sapphire Rapids issues vdpbf16ps at
   half the FMA's rate (its 64 flops then no more than the FMA's 32), Zen 5 at nearly the full rate. None for
   f32 compute, AMX tiles (not measured) and builds or CPUs without the instruction. */
enum { BENCH_DOT_NONE, BENCH_DOT_BF16_ZMM, BENCH_DOT_VNNI_ZMM, BENCH_DOT_VNNI_YMM };
static const char *const bench_dot_name[] = {"none", "vdpbf16ps zmm", "vpdpbusd zmm", "vpdpbusd ymm"};
static const double bench_dot_ops[] = {0.0, 64.0, 128.0, 64.0};
#define BENCH_DOT_STEP(OP) \
    a0 = OP(a0); a1 = OP(a1); a2 = OP(a2); a3 = OP(a3); a4 = OP(a4); a5 = OP(a5); \
    a6 = OP(a6); a7 = OP(a7); a8 = OP(a8); a9 = OP(a9); a10 = OP(a10); a11 = OP(a11)
#if BENCH_HAS_AVX512
BENCH_AVX512BF16 static float bench_dot_bf16(long iters, float seed) {
    const __m512bh x = (__m512bh)_mm512_set1_epi32(0x3f7f3f7f), y = (__m512bh)_mm512_set1_epi32(0x33d633d6); /* 0.996, 1e-7 */
    __m512 a0 = _mm512_set1_ps(seed + 0.10f), a1 = _mm512_set1_ps(seed + 0.11f), a2 = _mm512_set1_ps(seed + 0.12f);
    __m512 a3 = _mm512_set1_ps(seed + 0.13f), a4 = _mm512_set1_ps(seed + 0.14f), a5 = _mm512_set1_ps(seed + 0.15f);
    __m512 a6 = _mm512_set1_ps(seed + 0.16f), a7 = _mm512_set1_ps(seed + 0.17f), a8 = _mm512_set1_ps(seed + 0.18f);
    __m512 a9 = _mm512_set1_ps(seed + 0.19f), a10 = _mm512_set1_ps(seed + 0.20f), a11 = _mm512_set1_ps(seed + 0.21f);
    long i;
#define BENCH_DOT_BF(v) _mm512_dpbf16_ps(v, x, y)
    for (i = 0; i < iters; i++) { BENCH_DOT_STEP(BENCH_DOT_BF); }
#undef BENCH_DOT_BF
    a0 = _mm512_add_ps(_mm512_add_ps(_mm512_add_ps(a0, a1), _mm512_add_ps(a2, a3)), _mm512_add_ps(_mm512_add_ps(a4, a5), _mm512_add_ps(a6, a7)));
    a0 = _mm512_add_ps(a0, _mm512_add_ps(_mm512_add_ps(a8, a9), _mm512_add_ps(a10, a11)));
    return _mm512_reduce_add_ps(a0);
}
BENCH_AVX512VNNI static float bench_dot_vnni512(long iters, float seed) {
    const __m512i x = _mm512_set1_epi32(0x01020304), y = _mm512_set1_epi32(0x01fe01fe);
    int s = (int)(seed * 1000.0f);
    __m512i a0 = _mm512_set1_epi32(s), a1 = _mm512_set1_epi32(s + 1), a2 = _mm512_set1_epi32(s + 2), a3 = _mm512_set1_epi32(s + 3);
    __m512i a4 = _mm512_set1_epi32(s + 4), a5 = _mm512_set1_epi32(s + 5), a6 = _mm512_set1_epi32(s + 6), a7 = _mm512_set1_epi32(s + 7);
    __m512i a8 = _mm512_set1_epi32(s + 8), a9 = _mm512_set1_epi32(s + 9), a10 = _mm512_set1_epi32(s + 10), a11 = _mm512_set1_epi32(s + 11);
    long i;
#define BENCH_DOT_VN(v) _mm512_dpbusd_epi32(v, x, y)
    for (i = 0; i < iters; i++) { BENCH_DOT_STEP(BENCH_DOT_VN); }
#undef BENCH_DOT_VN
    a0 = _mm512_add_epi32(_mm512_add_epi32(_mm512_add_epi32(a0, a1), _mm512_add_epi32(a2, a3)), _mm512_add_epi32(_mm512_add_epi32(a4, a5), _mm512_add_epi32(a6, a7)));
    a0 = _mm512_add_epi32(a0, _mm512_add_epi32(_mm512_add_epi32(a8, a9), _mm512_add_epi32(a10, a11)));
    { /* the lanes wrap (vector adds); summed as unsigned here, where a signed sum could overflow */
        uint32_t out[16], t = 0;
        _mm512_storeu_si512((void *)out, a0);
        for (s = 0; s < 16; s++) t += out[s];
        return (float)t;
    }
}
#endif
#if BENCH_HAS_AVXVNNI
BENCH_AVXVNNI static float bench_dot_vnni256(long iters, float seed) {
    const __m256i x = _mm256_set1_epi32(0x01020304), y = _mm256_set1_epi32(0x01fe01fe);
    int s = (int)(seed * 1000.0f);
    uint32_t out[8];
    __m256i a0 = _mm256_set1_epi32(s), a1 = _mm256_set1_epi32(s + 1), a2 = _mm256_set1_epi32(s + 2), a3 = _mm256_set1_epi32(s + 3);
    __m256i a4 = _mm256_set1_epi32(s + 4), a5 = _mm256_set1_epi32(s + 5), a6 = _mm256_set1_epi32(s + 6), a7 = _mm256_set1_epi32(s + 7);
    __m256i a8 = _mm256_set1_epi32(s + 8), a9 = _mm256_set1_epi32(s + 9), a10 = _mm256_set1_epi32(s + 10), a11 = _mm256_set1_epi32(s + 11);
    long i;
#define BENCH_DOT_VN(v) _mm256_dpbusd_avx_epi32(v, x, y)
    for (i = 0; i < iters; i++) { BENCH_DOT_STEP(BENCH_DOT_VN); }
#undef BENCH_DOT_VN
    a0 = _mm256_add_epi32(_mm256_add_epi32(_mm256_add_epi32(a0, a1), _mm256_add_epi32(a2, a3)), _mm256_add_epi32(_mm256_add_epi32(a4, a5), _mm256_add_epi32(a6, a7)));
    a0 = _mm256_add_epi32(a0, _mm256_add_epi32(_mm256_add_epi32(a8, a9), _mm256_add_epi32(a10, a11)));
    _mm256_storeu_si256((__m256i *)(void *)out, a0); /* summed as unsigned: the lanes wrap */
    return (float)(out[0] + out[1] + out[2] + out[3] + out[4] + out[5] + out[6] + out[7]);
}
#endif
#undef BENCH_DOT_STEP

/* which dot instruction a model's GEMMs multiply with (its kernel and compute, as supermat_model_get_info says) */
static int bench_dot_for(supermat_kernel kernel, supermat_compute compute) {
#if BENCH_HAS_AVX512
    if (compute == SUPERMAT_COMPUTE_BF16 && kernel == SUPERMAT_KERNEL_AVX512 && supermat_cpu().avx512_bf16) return BENCH_DOT_BF16_ZMM;
    if (compute == SUPERMAT_COMPUTE_INT8 && kernel == SUPERMAT_KERNEL_AVX512 && supermat_cpu().avx512_vnni) return BENCH_DOT_VNNI_ZMM;
#endif
#if BENCH_HAS_AVXVNNI
    if (compute == SUPERMAT_COMPUTE_INT8 && kernel == SUPERMAT_KERNEL_AVX2 && supermat_cpu().avx_vnni) return BENCH_DOT_VNNI_YMM;
#endif
    (void)kernel; (void)compute;
    return BENCH_DOT_NONE;
}

/* one peak probe: what it measures, and its calibration (each caller its own: nothing carries between calls
   but what the caller keeps in it) */
typedef struct bench_peak {
    int zmm;    /* the FMA peak with 512-bit FMAs (the pipeline runs the AVX-512 or AMX kernel); else 256-bit */
    int dot;    /* BENCH_DOT_*: the peak of that dot instruction instead of the FMA's */
    long iters; /* per task, calibrated by the first bench_peak_of (0: not yet) */
} bench_peak;

typedef struct bench_peak_job { long iters; float *sink; int dot, zmm; } bench_peak_job;

static void bench_peak_task(void *user, int index, int thread) {
    bench_peak_job *j = (bench_peak_job *)user;
    (void)thread;
#if BENCH_HAS_AVX512
    if (j->dot == BENCH_DOT_BF16_ZMM) { j->sink[index] = bench_dot_bf16(j->iters, (float)index * 1e-3f); return; }
    if (j->dot == BENCH_DOT_VNNI_ZMM) { j->sink[index] = bench_dot_vnni512(j->iters, (float)index * 1e-3f); return; }
#endif
#if BENCH_HAS_AVXVNNI
    if (j->dot == BENCH_DOT_VNNI_YMM) { j->sink[index] = bench_dot_vnni256(j->iters, (float)index * 1e-3f); return; }
#endif
#if BENCH_HAS_AVX512
    if (j->zmm) { j->sink[index] = bench_fma_loop512(j->iters, (float)index * 1e-3f); return; }
#endif
#if BENCH_HAS_AVX2
    j->sink[index] = bench_fma_loop(j->iters, (float)index * 1e-3f);
#else
    j->sink[index] = 0.0f;
#endif
}

/* GFLOP/s (GOP/s for a dot instruction), best of `reps` runs of about 0.2 s each (0 without AVX2): with hook
   NULL on the calling thread alone, else on every thread of the pool. p->iters calibrates on the first call. */
static double bench_peak_of(bench_peak *p, const supermat_threading *hook, int reps) {
    long *iters_per_task = &p->iters;
    int dot = p->dot;
    bench_peak_job job;
    int tasks = hook ? 8 * hook->max_threads : 8, rep;
    double best = 0.0, t;
    float sink[8 * 64];
    if (!supermat_cpu().avx2) return 0.0;
    job.sink = sink;
    job.dot = dot;
    job.zmm = p->zmm;
    if (*iters_per_task <= 0) { /* about 0.2 s per run for one thread doing all 8 x max_threads tasks / max_threads */
        job.iters = 1000000;
        t = bench_now();
        bench_peak_task(&job, 0, 0);
        t = bench_now() - t;
        *iters_per_task = (long)((t > 0 ? (double)job.iters / t : 1e9) * 0.2 / 8.0);
        if (*iters_per_task < 10000) *iters_per_task = 10000;
    }
    job.iters = *iters_per_task;
    for (rep = 0; rep < reps; rep++) {
        double gf;
        int i;
        t = bench_now();
        if (hook) hook->parallel_for(hook->user, tasks, bench_peak_task, &job);
        else for (i = 0; i < tasks; i++) bench_peak_task(&job, i, 0);
        t = bench_now() - t;
        gf = (double)tasks * (double)job.iters * BENCH_CHAINS * (dot ? bench_dot_ops[dot] : p->zmm ? 32.0 : 16.0) / t / 1e9;
        if (gf > best) best = gf;
    }
    return best;
}
