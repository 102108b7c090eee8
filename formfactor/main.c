/* formfactor - form factors F_ij for every patch pair of a subdivided scene.
 *
 *     mpirun -n P formfactor [options] [SCENE.obj]
 *
 * Every rank loads the scene and builds the same patch mesh; rows are split
 * into contiguous blocks of about equal work; each rank computes its rows
 * in rounds and all ranks write each round with one collective MPI-IO call.
 * The file appears under its final name only when every rank succeeded.
 */
#define _GNU_SOURCE /* sched_getaffinity */
#include <getopt.h>
#include <sched.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "ff_backend.h"
#include "ff_comm.h"
#include "ff_cuda.h"
#include "ff_output.h"
#include "ff_rows.h"
#include "ff_setup.h"
#include "ff_stats.h"
#include "rad_ff_quad.h"
#include "rad_ffile.h"
#include "rad_fs.h"
#include "rad_log.h"
#include "rad_mesh.h"
#include "rad_parse.h"
#include "rad_scene.h"

#define FF_VERSION RAD_VERSION /* the project version (core/CMakeLists.txt) */
#define FF_ROUND_BYTES ((uint64_t)96 << 20) /* rows computed between collective writes */
/* Buffers up to this size come from the backend (page-locked for CUDA, so
 * results stream back by DMA); larger ones - a whole rank's rows with
 * --reciprocity on - from malloc. */
#define FF_BACKEND_BUFFER_MAX ((size_t)1 << 30)

/* --reciprocity: compute each unordered pair once and copy the other entry
 * (which needs the rank's rows in memory), or compute both (rows stream
 * through a round buffer); the bytes are the same. */
typedef enum ff_reciprocity { FF_RECIPROCITY_AUTO, FF_RECIPROCITY_ON, FF_RECIPROCITY_OFF } ff_reciprocity;

typedef struct ff_options {
    const char *scene_path; /* NULL = built-in Cornell box */
    const char *output;     /* "formfactors" */
    const char *stats_path; /* NULL = none */
    const char *errors_path; /* --errors: standard errors of F as a second file; NULL = none */
    int no_errors;          /* --no-errors: skip them (GPU: about N % less kernel time) */
    double target_error;    /* --target-error; 0 = one batch */
    uint32_t max_samples;   /* --max-samples; 0 = 64 x samples */
    const char *subdiv_only;
    const char *backend;    /* auto | cpu | cuda */
    int subdiv;
    uint32_t samples, shadow_rays;
    uint64_t seed;
    rad_element_type element;
    rad_estimator_id estimator;
    double quad_rtol, quad_atol; /* --quad-rtol, --quad-atol */
    double clamp_rho;       /* --clamp-rho: Kd above it set to it; 0 = refuse Kd >= 1 */
    double max_bytes;       /* --max-bytes: refuse a larger output; 0 = only the disk's free space */
    int flip_normals;       /* --flip-normals: every face wound the other way */
    ff_format format;
    int threads; /* 0 = cores / ranks on this node */
    int cull;    /* 1 = skip shadow rays that cannot hit anything (default) */
    ff_reciprocity reciprocity;
    int quiet;
    int help, version;
} ff_options;

static void print_help(void)
{
    printf("usage: mpirun -n P formfactor [options] [SCENE.obj]\n"
           "       formfactor [options] [SCENE.obj]          (one rank)\n"
           "\n"
           "Computes the form factor F_ij of every patch pair of SCENE.obj (default: the\n"
           "built-in Cornell box) and writes the N x N matrix with the patch table.\n"
           "\n"
           "  -o, --output FILE        output file (default: formfactors)\n"
           "      --subdiv S           split every face into 4^S patches (default: 0)\n"
           "      --subdiv-only GROUP  subdivide only faces of OBJ group GROUP (the paper's\n"
           "                           code subdivided only the box: --subdiv-only box)\n"
           "      --flip-normals       wind every face the other way round: for scenes whose\n"
           "                           faces all point away from where the light is (a closed\n"
           "                           object used as a room, faces wound against their vn)\n"
           "      --clamp-rho R        set every Kd value above R (0 < R < 1) to R, saying which,\n"
           "                           instead of refusing Kd >= 1 (Blender's white is Kd 1)\n"
           "      --samples K          point pairs per patch pair (default: 512)\n"
           "      --shadow-rays R      of those, pairs that carry a shadow ray (default: 32;\n"
           "                           0 = no occlusion)\n"
           "      --seed N             random seed (default: 1); same seed, same bytes\n"
           "      --target-error E     keep sampling each pair (batches that double the samples\n"
           "                           and shadow rays) until the standard error of F_ij and\n"
           "                           F_ji is at most E, or --max-samples is reached\n"
           "      --max-samples M      cap per pair for --target-error (default: 64 x --samples)\n"
           "      --errors FILE        also write each entry's standard error (float32, same\n"
           "                           layout as the form factors; docs/formats.md)\n"
           "      --no-errors          do not estimate standard errors (no summary in the stats;\n"
           "                           saves GPU kernel time and host memory)\n"
           "      --estimator E        quadrature | auto | mc | qmc | analytic (default: quadrature:\n"
           "                           the unoccluded factor by adaptive quadrature to --quad-rtol,\n"
           "                           and, where something might block the pair, its visible\n"
           "                           fraction from R stratified shadow rays; the others are\n"
           "                           Monte Carlo: auto: pairs closer than twice their radii use\n"
           "                           the contour-integral near-field estimator with K/8 samples;\n"
           "                           mc: random point pairs everywhere, as the paper; qmc:\n"
           "                           shifted-Halton point pairs; analytic: the contour estimator\n"
           "                           for every pair)\n"
           "      --quad-rtol R        quadrature: relative tolerance of each unoccluded factor\n"
           "                           (default: 1e-8; its error estimate is conservative)\n"
           "      --quad-atol A        quadrature: absolute tolerance, in units of F (default: 1e-13)\n"
           "      --backend B          auto | cpu | cuda (default: auto)\n"
           "      --element T          f64 | f32 matrix element type (default: f64)\n"
           "      --format F           native | sparse | paper (sparse: only each row's non-zero\n"
           "                           tiles of 64 entries; paper: int32 N + N*N float64 only)\n"
           "      --cull C             all | none: skip shadow rays where nothing can lie between\n"
           "                           the two patches (default: all; the same matrix)\n"
           "      --reciprocity M      auto | on | off: on computes each unordered pair once and\n"
           "                           copies the other entry (A_i F_ij = A_j F_ji), holding the\n"
           "                           rank's rows in memory; off computes both and streams rows;\n"
           "                           auto: on when the rows take at most a quarter of this\n"
           "                           node's memory per rank, and on the GPU at most 1 GiB\n"
           "                           (default). Same bytes either way.\n"
           "      --threads T          CPU threads per rank (default: cores / ranks per node)\n"
           "      --stats FILE.json    write counts and phase times (per rank and total)\n"
           "      --max-bytes SIZE     refuse, before any work, a run whose output (with --errors)\n"
           "                           would be larger (e.g. 20G, 512Mi); runs larger than the\n"
           "                           free space of the output's file system are always refused\n"
           "  -q, --quiet              only errors on stderr\n"
           "  -h, --help               this help\n"
           "      --version            print the version\n"
           "\n"
           "File layout: docs/formats.md. Estimator: docs/architecture.md.\n");
}

