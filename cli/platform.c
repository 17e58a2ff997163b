/* cli/platform.c - includes, stb, timing, small helpers.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>platform */
#if !defined(_WIN32)
#ifndef _FILE_OFFSET_BITS
#define _FILE_OFFSET_BITS 64
#endif
#if !defined(_POSIX_C_SOURCE) && !defined(__APPLE__)
#define _POSIX_C_SOURCE 200809L
#endif
#if !defined(_XOPEN_SOURCE) && !defined(__APPLE__)
#define _XOPEN_SOURCE 700 /* realpath */
#endif
#endif

#define SUPERMAT_IMPLEMENTATION
#include "supermat.h"
#include "sm_convert.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/stat.h>
#include <sys/types.h>
#if !defined(_WIN32)
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>
extern char **environ;
#endif
#include "smio.h" /* on Windows it brings win32.h: the POSIX calls below over the wide Win32 API */

/* stb: their warnings are not ours */
#if defined(__GNUC__) || defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpragmas"
#pragma GCC diagnostic ignored "-Wunknown-warning-option"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wcast-qual"
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#pragma GCC diagnostic ignored "-Wzero-as-null-pointer-constant"
#pragma GCC diagnostic ignored "-Wcomma"
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#endif
#define STB_IMAGE_IMPLEMENTATION
#define STBI_FAILURE_USERMSG
/* the formats the CLI documents, no others (picture_check.h: why) */
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_ONLY_BMP
#define STBI_ONLY_TGA
/* zeroed allocations: stb_image 2.27 decodes a JPEG scan with a Huffman table no DHT segment defined from its
   malloc'ed, uninitialised state (an index millions of bytes off; fuzz/fuzz_picture.c), and zeroed it decodes
   nothing out of bounds (every code hits the first slot of the acceleration table) */
#define STBI_MALLOC(sz) calloc(1, (sz))
#define STBI_REALLOC(p, sz) realloc((p), (sz))
#define STBI_FREE(p) free(p)
#include <stb/stb_image.h>
#ifdef SUPERMAT_CLI_WEBP
#include <webp/decode.h>
#endif
/* PNG compression: zlib's deflate when the build has zlib (CMake finds zlib1g-dev: SUPERMAT_CLI_ZLIB), several
   times faster than stb_image_write's own and smaller files (the pixels are the same either way) */
#ifdef SUPERMAT_CLI_ZLIB
#include <zlib.h>
static unsigned char *cli_zlib_compress(unsigned char *data, int len, int *out_len, int quality) {
    uLongf n = compressBound((uLong)len);
    unsigned char *out = (unsigned char *)malloc(n);
    (void)quality;
    if (!out) return NULL;
    if (compress2(out, &n, data, (uLong)len, Z_DEFAULT_COMPRESSION) != Z_OK) { free(out); return NULL; }
    *out_len = (int)n;
    return out;
}
#define STBIW_ZLIB_COMPRESS cli_zlib_compress
#endif
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#if defined(__GNUC__) || defined(__clang__)
#pragma GCC diagnostic pop
#endif
#include "picture_check.h"

/* stb_image's reason for the last failure, never NULL */
static const char *cli_stbi_reason(void) {
    const char *r = stbi_failure_reason();
    return r ? r : "not a picture supermat reads";
}

#if defined(__GNUC__) || defined(__clang__)
#define CLI_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define CLI_PRINTF(f, a)
#endif

#define CLI_OK 0
#define CLI_FAIL 1
#define CLI_USAGE 2

static double cli_now(void) {
#if defined(_WIN32)
    LARGE_INTEGER t, f;
    QueryPerformanceCounter(&t);
    QueryPerformanceFrequency(&f);
    return (double)t.QuadPart / (double)f.QuadPart;
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
#endif
}

/* a process-wide lock around io.c's few shared tables: `batch --jobs` runs its workers as threads on Windows
   (as processes elsewhere, where this does nothing) */
