#!/bin/sh
# Hierarchical links with the element pairs on the GPU (formfactor
# --method hierarchical --backend cuda: ff_backend_cuda's compute_pairs)
# against the CPU backend's, on one scene:
#   exact:    --link-tol 0, every pair down to the leaves, so both make the
#             same links and the couplings differ only by rounding (atan2,
#             sqrt, borderline ray hits): solutions within 1e-9 of max B;
#   uniform:  --uniform-leaves --link-tol 1e-2, where the oracle decides
#             (a coupling a few ulps apart may tip a decision): link counts
#             within 1 %, solutions within 1e-3 of max B;
#   clusters: --clusters on, the cluster links traced on the CPU beside
#             the GPU's pairs: the same bars.
# The stats must say "backend": "cuda". The passes' flat solves on the
# GPU (below), the last one's too. And --backend auto: the CPU where
# the leaves may reach fewer than 4096 a thread (--subdiv 2 on 2 threads:
# 46 faces x 16), the GPU from there (--subdiv 6: 46 x 4096), as its log
# and stats say. Skipped (77) without a GPU.
#   hier_backends.sh FORMFACTOR SOLVE RADIOSITY_CLOSE SCENE WORKDIR
set -u
ff=$1 solve=$2 close=$3 scene=$4 dir=$5
nvidia-smi -L >/dev/null 2>&1 || { echo "no GPU: skipped"; exit 77; }
mkdir -p "$dir" && cd "$dir" || exit 1
fail=0
links() { grep -o '"links": [0-9]*' "$1" | head -1 | sed 's/.*: //'; }
check() { # name tolerance formfactor-options...
  name=$1 tol=$2
  shift 2
  for b in cpu cuda; do
    "$ff" "$scene" --method hierarchical --backend "$b" "$@" -q -o "$name.$b.ff" --stats "$name.$b.json" ||
      { echo "FAIL: $name: formfactor --backend $b"; fail=1; return; }
    "$solve" "$name.$b.ff" -q --tol 1e-12 -o "$name.$b.rad" || { echo "FAIL: $name: solve of the $b links"; fail=1; return; }
  done
  grep -q '"backend": "cuda"' "$name.cuda.json" || { echo "FAIL: $name: the stats do not say cuda"; fail=1; }
  lc=$(links "$name.cpu.json") lg=$(links "$name.cuda.json")
  echo "$name: links cpu $lc, cuda $lg"
  awk -v a="$lc" -v b="$lg" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(a > 0 && d <= 0.01 * a) }' ||
    { echo "FAIL: $name: link counts differ by more than 1 %"; fail=1; }
  "$close" "$name.cpu.rad" "$name.cuda.rad" "$tol" || { echo "FAIL: $name: the solutions differ"; fail=1; }
}
check exact 1e-9 --subdiv 2 --link-tol 0
check uniform 1e-3 --subdiv 3 --uniform-leaves --link-tol 1e-2
check clusters 1e-3 --subdiv 3 --clusters on --link-tol 3e-2
"$ff" "$scene" --method hierarchical --subdiv 2 --threads 2 --link-tol 0.1 --passes 1 -o auto_small.ff \
  --stats auto_small.json 2> auto_small.log || { echo "FAIL: auto, small"; fail=1; }
grep -q '"backend": "cpu"' auto_small.json && grep -q -- '--backend auto: the CPU' auto_small.log ||
  { echo "FAIL: auto did not take the CPU below its bound"; cat auto_small.log; fail=1; }
"$ff" "$scene" --method hierarchical --subdiv 6 --threads 2 --link-tol 0.1 --passes 1 -q -o auto_large.ff \
  --stats auto_large.json || { echo "FAIL: auto, large"; fail=1; }
grep -q '"backend": "cuda"' auto_large.json || { echo "FAIL: auto did not take the GPU above its bound"; fail=1; }
# The passes' flat solves on the GPU (solve_links_flat_gpu: the flat operator's
# Jacobi there, from 4 M links by default; RAD_FF_GPU_SOLVE_LINKS=1 here):
# the stats count them, and the links and solution agree with the CPU's.
export RAD_FF_GPU_SOLVE_LINKS=1
check gpu_solves 1e-3 --subdiv 3 --uniform-leaves --link-tol 1e-2 --passes 3
unset RAD_FF_GPU_SOLVE_LINKS
grep -Eq '"gpu_solves": [1-9]' gpu_solves.cuda.json || { echo "FAIL: no oracle solve was on the GPU"; fail=1; }
grep -q '"gpu_solves": 0' gpu_solves.cpu.json || { echo "FAIL: the CPU backend's solves went to the GPU"; fail=1; }
# The last pass's flat solve where solve runs it on the file (--backend
# cuda: Jacobi on the GPU in both), so that --radiosity is still the bytes
# of formfactor, then solve, and says it took the GPU's solve (--passes 2:
# the last pass's leaves are new, so it solves from B = E; a warm solve is
# not handed over).
"$ff" "$scene" --method hierarchical --backend cuda --subdiv 3 --link-tol 1e-2 --passes 2 -q -o last.ff ||
  { echo "FAIL: last pass: formfactor"; fail=1; }
"$solve" last.ff --backend cuda -o last.file.rad 2> last.solve.log || { echo "FAIL: last pass: solve"; fail=1; }
"$ff" "$scene" --method hierarchical --backend cuda --subdiv 3 --link-tol 1e-2 --passes 2 --radiosity last.mem.rad \
  2> last.mem.log || { echo "FAIL: last pass: --radiosity"; fail=1; }
cmp last.file.rad last.mem.rad || { echo "FAIL: --radiosity differs from the two stages on the GPU"; fail=1; }
grep -q 'taken as it is (.*Jacobi on the GPU)' last.mem.log ||
  { echo "FAIL: --radiosity did not take the last pass's GPU solve"; cat last.mem.log; fail=1; }
grep -q 'on links, .*backend cuda$' last.solve.log ||
  { echo "FAIL: solve's flat sweeps did not run on the GPU"; cat last.solve.log; fail=1; }
[ "$fail" -eq 0 ] && echo "hierarchical links: the CUDA backend agrees with the CPU's; auto takes each where it should"
exit "$fail"
