#!/bin/sh
# Occlusion culling changes nothing but the work: byte-identical matrices
# with --cull all and --cull none, and the counts add up
# (rays without culling = rays with culling + rays saved). CPU backend: it
# applies both rules (the GPU only the convex-scene one; scripts/bench-gpu.sh).
#   formfactor_cull.sh FORMFACTOR SCENES_DIR WORKDIR
set -eu
ff=$1 scenes=$2 dir=$3
mkdir -p "$dir" && cd "$dir"
export OMP_NUM_THREADS=2
field() { grep -o "\"$2\": [0-9]*" "$1" | head -1 | sed 's/.*: //'; }
for case in closed_box:1 cornell_box:2 cornell_sphere:2 cluttered_room:1; do
  scene=${case%%:*} subdiv=${case##*:}
  for c in all none; do
    "$ff" "$scenes/$scene.obj" --backend cpu --subdiv "$subdiv" --samples 64 --cull $c -q -o "$scene.$c" --stats "$scene.$c.json"
  done
  cmp "$scene.all" "$scene.none" || { echo "FAIL: $scene differs with culling"; exit 1; }
  rays_all=$(field "$scene.all.json" rays) saved=$(field "$scene.all.json" rays_saved)
  rays_none=$(field "$scene.none.json" rays)
  [ "$rays_none" -eq $((rays_all + saved)) ] || { echo "FAIL: $scene: $rays_none != $rays_all + $saved"; exit 1; }
  [ "$(field "$scene.none.json" rays_saved)" -eq 0 ] || { echo "FAIL: $scene: --cull none saved rays"; exit 1; }
  echo "$scene: identical; $saved of $rays_none shadow rays culled"
done
# A single convex room needs no shadow ray at all.
[ "$(field closed_box.all.json rays)" -eq 0 ] || { echo "FAIL: closed box traced rays"; exit 1; }
[ "$(field closed_box.all.json pairs_open_scene)" -gt 0 ] || { echo "FAIL: closed box not seen as convex"; exit 1; }
# The Cornell box is not convex (its blocks), but some pairs have nothing between them.
[ "$(field cornell_box.all.json pairs_open_scene)" -eq 0 ] || { echo "FAIL: Cornell box taken for convex"; exit 1; }
[ "$(field cornell_box.all.json pairs_open_box)" -gt 0 ] || { echo "FAIL: no pair culled in the Cornell box"; exit 1; }
# With --target-error the batches a pair takes depend on its error, which
# culling leaves unchanged too (Monte Carlo estimator): identical bytes,
# errors included, and counts that add up.
for c in all none; do
  "$ff" "$scenes/cornell_box.obj" --backend cpu --subdiv 1 --samples 32 --target-error 0.003 --estimator auto \
    --cull $c -q -o target.$c --errors target.$c.err --stats target.$c.json
done
cmp target.all target.none && cmp target.all.err target.none.err || { echo "FAIL: --target-error differs with culling"; exit 1; }
# The quadrature estimator: the same matrix. Its errors differ where
# culling proves a pair unblocked (exactly 1 visible, error 0) while its
# traced rays, all unblocked, only bound the hidden part by one ray's share.
for c in all none; do
  "$ff" "$scenes/cornell_box.obj" --backend cpu --subdiv 1 --target-error 0.003 --cull $c -q -o quad.$c
done
cmp quad.all quad.none || { echo "FAIL: --target-error (quadrature) differs with culling"; exit 1; }
[ "$(field target.none.json rays)" -eq $(($(field target.all.json rays) + $(field target.all.json rays_saved))) ] ||
  { echo "FAIL: --target-error: rays do not add up"; exit 1; }
echo "--target-error: identical with and without culling"
# Far from the origin (the Cornell box moved 1 km): the backends compute in
# a frame centred on the scene, so float shadow rays stay as precise as
# near the origin and culling still changes nothing (R = 128: the hull).
awk '$1 == "v" { printf "v %.6f %.6f %.6f\n", $2 + 1e6, $3 + 7e5, $4 - 1.3e6; next } { print }' \
  "$scenes/cornell_box.obj" > far.obj
cp "$scenes/cornell_box.mtl" .
for c in all none; do
  "$ff" far.obj --backend cpu --subdiv 2 --samples 128 --shadow-rays 128 --cull $c -q -o far.$c --stats far.$c.json
done
cmp far.all far.none || { echo "FAIL: culling changed the far scene"; exit 1; }
[ "$(field far.all.json rays_saved)" -gt 0 ] || { echo "FAIL: nothing culled in the far scene"; exit 1; }
echo "far scene (1 km from the origin): identical with and without culling"
