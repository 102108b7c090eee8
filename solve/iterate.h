/* iterate.h - the solver's methods, for solver.c and for the tests that
 * drive a method or the CG check directly. Internal to solve/.
 *
 * One header per part, each including only what it needs; none of them
 * includes this one, and none calls back into solver.c:
 *   run.h         one channel's run and its bookkeeping (run.c)
 *   products.h    F·x for several vectors in one pass (products.c)
 *   stationary.h  Jacobi, Gauss-Seidel (stationary.c)
 *   cg_check.h    whether CG may run: the reciprocity check (cg_check.c)
 *   cg.h          conjugate gradients (cg.c)
 *   rounds.h      the GPU's rounds of refinement (rounds.c)
 */
#ifndef SOLVE_ITERATE_H
#define SOLVE_ITERATE_H

#include "cg.h"
#include "cg_check.h"
#include "products.h"
#include "rounds.h"
#include "run.h"
#include "solver.h"
#include "stationary.h"

#endif