/* A tolerance: a finite number in (0, 1). */
static rad_status parse_tolerance(const char *flag, const char *text, double *out)
{
    return rad_parse_real(flag, text, 0, 0, 1, 0, out);
}

static rad_status parse_uint(const char *flag, const char *text, uint64_t min, uint64_t max, uint64_t *out)
{
    return rad_parse_uint(flag, text, min, max, out);
}

static rad_status parse_options(int argc, char **argv, ff_options *o)
{
    enum { O_SUBDIV = 256, O_ONLY, O_SAMPLES, O_RAYS, O_SEED, O_BACKEND, O_ELEMENT, O_FORMAT, O_THREADS, O_STATS,
           O_VERSION, O_ESTIMATOR, O_CULL, O_RECIPROCITY, O_TARGET, O_MAX_SAMPLES, O_ERRORS, O_NO_ERRORS,
           O_QUAD_RTOL, O_QUAD_ATOL, O_FLIP_NORMALS, O_CLAMP_RHO, O_MAX_BYTES };
    static const struct option longs[] = {
        {"output", required_argument, 0, 'o'},      {"subdiv", required_argument, 0, O_SUBDIV},
        {"subdiv-only", required_argument, 0, O_ONLY}, {"samples", required_argument, 0, O_SAMPLES},
        {"shadow-rays", required_argument, 0, O_RAYS}, {"seed", required_argument, 0, O_SEED},
        {"backend", required_argument, 0, O_BACKEND}, {"element", required_argument, 0, O_ELEMENT},
        {"format", required_argument, 0, O_FORMAT},   {"threads", required_argument, 0, O_THREADS},
        {"stats", required_argument, 0, O_STATS},     {"quiet", no_argument, 0, 'q'},
        {"help", no_argument, 0, 'h'},                {"version", no_argument, 0, O_VERSION},
        {"estimator", required_argument, 0, O_ESTIMATOR}, {"cull", required_argument, 0, O_CULL},
        {"reciprocity", required_argument, 0, O_RECIPROCITY}, {"target-error", required_argument, 0, O_TARGET},
        {"max-samples", required_argument, 0, O_MAX_SAMPLES}, {"errors", required_argument, 0, O_ERRORS},
        {"no-errors", no_argument, 0, O_NO_ERRORS}, {"quad-rtol", required_argument, 0, O_QUAD_RTOL},
        {"quad-atol", required_argument, 0, O_QUAD_ATOL},
        {"flip-normals", no_argument, 0, O_FLIP_NORMALS}, {"clamp-rho", required_argument, 0, O_CLAMP_RHO},
        {"max-bytes", required_argument, 0, O_MAX_BYTES},
        {0, 0, 0, 0}};
    *o = (ff_options){.output = "formfactors", .backend = "auto", .samples = 512, .shadow_rays = 32, .seed = 1,
                      .element = RAD_ELEMENT_F64, .estimator = RAD_ESTIMATOR_QUADRATURE, .format = FF_FORMAT_NATIVE,
                      .cull = 1, .quad_rtol = RAD_FF_QUAD_RTOL, .quad_atol = RAD_FF_QUAD_ATOL};
    uint64_t v = 0;
    rad_status st = RAD_OK;
    int c;
    opterr = 0;
    while (st == RAD_OK && (c = getopt_long(argc, argv, "o:qh", longs, NULL)) != -1) {
        switch (c) {
        case 'o': o->output = optarg; break;
        case 'q': o->quiet = 1; break;
        case 'h': o->help = 1; break;
        case O_VERSION: o->version = 1; break;
        case O_SUBDIV: st = parse_uint("--subdiv", optarg, 0, 12, &v); o->subdiv = (int)v; break;
        case O_ONLY: o->subdiv_only = optarg; break;
        case O_SAMPLES: st = parse_uint("--samples", optarg, 1, 1u << 24, &v); o->samples = (uint32_t)v; break;
        case O_RAYS: st = parse_uint("--shadow-rays", optarg, 0, 1u << 24, &v); o->shadow_rays = (uint32_t)v; break;
        case O_SEED: st = parse_uint("--seed", optarg, 0, UINT64_MAX, &v); o->seed = v; break;
        case O_THREADS: st = parse_uint("--threads", optarg, 1, 1024, &v); o->threads = (int)v; break;
        case O_STATS: o->stats_path = optarg; break;
        case O_BACKEND:
            o->backend = optarg;
            if (strcmp(optarg, "auto") && strcmp(optarg, "cpu") && strcmp(optarg, "cuda")) {
                rad_error("--backend: expected auto, cpu or cuda, got '%s'", optarg);
                st = RAD_ERR_USAGE;
            }
            break;
        case O_ELEMENT:
            if (!strcmp(optarg, "f64")) o->element = RAD_ELEMENT_F64;
            else if (!strcmp(optarg, "f32")) o->element = RAD_ELEMENT_F32;
            else { rad_error("--element: expected f64 or f32, got '%s'", optarg); st = RAD_ERR_USAGE; }
            break;
        case O_ESTIMATOR:
            if (!rad_estimator_parse(optarg, &o->estimator)) {
                rad_error("--estimator: expected quadrature, auto, mc, qmc or analytic, got '%s'", optarg);
                st = RAD_ERR_USAGE;
            }
            break;
        case O_QUAD_RTOL: st = parse_tolerance("--quad-rtol", optarg, &o->quad_rtol); break;
        case O_QUAD_ATOL: st = parse_tolerance("--quad-atol", optarg, &o->quad_atol); break;
        case O_FLIP_NORMALS: o->flip_normals = 1; break;
        case O_MAX_BYTES: st = rad_parse_bytes("--max-bytes", optarg, &o->max_bytes); break;
        case O_CLAMP_RHO: st = rad_parse_real("--clamp-rho", optarg, 0, 0, 1, 0, &o->clamp_rho); break;
        case O_CULL:
            if (!strcmp(optarg, "all")) o->cull = 1;
            else if (!strcmp(optarg, "none")) o->cull = 0;
            else { rad_error("--cull: expected all or none, got '%s'", optarg); st = RAD_ERR_USAGE; }
            break;
        case O_TARGET: {
            char *end = NULL;
            o->target_error = optarg && *optarg ? strtod(optarg, &end) : 0;
            if (!end || *end || !(o->target_error > 0) || !isfinite(o->target_error)) {
                rad_error("--target-error: expected a positive number, got '%s'", optarg);
                st = RAD_ERR_USAGE;
            }
            break;
        }
        case O_MAX_SAMPLES: st = parse_uint("--max-samples", optarg, 1, 1u << 30, &v); o->max_samples = (uint32_t)v; break;
        case O_ERRORS: o->errors_path = optarg; break;
        case O_NO_ERRORS: o->no_errors = 1; break;
        case O_RECIPROCITY:
            if (!strcmp(optarg, "auto")) o->reciprocity = FF_RECIPROCITY_AUTO;
            else if (!strcmp(optarg, "on")) o->reciprocity = FF_RECIPROCITY_ON;
            else if (!strcmp(optarg, "off")) o->reciprocity = FF_RECIPROCITY_OFF;
            else { rad_error("--reciprocity: expected auto, on or off, got '%s'", optarg); st = RAD_ERR_USAGE; }
            break;
        case O_FORMAT:
            if (!strcmp(optarg, "native")) o->format = FF_FORMAT_NATIVE;
            else if (!strcmp(optarg, "sparse")) o->format = FF_FORMAT_SPARSE;
            else if (!strcmp(optarg, "paper")) o->format = FF_FORMAT_PAPER;
            else { rad_error("--format: expected native, sparse or paper, got '%s'", optarg); st = RAD_ERR_USAGE; }
            break;
        default:
            rad_error("unknown or incomplete option '%s' (see --help)", argv[optind - 1]);
            st = RAD_ERR_USAGE;
        }
    }
    if (st != RAD_OK) return st;
    if (optind < argc) o->scene_path = argv[optind++];
    if (optind < argc) {
        rad_error("unexpected argument '%s' (one scene at a time)", argv[optind]);
        return RAD_ERR_USAGE;
    }
    if (o->samples == 0) {
        rad_error("--samples must be at least 1");
        return RAD_ERR_USAGE;
    }
    if (o->shadow_rays > o->samples && o->estimator != RAD_ESTIMATOR_QUADRATURE) {
        rad_error("--shadow-rays %u exceeds --samples %u (rays are cast along sample pairs)", o->shadow_rays,
                  o->samples);
        return RAD_ERR_USAGE;
    }
    if (o->max_samples == 0) o->max_samples = o->samples <= (1u << 30) / 64 ? 64 * o->samples : 1u << 30;
    if (o->max_samples < o->samples) {
        rad_error("--max-samples %u is below --samples %u", o->max_samples, o->samples);
        return RAD_ERR_USAGE;
    }
    if (o->no_errors && o->errors_path) {
        rad_error("--no-errors and --errors %s contradict each other", o->errors_path);
        return RAD_ERR_USAGE;
    }
    /* Files: outputs are new, regular or character devices, and no two
     * roles name one file (docs/reliability.md, "Threat model: files on
     * disk"); the scene's MTL files are checked as the loader opens them. */
    rad_fs_role roles[] = {{"the scene", o->scene_path, 0}, {"-o", o->output, 1}, {"--stats", o->stats_path, 1},
                           {"--errors", o->errors_path, 1}};
    for (size_t k = 1; k < sizeof roles / sizeof roles[0]; k++)
        if (rad_fs_check_output(roles[k].option, roles[k].path) != RAD_OK) return RAD_ERR_USAGE;
    if (rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]) != RAD_OK) return RAD_ERR_USAGE;
    if (o->format == FF_FORMAT_PAPER && o->element != RAD_ELEMENT_F64) {
        rad_error("--format paper stores float64 only; drop --element f32");
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

/* Shared by every rank: what the run computes with. */
typedef struct ff_run {
    ff_comm *comm;
    ff_options opt;
    rad_scene scene;
    rad_mesh mesh;
    rad_ff_patch *patches;
    float *triangles;
    uint32_t *triangle_face, triangle_count;
    uint32_t *row_begin; /* ranks + 1 */
    const ff_backend *backend;
    void *backend_state;
    int pairs_once; /* --reciprocity as decided for this run (same on every rank) */
    int want_errors; /* standard errors computed (not --no-errors) */
    ff_rank_stats stats;
    double start;
    double planned_bytes, planned_memory; /* check_limits (rank 0): the outputs' size, memory per rank */
    /* Progress (report_progress): this rank's rows done before the current
     * backend call, the rows it has added to the shared counter, when, and
     * (rank 0) when it last reported, every how many seconds, and whether
     * to a terminal (one line that updates). calibrating: no reports. */
    uint32_t progress_base;
    uint64_t progress_added;
    double progress_added_at, progress_said_at, progress_every, compute_start;
    double estimated_seconds; /* estimate(): the calibration's forecast, or -1 */
    int progress_tty, calibrating;
} ff_run;

/* "1.2 s", "3 min 20 s", "33 h 10 min". */
static const char *format_seconds(double s, char *out, size_t size)
{
    if (!(s < 1e9)) snprintf(out, size, "longer than 30 years");
    else if (s < 0.01) snprintf(out, size, "%.1f ms", 1e3 * s);
    else if (s < 60) snprintf(out, size, "%.2g s", s);
    else if (s < 3600) snprintf(out, size, "%d min %d s", (int)(s / 60), (int)fmod(s, 60));
    else snprintf(out, size, "%d h %d min", (int)(s / 3600), (int)fmod(s / 60, 60));
    return out;
}

/* The backends' progress callback, on every rank: adds this rank's rows to
 * the shared counter at most once a second; rank 0 reports the whole run's
 * rows every progress_every seconds (about 40 lines per run, at least
 * 2 s apart; on a terminal one line, updated twice a second). */
static void report_progress(void *user, uint64_t rows_done)
{
    ff_run *run = user;
    if (run->calibrating) return;
    double t = ff_comm_time();
    uint64_t done = run->progress_base + rows_done;
    uint32_t mine = run->row_begin[ff_comm_rank(run->comm) + 1] - run->row_begin[ff_comm_rank(run->comm)];
    if (done > run->progress_added && (t - run->progress_added_at >= 1.0 || done == mine)) {
        ff_comm_progress_add(run->comm, done - run->progress_added);
        run->progress_added = done;
        run->progress_added_at = t;
    }
    if (ff_comm_rank(run->comm) != 0 || t - run->progress_said_at < run->progress_every) return;
    run->progress_said_at = t;
    double fraction = (double)ff_comm_progress_read(run->comm) / (double)(run->mesh.patch_count ? run->mesh.patch_count : 1);
    double elapsed = t - run->compute_start;
    /* The first rows say little about the rest: until 5 % are done, the
     * calibration's forecast (which sampled the whole matrix) holds. */
    double to_go = fraction > 0 ? elapsed * (1 - fraction) / fraction : -1;
    if (fraction < 0.05 && run->estimated_seconds >= 0)
        to_go = run->estimated_seconds > elapsed ? run->estimated_seconds - elapsed : 0;
    char took[32], left[32];
    const char *format = run->progress_tty ? "\r%s%.1f%% of the rows (%d rank(s)), %s elapsed, about %s to go\033[K"
                                           : "%s%.1f%% of the rows (%d rank(s)), %s elapsed, about %s to go";
    char line[256];
    snprintf(line, sizeof line, format, run->progress_tty ? "formfactor: " : "", 100 * fraction, ff_comm_size(run->comm),
             format_seconds(elapsed, took, sizeof took),
             to_go >= 0 ? format_seconds(to_go, left, sizeof left) : "?");
    if (run->progress_tty && rad_log_get_level() >= RAD_LOG_INFO) {
        fputs(line, stderr); /* the one line that updates; ended before the next message (run_formfactor) */
        fflush(stderr);
    } else {
        rad_info("%s", line);
    }
}

static int default_threads(const ff_run *run)
{
    if (run->opt.threads > 0) return run->opt.threads;
    const char *env = getenv("OMP_NUM_THREADS");
    if (env && atoi(env) > 0) return atoi(env);
    /* The cores this rank may run on (mpirun binds ranks to cores by
     * default), and no more than its share of the node. */
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    long t = cores / ff_comm_node_size(run->comm);
    cpu_set_t mask;
    if (sched_getaffinity(0, sizeof mask, &mask) == 0 && CPU_COUNT(&mask) < t) t = CPU_COUNT(&mask);
    return t > 0 ? (int)t : 1;
}

/* Largest N: the paper format stores N as int32, the mesh indexes patches
 * with uint32 (RAD_NO_VERTEX taken), the reader accepts up to 2^31. */
#define FF_MAX_PATCHES ((uint64_t)INT32_MAX)

/* "1.23 GiB": bytes as double, since refused sizes overflow 64 bits. */
static const char *format_bytes(double bytes, char *out, size_t size)
{
    static const char *const units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB", "ZiB"};
    int u = 0;
    while (bytes >= 1024 && u < 7) bytes /= 1024, u++;
    snprintf(out, size, u ? "%.3g %s" : "%.0f %s", bytes, units[u]);
    return out;
}

/* Physical memory of this node divided among the ranks on it (bytes). */
static double memory_per_rank(const ff_run *run)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    int node_ranks = ff_comm_node_size(run->comm) > 0 ? ff_comm_node_size(run->comm) : 1;
    return pages > 0 && page > 0 ? (double)pages * (double)page / node_ranks : INFINITY;
}

