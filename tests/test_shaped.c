/* test_shaped.c - the shaped solve's backends (solve/shaped.h,
 * solve/shaped_gpu.h) on files of links, each from its flat solution
 * (rad_lsolve to 1e-13), at --tol 1e-12:
 *
 *  1. The CPU's Gauss-Seidel against the host twin of the GPU's steps
 *     (SOLVE_SHAPED_HOST: shaped_host.c, the kernels' items through the
 *     same shaped_math.h functions in the same order): both converged,
 *     residual <= the tolerance, the same ends and point factors, B within
 *     1e-9 of max B (the two methods' stopping points, each within 1e-12),
 *     the energy balance alike (the row sums made per leaf, as on the GPU,
 *     against the host's), the twin the same bits run after run.
 *     Gauss-Seidel tree by tree and in groups of trees of several sizes
 *     (solve_shaped_options.group_work): the same bits on 1 and 3
 *     threads, each within 1e-9 of max B of tree by tree.
 *  2. Backend choice: auto below SOLVE_SHAPED_GPU_MIN_WEIGHTS runs the
 *     CPU, to the bit; cuda without a usable device (none built, or none
 *     visible) is an error and leaves B untouched.
 *  3. With --cuda (label gpu; 77 where no device is visible): the GPU
 *     against its host twin: the same ends and factors counted, B the
 *     same bits and the same iterations - unless a point factor's float
 *     rounds the other way because the GPU's atan2 differs from the host's
 *     in the last bit (odds ~1e-8 a factor; one such moves a leaf by up to
 *     ~1e-8 of B), so held to 1e-9 of max B and iterations within 1, with
 *     the bits' identity printed; the same bits when run again.
 *
 * 4. The flat operator (options.flat) from B = E: the CPU and the host
 *    twin within 1e-9 of max B of rad_lsolve's flat solution; with --cuda
 *    the GPU the same bits as its twin.
 *
 * The hierarchical files drop ends (point factors that sum to 0: 14 and
 * 31 of them on the sphere's files), so the drops are checked too: on the
 * host's plan (CPU), by the twin, and by the GPU's kernel.
 *
 * usage: test_shaped [--cuda] LINKS...
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gpu.h"
#include "rad_ffile.h"
#include "rad_lsolve.h"
#include "rad_test.h"
#include "shaped.h"
#include "stage.h"

#define TEST_TOL 1e-12

typedef struct fixture {
    const char *path;
    rad_ff_file *file;
    rad_links links;
    const rad_mesh *leaves;
    int channels;
    double *flat; /* 3 per leaf */
} fixture;

static void fixture_free(fixture *x)
{
    rad_links_free(&x->links);
    rad_ff_close(x->file);
    free(x->flat);
}

static int fixture_load(const char *path, fixture *x)
{
    memset(x, 0, sizeof *x);
    x->path = path;
    if (rad_ff_open(path, &x->file) != RAD_OK || rad_ff_read_links(x->file, &x->links) != RAD_OK) return 0;
    x->leaves = rad_ff_file_mesh(x->file);
    x->channels = solve_mesh_is_grey(x->leaves) ? 1 : 3;
    x->flat = malloc(3 * x->leaves->patch_count * sizeof *x->flat);
    if (!x->flat) return 0;
    rad_lsolve_options o = rad_lsolve_defaults();
    o.tolerance = 1e-13;
    o.max_iterations = 100000;
    o.channels = x->channels;
    rad_lsolve_result r;
    return rad_lsolve(&x->links, x->leaves, &o, x->flat, &r) == RAD_OK;
}

/* The shaped solve by `backend` from the flat solution into B (malloc'd),
 * on `threads` (0: OpenMP's default) with Gauss-Seidel's groups closing at
 * `group_work` (0: the default). */
static rad_status run_with(const fixture *x, solve_shaped_backend backend, int threads, uint64_t group_work,
                           int closure, double **out_B, solve_shaped_result *out)
{
    const size_t n = 3 * x->leaves->patch_count;
    double *B = malloc(n * sizeof *B);
    if (!B) return RAD_ERR_NOMEM;
    memcpy(B, x->flat, n * sizeof *B);
    const solve_shaped_options o = {.backend = backend,
                                    .gate = 0.1 * x->links.link_tol,
                                    .tolerance = TEST_TOL,
                                    .max_iterations = 10000,
                                    .channels = x->channels,
                                    .threads = threads,
                                    .group_work = group_work,
                                    .closure = closure};
    memset(out, 0, sizeof *out);
    rad_status status = solve_shaped(&x->links, x->leaves, &o, B, out);
    *out_B = B;
    return status;
}

