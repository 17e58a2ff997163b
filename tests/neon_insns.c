/* The work of one NEON pass or of its scalar twin, for counting the instructions it executes under qemu
   (tests/test_neon.sh: qemu-aarch64 -singlestep -d exec,nochain prints a line per executed instruction;
   qemu's wall time says nothing about a real core). Runs PASS in MODE over fixed data REPS times.
   usage: neon_insns widen_f16|widen_bf16|widen_i8|silu|geglu|srgb|layernorm|softmax|groupnorm|lowpass scalar|neon REPS */
#define SUPERMAT_IMPLEMENTATION
#include "../supermat.h"
#include <stdio.h>

static void lp_src(void *user, int y, float *row, int thread) {
    int i;
    (void)user; (void)thread;
    for (i = 0; i < 64 * SUPERMAT__DC; i++) row[i] = (float)(i & 255) * 0.004f + (float)y * 0.001f;
}
static void lp_sink(void *user, int y, float *row, int thread) { (void)thread; if (y == 100) *(float *)user = row[77]; }

int main(int argc, char **argv) {
    enum { N = 2048, C = 64, PIX = 64 };
    static float x[N], y[N], sc[16], scratch[4096];
    static double gn[64];
    static uint16_t h[N];
    static signed char q[N];
    float *scr = scratch;
    supermat__ctx X;
    int reps, r, i, neon;
    if (argc != 4) { fprintf(stderr, "usage: %s PASS scalar|neon REPS\n", argv[0]); return 2; }
    neon = !strcmp(argv[2], "neon");
    reps = atoi(argv[3]);
    for (i = 0; i < N; i++) {
        x[i] = (float)((i * 37 % 1000) - 500) * 0.02f;
        h[i] = (uint16_t)(0x3000 + i * 7 % 0x0FFF);
        q[i] = (signed char)(i * 13 % 255 - 127);
    }
    for (i = 0; i < 16; i++) sc[i] = 0.01f * (float)(i + 1);
    memset(&X, 0, sizeof X);
    X.neon = neon;
    supermat__select_kernels(&X);
    X.thr.max_threads = 1;
    X.scratch = &scr; X.scratch_floats = 4096;
    X.gn_stats = gn; X.gn_cap = 32;
    X.cap = (size_t)1 << 20;
    X.base = (char *)malloc(X.cap);
    for (r = 0; r < reps; r++) {
        if (!strcmp(argv[1], "widen_f16")) X.widen(h, 1, sc, N / 16, y);
        else if (!strcmp(argv[1], "widen_bf16")) X.widen(h, 2, sc, N / 16, y);
        else if (!strcmp(argv[1], "widen_i8")) X.widen(q, 3, sc, N / 16, y);
        else if (!strcmp(argv[1], "silu")) supermat__silu(&X, y, x, N);
        else if (!strcmp(argv[1], "layernorm")) { /* 8 rows of 256 channels */
            static float lg[256], lb[256];
            supermat__norm nm;
            if (r == 0) for (i = 0; i < 256; i++) { lg[i] = 1.0f; lb[i] = 0.0f; }
            nm.g = lg; nm.b = lb; nm.c = 256; nm.eps = 1e-5f;
            supermat__layernorm(&X, x, y, 8, &nm);
        } else if (!strcmp(argv[1], "geglu")) supermat__geglu(&X, x, y, 8, N / 16); /* 8 rows of 128 products */
        else if (!strcmp(argv[1], "srgb")) { /* the detail and colour steps' transfer: 1024 values decoded, then encoded */
            for (i = 0; i < N / 2; i++) y[i] = (float)i / (float)(N / 2);
            supermat__xfer_n(&X, 0, y, N / 2);
            supermat__xfer_n(&X, 1, y, N / 2);
        }
        else if (!strcmp(argv[1], "softmax")) { /* the attention's online softmax over 2048 scores, in blocks of 64 */
            float m = -INFINITY, l = 0.0f;
            int b;
            memcpy(y, x, sizeof y);
            for (b = 0; b < N; b += 64) {
#if SUPERMAT__HAS_NEON
                if (neon) { supermat__softmax_block_neon(y + b, 64, 0.125f, &m, &l); continue; }
#endif
                { /* the scalar form of supermat__attention */
                    float *s = y + b, mx = -INFINITY, sum = 0.0f, mnew, corr;
                    int c;
                    for (c = 0; c < 64; c++) { s[c] *= 0.125f; if (s[c] > mx) mx = s[c]; }
                    mnew = m > mx ? m : mx;
                    corr = m == -INFINITY ? 0.0f : expf(m - mnew);
                    for (c = 0; c < 64; c++) { s[c] = expf(s[c] - mnew); sum += s[c]; }
                    l = l * corr + sum; m = mnew;
                }
            }
        } else if (!strcmp(argv[1], "groupnorm")) { /* 32 x 32 pixels... as 1 x 32 x PIX/2, 64 channels in 32 groups */
            static float gx[PIX * C], gy[PIX * C], g[C], bt[C];
            supermat__norm nm;
            supermat__t in, out;
            if (r == 0) for (i = 0; i < PIX * C; i++) gx[i] = x[i % N] + (float)(i % 7);
            if (r == 0) for (i = 0; i < C; i++) { g[i] = 1.0f; bt[i] = 0.0f; }
            nm.g = g; nm.b = bt; nm.c = C; nm.eps = 1e-5f;
            in.d = gx; in.n = 1; in.h = 8; in.w = PIX / 8; in.c = C; out = in; out.d = gy;
            supermat__groupnorm(&X, &in, &out, &nm, 32, 0);
        } else if (!strcmp(argv[1], "lowpass")) { /* the detail step's low-pass of a 64 x 64 picture, sigma 1/64 (r 1, streamed) */
            supermat__dstream D;
            supermat__dstream_get(&X, &D, 64, 64, 1.0f / 64.0f);
            D.src = lp_src; D.sink = lp_sink; D.user = y;
            supermat__dstream_run(&D);
            supermat__dstream_put(&X, &D);
        } else { fprintf(stderr, "unknown pass %s\n", argv[1]); return 2; }
    }
    printf("%s %s x%d: %g\n", argv[1], argv[2], reps, (double)y[N / 3]);
    free(X.base);
    return X.status != SUPERMAT_SUCCESS;
}