static void cli_lock(int on) {
#if defined(_WIN32)
    smw_locked(on);
#else
    (void)on;
#endif
}

/* Runs the program argv[0] (looked up in PATH; no shell: the argument vector as given) with `input` (or
   nothing) written to its stdin and its stdout collected into out (cap bytes at most, NUL-terminated); its
   stderr is ours. Returns its exit status, 128 + a signal, or -1 when it could not be run (errno; ENOENT:
   not found). POSIX: posix_spawnp and pipes; Windows: CreateProcessW and pipes (win32.h). */
static int cli_spawn_piped(char **argv, const char *input, char *out, size_t cap) {
#if defined(_WIN32)
    return smw_spawn_piped(argv, input, out, cap);
#else
    int in[2], po[2], st = 0, r;
    size_t n = 0;
    pid_t pid;
    posix_spawn_file_actions_t fa;
    struct sigaction ign, old;
    if (pipe(in) != 0) return -1;
    if (pipe(po) != 0) { r = errno; close(in[0]); close(in[1]); errno = r; return -1; }
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, in[0], 0);
    posix_spawn_file_actions_adddup2(&fa, po[1], 1);
    posix_spawn_file_actions_addclose(&fa, in[0]);
    posix_spawn_file_actions_addclose(&fa, in[1]);
    posix_spawn_file_actions_addclose(&fa, po[0]);
    posix_spawn_file_actions_addclose(&fa, po[1]);
    fflush(stdout);
    fflush(stderr);
    r = posix_spawnp(&pid, argv[0], &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    close(in[0]);
    close(po[1]);
    if (r != 0) {
        close(in[1]);
        close(po[0]);
        errno = r;
        return -1;
    }
    memset(&ign, 0, sizeof ign);
    ign.sa_handler = SIG_IGN;
    sigaction(SIGPIPE, &ign, &old); /* a program that exits before reading its input must not kill us */
    if (input && *input) {
        size_t len = strlen(input), w = 0;
        while (w < len) {
            ssize_t k = write(in[1], input + w, len - w);
            if (k < 0 && errno == EINTR) continue;
            if (k <= 0) break;
            w += (size_t)k;
        }
    }
    close(in[1]);
    for (;;) {
        char tmp[4096];
        ssize_t k = read(po[0], tmp, sizeof tmp);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) break;
        if (out && n + 1 < cap) {
            size_t c = (size_t)k < cap - 1 - n ? (size_t)k : cap - 1 - n;
            memcpy(out + n, tmp, c);
            n += c;
        }
    }
    if (out && cap) out[n] = 0;
    close(po[0]);
    sigaction(SIGPIPE, &old, NULL);
    while (waitpid(pid, &st, 0) < 0)
        if (errno != EINTR) return -1;
    if (WIFEXITED(st)) return WEXITSTATUS(st);
    return 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
#endif
}

/* main()'s arguments in UTF-8: on Windows from GetCommandLineW (argv is in the ANSI code page there) */
static void cli_platform_args(int *argc, char ***argv) {
#if defined(_WIN32)
    smw_args(argc, argv);
#else
    (void)argc; (void)argv;
#endif
}

/* A stream whose bytes end up in memory (open_memstream): cli_memstream_close gives them, malloc'ed (*buf,
   *len), and closes it; -1 when a write failed or memory ran out. Windows has no open_memstream: a temporary
   file deleted on close ("D"), read back. */
