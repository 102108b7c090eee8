#!/usr/bin/env bash
# Issue 14 on the device machine, in one go: build (Release), the GPU
# tests, the disk's own bandwidth, fixed costs at N = 2944 and the
# pipeline at larger N. Logs, stats JSON and a summary (summary.txt) go to
# $OUT.
#   . .devdeps/setup.sh && scripts/bench-pipeline-gpu.sh
# SUBDIVS: the sizes of the large runs (default "5": N = 47104; 6 is
# N = 188416, about 2 min); TESTS=0 skips the tests; SOLVE_BACKENDS the
# solve backends timed (default "cpu"); SOLVE_RANKS, FF_RANKS rank counts
# for mpirun runs of solve and formfactor (several ranks on the one GPU);
# SOLVE_ARGS are added to every solve.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-bench-out}; mkdir -p "$out"
build=${BUILD_DIR:-/tmp/build-gpu}
work=${WORK:-$PWD/bench-work}; mkdir -p "$work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
exec > >(tee -a "$out/summary.txt") 2>&1
date -u; nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader; nproc
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} > "$out/cmake.log" 2>&1 ||
  { tail -30 "$out/cmake.log"; exit 1; }
cmake --build "$build" -j"$(nproc)" > "$out/build.log" 2>&1 || { grep -E "error|Error" "$out/build.log" | head -30; }
[ -x "$build/formfactor" ] && [ -x "$build/solve" ] || { echo "build failed"; exit 1; }
if [ "${TESTS:-1}" = 1 ]; then
  ctest --test-dir "$build" -L gpu --output-on-failure > "$out/ctest_gpu.log" 2>&1
  echo "ctest -L gpu rc=$?"; grep -E "Test +#|tests passed" "$out/ctest_gpu.log"
  ctest --test-dir "$build" -R "${TEST_REGEX:-ffile|formfactor_plan|formfactor_ranks|formfactor_sparse|solve}" -LE slow \
    -j8 --output-on-failure > "$out/ctest_more.log" 2>&1
  echo "ctest (more) rc=$?"; grep -E "tests passed|\(Failed\)|Failed|\*\*\*" "$out/ctest_more.log" | head -20
fi
dd if=/dev/zero of="$work/dd" bs=64M count=64 conv=fdatasync 2>&1 | tail -1; rm -f "$work/dd"
t() { # label, command...: wall seconds (date) and max RSS (time)
  local label=$1; shift
  local s e; s=$(date +%s.%N)
  /usr/bin/time -f "%M KiB max RSS" "$@" > "$out/$label.log" 2>&1
  local rc=$?; e=$(date +%s.%N)
  printf '%-28s %7.3f s wall  rc=%d  %s\n' "$label" "$(awk -v s="$s" -v e="$e" 'BEGIN { print e - s }')" $rc "$(tail -1 "$out/$label.log")"
}
phases() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); t = d.get("time_seconds", {})
print("    phases: " + ", ".join("%s %.3f" % (k, v) for k, v in t.items()))
PY
}
phases_solve() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
keys = ("backend", "load_seconds", "upload_seconds", "total_seconds")
print("    " + ", ".join("%s %s" % (k, d[k]) for k in keys if k in d) +
      "; channels: " + ", ".join("%.3f s" % c.get("seconds", 0) for c in d.get("channels", [])))
PY
}
ff="$build/formfactor"; solve="$build/solve"; scene=scenes/cornell_sphere.obj
echo "--- fixed costs, N = 2944"
nvidia-smi --query-gpu=persistence_mode --format=csv,noheader | sed 's/^/persistence mode: /'
if nvcc -O2 -o "$work/cuda_start_cost" tools/cuda_start_cost.cu > "$out/cuda_start_cost.build.log" 2>&1; then
  for r in 1 2; do
    t cuda_start_return "$work/cuda_start_cost"; sed 's/^/    /' "$out/cuda_start_return.log" | head -1
    t cuda_start__exit "$work/cuda_start_cost" _exit; sed 's/^/    /' "$out/cuda_start__exit.log" | head -1
  done
