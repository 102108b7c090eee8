/* ff_hierarchical.h - formfactor --method hierarchical: scene -> element
 * quadtrees -> links refined over passes (ff_links.h) -> the links file
 * (rad_ffile.h, layout RAD_FF_LAYOUT_LINKS) and --stats. docs/hierarchy.md. */
#ifndef FF_HIERARCHICAL_H
#define FF_HIERARCHICAL_H

#include "ff_comm.h"
#include "ff_options.h"
#include "rad_status.h"

/* Collective (rank 0 refines and writes; every rank computes its share of
 * each round's pairs); the status is every rank's. */
rad_status ff_hierarchical_run(ff_comm *comm, const ff_options *options);

#endif
