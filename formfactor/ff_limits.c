/* ff_limits.c - this machine's cores, memory and disk, and the refusal of
 * a run that does not fit them (ff_limits.h). */
#include "ff_limits.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "ff_output.h"
#include "ff_progress.h"
#include "rad_log.h"

double ff_limits_memory_per_rank(int node_ranks)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (node_ranks < 1) node_ranks = 1;
    return pages > 0 && page > 0 ? (double)pages * (double)page / node_ranks : INFINITY;
}

rad_status ff_limits_check(const ff_options *o, uint64_t n, int ranks, int node_ranks, ff_plan *out_plan)
{
    char dir[4096];
    const char *slash = strrchr(o->output, '/');
    if (slash)
        snprintf(dir, sizeof dir, "%.*s", slash == o->output ? 1 : (int)(slash - o->output), o->output);
    else
        snprintf(dir, sizeof dir, ".");
    struct statvfs fs; /* no answer: opening the output fails later and says why */
    double free_bytes = statvfs(dir, &fs) == 0 ? (double)fs.f_bavail * (double)fs.f_frsize : INFINITY;
    if (o->radiosity_path) free_bytes = INFINITY; /* the matrix stays in memory (--radiosity) */
    double per_rank = ff_limits_memory_per_rank(node_ranks);
    ff_plan_limits limits = {.patch_count = n, .ranks = ranks, .rank = 0,
                             .memory_per_rank = per_rank, .free_bytes = free_bytes,
                             .max_rows_per_write = ff_output_max_rows(n, o->format, o->element)};
    ff_plan_choices choices = ff_plan_choices_of(o);
    ff_plan_make(&limits, &choices, out_plan);
    const ff_plan *plan = out_plan;
    char why[4400] = "", have[32];
    if (plan->refusal == FF_PLAN_ACCEPTED && o->format == FF_FORMAT_SPARSE && plan->file_bytes > free_bytes) {
        char bound[32];
        rad_warn("%s has %s free and the sparse file may need up to %s (all N^2 entries); most scenes need a "
                 "tenth of that, and a full disk stops the run with nothing left behind",
                 dir, ff_progress_format_bytes(free_bytes, have, sizeof have),
                 ff_progress_format_bytes(plan->file_bytes, bound, sizeof bound));
    }
    switch (plan->refusal) {
    case FF_PLAN_ACCEPTED: return RAD_OK;
    case FF_PLAN_TOO_MANY_PATCHES:
        snprintf(why, sizeof why, "more than the format's limit of %" PRIu64 " patches", FF_MAX_PATCHES);
        break;
    case FF_PLAN_DISK:
        if (o->format == FF_FORMAT_SPARSE)
            snprintf(why, sizeof why, "%s has %s free, less than a tenth of that bound (the sparse file is often a "
                     "tenth of it: --allow-disk-overcommit runs anyway; a full disk stops the run, old output kept)",
                     dir, ff_progress_format_bytes(free_bytes, have, sizeof have));
        else
            snprintf(why, sizeof why, "%s has %s free", dir, ff_progress_format_bytes(free_bytes, have, sizeof have));
        break;
    case FF_PLAN_MAX_BYTES:
        snprintf(why, sizeof why, "--max-bytes is %s", ff_progress_format_bytes(o->max_bytes, have, sizeof have));
        break;
    case FF_PLAN_MEMORY:
        snprintf(why, sizeof why, "this node has %s per rank (%d rank(s) on it)",
                 ff_progress_format_bytes(per_rank, have, sizeof have), node_ranks > 0 ? node_ranks : 1);
        break;
    }
    char need[32], mem[32];
    rad_error("%s: %" PRIu64 " patches: %s would need %s (N^2 x %.0f bytes) and each rank about %s "
              "of memory, but %s; refused (--element f32 halves the file; each --subdiv level less divides it by 16)",
              o->refine_path ? "--refine" : "--subdiv", n, o->output,
              ff_progress_format_bytes(plan->file_bytes, need, sizeof need),
              plan->element_bytes, ff_progress_format_bytes(plan->memory_bytes, mem, sizeof mem), why);
    return RAD_ERR_NOMEM;
}
