/* stats.c - writes the --stats JSON file. */
#include "stats.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "rad_fs.h"
#include "rad_log.h"

/* A JSON string: quotes, backslashes and control characters escaped. */
static void put_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\')
            fprintf(f, "\\%c", *p);
        else if (*p < 0x20)
            fprintf(f, "\\u%04x", *p);
        else
            fputc(*p, f);
    }
    fputc('"', f);
}

/* A JSON number; JSON has no infinity or NaN, so those become null. */
static void put_number(FILE *f, double x)
{
    if (isfinite(x))
        fprintf(f, "%.17g", x);
    else
        fputs("null", f);
}

static void put_channel(FILE *f, const char *name, const solve_report *r)
{
    fputs("    {\"channel\": ", f);
    put_string(f, name);
    fputs(", \"method\": ", f);
    put_string(f, solve_method_name(r->method_used));
    fputs(", \"fallback\": ", f);
    if (r->fell_back)
        put_string(f, r->fallback_reason);
    else
        fputs("null", f);
    fprintf(f, ", \"iterations\": %u, \"converged\": %s, \"residual\": ", r->iterations,
            r->converged ? "true" : "false");
    put_number(f, r->residual);
    fputs(", \"error_bound\": ", f);
    put_number(f, r->error_bound);
    fputs(", \"reciprocity\": ", f);
    put_number(f, r->reciprocity >= 0 ? r->reciprocity : NAN);
    fputs(", \"margin\": ", f);
    put_number(f, r->margin);
    fputs(",\n     \"energy\": {\"emitted\": ", f);
    put_number(f, r->balance.emitted);
    fputs(", \"absorbed\": ", f);
    put_number(f, r->balance.absorbed);
    fputs(", \"escaped\": ", f);
    put_number(f, r->balance.escaped);
    fputs(", \"imbalance\": ", f);
    put_number(f, r->balance.imbalance);
    fputs("}", f);
    fputs(", \"seconds\": ", f);
    put_number(f, r->seconds);
    fputs(",\n     \"history\": [", f);
    for (size_t k = 0; k < r->history_count; k++) {
        if (k) fputs(k % 8 ? ", " : ",\n       ", f);
        fprintf(f, "%.6g", r->history[k]);
    }
    fputs("]}", f);
}

static void put_stats(FILE *f, const solve_stats *s)
{
    fputs("{\n  \"input\": ", f);
    put_string(f, s->input);
    fputs(",\n  \"output\": ", f);
    put_string(f, s->output);
    fputs(",\n  \"errors\": ", f);
    if (s->errors)
        put_string(f, s->errors);
    else
        fputs("null", f);
    fputs(",\n  \"row_sums\": {\"max\": ", f);
    put_number(f, s->row_sums.max);
    fprintf(f, ", \"max_row\": %zu, \"warned\": %zu, \"rule\": \"%s\"}", s->row_sums.max_row,
            s->row_sums.warned, s->row_sums.with_errors ? "errors" : "fixed");
    fprintf(f, ",\n  \"patch_count\": %zu,\n  \"grey\": %s,\n  \"method\": ", s->patch_count,
            s->channel_count == 1 ? "true" : "false");
    put_string(f, solve_method_name(s->method));
    fputs(",\n  \"tolerance\": ", f);
    put_number(f, s->tolerance);
    fprintf(f, ",\n  \"max_iterations\": %u,\n  \"converged\": %s,\n  \"load_seconds\": ", s->max_iterations,
            s->converged ? "true" : "false");
    put_number(f, s->load_seconds);
    fputs(",\n  \"total_seconds\": ", f);
    put_number(f, s->total_seconds);
    fputs(",\n  \"channels\": [\n", f);
    for (uint32_t c = 0; c < s->channel_count; c++) {
        if (c) fputs(",\n", f);
        put_channel(f, s->channel_names[c], s->reports[c]);
    }
    fputs("\n  ]\n}\n", f);
}

rad_status solve_stats_write(const char *path, const solve_stats *stats)
{
    char temp[4096];
    FILE *f = NULL;
    rad_status status = rad_fs_create_temp(path, temp, sizeof temp, &f);
    if (status != RAD_OK) return status;
    put_stats(f, stats);
    return rad_fs_close_commit(f, temp, path);
}
