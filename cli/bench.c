/* cli/bench.c - `supermat bench`: FMA peak, the pipeline per stage, GEMM kernels; `bench --image`: the speed / memory levers against the f32 maps and the truth.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>bench */
/* (a) the FMA peak: independent chains of _mm256_fmadd_ps, 12 per iteration (2 FMA ports x 4 cycles of
   latency need 8 in flight), on every thread of the pool */
#define CLI_FMA_CHAINS 12
#if SUPERMAT__HAS_AVX2
SUPERMAT__AVX2 static float cli_fma_loop(long iters, float seed) {
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
#if SUPERMAT__HAS_AVX512
/* the same with 512-bit vectors: the peak of the AVX-512 kernel */
SUPERMAT__AVX512 static float cli_fma_loop512(long iters, float seed) {
    const __m512 mul = _mm512_set1_ps(0.99999f), add = _mm512_set1_ps(1e-6f);
    __m512 a[CLI_FMA_CHAINS];
    long i;
    int c;
    for (c = 0; c < CLI_FMA_CHAINS; c++) a[c] = _mm512_set1_ps(seed + 0.10f + 0.01f * (float)c);
    for (i = 0; i < iters; i++) {
        a[0] = _mm512_fmadd_ps(a[0], mul, add); a[1] = _mm512_fmadd_ps(a[1], mul, add); a[2] = _mm512_fmadd_ps(a[2], mul, add);
        a[3] = _mm512_fmadd_ps(a[3], mul, add); a[4] = _mm512_fmadd_ps(a[4], mul, add); a[5] = _mm512_fmadd_ps(a[5], mul, add);
        a[6] = _mm512_fmadd_ps(a[6], mul, add); a[7] = _mm512_fmadd_ps(a[7], mul, add); a[8] = _mm512_fmadd_ps(a[8], mul, add);
        a[9] = _mm512_fmadd_ps(a[9], mul, add); a[10] = _mm512_fmadd_ps(a[10], mul, add); a[11] = _mm512_fmadd_ps(a[11], mul, add);
    }
    for (c = 1; c < CLI_FMA_CHAINS; c++) a[0] = _mm512_add_ps(a[0], a[c]);
    return _mm512_reduce_add_ps(a[0]);
}
#endif
/* 1: the peak is measured with 512-bit FMAs (the pipeline runs the AVX-512 kernel) */
static int cli_fma_zmm;

/* the peak of the instruction the GEMMs multiply with when the compute is not f32: `vdpbf16ps zmm` (bf16 compute
   on the AVX-512 kernel: 16 lanes x 2 products, 64 flops), `vpdpbusd zmm` (int8 compute on the AVX-512 kernel:
   16 lanes x 4 products, 128 ops) or `vpdpbusd ymm` (int8 on the AVX2 kernel, AVX-VNNI: 64 ops); the same 12
   independent chains as the FMA peak. CPUs differ here more than in FMAs: Sapphire Rapids issues vdpbf16ps at
   half the FMA's rate (its 64 flops then no more than the FMA's 32), Zen 5 at nearly the full rate. None for
   f32 compute, AMX tiles (not measured) and builds or CPUs without the instruction. */
enum { CLI_DOT_NONE, CLI_DOT_BF16_ZMM, CLI_DOT_VNNI_ZMM, CLI_DOT_VNNI_YMM };
static int cli_dot_isa;
static const char *const cli_dot_name[] = {"none", "vdpbf16ps zmm", "vpdpbusd zmm", "vpdpbusd ymm"};
static const double cli_dot_ops[] = {0.0, 64.0, 128.0, 64.0};
#define CLI_DOT_STEP(OP) \
    a0 = OP(a0); a1 = OP(a1); a2 = OP(a2); a3 = OP(a3); a4 = OP(a4); a5 = OP(a5); \
    a6 = OP(a6); a7 = OP(a7); a8 = OP(a8); a9 = OP(a9); a10 = OP(a10); a11 = OP(a11)
#if SUPERMAT__HAS_AVX512
SUPERMAT__AVX512BF16 static float cli_dot_bf16(long iters, float seed) {
    const __m512bh x = (__m512bh)_mm512_set1_epi32(0x3f7f3f7f), y = (__m512bh)_mm512_set1_epi32(0x33d633d6); /* 0.996, 1e-7 */
    __m512 a0 = _mm512_set1_ps(seed + 0.10f), a1 = _mm512_set1_ps(seed + 0.11f), a2 = _mm512_set1_ps(seed + 0.12f);
    __m512 a3 = _mm512_set1_ps(seed + 0.13f), a4 = _mm512_set1_ps(seed + 0.14f), a5 = _mm512_set1_ps(seed + 0.15f);
    __m512 a6 = _mm512_set1_ps(seed + 0.16f), a7 = _mm512_set1_ps(seed + 0.17f), a8 = _mm512_set1_ps(seed + 0.18f);
    __m512 a9 = _mm512_set1_ps(seed + 0.19f), a10 = _mm512_set1_ps(seed + 0.20f), a11 = _mm512_set1_ps(seed + 0.21f);
    long i;
#define CLI_DOT_BF(v) _mm512_dpbf16_ps(v, x, y)
    for (i = 0; i < iters; i++) { CLI_DOT_STEP(CLI_DOT_BF); }
#undef CLI_DOT_BF
    a0 = _mm512_add_ps(_mm512_add_ps(_mm512_add_ps(a0, a1), _mm512_add_ps(a2, a3)), _mm512_add_ps(_mm512_add_ps(a4, a5), _mm512_add_ps(a6, a7)));
    a0 = _mm512_add_ps(a0, _mm512_add_ps(_mm512_add_ps(a8, a9), _mm512_add_ps(a10, a11)));
    return _mm512_reduce_add_ps(a0);
}
SUPERMAT__AVX512VNNI static float cli_dot_vnni512(long iters, float seed) {
    const __m512i x = _mm512_set1_epi32(0x01020304), y = _mm512_set1_epi32(0x01fe01fe);
    int s = (int)(seed * 1000.0f);
    __m512i a0 = _mm512_set1_epi32(s), a1 = _mm512_set1_epi32(s + 1), a2 = _mm512_set1_epi32(s + 2), a3 = _mm512_set1_epi32(s + 3);
    __m512i a4 = _mm512_set1_epi32(s + 4), a5 = _mm512_set1_epi32(s + 5), a6 = _mm512_set1_epi32(s + 6), a7 = _mm512_set1_epi32(s + 7);
    __m512i a8 = _mm512_set1_epi32(s + 8), a9 = _mm512_set1_epi32(s + 9), a10 = _mm512_set1_epi32(s + 10), a11 = _mm512_set1_epi32(s + 11);
    long i;
#define CLI_DOT_VN(v) _mm512_dpbusd_epi32(v, x, y)
    for (i = 0; i < iters; i++) { CLI_DOT_STEP(CLI_DOT_VN); }
#undef CLI_DOT_VN
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
#if SUPERMAT__HAS_AVXVNNI
SUPERMAT__AVXVNNI static float cli_dot_vnni256(long iters, float seed) {
    const __m256i x = _mm256_set1_epi32(0x01020304), y = _mm256_set1_epi32(0x01fe01fe);
    int s = (int)(seed * 1000.0f);
    uint32_t out[8];
    __m256i a0 = _mm256_set1_epi32(s), a1 = _mm256_set1_epi32(s + 1), a2 = _mm256_set1_epi32(s + 2), a3 = _mm256_set1_epi32(s + 3);
    __m256i a4 = _mm256_set1_epi32(s + 4), a5 = _mm256_set1_epi32(s + 5), a6 = _mm256_set1_epi32(s + 6), a7 = _mm256_set1_epi32(s + 7);
    __m256i a8 = _mm256_set1_epi32(s + 8), a9 = _mm256_set1_epi32(s + 9), a10 = _mm256_set1_epi32(s + 10), a11 = _mm256_set1_epi32(s + 11);
    long i;
#define CLI_DOT_VN(v) _mm256_dpbusd_avx_epi32(v, x, y)
    for (i = 0; i < iters; i++) { CLI_DOT_STEP(CLI_DOT_VN); }
#undef CLI_DOT_VN
    a0 = _mm256_add_epi32(_mm256_add_epi32(_mm256_add_epi32(a0, a1), _mm256_add_epi32(a2, a3)), _mm256_add_epi32(_mm256_add_epi32(a4, a5), _mm256_add_epi32(a6, a7)));
    a0 = _mm256_add_epi32(a0, _mm256_add_epi32(_mm256_add_epi32(a8, a9), _mm256_add_epi32(a10, a11)));
    _mm256_storeu_si256((__m256i *)(void *)out, a0); /* summed as unsigned: the lanes wrap */
    return (float)(out[0] + out[1] + out[2] + out[3] + out[4] + out[5] + out[6] + out[7]);
}
#endif
#undef CLI_DOT_STEP

/* which dot instruction a model's GEMMs multiply with (its kernel and compute, as supermat_model_get_info says) */
static int cli_dot_for(supermat_kernel kernel, supermat_compute compute) {
#if SUPERMAT__HAS_AVX512
    if (compute == SUPERMAT_COMPUTE_BF16 && kernel == SUPERMAT_KERNEL_AVX512 && supermat_cpu_has_avx512_bf16()) return CLI_DOT_BF16_ZMM;
    if (compute == SUPERMAT_COMPUTE_INT8 && kernel == SUPERMAT_KERNEL_AVX512 && supermat_cpu_has_avx512_vnni()) return CLI_DOT_VNNI_ZMM;
#endif
#if SUPERMAT__HAS_AVXVNNI
    if (compute == SUPERMAT_COMPUTE_INT8 && kernel == SUPERMAT_KERNEL_AVX2 && supermat_cpu_has_avx_vnni()) return CLI_DOT_VNNI_YMM;
#endif
    (void)kernel; (void)compute;
    return CLI_DOT_NONE;
}

typedef struct cli_fma_job { long iters; float *sink; int dot; /* CLI_DOT_*: a dot instruction instead of the FMA */ } cli_fma_job;

static void cli_fma_task(void *user, int index, int thread) {
    cli_fma_job *j = (cli_fma_job *)user;
    (void)thread;
#if SUPERMAT__HAS_AVX512
    if (j->dot == CLI_DOT_BF16_ZMM) { j->sink[index] = cli_dot_bf16(j->iters, (float)index * 1e-3f); return; }
    if (j->dot == CLI_DOT_VNNI_ZMM) { j->sink[index] = cli_dot_vnni512(j->iters, (float)index * 1e-3f); return; }
#endif
#if SUPERMAT__HAS_AVXVNNI
    if (j->dot == CLI_DOT_VNNI_YMM) { j->sink[index] = cli_dot_vnni256(j->iters, (float)index * 1e-3f); return; }
#endif
#if SUPERMAT__HAS_AVX512
    if (cli_fma_zmm) { j->sink[index] = cli_fma_loop512(j->iters, (float)index * 1e-3f); return; }
#endif
#if SUPERMAT__HAS_AVX2
    j->sink[index] = cli_fma_loop(j->iters, (float)index * 1e-3f);
#else
    j->sink[index] = 0.0f;
#endif
}

static void cli_serial_for(void *user, int count, supermat_task_fn task, void *task_user) {
    int i;
    (void)user;
    for (i = 0; i < count; i++) task(task_user, i, 0);
}

/* GFLOP/s, best of `reps` runs of about 0.2 s each (0 without AVX2): with hook NULL on the calling
   thread alone, else on every thread of the pool. *iters_per_task calibrates on the first call. */
static double cli_peak_of(const supermat_threading *hook, int reps, long *iters_per_task, int dot) {
    cli_fma_job job;
    int tasks = hook ? 8 * hook->max_threads : 8, rep;
    double best = 0.0, t;
    float sink[8 * 64];
    if (!supermat_cpu_has_avx2()) return 0.0;
    job.sink = sink;
    job.dot = dot;
    if (*iters_per_task <= 0) { /* about 0.2 s per run for one thread doing all 8 x max_threads tasks / max_threads */
        job.iters = 1000000;
        t = cli_now();
        cli_fma_task(&job, 0, 0);
        t = cli_now() - t;
        *iters_per_task = (long)((t > 0 ? (double)job.iters / t : 1e9) * 0.2 / 8.0);
        if (*iters_per_task < 10000) *iters_per_task = 10000;
    }
    job.iters = *iters_per_task;
    for (rep = 0; rep < reps; rep++) {
        double gf;
        int i;
        t = cli_now();
        if (hook) hook->parallel_for(hook->user, tasks, cli_fma_task, &job);
        else for (i = 0; i < tasks; i++) cli_fma_task(&job, i, 0);
        t = cli_now() - t;
        gf = (double)tasks * (double)job.iters * CLI_FMA_CHAINS * (dot ? cli_dot_ops[dot] : cli_fma_zmm ? 32.0 : 16.0) / t / 1e9;
        if (gf > best) best = gf;
    }
    return best;
}
static double cli_fma_peak(const supermat_threading *hook, int reps, long *iters_per_task) {
    return cli_peak_of(hook, reps, iters_per_task, CLI_DOT_NONE);
}

/* (b) the pipeline, timed between the run's inspection points */
#define CLI_MAX_EVENTS 64
typedef struct cli_event { double t; supermat_stage stage; int branch; } cli_event;
typedef struct cli_events { cli_event ev[CLI_MAX_EVENTS]; int n; } cli_events;

static void cli_inspect_cb(void *user, supermat_stage stage, int branch, float *data, int n, int h, int w, int c) {
    cli_events *e = (cli_events *)user;
    (void)data; (void)n; (void)h; (void)w; (void)c;
    if (e->n < CLI_MAX_EVENTS) {
        e->ev[e->n].t = cli_now();
        e->ev[e->n].stage = stage;
        e->ev[e->n].branch = branch;
        e->n++;
    }
}

#define CLI_MAX_ROWS 12
typedef struct cli_row { char name[48]; double seconds, flops; } cli_row;

static const char *cli_branch_name(const supermat_model_info *mi, int branch) {
    if (mi->kind == SUPERMAT_KIND_UV_REFINE) return "refined";
    if (mi->branches < 2) return "output";
    return branch == 0 ? "albedo" : branch == 1 ? "roughness/metallic" : "branch";
}

/* stage rows from one run's events: t0 = before supermat_run, t1 = after. Each row ends at an event.
   The UNet is the trunk (ends at TRUNK) and one tail per wanted branch (ends at its UNET_OUT); the
   branch's X0 event follows at once (x0 = coefficient x output, no time), so it ends no row. */
static int cli_rows(const cli_events *e, double t0, double t1, const supermat_flops *fl, const supermat_model_info *mi, cli_row *rows) {
    int n = 0, i, ndec = 0, nbranch = 0;
    double prev = t0;
    for (i = 0; i < e->n; i++) {
        if (e->ev[i].stage == SUPERMAT_STAGE_DECODED) ndec++;
        if (e->ev[i].stage == SUPERMAT_STAGE_UNET_OUT) nbranch++;
    }
    for (i = 0; i < e->n && n < CLI_MAX_ROWS - 1; i++) {
        const cli_event *v = &e->ev[i];
        cli_row *r = &rows[n];
        r->flops = 0.0;
        switch (v->stage) {
        case SUPERMAT_STAGE_INPUT: snprintf(r->name, sizeof r->name, "input (plan walk, to [-1,1])"); break;
        case SUPERMAT_STAGE_LATENT: snprintf(r->name, sizeof r->name, "vae encode"); r->flops = fl->encode; break;
        case SUPERMAT_STAGE_UNET_IN: snprintf(r->name, sizeof r->name, "unet input (mask, position)"); break;
        case SUPERMAT_STAGE_TRUNK: snprintf(r->name, sizeof r->name, "unet trunk"); r->flops = fl->trunk; break;
        case SUPERMAT_STAGE_UNET_OUT:
            snprintf(r->name, sizeof r->name, "unet branch %s", cli_branch_name(mi, v->branch));
            r->flops = nbranch ? fl->branch / nbranch : 0.0; /* the tails have one architecture */
            break;
        case SUPERMAT_STAGE_DECODED:
            snprintf(r->name, sizeof r->name, "vae decode %s", cli_branch_name(mi, v->branch));
            r->flops = ndec ? fl->decode / ndec : 0.0;
            break;
        default: continue; /* X0 */
        }
        r->seconds = v->t - prev;
        prev = v->t;
        n++;
    }
    snprintf(rows[n].name, sizeof rows[n].name, "write outputs");
    rows[n].seconds = t1 - prev; rows[n].flops = 0.0; n++;
    return n;
}

/* (c) one 3x3 convolution GEMM through the header's private supermat__conv2d on packed weights */
#define CLI_GEMM_HW 64
#define CLI_GEMM_C 320
typedef struct cli_gemm {
    supermat__conv cv;
    supermat__t in, out;
    float **scratch;
    float *scratch_mem;
    int threads;
} cli_gemm;

static uint32_t cli_rand(uint32_t *s) { *s = *s * 1664525u + 1013904223u; return *s >> 8; }

static int cli_gemm_init(cli_gemm *g, int threads) {
    int K = 9 * CLI_GEMM_C, N = CLI_GEMM_C, np = (N + SUPERMAT__NR - 1) / SUPERMAT__NR, n, k, i;
    size_t nin = (size_t)CLI_GEMM_HW * CLI_GEMM_HW * CLI_GEMM_C, sf = (size_t)SUPERMAT__MC * SUPERMAT__KC;
    uint32_t seed = 12345u;
    memset(g, 0, sizeof *g);
    g->threads = threads;
    g->cv.k = 3; g->cv.stride = 1; g->cv.cin = CLI_GEMM_C; g->cv.cout = CLI_GEMM_C;
    g->cv.w.K = K; g->cv.w.N = N;
    g->cv.w.p = (float *)calloc((size_t)np * SUPERMAT__NR * (size_t)K, sizeof(float));
    g->cv.w.bias = (float *)calloc((size_t)np * SUPERMAT__NR, sizeof(float));
    g->in.d = (float *)malloc(nin * sizeof(float));
    g->out.d = (float *)malloc(nin * sizeof(float));
    g->scratch = (float **)malloc(sizeof(float *) * (size_t)threads);
    g->scratch_mem = (float *)malloc(sizeof(float) * sf * (size_t)threads);
    if (!g->cv.w.p || !g->cv.w.bias || !g->in.d || !g->out.d || !g->scratch || !g->scratch_mem) return CLI_FAIL;
    for (i = 0; i < threads; i++) g->scratch[i] = g->scratch_mem + sf * (size_t)i;
    /* W[n][k] packed as panel n/16, row k, column n%16 (K = (ky*3 + kx)*Cin + ci, the model's order) */
    for (n = 0; n < N; n++) {
        g->cv.w.bias[n] = (float)(cli_rand(&seed) % 2001u) * 1e-4f - 0.1f;
        for (k = 0; k < K; k++)
            g->cv.w.p[((size_t)(n / SUPERMAT__NR) * K + k) * SUPERMAT__NR + n % SUPERMAT__NR] = (float)(cli_rand(&seed) % 2001u) * 1e-5f - 0.01f;
    }
    for (i = 0; i < (int)nin; i++) g->in.d[i] = (float)(cli_rand(&seed) % 2001u) * 1e-3f - 1.0f;
    g->in.n = g->out.n = 1;
    g->in.h = g->out.h = CLI_GEMM_HW;
    g->in.w = g->out.w = CLI_GEMM_HW;
    g->in.c = g->out.c = CLI_GEMM_C;
    return CLI_OK;
}

static void cli_gemm_free(cli_gemm *g) {
    free(g->cv.w.p); free(g->cv.w.bias); free(g->in.d); free(g->out.d); free(g->scratch); free(g->scratch_mem);
}

/* best seconds of a few runs (at least one, more while under `budget` seconds) */
static double cli_gemm_time(cli_gemm *g, supermat__ukr_fn ukr, int mr, const supermat_threading *hook, double budget, float *copy) {
    supermat__ctx X;
    double best = 1e30, spent = 0.0;
    int runs = 0;
    memset(&X, 0, sizeof X);
    X.ukr = ukr;
    X.mr = mr;
    X.thr = *hook;
    X.scratch = g->scratch;
    X.scratch_floats = (size_t)SUPERMAT__MC * SUPERMAT__KC;
    while (runs < 1 || (spent < budget && runs < 10)) {
        double t = cli_now();
        X.status = SUPERMAT_SUCCESS;
        supermat__conv2d(&X, &g->in, g->in.h, g->in.w, &g->cv, 0, &g->out, NULL, NULL);
        t = cli_now() - t;
        if (X.status != SUPERMAT_SUCCESS) return -1.0;
        if (t < best) best = t;
        spent += t;
        runs++;
    }
    if (copy) memcpy(copy, g->out.d, sizeof(float) * (size_t)g->out.h * g->out.w * g->out.c);
    return best;
}

static void cli_json_string(FILE *f, const char *s) {
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') fprintf(f, "\\%c", c);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

static size_t cli_peak_rss(void) {
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
#ifdef __APPLE__
    return (size_t)ru.ru_maxrss;
#else
    return (size_t)ru.ru_maxrss * 1024u;
#endif
}
/* >>benchimage */
/* `supermat bench --image`: each mode (one speed / memory lever) runs on the same real input; the f32
   mode is the reference every other mode's float maps are compared with. */
enum {
    CLI_MODE_F32, CLI_MODE_F16, CLI_MODE_BF16, CLI_MODE_INT8, CLI_MODE_WINOGRAD_F2, CLI_MODE_WINOGRAD_F4,
    CLI_MODE_TILED_VAE, CLI_MODE_FOREGROUND, CLI_MODE_BRANCH_ALBEDO, CLI_MODE_BRANCH_RM, CLI_MODE_RES256,
    CLI_MODE_RES384, CLI_MODE_RES512, CLI_MODE_RES768, CLI_MODE_MV_WINDOW_OWN, CLI_MODE_MV_WINDOW_STRIDE4,
    CLI_MODE_BF16_COMPUTE, CLI_MODE_KERNEL_AVX2, CLI_MODE_BF16_AMX, CLI_MODE_BF16_AMX_WF4,
    CLI_MODE_INT8_COMPUTE, CLI_MODE_INT8_COMPUTE_WF4, CLI_MODE_INT8_COMPUTE_AVX2,
    CLI_MODE_COUNT
};
/* the model kinds a mode applies to */
#define CLI_KS 1u  /* supermat */
#define CLI_KMV 2u /* supermat-mv */
#define CLI_KUV 4u /* uv-refine */
static const struct { const char *name; unsigned kinds; } cli_modes[CLI_MODE_COUNT] = {
    {"f32", CLI_KS | CLI_KMV | CLI_KUV},         {"f16", CLI_KS | CLI_KMV | CLI_KUV},
    {"bf16", CLI_KS | CLI_KMV | CLI_KUV},        {"int8", CLI_KS | CLI_KMV | CLI_KUV},
    {"winograd_f2", CLI_KS | CLI_KMV | CLI_KUV}, {"winograd_f4", CLI_KS | CLI_KMV | CLI_KUV},
    {"tiled_vae", CLI_KS | CLI_KMV | CLI_KUV},   {"foreground", CLI_KS | CLI_KMV | CLI_KUV},
    {"branch_albedo", CLI_KS | CLI_KMV},         {"branch_rm", CLI_KS | CLI_KMV},
    {"res256", CLI_KS | CLI_KMV},                {"res384", CLI_KS | CLI_KMV},
    {"res512", CLI_KUV},                         {"res768", CLI_KUV},
    {"mv_window_own", CLI_KMV},                  {"mv_window_stride4", CLI_KMV},
    {"bf16_compute", CLI_KS | CLI_KMV | CLI_KUV}, {"kernel_avx2", CLI_KS | CLI_KMV | CLI_KUV},
    {"bf16_amx", CLI_KS | CLI_KMV | CLI_KUV},     {"bf16_amx_wf4", CLI_KS | CLI_KMV | CLI_KUV},
    {"int8_compute", CLI_KS | CLI_KMV | CLI_KUV}, {"int8_compute_wf4", CLI_KS | CLI_KMV | CLI_KUV},
    {"int8_compute_avx2", CLI_KS | CLI_KMV | CLI_KUV},
};
/* set by cli_mode_setup: the mode's compute and kernel (-1: the run's own kernel) */
static supermat_compute cli_mode_compute;
static int cli_mode_kernel = -1;

static unsigned cli_kind_bit(supermat_model_kind k) {
    return k == SUPERMAT_KIND_SUPERMAT ? CLI_KS : k == SUPERMAT_KIND_SUPERMAT_MV ? CLI_KMV : k == SUPERMAT_KIND_UV_REFINE ? CLI_KUV : 0u;
}

/* --modes: "all" (*n = 0 and *all = 1) or a comma list of names, in the order given, without repeats */
static int cli_parse_modes(const char *cmd, const char *s, int *list, int *n, int *all) {
    const char *p = s;
    int seen[CLI_MODE_COUNT], k;
    memset(seen, 0, sizeof seen);
    *n = 0; *all = 0;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == 3 && !strncmp(p, "all", 3)) *all = 1;
        else if (len != 0) {
            for (k = 0; k < CLI_MODE_COUNT; k++)
                if (strlen(cli_modes[k].name) == len && !strncmp(p, cli_modes[k].name, len)) break;
            if (k == CLI_MODE_COUNT) {
                char names[1000];
                size_t used = 0;
                int j;
                names[0] = 0;
                for (j = 0; j < CLI_MODE_COUNT && used < sizeof names; j++)
                    used += (size_t)snprintf(names + used, sizeof names - used, "%s%s", j ? ", " : "", cli_modes[j].name);
                cli_usage_error(cmd, "--modes: unknown mode '%.*s' (all, or a comma list of: %s)", (int)len, p, names);
                return -1;
            }
            if (!seen[k]) { seen[k] = 1; list[(*n)++] = k; }
        }
        p += len;
        if (*p == ',') p++;
    }
    if (!*all && !*n) { cli_usage_error(cmd, "--modes: empty list"); return -1; }
    return 0;
}

/* what one mode changes: the model (weights, conv), the outputs and the session levers. Returns 0,
   or 1 if the mode does not apply to this image (a resolution not below the image's), with `why`. */
static int cli_mode_setup(int mode, int w, int h, supermat_weights *weights, supermat_conv *conv, unsigned *outputs,
                          supermat_session_desc *sd, char *why, size_t why_cap) {
    int S = w > h ? w : h, t, R = 0;
    *weights = SUPERMAT_WEIGHTS_F32;
    *conv = SUPERMAT_CONV_DIRECT;
    *outputs = SUPERMAT_OUTPUT_ALL;
    cli_mode_compute = SUPERMAT_COMPUTE_F32;
    cli_mode_kernel = -1;
    switch (mode) {
    case CLI_MODE_BF16_COMPUTE: /* vdpbf16ps on the AVX-512 kernel */
        if (!supermat_cpu_has_avx512_bf16()) { snprintf(why, why_cap, "this CPU (or build) has no AVX512_BF16"); return 1; }
        cli_mode_compute = SUPERMAT_COMPUTE_BF16;
        cli_mode_kernel = SUPERMAT_KERNEL_AVX512;
        break;
    case CLI_MODE_BF16_AMX_WF4: /* AMX for the GEMMs of bf16 weights, Winograd F4 (f32) for the 3x3 convolutions */
        *conv = SUPERMAT_CONV_WINOGRAD_F4;
        /* fall through */
    case CLI_MODE_BF16_AMX:
        if (!supermat_cpu_has_amx_bf16()) { snprintf(why, why_cap, "this CPU (OS or build) has no AMX-BF16"); return 1; }
        cli_mode_compute = SUPERMAT_COMPUTE_BF16;
        cli_mode_kernel = SUPERMAT_KERNEL_AMX;
        break;
    case CLI_MODE_INT8_COMPUTE_WF4: /* int8 compute for the GEMMs, Winograd F4 (f32) for the 3x3 convolutions */
        *conv = SUPERMAT_CONV_WINOGRAD_F4;
        /* fall through */
    case CLI_MODE_INT8_COMPUTE: /* vpdpbusd on the AVX-512 kernel (AVX512_VNNI), else on the AVX2 one (AVX-VNNI) */
        if (!supermat_cpu_has_avx512_vnni() && !supermat_cpu_has_avx_vnni()) {
            snprintf(why, why_cap, "this CPU (or build) has neither AVX512_VNNI nor AVX-VNNI");
            return 1;
        }
        cli_mode_compute = SUPERMAT_COMPUTE_INT8;
        cli_mode_kernel = supermat_cpu_has_avx512_vnni() ? SUPERMAT_KERNEL_AVX512 : SUPERMAT_KERNEL_AVX2;
        break;
    case CLI_MODE_INT8_COMPUTE_AVX2: /* beside int8_compute on AVX512_VNNI: the 256-bit AVX-VNNI kernel, the same bits */
        if (!supermat_cpu_has_avx_vnni()) { snprintf(why, why_cap, "this CPU (or build) has no AVX-VNNI"); return 1; }
        if (!supermat_cpu_has_avx512_vnni()) { snprintf(why, why_cap, "int8_compute already runs the AVX-VNNI kernel"); return 1; }
        cli_mode_compute = SUPERMAT_COMPUTE_INT8;
        cli_mode_kernel = SUPERMAT_KERNEL_AVX2;
        break;
    case CLI_MODE_KERNEL_AVX2: /* beside the f32 row's AVX-512 kernel: the same bits, the time of the narrower one */
        if (!supermat_cpu_has_avx512()) { snprintf(why, why_cap, "the f32 row already runs the AVX2 (or scalar) kernel"); return 1; }
        cli_mode_kernel = SUPERMAT_KERNEL_AVX2;
        break;
    case CLI_MODE_F16: *weights = SUPERMAT_WEIGHTS_F16; break;
    case CLI_MODE_BF16: *weights = SUPERMAT_WEIGHTS_BF16; break;
    case CLI_MODE_INT8: *weights = SUPERMAT_WEIGHTS_I8; break;
    case CLI_MODE_WINOGRAD_F2: *conv = SUPERMAT_CONV_WINOGRAD_F2; break;
    case CLI_MODE_WINOGRAD_F4: *conv = SUPERMAT_CONV_WINOGRAD_F4; break;
    case CLI_MODE_TILED_VAE: /* 2x2 tiles */
        t = ((S / 8 + 4) / 2) * 8;
        sd->vae_tile = t < 40 ? 40 : t; /* larger than the overlap */
        sd->vae_overlap = 32;
        break;
    case CLI_MODE_FOREGROUND:
        t = (S / 4 + 16 + 7) / 8 * 8;
        sd->vae_tile = t < 32 ? 32 : t;
        sd->vae_overlap = 16;
        sd->skip_background = 1;
        break;
    case CLI_MODE_BRANCH_ALBEDO: *outputs = SUPERMAT_OUTPUT_ALBEDO; break;
    case CLI_MODE_BRANCH_RM: *outputs = SUPERMAT_OUTPUT_ROUGHNESS | SUPERMAT_OUTPUT_METALLIC; break;
    case CLI_MODE_RES256: R = 256; break;
    case CLI_MODE_RES384: R = 384; break;
    case CLI_MODE_RES512: R = 512; break;
    case CLI_MODE_RES768: R = 768; break;
    case CLI_MODE_MV_WINDOW_OWN: sd->mv_attention = SUPERMAT_MV_ATTENTION_OWN_VIEW; break;
    case CLI_MODE_MV_WINDOW_STRIDE4: sd->mv_attention = SUPERMAT_MV_ATTENTION_STRIDED; sd->mv_key_stride = 4; break;
    default: break;
    }
    if (R) {
        int ww, hh;
        if (R >= S) {
            snprintf(why, why_cap, "the network size %d is not below the image's %dx%d", R, w, h);
            return 1;
        }
        /* the longer side R, the other in proportion, both multiples of 8 */
        ww = (int)floor((double)w * R / S / 8.0 + 0.5) * 8;
        hh = (int)floor((double)h * R / S / 8.0 + 0.5) * 8;
        sd->work_width = ww < 8 ? 8 : ww;
        sd->work_height = hh < 8 ? 8 : hh;
    }
    return 0;
}

/* this machine's CPU name (Linux /proc/cpuinfo), or "" */
static void cli_cpu_name(char *buf, size_t cap) {
    FILE *f = fopen("/proc/cpuinfo", "r");
    char line[512];
    buf[0] = 0;
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        if (!strncmp(line, "model name", 10)) {
            char *c = strchr(line, ':'), *e;
            if (c) {
                c++;
                while (*c == ' ' || *c == '\t') c++;
                e = c + strlen(c);
                while (e > c && (e[-1] == '\n' || e[-1] == '\r' || e[-1] == ' ')) *--e = 0;
                snprintf(buf, cap, "%s", c);
            }
            break;
        }
    }
    fclose(f);
}

