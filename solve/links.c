/* links.c - solve on a file of links (links.h; docs/solve.md, "On links"):
 * the options checked, the leaves' row sums judged as a matrix's rows are
 * (matrix.h: the row-sum note or warning, the refusal of rho * row sum
 * >= 1), the flat solve (rad_lsolve on the CPU, or Jacobi sweeps on the
 * GPU: solve_links_flat_on_gpu), the shaped solve (on the CPU, or the GPU:
 * --backend),
 * then the radiosity file of the leaves mesh and the stats, as stage.c
 * writes them for a matrix. */
#include "links.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpu.h"
#include "matrix.h"
#include "rad_clock.h"
#include "rad_log.h"
#include "rad_lsolve.h"
#include "rad_rfile.h"
#include "shaped.h"
#include "stats.h"

rad_status solve_links_run(const solve_options *options, rad_ff_file *file)
{
    const double start = rad_clock_seconds();
    rad_links links;
    memset(&links, 0, sizeof links);
    rad_status status = solve_comm_agree(options->comm, rad_ff_read_links(file, &links));
    if (status == RAD_OK) {
        solve_links_input in = {.info = rad_ff_file_info(file), .leaves = rad_ff_file_mesh(file), .links = &links,
                                .load_seconds = rad_clock_seconds() - start};
        status = solve_links_solve(options, &in);
    }
    rad_links_free(&links);
    return status;
}

/* --method on links: Gauss-Seidel (auto's choice too) or Jacobi; and the
 * options that do not apply to links. */
static rad_status check_options(const solve_options *options, const char *input, rad_lsolve_method *out_method)
{
    if (options->params.method == SOLVE_CG) {
        rad_error("%s: holds links (hierarchical radiosity), which solve sweeps: --method gauss-seidel (or auto) "
                  "or jacobi; cg needs the matrix, which a link file does not store",
                  input);
        return RAD_ERR_USAGE;
    }
    if (options->errors) {
        rad_error("%s: holds links, each with its own error bound: --errors (the standard errors of a matrix's "
                  "entries) does not apply",
                  input);
        return RAD_ERR_USAGE;
    }
    if (options->by_group) {
        rad_error("%s: holds links: --by-group is not available for link files yet (issue 26)", input);
        return RAD_ERR_USAGE;
    }
    if (options->backend == SOLVE_BACKEND_CUDA && options->no_shape) {
        rad_info("%s: holds links, whose flat sweeps run on the CPU (--backend cuda runs the shaped solve, which "
                 "--shape off leaves out, and the flat sweeps that start it)",
                 input);
    } else if (options->backend == SOLVE_BACKEND_CUDA && !solve_gpu_built()) {
        rad_error("--backend cuda: this build of solve has no CUDA (nvcc was not found when it was configured, or "
                  "-DRAD_WITH_CUDA=OFF); --backend cpu or auto solves on the CPU");
        return RAD_ERR_UNSUPPORTED;
    } else if (options->backend == SOLVE_BACKEND_CUDA && solve_gpu_device_count() == 0) {
        rad_error("--backend cuda: no CUDA device is visible (no GPU, no driver, or CUDA_VISIBLE_DEVICES hides them); "
                  "--backend cpu or auto solves on the CPU");
        return RAD_ERR_BACKEND;
    }
    *out_method = options->params.method == SOLVE_JACOBI ? RAD_LSOLVE_JACOBI : RAD_LSOLVE_GAUSS_SEIDEL;
    return RAD_OK;
}

/* Each leaf's row sum, the F of its links, of its ancestors' and of the
 * clusters' that hold its root (leaf_count values, by leaf); NULL when out
 * of memory. The links are as rad_links_check passes them: parents before
 * children (clusters too), leaves in range, every root in one leaf
 * cluster. */
