/* rad_mem.h - large arrays on transparent huge pages.
 *
 * The matrix's arrays run to gigabytes (a sparse 188 416-patch matrix:
 * 13 GB of records, 26 GB as doubles) and are written once, page by page,
 * as they are filled: with 4 KiB pages that is millions of page faults,
 * which the kernel serialises per process. Where transparent huge pages
 * are on "madvise" (Debian's and most distributions' default), a region
 * advised with MADV_HUGEPAGE faults in 2 MiB at a time instead.
 *
 *     double *v = malloc(bytes);
 *     rad_mem_advise_huge(v, bytes);   // before the first touch
 *
 * Only whole 2 MiB pages inside [p, p + bytes) are advised; small arrays
 * and systems without madvise are left as they are (never an error). */
#ifndef RAD_MEM_H
#define RAD_MEM_H

#include <stddef.h>

/* Arrays smaller than this are not worth advising. */
#define RAD_MEM_HUGE_MIN ((size_t)16 << 20)

void rad_mem_advise_huge(void *p, size_t bytes);

/* malloc(bytes), advised as above before anything touches it: for large
 * arrays allocated once and then filled. Freed with free. */
void *rad_mem_alloc(size_t bytes);

/* An array that grows in place to at most `bytes` without ever moving:
 * address space reserved up front (an anonymous mapping that commits no
 * memory until its pages are touched: MAP_NORESERVE), advised as above.
 * Growing a multi-gigabyte buffer by realloc instead moves it (mremap),
 * and moving huge pages to an address they do not fit splits them: 23 s
 * to fill 13 GB that way on an H100 host, 2.5 s unadvised. NULL where
 * the reservation is refused (strict overcommit, no mmap): fall back to
 * malloc. Freed with rad_mem_release and the same `bytes`. */
void *rad_mem_reserve(size_t bytes);
void rad_mem_release(void *p, size_t bytes); /* NULL is fine */

/* An array that grows by appending (rad_mem_grow): its room in bytes,
 * and whether that is address space reserved (else malloc's). Zeroed at
 * first. */
typedef struct rad_mem_span {
    size_t bytes;
    int reserved;
} rad_mem_span;

/* Room for `need` bytes in the array p (NULL at first) of span: p itself
 * while it has the room, else a new array holding p's first `used` bytes
 * (p then released). The first reservation takes as much address space
 * as the machine has memory - which commits nothing - so the array never
 * moves again: realloc's moves of a growing multi-gigabyte array each
 * copy it into fresh pages and split its huge pages (above). Where
 * nothing can be reserved (not Linux, strict overcommit, or a limit on
 * the address space: RLIMIT_AS), malloc's arrays, doubled. NULL (p and
 * span untouched) for lack of memory. Freed with rad_mem_span_free. */
void *rad_mem_grow(void *p, size_t used, size_t need, rad_mem_span *span);
void rad_mem_span_free(void *p, rad_mem_span *span); /* NULL is fine; zeroes span */

/* Gives back the pages of a rad_mem_reserve array past its first `used`
 * bytes (whole 2 MiB pages, so that none is split): the array keeps its
 * address and reads as zeros there until written again. A buffer kept
 * from round to round, each round using a part of it, so stays resident
 * for what a round uses - without the first touch of fresh pages every
 * round (a fault and a page cleared for each) - and no more. */
void rad_mem_trim(void *p, size_t used, size_t bytes);

/* memcpy(dst, src, bytes) on up to `threads` OpenMP threads (0: up to
 * 8 of the team's), in slices of whole cache lines; one thread below a
 * few MiB. One thread copies at a fraction of what the memory moves: a
 * page-locked staging buffer emptied into pageable memory ran at 30 GB/s
 * on 8 threads of an H200 host against 13 GB/s for the driver's own
 * copy. Callable from any thread, OpenMP's or not. */
void rad_mem_copy(void *dst, const void *src, size_t bytes, int threads);

/* The process's resident high-water mark so far, in bytes (getrusage's
 * ru_maxrss); 0 where the system does not say. Taken after each phase,
 * it shows which phase set the peak (--stats' "peak_bytes"). */
double rad_mem_peak_bytes(void);

#endif
