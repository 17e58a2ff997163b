/* cli/opt_table.h - the option tables of the `supermat` commands: one table per command, from which
 * its argument parsing and its `--help` text both come (and docs/cli.md, generated from the help).
 *
 * A table is an array of cli_optdef ending with CLI_END. Its entries, in the order `--help` prints them:
 *   CLI_TEXT("...")      text printed as it is (the usage line, paragraphs, "options:")
 *   an option            {id > 0, "--name", "VALUE" or NULL for a flag, "help line\nline", "--old --names"}
 *                        printed as "  --name VALUE" then its help from the block's column, one line per
 *                        '\n'; older spellings (accepted until the next release) get a line saying so
 *   CLI_OPTS(other)      the entries of another table here (options several commands share)
 * cli_argp_next() walks argv against the table: it returns the id of each option (its value in *val,
 * `--name VALUE` or `--name=VALUE`), CLI_ARG_OPERAND for an operand, CLI_ARG_HELP for --help / -h,
 * CLI_ARG_END at the end, CLI_ARG_ERROR after printing a usage message (an unknown option, a missing
 * value, a value given to a flag). Everything after "--" is an operand.
 *
 * Static functions only, C99 and C++11: cli/main.c (C) and cli/mesh.cpp (C++) include it.
 */
#ifndef SUPERMAT_CLI_OPT_TABLE_H
#define SUPERMAT_CLI_OPT_TABLE_H

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#if defined(__GNUC__) || defined(__clang__)
#define CLI_OPT_PRINTF(f, a) __attribute__((format(printf, f, a)))
#define CLI_OPT_UNUSED __attribute__((unused))
#else
#define CLI_OPT_PRINTF(f, a)
#define CLI_OPT_UNUSED
#endif

typedef struct cli_optdef {
    int id;                        /* > 0 an option; 0 text (help NULL too: the end); -1 CLI_OPTS */
    const char *name;              /* "--model" */
    const char *value;             /* "FILE": takes a value; NULL: a flag */
    const char *help;              /* lines separated by '\n' (no trailing '\n'); text entries: printed as is */
    const char *alias;             /* older spellings, separated by spaces; NULL: none */
    const struct cli_optdef *more; /* CLI_OPTS: the table spliced here */
} cli_optdef;

#define CLI_TEXT(s) {0, NULL, NULL, s, NULL, NULL}
#define CLI_OPTS(t) {-1, NULL, NULL, NULL, NULL, t}
#define CLI_END {0, NULL, NULL, NULL, NULL, NULL}

#define CLI_HELP_COL 20 /* where an option's help starts, unless a longer name in its block pushes it right (then
                           2 spaces after the longest) */
#define CLI_HELP_NAME_MAX 22 /* a "--name VALUE" longer than this pushes nothing: its help starts on the next line */

enum { CLI_ARG_END = 0, CLI_ARG_HELP = -1, CLI_ARG_ERROR = -2, CLI_ARG_OPERAND = -3 };

typedef struct cli_argp {
    const char *cmd;           /* the command, for messages ("image"); NULL: the tool itself */
    const cli_optdef *table;
    int argc;
    char **argv;
    int i;                     /* the next argument */
    int operands_only;         /* after "--" */
    const char *name;          /* the option just returned, as the table spells it (for messages) */
} cli_argp;

/* "supermat CMD: message" and the hint, on stderr; returns 2, the usage exit status */
static int cli_usage_error(const char *cmd, const char *fmt, ...) CLI_OPT_PRINTF(2, 3) CLI_OPT_UNUSED;
static int cli_usage_error(const char *cmd, const char *fmt, ...) {
    va_list ap;
    fprintf(stderr, "supermat%s%s: ", cmd ? " " : "", cmd ? cmd : "");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\nTry 'supermat%s%s --help'.\n", cmd ? " " : "", cmd ? cmd : "");
    return 2;
}

/* does the space-separated list `names` hold the n bytes at s? */
static int cli_opt_in_list(const char *names, const char *s, size_t n) {
    while (names && *names) {
        const char *e = strchr(names, ' ');
        size_t k = e ? (size_t)(e - names) : strlen(names);
        if (k == n && !strncmp(names, s, n)) return 1;
        names += k;
        while (*names == ' ') names++;
    }
    return 0;
}

/* the option of table t (or of a table it splices) named by the n bytes at s, NULL if none */
static const cli_optdef *cli_opt_find(const cli_optdef *t, const char *s, size_t n) {
    for (; t->id != 0 || t->help; t++) {
        if (t->id < 0) {
            const cli_optdef *o = cli_opt_find(t->more, s, n);
            if (o) return o;
        } else if (t->id > 0 && ((strlen(t->name) == n && !strncmp(t->name, s, n)) || cli_opt_in_list(t->alias, s, n))) {
            return t;
        }
    }
    return NULL;
}

