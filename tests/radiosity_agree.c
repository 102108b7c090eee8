/* radiosity_agree.c - do two radiosity files solve the same form factors
 * to within what their residuals allow? (solve_mpi.sh: rank counts)
 *
 *   radiosity_agree FORMFACTORS A.rad B.rad
 *
 * Each file's B is within ||B - B*||_inf <= omega ||E||_inf / (1 - c) of
 * the exact solution B* (solver.h, error_bound: omega >= ||r||/||E|| is
 * the file's verified residual, c = max_i rho_i sum_j F_ij), so two
 * solutions differ by at most
 *     allowed = (omega_A + omega_B) ||E||_inf / (1 - c)
 * per channel, c and ||E|| computed here from the form-factor file. Exit
 * 0 when every channel's max_i |B_A - B_B| <= allowed (and both files are
 * converged solutions of that file's scene), 1 otherwise; prints both
 * numbers per channel. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "rad_ffile.h"
#include "rad_rfile.h"

/* Rounding in the verification pass itself: a relative slack far below
 * any tolerance solve accepts (>= 1e-15 would be absurd). */
#define AGREE_ROUNDING_SLACK 1e-12

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: radiosity_agree FORMFACTORS A.rad B.rad\n");
        return 2;
    }
    rad_ff_file *ff = NULL;
    rad_radiosity a = {0}, b = {0};
    double *row = NULL, *row_sum = NULL;
    int ok = 0;
    if (rad_ff_open(argv[1], &ff) != RAD_OK || rad_rf_read(argv[2], &a) != RAD_OK || rad_rf_read(argv[3], &b) != RAD_OK)
        goto done;
    const rad_mesh *mesh = rad_ff_file_mesh(ff);
    const size_t n = mesh->patch_count;
    if (a.mesh.patch_count != n || b.mesh.patch_count != n ||
        a.scene_fingerprint != rad_ff_file_info(ff)->scene_fingerprint || b.scene_fingerprint != a.scene_fingerprint) {
        printf("FAIL: %s and %s do not solve %s\n", argv[2], argv[3], argv[1]);
        goto done;
    }
    if (!a.converged || !b.converged) {
        printf("FAIL: %s%s not converged\n", a.converged ? "" : argv[2], b.converged ? "" : argv[3]);
        goto done;
    }
    row = malloc(n * sizeof *row);
    row_sum = malloc(n * sizeof *row_sum);
    if (!row || !row_sum) goto done;
    for (size_t i = 0; i < n; i++) {
        if (rad_ff_read_rows(ff, i, 1, row) != RAD_OK) goto done;
        double s = 0;
        for (size_t j = 0; j < n; j++) s += row[j];
        row_sum[i] = s;
    }
    ok = 1;
    for (int c = 0; c < 3; c++) {
        double contraction = 0, e_norm = 0, scale = 0, diff = 0;
        for (size_t i = 0; i < n; i++) {
            const rad_patch *p = &mesh->patches[i];
            contraction = fmax(contraction, p->rho[c] * row_sum[i]);
            e_norm = fmax(e_norm, p->emission[c]);
            double ba = a.radiosity[3 * i + c], bb = b.radiosity[3 * i + c];
            scale = fmax(scale, fabs(ba));
            diff = fmax(diff, fabs(ba - bb));
            if (!(fabs(ba - bb) <= INFINITY)) diff = INFINITY; /* NaN fails */
        }
        double allowed = (a.residual[c] + b.residual[c]) * e_norm / (1 - contraction) + AGREE_ROUNDING_SLACK * scale;
        int pass = contraction < 1 && diff <= allowed;
        printf("channel %d: max |B_A - B_B| = %.3g, allowed %.3g (residuals %.3g + %.3g, ||E|| %.6g, c %.6g)%s\n", c,
               diff, allowed, a.residual[c], b.residual[c], e_norm, contraction, pass ? "" : "  FAIL");
        ok &= pass;
    }
done:
    free(row);
    free(row_sum);
    rad_radiosity_free(&a);
    rad_radiosity_free(&b);
    rad_ff_close(ff);
    return ok ? 0 : 1;
}
