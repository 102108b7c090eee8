/* stats.c - writes the --stats JSON file. */
#include "stats.h"

#include <math.h>
#include <stdio.h>

#include "rad_fs.h"
#include "rad_json.h"

/* The residual history: 6 significant digits (a convergence curve, not
 * a result), 8 values a line. */
#define SOLVE_STATS_HISTORY_DIGITS 6
#define SOLVE_STATS_HISTORY_PER_LINE 8

static void put_number(rad_json_writer *w, const char *key, double value)
{
    rad_json_key(w, key);
    rad_json_number(w, value); /* non-finite: null */
}

static void put_name(rad_json_writer *w, const char *key, const char *name)
{
    rad_json_key(w, key);
    rad_json_string(w, name); /* NULL: null */
}

static void put_count(rad_json_writer *w, const char *key, uint64_t count)
{
    rad_json_key(w, key);
    rad_json_uint(w, count);
}

static void put_flag(rad_json_writer *w, const char *key, int flag)
{
    rad_json_key(w, key);
    rad_json_bool(w, flag);
}

static void put_balance(rad_json_writer *w, const solve_balance *b)
{
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_number(w, "emitted", b->emitted);
    put_number(w, "absorbed", b->absorbed);
    put_number(w, "escaped", b->escaped);
    put_number(w, "imbalance", b->imbalance);
    rad_json_end_object(w);
}

static void put_channel(rad_json_writer *w, const char *name, const solve_report *r)
{
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_name(w, "channel", name);
    put_name(w, "method", solve_method_name(r->method_used));
    put_name(w, "fallback", r->fell_back ? r->fallback_reason : NULL);
    put_count(w, "iterations", r->iterations);
    put_flag(w, "converged", r->converged);
    put_number(w, "residual", r->residual);
    put_number(w, "error_bound", r->error_bound);
    put_count(w, "rounds", r->rounds);
    put_number(w, "reciprocity", r->reciprocity >= 0 ? r->reciprocity : NAN); /* < 0: not measured */
    put_number(w, "margin", r->margin);
    rad_json_line_break(w);
    rad_json_key(w, "energy");
    put_balance(w, &r->balance);
    put_number(w, "seconds", r->seconds);
    rad_json_line_break(w);
    rad_json_key(w, "history");
    rad_json_begin_array(w, RAD_JSON_INLINE);
    for (size_t k = 0; k < r->history_count; k++) {
        if (k > 0 && k % SOLVE_STATS_HISTORY_PER_LINE == 0) rad_json_line_break(w);
        rad_json_number_digits(w, r->history[k], SOLVE_STATS_HISTORY_DIGITS);
    }
    rad_json_end_array(w);
    rad_json_end_object(w);
}

/* A file of links: its size and the solve's balance over all channels. */
static void put_links(rad_json_writer *w, const solve_stats_links *l)
{
    put_count(w, "nodes", l->node_count);
    put_count(w, "leaves", l->leaf_count);
    put_count(w, "links", l->link_count);
    put_number(w, "links_per_leaf", l->leaf_count ? (double)l->link_count / (double)l->leaf_count : 0);
    put_number(w, "link_tol", l->link_tol);
    put_number(w, "error_bound", l->error_bound);
    rad_json_key(w, "balance");
    put_balance(w, &l->balance);
    rad_json_key(w, "closure");
    const rad_closure_result *k = l->closure;
    if (k) {
        rad_json_begin_object(w, RAD_JSON_INLINE);
        put_count(w, "sweeps", k->iterations);
        put_number(w, "row_min", k->row_before[0]);
        put_number(w, "row_max", k->row_before[1]);
        put_number(w, "deviation", k->deviation);
        put_number(w, "scale_min", k->scale[0]);
        put_number(w, "scale_max", k->scale[1]);
        put_count(w, "leaves_without_links", k->empty);
        put_number(w, "seconds", k->seconds);
        rad_json_end_object(w);
    } else {
        rad_json_null(w);
    }
    rad_json_key(w, "shaped");
    const solve_shaped_result *r = l->shaped;
    if (!r) {
        rad_json_null(w);
        return;
    }
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_count(w, "ends", r->shaped_ends);
    put_count(w, "weights", r->weights);
    put_count(w, "iterations", r->iterations);
    put_number(w, "residual", r->residual);
    put_number(w, "change", r->change);
    put_number(w, "seconds", r->seconds);
    put_number(w, "factor_seconds", r->factor_seconds);
    put_number(w, "sweep_seconds", r->sweep_seconds);
    put_name(w, "backend", solve_shaped_backend_name(r->backend));
    rad_json_end_object(w);
}

static void put_stats(rad_json_writer *w, const solve_stats *s)
{
    rad_json_begin_object(w, RAD_JSON_BLOCK);
    put_name(w, "input", s->input);
    put_name(w, "output", s->output);
    put_name(w, "errors", s->errors);
    rad_json_key(w, "row_sums");
    rad_json_begin_object(w, RAD_JSON_INLINE);
    put_number(w, "max", s->row_sums.max);
    put_count(w, "max_row", s->row_sums.max_row);
    put_count(w, "warned", s->row_sums.warned);
    put_name(w, "rule", s->row_sums.with_errors ? "errors" : "fixed");
    rad_json_end_object(w);
    put_count(w, "patch_count", s->patch_count);
    if (s->links) put_links(w, s->links);
    put_flag(w, "grey", s->channel_count == 1);
    put_name(w, "method", solve_method_name(s->method));
    put_number(w, "tolerance", s->tolerance);
    put_count(w, "max_iterations", s->max_iterations);
    put_flag(w, "converged", s->converged);
    put_name(w, "backend", s->backend);
    put_name(w, "device", s->device);
    rad_json_key(w, "device_exact");
    if (s->device_exact < 0)
        rad_json_null(w);
    else
        rad_json_bool(w, s->device_exact);
    put_number(w, "upload_seconds", s->upload_seconds);
    put_count(w, "ranks", s->rank_count ? s->rank_count : 1);
    if (s->rank_rows && s->rank_entries) {
        rad_json_key(w, "rank_rows");
        rad_json_begin_array(w, RAD_JSON_INLINE);
        for (uint32_t r = 0; r < s->rank_count; r++) rad_json_uint(w, s->rank_rows[r]);
        rad_json_end_array(w);
        rad_json_key(w, "rank_entries");
        rad_json_begin_array(w, RAD_JSON_INLINE);
        for (uint32_t r = 0; r < s->rank_count; r++) rad_json_uint(w, s->rank_entries[r]);
        rad_json_end_array(w);
    }
    put_number(w, "load_seconds", s->load_seconds);
    put_number(w, "total_seconds", s->total_seconds);
    rad_json_key(w, "channels");
    rad_json_begin_array(w, RAD_JSON_BLOCK);
    for (uint32_t c = 0; c < s->channel_count; c++) put_channel(w, s->channel_names[c], s->reports[c]);
    rad_json_end_array(w);
    rad_json_end_object(w);
}

rad_status solve_stats_write(const char *path, const solve_stats *stats)
{
    char temp[4096];
    FILE *f = NULL;
    rad_status status = rad_fs_create_temp(path, temp, sizeof temp, &f);
    if (status != RAD_OK) return status;
    rad_json_writer w;
    rad_json_writer_init_file(&w, f);
    put_stats(&w, stats);
    rad_status written = rad_json_finish(&w);
    /* A failed write left ferror(f) set: this logs it and removes the temporary. */
    status = rad_fs_close_commit(f, temp, path);
    return status != RAD_OK ? status : written;
}
