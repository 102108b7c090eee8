#!/usr/bin/env bash
# The refinement loop (issue 15): solve a coarse mesh, then split where the
# solution says the mesh is too coarse, solve again, until a pass splits
# nothing, the patch budget is spent, or --passes passes have run. Each
# pass's form factors are computed for its whole mesh (formfactor --refine,
# core/rad_refine.h says what is split); render draws the result conforming.
#
#   scripts/refine.sh [--build DIR] [--scene SCENE.obj|builtin] [--tol T]
#                     [--start-subdiv S] [--max-patches N] [--passes K] [--growth G]
#                     [--ff-args "..."] [--image FILE.png|.exr] [--spp N] --out DIR
#
# Leaves DIR/radiosity (the last solution), DIR/ff<k> and DIR/rad<k> per
# pass, DIR/refine.json (per pass: patches, split, seconds) and, with
# --image, the picture (render --spp N, default 64: the light's edges need
# it against a path tracer, docs/accuracy.md). Defaults: build/, the
# built-in Cornell box, --tol 0.05, --start-subdiv 2, --max-patches 2400,
# --passes 4, --growth 2 (a pass at most doubles the mesh; scenes with many
# separate shadows do better with smaller passes: the cluttered room reaches
# 0.088 with 1.5 and 6 passes where 2 gives 0.101, docs/accuracy.md), and
# formfactor's --quad-rtol 1e-5 --shadow-rays 16 (image accuracy: the
# quadrature's default 1e-8 costs 3x the time for no visible change).
# Each pass's counts come from formfactor's --stats JSON, read with
# python3's json (docs/formats.md); a key it lacks stops the loop with an
# error naming it.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$here/build scene=builtin tol=0.05 start=2 max_patches=2400 passes=4 growth=2
ff_args="--quad-rtol 1e-5 --shadow-rays 16" image="" out="" spp=64
usage() { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; }
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --scene) scene=$2; shift 2 ;;
    --tol) tol=$2; shift 2 ;;
    --start-subdiv) start=$2; shift 2 ;;
    --max-patches) max_patches=$2; shift 2 ;;
    --passes) passes=$2; shift 2 ;;
    --growth) growth=$2; shift 2 ;;
    --ff-args) ff_args=$2; shift 2 ;;
    --image) image=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "refine.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -n "$out" ] || { echo "refine.sh: --out DIR is required (see --help)" >&2; exit 2; }
for p in formfactor solve; do
  [ -x "$build/$p" ] || { echo "refine.sh: $build/$p not found; build first (cmake --build build)" >&2; exit 1; }
done
command -v python3 >/dev/null || { echo "refine.sh: python3 not found (it reads formfactor's --stats)" >&2; exit 1; }

# stats FILE KEY...: the counts at those keys of formfactor's --stats JSON
# (a dotted key looks inside an object: refine.split), on one line; fails,
# naming the key, where the file lacks one or it is not a count, so that a
# renamed key stops the loop instead of ending it quietly.
stats() {
  python3 - "$@" <<'PY'
import json, sys
path, keys = sys.argv[1], sys.argv[2:]
try:
    with open(path) as f:
        doc = json.load(f)
except (OSError, ValueError) as e:
    sys.exit(f"refine.sh: {path}: cannot read formfactor's stats: {e}")
values = []
for key in keys:
    v = doc
    for part in key.split("."):
        if not isinstance(v, dict) or part not in v:
            sys.exit(f'refine.sh: {path}: formfactor\'s stats have no "{key}" (renamed? docs/formats.md)')
        v = v[part]
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        sys.exit(f'refine.sh: {path}: "{key}" is {json.dumps(v)}, not a count')
    values.append(str(v))
print(" ".join(values))
PY
}
mkdir -p "$out"
scene_arg=()
[ "$scene" = builtin ] || scene_arg=("$scene")
now() { date +%s.%N; }
json="$out/refine.json.tmp"
t_all=$(now)
printf '{\n  "scene": "%s", "tol": %s, "start_subdiv": %s, "max_patches": %s, "ff_args": "%s",\n  "passes": [\n' \
  "$scene" "$tol" "$start" "$max_patches" "$ff_args" > "$json"
# shellcheck disable=SC2086
for ((k = 0; k <= passes; k++)); do
  t0=$(now)
  if [ $k -eq 0 ]; then
    "$build/formfactor" "${scene_arg[@]}" --subdiv "$start" $ff_args -q -o "$out/ff0" --stats "$out/ff0.json"
  else
    # Each pass may at most double the mesh, so that later passes split
    # where the finer solutions say (tripling: relative RMSE 0.050 where
    # doubling reaches 0.036, Cornell box, about 2400 patches).
    cap=$(awk -v n="$patches" -v g="$growth" -v m="$max_patches" 'BEGIN { c = int(n * g); print c < m ? c : m }')
    "$build/formfactor" "${scene_arg[@]}" --refine "$out/rad$((k - 1))" --reuse "$out/ff$((k - 1))" --refine-tol "$tol" \
      --refine-max-patches "$cap" $ff_args -q -o "$out/ff$k" --stats "$out/ff$k.json"
  fi
  t1=$(now)
  "$build/solve" "$out/ff$k" -q -o "$out/rad$k" 2>/dev/null
  t2=$(now)
  # The first pass has no refine object: nothing split.
  split="" over=""
  if [ $k -eq 0 ]; then
    patches=$(stats "$out/ff$k.json" patches)
  else
    counts=$(stats "$out/ff$k.json" patches refine.split refine.over_max_patches)
    read -r patches split over <<< "$counts"
  fi
  [ $k -eq 0 ] || printf ',\n' >> "$json"
  printf '    {"pass": %d, "patches": %s, "split": %s, "formfactor_s": %.3f, "solve_s": %.3f}' \
    $k "$patches" "${split:-0}" "$(awk "BEGIN{print $t1 - $t0}")" "$(awk "BEGIN{print $t2 - $t1}")" >> "$json"
  echo "refine.sh: pass $k: $patches patches${split:+ ($split split)}" >&2
  last=$k
  [ $k -gt 0 ] && [ "${split:-0}" -eq 0 ] && break
  [ -n "$over" ] && [ "$over" -gt 0 ] && [ "$cap" -ge "$max_patches" ] && break
  [ "$patches" -ge "$max_patches" ] && break
done
cp "$out/rad$last" "$out/radiosity.tmp" && mv "$out/radiosity.tmp" "$out/radiosity"
t_end=$(now)
printf '\n  ],\n  "final_pass": %d, "seconds": %.3f\n}\n' "$last" "$(awk "BEGIN{print $t_end - $t_all}")" >> "$json"
mv "$json" "$out/refine.json"
if [ -n "$image" ]; then
  [ -x "$build/render" ] || { echo "refine.sh: $build/render not built (OpenImageIO); no image" >&2; exit 1; }
  "$build/render" "$out/radiosity" --spp "$spp" -q -o "$image"
fi
