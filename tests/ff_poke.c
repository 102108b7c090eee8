/* ff_poke.c - a form-factor file with one entry changed and every
 * checksum right, for the checks that follow the checksums (formfactor
 * --reuse: formfactor_io.sh).
 *
 *   ff_poke IN OUT ROW COLUMN VALUE
 *
 * Writes IN's matrix with F[ROW][COLUMN] = VALUE (strtod: "nan", "inf",
 * "-0.25", "1e300"), in IN's layout, element type and flags. */
#include <stdio.h>
#include <stdlib.h>

#include "rad_ffile.h"

int main(int argc, char **argv)
{
    if (argc != 6) {
        fprintf(stderr, "usage: ff_poke IN OUT ROW COLUMN VALUE\n");
        return 2;
    }
    rad_ff_file *in = NULL;
    double *F = NULL;
    int ok = 0;
    if (rad_ff_open(argv[1], &in) != RAD_OK) goto done;
    const size_t n = rad_ff_file_mesh(in)->patch_count;
    const size_t row = strtoul(argv[3], NULL, 10), column = strtoul(argv[4], NULL, 10);
    if (row >= n || column >= n) {
        fprintf(stderr, "ff_poke: entry (%zu, %zu) outside a %zu x %zu matrix\n", row, column, n, n);
        goto done;
    }
    F = malloc(n * n * sizeof *F);
    if (!F || rad_ff_read_rows(in, 0, n, F) != RAD_OK) goto done;
    F[row * n + column] = strtod(argv[5], NULL);
    ok = rad_ff_write_serial(argv[2], rad_ff_file_info(in), rad_ff_file_mesh(in), F) == RAD_OK;
done:
    free(F);
    rad_ff_close(in);
    return ok ? 0 : 1;
}
