#!/usr/bin/env bash
# The README's first command: install, build, and run the pipeline on the
# built-in Cornell box with no flags.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build >/dev/null
cmake --build build -j"$(nproc)"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# The built-in Cornell box by hierarchical radiosity (docs/hierarchy.md):
# every face split to level 5 (29 696 leaves), linked at the coarsest
# levels whose error meets --link-tol 1e-2, solved in memory
# (--radiosity); about 1.5 s on 2 cores, 2.5 s with render, and the image within 2.1 % RMS of a
# path tracer's (docs/accuracy.md, "The Cornell box in the time": the
# refined full matrix below, 2.2 %, takes 15 s). The unoccluded factors to
# 1e-5 and 8 shadow rays a partly hidden pair: the links' own tolerance is
# 1e-2. The alternatives:
#   ./scripts/refine.sh --build build --out build/refine    # the refined full matrix
#   build/formfactor --subdiv 3 && build/solve && build/render   # the plain pipeline
build/formfactor --method hierarchical --uniform-leaves --quad-rtol 1e-5 --shadow-rays 8 \
  --radiosity build/cornell_box.rad
if [ -x build/render ]; then
  build/render build/cornell_box.rad --spp 64 -o build/cornell_box.png
  build/render build/cornell_box.rad --spp 64 --quantity radiance -o build/cornell_box.exr
fi
ls -l build/cornell_box.* 2>/dev/null || true