static rad_status run(const fixture *x, solve_shaped_backend backend, double **out_B, solve_shaped_result *out)
{
    return run_with(x, backend, 0, 0, 0, out_B, out);
}

/* max |a - b| over max |b|. */
static double worst_relative(const double *a, const double *b, size_t n)
{
    double most = 0, diff = 0;
    for (size_t i = 0; i < n; i++) {
        most = fmax(most, fabs(b[i]));
        diff = fmax(diff, fabs(a[i] - b[i]));
    }
    return most > 0 ? diff / most : diff;
}

static void check_result(const char *what, rad_status status, const solve_shaped_result *r,
                         solve_shaped_backend backend)
{
    RAD_CHECK(status == RAD_OK);
    RAD_CHECK(r->converged);
    RAD_CHECK(r->residual <= TEST_TOL);
    RAD_CHECK(r->backend == backend);
    RAD_CHECK(r->seconds >= r->factor_seconds + r->sweep_seconds - 1e-9);
    printf("  %s: %llu ends, %llu point factors, %u iterations, residual %.3g, imbalance %.3g, %.3f s (factors "
           "%.3f, sweeps %.3f), %s\n",
           what, (unsigned long long)r->shaped_ends, (unsigned long long)r->weights, r->iterations, r->residual,
           r->imbalance, r->seconds, r->factor_seconds, r->sweep_seconds, r->device);
}

/* 1 and 2 on one file. */
static void check_host(const fixture *x)
{
    const size_t n = 3 * x->leaves->patch_count;
    double *cpu = NULL, *host = NULL, *again = NULL, *chosen = NULL;
    solve_shaped_result rc, rh, ra, rx;
    check_result("cpu", run(x, SOLVE_SHAPED_CPU, &cpu, &rc), &rc, SOLVE_SHAPED_CPU);
    check_result("host", run(x, SOLVE_SHAPED_HOST, &host, &rh), &rh, SOLVE_SHAPED_HOST);
    RAD_CHECK(rh.shaped_ends == rc.shaped_ends);
    RAD_CHECK(rh.weights == rc.weights);
    const double d = worst_relative(host, cpu, n);
    printf("  host twin against the CPU: max |dB| %.3g of max B\n", d);
    RAD_CHECK(d <= 1e-9);
    RAD_CHECK_NEAR(rh.change, rc.change, 1e-9);
    RAD_CHECK_REL(rh.emitted, rc.emitted, 1e-15);
    RAD_CHECK_REL(rh.absorbed, rc.absorbed, 1e-9);
    RAD_CHECK_REL(rh.escaped, rc.escaped, 1e-9);
    RAD_CHECK_NEAR(rh.imbalance, rc.imbalance, 1e-9);
    RAD_CHECK(strcmp(rh.device, "host") == 0 && strcmp(rc.device, "cpu") == 0);
    /* the twin again: the same bits */
    RAD_CHECK(run(x, SOLVE_SHAPED_HOST, &again, &ra) == RAD_OK);
    RAD_CHECK(memcmp(again, host, n * sizeof *host) == 0);
    RAD_CHECK(ra.iterations == rh.iterations);
    /* auto below the GPU's threshold: the CPU, to the bit */
    if (rc.weights < SOLVE_SHAPED_GPU_MIN_WEIGHTS) {
        RAD_CHECK(run(x, SOLVE_SHAPED_AUTO, &chosen, &rx) == RAD_OK);
        RAD_CHECK(rx.backend == SOLVE_SHAPED_CPU);
        RAD_CHECK(memcmp(chosen, cpu, n * sizeof *cpu) == 0);
    }
    free(cpu);
    free(host);
    free(again);
    free(chosen);
}

/* 1b: the CPU's Gauss-Seidel tree by tree (group_work 1) and in groups
 * of every size tried: the same bits on 1 and 3 threads, and each within
 * the tolerance's reach of the others (1e-9 of max B). */