/* the input of every mode */
typedef struct cli_bi_input {
    supermat_model_kind kind;
    int w, h, nviews, nmaps;         /* nmaps: 3 (albedo, roughness, metallic) or 1 (refined) */
    size_t np;                       /* pixels per view */
    supermat_image *in;              /* nviews inputs (one buffer repeated for synthetic views) */
    const float *c2w;                /* supermat-mv: nviews x 16 */
    unsigned char *mask, *pos;       /* uv-refine */
    unsigned char *fg;               /* nviews x np: 1 = foreground (alpha > 0; uv-refine: mask > 0.5) */
    supermat_image *ov[3];           /* supermat-mv: per-view output images, pointed at the buffers per run */
    unsigned char *truth[3];         /* supermat: the --truth-* maps (8-bit, np x 3 / np x 1), NULL = not given */
    unsigned char *gt_mask;          /* with a truth: 1 = an object pixel (input alpha >= 128) */
    size_t gt_n;                     /* object pixels */
    int any_truth;
} cli_bi_input;

static const char *const cli_bi_map_names[3] = {"albedo", "roughness", "metallic"};
static int cli_bi_channels(const cli_bi_input *in, int k) { return in->nmaps == 1 ? 3 : cli_map_channels[k]; }
static const char *cli_bi_map_name(const cli_bi_input *in, int k) { return in->nmaps == 1 ? "refined" : cli_bi_map_names[k]; }
static int cli_bi_wants(const cli_bi_input *in, unsigned outputs, int k) {
    return in->nmaps == 1 ? 1 : (outputs & (1u << k)) != 0; /* SUPERMAT_OUTPUT_ALBEDO = 1, ROUGHNESS = 2, METALLIC = 4 */
}

