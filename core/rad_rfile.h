/* rad_rfile.h - the radiosity file ("RADRAD"), written by solve and read by
 * render; see docs/formats.md.
 *
 * Usage:
 *     rad_radiosity r;
 *     if (rad_rf_read("radiosity", &r) != RAD_OK) ...;   // logs why
 *     ... r.radiosity[3 * i + c] for patch i, channel c ...
 *     rad_radiosity_free(&r);
 *
 * Layout (every number little-endian, sections 64-byte aligned, padding
 * zero):
 *   header        256 bytes, byte offsets:
 *                   0  char[8]  magic RAD_RF_MAGIC
 *                   8  u32      version (RAD_RF_VERSION)
 *                  12  u32      header size (256)
 *                  16  u64      N, patch count (>= 1)
 *                  24  u64      V, vertex count (>= 3)
 *                  32  u32      channel count (1 = solved once as grey, 3 = RGB)
 *                  36  u32      method (rad_solve_method that produced channel 0)
 *                  40  u32      converged (0 or 1)
 *                  44  u32[3]   iterations per channel
 *                  56  f64      tolerance on the relative residual
 *                  64  f64[3]   final relative residual per channel
 *                  88  u64      scene fingerprint of the form-factor file
 *                  96  u32[3]   method that produced each channel's B
 *                 108  u32      flags (RAD_RF_FLAG_*; reserved and 0 before
 *                               2026-11-26: those files read as flags 0)
 *                 112  u64      vertex table offset
 *                 120  u64      patch table offset
 *                 128  u64      radiosity offset
 *                 136  u64      file size in bytes
 *                 144  u64      payload checksum: rad_hash64(RAD_HASH_SEED, ...)
 *                               over bytes [256, file size)
 *                 152  char[88] scene: the OBJ path formfactor was given (as the
 *                               form-factor file records it), NUL-padded;
 *                               all zero when unknown (files before
 *                               2026-11-24, the built-in box). Informational:
 *                               render looks for the scene's camera sidecar
 *                               there; never validated beyond a NUL end
 *                 240  u64      reserved (0)
 *                 248  u64      header checksum: rad_hash64 over bytes [0, 248)
 *   vertex table  V * 3 float64 (x, y, z)
 *   patch table   N * 128-byte rad_patch records, fields in declaration
 *                 order (as in the form-factor file)
 *   radiosity     N * 3 float64 (B_r, B_g, B_b per patch; grey scenes store
 *                 the single solved channel in all three)
 * For channel_count 1, entries [1] and [2] of the per-channel arrays repeat
 * entry [0].
 *
 * A reader validates sizes and checksums before trusting any value, then
 * the values: finite positions, patch records (3 or 4 vertices, indices in
 * range, positive area, unit normal, rho in [0, 1), E >= 0), finite B,
 * known method and channel count. Unconverged solves are valid files
 * (converged = 0); render decides what to do with them.
 */
#ifndef RAD_RFILE_H
#define RAD_RFILE_H

#include <stdint.h>

#include "rad_mesh.h"
#include "rad_status.h"

#define RAD_RF_MAGIC "RADRAD\r\n" /* 8 bytes */
#define RAD_RF_VERSION 1u
#define RAD_RF_HEADER_BYTES 256u
#define RAD_RF_ALIGN 64u
#define RAD_RF_PATCH_BYTES 128u /* RAD_PATCH_RECORD_BYTES (rad_patch_table.h) */

typedef enum rad_solve_method {
    RAD_SOLVE_JACOBI = 1,
    RAD_SOLVE_GAUSS_SEIDEL = 2,
    RAD_SOLVE_CG = 3
} rad_solve_method;

typedef struct rad_radiosity {
    rad_mesh mesh;            /* geometry and materials (owned) */
    double *radiosity;        /* patch_count * 3: B per patch, RGB (owned) */
    uint32_t channel_count;   /* 1 if the scene was solved as grey, else 3 */
    uint32_t method;          /* rad_solve_method that produced channel 0 */
    uint32_t converged;       /* 1 if every channel met the tolerance */
    uint32_t iterations[3];
    double tolerance;
    double residual[3];       /* final relative residual per channel */
    uint64_t scene_fingerprint;
    uint32_t channel_method[3]; /* rad_solve_method that produced each channel's
                                   B; differs from `method` after a fallback */
    char scene_path[88];      /* the OBJ formfactor read, or "" (NUL-terminated) */
    uint32_t flags;           /* RAD_RF_FLAG_*; readers ignore bits they do not know */
} rad_radiosity;

/* The scene's Ke was read as emitted radiance (formfactor --ke radiance;
 * the form-factor file's RAD_FF_FLAG_KE_RADIANCE): E = pi Ke, so B / pi is
 * in Ke's units, the radiance a path tracer such as Cycles draws. */
#define RAD_RF_FLAG_KE_RADIANCE 1u

/* Writes to `path` through a temporary name in the same directory and a
 * rename, so a failure never leaves a partial file under `path`. Zero
 * entries of channel_method are written as `method`. */
rad_status rad_rf_write(const char *path, const rad_radiosity *radiosity);
/* Reads and validates; errors name the file and what is wrong
 * (RAD_ERR_IO: cannot open/read; RAD_ERR_FORMAT: foreign, truncated,
 * corrupt, future version; RAD_ERR_INVALID: values out of range).
 * *out_radiosity is set only on success. */
rad_status rad_rf_read(const char *path, rad_radiosity *out_radiosity);
void rad_radiosity_free(rad_radiosity *radiosity); /* safe on zeroed */

#endif
