#!/bin/sh
# Seed corpora for the fuzz targets, from scenes/ and from files the
# programs write.
#   tests/fuzz/make_corpus.sh OUT_DIR BIN_DIR
# BIN_DIR holds formfactor and solve (a normal build). Writes
# OUT_DIR/scene, OUT_DIR/ffile, OUT_DIR/rfile. Small files on purpose:
# libFuzzer runs faster on inputs of a few KiB.
set -eu
out=$1 bin=$2
src=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$out/scene" "$out/ffile" "$out/rfile" "$out/pair" "$out/work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1

# scene: OBJ text, then NUL + each MTL (the fuzz target's input format).
for obj in "$src"/scenes/*.obj "$src"/tests/data/*.obj; do
  name=$(basename "$obj" .obj)
  { cat "$obj"
    for mtl in $(sed -n 's/^mtllib //p' "$obj"); do
      printf '\0'; [ -f "$src/scenes/$mtl" ] && cat "$src/scenes/$mtl"
    done; } > "$out/scene/$name"
done
seed() { printf "$2" > "$out/scene/$1"; }
seed tri 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n'
seed quad_slashes 'mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\ng g1\nusemtl m\nf 1/1/1 2/1/1 3//1 -1/1\n\0newmtl m\nKd 0.5\nKe 1 2 3\n'
seed pentagon_crlf '\357\273\277v 0 0 0\r\nv 2 0 0\r\nv 2 1 0\r\nv 1 2 0\r\nv 0 1 0\r\nf 1 2 3 4 5\r\ns off\r\no thing'
seed nonplanar 'v 0 0 0 1\nv 1 0 0 1 0 0\nv 1 1 0.5\nv 0 1 0\nv 0.5 0.5 -1\nf 1 2 3 4\nf 1 2 5\nf 2 3 4 1 5\n'
seed concave 'v 0 0 0\nv 4 0 0\nv 4 4 0\nv 2 1 0\nv 0 4 0\nf 1 2 3 4 5\nf 1 1 2 3\nf 1 2 3 2\n'
seed holes 'o Plate with a hole\nv 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nv 1 1 0\nv 3 1 0\nv 3 3 0\nv 1 3 0\nf 1 2 3 4 1 5 8 7 6 5\ng Same  way\nf 1 2 3 4 1 5 6 7 8 5\n'
seed two_mtllibs 'mtllib a.mtl b.mtl\nmtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl light\nf 3 2 1\n\0newmtl red\nKd 0.5 0 0\nillum 2\nmap_Kd x.png\n\0newmtl light\nKe 10 10 10\nNs 3\n'

# Hostile shapes (issue 16): classic Mac OS line ends, coordinates and
# emission at and beyond the limits, junk and unknown keys, a long line.
seed tri_cr 'v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r'
seed huge_coords 'v 0 0 0\nv 1e12 0 0\nv 0 -1e12 0\nv 1e39 0 0\nv 1e154 1e100 0\nf 1 2 3\nf 1 2 4\n'
seed junk_keys 'mtllib a.mtl\nroot:$6$x:1:0:9:7:::\nkey1 1\nkey2 2\nkey1 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n\0newmtl m\nKd 0.5\nKe 1e30 1e308 0\ndaemon:*:1:1::/:/bin/sh\n'
{ printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n# '; head -c 8192 /dev/zero | tr '\0' 'x'; printf '\nf 3 2 1\n'; } > "$out/scene/long_line"

# ffile and rfile: files formfactor and solve write for small scenes.
cd "$out/work"
printf 'mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nusemtl lit\nf 1 2 3 4\nusemtl grey\nf 1 5 6 2\nf 2 6 3\n' > two.obj
printf 'newmtl lit\nKd 0.5 0.5 0.5\nKe 1 1 1\nnewmtl grey\nKd 0.25 0.5 0.75\n' > two.mtl
ff=$bin/formfactor solve=$bin/solve
"$ff" -q two.obj -o "$out/ffile/two_f64" --format dense --samples 16 --shadow-rays 4
"$ff" -q two.obj -o "$out/ffile/two_f32" --element f32 --samples 16 --shadow-rays 4 --estimator mc
"$ff" -q two.obj -o "$out/ffile/two_paper" --format paper --samples 16 --shadow-rays 4
"$ff" -q two.obj -o "$out/ffile/two_sub1" --subdiv 1 --samples 8 --shadow-rays 0
"$ff" -q "$src/scenes/closed_box.obj" -o "$out/ffile/closed_box" --samples 64
"$ff" -q -o "$out/ffile/cornell_box_f32" --format dense --element f32 --samples 16 --shadow-rays 8
"$ff" -q two.obj -o "$out/ffile/two_sparse" --format sparse --subdiv 1 --shadow-rays 0
"$ff" -q "$src/scenes/closed_box.obj" -o "$out/ffile/closed_box_sparse_f32" --format sparse --element f32 --subdiv 1
for f in two_f64 two_f32 two_sub1 closed_box cornell_box_f32; do
  "$solve" -q "$out/ffile/$f" -o "$out/rfile/$f"
done
"$solve" -q --method jacobi --max-iter 2 "$out/ffile/closed_box" -o "$out/rfile/closed_box_unconverged" || true
"$solve" -q --method cg "$out/ffile/two_f64" -o "$out/rfile/two_cg"
cd "$out" && rm -rf work
# The links layout (hierarchical radiosity): a small valid file that
# tests/test_lfile.c writes, kept among the regressions.
cp "$src/tests/fuzz/regressions/ffile/links-small" "$out/ffile/links_small"
# pair: one input per configuration of pair_cases.h (its first byte), the
# rest fixed bytes.
for k in 0 1 2 3 4 5 6 7; do
  { printf "\\$(printf '%03o' $k)"; printf 'seed-bytes-of-the-pair-target-0123456789abcdefghijklmnopqrstuvw'; } > "$out/pair/kind$k"
done
echo "make_corpus: $(ls scene | wc -l) scene, $(ls ffile | wc -l) ffile, $(ls rfile | wc -l) rfile seeds in $out"