static FILE *cli_memstream_open(char **buf, size_t *len) {
#if defined(_WIN32)
    wchar_t dir[MAX_PATH + 1], name[MAX_PATH + 16];
    *buf = NULL; *len = 0;
    if (!GetTempPathW(MAX_PATH + 1, dir) || !GetTempFileNameW(dir, L"smm", 0, name)) return NULL;
    return _wfopen(name, L"w+bD");
#else
    return open_memstream(buf, len);
#endif
}
static int cli_memstream_close(FILE *f, char **buf, size_t *len) {
#if defined(_WIN32)
    long long n;
    int bad = fflush(f) != 0 || ferror(f) || _fseeki64(f, 0, SEEK_END) != 0 || (n = _ftelli64(f)) < 0 || _fseeki64(f, 0, SEEK_SET) != 0;
    *buf = NULL; *len = 0;
    if (!bad && (*buf = (char *)malloc((size_t)n + 1)) != NULL && fread(*buf, 1, (size_t)n, f) == (size_t)n) {
        (*buf)[n] = 0;
        *len = (size_t)n;
    } else {
        free(*buf);
        *buf = NULL;
        bad = 1;
    }
    return fclose(f) != 0 || bad ? -1 : 0;
#else
    (void)buf; (void)len;
    return fclose(f) != 0 ? -1 : 0;
#endif
}

static double cli_mib(double bytes) { return bytes / (1024.0 * 1024.0); }

static void cli_error(const char *fmt, ...) CLI_PRINTF(1, 2);
#if defined(_WIN32) && (defined(__GNUC__) || defined(__clang__))
#define CLI_THREAD_LOCAL __thread /* batch --jobs: worker threads on Windows (processes elsewhere) */
#elif defined(_WIN32) && defined(_MSC_VER)
#define CLI_THREAD_LOCAL __declspec(thread)
#else
#define CLI_THREAD_LOCAL
#endif
static CLI_THREAD_LOCAL char cli_last_error[4096]; /* the last message cli_error printed (a batch journals it) */
static int cli_quiet;             /* keep messages in cli_last_error only (the fuzz harnesses) */
static void cli_error(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(cli_last_error, sizeof cli_last_error, fmt, ap);
    va_end(ap);
    if (!cli_quiet) fprintf(stderr, "supermat: error: %s\n", cli_last_error);
}

/* the library's message, the tensor concerned and the result name */
static void cli_lib_error(const char *what, supermat_result r, const supermat_error *e) {
    const char *msg = e && e->message[0] ? e->message : supermat_result_string(r);
    if (e && e->tensor[0]) cli_error("%s: %s (tensor '%s') [%s]", what, msg, e->tensor, supermat_result_string(r));
    else cli_error("%s: %s [%s]", what, msg, supermat_result_string(r));
}

static const char *cli_kind_name(supermat_model_kind k) {
    switch (k) {
    case SUPERMAT_KIND_SUPERMAT: return "supermat";
    case SUPERMAT_KIND_SUPERMAT_MV: return "supermat-mv";
    case SUPERMAT_KIND_UV_REFINE: return "uv-refine";
    default: return "unknown";
    }
}
static const char *cli_kernel_name(supermat_kernel k) {
    switch (k) {
    case SUPERMAT_KERNEL_SCALAR: return "scalar";
    case SUPERMAT_KERNEL_AVX2: return "avx2";
    case SUPERMAT_KERNEL_AVX512: return "avx512";
    case SUPERMAT_KERNEL_NEON: return "neon";
    case SUPERMAT_KERNEL_AMX: return "amx";
    default: return "auto";
    }
}
static const char *cli_dtype_name(supermat_dtype d) {
    switch (d) {
    case SUPERMAT_DTYPE_F32: return "F32";
    case SUPERMAT_DTYPE_F16: return "F16";
    case SUPERMAT_DTYPE_BF16: return "BF16";
    case SUPERMAT_DTYPE_I8: return "I8";
    default: return "?";
    }
}
static void cli_outputs_string(unsigned outputs, char *buf, size_t cap) {
    buf[0] = 0;
    if (outputs & SUPERMAT_OUTPUT_ALBEDO) snprintf(buf + strlen(buf), cap - strlen(buf), "albedo");
    if (outputs & SUPERMAT_OUTPUT_ROUGHNESS) snprintf(buf + strlen(buf), cap - strlen(buf), "%sroughness", buf[0] ? "," : "");
    if (outputs & SUPERMAT_OUTPUT_METALLIC) snprintf(buf + strlen(buf), cap - strlen(buf), "%smetallic", buf[0] ? "," : "");
}
