/* ff_plan.c - limits and choices to decisions (ff_plan.h); no I/O. */
#include "ff_plan.h"

#include <math.h>

#include "rad_ff_kernel.h"
#include "rad_mesh.h"

/* a * b, or SIZE_MAX where that does not fit (an allocation that fails). */
static size_t product_or_max(uint64_t a, uint64_t b)
{
    return b != 0 && a > SIZE_MAX / b ? SIZE_MAX : (size_t)(a * b);
}

/* Rows per round: round_bytes of doubles, at least 16 rows, at most
 * what one write carries. */
static uint32_t rows_per_round(uint64_t n, uint64_t round_bytes, uint32_t max_rows_per_write)
{
    uint64_t by_memory = round_bytes / (sizeof(double) * (n ? n : 1));
    if (by_memory < 16) by_memory = 16;
    if (by_memory > UINT32_MAX) by_memory = UINT32_MAX;
    return max_rows_per_write && max_rows_per_write < by_memory ? max_rows_per_write : (uint32_t)by_memory;
}

/* Streamed: the rows of rank `rank` when blocks of `per_round` rows of
 * N = n go to the ranks in turn (ff_plan.h). */
static uint64_t cyclic_rank_rows(uint64_t n, uint64_t per_round, uint64_t ranks, uint64_t rank)
{
    uint64_t blocks = (n + per_round - 1) / per_round;
    if (rank >= blocks) return 0;
    uint64_t rows = (blocks - rank + ranks - 1) / ranks * per_round;
    if ((blocks - 1) % ranks == rank) rows -= blocks * per_round - n; /* the last block is short */
    return rows;
}

/* Which rows this rank computes, round by round (ff_plan.h); `rank_rows`
 * and `most_rows` are the split's where the rank holds its block. */
static void plan_rows(const ff_plan_limits *limits, uint64_t rank_rows, uint64_t most_rows, ff_plan *plan)
{
    uint64_t n = limits->patch_count, ranks = (uint64_t)plan->ranks, rank = (uint64_t)plan->rank;
    uint64_t per_round = plan->rows_per_round;
    if (!plan->blocks) {
        uint64_t share = (n + ranks - 1) / ranks; /* every rank a block where N >= P */
        if (share > 0 && share < per_round) per_round = plan->rows_per_round = (uint32_t)share;
        /* Several ranks: at least FF_CYCLIC_MIN_ROUNDS blocks each, so that
         * each rank's rows spread over the matrix and costly rows (near
         * pairs, occluded ones) fall to every rank alike; not below 16
         * rows a block. The bytes do not depend on the block size. */
        uint64_t spread = (n + ranks * FF_CYCLIC_MIN_ROUNDS - 1) / (ranks * FF_CYCLIC_MIN_ROUNDS);
        if (spread < 16) spread = 16;
        if (ranks > 1 && spread < per_round) per_round = plan->rows_per_round = (uint32_t)spread;
        uint64_t blocks = (n + per_round - 1) / per_round;
        plan->rounds = (blocks + ranks - 1) / ranks;
        rank_rows = cyclic_rank_rows(n, per_round, ranks, rank);
        most_rows = cyclic_rank_rows(n, per_round, ranks, 0);
        for (uint64_t r = 1; r < ranks && r < blocks; r++) {
            uint64_t rows = cyclic_rank_rows(n, per_round, ranks, r);
            if (rows > most_rows) most_rows = rows;
        }
    } else {
        plan->rounds = (most_rows + per_round - 1) / per_round;
    }
    uint64_t even = (n + ranks - 1) / ranks, begin = even * rank < n ? even * rank : n;
    uint64_t end = begin + even < n ? begin + even : n;
    if (limits->row_begin) begin = limits->row_begin[limits->rank], end = limits->row_begin[limits->rank + 1];
    plan->block_begin = (uint32_t)(begin < UINT32_MAX ? begin : UINT32_MAX);
    plan->block_end = (uint32_t)(end < UINT32_MAX ? end : UINT32_MAX);
    plan->rank_rows = (uint32_t)(rank_rows < UINT32_MAX ? rank_rows : UINT32_MAX);
    plan->most_rows = (uint32_t)(most_rows < UINT32_MAX ? most_rows : UINT32_MAX);
}

