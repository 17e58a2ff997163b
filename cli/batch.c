/* cli/batch.c - `supermat batch`: an asset library, resumable, sharded, with a journal.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone.
 *
 *   supermat batch image [--model F] --out DIR [--shard I/N] [--jobs J] [--retry-failed] [--fail-fast]
 *                        [--json F] [run options] INPUT...
 *   supermat batch --merge --out DIR [INPUT...]
 *
 * Items: every picture named, found under a folder (recursive, by extension, hidden entries and DIR
 * itself left out) or listed in a manifest (@list.txt: one path per line, or JSON Lines objects with
 * "input" and the per-item options "outputs" and "float"). Each item has a key: its output folder under
 * DIR (the path below the folder it was found in; "" for a named file) and its stem; outputs are those
 * `supermat image` writes, DIR/<folder>/<stem>_albedo.png ... The items are sorted by key, and --shard
 * I/N takes every N-th from the I-th (0-based): the same partition on every machine.
 *
 * The journal (DIR/journal.jsonl; with --shard DIR/journal.I-of-N.jsonl) gets one JSON line per item
 * finished, appended with one write() and fsync()ed after the item's outputs were renamed into place:
 * {"item", "input", "status": "done"|"failed", "seconds", "outputs", "error"}. The last record of an
 * item counts. A re-run skips what is done, and what failed unless --retry-failed; a run killed at any
 * instant loses no finished item (its record is on disk) and leaves no partial output (each file is
 * written as FILE.tmp and renamed; an unfinished item is redone, replacing what it had written). DIR
 * belongs to the batch: an item's outputs are replaced until the journal says it is done.
 *
 * One model load per process; one session, reused while pictures keep their size. --jobs J forks J
 * workers after the model load (they share its memory pages; on Windows, which has no fork, they are J threads
 * sharing the one model, each with its own session), each on every J-th item with threads / J threads, all
 * appending to the one journal. --merge writes DIR/journal.jsonl from the shards' journals
 * (the last record per item) and, given the inputs, says which items are missing.
 * Exit status: 0 when every item is done, 1 when some failed (or are missing), 2 usage. */

/* >>batch */
#include <ctype.h>
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#if !defined(_WIN32)
#include <sys/file.h>
#include <sys/wait.h>
#endif
#ifdef __linux__
#include <sys/prctl.h>
#endif

typedef struct cli_bitem {
    char *input;        /* the picture's path */
    char *sub;          /* its output folder relative to DIR ("" = DIR) */
    char *stem;
    char *key;          /* sub/stem (or stem): the item's name in the journal */
    unsigned outputs;
    int want_float;
    int status;         /* from the journal: 0 none, 1 done, 2 failed */
} cli_bitem;

typedef struct cli_blist {
    cli_bitem *v;
    size_t n, cap;
} cli_blist;

static char *cli_strdup(const char *s) {
    size_t n = strlen(s) + 1;
    char *c = (char *)malloc(n);
    if (c) memcpy(c, s, n);
    return c;
}

static void cli_blist_free(cli_blist *L) {
    size_t i;
    for (i = 0; i < L->n; i++) { free(L->v[i].input); free(L->v[i].sub); free(L->v[i].stem); free(L->v[i].key); }
    free(L->v);
    memset(L, 0, sizeof *L);
}

static int cli_blist_add(cli_blist *L, const char *input, const char *sub, unsigned outputs, int want_float) {
    cli_bitem *it;
    size_t n;
    if (L->n == L->cap) {
        size_t cap = L->cap ? 2 * L->cap : 64;
        cli_bitem *v = (cli_bitem *)realloc(L->v, cap * sizeof *v);
        if (!v) { cli_error("out of memory"); return CLI_FAIL; }
        L->v = v; L->cap = cap;
    }
    it = &L->v[L->n];
    memset(it, 0, sizeof *it);
    it->input = cli_strdup(input);
    it->sub = cli_strdup(sub);
    it->stem = cli_stem(input);
    it->outputs = outputs;
    it->want_float = want_float;
    if (!it->input || !it->sub || !it->stem) goto oom;
    n = strlen(sub) + strlen(it->stem) + 2;
    if (!(it->key = (char *)malloc(n))) goto oom;
    snprintf(it->key, n, "%s%s%s", sub, sub[0] ? "/" : "", it->stem);
    L->n++;
    return CLI_OK;
oom:
    free(it->input); free(it->sub); free(it->stem); free(it->key);
    cli_error("out of memory");
    return CLI_FAIL;
}

/* What the batch's functions share, passed to each that needs it (no file-scope state) */
typedef struct cli_batch_ctx {
    int mesh_mode;     /* 1: items are glTF assets (`batch mesh`), 0: pictures */
    char *out_real;    /* the output folder, resolved: outputs are never taken as inputs (NULL: not yet) */
    int allow_outside; /* --allow-outside-refs (a global option: cli_g): linked pictures outside a folder */
} cli_batch_ctx;

static int cli_is_picture_name(const cli_batch_ctx *B, const char *name) {
    static const char *const pics[] = {"png", "jpg", "jpeg", "webp", "bmp", "tga"}, *const meshes[] = {"gltf", "glb"};
    const char *const *ext = B->mesh_mode ? meshes : pics;
    size_t next = B->mesh_mode ? 2 : 6;
    const char *d = strrchr(name, '.');
    size_t k;
    if (!d || d == name) return 0;
    for (k = 0; k < next; k++) {
        const char *a = d + 1, *b = ext[k];
        while (*a && *b && tolower((unsigned char)*a) == *b) { a++; b++; }
        if (!*a && !*b) return 1;
    }
    return 0;
}

/* the pictures under folder root/rel (recursive), skipping hidden entries and the output folder */
static int cli_walk(const cli_batch_ctx *B, cli_blist *L, const char *root, const char *rel, const struct stat *out_st, int depth, unsigned outputs,
                    int want_float) {
    char *dir;
    DIR *d;
    struct dirent *e;
    int rc = CLI_OK;
    size_t n = strlen(root) + strlen(rel) + 2;
    if (depth > 64) { cli_error("'%s/%s': folders nested too deep", root, rel); return CLI_FAIL; }
    if (!(dir = (char *)malloc(n))) { cli_error("out of memory"); return CLI_FAIL; }
    snprintf(dir, n, "%s%s%s", root, rel[0] ? "/" : "", rel);
    if (!(d = opendir(dir))) { cli_error("cannot read folder '%s': %s", dir, strerror(errno)); free(dir); return CLI_FAIL; }
    while (rc == CLI_OK && (e = readdir(d)) != NULL) {
        struct stat st;
        char *path, *sub;
        size_t pn;
        if (e->d_name[0] == '.') continue;
        pn = strlen(dir) + strlen(e->d_name) + 2;
        if (!(path = (char *)malloc(pn))) { cli_error("out of memory"); rc = CLI_FAIL; break; }
        snprintf(path, pn, "%s/%s", dir, e->d_name);
        if (stat(path, &st) != 0) { free(path); continue; } /* a dangling link */
        if (S_ISDIR(st.st_mode)) {
            struct stat lst;
            int is_out = out_st && st.st_dev == out_st->st_dev && st.st_ino == out_st->st_ino;
            if (!is_out && lstat(path, &lst) == 0 && !S_ISLNK(lst.st_mode)) { /* linked folders are not followed */
                pn = strlen(rel) + strlen(e->d_name) + 2;
                if (!(sub = (char *)malloc(pn))) { cli_error("out of memory"); rc = CLI_FAIL; }
                else {
                    snprintf(sub, pn, "%s%s%s", rel, rel[0] ? "/" : "", e->d_name);
                    rc = cli_walk(B, L, root, sub, out_st, depth + 1, outputs, want_float);
                    free(sub);
                }
            }
        } else if (S_ISREG(st.st_mode) && cli_is_picture_name(B, e->d_name)) {
            struct stat lst;
            char *real_root = NULL;
            int in = 1;
            if (!B->allow_outside && lstat(path, &lst) == 0 && S_ISLNK(lst.st_mode) && (real_root = realpath(root, NULL)) != NULL)
                in = smio_inside(real_root, path, NULL) == 1;
            free(real_root);
            if (in) rc = cli_blist_add(L, path, rel, outputs, want_float);
            else fprintf(stderr, "supermat: warning: '%s' is a symbolic link to a file outside '%s': left out (--allow-outside-refs takes it)\n", path, root);
        }
        free(path);
    }
    closedir(d);
    free(dir);
    return rc;
}

