#!/bin/sh
# Long runs (issue 17): before any work formfactor says what the run will
# take (output size, memory per rank, time from a calibration); a run
# larger than --max-bytes is refused up front and leaves nothing; progress
# lines count the rows of every rank.
#   long_runs.sh FORMFACTOR SCENES_DIR WORKDIR
set -u
ff=$1 scenes=$2 dir=$3
rm -rf "$dir" && mkdir -p "$dir" && cd "$dir" || exit 1
export OMP_NUM_THREADS=2 OMP_WAIT_POLICY=passive
fail() { echo "FAIL: $*"; exit 1; }

# 1. The estimate line: exact size of a dense file (N = 2944, f64: 66.6 MiB),
# its bound for the sparse default, memory, a calibrated time.
"$ff" "$scenes/cornell_sphere.obj" --subdiv 3 --format dense -o a.ff 2> err.txt || fail "formfactor: $(cat err.txt)"
grep -q "estimate: 66.6 MiB to write, about .* of memory per rank, about .* of form factors on 1 rank(s) (calibrated on 64 of 2944 rows in .*)" err.txt ||
  fail "no estimate line: $(cat err.txt)"
"$ff" "$scenes/cornell_sphere.obj" --subdiv 3 -o s.ff 2> err.txt || fail "formfactor, sparse: $(cat err.txt)"
grep -q "estimate: at most 66.6 MiB to write, about" err.txt || fail "no bound for the sparse file: $(cat err.txt)"
# Small scenes are not calibrated, and -q says nothing.
"$ff" --subdiv 1 -o b.ff 2> err.txt || fail "the built-in box: $(cat err.txt)"
grep -q "estimate: .* to write, about .* of memory per rank, seconds of form factors" err.txt ||
  fail "small scene: $(cat err.txt)"
"$ff" -q --subdiv 1 -o b.ff 2> err.txt || fail "-q"
[ -s err.txt ] && fail "-q printed: $(cat err.txt)"
echo "ok: the estimate line comes before any work"

# 2. --max-bytes: refused before any work, nothing left behind; the old output stays.
echo old > c.ff
"$ff" "$scenes/cornell_sphere.obj" --subdiv 3 --max-bytes 10M -o c.ff 2> err.txt && fail "--max-bytes 10M accepted a 66.6 MiB run"
grep -q "would need 66.6 MiB (N^2 x 8 bytes) .* but --max-bytes is 9.54 MiB; refused (--element f32 halves the file" err.txt ||
  fail "--max-bytes: message: $(cat err.txt)"
grep -q "estimate:" err.txt && fail "a refused run calibrated"
[ "$(cat c.ff)" = old ] || fail "--max-bytes: the old output changed"
[ "$(ls | grep -c tmp)" = 0 ] || fail "--max-bytes left a temporary: $(ls)"
"$ff" "$scenes/cornell_sphere.obj" --subdiv 3 --max-bytes 67Mi -o d.ff 2> err.txt || fail "--max-bytes 67Mi: $(cat err.txt)"
"$ff" --max-bytes 5g -o e.ff 2> err.txt; rc=$?
[ $rc = 2 ] || fail "--max-bytes 5g: exit $rc, expected 2"
grep -q "is not a size in bytes" err.txt || fail "--max-bytes 5g: $(cat err.txt)"
echo "ok: --max-bytes refuses up front and leaves the old output"

# 3. Progress counts every rank: with two ranks, rank 0 holds about half the
# rows, so a line above 60 % can only come from both ranks' counts.
if command -v mpirun > /dev/null; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
  RAD_PROGRESS_SECONDS=0.05 OMP_NUM_THREADS=1 mpirun -n 2 "$ff" "$scenes/cornell_sphere.obj" --subdiv 3 \
    --reciprocity off --no-errors -o f.ff 2> err.txt || fail "mpirun -n 2: $(cat err.txt)"
  grep -q "of the rows (2 rank(s))" err.txt || fail "no progress lines: $(cat err.txt)"
  top=$(grep -o "[0-9.]*% of the rows (2 rank(s))" err.txt | sed 's/%.*//' | sort -n | tail -1)
  awk -v t="$top" 'BEGIN { exit !(t > 60) }' || fail "progress stops at $top %: rank 1's rows are not counted: $(cat err.txt)"
  echo "ok: progress lines count both ranks (up to $top %)"
fi
