/* radiosity_close.c - are two radiosity files of the same patches within
 * a stated relative difference? (hier_backends.sh: CPU against CUDA)
 *
 *   radiosity_close A.rad B.rad TOL
 *
 * Prints, per channel, max_i |B_A - B_B| and the RMS difference, each over
 * max_i |B_A|; exits 0 when every channel's max is <= TOL, 1 otherwise
 * (2: usage or unreadable files, or different patch counts). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "rad_rfile.h"

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: radiosity_close A.rad B.rad TOL\n");
        return 2;
    }
    char *end = NULL;
    const double tol = strtod(argv[3], &end);
    if (!end || *end || !(tol >= 0)) {
        fprintf(stderr, "radiosity_close: TOL '%s' is not a number >= 0\n", argv[3]);
        return 2;
    }
    rad_radiosity a = {0}, b = {0};
    int rc = 2;
    if (rad_rf_read(argv[1], &a) != RAD_OK || rad_rf_read(argv[2], &b) != RAD_OK) goto done;
    const size_t n = a.mesh.patch_count;
    if (b.mesh.patch_count != n || n == 0) {
        fprintf(stderr, "radiosity_close: %zu patches against %zu\n", n, b.mesh.patch_count);
        goto done;
    }
    rc = 0;
    for (int c = 0; c < 3; c++) {
        double top = 0, most = 0, squares = 0;
        for (size_t i = 0; i < n; i++) {
            const double x = a.radiosity[3 * i + c], d = fabs(x - b.radiosity[3 * i + c]);
            top = fmax(top, fabs(x));
            most = fmax(most, d);
            squares += d * d;
        }
        const double rel = top > 0 ? most / top : most, rms = top > 0 ? sqrt(squares / (double)n) / top : 0;
        const int ok = rel <= tol;
        printf("channel %d: max |dB| %.3g, RMS %.3g of max |B| %.6g (tolerance %.3g): %s\n", c, rel, rms, top, tol,
               ok ? "ok" : "FAIL");
        if (!ok || isnan(rel)) rc = 1;
    }
done:
    rad_radiosity_free(&a);
    rad_radiosity_free(&b);
    return rc;
}
