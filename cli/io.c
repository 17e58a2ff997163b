/* cli/io.c - the shared I/O module: reading files, creating folders, the overwrite policy, atomic writes (FILE.tmp, checked, renamed), PNG / PFM / JSON report writers, and pictures as users have them (16-bit, EXIF, WebP, folders).
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>files */
/* Big files (model files) are mapped read-only instead of read: no copy, and no page zeroing for
   gigabytes of buffer; the library only reads them. cli_free_file() releases either kind. */
static struct { void *p; size_t n; } cli_maps[8];
static void cli_free_file(void *p) {
    int i;
    if (!p) return;
    cli_lock(1);
    for (i = 0; i < 8; i++)
        if (cli_maps[i].p == p) { munmap(p, cli_maps[i].n); cli_maps[i].p = NULL; cli_lock(0); return; }
    cli_lock(0);
    free(p);
}

/* Reads (or maps) a whole file (64-bit sizes): only a regular file (smio.h: a FIFO, a device or a folder
   is refused without blocking). 0 on success, else prints an error and returns CLI_FAIL. */
static int cli_read_file(const char *path, unsigned char **data, size_t *size) {
    struct stat st;
    unsigned char *buf;
    size_t n;
    char why[256];
    int fd = smio_open_regular(path, 0, why, sizeof why);
    *data = NULL; *size = 0;
    if (fd < 0) {
        if (errno == ENOENT) cli_error("cannot open '%s': %s", path, strerror(ENOENT));
        else cli_error("cannot open '%s': it %s", path, why);
        return CLI_FAIL;
    }
    if (fstat(fd, &st) != 0) { cli_error("cannot read '%s': %s", path, strerror(errno)); close(fd); return CLI_FAIL; }
    if (st.st_size < 0 || (uint64_t)st.st_size > (uint64_t)(SIZE_MAX - 64)) {
        cli_error("'%s' is too large for this machine's address space", path);
        close(fd);
        return CLI_FAIL;
    }
    n = (size_t)st.st_size;
    if (n >= ((size_t)1 << 20)) {
        int i;
        cli_lock(1);
        for (i = 0; i < 8 && cli_maps[i].p; i++) {}
        if (i < 8) {
            void *m = mmap(NULL, n, PROT_READ, MAP_PRIVATE, fd, 0); /* Windows: CreateFileMappingW (win32.h) */
            if (m != MAP_FAILED) {
                cli_maps[i].p = m; cli_maps[i].n = n;
                cli_lock(0);
                close(fd);
                *data = (unsigned char *)m; *size = n;
                return CLI_OK;
            }
        }
        cli_lock(0);
    }
    buf = (unsigned char *)malloc(n ? n : 1);
    if (!buf) { cli_error("out of memory reading '%s' (%.1f MiB)", path, cli_mib((double)n)); close(fd); return CLI_FAIL; }
    if (smio_read_all(fd, buf, n) != 0) {
        cli_error("cannot read '%s': %s", path, errno ? strerror(errno) : "the file got shorter while reading");
        free(buf);
        close(fd);
        return CLI_FAIL;
    }
    close(fd);
    *data = buf; *size = n;
    return CLI_OK;
}

/* mkdir -p */
static int cli_mkdirs(const char *dir) {
    size_t n = strlen(dir), i;
    char *p = (char *)malloc(n + 1);
    struct stat st;
    if (!p) { cli_error("out of memory"); return CLI_FAIL; }
    memcpy(p, dir, n + 1);
    for (i = 1; i <= n; i++) {
        if (p[i] == '/' || p[i] == 0) {
            char c = p[i];
            p[i] = 0;
            if (mkdir(p, 0777) != 0 && errno != EEXIST) {
                cli_error("cannot create folder '%s': %s", p, strerror(errno));
                free(p);
                return CLI_FAIL;
            }
            p[i] = c;
        }
    }
    free(p);
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) { cli_error("'%s' is not a folder", dir); return CLI_FAIL; }
    return CLI_OK;
}

/* the folders rel below the output folder root, made where missing, none of them through a link */
static int cli_mkdirs_below(const char *root, const char *rel) {
    char msg[1024];
    int fd = smio_dir_open(root, rel, 1, msg, sizeof msg);
    if (fd < 0) { cli_error("%s", msg); return CLI_FAIL; }
    close(fd);
    return CLI_OK;
}

/* malloc'ed "dir/stem suffix" */
static char *cli_join(const char *dir, const char *stem, const char *suffix) {
    size_t a = strlen(dir), b = strlen(stem), c = strlen(suffix);
    char *p = (char *)malloc(a + b + c + 2);
    if (!p) return NULL;
    memcpy(p, dir, a);
    if (a && dir[a - 1] != '/') p[a++] = '/';
    memcpy(p + a, stem, b);
    memcpy(p + a + b, suffix, c + 1);
    return p;
}

/* malloc'ed file name without folder and last extension */
static char *cli_stem(const char *path) {
    const char *b = strrchr(path, '/'), *dot;
    size_t n;
    char *s;
    b = b ? b + 1 : path;
    dot = strrchr(b, '.');
    n = dot && dot != b ? (size_t)(dot - b) : strlen(b);
    s = (char *)malloc(n + 1);
    if (!s) return NULL;
    memcpy(s, b, n);
    s[n] = 0;
    return s;
}

/* the stem of a picture that shares its stem with another input (a.png and a.jpg): the extension kept,
   "a_png" ("a" when there is none); `image` and `batch` name such pictures' maps this way */
static char *cli_stem_with_ext(const char *path) {
    const char *b = strrchr(path, '/'), *dot;
    char *s, *p;
    b = b ? b + 1 : path;
    dot = strrchr(b, '.');
    s = cli_stem(path);
    if (!s || !dot || dot == b || !dot[1]) return s;
    p = (char *)malloc(strlen(s) + strlen(dot) + 1);
    if (p) sprintf(p, "%s_%s", s, dot + 1);
    free(s);
    return p;
}

