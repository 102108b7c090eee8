#include "ff_stats.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "rad_fs.h"
#include "rad_log.h"

/* Phase times of the whole run: the slowest rank's, as the paper reported. */
static ff_rank_stats overall(const ff_run_info *run, const ff_rank_stats *ranks)
{
    ff_rank_stats all = ranks[0];
    all.row_begin = 0;
    all.row_end = run->patch_count;
    for (int r = 1; r < run->ranks; r++) {
        const ff_rank_stats *s = &ranks[r];
#define FF_MAX(field) all.field = s->field > all.field ? s->field : all.field
        FF_MAX(load); FF_MAX(subdivide); FF_MAX(setup); FF_MAX(form_factors);
        FF_MAX(visibility); FF_MAX(io); FF_MAX(total); FF_MAX(gpu_memory); FF_MAX(mirror);
#undef FF_MAX
        all.counters.pairs += s->counters.pairs;
        all.counters.pairs_mirrored += s->counters.pairs_mirrored;
        all.counters.pairs_culled += s->counters.pairs_culled;
        all.counters.pairs_near += s->counters.pairs_near;
        all.counters.pairs_open_scene += s->counters.pairs_open_scene;
        all.counters.pairs_open_box += s->counters.pairs_open_box;
        all.counters.rays_saved += s->counters.rays_saved;
        all.counters.samples += s->counters.samples;
        all.counters.rays += s->counters.rays;
        all.counters.rays_occluded += s->counters.rays_occluded;
        all.counters.pairs_refined += s->counters.pairs_refined;
        all.counters.pairs_capped += s->counters.pairs_capped;
        ff_rows_summary_merge(&all.rows, &s->rows);
    }
    return all;
}

static void write_times(FILE *f, const ff_rank_stats *s)
{
    fprintf(f,
            "{\"load\": %.6f, \"subdivide\": %.6f, \"setup\": %.6f, \"form_factors\": %.6f, "
            "\"visibility\": %.6f, \"gpu_memory\": %.6f, \"mirror\": %.6f, \"io\": %.6f, \"total\": %.6f}",
            s->load, s->subdivide, s->setup, s->form_factors, s->visibility, s->gpu_memory, s->mirror, s->io, s->total);
}

static void write_counters(FILE *f, const ff_counters *c)
{
    fprintf(f,
            "\"pairs\": %llu, \"pairs_mirrored\": %llu, \"pairs_culled\": %llu, \"pairs_near\": %llu, \"samples\": %llu, \"rays\": %llu, "
            "\"rays_occluded\": %llu, \"pairs_open_scene\": %llu, \"pairs_open_box\": %llu, \"rays_saved\": %llu, "
            "\"pairs_refined\": %llu, \"pairs_capped\": %llu",
            (unsigned long long)c->pairs, (unsigned long long)c->pairs_mirrored, (unsigned long long)c->pairs_culled,
            (unsigned long long)c->pairs_near, (unsigned long long)c->samples,
            (unsigned long long)c->rays, (unsigned long long)c->rays_occluded, (unsigned long long)c->pairs_open_scene,
            (unsigned long long)c->pairs_open_box, (unsigned long long)c->rays_saved,
            (unsigned long long)c->pairs_refined, (unsigned long long)c->pairs_capped);
}

static void write_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; s++) {
        if (*s == '"' || *s == '\\') fputc('\\', f);
        if ((unsigned char)*s < 0x20)
            fprintf(f, "\\u%04x", *s);
        else
            fputc(*s, f);
    }
    fputc('"', f);
}