/* ---- a little JSON: flat objects of strings, numbers, booleans and arrays (journal and manifest lines) ---- */
static const char *cli_json_ws(const char *p) { while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n') p++; return p; }

/* a string at p (after its opening quote is p[0] == '"'): unescaped into out (cap bytes); the end, or NULL */
static const char *cli_json_parse_string(const char *p, char *out, size_t cap) {
    size_t n = 0;
    if (*p != '"') return NULL;
    for (p++; *p && *p != '"'; p++) {
        unsigned c = (unsigned char)*p;
        if (c < 0x20) return NULL;
        if (c == '\\') {
            p++;
            switch (*p) {
            case '"': c = '"'; break;
            case '\\': c = '\\'; break;
            case '/': c = '/'; break;
            case 'b': c = '\b'; break;
            case 'f': c = '\f'; break;
            case 'n': c = '\n'; break;
            case 'r': c = '\r'; break;
            case 't': c = '\t'; break;
            case 'u': {
                unsigned v = 0;
                int k;
                for (k = 1; k <= 4; k++) {
                    char h = p[k];
                    if (!isxdigit((unsigned char)h)) return NULL;
                    v = v * 16 + (unsigned)(isdigit((unsigned char)h) ? h - '0' : tolower((unsigned char)h) - 'a' + 10);
                }
                p += 4;
                if (v >= 0x80) { /* UTF-8 (surrogate pairs are not joined: paths in journals are written by us) */
                    unsigned char u[3];
                    int m = 0;
                    if (v < 0x800) { u[m++] = (unsigned char)(0xC0 | (v >> 6)); }
                    else { u[m++] = (unsigned char)(0xE0 | (v >> 12)); u[m++] = (unsigned char)(0x80 | ((v >> 6) & 63)); }
                    u[m++] = (unsigned char)(0x80 | (v & 63));
                    for (k = 0; k < m - 1; k++) { if (n + 1 < cap) out[n++] = (char)u[k]; }
                    c = u[m - 1];
                } else c = v;
                break;
            }
            default: return NULL;
            }
        }
        if (n + 1 < cap) out[n++] = (char)c;
        else return NULL; /* too long */
    }
    if (*p != '"') return NULL;
    if (cap) out[n] = 0;
    return p + 1;
}

/* skips one value (string, number, true/false/null, array of those) */
static const char *cli_json_skip(const char *p) {
    static char scratch[8192];
    p = cli_json_ws(p);
    if (*p == '"') return cli_json_parse_string(p, scratch, sizeof scratch);
    if (*p == '[') {
        p = cli_json_ws(p + 1);
        if (*p == ']') return p + 1;
        for (;;) {
            if (!(p = cli_json_skip(p))) return NULL;
            p = cli_json_ws(p);
            if (*p == ']') return p + 1;
            if (*p != ',') return NULL;
            p++;
        }
    }
    if (!strncmp(p, "true", 4) || !strncmp(p, "null", 4)) return p + 4;
    if (!strncmp(p, "false", 5)) return p + 5;
    if (*p == '-' || isdigit((unsigned char)*p)) {
        char *e;
        (void)strtod(p, &e);
        return e == p ? NULL : e;
    }
    return NULL;
}

/* calls f(user, key, value_start) for each member of the object in line; -1 on malformed JSON or when f
   returns nonzero */
typedef int (*cli_json_member_fn)(void *user, const char *key, const char *value);
static int cli_json_object(const char *line, cli_json_member_fn f, void *user) {
    char key[256];
    const char *p = cli_json_ws(line);
    if (*p != '{') return -1;
    p = cli_json_ws(p + 1);
    if (*p == '}') return *cli_json_ws(p + 1) ? -1 : 0;
    for (;;) {
        if (!(p = cli_json_parse_string(p, key, sizeof key))) return -1;
        p = cli_json_ws(p);
        if (*p != ':') return -1;
        p = cli_json_ws(p + 1);
        if (f(user, key, p)) return -1;
        if (!(p = cli_json_skip(p))) return -1;
        p = cli_json_ws(p);
        if (*p == '}') return *cli_json_ws(p + 1) ? -1 : 0;
        if (*p != ',') return -1;
        p = cli_json_ws(p + 1);
    }
}

/* ---- manifests ---- */
typedef struct cli_mline {
    char input[4096];
    unsigned outputs;
    int want_float, has_input, bad;
    char why[128];
} cli_mline;

static int cli_manifest_member(void *user, const char *key, const char *v) {
    cli_mline *m = (cli_mline *)user;
    char s[4096];
    if (!strcmp(key, "input")) {
        if (!cli_json_parse_string(v, m->input, sizeof m->input)) { snprintf(m->why, sizeof m->why, "\"input\" is not a string"); return 1; }
        m->has_input = 1;
    } else if (!strcmp(key, "outputs")) {
        unsigned bits = 0;
        const char *bad = NULL;
        size_t n = 0;
        if (!cli_json_parse_string(v, s, sizeof s)) { snprintf(m->why, sizeof m->why, "\"outputs\" is not a string"); return 1; }
        if (cli_outputs_bits(s, &bits, &bad, &n)) { snprintf(m->why, sizeof m->why, "\"outputs\": unknown '%.*s' (albedo, roughness, metallic: a comma list)", (int)(n < 32 ? n : 32), bad); return 1; }
        if (!bits) { snprintf(m->why, sizeof m->why, "\"outputs\" is empty"); return 1; }
        m->outputs = bits;
    } else if (!strcmp(key, "float")) {
        if (!strncmp(v, "true", 4)) m->want_float = 1;
        else if (!strncmp(v, "false", 5)) m->want_float = 0;
        else { snprintf(m->why, sizeof m->why, "\"float\" is not true or false"); return 1; }
    } else {
        snprintf(m->why, sizeof m->why, "unknown key \"%.64s\" (input, outputs, float)", key);
        return 1;
    }
    return 0;
}

static int cli_add_input(const cli_batch_ctx *B, cli_blist *L, const char *cmd, const char *in, const struct stat *out_st, unsigned outputs, int want_float);

static int cli_manifest(const cli_batch_ctx *B, cli_blist *L, const char *cmd, const char *path, const struct stat *out_st, unsigned outputs, int want_float) {
    char why[256];
    int fd = smio_open_regular(path, 0, why, sizeof why);
    FILE *f = fd >= 0 ? fdopen(fd, "r") : NULL;
    char *line = NULL;
    size_t cap = 0;
    long no = 0;
    ssize_t got;
    int rc = CLI_OK;
    if (!f) { if (fd >= 0) close(fd); cli_error("cannot read the list '%s': it %s", path, why); return CLI_FAIL; }
    while (rc == CLI_OK && (got = getline(&line, &cap, f)) >= 0) {
        char *s = line, *e;
        no++;
        while (*s == ' ' || *s == '\t') s++;
        e = s + strlen(s);
        while (e > s && (e[-1] == '\n' || e[-1] == '\r' || e[-1] == ' ' || e[-1] == '\t')) *--e = 0;
        if (!*s || *s == '#') continue;
        if (*s == '{') {
            cli_mline m;
            memset(&m, 0, sizeof m);
            m.outputs = outputs;
            m.want_float = want_float;
            if (cli_json_object(s, cli_manifest_member, &m) != 0 || !m.has_input) {
                rc = cli_usage_error(cmd, "%s:%ld: %s", path, no, m.why[0] ? m.why : m.has_input ? "not a JSON object" : "no \"input\"");
                break;
            }
            rc = cli_add_input(B, L, cmd, m.input, out_st, m.outputs, m.want_float);
        } else
            rc = cli_add_input(B, L, cmd, s, out_st, outputs, want_float);
    }
    if (rc == CLI_OK && ferror(f)) { cli_error("cannot read the list '%s'", path); rc = CLI_FAIL; }
    free(line);
    fclose(f);
    return rc;
}

static int cli_add_input(const cli_batch_ctx *B, cli_blist *L, const char *cmd, const char *in, const struct stat *out_st, unsigned outputs, int want_float) {
    struct stat st;
    if (in[0] == '@') return cli_manifest(B, L, cmd, in + 1, out_st, outputs, want_float);
    if (stat(in, &st) != 0) { cli_error("'%s': %s", in, strerror(errno)); return CLI_FAIL; }
    if (B->out_real && smio_inside(B->out_real, in, NULL) == 1)
        return cli_usage_error(cmd, "%s '%s' is %s the output folder '%s': what the batch writes there would be read as %s on the next "
                               "run; give --out a folder outside it", S_ISDIR(st.st_mode) ? "the input folder" : "the input",
                               in, S_ISDIR(st.st_mode) ? "(or is inside)" : "inside", B->out_real,
                               B->mesh_mode ? "assets" : "pictures");
    if (S_ISDIR(st.st_mode)) return cli_walk(B, L, in, "", out_st, 0, outputs, want_float);
    return cli_blist_add(L, in, "", outputs, want_float);
}

static int cli_bitem_cmp(const void *a, const void *b) {
    return strcmp(((const cli_bitem *)a)->key, ((const cli_bitem *)b)->key);
}
static cli_bitem *cli_bfind(const cli_blist *L, const char *key) {
    cli_bitem k;
    k.key = (char *)key;
    return (cli_bitem *)bsearch(&k, L->v, L->n, sizeof *L->v, cli_bitem_cmp);
}

/* ---- the journal ---- */
typedef struct cli_jrec {
    char item[4096];
    char status[16];
} cli_jrec;
static int cli_journal_member(void *user, const char *key, const char *v) {
    cli_jrec *r = (cli_jrec *)user;
    if (!strcmp(key, "item")) return cli_json_parse_string(v, r->item, sizeof r->item) ? 0 : 1;
    if (!strcmp(key, "status")) return cli_json_parse_string(v, r->status, sizeof r->status) ? 0 : 1;
    return 0;
}

/* calls f(user, rec, line) for every well-formed record of a journal (a torn last line, from a kill in
   the middle of a write, is left out); 0, or -1 when the file cannot be read (a missing one is empty) */
typedef void (*cli_journal_fn)(void *user, const cli_jrec *r, const char *line);
static int cli_journal_read(const char *path, cli_journal_fn f, void *user) {
    char why[256];
    int fd = smio_open_regular(path, 1, why, sizeof why); /* the batch's own file: never a link, never a FIFO */
    FILE *fp = fd >= 0 ? fdopen(fd, "r") : NULL;
    char *line = NULL;
    size_t cap = 0;
    ssize_t got;
    if (!fp) {
        if (fd < 0 && errno == ENOENT) return 0;
        if (fd >= 0) close(fd);
        errno = EINVAL;
        cli_error("cannot read the journal '%s': it %s", path, why);
        return -2;
    }
    while ((got = getline(&line, &cap, fp)) >= 0) {
        cli_jrec r;
        if (got == 0 || line[got - 1] != '\n') break; /* torn */
        memset(&r, 0, sizeof r);
        if (cli_json_object(line, cli_journal_member, &r) == 0 && r.item[0] && r.status[0]) f(user, &r, line);
    }
    free(line);
    fclose(fp);
    return 0;
}
static void cli_journal_status(void *user, const cli_jrec *r, const char *line) {
    cli_bitem *it = cli_bfind((const cli_blist *)user, r->item);
    (void)line;
    if (it) it->status = !strcmp(r->status, "done") ? 1 : 2;
}

/* the names of an item's outputs relative to DIR */
/* Pictures of one folder that share a stem (a.png, a.jpg) keep their extension in it (a_png, a_jpg: see
   cli_stem_with_ext), so each gets its own maps; the same file listed twice stays one key (dropped later). */
static int cli_blist_disambiguate(cli_blist *L) {
    size_t k, r;
    qsort(L->v, L->n, sizeof *L->v, cli_bitem_cmp);
    for (k = 0; k < L->n; k = r) {
        int differ = 0;
        for (r = k + 1; r < L->n && !strcmp(L->v[r].key, L->v[k].key); r++)
            if (strcmp(L->v[r].input, L->v[k].input)) differ = 1;
        if (differ) {
            size_t i;
            for (i = k; i < r; i++) {
                cli_bitem *it = &L->v[i];
                char *stem = cli_stem_with_ext(it->input), *key;
                size_t n;
                if (!stem) { cli_error("out of memory"); return CLI_FAIL; }
                n = strlen(it->sub) + strlen(stem) + 2;
                if (!(key = (char *)malloc(n))) { free(stem); cli_error("out of memory"); return CLI_FAIL; }
                snprintf(key, n, "%s%s%s", it->sub, it->sub[0] ? "/" : "", stem);
                free(it->stem); free(it->key);
                it->stem = stem; it->key = key;
            }
        }
    }
    return CLI_OK;
}
static const char *cli_ext_of(const char *path) {
    const char *d = strrchr(path, '.'), *sl = strrchr(path, '/');
    return d && (!sl || d > sl) ? d : "";
}
static void cli_item_outputs(const cli_batch_ctx *B, FILE *f, const cli_bitem *it) {
    int k, e, first = 1;
    fputc('[', f);
    if (B->mesh_mode) { /* the asset file (its textures and buffer lie beside it) */
        char name[8192];
        snprintf(name, sizeof name, "%s%s%s%s", it->sub, it->sub[0] ? "/" : "", it->stem, cli_ext_of(it->input));
        cli_json_string(f, name);
        fputc(']', f);
        return;
    }
    for (k = 0; k < 3; k++) {
        static const unsigned bit[3] = {SUPERMAT_OUTPUT_ALBEDO, SUPERMAT_OUTPUT_ROUGHNESS, SUPERMAT_OUTPUT_METALLIC};
        if (!(it->outputs & bit[k])) continue;
        for (e = 0; e <= it->want_float; e++) {
            char name[8192];
            snprintf(name, sizeof name, "%s%s%s%s.%s", it->sub, it->sub[0] ? "/" : "", it->stem, cli_map_suffixes[k], e ? "pfm" : "png");
            if (!first) fputc(',', f);
            cli_json_string(f, name);
            first = 0;
        }
    }
    fputc(']', f);
}

/* one record, one write(), then fsync: CLI_OK or CLI_FAIL with the message */
static int cli_journal_append(const cli_batch_ctx *B, int fd, const char *jpath, const cli_bitem *it, int done, double secs, const char *error) {
    char *buf = NULL;
    size_t len = 0, off = 0;
    FILE *f = cli_memstream_open(&buf, &len);
    int rc = CLI_OK;
    if (!f) { cli_error("out of memory"); return CLI_FAIL; }
    fputs("{\"item\":", f);
    cli_json_string(f, it->key);
    fputs(",\"input\":", f);
    cli_json_string(f, it->input);
    fprintf(f, ",\"status\":\"%s\",\"seconds\":%.3f,\"outputs\":", done ? "done" : "failed", secs);
    if (done) cli_item_outputs(B, f, it);
    else fputs("[]", f);
    fputs(",\"error\":", f);
    if (error) cli_json_string(f, error);
    else fputs("null", f);
    fputs("}\n", f);
    if (cli_memstream_close(f, &buf, &len) != 0 || !buf) { free(buf); cli_error("out of memory"); return CLI_FAIL; }
    while (off < len) {
        ssize_t w = write(fd, buf + off, len - off);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) { cli_error("cannot append to the journal '%s': %s", jpath, w < 0 ? strerror(errno) : "short write"); rc = CLI_FAIL; break; }
        off += (size_t)w;
    }
    if (rc == CLI_OK && fsync(fd) != 0 && errno != EINVAL) { cli_error("cannot sync the journal '%s': %s", jpath, strerror(errno)); rc = CLI_FAIL; }
    free(buf);
    return rc;
}