/* Rank 0, before the mesh is built: a run whose patch count exceeds the
 * format, whose file would not fit in the free space of the output's file
 * system, or whose memory per rank would exceed this node's memory per
 * rank is refused with the numbers instead of being attempted. */
static rad_status check_limits(ff_run *run)
{
    rad_mesh_options mo = {.subdiv = run->opt.subdiv, .only_group = run->opt.subdiv_only};
    uint64_t n = rad_mesh_count_patches(&run->scene, &mo);
    double dn = (double)n;
    double element = run->opt.format == FF_FORMAT_PAPER || run->opt.element == RAD_ELEMENT_F64 ? 8 : 4;
    /* File: header, vertex and patch tables, matrix, row checksums; and
     * the --errors file beside it (float32; assumed on the same file
     * system). */
    double tables = RAD_FF_HEADER_BYTES + dn * (sizeof(rad_patch) + 24 + 8);
    double file_bytes = tables + dn * dn * element + (run->opt.errors_path ? tables + dn * dn * 4 : 0);
    /* Per rank: mesh and its vertex bound, kernel patches, the prologue
     * (rank 0), checksums, and a round of rows (compute_and_write) as
     * double plus its stored copy, for the values and (unless
     * --no-errors) the standard errors; with --reciprocity on, the rank's
     * whole block of rows instead of a round (auto only picks it when it
     * fits in a quarter of the memory). */
    int errors = !run->opt.no_errors;
    double round_rows = fmax(16, fmin(dn, (double)FF_ROUND_BYTES / (8 * fmax(dn, 1))));
    if (run->opt.reciprocity == FF_RECIPROCITY_ON)
        round_rows = fmax(round_rows, ceil(dn / fmax(ff_comm_size(run->comm), 1)));
    double memory = dn * (2 * sizeof(rad_patch) + 2 * 24 + sizeof(rad_ff_patch) + 16) +
                    round_rows * dn * ((8 + element) + errors * (8 + 4));
    char why[4200] = "", have[32];
    if (n > FF_MAX_PATCHES)
        snprintf(why, sizeof why, "more than the format's limit of %" PRIu64 " patches", FF_MAX_PATCHES);
    char dir[4096];
    const char *slash = strrchr(run->opt.output, '/');
    if (slash)
        snprintf(dir, sizeof dir, "%.*s", slash == run->opt.output ? 1 : (int)(slash - run->opt.output), run->opt.output);
    else
        snprintf(dir, sizeof dir, ".");
    struct statvfs fs; /* no answer: opening the output fails later and says why */
    double free_bytes = statvfs(dir, &fs) == 0 ? (double)fs.f_bavail * (double)fs.f_frsize : INFINITY;
    if (!why[0] && file_bytes > free_bytes)
        snprintf(why, sizeof why, "%s has %s free", dir, format_bytes(free_bytes, have, sizeof have));
    if (!why[0] && run->opt.max_bytes > 0 && file_bytes > run->opt.max_bytes)
        snprintf(why, sizeof why, "--max-bytes is %s", format_bytes(run->opt.max_bytes, have, sizeof have));
    run->planned_bytes = file_bytes;
    run->planned_memory = memory;
    double per_rank = memory_per_rank(run);
    int node_ranks = ff_comm_node_size(run->comm) > 0 ? ff_comm_node_size(run->comm) : 1;
    if (!why[0] && memory > per_rank)
        snprintf(why, sizeof why, "this node has %s per rank (%d rank(s) on it)",
                 format_bytes(per_rank, have, sizeof have), node_ranks);
    if (why[0]) {
        char need[32], mem[32];
        rad_error("--subdiv %d: %" PRIu64 " patches: %s would need %s (N^2 x %.0f bytes) and each rank about %s "
                  "of memory, but %s; refused (--element f32 halves the file; each --subdiv level less divides it by 16)",
                  run->opt.subdiv, n, run->opt.output, format_bytes(file_bytes, need, sizeof need), element,
                  format_bytes(memory, mem, sizeof mem), why);
        return RAD_ERR_NOMEM;
    }
    return RAD_OK;
}