/* one run into maps[k] (float32, views one after the other), maps[k] NULL = not wanted */
static supermat_result cli_bi_run(supermat_session *s, const cli_bi_input *in, float *const *maps, supermat_error *err) {
    supermat_run_desc rd;
    int k, v;
    memset(&rd, 0, sizeof rd);
    rd.input = in->in[0];
    if (in->kind == SUPERMAT_KIND_UV_REFINE) {
        rd.mask.pixels = in->mask; rd.mask.width = in->w; rd.mask.height = in->h; rd.mask.channels = 1;
        rd.position.pixels = in->pos; rd.position.width = in->w; rd.position.height = in->h; rd.position.channels = 3;
        rd.refined.pixels = maps[0]; rd.refined.channels = 3; rd.refined.format = SUPERMAT_FORMAT_F32;
    } else if (in->kind == SUPERMAT_KIND_SUPERMAT_MV) {
        rd.input_views = in->in;
        rd.cameras = in->c2w;
        for (k = 0; k < 3; k++) {
            if (!maps[k]) continue;
            for (v = 0; v < in->nviews; v++) {
                supermat_image *o = &in->ov[k][v];
                memset(o, 0, sizeof *o);
                o->pixels = maps[k] + in->np * (size_t)cli_map_channels[k] * (size_t)v;
                o->channels = cli_map_channels[k];
                o->format = SUPERMAT_FORMAT_F32;
            }
        }
        rd.albedo_views = maps[0] ? in->ov[0] : NULL;
        rd.roughness_views = maps[1] ? in->ov[1] : NULL;
        rd.metallic_views = maps[2] ? in->ov[2] : NULL;
    } else {
        supermat_image *o[3];
        o[0] = &rd.albedo; o[1] = &rd.roughness; o[2] = &rd.metallic;
        for (k = 0; k < 3; k++) {
            if (!maps[k]) continue;
            o[k]->pixels = maps[k]; o[k]->channels = cli_map_channels[k]; o[k]->format = SUPERMAT_FORMAT_F32;
        }
    }
    return supermat_run(s, &rd, err);
}

