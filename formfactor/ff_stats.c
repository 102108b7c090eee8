#include "ff_stats.h"

#include <stdio.h>

#include "rad_fs.h"
#include "rad_json.h"
#include "rad_log.h"

/* Phase times of the whole run: the slowest rank's, as the paper reported;
 * counters: the sum of the ranks'. */
static ff_rank_stats overall(const ff_run_info *run, const ff_rank_stats *ranks)
{
    ff_rank_stats all = ranks[0];
    all.row_count = run->patch_count;
    all.row_begin = 0;
    all.row_end = run->patch_count;
    all.block_size = 0;
    for (int r = 1; r < run->ranks; r++) {
        const ff_rank_stats *s = &ranks[r];
#define FF_MAX(field) all.field = s->field > all.field ? s->field : all.field
        FF_MAX(load); FF_MAX(subdivide); FF_MAX(setup); FF_MAX(form_factors);
        FF_MAX(visibility); FF_MAX(io); FF_MAX(total); FF_MAX(gpu_memory); FF_MAX(mirror);
        FF_MAX(cuda_start); FF_MAX(estimate); FF_MAX(write);
#undef FF_MAX
        all.write_bytes += s->write_bytes;
        ff_counters_add(&all.counters, &s->counters);
        ff_rows_summary_merge(&all.rows, &s->rows);
    }
    return all;
}

/* Measurements get the digits they have: times to the microsecond, rates
 * to 6 significant digits, form factors and their errors to 9. */
#define FF_STATS_TIME_DECIMALS 6
#define FF_STATS_RATE_DIGITS 6
#define FF_STATS_VALUE_DIGITS 9

static void put_time(rad_json_writer *w, const char *key, double seconds)
{
    rad_json_key(w, key);
    rad_json_number_fixed(w, seconds, FF_STATS_TIME_DECIMALS);
}

static void put_value(rad_json_writer *w, const char *key, double value)
{
    rad_json_key(w, key);
    rad_json_number_digits(w, value, FF_STATS_VALUE_DIGITS);
}

static void put_count(rad_json_writer *w, const char *key, uint64_t count)
{
    rad_json_key(w, key);
    rad_json_uint(w, count);
}

static void put_name(rad_json_writer *w, const char *key, const char *name)
{
    rad_json_key(w, key);
    rad_json_string(w, name);
}

static void put_times(rad_json_writer *w, const ff_rank_stats *s)
{
    rad_json_key(w, "time_seconds");
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_time(w, "load", s->load);
    put_time(w, "subdivide", s->subdivide);
    put_time(w, "setup", s->setup);
    put_time(w, "form_factors", s->form_factors);
    put_time(w, "visibility", s->visibility);
    put_time(w, "gpu_memory", s->gpu_memory);
    put_time(w, "mirror", s->mirror);
    put_time(w, "cuda_start", s->cuda_start);
    put_time(w, "estimate", s->estimate);
    put_time(w, "io", s->io);
    put_time(w, "write", s->write);
    put_time(w, "total", s->total);
    rad_json_end_object(w);
}

/* The counters, as members of the object being written: on one line. */
static void put_counters(rad_json_writer *w, const ff_counters *c)
{
    rad_json_line_begin(w);
    put_count(w, "pairs", c->pairs);
    put_count(w, "pairs_mirrored", c->pairs_mirrored);
    put_count(w, "pairs_culled", c->pairs_not_facing); /* the key predates the name (docs/formats.md) */
    put_count(w, "pairs_reused", c->pairs_reused);
    put_count(w, "pairs_near", c->pairs_near);
    put_count(w, "samples", c->samples);
    put_count(w, "rays", c->rays);
    put_count(w, "rays_occluded", c->rays_occluded);
    put_count(w, "pairs_open_scene", c->pairs_open_scene);
    put_count(w, "pairs_open_box", c->pairs_open_box);
    put_count(w, "rays_saved", c->rays_saved);
    put_count(w, "pairs_refined", c->pairs_refined);
    put_count(w, "pairs_capped", c->pairs_capped);
    rad_json_line_end(w);
}

static void put_standard_error(rad_json_writer *w, const ff_run_info *run, const ff_rows_summary *e)
{
    rad_json_key(w, "standard_error");
    if (!run->errors) {
        rad_json_null(w);
        return;
    }
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_value(w, "max", e->error_max);
    put_value(w, "mean", e->error_count ? e->error_sum / e->error_count : 0.0);
    put_value(w, "mean_relative", e->error_count ? e->error_relative_sum / e->error_count : 0.0);
    put_count(w, "entries", e->error_count);
    rad_json_key(w, "worst");
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_count(w, "row", e->error_max_row);
    put_count(w, "column", e->error_max_column);
    put_value(w, "F", e->error_max_value);
    rad_json_end_object(w);
    rad_json_end_object(w);
}

