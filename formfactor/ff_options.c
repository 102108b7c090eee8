/* ff_options.c - formfactor's command line (ff_options.h): getopt_long,
 * the name tables of the options' values, the checks of the options
 * together, and the --help text. */
#include "ff_options.h"

#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ff_links.h"
#include "rad_ff_quad.h"
#include "rad_fs.h"
#include "rad_log.h"
#include "rad_parse.h"

const char ff_options_help[] =
    "usage: mpirun -n P formfactor [options] [SCENE.obj]\n"
    "       formfactor [options] [SCENE.obj]          (one rank)\n"
    "\n"
    "Computes the form factor F_ij of every patch pair of SCENE.obj (default: the\n"
    "built-in Cornell box) and writes the N x N matrix with the patch table.\n"
    "\n"
    "  -o, --output FILE        output file (default: formfactors)\n"
    "      --radiosity FILE     solve in memory and write the radiosity FILE (render's\n"
    "                           input) instead of the matrix: scene to radiosity without\n"
    "                           writing and reading the N x N file; the same bytes as\n"
    "                           formfactor, then solve with its defaults (one GPU per rank\n"
    "                           under --backend cuda|auto; sparse format; not with -o or\n"
    "                           --errors); --method hierarchical: the links solved in\n"
    "                           memory, the same bytes as writing them, then solve\n"
    "      --subdiv S           split every face into 4^S patches (default: 0; not with\n"
    "                           --refine, whose mesh comes from RADIOSITY); hierarchical:\n"
    "                           the finest level elements reach (default: 5)\n"
    "      --method M           full | hierarchical | auto (default: full): full computes\n"
    "                           every pair of the --subdiv mesh; hierarchical links\n"
    "                           elements of quadtrees over the faces at the coarsest\n"
    "                           levels whose error meets --link-tol and writes the links\n"
    "                           (docs/hierarchy.md; element pairs on the GPU under\n"
    "                           --backend cuda, and auto from 4096 leaves a CPU thread:\n"
    "                           below, the CPU is done before CUDA starts); auto: hierarchical when\n"
    "                           the --subdiv mesh has more than 20000 patches\n"
    "      --link-tol T         hierarchical: refine a link while the radiosity its error\n"
    "                           may move its receiver by exceeds T times the scene's mean\n"
    "                           radiosity (default: 1e-2; 3e-3 for a finer picture; 0: every\n"
    "                           pair down to the finest level)\n"
    "      --oracle O           auto | error | gather | power | factor (default: auto =\n"
    "                           gather with uniform or sized leaves, else error): what a link's\n"
    "                           estimate is weighed by: rho B x the error of F (against\n"
    "                           T x the mean radiosity); the same for what solve's shaped\n"
    "                           solve leaves of that error, plus the source's spread of B\n"
    "                           (gather; docs/hierarchy.md); rho A B F (BF, against T x\n"
    "                           the emitted power); or F alone (then T bounds F)\n"
    "      --min-area A         hierarchical: no element smaller than A times the scene's\n"
    "                           area (default: 1e-7)\n"
    "      --passes P           hierarchical: refinement passes, each re-weighing the\n"
    "                           links by the last solution's B (default: 3)\n"
    "      --clusters C         auto | on | off (default: auto = on from 2048 faces):\n"
    "                           hierarchical: start from one link of a cluster tree over\n"
    "                           the faces instead of every pair of faces (docs/hierarchy.md)\n"
    "      --cluster-cone DEG   hierarchical with clusters: no cluster link at a cluster\n"
    "                           whose normals spread more than DEG degrees from their mean\n"
    "                           (one irradiance for faces facing apart moves light from\n"
    "                           walls to objects); such clusters split by orientation\n"
    "                           (default: 70; 180: any cluster links)\n"
    "      --cluster-open S     hierarchical with clusters: no cluster link at a cluster\n"
    "                           whose faces' openness (the share of 32 rays from a face\n"
    "                           that go an eighth of the scene unblocked) spreads more\n"
    "                           than S: faces hidden at close range (above a lamp,\n"
    "                           behind books) would take the light of open ones\n"
    "                           (default: 0.8; 1: any cluster links, nothing traced)\n"
    "      --closure on|off     hierarchical: where the scene is closed (a convex\n"
    "                           enclosure, or 16 rays from every face all meeting\n"
    "                           fronts), mark the links so that the solve scales every\n"
    "                           leaf's row to 1, keeping reciprocity: exact totals (the\n"
    "                           furnace, net exchange), but a lit room's light is less\n"
    "                           accurate (docs/hierarchy.md, \"Closure\"; default off)\n"
    "      --uniform-leaves     hierarchical: split every face to --subdiv first, so that\n"
    "                           the leaves are the full matrix's at --subdiv whatever\n"
    "                           --link-tol (to compare the two: tools/hier_study.py)\n"
    "      --sized-leaves       hierarchical: split every face first until its pieces are\n"
    "                           no larger than the largest face's at --subdiv: leaves of\n"
    "                           about one size, fewer than --uniform-leaves where faces\n"
    "                           differ in size, and known in advance as those are\n"
    "      --subdiv-only GROUP  subdivide only faces of OBJ group GROUP (the paper's\n"
    "                           code subdivided only the box: --subdiv-only box)\n"
    "      --refine RADIOSITY   instead of --subdiv: take the mesh of RADIOSITY (solve's\n"
    "                           output for this scene) and split each patch whose\n"
    "                           luminance differs from what its neighbours on its\n"
    "                           surface predict by more than --refine-tol times the\n"
    "                           scene's mean (shadow edges, penumbrae, corners, contact\n"
    "                           lines); scripts/refine.sh runs the loop\n"
    "      --refine-tol T       (default: 0.05)\n"
    "      --refine-min-size F  split no patch smaller than F times the scene's\n"
    "                           diagonal (default: 0.0078125 = 1/128)\n"
    "      --refine-max-patches N  at most N patches: the largest errors split first\n"
    "      --reuse FORMFACTORS  with --refine: the form-factor file RADIOSITY was solved\n"
    "                           from; pairs of two unsplit patches copy their entries\n"
    "                           instead of computing them (CPU backend); refused if it\n"
    "                           was computed with other settings (--estimator, --samples,\n"
    "                           --shadow-rays, --seed, --element; --quad-rtol and\n"
    "                           --quad-atol, which the file does not record, must be the\n"
    "                           defaults) or holds an entry that is not a form factor\n"
    "      --contacts C         cut | keep (default: cut): cut faces where other faces\n"
    "                           rest on or pass through them (a floor along a block's\n"
    "                           footprint) and drop the pieces hidden inside or under\n"
    "                           geometry; a piece gets patches about the size of its\n"
    "                           face's; keep: mesh the faces as they are\n"
    "      --flip-normals       wind every face the other way round: for scenes whose\n"
    "                           faces all point away from where the light is (a closed\n"
    "                           object used as a room, faces wound against their vn);\n"
    "                           OBJ scenes only\n"
    "      --flip-group NAMES   wind only the faces of these OBJ objects or groups (`o`,\n"
    "                           `g`; comma-separated) the other way round: a room made\n"
    "                           from Blender's cube, unflipped, around objects that are\n"
    "                           right (--flip-group Room); OBJ scenes only\n"
    "      --keep-normals       run a scene whose enclosing object faces outward (away\n"
    "                           from everything inside it) as it is; without it such a\n"
    "                           scene is refused, naming the --flip-group to give\n"
    "      --clamp-rho R        set every Kd value above R (0 < R < 1) to R, saying which,\n"
    "                           instead of refusing Kd >= 1 (Blender's white is Kd 1);\n"
    "                           OBJ scenes only\n"
    "      --ke K               radiosity | radiance (default: radiosity): what the MTL's\n"
    "                           Ke is: the emitted radiosity E, or the emitted radiance\n"
    "                           L (Blender's emission colour x strength, what Cycles\n"
    "                           draws), read as E = pi L; the files record it, and\n"
    "                           render then writes radiance. OBJ scenes only\n"
    "      --preset P           final | preview (default: final): preview sets\n"
    "                           --quad-rtol 1e-5 --shadow-rays 16 where not given, several\n"
    "                           times faster on curved meshes for a picture that differs\n"
    "                           by well under 1/255 (docs/performance.md, \"Presets\")\n"
    "      --samples K          point pairs per patch pair (default: 512)\n"
    "      --shadow-rays R      of those, pairs that carry a shadow ray (default: 32;\n"
    "                           0 = no occlusion)\n"
    "      --seed N             random seed (default: 1); same seed, same bytes\n"
    "      --target-error E     keep sampling each pair (batches that double the samples\n"
    "                           and shadow rays) until the standard error of F_ij and\n"
    "                           F_ji is at most E, or --max-samples is reached; a pair\n"
    "                           never takes fewer samples or rays than without it\n"
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
    "                           (default: 1e-8; its error estimate is conservative;\n"
    "                           hierarchical with --link-tol > 0: at most 1e-5, what the\n"
    "                           link oracle can use)\n"
    "      --quad-atol A        quadrature: absolute tolerance, in units of F (default: 1e-13)\n"
    "      --backend B          auto | cpu | cuda (default: auto)\n"
    "      --element T          f64 | f32 matrix element type (default: f64)\n"
    "      --format F           sparse | dense | paper (default: sparse, only each row's\n"
    "                           non-zero tiles of 64 entries; dense: all N*N entries;\n"
    "                           paper: int32 N + N*N float64 only)\n"
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
    "                           (sparse files: whose bound, all N^2 entries, is more than\n"
    "                           10 times that free space)\n"
    "      --allow-disk-overcommit  run a sparse file whose bound is more than 10 times the\n"
    "                           free space anyway (most scenes' files are a tenth of\n"
    "                           their bound; a full disk stops the run, old output kept)\n"
    "      --max-seconds S      refuse, before writing anything, a run whose calibrated\n"
    "                           estimate (the estimate line) is longer than S seconds;\n"
    "                           runs under 256 patches are not calibrated and pass\n"
    "      --dry-run            load the scene, cut contacts, build the --subdiv mesh, the\n"
    "                           patches and the occluders' BVH, say what each took, and\n"
    "                           stop: nothing computed or written (a large scene's cost\n"
    "                           before its run; no limits or estimate)\n"
    "  -q, --quiet              only errors on stderr\n"
    "  -h, --help               this help\n"
    "      --version            print the version\n"
    "\n"
    "File layout: docs/formats.md. Estimator: docs/architecture.md.\n";