/* `supermat batch`: its options and --help. Every batch takes cli_opts_batch_run; `batch image` the options of
   `supermat image` it passes on (cli_opts_batch_image), `batch mesh` those of `supermat mesh`
   (supermat_cli_mesh_bake_options, mesh.cpp's own table: each goes to supermat_cli_mesh_opt_set). */
enum { CLI_BATCH_OUT = 1, CLI_BATCH_SHARD, CLI_BATCH_JOBS, CLI_BATCH_RETRY, CLI_BATCH_FAIL_FAST, CLI_BATCH_JSON, CLI_BATCH_MERGE,
       CLI_BATCH_MODEL, CLI_BATCH_OUTPUTS, CLI_BATCH_ALPHA };
static const cli_optdef cli_opts_batch_run[] = {
    {CLI_BATCH_OUT, "--out", "DIR", "the output folder (required)", NULL, NULL},
    {CLI_BATCH_SHARD, "--shard", "I/N", "only the items I, I+N, I+2N, ... (0-based) of the list sorted by output name:\n"
                                        "N processes or machines, one shard each, share the work (journal per shard)", NULL, NULL},
    {CLI_BATCH_JOBS, "--jobs", "J", "J worker processes (forked after the model load: one copy of the weights;\n"
                                    "threads on Windows), each on every J-th item, with threads / J threads (default 1)", NULL, NULL},
    {CLI_BATCH_RETRY, "--retry-failed", NULL, "run the items the journal says failed again", NULL, NULL},
    {CLI_BATCH_FAIL_FAST, "--fail-fast", NULL, "stop at the first failed item (default: go on, exit 1 at the end)", NULL, NULL},
    {CLI_BATCH_JSON, "--json", "FILE", "a summary: items, done, failed, skipped, seconds, journal", NULL, NULL},
    {CLI_BATCH_MERGE, "--merge", NULL, "write DIR/journal.jsonl from DIR/journal.*-of-*.jsonl (the last record per item);\n"
                                       "with INPUTs, also the items that have no done record (exit 1 if any)", NULL, NULL},
    CLI_END};