fi
t ff_version "$ff" --version
t ff_version_cpu "$ff" --version --backend cpu
t n20_ff "$ff" --backend cuda -q -o "$work/ff0" --stats "$out/n20_ff.json"; phases "$out/n20_ff.json"
t n2944_ff_streamed "$ff" $scene --subdiv 3 --backend cuda --reciprocity off -q -o "$work/ff3s" \
  --stats "$out/n2944_ff_streamed.json"; phases "$out/n2944_ff_streamed.json"
for r in 1 2 3; do
  t "n2944_ff_$r" "$ff" $scene --subdiv 3 --backend cuda -q -o "$work/ff3" --stats "$out/n2944_ff_$r.json"
  phases "$out/n2944_ff_$r.json"
  t "n2944_solve_$r" "$solve" "$work/ff3" -q -o "$work/rad3" ${SOLVE_ARGS:-} --stats "$out/n2944_solve_$r.json"
  phases_solve "$out/n2944_solve_$r.json"
done
for s in ${SUBDIVS:-5}; do
  echo "--- cornell_sphere --subdiv $s --element f32"
  for mode in gpu host; do
    fin=""; [ $mode = host ] && fin="env RAD_FF_FINISH=host"
    rm -f "$work/ff$s"
    t "s${s}_ff_$mode" $fin "$ff" $scene --subdiv $s --element f32 --backend cuda -o "$work/ff$s" \
      --stats "$out/s${s}_ff_$mode.json"
    phases "$out/s${s}_ff_$mode.json"
    echo "    file $(stat -c %s "$work/ff$s") bytes"
    t "s${s}_sync_$mode" sync   # formfactor leaves its file in the page cache: this makes it durable
    [ $mode = gpu ] && cp "$out/s${s}_ff_gpu.log" "$out/s${s}_ff_gpu.keep"
    [ "${HOST_TOO:-1}" = 1 ] || break
  done
  sync
  for b in ${SOLVE_BACKENDS:-cpu}; do
    t "s${s}_solve_$b" "$solve" "$work/ff$s" -o "$work/rad$s.$b" --backend $b ${SOLVE_ARGS:-} --stats "$out/s${s}_solve_$b.json"
    phases_solve "$out/s${s}_solve_$b.json"
    grep -E "load|CG|iterations|backend|round" "$out/s${s}_solve_$b.log" | head -12 | sed 's/^/    /'
  done
  for k in ${SOLVE_RANKS:-}; do
    t "s${s}_solve_mpi$k" mpirun --oversubscribe -n $k "$solve" "$work/ff$s" -o "$work/rad$s.mpi$k" --backend cpu \
      ${SOLVE_ARGS:-} --stats "$out/s${s}_solve_mpi$k.json"
    grep -E "load|CG|iterations|rank" "$out/s${s}_solve_mpi$k.log" | head -6 | sed 's/^/    /'
  done
  for k in ${FF_RANKS:-}; do   # several ranks sharing the one GPU
    t "s${s}_ff_mpi$k" mpirun --oversubscribe -n $k "$ff" $scene --subdiv $s --element f32 --backend cuda -q \
      -o "$work/ff$s.mpi$k" --stats "$out/s${s}_ff_mpi$k.json"
    phases "$out/s${s}_ff_mpi$k.json"
    cmp -s "$work/ff$s" "$work/ff$s.mpi$k" && echo "    same bytes as 1 rank" || echo "    DIFFERENT bytes from 1 rank"
    rm -f "$work/ff$s.mpi$k"
  done
  rm -f "$work/ff$s" "$work/rad$s"*
done
rm -rf "$work"
tar czf "$out/all.tgz" -C "$out" --exclude all.tgz . 2>/dev/null  # more than the files limit comes back in one
