/* ff_plan.h - what a formfactor run will do, decided before it does it.
 *
 * A pure function from the limits (the scene's size, the ranks and their
 * rows, the memory, the disk, the GPUs) and the user's choices (element
 * type, format, --errors, --reciprocity, --backend, --max-bytes) to the
 * decisions: refuse or not, and why; which backend; each unordered pair
 * once or both entries; rows per round and rounds; the size of the row
 * buffers. No MPI, no I/O, no globals: the driver (ff_driver.c) measures
 * the limits, makes the ranks agree and acts on the plan;
 * tests/test_plan.c checks it on made-up machines.
 *
 *     ff_plan_limits limits = {.patch_count = n, .ranks = 4, .rank = r, .row_begin = split,
 *                              .memory_per_rank = 16e9, .free_bytes = INFINITY};
 *     ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .standard_errors = 1};
 *     ff_plan plan;
 *     ff_plan_make(&limits, &choices, &plan);
 *
 * The driver plans twice: on rank 0 before the mesh is built (row_begin
 * NULL), to refuse a run too large for the format, the disk, --max-bytes or
 * the memory before any work; and on every rank once the rows are split,
 * for everything else. Sizes are doubles: refused runs overflow 64 bits.
 */
#ifndef FF_PLAN_H
#define FF_PLAN_H

#include <stddef.h>
#include <stdint.h>

#include "ff_options.h"
#include "ff_output.h"
#include "rad_ffile.h"

/* Largest N: the paper format stores N as int32, the mesh indexes patches
 * with uint32 (RAD_NO_VERTEX taken), the reader accepts up to 2^31. */
#define FF_MAX_PATCHES ((uint64_t)INT32_MAX)
/* Rows computed between writes: about this many bytes of
 * doubles (at least 16 rows, at most max_rows_per_write). Big
 * enough that a GPU launch fills the device (N = 2944 is one round), small
 * enough that a streamed run's memory stays O(N), not O(N^2). */
#define FF_ROUND_BYTES ((uint64_t)96 << 20)
/* The same where the GPU streams rows into a sparse file: the rows stay on
 * the device and only their records come back (compute_records), so a
 * round can be larger - fewer launches, copies and writes
 * (N = 47 104: 1425 rows, capped by one write, instead of 267). */
#define FF_DEVICE_ROUND_BYTES ((uint64_t)1 << 30)
/* Streamed rows on several ranks go out in blocks, in turn (rank 0's
 * block, rank 1's, ...: the file in row order); at least this many blocks
 * per rank, for balance (ff_plan.c). */
#define FF_CYCLIC_MIN_ROUNDS 8u
/* Buffers up to this size come from the backend (page-locked for CUDA, so
 * results stream back by DMA); larger ones - a whole rank's rows with
 * --reciprocity on - from malloc. */
#define FF_BACKEND_BUFFER_MAX ((size_t)1 << 30)

/* What the machine and the scene allow. */
typedef struct ff_plan_limits {
    uint64_t patch_count;     /* N (rad_mesh_count_patches); may exceed FF_MAX_PATCHES: then refused */
    int ranks;                /* all ranks, >= 1 */
    int rank;                 /* this one, in [0, ranks) */
    /* The split of rows among ranks (ff_partition_rows): ranks + 1 entries,
     * rank r owns [row_begin[r], row_begin[r + 1]) where it holds them
     * all (pairs_once; streamed rounds take rows block-cyclically: see
     * rows_per_round). NULL before the mesh is built: an even split is
     * assumed. */
    const uint32_t *row_begin;
    double memory_per_rank;   /* bytes: this node's physical memory / ranks on it; INFINITY = unknown */
    double free_bytes;        /* bytes free on the output's file system; INFINITY = unknown */
    int gpus_visible;         /* CUDA devices this process sees (0 when not asked: --backend cpu) */
    uint32_t max_rows_per_write; /* rows one write carries (ff_output_max_rows); 0 = no cap */
} ff_plan_limits;

/* What the user asked for (ff_options.h); zero = the defaults but element. */
typedef struct ff_plan_choices {
    rad_element_type element;  /* --element */
    ff_format format;          /* --format (paper stores float64) */
    int errors_file;           /* --errors: a float32 file of the same layout beside the matrix */
    int standard_errors;       /* not --no-errors: an errors buffer beside each row buffer */
    ff_reciprocity reciprocity;
    ff_backend_choice backend;
    double max_bytes;          /* --max-bytes: refuse larger outputs; 0 = no limit */
    int allow_disk_overcommit; /* --allow-disk-overcommit: no FF_PLAN_DISK for a sparse file */
    int held;                  /* --radiosity: the matrix is held in memory and solved there (blocks) */
} ff_plan_choices;

/* A sparse file whose bound (file_bytes) is more than this many times the
 * free space is refused (FF_PLAN_DISK) unless allow_disk_overcommit: most
 * scenes' sparse files are about a tenth of their bound. */
#define FF_PLAN_SPARSE_OVERCOMMIT 10.0

