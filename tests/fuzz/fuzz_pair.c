/* fuzz_pair.c - the per-pair numerics: rad_ff_quad_unoccluded and
 * rad_ff_point_polygon on two patches decoded from the input in hard
 * configurations (shared edges and vertices, slivers, near-coplanar,
 * coplanar, tiny against huge, nearly touching; tests/fuzz/pair_cases.h
 * says how and what is checked). A violated invariant prints the pair and
 * aborts, as a sanitizer report would. tests/test_pair_fuzz.c runs the
 * same checks on 20 000 pairs from a fixed seed without libFuzzer.
 */
#include "fuzz_common.h" /* first: it defines _GNU_SOURCE */

#include "pair_cases.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pair_case c;
    char why[512];
    pair_case_decode(data, size, &c);
    const char *failed = pair_case_check(&c, 1, why, sizeof why);
    if (failed) {
        fprintf(stderr, "fuzz_pair: %s\n", failed);
        pair_case_print(stderr, &c);
        abort();
    }
    return 0;
}
