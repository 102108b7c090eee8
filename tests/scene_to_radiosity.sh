#!/bin/sh
# formfactor --radiosity (issue 28, item 3): scene to radiosity without
# writing and reading the matrix. Checks:
#   - alone, its radiosity is the same bytes as formfactor, then solve
#     (the default box; streamed rows with --reciprocity off; f32);
#   - under mpirun -n 2 and 3 (ranks' blocks of rows, one left empty at 3
#     on this small mesh) it agrees with one rank within what the
#     residuals allow (radiosity_agree: on the CPU the ranks' partial sums
#     round differently; on the GPU the bytes are the same, below);
#   - the flags it cannot go with are refused (exit 2) and no matrix file
#     is written by it; a bad output path fails before any work;
#   - with a GPU (else that part is skipped): --backend cuda on 1, 2 and 3
#     ranks gives the bytes of formfactor --backend cuda, then one GPU's
#     solve --backend cuda.
#   scene_to_radiosity.sh FORMFACTOR SOLVE RADIOSITY_AGREE SCENE WORKDIR
set -eu
ff=$1 solve=$2 agree=$3 scene=$4 dir=$5
mkdir -p "$dir" && cd "$dir" && rm -rf ./*
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
fail() { echo "FAIL: $*"; exit 1; }

# Alone: the same bytes as the two stages.
for flags in "" "--reciprocity off" "--element f32 --reciprocity off"; do
  tag=$(echo "x$flags" | tr -c 'a-z0-9\n' _)
  "$ff" --subdiv 2 $flags -q -o $tag.ff
  "$solve" $tag.ff -q -o $tag.file.rad
  "$ff" --subdiv 2 $flags -q --radiosity $tag.mem.rad > $tag.log 2>&1 || fail "$flags: exit $?: $(cat $tag.log)"
  cmp $tag.file.rad $tag.mem.rad || fail "'$flags': --radiosity differs from formfactor, then solve"
  echo "same bytes: formfactor --radiosity and formfactor, then solve ($flags)"
done
ls | grep -qx formfactors && fail "--radiosity wrote a matrix file"

# Ranks: every rank solves the rows it computed.
"$ff" "$scene" --subdiv 2 -q -o sphere.ff
"$ff" "$scene" --subdiv 2 -q --radiosity sphere.1.rad
for p in 2 3; do
  mpirun -n $p "$ff" "$scene" --subdiv 2 --radiosity sphere.$p.rad > sphere.$p.log 2>&1 ||
    fail "$p ranks: exit $?: $(cat sphere.$p.log)"
  grep -q "rows split over $p ranks" sphere.$p.log || fail "$p ranks: the solve did not run on $p ranks"
  "$agree" sphere.ff sphere.1.rad sphere.$p.rad || fail "$p ranks disagree with one"
done
ls | grep -qx formfactors && fail "--radiosity wrote a matrix file"

# Refusals: usage errors, before any work.
for bad in "-o refused.ff" "--errors refused_errors.ff" "--format dense" "--method hierarchical -o refused.ff"; do
  set +e
  "$ff" --radiosity r.rad $bad > bad.log 2>&1
  rc=$?
  set -e
  [ $rc -eq 2 ] || fail "--radiosity with $bad: exit $rc, expected 2"
  grep -q "radiosity" bad.log || fail "--radiosity with $bad: no reason given: $(cat bad.log)"
  [ ! -e r.rad ] && [ ! -e refused.ff ] && [ ! -e refused_errors.ff ] || fail "--radiosity with $bad left a file"
done
set +e
"$ff" --radiosity no/such/dir/r.rad > bad.log 2>&1
rc=$?
set -e
[ $rc -ne 0 ] || fail "--radiosity into a missing folder succeeded"
echo "refusals: ok"

# The GPU: the same bytes for any number of ranks.
if nvidia-smi -L >/dev/null 2>&1; then
  "$ff" "$scene" --subdiv 3 --element f32 --backend cuda -q -o gpu.ff
  "$solve" gpu.ff --backend cuda -q -o gpu.file.rad
  for p in 1 2 3; do
    mpirun -n $p "$ff" "$scene" --subdiv 3 --element f32 --backend cuda --radiosity gpu.$p.rad > gpu.$p.log 2>&1 ||
      fail "GPU, $p ranks: exit $?: $(cat gpu.$p.log)"
    grep -q "backend cuda" gpu.$p.log || fail "GPU, $p ranks: the solve did not run on the GPU"
    cmp gpu.file.rad gpu.$p.rad || fail "GPU, $p ranks: differs from formfactor, then solve on one GPU"
    echo "same bytes: formfactor --backend cuda --radiosity on $p ranks and the two stages on one GPU"
  done
else
  echo "no GPU: the GPU part skipped"
fi
