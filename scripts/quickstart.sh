#!/usr/bin/env bash
# The README's first command: install, build, and run the pipeline on the
# built-in Cornell box with no flags.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build >/dev/null
cmake --build build -j"$(nproc)"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cd build
# The built-in Cornell box; --subdiv 3 (1280 patches, ~2 s on 2 cores) for a
# smooth picture; without it each face is a single patch.
# --errors: each entry's standard error beside the matrix, so that solve
# warns about a row sum only beyond what the shadow rays' noise explains.
./formfactor --subdiv 3 --errors formfactors.err   # -> build/formfactors
./solve --errors formfactors.err                   # -> build/radiosity
if [ -x ./render ]; then ./render -o cornell_box.png && ./render -o cornell_box.exr; fi
ls -l formfactors radiosity cornell_box.* 2>/dev/null || true
