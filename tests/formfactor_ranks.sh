#!/bin/sh
# Byte-identical output for 1, 2 and 3 MPI ranks (and for a repeated run),
# in the native and the paper format.
#   formfactor_ranks.sh FORMFACTOR SCENE WORKDIR
set -eu
ff=$1 scene=$2 dir=$3
mkdir -p "$dir" && cd "$dir"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1
args="$scene --subdiv 1 --samples 64 --shadow-rays 16 -q"
for p in 1 2 3; do
  mpirun --oversubscribe -n $p "$ff" $args -o ranks$p --stats ranks$p.json
  mpirun --oversubscribe -n $p "$ff" $args -o paper$p --format paper
done
"$ff" $args -o ranks1again            # a plain (singleton) run, again
for f in ranks2 ranks3 ranks1again; do
  cmp ranks1 $f || { echo "FAIL: $f differs from ranks1"; exit 1; }
done
cmp paper1 paper2 && cmp paper1 paper3 || { echo "FAIL: paper-format files differ"; exit 1; }
# The paper format is int32 N then N*N float64, nothing else.
n=$(od -An -t d4 -N4 paper1 | tr -d ' ')
size=$(wc -c < paper1)
[ "$size" -eq $((4 + 8 * n * n)) ] || { echo "FAIL: paper file is $size bytes for N=$n"; exit 1; }
grep -q '"ranks": 3' ranks3.json || { echo "FAIL: stats do not record 3 ranks"; exit 1; }
echo "identical bytes for 1, 2, 3 ranks (N=$n)"
