/* rad_parse.h - numbers from the command line, strictly.
 *
 * One parser for every program's numeric options: the whole text must be
 * the number (no spaces, no trailing characters, no sign on a count), it
 * must not overflow (2^64 is not read as 2^64 - 1), and it must lie in the
 * stated range, whose bounds the message names:
 *     "--seed: '18446744073709551616' is not an integer in [0, 18446744073709551615]"
 * Ranges start at 1 where 0 means nothing (--threads, --max-samples): the
 * default is had by leaving the option out.
 */
#ifndef RAD_PARSE_H
#define RAD_PARSE_H

#include <stdint.h>

#include "rad_status.h"

/* A decimal integer in [min, max]. RAD_ERR_USAGE (logged) otherwise. */
rad_status rad_parse_uint(const char *option, const char *text, uint64_t min, uint64_t max, uint64_t *out);

/* A finite number in (lo, hi) - or [lo, hi] where the flags say inclusive.
 * RAD_ERR_USAGE (logged) otherwise. */
rad_status rad_parse_real(const char *option, const char *text, double lo, int lo_inclusive, double hi,
                          int hi_inclusive, double *out);

/* A size in bytes: a positive number with an optional unit, k M G T P
 * (powers of 1000) or Ki Mi Gi Ti Pi (powers of 1024), a trailing B
 * allowed ("53.7G", "2GiB", "500MB", "1e9"). At least 1 byte, at most
 * 2^63. RAD_ERR_USAGE (logged) otherwise. */
rad_status rad_parse_bytes(const char *option, const char *text, double *out);

#endif
