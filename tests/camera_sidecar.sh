#!/bin/sh
# The camera sidecar <scene>.camera (render/sidecar.h): found from the
# radiosity file, not from render's current folder; another scene's camera
# of the same name is never taken silently; a scene path too long for the
# radiosity file is said, with --camera FILE; a huge camera file is refused
# unread; a sidecar outside the scene's folder is warned of.
#   camera_sidecar.sh BIN_DIR DATA_DIR WORKDIR
set -u
bin=$1 data=$2 dir=$3
rm -rf "$dir" && mkdir -p "$dir" && cd "$dir" || exit 1
export OMP_NUM_THREADS=2
fail() { echo "FAIL: $*"; exit 1; }
cam_a='eye 2 1.5 3.9; look_at 2 1.2 0; up 0 1 0; fov_y 70'
cam_b='eye 1 1 3; look_at 1 1 0; up 0 1 0; fov_y 50'
render() { "$bin/render" "$@" --width 16 --height 16 --spp 1 -o "$dir/out.png"; }

# Two folders with a scenes/room.obj each: a's is the room, b's another
# room (one vertex moved), each with its own camera.
mkdir -p a/scenes b/scenes c d e
cp "$data/room.obj" "$data/room.mtl" a/scenes/
cp "$data/room.mtl" b/scenes/
awk '/^v / && !done { print "v 0.1 0 0"; done = 1; next } { print }' "$data/room.obj" > b/scenes/room.obj
cmp -s a/scenes/room.obj b/scenes/room.obj && fail "setup: b's room is a's"
echo "$cam_a" > a/scenes/room.camera
echo "$cam_b" > b/scenes/room.camera
(cd a && "$bin/formfactor" -q scenes/room.obj --subdiv 0 -o room.ff && "$bin/solve" -q room.ff -o room.rad) ||
  fail "formfactor/solve"

# 1. In the folder formfactor ran in: its sidecar, no warning.
(cd a && render room.rad) 2> err.txt || fail "render in a: $(cat err.txt)"
grep -q "camera: from scenes/room.camera, the scene's sidecar" err.txt || fail "1: sidecar not used: $(cat err.txt)"
grep -q "$cam_a" err.txt || fail "1: camera values: $(cat err.txt)"
grep -q "warning" err.txt && fail "1: warned: $(cat err.txt)"
echo "ok: in formfactor's folder, the scene's sidecar, no warning"

# 2. From a folder with another scenes/room.obj: the solved scene's camera
# (beside the radiosity file), not the other scene's.
(cd b && render ../a/room.rad) 2> err.txt || fail "render in b: $(cat err.txt)"
grep -q "camera: from ../a/scenes/room.camera, the scene's sidecar" err.txt || fail "2: wrong sidecar: $(cat err.txt)"
grep -q "$cam_a" err.txt || fail "2: camera values: $(cat err.txt)"
grep -q "names two files" err.txt || fail "2: the two candidates not named: $(cat err.txt)"
echo "ok: from another scene's folder, the solved scene's camera"

# 3. From a folder with no scene at all: found beside the radiosity file.
(cd c && render ../a/room.rad) 2> err.txt || fail "render in c: $(cat err.txt)"
grep -q "camera: from ../a/scenes/room.camera, the scene's sidecar" err.txt || fail "3: no sidecar: $(cat err.txt)"
echo "ok: from an empty folder, the sidecar beside the radiosity file"

# 4. Only another scene of that name to be found: its camera with a warning.
cp a/room.rad d/room.rad && cp -r b/scenes d/
(cd d && render room.rad) 2> err.txt || fail "render in d: $(cat err.txt)"
grep -q "warning: scenes/room.camera: the camera sidecar of scenes/room.obj, which is not the scene room.rad was solved for" err.txt ||
  fail "4: another scene's camera without a warning: $(cat err.txt)"
echo "ok: another scene's sidecar is warned of"

# 5. A sidecar without its OBJ: not used, said.
cp a/room.rad e/room.rad && mkdir e/scenes && echo "$cam_b" > e/scenes/room.camera
(cd e && render room.rad) 2> err.txt || fail "render in e: $(cat err.txt)"
grep -q "warning: scenes/room.camera: not used as the camera: its scene scenes/room.obj is not there" err.txt ||
  fail "5: a sidecar without its scene: $(cat err.txt)"
grep -q "camera: automatic framing" err.txt || fail "5: camera: $(cat err.txt)"
echo "ok: a sidecar without its OBJ is not used, and said"

# 6. A scene path of 88 bytes or more: solve and render say so, with --camera FILE.
long=scenes/$(printf '%074d' 0)  # scenes/<74 digits>/room.obj: 90 bytes
mkdir -p "a/$long" && cp "$data/room.obj" "$data/room.mtl" "a/$long/" && echo "$cam_a" > "a/$long/room.camera"
(cd a && "$bin/formfactor" -q "$long/room.obj" --subdiv 0 -o long.ff && "$bin/solve" long.ff -o long.rad) 2> err.txt ||
  fail "long: $(cat err.txt)"
grep -q "warning: long.ff: the scene path $long/room.obj is 90 bytes; the radiosity file holds at most 87" err.txt ||
  fail "6: solve says nothing: $(cat err.txt)"
(cd a && render long.rad) 2> err.txt || fail "render long: $(cat err.txt)"
grep -q "warning: long.rad: the radiosity file names no scene (a scene path of 88 bytes or more" err.txt &&
  grep -q -- "give --camera FILE" err.txt || fail "6: render says nothing: $(cat err.txt)"
echo "ok: a scene path too long for the radiosity file is said, with --camera FILE"

# 7. A huge camera file is refused unread; so is a large one given by --camera.
mv a/scenes/room.camera a/room.camera.keep
truncate -s 1G a/scenes/room.camera || fail "truncate"
(cd a && timeout 20 "$bin/render" room.rad --width 16 --height 16 --spp 1 -o "$dir/big.png") 2> err.txt &&
  fail "7: a 1 GiB sidecar accepted"
grep -q "scenes/room.camera: 1073741824 bytes; a camera file (four short lines) is at most 16384 bytes" err.txt ||
  fail "7: 1 GiB sidecar: $(cat err.txt)"
[ -e big.png ] && fail "7: an image from a refused camera"
rm a/scenes/room.camera
{ echo "$cam_a"; i=0; while [ $i -lt 400 ]; do echo "# a comment line of some fifty characters, padding"; i=$((i+1)); done; } > big.camera
(cd a && render room.rad --camera ../big.camera) 2> err.txt && fail "7: a 20 KiB --camera accepted"
grep -q "big.camera: .* bytes; a camera file (four short lines) is at most 16384 bytes" err.txt || fail "7: $(cat err.txt)"
echo "ok: camera files over 16 KiB are refused, a 1 GiB one unread"

# 8. A sidecar that is a symbolic link out of the scene's folder: used, warned of.
mv a/room.camera.keep elsewhere.camera
ln -s ../../elsewhere.camera a/scenes/room.camera
(cd a && render room.rad) 2> err.txt || fail "render symlink: $(cat err.txt)"
grep -q "warning: scenes/room.camera: the camera sidecar lies outside the scene's folder" err.txt ||
  fail "8: no warning: $(cat err.txt)"
grep -q "$cam_a" err.txt || fail "8: camera values: $(cat err.txt)"
echo "ok: a sidecar outside the scene's folder is warned of"