/* The overwrite policy of every output file (main() takes --force / --skip-existing before any command
   sees its options): by default a path that exists -- a file, a symbolic link (live or dangling), anything
   -- and that this run did not write is refused before anything is written, and the final step links
   PATH.tmp to PATH without replacing anything (link(): atomic, so a file that appears meanwhile is not
   clobbered either). --force replaces it (a symbolic link itself is replaced, its target untouched);
   --skip-existing keeps it and goes on. A path this run wrote itself may be written again. */
enum { CLI_POLICY_REFUSE = 0, CLI_POLICY_FORCE, CLI_POLICY_SKIP }; /* = supermat_cli_mesh_global's 0, 1, 2 */

/* The global options (`supermat --help` prints cli_opts_global): main() fills one cli_global_opts from argv
   through that table (cli_global_parse, before any command sees its own options) and hands it here with
   cli_global_set; the I/O layer reads it from cli_g alone. A single static rather than a pointer through
   every write, since every command writes through this file: these are process-wide options, fixed
   before any command runs. The one change after that: `batch` owns its output folder (cli_io_own_outputs,
   below). Commands that run another one pass them on explicitly (mesh: supermat_cli_mesh_global). */
typedef struct cli_global_opts {
    int policy;        /* CLI_POLICY_*: --force, --skip-existing, neither (refuse existing outputs) */
    int allow_outside; /* --allow-outside-refs: trusted local use (mesh: references outside the asset's
                          folder; batch: linked pictures outside an input folder) */
} cli_global_opts;
static cli_global_opts cli_g = {CLI_POLICY_REFUSE, 0};
static void cli_global_set(const cli_global_opts *g) { cli_g = *g; }

enum { CLI_G_FORCE = 1, CLI_G_SKIP_EXISTING, CLI_G_ALLOW_OUTSIDE };
static const cli_optdef cli_opts_global[] = {
    {CLI_G_FORCE, "--force", NULL, "replace existing files (a symbolic link itself, not its target)", NULL, NULL},
    {CLI_G_SKIP_EXISTING, "--skip-existing", NULL, "keep existing files and go on (an input whose maps all exist is not run)", NULL, NULL},
    {CLI_G_ALLOW_OUTSIDE, "--allow-outside-refs", NULL, "trusted files only: `mesh` reads references outside the asset's folder,\n"
                                                        "`batch` takes linked pictures that lead outside an input folder", NULL, NULL},
    CLI_END};

/* The global options, anywhere after the command name and before a "--": into *g, and taken out of argv
   (*argc shrinks; argv[*argc] = NULL), so that a command sees only its own options. CLI_OK, or CLI_USAGE
   after the message. */
static int cli_global_parse(int *argc, char **argv, cli_global_opts *g) {
    int i, j;
    memset(g, 0, sizeof *g);
    g->policy = CLI_POLICY_REFUSE;
    if (*argc <= 2) return CLI_OK;
    for (i = j = 2; i < *argc; i++) {
        const char *a = argv[i], *eq = strchr(a, '=');
        size_t n = eq ? (size_t)(eq - a) : strlen(a);
        const cli_optdef *o;
        if (!strcmp(a, "--")) { while (i < *argc) argv[j++] = argv[i++]; break; }
        o = a[0] == '-' && a[1] == '-' ? cli_opt_find(cli_opts_global, a, n) : NULL;
        if (!o) { argv[j++] = argv[i]; continue; }
        if (eq) return cli_usage_error(NULL, "option '%s' takes no value", o->name);
        if (o->id == CLI_G_ALLOW_OUTSIDE) { g->allow_outside = 1; continue; }
        {
            int want = o->id == CLI_G_FORCE ? CLI_POLICY_FORCE : CLI_POLICY_SKIP;
            if (g->policy != CLI_POLICY_REFUSE && g->policy != want) return cli_usage_error(NULL, "--force and --skip-existing exclude each other");
            g->policy = want;
        }
    }
    *argc = j;
    argv[j] = NULL;
    return CLI_OK;
}
static char **cli_written;
static size_t cli_nwritten, cli_capwritten;
#define CLI_SKIPPED 3 /* cli_out_allowed: keep the existing file (not an exit status) */

static int cli_wrote(const char *path) {
    size_t i;
    for (i = 0; i < cli_nwritten; i++) if (!strcmp(cli_written[i], path)) return 1;
    return 0;
}

static void cli_note_written(const char *path) {
    size_t n = strlen(path) + 1;
    char *c;
    if (cli_g.policy == CLI_POLICY_FORCE || cli_wrote(path)) return; /* --force consults no list (a batch writes many files) */
    if (cli_nwritten == cli_capwritten) {
        size_t cap = cli_capwritten ? 2 * cli_capwritten : 64;
        char **w = (char **)realloc(cli_written, cap * sizeof *w);
        if (!w) return; /* only loses the right to rewrite it in this run */
        cli_written = w;
        cli_capwritten = cap;
    }
    if ((c = (char *)malloc(n)) != NULL) { memcpy(c, path, n); cli_written[cli_nwritten++] = c; }
}

/* CLI_OK: write PATH; CLI_SKIPPED: keep it (--skip-existing); CLI_FAIL: refused, with the message */
static int cli_out_allowed(const char *path) {
    struct stat st;
    if (lstat(path, &st) != 0 || cli_wrote(path) || cli_g.policy == CLI_POLICY_FORCE) return CLI_OK;
    if (cli_g.policy == CLI_POLICY_SKIP) return CLI_SKIPPED;
    cli_error("'%s' exists%s and was not written by this run: --force replaces it, --skip-existing keeps it",
              path, S_ISLNK(st.st_mode) ? " (a symbolic link)" : S_ISDIR(st.st_mode) ? " (a folder)" : "");
    return CLI_FAIL;
}

