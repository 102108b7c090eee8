#!/usr/bin/env bash
# The test command of the README (and of CI), in three passes:
#  1. configure, build (warnings are errors) and run the whole CTest suite;
#     GPU tests skip themselves without a GPU;
#  2. the sanitized pass: the same sources built with ASan + UBSan
#     (-DRAD_SANITIZE=ON -DRAD_WERROR=ON) in BUILD_DIR-asan, running the
#     CPU suite but for the slow statistical tests (ctest -LE "gpu|slow");
#     any sanitizer report fails a test;
#  3. a fuzz smoke run: the libFuzzer targets (clang, BUILD_DIR-fuzz) for
#     RAD_FUZZ_SECONDS (default 20) each, skipped when clang is missing.
# RAD_TEST_PASSES picks passes (default "normal sanitize fuzz"); arguments
# go to ctest in passes 1 and 2. docs/reliability.md explains the settings.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD_DIR:-build}
passes=${RAD_TEST_PASSES:-normal sanitize fuzz}
jobs=$(nproc)
# mpirun refuses root unless told (CI and the GPU machine run as root).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# ctest -j runs several OpenMP programs at once on few cores; spinning
# OpenMP threads then wait for each other's time slices (test_solve: 3 s
# alone, 5 minutes spinning). Sleeping waits keep the suite fast.
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}

if [[ " $passes " == *" normal "* ]]; then
  cmake -S . -B "$build" -DRAD_WERROR=ON >/dev/null
  cmake --build "$build" -j"$jobs"
  ctest --test-dir "$build" --output-on-failure -j"$jobs" "$@"
fi

if [[ " $passes " == *" sanitize "* ]]; then
  asan=${ASAN_BUILD_DIR:-$build-asan}
  cmake -S . -B "$asan" -DRAD_SANITIZE=ON -DRAD_WERROR=ON -DRAD_WITH_CUDA=OFF >/dev/null
  cmake --build "$asan" -j"$jobs"
  # halt_on_error: a UBSan report fails the test instead of scrolling by.
  # Leaks are checked; Open MPI's own are suppressed (tests/lsan.supp), which
  # needs the slow unwinder to see through its libraries.
  ASAN_OPTIONS=fast_unwind_on_malloc=0:detect_stack_use_after_return=1 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0 \
    ctest --test-dir "$asan" --output-on-failure -j"$jobs" -LE "gpu|slow" "$@"
fi

if [[ " $passes " == *" fuzz "* ]]; then
  if command -v clang >/dev/null && [ -x "$build/formfactor" ]; then
    fuzz=${FUZZ_BUILD_DIR:-$build-fuzz}
    CC=clang CXX=clang++ cmake -S . -B "$fuzz" -DRAD_FUZZ=ON -DRAD_WERROR=ON -DRAD_WITH_CUDA=OFF >/dev/null
    cmake --build "$fuzz" -j"$jobs" --target fuzz_scene fuzz_ffile fuzz_rfile
    # Fresh corpora each time (seeds from this build), one target at a time.
    rm -rf "$fuzz/fuzz-work"
    # Repeatable: a fixed number of executions from a fixed seed (at most
    # RAD_FUZZ_SECONDS each); long runs without it: docs/reliability.md.
    # Absolute paths: make_corpus.sh changes directory.
    RAD_FUZZ_RUNS=${RAD_FUZZ_RUNS:-100000} tests/fuzz/run_fuzz.sh "$(cd "$fuzz" && pwd)" "${RAD_FUZZ_SECONDS:-60}" \
      "$(cd "$build" && pwd)"
  else
    echo "test.sh: fuzz smoke run skipped (needs clang and the normal build)"
  fi
fi