/* One enum's names, in the order --help lists them. */
typedef struct ff_name {
    int value;
    const char *name;
} ff_name;

#define FF_NAMES_COUNT(table) (sizeof table / sizeof table[0])

static const ff_name backend_names[] = {
    {FF_BACKEND_AUTO, "auto"}, {FF_BACKEND_CPU, "cpu"}, {FF_BACKEND_CUDA, "cuda"}};
static const ff_name method_names[] = {
    {FF_METHOD_FULL, "full"}, {FF_METHOD_HIERARCHICAL, "hierarchical"}, {FF_METHOD_AUTO, "auto"}};
static const ff_name switch_names[] = {{-1, "auto"}, {0, "off"}, {1, "on"}};
static const ff_name oracle_names[] = {{FF_ORACLE_AUTO, "auto"}, {0, "error"}, {1, "power"}, {2, "factor"}, {3, "gather"}};

const char *ff_method_name(ff_method method)
{
    for (size_t k = 0; k < FF_NAMES_COUNT(method_names); k++)
        if (method_names[k].value == (int)method) return method_names[k].name;
    return "unknown";
}

static const ff_name preset_names[] = {{FF_PRESET_FINAL, "final"}, {FF_PRESET_PREVIEW, "preview"}};
static const ff_name cull_names[] = {{FF_CULL_ALL, "all"}, {FF_CULL_NONE, "none"}};
static const ff_name contacts_names[] = {{RAD_MESH_CONTACTS_CUT, "cut"}, {RAD_MESH_CONTACTS_KEEP, "keep"}};
static const ff_name reciprocity_names[] = {
    {FF_RECIPROCITY_AUTO, "auto"}, {FF_RECIPROCITY_ON, "on"}, {FF_RECIPROCITY_OFF, "off"}};