static void check_groups(const fixture *x)
{
    const size_t n = 3 * x->leaves->patch_count;
    const uint64_t works[] = {1, 4096, 0, UINT64_MAX};
    double *first = NULL;
    for (size_t w = 0; w < sizeof works / sizeof works[0]; w++) {
        double *one = NULL, *three = NULL;
        solve_shaped_result r1, r3;
        RAD_CHECK(run_with(x, SOLVE_SHAPED_CPU, 1, works[w], 0, &one, &r1) == RAD_OK);
        RAD_CHECK(run_with(x, SOLVE_SHAPED_CPU, 3, works[w], 0, &three, &r3) == RAD_OK);
        RAD_CHECK(r1.converged && r3.converged);
        RAD_CHECK(memcmp(one, three, n * sizeof *one) == 0);
        RAD_CHECK(r1.iterations == r3.iterations);
        RAD_CHECK(memcmp(&r1.imbalance, &r3.imbalance, sizeof r1.imbalance) == 0);
        const double d = first ? worst_relative(one, first, n) : 0;
        printf("  groups closing at %llu: %u iterations, 1 and 3 threads the same bits, max |dB| %.3g of max B "
               "against tree by tree\n",
               (unsigned long long)(works[w] ? works[w] : SOLVE_SHAPED_GROUP_WORK), r1.iterations, d);
        RAD_CHECK(d <= 1e-9);
        if (!first) first = one;
        else free(one);
        free(three);
    }
    free(first);
}

/* Closure (rad_closure.h) through `a` and `b` (the CPU and the host twin,
 * or cuda and the host twin): the rows balanced to 1 within 1e-9 by each,
 * the same scales' range, the two solutions within 1e-9 of max B, and the
 * energy balanced as without closure (the links are reciprocal whether or
 * not the scene is closed: on an open one, forcing its rows to 1 is wrong
 * light but still a reciprocal operator). */
static void check_closure(const fixture *x, solve_shaped_backend a, solve_shaped_backend b)
{
    const size_t n = 3 * x->leaves->patch_count;
    double *Ba = NULL, *Bb = NULL;
    solve_shaped_result ra, rb;
    RAD_CHECK(run_with(x, a, 0, 0, 1, &Ba, &ra) == RAD_OK);
    RAD_CHECK(run_with(x, b, 0, 0, 1, &Bb, &rb) == RAD_OK);
    RAD_CHECK(ra.converged && rb.converged);
    RAD_CHECK(ra.closure.deviation <= 1e-9 && rb.closure.deviation <= 1e-9);
    RAD_CHECK_NEAR(ra.closure.scale[0], rb.closure.scale[0], 1e-9);
    RAD_CHECK_NEAR(ra.closure.scale[1], rb.closure.scale[1], 1e-9);
    const double d = worst_relative(Bb, Ba, n);
    printf("  closure (%s, %s): rows %.4f .. %.4f to 1 in %u sweeps, scales %.4f .. %.4f; max |dB| %.3g of max B; "
           "imbalance %.3g\n",
           solve_shaped_backend_name(a), solve_shaped_backend_name(b), ra.closure.row_before[0],
           ra.closure.row_before[1], ra.closure.iterations, ra.closure.scale[0], ra.closure.scale[1], d, ra.imbalance);
    RAD_CHECK(d <= 1e-9);
    RAD_CHECK(fabs(ra.imbalance) <= 1e-6 && fabs(rb.imbalance) <= 1e-6);
    free(Ba);
    free(Bb);
}

/* The flat operator (solve_shaped_options.flat: no end shaped, no pairs
 * looked for) swept by `backend` from B = E to the tolerance: no ends, no
 * point factors, within 1e-9 of max B of rad_lsolve's flat solution, the
 * energy balanced; in *out_B (malloc'd) for the caller's comparison. */
static void check_flat(const fixture *x, solve_shaped_backend backend, double **out_B, solve_shaped_result *r)
{
    const size_t m = x->leaves->patch_count;
    double *B = malloc(3 * m * sizeof *B);
    RAD_CHECK(B != NULL);
    if (!B) return;
    for (size_t k = 0; k < m; k++)
        for (int c = 0; c < 3; c++) B[3 * k + c] = x->leaves->patches[k].emission[c];
    const solve_shaped_options o = {.backend = backend,
                                    .gate = 0.1 * x->links.link_tol,
                                    .tolerance = TEST_TOL,
                                    .max_iterations = 100000,
                                    .channels = x->channels,
                                    .flat = 1};
    memset(r, 0, sizeof *r);
    RAD_CHECK(solve_shaped(&x->links, x->leaves, &o, B, r) == RAD_OK);
    RAD_CHECK(r->converged && r->residual <= TEST_TOL);
    RAD_CHECK(r->shaped_ends == 0 && r->weights == 0);
    const double d = worst_relative(B, x->flat, 3 * m);
    printf("  flat (%s): %u iterations from E, max |dB| %.3g of max B against rad_lsolve, imbalance %.3g\n",
           solve_shaped_backend_name(backend), r->iterations, d, r->imbalance);
    RAD_CHECK(d <= 1e-9);
    RAD_CHECK(fabs(r->imbalance) <= 1e-6);
    *out_B = B;
}