static void put_rank(rad_json_writer *w, const ff_rank_stats *s)
{
    rad_json_begin_object(w, RAD_JSON_INLINE);
    rad_json_key(w, "rank");
    rad_json_int(w, s->rank);
    rad_json_key(w, "threads");
    rad_json_int(w, s->threads);
    put_count(w, "rows", s->row_count);
    if (s->block_size == 0) { /* its block of the split */
        rad_json_key(w, "row_range");
        rad_json_begin_array(w, RAD_JSON_INLINE);
        rad_json_uint(w, s->row_begin);
        rad_json_uint(w, s->row_end);
        rad_json_end_array(w);
    } else { /* streamed: blocks taken in turn by the ranks */
        rad_json_key(w, "row_blocks");
        rad_json_begin_object(w, RAD_JSON_INLINE);
        put_count(w, "first", s->row_begin);
        put_count(w, "size", s->block_size);
        put_count(w, "every", s->block_stride);
        rad_json_end_object(w);
    }
    put_counters(w, &s->counters);
    put_count(w, "written_bytes", s->write_bytes);
    put_times(w, s);
    rad_json_end_object(w);
}

static void put_run(rad_json_writer *w, const ff_run_info *run, const ff_rank_stats *ranks)
{
    ff_rank_stats all = overall(run, ranks);
    /* Throughput over compute time (kernel + shadow rays; the GPU kernel on
     * CUDA), not over the whole run, which includes start-up and I/O. */
    double seconds = all.form_factors + all.visibility > 0 ? all.form_factors + all.visibility : 1e-9;
    char fingerprint[17];
    snprintf(fingerprint, sizeof fingerprint, "%016llx", (unsigned long long)run->fingerprint);
    rad_json_begin_object(w, RAD_JSON_BLOCK);
    put_name(w, "program", "formfactor");
    put_name(w, "scene", run->scene);
    put_name(w, "scene_fingerprint", fingerprint);
    put_count(w, "patches", run->patch_count);
    rad_json_key(w, "subdiv");
    rad_json_int(w, run->subdiv);
    put_name(w, "subdiv_only", run->subdiv_only); /* NULL: null */
    put_name(w, "contacts", run->contacts);
    rad_json_key(w, "refine");
    if (!run->refine_from) {
        rad_json_null(w);
    } else {
        rad_json_begin_object(w, RAD_JSON_BLOCK);
        put_name(w, "from", run->refine_from);
        rad_json_key(w, "tolerance");
        rad_json_number_digits(w, run->refine_tol, 6);
        put_count(w, "patches_before", run->refine_patches_before);
        put_count(w, "split", run->refine->split);
        put_count(w, "over_tolerance", run->refine->marked);
        put_count(w, "balanced", run->refine->balanced);
        put_count(w, "at_min_size", run->refine->too_small);
        put_count(w, "over_max_patches", run->refine->over_budget);
        rad_json_key(w, "max_jump");
        rad_json_number_digits(w, run->refine->max_indicator, 6);
        rad_json_end_object(w);
    }
    put_count(w, "samples_per_pair", run->samples);
    put_count(w, "shadow_rays_per_pair", run->shadow_rays);
    put_count(w, "seed", run->seed);
    put_name(w, "estimator", run->estimator);
    put_name(w, "cull", run->cull);
    put_name(w, "reciprocity", run->reciprocity);
    put_name(w, "backend", run->backend);
    put_name(w, "element", run->element);
    put_name(w, "format", run->format);
    put_name(w, "output", run->output);
    put_count(w, "written_bytes", all.write_bytes);
    put_name(w, "write_method", ranks[0].write_mapped ? "map" : "pwrite"); /* rank 0's (ff_writer.h) */
    rad_json_key(w, "ranks");
    rad_json_int(w, run->ranks);
    rad_json_key(w, "gpus_visible");
    rad_json_int(w, run->gpus_visible);
    put_counters(w, &all.counters);
    rad_json_key(w, "rays_per_second");
    rad_json_number_digits(w, all.counters.rays / seconds, FF_STATS_RATE_DIGITS);
    rad_json_key(w, "samples_per_second");
    rad_json_number_digits(w, all.counters.samples / seconds, FF_STATS_RATE_DIGITS);
    rad_json_key(w, "row_sum");
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_value(w, "min", all.rows.row_sum_min);
    put_value(w, "max", all.rows.row_sum_max);
    put_value(w, "mean", run->patch_count ? all.rows.row_sum_total / run->patch_count : 0.0);
    rad_json_end_object(w);
    put_standard_error(w, run, &all.rows);
    put_value(w, "target_error", run->target_error);
    put_count(w, "max_samples_per_pair", run->max_samples);
    put_times(w, &all);
    rad_json_key(w, "per_rank");
    rad_json_begin_array(w, RAD_JSON_BLOCK);
    for (int r = 0; r < run->ranks; r++) put_rank(w, &ranks[r]);
    rad_json_end_array(w);
    rad_json_end_object(w);
}

