/* gpu.h - the C-callable face of solve's CUDA code: the form-factor matrix
 * resident on one GPU, and the vector work of up to SOLVE_GPU_LANES
 * channels iterating in lockstep on it. No CUDA types here; gpu_cuda.cu
 * implements it, gpu_none.c (builds without nvcc) says there is no GPU.
 *
 * Usage (the iteration control stays on the host: cg.c, stationary.c,
 * rounds.c; docs/solve.md, "On the GPU"):
 *     solve_gpu_tiles tiles;
 *     solve_gpu_tiles_make(&rows, &tiles);          // F as float tiles, on the host
 *     solve_gpu *gpu;
 *     solve_gpu_create(&tiles, area, &gpu);         // copies them once
 *     solve_gpu_tiles_free(&tiles);
 *     solve_gpu_lanes_load(gpu, 3, rho, E, B, e_norm);
 *     for (;;) {
 *         solve_gpu_lanes_iterate(gpu, ops, omega); // one pass over F for all lanes
 *         ... decide on the host; solve_gpu_cg_restart / solve_gpu_jacobi_accept ...
 *     }
 *     solve_gpu_lanes_store(gpu, c, B);
 *     solve_gpu_destroy(gpu);
 *
 * Under mpirun (solve_gpu_create_ranks) each rank's GPU holds its block
 * of rows; the vectors stay whole (N entries) on every GPU. Each pass
 * multiplies the rank's rows and updates their entries; the ranks then
 * exchange what changed through the callback they were given (stage.c:
 * MPI_Allgatherv, comm.h): the operand of the next product (B or CG's p),
 * and the partial sums and maxima of each reduction before it is finished.
 * Reductions run over fixed chunks of rows (solve_gpu_row_quantum), each
 * summed alike whichever rank holds it, and the chunks' partials are added
 * in one fixed order on every rank: the same bits for any number of
 * ranks, as for one GPU alone.
 *
 * The matrix: the 64-column tiles of a sparse file as they are stored
 * (row_tiles, tile_column), a dense matrix as all the tiles of each row,
 * every tile padded to 64 entries; entries as float (exact when the file
 * stores f32), products summed in double. gpu_tiles.c builds that on the
 * host (plain C, OpenMP); gpu_cuda.cu copies it. Vectors are double. Every
 * reduction (a row's product, a dot product, a maximum) runs in a fixed
 * order for a given N: the same inputs give the same bits, run after run.
 */
#ifndef SOLVE_GPU_H
#define SOLVE_GPU_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"
#include "rows.h"

/* Channels one pass over the matrix serves (a scene's red, green, blue). */
#define SOLVE_GPU_LANES 3

typedef struct solve_gpu solve_gpu; /* opaque */

/* 1 when this build has the CUDA backend (nvcc found at configure time). */
int solve_gpu_built(void);
/* CUDA devices usable by this process; 0 with no GPU or no driver (never
 * an error: --backend auto then picks the CPU). */
int solve_gpu_device_count(void);
/* Starts CUDA (driver and the device's context, 0.2-0.3 s on an H100) on a
 * thread while the file loads, on device `rank` mod the devices (rank: the
 * MPI rank, 0 alone); solve_gpu_device_count and solve_gpu_create wait for
 * it, and so does solve_gpu_prestart_join (before the stage returns). Does
 * nothing in builds without CUDA. */
void solve_gpu_prestart(int rank);
void solve_gpu_prestart_join(void);

/* --backend auto solves on the GPU only from this many stored entries up
 * (64 MiB of doubles): below it the CPU's iterations take less time than
 * starting CUDA and uploading (N = 2944 on an H100: 0.04 s on the CPU
 * against 0.33 s with CUDA; N = 47 104, 226 M entries: the GPU wins). */
#define SOLVE_GPU_AUTO_MIN_ENTRIES ((uint64_t)8 << 20)

/* The matrix as the device stores it: flat arrays and counts. */
typedef struct solve_gpu_tiles {
    size_t n, tile_count;  /* n: the rows held (all N, or a rank's block: solve_gpu_tiles_make_rows) */
    uint64_t *row_tiles;   /* n + 1: held row r's tiles are [row_tiles[r], row_tiles[r + 1]) */
    uint32_t *tile_column; /* tile_count: each tile's first column (a multiple of 64) */
    float *values;         /* tile_count * RAD_FF_TILE_COLUMNS: F_ij rounded to float, zero-padded */
    double *diag;          /* n: F_ii of each held row in double (Jacobi's divisor, CG's preconditioner) */
    int exact;             /* 1 when every float is its double (an f32 file) */
    /* Where the values come from: F's rows [source_begin, source_begin + n).
     * With values NULL (solve_gpu_tiles_layout_rows) they are converted
     * while they are copied (solve_gpu_tiles_fill), and exact is known only
     * then (solve_gpu_exact). */
    const solve_rows *source;
    size_t source_begin;
} solve_gpu_tiles;

/* Rows per OpenMP thread pass, as SOLVE_PARALLEL_MIN_ROWS (run.h). */
#define SOLVE_GPU_PARALLEL_MIN_ROWS 256

/* Builds the tiles of F on the host threads (gpu_tiles.c; no CUDA).
 * Out of memory: logged, RAD_ERR_NOMEM, *out_tiles untouched. */
rad_status solve_gpu_tiles_make(const solve_rows *F, solve_gpu_tiles *out_tiles);
/* The same for rows [row_begin, row_end) only (F holds them: a rank's block). */
rad_status solve_gpu_tiles_make_rows(const solve_rows *F, size_t row_begin, size_t row_end, solve_gpu_tiles *out_tiles);
void solve_gpu_tiles_free(solve_gpu_tiles *tiles); /* safe on zeroed */
/* The layout alone (row_tiles, tile_column, diag; values NULL): the values
 * are streamed from F when solve_gpu_create_ranks copies them, so the host
 * never holds the float matrix whole. */