/* Why a run is refused: the first that applies, in this order. */
typedef enum ff_plan_refusal {
    FF_PLAN_ACCEPTED = 0,
    FF_PLAN_TOO_MANY_PATCHES, /* N > FF_MAX_PATCHES */
    FF_PLAN_DISK,             /* file_bytes > free_bytes; sparse (file_bytes bounds it): file_bytes >
                                 FF_PLAN_SPARSE_OVERCOMMIT x free_bytes, unless allow_disk_overcommit */
    FF_PLAN_MAX_BYTES,        /* file_bytes > --max-bytes (sparse: its bound) */
    FF_PLAN_MEMORY            /* memory_bytes > memory_per_rank */
} ff_plan_refusal;

typedef struct ff_plan {
    ff_plan_refusal refusal;
    double element_bytes; /* one stored matrix entry: 8 (f64, or the paper format) or 4 */
    /* The outputs: header, vertex and patch tables, matrix, row checksums;
     * and the --errors file beside them (float32; assumed on the same file
     * system). */
    double file_bytes;
    /* Per rank, from an even split (so the same before and after it): the
     * program itself (code and libraries, FF_PLAN_PROCESS_BYTES), the
     * mesh and its vertex bound, kernel patches, the prologue (rank 0),
     * checksums, and a round of rows as double plus its stored copy, for
     * the values and (standard_errors) their errors; with each pair
     * computed once (pairs_once: --reciprocity on, or auto where it fits
     * in a quarter of the memory), the rank's whole block of rows as
     * doubles, values and errors, instead of a round (the refusal is
     * judged before, on the streamed plan: auto picks the block only
     * where it fits). */
    double memory_bytes;
    int gpu;              /* the CUDA backend: --backend cuda, or auto with a GPU visible */
    /* Each unordered pair computed once, the other entry copied
     * (A_i F_ij = A_j F_ji): --reciprocity on, or auto when the rank's
     * block of rows (values and errors) takes at most a quarter of its
     * memory and, on the GPU, the format is not sparse (a sparse file
     * streams there: device_records) and its values at most FF_BACKEND_BUFFER_MAX
     * (beyond the page-locked limit rows come back by pageable copies,
     * slower than the kernels saved; docs/performance.md). Ranks must
     * agree: where one rank's plan streams, all must (the driver then plans
     * again with FF_RECIPROCITY_OFF). */
    int pairs_once;
    /* Streamed rounds of a sparse file on the GPU come back finished and
     * encoded (the backend's compute_records; the driver falls back to
     * finishing on the CPU where the backend has none): rounds of
     * FF_DEVICE_ROUND_BYTES, and no row buffers on the host. */
    int device_records;
    /* Rows a rank computes between writes, and (every rank
     * joins every round's write) the rounds, the same on every rank.
     * Which rows a round holds (ff_plan_round_rows):
     *   pairs_once: the rank's block of the split [block_begin, block_end),
     *     rows_per_round at a time (the records are placed in row order by
     *     ff_output_reserve); rounds: those of the largest block;
     *   streamed: blocks of rows_per_round taken in turn by the ranks
     *     (block-cyclic) - round k of rank r holds rows
     *     [(k P + r) R, min((k P + r + 1) R, N)), empty past N - so that
     *     each round's writes append rank 0's block, rank 1's, ...: the
     *     sparse file's records in row order, the same bytes for any rank
     *     count; rounds = ceil(ceil(N / R) / P). R is also at most
     *     ceil(N / P) there, so that every rank has rows where N >= P
     *     (the bytes do not depend on R: the records lie in row order). */
    uint32_t rows_per_round;
    uint64_t rounds;
    /* Each rank's rows one block, the split's, rows_per_round at a time:
     * with pairs_once, and for a matrix handed to the solve in memory
     * (choices.held), which takes the ranks' contiguous row blocks; else
     * block-cyclic (below). */
    int blocks;
    uint32_t block_begin, block_end; /* pairs_once: this rank's block of the split (an even share before it) */
    uint32_t rank_rows;              /* rows this rank computes in all */
    uint32_t most_rows;              /* ... and the busiest rank */
    uint64_t patch_count;            /* the limits' N, ranks and rank, for ff_plan_round_rows */
    int ranks, rank;
    /* Doubles in each row buffer (values; errors too when standard_errors):
     * a round's rows streamed, the rank's whole block with pairs_once;
     * at least 1. */
    size_t buffer_doubles;
} ff_plan;

/* The choices the options make (--element, --format, --errors, --no-errors,
 * --reciprocity, --backend, --max-bytes, --allow-disk-overcommit). */
ff_plan_choices ff_plan_choices_of(const ff_options *options);

void ff_plan_make(const ff_plan_limits *limits, const ff_plan_choices *choices, ff_plan *out_plan);
/* Round `round` of this rank's rows (rows_per_round says which):
 * returns its row count, 0 where the rank has no rows left, and sets
 * *out_first to its first row (N then). For an accepted plan (N fits in
 * uint32). */
uint32_t ff_plan_round_rows(const ff_plan *plan, uint64_t round, uint32_t *out_first);

#endif