static const cli_optdef cli_opts_batch_image[] = {
    {CLI_BATCH_MODEL, "--model", "FILE|NAME", "as `supermat image` (a file, official or default; default: the default\n"
                                                "model), loaded once for the batch", NULL, NULL},
    {CLI_BATCH_OUTPUTS, "--outputs", "LIST", CLI_HELP_OUTPUTS "; a manifest line's \"outputs\" wins", NULL, NULL},
    {CLI_BATCH_ALPHA, "--alpha", "A", "keep | drop, as `supermat image`", NULL, NULL},
    {CLI_O_FLOAT, "--float", NULL, "also the PFM maps, as `supermat image --float`; a manifest line's \"float\" wins", NULL, NULL},
    CLI_OPTS(cli_opts_work),
    {CLI_O_DETAIL, "--detail", "F|off", "as `supermat image`", NULL, NULL},
    {CLI_O_CHROMA, "--chroma", "W|off", "as `supermat image`", NULL, NULL},
    {CLI_O_ROUGH_CURVE, "--roughness-curve", "LIST|off", "as `supermat image`", NULL, NULL},
    {CLI_O_METAL_CURVE, "--metallic-curve", "LIST|off", "as `supermat image`", NULL, NULL},
    CLI_OPTS(cli_opts_machine),
    CLI_END};
static const cli_optdef cli_opts_batch[] = {
    CLI_TEXT("usage: supermat batch image [--model FILE] --out DIR [options] INPUT...\n"
             "       supermat batch mesh [--model official | --mv-model F] [--refine | --albedo-refine F | --rm-refine F |\n"
             "                           --passthrough] --out DIR\n"
             "                           [mesh options] [batch options] INPUT...\n"
             "       supermat batch --merge --out DIR [INPUT...]\n"
             "\n"
             "Runs `supermat image` over an asset library, resumably. INPUT is a picture, a folder (searched\n"
             "recursively for .png .jpg .jpeg .webp .bmp .tga; hidden entries and DIR itself left out) or @LIST: a\n"
             "file with one path per line, or JSON Lines objects {\"input\": PATH, \"outputs\": \"albedo,...\",\n"
             "\"float\": true} (paths relative to the current folder; blank lines and # comments skipped).\n"
             "Each item's maps go where `supermat image` would put them, below DIR in the same sub-folder as the\n"
             "picture below the folder it was found in: DIR/<sub>/<stem>_albedo.png, ...; pictures of one folder\n"
             "that share a stem keep their extension in it: a.png, a.jpg -> a_png_albedo.png, a_jpg_albedo.png.\n"
             "\n"
             "The journal DIR/journal.jsonl (with --shard: DIR/journal.I-of-N.jsonl) gets one JSON line per\n"
             "finished item, written after its outputs: item, input, status (done / failed), seconds, outputs,\n"
             "error. A re-run skips done items (and failed ones, unless --retry-failed); a killed run loses no\n"
             "finished item and leaves no partial file. DIR belongs to the batch: outputs of an item that is not\n"
             "done are replaced.\n"
             "\n"
             "options:\n"),
    CLI_OPTS(cli_opts_batch_run),
    CLI_TEXT("\nbatch image: the options of `supermat image`, for every picture:\n"),
    CLI_OPTS(cli_opts_batch_image),
    CLI_TEXT("\n"
             "batch mesh: INPUTs are .gltf / .glb assets (folders searched for them); each is baked as `supermat mesh`\n"
             "does into DIR/<sub>/<stem>.gltf|.glb (the input's extension) with its textures beside it. The options\n"
             "of `supermat mesh` (`supermat mesh --help`) but --debug-dir, and those of the batch, are taken; each\n"
             "process loads the models once.\n"
             "\n"
             "One line per item on stderr ([i/N] item seconds status); a progress line on a terminal.\n"
             "exit status: 0 every item done, 1 some failed or missing, 2 usage error\n"),
    CLI_END};
/* what `batch image` (and `batch --merge`) parses */
static const cli_optdef cli_opts_batch_image_args[] = {CLI_OPTS(cli_opts_batch_run), CLI_OPTS(cli_opts_batch_image), CLI_END};