/* The loader reads the OBJ and each mtllib through here: none of them may
 * be an output of this run (`-o scene.mtl` would replace the scene's
 * materials). */
static rad_status read_scene_file(const char *path, char **out_data, size_t *out_size, void *user)
{
    const ff_options *o = user;
    rad_fs_role roles[] = {{"the scene's file", path, 0}, {"-o", o->output, 1}, {"--stats", o->stats_path, 1},
                           {"--errors", o->errors_path, 1}};
    *out_data = NULL;
    if (rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]) != RAD_OK) return RAD_ERR_USAGE;
    return rad_fs_read_all(path, out_data, out_size);
}

static rad_status load(ff_run *run)
{
    double t0 = ff_comm_time();
    rad_scene_options loader = {.read_file = read_scene_file, .read_file_user = &run->opt,
                                .clamp_rho = run->opt.clamp_rho, .flip_normals = run->opt.flip_normals};
    rad_status st = run->opt.scene_path ? rad_scene_load_file(run->opt.scene_path, &loader, &run->scene)
                                        : rad_scene_load_default(&run->scene);
    double t1 = ff_comm_time();
    if (st == RAD_OK && ff_comm_rank(run->comm) == 0) st = check_limits(run);
    if (st == RAD_OK) {
        rad_mesh_options mo = {.subdiv = run->opt.subdiv, .only_group = run->opt.subdiv_only};
        st = rad_mesh_build(&run->scene, &mo, &run->mesh);
    }
    if (st == RAD_OK && run->mesh.patch_count == 0) {
        rad_error("%s: the scene has no faces", run->scene.path);
        st = RAD_ERR_INVALID;
    }
    run->stats.load = t1 - t0;
    run->stats.subdivide = ff_comm_time() - t1;
    return st;
}

