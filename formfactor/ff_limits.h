/* ff_limits.h - what this machine gives a run: memory per rank (threads:
 * rad_cpu.h), the free space of the output's file system; and rank 0's check,
 * before the mesh is built, that a run fits them (ff_plan.h decides,
 * this says why not, with the numbers).
 *
 * node_ranks: the ranks on this node (ff_comm_node_size).
 */
#ifndef FF_LIMITS_H
#define FF_LIMITS_H

#include <stdint.h>

#include "ff_options.h"
#include "ff_plan.h"
#include "rad_status.h"


/* Physical memory of this node divided among the ranks on it (bytes);
 * INFINITY where unknown. */
double ff_limits_memory_per_rank(int node_ranks);

/* Rank 0, before the mesh is built: plans a run of patch_count patches on
 * `ranks` ranks (*out_plan) and refuses (RAD_ERR_NOMEM, logged with the
 * numbers) one whose patch count exceeds the format, whose file would not
 * fit in the free space of the output's file system or under --max-bytes,
 * or whose memory per rank would exceed this node's memory per rank. Warns
 * where a sparse file's bound exceeds the free space. */
rad_status ff_limits_check(const ff_options *options, uint64_t patch_count, int ranks, int node_ranks,
                           ff_plan *out_plan);

#endif
