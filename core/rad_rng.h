/* rad_rng.h - counter-based random numbers (Philox-4x32-10), host and device.
 *
 * A counter-based generator has no state to carry: the four numbers for
 * (counter, key) are a pure function of them. The form-factor estimators key
 * every sample by (patch a, patch b, sample index) and the user's seed, so
 * the matrix does not depend on how rows are split across ranks, threads or
 * GPUs, nor on the order in which pairs are visited.
 *
 * Reference: Salmon et al., "Parallel random numbers: as easy as 1, 2, 3",
 * SC 2011 (the round constants below are theirs).
 */
#ifndef RAD_RNG_H
#define RAD_RNG_H

#include <stdint.h>

#include "rad_math.h"

typedef struct rad_u32x4 {
    uint32_t v[4];
} rad_u32x4;

static inline RAD_HD uint32_t rad_mulhilo32(uint32_t a, uint32_t b, uint32_t *hi)
{
    uint64_t p = (uint64_t)a * (uint64_t)b;
    *hi = (uint32_t)(p >> 32);
    return (uint32_t)p;
}

/* Philox-4x32 with 10 rounds. */
static inline RAD_HD rad_u32x4 rad_philox4x32(rad_u32x4 ctr, uint32_t key0, uint32_t key1)
{
    /* Fully unrolled so that CPU compilers can vectorize loops over samples. */
#if defined(__CUDACC__)
#pragma unroll
#elif defined(__GNUC__)
#pragma GCC unroll 10
#endif
    for (int round = 0; round < 10; round++) {
        uint32_t hi0, hi1;
        uint32_t lo0 = rad_mulhilo32(0xD2511F53u, ctr.v[0], &hi0);
        uint32_t lo1 = rad_mulhilo32(0xCD9E8D57u, ctr.v[2], &hi1);
        rad_u32x4 next;
        next.v[0] = hi1 ^ ctr.v[1] ^ key0;
        next.v[1] = lo1;
        next.v[2] = hi0 ^ ctr.v[3] ^ key1;
        next.v[3] = lo0;
        ctr = next;
        key0 += 0x9E3779B9u;
        key1 += 0xBB67AE85u;
    }
    return ctr;
}

/* A uint32 mapped to the open interval (0, 1): never exactly 0 or 1. */
static inline RAD_HD double rad_u01(uint32_t x)
{
    /* Exactly ((double)x + 0.5) / 2^32, through a signed conversion, which
     * vector units (AVX2) have and the unsigned one lacks. */
    return ((double)(int32_t)(x ^ 0x80000000u) + 2147483648.5) * (1.0 / 4294967296.0);
}

#endif
