#!/bin/sh
# update_references.sh - regenerate the render image-test references, on purpose.
#
#   tests/update_references.sh [BUILD_DIR]        (default BUILD_DIR: build)
#
# Builds the three stages, runs the image tests' pipeline through CTest
# (render_image_<scene> pulls in its formfactor and solve fixtures, so the
# settings are exactly the tests'), shows how far each new picture is from
# the committed one, and copies the new pictures over tests/references/.
# Nothing else ever writes there: a failing render_idiff_* test never
# updates a reference. Look at the new images, then commit them with a note
# saying why they changed. See docs/render.md.
set -eu

here=$(cd "$(dirname "$0")" && pwd)
build=${1:-build}
if [ ! -f "$build/CMakeCache.txt" ]; then
    echo "update_references.sh: '$build' is not a configured build folder (cmake -S . -B $build)" >&2
    exit 2
fi
cmake --build "$build" --target formfactor solve render test_render
ctest --test-dir "$build" -R '^render_image_' --output-on-failure

out="$build/tests/render_images"
mkdir -p "$here/references"
for scene in cornell_box cornell_sphere; do
    new="$out/$scene.png"
    ref="$here/references/$scene.png"
    if [ -f "$ref" ]; then
        echo "== $scene: new picture against the old reference"
        idiff "$new" "$ref" || true
    fi
    cp "$new" "$ref"
    echo "updated $ref"
done