/* The output folder whose sub-folders a command writes into (`batch`: DIR/<folder>/...): below it every
   folder is opened without following a link (smio_dir_open), so a link planted there is refused. A path
   outside it is written in the folder its name says (the user's choice, links included). */
static const char *cli_out_root;

/* `batch`: DIR belongs to the batch. Below it no link is followed (cli_out_root), and an output there that
   the journal does not say is done is replaced: the policy becomes --force (batch refuses
   --skip-existing itself). */
static void cli_io_own_outputs(const char *dir) {
    cli_out_root = dir;
    cli_g.policy = CLI_POLICY_FORCE;
}

/* the folder of path (opened as above) and its last component; -1 and the message when it cannot be */
static int cli_out_dirfd(const char *path, const char **base) {
    const char *slash = strrchr(path, '/');
    size_t rn = cli_out_root ? strlen(cli_out_root) : 0;
    char msg[1024], *dir;
    int fd;
    *base = slash ? slash + 1 : path;
    if (!slash) {
        fd = open(".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd < 0) cli_error("cannot write '%s': the current folder: %s", path, strerror(errno));
        return fd;
    }
    dir = (char *)malloc((size_t)(slash - path) + 2);
    if (!dir) { cli_error("out of memory"); return -1; }
    memcpy(dir, path, (size_t)(slash - path));
    dir[slash - path] = 0;
    if (slash == path) strcpy(dir, "/");
    while (rn > 1 && cli_out_root[rn - 1] == '/') rn--;
    if (cli_out_root && rn && !strncmp(dir, cli_out_root, rn) && (dir[rn] == '/' || dir[rn] == 0)) {
        char *root = (char *)malloc(rn + 1);
        if (!root) { free(dir); cli_error("out of memory"); return -1; }
        memcpy(root, cli_out_root, rn);
        root[rn] = 0;
        fd = smio_dir_open(root, dir + rn, 0, msg, sizeof msg); /* made before: cli_mkdirs_below */
        free(root);
    } else
        fd = smio_dir_open(dir, "", 0, msg, sizeof msg);
    if (fd < 0) cli_error("cannot write '%s': %s", path, msg);
    free(dir);
    return fd;
}

/* The output-folder policy of every command: a folder named by --out DIR is created; the folder of an
   output FILE must exist, and is checked here before any work (CLI_OK, or CLI_FAIL after the message). */
static int cli_out_folder_ok(const char *path) {
    const char *base;
    int fd = cli_out_dirfd(path, &base);
    if (fd < 0) return CLI_FAIL;
    close(fd);
    return CLI_OK;
}

/* The folders whose leftovers of dead runs were removed (smio_clean_stale), once per folder and process */
typedef struct cli_dir_id { unsigned long long dev, ino; } cli_dir_id; /* wide enough for Windows' 64-bit file index */
static cli_dir_id *cli_cleaned;
static size_t cli_ncleaned, cli_capcleaned;
static void cli_clean_once_locked(int dirfd) {
    struct stat st;
    size_t i;
    if (fstat(dirfd, &st) != 0) return;
    for (i = 0; i < cli_ncleaned; i++)
        if (cli_cleaned[i].dev == st.st_dev && cli_cleaned[i].ino == st.st_ino) return;
    if (cli_ncleaned == cli_capcleaned) {
        size_t cap = cli_capcleaned ? 2 * cli_capcleaned : 16;
        cli_dir_id *v = (cli_dir_id *)realloc(cli_cleaned, cap * sizeof *cli_cleaned);
        if (!v) return;
        cli_cleaned = v;
        cli_capcleaned = cap;
    }
    cli_cleaned[cli_ncleaned].dev = st.st_dev;
    cli_cleaned[cli_ncleaned].ino = st.st_ino;
    cli_ncleaned++;
    smio_clean_stale(dirfd);
}
static void cli_clean_once(int dirfd) {
    cli_lock(1);
    cli_clean_once_locked(dirfd);
    cli_lock(0);
}

/* Output files are written to a new temporary file beside PATH (smio_tmp_create: a unique name created
   with O_EXCL | O_NOFOLLOW, never an existing file or link), fsync()ed, and renamed (or linked) to PATH
   once complete and closed without error: a failed write leaves neither a half-written PATH nor the
   temporary file (and keeps an older PATH as it was); a killed run's temporary file is removed by the
   next run writing into that folder. Neither the rename nor the link follows a link at PATH. */
typedef struct cli_out {
    FILE *f;
    int dirfd;       /* PATH's folder */
    const char *base;/* PATH's last component */
    char tmp[256];   /* the temporary file's name in dirfd */
    const char *path;
    int err;         /* the first errno of a failed write, or -1; 0 while all is well */
    int skip;        /* --skip-existing and PATH exists: nothing is written */
    int replace;     /* PATH may be replaced (--force, or written by this run) */
} cli_out;

static int cli_out_open(cli_out *o, const char *path) {
    int a, fd;
    memset(o, 0, sizeof *o);
    o->dirfd = -1;
    o->path = path;
    a = cli_out_allowed(path);
    if (a == CLI_FAIL) return CLI_FAIL;
    if (a == CLI_SKIPPED) { o->skip = 1; return CLI_OK; }
    o->replace = cli_g.policy == CLI_POLICY_FORCE || cli_wrote(path);
    if ((o->dirfd = cli_out_dirfd(path, &o->base)) < 0) return CLI_FAIL;
    cli_clean_once(o->dirfd);
    fd = smio_tmp_create(o->dirfd, o->base, o->tmp, sizeof o->tmp);
    if (fd < 0 || !(o->f = fdopen(fd, "wb"))) {
        cli_error("cannot write '%s': %s", path, strerror(errno));
        if (fd >= 0) { close(fd); unlinkat(o->dirfd, o->tmp, 0); }
        close(o->dirfd);
        o->dirfd = -1;
        return CLI_FAIL;
    }
    return CLI_OK;
}

/* malloc'ed path of the temporary file (to read it back before the rename), or NULL */
static char *cli_out_tmp_path(const cli_out *o) {
    size_t d = (size_t)(o->base - o->path);
    char *p = (char *)malloc(d + strlen(o->tmp) + 1);
    if (!p) return NULL;
    memcpy(p, o->path, d);
    strcpy(p + d, o->tmp);
    return p;
}

static void cli_out_write(cli_out *o, const void *data, size_t n) {
    if (o->skip || o->err || !n) return;
    errno = 0;
    if (fwrite(data, 1, n, o->f) != n) o->err = errno ? errno : -1;
}

/* stb_image_write's callback */
static void cli_out_stbi(void *ctx, void *data, int n) {
    if (n > 0) cli_out_write((cli_out *)ctx, data, (size_t)n);
}

/* ok = the caller's part succeeded: closes, then renames PATH.tmp to PATH, or removes PATH.tmp
   (with a message unless the caller failed and has said why) */
static int cli_out_close(cli_out *o, int ok) {
    int rc = CLI_OK, exists = 0;
    if (o->skip) {
        if (ok) fprintf(stderr, "kept '%s' (it exists; --skip-existing)\n", o->path);
        return ok ? CLI_OK : CLI_FAIL;
    }
    if (!o->f) return CLI_FAIL;
    errno = 0;
    if (fflush(o->f) != 0 && !o->err) o->err = errno ? errno : -1;
    errno = 0;
    if (ok && !o->err && fsync(fileno(o->f)) != 0 && errno != EINVAL && errno != EROFS) o->err = errno ? errno : -1;
    errno = 0;
    if (fclose(o->f) != 0 && !o->err) o->err = errno ? errno : -1;
    o->f = NULL;
    errno = 0;
    if (ok && !o->err) {
        if (o->replace) {
            if (renameat(o->dirfd, o->tmp, o->dirfd, o->base) != 0) o->err = errno ? errno : -1;
        } else if (linkat(o->dirfd, o->tmp, o->dirfd, o->base, 0) == 0) {
            unlinkat(o->dirfd, o->tmp, 0);      /* PATH is the new file; only the temporary name goes */
        } else if (errno == EEXIST) {
            exists = 1;                        /* it appeared while we computed */
        } else {                               /* a file system without hard links: check, then rename */
            struct stat st;
            if (fstatat(o->dirfd, o->base, &st, AT_SYMLINK_NOFOLLOW) == 0) exists = 1;
            else if (renameat(o->dirfd, o->tmp, o->dirfd, o->base) != 0) o->err = errno ? errno : -1;
        }
        if (!o->err && !exists) (void)fsync(o->dirfd); /* the new name on disk too */
    }
    if (exists) {
        cli_error("'%s' appeared while it was being written, and was not written by this run: kept it (--force replaces it)", o->path);
        unlinkat(o->dirfd, o->tmp, 0);
        rc = CLI_FAIL;
    } else if (!ok || o->err) {
        if (ok) cli_error("cannot write '%s': %s", o->path, o->err > 0 ? strerror(o->err) : "write error");
        unlinkat(o->dirfd, o->tmp, 0);
        rc = CLI_FAIL;
    } else {
        cli_note_written(o->path);
    }
    close(o->dirfd);
    o->dirfd = -1;
    return rc;
}

/* A text output built in memory (open_memstream), then written like every output: the overwrite policy,
   FILE.tmp, rename. cli_mem_open checks the policy first (before the work that fills it). */
typedef struct cli_mem {
    FILE *f;
    char *buf;
    size_t len;
} cli_mem;

/* may a report (a file the work produces, not an input's output) be written at path? CLI_OK or CLI_FAIL
   with the message; --skip-existing does not apply to a report: it refuses */
static int cli_report_allowed(const char *path) {
    if (cli_out_allowed(path) == CLI_OK) return CLI_OK;
    if (cli_g.policy == CLI_POLICY_SKIP) cli_error("'%s' exists: --skip-existing keeps files, --force replaces this report", path);
    return CLI_FAIL;
}

static FILE *cli_mem_open(cli_mem *m, const char *path) {
    memset(m, 0, sizeof *m);
    if (cli_report_allowed(path) != CLI_OK) return NULL;
    m->f = cli_memstream_open(&m->buf, &m->len);
    if (!m->f) cli_error("out of memory");
    return m->f;
}

/* closes the stream m->f (already closed when closed = 1) and writes its bytes to path; ok = 0: discards */
static int cli_mem_commit(cli_mem *m, const char *path, int ok, int closed) {
    int rc = CLI_FAIL;
    cli_out o;
    if (!closed && m->f && cli_memstream_close(m->f, &m->buf, &m->len) != 0) ok = 0;
    m->f = NULL;
    if (ok && m->buf && cli_out_open(&o, path) == CLI_OK) {
        cli_out_write(&o, m->buf, m->len);
        rc = cli_out_close(&o, 1);
    }
    free(m->buf);
    m->buf = NULL;
    return rc;
}

/* PFM: "PF" (RGB) or "Pf" (gray), scale -1.0 = little endian, rows bottom to top */
static int cli_write_pfm(const char *path, const float *px, int w, int h, int channels) {
    cli_out o;
    unsigned char *row;
    char hdr[64];
    size_t rn = (size_t)w * (size_t)channels, i;
    int y, n;
    row = (unsigned char *)malloc(rn * 4);
    if (!row) { cli_error("out of memory"); return CLI_FAIL; }
    if (cli_out_open(&o, path) != CLI_OK) { free(row); return CLI_FAIL; }
    n = snprintf(hdr, sizeof hdr, "%s\n%d %d\n-1.0\n", channels == 3 ? "PF" : "Pf", w, h);
    cli_out_write(&o, hdr, (size_t)n);
    for (y = h - 1; y >= 0 && !o.err; y--) {
        const float *src = px + (size_t)y * rn;
        for (i = 0; i < rn; i++) {
            uint32_t u;
            memcpy(&u, &src[i], 4);
            row[4 * i] = (unsigned char)(u & 255u);
            row[4 * i + 1] = (unsigned char)((u >> 8) & 255u);
            row[4 * i + 2] = (unsigned char)((u >> 16) & 255u);
            row[4 * i + 3] = (unsigned char)(u >> 24);
        }
        cli_out_write(&o, row, rn * 4);
    }
    free(row);
    return cli_out_close(&o, 1);
}

/* an 8-bit PNG of w x h pixels of `channels` bytes (1 gray, 3 RGB, 4 RGBA), rows top to bottom */
static int cli_write_png_u8(const char *path, const unsigned char *px, int w, int h, int channels) {
    cli_out o;
    int ok;
    if (cli_out_open(&o, path) != CLI_OK) return CLI_FAIL;
    ok = stbi_write_png_to_func(cli_out_stbi, &o, w, h, channels, px, w * channels);
    if (!ok) cli_error("cannot write '%s': PNG encoding failed (out of memory?)", path);
    return cli_out_close(&o, ok);
}

/* one map value in [0, 1] as the 8-bit PNGs store it, exactly as the library's 8-bit path (rintf(v * 255));
   also what `bench --image` compares with the truth files */
static unsigned char cli_quantize(float v) {
    v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v; /* the library already clamps: a no-op */
    return (unsigned char)rintf(v * 255.0f);
}

/* 8-bit PNG from floats in [0, 1], quantised by cli_quantize() */
static int cli_write_png(const char *path, const float *px, int w, int h, int channels, unsigned char *tmp) {
    size_t n = (size_t)w * (size_t)h * (size_t)channels, i;
    for (i = 0; i < n; i++) tmp[i] = cli_quantize(px[i]);
    return cli_write_png_u8(path, tmp, w, h, channels);
}

/* A pre-packed file (`supermat pack`) runs with the convolution and compute options it was packed for,
   unless the command line asked for another compute (then the library says why it cannot). */
/* A pre-packed file: the library takes conv and compute left 0 as the ones it was packed for, so an explicit
   `--conv direct` / `--compute f32` (the zero values) is checked here: CLI_OK, or a message and CLI_FAIL. */
static int cli_packed_check(const char *path, const supermat_model *model, const cli_levers *lv) {
    supermat_model_info mi;
    memset(&mi, 0, sizeof mi);
    supermat_model_get_info(model, &mi);
    if (!mi.prepacked || ((!lv->conv_given || mi.conv == lv->conv) && (!lv->compute_given || mi.compute == lv->compute))) return CLI_OK;
    cli_error("model '%s': this file was pre-packed for conv %s, compute %s; run it with those (or without --conv / --compute), "
              "or pack the original file for conv %s, compute %s", path, cli_conv_name(mi.conv), cli_compute_name(mi.compute),
              cli_conv_name(lv->conv), cli_compute_name(lv->compute));
    return CLI_FAIL;
}

/* loads the model file and creates the model; the buffer is borrowed by the model (free it after) */
static int cli_load_model(const char *path, supermat_kernel kernel, const cli_levers *lv, unsigned char **buf, size_t *size,
                          supermat_model **model, double *create_seconds) {
    supermat_model_desc md;
    supermat_error err;
    supermat_result r;
    double t0;
    char what[600];
    *model = NULL;
    if (cli_read_file(path, buf, size)) return CLI_FAIL;
    memset(&md, 0, sizeof md);
    md.data = *buf; md.size = *size; md.kernel = kernel; md.weights = lv->weights; md.conv = lv->conv; md.compute = lv->compute;
    md.max_memory = lv->max_memory;
    t0 = cli_now();
    r = supermat_model_create(&md, model, &err);
    if (create_seconds) *create_seconds = cli_now() - t0;
    if (r != SUPERMAT_SUCCESS) {
        snprintf(what, sizeof what, "model '%s'", path);
        cli_lib_error(what, r, &err);
        cli_free_file(*buf); *buf = NULL;
        return CLI_FAIL;
    }
    if (cli_packed_check(path, *model, lv) != CLI_OK) {
        supermat_model_destroy(*model); *model = NULL;
        cli_free_file(*buf); *buf = NULL;
        return CLI_FAIL;
    }
    return CLI_OK;
}

/* the command that runs a model of this kind */
static const char *cli_kind_command(supermat_model_kind k) {
    switch (k) {
    case SUPERMAT_KIND_SUPERMAT: return "`supermat image` (one image at a time)";
    case SUPERMAT_KIND_SUPERMAT_MV: return "`supermat views` (several views of one object with a meta.json of cameras)";
    case SUPERMAT_KIND_UV_REFINE: return "`supermat refine` (a partial UV map with its mask and position map)";
    default: return "none of the commands";
    }
}

/* CLI_OK if the model is of kind `want`, else a message saying which command runs it */
static int cli_require_kind(const char *cmd, const char *path, const supermat_model *model, supermat_model_kind want) {
    supermat_model_info mi;
    memset(&mi, 0, sizeof mi);
    supermat_model_get_info(model, &mi);
    if (mi.kind == want) return CLI_OK;
    cli_error("model '%s' is a %s model, `supermat %s` runs %s models: use %s", path, cli_kind_name(mi.kind), cmd,
              cli_kind_name(want), cli_kind_command(mi.kind));
    return CLI_FAIL;
}

/* Before any work on an input: may its maps be written? CLI_OK, CLI_SKIPPED (--skip-existing and every
   one of them exists: nothing to do for this input) or CLI_FAIL (one exists and would be refused). */
static int cli_maps_allowed(const char *dir, const char *stem, int n, const char *const *suffixes, const int *wanted,
                            int want_float) {
    int k, f, all = 1, any = 0;
    for (k = 0; k < n; k++) {
        if (!wanted[k]) continue;
        for (f = 0; f <= want_float; f++) {
            char suffix[64], *path;
            int a;
            snprintf(suffix, sizeof suffix, "%s.%s", suffixes[k], f ? "pfm" : "png");
            path = cli_join(dir, stem, suffix);
            if (!path) { cli_error("out of memory"); return CLI_FAIL; }
            a = cli_out_allowed(path);
            free(path);
            if (a == CLI_FAIL) return CLI_FAIL;
            any = 1;
            if (a != CLI_SKIPPED) all = 0;
        }
    }
    return any && all ? CLI_SKIPPED : CLI_OK;
}

/* DIR/<stem><suffix>.png for each map that is not NULL (and .pfm with want_float); tmp holds w*h*3 bytes */
static int cli_write_maps(const char *dir, const char *stem, int n, const char *const *suffixes, float *const *maps,
                          const int *channels, int w, int h, int want_float, unsigned char *tmp) {
    int k, rc = CLI_OK;
    for (k = 0; k < n && rc == CLI_OK; k++) {
        char suffix[64], *path;
        if (!maps[k]) continue;
        snprintf(suffix, sizeof suffix, "%s.png", suffixes[k]);
        path = cli_join(dir, stem, suffix);
        if (!path) { cli_error("out of memory"); return CLI_FAIL; }
        rc = cli_write_png(path, maps[k], w, h, channels[k], tmp);
        free(path);
        if (rc == CLI_OK && want_float) {
            snprintf(suffix, sizeof suffix, "%s.pfm", suffixes[k]);
            path = cli_join(dir, stem, suffix);
            if (!path) { cli_error("out of memory"); return CLI_FAIL; }
            rc = cli_write_pfm(path, maps[k], w, h, channels[k]);
            free(path);
        }
    }
    return rc;
}
/* >>inputs: pictures as users have them */
/* Every picture goes through cli_pic_info / cli_load (stb_image underneath):
   - a folder, a missing file: named as such (stb_image says "can't fopen" / "unknown image type");
   - WebP (the official example pictures): decoded by libwebp when the build has it (SUPERMAT_CLI_WEBP:
     CMake finds libwebp-dev), else recognised and refused with what to do;
   - 16-bit PNG: `image` reads it at full precision (cli_pic_info's is16: float input, v / 65535, the same
     sRGB encoding); the other commands refuse it instead of cutting it to 8 bits silently;
   - JPEG EXIF orientation (tag 0x0112, 2..8): applied, so the picture is processed upright as viewers
     show it, and sizes are reported after it (5..8 swap width and height). */

/* the EXIF orientation of a JPEG file's bytes (1..8), 1 when absent / not a JPEG / unreadable */
static int cli_exif_orientation(const unsigned char *b, size_t n) {
    size_t pos = 2;
    int o = 1;
    if (n > 65536 + 4) n = 65536 + 4; /* EXIF lives in the first segment */
    if (n < 4 || b[0] != 0xFF || b[1] != 0xD8) return 1;
    while (pos + 4 <= n && b[pos] == 0xFF) {
        unsigned marker = b[pos + 1];
        size_t len = ((size_t)b[pos + 2] << 8) | b[pos + 3], t;
        if (marker == 0xDA || marker == 0xD9 || len < 2) break;          /* image data: no EXIF before it */
        if (marker == 0xE1 && pos + 4 + len <= n + 2 && len >= 16 && !memcmp(b + pos + 4, "Exif\0\0", 6)) {
            const unsigned char *t0 = b + pos + 10;                      /* TIFF header */
            size_t tl = len - 8, ifd, k, cnt;
            int le = t0[0] == 'I';
#define CLI_RD16(p) (le ? (unsigned)((p)[0] | ((p)[1] << 8)) : (unsigned)(((p)[0] << 8) | (p)[1]))
#define CLI_RD32(p) (le ? ((size_t)(p)[0] | ((size_t)(p)[1] << 8) | ((size_t)(p)[2] << 16) | ((size_t)(p)[3] << 24)) \
                        : (((size_t)(p)[0] << 24) | ((size_t)(p)[1] << 16) | ((size_t)(p)[2] << 8) | (size_t)(p)[3]))
            if ((t0[0] != 'I' && t0[0] != 'M') || t0[1] != t0[0]) break;
            ifd = CLI_RD32(t0 + 4);
            if (ifd > tl || tl - ifd < 2) break;               /* (no wrap-around where size_t is 32 bits) */
            cnt = CLI_RD16(t0 + ifd);
            for (k = 0; k < cnt; k++) {
                t = ifd + 2 + 12 * k;
                if (t + 12 > tl) break;
                if (CLI_RD16(t0 + t) == 0x0112) {
                    unsigned v = CLI_RD16(t0 + t + 8);
                    if (v >= 1 && v <= 8) o = (int)v;
                    break;
                }
            }
#undef CLI_RD16
#undef CLI_RD32
            break;
        }
        pos += 2 + len;
    }
    return o;
}

