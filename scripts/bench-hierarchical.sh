#!/usr/bin/env bash
# Hierarchical radiosity (issue 26) timed on this machine, one call:
#   . .devdeps/setup.sh && scripts/bench-hierarchical.sh      (the GPU machine)
#   scripts/bench-hierarchical.sh                             (anywhere)
# Builds formfactor, solve (Release, BUILD_DIR, default /tmp/build-hier),
# then times scene -> links file -> radiosity (formfactor --method
# hierarchical, then solve) at each tolerance and finest level below, on
# THREADS (default "2 all") threads (the growth on GROWTH_THREADS, default 16), with peak memory; and the growth of time
# with the leaves on cornell_sphere at a fixed tolerance (--uniform-leaves
# off: the leaves the tolerance makes); THREADS=none skips that table. Then
# uniform leaves (UNIFORM_THREADS, UNIFORM_BOX_TOLS, UNIFORM_SPHERE_TOLS).
# BACKEND (default cpu) is formfactor's and solve's --backend: cuda or
# auto build with CUDA (Hopper) and put the element pairs and the link
# sweeps on the GPU. Writes hier_bench.md and the stats
# JSON under $OUT (default ./hier-bench-out).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-hier-bench-out}; mkdir -p "$out"
build=${BUILD_DIR:-/tmp/build-hier}
cores=$(nproc)
backend=${BACKEND:-cpu}
cuda=OFF
[ "$backend" = cpu ] || cuda="ON -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90}"
# shellcheck disable=SC2086 # cuda holds two words
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DRAD_WITH_RENDER=OFF -DRAD_WITH_CUDA=$cuda > "$out/cmake.log" 2>&1 &&
  cmake --build "$build" -j"$cores" --target formfactor solve > "$out/build.log" 2>&1 || { tail -20 "$out/build.log"; exit 1; }
ff="$build/formfactor" solve="$build/solve"
threads_list=${THREADS:-"2 all"}
j() { grep -o "\"$2\": [0-9.e+-]*" "$1" | head -1 | sed 's/.*: //'; }
# run LABEL THREADS FF-ARGS...: one row of the table
run() {
  local label=$1 t=$2; shift 2
  [ "$t" = all ] && t=$cores
  local tag; tag=$(echo "$label-$t" | tr ' /=' '___')
  local t0 t1 t2
  t0=$(date +%s.%N)
  if [ -x /usr/bin/time ]; then
    /usr/bin/time -f "%M" -o "$out/$tag.mem" env OMP_NUM_THREADS="$t" "$ff" "$@" --backend "$backend" -q -o /tmp/hier.ff --stats "$out/$tag.json" || { echo "| $label | $t | failed |"; return; }
  else
    echo 0 > "$out/$tag.mem"
    OMP_NUM_THREADS="$t" "$ff" "$@" --backend "$backend" -q -o /tmp/hier.ff --stats "$out/$tag.json" || { echo "| $label | $t | failed |"; return; }
  fi
  t1=$(date +%s.%N)
  OMP_NUM_THREADS="$t" "$solve" /tmp/hier.ff --backend "$backend" -q -o /tmp/hier.rad --stats "$out/$tag.solve.json" || { echo "| $label | $t | solve failed |"; return; }
  t2=$(date +%s.%N)
  printf "| %s | %s | %s | %s | %s | %.1f | %s | %.2f | %.2f | %.2f | %.0f |\n" "$label" "$t" "$(j "$out/$tag.json" leaves)" \
    "$(j "$out/$tag.json" elements)" "$(j "$out/$tag.json" links)" "$(j "$out/$tag.json" links_per_element)" \
    "$(j "$out/$tag.json" error_bound)" "$(awk -v a="$t0" -v b="$t1" 'BEGIN{print b-a}')" \
    "$(awk -v a="$t1" -v b="$t2" 'BEGIN{print b-a}')" "$(awk -v a="$t0" -v b="$t2" 'BEGIN{print b-a}')" \
    "$(( $(cat "$out/$tag.mem") / 1024 ))"
}
{
echo "# Hierarchical radiosity: time ($(lscpu | grep -m1 'Model name' | sed 's/.*: *//'), $cores cores, $(date -u +%F))"
echo
echo "formfactor --method hierarchical then solve, both --backend $backend; wall seconds; peak MiB of formfactor."
echo
echo "| run | threads | leaves | elements | links | links/element | error bound | formfactor s | solve s | total s | MiB |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for t in $threads_list; do
  [ "$t" = none ] && continue
  for tol in 3e-2 1e-2 3e-3; do
    run "cornell_box L5 tol $tol" "$t" --method hierarchical --subdiv 5 --link-tol "$tol"
  done
  for tol in 3e-2 1e-2 3e-3; do
    run "cornell_sphere L6 tol $tol" "$t" scenes/cornell_sphere.obj --method hierarchical --subdiv 6 --link-tol "$tol"
  done
done
echo
echo "## Uniform leaves (--uniform-leaves; --oracle auto = gather, solve's shaped solve)"
echo
echo "| run | threads | leaves | elements | links | links/element | error bound | formfactor s | solve s | total s | MiB |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for t in ${UNIFORM_THREADS:-16}; do
  for tol in ${UNIFORM_BOX_TOLS:-3e-2 1e-2}; do
    run "cornell_box uniform L5 tol $tol" "$t" --method hierarchical --subdiv 5 --uniform-leaves --link-tol "$tol"
  done
  for tol in ${UNIFORM_SPHERE_TOLS:-1e-2 3e-3 1e-3}; do
    run "cornell_sphere uniform L6 tol $tol" "$t" scenes/cornell_sphere.obj --method hierarchical --subdiv 6 --uniform-leaves --link-tol "$tol"
  done
done
echo
echo "## Growth: cornell_sphere, --link-tol 1e-2, finest level L, uniform leaves"
echo
echo "| run | threads | leaves | elements | links | links/element | error bound | formfactor s | solve s | total s | MiB |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for level in ${LEVELS:-2 3 4 5 6 7}; do
  run "cornell_sphere uniform L$level tol 1e-2" "${GROWTH_THREADS:-16}" scenes/cornell_sphere.obj --method hierarchical --subdiv "$level" --link-tol 1e-2 --uniform-leaves
done
} 2>&1 | tee "$out/hier_bench.md"
