/* libFuzzer harness: the converter's diffusers config and tokenizer readers (`supermat convert --base`):
   the input's first byte picks one of the base folder's JSON files (unet/config.json, vae/config.json,
   scheduler/scheduler_config.json, text_encoder/config.json, tokenizer/vocab.json,
   tokenizer/special_tokens_map.json, tokenizer/tokenizer_config.json) and the rest of the
   input replaces it in a copy of the committed tiny base folder (in /dev/shm), and sm_convert converts the
   tiny checkpoint with it (a valid config gives a whole conversion, so this harness runs at a few
   executions per second: most of its value is in the invalid configs it reaches). SUPERMAT_FUZZ_TINY (compiled in by
   CMake, or the environment variable) is tests/data/tiny.

     clang -g -O1 -fsanitize=fuzzer,address,undefined -I.. -I../convert -DSUPERMAT_FUZZ_TINY='"../tests/data/tiny"' \
         fuzz_config.c ../convert/sm_convert.c -o fuzz_config -lm -lpthread
     ./fuzz_config -max_total_time=3600 work corpus/config */
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200809L
#endif
#ifndef SUPERMAT_TEST_LINKED_IMPL /* tests/supermat_impl.c (CMakeLists.txt) */
#define SUPERMAT_IMPLEMENTATION
#endif
#include "supermat.h"
#include "sm_convert.h"
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef SUPERMAT_FUZZ_TINY
#define SUPERMAT_FUZZ_TINY "tests/data/tiny"
#endif

static const char *const files[] = {"unet/config.json", "vae/config.json", "scheduler/scheduler_config.json", "text_encoder/config.json",
                                    "tokenizer/vocab.json", "tokenizer/special_tokens_map.json", "tokenizer/tokenizer_config.json"};
enum { NFILES = sizeof files / sizeof files[0] };
static char base[256], tiny[1024], out[300];
static unsigned char *orig[NFILES];
static size_t orig_n[NFILES];

static int put(const char *path, const void *p, size_t n) {
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    if (n && fwrite(p, 1, n, f) != n) { fclose(f); return -1; }
    return fclose(f);
}
static unsigned char *get(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    unsigned char *b = NULL;
    long sz;
    *n = 0;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (sz = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0 && (b = (unsigned char *)malloc((size_t)sz + 1)) != NULL &&
        fread(b, 1, (size_t)sz, f) == (size_t)sz) *n = (size_t)sz;
    fclose(f);
    return b;
}

static int setup(void) {
    static const char *const dirs[] = {"", "/unet", "/vae", "/scheduler", "/text_encoder", "/tokenizer"};
    static const char vocab[] = "{\"!\": 0, \"a</w>\": 320, \"<|startoftext|>\": 49406, \"<|endoftext|>\": 49407}";
    static const char special[] = "{\"bos_token\": \"<|startoftext|>\", \"eos_token\": \"<|endoftext|>\", \"pad_token\": \"!\", \"unk_token\": \"<|endoftext|>\"}";
    static const char tcfg[] = "{\"model_max_length\": 77, \"pad_token\": \"!\"}";
    const char *env = getenv("SUPERMAT_FUZZ_TINY");
    struct stat st;
    char path[1400];
    size_t k;
    snprintf(tiny, sizeof tiny, "%s", env && env[0] ? env : SUPERMAT_FUZZ_TINY);
    snprintf(base, sizeof base, "%s/supermat_fuzz_config_%ld", stat("/dev/shm", &st) == 0 ? "/dev/shm" : "/tmp", (long)getpid());
    for (k = 0; k < sizeof dirs / sizeof dirs[0]; k++) { snprintf(path, sizeof path, "%s%s", base, dirs[k]); mkdir(path, 0777); }
    for (k = 0; k < NFILES; k++) {
        snprintf(path, sizeof path, "%s/base/%s", tiny, files[k]);
        orig[k] = get(path, &orig_n[k]);
        if (!orig[k]) { /* the tokenizer: small valid files of our own */
            const char *s = k == 4 ? vocab : k == 5 ? special : tcfg;
            orig_n[k] = strlen(s);
            orig[k] = (unsigned char *)malloc(orig_n[k] + 1);
            if (!orig[k]) return -1;
            memcpy(orig[k], s, orig_n[k]);
        }
        snprintf(path, sizeof path, "%s/%s", base, files[k]);
        if (put(path, orig[k], orig_n[k])) return -1;
    }
    /* the weights: links to the committed files */
    snprintf(path, sizeof path, "%s/base/vae/diffusion_pytorch_model.safetensors", tiny);
    { char dst[400]; snprintf(dst, sizeof dst, "%s/vae/diffusion_pytorch_model.safetensors", base); if (symlink(path, dst) && errno != EEXIST) return -1; }
    snprintf(path, sizeof path, "%s/base/text_encoder/model.safetensors", tiny);
    { char dst[400]; snprintf(dst, sizeof dst, "%s/text_encoder/model.safetensors", base); if (symlink(path, dst) && errno != EEXIST) return -1; }
    snprintf(out, sizeof out, "%s/out.safetensors", base);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static int ready, last = -1;
    char path[400], err[1024], ckpt[1100];
    sm_convert_desc d;
    int which;
    if (!ready) { if (setup()) return 0; ready = 1; }
    if (size < 1) return 0;
    which = data[0] % NFILES;
    if (last >= 0 && last != which) { snprintf(path, sizeof path, "%s/%s", base, files[last]); put(path, orig[last], orig_n[last]); }
    snprintf(path, sizeof path, "%s/%s", base, files[which]);
    if (put(path, data + 1, size - 1)) return 0;
    last = which;
    snprintf(ckpt, sizeof ckpt, "%s/supermat.pth", tiny);
    memset(&d, 0, sizeof d);
    d.kind = "supermat"; d.checkpoint = ckpt; d.base_dir = base; d.output = out; d.threads = 1;
    if (sm_convert(&d, err, sizeof err) == 0) {
        supermat_model_desc md; /* the converted file must load */
        supermat_model *m = NULL;
        supermat_error e;
        size_t n = 0;
        unsigned char *b = get(out, &n);
        memset(&md, 0, sizeof md);
        md.data = b; md.size = n;
        if (b && supermat_model_create(&md, &m, &e) == SUPERMAT_SUCCESS) supermat_model_destroy(m);
        free(b);
    }
    remove(out);
    return 0;
}
