/* ff_progress.c - the estimate line and the progress lines (ff_progress.h). */
#include "rad_clock.h"
#include "ff_progress.h"

#include <math.h>
#include <stdio.h>
#include <unistd.h>

#include "ff_row_buffer.h"
#include "rad_log.h"

const char *ff_progress_format_seconds(double s, char *out, size_t size)
{
    if (!(s < 1e9)) snprintf(out, size, "longer than 30 years");
    else if (s < 0.01) snprintf(out, size, "%.1f ms", 1e3 * s);
    else if (s < 60) snprintf(out, size, "%.2g s", s);
    else if (s < 3600) snprintf(out, size, "%d min %d s", (int)(s / 60), (int)fmod(s, 60));
    else snprintf(out, size, "%d h %d min", (int)(s / 3600), (int)fmod(s / 60, 60));
    return out;
}

const char *ff_progress_format_bytes(double bytes, char *out, size_t size)
{
    static const char *const units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB", "ZiB"};
    int u = 0;
    while (bytes >= 1024 && u < 7) bytes /= 1024, u++;
    snprintf(out, size, u ? "%.3g %s" : "%.0f %s", bytes, units[u]);
    return out;
}

void ff_progress_init(ff_progress *p, ff_comm *comm, uint32_t patch_count, double every_override)
{
    *p = (ff_progress){.comm = comm, .patch_count = patch_count, .every_override = every_override,
                       .every = 2.0, .estimated_seconds = -1};
    p->tty = ff_comm_rank(comm) == 0 && isatty(STDERR_FILENO) && rad_log_get_level() >= RAD_LOG_INFO;
}

/* Adds this rank's rows to the shared counter at most once a second;
 * rank 0 reports the whole run's rows every `every` seconds. */
void ff_progress_report(void *user, uint64_t rows_done)
{
    ff_progress *p = user;
    if (p->calibrating) return;
    double t = rad_clock_seconds();
    uint64_t done = p->base + rows_done;
    /* at most once a second, and at the end of each call (the other
     * ranks' counts then reach rank 0 round by round) */
    if (done > p->added && (t - p->added_at >= 1.0 || done == p->call_end)) {
        ff_comm_progress_add(p->comm, done - p->added);
        p->added = done;
        p->added_at = t;
    }
    if (ff_comm_rank(p->comm) != 0 || t - p->said_at < p->every) return;
    p->said_at = t;
    double fraction = (double)ff_comm_progress_read(p->comm) / (double)(p->patch_count ? p->patch_count : 1);
    double elapsed = t - p->compute_start;
    /* The first rows say little about the rest: until 5 % are done, the
     * calibration's forecast (which sampled the whole matrix) holds. */
    double to_go = fraction > 0 ? elapsed * (1 - fraction) / fraction : -1;
    if (fraction < 0.05 && p->estimated_seconds >= 0)
        to_go = p->estimated_seconds > elapsed ? p->estimated_seconds - elapsed : 0;
    char took[32], left[32];
    const char *format = p->tty ? "\r%s%.1f%% of the rows (%d rank(s)), %s elapsed, about %s to go\033[K"
                                : "%s%.1f%% of the rows (%d rank(s)), %s elapsed, about %s to go";
    char line[256];
    snprintf(line, sizeof line, format, p->tty ? "formfactor: " : "", 100 * fraction, ff_comm_size(p->comm),
             ff_progress_format_seconds(elapsed, took, sizeof took),
             to_go >= 0 ? ff_progress_format_seconds(to_go, left, sizeof left) : "?");
    if (p->tty && rad_log_get_level() >= RAD_LOG_INFO) {
        fputs(line, stderr); /* the one line that updates; ended by ff_progress_finish */
        fflush(stderr);
    } else {
        rad_info("%s", line);
    }
}

void ff_progress_start(ff_progress *p)
{
    ff_comm_progress_open(p->comm);
    p->base = 0;
    p->compute_start = rad_clock_seconds();
    p->said_at = p->compute_start;
}

void ff_progress_finish(ff_progress *p)
{
    ff_comm_progress_close(p->comm);
    if (p->tty && p->said_at > p->compute_start) fputc('\n', stderr); /* end the updating line */
}

void ff_progress_call_begin(ff_progress *p, uint32_t rows)
{
    p->call_end = p->base + rows;
}

void ff_progress_call_end(ff_progress *p)
{
    p->base = p->call_end;
}

