/* test_plan.c - formfactor's plan (ff_plan.h) on made-up machines: no
 * MPI, no files, no scene; built from ff_plan.c alone.
 *
 *   a small scene: accepted, each pair once, one round holding every row
 *   a memory-limited run: auto streams, 267 rows per round (96 MiB of
 *     doubles at N = 47104), 45 rounds for a quarter of the rows; with
 *     more memory the block is kept; on the GPU a block beyond 1 GiB streams
 *   refusals: --max-bytes, the disk before it, the format's patch limit,
 *     the memory with --reciprocity on
 *   edges: one patch, more ranks than rows, a write cap below 16 rows
 *   the plan before the split (rank 0, before the mesh) and after it
 *     agree on the sizes the estimate line prints
 *   the rows of each round: streamed, blocks taken in turn by 1, 2 and 3
 *     ranks, so that every round's write is in row order; with pairs_once
 *     the rank's block of the split
 */
#include <math.h>
#include <stdio.h>

#include "ff_plan.h"
#include "rad_test.h"

#define GiB (1024.0 * 1024.0 * 1024.0)

static ff_plan make(const ff_plan_limits *limits, const ff_plan_choices *choices)
{
    ff_plan plan;
    ff_plan_make(limits, choices, &plan);
    return plan;
}

/* The file: a 256-byte header, per patch its 128-byte record, a vertex
 * bound (24 bytes) and a row checksum (8), and the N x N matrix. */
static double file_bytes(double n, double element)
{
    return 256 + n * (128 + 24 + 8) + n * n * element;
}

static void small_scene(void)
{
    /* The built-in Cornell box: 20 patches, one rank; "6.5 KiB to write". */
    ff_plan_limits limits = {.patch_count = 20, .ranks = 1, .row_begin = (const uint32_t[]){0, 20},
                             .memory_per_rank = 8 * GiB, .free_bytes = INFINITY};
    ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .standard_errors = 1};
    ff_plan p = make(&limits, &choices);
    RAD_CHECK(p.refusal == FF_PLAN_ACCEPTED);
    RAD_CHECK(p.element_bytes == 8);
    RAD_CHECK(p.file_bytes == 6656 && p.file_bytes == file_bytes(20, 8));
    RAD_CHECK(p.gpu == 0);
    RAD_CHECK(p.pairs_once == 1);
    RAD_CHECK(p.rows_per_round == (96u << 20) / (8 * 20)); /* FF_ROUND_BYTES of doubles */
    RAD_CHECK(p.rounds == 1);
    RAD_CHECK(p.buffer_doubles == 20 * 20); /* the whole block */

    /* --errors adds a float32 file of the same layout. */
    choices.errors_file = 1;
    ff_plan e = make(&limits, &choices);
    RAD_CHECK(e.file_bytes == file_bytes(20, 8) + file_bytes(20, 4));
    /* --no-errors: no errors block, 8 bytes less per entry of the block (its double). */
    choices.standard_errors = 0;
    ff_plan q = make(&limits, &choices);
    RAD_CHECK_NEAR(p.memory_bytes - q.memory_bytes, 20 * 20 * 8, 1e-9);
    /* --element f32 halves the matrix; the paper format stores float64 anyway. */
    choices = (ff_plan_choices){.element = RAD_ELEMENT_F32, .standard_errors = 1};
    RAD_CHECK(make(&limits, &choices).file_bytes == file_bytes(20, 4));
    choices.format = FF_FORMAT_PAPER;
    RAD_CHECK(make(&limits, &choices).element_bytes == 8);
    /* --reciprocity off: the rows stream, the buffer holds one round. */
    choices = (ff_plan_choices){.element = RAD_ELEMENT_F64, .standard_errors = 1, .reciprocity = FF_RECIPROCITY_OFF};
    ff_plan s = make(&limits, &choices);
    RAD_CHECK(s.pairs_once == 0);
    RAD_CHECK(s.rounds == 1);
    RAD_CHECK(s.buffer_doubles == (size_t)s.rows_per_round * 20);
}