/* the same pixels turned upright for EXIF orientation o (2..8); a new buffer, or NULL (out of memory) */
static unsigned char *cli_orient(const unsigned char *px, int w, int h, int ch, int o, int *ow, int *oh) {
    int tw = o >= 5 ? h : w, th = o >= 5 ? w : h, x, y;
    unsigned char *out = (unsigned char *)malloc((size_t)tw * th * ch);
    if (!out) return NULL;
    for (y = 0; y < th; y++)
        for (x = 0; x < tw; x++) {
            int sx, sy; /* the stored pixel shown at (x, y) */
            switch (o) {
            case 2: sx = w - 1 - x; sy = y; break;                 /* mirrored */
            case 3: sx = w - 1 - x; sy = h - 1 - y; break;         /* 180 */
            case 4: sx = x; sy = h - 1 - y; break;                 /* mirrored vertically */
            case 5: sx = y; sy = x; break;                         /* transposed */
            case 6: sx = y; sy = h - 1 - x; break;                 /* 90 clockwise to view */
            case 7: sx = w - 1 - y; sy = h - 1 - x; break;         /* transverse */
            case 8: sx = w - 1 - y; sy = x; break;                 /* 90 counter-clockwise to view */
            default: sx = x; sy = y; break;
            }
            memcpy(out + ((size_t)y * tw + x) * ch, px + ((size_t)sy * w + sx) * ch, (size_t)ch);
        }
    *ow = tw;
    *oh = th;
    return out;
}

