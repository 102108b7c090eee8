/* ff_progress.h - what a run tells the user while it works: the estimate
 * line before any row (rank 0: the outputs' size, the memory per rank and
 * the time, from a calibration on the run's own backend), with
 * --max-seconds's refusal, and progress lines while the rows are computed
 * (rank 0 speaks; every rank adds its rows to a shared counter).
 *
 *     ff_progress progress;
 *     ff_progress_init(&progress, comm, patch_count, options.progress_seconds);
 *     setup.progress = ff_progress_report, setup.progress_user = &progress;
 *     ... create the backend ...
 *     if (rank == 0) st = ff_progress_estimate(&progress, &estimate_inputs);
 *     ff_progress_start(&progress);          // collective
 *     for each backend call of `rows` rows:
 *         ff_progress_call_begin(&progress, rows), compute, ff_progress_call_end(&progress);
 *     ff_progress_finish(&progress);         // collective
 *
 * Lines: about 40 a run, at least 2 s apart (options.progress_seconds
 * overrides: RAD_PROGRESS_SECONDS); on a terminal one line that updates
 * twice a second, ended before the next message.
 */
#ifndef FF_PROGRESS_H
#define FF_PROGRESS_H

#include <stddef.h>
#include <stdint.h>

#include "ff_backend.h"
#include "ff_comm.h"
#include "ff_options.h"
#include "ff_plan.h"
#include "rad_status.h"

typedef struct ff_progress {
    ff_comm *comm;
    uint32_t patch_count;
    double every_override;  /* seconds between lines, or 0: by the estimate */
    /* This rank's rows done before the current backend call, and after it. */
    uint32_t base, call_end;
    uint64_t added;         /* rows this rank has added to the shared counter */
    double added_at;        /* when (ff_comm_time seconds) */
    double said_at;         /* rank 0: when it last reported */
    double every;           /* seconds between reports */
    double compute_start;   /* when the rows began (ff_progress_start) */
    double estimated_seconds; /* ff_progress_estimate's forecast, or -1 */
    int tty;                /* rank 0 reports to a terminal: one line that updates */
    int calibrating;        /* no reports: the estimate's rows are not the run's */
} ff_progress;

/* Before the backend is created (its callback's user is *progress);
 * every_override: options.progress_seconds. Sees whether rank 0's stderr
 * is a terminal (under -q no line updates). */
void ff_progress_init(ff_progress *progress, ff_comm *comm, uint32_t patch_count, double every_override);

/* The backends' callback (ff_setup.progress), on every rank: rows_done of
 * the current call. */
void ff_progress_report(void *progress, uint64_t rows_done);

/* What ff_progress_estimate needs of the run. */
typedef struct ff_estimate_inputs {
    const ff_backend *backend;
    void *backend_state;
    int records;                /* the rounds come back encoded (compute_records): calibrate the same way */
    int want_errors;            /* standard errors computed (not --no-errors) */
    const ff_plan *plan;        /* file_bytes, memory_bytes; pairs_once and most_rows: the busiest rank's rows */
    const ff_options *options;  /* --element, --format, --errors, --max-seconds */
} ff_estimate_inputs;

/* Rank 0, before any row is written: logs the estimate line (the time
 * from a calibration of about 1/64 of the matrix for runs of at least
 * 1024 patches) and sets the progress lines' cadence from it. With
 * --max-seconds, refuses (RAD_ERR_USAGE, logged) a run estimated to take
 * longer or whose calibration could not run. */
rad_status ff_progress_estimate(ff_progress *progress, const ff_estimate_inputs *inputs);

/* Collective, around the run's rows: the shared counter opened and
 * closed; finish ends the terminal's updating line. */
void ff_progress_start(ff_progress *progress);
void ff_progress_finish(ff_progress *progress);

/* Around each backend call of `rows` rows of this rank. */
void ff_progress_call_begin(ff_progress *progress, uint32_t rows);
void ff_progress_call_end(ff_progress *progress);

/* "1.2 s", "3 min 20 s", "33 h 10 min"; "1.23 GiB" (bytes as double:
 * refused sizes overflow 64 bits). Return out. */
const char *ff_progress_format_seconds(double seconds, char *out, size_t size);
const char *ff_progress_format_bytes(double bytes, char *out, size_t size);

#endif
