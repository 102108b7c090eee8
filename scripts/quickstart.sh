#!/usr/bin/env bash
# The README's first command: install, build, and run the pipeline on the
# built-in Cornell box with no flags.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build >/dev/null
cmake --build build -j"$(nproc)"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# The built-in Cornell box, refined where the light changes: a coarse
# solve (--subdiv 2), then passes of formfactor --refine that split the
# patches where the solution says the mesh is too coarse (shadow edges,
# corners, contact lines), each solved again, up to 2400 patches; about 15 s
# on 2 cores (docs/accuracy.md: within 0.1 % of a path tracer's mean).
# scripts/refine.sh --help says what it runs; the plain pipeline is
#   build/formfactor --subdiv 3 && build/solve && build/render
./scripts/refine.sh --build build --out build/refine
if [ -x build/render ]; then
  build/render build/refine/radiosity --spp 64 -o build/cornell_box.png
  build/render build/refine/radiosity --spp 64 --quantity radiance -o build/cornell_box.exr
fi
ls -l build/refine/radiosity build/cornell_box.* 2>/dev/null || true