static int cli_is_webp(const unsigned char *b, size_t n) {
    return n >= 12 && !memcmp(b, "RIFF", 4) && !memcmp(b + 8, "WEBP", 4);
}

#ifdef SUPERMAT_CLI_WEBP
/* a WebP file as `want` channels (0 = 4), like stbi_load (1 gray, 2 gray + alpha, 3 RGB, 4 RGBA; gray as
   stb computes it); *c = 4 (3 without alpha). NULL and a message when it cannot be decoded. */
static unsigned char *cli_load_webp(const char *path, const unsigned char *data, size_t size, int *w, int *h, int *c, int want) {
    unsigned char *rgba, *out;
    size_t n, i;
    WebPBitstreamFeatures ft;
    int k;
    if (WebPGetFeatures(data, size, &ft) != VP8_STATUS_OK || !(rgba = WebPDecodeRGBA(data, size, w, h))) {
        cli_error("cannot decode the WebP picture '%s' (libwebp)", path);
        return NULL;
    }
    *c = ft.has_alpha ? 4 : 3;
    k = want ? want : 4;
    n = (size_t)*w * (size_t)*h;
    out = (unsigned char *)malloc(n * (size_t)k);
    if (out)
        for (i = 0; i < n; i++) {
            const unsigned char *p = rgba + 4 * i;
            unsigned char *q = out + (size_t)k * i;
            if (k >= 3) { q[0] = p[0]; q[1] = p[1]; q[2] = p[2]; if (k == 4) q[3] = p[3]; }
            else { q[0] = (unsigned char)((p[0] * 77 + p[1] * 150 + 29 * p[2]) >> 8); if (k == 2) q[1] = p[3]; }
        }
    WebPFree(rgba);
    if (!out) cli_error("out of memory decoding '%s'", path);
    return out;
}
#endif

