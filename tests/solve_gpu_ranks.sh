#!/bin/sh
# mpirun -n K solve --backend cuda (issue 28): each rank keeps its block of
# rows on its GPU (rank mod the GPUs: here several ranks may share one) and
# the ranks exchange B, CG's direction and the reductions' partial sums
# each iteration. The radiosity is the same bytes as one process on one
# GPU: for an f32 file (the GPU's matrix is exact) and an f64 one
# (refinement rounds against the double matrix), with CG and with Jacobi,
# on 2 and 3 ranks. Skipped (77) without a GPU.
#   solve_gpu_ranks.sh FORMFACTOR SOLVE SCENE WORKDIR
set -eu
ff=$1 solve=$2 scene=$3 dir=$4
nvidia-smi -L >/dev/null 2>&1 || { echo "no GPU: skipped"; exit 77; }
mkdir -p "$dir" && cd "$dir" && rm -f ./*.ff ./*.rad ./*.json ./*.log
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
fail() { echo "FAIL: $*"; exit 1; }
"$ff" "$scene" --subdiv 3 --element f32 -q -o f32.ff
"$ff" "$scene" --subdiv 3 -q -o f64.ff
for f in f32 f64; do
  for m in cg jacobi; do
    "$solve" $f.ff --backend cuda --method $m -q -o $f.$m.rad --stats $f.$m.json || fail "$f, $m: one GPU"
    grep -q '"backend": "cuda"' $f.$m.json || fail "$f, $m: the stats do not say cuda"
    for p in 2 3; do
      mpirun -n $p "$solve" $f.ff --backend cuda --method $m -q -o $f.$m.$p.rad --stats $f.$m.$p.json \
        > $f.$m.$p.log 2>&1 || fail "$f, $m, $p ranks: exit $?: $(cat $f.$m.$p.log)"
      grep -q '"backend": "cuda"' $f.$m.$p.json && grep -q "\"ranks\": $p" $f.$m.$p.json ||
        fail "$f, $m, $p ranks: the stats do not say cuda on $p ranks"
      cmp $f.$m.rad $f.$m.$p.rad || fail "$f, $m: $p ranks on the GPU differ from one GPU"
      echo "same bytes: $f, $m, $p ranks on the GPU and one GPU"
    done
  done
done