typedef struct cli_merge_ctx {
    cli_blist *L;     /* the inputs' items, when given */
    char **keys, **lines;
    size_t n, cap;
    int oom;
} cli_merge_ctx;
static void cli_merge_rec(void *user, const cli_jrec *r, const char *line) {
    cli_merge_ctx *M = (cli_merge_ctx *)user;
    size_t i;
    for (i = 0; i < M->n; i++) /* the last record of an item wins (linear: merges are rare and small) */
        if (!strcmp(M->keys[i], r->item)) {
            char *c = cli_strdup(line);
            if (!c) { M->oom = 1; return; }
            free(M->lines[i]);
            M->lines[i] = c;
            return;
        }
    if (M->n == M->cap) {
        size_t cap = M->cap ? 2 * M->cap : 64;
        char **k = (char **)realloc(M->keys, cap * sizeof *k), **l;
        if (!k) { M->oom = 1; return; }
        M->keys = k;
        if (!(l = (char **)realloc(M->lines, cap * sizeof *l))) { M->oom = 1; return; }
        M->lines = l;
        M->cap = cap;
    }
    M->keys[M->n] = cli_strdup(r->item);
    M->lines[M->n] = cli_strdup(line);
    if (!M->keys[M->n] || !M->lines[M->n]) { free(M->keys[M->n]); free(M->lines[M->n]); M->oom = 1; return; }
    M->n++;
}

static int cli_batch_merge(const char *out_dir, cli_blist *L, int have_inputs) {
    cli_merge_ctx M;
    DIR *d = opendir(out_dir);
    struct dirent *e;
    char *target = cli_join(out_dir, "journal", ".jsonl");
    char **names = NULL;
    size_t nn = 0, i;
    int rc = CLI_OK, failed = 0, missing = 0, shards = 0;
    cli_mem mem;
    FILE *f;
    memset(&M, 0, sizeof M);
    M.L = L;
    if (!target) { cli_error("out of memory"); if (d) closedir(d); return CLI_FAIL; }
    if (!d) { cli_error("cannot read folder '%s': %s", out_dir, strerror(errno)); free(target); return CLI_FAIL; }
    while ((e = readdir(d)) != NULL) { /* journal.I-of-N.jsonl, in name order */
        int a, b, used = 0;
        char tail[8];
        if (sscanf(e->d_name, "journal.%d-of-%d.%6s%n", &a, &b, tail, &used) == 3 && !strcmp(tail, "jsonl") && used == (int)strlen(e->d_name)) {
            char **nv = (char **)realloc(names, (nn + 1) * sizeof *nv);
            if (!nv || !(nv[nn] = cli_join(out_dir, e->d_name, ""))) { free(nv ? nv : names); names = NULL; nn = 0; rc = CLI_FAIL; cli_error("out of memory"); break; }
            names = nv;
            nn++;
        }
    }
    closedir(d);
    for (i = 0; i + 1 < nn; i++) { /* sort the names */
        size_t j;
        for (j = i + 1; j < nn; j++) if (strcmp(names[j], names[i]) < 0) { char *t = names[i]; names[i] = names[j]; names[j] = t; }
    }
    for (i = 0; i < nn && rc == CLI_OK; i++) {
        int jr = cli_journal_read(names[i], cli_merge_rec, &M);
        if (jr == -2) rc = CLI_FAIL;
        else if (jr != 0) { cli_error("cannot read '%s': %s", names[i], strerror(errno)); rc = CLI_FAIL; }
        shards++;
    }
    if (rc == CLI_OK && M.oom) { cli_error("out of memory"); rc = CLI_FAIL; }
    if (rc == CLI_OK && !nn) { cli_error("no journal.I-of-N.jsonl in '%s'", out_dir); rc = CLI_FAIL; }
    if (rc == CLI_OK) { /* sorted by item */
        size_t a2, b2;
        for (a2 = 0; a2 + 1 < M.n; a2++)
            for (b2 = a2 + 1; b2 < M.n; b2++)
                if (strcmp(M.keys[b2], M.keys[a2]) < 0) {
                    char *t = M.keys[a2]; M.keys[a2] = M.keys[b2]; M.keys[b2] = t;
                    t = M.lines[a2]; M.lines[a2] = M.lines[b2]; M.lines[b2] = t;
                }
        for (i = 0; i < M.n; i++) if (strstr(M.lines[i], "\"status\":\"done\"") == NULL) failed++;
        /* the merged journal is the batch's own file: cli_io_own_outputs made the policy --force */
        if (!(f = cli_mem_open(&mem, target))) rc = CLI_FAIL;
        else {
            for (i = 0; i < M.n; i++) fputs(M.lines[i], f);
            rc = cli_mem_commit(&mem, target, 1, 0);
        }
    }
    if (rc == CLI_OK && have_inputs) {
        for (i = 0; i < L->n; i++) {
            size_t j;
            int done = 0;
            for (j = 0; j < M.n && !done; j++)
                if (!strcmp(M.keys[j], L->v[i].key)) done = strstr(M.lines[j], "\"status\":\"done\"") != NULL;
            if (!done) {
                missing++;
                if (missing <= 20) fprintf(stderr, "not done: %s (%s)\n", L->v[i].key, L->v[i].input);
            }
        }
    }
    if (rc == CLI_OK)
        fprintf(stderr, "merged %d journal(s) into %s: %zu items, %zu done, %d failed%s", shards, target, M.n, M.n - (size_t)failed, failed,
                have_inputs ? "" : "\n");
    if (rc == CLI_OK && have_inputs) fprintf(stderr, "; of %zu inputs %d not done\n", L->n, missing);
    for (i = 0; i < M.n; i++) { free(M.keys[i]); free(M.lines[i]); }
    free(M.keys); free(M.lines);
    for (i = 0; i < nn; i++) free(names[i]);
    free(names);
    free(target);
    if (rc != CLI_OK) return rc;
    return failed || missing ? CLI_FAIL : CLI_OK;
}

/* `supermat mesh` as functions (cli/mesh.cpp): its options parsed and checked once, before any asset, then
   one run per asset */
typedef struct supermat_cli_mesh_opts supermat_cli_mesh_opts;
#ifdef SUPERMAT_CLI_MESH
int supermat_cli_mesh_run(const supermat_cli_mesh_opts *opts, const char *in, const char *out, int force, int allow_outside);
void supermat_cli_mesh_opts_free(supermat_cli_mesh_opts *opts);
void supermat_cli_mesh_keep_models(int keep);   /* the models stay loaded from one asset to the next */
extern const cli_optdef supermat_cli_mesh_bake_options[]; /* `supermat mesh`'s options but --debug-dir (ids >= 300) */
supermat_cli_mesh_opts *supermat_cli_mesh_opts_new(void);
/* 1: id is one of supermat_cli_mesh_bake_options and its value is in o; -1 after a usage message; 0: not one */
int supermat_cli_mesh_opt_set(supermat_cli_mesh_opts *o, int id, const char *value);
int supermat_cli_mesh_opts_check(const supermat_cli_mesh_opts *o); /* 0, or 2 after a usage message */
/* what `batch mesh` parses */
static const cli_optdef cli_opts_batch_mesh_args[] = {CLI_OPTS(cli_opts_batch_run), CLI_OPTS(supermat_cli_mesh_bake_options), CLI_END};
#endif
static void cli_batch_mesh_free(supermat_cli_mesh_opts *o) {
#ifdef SUPERMAT_CLI_MESH
    supermat_cli_mesh_opts_free(o);
#else
    (void)o;
#endif
}
/* one asset to DIR/<stem>.<ext>, replacing what a killed run left (the mesh run removes the staging folders and
   temporary files that dead runs left in DIR: smio_clean_stale) */