rad_status solve_gpu_tiles_layout_rows(const solve_rows *F, size_t row_begin, size_t row_end,
                                       solve_gpu_tiles *out_tiles);
/* Held rows [first, end)'s tile values, from tiles->source, into `to`
 * (tile row_tiles[first] at to[0]; zero-padded floats), on the host's
 * threads. Returns 1 when every float is its double. */
int solve_gpu_tiles_fill(const solve_gpu_tiles *tiles, size_t first, size_t end, float *to);

/* Copies `tiles` (area: n patch areas) to device 0. Errors (no device, not
 * enough GPU memory, a failed CUDA call) are logged; *out_gpu is set only
 * on success. */
rad_status solve_gpu_create(const solve_gpu_tiles *tiles, const double *area, solve_gpu **out_gpu);

/* Rows a reduction's chunk holds for N = n: a multiple of 256, at least
 * n / 512 (the partials of one reduction, at most 512, fit the finishing
 * kernel's fixed order). Where the rows are split over ranks every rank's
 * first row is a multiple of it. */
size_t solve_gpu_row_quantum(size_t n);

/* A matrix split over ranks: this GPU's share and how ranks exchange. */
typedef struct solve_gpu_ranks {
    size_t n;                  /* N: every vector's length and the columns */
    size_t ranks;              /* >= 1 */
    const size_t *row_split;   /* ranks + 1: every rank's first row, multiples of solve_gpu_row_quantum(n), then N */
    size_t rank;               /* this one: tiles hold rows [row_split[rank], row_split[rank + 1]) */
    int device;                /* the CUDA device (rank mod devices) */
    /* Collective, in place: entries [split[r], split[r + 1]) of each of
     * `count` host arrays come from rank r, on every rank (split: ranks + 1
     * values). NULL alone. */
    rad_status (*gather)(void *user, const size_t *split, double *const *arrays, size_t count);
    void *user;
} solve_gpu_ranks;

/* solve_gpu_create for this rank's rows (`tiles`: row_split[rank + 1] -
 * row_split[rank] of them) of a matrix split over ranks; area has N
 * entries. Not collective: the caller agrees on the outcome. */
rad_status solve_gpu_create_ranks(const solve_gpu_tiles *tiles, const double *area, const solve_gpu_ranks *ranks,
                                  solve_gpu **out_gpu);
void solve_gpu_destroy(solve_gpu *gpu); /* safe on NULL */

/* 1 when every entry of F is a float exactly (f32 files): the device
 * matrix is F itself. Otherwise it is F rounded to float. */
int solve_gpu_exact(const solve_gpu *gpu);
/* Sets it: the ranks' agreement, each having streamed its own rows. */
void solve_gpu_set_exact(solve_gpu *gpu, int exact);
/* The device's name, e.g. "NVIDIA H100 80GB HBM3". */
const char *solve_gpu_device_name(const solve_gpu *gpu);
/* Bytes of device memory the matrix takes. */
size_t solve_gpu_matrix_bytes(const solve_gpu *gpu);

/* y_c = F x_c for c < count (count <= SOLVE_GPU_LANES), host vectors of N
 * doubles each, through the lanes' vectors (their contents are lost); with
 * ranks, collective: every rank gets all of y. */
rad_status solve_gpu_multiply(solve_gpu *gpu, size_t count, const double *const *x, double *const *y);

/* Loads `count` (<= SOLVE_GPU_LANES) lanes: lane c iterates on
 * (I - diag(rho[c]) F) B = E[c] from B[c], its stopping rule scaled by
 * e_norm[c] (run.h). Host arrays of N doubles (whole, on every rank); copied. */
rad_status solve_gpu_lanes_load(solve_gpu *gpu, size_t count, const double *const *rho, const double *const *E,
                                const double *const *B, const double *e_norm);
/* Copies lane c's current B (N doubles) to the host (with ranks: collective). */
rad_status solve_gpu_lanes_store(solve_gpu *gpu, size_t lane, double *out_B);

/* What a lane does with its pass over F (docs/solve.md, "On the GPU"). */
typedef enum solve_gpu_op {
    SOLVE_GPU_IDLE = 0,
    SOLVE_GPU_CG_RESIDUAL, /* y = F B: r = diag(A/rho)(E + rho y - B), z = r / K_ii (cg.c cg_residual) */
    SOLVE_GPU_CG_STEP,     /* y = F p: q = K p; if p.q > 0 one CG update of B, r, z, p (cg.c cg_step) */
    SOLVE_GPU_JACOBI       /* y = F B: next = B + r / (1 - rho F_ii) (stationary.c jacobi_sweep) */
} solve_gpu_op;

/* One pass over F for every lane whose ops[c] is not idle, then each
 * lane's op. out_omega[c]: omega of the iterate measured (CG residual,
 * Jacobi: of B; CG step: of the new B, from the recurrence), or NAN for a
 * CG step that met p.Kp <= 0 (then nothing changed). Idle lanes' entries
 * are left alone. Waits for the device. With ranks, collective (as are
 * solve_gpu_cg_restart and solve_gpu_lanes_store), with the same ops on
 * every rank. */
rad_status solve_gpu_lanes_iterate(solve_gpu *gpu, const solve_gpu_op *ops, double *out_omega);
/* For every lane c with restart[c] != 0: p = z and rz = r.z (a fresh
 * search direction). Does not wait. */
rad_status solve_gpu_cg_restart(solve_gpu *gpu, const int *restart);
/* Lane c takes the iterate its last Jacobi op computed (B = next). */
void solve_gpu_jacobi_accept(solve_gpu *gpu, size_t lane);

#endif
