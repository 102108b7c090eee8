#!/bin/sh
# formfactor's inputs and outputs, checked before the work they would
# waste: every output's folder up front (a late --stats must not fail after
# -o replaced the old file), --reuse entries that are not form factors, a
# scene without light named before the estimate, --target-error never
# worse than none, settings that must match (--subdiv with --refine,
# --reuse's --seed/--element (--quad-rtol: a warning), a changed --flip-normals or
# --clamp-rho named, OBJ-only flags on the built-in box), --max-seconds, a
# bounded calibration and the disk's 10x rule for sparse files.
#   formfactor_io.sh BIN_DIR FF_POKE SCENES_DIR WORKDIR
set -u
bin=$1 poke=$2 scenes=$3 dir=$4
ff=$bin/formfactor solve=$bin/solve
rm -rf "$dir" && mkdir -p "$dir" && cd "$dir" || exit 1
export OMP_NUM_THREADS=2 OMP_WAIT_POLICY=passive
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
fail() { echo "FAIL: $*"; exit 1; }
# refused WHAT REGEX COMMAND...: exits non-zero, says REGEX, leaves old.ff as it was.
refused() {
  what=$1 regex=$2
  shift 2
  echo old > old.ff
  "$@" > err.txt 2>&1 && fail "$what: accepted"
  grep -Eq -- "$regex" err.txt || fail "$what: message does not match '$regex': $(cat err.txt)"
  [ "$(cat old.ff)" = old ] || fail "$what: the old output was changed"
  ls old.ff.tmp-* > /dev/null 2>&1 && fail "$what: a temporary was left"
  echo "ok: $what: $(grep -Em1 -- "$regex" err.txt)"
}

# a. Every output is checked before any work: a --stats or --errors file in
# a missing folder fails with the old -o file untouched (it used to be
# replaced by the new matrix first, and then --stats failed).
refused "--stats in a missing folder" "--stats: no/such/s.json: cannot write" \
  "$ff" --subdiv 1 -q -o old.ff --stats no/such/s.json
refused "--errors in a missing folder" "--errors: no/such/e.ff: cannot write" \
  "$ff" --subdiv 1 -q -o old.ff --errors no/such/e.ff
if command -v mpirun > /dev/null; then
  refused "--stats in a missing folder, 2 ranks" "no/such/s.json: cannot write" \
    mpirun -n 2 "$ff" --subdiv 1 -q -o old.ff --stats no/such/s.json
fi

