#!/bin/sh
# Real meshes through the three programs: the Blender corpus
# (tests/data/corpus, made by tools/make_corpus_blender.py) and the OBJ test
# files of the Debian package assimp-testmodels (another loader's test
# suite; scripts/install-deps.sh installs it), each alone and in a closed
# lit room (Blender's own room, or tests/corpus_room.py around an assimp
# model).
#   corpus.sh quick|slow|large BIN_DIR DATA_DIR WORKDIR
# quick: the models that take seconds (CTest `corpus`, label unit);
# slow: the ones that take minutes on two cores (CTest `corpus_slow`, label
# slow); large: Suzanne with a subdivision surface, 15 859 patches (not in
# CTest: about 5 s on an H200, much longer on two cores; run it by hand or
# through scripts/bench-near-field.sh).
# Per run: formfactor with the defaults (--subdiv 0) and --errors, --stats;
#  - no signal and no hang (timeout: RAD_CORPUS_TIMEOUT seconds a run,
#    default 120 quick, 900 slow);
#  - exit 0, or, where the manifest names an error for a genuinely invalid
#    input, only `formfactor: error:` lines on stderr, one of which matches it;
#  - row sums (tests/corpus_rows.py, numpy): every S_i <= 1 + 3 sigma_i +
#    1e-6, sigma_i from the --errors file; in a closed room (manifest:
#    closed) also |S_i - 1| <= 1e-3 + 3 sigma_i;
#  - solve and render (64 x 64) exit 0.
# Prints a line per run (patches, time, quadrature points and shadow rays
# from --stats, pairs capped, row sums) and "N passed, N failed". Exits 77
# without numpy; assimp models are skipped (and named) where the package is
# missing (RAD_ASSIMP_MODELS: its models folder).
set -u
tier=$1 bin=$2 data=$3 work=$4
py=${RAD_PYTHON3:-python3}
here=$(cd "$(dirname "$0")" && pwd)
assimp=${RAD_ASSIMP_MODELS:-/usr/share/assimp/models}
case $tier in
  quick) limit=${RAD_CORPUS_TIMEOUT:-120} ;;
  slow | large) limit=${RAD_CORPUS_TIMEOUT:-900} ;;
  *) echo "usage: corpus.sh quick|slow|large BIN_DIR DATA_DIR WORKDIR"; exit 2 ;;
esac
"$py" -c "import numpy" 2>/dev/null || { echo "numpy missing ($py): skipped"; exit 77; }
rm -rf "$work" && mkdir -p "$work" || exit 1
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}