static void memory_limited(void)
{
    /* N = 47104 on 4 ranks of 16 GiB each: a rank's block of values and
     * errors is 11776 x 47104 x 16 bytes = 8.3 GiB, over a quarter of its
     * memory, so auto streams. */
    const uint32_t split[] = {0, 11776, 23552, 35328, 47104};
    ff_plan_limits limits = {.patch_count = 47104, .ranks = 4, .rank = 1, .row_begin = split,
                             .memory_per_rank = 16 * GiB, .free_bytes = INFINITY};
    ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .standard_errors = 1};
    ff_plan p = make(&limits, &choices);
    RAD_CHECK(p.refusal == FF_PLAN_ACCEPTED);
    RAD_CHECK(p.pairs_once == 0);
    RAD_CHECK(p.rows_per_round == 267);          /* floor(96 MiB / (8 x 47104)) */
    RAD_CHECK(p.rounds == 45);                   /* ceil(11776 / 267) */
    RAD_CHECK(p.buffer_doubles == (size_t)267 * 47104);
    /* Without standard errors the block (4.1 GiB) fits in a quarter of 32 GiB, with them not. */
    limits.memory_per_rank = 32 * GiB;
    RAD_CHECK(make(&limits, &choices).pairs_once == 0);
    choices.standard_errors = 0;
    RAD_CHECK(make(&limits, &choices).pairs_once == 1);
    /* With 64 GiB per rank the block is kept: one buffer for the rank's rows. */
    choices.standard_errors = 1;
    limits.memory_per_rank = 64 * GiB;
    ff_plan once = make(&limits, &choices);
    RAD_CHECK(once.pairs_once == 1);
    RAD_CHECK(once.rows_per_round == 267 && once.rounds == 45); /* computed and written in the same rounds */
    RAD_CHECK(once.buffer_doubles == (size_t)11776 * 47104);
    /* On the GPU a block beyond the page-locked limit streams. */
    choices.backend = FF_BACKEND_CUDA;
    RAD_CHECK(make(&limits, &choices).pairs_once == 0);
    choices.backend = FF_BACKEND_AUTO;
    limits.gpus_visible = 1;
    ff_plan gpu = make(&limits, &choices);
    RAD_CHECK(gpu.gpu == 1 && gpu.pairs_once == 0);
    /* ... and its rounds come back as records (the sparse default):
     * FF_DEVICE_ROUND_BYTES of doubles, 2849 rows, capped by one write;
     * no row buffers on the host. Dense files come back as rows. */
    RAD_CHECK(gpu.device_records == 1 && gpu.buffer_doubles == 1);
    /* 1 GiB of doubles is 2849 rows; 4 ranks take blocks of ceil(47104 / 32) = 1472 in turn, 8 each */
    RAD_CHECK(gpu.rows_per_round == 1472 && gpu.rounds == 8);
    limits.max_rows_per_write = 1425;
    RAD_CHECK(make(&limits, &choices).rows_per_round == 1425);
    limits.max_rows_per_write = 0;
    choices.format = FF_FORMAT_DENSE;
    ff_plan dense = make(&limits, &choices);
    RAD_CHECK(dense.device_records == 0 && dense.rows_per_round == 267 && dense.buffer_doubles == (size_t)267 * 47104);
    choices.format = FF_FORMAT_SPARSE;
    /* --reciprocity on and off are obeyed, whatever the memory. */
    choices.reciprocity = FF_RECIPROCITY_ON;
    RAD_CHECK(make(&limits, &choices).pairs_once == 1);
    RAD_CHECK(make(&limits, &choices).device_records == 0); /* the mirror needs the rows */
    limits.gpus_visible = 0;
    choices.reciprocity = FF_RECIPROCITY_OFF;
    RAD_CHECK(make(&limits, &choices).pairs_once == 0);
    /* One collective write takes 712 float64 rows here (256 MiB): not the limit. */
    limits.max_rows_per_write = 712;
    RAD_CHECK(make(&limits, &choices).rows_per_round == 267);
}

