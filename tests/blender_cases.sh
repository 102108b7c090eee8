#!/bin/sh
# From Blender to a right picture (issue 30 items 1, 2, 3, 7, 8, 10): the
# scenes of tests/data/blender/cases (tools/make_blender_cases.py, exported
# once by Blender 5.0) each give a picture or a message naming the cause and
# the remedy:
#   a room from Blender's cube, unflipped, with objects or only a light:
#     refused naming --flip-group Room, which then gives a closed room;
#   Blender's default scene (cube, lamp): every stage names the lamp;
#   a light panel on the ceiling: cut out, rows close; 1 cm below a 5 m
#     ceiling: named with the remedy;
#   a smooth UV sphere: no false "non-planar" alarms; subdivided Suzanne:
#     the doubling of N said once;
#   --preset preview: its settings, said.
#   blender_cases.sh BIN_DIR DATA_DIR WORKDIR   (render's cases skipped where it was not built)
set -u
bin=$1 data=$2 dir=$3
rm -rf "$dir" && mkdir -p "$dir" && cp "$data"/* "$dir"/ && cd "$dir" || exit 1
export OMP_NUM_THREADS=2
fail() { echo "FAIL: $*"; exit 1; }
has_render=0; [ -x "$bin/render" ] && has_render=1
py=${RAD_PYTHON3:-python3}
ff() { "$bin/formfactor" --ke radiance --subdiv 0 --shadow-rays 4 "$@"; }

# The fraction of the emitted light that escapes, from solve's energy line.
escaped() {
  sed -n 's/.*energy: emitted \([0-9.e+-]*\), absorbed [0-9.e+-]*, escaped \([0-9.e+-]*\).*/\2 \1/p' "$1" |
    head -1 | awk '{ printf "%.4f", $1 / $2 }'
}

# 1-2. The unflipped room, with objects and empty (only its light):
# refused before any work, naming the object and the flag; the flag fixes it.
for s in room_outward_objects room_outward_empty; do
  ff $s.obj -o $s.ff 2> err.txt && fail "$s: an outward room accepted: $(cat err.txt)"
  grep -q "$s.obj:21: object 'Room' (6 faces) encloses every other face, and 100% of its area faces outward" err.txt &&
    grep -q "run formfactor with --flip-group Room (only that object" err.txt ||
    fail "$s: the refusal does not name the object and the flag: $(cat err.txt)"
  [ -e $s.ff ] && fail "$s: a refused run left an output"
  ff $s.obj --flip-group Room -o $s.ff --stats $s.json 2> err.txt || fail "$s --flip-group Room: $(cat err.txt)"
  grep -q "warning" err.txt && fail "$s --flip-group Room warns: $(cat err.txt)"
  "$py" - $s.json <<'PY' || fail "$s --flip-group Room: row sums"
import json, sys
rows = json.load(open(sys.argv[1]))["row_sum"]
assert rows["min"] > 0.9 and rows["max"] < 1.1, rows
PY
  "$bin/solve" $s.ff -o $s.rad 2> err.txt || fail "$s solve: $(cat err.txt)"
  e=$(escaped err.txt)
  awk -v e="$e" 'BEGIN { exit !(e < 0.05) }' || fail "$s: $e of the light escapes a closed room: $(cat err.txt)"
  if [ $has_render = 1 ]; then
    "$bin/render" $s.rad -o $s.png 2> err.txt || fail "$s render: $(cat err.txt)"
    grep -q "camera: from $s.camera, the scene's sidecar" err.txt || fail "$s: sidecar not found: $(cat err.txt)"
    grep -q "black" err.txt && fail "$s: black: $(cat err.txt)"
  fi
  ff $s.obj --keep-normals -o keep.ff 2> err.txt || fail "$s --keep-normals: $(cat err.txt)"
done
# --flip-normals flips everything (compatibility); a name the scene lacks is refused.
ff room_outward_objects.obj --flip-group Walls -o x.ff 2> err.txt && fail "--flip-group Walls accepted"
grep -q "room_outward_objects.obj: --flip-group 'Walls': no object or group (\`o\` or \`g\`) of that name; the scene's: 'Room', 'Light', 'BoxTall', 'BoxLow', 'Sphere'" err.txt ||
  fail "--flip-group of a missing name: $(cat err.txt)"
# The room Blender users get right: the same picture without any flag.
ff room_inward_objects.obj -o in.ff 2> err.txt || fail "inward room: $(cat err.txt)"
grep -q "warning" err.txt && fail "the inward room warns: $(cat err.txt)"
echo "ok: an unflipped room is refused naming --flip-group Room, which closes it"

# 3. Blender's default scene: the lamp named at each stage, not the normals.
ff default_scene.obj -o default.ff 2> err.txt || fail "default scene: $(cat err.txt)"
grep -q "no face emits light.*Blender's lights (Light objects: point, sun, spot and area lamps, the default scene's 'Light') are not written to OBJ files" err.txt ||
  fail "formfactor does not name the lamp: $(cat err.txt)"