static rad_status select_backend(ff_run *run, int gpus)
{
    const char *want = run->opt.backend;
    /* auto: the GPU when this process sees one, else the CPU. */
    run->backend = !strcmp(want, "cuda") || (!strcmp(want, "auto") && gpus > 0) ? &ff_backend_cuda : &ff_backend_cpu;
    return RAD_OK;
}

static rad_status setup(ff_run *run)
{
    double t0 = ff_comm_time();
    int ranks = ff_comm_size(run->comm);
    uint32_t n = (uint32_t)run->mesh.patch_count;
    double centre[3];
    ff_frame_centre(&run->mesh, centre);
    rad_status st = ff_patches_build(&run->mesh, centre, &run->patches);
    if (st == RAD_OK)
        st = ff_occluders_build(&run->scene, centre, &run->triangles, &run->triangle_face, &run->triangle_count);
    run->row_begin = calloc((size_t)ranks + 1, sizeof *run->row_begin);
    if (st == RAD_OK && !run->row_begin) st = RAD_ERR_NOMEM;
    double eps = ff_plane_eps(&run->mesh);
    int convex = run->opt.cull && ff_scene_is_convex_enclosure(&run->scene, eps);
    if (st == RAD_OK) st = ff_partition_rows(run->patches, n, eps, ranks, run->row_begin);
    /* Collective, so every rank asks, even one that failed above. */
    int rank = ff_comm_rank(run->comm);
    run->want_errors = !run->opt.no_errors;
    double rows_bytes = st == RAD_OK ? (double)(run->row_begin[rank + 1] - run->row_begin[rank]) * n * sizeof(double) : 0;
    double block_bytes = (1 + run->want_errors) * rows_bytes; /* values and errors */
    /* auto: on where it pays. On the GPU a block beyond the page-locked
     * limit would come back by pageable copies (N = 47 104: 13.9 s, or 8 s
     * to page-lock it), more than the 1.4 s of kernels saved, so there the
     * rows stream (docs/performance.md). */
    int gpu = run->backend == &ff_backend_cuda;
    uint64_t too_big = ff_comm_max_u64(run->comm, block_bytes > memory_per_rank(run) / 4 ||
                                                      (gpu && rows_bytes > FF_BACKEND_BUFFER_MAX));
    run->pairs_once = run->opt.reciprocity == FF_RECIPROCITY_ON || (run->opt.reciprocity == FF_RECIPROCITY_AUTO && !too_big);
    run->stats.threads = default_threads(run);
    if (st == RAD_OK) {
        ff_setup su = {.patches = run->patches, .patch_count = n, .triangles = run->triangles,
                       .triangle_face = run->triangle_face, .triangle_count = run->triangle_count,
                       .samples = run->opt.samples, .shadow_rays = run->opt.shadow_rays, .seed = run->opt.seed,
                       .estimator = run->opt.estimator, .quad_rtol = run->opt.quad_rtol,
                       .quad_atol = run->opt.quad_atol, .target_error = run->opt.target_error,
                       .max_samples = run->opt.max_samples, .errors = run->want_errors, .cull = run->opt.cull, .scene_convex = convex,
                       .cull_margin = ff_cull_margin(&run->mesh, centre, eps), .plane_eps = eps, .pairs_once = run->pairs_once, .threads = run->stats.threads, .device = ff_comm_rank(run->comm),
                       .progress = report_progress, .progress_user = run};
        st = run->backend->create(&su, &run->backend_state);
    }
    run->stats.setup = ff_comm_time() - t0;
    return st;
}

/* Rows per round: about FF_ROUND_BYTES of doubles (at least 16 rows, at
 * most what one collective write takes): big enough that a GPU launch
 * fills the device (N = 2944 is one round), small enough that a streamed
 * run's memory stays O(N), not O(N^2). */
static uint32_t rows_per_round(const ff_run *run, const ff_output *out)
{
    uint64_t by_memory = FF_ROUND_BYTES / (sizeof(double) * run->mesh.patch_count);
    uint32_t per_round = ff_output_max_rows(out);
    if (by_memory < 16) by_memory = 16;
    return per_round > by_memory ? (uint32_t)by_memory : per_round;
}

/* Round `round` of a rank's rows [begin, end): its first row (end once the
 * rows are used up) and, returned, its row count (0 then). */