# tier|name|source|variants|closed|alone expects|room expects
# source: corpus:NAME (NAME.obj in the room, NAME_alone.obj alone, both
# written by Blender) or assimp:PATH (the file alone; corpus_room.py puts
# it in the room). variants: both | alone | room. closed: yes where the
# model is watertight and faces out, so the room version is a closed scene.
# expects: ok, or error:REGEX for an input that is genuinely invalid (its
# room version's line numbers are the model's + 3).
manifest() {
  cat <<'EOF'
quick|cad_boolean|corpus:cad_boolean|both|yes|ok|ok
quick|cylinder_bevel|corpus:cylinder_bevel|both|yes|ok|ok
quick|uv_sphere|corpus:uv_sphere|both|yes|ok|ok
quick|thin_plates|corpus:thin_plates|both|yes|ok|ok
quick|suzanne_table|corpus:suzanne_table|both|no|ok|ok
large|suzanne_subsurf|corpus:suzanne_subsurf|both|no|ok|ok
quick|torus|corpus:torus|both|yes|ok|ok
slow|text|corpus:text|both|yes|ok|ok
quick|box|assimp:OBJ/box.obj|both|yes|error:box.obj:22: usemtl 'Default': no such material|ok
quick|box_longline|assimp:OBJ/box_longline.obj|both|yes|error:box_longline.obj:22: usemtl 'Defauli': no such material|error:box_longline.obj:26: face crosses itself; cannot triangulate
quick|box_mat_with_spaces|assimp:OBJ/box_mat_with_spaces.obj|both|yes|ok|ok
quick|box_without_lineending|assimp:OBJ/box_without_lineending.obj|both|yes|error:box_without_lineending.obj:22: usemtl 'Default': no such material|ok
quick|box_UTF16BE|assimp:OBJ/box_UTF16BE.obj|both|no|error:box_UTF16BE.obj: is UTF-16 text \(byte-order mark FE FF\); save it as UTF-8 or ASCII|error:box_UTF16BE.obj:4: contains a NUL byte
quick|concave_polygon|assimp:OBJ/concave_polygon.obj|both|no|ok|ok
quick|cube_mtllib_after_g|assimp:OBJ/cube_mtllib_after_g.obj|both|yes|error:cube_mtllib_after_g.mat: cannot open|ok
quick|cube_usemtl|assimp:OBJ/cube_usemtl.obj|both|yes|error:cube_usemtl.mtl:3: Kd 1.000 out of range \[0,1\)|ok
quick|cube_with_vertexcolors|assimp:OBJ/cube_with_vertexcolors.obj|both|yes|ok|ok
quick|cube_with_vertexcolors_uni|assimp:OBJ/cube_with_vertexcolors_uni.obj|both|yes|ok|ok
quick|multiple_spaces|assimp:OBJ/multiple_spaces.obj|both|no|ok|ok
quick|number_formats|assimp:OBJ/number_formats.obj|both|no|error:number_formats.obj:11: bad number '3.1\+e2'|error:number_formats.obj:14: bad number '3.1\+e2'
quick|point_cloud|assimp:OBJ/point_cloud.obj|both|yes|error:point_cloud.obj: no faces|ok
quick|regr_3429812|assimp:OBJ/regr_3429812.obj|both|no|error:regr_3429812.mtl:6: Kd 1 out of range \[0,1\)|ok
quick|space_in_material_name|assimp:OBJ/space_in_material_name.obj|both|no|ok|ok
quick|testline|assimp:OBJ/testline.obj|both|yes|error:testline.obj:14: usemtl 'Default': no such material|ok
quick|testmixed|assimp:OBJ/testmixed.obj|both|no|error:testmixed.obj:14: usemtl 'Default': no such material|ok
quick|testpoints|assimp:OBJ/testpoints.obj|both|yes|error:testpoints.obj:14: usemtl 'Default': no such material|ok
quick|empty|assimp:invalid/empty.obj|both|yes|error:empty.obj: no faces|ok
quick|malformed|assimp:invalid/malformed.obj|both|no|error:malformed.obj:22: usemtl 'Default': no such material|error:malformed.obj:25: vertex index 12 out of range
quick|malformed2|assimp:invalid/malformed2.obj|both|no|error:malformed2.obj:22: usemtl 'DefaultDoesNotExist': no such material|error:malformed2.obj:25: face has 0 vertices
quick|empty_mat|assimp:OBJ/empty_mat.obj|alone|no|error:empty_mat.mtl:3: 'newmtl' needs a name|ok
slow|empty_mat|assimp:OBJ/empty_mat.obj|room|no|ok|ok
slow|spider|assimp:OBJ/spider.obj|both|no|ok|ok
slow|regr01|assimp:OBJ/regr01.obj|both|no|ok|ok
slow|wuson|assimp:OBJ/WusonOBJ.obj|both|no|ok|ok
EOF
}

passed=0 failed=0 skipped=0
say() { echo "$*"; }
fail() { say "FAIL: $*"; failed=$((failed + 1)); }

# stat KEY FILE: a number from the stats JSON (top-level key).
stat() { "$py" -c "import json,sys; d=json.load(open(sys.argv[1])); print(d.get(sys.argv[2]))" "$2" "$1" 2>/dev/null; }

