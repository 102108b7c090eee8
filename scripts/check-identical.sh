#!/usr/bin/env bash
# Byte-identity check for refactors (issue 25): runs the same cases with two
# builds and compares every file they write with cmp; --stats JSON files are
# compared after dropping what changes from run to run (times, rates).
#
#   scripts/check-identical.sh OLD_BUILD NEW_BUILD [WORK_DIR]
#
# OLD_BUILD and NEW_BUILD are build folders holding formfactor, solve and
# render (e.g. a worktree of the commit before the change, built with
# -DRAD_WITH_CUDA=OFF, and this tree's build). Exit 0 when every file is
# identical; otherwise lists the files that differ and exits 1. Takes about
# two minutes on two cores.
set -euo pipefail
[[ $# -ge 2 ]] || { echo "usage: $0 OLD_BUILD NEW_BUILD [WORK_DIR]" >&2; exit 2; }
old=$(cd "$1" && pwd)
new=$(cd "$2" && pwd)
src=$(cd "$(dirname "$0")/.." && pwd)
work=${3:-$(mktemp -d)}
mkdir -p "$work"
work=$(cd "$work" && pwd)
scenes=$src/scenes
corpus=$src/tests/data/corpus
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMP_WAIT_POLICY=passive

# run BUILD SIDE: every case, outputs under $work/SIDE. The scene paths are
# the same for both sides, so the files record the same names.
run_cases() {
  local b=$1 d=$work/$2
  rm -rf "$d" && mkdir -p "$d" && cd "$d"
  local ff=$b/formfactor sv=$b/solve rd=$b/render
  {
    # The built-in box, defaults (sparse), with errors and stats.
    $ff --errors box.err --stats box.ff.json -o box.ff
    $sv --stats box.sv.json -o box.rad box.ff
    $rd -o box.png box.rad
    $rd -o box.exr --width 96 --height 64 --spp 4 box.rad
    # OBJ Cornell box: dense, f32, reciprocity off, every solve method.
    $ff --format dense --element f32 --reciprocity off --subdiv 1 \
        --errors cb.err --stats cb.ff.json -o cb.ff "$scenes/cornell_box.obj"
    for m in jacobi gauss-seidel cg; do
      $sv --method $m --errors cb.err --stats cb.$m.json -o cb.$m.rad cb.ff
    done
    $rd -o cb.png --spp 4 cb.cg.rad
    # Paper format; Monte Carlo estimators.
    $ff --format paper -o cb.paper "$scenes/cornell_box.obj"
    $ff --estimator mc --stats mc.ff.json -o mc.ff "$scenes/closed_box.obj"
    $ff --estimator qmc -o qmc.ff "$scenes/closed_box.obj"
    $ff --estimator auto --subdiv 1 -o auto.ff "$scenes/cornell_box.obj"
    $ff --estimator analytic -o an.ff "$scenes/closed_box.obj"
    # Groups, contacts, flips and clamps on an OBJ with many faces.
    $ff --stats room.ff.json -o room.ff "$scenes/cluttered_room.obj"
    $sv --by-group room.csv --stats room.sv.json -o room.rad room.ff
    $sv --by-group room.npy -o room2.rad room.ff
    $rd -o room.png --spp 4 room.rad
    $ff --contacts keep --cull none -o keep.ff "$scenes/cluttered_room.obj"
    $ff --subdiv 1 --subdiv-only box -o only.ff "$scenes/cornell_box.obj"
    # A curved scene with its camera sidecar.
    $ff --shadow-rays 8 --stats sph.ff.json -o sph.ff "$scenes/cornell_sphere.obj"
    $sv -o sph.rad sph.ff
    $rd -o sph.png --spp 4 sph.rad
    # --target-error adds rays.
    $ff --target-error 0.003 --errors te.err --stats te.ff.json -o te.ff "$scenes/cornell_box.obj"
    # The refinement loop: --refine with --reuse.
    $sv -o cb0.rad box.ff >/dev/null
    $ff --stats ref0.ff.json -o ref0.ff "$scenes/cornell_box.obj"
    $sv -o ref0.rad ref0.ff
    $ff --refine ref0.rad --reuse ref0.ff --stats ref1.ff.json -o ref1.ff "$scenes/cornell_box.obj"
    $sv -o ref1.rad ref1.ff
    # Real meshes: Blender exports with near faces, holes and slivers.
    $ff --shadow-rays 8 --stats suz.ff.json -o suz.ff "$corpus/suzanne_table.obj"
    $sv -o suz.rad suz.ff
    $ff --shadow-rays 8 -o cad.ff "$corpus/cad_boolean.obj"
    # Two ranks write one file.
    if command -v mpirun >/dev/null; then
      mpirun -n 2 --oversubscribe $ff --stats mpi.ff.json -o mpi.ff "$scenes/cornell_box.obj"
      mpirun -n 2 --oversubscribe $sv -o mpi.rad mpi.ff
    fi
    # Refusals write nothing and say the same.
    $ff --samples 0 -o bad.ff || echo "exit $?"
    $sv -o bad.rad missing.ff || echo "exit $?"
  } > stdout.txt 2> stderr.raw || true
  # Timings, rates and progress lines differ from run to run.
  grep -v -E 'time \(s, |[0-9.]+ ?(s|ms|seconds)\b|/s\b|estimate|ETA|elapsed' stderr.raw > stderr.txt || true
  rm -f stderr.raw
}

run_cases "$old" old
run_cases "$new" new

strip_json() {
  python3 - "$1" <<'EOF'
import json, sys
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items()
                if not any(s in k for s in ("seconds", "per_second", "threads", "time"))}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
print(json.dumps(strip(json.load(open(sys.argv[1]))), sort_keys=True, indent=1))
EOF
}

status=0
count=0
cd "$work/old"
for f in *; do
  count=$((count + 1))
  if [[ ! -e "$work/new/$f" ]]; then echo "missing in new: $f"; status=1; continue; fi
  if [[ $f == *.json ]]; then
    if ! diff <(strip_json "$f") <(strip_json "$work/new/$f") >/dev/null; then
      echo "differs: $f"; status=1
    fi
  elif ! cmp -s "$f" "$work/new/$f"; then
    echo "differs: $f"; status=1
  fi
done
for f in "$work/new"/*; do
  [[ -e "$work/old/$(basename "$f")" ]] || { echo "only in new: $(basename "$f")"; status=1; }
done
if [[ $status == 0 ]]; then
  echo "identical: $count files ($work)"
else
  echo "outputs differ ($work/old vs $work/new)"
fi
exit $status