static int cli_batch_mesh_item(const cli_batch_ctx *B, const supermat_cli_mesh_opts *mo, const cli_bitem *it, const char *dir) {
#ifdef SUPERMAT_CLI_MESH
    char *out;
    int rc;
    out = cli_join(dir, it->stem, cli_ext_of(it->input));
    if (!out) { cli_error("out of memory"); return CLI_FAIL; }
    fflush(stdout);
    rc = supermat_cli_mesh_run(mo, it->input, out, 1, B->allow_outside);
    fflush(stdout);
    if (rc != 0) cli_error("supermat mesh %s: exit %d (its message is above)", it->input, rc);
    free(out);
    return rc == 0 ? CLI_OK : CLI_FAIL;
#else
    (void)B; (void)mo; (void)it; (void)dir;
    cli_error("built without tinygltf");
    return CLI_FAIL;
#endif
}

/* --jobs: one worker's share of the items left to run (the r-th of them, in key order, when r % nworkers == w),
   each item's record appended to the journal after its outputs are in place. With several workers the items'
   status is left as it was (the journal is read again after them). */
typedef struct cli_bwork {
    cli_batch_ctx *B;
    supermat_cli_mesh_opts *mopts;
    cli_blist *L;
    cli_image_ctx X; /* this worker's own: its session (the model is shared) */
    const char *out_dir, *jpath;
    int fd, shard_i, shard_n, retry, fail_fast, nworkers, w;
    size_t mine, ran_done, ran_failed;
    int rc;          /* CLI_FAIL: the journal failed, or --fail-fast stopped at a failed item */
} cli_bwork;

static void cli_batch_worker(cli_bwork *W) {
    cli_blist *L = W->L;
    size_t run_i = 0, pos = 0, k;
    W->rc = CLI_OK;
#ifdef SUPERMAT_CLI_MESH
    if (W->B->mesh_mode) supermat_cli_mesh_keep_models(1); /* each process loads the models once */
#endif
    for (k = 0; k < L->n && W->rc == CLI_OK; k++) {
        cli_bitem *it = &L->v[k];
        char prefix[64], *dir;
        double s0;
        int r;
        if ((int)(k % (size_t)W->shard_n) != W->shard_i) continue;
        pos++;
        if (it->status == 1 || (it->status == 2 && !W->retry)) continue;
        if ((int)(run_i++ % (size_t)W->nworkers) != W->w) continue;
        snprintf(prefix, sizeof prefix, "[%zu/%zu] ", pos, W->mine);
        W->X.prefix = prefix;
        W->X.outputs = it->outputs;
        W->X.want_float = it->want_float;
        dir = it->sub[0] ? cli_join(W->out_dir, it->sub, "") : cli_strdup(W->out_dir);
        s0 = cli_now();
        cli_last_error[0] = 0;
        if (!dir) { cli_error("out of memory"); r = CLI_FAIL; }
        else if ((r = cli_mkdirs_below(W->out_dir, it->sub)) == CLI_OK) {
            if (!W->B->mesh_mode) r = cli_image_one(&W->X, it->input, dir, it->stem);
            else r = cli_batch_mesh_item(W->B, W->mopts, it, dir);
        }
        free(dir);
        if (r == CLI_SKIPPED) r = CLI_OK;
        if (cli_journal_append(W->B, W->fd, W->jpath, it, r == CLI_OK, cli_now() - s0, r == CLI_OK ? NULL : cli_last_error) != CLI_OK) {
            W->rc = CLI_FAIL;
            break;
        }
        fprintf(stderr, "%s%s %.2f s %s%s\n", prefix, it->key, cli_now() - s0, r == CLI_OK ? "done" : "FAILED: ", r == CLI_OK ? "" : cli_last_error);
        if (r == CLI_OK) { if (W->nworkers == 1) it->status = 1; W->ran_done++; }
        else {
            if (W->nworkers == 1) it->status = 2;
            W->ran_failed++;
            if (W->fail_fast) { fprintf(stderr, "batch: stopped at the first failed item (--fail-fast)\n"); W->rc = CLI_FAIL; }
        }
    }
    cli_image_ctx_release(&W->X);
#ifdef SUPERMAT_CLI_MESH
    if (W->B->mesh_mode) supermat_cli_mesh_keep_models(0);
#endif
}

#if defined(_WIN32)
/* --jobs on Windows: the workers are threads of this process (no fork there): one model in memory, each
   worker its own session; killing the batch ends them all at once, as on Linux */
static DWORD WINAPI cli_batch_thread(LPVOID p) {
    cli_batch_worker((cli_bwork *)p);
    return 0;
}
static int cli_batch_workers_run(cli_bwork *W, int n) {
    HANDLE *th = (HANDLE *)calloc((size_t)n, sizeof *th);
    int w, rc = CLI_OK;
    if (!th) { cli_error("out of memory"); return CLI_FAIL; }
    for (w = 0; w < n; w++)
        if (!(th[w] = CreateThread(NULL, 0, cli_batch_thread, &W[w], 0, NULL))) { cli_error("cannot start a worker (error %lu)", (unsigned long)GetLastError()); rc = CLI_FAIL; break; }
    for (w = 0; w < n; w++)
        if (th[w]) { WaitForSingleObject(th[w], INFINITE); CloseHandle(th[w]); }
    free(th);
    return rc;
}
#else
/* --jobs: the workers are processes forked after the model load (they share its pages); a killed batch
   takes them along (Linux: PR_SET_PDEATHSIG) */
static int cli_batch_workers_run(cli_bwork *W, int n) {
    pid_t *pids = (pid_t *)calloc((size_t)n, sizeof *pids);
    int w, rc = CLI_OK;
    if (!pids) { cli_error("out of memory"); return CLI_FAIL; }
    fflush(stdout); fflush(stderr);
    for (w = 0; w < n; w++) {
        pid_t p = fork();
        if (p < 0) { cli_error("cannot start a worker: %s", strerror(errno)); rc = CLI_FAIL; break; }
        if (p > 0) { pids[w] = p; continue; }
#ifdef __linux__
        prctl(PR_SET_PDEATHSIG, SIGKILL); /* a killed batch takes its workers along */
#endif
        cli_batch_worker(&W[w]);
        _exit(W[w].rc == CLI_OK && !W[w].ran_failed ? 0 : 1);
    }
    for (w = 0; w < n; w++) {
        int st;
        if (pids[w] <= 0) continue;
        while (waitpid(pids[w], &st, 0) < 0 && errno == EINTR) {}
        if (!WIFEXITED(st) || (WEXITSTATUS(st) != 0 && WEXITSTATUS(st) != 1)) { cli_error("worker %d ended abnormally", w); rc = CLI_FAIL; }
    }
    free(pids);
    return rc;
}
#endif

