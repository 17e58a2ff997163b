/* The default thread count (threads = 0): CPU-list and cgroup-quota parsing, and the count itself.
 *   test_threads            parsers + 1 <= default <= online cores
 *   test_threads N          also: the default is exactly N (the tests run it under `taskset -c 0` with 1) */
#define SUPERMAT_IMPLEMENTATION
#include "supermat.h"

#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

static int failures;
#define CHECK_EQ(a, b)                                                                              \
    do {                                                                                            \
        long a_ = (long)(a), b_ = (long)(b);                                                        \
        if (a_ != b_) { printf("FAIL %s:%d: %s = %ld, expected %ld\n", __FILE__, __LINE__, #a, a_, b_); failures++; } \
    } while (0)

int main(int argc, char **argv) {
    int n;
    long online = sysconf(_SC_NPROCESSORS_ONLN);
    /* Cpus_allowed_list */
    CHECK_EQ(supermat__cpu_list_count("0"), 1);
    CHECK_EQ(supermat__cpu_list_count("0-3"), 4);
    CHECK_EQ(supermat__cpu_list_count("0-3,8,10-11\n"), 7);
    CHECK_EQ(supermat__cpu_list_count(" 5 "), 1);
    CHECK_EQ(supermat__cpu_list_count(""), -1);
    CHECK_EQ(supermat__cpu_list_count("3-1"), -1);
    CHECK_EQ(supermat__cpu_list_count("0-"), -1);
    CHECK_EQ(supermat__cpu_list_count("ff"), -1);
    CHECK_EQ(supermat__cpu_list_count("0,x"), -1);
    /* cgroup v2 cpu.max, v1 quota + period */
    CHECK_EQ(supermat__cpu_quota("max 100000\n", NULL), 0);
    CHECK_EQ(supermat__cpu_quota("100000 100000\n", NULL), 1);
    CHECK_EQ(supermat__cpu_quota("150000 100000\n", NULL), 2);
    CHECK_EQ(supermat__cpu_quota("50000 100000\n", NULL), 1);
    CHECK_EQ(supermat__cpu_quota("400000 100000", NULL), 4);
    CHECK_EQ(supermat__cpu_quota("-1\n", "100000\n"), 0);
    CHECK_EQ(supermat__cpu_quota("300000\n", "100000\n"), 3);
    CHECK_EQ(supermat__cpu_quota("garbage", NULL), -1);
    CHECK_EQ(supermat__cpu_quota("100000", "x"), -1);
    n = supermat_default_threads();
    printf("supermat_default_threads() = %d (online cores %ld)\n", n, online);
    if (n < 1 || n > 64 || (online > 0 && n > online)) { printf("FAIL: out of range\n"); failures++; }
    if (argc > 1) CHECK_EQ(n, atoi(argv[1]));
    {   /* a session with threads = 0 plans for that many workers: the pool reports it */
        supermat_pool *pool = NULL;
        supermat_threading hook;
        if (supermat_pool_create(0, NULL, &pool, &hook) != SUPERMAT_SUCCESS) { printf("FAIL: pool\n"); failures++; }
        else { CHECK_EQ(hook.max_threads, n); supermat_pool_destroy(pool); }
    }
    printf("%s\n", failures ? "FAILED" : "ok");
    return failures ? 1 : 0;
}
