#!/usr/bin/env bash
# GPU benchmark, end to end in one go (build, check, time), as run on the
# device machine:   . .devdeps/setup.sh && scripts/bench-gpu.sh
# Writes logs and stats JSON under $OUT (default ./bench-out), packed into
# bench.tgz at the end so that they travel back in one file.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-bench-out}; mkdir -p "$out"
build=${BUILD_DIR:-/tmp/build-gpu}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader > "$out/gpu.txt" 2>&1
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} > "$out/cmake.log" 2>&1 || { tail -30 "$out/cmake.log"; exit 1; }
cmake --build "$build" -j"$(nproc)" --target formfactor ${TEST_TARGETS:-test_cuda test_bvh test_formfactor test_ffile test_quadrature test_hard_cases} > "$out/build.log" 2>&1 || { grep -E "error|Error" "$out/build.log" | head -30; exit 1; }
ctest --test-dir "$build" -R "${TEST_REGEX:-formfactor_cuda|formfactor_gpu_ranks|bvh|formfactor_cpu|ffile|formfactor_quadrature|formfactor_hard_cases}" --output-on-failure -V > "$out/ctest.log" 2>&1
echo "ctest rc=$?"; grep -E "Passed|Failed|Skipped|differ|cuda |F = " "$out/ctest.log" | head -30
ff="$build/formfactor"; scene=scenes/cornell_sphere.obj
run() { # name, args...
  local name=$1; shift
  /usr/bin/time -f "%e s wall, %M KiB max RSS" "$ff" "$@" --stats "$out/$name.json" -o /tmp/ff_$name > "$out/$name.log" 2>&1
  echo "$name rc=$? $(tail -1 "$out/$name.log")"
  grep -E "time \(s" "$out/$name.log" | sed 's/^/    /'
}
run n424_gpu   $scene --subdiv 3 --subdiv-only box --backend cuda
run n2944_gpu  $scene --subdiv 3 --backend cuda
run n2944_gpu_norays $scene --subdiv 3 --backend cuda --shadow-rays 0
run n2944_cpu16 $scene --subdiv 3 --backend cpu
if [ "${ESTIMATORS:-1}" = 1 ]; then   # the Monte Carlo estimators beside the default (quadrature)
  for e in mc auto; do run n2944_gpu_$e $scene --subdiv 3 --backend cuda --estimator $e; done
  run n2944_cpu16_mc $scene --subdiv 3 --backend cpu --estimator mc
fi
cmp /tmp/ff_n2944_gpu /tmp/ff_n2944_cpu16 >/dev/null && echo "cpu/gpu bytes identical" || echo "cpu/gpu bytes differ (expected: sum order)"
[ "${MID:-1}" = 1 ] && run n11776_gpu $scene --subdiv 4 --backend cuda --element f32
[ "${BIG:-1}" = 1 ] && run n47104_gpu $scene --subdiv 5 --backend cuda --element f32
if [ "${RECIPROCITY:-1}" = 1 ]; then   # each pair once (default) against both entries computed (issue 7)
  run n2944_gpu_off $scene --subdiv 3 --backend cuda --reciprocity off
  cmp /tmp/ff_n2944_gpu /tmp/ff_n2944_gpu_off && echo "n2944 gpu: reciprocity on/off identical" || echo "n2944 gpu: reciprocity on/off DIFFER"
  run n2944_cpu16_off $scene --subdiv 3 --backend cpu --reciprocity off
  cmp /tmp/ff_n2944_cpu16 /tmp/ff_n2944_cpu16_off && echo "n2944 cpu: reciprocity on/off identical" || echo "n2944 cpu: reciprocity on/off DIFFER"
  if [ "${BIG:-1}" = 1 ]; then
    run n47104_gpu_off $scene --subdiv 5 --backend cuda --element f32 --reciprocity off
    cmp /tmp/ff_n47104_gpu /tmp/ff_n47104_gpu_off && echo "n47104 gpu: reciprocity on/off identical" || echo "n47104 gpu: reciprocity on/off DIFFER"
  fi
fi
if [ "${NOERRORS:-1}" = 1 ]; then   # what estimating the standard errors costs
  run n2944_gpu_noerr $scene --subdiv 3 --backend cuda --no-errors
  run n2944_gpu_off_noerr $scene --subdiv 3 --backend cuda --no-errors --reciprocity off
  cmp /tmp/ff_n2944_gpu /tmp/ff_n2944_gpu_noerr && echo "n2944 gpu: same bytes without errors" || echo "n2944 gpu: --no-errors DIFFERS"
  [ "${BIG:-1}" = 1 ] && run n47104_gpu_noerr $scene --subdiv 5 --backend cuda --element f32 --no-errors &&
    { cmp /tmp/ff_n47104_gpu /tmp/ff_n47104_gpu_noerr && echo "n47104 gpu: same bytes (reciprocity on, no errors)" || echo "n47104: DIFFER"; }
fi
if [ "${TARGET:-1}" = 1 ]; then   # standard errors and --target-error (issue 6)
  run n2944_gpu_errors $scene --subdiv 3 --backend cuda --errors /tmp/ff_n2944_gpu_errors.err
  for t in 3e-3 1e-3 3e-4; do
    run n2944_gpu_target$t $scene --subdiv 3 --backend cuda --samples 64 --target-error $t
    grep -o '"standard_error": {[^}]*}' "$out/n2944_gpu_target$t.json" | sed 's/^/    /'
  done
  run n2944_cpu16_target1e-3 $scene --subdiv 3 --backend cpu --samples 64 --target-error 1e-3
fi
if [ "${RANKS2:-0}" = 1 ]; then   # two GPUs of one host, one rank each
  mpirun -n 1 "$ff" $scene --subdiv 5 --backend cuda --element f32 -o /tmp/ff_g1 --stats "$out/n47104_gpu1rank.json" > "$out/n47104_gpu1rank.log" 2>&1
  mpirun -n 2 "$ff" $scene --subdiv 5 --backend cuda --element f32 -o /tmp/ff_g2 --stats "$out/n47104_gpu2rank.json" > "$out/n47104_gpu2rank.log" 2>&1
  cmp /tmp/ff_g1 /tmp/ff_g2 && echo "1 vs 2 GPUs: identical bytes" || echo "1 vs 2 GPUs: DIFFER"
  grep -E "time \(s" "$out"/n47104_gpu?rank.log
fi
if [ "${CULL:-0}" = 1 ]; then   # occlusion culling on and off (issue 7)
  for case in "closed_box --subdiv 4" "cornell_box --subdiv 3" "cornell_sphere --subdiv 3" "cluttered_room --subdiv 2" "cornell_sphere --subdiv 5 --element f32"; do
    set -- $case; name=cull_$1_$3
    for c in all none; do
      "$ff" scenes/$1.obj "${@:2}" --backend cuda --cull $c -q -o /tmp/ff_$c --stats "$out/${name}_$c.json"
      echo "$name cull=$c: $(grep -o '"form_factors": [0-9.]*, "visibility": [0-9.]*' "$out/${name}_$c.json" | head -1) $(grep -o '"rays": [0-9]*, "rays_occluded": [0-9]*, "pairs_open_scene": [0-9]*, "pairs_open_box": [0-9]*, "rays_saved": [0-9]*' "$out/${name}_$c.json" | head -1)"
    done
    cmp /tmp/ff_all /tmp/ff_none && echo "$name: identical with and without culling" || echo "$name: DIFFER"
  done
fi
rm -f /tmp/ff_*
tar czf /tmp/bench.tgz -C "$out" . && find "$out" -type f -delete && mv /tmp/bench.tgz "$out/"
