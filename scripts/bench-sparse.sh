#!/usr/bin/env bash
# The sparse form-factor file against the dense one at growing N, on the
# device machine (issue 14), in one go:
#   . .devdeps/setup.sh && scripts/bench-sparse.sh          (logs in $OUT)
# For each size: formfactor dense and sparse (wall, phases, file size),
# solve on each (wall, load); the disk's own sequential write bandwidth
# (dd with fdatasync) in the same folder first. SUBDIVS picks the sizes
# (default "3 4 5"; --element f32 above 3); DENSE_SOLVE_MAX the largest
# subdivision whose dense file solve also reads (default 4).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-bench-out}; mkdir -p "$out"
build=${BUILD_DIR:-/tmp/build-gpu}
work=${WORK:-$PWD/bench-work}; mkdir -p "$work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
nvidia-smi --query-gpu=name,memory.total --format=csv,noheader > "$out/gpu.txt" 2>&1
nproc >> "$out/gpu.txt"
if [ ! -x "$build/solve" ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} > "$out/cmake.log" 2>&1
  cmake --build "$build" -j"$(nproc)" --target formfactor solve test_ffile test_ffile_sparse > "$out/build.log" 2>&1 ||
    { grep -E "error" "$out/build.log" | head -20; exit 1; }
fi
"$build/tests/test_ffile_sparse" > "$out/test_ffile_sparse.log" 2>&1; echo "test_ffile_sparse rc=$?"
# The disk: 4 GiB written with fdatasync, as formfactor's file would be.
dd if=/dev/zero of="$work/dd" bs=64M count=64 conv=fdatasync 2>&1 | tail -1 | tee "$out/dd.txt"
rm -f "$work/dd"
t() { # label, command...: wall seconds and max RSS
  local label=$1; shift
  /usr/bin/time -f "$label %e s wall, %M KiB max RSS" "$@" > "$out/$label.log" 2>&1
  local rc=$?; echo "$(tail -1 "$out/$label.log") rc=$rc"
}
for s in ${SUBDIVS:-3 4 5}; do
  el=""; [ "$s" -gt 3 ] && el="--element f32"
  for f in dense sparse; do
    rm -f "$work/ff"
    t "s${s}_ff_$f" "$build/formfactor" scenes/cornell_sphere.obj --subdiv $s $el --backend ${BACKEND:-cuda} --format $f \
      -o "$work/ff" --stats "$out/s${s}_ff_$f.json"
    grep -o '"time_seconds": {[^}]*}' "$out/s${s}_ff_$f.json" | head -1
    echo "  file: $(stat -c %s "$work/ff") bytes"
    sync
    if [ "$f" = sparse ] || [ "$s" -le "${DENSE_SOLVE_MAX:-4}" ]; then
      echo 3 > /proc/sys/vm/drop_caches 2>/dev/null || true
      t "s${s}_solve_$f" "$build/solve" "$work/ff" -o "$work/rad" --stats "$out/s${s}_solve_$f.json"
      grep -oE "\"(load|total)_seconds\": [0-9.e+-]+" "$out/s${s}_solve_$f.json" | tr "\n" " "; echo
    fi
  done
done
rm -rf "$work"
tar czf "$out/logs.tgz" -C "$out" --exclude logs.tgz . 2>/dev/null
