/* cg_check.c - the reciprocity check that decides whether CG may run
 * (cg_check.h): each row's skew term delta_i, measured (one process, or
 * across ranks with the transposed tiles exchanged) or bounded for a file
 * reciprocal by construction, against its diagonal-dominance margin m_i.
 *
 * Across ranks (docs/solve.md, "Across ranks") each rank checks its own
 * rows and the results are combined, the same bits as one process alone.
 */
#include "cg_check.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"
#include "solver.h" /* SOLVE_CG_RECIPROCITY */

/* delta_i = sum_j |A_i F_ij - A_j F_ji| over reflecting i != j, dense or
 * sparse alike: by blocks of 64 x 64 entries (a tile and its transpose),
 * one block of rows per task on the OpenMP threads. A block of rows takes
 * its partner blocks in ascending order and only it writes its rows'
 * delta_i, so each delta_i is summed in one fixed order, whatever the
 * number of threads. A sparse matrix visits only the blocks where a tile
 * or its transpose is stored (a bitmap of blocks; without memory for it,
 * every block); the others add |0 - 0|. */
static void skew_terms(const solve_run *run, double *delta)
{
    const size_t n = run->n, T = RAD_FF_TILE_COLUMNS, blocks = (n + T - 1) / T;
    const solve_rows *F = &run->F;
    const double *A = run->area, *rho = run->rho;
    unsigned char *stored = NULL; /* bit I * blocks + J: block (I, J) has a stored tile or transpose */
    if (!F->dense) {
        stored = calloc((blocks * blocks + 7) / 8, 1);
        for (size_t i = 0; stored && i < n; i++)
            for (uint64_t t = F->row_tiles[i]; t < F->row_tiles[i + 1]; t++) {
                size_t I = i / T, J = F->tile_column[t] / T;
                stored[(I * blocks + J) / 8] |= (unsigned char)(1u << ((I * blocks + J) % 8));
                stored[(J * blocks + I) / 8] |= (unsigned char)(1u << ((J * blocks + I) % 8));
            }
    }
#pragma omp parallel for schedule(dynamic, 1) if (n >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t I = 0; I < blocks; I++) {
        const double *row_i[RAD_FF_TILE_COLUMNS], *row_j[RAD_FF_TILE_COLUMNS];
        size_t i0 = I * T, i1 = i0 + T < n ? i0 + T : n;
        for (size_t i = i0; i < i1; i++) delta[i] = 0;
        for (size_t J = 0; J < blocks; J++) {
            if (stored && !(stored[(I * blocks + J) / 8] & (1u << ((I * blocks + J) % 8)))) continue;
            size_t j0 = J * T, j1 = j0 + T < n ? j0 + T : n;
            for (size_t i = i0; i < i1; i++) row_i[i - i0] = solve_row_tile(F, i, j0);
            for (size_t j = j0; j < j1; j++) row_j[j - j0] = solve_row_tile(F, j, i0);
            for (size_t i = i0; i < i1; i++) {
                if (rho[i] == 0) continue;
                double sum = delta[i];
                for (size_t j = j0; j < j1; j++) {
                    if (j == i || rho[j] == 0) continue;
                    double fij = row_i[i - i0] ? row_i[i - i0][j - j0] : 0;
                    double fji = row_j[j - j0] ? row_j[j - j0][i - i0] : 0;
                    sum += fabs(A[i] * fij - A[j] * fji);
                }
                delta[i] = sum;
            }
        }
    }
    free(stored);
}

/* Words of a segment sent by skew_exchange: row j, first column, count,
 * then the entries' bits. */
#define SKEW_SEGMENT_HEADER 3

/* The pieces of the held rows' stored spans that lie in each rank d's
 * rows, for d and then row j ascending: with send NULL, counts the words
 * for each d into words_to[d]; else writes them from send + at[d]. */