/* Every picture is read once into memory by cli_read_file (a regular file, never a FIFO or a device), then
   checked and decoded from there: stb_image never opens a path itself. */
/* the picture's bytes checked before stb_image sees them (picture_check.h); 0 and the message when refused */
static int cli_pic_bytes_ok(const char *path, const char *what, const unsigned char *data, size_t size) {
    const char *why = supermat_cli_picture_check(data, size);
    if (why) { cli_error("%s '%s' %s", what, path, why); return 0; }
    if (size > (size_t)INT_MAX) { cli_error("%s '%s' is %.1f MiB: at most 2 GiB a picture file", what, path, cli_mib((double)size)); return 0; }
    return 1;
}

/* the size a PNG or BMP header claims (1), read before stb_image, which refuses some large claims with
   another format's "unknown type" message; 0 for other formats */
static int cli_header_size(const unsigned char *d, size_t n, long *w, long *h) {
    if (n >= 24 && !memcmp(d, "\x89PNG\r\n\x1a\n", 8) && !memcmp(d + 12, "IHDR", 4)) {
        uint32_t x = ((uint32_t)d[16] << 24) | ((uint32_t)d[17] << 16) | ((uint32_t)d[18] << 8) | d[19];
        uint32_t y = ((uint32_t)d[20] << 24) | ((uint32_t)d[21] << 16) | ((uint32_t)d[22] << 8) | d[23];
        *w = (long)(x > 1u << 30 ? 1u << 30 : x); /* (a long may have 32 bits) */
        *h = (long)(y > 1u << 30 ? 1u << 30 : y);
        return 1;
    }
    if (n >= 26 && d[0] == 'B' && d[1] == 'M') {
        int64_t x = (int32_t)((uint32_t)d[18] | (uint32_t)d[19] << 8 | (uint32_t)d[20] << 16 | (uint32_t)d[21] << 24);
        int64_t y = (int32_t)((uint32_t)d[22] | (uint32_t)d[23] << 8 | (uint32_t)d[24] << 16 | (uint32_t)d[25] << 24);
        if (x < 0) return 0; /* a corrupt picture: said below, with the width it claims */
        if (y < 0) y = -y;   /* negative: rows top to bottom */
        *w = (long)(x > 1L << 30 ? 1L << 30 : x);
        *h = (long)(y > 1L << 30 ? 1L << 30 : y);
        return 1;
    }
    return 0;
}

