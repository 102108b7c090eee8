#!/bin/sh
# Hierarchical links files (issue 26) are the same bytes for any thread and
# rank count: formfactor --method hierarchical on cornell_sphere with 1 and
# 2 threads, and under mpirun -n 2 and -n 3 (every rank computes its chunks
# of each round's pairs, ff_rank_rounds.h; three cut the rounds unevenly;
# through shared memory and through messages),
# then solve's radiosity files too, and formfactor --radiosity's (the links
# solved in memory), on one rank and on two.
#   hier_identical.sh FORMFACTOR SOLVE SCENE WORKDIR [FORMFACTOR OPTIONS]
# (the options replace --subdiv 4 --link-tol 3e-2; with --clusters on the
# file also holds clusters: version 5)
set -u
ff=$1 solve=$2 scene=$3 dir=$4
options=${5:---subdiv 4 --link-tol 3e-2}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mkdir -p "$dir" && cd "$dir" || exit 1
rm -f ./*.ff ./*.rad
args="$scene --method hierarchical $options -q"
# shellcheck disable=SC2086 # args is a list of words
OMP_NUM_THREADS=1 "$ff" $args -o t1.ff || exit 1
# shellcheck disable=SC2086
OMP_NUM_THREADS=2 "$ff" $args -o t2.ff || exit 1
failed=0
cmp t1.ff t2.ff || { echo "FAIL: 1 and 2 threads differ"; failed=1; }
if command -v mpirun >/dev/null; then
  # shellcheck disable=SC2086
  OMP_NUM_THREADS=1 mpirun -n 2 --oversubscribe "$ff" $args -o r2.ff || exit 1
  cmp t1.ff r2.ff || { echo "FAIL: 1 and 2 ranks differ"; failed=1; }
  # shellcheck disable=SC2086
  OMP_NUM_THREADS=1 mpirun -n 3 --oversubscribe "$ff" $args -o r3.ff || exit 1
  cmp t1.ff r3.ff || { echo "FAIL: 1 and 3 ranks differ"; failed=1; }
  # shellcheck disable=SC2086
  RAD_MPI_PIECE=777 OMP_NUM_THREADS=1 mpirun -x RAD_MPI_PIECE -n 2 --oversubscribe "$ff" $args -o p2.ff || exit 1
  cmp t1.ff p2.ff || { echo "FAIL: 1 and 2 ranks in pieces differ"; failed=1; }
  # the same through messages, as between nodes (here the ranks share one
  # node and exchange the rounds through shared memory)
  # shellcheck disable=SC2086
  # and large rounds in pieces (1000 pairs here, 4 M in a run)
  # shellcheck disable=SC2086
  RAD_MPI_MESSAGES=1 RAD_MPI_PIECE=1000 OMP_NUM_THREADS=1 mpirun -x RAD_MPI_MESSAGES -x RAD_MPI_PIECE -n 3 \
    --oversubscribe "$ff" $args -o m3.ff || exit 1
  cmp t1.ff m3.ff || { echo "FAIL: 1 and 3 ranks through messages differ"; failed=1; }
  # shellcheck disable=SC2086
  OMP_NUM_THREADS=1 mpirun -n 2 --oversubscribe "$ff" $args --radiosity m2.rad || exit 1
fi
OMP_NUM_THREADS=1 "$solve" t1.ff -q -o t1.rad || exit 1
OMP_NUM_THREADS=2 "$solve" t2.ff -q -o t2.rad || exit 1
cmp t1.rad t2.rad || { echo "FAIL: solve on 1 and 2 threads differs"; failed=1; }
# scene to radiosity in one process: the links solved in memory
# shellcheck disable=SC2086
OMP_NUM_THREADS=2 "$ff" $args --radiosity m.rad || exit 1
cmp t1.rad m.rad || { echo "FAIL: formfactor --radiosity differs from formfactor, then solve"; failed=1; }
if [ -f m2.rad ]; then
  cmp t1.rad m2.rad || { echo "FAIL: formfactor --radiosity on 2 ranks differs"; failed=1; }
fi
[ "$failed" -eq 0 ] && echo "links and radiosity: the same bytes for 1 and 2 threads and ranks, and in memory"
exit "$failed"
