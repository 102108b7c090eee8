/* ff_rows.c - couplings to form factors, and the reciprocity mirror (ff_rows.h). */
#include <stdlib.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "ff_rows.h"
#include "rad_log.h"

/* Doubles per exchanged piece (32 MiB): bounds the buffers, not the volume. */
#define FF_ROWS_PIECE ((size_t)1 << 22)
/* Tile edge of the in-block transpose, for the cache. */
#define FF_ROWS_TILE 64u

void ff_rows_summary_merge(ff_rows_summary *into, const ff_rows_summary *from)
{
    if (from->rows > 0) {
        if (into->rows == 0 || from->row_sum_min < into->row_sum_min) into->row_sum_min = from->row_sum_min;
        if (into->rows == 0 || from->row_sum_max > into->row_sum_max) into->row_sum_max = from->row_sum_max;
    }
    into->rows += from->rows;
    into->row_sum_total += from->row_sum_total;
    into->error_sum += from->error_sum;
    into->error_relative_sum += from->error_relative_sum;
    into->error_count += from->error_count;
    if (from->error_max > into->error_max) {
        into->error_max = from->error_max;
        into->error_max_value = from->error_max_value;
        into->error_max_row = from->error_max_row;
        into->error_max_column = from->error_max_column;
    }
}

/* One row: scale, sum, and its errors' share of the summary. */
static void finish_row(const double *area, uint32_t n, uint32_t i, double *row, double *err, ff_rows_summary *s)
{
    double sum = 0;
    for (uint32_t j = 0; j < n; j++) {
        row[j] *= area[j];
        sum += row[j];
    }
    if (err) {
        for (uint32_t j = 0; j < n; j++) {
            err[j] *= area[j];
            if (!(row[j] > 0)) continue;
            s->error_sum += err[j];
            s->error_relative_sum += err[j] / row[j];
            s->error_count++;
            if (err[j] > s->error_max) {
                s->error_max = err[j];
                s->error_max_value = row[j];
                s->error_max_row = i;
                s->error_max_column = j;
            }
        }
    }
    ff_rows_summary one = {.row_sum_min = sum, .row_sum_max = sum, .row_sum_total = sum, .rows = 1};
    ff_rows_summary_merge(s, &one);
}

void ff_rows_finish(const double *area, uint32_t n, uint32_t row_begin, uint32_t row_count, double *rows,
                    double *errors, int threads, ff_rows_summary *summary)
{
    enum { MAX_THREADS = 256 };
    ff_rows_summary part[MAX_THREADS] = {{0}};
    if (threads < 1) threads = 1;
    if (threads > MAX_THREADS) threads = MAX_THREADS;
    /* Static blocks of rows per thread, merged in thread order: the
     * summary does not depend on timing. */
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int t = 0; t < threads; t++) {
        uint32_t r0 = (uint32_t)((uint64_t)row_count * t / threads);
        uint32_t r1 = (uint32_t)((uint64_t)row_count * (t + 1) / threads);
        for (uint32_t r = r0; r < r1; r++)
            finish_row(area, n, row_begin + r, rows + (size_t)r * n, errors ? errors + (size_t)r * n : NULL,
                       &part[t]);
    }
    for (int t = 0; t < threads; t++) ff_rows_summary_merge(summary, &part[t]);
}

uint64_t ff_rows_mirror_local(uint32_t n, uint32_t begin, uint32_t end, double *block, int threads)
{
    uint64_t mirrored = 0;
    /* Tile row ti handles the pairs whose lower index lies in it: every
     * pair by exactly one iteration, so the iterations never touch the same
     * entry and run in parallel. */
#pragma omp parallel for num_threads(threads > 0 ? threads : 1) schedule(dynamic, 1) reduction(+ : mirrored)
    for (uint32_t ti = begin; ti < end; ti += FF_ROWS_TILE) {
        uint32_t ti_end = end - ti < FF_ROWS_TILE ? end : ti + FF_ROWS_TILE;
        for (uint32_t tj = ti; tj < end; tj += FF_ROWS_TILE) {
            uint32_t tj_end = end - tj < FF_ROWS_TILE ? end : tj + FF_ROWS_TILE;
            for (uint32_t i = ti; i < ti_end; i++) {
                double *row_i = block + (size_t)(i - begin) * n;
                for (uint32_t j = tj > i + 1 ? tj : i + 1; j < tj_end; j++) {
                    double *row_j = block + (size_t)(j - begin) * n;
                    if (rad_ff_row_computes(i, j))
                        row_j[i] = row_i[j];
                    else
                        row_i[j] = row_j[i];
                    mirrored++;
                }
            }
        }
    }
    return mirrored;
}

