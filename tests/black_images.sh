#!/bin/sh
# No silent black images (issue 17): a scene without emitters, faces that
# all point away from each other (Blender's default cube used as a room),
# and a camera that sees nothing lit each get a warning saying why. And
# cameras: a view along the default up works, and says so.
#   black_images.sh BIN_DIR WORKDIR   (render's case skipped where it was not built)
set -u
bin=$1 dir=$2
rm -rf "$dir" && mkdir -p "$dir" && cd "$dir" || exit 1
export OMP_NUM_THREADS=2
fail() { echo "FAIL: $*"; exit 1; }
printf 'newmtl g\nKd 0.5 0.5 0.5\n' > dark.mtl
# The unit cube as Blender writes its default cube: faces outward, no Ke.
printf 'mtllib dark.mtl\nusemtl g\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n' > cube.obj
"$bin/formfactor" cube.obj -o cube.ff 2> err.txt || fail "formfactor: $(cat err.txt)"
grep -q "every form factor is 0: no two patches face each other" err.txt || fail "no warning for outward faces: $(cat err.txt)"
"$bin/solve" cube.ff -o cube.rad 2> err.txt || fail "solve: $(cat err.txt)"
grep -q "no patch emits light" err.txt || fail "no warning for a scene without Ke: $(cat err.txt)"
echo "ok: outward faces and a scene without emitters are named"
if [ -x "$bin/render" ]; then
  "$bin/render" cube.rad -o cube.png --width 32 --height 32 2> err.txt || fail "render: $(cat err.txt)"
  grep -q "the image is black: every radiosity is 0" err.txt || fail "render: no warning: $(cat err.txt)"
  "$bin/formfactor" -q -o box.ff && "$bin/solve" -q box.ff -o box.rad || fail "the built-in box"
  "$bin/render" box.rad -o away.png --width 32 --height 32 --eye 0,0,-5000 --look-at 0,0,-10000 2> err.txt ||
    fail "render looking away: $(cat err.txt)"
  grep -q "the image is black: the camera sees nothing lit" err.txt || fail "render looking away: no warning: $(cat err.txt)"
  "$bin/render" box.rad -o box.png --width 32 --height 32 2> err.txt || fail "render: $(cat err.txt)"
  grep -q "black" err.txt && fail "a lit image was called black"
  echo "ok: render names why an image is black, and only then"
  # Cameras (issue 17): a view along the default up (the Cornell camera's
  # +y) takes another up instead of failing; messages say where the camera
  # came from.
  "$bin/render" box.rad -o up.png --width 32 --height 32 --eye 278,-500,280 --look-at 278,273,280 2> err.txt ||
    fail "render looking along y: $(cat err.txt)"
  grep -q "using up +z" err.txt || fail "no word on the up used: $(cat err.txt)"
  grep -q "camera: the Cornell box's measured camera, with --eye/--look-at/--up/--fov on top" err.txt ||
    fail "the camera's source: $(cat err.txt)"
  echo "ok: a view along the default up gets another up, and the camera's source is named"
fi