#define CLI_PSNR_CAP 200.0
typedef struct cli_bi_row {
    int mode, done;
    double seconds, speedup, flops;
    size_t peak_bytes;
    int has[3], has_fg[3], has_gt[3];
    double psnr[3], psnr_fg[3], max_abs[3], gt_psnr[3];
} cli_bi_row;

static double cli_psnr(double sse, double n) {
    double mse = sse / n, p;
    if (mse != mse) return mse; /* NaN: shown as nan, written as null */
    if (!(mse > 0.0)) return CLI_PSNR_CAP;
    p = 10.0 * log10(1.0 / mse);
    return p > CLI_PSNR_CAP ? CLI_PSNR_CAP : p;
}

/* PSNR (all pixels, foreground pixels) and max abs error of map k against the reference */
static void cli_bi_compare(const cli_bi_input *in, int k, const float *ref, const float *got, cli_bi_row *row) {
    int c = cli_bi_channels(in, k), j;
    size_t n = in->np * (size_t)in->nviews, p, nfg = 0;
    double sse = 0.0, sse_fg = 0.0, mx = 0.0;
    for (p = 0; p < n; p++) {
        double s = 0.0;
        for (j = 0; j < c; j++) {
            double d = (double)got[p * (size_t)c + (size_t)j] - (double)ref[p * (size_t)c + (size_t)j], a = fabs(d);
            s += d * d;
            if (a > mx || a != a) mx = a; /* a NaN shows */
        }
        sse += s;
        if (in->fg[p]) { sse_fg += s; nfg++; }
    }
    row->has[k] = 1;
    row->psnr[k] = cli_psnr(sse, (double)n * c);
    row->max_abs[k] = mx;
    row->has_fg[k] = nfg > 0;
    row->psnr_fg[k] = nfg ? cli_psnr(sse_fg, (double)nfg * c) : 0.0;
}

/* PSNR of map k against its truth file: the map quantised as `supermat image` writes it (cli_quantize),
   over the object's pixels and the map's channels, values / 255. A NaN in the map gives NaN. */
static void cli_bi_compare_truth(const cli_bi_input *in, int k, const float *got, cli_bi_row *row) {
    int c = cli_map_channels[k], j, nan = 0;
    const unsigned char *t = in->truth[k];
    size_t p;
    uint64_t sse = 0;
    for (p = 0; p < in->np; p++) {
        if (!in->gt_mask[p]) continue;
        for (j = 0; j < c; j++) {
            size_t at = p * (size_t)c + (size_t)j;
            int d;
            if (got[at] != got[at]) { nan = 1; continue; }
            d = (int)cli_quantize(got[at]) - (int)t[at];
            sse += (uint64_t)(d * d);
        }
    }
    row->has_gt[k] = 1;
    row->gt_psnr[k] = nan ? (double)NAN : cli_psnr((double)sse / (255.0 * 255.0), (double)in->gt_n * c);
}

static double cli_bi_peak; /* this machine's FMA peak (GFLOP/s) measured at the start, 0 = unknown */
static void cli_bi_print_header(const cli_bi_input *in) {
    int k;
    printf("%-18s %9s %8s %9s %9s %8s %6s", "", "", "", "", "", "", "");
    for (k = 0; k < in->nmaps; k++) printf(" | %-*s", in->any_truth ? 33 : 25, cli_bi_map_name(in, k));
    printf("\n%-18s %9s %8s %9s %9s %8s %6s", "mode", "seconds", "speedup", "peak MiB", "GFLOP", "GFLOP/s", "%peak");
    for (k = 0; k < in->nmaps; k++) {
        printf(" | %7s %7s %9s", "psnr", "psnr_fg", "max_abs");
        if (in->any_truth) printf(" %7s", "gt_psnr");
    }
    printf("\n");
}

static void cli_bi_print_row(const cli_bi_input *in, const cli_bi_row *r) {
    int k;
    double gf = r->seconds > 0 ? r->flops / r->seconds / 1e9 : 0.0;
    printf("%-18s %9.4f %7.2fx %9.1f %9.3f %8.2f", cli_modes[r->mode].name, r->seconds, r->speedup, cli_mib((double)r->peak_bytes),
           r->flops / 1e9, gf);
    if (cli_bi_peak > 0) printf(" %5.1f%%", 100.0 * gf / cli_bi_peak);
    else printf(" %6s", "-");
    for (k = 0; k < in->nmaps; k++) {
        if (!r->has[k]) printf(" | %7s %7s %9s", "-", "-", "-");
        else {
            printf(" | %7.2f", r->psnr[k]);
            if (r->has_fg[k]) printf(" %7.2f", r->psnr_fg[k]);
            else printf(" %7s", "-");
            printf(" %9.3e", r->max_abs[k]);
        }
        if (!in->any_truth) continue;
        if (r->has_gt[k]) printf(" %7.2f", r->gt_psnr[k]);
        else printf(" %7s", "-");
    }
    printf("\n");
    fflush(stdout);
}

static void cli_json_number_or_null(FILE *f, int has, double v) {
    if (has && v == v && v - v == 0.0) fprintf(f, "%.6g", v);
    else fputs("null", f);
}

/* writes and closes f (opened before the runs, so that a bad path fails at once) */
static int cli_bi_write_json(FILE *f, const char *path, const cli_bi_input *in, const cli_bi_row *rows, int nrows) {
    int i, k, q, first = 1;
    static const char *const groups[4] = {"psnr", "psnr_fg", "max_abs", "gt_psnr"};
    fputs("[\n", f);
    for (i = 0; i < nrows; i++) {
        const cli_bi_row *r = &rows[i];
        if (!r->done) continue;
        fprintf(f, "%s  {\"mode\": \"%s\", \"seconds\": %.6g, \"speedup\": %.6g, \"peak_bytes\": %llu, \"flops\": %.6g", first ? "" : ",\n",
                cli_modes[r->mode].name, r->seconds, r->speedup, (unsigned long long)r->peak_bytes, r->flops);
        fputs(", \"fma_peak_gflops\": ", f);
        cli_json_number_or_null(f, cli_bi_peak > 0, cli_bi_peak);
        fputs(", \"fraction_of_peak\": ", f);
        cli_json_number_or_null(f, cli_bi_peak > 0 && r->seconds > 0, r->seconds > 0 ? r->flops / r->seconds / 1e9 / cli_bi_peak : 0.0);
        first = 0;
        for (q = 0; q < 4; q++) {
            fprintf(f, ", \"%s\": {", groups[q]);
            for (k = 0; k < in->nmaps; k++) {
                fprintf(f, "%s\"%s\": ", k ? ", " : "", cli_bi_map_name(in, k));
                if (q == 0) cli_json_number_or_null(f, r->has[k], r->psnr[k]);
                else if (q == 1) cli_json_number_or_null(f, r->has[k] && r->has_fg[k], r->psnr_fg[k]);
                else if (q == 2) cli_json_number_or_null(f, r->has[k], r->max_abs[k]);
                else cli_json_number_or_null(f, r->has_gt[k], r->gt_psnr[k]);
            }
            fputc('}', f);
        }
        fputc('}', f);
    }
    fputs(first ? "]\n" : "\n]\n", f);
    if (ferror(f) | (fclose(f) != 0)) { cli_error("cannot write '%s'", path); return CLI_FAIL; }
    return CLI_OK;
}

typedef struct cli_bench_opts {
    const char *model_path, *json_path, *mask_path, *pos_path, *cam_path;
    const char *truth_paths[3];      /* --truth-albedo, --truth-roughness, --truth-metallic (NULL = not given) */
    const char *images[CLI_MAX_VIEWS];
    int nimg, views, threads, repeats, nmodes, modes_all;
    int modes[CLI_MODE_COUNT];
    supermat_kernel kernel;
} cli_bench_opts;

static supermat_result cli_bi_model(const unsigned char *buf, size_t size, supermat_kernel kernel, supermat_weights weights,
                                    supermat_conv conv, supermat_model **model, supermat_error *err) {
    supermat_model_desc md;
    memset(&md, 0, sizeof md);
    md.data = buf; md.size = size; md.kernel = cli_mode_kernel >= 0 ? (supermat_kernel)cli_mode_kernel : kernel; md.weights = weights;
    md.conv = conv; md.compute = cli_mode_compute;
    return supermat_model_create(&md, model, err);
}

