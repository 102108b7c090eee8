/* ff_options.h - formfactor's command line: the options, the names of
 * their values, and --help.
 *
 *     ff_options options;
 *     rad_status status = ff_options_parse(argc, argv, &options); // logs what is wrong
 *     if (status == RAD_OK && options.help) fputs(ff_options_help, stdout);
 *
 * Each option with a fixed set of values is one enum with one name table:
 * the parser reads the names through it, the stats and messages print them
 * through it (ff_*_name). The estimator's table is core's
 * (rad_estimator_name, rad_estimator.h), shared with the file format.
 */
#ifndef FF_OPTIONS_H
#define FF_OPTIONS_H

#include <stdint.h>

#include "ff_output.h"
#include "rad_estimator.h"
#include "rad_ffile.h"
#include "rad_mesh.h"
#include "rad_refine.h"
#include "rad_status.h"

/* --backend: auto = the GPU when this process sees one, else the CPU. */
typedef enum ff_backend_choice { FF_BACKEND_AUTO, FF_BACKEND_CPU, FF_BACKEND_CUDA } ff_backend_choice;

/* --cull: all = skip shadow rays where nothing can lie between the two
 * patches (the same matrix); none = cast them all. */
typedef enum ff_cull { FF_CULL_ALL, FF_CULL_NONE } ff_cull;

/* --reciprocity: compute each unordered pair once and copy the other
 * entry (which needs the rank's rows in memory), or compute both (rows
 * stream through a round buffer); auto decides by memory (ff_plan.h). The
 * bytes are the same. */
/* --method: full = the N x N matrix of the --subdiv mesh; hierarchical =
 * links between elements of quadtrees over the faces (ff_links.h);
 * auto = hierarchical where the full matrix would hold more than
 * FF_AUTO_HIERARCHICAL_PATCHES patches, said on stderr. */
typedef enum ff_method { FF_METHOD_FULL = 0, FF_METHOD_HIERARCHICAL = 1, FF_METHOD_AUTO = 2 } ff_method;
#define FF_AUTO_HIERARCHICAL_PATCHES 20000u
/* Hierarchical runs: the finest level when --subdiv is not given, the
 * default --link-tol, --min-area (of the scene's total area) and --passes. */
#define FF_HIER_MAX_LEVEL 5
/* --method hierarchical --backend auto takes the GPU where a GPU is visible
 * and the leaves may reach this many a CPU thread (faces x 4^level, an
 * upper bound): below, the CPU's threads finish before CUDA has started
 * (0.22-0.35 s on an H100 host). The Cornell box's quick start (29 696
 * leaves) on 16 cores: 0.46-0.54 s on the CPU, 0.62-0.69 s with CUDA;
 * cornell_sphere at level 5 (47 104) 0.74 s either way, at level 6 (188 416)
 * 2.3 s against 6.8 s (docs/performance.md). */
#define FF_HIER_CPU_LEAVES_PER_THREAD 4096u
#define FF_HIER_LINK_TOL 1e-2
#define FF_HIER_MIN_AREA 1e-7
#define FF_HIER_PASSES 3
/* --cluster-cone's default (docs/hierarchy.md, "Clusters facing apart"). */
#define FF_CLUSTER_CONE_DEG 70.0
/* --cluster-open's default (docs/hierarchy.md, "Clusters partly hidden"). */
#define FF_CLUSTER_OPEN 0.8

typedef enum ff_reciprocity { FF_RECIPROCITY_AUTO, FF_RECIPROCITY_ON, FF_RECIPROCITY_OFF } ff_reciprocity;

/* The names as the command line and the stats spell them ("auto", "cpu",
 * ...); "unknown" for a value outside the enum. */
const char *ff_backend_choice_name(ff_backend_choice backend);
const char *ff_cull_name(ff_cull cull);
const char *ff_contacts_name(rad_mesh_contacts contacts); /* "cut", "keep" */
const char *ff_reciprocity_name(ff_reciprocity reciprocity);
const char *ff_element_name(rad_element_type element); /* "f64", "f32" */
const char *ff_format_name(ff_format format);          /* "sparse", "dense", "paper" */
const char *ff_method_name(ff_method method);          /* "full", "hierarchical", "auto" */