/* The program itself, in every rank's memory: code, libraries (Embree,
 * OpenMP) and what they allocate at start (resident: 7.7 MiB for
 * formfactor --version, 8.2 MiB for a 6-patch run; x86-64, CPU build). */
#define FF_PLAN_PROCESS_BYTES (8.0 * 1024 * 1024)

/* The outputs' size and the memory per rank (ff_plan.h says what counts). */
static void plan_sizes(const ff_plan_limits *limits, const ff_plan_choices *choices, ff_plan *plan)
{
    double dn = (double)limits->patch_count;
    double element = plan->element_bytes;
    double tables = RAD_FF_HEADER_BYTES + dn * (sizeof(rad_patch) + 24 + 8);
    plan->file_bytes = tables + dn * dn * element + (choices->errors_file ? tables + dn * dn * 4 : 0);
    /* A round here is capped at N rows; the rounds themselves are not
     * (rows_per_round): an estimate of what is touched, not allocated. */
    double round_rows = fmax(16, fmin(dn, (double)FF_ROUND_BYTES / (8 * fmax(dn, 1))));
    if (choices->reciprocity == FF_RECIPROCITY_ON) round_rows = fmax(round_rows, ceil(dn / fmax(limits->ranks, 1)));
    int errors = choices->standard_errors != 0;
    plan->memory_bytes = FF_PLAN_PROCESS_BYTES + dn * (2 * sizeof(rad_patch) + 2 * 24 + sizeof(rad_ff_patch) + 16) +
                         round_rows * dn * ((8 + element) + errors * (8 + 4));
}

/* Each pair once (pairs_once): the rank's block of rows stays in memory as
 * doubles, values and (standard_errors) errors, until it is written; the
 * write converts through small buffers. From an even split, like
 * plan_sizes. Before this the estimate counted one round of rows, not the
 * block: 341 MiB said, 1.5 GB used at N = 9723 (issue 30). */
static void plan_block_memory(const ff_plan_limits *limits, const ff_plan_choices *choices, ff_plan *plan)
{
    double dn = (double)limits->patch_count;
    double block_rows = ceil(dn / fmax(limits->ranks, 1));
    int errors = choices->standard_errors != 0;
    plan->memory_bytes = FF_PLAN_PROCESS_BYTES + dn * (2 * sizeof(rad_patch) + 2 * 24 + sizeof(rad_ff_patch) + 16) +
                         block_rows * dn * (8 + errors * 8);
}

static ff_plan_refusal refusal_of(const ff_plan_limits *limits, const ff_plan_choices *choices, const ff_plan *plan)
{
    if (limits->patch_count > FF_MAX_PATCHES) return FF_PLAN_TOO_MANY_PATCHES;
    /* A sparse file's size is known once written: file_bytes, the dense
     * size, only bounds it, so the disk refuses it only when the bound is
     * far beyond the free space (between, the driver warns; a full disk
     * fails the write, which removes the file). */
    if (choices->format != FF_FORMAT_SPARSE && plan->file_bytes > limits->free_bytes) return FF_PLAN_DISK;
    if (choices->format == FF_FORMAT_SPARSE && !choices->allow_disk_overcommit &&
        plan->file_bytes > FF_PLAN_SPARSE_OVERCOMMIT * limits->free_bytes)
        return FF_PLAN_DISK;
    if (choices->max_bytes > 0 && plan->file_bytes > choices->max_bytes) return FF_PLAN_MAX_BYTES;
    if (plan->memory_bytes > limits->memory_per_rank) return FF_PLAN_MEMORY;
    return FF_PLAN_ACCEPTED;
}