/* check_flat by `a` and `b`: b (the host twin) the same bits as a (cuda),
 * where same_bits. */
static void check_flat_pair(const fixture *x, solve_shaped_backend a, solve_shaped_backend b, int same_bits)
{
    double *Ba = NULL, *Bb = NULL;
    solve_shaped_result ra, rb;
    check_flat(x, a, &Ba, &ra);
    check_flat(x, b, &Bb, &rb);
    if (same_bits && Ba && Bb) {
        RAD_CHECK(memcmp(Ba, Bb, 3 * x->leaves->patch_count * sizeof *Ba) == 0);
        RAD_CHECK(ra.iterations == rb.iterations);
    }
    free(Ba);
    free(Bb);
}

/* 2: cuda where it cannot run fails and leaves B alone. */
static void check_cuda_refused(const fixture *x)
{
    double *B = NULL;
    solve_shaped_result r;
    rad_test_capture_log();
    const rad_status status = run(x, SOLVE_SHAPED_CUDA, &B, &r);
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(status == (solve_gpu_built() ? RAD_ERR_BACKEND : RAD_ERR_UNSUPPORTED));
    RAD_CHECK(rad_test_log_contains("--backend cuda"));
    RAD_CHECK(memcmp(B, x->flat, 3 * x->leaves->patch_count * sizeof *B) == 0);
    free(B);
}

/* 3 on one file. */
static void check_cuda(const fixture *x)
{
    const size_t n = 3 * x->leaves->patch_count;
    double *gpu = NULL, *host = NULL, *again = NULL;
    solve_shaped_result rg, rh, ra;
    check_result("cuda", run(x, SOLVE_SHAPED_CUDA, &gpu, &rg), &rg, SOLVE_SHAPED_CUDA);
    check_result("host", run(x, SOLVE_SHAPED_HOST, &host, &rh), &rh, SOLVE_SHAPED_HOST);
    RAD_CHECK(rg.shaped_ends == rh.shaped_ends);
    RAD_CHECK(rg.weights == rh.weights);
    const int same = memcmp(gpu, host, n * sizeof *gpu) == 0;
    const double d = worst_relative(gpu, host, n);
    printf("  cuda against its host twin: max |dB| %.3g of max B, %s; iterations %u and %u\n", d,
           same ? "the same bits" : "NOT the same bits (a point factor rounded the other way?)", rg.iterations,
           rh.iterations);
    RAD_CHECK(d <= 1e-9);
    RAD_CHECK(rg.iterations + 1 >= rh.iterations && rh.iterations + 1 >= rg.iterations);
    if (same) RAD_CHECK(rg.iterations == rh.iterations && rg.imbalance == rh.imbalance);
    RAD_CHECK(run(x, SOLVE_SHAPED_CUDA, &again, &ra) == RAD_OK);
    RAD_CHECK(memcmp(again, gpu, n * sizeof *gpu) == 0);
    free(gpu);
    free(host);
    free(again);
}

int main(int argc, char **argv)
{
    int cuda = argc > 1 && strcmp(argv[1], "--cuda") == 0;
    if (argc < 2 + cuda) {
        fprintf(stderr, "usage: test_shaped [--cuda] LINKS...\n");
        return 2;
    }
    if (cuda && solve_gpu_device_count() == 0) {
        printf("no CUDA device: skipped\n");
        return 77;
    }
    rad_log_set_level(RAD_LOG_WARN);
    for (int a = 1 + cuda; a < argc; a++) {
        fixture x;
        printf("%s\n", argv[a]);
        if (!fixture_load(argv[a], &x)) {
            fprintf(stderr, "%s: cannot read or solve flat\n", argv[a]);
            rad_test_failures++;
            fixture_free(&x);
            continue;
        }
        if (cuda) {
            check_cuda(&x);
            check_closure(&x, SOLVE_SHAPED_CUDA, SOLVE_SHAPED_HOST);
            check_flat_pair(&x, SOLVE_SHAPED_CUDA, SOLVE_SHAPED_HOST, 1);
        } else {
            check_host(&x);
            check_groups(&x);
            check_closure(&x, SOLVE_SHAPED_CPU, SOLVE_SHAPED_HOST);
            check_flat_pair(&x, SOLVE_SHAPED_CPU, SOLVE_SHAPED_HOST, 0);
            if (solve_gpu_device_count() == 0) check_cuda_refused(&x);
        }
        fixture_free(&x);
    }
    return rad_test_finish();
}