/* stbi_info with the cases above; 0 (and the message, with `what`) when it cannot be read; max_memory:
   --max-memory (0 = none), checked against the decoded size from the header. is16: NULL refuses a picture
   of 16 bits per channel (the command reads 8), else says whether it is one (read it with cli_load16f). */
static int cli_pic_info(const char *path, const char *what, int *w, int *h, int *c, size_t max_memory, int *is16) {
    struct stat st;
    unsigned char *data = NULL;
    size_t size = 0;
    int deep;
    if (is16) *is16 = 0;
    if (stat(path, &st) != 0) { cli_error("cannot read %s '%s': %s", what, path, strerror(errno)); return 0; }
    if (S_ISDIR(st.st_mode)) { cli_error("%s '%s' is a folder: give the picture files (e.g. '%s/*.png')", what, path, path); return 0; }
    if (cli_read_file(path, &data, &size)) return 0;
    if (cli_is_webp(data, size)) {
#ifdef SUPERMAT_CLI_WEBP
        WebPBitstreamFeatures ft;
        int ok = WebPGetFeatures(data, size, &ft) == VP8_STATUS_OK;
        cli_free_file(data);
        if (!ok) { cli_error("cannot read %s '%s': not a valid WebP file (libwebp)", what, path); return 0; }
        *w = ft.width; *h = ft.height; *c = ft.has_alpha ? 4 : 3;
        return 1;
#else
        cli_free_file(data);
        cli_error("%s '%s' is WebP, which this build does not read (built without libwebp-dev): convert it to PNG first (e.g. `dwebp '%s' -o picture.png`, Debian's webp package) or rebuild with libwebp-dev", what, path, path);
        return 0;
#endif
    }
    if (!cli_pic_bytes_ok(path, what, data, size)) { cli_free_file(data); return 0; }
    {
        long hw, hh;
        if (cli_header_size(data, size, &hw, &hh) && (hw > 16384 || hh > 16384)) {
            cli_error("%s '%s' is %ldx%ld: at most 16384 pixels a side (the largest a session takes)", what, path, hw, hh);
            cli_free_file(data);
            return 0;
        }
    }
    if (!stbi_info_from_memory(data, (int)size, w, h, c)) {
        cli_error("cannot read %s '%s': %s", what, path, cli_stbi_reason());
        cli_free_file(data);
        return 0;
    }
    deep = stbi_is_16_bit_from_memory(data, (int)size);
    if (is16) *is16 = deep;
    if (cli_exif_orientation(data, size) >= 5) { int t = *w; *w = *h; *h = t; }
    cli_free_file(data);
    if (deep && !is16) {
        cli_error("%s '%s' has 16 bits per channel, which this command does not read (it would lose 8 of them): "
                  "give an 8-bit PNG (`supermat image` reads 16-bit pictures)", what, path);
        return 0;
    }
    if (*w <= 0 || *h <= 0) { /* stb_image passes a BMP header's negative width on as it is */
        cli_error("%s '%s' claims a size of %dx%d pixels: a corrupt picture", what, path, *w, *h);
        return 0;
    }
    if (*w > 16384 || *h > 16384) { /* from the header, before decoding: a small file may claim a huge picture */
        cli_error("%s '%s' is %dx%d: at most 16384 pixels a side (the largest a session takes)", what, path, *w, *h);
        return 0;
    }
    if (max_memory) { /* the decoded bytes, before decoding: RGBA at 8 bits, or 16 bits and its float copy */
        double need = (double)*w * (double)*h * 4.0 * (deep ? 2.0 + 4.0 : 1.0);
        if (need > (double)max_memory) {
            cli_error("%s '%s' (%dx%d) needs %.1f MiB decoded, more than --max-memory %.1f MiB", what, path, *w, *h, cli_mib(need),
                      cli_mib((double)max_memory));
            return 0;
        }
    }
    return 1;
}

