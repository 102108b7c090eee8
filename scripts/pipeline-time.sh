#!/usr/bin/env bash
# Wall time of each stage at the paper's size, one GPU (issue 14's fixed
# costs): formfactor, solve, render of cornell_sphere --subdiv 3, each run
# three times, with formfactor's own phase times. render needs OpenImageIO,
# which the device machine lacks: it is skipped where it was not built. Run
# on the device machine:
#   . .devdeps/setup.sh && scripts/pipeline-time.sh      (logs in $OUT)
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-pipeline-out}; mkdir -p "$out"
build=${BUILD_DIR:-/tmp/build-gpu}
if [ ! -x "$build/solve" ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} > "$out/cmake.log" 2>&1
  cmake --build "$build" -j"$(nproc)" --target formfactor solve > "$out/build.log" 2>&1 || { tail -20 "$out/build.log"; exit 1; }
  cmake --build "$build" -j"$(nproc)" --target render >> "$out/build.log" 2>&1 || echo "render not built (no OpenImageIO here)" 
fi
work=$(mktemp -d)
t() { local s e; s=$(date +%s.%N); "$@"; local rc=$?; e=$(date +%s.%N); printf '%-10s %s s (rc %d)\n' "$(basename "$1")" "$(awk -v s="$s" -v e="$e" 'BEGIN { printf "%.3f", e - s }')" $rc; }
for rep in 1 2 3; do
  t "$build/formfactor" scenes/cornell_sphere.obj --subdiv 3 --backend ${BACKEND:-auto} -q -o "$work/ff" --stats "$out/ff$rep.json"
  t "$build/solve" "$work/ff" -q -o "$work/rad"
  [ -x "$build/render" ] && t "$build/render" "$work/rad" -q -o "$work/img.png"
  grep -o '"time_seconds": {[^}]*}' "$out/ff$rep.json" | head -1
done
t "$build/formfactor" --version > /dev/null
t "$build/solve" --help > /dev/null
[ -x "$build/render" ] && t "$build/render" --help > /dev/null
rm -rf "$work"
