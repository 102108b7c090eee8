/* main.c - the `solve` command line; the work is in stage.c. Starts and
 * ends MPI (comm.h) when an MPI launcher started the process: the only
 * place that exits. */
#include <errno.h>
#include <getopt.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_cpu.h"
#include "rad_log.h"
#include "rad_fs.h"
#include "groups.h"
#include "comm.h"
#include "rad_parse.h"
#include "stage.h"

static const char usage_text[] =
    "usage: solve [options] [FORMFACTORS]\n"
    "\n"
    "Solves (I - diag(rho) F) B = E for every colour channel of the form-factor\n"
    "file FORMFACTORS (default: formfactors) and writes the radiosity file.\n"
    "\n"
    "options:\n"
    "  -o, --output FILE   radiosity file to write (default: radiosity)\n"
    "  --method M          jacobi | gauss-seidel | cg | auto (default: auto =\n"
    "                      cg when the matrix is reciprocal enough for its\n"
    "                      diagonal-dominance margin, else gauss-seidel)\n"
    "  --tol X             stop when every patch's residual |E + rho F B - B|_i\n"
    "                      is <= X min(||E||inf, E_i + rho_i (F B)_i)\n"
    "                      (default: 1e-10; links files: 1e-4 x their link-tol,\n"
    "                      within 1e-10 .. 1e-6; see docs/solve.md)\n"
    "  --max-iter N        iteration limit per channel (default: 100000)\n"
    "  --backend B         auto | cpu | cuda (default: auto = cuda when this\n"
    "                      build has CUDA, a GPU is visible and the matrix\n"
    "                      stores at least 8 M entries, else cpu). cuda\n"
    "                      keeps the matrix on the GPU as float and runs cg and\n"
    "                      jacobi there, every channel in one pass over it;\n"
    "                      gauss-seidel runs on the CPU. Every result is\n"
    "                      verified on the CPU with the matrix as stored and,\n"
    "                      for f64 files, refined until it meets --tol\n"
    "                      (docs/solve.md, \"On the GPU\")\n"
    "  --errors FILE       the standard errors of the form factors (the file\n"
    "                      formfactor --errors wrote beside them): warn only\n"
    "                      about rows summing above 1 beyond 3 standard errors\n"
    "                      (without it: above 1.001)\n"
    "  --stats FILE.json   write iterations, residuals, energy balance and timings\n"
    "                      as JSON\n"
    "  --by-group FILE     results per OBJ group (surface): patches, area,\n"
    "                      area-weighted mean radiosity, emitted and absorbed\n"
    "                      power per channel; FILE.csv or FILE.npy (NumPy);\n"
    "                      needs a form-factor file with a group table\n"
    "                      (docs/solve.md, \"Results by surface\")\n"
    "  --shape on|off      links only: spread each link over its elements'\n"
    "                      leaves by the point factor (default: on)\n"
    "  --closure auto|on|off  links only: scale the links so that every\n"
    "                      leaf's row sums to 1, as a closed scene's do,\n"
    "                      keeping reciprocity (the furnace then exact;\n"
    "                      docs/hierarchy.md, \"Closure\"); auto (default):\n"
    "                      where formfactor --closure on found the scene\n"
    "                      closed\n"
    "  -q, --quiet         only warnings and errors on stderr\n"
    "  -h, --help          this text\n"
    "      --version       print the version\n"
    "\n"
    "Refuses (exit 1, nothing written) a matrix in which some patch has\n"
    "rho * (row sum of F) >= 1: it would reflect more light than it receives.\n"
    "\n"
    "A file of links (hierarchical radiosity, formfactor --method hierarchical)\n"
    "is solved on its links: --method gauss-seidel (also auto) or jacobi\n"
    "sweeps gather along the links, push to the leaves and pull means up;\n"
    "--tol, --max-iter and --stats as above (the residual over ||E||inf);\n"
    "cg, --errors and --by-group do not apply (exit 2). Then the links are\n"
    "solved again, each spread over its elements' leaves by how well each leaf\n"
    "sees the other end (--shape on, the default; off writes the flat\n"
    "solution, on the CPU): on the GPU with --backend cuda, and auto from 4 M\n"
    "point factors (Jacobi sweeps there); the flat sweeps before it too, with\n"
    "cuda and auto from 4 M links. Threads: OMP_NUM_THREADS (docs/solve.md,\n"
    "\"On links\").\n"
    "\n"
    "Matrices larger than one node: mpirun -n K solve [options] FORMFACTORS\n"
    "splits the rows over K ranks (balanced by stored entries); each rank\n"
    "reads and holds only its rows, rank 0 writes the outputs. Gauss-Seidel\n"
    "then runs within each rank's rows and as Jacobi between them; results\n"
    "agree with one process within the tolerance (docs/solve.md,\n"
    "\"Across ranks\").\n"
    "\n"
    "exit status: 0 solved; 1 bad input, I/O error, or --backend cuda without\n"
    "a GPU; 2 bad command line (--backend cuda in a build without CUDA);\n"
    "3 not converged (the output is still written, marked unconverged)\n";