static double *leaf_row_sums(const rad_links *L)
{
    const uint32_t n = L->node_count;
    const uint64_t ids = rad_links_id_count(L);
    double *id = malloc((ids ? ids : 1) * sizeof *id);
    double *leaf = malloc((L->leaf_count ? L->leaf_count : 1) * sizeof *leaf);
    uint32_t *root_cluster = L->cluster_count ? malloc((size_t)L->root_count * sizeof *root_cluster) : NULL;
    if (!id || !leaf || (L->cluster_count && !root_cluster)) {
        free(id);
        free(leaf);
        free(root_cluster);
        return NULL;
    }
    /* each id's own links, summed in order on the threads; then down the trees */
#pragma omp parallel for schedule(dynamic, 1024)
    for (uint64_t i = 0; i < ids; i++) {
        double s = 0;
        for (uint64_t k = L->first_link[i]; k < L->first_link[i + 1]; k++) s += L->links[k].factor;
        id[i] = s;
    }
    for (uint32_t c = 0; c < L->cluster_count; c++) { /* down the cluster tree */
        const rad_link_cluster *k = &L->clusters[c];
        id[n + c] += k->parent != RAD_NO_ELEMENT ? id[n + k->parent] : 0;
        if (k->child_count == 0)
            for (uint32_t q = k->root_begin; q < k->root_end; q++) root_cluster[L->cluster_roots[q]] = c;
    }
    for (uint32_t i = 0; i < n; i++) {
        const double s = id[i];
        uint32_t up = L->nodes[i].parent;
        if (up == RAD_NO_ELEMENT && root_cluster) up = n + root_cluster[i];
        id[i] = s + (up != RAD_NO_ELEMENT ? id[up] : 0);
        if (L->nodes[i].first_child == RAD_NO_ELEMENT) leaf[L->nodes[i].leaf] = id[i];
    }
    free(id);
    free(root_cluster);
    return leaf;
}

/* The links at a cluster or from one. */
static uint64_t cluster_link_count(const rad_links *L)
{
    const uint32_t n = L->node_count;
    uint64_t count = L->first_link[rad_links_id_count(L)] - L->first_link[n];
#pragma omp parallel for schedule(static) reduction(+ : count)
    for (uint64_t k = 0; k < L->first_link[n]; k++) count += L->links[k].source >= n;
    return count;
}

/* The bound on ||B - B_exact||_inf of a channel (solver.h's): residual
 * ||E||_inf / (1 - max rho), the exact factors' rows summing to at most 1
 * (a leaf's row sum through coarse links is the hierarchy's approximation,
 * which the file's error bound covers). */
static double channel_error_bound(const rad_mesh *leaves, const double *row_sum, int c, double residual)
{
    (void)row_sum;
    double e_norm = 0, reflected = 0;
    for (size_t l = 0; l < leaves->patch_count; l++) {
        const rad_patch *p = &leaves->patches[l];
        if (p->emission[c] > e_norm) e_norm = p->emission[c];
        if (p->rho[c] > reflected) reflected = p->rho[c];
    }
    return reflected < 1 ? residual * e_norm / (1 - reflected) : INFINITY;
}

/* What solve_links_solve works with; freed in one place. */
typedef struct links_state {
    const solve_options *options;
    const solve_links_input *in;
    const char *input, *output;
    double start;
    int grey;
    rad_lsolve_options solve;
    rad_lsolve_result result;
    rad_status solved; /* RAD_OK or RAD_ERR_NOT_CONVERGED */
    int flat_gpu;      /* the flat solve ran on the GPU (solve_links_flat_gpu) */
    char flat_device[128];
    int shaped;        /* the shaped solve ran (shaped.h) */
    int closure;       /* the rows balanced to 1 (rad_closure.h) */
    solve_shaped_result shape;
    solve_row_sum_summary row_sums;
    double *row_sum;   /* by leaf */
    double *radiosity; /* 3 per leaf */
    solve_report reports[3];
} links_state;

/* The leaves' row sums: not judged as a matrix's rows are. A leaf's row
 * sum is what its links and its ancestors' carry, each the mean factor of
 * a larger element; near an edge of that element it can lie well above 1
 * (1.5 on the Cornell box at --link-tol 1e-3) while the elements' own
 * sums, which the links conserve, do not. So the note says so, and no row
 * is refused: the sweeps' residual says whether the solve converged. */
static rad_status judge_rows(links_state *s)
{
    const rad_mesh *leaves = s->in->leaves;
    solve_row_sum_summary sum = {0};
    for (size_t l = 0; l < leaves->patch_count; l++)
        if (s->row_sum[l] > sum.max) sum.max = s->row_sum[l], sum.max_row = l;
    for (size_t l = 0; l < leaves->patch_count; l++) sum.warned += s->row_sum[l] > 1.001;
    s->row_sums = sum;
    if (sum.warned)
        rad_info("%s: %zu leaves gather more than 1.001 of their light through links above them (largest: leaf %zu, "
                 "%.4f): the hierarchy's approximation near the edges of coarse elements, bounded by the file's "
                 "error bound, not noise",
                 s->input, sum.warned, sum.max_row, sum.max);
    return RAD_OK;
}