rad_status ff_stats_write_json(const char *path, const ff_run_info *run, const ff_rank_stats *ranks)
{
    char temp[4096];
    FILE *f = NULL;
    rad_status status = rad_fs_create_temp(path, temp, sizeof temp, &f);
    if (status != RAD_OK) return status;
    rad_json_writer w;
    rad_json_writer_init_file(&w, f);
    put_run(&w, run, ranks);
    rad_status written = rad_json_finish(&w);
    /* A failed write left ferror(f) set: this logs it and removes the temporary. */
    status = rad_fs_close_commit(f, temp, path);
    return status != RAD_OK ? status : written;
}

void ff_stats_log_summary(const ff_run_info *run, const ff_rank_stats *ranks)
{
    ff_rank_stats all = overall(run, ranks);
    const ff_counters *c = &all.counters;
    rad_info("%u patches, %llu pairs computed (%llu culled, %llu near-field), %llu entries copied by reciprocity, "
             "%llu samples, %llu shadow rays (%.1f%% occluded), %d rank(s)",
             run->patch_count, (unsigned long long)c->pairs, (unsigned long long)c->pairs_not_facing,
             (unsigned long long)c->pairs_near, (unsigned long long)c->pairs_mirrored,
             (unsigned long long)c->samples, (unsigned long long)c->rays,
             c->rays ? 100.0 * c->rays_occluded / c->rays : 0.0, run->ranks);
    if (c->rays + c->rays_saved > 0)
        rad_info("culling: %llu pairs need no shadow rays (%llu: convex scene, %llu: nothing in their box); "
                 "%llu rays saved, %.1f%% of %llu",
                 (unsigned long long)(c->pairs_open_scene + c->pairs_open_box), (unsigned long long)c->pairs_open_scene,
                 (unsigned long long)c->pairs_open_box, (unsigned long long)c->rays_saved,
                 100.0 * c->rays_saved / (double)(c->rays + c->rays_saved), (unsigned long long)(c->rays + c->rays_saved));
    rad_info("time (s, slowest rank): load %.3f  subdivide %.3f  setup %.3f  form factors %.3f  visibility %.3f  "
             "GPU memory %.3f  I/O %.3f  total %.3f",
             all.load, all.subdivide, all.setup, all.form_factors, all.visibility, all.gpu_memory, all.io, all.total);
    if (run->held)
        rad_info("no file written (--radiosity): the rows went into the solve's matrix as they came, decoded in "
                 "%.3f s in the background on the slowest rank", all.write);
    else
        rad_info("written: %.3f GB by %d rank(s) (%s), in flight %.3f s on the slowest rank", all.write_bytes * 1e-9,
                 run->ranks, ranks[0].write_mapped ? "mapped" : "pwrite", all.write);
    rad_info("row sums: min %.6f  max %.6f  mean %.6f", all.rows.row_sum_min, all.rows.row_sum_max,
             run->patch_count ? all.rows.row_sum_total / run->patch_count : 0.0);
    if (run->patch_count > 1 && !(all.rows.row_sum_max > 0))
        rad_warn("every form factor is 0: no two patches face each other, so no light is exchanged. Right for one "
                 "convex object seen from outside (Blender's default cube); a room seen from inside needs its "
                 "faces pointing inward: run again with --flip-normals (every face) or --flip-group NAME (one "
                 "OBJ object), or in Blender: Edit Mode, Mesh > Normals > Flip");
    const ff_rows_summary *e = &all.rows;
    /* The entries with an error are those with F > 0, so their F sum to row_sum_total. */
    double mean_error = e->error_count ? e->error_sum / e->error_count : 0.0;
    double mean_f = e->error_count ? all.rows.row_sum_total / e->error_count : 0.0;
    if (run->errors)
        rad_info("standard errors of the %llu entries F > 0: mean %.3g against their mean F %.3g (%.3g%%), max %.3g "
                 "at F[%u][%u] = %.3g", (unsigned long long)e->error_count, mean_error, mean_f,
                 mean_f > 0 ? 100.0 * mean_error / mean_f : 0.0, e->error_max, e->error_max_row,
                 e->error_max_column, e->error_max_value);
    if (run->target_error > 0 && c->pairs_capped == 0)
        rad_info("--target-error %.3g: met by every pair (%llu took more samples or rays)", run->target_error,
                 (unsigned long long)c->pairs_refined);
    else if (run->target_error > 0)
        rad_warn("--target-error %.3g: %llu pairs are still above it at their cap (%llu took more samples or rays; "
                 "quadrature limits are not counted unless their error misses the target too); "
                 "the worst is F[%u][%u] = %.6g with a standard error of %.3g; --errors FILE lists every entry's, "
                 "a larger --max-samples raises the cap",
                 run->target_error, (unsigned long long)c->pairs_capped, (unsigned long long)c->pairs_refined,
                 e->error_max_row, e->error_max_column, e->error_max_value, e->error_max);
}
