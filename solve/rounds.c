/* rounds.c - the GPU backend's solve of a system's channels: CG or Jacobi
 * lanes on the device, each result verified on the host with the double
 * matrix, and rounds of mixed-precision refinement until the verified
 * residual meets the tolerance (docs/solve.md, "On the GPU").
 *
 * The device holds F32 = F rounded to float (exact for f32 files). Round
 * k + 1 solves, on the device, from B_k,
 *     (I - diag(rho) F32) B = E + diag(rho) (F - F32) B_k,
 * whose residual at B_k is the true residual of B_k: classical iterative
 * refinement written as defect correction. Its fixed point is the solution
 * with the double F, and each round shrinks the error by about the
 * relative size of F - F32 (6e-8) times the system's amplification, so
 * the second round meets any tolerance solve allows. The right-hand side
 * keeps E's sign pattern up to that tiny term, so the per-patch stopping
 * rule (run.h) applies to every round unchanged.
 */
#include "rounds.h"

#include <math.h>
#include <stdlib.h>

#include "cg.h"
#include "products.h"
#include "rad_log.h"
#include "stationary.h"

/* out_i = E_i + rho_i sum_j (F_ij - float(F_ij)) B_j, rows by one thread
 * each (no dependence on the thread count); this rank's rows, then every
 * rank's (collective: the GPUs take whole vectors). */
static rad_status refined_emission(const solve_run *run, const double *E, const double *B, double *out)
{
    const size_t begin = run->row_begin, end = run->row_end;
#pragma omp parallel for schedule(dynamic, 64) if (end - begin >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t i = begin; i < end; i++) {
        double rho = run->rho[i], s = 0;
        if (rho != 0)
            for (size_t k = 0; k < solve_row_span_count(&run->F, i); k++) {
                solve_span sp = solve_row_span(&run->F, i, k);
                for (size_t j = sp.begin; j < sp.end; j++) {
                    double f = sp.values[j - sp.begin];
                    s += (f - (double)(float)f) * B[j];
                }
            }
        out[i] = E[i] + rho * s;
    }
    return solve_comm_gather_rows(run->comm, &out, 1);
}

rad_status solve_gpu_channels(solve_gpu *gpu, solve_gpu_channel *channels, size_t count)
{
    rad_status status = RAD_OK;
    if (count == 0) return RAD_OK;
    const size_t n = channels[0].run->n;
    const int exact = solve_gpu_exact(gpu);
    solve_run **cg_runs = calloc(count, sizeof *cg_runs), **jacobi_runs = calloc(count, sizeof *jacobi_runs);
    char **cg_why = calloc(count, sizeof *cg_why);
    int *cg_stopped = calloc(count, sizeof *cg_stopped), *pending = calloc(count, sizeof *pending);
    size_t *cg_channel = calloc(count, sizeof *cg_channel);
    const double **emission = calloc(count, sizeof *emission);
    double *tolerance = calloc(count, sizeof *tolerance);
    double *refined = exact ? NULL : malloc(count * n * sizeof *refined);
    const double **product_x = calloc(count, sizeof *product_x);
    double **product_y = calloc(count, sizeof *product_y);
    if (!cg_runs || !jacobi_runs || !cg_why || !cg_stopped || !pending || !cg_channel || !emission || !tolerance ||
        !product_x || !product_y || (!exact && !refined)) {
        rad_error("%s: out of memory for %zu channels of %zu patches", channels[0].run->label, count, n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    for (size_t c = 0; c < count; c++) {
        solve_gpu_channel *ch = &channels[c];
        ch->stopped = 0;
        ch->verified = NAN;
        ch->rounds = 0;
        emission[c] = ch->run->E;
        tolerance[c] = ch->run->tolerance;
        pending[c] = 1;
    }
    for (uint32_t round = 1; round <= SOLVE_GPU_MAX_ROUNDS; round++) {
        size_t cg_count = 0, jacobi_count = 0;
        for (size_t c = 0; c < count; c++) {
            if (!pending[c]) continue;
            solve_gpu_channel *ch = &channels[c];
            solve_run *run = ch->run;
            ch->rounds = round;
            if (round > 1) {
                run->tolerance = tolerance[c] * SOLVE_GPU_ROUND_MARGIN;
                if (!exact) {
                    if ((status = refined_emission(run, emission[c], run->B, refined + c * n)) != RAD_OK) break;
                    run->E = refined + c * n;
                }
                rad_info("%s: verified residual %.4g > %.4g with the double matrix: refinement round %u on the GPU",
                         run->label, ch->verified, tolerance[c], round);
            }
            if (ch->method == SOLVE_CG) {
                cg_runs[cg_count] = run;
                cg_why[cg_count] = ch->why;
                cg_channel[cg_count++] = c;
            } else {
                jacobi_runs[jacobi_count++] = run;
            }
        }
        if (status == RAD_OK && cg_count)
            status = solve_cg_many(cg_runs, cg_count, gpu, cg_stopped, cg_why, channels[0].why_size);
        if (status == RAD_OK && jacobi_count) status = solve_jacobi_many(jacobi_runs, jacobi_count, gpu);
        for (size_t c = 0; c < count; c++) { /* the true system again */
            channels[c].run->E = emission[c];
            channels[c].run->tolerance = tolerance[c];
        }
        if (status != RAD_OK) break;
        for (size_t k = 0; k < cg_count; k++) {
            if (!cg_stopped[k]) continue;
            channels[cg_channel[k]].stopped = 1; /* Gauss-Seidel on the host finishes it */
            pending[cg_channel[k]] = 0;
        }
        /* verified with the double matrix, every channel in one pass over F */
        size_t left = 0, verify = 0;
        for (size_t c = 0; c < count; c++) {
            if (!pending[c]) continue;
            product_x[verify] = channels[c].run->B;
            product_y[verify++] = channels[c].product;
        }
        solve_rows_multiply(&channels[0].run->F, channels[0].run->row_begin, channels[0].run->row_end, verify,
                            product_x, product_y);
        for (size_t c = 0; c < count; c++) {
            if (!pending[c]) continue;
            solve_run *run = channels[c].run;
            double verified = solve_run_residual_of(run, run->B, channels[c].product);
            channels[c].verified = verified;
            pending[c] = verified > run->tolerance && run->iterations < run->max_iterations; /* NaN: done */
            left += pending[c] != 0;
        }
        if (!left) break;
    }
done:
    free(cg_runs);
    free(jacobi_runs);
    free(cg_why);
    free(cg_stopped);
    free(pending);
    free(cg_channel);
    free(emission);
    free(tolerance);
    free(refined);
    free(product_x);
    free(product_y);
    return status;
}