static void skew_pack(const solve_run *run, const size_t *split, size_t ranks, uint64_t *words_to, uint64_t *at,
                      uint64_t *send)
{
    const solve_rows *F = &run->F;
    for (size_t d = 0; d < ranks; d++)
        for (size_t j = run->row_begin; j < run->row_end; j++)
            for (size_t k = 0; k < solve_row_span_count(F, j); k++) {
                solve_span sp = solve_row_span(F, j, k);
                size_t lo = sp.begin > split[d] ? sp.begin : split[d];
                size_t hi = sp.end < split[d + 1] ? sp.end : split[d + 1];
                if (lo >= hi) continue;
                if (!send) {
                    words_to[d] += SKEW_SEGMENT_HEADER + (hi - lo);
                    continue;
                }
                uint64_t *w = send + at[d];
                w[0] = j, w[1] = lo, w[2] = hi - lo;
                memcpy(w + SKEW_SEGMENT_HEADER, sp.values + (lo - sp.begin), (hi - lo) * sizeof(double));
                at[d] += SKEW_SEGMENT_HEADER + (hi - lo);
            }
}

/* delta_i for the held rows when other ranks hold the rest: every rank
 * sends each owner the pieces of its stored rows that fall in the owner's
 * columns (the transposed tiles; one MPI_Alltoallv), so each rank sees
 * F_ji for its rows i from every row j. The non-zero F_ji arrive ordered
 * by j (ranks in order, rows in order within a rank), and delta_i sums
 * over j ascending, the same order as skew_terms: the terms it leaves out
 * are |0 - 0| = 0, so the same bits as one process alone. */
static rad_status skew_terms_ranks(const solve_run *run, double *delta)
{
    const size_t b = run->row_begin, e = run->row_end, held = e - b;
    const size_t ranks = (size_t)solve_comm_size(run->comm);
    const size_t *split = solve_comm_row_split(run->comm);
    const solve_rows *F = &run->F;
    const double *A = run->area, *rho = run->rho;
    rad_status status = RAD_OK;
    uint64_t *words_to = calloc(ranks, sizeof *words_to), *at = calloc(ranks, sizeof *at);
    uint64_t *send = NULL, *got = NULL, got_count = 0, total = 0;
    size_t *start = calloc(held + 1, sizeof *start), *fill = NULL;
    uint64_t *tj = NULL;
    double *tv = NULL;
    if (!words_to || !at || !start) status = RAD_ERR_NOMEM;
    if (status == RAD_OK) {
        skew_pack(run, split, ranks, words_to, at, NULL);
        for (size_t d = 0; d < ranks; d++) at[d] = total, total += words_to[d];
        send = malloc((total ? total : 1) * sizeof *send);
        if (!send) status = RAD_ERR_NOMEM;
    }
    if (status == RAD_OK) {
        skew_pack(run, split, ranks, words_to, at, send);
    }
    if (status == RAD_ERR_NOMEM) rad_error("%s: out of memory for the CG check's transposed tiles", run->label);
    status = solve_comm_agree(run->comm, status);
    if (status == RAD_OK) status = solve_comm_exchange(run->comm, send, words_to, &got, &got_count);
    free(send);
    send = NULL;
    if (status != RAD_OK) goto done;
    /* F_ji by row i: counts, offsets, then the entries in arrival order. */
    for (uint64_t w = 0; w < got_count; w += SKEW_SEGMENT_HEADER + got[w + 2])
        for (uint64_t k = 0; k < got[w + 2]; k++) {
            double f;
            memcpy(&f, &got[w + SKEW_SEGMENT_HEADER + k], sizeof f);
            if (f != 0) start[got[w + 1] + k - b + 1]++;
        }
    for (size_t i = 0; i < held; i++) start[i + 1] += start[i];
    fill = malloc((held ? held : 1) * sizeof *fill);
    tj = malloc((start[held] ? start[held] : 1) * sizeof *tj);
    tv = malloc((start[held] ? start[held] : 1) * sizeof *tv);
    status = fill && tj && tv ? RAD_OK : RAD_ERR_NOMEM;
    if (status != RAD_OK) rad_error("%s: out of memory for the CG check's transposed tiles", run->label);
    status = solve_comm_agree(run->comm, status);
    if (status != RAD_OK) goto done;
    memcpy(fill, start, held * sizeof *fill);
    for (uint64_t w = 0; w < got_count; w += SKEW_SEGMENT_HEADER + got[w + 2])
        for (uint64_t k = 0; k < got[w + 2]; k++) {
            double f;
            memcpy(&f, &got[w + SKEW_SEGMENT_HEADER + k], sizeof f);
            if (f == 0) continue;
            size_t r = (size_t)(got[w + 1] + k) - b;
            tj[fill[r]] = got[w];
            tv[fill[r]++] = f;
        }
#pragma omp parallel for schedule(dynamic, 64) if (held >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t i = b; i < e; i++) {
        double sum = 0;
        size_t t = start[i - b], t_end = start[i - b + 1];
        if (rho[i] == 0) {
            delta[i] = 0;
            continue;
        }
        for (size_t k = 0; k < solve_row_span_count(F, i); k++) {
            solve_span sp = solve_row_span(F, i, k);
            for (size_t j = sp.begin; j < sp.end; j++) {
                for (; t < t_end && tj[t] < j; t++) /* F_ij not stored, F_ji is */
                    if (tj[t] != i && rho[tj[t]] != 0) sum += fabs(A[i] * 0.0 - A[tj[t]] * tv[t]);
                double fji = t < t_end && tj[t] == j ? tv[t++] : 0;
                if (j == i || rho[j] == 0) continue;
                sum += fabs(A[i] * sp.values[j - sp.begin] - A[j] * fji);
            }
        }
        for (; t < t_end; t++)
            if (tj[t] != i && rho[tj[t]] != 0) sum += fabs(A[i] * 0.0 - A[tj[t]] * tv[t]);
        delta[i] = sum;
    }
