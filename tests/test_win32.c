/* What only a Windows build can show (MinGW-w64 here, run under wine by tests/test_mingw.sh):
 *   test_win32 MODEL.safetensors EXPECT
 * EXPECT: the host CPU's features as the Linux build sees them, "avx2,avx512,avx512_bf16,avx512_vnni,avx_vnni"
 * or a subset ("-" for none): what this file prints when compiled for Linux. Checks:
 *   - supermat_cpu() reports the same features on Windows (CPUID and XGETBV as on Linux), so the dispatch
 *     picks the same kernel, and a model created with SUPERMAT_KERNEL_AUTO is not the scalar one where the
 *     CPU has AVX2;
 *   - the built-in pool runs on Win32 threads: supermat_pool_create(4) gives 4 threads, a parallel-for of
 *     200 tasks runs every index once, on more than one OS thread;
 *   - supermat_default_threads() follows the process affinity mask (all CPUs, then one);
 *   - a session on 3 threads gives the same bits as one on 1 thread (the determinism promise), and its
 *     built-in pool runs the work on more than one OS thread (counted through the inspect hook's thread). */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include "test_util.h"

#ifndef _WIN32
/* elsewhere: the features this build sees, as EXPECT (what tests/test_mingw.sh passes to the Windows build) */
int main(void) {
    supermat_cpu_info c = supermat_cpu();
    char list[128] = "";
    if (c.avx2) strcat(list, ",avx2");
    if (c.avx512) strcat(list, ",avx512");
    if (c.avx512_bf16) strcat(list, ",avx512_bf16");
    if (c.avx512_vnni) strcat(list, ",avx512_vnni");
    if (c.avx_vnni) strcat(list, ",avx_vnni");
    printf("%s\n", list[0] ? list + 1 : "-");
    return 0;
}
#else
#include <windows.h>

#define CHECK(cond) TU_CHECK(cond, "%s", #cond)

static volatile LONG hits[200];
static DWORD ids[200];
static void task(void *user, int i, int thread) {
    (void)user; (void)thread;
    InterlockedIncrement(&hits[i]);
    ids[i] = GetCurrentThreadId();
    Sleep(1);
}
/* 1 when the comma list has the word */
static int has(const char *list, const char *word) {
    size_t n = strlen(word);
    const char *p = list;
    while ((p = strstr(p, word)) != NULL) {
        if ((p == list || p[-1] == ',') && (p[n] == 0 || p[n] == ',')) return 1;
        p += n;
    }
    return 0;
}
static int distinct(const DWORD *v, int n) {
    int i, j, k = 0;
    for (i = 0; i < n; i++) {
        for (j = 0; j < i && v[j] != v[i]; j++) {}
        if (j == i) k++;
    }
    return k;
}

/* a caller's parallel-for that counts the OS threads the library's own pool would use is not possible from
   outside; instead the session is given this hook, which forwards to a built-in pool and records threads */
static supermat_threading inner;
static DWORD seen[64];
static volatile LONG nseen;
static void rec_task_wrap(void *user, int i, int thread);
typedef struct { supermat_task_fn fn; void *user; } fwd;
static void rec_task_wrap(void *user, int i, int thread) {
    fwd *f = (fwd *)user;
    DWORD me = GetCurrentThreadId();
    LONG k, n = nseen;
    for (k = 0; k < n && k < 64; k++)
        if (seen[k] == me) break;
    if (k == n && n < 64) {
        LONG slot = InterlockedIncrement(&nseen) - 1;
        if (slot < 64) seen[slot] = me;
    }
    f->fn(f->user, i, thread);
}
static void rec_for(void *user, int count, supermat_task_fn fn, void *task_user) {
    fwd f;
    (void)user;
    f.fn = fn; f.user = task_user;
    inner.parallel_for(inner.user, count, rec_task_wrap, &f);
}

static int run_model(const unsigned char *file, size_t size, int threads, int hook, float *out, int w, int h) {
    supermat_model_desc md;
    supermat_session_desc sd;
    supermat_run_desc rd;
    supermat_model *m = NULL;
    supermat_session *s = NULL;
    unsigned char px[64 * 64 * 4];
    supermat_error err;
    int r;
    memset(&md, 0, sizeof md);
    md.data = file; md.size = size;
    if ((r = supermat_model_create(&md, &m, &err)) != SUPERMAT_SUCCESS) { printf("model: %s\n", err.message); return r; }
    memset(&sd, 0, sizeof sd);
    sd.model = m; sd.width = w; sd.height = h; sd.work_width = sd.work_height = SUPERMAT_WORK_NATIVE; sd.threads = threads;
    if (hook) { sd.threading.parallel_for = rec_for; sd.threading.max_threads = inner.max_threads; }
    if ((r = supermat_session_create(&sd, &s, &err)) != SUPERMAT_SUCCESS) { printf("session: %s\n", err.message); supermat_model_destroy(m); return r; }
    tu_disc_rgba(px, w, h, w / 2, h / 2, w / 3);
    memset(&rd, 0, sizeof rd);
    rd.input.pixels = px; rd.input.width = w; rd.input.height = h; rd.input.channels = 4; rd.input.format = SUPERMAT_FORMAT_U8;
    rd.albedo.pixels = out; rd.albedo.width = w; rd.albedo.height = h; rd.albedo.channels = 3; rd.albedo.format = SUPERMAT_FORMAT_F32;
    r = supermat_run(s, &rd, &err);
    if (r) printf("run: %s\n", err.message);
    supermat_session_destroy(s);
    supermat_model_destroy(m);
    return r;
}