static void backend_choice(void)
{
    ff_plan_limits limits = {.patch_count = 20, .ranks = 1, .memory_per_rank = INFINITY, .free_bytes = INFINITY};
    ff_plan_choices choices = {.element = RAD_ELEMENT_F64};
    RAD_CHECK(make(&limits, &choices).gpu == 0); /* auto, no GPU */
    limits.gpus_visible = 2;
    RAD_CHECK(make(&limits, &choices).gpu == 1); /* auto, GPUs */
    choices.backend = FF_BACKEND_CPU;
    RAD_CHECK(make(&limits, &choices).gpu == 0);
    limits.gpus_visible = 0;
    choices.backend = FF_BACKEND_CUDA;
    RAD_CHECK(make(&limits, &choices).gpu == 1); /* asked for: the backend then says there is none */
}

static void refusals(void)
{
    /* cornell_sphere --subdiv 3: N = 2944, 66.6 MiB (tests/long_runs.sh). */
    ff_plan_limits limits = {.patch_count = 2944, .ranks = 1, .memory_per_rank = 8 * GiB, .free_bytes = INFINITY};
    ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .standard_errors = 1, .max_bytes = 10e6};
    ff_plan p = make(&limits, &choices);
    RAD_CHECK(p.file_bytes == 69808384 && p.file_bytes == file_bytes(2944, 8));
    RAD_CHECK(p.refusal == FF_PLAN_MAX_BYTES);
    choices.max_bytes = 67.0 * 1024 * 1024;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_ACCEPTED);
    choices.max_bytes = 69808384; /* exactly the size: allowed */
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_ACCEPTED);
    choices.element = RAD_ELEMENT_F32; /* halves the file */
    choices.max_bytes = 40e6;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_ACCEPTED);
    /* The disk is checked before --max-bytes, for the dense formats; the
     * sparse file's size is only bounded, so the disk does not refuse it. */
    choices = (ff_plan_choices){.element = RAD_ELEMENT_F64, .format = FF_FORMAT_DENSE, .max_bytes = 10e6};
    limits.free_bytes = 50e6;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_DISK);
    choices.format = FF_FORMAT_SPARSE;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_MAX_BYTES);
    choices.max_bytes = 0;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_ACCEPTED);
    /* ... unless its bound is more than FF_PLAN_SPARSE_OVERCOMMIT times the
     * free space (69.8 MB against 6.9 MB: 10.1x), which
     * --allow-disk-overcommit lets through. */
    limits.free_bytes = 6.9e6;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_DISK);
    limits.free_bytes = 7.0e6; /* 9.97x */
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_ACCEPTED);
    limits.free_bytes = 6.9e6;
    choices.allow_disk_overcommit = 1;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_ACCEPTED);
    limits.free_bytes = 50e6;
    choices = (ff_plan_choices){.element = RAD_ELEMENT_F64, .format = FF_FORMAT_DENSE, .max_bytes = 10e6};
    /* The format's limit before everything. */
    limits.patch_count = (uint64_t)1 << 31;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_TOO_MANY_PATCHES);
    limits.patch_count = FF_MAX_PATCHES;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_DISK);
    /* cluttered_room --subdiv 4 --reciprocity on on one rank of 23.5 GiB:
     * the whole block in memory (about 60 GiB); auto would stream. */
    limits = (ff_plan_limits){.patch_count = 47872, .ranks = 1, .memory_per_rank = 23.5 * GiB,
                              .free_bytes = 100 * GiB};
    choices = (ff_plan_choices){.element = RAD_ELEMENT_F64, .standard_errors = 1,
                                .reciprocity = FF_RECIPROCITY_ON};
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_MEMORY);
    choices.reciprocity = FF_RECIPROCITY_AUTO;
    ff_plan a = make(&limits, &choices);
    RAD_CHECK(a.refusal == FF_PLAN_ACCEPTED);
    RAD_CHECK(a.pairs_once == 0);
    /* Unknown memory and disk (INFINITY) refuse nothing. */
    limits.memory_per_rank = limits.free_bytes = INFINITY;
    choices.reciprocity = FF_RECIPROCITY_ON;
    RAD_CHECK(make(&limits, &choices).refusal == FF_PLAN_ACCEPTED);
}