static int cli_batch(int argc, char **argv) {
    const char *cmd = "batch", *v, *model_arg = NULL, *model_path = NULL, *out_dir = NULL, *json_path = NULL;
    unsigned outputs = SUPERMAT_OUTPUT_ALL;
    int want_float = 0, threads = 0, i, m, rc = CLI_OK, tty = isatty(2), work_opt = -1, merge = 0, jobs = 1;
    int shard_i = 0, shard_n = 1, retry = 0, fail_fast = 0, have_inputs = 0, fd = -1;
    supermat_kernel kernel = SUPERMAT_KERNEL_AUTO;
    unsigned char *file = NULL;
    size_t file_size = 0, k, mine = 0, done_before = 0, failed_before = 0, ran_done = 0, ran_failed = 0, left = 0;
    cli_blist L;
    cli_image_ctx X;
    cli_model_ref mref;
    struct stat out_st;
    int have_out_st = 0;
    char *jpath = NULL;
    double t0 = cli_now();
    const char **inputs;
    int ninputs = 0;
    supermat_cli_mesh_opts *mopts = NULL; /* batch mesh: `supermat mesh`'s options, checked once */
    const cli_optdef *args = cli_opts_batch_image_args;
    cli_batch_ctx B;
    cli_argp P;

    memset(&L, 0, sizeof L);
    memset(&X, 0, sizeof X);
    memset(&B, 0, sizeof B);
    B.allow_outside = cli_g.allow_outside;
    cli_levers_init(&X.lv);
    if (argc >= 3 && (!strcmp(argv[2], "--help") || !strcmp(argv[2], "-h"))) { cli_help_print(stdout, cli_opts_batch); return CLI_OK; }
    i = 2;
    if (argc >= 3 && !strcmp(argv[2], "image")) i = 3;
    else if (argc >= 3 && !strcmp(argv[2], "--merge")) i = 2; /* an option of the table */
    else if (argc >= 3 && !strcmp(argv[2], "mesh")) {
#ifdef SUPERMAT_CLI_MESH
        B.mesh_mode = 1;
        args = cli_opts_batch_mesh_args;
        i = 3;
        if (!(mopts = supermat_cli_mesh_opts_new())) return CLI_FAIL;
#else
        cli_error("this supermat was built without tinygltf (libtinygltf-dev): `batch mesh` is not available");
        return CLI_FAIL;
#endif
    }
    else return cli_usage_error(cmd, "give what to run: `supermat batch image ...` (or `supermat batch --merge --out DIR`)");
    inputs = (const char **)malloc(sizeof(char *) * (size_t)(argc > 0 ? argc : 1));
    if (!inputs) { cli_batch_mesh_free(mopts); cli_error("out of memory"); return CLI_FAIL; }
    cli_argp_init(&P, cmd, args, argc, argv, i);
    for (;;) {
        const char *a = P.i < P.argc && !P.operands_only ? P.argv[P.i] : "";
        if (B.mesh_mode && a[0] == '-' && a[1] == '-') { /* an option of `batch image` alone: say so */
            size_t n = strcspn(a, "=");
            if (!cli_opt_find(args, a, n) && cli_opt_find(cli_opts_batch_image, a, n)) {
                rc = cli_usage_error(cmd, "'%.*s' is an option of `batch image`, not of `batch mesh`", (int)n, a);
                break;
            }
        }
        if ((m = cli_argp_next(&P, &v)) == CLI_ARG_END) break;
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, cli_opts_batch); free(inputs); cli_batch_mesh_free(mopts); return CLI_OK; }
        if (m == CLI_ARG_ERROR) { rc = CLI_USAGE; break; }
        if (m == CLI_ARG_OPERAND) inputs[ninputs++] = v;
        else if (m == CLI_BATCH_OUT) out_dir = v;
        else if (m == CLI_BATCH_JSON) json_path = v;
        else if (m == CLI_BATCH_MERGE) merge = 1;
        else if (m == CLI_BATCH_RETRY) retry = 1;
        else if (m == CLI_BATCH_FAIL_FAST) fail_fast = 1;
        else if (m == CLI_BATCH_SHARD) {
            char extra;
            if (sscanf(v, "%d/%d%c", &shard_i, &shard_n, &extra) != 2 || shard_n < 1 || shard_i < 0 || shard_i >= shard_n) {
                rc = cli_usage_error(cmd, "--shard I/N: 0 <= I < N (got '%s')", v);
                break;
            }
        } else if (m == CLI_BATCH_JOBS) {
            jobs = atoi(v);
            if (jobs < 1 || jobs > 256) { rc = cli_usage_error(cmd, "--jobs J: 1 to 256 (got '%s')", v); break; }
        } else if (m == CLI_BATCH_MODEL) model_arg = v;
        else if (m == CLI_BATCH_OUTPUTS) {
            if (cli_parse_outputs(cmd, v, &outputs)) { rc = CLI_USAGE; break; }
        }
        else if (m == CLI_BATCH_ALPHA) {
            if (cli_parse_alpha(cmd, v, &X.alpha_drop)) { rc = CLI_USAGE; break; }
        }
#ifdef SUPERMAT_CLI_MESH
        else if (B.mesh_mode) { /* one of `supermat mesh`'s (its table is args' second half) */
            if (supermat_cli_mesh_opt_set(mopts, m, v) <= 0) { rc = CLI_USAGE; break; }
        }
#endif
        else if (cli_run_value(cmd, m, v, &want_float, &work_opt, &threads, &kernel, &X.lv) <= 0) { rc = CLI_USAGE; break; }
    }
    if (rc == CLI_OK && !out_dir) rc = cli_usage_error(cmd, "--out DIR is required");
    if (rc == CLI_OK && !merge && !ninputs) rc = cli_usage_error(cmd, "no input (pictures, folders or @LIST)");
    if (rc == CLI_OK && cli_g.policy == CLI_POLICY_SKIP) rc = cli_usage_error(cmd, "--skip-existing does not apply: the journal says what is done");
#ifdef SUPERMAT_CLI_MESH
    if (rc == CLI_OK && B.mesh_mode && !merge && supermat_cli_mesh_opts_check(mopts) != 0) rc = CLI_USAGE; /* it said why */