# run_case LABEL OBJ EXPECT CLOSED
run_case() {
  label=$1 obj=$2 expect=$3 closed=$4
  out=$work/$label
  t0=$(date +%s.%N)
  timeout -k 10 "$limit" "$bin/formfactor" "$obj" -q -o "$out.ff" --errors "$out.err" --stats "$out.json" \
    > "$out.log" 2>&1
  rc=$?
  t=$(echo "$(date +%s.%N) - $t0" | bc)
  t=$(printf '%.1f' "$t")
  if [ $rc -eq 124 ] || [ $rc -eq 137 ]; then
    fail "$label: formfactor still running after ${limit} s (killed)"
    return
  fi
  if [ $rc -gt 128 ]; then
    fail "$label: formfactor died of signal $((rc - 128)) after $t s: $(tail -n 3 "$out.log" | tr '\n' ' ')"
    return
  fi
  case $expect in
  error:*)
    want=${expect#error:}
    if [ $rc -eq 0 ]; then
      fail "$label: accepted ($t s), expected the error /$want/"
      return
    fi
    if grep -qv '^formfactor: error: ' "$out.log"; then
      fail "$label: exit $rc with more than errors on stderr: $(head -n 3 "$out.log" | tr '\n' ' ')"
      return
    fi
    if ! grep -Eq "$want" "$out.log"; then
      fail "$label: exit $rc, not the expected error /$want/: $(cat "$out.log" | tr '\n' ' ')"
      return
    fi
    [ -e "$out.ff" ] && { fail "$label: a refused scene left $out.ff"; return; }
    lines=$(wc -l < "$out.log")
    say "ok: $label: refused in $t s ($lines line(s)): $(head -n 1 "$out.log")"
    passed=$((passed + 1))
    return ;;
  esac
  if [ $rc -ne 0 ]; then
    fail "$label: exit $rc after $t s: $(cat "$out.log" | tr '\n' ' ')"
    return
  fi
  info="patches $(stat patches "$out.json"), $t s, quadrature points $(stat samples "$out.json"), shadow rays $(stat rays "$out.json"), pairs $(stat pairs "$out.json"), capped $(stat pairs_capped "$out.json")"
  tol=; [ "$closed" = yes ] && tol="--closed 1e-3"
  # shellcheck disable=SC2086
  rows=$("$py" "$here/corpus_rows.py" "$out.ff" "$out.err" $tol 2>&1)
  rrc=$?
  if [ $rrc -ne 0 ]; then
    fail "$label: $info; $rows"
    return
  fi
  timeout -k 10 "$limit" "$bin/solve" "$out.ff" -o "$out.rad" -q > "$out.solve.log" 2>&1
  src=$?
  if [ $src -ne 0 ]; then
    fail "$label: $info; solve exit $src: $(tr '\n' ' ' < "$out.solve.log")"
    return
  fi
  if [ -x "$bin/render" ]; then
    timeout -k 10 "$limit" "$bin/render" "$out.rad" -o "$out.png" --width 64 --height 64 -q > "$out.render.log" 2>&1
    grc=$?
    if [ $grc -ne 0 ] || [ ! -s "$out.png" ]; then
      fail "$label: $info; render exit $grc: $(tr '\n' ' ' < "$out.render.log")"
      return
    fi
  fi
  say "ok: $label: $info; $rows"
  passed=$((passed + 1))
}

start=$(date +%s)
manifest | while IFS='|' read -r t name src variants closed e_alone e_room; do
  [ "$t" = "$tier" ] || continue
  case $src in
  corpus:*)
    base=$data/${src#corpus:}
    alone=$base"_alone.obj" room=$base.obj ;;
  assimp:*)
    alone=$assimp/${src#assimp:}
    if [ ! -r "$alone" ]; then
      echo "skip: $name: $alone missing (Debian package assimp-testmodels)"
      echo skip >> "$work/.skipped"
      continue
    fi
    room=$work/$name.obj
    "$py" "$here/corpus_room.py" "$alone" "$room" 2> /dev/null || { echo "FAIL: corpus_room.py $alone"; echo x >> "$work/.failed"; continue; } ;;
  esac
  passed=0 failed=0
  [ "$variants" = room ] || run_case "$name.alone" "$alone" "$e_alone" no
  [ "$variants" = alone ] || run_case "$name.room" "$room" "$e_room" "$closed"
  i=0; while [ $i -lt $passed ]; do echo ok >> "$work/.passed"; i=$((i + 1)); done
  i=0; while [ $i -lt $failed ]; do echo x >> "$work/.failed"; i=$((i + 1)); done
done
count() { [ -f "$1" ] && wc -l < "$1" || echo 0; }
p=$(count "$work/.passed") f=$(count "$work/.failed") s=$(count "$work/.skipped")
echo "corpus ($tier): $(($(date +%s) - start)) s"
echo "$p passed, $f failed"
[ "$f" -eq 0 ] || exit 1
[ "$p" -gt 0 ] || exit 77
exit 0
