/* rad_hash.h - 64-bit checksums and fingerprints.
 *
 * rad_hash64 is FNV-1a over 8-byte little-endian words (with a byte-wise
 * tail), fast enough to checksum every row of a form-factor matrix as it is
 * written. It detects corruption; it is not cryptographic.
 */
#ifndef RAD_HASH_H
#define RAD_HASH_H

#include <stddef.h>
#include <stdint.h>

#define RAD_HASH_SEED UINT64_C(0xcbf29ce484222325)

/* Continue a hash `h` (start with RAD_HASH_SEED) over `size` bytes. */
uint64_t rad_hash64(uint64_t h, const void *data, size_t size);

#endif
