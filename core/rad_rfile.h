/* rad_rfile.h - the radiosity file ("RADRAD"), written by solve and read by
 * render; see docs/formats.md.
 *
 * Layout (little-endian, sections 64-byte aligned):
 *   header        256 bytes: magic, version, N, V, channel count (1 = grey,
 *                 3 = RGB), solver method, tolerance, final residual per
 *                 channel, iterations per channel, converged flag, the
 *                 source form-factor file's scene fingerprint, checksums
 *   vertex table  V * 3 float64
 *   patch table   N * 128-byte rad_patch records (as in the form-factor file)
 *   radiosity     N * 3 float64 (B_r, B_g, B_b per patch; grey scenes store
 *                 the single solved channel in all three)
 * A reader validates sizes and checksums before trusting any value.
 */
#ifndef RAD_RFILE_H
#define RAD_RFILE_H

#include <stdint.h>

#include "rad_mesh.h"
#include "rad_status.h"

#define RAD_RF_MAGIC "RADRAD\r\n" /* 8 bytes */
#define RAD_RF_VERSION 1u

typedef enum rad_solve_method {
    RAD_SOLVE_JACOBI = 1,
    RAD_SOLVE_GAUSS_SEIDEL = 2,
    RAD_SOLVE_CG = 3
} rad_solve_method;

typedef struct rad_radiosity {
    rad_mesh mesh;            /* geometry and materials (owned) */
    double *radiosity;        /* patch_count * 3: B per patch, RGB (owned) */
    uint32_t channel_count;   /* 1 if the scene was solved as grey, else 3 */
    uint32_t method;          /* rad_solve_method */
    uint32_t converged;       /* 1 if every channel met the tolerance */
    uint32_t iterations[3];
    double tolerance;
    double residual[3];       /* final relative residual per channel */
    uint64_t scene_fingerprint;
} rad_radiosity;

/* Writes to `path` through a temporary name in the same directory and a
 * rename, so a failure never leaves a partial file under `path`. */
rad_status rad_rf_write(const char *path, const rad_radiosity *radiosity);
/* Reads and validates; errors name the file and what is wrong. */
rad_status rad_rf_read(const char *path, rad_radiosity *out_radiosity);
void rad_radiosity_free(rad_radiosity *radiosity); /* safe on zeroed */

#endif