typedef struct ff_options {
    const char *scene_path;  /* NULL = built-in Cornell box */
    const char *output;      /* "formfactors" */
    int output_given;        /* -o was on the command line */
    const char *radiosity_path; /* --radiosity FILE: solve in memory and write the radiosity, not the matrix
                                   (scene to radiosity without the round trip; NULL = write the matrix) */
    const char *stats_path;  /* NULL = none */
    const char *errors_path; /* --errors: standard errors of F as a second file; NULL = none */
    int no_errors;           /* --no-errors: skip them (GPU: about N % less kernel time) */
    double target_error;     /* --target-error; 0 = one batch */
    uint32_t max_samples;    /* --max-samples; resolved: 64 x samples when not given */
    const char *subdiv_only; /* --subdiv-only GROUP; NULL = every face */
    rad_mesh_contacts contacts; /* --contacts cut|keep (rad_mesh.h); 0 = cut */
    ff_backend_choice backend;
    int subdiv;
    int subdiv_given;        /* --subdiv was on the command line (refused with --refine) */
    uint32_t samples, shadow_rays;
    uint64_t seed;
    rad_element_type element;
    rad_estimator_id estimator;
    double quad_rtol, quad_atol; /* --quad-rtol, --quad-atol */
    double clamp_rho;        /* --clamp-rho: Kd above it set to it; 0 = refuse Kd >= 1 */
    double max_bytes;        /* --max-bytes: refuse a larger output; 0 = only the disk's free space */
    double max_seconds;      /* --max-seconds: refuse a run estimated to take longer; 0 = no limit */
    int dry_run;             /* --dry-run: load, mesh and set up, report the stages' times, stop */
    int allow_disk_overcommit; /* --allow-disk-overcommit: run a sparse file whose bound is over 10x the free space */
    int flip_normals;        /* --flip-normals: every face wound the other way */
    const char *flip_groups; /* --flip-group NAME[,NAME...]: those OBJ objects/groups' faces wound
                                the other way (rad_scene_options.flip_groups); NULL = none */
    int keep_normals;        /* --keep-normals: run a scene enclosed by an outward-facing shell
                                (rad_enclosure.h) as it is instead of refusing it */
    ff_method method;        /* --method */
    double link_tol;         /* --link-tol (hierarchical) */
    int oracle;              /* --oracle: ff_oracle (ff_links.h), or FF_ORACLE_AUTO: gather with
                                uniform or sized leaves, else error */
    double min_area;         /* --min-area: fraction of the scene's total area */
    uint32_t passes;         /* --passes: refinement passes (hierarchical) */
    int uniform_leaves;      /* --uniform-leaves: every face split to --subdiv first (hierarchical) */
    int sized_leaves;        /* --sized-leaves: every face split first to the largest face's leaf area */
    int clusters;            /* --clusters: 1 on, 0 off, -1 auto (on from FF_CLUSTERS_AUTO_ROOTS faces) */
    double cluster_cone;     /* --cluster-cone: degrees (180: any cluster may link) */
    double cluster_open;     /* --cluster-open: largest spread of openness a linked cluster may hold (1: any) */
    int closure;             /* --closure: 1 on (where the scene is closed, ff_scene_is_closed: sets
                                RAD_FF_FLAG_CLOSED, for solve, rad_closure.h), 0 off (the default) */
    int preset;              /* --preset: FF_PRESET_FINAL (default) or FF_PRESET_PREVIEW */
    int ke_radiance;         /* --ke radiance: Ke is emitted radiance, E = pi Ke
                                (rad_scene_options.ke_radiance); 0 = --ke radiosity */
    const char *refine_path; /* --refine RADIOSITY: split that solution's mesh; NULL = none */
    const char *reuse_path;  /* --reuse FORMFACTORS: that mesh's matrix, for the unsplit pairs */
    rad_refine_options refine; /* --refine-tol, --refine-min-size, --refine-max-patches
                                  (0 = no limit); defaults rad_refine_defaults() */
    ff_format format;
    int threads;             /* --threads, else OMP_NUM_THREADS; 0 = cores / ranks on this node */
    ff_cull cull;
    ff_reciprocity reciprocity;
    int quiet;
    int help, version;
    /* From the environment, for tests and benchmarks (read once, by ff_options_parse): */
    double progress_seconds; /* RAD_PROGRESS_SECONDS: progress lines every so many seconds; 0 = by the estimate */
    int finish_on_host;      /* RAD_FF_FINISH=host: the CPU finishes rows a GPU would encode (the same bytes) */
    uint64_t gpu_solve_links; /* RAD_FF_GPU_SOLVE_LINKS: hierarchical passes' flat solves go to the GPU from this
                                 many links (tests, >= 1); 0: the default (ff_hierarchical.c) */
    ff_write_method write_method; /* RAD_FF_WRITE=pwrite: no mapped writes (ff_writer.h; the same bytes) */
} ff_options;

/* --preset preview: where not given, --quad-rtol FF_PREVIEW_QUAD_RTOL and
 * --shadow-rays FF_PREVIEW_SHADOW_RAYS. On curved Blender meshes (the
 * corpus room with a smooth UV sphere, subdivided Suzanne) that was 7.7x
 * faster than the defaults for a picture 0.4/255 from theirs on average
 * (issue 30; docs/performance.md, "Presets"). final: the defaults. */
enum { FF_PRESET_FINAL = 0, FF_PRESET_PREVIEW = 1 };
#define FF_PREVIEW_QUAD_RTOL 1e-5
#define FF_PREVIEW_SHADOW_RAYS 16

/* Parses argv (getopt_long: "--name VALUE", "--name=VALUE", unambiguous
 * abbreviations, "-oFILE") into *out, defaults filled in, reads the
 * environment's settings (OMP_NUM_THREADS where --threads is not given,
 * RAD_PROGRESS_SECONDS, RAD_FF_FINISH, RAD_FF_WRITE: the only place formfactor reads
 * its environment), and checks the options together: contradictions, and
 * the output files (new, regular or character devices, no two roles
 * naming one file; docs/reliability.md, "Threat model: files on disk").
 * RAD_ERR_USAGE, logged, otherwise. */
rad_status ff_options_parse(int argc, char **argv, ff_options *out);

/* 0 when argv says the run will not touch a GPU (--backend cpu, --help,
 * --version) or will decide later (--method hierarchical, which starts
 * CUDA once the scene's size says it may use it), else 1: a quick look
 * before MPI starts and the options are parsed, so that CUDA can start
 * early (ff_cuda.h). A wrong 1 only costs the start of CUDA. */
int ff_options_may_use_gpu(int argc, char **argv);

/* The --help text (for stdout). */
extern const char ff_options_help[];

#endif
