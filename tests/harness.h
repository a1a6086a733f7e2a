/*
 * tests/harness.h: the in-house test harness. A test program defines test functions with TEST,
 * runs them with RUN from main and returns spc_test_finish(), which prints "N passed, N failed"
 * (tests, not assertions) and returns nonzero if any test failed. SPC_TEST_ONLY=a,b runs only the
 * tests named.
 */
#ifndef SPC_TESTS_HARNESS_H
#define SPC_TESTS_HARNESS_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int spc_t_passed = 0, spc_t_failed = 0, spc_t_cur_failed = 0;
static const char *spc_t_cur = "";

#define TEST(name) static void name(void)

/* SPC_TEST_ONLY=name (comma-separated names) runs only those tests of a program (debugging). */
static inline int spc_t_selected(const char *name)
{
    const char *only = getenv("SPC_TEST_ONLY");
    if (!only || !*only)
        return 1;
    size_t n = strlen(name);
    for (const char *p = only; (p = strstr(p, name)) != NULL; p += n)
        if ((p == only || p[-1] == ',') && (p[n] == '\0' || p[n] == ','))
            return 1;
    return 0;
}

/* SPC_TEST_QUICK=1 is set by the sanitizer pass of .ci/run, where the code runs several times
 * slower. Tests that loop over many independent cases (BSDF configurations, scenes, solver
 * settings) then step through them by spc_test_stride(n): about three cases spread over the list,
 * each at its full size, so every assertion that runs keeps its significance; the full run covers
 * the rest. */
static inline int spc_test_quick(void)
{
    const char *q = getenv("SPC_TEST_QUICK");
    return q && *q && strcmp(q, "0") != 0;
}
static inline int spc_test_stride(int ncases) { return spc_test_quick() && ncases > 2 ? (ncases + 2) / 3 : 1; }

#define RUN(name)                                                                                                     \
    if (spc_t_selected(#name))                                                                                        \
    do {                                                                                                              \
        spc_t_cur = #name;                                                                                            \
        spc_t_cur_failed = 0;                                                                                         \
        name();                                                                                                       \
        if (spc_t_cur_failed) {                                                                                       \
            ++spc_t_failed;                                                                                           \
            printf("FAIL %s\n", #name);                                                                               \
        } else {                                                                                                      \
            ++spc_t_passed;                                                                                           \
            printf("ok   %s\n", #name);                                                                               \
        }                                                                                                             \
        fflush(stdout);                                                                                               \
    } while (0)

#define CHECK(cond)                                                                                                   \
    do {                                                                                                              \
        if (!(cond)) {                                                                                                \
            printf("  %s:%d: %s: check failed: %s\n", __FILE__, __LINE__, spc_t_cur, #cond);                          \
            spc_t_cur_failed = 1;                                                                                     \
        }                                                                                                             \
    } while (0)

#define CHECK_MSG(cond, ...)                                                                                          \
    do {                                                                                                              \
        if (!(cond)) {                                                                                                \
            printf("  %s:%d: %s: check failed: %s: ", __FILE__, __LINE__, spc_t_cur, #cond);                          \
            printf(__VA_ARGS__);                                                                                      \
            printf("\n");                                                                                             \
            spc_t_cur_failed = 1;                                                                                     \
        }                                                                                                             \
    } while (0)

/* This program's path in exe (n bytes); false, after a failed check, if it cannot be read. */
static inline int spc_t_self_exe(char *exe, size_t n)
{
    ssize_t len = readlink("/proc/self/exe", exe, n - 1);
    CHECK(len > 0);
    if (len <= 0)
        return 0;
    exe[len] = '\0';
    return 1;
}

/* Runs the tests named in `only` (comma-separated) again in a child process of this program under
 * each instruction set of isas (SPECULA_VECTOR_ISA caps the one a process picks), with their output
 * discarded; the calling test fails for each child that exits nonzero. */
static inline void spc_t_under_isas(const char *only, const char *const *isas, int n)
{
    char exe[4096];
    if (!spc_t_self_exe(exe, sizeof exe))
        return;
    for (int i = 0; i < n; ++i) {
        char cmd[8192];
        snprintf(cmd, sizeof cmd, "SPECULA_VECTOR_ISA=%s SPC_TEST_ONLY=%s '%s' >/dev/null", isas[i], only, exe);
        int rc = system(cmd);
        CHECK_MSG(rc == 0, "%s: exit status %d", isas[i], rc);
    }
}

#define CHECK_NEAR(a, b, tol)                                                                                         \
    do {                                                                                                              \
        double spc_t_a = (a), spc_t_b = (b), spc_t_tol = (tol);                                                       \
        if (!(fabs(spc_t_a - spc_t_b) <= spc_t_tol)) {                                                                \
            printf("  %s:%d: %s: %s = %.12g, %s = %.12g, |diff| %.3g > %.3g\n", __FILE__, __LINE__, spc_t_cur, #a,    \
                   spc_t_a, #b, spc_t_b, fabs(spc_t_a - spc_t_b), spc_t_tol);                                          \
            spc_t_cur_failed = 1;                                                                                     \
        }                                                                                                             \
    } while (0)

/* Relative closeness: |a-b| <= rel * max(|a|,|b|) + abs_tol. */
#define CHECK_REL(a, b, rel, abs_tol) CHECK_NEAR(a, b, (rel) * fmax(fabs(a), fabs(b)) + (abs_tol))

static inline int spc_test_finish(void)
{
    printf("%d passed, %d failed\n", spc_t_passed, spc_t_failed);
    return spc_t_failed ? 1 : 0;
}

/* Source tree root (set by ctest), so tests find scenes/ and ../shared. */
static inline const char *spc_test_source_dir(void)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    return d ? d : ".";
}

#endif
