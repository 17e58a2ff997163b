/* tests/test_opt_table.c - the option tables of the `supermat` commands (cli/opt_table.h): what
 * cli_argp_next returns for each form of argument (--name VALUE, --name=VALUE, flags, old spellings,
 * operands, "--", "-", --help / -h) and that every malformed argument is a usage error with its message
 * (unknown option, a prefix of an option, a single-dash word, a missing value, a value given to a flag);
 * and the --help text cli_help_print makes from a table (column 20, continuation lines, a block pushed
 * right by a long name, a spliced table, the old-spelling line). Built as C and as C++ (cli/mesh.cpp
 * includes the header too). Exit 0 when every check passes. */
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200809L /* dup, dup2, fileno */
#endif
#include "cli/opt_table.h"

#include <stdlib.h>
#include <string.h>
#if !defined(_WIN32)
#include <unistd.h>
#endif

static int fails = 0, checks = 0;
#define CHECK(c) do { checks++; if (!(c)) { fails++; printf("FAIL line %d: %s\n", __LINE__, #c); } } while (0)

enum { O_OUT = 1, O_FLOAT, O_WEIGHTS, O_LONG, O_THREADS };
static const cli_optdef shared[] = {
    {O_THREADS, "--threads", "N", "threads", NULL, NULL},
    CLI_END};
static const cli_optdef table[] = {
    CLI_TEXT("usage: t [options] FILE...\n\noptions:\n"),
    {O_OUT, "--out", "DIR", "the output folder", NULL, NULL},
    {O_FLOAT, "--float", NULL, "also float maps,\nas PFM", NULL, NULL},
    {O_WEIGHTS, "--weights", "W", "the storage", "--precision --dtype", NULL},
    CLI_OPTS(shared),
    CLI_TEXT("\nmore:\n"),
    {O_LONG, "--truth-roughness", "FILE", "a long name\npushes its block", "--truth-r", NULL},
    CLI_END};

/* parses argv (NULL-terminated, after "prog cmd"), writing "id:value " per result into out */
static int parse(const char **args, char *out, size_t cap) {
    char *argv[32];
    int argc = 2, r;
    const char *v;
    cli_argp p;
    argv[0] = (char *)"supermat";
    argv[1] = (char *)"t";
    while (*args) argv[argc++] = (char *)*args++;
    argv[argc] = NULL;
    out[0] = 0;
    cli_argp_init(&p, "t", table, argc, argv, 2);
    while ((r = cli_argp_next(&p, &v)) != CLI_ARG_END) {
        size_t n = strlen(out);
        snprintf(out + n, cap - n, "%d:%s ", r, v ? v : "-");
        if (r == CLI_ARG_ERROR || r == CLI_ARG_HELP) return r;
    }
    return 0;
}

/* runs parse with stderr captured into err (POSIX; elsewhere err is left empty) */
static int parse_err(const char **args, char *out, size_t cap, char *err, size_t errcap) {
    int r;
    err[0] = 0;
#if !defined(_WIN32)
    {
        FILE *tmp = tmpfile();
        int saved = dup(2);
        size_t n;
        fflush(stderr);
        dup2(fileno(tmp), 2);
        r = parse(args, out, cap);
        fflush(stderr);
        dup2(saved, 2);
        close(saved);
        rewind(tmp);
        n = fread(err, 1, errcap - 1, tmp);
        err[n] = 0;
        fclose(tmp);
    }
#else
    (void)errcap;
    r = parse(args, out, cap);
#endif
    return r;
}

static void expect_error(const char **args, const char *message) {
    char out[512], err[512];
    int r = parse_err(args, out, sizeof out, err, sizeof err);
    CHECK(r == CLI_ARG_ERROR);
#if !defined(_WIN32)
    CHECK(strstr(err, message) != NULL);
    CHECK(strstr(err, "Try 'supermat t --help'.") != NULL);
    if (!strstr(err, message)) printf("  stderr was: %s", err);
#else
    (void)message;
#endif
}

int main(void) {
    char out[512], err[512];
    {   /* every accepted form, in order */
        const char *a[] = {"--out", "d", "--float", "a.png", "--weights=f16", "--precision", "bf16", "--dtype=int8",
                           "--threads", "2", "-", "--out=", "--truth-r", "t.png", "--", "--float", "-x", NULL};
        CHECK(parse(a, out, sizeof out) == 0);
        CHECK(!strcmp(out, "1:d 2:- -3:a.png 3:f16 3:bf16 3:int8 5:2 -3:- 1: 4:t.png -3:--float -3:-x "));
        if (strcmp(out, "1:d 2:- -3:a.png 3:f16 3:bf16 3:int8 5:2 -3:- 1: 4:t.png -3:--float -3:-x ")) printf("  got: %s\n", out);
    }
    {   /* a value that looks like an option is still the value */
        const char *a[] = {"--out", "--float", NULL};
        CHECK(parse(a, out, sizeof out) == 0 && !strcmp(out, "1:--float "));
    }
    {   /* --help and -h end the walk */
        const char *a[] = {"--out", "d", "--help", "--bogus", NULL};
        const char *b[] = {"-h", NULL};
        CHECK(parse(a, out, sizeof out) == CLI_ARG_HELP);
        CHECK(parse(b, out, sizeof out) == CLI_ARG_HELP);
    }
    {
        const char *a[] = {"--bogus", NULL};
        const char *b[] = {"--ou", "d", NULL};
        const char *c[] = {"--outx", "d", NULL};
        const char *d[] = {"-o", "d", NULL};
        const char *e[] = {"a.png", "--out", NULL};
        const char *f[] = {"--float=1", NULL};
        const char *g[] = {"--bogus=3", NULL};
        const char *h[] = {"--weights", NULL};
        expect_error(a, "supermat t: unknown option '--bogus'");
        expect_error(b, "unknown option '--ou'");
        expect_error(c, "unknown option '--outx'");
        expect_error(d, "unknown option '-o'");
        expect_error(e, "option '--out' needs a value");
        expect_error(f, "option '--float' takes no value");
        expect_error(g, "unknown option '--bogus'");
        expect_error(h, "option '--weights' needs a value");
    }
    {   /* the help text */
        static const char want[] =
            "usage: t [options] FILE...\n"
            "\n"
            "options:\n"
            "  --out DIR         the output folder\n"
            "  --float           also float maps,\n"
            "                    as PFM\n"
            "  --weights W       the storage\n"
            "                    (--precision, --dtype: the old spellings, until the next release)\n"
            "  --threads N       threads\n"
            "\n"
            "more:\n"
            "  --truth-roughness FILE  a long name\n"
            "                          pushes its block\n"
            "                          (--truth-r: the old spelling, until the next release)\n";
        FILE *f = tmpfile();
        char got[1024];
        size_t n;
        CHECK(f != NULL);
        if (f) {
            cli_help_print(f, table);
            rewind(f);
            n = fread(got, 1, sizeof got - 1, f);
            got[n] = 0;
            fclose(f);
            CHECK(!strcmp(got, want));
            if (strcmp(got, want)) printf("  help was:\n%s", got);
        }
    }
    (void)err;
    printf("%d checks, %d failed\n", checks, fails);
    return fails ? 1 : 0;
}