static void cli_argp_init(cli_argp *p, const char *cmd, const cli_optdef *table, int argc, char **argv, int first) {
    memset(p, 0, sizeof *p);
    p->cmd = cmd;
    p->table = table;
    p->argc = argc;
    p->argv = argv;
    p->i = first;
}

static int cli_argp_next(cli_argp *p, const char **val) {
    const char *a, *eq;
    const cli_optdef *o;
    size_t n;
    *val = NULL;
    p->name = NULL;
    if (p->i >= p->argc) return CLI_ARG_END;
    a = p->argv[p->i++];
    if (p->operands_only || a[0] != '-' || !a[1]) { *val = a; return CLI_ARG_OPERAND; }
    if (!strcmp(a, "--")) {
        p->operands_only = 1;
        return cli_argp_next(p, val);
    }
    if (!strcmp(a, "--help") || !strcmp(a, "-h")) return CLI_ARG_HELP;
    eq = strchr(a, '=');
    n = eq ? (size_t)(eq - a) : strlen(a);
    o = a[1] == '-' ? cli_opt_find(p->table, a, n) : NULL;
    if (!o) return cli_usage_error(p->cmd, "unknown option '%.*s'", (int)n, a), CLI_ARG_ERROR;
    p->name = o->name;
    if (!o->value) {
        if (eq) return cli_usage_error(p->cmd, "option '%s' takes no value", o->name), CLI_ARG_ERROR;
        return o->id;
    }
    if (eq) { *val = eq + 1; return o->id; }
    if (p->i >= p->argc) return cli_usage_error(p->cmd, "option '%.*s' needs a value", (int)n, a), CLI_ARG_ERROR;
    *val = p->argv[p->i++];
    return o->id;
}

/* the widest "--name VALUE" of the options from t up to the next text entry (spliced tables included);
   *stop: set when a text entry ended the block */
static size_t cli_opt_block_width(const cli_optdef *t, int *stop) {
    size_t w = 0;
    for (; (t->id != 0 || t->help) && !*stop; t++) {
        if (t->id == 0) { *stop = 1; break; }
        if (t->id < 0) {
            size_t k = cli_opt_block_width(t->more, stop);
            if (k > w) w = k;
        } else {
            size_t k = strlen(t->name) + (t->value ? 1 + strlen(t->value) : 0);
            if (k > w && k <= CLI_HELP_NAME_MAX) w = k;
        }
    }
    return w;
}

static void cli_opt_print_lines(FILE *f, const char *s, int col, int first_done) {
    while (*s) {
        const char *e = strchr(s, '\n');
        int k = e ? (int)(e - s) : (int)strlen(s);
        if (first_done) fprintf(f, "%*s", col, "");
        first_done = 1;
        fprintf(f, "%.*s\n", k, s);
        s += k;
        if (*s == '\n') s++;
    }
}

/* prints the entries of t; *col: the current block's help column (0: to be measured) */
static void cli_help_print_table(FILE *f, const cli_optdef *t, int *col) {
    for (; t->id != 0 || t->help; t++) {
        if (t->id == 0) { fputs(t->help, f); *col = 0; continue; }
        if (!*col) {
            int stop = 0;
            size_t w = cli_opt_block_width(t, &stop);
            *col = w + 3 > CLI_HELP_COL ? (int)w + 4 : CLI_HELP_COL; /* "  NAME VALUE" and one space fit, else two */
        }
        if (t->id < 0) { cli_help_print_table(f, t->more, col); continue; }
        {
            int k = fprintf(f, "  %s%s%s", t->name, t->value ? " " : "", t->value ? t->value : "");
            if (k + 1 > *col) fprintf(f, "\n%*s", *col, ""); /* wider than the column: the help below it */
            else fprintf(f, "%*s", *col - k, "");
            cli_opt_print_lines(f, t->help, *col, 0);
            if (t->alias) {
                const char *a = t->alias;
                fprintf(f, "%*s(", *col, "");
                while (*a) {
                    size_t k = strcspn(a, " ");
                    fprintf(f, "%s%.*s", a == t->alias ? "" : ", ", (int)k, a);
                    a += k;
                    while (*a == ' ') a++;
                }
                fprintf(f, ": the old spelling%s, until the next release)\n", strchr(t->alias, ' ') ? "s" : "");
            }
        }
    }
}

/* the command's --help text, from its table */
static void cli_help_print(FILE *f, const cli_optdef *t) {
    int col = 0;
    cli_help_print_table(f, t, &col);
}

#endif