static int cli_bench_image(const cli_bench_opts *o) {
    const char *path0 = o->images[0];
    int i, k, v, rc = CLI_OK, w = 0, h = 0, nviews = 1, ncam = 0, nrows = 0, failed = 0, order[CLI_MODE_COUNT], norder = 0;
    unsigned char *file = NULL, *px[CLI_MAX_VIEWS];
    size_t file_size = 0, nout[3] = {0, 0, 0};
    supermat_model *base = NULL;
    supermat_model_info mi;
    supermat_error err;
    supermat_result r;
    supermat_pool *pool = NULL;
    supermat_threading hook;
    cli_bi_input in;
    cli_camera *cams = NULL;
    float *c2w = NULL, *ref[3] = {NULL, NULL, NULL}, *cur[3] = {NULL, NULL, NULL};
    cli_bi_row rows[CLI_MODE_COUNT];
    char skipped[CLI_MODE_COUNT][160], cpu[256];
    int nskipped = 0, skipped_mode[CLI_MODE_COUNT];
    double f32_seconds = 0.0;
    FILE *jf = NULL;
    cli_mem jm;

    memset(px, 0, sizeof px);
    memset(&in, 0, sizeof in);
    memset(&mi, 0, sizeof mi);
    memset(rows, 0, sizeof rows);
    memset(&hook, 0, sizeof hook);

    /* the images' sizes before the (slow) model load */
    for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
        int iw, ih, c;
        if (!cli_pic_info(o->images[i], "image", &iw, &ih, &c, 0)) { rc = CLI_FAIL; break; }
        if (i == 0) { w = iw; h = ih; }
        if (iw != w || ih != h) {
            cli_error("image '%s' is %dx%d but image '%s' is %dx%d: all views must have the same size (supermat does not resize)",
                      o->images[i], iw, ih, path0, w, h);
            rc = CLI_FAIL;
        } else if (w % 8 || h % 8) {
            cli_error("image '%s' is %dx%d: width and height must both be multiples of 8 (supermat does not resize; "
                      "resize it first, e.g. to 512x512)", o->images[i], w, h);
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < 2 && rc == CLI_OK; i++) {
        const char *p = i ? o->pos_path : o->mask_path, *what = i ? "the position map" : "the mask";
        int iw, ih, c;
        if (!p) continue;
        if (!cli_pic_info(p, what, &iw, &ih, &c, 0)) { rc = CLI_FAIL; break; }
        if (iw != w || ih != h) {
            cli_error("%s '%s' is %dx%d but the map '%s' is %dx%d: the map, the mask and the position map must have the same "
                      "size (supermat does not resize)", what, p, iw, ih, path0, w, h);
            rc = CLI_FAIL;
        }
    }
    for (k = 0; k < 3 && rc == CLI_OK; k++) { /* the truth files: readable, 8-bit, the image's size, colour / gray */
        const char *p = o->truth_paths[k];
        int iw, ih, c;
        if (!p) continue;
        in.any_truth = 1;
        char what[64];
        int ok, keep16 = cli_accept16;
        snprintf(what, sizeof what, "the %s truth", cli_bi_map_names[k]);
        cli_accept16 = 1; /* a 16-bit truth is refused below, with its reason */
        ok = cli_pic_info(p, what, &iw, &ih, &c, 0);
        cli_accept16 = keep16;
        if (!ok) {
            rc = CLI_FAIL;
        } else if (iw != w || ih != h) {
            cli_error("the %s truth '%s' is %dx%d but the image '%s' is %dx%d: a truth map must have the image's size "
                      "(supermat does not resize)", cli_bi_map_names[k], p, iw, ih, path0, w, h);
            rc = CLI_FAIL;
        } else if (cli_pic_is16) {
            cli_error("the %s truth '%s' has 16 bits per channel: give an 8-bit PNG (the maps are compared as "
                      "`supermat image` writes them, 8-bit)", cli_bi_map_names[k], p);
            rc = CLI_FAIL;
        } else if (k == 0 ? c < 3 : c > 2) {
            cli_error("the %s truth '%s' is %s: give an 8-bit %s PNG", cli_bi_map_names[k], p,
                      c <= 2 ? "gray" : "in colour", k == 0 ? "RGB (sRGB)" : "gray");
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK && o->json_path) {
        jf = cli_mem_open(&jm, o->json_path);
        if (!jf) rc = CLI_FAIL;
    }

    /* the reference model, and what the inputs must be for its kind */
    if (rc == CLI_OK) rc = cli_read_file(o->model_path, &file, &file_size);
    if (rc == CLI_OK) {
        r = cli_bi_model(file, file_size, o->kernel, SUPERMAT_WEIGHTS_F32, SUPERMAT_CONV_DIRECT, &base, &err);
        if (r != SUPERMAT_SUCCESS) {
            char what[600];
            snprintf(what, sizeof what, "model '%s'", o->model_path);
            cli_lib_error(what, r, &err);
            rc = CLI_FAIL;
        } else supermat_model_get_info(base, &mi);
    }
    if (rc == CLI_OK) {
        const char *kn = cli_kind_name(mi.kind);
        in.kind = mi.kind;
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) {
            if (o->nimg != 1 || !o->mask_path || !o->pos_path) {
                cli_error("model '%s' is a uv-refine model: give one --image MAP with --mask MASK and --position POS", o->model_path);
                rc = CLI_FAIL;
            }
        } else if (o->mask_path || o->pos_path) {
            cli_error("--mask and --position are for a uv-refine model; model '%s' is a %s model", o->model_path, kn);
            rc = CLI_FAIL;
        }
        if (rc == CLI_OK && in.any_truth && mi.kind != SUPERMAT_KIND_SUPERMAT) {
            cli_error("--truth-albedo, --truth-roughness and --truth-metallic are for a supermat model (one image); "
                      "model '%s' is a %s model", o->model_path, kn);
            rc = CLI_FAIL;
        }
        if (rc == CLI_OK && mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            if (o->nimg > 1 && !o->cam_path) {
                cli_error("%d views: give their cameras with --cameras meta.json (one --image without cameras is repeated as "
                          "--views views on a circle of cameras)", o->nimg);
                rc = CLI_FAIL;
            } else if (o->cam_path && o->views && o->views != o->nimg) {
                cli_error("--views %d with %d --image view%s and --cameras: the views are the images", o->views, o->nimg, o->nimg == 1 ? "" : "s");
                rc = CLI_FAIL;
            } else if (o->cam_path && mi.class_embed_in != 16) {
                cli_error("model '%s' takes %d camera numbers per view; a meta.json camera is a 4x4 matrix (16)", o->model_path, mi.class_embed_in);
                rc = CLI_FAIL;
            }
            nviews = o->cam_path ? o->nimg : o->views ? o->views : 6;
        } else if (rc == CLI_OK) {
            if (o->nimg > 1) {
                cli_error("%d --image inputs: model '%s' is a %s model, which takes one (only a supermat-mv model takes several views)",
                          o->nimg, o->model_path, kn);
                rc = CLI_FAIL;
            } else if (o->cam_path || o->views > 1) {
                cli_error("%s: model '%s' is a %s model, only a supermat-mv model takes views and cameras",
                          o->cam_path ? "--cameras" : "--views", o->model_path, kn);
                rc = CLI_FAIL;
            }
        }
    }
    /* the views' cameras (a supermat-mv model) */
    if (rc == CLI_OK && o->cam_path) {
        c2w = (float *)calloc((size_t)o->nimg * 16, sizeof(float));
        if (!c2w) { cli_error("out of memory"); rc = CLI_FAIL; }
        if (rc == CLI_OK) rc = cli_read_cameras(o->cam_path, &cams, &ncam);
        for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
            char *stem = cli_stem(o->images[i]);
            long index;
            const cli_camera *c;
            if (!stem) { cli_error("out of memory"); rc = CLI_FAIL; break; }
            index = cli_stem_index(stem);
            free(stem);
            if (index < 0) {
                cli_error("view '%s': its file name does not end with a number (up to 9 digits; e.g. color_0003.png -> 3), "
                          "so it has no camera index in the meta.json", o->images[i]);
                rc = CLI_FAIL;
                break;
            }
            c = cli_find_camera(cams, ncam, index, o->images[i], o->cam_path);
            if (!c) rc = CLI_FAIL;
            else memcpy(c2w + 16 * i, c->m, sizeof c->m);
        }
    }

    /* the modes, f32 first */
    if (rc == CLI_OK) {
        unsigned kb = cli_kind_bit(mi.kind);
        order[norder++] = CLI_MODE_F32;
        if (o->modes_all) {
            for (k = 1; k < CLI_MODE_COUNT; k++) if (cli_modes[k].kinds & kb) order[norder++] = k;
        }
        for (i = 0; i < o->nmodes && rc == CLI_OK; i++) {
            int m = o->modes[i], j, dup = 0;
            if (!(cli_modes[m].kinds & kb)) {
                cli_error("--modes: mode '%s' does not apply to model '%s', a %s model", cli_modes[m].name, o->model_path,
                          cli_kind_name(mi.kind));
                rc = CLI_FAIL;
            }
            for (j = 0; j < norder; j++) dup |= order[j] == m;
            if (!dup) order[norder++] = m;
        }
    }

    /* the input pixels */
    if (rc == CLI_OK) {
        in.w = w; in.h = h; in.nviews = nviews; in.np = (size_t)w * (size_t)h;
        in.nmaps = mi.kind == SUPERMAT_KIND_UV_REFINE ? 1 : 3;
        in.in = (supermat_image *)calloc((size_t)nviews, sizeof *in.in);
        in.fg = (unsigned char *)malloc(in.np * (size_t)nviews);
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            for (k = 0; k < 3; k++) in.ov[k] = (supermat_image *)calloc((size_t)nviews, sizeof(supermat_image));
            if (!c2w) {
                c2w = (float *)calloc((size_t)nviews * 16, sizeof(float));
                if (c2w) cli_ring_cameras(nviews, c2w);
            }
            in.c2w = c2w;
        }
        if (!in.in || !in.fg || (mi.kind == SUPERMAT_KIND_SUPERMAT_MV && (!in.ov[0] || !in.ov[1] || !in.ov[2] || !c2w))) {
            cli_error("out of memory");
            rc = CLI_FAIL;
        }
    }
    for (i = 0; i < o->nimg && rc == CLI_OK; i++) {
        int iw = 0, ih = 0, c = 0, uv = mi.kind == SUPERMAT_KIND_UV_REFINE;
        px[i] = cli_load(o->images[i], &iw, &ih, &c, uv ? 3 : 4);
        if (!px[i]) { cli_error("cannot read image '%s': %s", o->images[i], cli_stbi_reason()); rc = CLI_FAIL; break; }
        if (iw != w || ih != h) { cli_error("image '%s' is %dx%d, not %dx%d as before (did it change?)", o->images[i], iw, ih, w, h); rc = CLI_FAIL; break; }
    }
    if (rc == CLI_OK && mi.kind == SUPERMAT_KIND_UV_REFINE) {
        int iw = 0, ih = 0, c = 0;
        in.mask = cli_load_gray(o->mask_path, &iw, &ih);
        if (!in.mask) { cli_error("cannot read the mask '%s': %s", o->mask_path, cli_stbi_reason()); rc = CLI_FAIL; }
        else if (iw != w || ih != h) { cli_error("the mask '%s' is %dx%d, not %dx%d as before (did it change?)", o->mask_path, iw, ih, w, h); rc = CLI_FAIL; }
        if (rc == CLI_OK) {
            in.pos = cli_load(o->pos_path, &iw, &ih, &c, 3);
            if (!in.pos) { cli_error("cannot read the position map '%s': %s", o->pos_path, cli_stbi_reason()); rc = CLI_FAIL; }
            else if (iw != w || ih != h) { cli_error("the position map '%s' is %dx%d, not %dx%d as before (did it change?)", o->pos_path, iw, ih, w, h); rc = CLI_FAIL; }
        }
    }
    if (rc == CLI_OK) {
        int uv = mi.kind == SUPERMAT_KIND_UV_REFINE;
        size_t p;
        for (v = 0; v < nviews; v++) {
            unsigned char *src = px[v < o->nimg ? v : 0];
            unsigned char *fg = in.fg + in.np * (size_t)v;
            in.in[v].pixels = src; in.in[v].width = w; in.in[v].height = h; in.in[v].channels = uv ? 3 : 4;
            in.in[v].format = SUPERMAT_FORMAT_U8;
            for (p = 0; p < in.np; p++) fg[p] = uv ? in.mask[p] >= 128 /* > 0.5 */ : src[p * 4 + 3] > 0;
        }
        if (in.any_truth) { /* a supermat model: one view */
            in.gt_mask = (unsigned char *)malloc(in.np);
            if (!in.gt_mask) { cli_error("out of memory"); rc = CLI_FAIL; }
            for (p = 0; rc == CLI_OK && p < in.np; p++) {
                in.gt_mask[p] = px[0][p * 4 + 3] >= 128;
                in.gt_n += in.gt_mask[p];
            }
            if (rc == CLI_OK && !in.gt_n) {
                cli_error("image '%s' has no object pixels (alpha >= 128): nothing to compare the truth maps with", path0);
                rc = CLI_FAIL;
            }
        }
        for (k = 0; k < 3 && rc == CLI_OK; k++) {
            const char *tp = o->truth_paths[k];
            int iw = 0, ih = 0, c = 0;
            if (!tp) continue;
            in.truth[k] = k == 0 ? cli_load(tp, &iw, &ih, &c, 3) : cli_load_gray(tp, &iw, &ih);
            if (!in.truth[k]) { cli_error("cannot read the %s truth '%s': %s", cli_bi_map_names[k], tp, cli_stbi_reason()); rc = CLI_FAIL; }
            else if (iw != w || ih != h) {
                cli_error("the %s truth '%s' is %dx%d, not %dx%d as before (did it change?)", cli_bi_map_names[k], tp, iw, ih, w, h);
                rc = CLI_FAIL;
            }
        }
        for (k = 0; k < in.nmaps && rc == CLI_OK; k++) {
            nout[k] = in.np * (size_t)nviews * (size_t)cli_bi_channels(&in, k);
            ref[k] = (float *)malloc(nout[k] * sizeof(float));
            cur[k] = (float *)malloc(nout[k] * sizeof(float));
            if (!ref[k] || !cur[k]) { cli_error("out of memory for the maps (%d view%s of %dx%d)", nviews, nviews == 1 ? "" : "s", w, h); rc = CLI_FAIL; break; }
        }
    }

    /* one pool for every session */
    if (rc == CLI_OK) {
#if SUPERMAT__HAS_PTHREADS
        if (supermat_pool_create(o->threads, NULL, &pool, &hook) != SUPERMAT_SUCCESS) { cli_error("cannot create the thread pool"); rc = CLI_FAIL; }
#else
        hook.parallel_for = cli_serial_for; hook.user = NULL; hook.max_threads = 1;
#endif
    }

    if (rc == CLI_OK) {
        char vs[48], ins[64];
        vs[0] = 0;
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV)
            snprintf(vs, sizeof vs, " x %d view%s%s", nviews, nviews == 1 ? "" : "s", o->cam_path ? "" : " (one image, cameras on a circle)");
        snprintf(ins, sizeof ins, "%s", mi.kind == SUPERMAT_KIND_UV_REFINE ? "map" : o->nimg > 1 ? "views" : "image");
        cli_cpu_name(cpu, sizeof cpu);
        printf("supermat bench: %s (%s, kernel %s)\n", o->model_path, cli_kind_name(mi.kind), cli_kernel_name(mi.kernel));
        printf("%-8s %s%s, %dx%d%s\n", ins, path0, o->nimg > 1 ? ", ..." : "", w, h, vs);
        printf("machine  %s%s%d thread%s, seconds = best of %d run%s\n", cpu, cpu[0] ? ", " : "", hook.max_threads,
               hook.max_threads == 1 ? "" : "s", o->repeats, o->repeats == 1 ? "" : "s");
        {
            long fma_iters = 0;
            cli_fma_zmm = mi.kernel == SUPERMAT_KERNEL_AVX512 || mi.kernel == SUPERMAT_KERNEL_AMX; /* AMX: % of the AVX-512 FMA peak */
            cli_bi_peak = mi.kernel == SUPERMAT_KERNEL_AVX2 || mi.kernel == SUPERMAT_KERNEL_AVX512 ? cli_fma_peak(&hook, 3, &fma_iters) : 0.0;
            if (cli_bi_peak > 0) printf("FMA peak %.1f GFLOP/s on %d thread%s (measured now; %%peak = GFLOP/s / this)\n", cli_bi_peak, hook.max_threads, hook.max_threads == 1 ? "" : "s");
        }
        if (in.any_truth) {
            printf("truth   ");
            for (k = 0; k < 3; k++) if (o->truth_paths[k]) printf(" %s %s", cli_bi_map_names[k], o->truth_paths[k]);
            printf(" (%lu object pixels)\n", (unsigned long)in.gt_n);
        }
        printf("\n");
        cli_bi_print_header(&in);
        fflush(stdout);
    }

    for (i = 0; i < norder && rc == CLI_OK; i++) {
        int mode = order[i], rep, skip;
        supermat_weights wt;
        supermat_conv conv;
        unsigned outputs;
        supermat_session_desc sd;
        supermat_model *model = base, *extra = NULL;
        supermat_session *sess = NULL;
        supermat_model_info emi;
        supermat_flops fl;
        size_t sbytes = 0;
        float *maps[3];
        double best = 1e30;
        char what[80];
        cli_bi_row *row = &rows[nrows];
        memset(&sd, 0, sizeof sd);
        skip = cli_mode_setup(mode, w, h, &wt, &conv, &outputs, &sd, skipped[nskipped], sizeof skipped[nskipped]);
        if (skip) { skipped_mode[nskipped++] = mode; continue; }
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) outputs = SUPERMAT_OUTPUT_ALL;
        row->mode = mode;
        nrows++;
        snprintf(what, sizeof what, "mode %s", cli_modes[mode].name);
        r = SUPERMAT_SUCCESS;
        if (wt != SUPERMAT_WEIGHTS_F32 || conv != SUPERMAT_CONV_DIRECT || cli_mode_compute != SUPERMAT_COMPUTE_F32 || cli_mode_kernel >= 0) {
            r = cli_bi_model(file, file_size, o->kernel, wt, conv, &extra, &err);
            model = extra;
        }
        memset(&emi, 0, sizeof emi);
        if (r == SUPERMAT_SUCCESS) {
            supermat_model_get_info(model, &emi);
            sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.views = nviews; sd.threading = hook;
            r = supermat_session_memory(&sd, &sbytes, &err);
        }
        if (r == SUPERMAT_SUCCESS) r = supermat_session_create(&sd, &sess, &err);
        for (k = 0; k < 3; k++) maps[k] = k < in.nmaps && cli_bi_wants(&in, outputs, k) ? (mode == CLI_MODE_F32 ? ref[k] : cur[k]) : NULL;
        for (rep = 0; rep < o->repeats && r == SUPERMAT_SUCCESS; rep++) {
            double t0 = cli_now(), t;
            r = cli_bi_run(sess, &in, maps, &err);
            t = cli_now() - t0;
            if (t < best) best = t;
        }
        if (r == SUPERMAT_SUCCESS) {
            memset(&fl, 0, sizeof fl);
            supermat_session_last_flops(sess, &fl);
            row->done = 1;
            row->seconds = best;
            if (mode == CLI_MODE_F32) f32_seconds = best;
            row->speedup = best > 0 ? f32_seconds / best : 0.0;
            row->peak_bytes = emi.model_bytes + sbytes;
            row->flops = fl.total;
            for (k = 0; k < in.nmaps; k++) if (maps[k]) cli_bi_compare(&in, k, ref[k], maps[k], row);
            for (k = 0; k < in.nmaps; k++) if (maps[k] && in.truth[k]) cli_bi_compare_truth(&in, k, maps[k], row);
            cli_bi_print_row(&in, row);
        } else {
            fflush(stdout);
            cli_lib_error(what, r, &err);
            printf("%-18s failed: %s\n", cli_modes[mode].name, err.message[0] ? err.message : supermat_result_string(r));
            fflush(stdout);
            failed++;
            if (mode == CLI_MODE_F32) rc = CLI_FAIL; /* no reference: nothing to compare with */
        }
        supermat_session_destroy(sess);
        supermat_model_destroy(extra);
    }

    if (rc == CLI_OK) {
        for (i = 0; i < nskipped; i++) printf("%-18s skipped: %s\n", cli_modes[skipped_mode[i]].name, skipped[i]);
        printf("\nseconds: supermat_run only; speedup: f32 seconds / seconds; peak MiB: model + session arena (supermat_session_memory);\n"
               "psnr, psnr_fg (dB, capped at %.0f), max_abs: against the f32 maps (float, [0, 1]), all pixels and the foreground (%s)\n",
               CLI_PSNR_CAP, mi.kind == SUPERMAT_KIND_UV_REFINE ? "mask > 0.5" : "input alpha > 0");
        if (in.any_truth)
            printf("gt_psnr (dB, capped at %.0f): against the truth files, the maps quantised to 8 bits as `supermat image` writes them,\n"
                   "over the object's pixels (input alpha >= 128); - where no truth was given or the mode does not compute the map\n",
                   CLI_PSNR_CAP);
        if (jf) {
            FILE *f = jf;
            int ok;
            jf = NULL;
            ok = cli_bi_write_json(f, o->json_path, &in, rows, nrows) == CLI_OK; /* closes f */
            if (cli_mem_commit(&jm, o->json_path, ok, 1) != CLI_OK) rc = CLI_FAIL;
        }
        if (failed) {
            cli_error("%d mode%s failed (see above)", failed, failed == 1 ? "" : "s");
            rc = CLI_FAIL;
        }
    }

    if (jf) cli_mem_commit(&jm, o->json_path, 0, 0); /* nothing measured: no file */
    for (k = 0; k < 3; k++) { free(ref[k]); free(cur[k]); free(in.ov[k]); if (in.truth[k]) stbi_image_free(in.truth[k]); }
    free(in.gt_mask);
    for (i = 0; i < o->nimg; i++) if (px[i]) stbi_image_free(px[i]);
    if (in.mask) stbi_image_free(in.mask);
    if (in.pos) stbi_image_free(in.pos);
    free(in.in); free(in.fg); free(c2w); free(cams);
    supermat_model_destroy(base);
    cli_free_file(file);