static void edges(void)
{
    /* One patch: "424 bytes to write", one round of one row. */
    ff_plan_limits limits = {.patch_count = 1, .ranks = 1, .row_begin = (const uint32_t[]){0, 1},
                             .memory_per_rank = 8 * GiB, .free_bytes = INFINITY};
    ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .standard_errors = 1};
    ff_plan one = make(&limits, &choices);
    RAD_CHECK(one.refusal == FF_PLAN_ACCEPTED);
    RAD_CHECK(one.file_bytes == 424);
    RAD_CHECK(one.pairs_once == 1 && one.rounds == 1 && one.buffer_doubles == 1);

    /* Two patches on three ranks: rank 2 has no rows, and still joins the
     * one collective write, with a buffer of at least one double. */
    const uint32_t split[] = {0, 1, 2, 2};
    limits = (ff_plan_limits){.patch_count = 2, .ranks = 3, .rank = 2, .row_begin = split,
                              .memory_per_rank = 8 * GiB, .free_bytes = INFINITY};
    for (int reciprocity = FF_RECIPROCITY_AUTO; reciprocity <= FF_RECIPROCITY_OFF; reciprocity++) {
        choices.reciprocity = (ff_reciprocity)reciprocity;
        ff_plan idle = make(&limits, &choices);
        RAD_CHECK(idle.refusal == FF_PLAN_ACCEPTED);
        RAD_CHECK(idle.rounds == 1);
        RAD_CHECK(idle.buffer_doubles >= 1);
        RAD_CHECK(idle.pairs_once == (reciprocity != FF_RECIPROCITY_OFF));
    }
    limits.rank = 0;
    choices.reciprocity = FF_RECIPROCITY_AUTO;
    RAD_CHECK(make(&limits, &choices).buffer_doubles == 2);

    /* N = 4 000 000: 96 MiB holds fewer than 16 rows, so 16; but one
     * collective write (256 MiB) takes only 8 float64 rows of it. */
    limits = (ff_plan_limits){.patch_count = 4000000, .ranks = 1, .memory_per_rank = INFINITY,
                              .free_bytes = INFINITY, .max_rows_per_write = 8};
    choices = (ff_plan_choices){.element = RAD_ELEMENT_F64, .reciprocity = FF_RECIPROCITY_OFF};
    ff_plan big = make(&limits, &choices);
    RAD_CHECK(big.rows_per_round == 8);
    RAD_CHECK(big.rounds == 500000);
    RAD_CHECK(big.buffer_doubles == (size_t)8 * 4000000);
    limits.max_rows_per_write = 15;
    RAD_CHECK(make(&limits, &choices).rows_per_round == 15);
    limits.max_rows_per_write = 17; /* the 16-row floor is below the cap */
    RAD_CHECK(make(&limits, &choices).rows_per_round == 16);
    limits.max_rows_per_write = 1; /* a row beyond one write: one row per round */
    RAD_CHECK(make(&limits, &choices).rows_per_round == 1);

    /* No patches (the driver refuses such a scene first): no rounds, no crash. */
    limits = (ff_plan_limits){.patch_count = 0, .ranks = 2, .row_begin = (const uint32_t[]){0, 0, 0}};
    ff_plan none = make(&limits, &choices);
    RAD_CHECK(none.rounds == 0 && none.buffer_doubles == 1);
}

static void gpu_streams_sparse_files(void)
{
    /* The paper's size on one GPU: a sparse file streams (finished on the
     * device), a dense one keeps the block and mirrors; on the CPU the
     * block fits and is kept; --reciprocity on is obeyed. */
    ff_plan_limits limits = {.patch_count = 2944, .ranks = 1, .memory_per_rank = 64 * GiB, .free_bytes = INFINITY,
                             .gpus_visible = 1};
    ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .standard_errors = 1};
    ff_plan sparse = make(&limits, &choices);
    RAD_CHECK(sparse.gpu && !sparse.pairs_once && sparse.device_records && sparse.buffer_doubles == 1);
    RAD_CHECK(sparse.rounds == 1);
    choices.format = FF_FORMAT_DENSE;
    ff_plan dense = make(&limits, &choices);
    RAD_CHECK(dense.gpu && dense.pairs_once && !dense.device_records);
    choices.format = FF_FORMAT_SPARSE;
    choices.reciprocity = FF_RECIPROCITY_ON;
    ff_plan once = make(&limits, &choices);
    RAD_CHECK(once.pairs_once && !once.device_records);
    choices.reciprocity = FF_RECIPROCITY_AUTO;
    limits.gpus_visible = 0;
    ff_plan cpu = make(&limits, &choices);
    RAD_CHECK(!cpu.gpu && cpu.pairs_once && !cpu.device_records);
}