/* a 16-bit picture as RGBA floats v / 65535 (same encoding as 8-bit: sRGB, straight alpha), upright;
   free with free() */
static float *cli_load16f(const char *path, int *w, int *h) {
    int c = 0;
    unsigned short *p;
    unsigned char *data = NULL;
    size_t size = 0, n, i;
    float *f;
    if (cli_read_file(path, &data, &size)) return NULL;
    if (!cli_pic_bytes_ok(path, "picture", data, size)) { cli_free_file(data); return NULL; }
    p = stbi_load_16_from_memory(data, (int)size, w, h, &c, 4);
    cli_free_file(data);
    if (!p) return NULL;
    n = (size_t)*w * (size_t)*h * 4;
    f = (float *)malloc(n * sizeof *f);
    if (f) for (i = 0; i < n; i++) f[i] = (float)p[i] / 65535.0f;
    stbi_image_free(p);
    return f;
}

/* stbi_load, turned upright by the EXIF orientation (JPEG); free with stbi_image_free */
static unsigned char *cli_load(const char *path, int *w, int *h, int *c, int want) {
    unsigned char *px, *data = NULL;
    size_t size = 0;
    int o;
    if (cli_read_file(path, &data, &size)) return NULL;
#ifdef SUPERMAT_CLI_WEBP
    if (cli_is_webp(data, size)) {
        px = cli_load_webp(path, data, size, w, h, c, want);
        cli_free_file(data);
        return px;
    }
#endif
    if (!cli_pic_bytes_ok(path, "picture", data, size)) { cli_free_file(data); return NULL; }
    px = stbi_load_from_memory(data, (int)size, w, h, c, want);
    o = px ? cli_exif_orientation(data, size) : 1;
    cli_free_file(data);
    if (px && o > 1) {
        int ow, oh;
        unsigned char *up = cli_orient(px, *w, *h, want ? want : *c, o, &ow, &oh);
        if (!up) { stbi_image_free(px); return NULL; }
        /* stbi_image_free is free() (Debian's libstb uses the default allocator) */
        stbi_image_free(px);
        px = up;
        *w = ow;
        *h = oh;
    }
    return px;
}
