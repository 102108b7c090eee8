/* groups.h - results by surface (solve --by-group): for every OBJ group of
 * the form-factor file's group table (docs/formats.md), one row:
 *
 *   group      the name (last `g` or `o` before the faces)
 *   patches    how many patches it has
 *   area       A_G = sum_{i in G} A_i                     (scene units^2)
 *   radiosity  sum_{i in G} A_i B_i / A_G, per channel    (units of E)
 *   emitted    sum_{i in G} A_i E_i, per channel          (area x radiosity)
 *   absorbed   sum_{i in G} A_i (1 - rho_i) H_i, per channel,
 *              H_i = sum_j F_ij B_j (what patch i receives per unit area)
 *
 * Summed over the groups, emitted and absorbed are the stage's energy
 * balance (solver.h, solve_balance). Grey scenes give the one solved
 * channel three times, as the radiosity file does. docs/solve.md,
 * "Results by surface".
 *
 * Formats, by the file name's extension:
 *   .csv  a header row, then one row per group in the table's order;
 *         numbers with 17 significant digits (they read back to the bit);
 *         a name with a comma, quote or line break is quoted (RFC 4180);
 *   .npy  a NumPy array of G records, dtype
 *         [('group', 'S64'), ('patches', '<u8'), ('area', '<f8'),
 *          ('radiosity', '<f8', (3,)), ('emitted', '<f8', (3,)),
 *          ('absorbed', '<f8', (3,))]   (np.load, no pickle).
 */
#ifndef SOLVE_GROUPS_H
#define SOLVE_GROUPS_H

#include "rad_mesh.h"
#include "rad_status.h"
#include "solver.h"

typedef enum solve_groups_format {
    SOLVE_GROUPS_CSV = 1,
    SOLVE_GROUPS_NPY = 2
} solve_groups_format;

/* The format named by the extension of `path` (.csv or .npy, any case);
 * RAD_ERR_USAGE, logged naming `option`, for anything else. */
rad_status solve_groups_format_of(const char *option, const char *path, solve_groups_format *out_format);

/* Computes the rows for `mesh` (group_count > 0) from the matrix of
 * `system`, rho and E from the patch table and `radiosity` (N * 3, as in
 * the radiosity file), and writes them to `path` (temporary name +
 * rename). One pass over F per channel, rows summed in a fixed order.
 * Collective across the ranks of system->comm (each its rows); rank 0
 * writes, and every rank returns the same status. */
rad_status solve_groups_write(const char *path, const solve_system *system, const rad_mesh *mesh,
                              const double *radiosity);

#endif