/* Where the shaped solve ran, if not on the CPU. */
static int shaped_on_gpu(const links_state *s) { return s->shaped && s->shape.backend == SOLVE_SHAPED_CUDA; }

/* Where the flat and the shaped solve ran, in words. */
static const char *backend_words(const links_state *s)
{
    if (s->flat_gpu) return !s->shaped || shaped_on_gpu(s) ? "cuda" : "cuda, the shaped solve cpu";
    return shaped_on_gpu(s) ? "cpu, the shaped solve cuda" : "cpu";
}

/* The channels' reports, as stage.c logs and stats.c writes them. */
static void fill_reports(links_state *s)
{
    static const char *const rgb_names[3] = {"red", "green", "blue"};
    const int channels = s->grey ? 1 : 3;
    const rad_lsolve_result *r = &s->result;
    for (int c = 0; c < channels; c++) {
        solve_report *rep = &s->reports[c];
        memset(rep, 0, sizeof *rep);
        rep->method_used = s->solve.method == RAD_LSOLVE_JACOBI || s->flat_gpu ? SOLVE_JACOBI : SOLVE_GAUSS_SEIDEL;
        rep->iterations = r->iterations[c];
        rep->residual = r->residual[c];
        rep->converged = r->residual[c] <= s->solve.tolerance;
        rep->seconds = r->seconds; /* the channels' solve together */
        rep->reciprocity = -1;     /* not measured */
        rep->margin = NAN;
        rep->error_bound = channel_error_bound(s->in->leaves, s->row_sum, c, r->residual[c]);
        /* the balance is over the channels together (the stats' "balance") */
        rep->balance = (solve_balance){NAN, NAN, NAN, NAN};
        rad_info("%s: %s: %s on links, %u iterations, residual %.3g, %.3f s, backend %s", s->input,
                 s->grey ? "grey" : rgb_names[c], solve_method_name(rep->method_used), rep->iterations,
                 rep->residual, rep->seconds, backend_words(s));
    }
    rad_info("%s: energy%s: emitted %.9g, absorbed %.9g, escaped %.9g (imbalance %.2g)", s->input,
             s->grey ? "" : " (the channels summed)", r->emitted, r->absorbed, r->escaped, r->imbalance);
}

/* The flat solve's tolerance where the shaped solve follows it (below). */
#define SOLVE_LINKS_FLAT_START_TOL 1e-6

/* --tol on links where none is given. Each link may move its receiver by
 * link-tol times the mean radiosity (formfactor's oracle), so a residual
 * far below that buys nothing: 1e-4 of link-tol, within [1e-10, 1e-6]
 * (link-tol 1e-2: 1e-6, and the Cornell box's B at 1.4e-7 of max B from
 * 1e-10's, in 16 fewer sweeps); exact links (link-tol 0) take
 * SOLVE_DEFAULT_TOLERANCE. */
static double links_default_tolerance(double link_tol)
{
    const double t = 1e-4 * link_tol;
    return !(t > SOLVE_DEFAULT_TOLERANCE) ? SOLVE_DEFAULT_TOLERANCE : t < 1e-6 ? t : 1e-6;
}

/* The shaped solve's gate (shaped.h): an end is shaped where that may
 * move a leaf by a tenth of what the oracle let each link err by. */
#define SHAPE_GATE_OF_LINK_TOL 0.1

/* --backend for the shaped solve: cuda on the GPU (each rank its own,
 * rank mod the devices); auto the GPU from SOLVE_SHAPED_GPU_MIN_WEIGHTS
 * point factors up, for one process (ranks each solving alone would each
 * start CUDA); cpu the CPU. */
static solve_shaped_backend shaped_backend(const solve_options *options)
{
    if (options->backend == SOLVE_BACKEND_CUDA) return SOLVE_SHAPED_CUDA;
    if (options->backend == SOLVE_BACKEND_AUTO && solve_comm_size(options->comm) == 1) return SOLVE_SHAPED_AUTO;
    return SOLVE_SHAPED_CPU;
}

/* The shaped solve from the flat solution, unless --shape off. Its
 * residual, sweeps and balance replace the flat ones in the outputs. */
