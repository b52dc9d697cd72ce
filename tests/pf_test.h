/*
 * Minimal test harness: each test file is one executable with one or more
 * PF_TEST functions run from main via PF_RUN. A failed check prints file:line
 * and the values, and marks the executable failed (exit 1) without stopping
 * the remaining checks of that test.
 */
#ifndef PF_TEST_H
#define PF_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern int pf_test_failures;
extern const char *pf_test_current;

#define PF_CHECK(cond)                                                                    \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: [%s] check failed: %s\n", __FILE__, __LINE__,        \
                    pf_test_current, #cond);                                              \
            pf_test_failures++;                                                           \
        }                                                                                 \
    } while (0)

#define PF_CHECK_MSG(cond, ...)                                                           \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: [%s] check failed: %s: ", __FILE__, __LINE__,        \
                    pf_test_current, #cond);                                              \
            fprintf(stderr, __VA_ARGS__);                                                 \
            fputc('\n', stderr);                                                          \
            pf_test_failures++;                                                           \
        }                                                                                 \
    } while (0)

/* |actual - expected| <= tolerance; NaN always fails. */
#define PF_CHECK_NEAR(actual, expected, tolerance)                                        \
    do {                                                                                  \
        double pf_a_ = (double)(actual), pf_e_ = (double)(expected);                      \
        if (!(fabs(pf_a_ - pf_e_) <= (double)(tolerance))) {                              \
            fprintf(stderr, "%s:%d: [%s] %s = %.9g, expected %.9g (tolerance %g)\n",      \
                    __FILE__, __LINE__, pf_test_current, #actual, pf_a_, pf_e_,           \
                    (double)(tolerance));                                                 \
            pf_test_failures++;                                                           \
        }                                                                                 \
    } while (0)

/* A pf_status call that must succeed; prints the error message otherwise. */
#define PF_CHECK_OK(call, errp)                                                           \
    do {                                                                                  \
        int pf_s_ = (int)(call);                                                          \
        if (pf_s_ != 0) {                                                                 \
            fprintf(stderr, "%s:%d: [%s] %s failed (%d): %s\n", __FILE__, __LINE__,       \
                    pf_test_current, #call, pf_s_, (errp)->message);                      \
            pf_test_failures++;                                                           \
        }                                                                                 \
    } while (0)

/* Same, but stops the current test function (later checks would only cascade). */
#define PF_REQUIRE_OK(call, errp)                                                         \
    do {                                                                                  \
        int pf_s_ = (int)(call);                                                          \
        if (pf_s_ != 0) {                                                                 \
            fprintf(stderr, "%s:%d: [%s] %s failed (%d): %s\n", __FILE__, __LINE__,       \
                    pf_test_current, #call, pf_s_, (errp)->message);                      \
            pf_test_failures++;                                                           \
            return;                                                                       \
        }                                                                                 \
    } while (0)

#define PF_REQUIRE(cond)                                                                  \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: [%s] requirement failed: %s\n", __FILE__, __LINE__,   \
                    pf_test_current, #cond);                                              \
            pf_test_failures++;                                                           \
            return;                                                                       \
        }                                                                                 \
    } while (0)

#define PF_REQUIRE_MSG(cond, ...)                                                         \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: [%s] requirement failed: %s: ", __FILE__, __LINE__,   \
                    pf_test_current, #cond);                                              \
            fprintf(stderr, __VA_ARGS__);                                                 \
            fputc('\n', stderr);                                                          \
            pf_test_failures++;                                                           \
            return;                                                                       \
        }                                                                                 \
    } while (0)

#define PF_TEST(name) static void name(void)

#define PF_RUN(name)                                                                      \
    do {                                                                                  \
        int pf_before_ = pf_test_failures;                                                \
        pf_test_current = #name;                                                          \
        name();                                                                           \
        printf("%s %s\n", pf_test_failures == pf_before_ ? "ok  " : "FAIL", #name);       \
        fflush(stdout);                                                                   \
    } while (0)

/* Return this from main. (Counters live in pf_test_main.c, linked into every test.) */

static inline int pf_test_finish(void) { return pf_test_failures ? 1 : 0; }

/* Path of a shared scene: $PF_SHARED_SCENES/<name>/<name>.gltf (set by ctest). */
static inline const char *pf_test_shared_scene(const char *name, char *buffer, size_t size)
{
    const char *root = getenv("PF_SHARED_SCENES");
    snprintf(buffer, size, "%s/%s/%s.gltf", root ? root : "../shared/scenes", name, name);
    return buffer;
}

/* A fresh scratch directory for this test ($PF_TEST_TMP/<test>), created if missing. */
static inline const char *pf_test_tmpdir(char *buffer, size_t size)
{
    const char *root = getenv("PF_TEST_TMP");
    snprintf(buffer, size, "%s", root ? root : "/tmp");
    return buffer;
}

#endif