static void before_and_after_the_split(void)
{
    /* Rank 0 plans before the mesh (no split: an even share assumed) and
     * again after it; the estimate line prints sizes from the second, the
     * refusal message from the first: they must agree. */
    const uint32_t split[] = {0, 700, 2944};
    for (int reciprocity = FF_RECIPROCITY_AUTO; reciprocity <= FF_RECIPROCITY_OFF; reciprocity++) {
        ff_plan_limits limits = {.patch_count = 2944, .ranks = 2, .memory_per_rank = 8 * GiB,
                                 .free_bytes = INFINITY};
        ff_plan_choices choices = {.element = RAD_ELEMENT_F32, .standard_errors = 1, .errors_file = 1,
                                   .reciprocity = (ff_reciprocity)reciprocity};
        ff_plan before = make(&limits, &choices);
        limits.row_begin = split;
        ff_plan after = make(&limits, &choices);
        RAD_CHECK(before.file_bytes == after.file_bytes);
        RAD_CHECK(before.memory_bytes == after.memory_bytes);
        RAD_CHECK(after.rounds == (after.pairs_once ? 1u : FF_CYCLIC_MIN_ROUNDS));
        RAD_CHECK(after.buffer_doubles == (after.pairs_once ? (size_t)700 * 2944 : (size_t)after.rows_per_round * 2944));
    }
}

/* Streamed: walking the rounds, and in each the ranks in order (the order
 * of the collective writes' records), gives rows 0, 1, ..., N - 1 once
 * each; every rank has the same number of rounds, ceil(ceil(N / R) / P). */
static void check_cyclic_rounds(uint64_t n, int ranks, uint32_t max_rows_per_write, uint32_t expect_per_round)
{
    uint32_t next = 0, most = 0;
    uint64_t rounds = 0;
    for (int rank = 0; rank < ranks; rank++) {
        ff_plan_limits limits = {.patch_count = n, .ranks = ranks, .rank = rank, .memory_per_rank = INFINITY,
                                 .free_bytes = INFINITY, .max_rows_per_write = max_rows_per_write};
        ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .reciprocity = FF_RECIPROCITY_OFF};
        ff_plan p = make(&limits, &choices);
        RAD_CHECK(p.pairs_once == 0 && p.rows_per_round == expect_per_round);
        uint64_t blocks = (n + p.rows_per_round - 1) / p.rows_per_round;
        RAD_CHECK(p.rounds == (blocks + ranks - 1) / ranks);
        RAD_CHECK(rank == 0 || p.rounds == rounds);
        rounds = p.rounds;
        uint32_t sum = 0, first;
        for (uint64_t round = 0; round < p.rounds; round++) sum += ff_plan_round_rows(&p, round, &first);
        RAD_CHECK(sum == p.rank_rows);
        most = sum > most ? sum : most;
    }
    for (uint64_t round = 0; round < rounds; round++) {
        for (int rank = 0; rank < ranks; rank++) {
            ff_plan_limits limits = {.patch_count = n, .ranks = ranks, .rank = rank, .memory_per_rank = INFINITY,
                                     .free_bytes = INFINITY, .max_rows_per_write = max_rows_per_write};
            ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .reciprocity = FF_RECIPROCITY_OFF};
            ff_plan p = make(&limits, &choices);
            uint32_t first, count = ff_plan_round_rows(&p, round, &first);
            RAD_CHECK(p.most_rows == most);
            if (count == 0) {
                RAD_CHECK(first == n);
                continue;
            }
            RAD_CHECK(first == next); /* this write's records follow the last one's */
            RAD_CHECK((first / p.rows_per_round) % (uint32_t)ranks == (uint32_t)rank);
            next = first + count;
        }
    }
    RAD_CHECK(next == n);
}

