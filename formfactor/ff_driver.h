/* ff_driver.h - one formfactor run as one call: options in, the
 * form-factor file (and the --errors and --stats files) out. main.c only
 * starts MPI and parses the command line; the decisions are ff_plan.h's,
 * the scene and a refined mesh ff_load.h's, the machine's limits
 * ff_limits.h's, the estimate and progress lines ff_progress.h's.
 *
 * Every rank loads the scene and builds the same patch mesh; rank 0
 * refuses, before the mesh is built, a run too large for the format, the
 * disk, --max-bytes or the memory. Each rank computes its rows in rounds
 * (ff_plan.h says which: a contiguous block of about equal work where it
 * holds them all, blocks taken in turn where they stream); the ranks agree
 * on where each round's rows go (an exclusive scan) and each writes its
 * own in the background while it computes the next round (ff_output.h,
 * ff_writer.h). Rank 0 reports:
 * the estimate line before any row is computed, progress lines, the
 * summary. The files appear under their final names only when every rank
 * succeeded (the --errors file is renamed first, so a failure there
 * leaves the old matrix too).
 */
#ifndef FF_DRIVER_H
#define FF_DRIVER_H

#include "ff_comm.h"
#include "ff_options.h"
#include "rad_status.h"

/* Collective: every rank with the same options (ff_options_parse). The
 * reasons for a failure are logged (by rank 0 where all ranks know them);
 * every rank returns the same status. */
rad_status ff_driver_run(ff_comm *comm, const ff_options *options);

#endif