rad_status ff_stats_write_json(const char *path, const ff_run_info *run, const ff_rank_stats *ranks)
{
    char temp[4096];
    FILE *f = NULL;
    rad_status status = rad_fs_create_temp(path, temp, sizeof temp, &f);
    if (status != RAD_OK) return status;
    ff_rank_stats all = overall(run, ranks);
    /* Throughput over compute time (kernel + shadow rays; the GPU kernel on
     * CUDA), not over the whole run, which includes start-up and I/O. */
    double seconds = all.form_factors + all.visibility > 0 ? all.form_factors + all.visibility : 1e-9;
    fprintf(f, "{\n  \"program\": \"formfactor\",\n  \"scene\": ");
    write_string(f, run->scene);
    fprintf(f, ",\n  \"scene_fingerprint\": \"%016llx\",\n", (unsigned long long)run->fingerprint);
    fprintf(f, "  \"patches\": %u,\n  \"subdiv\": %d,\n  \"subdiv_only\": ", run->patch_count, run->subdiv);
    if (run->subdiv_only) write_string(f, run->subdiv_only); else fputs("null", f);
    fprintf(f, ",\n  \"samples_per_pair\": %u,\n  \"shadow_rays_per_pair\": %u,\n  \"seed\": %llu,\n",
            run->samples, run->shadow_rays, (unsigned long long)run->seed);
    fprintf(f, "  \"estimator\": \"%s\",\n  \"cull\": \"%s\",\n  \"reciprocity\": \"%s\",\n", run->estimator, run->cull,
            run->reciprocity);
    fprintf(f, "  \"backend\": \"%s\",\n  \"element\": \"%s\",\n  \"format\": \"%s\",\n  \"output\": ", run->backend,
            run->element, run->format);
    write_string(f, run->output);
    fprintf(f, ",\n  \"ranks\": %d,\n  \"gpus_visible\": %d,\n  ", run->ranks, run->gpus_visible);
    write_counters(f, &all.counters);
    fprintf(f, ",\n  \"rays_per_second\": %.6g,\n  \"samples_per_second\": %.6g,\n",
            all.counters.rays / seconds, all.counters.samples / seconds);
    fprintf(f, "  \"row_sum\": {\"min\": %.9g, \"max\": %.9g, \"mean\": %.9g},\n", all.rows.row_sum_min, all.rows.row_sum_max,
            run->patch_count ? all.rows.row_sum_total / run->patch_count : 0.0);
    const ff_rows_summary *e = &all.rows;
    if (!run->errors)
        fprintf(f, "  \"standard_error\": null,\n");
    else
        fprintf(f,
                "  \"standard_error\": {\"max\": %.9g, \"mean\": %.9g, \"mean_relative\": %.9g, \"entries\": %llu, "
                "\"worst\": {\"row\": %u, \"column\": %u, \"F\": %.9g}},\n",
                e->error_max, e->error_count ? e->error_sum / e->error_count : 0.0,
                e->error_count ? e->error_relative_sum / e->error_count : 0.0, (unsigned long long)e->error_count,
                e->error_max_row, e->error_max_column, e->error_max_value);
    fprintf(f, "  \"target_error\": %.9g,\n  \"max_samples_per_pair\": %u,\n", run->target_error, run->max_samples);
    fprintf(f, "  \"time_seconds\": ");
    write_times(f, &all);
    fprintf(f, ",\n  \"per_rank\": [\n");
    for (int r = 0; r < run->ranks; r++) {
        const ff_rank_stats *s = &ranks[r];
        fprintf(f, "    {\"rank\": %d, \"threads\": %d, \"rows\": [%u, %u], ", s->rank, s->threads, s->row_begin,
                s->row_end);
        write_counters(f, &s->counters);
        fprintf(f, ", \"time_seconds\": ");
        write_times(f, s);
        fprintf(f, "}%s\n", r + 1 < run->ranks ? "," : "");
    }
    fprintf(f, "  ]\n}\n");
    return rad_fs_close_commit(f, temp, path);
}

void ff_stats_log_summary(const ff_run_info *run, const ff_rank_stats *ranks)
{
    ff_rank_stats all = overall(run, ranks);
    const ff_counters *c = &all.counters;
    rad_info("%u patches, %llu pairs computed (%llu culled, %llu near-field), %llu entries copied by reciprocity, "
             "%llu samples, %llu shadow rays (%.1f%% occluded), %d rank(s)",
             run->patch_count, (unsigned long long)c->pairs, (unsigned long long)c->pairs_culled,
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
    rad_info("row sums: min %.6f  max %.6f  mean %.6f", all.rows.row_sum_min, all.rows.row_sum_max,
             run->patch_count ? all.rows.row_sum_total / run->patch_count : 0.0);
    if (run->patch_count > 1 && !(all.rows.row_sum_max > 0))
        rad_warn("every form factor is 0: no two patches face each other, so no light is exchanged. Do the faces "
                 "point away from each other - a closed object seen from inside, such as Blender's default cube "
                 "used as a room? Run again with --flip-normals, or reverse the faces' vertex order (in Blender: "
                 "Mesh > Normals > Flip)");
    const ff_rows_summary *e = &all.rows;
    if (run->errors)
        rad_info("standard errors of F > 0: mean %.3g (%.2g%% of F), max %.3g at F[%u][%u] = %.3g",
                 e->error_count ? e->error_sum / e->error_count : 0.0,
                 e->error_count ? 100.0 * e->error_relative_sum / e->error_count : 0.0, e->error_max,
                 e->error_max_row, e->error_max_column, e->error_max_value);
    if (run->target_error > 0 && c->pairs_capped == 0)
        rad_info("--target-error %.3g: met by every pair (%llu took more samples or rays)", run->target_error,
                 (unsigned long long)c->pairs_refined);
    else if (run->target_error > 0)
        rad_warn("--target-error %.3g: %llu pairs are still above it at their cap (%llu took more samples or rays); "
                 "the worst is F[%u][%u] = %.6g with a standard error of %.3g; --errors FILE lists every entry's, "
                 "a larger --max-samples raises the cap",
                 run->target_error, (unsigned long long)c->pairs_capped, (unsigned long long)c->pairs_refined,
                 e->error_max_row, e->error_max_column, e->error_max_value, e->error_max);
}
