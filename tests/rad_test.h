/* rad_test.h - the few macros every test program uses.
 *
 *   RAD_CHECK(cond)                  fails the test (keeps going) if !cond
 *   RAD_CHECK_NEAR(a, b, tol)        |a - b| <= tol
 *   RAD_CHECK_REL(a, b, rel)         |a - b| <= rel * |b|
 *   rad_test_capture_log()           route the logger into a buffer
 *   rad_test_log_contains("text")    was "text" in a captured message?
 *   rad_test_read_file / rad_test_write_file   a file's bytes, whole
 *   return rad_test_finish();        exit code: 0 pass, 1 fail
 */
#ifndef RAD_TEST_H
#define RAD_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

static int rad_test_failures;
static char rad_test_log[1 << 16];

#define RAD_CHECK(cond)                                                            \
    do {                                                                           \
        if (!(cond)) {                                                             \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
            rad_test_failures++;                                                   \
        }                                                                          \
    } while (0)

#define RAD_CHECK_NEAR(a, b, tol)                                                      \
    do {                                                                               \
        double a_ = (a), b_ = (b), t_ = (tol);                                         \
        if (!(fabs(a_ - b_) <= t_)) {                                                  \
            fprintf(stderr, "%s:%d: %s = %.10g, expected %.10g +- %.3g\n", __FILE__,   \
                    __LINE__, #a, a_, b_, t_);                                         \
            rad_test_failures++;                                                       \
        }                                                                              \
    } while (0)

#define RAD_CHECK_REL(a, b, rel) RAD_CHECK_NEAR(a, b, (rel) * fabs((double)(b)))

static void rad_test_sink(rad_log_level level, const char *message, void *user)
{
    (void)user;
    size_t used = strlen(rad_test_log);
    snprintf(rad_test_log + used, sizeof rad_test_log - used, "%s\n", message);
    if (level <= RAD_LOG_WARN) fprintf(stderr, "  [log] %s\n", message);
}

static inline void rad_test_capture_log(void)
{
    rad_test_log[0] = 0;
    rad_log_set_sink(rad_test_sink, NULL);
}

static inline int rad_test_log_contains(const char *text)
{
    return strstr(rad_test_log, text) != NULL;
}

/* A whole file's bytes (freed by the caller), or NULL; *size gets its length. */
static inline unsigned char *rad_test_read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    *size = (size_t)ftell(f);
    rewind(f);
    unsigned char *data = malloc(*size ? *size : 1);
    if (data && fread(data, 1, *size, f) != *size) {
        free(data);
        data = NULL;
    }
    fclose(f);
    return data;
}

/* Writes `size` bytes as the whole of `path` (tests make damaged copies so). */
static inline void rad_test_write_file(const char *path, const unsigned char *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f) return;
    if (size) fwrite(data, 1, size, f);
    fclose(f);
}

static inline int rad_test_finish(void)
{
    if (rad_test_failures) fprintf(stderr, "%d check(s) failed\n", rad_test_failures);
    return rad_test_failures ? 1 : 0;
}

#endif