static uint32_t round_rows(uint32_t begin, uint32_t end, uint32_t per_round, uint64_t round, uint32_t *r0)
{
    uint64_t first = begin + round * per_round;
    *r0 = first < end ? (uint32_t)first : end;
    return end - *r0 < per_round ? end - *r0 : per_round;
}

/* The files of a run: the matrix, and its standard errors on request. */
typedef struct ff_files {
    ff_output *matrix;
    ff_output *errors; /* NULL without --errors */
} ff_files;

/* Collective: rows [r0, r0 + count) of this rank into each file (count may be 0). */
static rad_status write_round(ff_run *run, const ff_files *files, uint32_t r0, uint32_t count, const double *rows,
                              const double *errors)
{
    double t0 = ff_comm_time();
    rad_status st = ff_output_write_rows(files->matrix, r0, count, rows);
    if (files->errors) {
        rad_status e = ff_output_write_rows(files->errors, r0, count, errors);
        if (st == RAD_OK) st = e;
    }
    run->stats.io += ff_comm_time() - t0;
    return st;
}

static double *alloc_buffer(ff_run *run, size_t count)
{
    if (count == 0) count = 1;
    return count * sizeof(double) <= FF_BACKEND_BUFFER_MAX ? run->backend->alloc_rows(run->backend_state, count)
                                                           : malloc(count * sizeof(double));
}

static void free_buffer(ff_run *run, size_t count, double *buffer)
{
    if (count == 0) count = 1;
    if (count * sizeof(double) <= FF_BACKEND_BUFFER_MAX)
        run->backend->free_rows(run->backend_state, buffer);
    else
        free(buffer);
}

/* Rank 0, before any row is written: one line with what the run will
 * take - the outputs' size, the memory per rank and the time. The time
 * comes from a calibration: FF_CALIBRATION_CHUNKS chunks of rows spread
 * over the matrix, together about 1/64 of it, computed by the run's own
 * backend (and computed again later: 1.6 % more work) and scaled to all
 * rows, divided among the ranks. A GPU's chunks of a small scene are
 * mostly launch latency, so small runs are overestimated; runs of fewer
 * than FF_CALIBRATION_MIN patches take seconds and are not calibrated.
 * Sets the progress lines' cadence from the estimate. */
#define FF_CALIBRATION_CHUNKS 4
#define FF_CALIBRATION_MIN 1024
static void estimate(ff_run *run)
{
    uint32_t n = (uint32_t)run->mesh.patch_count;
    double seconds = -1, calibration = 0;
    uint32_t chunk = n / 64 / FF_CALIBRATION_CHUNKS > 2 ? n / 64 / FF_CALIBRATION_CHUNKS : 2;
    if (n >= FF_CALIBRATION_MIN) {
        double *rows = alloc_buffer(run, (size_t)chunk * n);
        double *errors = run->want_errors ? alloc_buffer(run, (size_t)chunk * n) : NULL;
        if (rows && (errors || !run->want_errors)) {
            ff_counters scratch = {0};
            rad_status st = RAD_OK;
            run->calibrating = 1;
            double t0 = ff_comm_time();
            for (uint32_t k = 0; k < FF_CALIBRATION_CHUNKS && st == RAD_OK; k++) {
                uint64_t centre = (uint64_t)n * (2 * k + 1) / (2 * FF_CALIBRATION_CHUNKS);
                uint32_t r0 = centre > chunk / 2 ? (uint32_t)(centre - chunk / 2) : 0;
                if (r0 + chunk > n) r0 = n - chunk;
                st = run->backend->compute_rows(run->backend_state, r0, chunk, rows, errors, &scratch);
            }
            calibration = ff_comm_time() - t0;
            run->calibrating = 0;
            if (st == RAD_OK)
                seconds = calibration * ((double)n / (FF_CALIBRATION_CHUNKS * chunk)) / ff_comm_size(run->comm);
        }
        if (rows) free_buffer(run, (size_t)chunk * n, rows);
        if (errors) free_buffer(run, (size_t)chunk * n, errors);
    }
    char bytes[32], memory[32], time[32], took[32];
    /* The sparse format's size is known once written: the dense size bounds it. */
    const char *bound = run->opt.format == FF_FORMAT_SPARSE ? "at most " : "";
    if (seconds >= 0)
        rad_info("estimate: %s%s to write, about %s of memory per rank, about %s of form factors on %d rank(s) "
                 "(calibrated on %u of %u rows in %s)",
                 bound, format_bytes(run->planned_bytes, bytes, sizeof bytes),
                 format_bytes(run->planned_memory, memory, sizeof memory), format_seconds(seconds, time, sizeof time),
                 ff_comm_size(run->comm), FF_CALIBRATION_CHUNKS * chunk, n,
                 format_seconds(calibration, took, sizeof took));
    else
        rad_info("estimate: %s%s to write, about %s of memory per rank, seconds of form factors", bound,
                 format_bytes(run->planned_bytes, bytes, sizeof bytes),
                 format_bytes(run->planned_memory, memory, sizeof memory));
    run->estimated_seconds = seconds;
    run->progress_every = seconds / 40 > 2.0 ? seconds / 40 : 2.0;
    if (run->progress_tty) run->progress_every = 0.5;
    /* Tests ask for lines at a cadence of their own. */
    const char *every = getenv("RAD_PROGRESS_SECONDS");
    if (every && atof(every) > 0) run->progress_every = atof(every);
}

/* Row buffers of `count` doubles, for the values and (if wanted) the
 * standard errors; collective: fails on every rank if it fails on one. */
static rad_status alloc_buffers(ff_run *run, size_t count, double **rows, double **errors)
{
    *rows = alloc_buffer(run, count);
    *errors = run->want_errors ? alloc_buffer(run, count) : NULL;
    rad_status st = ff_comm_agree(run->comm, *rows && (*errors || !run->want_errors) ? RAD_OK : RAD_ERR_NOMEM);
    if (st != RAD_OK) {
        if (*rows) free_buffer(run, count, *rows);
        if (*errors) free_buffer(run, count, *errors);
        *rows = *errors = NULL;
    }
    return st;
}

/* --reciprocity off: every entry computed, rows stream through one round
 * buffer: compute a round, scale, write it collectively, next. */
