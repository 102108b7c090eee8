/* ff_output.h - the form-factor file, written by all ranks at once.
 *
 *     ff_output *out;
 *     ff_output_open(comm, path, FF_FORMAT_SPARSE, &info, &mesh, &options, &out);  // collective
 *     for each round: ff_output_write_rows(out, row0, rows, data);         // collective
 *     status = ff_output_close(out, status);                               // collective
 *     status = ff_output_commit(out, status);                              // collective
 *
 * Rank 0 picks a temporary name beside `path`; every rank opens it and
 * writes its own row blocks there at offsets computed from the layout, on
 * its own (ff_writer.h: no collective write, no rank waits for another's
 * bytes) and in the background: a write returns once the rows are placed
 * and encoded, and its bytes go to the file while the rank computes the
 * next round. Rank 0 adds the header and the row checksums last and
 * renames the file only if every rank succeeded. Otherwise the temporary
 * is removed and whatever was under `path` before stays as it was.
 *
 * The sparse format's row records vary in size, so their offsets come from
 * the ranks' sizes (an exclusive scan, the one collective step of a write)
 * as they are written: each write appends its rows after the previous
 * one's, rank by rank. A rank that holds all its rows before writing calls
 * ff_output_reserve first: the records then lie in row order whatever the
 * number of ranks and rounds. Ranks that stream rows take blocks in turn
 * (ff_plan.h), so each write's rows follow the last write's: row order
 * again. Either way the file is the same bytes for any rank count, thread
 * count, round size and way of writing. A rank's rows need not be
 * contiguous: the row index is gathered by row number; every row is
 * written once.
 */
#ifndef FF_OUTPUT_H
#define FF_OUTPUT_H

#include <stdint.h>

#include "ff_backend.h"
#include "ff_comm.h"
#include "ff_handoff.h"
#include "ff_writer.h"
#include "rad_ffile.h"

typedef enum ff_format {
    FF_FORMAT_SPARSE = 0, /* docs/formats.md, version 3: only the non-zero tiles of each row (the default) */
    FF_FORMAT_DENSE = 1,  /* docs/formats.md, version 2: every entry */
    FF_FORMAT_PAPER = 2   /* int32 N, then N*N float64, row-major; nothing else */
} ff_format;

typedef struct ff_output ff_output;

/* How a rank writes; zero = the defaults. */
typedef struct ff_output_options {
    int threads;                  /* OpenMP threads that convert, encode and checksum a write's rows; 0 = 1 */
    int write_threads;            /* threads that write them in the background (ff_writer.h); 0 = 1 */
    ff_write_method write_method; /* 0 = auto: a mapping where the file allows it, else pwrite */
} ff_output_options;

/* This rank's writes (ff_output_written, after ff_output_close). */
typedef struct ff_output_write_stats {
    double seconds;     /* writes in flight, from each start until done (mostly behind the computation) */
    uint64_t bytes;
    const char *method; /* "map" or "pwrite" (ff_writer.h) */
} ff_output_write_stats;

rad_status ff_output_open(ff_comm *comm, const char *path, ff_format format, const rad_ff_info *info,
                          const rad_mesh *mesh, const ff_output_options *options, ff_output **out_output);
/* Collective, sparse format: an output that hands this rank's records to
 * `consume` instead of writing a file (formfactor --radiosity, issue 28:
 * solve's matrix decodes them, ff_solve.h), on a background thread while
 * the rank computes its next rows (ff_handoff.h). The same calls as a
 * file's (reserve, write_rows, write_records, close, commit); no file, no
 * temporary, no row index. */
rad_status ff_output_open_held(ff_comm *comm, const rad_ff_info *info, ff_handoff_consume consume, void *user,
                               const ff_output_options *options, ff_output **out_output);
/* Largest number of rows one write may carry in a file of this format
 * (bounds the two buffers a write is encoded into); known before it is
 * opened (ff_plan.h). */
uint32_t ff_output_max_rows(uint64_t patch_count, ff_format format, rad_element_type element);
/* Collective, sparse format, optional, before the first write: this
 * rank's rows, all of them (row_count x N, as they will be written), so
 * that the records can be placed in row order. Other formats: nothing. */
rad_status ff_output_reserve(ff_output *output, uint32_t row_count, const double *rows);
/* Collective: this rank's rows [row_begin, row_begin + row_count) (row_count may be 0),
 * encoded into a buffer of the output's own; `rows` may be reused once it returns. */
rad_status ff_output_write_rows(ff_output *output, uint32_t row_begin, uint32_t row_count, const double *rows);
/* Collective, sparse format: the same as ff_output_write_rows for rows
 * that are already encoded (a backend's compute_records, ff_backend.h).
 * They are written from `records` itself, in the background: its bytes
 * must stay as they are until the next write to this output (or its
 * close) returns. */
rad_status ff_output_write_records(ff_output *output, uint32_t row_begin, uint32_t row_count,
                                   const ff_records *records);
/* Collective, in two steps so that several files can appear together:
 * close writes the header and closes the file under its temporary name;
 * commit renames it to its final name, or removes it if `status` is not
 * RAD_OK on any rank, and frees `output`. Both return the agreed status. */
rad_status ff_output_close(ff_output *output, rad_status status);
ff_output_write_stats ff_output_written(const ff_output *output);
rad_status ff_output_commit(ff_output *output, rad_status status);

#endif