done:
    free(words_to);
    free(at);
    free(got);
    free(start);
    free(fill);
    free(tj);
    free(tv);
    return status;
}

/* The checks of the ranks' rows as one: the smallest margin and the
 * largest ratio, each at its first row (as one process finds them). */
static solve_cg_check combine_checks(solve_comm *comm, solve_cg_check c)
{
    if (solve_comm_size(comm) == 1) return c;
    solve_cg_check all = c;
    all.margin = -solve_comm_max(comm, -c.margin);
    all.ratio = solve_comm_max(comm, c.ratio);
    double margin_row = c.margin == all.margin ? (double)c.margin_row : INFINITY;
    int has_ratio = all.ratio > 0 && c.ratio == all.ratio;
    double ratio_row = has_ratio ? (double)c.ratio_row : INFINITY;
    all.margin_row = (size_t)-solve_comm_max(comm, -margin_row);
    all.ratio_row = all.ratio > 0 ? (size_t)-solve_comm_max(comm, -ratio_row) : 0;
    int mine = has_ratio && c.ratio_row == all.ratio_row;
    double sums[3] = {(double)c.no_margin_count, mine ? c.ratio_delta : 0, mine ? c.ratio_margin : 0};
    solve_comm_sum(comm, sums, 3);
    all.no_margin_count = (size_t)sums[0];
    all.ratio_delta = sums[1];
    all.ratio_margin = sums[2];
    return all;
}

/* Each held row's sum over reflecting columns, rows on the OpenMP
 * threads, each summed left to right: the same bits for any thread count. */
static void active_sums(const solve_run *run, size_t begin, size_t end, double *active)
{
    const double *rho = run->rho;
#pragma omp parallel for schedule(dynamic, 64) if (end - begin >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t i = begin; i < end; i++) {
        double sum = 0;
        if (rho[i] != 0)
            for (size_t k = 0; k < solve_row_span_count(&run->F, i); k++) {
                solve_span sp = solve_row_span(&run->F, i, k);
                for (size_t j = sp.begin; j < sp.end; j++)
                    if (rho[j] != 0) sum += sp.values[j - sp.begin];
            }
        active[i] = sum;
    }
}