int main(int argc, char **argv) {
    supermat_cpu_info c = supermat_cpu();
    const char *expect = argc > 2 ? argv[2] : "";
    supermat_pool *pool = NULL;
    supermat_threading hook;
    DWORD_PTR pm = 0, sm = 0;
    int i, all_once = 1;
    if (argc < 3) { printf("usage: test_win32 MODEL EXPECT\n"); return 2; }

    /* the CPU features and the kernel */
    CHECK(c.avx2 == has(expect, "avx2"));
    CHECK(c.avx512 == has(expect, "avx512"));
    CHECK(c.avx512_bf16 == has(expect, "avx512_bf16"));
    CHECK(c.avx512_vnni == has(expect, "avx512_vnni"));
    CHECK(c.avx_vnni == has(expect, "avx_vnni"));
    printf("cpu: avx2 %d, avx512 %d, avx512_bf16 %d, avx512_vnni %d, avx_vnni %d (expected %s)\n", c.avx2, c.avx512, c.avx512_bf16,
           c.avx512_vnni, c.avx_vnni, expect);
    {
        size_t size = 0;
        unsigned char *file = tu_load(argv[1], &size);
        supermat_model_desc md;
        supermat_model *m = NULL;
        supermat_model_info mi;
        CHECK(file != NULL);
        if (file) {
            memset(&md, 0, sizeof md);
            md.data = file; md.size = size;
            CHECK(supermat_model_create(&md, &m, NULL) == SUPERMAT_SUCCESS);
            if (m) {
                memset(&mi, 0, sizeof mi);
                supermat_model_get_info(m, &mi);
                printf("kernel picked: %d (scalar %d, avx2 %d, avx512 %d)\n", (int)mi.kernel, (int)SUPERMAT_KERNEL_SCALAR,
                       (int)SUPERMAT_KERNEL_AVX2, (int)SUPERMAT_KERNEL_AVX512);
                CHECK(mi.kernel == (c.avx512 ? SUPERMAT_KERNEL_AVX512 : c.avx2 ? SUPERMAT_KERNEL_AVX2 : SUPERMAT_KERNEL_SCALAR));
                if (c.avx2) CHECK(mi.kernel != SUPERMAT_KERNEL_SCALAR);
                supermat_model_destroy(m);
            }
            free(file);
        }
    }

    /* the pool on Win32 threads */
    CHECK(supermat_pool_create(4, NULL, &pool, &hook) == SUPERMAT_SUCCESS);
    CHECK(hook.max_threads == 4);
    if (pool) {
        hook.parallel_for(hook.user, 200, task, NULL);
        for (i = 0; i < 200; i++) if (hits[i] != 1) all_once = 0;
        CHECK(all_once);
        printf("pool of 4: 200 tasks on %d OS threads\n", distinct(ids, 200));
        CHECK(distinct(ids, 200) > 1);
        supermat_pool_destroy(pool);
    }

    /* the default thread count follows the affinity mask */
    CHECK(GetProcessAffinityMask(GetCurrentProcess(), &pm, &sm));
    {
        int n = 0;
        DWORD_PTR b;
        for (b = pm; b; b &= b - 1) n++;
        printf("affinity: %d CPUs, supermat_default_threads %d\n", n, supermat_default_threads());
        CHECK(supermat_default_threads() == (n < 64 ? n : 64));
        if (n > 1 && SetProcessAffinityMask(GetCurrentProcess(), pm & (~pm + 1))) { /* the lowest CPU alone */
            printf("affinity: 1 CPU, supermat_default_threads %d\n", supermat_default_threads());
            CHECK(supermat_default_threads() == 1);
            SetProcessAffinityMask(GetCurrentProcess(), pm);
        }
    }

    /* a session on 1 and 3 threads: the same bits; the built-in pool's work on several OS threads */
    {
        size_t size = 0;
        unsigned char *file = tu_load(argv[1], &size);
        int w = 48, h = 40;
        float *a1 = (float *)calloc((size_t)w * h * 3, sizeof(float)), *a3 = (float *)calloc((size_t)w * h * 3, sizeof(float)),
              *ah = (float *)calloc((size_t)w * h * 3, sizeof(float));
        supermat_pool *p2 = NULL;
        CHECK(file && a1 && a3 && ah);
        if (file && a1 && a3 && ah) {
            CHECK(run_model(file, size, 1, 0, a1, w, h) == SUPERMAT_SUCCESS);
            CHECK(run_model(file, size, 3, 0, a3, w, h) == SUPERMAT_SUCCESS);
            CHECK(memcmp(a1, a3, (size_t)w * h * 3 * sizeof(float)) == 0);
            CHECK(supermat_pool_create(3, NULL, &p2, &inner) == SUPERMAT_SUCCESS);
            if (p2) {
                CHECK(run_model(file, size, 0, 1, ah, w, h) == SUPERMAT_SUCCESS);
                printf("a session on a pool of 3: its tasks ran on %ld OS threads\n", (long)nseen);
                CHECK(nseen > 1);
                CHECK(memcmp(a1, ah, (size_t)w * h * 3 * sizeof(float)) == 0);
                supermat_pool_destroy(p2);
            }
        }
        free(file); free(a1); free(a3); free(ah);
    }
    return tu_finish("win32");
}
#endif