static void rows_of_each_round(void)
{
    /* N = 100, rounds of 7 rows (one write's cap): 15 blocks, the last of
     * 2 rows; N is not a multiple of 7 P. */
    check_cyclic_rounds(100, 1, 7, 7); /* 15 rounds */
    check_cyclic_rounds(100, 2, 7, 7); /* 8 rounds, rank 1 idle in the last */
    check_cyclic_rounds(100, 3, 7, 7); /* 5 rounds */
    ff_plan_limits limits = {.patch_count = 100, .ranks = 3, .rank = 1, .memory_per_rank = INFINITY,
                             .free_bytes = INFINITY, .max_rows_per_write = 7};
    ff_plan_choices choices = {.element = RAD_ELEMENT_F64, .reciprocity = FF_RECIPROCITY_OFF};
    ff_plan p = make(&limits, &choices);
    uint32_t first;
    RAD_CHECK(p.rounds == 5 && p.rank_rows == 5 * 7 && p.most_rows == 5 * 7);
    RAD_CHECK(ff_plan_round_rows(&p, 0, &first) == 7 && first == 7);   /* block 1 */
    RAD_CHECK(ff_plan_round_rows(&p, 1, &first) == 7 && first == 28);  /* block 4 */
    RAD_CHECK(ff_plan_round_rows(&p, 4, &first) == 7 && first == 91);  /* block 13 */
    limits.rank = 2;
    p = make(&limits, &choices);
    RAD_CHECK(p.rank_rows == 4 * 7 + 2);
    RAD_CHECK(ff_plan_round_rows(&p, 4, &first) == 2 && first == 98);  /* block 14, cut at N */
    limits.rank = 0;
    p = make(&limits, &choices);
    RAD_CHECK(ff_plan_round_rows(&p, 4, &first) == 7 && first == 84);  /* block 12 */
    RAD_CHECK(p.rank_rows == 35);

    /* N = 2944 (cornell_sphere --subdiv 3), 96 MiB rounds: 4274 rows, more
     * than N. One rank takes them in one round; several ranks take blocks of
     * ceil(N / (8 P)) rows in turn (FF_CYCLIC_MIN_ROUNDS), so that each
     * rank's rows spread over the matrix (the bytes do not depend on R). */
    check_cyclic_rounds(2944, 1, 0, 2944);
    check_cyclic_rounds(2944, 2, 0, 184);
    check_cyclic_rounds(2944, 3, 0, 123);
    check_cyclic_rounds(200, 2, 0, 16); /* never below 16 rows a block */
    /* N = 47104, rounds of 267 rows: many rounds, the last ones uneven. */
    check_cyclic_rounds(47104, 1, 0, 267);
    check_cyclic_rounds(47104, 3, 0, 267);
    /* More ranks than rows: blocks of one row, the last ranks idle. */
    check_cyclic_rounds(2, 3, 0, 1);

    /* pairs_once: the rank's block of the split, in rounds from its start. */
    const uint32_t split[] = {0, 40, 100};
    limits = (ff_plan_limits){.patch_count = 100, .ranks = 2, .rank = 1, .row_begin = split,
                              .memory_per_rank = INFINITY, .free_bytes = INFINITY, .max_rows_per_write = 7};
    choices.reciprocity = FF_RECIPROCITY_ON;
    p = make(&limits, &choices);
    RAD_CHECK(p.pairs_once && p.rows_per_round == 7 && p.rounds == 9); /* ceil(60 / 7) */
    RAD_CHECK(p.block_begin == 40 && p.block_end == 100 && p.rank_rows == 60);
    RAD_CHECK(ff_plan_round_rows(&p, 0, &first) == 7 && first == 40);
    RAD_CHECK(ff_plan_round_rows(&p, 8, &first) == 4 && first == 96);
    limits.rank = 0;
    p = make(&limits, &choices);
    RAD_CHECK(p.rounds == 9 && ff_plan_round_rows(&p, 5, &first) == 5 && first == 35);
    RAD_CHECK(ff_plan_round_rows(&p, 6, &first) == 0 && first == 40);
}

int main(void)
{
    small_scene();
    memory_limited();
    backend_choice();
    refusals();
    edges();
    before_and_after_the_split();
    gpu_streams_sparse_files();
    rows_of_each_round();
    return rad_test_finish();
}