/* The calibration: FF_CALIBRATION_CHUNKS chunks of rows spread over the
 * matrix, together about 1/64 of it, computed by the run's own backend
 * (and computed again later: 1.6 % more work) and scaled to the rows of
 * the busiest rank (busiest_rows); at most FF_CALIBRATION_PAIRS pairs in
 * all (at least one row a chunk), so that a huge run's calibration takes
 * bounded memory and time (N = 326 698: 4 rows, not 1/64 of the run). A
 * GPU's chunks of a small scene are mostly launch latency, so small runs
 * are overestimated; runs of fewer than FF_CALIBRATION_MIN patches take
 * seconds and are not calibrated. 16 chunks, not four, and from 256
 * patches, not 1024: a room's costly rows (a floor under objects: shadow
 * rays for most pairs) lie in a few percent of the matrix, which four
 * chunks missed (20 s said, 74 s taken at N = 9286; issue 30), and
 * curved meshes took 83 s below 1024 patches, where nothing was said.
 * Where FF_CALIBRATION_PAIRS allows fewer than one row a chunk, fewer
 * chunks (calibration_chunks). */
#define FF_CALIBRATION_CHUNKS 16
#define FF_CALIBRATION_MIN 256
/* At least this many rows a chunk (FF_CALIBRATION_PAIRS allowing): the
 * threads share a chunk's rows, and a chunk of one row each left one
 * thread waiting on the other's costlier row at every chunk. */
#define FF_CALIBRATION_CHUNK_ROWS 4
#define FF_CALIBRATION_PAIRS ((uint64_t)1 << 21)
/* How many chunks: FF_CALIBRATION_CHUNKS, fewer where FF_CALIBRATION_PAIRS
 * holds fewer rows (at least one). */
static uint32_t calibration_chunks(uint32_t n)
{
    uint64_t rows = FF_CALIBRATION_PAIRS / (n ? n : 1);
    return rows >= FF_CALIBRATION_CHUNKS ? FF_CALIBRATION_CHUNKS : rows > 0 ? (uint32_t)rows : 1;
}

/* The first row of calibration chunk k of `chunks`: chunks centred in equal parts of the matrix. */
static uint32_t calibration_row(uint32_t n, uint32_t chunks, uint32_t chunk, uint32_t k)
{
    uint64_t centre = (uint64_t)n * (2 * k + 1) / (2 * chunks);
    uint32_t r0 = centre > chunk / 2 ? (uint32_t)(centre - chunk / 2) : 0;
    return r0 + chunk > n ? n - chunk : r0;
}

/* The rows whose time is the run's: in blocks (pairs_once, --radiosity) a block of the split,
 * which balances the ranks' work (not their rows), so N / ranks; streamed,
 * the most rows a rank takes in blocks of rows_per_round (one block more than
 * another rank's where the blocks do not divide evenly). */
static double busiest_rows(const ff_progress *p, const ff_plan *plan)
{
    if (plan->blocks) return (double)p->patch_count / ff_comm_size(p->comm);
    return plan->most_rows;
}

/* Rows in each calibration chunk: 1/64 of the matrix over the chunks (at
 * least FF_CALIBRATION_CHUNK_ROWS), within FF_CALIBRATION_PAIRS (at least 1). */
static uint32_t calibration_chunk(uint32_t n)
{
    uint32_t chunks = calibration_chunks(n);
    uint32_t chunk = n / 64 / chunks > FF_CALIBRATION_CHUNK_ROWS ? n / 64 / chunks : FF_CALIBRATION_CHUNK_ROWS;
    uint64_t most = FF_CALIBRATION_PAIRS / chunks / (n ? n : 1);
    if (most < 1) most = 1;
    return chunk > most ? (uint32_t)most : chunk;
}

/* Times the calibration's chunks: *out_seconds, or *out_failed says why
 * they could not run. */