solve_cg_check solve_cg_check_matrix(const solve_run *run)
{
    const size_t n = run->n;
    const size_t begin = run->row_end ? run->row_begin : 0, end = run->row_end ? run->row_end : n;
    const double *A = run->area, *rho = run->rho;
    double *delta = run->work; /* sum_j |A_i F_ij - A_j F_ji| per row */
    solve_skew_cache *cache = run->skew;
    int cached = cache && cache->rho && cache->delta;
    for (size_t i = 0; cached && i < n; i++) cached = (cache->rho[i] == 0) == (rho[i] == 0);
    solve_cg_check c = {.margin = INFINITY};
    double *own_active = NULL, *active = cache && cache->active ? cache->active : NULL;
    if (!active && !(active = own_active = malloc((n ? n : 1) * sizeof *active))) {
        rad_error("%s: out of memory for the CG check (%zu patches)", run->label, n);
        c.status = RAD_ERR_NOMEM;
    }
    c.status = solve_comm_agree(run->comm, c.status);
    if (c.status != RAD_OK) return c;
    int measured_delta = 0;
    if (run->reciprocity_bound > 0) { /* reciprocal by construction: sum_j b A_i F_ij >= delta_i */
        for (size_t i = begin; i < end; i++) delta[i] = run->reciprocity_bound * A[i] * fabs(run->row_sum[i]);
    } else if (cached) {
        memcpy(delta, cache->delta, n * sizeof *delta);
    } else {
        if (solve_comm_size(run->comm) > 1)
            c.status = skew_terms_ranks(run, delta);
        else
            skew_terms(run, delta);
        measured_delta = 1;
    }
    if (c.status != RAD_OK) {
        free(own_active);
        return c;
    }
    if (!cached) active_sums(run, begin, end, active); /* else the cache holds this zero pattern's */
    if (cache && cache->delta && !cached) {
        if (measured_delta) memcpy(cache->delta, delta, n * sizeof *delta);
        cache->rho = run->reciprocity_bound > 0 || measured_delta ? rho : NULL;
    }
    for (size_t i = begin; i < end; i++) {
        if (rho[i] == 0) continue;
        double margin = 1 / rho[i] - active[i], skew = delta[i] / (2 * A[i]);
        if (margin < c.margin) {
            c.margin = margin;
            c.margin_row = i;
        }
        if (!(margin > 0)) {
            c.no_margin_count++;
        } else if (skew / margin > c.ratio) {
            c.ratio = skew / margin;
            c.ratio_row = i;
            c.ratio_delta = skew;
            c.ratio_margin = margin;
        }
    }
    free(own_active);
    return combine_checks(run->comm, c);
}

int solve_cg_check_passes(const solve_cg_check *check)
{
    return check->no_margin_count == 0 && check->ratio <= SOLVE_CG_RECIPROCITY;
}

void solve_cg_check_describe(const solve_cg_check *check, char *why, size_t why_size)
{
    if (check->no_margin_count)
        snprintf(why, why_size,
                 "no diagonal-dominance margin for CG: %zu rows have m_i = 1/rho_i - sum_j F_ij <= 0 (smallest: "
                 "row %zu, m = %.3g), so K need not be positive definite (see docs/solve.md)",
                 check->no_margin_count, check->margin_row, check->margin);
    else
        snprintf(why, why_size,
                 "matrix not reciprocal enough for CG: row %zu has delta_i/m_i = %.3g > %.3g (skew part "
                 "delta_i = %.3g against margin m_i = 1/rho_i - sum_j F_ij = %.3g; see docs/solve.md)",
                 check->ratio_row, check->ratio, SOLVE_CG_RECIPROCITY, check->ratio_delta, check->ratio_margin);
}