static const ff_name element_names[] = {{RAD_ELEMENT_F64, "f64"}, {RAD_ELEMENT_F32, "f32"}};
/* --ke: the value is ff_options.ke_radiance */
static const ff_name ke_names[] = {{0, "radiosity"}, {1, "radiance"}};
static const ff_name format_names[] = {
    {FF_FORMAT_SPARSE, "sparse"}, {FF_FORMAT_DENSE, "dense"}, {FF_FORMAT_PAPER, "paper"}};
/* The estimators in --help's order; their names are rad_estimator_name's. */
static const rad_estimator_id estimator_order[] = {RAD_ESTIMATOR_QUADRATURE, RAD_ESTIMATOR_AUTO, RAD_ESTIMATOR_MC,
                                                   RAD_ESTIMATOR_QMC, RAD_ESTIMATOR_ANALYTIC};

static const char *name_of(const ff_name *table, size_t count, int value)
{
    for (size_t k = 0; k < count; k++)
        if (table[k].value == value) return table[k].name;
    return "unknown";
}

const char *ff_backend_choice_name(ff_backend_choice backend)
{
    return name_of(backend_names, FF_NAMES_COUNT(backend_names), (int)backend);
}

const char *ff_contacts_name(rad_mesh_contacts contacts)
{
    return name_of(contacts_names, FF_NAMES_COUNT(contacts_names), (int)contacts);
}