static void calibrate(ff_progress *p, const ff_estimate_inputs *in, uint32_t chunk, double *out_seconds,
                      const char **out_failed)
{
    uint32_t n = p->patch_count, chunks = calibration_chunks(n);
    const ff_backend *backend = in->backend;
    ff_counters scratch = {0};
    rad_status st = RAD_OK;
    *out_failed = NULL;
    if (in->records) {
        /* Rows the backend finishes itself: calibrated the same way, so
         * that no rows cross to the host (at N = 188 416 those copies took
         * 2.9 s). */
        ff_rows_summary ignored = {0};
        p->calibrating = 1;
        double t0 = rad_clock_seconds();
        for (uint32_t k = 0; k < chunks && st == RAD_OK; k++) {
            ff_records values, errors;
            st = backend->compute_records(in->backend_state, calibration_row(n, chunks, chunk, k), chunk,
                                          in->options->element, &values, in->options->errors_path ? &errors : NULL,
                                          &ignored, &scratch);
        }
        *out_seconds = rad_clock_seconds() - t0;
        p->calibrating = 0;
        if (st != RAD_OK) *out_failed = "its rows failed";
        return;
    }
    double *rows = ff_row_buffer_alloc(backend, in->backend_state, (size_t)chunk * n);
    double *errors = in->want_errors ? ff_row_buffer_alloc(backend, in->backend_state, (size_t)chunk * n) : NULL;
    if (rows && (errors || !in->want_errors)) {
        p->calibrating = 1;
        double t0 = rad_clock_seconds();
        for (uint32_t k = 0; k < chunks && st == RAD_OK; k++) {
            st = backend->compute_rows(in->backend_state, calibration_row(n, chunks, chunk, k), chunk, rows, errors,
                                       &scratch);
        }
        *out_seconds = rad_clock_seconds() - t0;
        p->calibrating = 0;
        if (st != RAD_OK) *out_failed = "its rows failed";
    } else {
        *out_failed = "out of memory for its rows";
    }
    if (rows) ff_row_buffer_free(backend, in->backend_state, (size_t)chunk * n, rows);
    if (errors) ff_row_buffer_free(backend, in->backend_state, (size_t)chunk * n, errors);
}

rad_status ff_progress_estimate(ff_progress *p, const ff_estimate_inputs *in)
{
    uint32_t n = p->patch_count;
    const ff_plan *plan = in->plan;
    int ranks = ff_comm_size(p->comm);
    double seconds = -1, calibration = 0;
    uint32_t chunk = calibration_chunk(n), rows = calibration_chunks(n) * chunk;
    const char *failed = NULL; /* why a calibrated run has no time */
    if (n >= FF_CALIBRATION_MIN) {
        calibrate(p, in, chunk, &calibration, &failed);
        if (!failed) seconds = calibration * (busiest_rows(p, plan) / rows);
    }
    char bytes[32], memory[32], time[32], took[32];
    /* The sparse format's size is known once written: the dense size bounds it. */
    const char *bound = in->options->format == FF_FORMAT_SPARSE ? "at most " : "";
    if (seconds >= 0)
        rad_info("estimate: %s%s to write, about %s of memory per rank, about %s of form factors on %d rank(s) "
                 "(calibrated on %u of %u rows in %s)",
                 bound, ff_progress_format_bytes(plan->file_bytes, bytes, sizeof bytes),
                 ff_progress_format_bytes(plan->memory_bytes, memory, sizeof memory),
                 ff_progress_format_seconds(seconds, time, sizeof time), ranks, rows, n,
                 ff_progress_format_seconds(calibration, took, sizeof took));
    else if (failed)
        rad_info("estimate: %s%s to write, about %s of memory per rank, time of form factors unknown (the "
                 "calibration on %u of %u rows could not run: %s)", bound,
                 ff_progress_format_bytes(plan->file_bytes, bytes, sizeof bytes),
                 ff_progress_format_bytes(plan->memory_bytes, memory, sizeof memory), rows,
                 n, failed);
    else
        rad_info("estimate: %s%s to write, about %s of memory per rank, seconds of form factors (under %d "
                 "patches: not calibrated)", bound,
                 ff_progress_format_bytes(plan->file_bytes, bytes, sizeof bytes),
                 ff_progress_format_bytes(plan->memory_bytes, memory, sizeof memory), FF_CALIBRATION_MIN);
    p->estimated_seconds = seconds;
    p->every = seconds / 40 > 2.0 ? seconds / 40 : 2.0;
    if (p->tty) p->every = 0.5;
    if (p->every_override > 0) p->every = p->every_override; /* tests ask for lines at a cadence of their own */
    double limit = in->options->max_seconds;
    if (limit > 0 && failed) {
        rad_error("--max-seconds %g: the run's time is unknown (its calibration could not run: %s); refused "
                  "(drop --max-seconds to run it anyway)", limit, failed);
        return RAD_ERR_USAGE;
    }
    if (limit > 0 && seconds > limit) {
        char limit_text[32];
        rad_error("--max-seconds %g: the run is estimated at about %s of form factors on %d rank(s), more than %s; "
                  "refused before writing anything (more ranks or GPUs, a lower --subdiv, fewer --shadow-rays, or a "
                  "larger --max-seconds)", limit, ff_progress_format_seconds(seconds, time, sizeof time), ranks,
                  ff_progress_format_seconds(limit, limit_text, sizeof limit_text));
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}