# b. --reuse: entries that are not form factors, in a file whose checksums
# are right (ff_poke), are refused naming the first one.
"$ff" --subdiv 1 -q -o ff0 || fail "formfactor"
"$solve" ff0 -q -o rad0 2> /dev/null || fail "solve"
for case in "nan:not a finite number" "inf:not a finite number" "-0.25:negative" "1e300:above 1" \
            "0.5:break reciprocity"; do
  value=${case%%:*} why=${case#*:}
  "$poke" ff0 bad.ff 3 40 "$value" || fail "ff_poke $value"
  refused "--reuse with F[3][40] = $value" "--reuse bad.ff: F\[3\]\[40\] = .*$why" \
    "$ff" --refine rad0 --reuse bad.ff --backend cpu -q -o old.ff
done
"$ff" --refine rad0 --reuse ff0 --backend cpu -q -o ff1 || fail "--reuse of a good file"
# float32 files pass the reciprocity check at their rounding.
"$ff" --subdiv 1 --element f32 -q -o f32.ff && "$solve" f32.ff -q -o f32.rad 2> /dev/null &&
  "$ff" --refine f32.rad --reuse f32.ff --element f32 --backend cpu -q -o f32b.ff || fail "--reuse of a float32 file"
echo "ok: --reuse takes good files, float32 too"

# c. A scene where nothing emits: one warning, before the estimate line;
# the matrix is still written.
printf 'newmtl g\nKd 0.5 0.5 0.5\n' > dark.mtl
printf 'mtllib dark.mtl\nusemtl g\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 2 3 4\nf 8 7 6 5\nf 5 6 2 1\nf 6 7 3 2\nf 7 8 4 3\nf 8 5 1 4\n' > room.obj
"$ff" room.obj --subdiv 1 -o room.ff 2> err.txt || fail "dark room: $(cat err.txt)"
[ -s room.ff ] || fail "dark room: no matrix written"
warned=$(grep -n "no face emits light" err.txt | head -1 | cut -d: -f1)
estimated=$(grep -n "estimate:" err.txt | head -1 | cut -d: -f1)
[ -n "$warned" ] || fail "dark room: no warning: $(cat err.txt)"
[ "$(grep -c "no face emits light" err.txt)" = 1 ] || fail "dark room: warned more than once: $(cat err.txt)"
[ -n "$estimated" ] && [ "$warned" -lt "$estimated" ] || fail "dark room: the warning comes after the estimate: $(cat err.txt)"
grep "no face emits light" err.txt | grep -q "image will be black" || fail "dark room: says nothing of the image"
"$ff" --subdiv 1 -o lit.ff 2> err.txt || fail "the built-in box"
grep -q "emits" err.txt && fail "a lit scene was called dark: $(cat err.txt)"
# The hierarchy on it too: B = 0 everywhere, so its error bound is 0 (it
# was infinite, and the writer refused the links as not valid).
"$ff" room.obj --method hierarchical --subdiv 2 -q -o dark_links.ff 2> err.txt || fail "dark room, hierarchical: $(cat err.txt)"
"$solve" dark_links.ff -q -o dark_links.rad 2> err.txt || fail "dark room, hierarchical, solve: $(cat err.txt)"
echo "ok: a scene without light is named before the estimate, once"

# d. --target-error never makes results worse than no target: a loose one
# changes no byte (it used to stop partly hidden pairs' rays at the first
# batch), and a pair whose quadrature stopped at its limit but meets the
# target is not counted as a miss.
"$ff" --subdiv 1 -q -o plain.ff || fail "plain"
"$ff" --subdiv 1 --target-error 1 -q -o loose.ff || fail "--target-error 1"
cmp -s plain.ff loose.ff || fail "--target-error 1 changed the matrix (fewer rays than the default)"
"$ff" --quad-rtol 1e-14 --quad-atol 1e-30 --target-error 1 -o capped.ff 2> err.txt || fail "capped"
grep -q -- "--target-error 1: met by every pair" err.txt ||
  fail "quadrature limits counted as target misses: $(grep target err.txt)"
echo "ok: --target-error only adds rays, and counts only its own misses"

# e. Settings that must match, or that do not apply, are refused by name.
refused "--subdiv with --refine" "--subdiv 2 with --refine rad0: .*drop --subdiv" \
  "$ff" --refine rad0 --subdiv 2 -q -o old.ff
refused "--uniform-leaves with --sized-leaves" "--uniform-leaves and --sized-leaves: .*give one" \
  "$ff" --method hierarchical --uniform-leaves --sized-leaves -q -o old.ff
refused "--reuse with another --seed" "--reuse ff0: computed with --seed 1, this run with --seed 2" \
  "$ff" --refine rad0 --reuse ff0 --seed 2 --backend cpu -q -o old.ff
refused "--reuse with another --element" "--reuse ff0: stored as --element f64, this run writes --element f32" \
  "$ff" --refine rad0 --reuse ff0 --element f32 --backend cpu -q -o old.ff
# --quad-rtol with --reuse cannot be checked (the file does not record it):
# a warning, and the run goes on (the refinement loop passes the same
# tolerances to every pass).
"$ff" --refine rad0 --reuse ff0 --quad-rtol 1e-6 -q -o tol.ff 2> err.txt || fail "--reuse with --quad-rtol: $(cat err.txt)"
grep -q "they cannot be checked" err.txt || fail "--reuse with --quad-rtol: no warning: $(cat err.txt)"
echo "ok: --reuse with --quad-rtol: warned, not refused"
refused "--flip-normals on the built-in box" "--flip-normals: applies to OBJ scenes" "$ff" --flip-normals -q -o old.ff
refused "--clamp-rho on the built-in box" "--clamp-rho: applies to OBJ scenes" "$ff" --clamp-rho 0.9 -q -o old.ff
refused "--ke radiance on the built-in box" "--ke radiance: applies to OBJ scenes" "$ff" --ke radiance -q -o old.ff
refused "--ke with a bad value" "--ke: expected radiosity or radiance, got 'watts'" "$ff" room.obj --ke watts -q -o old.ff
"$solve" room.ff -q -o room.rad 2> /dev/null || fail "solve room"
refused "--refine with another --flip-normals" "solved for another scene .*this run has --flip-normals" \
  "$ff" room.obj --flip-normals --refine room.rad -q -o old.ff
printf 'newmtl g\nKd 1 0.5 0.5\n' > dark.mtl
refused "--refine with another --clamp-rho" "solved for another scene .*material 'g' has Kd 0.9 0.5 0.5 here and 0.5 0.5 0.5 there \(another --clamp-rho" \
  "$ff" room.obj --clamp-rho 0.9 --refine room.rad -q -o old.ff

# f. --max-seconds refuses a run whose estimate is longer, before writing
# (with -q too); a huge run's calibration is bounded (at most 2^21 pairs:
# it used to compute 1/64 of the run, 1276 rows here); a sparse file
# whose bound is more than 10x the free space is refused unless
# --allow-disk-overcommit.
refused "--max-seconds" "--max-seconds 0.001: the run is estimated at about .* refused before writing anything" \
  "$ff" "$scenes/cornell_sphere.obj" --subdiv 3 --max-seconds 0.001 -o old.ff
refused "--max-seconds, -q" "--max-seconds 0.001: the run is estimated" \
  "$ff" "$scenes/cornell_sphere.obj" --subdiv 3 --max-seconds 0.001 -q -o old.ff
# (--backend cpu: on a GPU the same run is estimated at 2 minutes, not hours.)
refused "--max-seconds on a huge run" "--max-seconds 5: the run is estimated at about [0-9]+ h" \
  "$ff" --subdiv 6 --shadow-rays 0 --backend cpu --max-seconds 5 -o old.ff
rows=$(sed -n 's/.*calibrated on \([0-9]*\) of 81676 rows.*/\1/p' err.txt)
[ -n "$rows" ] && [ "$rows" -le 26 ] || fail "the calibration took $rows rows of 81676: $(cat err.txt)"
"$ff" --subdiv 1 --max-seconds 0.001 -q -o small.ff || fail "--max-seconds refused an uncalibrated small run"
"$ff" --max-seconds 0 -o x.ff 2> err.txt; [ $? = 2 ] || fail "--max-seconds 0 accepted"
# 5.2 M patches: a bound of 199 TiB, far beyond any test machine's disk.
refused "a sparse bound over 10x the free space" "less than a tenth of that bound .*--allow-disk-overcommit" \
  timeout 120 "$ff" --subdiv 9 -o old.ff
refused "--allow-disk-overcommit" "but --max-bytes is" "$ff" --subdiv 9 --allow-disk-overcommit --max-bytes 1G -o old.ff
"$ff" --help | grep -q -- "--allow-disk-overcommit" || fail "--help does not name --allow-disk-overcommit"
"$ff" --help | grep -q -- "--max-seconds S" || fail "--help does not name --max-seconds"
echo "formfactor_io: all checks passed"