const char *ff_cull_name(ff_cull cull)
{
    return name_of(cull_names, FF_NAMES_COUNT(cull_names), (int)cull);
}

const char *ff_reciprocity_name(ff_reciprocity reciprocity)
{
    return name_of(reciprocity_names, FF_NAMES_COUNT(reciprocity_names), (int)reciprocity);
}

const char *ff_element_name(rad_element_type element)
{
    return name_of(element_names, FF_NAMES_COUNT(element_names), (int)element);
}

const char *ff_format_name(ff_format format)
{
    return name_of(format_names, FF_NAMES_COUNT(format_names), (int)format);
}

/* The value `text` names in `table`; otherwise RAD_ERR_USAGE with the
 * names listed: "--cull: expected all or none, got 'some'". */
static rad_status parse_name(const char *flag, const char *text, const ff_name *table, size_t count, int *out)
{
    for (size_t k = 0; k < count; k++) {
        if (strcmp(text, table[k].name) == 0) {
            *out = table[k].value;
            return RAD_OK;
        }
    }
    char expected[256] = "";
    size_t used = 0;
    for (size_t k = 0; k < count && used < sizeof expected; k++)
        used += (size_t)snprintf(expected + used, sizeof expected - used, "%s%s",
                                 k == 0 ? "" : k + 1 < count ? ", " : " or ", table[k].name);
    rad_error("%s: expected %s, got '%s'", flag, expected, text);
    return RAD_ERR_USAGE;
}

static rad_status parse_estimator(const char *text, rad_estimator_id *out)
{
    ff_name table[FF_NAMES_COUNT(estimator_order)];
    for (size_t k = 0; k < FF_NAMES_COUNT(estimator_order); k++)
        table[k] = (ff_name){(int)estimator_order[k], rad_estimator_name(estimator_order[k])};
    int value = 0;
    rad_status status = parse_name("--estimator", text, table, FF_NAMES_COUNT(table), &value);
    if (status == RAD_OK) *out = (rad_estimator_id)value;
    return status;
}

/* A tolerance: a finite number in (0, 1). */
static rad_status parse_tolerance(const char *flag, const char *text, double *out)
{
    return rad_parse_real(flag, text, 0, 0, 1, 0, out);
}

