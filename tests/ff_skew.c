/* ff_skew.c - a form-factor file made non-reciprocal on purpose, for the
 * CG check's skew term (solve_mpi.sh: its value must not depend on the
 * rank count).
 *
 *   ff_skew IN OUT S
 *
 * Writes IN's matrix with every entry above the diagonal scaled by 1 + S,
 * in IN's layout and element type, so A_i F_ij - A_j F_ji ~ S A_i F_ij. */
#include <stdio.h>
#include <stdlib.h>

#include "rad_ffile.h"

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: ff_skew IN OUT S\n");
        return 2;
    }
    const double s = atof(argv[3]);
    rad_ff_file *in = NULL;
    double *F = NULL;
    int ok = 0;
    if (rad_ff_open(argv[1], &in) != RAD_OK) goto done;
    const size_t n = rad_ff_file_mesh(in)->patch_count;
    F = malloc(n * n * sizeof *F);
    if (!F || rad_ff_read_rows(in, 0, n, F) != RAD_OK) goto done;
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++) F[i * n + j] *= 1 + s;
    rad_ff_info info = *rad_ff_file_info(in);
    info.flags &= ~RAD_FF_FLAG_RECIPROCAL; /* no longer reciprocal by construction */
    ok = rad_ff_write_serial(argv[2], &info, rad_ff_file_mesh(in), F) == RAD_OK;
done:
    free(F);
    rad_ff_close(in);
    return ok ? 0 : 1;
}