/* The entries that rows [a0, a1) compute in columns [b0, b1) (a range
 * disjoint from it), in order: row by row, columns ascending. Within a row
 * they are every other column, of the parity rad_ff_row_computes picks. */
typedef struct pair_stream {
    uint32_t a1, b0, b1;
    uint32_t i, j; /* the next entry; i == a1 at the end */
} pair_stream;

static uint32_t first_column(uint32_t i, uint32_t b0)
{
    uint32_t parity = b0 > i ? (i + 1) & 1u : i & 1u; /* columns above i: other parity; below: same */
    return b0 + ((b0 & 1u) ^ parity);
}

static void stream_settle(pair_stream *s)
{
    while (s->i < s->a1 && s->j >= s->b1) {
        s->i++;
        if (s->i < s->a1) s->j = first_column(s->i, s->b0);
    }
}

static pair_stream stream_open(uint32_t a0, uint32_t a1, uint32_t b0, uint32_t b1)
{
    pair_stream s = {.a1 = a1, .b0 = b0, .b1 = b1, .i = a0, .j = a0 < a1 ? first_column(a0, b0) : 0};
    stream_settle(&s);
    return s;
}

static void stream_next(pair_stream *s)
{
    s->j += 2;
    stream_settle(s);
}

static uint64_t stream_length(uint32_t a0, uint32_t a1, uint32_t b0, uint32_t b1)
{
    uint64_t total = 0;
    for (uint32_t i = a0; i < a1; i++) {
        uint32_t j = first_column(i, b0);
        if (j < b1) total += (b1 - j + 1) / 2;
    }
    return total;
}

rad_status ff_rows_exchange(ff_comm *comm, const uint32_t *row_begin, uint32_t n, double *block, uint64_t *mirrored)
{
    int rank = ff_comm_rank(comm), ranks = ff_comm_size(comm);
    uint32_t begin = row_begin[rank], end = row_begin[rank + 1];
    double *send = ranks > 1 ? malloc(sizeof(double) * FF_ROWS_PIECE) : NULL;
    double *recv = ranks > 1 ? malloc(sizeof(double) * FF_ROWS_PIECE) : NULL;
    rad_status st = ff_comm_agree(comm, ranks > 1 && (!send || !recv) ? RAD_ERR_NOMEM : RAD_OK);
    if (st != RAD_OK && (!send || !recv)) rad_error("out of memory for the reciprocity exchange buffers");
    /* Step s: send to rank + s what this rank computed for its rows, receive
     * from rank - s what that rank computed for this rank's rows. */
    for (int step = 1; st == RAD_OK && step < ranks; step++) {
        int dest = (rank + step) % ranks, source = (rank - step + ranks) % ranks;
        pair_stream out = stream_open(begin, end, row_begin[dest], row_begin[dest + 1]);
        pair_stream in = stream_open(row_begin[source], row_begin[source + 1], begin, end);
        uint64_t out_left = stream_length(begin, end, row_begin[dest], row_begin[dest + 1]);
        uint64_t in_left = stream_length(row_begin[source], row_begin[source + 1], begin, end);
        uint64_t mine = ((out_left > in_left ? out_left : in_left) + FF_ROWS_PIECE - 1) / FF_ROWS_PIECE;
        uint64_t pieces = ff_comm_max_u64(comm, mine); /* every pair of partners makes the same calls */
        for (uint64_t piece = 0; piece < pieces; piece++) {
            size_t send_count = out_left < FF_ROWS_PIECE ? (size_t)out_left : FF_ROWS_PIECE;
            size_t recv_count = in_left < FF_ROWS_PIECE ? (size_t)in_left : FF_ROWS_PIECE;
            for (size_t k = 0; k < send_count; k++, stream_next(&out))
                send[k] = block[(size_t)(out.i - begin) * n + out.j];
            rad_status local = ff_comm_sendrecv(comm, dest, send, send_count, source, recv, recv_count);
            if (local == RAD_OK)
                for (size_t k = 0; k < recv_count; k++, stream_next(&in))
                    block[(size_t)(in.j - begin) * n + in.i] = recv[k];
            out_left -= send_count;
            in_left -= recv_count;
            if (mirrored) *mirrored += recv_count;
            if (local != RAD_OK) st = local;
        }
        st = ff_comm_agree(comm, st);
    }
    free(send);
    free(recv);
    return st;
}