void ff_plan_make(const ff_plan_limits *limits, const ff_plan_choices *choices, ff_plan *out_plan)
{
    ff_plan plan = {0};
    uint64_t n = limits->patch_count;
    int ranks = limits->ranks > 0 ? limits->ranks : 1;
    plan.element_bytes = choices->format == FF_FORMAT_PAPER || choices->element == RAD_ELEMENT_F64 ? 8 : 4;
    plan_sizes(limits, choices, &plan);
    plan.refusal = refusal_of(limits, choices, &plan);
    plan.gpu = choices->backend == FF_BACKEND_CUDA || (choices->backend == FF_BACKEND_AUTO && limits->gpus_visible > 0);

    /* This rank's block of the split and the largest; before the split, an even share. */
    uint64_t even = (n + (uint64_t)ranks - 1) / (uint64_t)ranks, rank_rows = even, most_rows = even;
    if (limits->row_begin) {
        rank_rows = limits->row_begin[limits->rank + 1] - limits->row_begin[limits->rank];
        most_rows = 0;
        for (int r = 0; r < ranks; r++) {
            uint64_t rows = limits->row_begin[r + 1] - limits->row_begin[r];
            if (rows > most_rows) most_rows = rows;
        }
    }

    double rows_bytes = (double)rank_rows * (double)n * (double)sizeof(double);
    double block_bytes = (1 + (choices->standard_errors != 0)) * rows_bytes; /* values and errors */
    /* On the GPU a sparse file streams: its rounds are finished on the
     * device and only their records come back (device_records), which
     * beats computing half the pairs and mirroring them on the host at
     * any size (N = 2944 on an H100: 0.32 against 0.48 s). */
    int block_fits = !(block_bytes > limits->memory_per_rank / 4) &&
                     !(plan.gpu && rows_bytes > (double)FF_BACKEND_BUFFER_MAX) &&
                     !(plan.gpu && choices->format == FF_FORMAT_SPARSE);
    plan.pairs_once = choices->reciprocity == FF_RECIPROCITY_ON || (choices->reciprocity == FF_RECIPROCITY_AUTO && block_fits);

    if (plan.pairs_once) plan_block_memory(limits, choices, &plan);
    plan.device_records = plan.gpu && !plan.pairs_once && choices->format == FF_FORMAT_SPARSE;
    plan.rows_per_round = rows_per_round(n, plan.device_records ? FF_DEVICE_ROUND_BYTES : FF_ROUND_BYTES,
                                         limits->max_rows_per_write);
    plan.blocks = plan.pairs_once || choices->held;
    plan.patch_count = n;
    plan.ranks = ranks;
    plan.rank = limits->rank;
    plan_rows(limits, rank_rows, most_rows, &plan);
    plan.buffer_doubles = plan.device_records ? 1 : product_or_max(plan.pairs_once ? rank_rows : plan.rows_per_round, n);
    if (plan.buffer_doubles == 0) plan.buffer_doubles = 1;
    *out_plan = plan;
}

uint32_t ff_plan_round_rows(const ff_plan *plan, uint64_t round, uint32_t *out_first)
{
    uint64_t per_round = plan->rows_per_round, first, end;
    if (plan->blocks) {
        first = plan->block_begin + round * per_round;
        end = plan->block_end;
    } else {
        first = (round * (uint64_t)plan->ranks + (uint64_t)plan->rank) * per_round;
        end = plan->patch_count;
    }
    if (first > end) first = end;
    if (end - first < per_round) per_round = end - first;
    *out_first = (uint32_t)first;
    return (uint32_t)per_round;
}

ff_plan_choices ff_plan_choices_of(const ff_options *o)
{
    return (ff_plan_choices){.element = o->element, .format = o->format, .errors_file = o->errors_path != NULL,
                             .standard_errors = !o->no_errors, .reciprocity = o->reciprocity,
                             .backend = o->backend, .max_bytes = o->max_bytes,
                             .allow_disk_overcommit = o->allow_disk_overcommit, .held = o->radiosity_path != NULL};
}
