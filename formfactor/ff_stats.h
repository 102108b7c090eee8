/* ff_stats.h - what one formfactor run did and how long each phase took,
 * per rank and overall, as JSON (--stats) and as a summary on stderr. */
#ifndef FF_STATS_H
#define FF_STATS_H

#include <stdint.h>

#include "ff_backend.h"
#include "ff_rows.h"
#include "rad_refine.h"
#include "rad_status.h"

/* The paper's phases, wall-clock seconds on one rank. */
typedef struct ff_rank_stats {
    int32_t rank;
    int32_t threads;
    uint32_t row_count; /* rows this rank computed */
    /* Which (ff_plan.h): with block_size 0 (pairs_once) its block of the
     * split [row_begin, row_end); else (streamed) blocks of block_size
     * rows, the first at row_begin, one every block_stride rows, the last
     * cut at row_end = N. */
    uint32_t row_begin, row_end, block_size;
    uint64_t block_stride;
    double load, subdivide, setup, form_factors, visibility, io, total;
    double mirror;     /* --reciprocity on: copying entries between rows and ranks */
    double gpu_memory; /* CUDA: allocation + transfers (form_factors is then the GPU kernel) */
    double cuda_start; /* waiting for CUDA's driver and context (what ff_cuda_prestart did not hide) */
    double estimate;   /* the estimate line's calibration (rank 0) */
    /* The output's bytes, written in the background (ff_writer.h): the
     * seconds its writes were in flight, mostly behind the computation
     * (io is what the rank waited for them, with the encoding), how many
     * bytes, and whether through a mapping (1) or pwrite (0). */
    double write;
    uint64_t write_bytes;
    int32_t write_mapped;
    ff_counters counters;
    ff_rows_summary rows; /* row sums and standard errors of this rank's rows */
} ff_rank_stats;

typedef struct ff_run_info {
    const char *scene;
    uint64_t fingerprint;
    uint32_t patch_count;
    int subdiv;
    const char *subdiv_only;
    const char *contacts; /* "cut" or "keep" (--contacts) */
    uint32_t samples, shadow_rays;
    uint64_t seed;
    const char *estimator;
    const char *cull;
    const char *reciprocity; /* "on" (each pair once) or "off" (both entries computed) */
    double target_error;     /* 0 = none */
    int errors;              /* standard errors were estimated */
    uint32_t max_samples;
    const char *backend;
    const char *element;
    const char *format;
    const char *output;
    int held;                /* --radiosity: the rows went into the solve's matrix, not to a file */
    int ranks;
    int gpus_visible;
    const char *refine_from;      /* --refine RADIOSITY, or NULL */
    double refine_tol;
    const rad_refine_stats *refine;
    size_t refine_patches_before;
} ff_run_info;

/* Writes the JSON document (temp + rename). `ranks` has run->ranks entries. */
rad_status ff_stats_write_json(const char *path, const ff_run_info *run, const ff_rank_stats *ranks);
/* One line per phase on stderr (rank 0): the paper's table for this run. */
void ff_stats_log_summary(const ff_run_info *run, const ff_rank_stats *ranks);

#endif