static rad_status shape(links_state *s)
{
    if (s->options->no_shape) return RAD_OK;
    const solve_shaped_options o = {.threads = s->options->threads,
                                    .backend = shaped_backend(s->options),
                                    .device = solve_comm_rank(s->options->comm),
                                    .gate = SHAPE_GATE_OF_LINK_TOL * s->in->links->link_tol,
                                    .tolerance = s->solve.tolerance,
                                    .max_iterations = s->solve.max_iterations,
                                    .channels = s->grey ? 1 : 3,
                                    .closure = s->closure};
    rad_status status = solve_shaped(s->in->links, s->in->leaves, &o, s->radiosity, &s->shape);
    /* each rank solved alone (a GPU may fail on one): a failure anywhere is every rank's */
    const rad_status failed = solve_comm_agree(s->options->comm, status == RAD_ERR_NOT_CONVERGED ? RAD_OK : status);
    if (failed != RAD_OK) return failed;
    s->shaped = 1;
    const solve_shaped_result *r = &s->shape;
    rad_info("%s: shaped: %llu link ends spread over their leaves (%llu point factors), %u iterations, residual "
             "%.3g, B moved by up to %.3g of its largest value, %.3f s (factors %.3f s, sweeps %.3f s), backend %s%s%s",
             s->input, (unsigned long long)r->shaped_ends, (unsigned long long)r->weights, r->iterations, r->residual,
             r->change, r->seconds, r->factor_seconds, r->sweep_seconds, solve_shaped_backend_name(r->backend),
             r->backend == SOLVE_SHAPED_CUDA ? ": " : "", r->backend == SOLVE_SHAPED_CUDA ? r->device : "");
    for (int c = 0; c < 3; c++) {
        s->result.iterations[c] += r->iterations;
        s->result.residual[c] = r->residual;
    }
    s->result.converged = r->converged;
    s->result.emitted = r->emitted;
    s->result.absorbed = r->absorbed;
    s->result.escaped = r->escaped;
    s->result.imbalance = r->imbalance;
    return status;
}

static rad_status write_outputs(const links_state *s)
{
    const solve_links_input *in = s->in;
    rad_radiosity out;
    memset(&out, 0, sizeof out);
    out.mesh = *in->leaves; /* borrowed; not freed here */
    out.radiosity = s->radiosity;
    out.channel_count = s->grey ? 1 : 3;
    out.method = (uint32_t)s->reports[0].method_used;
    out.converged = s->solved == RAD_OK;
    out.tolerance = s->solve.tolerance;
    for (int c = 0; c < 3; c++) {
        out.iterations[c] = s->result.iterations[c];
        out.residual[c] = s->result.residual[c];
        out.channel_method[c] = out.method;
    }
    const int rank = solve_comm_rank(s->options->comm);
    solve_radiosity_describe(in->info, s->input, rank == 0, &out);
    rad_status status = rank == 0 ? rad_rf_write(s->output, &out) : RAD_OK;
    status = solve_comm_agree(s->options->comm, status);
    if (status != RAD_OK || !s->options->stats) return status;
    static const char *const rgb_names[3] = {"red", "green", "blue"};
    const solve_stats_links links = {.node_count = in->links->node_count,
                                     .leaf_count = in->links->leaf_count,
                                     .link_count = in->links->link_count,
                                     .link_tol = in->links->link_tol,
                                     .error_bound = in->links->error_bound,
                                     .balance = {s->result.emitted, s->result.absorbed, s->result.escaped,
                                                 s->result.imbalance},
                                     .shaped = s->shaped ? &s->shape : NULL,
                                     .closure = !s->closure ? NULL : s->shaped ? &s->shape.closure : &s->result.closure};
    solve_stats st = {
        .input = s->input,
        .output = s->output,
        .row_sums = s->row_sums,
        .patch_count = in->leaves->patch_count,
        .method = s->options->params.method,
        .tolerance = s->solve.tolerance,
        .max_iterations = s->solve.max_iterations,
        .load_seconds = in->load_seconds,
        .backend = shaped_on_gpu(s) || s->flat_gpu ? "cuda" : "cpu",
        .device = shaped_on_gpu(s) ? s->shape.device : s->flat_gpu ? s->flat_device : NULL,
        .device_exact = -1,
        .total_seconds = in->load_seconds + rad_clock_seconds() - s->start,
        .converged = s->solved == RAD_OK,
        .channel_count = (uint32_t)out.channel_count,
        .rank_count = (uint32_t)solve_comm_size(s->options->comm),
        .links = &links,
    };
    for (uint32_t c = 0; c < out.channel_count; c++) {
        st.channel_names[c] = s->grey ? "grey" : rgb_names[c];
        st.reports[c] = &s->reports[c];
    }
    status = rank == 0 ? solve_stats_write(s->options->stats, &st) : RAD_OK;
    return solve_comm_agree(s->options->comm, status);
}

