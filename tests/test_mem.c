/* test_mem.c - rad_mem_trim: a reserved array's pages past what a round
 * uses given back, the rest kept; rad_mem_grow: an array grown in place.
 *
 *  - After a trim to `used` bytes, the bytes before `used` and before the
 *    next 2 MiB boundary keep what was written; past that boundary the
 *    pages are no longer resident (mincore) and read zeros.
 *  - The array stays usable: written again past the trim, it holds what
 *    was written.
 *  - A trim to the whole size, or of NULL, changes nothing.
 * rad_mem_copy: every byte copied and none past the end, for sizes that
 * do not divide by the threads or by a cache line, on 0 (the default) to
 * 16 threads, from unaligned addresses. */
#define _DEFAULT_SOURCE /* mincore */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>
#endif

#include "rad_mem.h"
#include "rad_test.h"

#define MIB ((size_t)1 << 20)

static int all_bytes(const unsigned char *p, size_t n, unsigned char v)
{
    for (size_t k = 0; k < n; k++)
        if (p[k] != v) return 0;
    return 1;
}

#if defined(__linux__)
/* The share of the pages of [p, p + n) resident now. */
static double resident_share(const unsigned char *p, size_t n)
{
    const size_t page = (size_t)sysconf(_SC_PAGESIZE);
    uintptr_t begin = (uintptr_t)p & ~(uintptr_t)(page - 1);
    size_t pages = ((uintptr_t)p + n - begin + page - 1) / page;
    unsigned char *v = malloc(pages);
    if (!v || mincore((void *)begin, pages * page, v) != 0) {
        free(v);
        return -1;
    }
    size_t in = 0;
    for (size_t k = 0; k < pages; k++) in += v[k] & 1;
    free(v);
    return (double)in / (double)pages;
}
#endif

static void test_trim(void)
{
    const size_t bytes = 40 * MIB, used = 5 * MIB + 123;
    unsigned char *p = rad_mem_reserve(bytes);
#if defined(__linux__)
    RAD_CHECK(p != NULL);
#endif
    if (!p) return; /* no reservations here (rad_mem.h): callers fall back to malloc */
    memset(p, 0xab, bytes);
    rad_mem_trim(p, bytes, bytes); /* the whole: nothing given back */
    RAD_CHECK(all_bytes(p, bytes, 0xab));
    rad_mem_trim(NULL, used, bytes);
    rad_mem_trim(p, used, bytes);
    const uintptr_t huge = 2 * MIB;
    const size_t kept = (size_t)((((uintptr_t)p + used + huge - 1) & ~(huge - 1)) - (uintptr_t)p);
    RAD_CHECK(kept >= used && kept < used + huge);
    RAD_CHECK(all_bytes(p, kept, 0xab));
#if defined(__linux__)
    /* resident before reading: a read maps the zero page back in */
    const double gone = resident_share(p + kept, bytes - kept), here = resident_share(p, used);
    RAD_CHECK(gone >= 0 && gone < 0.01);
    RAD_CHECK(here > 0.99);
    RAD_CHECK(all_bytes(p + kept, bytes - kept, 0));
#endif
    memset(p + kept, 0x5c, bytes - kept); /* used again past the trim */
    RAD_CHECK(all_bytes(p + kept, bytes - kept, 0x5c));
    RAD_CHECK(all_bytes(p, kept, 0xab));
    rad_mem_release(p, bytes);
}

/* rad_mem_grow: from nothing, then larger and larger, what was written
 * kept; in place once reserved (Linux without an address-space limit). */
static void test_grow(void)
{
    rad_mem_span span = {0};
    unsigned char *p = rad_mem_grow(NULL, 0, 1000, &span);
    RAD_CHECK(p != NULL && span.bytes >= 1000);
    if (!p) return;
    memset(p, 0x11, 1000);
    size_t used = 1000;
    unsigned char *first = p;
    for (size_t need = 3000; need <= 64 * MIB; need *= 4) {
        unsigned char *q = rad_mem_grow(p, used, need, &span);
        RAD_CHECK(q != NULL && span.bytes >= need);
        if (!q) break;
        RAD_CHECK(all_bytes(q, 1000, 0x11));
        if (span.reserved) RAD_CHECK(q == first); /* never moved */
        memset(q + used, 0x22, need - used);
        RAD_CHECK(all_bytes(q + 1000, need - 1000, 0x22));
        p = q, used = need;
    }
#if defined(__linux__)
    struct rlimit as;
    if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur == RLIM_INFINITY) RAD_CHECK(span.reserved);
#endif
    unsigned char *same = rad_mem_grow(p, used, used / 2, &span); /* room enough: p itself */
    RAD_CHECK(same == p);
    rad_mem_span_free(p, &span);
    RAD_CHECK(span.bytes == 0 && span.reserved == 0);
    rad_mem_span_free(NULL, &span);
}

static void test_copy(void)
{
    const size_t most = 9 * MIB + 77;
    unsigned char *src = malloc(most + 3), *dst = malloc(most + 3);
    RAD_CHECK(src && dst);
    if (!src || !dst) {
        free(src), free(dst);
        return;
    }
    for (size_t k = 0; k < most + 3; k++) src[k] = (unsigned char)(k * 131 + (k >> 11));
    const size_t sizes[] = {0, 1, 63, 65, MIB - 1, 2 * MIB + 5, 8 * MIB, most};
    const int threads[] = {0, 1, 2, 3, 7, 16};
    for (size_t i = 0; i < sizeof sizes / sizeof *sizes; i++)
        for (size_t t = 0; t < sizeof threads / sizeof *threads; t++) {
            const size_t n = sizes[i];
            memset(dst, 0xEE, most + 3);
            rad_mem_copy(dst + 1, src + 2, n, threads[t]);
            RAD_CHECK(dst[0] == 0xEE && memcmp(dst + 1, src + 2, n) == 0 && dst[n + 1] == 0xEE);
        }
    free(src);
    free(dst);
}

int main(void)
{
    test_trim();
    test_grow();
    test_copy();
    return rad_test_finish();
}
