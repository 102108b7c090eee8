/* test_pair_fuzz.c - the checks of the fuzz target fuzz_pair on 20 000
 * pairs from a fixed seed (tests/fuzz/pair_cases.h: hard configurations of
 * two patches; rad_ff_quad_unoccluded and rad_ff_point_polygon must give
 * finite, bounded, reciprocal results with honest errors and bounded
 * work), so CI checks them without libFuzzer; under AddressSanitizer (the
 * sanitized pass) an out-of-bounds write fails it too.
 *
 *     test_pair_fuzz [CASES [QUAD_STRIDE [SEED]]]
 *
 * Every case checks the point factors; every QUAD_STRIDE-th (default 16:
 * 1250 of 20 000) also the quadrature both ways, which costs up to
 * 2 x 4096 cells (about 13 ms a case on average), to stay within ~20 s.
 *
 * Prints each failing case's pair (corners to 17 digits: a reproducer),
 * at most 3 per configuration, and per configuration the cases run and
 * failed, then "N passed, N failed".
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "fuzz/pair_cases.h"

static uint64_t splitmix64(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

int main(int argc, char **argv)
{
    long cases = argc > 1 ? strtol(argv[1], NULL, 10) : 20000;
    long stride = argc > 2 ? strtol(argv[2], NULL, 10) : 16;
    uint64_t seed = argc > 3 ? strtoull(argv[3], NULL, 10) : 20240611u;
    if (stride < 1) stride = 1;
    long run[PAIR_KINDS] = {0}, bad[PAIR_KINDS] = {0};
    long passed = 0, failed = 0;
    clock_t t0 = clock();
    for (long n = 0; n < cases; n++) {
        uint8_t bytes[64];
        for (int k = 0; k < 64; k += 8) {
            uint64_t v = splitmix64(&seed);
            for (int b = 0; b < 8; b++) bytes[k + b] = (uint8_t)(v >> (8 * b));
        }
        pair_case c;
        char why[512];
        pair_case_decode(bytes, sizeof bytes, &c);
        const char *failure = pair_case_check(&c, n % stride == 0, why, sizeof why);
        run[c.kind]++;
        if (!failure) {
            passed++;
            continue;
        }
        failed++;
        if (bad[c.kind]++ < 3) {
            printf("FAIL: case %ld: %s\n", n, failure);
            pair_case_print(stdout, &c);
        }
    }
    for (int k = 0; k < PAIR_KINDS; k++)
        printf("%-14s %6ld cases, %5ld failed\n", pair_kind_names[k], run[k], bad[k]);
    printf("%.1f s\n", (double)(clock() - t0) / CLOCKS_PER_SEC);
    printf("%ld passed, %ld failed\n", passed, failed);
    return failed ? 1 : 0;
}