typedef struct cli {
    solve_options options;
    int help, quiet, version;
} cli;

static rad_status parse_tolerance(const char *text, double *out)
{
    return rad_parse_real("--tol", text, 0, 0, 1, 0, out);
}

static rad_status parse_count(const char *text, uint32_t *out)
{
    uint64_t v = 0;
    rad_status status = rad_parse_uint("--max-iter", text, 1, UINT32_MAX, &v);
    *out = (uint32_t)v;
    return status;
}

/* getopt_long, as formfactor and render parse theirs: "--name VALUE",
 * "--name=VALUE", "-o VALUE"; options and the input in any order. */
static rad_status parse_args(int argc, char **argv, cli *out)
{
    enum { O_METHOD = 256, O_TOL, O_MAX_ITER, O_STATS, O_ERRORS, O_BY_GROUP, O_VERSION, O_BACKEND, O_SHAPE, O_CLOSURE };
    static const struct option longs[] = {
        {"output", required_argument, 0, 'o'},       {"method", required_argument, 0, O_METHOD},
        {"tol", required_argument, 0, O_TOL},         {"max-iter", required_argument, 0, O_MAX_ITER},
        {"stats", required_argument, 0, O_STATS},     {"errors", required_argument, 0, O_ERRORS},
        {"by-group", required_argument, 0, O_BY_GROUP}, {"quiet", no_argument, 0, 'q'},
        {"help", no_argument, 0, 'h'},                {"version", no_argument, 0, O_VERSION},
        {"backend", required_argument, 0, O_BACKEND}, {"shape", required_argument, 0, O_SHAPE},
        {"closure", required_argument, 0, O_CLOSURE},
        {0, 0, 0, 0}};
    cli c;
    memset(&c, 0, sizeof c);
    rad_status status = RAD_OK;
    int opt, at = 0;
    opterr = 0; /* our own messages */
    optind = 1;
    while (status == RAD_OK && (opt = getopt_long(argc, argv, ":o:qh", longs, &at)) != -1) {
        const char *value = optarg;
        switch (opt) {
        case 'o': c.options.output = value; break;
        case 'q': c.quiet = 1; break;
        case 'h': c.help = 1; break;
        case O_VERSION: c.version = 1; break;
        case O_METHOD: status = solve_method_parse(value, &c.options.params.method); break;
        case O_BACKEND: status = solve_backend_parse(value, &c.options.backend); break;
        case O_TOL: status = parse_tolerance(value, &c.options.params.tolerance); break;
        case O_MAX_ITER: status = parse_count(value, &c.options.params.max_iterations); break;
        case O_STATS: c.options.stats = value; break;
        case O_ERRORS: c.options.errors = value; break;
        case O_SHAPE:
            if (strcmp(value, "on") == 0 || strcmp(value, "off") == 0) {
                c.options.no_shape = strcmp(value, "off") == 0;
            } else {
                rad_error("--shape: '%s' is not on or off", value);
                status = RAD_ERR_USAGE;
            }
            break;
        case O_CLOSURE:
            if (strcmp(value, "auto") == 0) c.options.closure = SOLVE_CLOSURE_AUTO;
            else if (strcmp(value, "on") == 0) c.options.closure = SOLVE_CLOSURE_ON;
            else if (strcmp(value, "off") == 0) c.options.closure = SOLVE_CLOSURE_OFF;
            else {
                rad_error("--closure: '%s' is not auto, on or off", value);
                status = RAD_ERR_USAGE;
            }
            break;
        case O_BY_GROUP: {
            solve_groups_format format;
            status = solve_groups_format_of("--by-group", value, &format);
            if (status == RAD_OK) c.options.by_group = value;
            break;
        }
        case ':': /* a known option without its value */
            rad_error("%s needs a value", argv[optind - 1]);
            status = RAD_ERR_USAGE;
            break;
        default:
            rad_error("unknown option '%s' (see solve --help)", argv[optind - 1]);
            status = RAD_ERR_USAGE;
        }
    }
    for (int i = optind; status == RAD_OK && i < argc; i++) {
        if (c.options.input) {
            rad_error("more than one form-factor file given ('%s' and '%s')", c.options.input, argv[i]);
            status = RAD_ERR_USAGE;
        } else {
            c.options.input = argv[i];
        }
    }
    if (status == RAD_OK) *out = c;
    return status;
}

