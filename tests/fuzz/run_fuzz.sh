#!/bin/sh
# Runs the libFuzzer targets one after another (one process at a time).
#   tests/fuzz/run_fuzz.sh FUZZ_BUILD_DIR SECONDS_PER_TARGET BIN_DIR [WORK_DIR] [TARGET...]
# FUZZ_BUILD_DIR: a build with -DRAD_FUZZ=ON (CC=clang); BIN_DIR: a normal
# build with formfactor and solve, for the seed corpora (make_corpus.sh).
# WORK_DIR (default: FUZZ_BUILD_DIR/fuzz-work) keeps the growing corpora,
# crash artifacts and logs between runs. Prints, per target, executions and
# seconds from libFuzzer's final stats, and exits 1 if any target found a
# crash (the input is in WORK_DIR/artifacts: copy it to
# tests/fuzz/regressions/TARGET/ once fixed). RAD_FUZZ_RUNS=N makes a run
# repeatable: N executions from seed 1 (CI uses it, so that a new finding
# shows up in a fuzzing session, not as a random CI failure).
set -u
build=$1 seconds=$2 bin=$3
work=${4:-$build/fuzz-work}
[ $# -ge 4 ] && shift 4 || shift $#
targets=${*:-scene ffile rfile}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$work/artifacts" "$work/logs"
[ -d "$work/seeds" ] || "$here/make_corpus.sh" "$work/seeds" "$bin" >/dev/null 2>&1 || exit 1
status=0
for t in $targets; do
  exe=$build/tests/fuzz/fuzz_$t
  [ -x "$exe" ] || { echo "run_fuzz: $exe missing (configure with CC=clang -DRAD_FUZZ=ON)"; exit 1; }
  mkdir -p "$work/corpus/$t"
  dict=; [ "$t" = scene ] && dict=-dict=$here/obj.dict
  log=$work/logs/$t-$(date +%Y%m%d-%H%M%S).log
  # -rss_limit_mb / -malloc_limit_mb: an input that makes a reader allocate
  # more than 2 GiB is a finding too (sizes must be checked against the file).
  "$exe" "$work/corpus/$t" "$work/seeds/$t" "$here/regressions/$t" $dict \
      -max_total_time="$seconds" ${RAD_FUZZ_RUNS:+-runs=$RAD_FUZZ_RUNS -seed=1} -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048 -max_len=8192 \
      -print_final_stats=1 -artifact_prefix="$work/artifacts/$t-" > "$log" 2>&1
  rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  secs=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log")
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1)
  if [ $rc -ne 0 ]; then
    status=1
    echo "fuzz_$t: FOUND A PROBLEM after ${execs:-?} executions (log: $log)"
    grep -m3 -E 'ERROR|runtime error|violates|SUMMARY' "$log"
  else
    echo "fuzz_$t: ${execs:-?} executions in ${secs:-?} s, $cov, corpus $(ls "$work/corpus/$t" | wc -l) inputs, no crash"
  fi
done
exit $status
