/* The macOS branch of the default thread count: the performance cores from sysctlbyname
   ("hw.perflevel0.logicalcpu"), compiled here on Linux with SUPERMAT__TEST_SYSCTL against a stand-in
   sysctlbyname that answers as the test says (macOS itself is not built or run here).
   Checks: the name asked, a read-only query (no new value), and the count: the answer when it is below the
   online cores (1 on a machine of 2 or more), the other count when the query fails, answers 0, answers more
   than the online cores or writes another size. */
#include <stddef.h>
#include <stdio.h>
#include <string.h>

static int mock_answer = -1;    /* -1: the query fails (an Intel Mac, macOS before 12) */
static size_t mock_len = sizeof(int);
static int mock_calls, mock_bad_args;
int sysctlbyname(const char *name, void *oldp, size_t *oldlenp, void *newp, size_t newlen);
int sysctlbyname(const char *name, void *oldp, size_t *oldlenp, void *newp, size_t newlen) {
    mock_calls++;
    if (strcmp(name, "hw.perflevel0.logicalcpu") || !oldp || !oldlenp || *oldlenp != sizeof(int) || newp || newlen) mock_bad_args++;
    if (mock_answer < 0) return -1;
    memcpy(oldp, &mock_answer, sizeof(int));
    *oldlenp = mock_len;
    return 0;
}

#define SUPERMAT__TEST_SYSCTL
#define SUPERMAT_IMPLEMENTATION
#include "supermat.h"

static int failures;
static void expect(const char *what, int got, int want) {
    if (got != want) { printf("FAIL %s: %d threads, expected %d\n", what, got, want); failures++; }
    else printf("ok   %s: %d\n", what, got);
}

int main(void) {
    int n0, calls;
    mock_answer = -1;
    n0 = supermat_default_threads();
    calls = mock_calls;
    if (calls < 1) { printf("FAIL: sysctlbyname was not asked\n"); failures++; }
    if (n0 < 1 || n0 > sysconf(_SC_NPROCESSORS_ONLN)) { printf("FAIL the query fails: %d threads, not 1 to the online cores\n", n0); failures++; }
    else printf("ok   the query fails: %d (the online cores, as the Linux checks leave them)\n", n0);
    mock_answer = 0;
    expect("it answers 0: ignored", supermat_default_threads(), n0);
    mock_answer = n0 + 5;
    expect("it answers more than the online cores: ignored", supermat_default_threads(), n0);
    mock_answer = 1; mock_len = 8;
    expect("it writes another size: ignored", supermat_default_threads(), n0);
    mock_len = sizeof(int);
    if (n0 >= 2) expect("it answers 1 performance core: 1", supermat_default_threads(), 1);
    else printf("skip the 1-core answer: this machine gives 1 thread already\n");
    if (mock_bad_args) { printf("FAIL: %d queries with another name or a new value\n", mock_bad_args); failures++; }
    printf("sysctlbyname asked %d times, as hw.perflevel0.logicalcpu, read only\n%s\n", mock_calls, failures ? "FAILED" : "ok");
    return failures ? 1 : 0;
}
