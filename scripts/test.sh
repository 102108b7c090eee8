#!/usr/bin/env bash
# The test command of the README: configure, build (warnings are errors),
# and run the whole CTest suite. GPU tests skip themselves without a GPU.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD_DIR:-build}
cmake -S . -B "$build" -DRAD_WERROR=ON >/dev/null
cmake --build "$build" -j"$(nproc)"
# mpirun refuses root unless told (CI and the GPU machine run as root).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
ctest --test-dir "$build" --output-on-failure -j"$(nproc)" "$@"