/* argv into *o, one option at a time; the first bad one is reported. */
static rad_status parse_argv(int argc, char **argv, ff_options *o)
{
    enum { O_SUBDIV = 256, O_ONLY, O_SAMPLES, O_RAYS, O_SEED, O_BACKEND, O_ELEMENT, O_FORMAT, O_THREADS, O_STATS,
           O_VERSION, O_ESTIMATOR, O_CULL, O_RECIPROCITY, O_TARGET, O_MAX_SAMPLES, O_ERRORS, O_NO_ERRORS,
           O_QUAD_RTOL, O_QUAD_ATOL, O_FLIP_NORMALS, O_CLAMP_RHO, O_MAX_BYTES, O_REFINE, O_REFINE_TOL,
           O_REFINE_MIN_SIZE, O_REFINE_MAX_PATCHES, O_REUSE, O_CONTACTS, O_MAX_SECONDS, O_OVERCOMMIT, O_KE,
           O_FLIP_GROUP, O_KEEP_NORMALS, O_PRESET, O_METHOD, O_LINK_TOL, O_ORACLE, O_MIN_AREA, O_PASSES, O_UNIFORM_LEAVES, O_SIZED_LEAVES, O_RADIOSITY, O_DRY_RUN, O_CLUSTERS, O_CLUSTER_CONE, O_CLUSTER_OPEN, O_CLOSURE };
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
        {"max-bytes", required_argument, 0, O_MAX_BYTES}, {"refine", required_argument, 0, O_REFINE},
        {"refine-tol", required_argument, 0, O_REFINE_TOL}, {"refine-min-size", required_argument, 0, O_REFINE_MIN_SIZE},
        {"refine-max-patches", required_argument, 0, O_REFINE_MAX_PATCHES}, {"reuse", required_argument, 0, O_REUSE},
        {"contacts", required_argument, 0, O_CONTACTS}, {"max-seconds", required_argument, 0, O_MAX_SECONDS},
        {"dry-run", no_argument, 0, O_DRY_RUN},
        {"allow-disk-overcommit", no_argument, 0, O_OVERCOMMIT}, {"ke", required_argument, 0, O_KE},
        {"flip-group", required_argument, 0, O_FLIP_GROUP}, {"keep-normals", no_argument, 0, O_KEEP_NORMALS},
        {"preset", required_argument, 0, O_PRESET}, {"method", required_argument, 0, O_METHOD},
        {"link-tol", required_argument, 0, O_LINK_TOL}, {"oracle", required_argument, 0, O_ORACLE},
        {"min-area", required_argument, 0, O_MIN_AREA}, {"passes", required_argument, 0, O_PASSES},
        {"uniform-leaves", no_argument, 0, O_UNIFORM_LEAVES}, {"sized-leaves", no_argument, 0, O_SIZED_LEAVES}, {"clusters", required_argument, 0, O_CLUSTERS}, {"cluster-cone", required_argument, 0, O_CLUSTER_CONE}, {"cluster-open", required_argument, 0, O_CLUSTER_OPEN}, {"closure", required_argument, 0, O_CLOSURE}, {"radiosity", required_argument, 0, O_RADIOSITY},
        {0, 0, 0, 0}};
    int rays_given = 0, rtol_given = 0;
    uint64_t v = 0;
    int named = 0; /* an option's value read through a name table */
    rad_status st = RAD_OK;
    int c;
    opterr = 0;
    while (st == RAD_OK && (c = getopt_long(argc, argv, "o:qh", longs, NULL)) != -1) {
        switch (c) {
        case 'o': o->output = optarg, o->output_given = 1; break;
        case O_RADIOSITY: o->radiosity_path = optarg; break;
        case 'q': o->quiet = 1; break;
        case 'h': o->help = 1; break;
        case O_VERSION: o->version = 1; break;
        case O_SUBDIV:
            st = rad_parse_uint("--subdiv", optarg, 0, 12, &v);
            o->subdiv = (int)v;
            o->subdiv_given = 1;
            break;
        case O_ONLY: o->subdiv_only = optarg; break;
        case O_SAMPLES: st = rad_parse_uint("--samples", optarg, 1, 1u << 24, &v); o->samples = (uint32_t)v; break;
        case O_RAYS: st = rad_parse_uint("--shadow-rays", optarg, 0, 1u << 24, &v); o->shadow_rays = (uint32_t)v, rays_given = 1; break;
        case O_SEED: st = rad_parse_uint("--seed", optarg, 0, UINT64_MAX, &v); o->seed = v; break;
        case O_THREADS: st = rad_parse_uint("--threads", optarg, 1, 1024, &v); o->threads = (int)v; break;
        case O_STATS: o->stats_path = optarg; break;
        case O_BACKEND:
            st = parse_name("--backend", optarg, backend_names, FF_NAMES_COUNT(backend_names), &named);
            if (st == RAD_OK) o->backend = (ff_backend_choice)named;
            break;
        case O_ELEMENT:
            st = parse_name("--element", optarg, element_names, FF_NAMES_COUNT(element_names), &named);
            if (st == RAD_OK) o->element = (rad_element_type)named;
            break;
        case O_ESTIMATOR: st = parse_estimator(optarg, &o->estimator); break;
        case O_QUAD_RTOL: st = parse_tolerance("--quad-rtol", optarg, &o->quad_rtol), rtol_given = 1; break;
        case O_FLIP_GROUP:
            o->flip_groups = optarg;
            if (!*optarg || strstr(optarg, ",,") || optarg[0] == ',' || optarg[strlen(optarg) - 1] == ',') {
                rad_error("--flip-group '%s': expected NAME[,NAME...] (the OBJ's `o` or `g` names)", optarg);
                st = RAD_ERR_USAGE;
            }
            break;
        case O_KEEP_NORMALS: o->keep_normals = 1; break;
        case O_METHOD:
            st = parse_name("--method", optarg, method_names, FF_NAMES_COUNT(method_names), &named);
            if (st == RAD_OK) o->method = (ff_method)named;
            break;
        case O_LINK_TOL: st = rad_parse_real("--link-tol", optarg, 0, 1, 1e6, 0, &o->link_tol); break;
        case O_ORACLE: st = parse_name("--oracle", optarg, oracle_names, FF_NAMES_COUNT(oracle_names), &o->oracle); break;
        case O_MIN_AREA: st = rad_parse_real("--min-area", optarg, 0, 1, 1, 0, &o->min_area); break;
        case O_UNIFORM_LEAVES: o->uniform_leaves = 1; break;
        case O_SIZED_LEAVES: o->sized_leaves = 1; break;
        case O_CLUSTERS: st = parse_name("--clusters", optarg, switch_names, FF_NAMES_COUNT(switch_names), &o->clusters); break;
        case O_CLOSURE: st = parse_name("--closure", optarg, switch_names + 1, FF_NAMES_COUNT(switch_names) - 1, &o->closure); break;
        case O_PASSES: st = rad_parse_uint("--passes", optarg, 1, 100, &v); o->passes = (uint32_t)v; break;
        case O_CLUSTER_CONE: st = rad_parse_real("--cluster-cone", optarg, 0, 0, 180, 1, &o->cluster_cone); break;
        case O_CLUSTER_OPEN: st = rad_parse_real("--cluster-open", optarg, 0, 0, 1, 1, &o->cluster_open); break;
        case O_PRESET: st = parse_name("--preset", optarg, preset_names, FF_NAMES_COUNT(preset_names), &o->preset); break;
        case O_QUAD_ATOL: st = parse_tolerance("--quad-atol", optarg, &o->quad_atol); break;
        case O_FLIP_NORMALS: o->flip_normals = 1; break;
        case O_KE: st = parse_name("--ke", optarg, ke_names, FF_NAMES_COUNT(ke_names), &o->ke_radiance); break;
        case O_MAX_BYTES: st = rad_parse_bytes("--max-bytes", optarg, &o->max_bytes); break;
        case O_MAX_SECONDS: st = rad_parse_real("--max-seconds", optarg, 0, 0, 1e12, 1, &o->max_seconds); break;
        case O_DRY_RUN: o->dry_run = 1; break;
        case O_OVERCOMMIT: o->allow_disk_overcommit = 1; break;
        case O_REFINE: o->refine_path = optarg; break;
        case O_REUSE: o->reuse_path = optarg; break;
        case O_REFINE_TOL: st = rad_parse_real("--refine-tol", optarg, 0, 0, 1e6, 0, &o->refine.tolerance); break;
        case O_REFINE_MIN_SIZE: st = parse_tolerance("--refine-min-size", optarg, &o->refine.min_size); break;
        case O_REFINE_MAX_PATCHES:
            st = rad_parse_uint("--refine-max-patches", optarg, 1, UINT32_MAX - 1, &v);
            o->refine.max_patches = (size_t)v;
            break;
        case O_CLAMP_RHO: st = rad_parse_real("--clamp-rho", optarg, 0, 0, 1, 0, &o->clamp_rho); break;
        case O_CONTACTS:
            st = parse_name("--contacts", optarg, contacts_names, FF_NAMES_COUNT(contacts_names), &named);
            if (st == RAD_OK) o->contacts = (rad_mesh_contacts)named;
            break;
        case O_CULL:
            st = parse_name("--cull", optarg, cull_names, FF_NAMES_COUNT(cull_names), &named);
            if (st == RAD_OK) o->cull = (ff_cull)named;
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
        case O_MAX_SAMPLES:
            st = rad_parse_uint("--max-samples", optarg, 1, 1u << 30, &v);
            o->max_samples = (uint32_t)v;
            break;
        case O_ERRORS: o->errors_path = optarg; break;
        case O_NO_ERRORS: o->no_errors = 1; break;
        case O_RECIPROCITY:
            st = parse_name("--reciprocity", optarg, reciprocity_names, FF_NAMES_COUNT(reciprocity_names), &named);
            if (st == RAD_OK) o->reciprocity = (ff_reciprocity)named;
            break;
        case O_FORMAT:
            st = parse_name("--format", optarg, format_names, FF_NAMES_COUNT(format_names), &named);
            if (st == RAD_OK) o->format = (ff_format)named;
            break;
        default:
            rad_error("unknown or incomplete option '%s' (see --help)", argv[optind - 1]);
            st = RAD_ERR_USAGE;
        }
    }
    if (st != RAD_OK) return st;
    if (o->preset == FF_PRESET_PREVIEW) { /* what the flags did not set */
        if (!rays_given) o->shadow_rays = FF_PREVIEW_SHADOW_RAYS;
        if (!rtol_given) o->quad_rtol = FF_PREVIEW_QUAD_RTOL;
    }
    if (optind < argc) o->scene_path = argv[optind++];
    if (optind < argc) {
        rad_error("unexpected argument '%s' (one scene at a time)", argv[optind]);
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

/* The settings formfactor takes from its environment, read here once.
 * Values as the driver read them before (atoi, atof: a value that is not
 * a positive number is ignored). */
static void read_environment(ff_options *o)
{
    const char *threads = getenv("OMP_NUM_THREADS");
    if (o->threads == 0 && threads && atoi(threads) > 0) o->threads = atoi(threads);
    const char *every = getenv("RAD_PROGRESS_SECONDS"); /* tests ask for lines at a cadence of their own */
    if (every && atof(every) > 0) o->progress_seconds = atof(every);
    const char *finish = getenv("RAD_FF_FINISH");
    o->finish_on_host = finish && strcmp(finish, "host") == 0;
    const char *gpu_solve = getenv("RAD_FF_GPU_SOLVE_LINKS"); /* tests: the passes' GPU solves from this many links */
    o->gpu_solve_links = gpu_solve && atoll(gpu_solve) > 0 ? (uint64_t)atoll(gpu_solve) : 0;
    const char *write = getenv("RAD_FF_WRITE");
    o->write_method = write && strcmp(write, "pwrite") == 0 ? FF_WRITE_PWRITE : FF_WRITE_AUTO;
}

/* The options together: contradictions, the --max-samples default, and
 * the output files. */
static rad_status check_options(ff_options *o)
{
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
    if (o->reuse_path && !o->refine_path) {
        rad_error("--reuse %s: only with --refine (the matrix of the mesh being refined)", o->reuse_path);
        return RAD_ERR_USAGE;
    }
    if (o->reuse_path && o->errors_path) {
        rad_error("--reuse and --errors: reused entries have no standard errors here; drop one");
        return RAD_ERR_USAGE;
    }
    if (o->refine_path && o->subdiv_given) {
        rad_error("--subdiv %d with --refine %s: the refined mesh is that solution's, split where it is too coarse; "
                  "drop --subdiv (--refine-tol and --refine-min-size set how fine)",
                  o->subdiv, o->refine_path);
        return RAD_ERR_USAGE;
    }
    if (!o->scene_path && (o->flip_normals || o->flip_groups || o->clamp_rho > 0 || o->ke_radiance)) {
        rad_error("%s: applies to OBJ scenes; the built-in Cornell box's faces point inward, its Kd are below 1 "
                  "and its Ke is radiosity",
                  o->flip_normals ? "--flip-normals" : o->flip_groups ? "--flip-group"
                                  : o->clamp_rho > 0 ? "--clamp-rho" : "--ke radiance");
        return RAD_ERR_USAGE;
    }
    if (o->reuse_path && o->estimator == RAD_ESTIMATOR_QUADRATURE &&
        (o->quad_rtol != RAD_FF_QUAD_RTOL || o->quad_atol != RAD_FF_QUAD_ATOL)) {
        /* A warning, not a refusal: the refinement loop (scripts/refine.sh,
         * the quick start) passes the same tolerances to every pass. */
        rad_warn("--reuse %s with --quad-rtol or --quad-atol: a form-factor file does not record the quadrature "
                 "tolerances it was computed with, so they cannot be checked; its entries are copied as they "
                 "are (give every pass the same tolerances)",
                 o->reuse_path);
    }
    if (o->refine_path && o->subdiv_only) {
        rad_error("--refine splits the mesh of %s as it is; drop --subdiv-only", o->refine_path);
        return RAD_ERR_USAGE;
    }
    if (o->method == FF_METHOD_HIERARCHICAL) {
        const char *bad = o->refine_path ? "--refine" : o->reuse_path ? "--reuse" : o->errors_path ? "--errors"
                        : o->subdiv_only ? "--subdiv-only" : NULL;
        if (bad) {
            rad_error("--method hierarchical: %s is for full matrices (hierarchical runs refine their own "
                      "elements)", bad);
            return RAD_ERR_USAGE;
        }
    }
    if ((o->uniform_leaves || o->sized_leaves) && o->method == FF_METHOD_FULL) {
        rad_error("%s: for --method hierarchical (or auto); the full matrix's leaves are the --subdiv mesh",
                  o->uniform_leaves ? "--uniform-leaves" : "--sized-leaves");
        return RAD_ERR_USAGE;
    }
    if (o->uniform_leaves && o->sized_leaves) {
        rad_error("--uniform-leaves and --sized-leaves: the leaves are made one way; give one");
        return RAD_ERR_USAGE;
    }
    if (o->radiosity_path) {
        const char *bad = o->output_given ? "-o" : o->errors_path ? "--errors"
                        : o->format != FF_FORMAT_SPARSE && o->method != FF_METHOD_HIERARCHICAL ? "--format dense|paper"
                        : NULL;
        if (bad) {
            rad_error("--radiosity %s: the matrix (or the links) is solved in memory and not written, so %s does "
                      "not apply",
                      o->radiosity_path, bad);
            return RAD_ERR_USAGE;
        }
    }
    rad_fs_role roles[] = {{"the scene", o->scene_path, 0}, {"-o", o->radiosity_path ? NULL : o->output, 1},
                           {"--stats", o->stats_path, 1}, {"--radiosity", o->radiosity_path, 1},
                           {"--errors", o->errors_path, 1}, {"--refine", o->refine_path, 0},
                           {"--reuse", o->reuse_path, 0}};
    for (size_t k = 1; k < sizeof roles / sizeof roles[0]; k++)
        if (rad_fs_check_output(roles[k].option, roles[k].path) != RAD_OK) return RAD_ERR_USAGE;
    if (rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]) != RAD_OK) return RAD_ERR_USAGE;
    if (o->format == FF_FORMAT_PAPER && o->element != RAD_ELEMENT_F64) {
        rad_error("--format paper stores float64 only; drop --element f32");
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

rad_status ff_options_parse(int argc, char **argv, ff_options *out)
{
    /* Zero is the default for the enums (auto, all, auto, sparse). */
    *out = (ff_options){.output = "formfactors", .samples = 512, .shadow_rays = 32, .seed = 1,
                        .oracle = FF_ORACLE_AUTO, .clusters = -1, .closure = 0, .cluster_cone = FF_CLUSTER_CONE_DEG, .cluster_open = FF_CLUSTER_OPEN, .link_tol = FF_HIER_LINK_TOL, .min_area = FF_HIER_MIN_AREA, .passes = FF_HIER_PASSES,
                        .element = RAD_ELEMENT_F64, .estimator = RAD_ESTIMATOR_QUADRATURE,
                        .quad_rtol = RAD_FF_QUAD_RTOL, .quad_atol = RAD_FF_QUAD_ATOL};
    out->refine = rad_refine_defaults();
    rad_status status = parse_argv(argc, argv, out);
    if (status != RAD_OK) return status;
    read_environment(out);
    return check_options(out);
}

/* "--backend" as getopt_long takes it: the whole name or an unambiguous
 * abbreviation ("--back"; "--b" alone is not: --b could be --by-...). */
static int names_backend(const char *arg, size_t len)
{
    return len >= 4 && len <= 9 && strncmp(arg, "--backend", len) == 0;
}

/* "--method" as getopt_long takes it (no other option starts "--me"). */
static int names_method(const char *arg, size_t len)
{
    return len >= 4 && len <= 8 && strncmp(arg, "--method", len) == 0;
}

int ff_options_may_use_gpu(int argc, char **argv)
{
    int hierarchical = 0; /* the last --method given wins, as getopt_long takes them */
    for (int k = 1; k < argc; k++) {
        const char *a = argv[k];
        if (strcmp(a, "--") == 0) break;
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0 || strcmp(a, "--version") == 0) return 0;
        const char *eq = strchr(a, '=');
        if (eq && names_backend(a, (size_t)(eq - a)) && strcmp(eq + 1, "cpu") == 0) return 0;
        if (!eq && names_backend(a, strlen(a)) && k + 1 < argc && strcmp(argv[k + 1], "cpu") == 0) return 0;
        if (eq && names_method(a, (size_t)(eq - a))) hierarchical = strcmp(eq + 1, "hierarchical") == 0;
        if (!eq && names_method(a, strlen(a)) && k + 1 < argc) hierarchical = strcmp(argv[k + 1], "hierarchical") == 0;
    }
    /* hierarchical starts CUDA itself once it knows the scene's size
     * (--method auto, which may choose it, still starts early) */
    return !hierarchical;
}