static rad_status compute_streamed(ff_run *run, const ff_files *files, ff_counters *counters)
{
    int rank = ff_comm_rank(run->comm);
    uint32_t n = (uint32_t)run->mesh.patch_count;
    uint32_t begin = run->row_begin[rank], end = run->row_begin[rank + 1];
    uint32_t per_round = rows_per_round(run, files->matrix);
    uint64_t rounds = ff_comm_max_u64(run->comm, (end - begin + (uint64_t)per_round - 1) / per_round);
    double *rows = NULL, *errors = NULL;
    rad_status st = alloc_buffers(run, (size_t)per_round * n, &rows, &errors);
    if (st != RAD_OK) {
        rad_error("out of memory for %u rows of %u form factors", per_round, n);
        return st;
    }
    for (uint64_t round = 0; round < rounds; round++) {
        uint32_t r0, count = round_rows(begin, end, per_round, round, &r0);
        if (st == RAD_OK && count > 0) {
            run->progress_base = r0 - begin;
            st = run->backend->compute_rows(run->backend_state, r0, count, rows, errors, counters);
        }
        if (st == RAD_OK) ff_rows_finish(run->patches, n, r0, count, rows, errors, run->stats.threads, &run->stats.rows);
        /* A failed rank still joins the collective write, with no rows. */
        rad_status w = write_round(run, files, r0, st == RAD_OK ? count : 0, rows, errors);
        if (st == RAD_OK) st = w;
    }
    free_buffer(run, (size_t)per_round * n, rows);
    if (errors) free_buffer(run, (size_t)per_round * n, errors);
    return st;
}

/* --reciprocity on: each unordered pair computed once, by the row
 * rad_ff_row_computes picks; the rank's rows (and their errors) stay in
 * memory until the entries computed by other rows (here and on other
 * ranks) are copied in, then they are scaled and written in rounds. */
static rad_status compute_once(ff_run *run, const ff_files *files, ff_counters *counters)
{
    int rank = ff_comm_rank(run->comm);
    uint32_t n = (uint32_t)run->mesh.patch_count;
    uint32_t begin = run->row_begin[rank], end = run->row_begin[rank + 1];
    uint32_t per_round = rows_per_round(run, files->matrix);
    uint64_t rounds = ff_comm_max_u64(run->comm, (end - begin + (uint64_t)per_round - 1) / per_round);
    double *block = NULL, *errors = NULL;
    rad_status st = alloc_buffers(run, (size_t)(end - begin) * n, &block, &errors);
    if (st != RAD_OK) {
        rad_error("out of memory for this rank's %u rows of %u form factors (try --reciprocity off)", end - begin, n);
        return st;
    }
    uint32_t r0, count;
    for (uint64_t round = 0; st == RAD_OK && (count = round_rows(begin, end, per_round, round, &r0)) > 0; round++) {
        run->progress_base = r0 - begin;
        size_t at = (size_t)(r0 - begin) * n;
        st = run->backend->compute_rows(run->backend_state, r0, count, block + at, errors ? errors + at : NULL,
                                        counters);
    }
    st = ff_comm_agree(run->comm, st);
    if (st == RAD_OK) {
        double t0 = ff_comm_time();
        counters->pairs_mirrored += ff_rows_mirror_local(n, begin, end, block, run->stats.threads);
        st = ff_rows_exchange(run->comm, run->row_begin, n, block, &counters->pairs_mirrored);
        if (errors) {
            ff_rows_mirror_local(n, begin, end, errors, run->stats.threads);
            if (st == RAD_OK) st = ff_rows_exchange(run->comm, run->row_begin, n, errors, NULL);
        }
        run->stats.mirror = ff_comm_time() - t0;
    }
    if (st == RAD_OK) {
        ff_rows_finish(run->patches, n, begin, end - begin, block, errors, run->stats.threads, &run->stats.rows);
    }
    /* The sparse format places all the rank's records in row order (the
     * same bytes for any rank count); collective, so every rank joins. */
    uint32_t reserve = st == RAD_OK ? end - begin : 0;
    if (files->matrix) ff_output_reserve(files->matrix, reserve, block);
    if (files->errors) ff_output_reserve(files->errors, reserve, errors);
    if (st == RAD_OK) {
        /* Every rank joins every collective write, with no rows after a failure. */
        for (uint64_t round = 0; round < rounds; round++) {
            count = round_rows(begin, end, per_round, round, &r0);
            size_t at = (size_t)(r0 - begin) * n;
            rad_status w = write_round(run, files, r0, st == RAD_OK ? count : 0, block + at, errors ? errors + at : NULL);
            if (st == RAD_OK) st = w;
        }
    }
    free_buffer(run, (size_t)(end - begin) * n, block);
    if (errors) free_buffer(run, (size_t)(end - begin) * n, errors);
    return st;
}

/* Computes this rank's rows and writes them collectively. */
static rad_status compute_and_write(ff_run *run, const ff_files *files)
{
    int rank = ff_comm_rank(run->comm);
    uint32_t begin = run->row_begin[rank], end = run->row_begin[rank + 1];
    run->stats.row_begin = begin;
    run->stats.row_end = end;
    ff_counters counters = {0};
    rad_status st = run->pairs_once ? compute_once(run, files, &counters) : compute_streamed(run, files, &counters);
    run->stats.counters = counters;
    run->stats.form_factors = counters.kernel_seconds;
    run->stats.visibility = counters.visibility_seconds;
    run->stats.gpu_memory = counters.memory_seconds;
    return st;
}

static rad_status write_stats(ff_run *run, int gpus)
{
    int rank = ff_comm_rank(run->comm), ranks = ff_comm_size(run->comm);
    ff_rank_stats *all = rank == 0 ? calloc((size_t)ranks, sizeof *all) : NULL;
    rad_status st = ff_comm_agree(run->comm, rank == 0 && !all ? RAD_ERR_NOMEM : RAD_OK);
    if (st != RAD_OK) return st;
    run->stats.rank = rank;
    ff_comm_gather(run->comm, &run->stats, sizeof run->stats, all, 0);
    if (rank == 0) {
        const char *scene = run->opt.scene_path ? run->opt.scene_path : rad_default_scene_name;
        ff_run_info info = {.scene = scene, .fingerprint = run->scene.fingerprint,
                            .patch_count = (uint32_t)run->mesh.patch_count, .subdiv = run->opt.subdiv,
                            .subdiv_only = run->opt.subdiv_only, .samples = run->opt.samples,
                            .shadow_rays = run->opt.shadow_rays, .seed = run->opt.seed,
                            .estimator = rad_estimator_name(run->opt.estimator),
                            .cull = run->opt.cull ? "all" : "none", .reciprocity = run->pairs_once ? "on" : "off",
                            .target_error = run->opt.target_error, .max_samples = run->opt.max_samples,
                            .errors = run->want_errors,
                            .backend = run->backend->name,
                            .element = run->opt.element == RAD_ELEMENT_F32 ? "f32" : "f64",
                            .format = run->opt.format == FF_FORMAT_PAPER    ? "paper"
                                      : run->opt.format == FF_FORMAT_SPARSE ? "sparse"
                                                                            : "native",
                            .output = run->opt.output, .ranks = ranks, .gpus_visible = gpus};
        ff_stats_log_summary(&info, all);
        if (run->opt.stats_path) st = ff_stats_write_json(run->opt.stats_path, &info, all);
    }
    free(all);
    return ff_comm_agree(run->comm, st);
}