grep -q "Right for one convex object seen from outside (Blender's default cube)" err.txt ||
  fail "formfactor's all-zero F warning: $(cat err.txt)"
"$bin/solve" default.ff -o default.rad 2> err.txt || fail "solve default: $(cat err.txt)"
grep -q "no patch emits light.*Blender's lights" err.txt || fail "solve does not name the lamp: $(cat err.txt)"
if [ $has_render = 1 ]; then
  "$bin/render" default.rad -o default.png 2> err.txt || fail "render default: $(cat err.txt)"
  grep -q "the image is black: every radiosity is 0.*Blender's lights" err.txt || fail "render: $(cat err.txt)"
  # Automatic framing that sees nothing lit does not advise automatic framing.
  "$bin/formfactor" -q --ke radiance room_outward_objects.obj --keep-normals -o keep.ff && "$bin/solve" -q keep.ff -o keep.rad ||
    fail "keep"
  "$bin/render" keep.rad -o keep.png --camera auto --eye 0,20,0 --look-at 0,40,0 2> err.txt || fail "render away"
  grep -q "try the automatic framing" err.txt || fail "render looking away: $(cat err.txt)"
fi
echo "ok: Blender's default scene names its lamp at every stage"

# 7. A light panel snapped onto the ceiling: the ceiling behind it cut out,
# rows closed, no warning; 1 cm under a 5 m room's ceiling: named.
ff panel_on_ceiling.obj -o on.ff --stats on.json 2> err.txt || fail "panel on ceiling: $(cat err.txt)"
grep -q "warning" err.txt && fail "panel on ceiling warns: $(cat err.txt)"
grep -q "contacts: 1 of 7 faces cut, [1-9][0-9]* pieces dropped as hidden" err.txt || fail "panel on ceiling not cut: $(cat err.txt)"
"$py" - on.json <<'PY' || fail "panel on ceiling: row sums"
import json, sys
rows = json.load(open(sys.argv[1]))["row_sum"]
assert rows["min"] > 0.999 and rows["max"] < 1.001, rows
PY
ff panel_below_ceiling.obj -o below.ff 2> err.txt || fail "panel below ceiling: $(cat err.txt)"
grep -q "panel_below_ceiling.obj:35: a face of 'Light' lies 0.01 in front of the face of 'Room' at line 26, parallel to it and facing the same way" err.txt &&
  grep -q "Snap it onto that face" err.txt || fail "panel 1 cm below: not named: $(cat err.txt)"
echo "ok: a panel on the ceiling is cut out; one 1 cm below is named with the remedy"

# 8. The UV sphere's rounding is not "non-planar"; Suzanne's real non-planar
# quads are said once, with how much N grows (stopped before the long run).
ff sphere_smooth.obj -o sphere.ff --stats sphere.json 2> err.txt || fail "sphere: $(cat err.txt)"
grep -q "non-planar" err.txt && fail "sphere: false non-planar alarms: $(cat err.txt)"
grep -q "519 patches from 519 faces" err.txt || fail "sphere: its quads split: $(cat err.txt)"
"$bin/solve" sphere.ff -o sphere.rad 2> err.txt || fail "sphere solve: $(cat err.txt)"
grep -q "warning" err.txt && fail "sphere: solve warns at these settings: $(cat err.txt)"
"$bin/formfactor" --ke radiance suzanne_smooth.obj --max-seconds 0.001 -o suz.ff 2> err.txt
grep -q "suzanne_smooth.obj:4063: 1961 non-planar polygons .* were split into 3921 triangles: 3935 faces where the file has 1975 polygons, 99% more patches" err.txt ||
  fail "suzanne: the doubling not said: $(cat err.txt)"
[ "$(grep -c 'non-planar' err.txt)" = 1 ] || fail "suzanne: said more than once: $(cat err.txt)"
echo "ok: rounding is not non-planarity; a doubled N is said once"

# 10. --preset preview: its settings, explicit flags on top.
"$bin/formfactor" --ke radiance sphere_smooth.obj --preset preview --max-seconds 0.001 -o p.ff 2> err.txt
grep -q "512 samples and 16 shadow rays per pair" err.txt || fail "--preset preview: $(cat err.txt)"
"$bin/formfactor" --ke radiance sphere_smooth.obj --shadow-rays 8 --preset preview --max-seconds 0.001 -o p.ff 2> err.txt
grep -q "512 samples and 8 shadow rays per pair" err.txt || fail "--preset preview overrode --shadow-rays: $(cat err.txt)"
"$bin/formfactor" --preset fast -o p.ff 2> err.txt && fail "--preset fast accepted"
echo "ok: --preset preview sets its settings where the flags do not"