int solve_links_flat_on_gpu(solve_backend backend, int ranks, uint64_t link_count)
{
    if (backend == SOLVE_BACKEND_CUDA) return 1;
    return backend == SOLVE_BACKEND_AUTO && ranks == 1 && link_count >= SOLVE_LINKS_FLAT_GPU_MIN_LINKS &&
           solve_gpu_built() && solve_gpu_device_count() > 0;
}

rad_status solve_links_flat_gpu(const rad_links *links, const rad_mesh *leaves, const rad_lsolve_options *o,
                                int device, double *B, rad_lsolve_result *out, char *device_name)
{
    const rad_lsolve_options defaults = rad_lsolve_defaults();
    if (!o->warm_start)
        for (size_t k = 0; k < leaves->patch_count; k++)
            memcpy(&B[3 * k], leaves->patches[k].emission, 3 * sizeof *B);
    const solve_shaped_options so = {.threads = o->threads,
                                     .backend = SOLVE_SHAPED_CUDA,
                                     .device = device,
                                     .tolerance = o->tolerance > 0 ? o->tolerance : defaults.tolerance,
                                     .max_iterations = o->max_iterations ? o->max_iterations : defaults.max_iterations,
                                     .channels = o->channels == 1 ? 1 : 3,
                                     .flat = 1};
    solve_shaped_result r;
    const rad_status st = solve_shaped(links, leaves, &so, B, &r);
    if (st != RAD_OK && st != RAD_ERR_NOT_CONVERGED) {
        rad_warn("the flat solve could not run on the GPU (above): it runs on the CPU");
        return RAD_ERR_BACKEND;
    }
    memset(out, 0, sizeof *out);
    for (int c = 0; c < 3; c++) out->iterations[c] = r.iterations, out->residual[c] = r.residual;
    out->converged = r.converged;
    out->emitted = r.emitted, out->absorbed = r.absorbed, out->escaped = r.escaped;
    out->imbalance = r.imbalance;
    out->seconds = r.seconds;
    if (device_name) snprintf(device_name, 128, "%s", r.device);
    return st;
}

/* Whether the flat solve handed in is the one `o` would run, on the GPU
 * where `gpu` (from B = E, converged within o's iteration limit: the same
 * sweeps). */
static int flat_taken(const solve_links_flat *given, const rad_lsolve_options *o, int gpu)
{
    if (!given || o->warm_start || o->closure || !given->result.converged || given->tolerance != o->tolerance ||
        given->method != o->method || given->channels != o->channels || !given->gpu != !gpu)
        return 0;
    for (int c = 0; c < given->channels; c++)
        if (given->result.iterations[c] > o->max_iterations) return 0;
    return 1;
}