#if SUPERMAT__HAS_PTHREADS
    supermat_pool_destroy(pool);
#endif
    (void)pool;
    return rc;
}

/* `supermat bench`: the options, then (a), (b), (c) above, or with --image cli_bench_image() */
static int cli_bench(int argc, char **argv) {
    const char *cmd = "bench", *v, *model_arg = NULL, *model_path = NULL, *json_path = NULL;
    int w = 512, h = 512, threads = 0, repeats = 1, i, m, rc = CLI_OK, nrows = 0, rep, x, y, k;
    int views = 0, nviews = 1, pipeline_only = 0;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    unsigned char *file = NULL, *rgba = NULL, *alb = NULL, *rough = NULL, *metal = NULL, *mask = NULL, *pos = NULL;
    supermat_image *in_v = NULL, *alb_v = NULL, *rough_v = NULL, *metal_v = NULL;
    float *c2w = NULL;
    size_t file_size = 0, session_bytes = 0, np = 0, rss = 0;
    long fma_iters = 0;
    supermat_model *model = NULL;
    supermat_model_info mi;
    supermat_session *sess = NULL;
    supermat_session_desc sd;
    supermat_threading hook;
    supermat_flops fl;
    supermat_error err;
    supermat_result r;
    supermat_pool *pool = NULL;
    double peak = 0.0, peak1 = 0.0, dpeak = 0.0, dpeak1 = 0.0, create_s = 0.0, best_total = 1e30, sum_total = 0.0;
    double gemm_flops = 2.0 * CLI_GEMM_HW * CLI_GEMM_HW * (double)CLI_GEMM_C * 9.0 * CLI_GEMM_C;
    double t_avx2 = -1.0, t_scalar = -1.0, t_avx512 = -1.0, gemm_diff = 0.0;
    int avx512_same = 0;
    cli_row rows[CLI_MAX_ROWS];
    cli_events ev;
    char outs_s[64];
    cli_bench_opts bo;
    int size_given = 0, outputs_given = 0, weights_given = 0, modes_given = 0;
    cli_model_ref mref;
    cli_levers lv;

    cli_levers_init(&lv);
    memset(&bo, 0, sizeof bo);
    bo.modes_all = 1;

    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(cli_usage_bench, stdout); fputs(cli_usage_bench_image, stdout); fputs(cli_usage_bench_modes, stdout); fputs(cli_usage_bench_truth, stdout); cli_print_default_model_help(); return CLI_OK; }
        if ((m = cli_opt(cmd, argc, argv, &i, "--model", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            model_arg = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--size", &v)) != 0) {
            if (m < 0 || cli_parse_size(cmd, v, &w, &h)) return CLI_USAGE;
            size_given = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--threads", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--threads", v, 0, 64, &threads)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--repeats", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--repeats", v, 1, 1000, &repeats)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--views", &v)) != 0) {
            if (m < 0 || cli_parse_int(cmd, "--views", v, 1, CLI_MAX_VIEWS, &views)) return CLI_USAGE;
        } else if (!strcmp(a, "--pipeline-only")) {
            pipeline_only = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--outputs", &v)) != 0) {
            if (m < 0 || cli_parse_outputs(cmd, v, &outputs)) return CLI_USAGE;
            outputs_given = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--kernel", &v)) != 0) {
            if (m < 0 || cli_parse_kernel(cmd, v, &kernel)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--weights", &v)) != 0) {
            if (m < 0 || cli_parse_weights(cmd, v, &lv)) return CLI_USAGE;
            weights_given = 1;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--compute", &v)) != 0) {
            if (m < 0 || cli_parse_compute(cmd, v, &lv)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--conv", &v)) != 0) {
            if (m < 0 || cli_parse_conv(cmd, v, &lv)) return CLI_USAGE;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--json", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            json_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--image", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            if (bo.nimg == CLI_MAX_VIEWS) return cli_usage_error(cmd, "more than %d --image views: at most %d are processed together", CLI_MAX_VIEWS, CLI_MAX_VIEWS);
            bo.images[bo.nimg++] = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--mask", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            bo.mask_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--position", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            bo.pos_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--cameras", &v)) != 0) {
            if (m < 0) return CLI_USAGE;
            bo.cam_path = v;
        } else if ((m = cli_opt(cmd, argc, argv, &i, "--modes", &v)) != 0) {
            if (m < 0 || cli_parse_modes(cmd, v, bo.modes, &bo.nmodes, &bo.modes_all)) return CLI_USAGE;
            modes_given = 1;
        } else if (!strncmp(a, "--truth-", 8)) {
            static const char *const truth_opts[3] = {"--truth-albedo", "--truth-roughness", "--truth-metallic"};
            for (k = 0; k < 3; k++) if ((m = cli_opt(cmd, argc, argv, &i, truth_opts[k], &v)) != 0) break;
            if (k == 3) return cli_usage_error(cmd, "unknown option '%s' (--truth-albedo, --truth-roughness, --truth-metallic)", a);
            if (m < 0) return CLI_USAGE;
            if (!v[0]) return cli_usage_error(cmd, "%s: an empty file name", truth_opts[k]);
            bo.truth_paths[k] = v;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage_error(cmd, "unknown option '%s'", a);
        } else {
            return cli_usage_error(cmd, "unexpected argument '%s'", a);
        }
    }
    if (bo.nimg) {
        if (size_given) return cli_usage_error(cmd, "--size does not apply with --image (the image's own size is used)");
        if (outputs_given) return cli_usage_error(cmd, "--outputs does not apply with --image (the modes choose the outputs)");
        if (weights_given) return cli_usage_error(cmd, "--weights does not apply with --image (use --modes f16,bf16,int8)");
        if (lv.conv_given) return cli_usage_error(cmd, "--conv does not apply with --image (use --modes winograd_f2,winograd_f4)");
        if (pipeline_only) return cli_usage_error(cmd, "--pipeline-only does not apply with --image");
        if ((rc = cli_model_path(cmd, model_arg, 1, &mref)) != CLI_OK) return rc;
        model_path = mref.path;
        bo.model_path = model_path; bo.json_path = json_path; bo.views = views; bo.threads = threads; bo.repeats = repeats;
        bo.kernel = kernel;
        return cli_bench_image(&bo);
    }
    if (modes_given || bo.mask_path || bo.pos_path || bo.cam_path)
        return cli_usage_error(cmd, "%s needs --image", modes_given ? "--modes" : bo.mask_path ? "--mask" : bo.pos_path ? "--position" : "--cameras");
    for (k = 0; k < 3; k++)
        if (bo.truth_paths[k])
            return cli_usage_error(cmd, "--truth-%s needs --image (it is compared with the maps of --image)", cli_bi_map_names[k]);
    if ((rc = cli_model_path(cmd, model_arg, 1, &mref)) != CLI_OK) return rc;
    model_path = mref.path;
    memset(&mi, 0, sizeof mi);
    memset(&fl, 0, sizeof fl);
    if (json_path && cli_report_allowed(json_path) != CLI_OK) return CLI_FAIL; /* before measuring */

    /* one pool for everything: the FMA peak, the session and the GEMM */
#if SUPERMAT__HAS_PTHREADS
    if (supermat_pool_create(threads, NULL, &pool, &hook) != SUPERMAT_SUCCESS) { cli_error("cannot create the thread pool"); return CLI_FAIL; }
#else
    hook.parallel_for = cli_serial_for; hook.user = NULL; hook.max_threads = 1;
#endif
    (void)cli_serial_for;

    /* (a) here and again at the end (the best counts: a busy neighbour only lowers it); with 512-bit FMAs
       when the pipeline runs the AVX-512 kernel */
    cli_fma_zmm = kernel == SUPERMAT_KERNEL_AVX512 || kernel == SUPERMAT_KERNEL_AMX || (kernel == SUPERMAT_KERNEL_AUTO && supermat_cpu_has_avx512());
    if (!pipeline_only) {
        peak1 = cli_fma_peak(NULL, 3, &fma_iters);
        peak = cli_fma_peak(&hook, 3, &fma_iters);
    }

    /* (b) */
    rc = cli_load_model(model_path, kernel, &lv, &file, &file_size, &model, &create_s);
    if (rc == CLI_OK) {
        supermat_model_get_info(model, &mi);
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) nviews = views ? views : 6;
        else if (views > 1) {
            cli_error("--views %d: model '%s' is a %s model, only a supermat-mv model takes several views", views, model_path,
                      cli_kind_name(mi.kind));
            rc = CLI_FAIL;
        }
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) outputs = SUPERMAT_OUTPUT_ALL; /* one refined map, whatever --outputs says */
    }
    if (mi.kind == SUPERMAT_KIND_UV_REFINE) snprintf(outs_s, sizeof outs_s, "refined");
    else cli_outputs_string(outputs, outs_s, sizeof outs_s);
    if (rc == CLI_OK) {
        memset(&sd, 0, sizeof sd);
        sd.model = model; sd.width = w; sd.height = h; sd.outputs = outputs; sd.views = nviews; sd.threading = hook;
        r = supermat_session_memory(&sd, &session_bytes, &err);
        if (r == SUPERMAT_SUCCESS) r = supermat_session_create(&sd, &sess, &err);
        if (r != SUPERMAT_SUCCESS) { cli_lib_error("session", r, &err); rc = CLI_FAIL; }
    }
    if (rc == CLI_OK) {
        size_t nv = (size_t)nviews;
        np = (size_t)w * (size_t)h;
        rgba = (unsigned char *)malloc(np * 4 * nv);
        alb = (unsigned char *)malloc(np * 3 * nv); /* uv-refine: the refined map */
        rough = (unsigned char *)malloc(np * nv);
        metal = (unsigned char *)malloc(np * nv);
        mask = (unsigned char *)malloc(np);
        pos = (unsigned char *)malloc(np * 3);
        in_v = (supermat_image *)calloc(nv, sizeof *in_v);
        alb_v = (supermat_image *)calloc(nv, sizeof *alb_v);
        rough_v = (supermat_image *)calloc(nv, sizeof *rough_v);
        metal_v = (supermat_image *)calloc(nv, sizeof *metal_v);
        c2w = (float *)calloc(nv * 16, sizeof(float));
        if (!rgba || !alb || !rough || !metal || !mask || !pos || !in_v || !alb_v || !rough_v || !metal_v || !c2w) {
            cli_error("out of memory");
            rc = CLI_FAIL;
        }
    }
    if (rc == CLI_OK) {
        /* a deterministic pattern per view: gradients, a checker, an opaque disk (moving from view to view) on
           transparent noise; for uv-refine the same as the map (alpha ignored), banded mask, gradient positions */
        uint32_t seed = 7u;
        for (k = 0; k < nviews; k++) {
            double cx = 0.5 + 0.05 * sin(2.0 * 3.14159265358979323846 * k / nviews);
            for (y = 0; y < h; y++)
                for (x = 0; x < w; x++) {
                    unsigned char *p = rgba + (((size_t)k * h + y) * w + x) * 4;
                    double dx = (x + 0.5) / w - cx, dy = (y + 0.5) / h - 0.5, d = sqrt(dx * dx + dy * dy);
                    int inside = d < 0.4, check = ((x / 8) + (y / 8) + k) & 1;
                    p[0] = (unsigned char)(inside ? 40 + 180 * x / w : (int)(cli_rand(&seed) & 255u));
                    p[1] = (unsigned char)(inside ? 40 + 180 * y / h : (int)(cli_rand(&seed) & 255u));
                    p[2] = (unsigned char)(inside ? (check ? 200 : 60) : (int)(cli_rand(&seed) & 255u));
                    p[3] = (unsigned char)(inside ? 255 : d < 0.41 ? 128 : 0);
                }
        }
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++) {
                size_t o = (size_t)y * w + x;
                mask[o] = (unsigned char)(85 * (((x / 16) + (y / 16)) % 4));
                pos[o * 3] = (unsigned char)(255 * x / w);
                pos[o * 3 + 1] = (unsigned char)(255 * y / h);
                pos[o * 3 + 2] = 127;
            }
        cli_ring_cameras(nviews, c2w);
        for (k = 0; k < nviews; k++) {
            in_v[k].pixels = rgba + np * 4 * (size_t)k; in_v[k].width = w; in_v[k].height = h; in_v[k].channels = 4;
            alb_v[k].pixels = alb + np * 3 * (size_t)k; alb_v[k].channels = 3;
            rough_v[k].pixels = rough + np * (size_t)k; rough_v[k].channels = 1;
            metal_v[k].pixels = metal + np * (size_t)k; metal_v[k].channels = 1;
        }
    }
    for (rep = 0; rep < repeats && rc == CLI_OK; rep++) {
        supermat_run_desc rd;
        double t0, t1;
        cli_row tmp[CLI_MAX_ROWS];
        int n;
        memset(&rd, 0, sizeof rd);
        rd.input = in_v[0];
        if (mi.kind == SUPERMAT_KIND_UV_REFINE) {
            rd.mask.pixels = mask; rd.mask.width = w; rd.mask.height = h; rd.mask.channels = 1;
            rd.position.pixels = pos; rd.position.width = w; rd.position.height = h; rd.position.channels = 3;
            rd.refined = alb_v[0];
        } else if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) {
            rd.input_views = in_v;
            rd.cameras = c2w;
            if (outputs & SUPERMAT_OUTPUT_ALBEDO) rd.albedo_views = alb_v;
            if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) rd.roughness_views = rough_v;
            if (outputs & SUPERMAT_OUTPUT_METALLIC) rd.metallic_views = metal_v;
        } else {
            if (outputs & SUPERMAT_OUTPUT_ALBEDO) rd.albedo = alb_v[0];
            if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) rd.roughness = rough_v[0];
            if (outputs & SUPERMAT_OUTPUT_METALLIC) rd.metallic = metal_v[0];
        }
        memset(&ev, 0, sizeof ev);
        rd.inspect = cli_inspect_cb; rd.inspect_user = &ev;
        t0 = cli_now();
        r = supermat_run(sess, &rd, &err);
        t1 = cli_now();
        if (r != SUPERMAT_SUCCESS) { cli_lib_error("run", r, &err); rc = CLI_FAIL; break; }
        supermat_session_flops(sess, &fl);
        n = cli_rows(&ev, t0, t1, &fl, &mi, tmp);
        sum_total += t1 - t0;
        if (t1 - t0 < best_total) { best_total = t1 - t0; nrows = n; memcpy(rows, tmp, sizeof(cli_row) * (size_t)n); }
    }

    rss = cli_peak_rss(); /* the pipeline's peak, before the GEMM's buffers */

    /* (c) */
    if (rc == CLI_OK && !pipeline_only) {
        cli_gemm g;
        float *ref = NULL;
        size_t nout = (size_t)CLI_GEMM_HW * CLI_GEMM_HW * CLI_GEMM_C, k;
        if (cli_gemm_init(&g, hook.max_threads) != CLI_OK || !(ref = (float *)malloc(nout * sizeof(float)))) {
            cli_error("out of memory for the GEMM benchmark");
            rc = CLI_FAIL;
        } else {
#if SUPERMAT__HAS_AVX2
            if (supermat_cpu_has_avx2()) t_avx2 = cli_gemm_time(&g, supermat__ukr_avx2, SUPERMAT__MR, &hook, 0.5, ref);
#endif
#if SUPERMAT__HAS_AVX512
            if (supermat_cpu_has_avx512()) {
                t_avx512 = cli_gemm_time(&g, supermat__ukr_avx512, SUPERMAT__MR512, &hook, 0.5, NULL);
                avx512_same = t_avx512 > 0 && ref && !memcmp(ref, g.out.d, nout * sizeof(float));
            }
#endif
            t_scalar = cli_gemm_time(&g, supermat__ukr_scalar, SUPERMAT__MR, &hook, 1.0, NULL);
            if (t_avx2 > 0) {
                double mx = 0.0, md = 0.0;
                for (k = 0; k < nout; k++) {
                    double a = fabs((double)ref[k]), d = fabs((double)ref[k] - (double)g.out.d[k]);
                    if (a > mx) mx = a;
                    if (d > md) md = d;
                }
                gemm_diff = mx > 0 ? md / mx : md;
            }
        }
        free(ref);
        cli_gemm_free(&g);
    }

    if (rc == CLI_OK && !pipeline_only) {
        double p1 = cli_fma_peak(NULL, 3, &fma_iters), pa = cli_fma_peak(&hook, 3, &fma_iters);
        if (p1 > peak1) peak1 = p1;
        if (pa > peak) peak = pa;
        cli_dot_isa = cli_dot_for(mi.kernel, mi.compute);
        if (cli_dot_isa != CLI_DOT_NONE) { /* the compute's own instruction, best of 2 x 3 runs like the FMA peak */
            long dot_iters = 0;
            int r;
            for (r = 0; r < 2; r++) {
                double d1 = cli_peak_of(NULL, 3, &dot_iters, cli_dot_isa), da = cli_peak_of(&hook, 3, &dot_iters, cli_dot_isa);
                if (d1 > dpeak1) dpeak1 = d1;
                if (da > dpeak) dpeak = da;
            }
        }
    }
    if (rc == CLI_OK) {
        size_t planned = mi.model_bytes + session_bytes;
        double total_flops = fl.total;
        FILE *jf = NULL;
        cli_mem jm;
        char vs[32];
        vs[0] = 0;
        if (mi.kind == SUPERMAT_KIND_SUPERMAT_MV) snprintf(vs, sizeof vs, " x %d view%s", nviews, nviews == 1 ? "" : "s");
        printf("supermat bench: %s (%s, kernel %s, %s compute, %s convolutions), %dx%d%s, outputs %s, %d thread%s\n", model_path,
               cli_kind_name(mi.kind), cli_kernel_name(mi.kernel), cli_compute_name(mi.compute),
               cli_conv_name(mi.conv), w, h, vs, outs_s, hook.max_threads, hook.max_threads == 1 ? "" : "s");
        if (pipeline_only) printf("FMA peak      skipped (--pipeline-only)\n");
        else if (peak > 0) printf("FMA peak      %.1f GFLOP/s on %d thread%s, %.1f GFLOP/s on one (%s, %d independent %s chains; best of 6)\n",
                             peak, hook.max_threads, hook.max_threads == 1 ? "" : "s", peak1, cli_fma_zmm ? "AVX-512" : "AVX2", CLI_FMA_CHAINS,
                             cli_fma_zmm ? "_mm512_fmadd_ps" : "_mm256_fmadd_ps");
        else printf("FMA peak      n/a (no AVX2/FMA on this CPU or in this build)\n");
        if (dpeak > 0)
            printf("dot peak      %.1f GOP/s on %d thread%s, %.1f on one (%s, %d independent chains, %.0f ops each; best of 6): what the %s compute's GEMMs multiply with; %% dot = GFLOP/s / this\n",
                   dpeak, hook.max_threads, hook.max_threads == 1 ? "" : "s", dpeak1, cli_dot_name[cli_dot_isa], CLI_FMA_CHAINS,
                   cli_dot_ops[cli_dot_isa], cli_compute_name(mi.compute));
        printf("model create  %.3f s (validation and weight packing)\n", create_s);
        printf("\n%-32s %9s %9s %9s %7s%s\n", repeats > 1 ? "stage (fastest run)" : "stage", "seconds", "GFLOP", "GFLOP/s", "% peak",
               dpeak > 0 ? "   % dot" : "");
        for (i = 0; i < nrows; i++) {
            printf("%-32s %9.4f %9.3f", rows[i].name, rows[i].seconds, rows[i].flops / 1e9);
            if (rows[i].flops > 0 && rows[i].seconds > 0) {
                double gfs = rows[i].flops / rows[i].seconds / 1e9;
                printf(" %9.2f", gfs);
                if (peak > 0) printf(" %6.1f%%", 100.0 * gfs / peak);
                else printf(" %7s", "-");
                if (dpeak > 0) printf(" %7.1f%%", 100.0 * gfs / dpeak);
            } else {
                printf(" %9s %7s", "-", "-");
                if (dpeak > 0) printf(" %8s", "-");
            }
            printf("\n");
        }
        printf("%-32s %9.4f %9.3f %9.2f", "total", best_total, total_flops / 1e9, total_flops / best_total / 1e9);
        if (peak > 0) printf(" %6.1f%%", 100.0 * total_flops / best_total / 1e9 / peak);
        else printf(" %7s", "-");
        if (dpeak > 0) printf(" %7.1f%%", 100.0 * total_flops / best_total / 1e9 / dpeak);
        printf("\n");
        if (repeats > 1) printf("(%d runs, mean total %.4f s)\n", repeats, sum_total / repeats);
        printf("\nmemory        model %.1f MiB + session %.1f MiB = %.1f MiB planned; process peak RSS %.1f MiB (getrusage, after the runs; includes the %.1f MiB file buffer)\n",
               cli_mib((double)mi.model_bytes), cli_mib((double)session_bytes), cli_mib((double)planned), cli_mib((double)rss),
               cli_mib((double)file_size));
        if (pipeline_only) printf("conv GEMM     skipped (--pipeline-only)\n");
        else printf("conv GEMM     3x3, %dx%dx%d -> %d (M=%d, K=%d, N=%d, %.2f GFLOP), packed weights, %d thread%s:\n", CLI_GEMM_HW,
               CLI_GEMM_HW, CLI_GEMM_C, CLI_GEMM_C, CLI_GEMM_HW * CLI_GEMM_HW, 9 * CLI_GEMM_C, CLI_GEMM_C, gemm_flops / 1e9,
               hook.max_threads, hook.max_threads == 1 ? "" : "s");
        if (t_avx2 > 0) printf("              avx2   %8.2f GFLOP/s (%.4f s)\n", gemm_flops / t_avx2 / 1e9, t_avx2);
        else if (!pipeline_only) printf("              avx2   n/a\n");
        if (t_avx512 > 0) printf("              avx512 %8.2f GFLOP/s (%.4f s), %.2fx avx2, %s bits as avx2\n", gemm_flops / t_avx512 / 1e9, t_avx512,
                                 t_avx2 > 0 ? t_avx2 / t_avx512 : 0.0, avx512_same ? "the same" : "NOT the same");
        else if (!pipeline_only) printf("              avx512 n/a (no AVX-512F on this CPU or in this build)\n");
        if (t_scalar > 0) printf("              scalar %8.2f GFLOP/s (%.4f s)\n", gemm_flops / t_scalar / 1e9, t_scalar);
        if (t_avx2 > 0) printf("              ratio  %.1fx (avx2 / scalar); max difference %.2g of max |C|; avx2 at %.1f%% of the FMA peak\n",
                               t_scalar / t_avx2, gemm_diff, peak > 0 ? 100.0 * gemm_flops / t_avx2 / 1e9 / peak : 0.0);
        if (t_avx512 > 0 && peak > 0) printf("              avx512 at %.1f%% of the FMA peak\n", 100.0 * gemm_flops / t_avx512 / 1e9 / peak);

        if (json_path) {
            jf = cli_mem_open(&jm, json_path);
            if (!jf) rc = CLI_FAIL;
        }
        if (jf) {
            fprintf(jf, "{\n  \"version\": \"%d.%d.%d\",\n  \"model\": ", (SUPERMAT_VERSION >> 16) & 255, (SUPERMAT_VERSION >> 8) & 255,
                    SUPERMAT_VERSION & 255);
            cli_json_string(jf, model_path);
            fprintf(jf, ",\n  \"kind\": \"%s\",\n  \"kernel\": \"%s\",\n  \"compute\": \"%s\",\n  \"conv\": \"%s\",\n  \"width\": %d,\n  \"height\": %d,\n  \"views\": %d,\n  \"outputs\": \"%s\",\n",
                    cli_kind_name(mi.kind), cli_kernel_name(mi.kernel), cli_compute_name(mi.compute), cli_conv_name(mi.conv),
                    w, h, nviews, outs_s);
            fprintf(jf, "  \"threads\": %d,\n  \"repeats\": %d,\n  \"fma_peak_gflops\": %.6g,\n  \"fma_peak_one_thread_gflops\": %.6g,\n  \"model_create_seconds\": %.6g,\n",
                    hook.max_threads, repeats, peak, peak1, create_s);
            fputs("  \"dot_peak_gops\": ", jf);
            cli_json_number_or_null(jf, dpeak > 0, dpeak);
            fputs(",\n  \"dot_peak_one_thread_gops\": ", jf);
            cli_json_number_or_null(jf, dpeak > 0, dpeak1);
            fprintf(jf, ",\n  \"dot_peak_isa\": \"%s\",\n", cli_dot_name[dpeak > 0 ? cli_dot_isa : CLI_DOT_NONE]);
            fprintf(jf, "  \"stages\": [\n");
            for (i = 0; i < nrows; i++) {
                double gfs = rows[i].seconds > 0 ? rows[i].flops / rows[i].seconds / 1e9 : 0.0;
                fprintf(jf, "    {\"stage\": ");
                cli_json_string(jf, rows[i].name);
                fprintf(jf, ", \"seconds\": %.6g, \"gflop\": %.6g, \"gflops\": %.6g, \"percent_of_peak\": %.6g, \"percent_of_dot_peak\": ", rows[i].seconds,
                        rows[i].flops / 1e9, gfs, peak > 0 ? 100.0 * gfs / peak : 0.0);
                cli_json_number_or_null(jf, dpeak > 0, dpeak > 0 ? 100.0 * gfs / dpeak : 0.0);
                fprintf(jf, "}%s\n", i + 1 < nrows ? "," : "");
            }
            fprintf(jf, "  ],\n  \"total\": {\"seconds\": %.6g, \"mean_seconds\": %.6g, \"gflop\": %.6g, \"gflops\": %.6g, \"percent_of_peak\": %.6g, \"percent_of_dot_peak\": ",
                    best_total, sum_total / repeats, total_flops / 1e9, total_flops / best_total / 1e9,
                    peak > 0 ? 100.0 * total_flops / best_total / 1e9 / peak : 0.0);
            cli_json_number_or_null(jf, dpeak > 0, dpeak > 0 ? 100.0 * total_flops / best_total / 1e9 / dpeak : 0.0);
            fputs("},\n", jf);
            fprintf(jf, "  \"flops\": {\"encode\": %.6g, \"trunk\": %.6g, \"branch\": %.6g, \"decode\": %.6g, \"total\": %.6g},\n",
                    fl.encode, fl.trunk, fl.branch, fl.decode, fl.total);
            fprintf(jf, "  \"memory\": {\"model_bytes\": %llu, \"session_bytes\": %llu, \"planned_bytes\": %llu, \"peak_rss_bytes\": %llu, \"file_bytes\": %llu},\n",
                    (unsigned long long)mi.model_bytes, (unsigned long long)session_bytes, (unsigned long long)planned,
                    (unsigned long long)rss, (unsigned long long)file_size);
            if (pipeline_only) fprintf(jf, "  \"gemm\": null\n}\n");
            else fprintf(jf, "  \"gemm\": {\"M\": %d, \"K\": %d, \"N\": %d, \"gflop\": %.6g, \"avx2_gflops\": %.6g, \"avx512_gflops\": %.6g, \"avx512_same_bits\": %s, \"scalar_gflops\": %.6g, \"ratio\": %.6g, \"max_rel_diff\": %.6g},\n  \"fma_peak_isa\": \"%s\"\n}\n",
                    CLI_GEMM_HW * CLI_GEMM_HW, 9 * CLI_GEMM_C, CLI_GEMM_C, gemm_flops / 1e9, t_avx2 > 0 ? gemm_flops / t_avx2 / 1e9 : 0.0,
                    t_avx512 > 0 ? gemm_flops / t_avx512 / 1e9 : 0.0, avx512_same ? "true" : "false",
                    t_scalar > 0 ? gemm_flops / t_scalar / 1e9 : 0.0, t_avx2 > 0 ? t_scalar / t_avx2 : 0.0, gemm_diff, cli_fma_zmm ? "avx512" : "avx2");
            if (cli_mem_commit(&jm, json_path, 1, 0) != CLI_OK) rc = CLI_FAIL;
        }
    }

    free(rgba); free(alb); free(rough); free(metal); free(mask); free(pos);
    free(in_v); free(alb_v); free(rough_v); free(metal_v); free(c2w);
    supermat_session_destroy(sess);
    supermat_model_destroy(model);
    cli_free_file(file);
#if SUPERMAT__HAS_PTHREADS
    supermat_pool_destroy(pool);
#endif
    (void)pool;
    return rc;
}