#endif
    if (rc != CLI_OK) { free(inputs); cli_batch_mesh_free(mopts); return rc; }
    cli_io_own_outputs(out_dir); /* DIR belongs to the batch: below it no link is followed, and an unfinished
                                    item's outputs are replaced */

    if (!merge && (rc = cli_mkdirs(out_dir)) != CLI_OK) { free(inputs); cli_batch_mesh_free(mopts); return rc; }
    if (stat(out_dir, &out_st) == 0) have_out_st = 1;
    if (!merge) B.out_real = realpath(out_dir, NULL);
    for (i = 0; i < ninputs && rc == CLI_OK; i++) rc = cli_add_input(&B, &L, cmd, inputs[i], have_out_st ? &out_st : NULL, outputs, want_float);
    have_inputs = ninputs > 0;
    free(inputs);
    if (rc == CLI_OK && B.mesh_mode) { /* the asset keeps its extension: a.gltf and a.glb share a key */
        for (k = 0; k < L.n; k++) {
            const char *e = cli_ext_of(L.v[k].input);
            if (strcmp(e, ".gltf") && strcmp(e, ".glb")) { rc = cli_usage_error(cmd, "'%s' is not a .gltf or .glb asset", L.v[k].input); break; }
        }
    }
    if (rc == CLI_OK && L.n > 1 && !B.mesh_mode) rc = cli_blist_disambiguate(&L);
    if (rc == CLI_OK && L.n > 1) {
        qsort(L.v, L.n, sizeof *L.v, cli_bitem_cmp);
        for (k = 1; k < L.n && rc == CLI_OK; k++)
            if (!strcmp(L.v[k].key, L.v[k - 1].key)) {
                if (!strcmp(L.v[k].input, L.v[k - 1].input)) { /* named twice: once is enough */
                    cli_bitem t = L.v[k];
                    free(t.input); free(t.sub); free(t.stem); free(t.key);
                    memmove(&L.v[k], &L.v[k + 1], (L.n - k - 1) * sizeof *L.v);
                    L.n--;
                    k--;
                } else
                    rc = cli_usage_error(cmd, "'%s' and '%s' would write the same files (%s_*)", L.v[k - 1].input, L.v[k].input, L.v[k].key);
            }
    }
    if (rc != CLI_OK) { cli_blist_free(&L); cli_batch_mesh_free(mopts); free(B.out_real); return rc; }
    if (merge) { rc = cli_batch_merge(out_dir, &L, have_inputs); cli_blist_free(&L); cli_batch_mesh_free(mopts); return rc; }

    /* this shard's items, and what the journal says of them */
    {
        char name[64];
        if (shard_n > 1) snprintf(name, sizeof name, "journal.%d-of-%d", shard_i, shard_n);
        else snprintf(name, sizeof name, "journal");
        jpath = cli_join(out_dir, name, ".jsonl");
        if (!jpath) { cli_error("out of memory"); cli_blist_free(&L); cli_batch_mesh_free(mopts); free(B.out_real); return CLI_FAIL; }
    }
    {
        int jr = cli_journal_read(jpath, cli_journal_status, &L);
        if (jr != 0) { /* -2: it said why */
            if (jr != -2) cli_error("cannot read the journal '%s': %s", jpath, strerror(errno));
            rc = CLI_FAIL;
        }
    }
    for (k = 0; k < L.n; k++) {
        if ((int)(k % (size_t)shard_n) != shard_i) continue;
        mine++;
        if (L.v[k].status == 1) done_before++;
        else if (L.v[k].status == 2 && !retry) failed_before++;
        else left++;
    }
    if (rc == CLI_OK) {
        char of[64] = "";
        if (shard_n > 1) snprintf(of, sizeof of, " (shard %d/%d of %zu)", shard_i, shard_n, L.n);
        fprintf(stderr, "batch: %zu item(s)%s: %zu done before, %zu failed before%s, %zu to run; journal %s\n", mine, of,
                done_before, failed_before, failed_before ? " (--retry-failed runs them)" : "", left, jpath);
    }
    if (rc == CLI_OK && left && !B.mesh_mode) { /* one model load for the whole batch (mesh: on its first asset) */
        rc = cli_model_path("image", model_arg, 1, &mref);
        if (rc == CLI_OK) model_path = mref.path;
        if (rc == CLI_OK) rc = cli_load_model(model_path, kernel, &X.lv, &file, &file_size, &X.model, NULL);
        if (rc == CLI_OK) rc = cli_require_kind(cmd, model_path, X.model, SUPERMAT_KIND_SUPERMAT);
        X.work_opt = work_opt;
    }
    if (rc == CLI_OK && left && (fd = open(jpath, O_RDWR | O_APPEND | O_CREAT | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC, 0644)) < 0) {
        cli_error("cannot open the journal '%s': %s", jpath, errno == ELOOP ? "it is a symbolic link (never followed)" : strerror(errno));
        rc = CLI_FAIL;
    }
    if (rc == CLI_OK && fd >= 0) { /* a regular file, and this batch's alone: a second batch on DIR refuses to start */
        struct stat jst;
        memset(&jst, 0, sizeof jst);
        if (fstat(fd, &jst) != 0 || !S_ISREG(jst.st_mode)) {
            cli_error("the journal '%s' is %s, not a regular file", jpath, smio_kind(jst.st_mode));
            rc = CLI_FAIL;
        } else if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            cli_error("another batch is writing into '%s' (its journal '%s' is locked): one batch per output folder and shard", out_dir, jpath);
            rc = CLI_FAIL;
        } else
            (void)fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    }
    if (rc == CLI_OK && fd >= 0) { /* a line torn by a kill gets its end, so the next record starts a line of its own */
        struct stat jst;
        char last = '\n';
        if (fstat(fd, &jst) == 0 && jst.st_size > 0 && pread(fd, &last, 1, jst.st_size - 1) == 1 && last != '\n' && write(fd, "\n", 1) != 1) {
            cli_error("cannot append to the journal '%s': %s", jpath, strerror(errno));
            rc = CLI_FAIL;
        }
    }
    if (json_path && rc == CLI_OK && cli_report_allowed(json_path) != CLI_OK) rc = CLI_FAIL;

    if (rc == CLI_OK && left) {
        int nworkers = jobs < (int)left ? jobs : (int)left, w;
        int threads_total = threads > 0 ? threads : supermat_default_threads();
        cli_bwork *W = (cli_bwork *)calloc((size_t)(nworkers > 0 ? nworkers : 1), sizeof *W);
        if (!W) { cli_error("out of memory"); rc = CLI_FAIL; nworkers = 0; }
        for (w = 0; w < nworkers; w++) {
            W[w].B = &B; W[w].mopts = mopts; W[w].L = &L; W[w].X = X;
            W[w].out_dir = out_dir; W[w].jpath = jpath; W[w].fd = fd;
            W[w].shard_i = shard_i; W[w].shard_n = shard_n; W[w].retry = retry; W[w].fail_fast = fail_fast;
            W[w].nworkers = nworkers; W[w].w = w; W[w].mine = mine;
            W[w].X.outputs = outputs; W[w].X.want_float = want_float; W[w].X.tty = tty && nworkers == 1;
            W[w].X.threads = nworkers > 1 ? (threads_total / nworkers > 0 ? threads_total / nworkers : 1) : threads;
        }
        if (nworkers == 1) {
            cli_batch_worker(&W[0]);
            ran_done = W[0].ran_done;
            ran_failed = W[0].ran_failed;
            if (W[0].rc != CLI_OK && !ran_failed) rc = CLI_FAIL; /* the journal itself failed */
        } else if (nworkers > 1) {
            if (cli_batch_workers_run(W, nworkers) != CLI_OK) rc = CLI_FAIL;
            /* the workers' records: read the journal again */
            for (k = 0; k < L.n; k++) L.v[k].status = 0;
            int jr = cli_journal_read(jpath, cli_journal_status, &L);
            if (jr != 0) { if (jr != -2) cli_error("cannot read the journal '%s'", jpath); rc = CLI_FAIL; }
            ran_done = ran_failed = 0;
            {
                size_t d = 0, f = 0;
                for (k = 0; k < L.n; k++) {
                    if ((int)(k % (size_t)shard_n) != shard_i) continue;
                    if (L.v[k].status == 1) d++;
                    else if (L.v[k].status == 2) f++;
                }
                ran_done = d >= done_before ? d - done_before : 0;
                ran_failed = f;
            }
        }
        free(W);
    }
    if (fd >= 0) close(fd);
    {
        size_t d = 0, f = 0, n = 0;
        for (k = 0; k < L.n; k++) {
            if ((int)(k % (size_t)shard_n) != shard_i) continue;
            n++;
            if (L.v[k].status == 1) d++;
            else if (L.v[k].status == 2) f++;
        }
        fprintf(stderr, "batch: %zu of %zu item(s) done (%zu in this run), %zu failed, %zu not run; %.1f s\n", d, n, ran_done, f, n - d - f,
                cli_now() - t0);
        if (json_path && rc == CLI_OK) {
            cli_mem mem;
            FILE *jf = cli_mem_open(&mem, json_path);
            if (!jf) rc = CLI_FAIL;
            else {
                fprintf(jf, "{\"items\": %zu, \"done\": %zu, \"done_this_run\": %zu, \"failed\": %zu, \"not_run\": %zu, \"seconds\": %.3f, "
                            "\"shard\": \"%d/%d\", \"journal\": ", n, d, ran_done, f, n - d - f, cli_now() - t0, shard_i, shard_n);
                cli_json_string(jf, jpath);
                fputs("}\n", jf);
                rc = cli_mem_commit(&mem, json_path, 1, 0);
            }
        }
        if (rc == CLI_OK && d != n) rc = CLI_FAIL;
    }
    supermat_model_destroy(X.model);
    cli_free_file(file);
    cli_blist_free(&L);
    free(jpath);
    cli_batch_mesh_free(mopts);
    free(B.out_real);
    return rc;
}