rad_status solve_links_solve(const solve_options *options, const solve_links_input *in)
{
    links_state s;
    memset(&s, 0, sizeof s);
    s.options = options;
    s.in = in;
    s.input = options->input ? options->input : SOLVE_DEFAULT_INPUT;
    s.output = options->output ? options->output : SOLVE_DEFAULT_OUTPUT;
    s.start = rad_clock_seconds();
    const rad_links *links = in->links;
    const rad_mesh *leaves = in->leaves;
    s.solve = rad_lsolve_defaults();
    /* agreed: whether a GPU is visible may differ between ranks */
    rad_status status = solve_comm_agree(options->comm, check_options(options, s.input, &s.solve.method));
    if (status == RAD_OK && links->leaf_count != leaves->patch_count) {
        rad_error("%s: %u leaves in the links, %zu patches in the patch table", s.input, links->leaf_count,
                  leaves->patch_count);
        status = RAD_ERR_INVALID;
    }
    if (status == RAD_OK) {
        s.row_sum = leaf_row_sums(links);
        s.radiosity = malloc((leaves->patch_count ? 3 * leaves->patch_count : 1) * sizeof *s.radiosity);
        if (!s.row_sum || !s.radiosity) {
            rad_error("%s: out of memory for %zu leaves", s.input, leaves->patch_count);
            status = RAD_ERR_NOMEM;
        }
    }
    if (status == RAD_OK) status = judge_rows(&s);
    if (status == RAD_OK) {
        s.grey = solve_mesh_is_grey(leaves);
        s.solve.tolerance = options->params.tolerance > 0 ? options->params.tolerance
                                                         : links_default_tolerance(links->link_tol);
        s.solve.max_iterations =
            options->params.max_iterations ? options->params.max_iterations : SOLVE_DEFAULT_MAX_ITERATIONS;
        s.solve.channels = s.grey ? 1 : 3;
        rad_info("%s: %u nodes over %u roots, %u leaves, %llu links (%.1f a leaf), %s, read in %.2f s", s.input,
                 links->node_count, links->root_count, links->leaf_count, (unsigned long long)links->link_count,
                 links->leaf_count ? (double)links->link_count / links->leaf_count : 0.0,
                 s.grey ? "grey (solved once)" : "RGB", in->load_seconds);
        if (links->cluster_count)
            rad_info("%s: %u clusters above the roots, %llu links at or from a cluster (solved flat)", s.input,
                     links->cluster_count, (unsigned long long)cluster_link_count(links));
        /* With the shaped solve to follow, the flat solution is its start
         * and its gate, and the shape moves B by percents (0.06 of max B
         * on cornell_sphere): solved past SOLVE_LINKS_FLAT_START_TOL,
         * the flat sweeps would only be undone. The shaped sweeps then
         * meet --tol. */
        rad_lsolve_options flat = s.solve;
        if (!options->no_shape && flat.tolerance < SOLVE_LINKS_FLAT_START_TOL)
            flat.tolerance = SOLVE_LINKS_FLAT_START_TOL;
        s.closure = options->closure == SOLVE_CLOSURE_ON ||
                    (options->closure == SOLVE_CLOSURE_AUTO && in->info && (in->info->flags & RAD_FF_FLAG_CLOSED));
        if (s.closure)
            rad_info("%s: closure: the scene is closed%s; every leaf's row balanced to 1 (reciprocity kept)", s.input,
                     options->closure == SOLVE_CLOSURE_ON ? " (--closure on)" : " (formfactor found it so)");
        flat.closure = s.closure && options->no_shape; /* the shaped solve balances its own operator */
        const int flat_gpu = !options->no_shape && solve_links_flat_on_gpu(options->backend,
                                                                            solve_comm_size(options->comm),
                                                                            links->link_count);
        if (flat_taken(in->flat, &flat, flat_gpu)) {
            memcpy(s.radiosity, in->flat->B, 3 * leaves->patch_count * sizeof *s.radiosity);
            s.result = in->flat->result;
            s.flat_gpu = in->flat->gpu;
            snprintf(s.flat_device, sizeof s.flat_device, "%s", in->flat->device ? in->flat->device : "");
            rad_info("%s: flat: the last pass's solve taken as it is (to %.3g, %u sweeps%s)", s.input, flat.tolerance,
                     s.result.iterations[0], s.flat_gpu ? ", Jacobi on the GPU" : "");
        } else {
            status = flat_gpu ? solve_links_flat_gpu(links, leaves, &flat, solve_comm_rank(options->comm),
                                                     s.radiosity, &s.result, s.flat_device)
                              : RAD_ERR_BACKEND;
            s.flat_gpu = status == RAD_OK || status == RAD_ERR_NOT_CONVERGED;
            if (status == RAD_ERR_BACKEND) status = rad_lsolve(links, leaves, &flat, s.radiosity, &s.result);
        }
        if (status == RAD_OK) status = shape(&s);
    }
    if (status == RAD_OK || status == RAD_ERR_NOT_CONVERGED) {
        s.solved = status;
        fill_reports(&s);
        status = write_outputs(&s);
        if (status == RAD_OK && s.solved != RAD_OK) {
            rad_error("%s: not converged; wrote %s marked unconverged (raise --max-iter)", s.input, s.output);
            status = s.solved;
        } else if (status == RAD_OK) {
            rad_info("%s: wrote %s", s.input, s.output);
        }
    }
    free(s.row_sum);
    free(s.radiosity);
    for (int c = 0; c < 3; c++) solve_report_free(&s.reports[c]);
    return status;
}