/* Everything after MPI is up; every rank returns the same status. */
static rad_status run(int argc, char **argv, solve_comm *comm)
{
    const int rank = solve_comm_rank(comm);
    if (rank != 0) rad_log_set_level(RAD_LOG_NONE); /* rank 0 speaks for all: the same on every rank */
    cli c;
    rad_status status = parse_args(argc, argv, &c);
    if (status != RAD_OK) {
        if (rank == 0) fputs("try 'solve --help'\n", stderr);
        return status;
    }
    if (c.version || c.help) {
        if (rank == 0) fputs(c.version ? "solve " RAD_VERSION "\n" : usage_text, stdout);
        return RAD_OK;
    }
    /* Before any work: docs/reliability.md, "Threat model: files on disk". */
    const char *output = c.options.output ? c.options.output : SOLVE_DEFAULT_OUTPUT;
    rad_fs_role roles[] = {{"the form-factor file", c.options.input ? c.options.input : SOLVE_DEFAULT_INPUT, 0},
                           {"--errors", c.options.errors, 0},
                           {"-o", output, 1},
                           {"--stats", c.options.stats, 1},
                           {"--by-group", c.options.by_group, 1}};
    status = rad_fs_check_output("-o", output);
    if (status == RAD_OK) status = rad_fs_check_output("--stats", c.options.stats);
    if (status == RAD_OK) status = rad_fs_check_output("--by-group", c.options.by_group);
    if (status == RAD_OK) status = rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]);
    status = solve_comm_agree(comm, status);
    if (status != RAD_OK) return status;
    if (c.quiet) rad_log_set_level(RAD_LOG_WARN);
    if (rank != 0) rad_log_set_level(RAD_LOG_ERROR); /* the stage decides when other ranks speak */
    c.options.comm = comm;
    /* Ranks sharing a node share its cores (rad_cpu.h); OMP_NUM_THREADS,
     * where set, stays OpenMP's to apply. */
    int node_ranks = solve_comm_node_size(comm);
    const char *omp = getenv("OMP_NUM_THREADS");
    if (node_ranks > 1 && !(omp && *omp)) c.options.threads = rad_cpu_threads_per_rank(0, node_ranks);
    return solve_stage_run(&c.options);
}

int main(int argc, char **argv)
{
    rad_log_set_program("solve");
    solve_comm *comm = NULL;
    rad_status status = solve_comm_init(&argc, &argv, &comm);
    if (status == RAD_OK) status = run(argc, argv, comm);
    solve_comm_finalize(comm);
    return rad_status_exit_code(status);
}
