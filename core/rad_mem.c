/* rad_mem.c - huge pages for large arrays (rad_mem.h). */
#define _GNU_SOURCE /* MADV_HUGEPAGE */
#include "rad_mem.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#if defined(__unix__)
#include <sys/mman.h>
#include <unistd.h>
#endif
#if defined(__unix__) || defined(__APPLE__)
#include <sys/resource.h>
#endif

#define HUGE_PAGE ((uintptr_t)2 << 20) /* a transparent huge page on x86-64 and most arm64 kernels */

void rad_mem_advise_huge(void *p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    const uintptr_t huge = HUGE_PAGE;
    if (!p || bytes < RAD_MEM_HUGE_MIN) return;
    uintptr_t begin = ((uintptr_t)p + huge - 1) & ~(huge - 1), end = ((uintptr_t)p + bytes) & ~(huge - 1);
    if (end > begin) (void)madvise((void *)begin, (size_t)(end - begin), MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

void *rad_mem_alloc(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    rad_mem_advise_huge(p, bytes);
    return p;
}

void *rad_mem_reserve(size_t bytes)
{
#if defined(__unix__) && defined(MAP_ANONYMOUS) && defined(MAP_NORESERVE)
    if (bytes == 0) bytes = 1;
    void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (p == MAP_FAILED) return NULL;
    rad_mem_advise_huge(p, bytes);
    return p;
#else
    (void)bytes;
    return NULL;
#endif
}

void rad_mem_release(void *p, size_t bytes)
{
#if defined(__unix__) && defined(MAP_ANONYMOUS) && defined(MAP_NORESERVE)
    if (p) munmap(p, bytes ? bytes : 1);
#else
    (void)p;
    (void)bytes;
#endif
}

/* The address space a growing array reserves at first: the machine's
 * memory; 0 where a limit on the address space (RLIMIT_AS) would count
 * it, or the system does not say. */
static size_t reservation_bytes(void)
{
#if defined(__linux__) && defined(_SC_PHYS_PAGES)
    struct rlimit as;
    if (getrlimit(RLIMIT_AS, &as) != 0 || as.rlim_cur != RLIM_INFINITY) return 0;
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? (size_t)pages * (size_t)page : 0;
#else
    return 0;
#endif
}

void *rad_mem_grow(void *p, size_t used, size_t need, rad_mem_span *span)
{
    if (p && need <= span->bytes) return p;
    size_t room = need > SIZE_MAX / 2 ? need : 2 * need;
    const size_t machine = reservation_bytes();
    void *q = machine ? rad_mem_reserve(room > machine ? room : machine) : NULL;
    const int reserved = q != NULL;
    if (reserved) {
        room = room > machine ? room : machine;
    } else {
        if (p && !span->reserved) {
            q = realloc(p, room);
            if (!q) return NULL;
            span->bytes = room;
            return q;
        }
        if (!(q = malloc(room))) return NULL;
    }
    if (p) {
        memcpy(q, p, used);
        rad_mem_span_free(p, span);
    }
    span->bytes = room;
    span->reserved = reserved;
    return q;
}

void rad_mem_span_free(void *p, rad_mem_span *span)
{
    if (span->reserved)
        rad_mem_release(p, span->bytes);
    else
        free(p);
    span->bytes = 0;
    span->reserved = 0;
}

void rad_mem_trim(void *p, size_t used, size_t bytes)
{
#if defined(__linux__) && defined(MADV_DONTNEED)
    const uintptr_t huge = HUGE_PAGE;
    if (!p) return;
    uintptr_t begin = ((uintptr_t)p + used + huge - 1) & ~(huge - 1), end = ((uintptr_t)p + bytes) & ~(uintptr_t)4095;
    if (end > begin) (void)madvise((void *)begin, (size_t)(end - begin), MADV_DONTNEED);
#else
    (void)p;
    (void)used;
    (void)bytes;
#endif
}

#define COPY_SLICE_MIN ((size_t)1 << 20) /* bytes a thread: below it, fewer threads */
#define COPY_THREADS_MAX 8               /* the memory's bandwidth is reached by about as many */

void rad_mem_copy(void *dst, const void *src, size_t bytes, int threads)
{
    size_t slices = bytes / COPY_SLICE_MIN;
#ifdef _OPENMP
    if (threads <= 0) threads = omp_get_max_threads() < COPY_THREADS_MAX ? omp_get_max_threads() : COPY_THREADS_MAX;
#else
    threads = 1;
#endif
    if (slices > (size_t)threads) slices = (size_t)threads;
    if (slices <= 1) {
        memcpy(dst, src, bytes);
        return;
    }
    const size_t line = 64, share = (bytes / slices + line - 1) / line * line;
#pragma omp parallel for num_threads((int)slices) schedule(static, 1)
    for (size_t k = 0; k < slices; k++) {
        const size_t at = k * share < bytes ? k * share : bytes;
        const size_t n = bytes - at < share ? bytes - at : share;
        memcpy((char *)dst + at, (const char *)src + at, n);
    }
}

double rad_mem_peak_bytes(void)
{
#if defined(__unix__) || defined(__APPLE__) /* macOS defines only the second */
    struct rusage u;
    if (getrusage(RUSAGE_SELF, &u) != 0) return 0;
#if defined(__APPLE__)
    return (double)u.ru_maxrss; /* bytes there */
#else
    return 1024.0 * (double)u.ru_maxrss; /* kilobytes on Linux and the BSDs */
#endif
#else
    return 0;
#endif
}