static rad_status run_formfactor(ff_run *run)
{
    int rank = ff_comm_rank(run->comm);
    run->start = ff_comm_time();
    /* Loading is deterministic, so rank 0 alone reports its errors. */
    rad_log_level level = rad_log_get_level();
    if (rank != 0) rad_log_set_level(RAD_LOG_NONE);
    rad_status st = ff_comm_agree(run->comm, load(run));
    if (rank != 0) rad_log_set_level(level);
    if (st != RAD_OK) return st;
    if (run->mesh.patch_count > UINT32_MAX / 2) {
        if (rank == 0) rad_error("%zu patches: more than this format's 2^31 limit", run->mesh.patch_count);
        return RAD_ERR_NOMEM;
    }
    /* Asking CUDA starts its driver (~0.5 s); a CPU run does not need it. */
    int gpus = strcmp(run->opt.backend, "cpu") ? ff_cuda_device_count() : 0;
    if ((st = ff_comm_agree(run->comm, select_backend(run, gpus))) != RAD_OK) return st;
    if ((st = ff_comm_agree(run->comm, setup(run))) != RAD_OK) return st;
    if (rank == 0)
        rad_info("%s: %zu patches from %zu faces, %u samples and %u shadow rays per pair, %d rank(s) x %d thread(s), "
                 "backend %s",
                 run->opt.scene_path ? run->opt.scene_path : rad_default_scene_name, run->mesh.patch_count,
                 run->scene.face_count, run->opt.samples, run->opt.shadow_rays, ff_comm_size(run->comm),
                 run->stats.threads, run->backend->name);
    run->progress_every = 2.0;
    run->estimated_seconds = -1;
    run->progress_tty = rank == 0 && isatty(STDERR_FILENO) && rad_log_get_level() >= RAD_LOG_INFO;
    if (rank == 0 && rad_log_get_level() >= RAD_LOG_INFO) estimate(run);

    rad_ff_info info = {.patch_count = run->mesh.patch_count, .vertex_count = run->mesh.vertex_count,
                        .element_type = run->opt.element, .estimator = run->opt.estimator,
                        .samples = run->opt.samples, .shadow_rays = run->opt.shadow_rays, .seed = run->opt.seed,
                        .scene_fingerprint = run->scene.fingerprint, .subdiv = run->opt.subdiv,
                        .flags = run->opt.subdiv_only ? RAD_FF_FLAG_PARTIAL_SUBDIV : 0,
                        .group_count = (uint32_t)run->mesh.group_count};
    snprintf(info.scene_name, sizeof info.scene_name, "%s",
             run->opt.scene_path ? run->opt.scene_path : rad_default_scene_name);
    ff_files files = {0};
    double t0 = ff_comm_time();
    st = ff_output_open(run->comm, run->opt.output, run->opt.format, &info, &run->mesh, &files.matrix);
    if (st == RAD_OK && run->opt.errors_path) {
        rad_ff_info error_info = info;
        error_info.element_type = RAD_ELEMENT_F32;
        error_info.flags |= RAD_FF_FLAG_STANDARD_ERRORS;
        ff_format format = run->opt.format == FF_FORMAT_SPARSE ? FF_FORMAT_SPARSE : FF_FORMAT_NATIVE;
        st = ff_output_open(run->comm, run->opt.errors_path, format, &error_info, &run->mesh, &files.errors);
        if (st != RAD_OK) files.errors = NULL;
    }
    if (files.matrix) ff_output_set_threads(files.matrix, run->stats.threads);
    if (files.errors) ff_output_set_threads(files.errors, run->stats.threads);
    run->stats.io += ff_comm_time() - t0;
    ff_comm_progress_open(run->comm);
    run->compute_start = ff_comm_time();
    run->progress_said_at = run->compute_start;
    if (st == RAD_OK) st = compute_and_write(run, &files);
    ff_comm_progress_close(run->comm);
    if (run->progress_tty && run->progress_said_at > run->compute_start) fputc('\n', stderr); /* end the updating line */
    t0 = ff_comm_time();
    /* Both files are written and closed before either is renamed; the
     * errors file is renamed first, so a failure there leaves the old
     * matrix in place too. (Both destinations were checked up front.) */
    if (files.matrix) st = ff_output_close(files.matrix, st);
    if (files.errors) st = ff_output_close(files.errors, st);
    if (files.errors) st = ff_output_commit(files.errors, st);
    if (files.matrix) st = ff_output_commit(files.matrix, st);
    run->stats.io += ff_comm_time() - t0;
    run->stats.total = ff_comm_time() - run->start;
    if (st != RAD_OK) return st;
    if (rank == 0) rad_info("wrote %s%s%s", run->opt.output, run->opt.errors_path ? " and " : "",
                            run->opt.errors_path ? run->opt.errors_path : "");
    return write_stats(run, gpus);
}

static void run_free(ff_run *run)
{
    if (run->backend && run->backend_state) run->backend->destroy(run->backend_state);
    free(run->patches);
    free(run->triangles);
    free(run->triangle_face);
    free(run->row_begin);
    rad_mesh_free(&run->mesh);
    rad_scene_free(&run->scene);
}

int main(int argc, char **argv)
{
    rad_log_set_program("formfactor");
    ff_comm *comm = NULL;
    rad_status st = ff_comm_init(&argc, &argv, &comm);
    if (st != RAD_OK) return rad_status_exit_code(st);
    int rank = ff_comm_rank(comm);
    ff_run run = {.comm = comm};
    /* Every rank parses the same argv; rank 0 speaks for all. */
    rad_log_level level = rad_log_get_level();
    if (rank != 0) rad_log_set_level(RAD_LOG_NONE);
    st = parse_options(argc, argv, &run.opt);
    if (rank != 0) rad_log_set_level(level);
    if (st == RAD_OK && (run.opt.help || run.opt.version)) {
        if (rank == 0) {
            if (run.opt.help) print_help();
            else printf("formfactor %s\n", FF_VERSION);
        }
    } else if (st == RAD_OK) {
        if (run.opt.quiet) rad_log_set_level(RAD_LOG_ERROR);
        if (rank != 0) rad_log_set_level(RAD_LOG_ERROR);
        st = run_formfactor(&run);
    } else if (rank == 0) {
        fprintf(stderr, "formfactor: try --help\n");
    }
    run_free(&run);
    ff_comm_finalize(comm);
    return rad_status_exit_code(st);
}
