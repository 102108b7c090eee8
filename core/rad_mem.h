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

#endif
