#!/usr/bin/env bash
# Strong and weak scaling over the GPUs of one host, one MPI rank per GPU,
# the paper's sampling. One call does it all (build, runs, byte checks,
# table):   . .devdeps/setup.sh && scripts/scaling-gpu.sh
# Writes scaling.md and the stats JSON under $OUT (default ./scaling-out),
# packed into scaling.tgz. GPUS="1 2 4 8" picks the counts (default: 1, 2,
# 4, 8 up to the GPUs present). DEST is where the matrices are written
# (default /dev/shm when it has room, so the disk does not hide the scaling).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-scaling-out}; mkdir -p "$out"
build=${BUILD_DIR:-/tmp/build-gpu}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
ngpu=$(nvidia-smi -L 2>/dev/null | wc -l)
[ "$ngpu" -gt 0 ] || { echo "no GPU"; exit 1; }
if [ -z "${GPUS:-}" ]; then GPUS=""; for p in 1 2 4 8; do [ $p -le "$ngpu" ] && GPUS="$GPUS $p"; done; fi
dest=${DEST:-/dev/shm}; [ -d "$dest" ] && [ "$(df -Pk "$dest" | awk 'NR==2{print $4}')" -gt 20000000 ] || dest=/tmp
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} -DRAD_WITH_RENDER=OFF > "$out/cmake.log" 2>&1 &&
  cmake --build "$build" -j"$(nproc)" --target formfactor > "$out/build.log" 2>&1 || { tail -20 "$out/build.log"; exit 1; }
ff="$build/formfactor"; scene=scenes/cornell_sphere.obj
t() { grep -o "\"$2\": [0-9.e+-]*" "$1" | head -1 | sed 's/.*: //'; }
row() { # label json base_json
  local j=$1 b=$2
  printf "| %s | %s | %s | %s | %s | %s | %s |\n" "$3" "$(t $j form_factors)" "$(t $j visibility)" "$(t $j gpu_memory)" "$(t $j io)" "$(t $j total)" \
    "$(awk -v a="$(t $b total)" -v c="$(t $j total)" -v k1="$(t $b form_factors)" -v k2="$(t $j form_factors)" 'BEGIN{printf "%.2f / %.2f", k1/k2, a/c}')"
}
{
echo "# GPU scaling ($(nvidia-smi --query-gpu=name --format=csv,noheader | head -1), $ngpu GPUs, $(date -u +%F))"
echo; echo "Matrices written to $dest. Columns in seconds, slowest rank; speed-up = sampling / total against 1 GPU."
echo; echo "## Strong scaling: cornell_sphere --subdiv 5 (N = 47 104), float32, 512 pairs + 32 rays"
echo; echo "| GPUs | GPU compute | occlusion | GPU memory | I/O | total | speed-up |"; echo "|---|---|---|---|---|---|---|"
} > "$out/scaling.md"
for p in $GPUS; do
  mpirun -n $p --bind-to none "$ff" $scene --subdiv 5 --element f32 --backend cuda -q -o "$dest/strong$p" --stats "$out/strong$p.json" || echo "strong $p failed"
  row "$out/strong$p.json" "$out/strong1.json" "$p" >> "$out/scaling.md"
  [ $p -gt 1 ] && { cmp "$dest/strong1" "$dest/strong$p" && echo "strong $p GPUs: identical bytes to 1 GPU" || echo "strong $p GPUs: BYTES DIFFER"; rm -f "$dest/strong$p"; }
done
rm -f "$dest/strong1"
{
echo; echo "## Weak scaling: work (pairs x samples) grows with the GPUs: cornell_sphere --subdiv 4 (N = 11 776), 512 x P pairs per patch pair"
echo; echo "| GPUs | GPU compute | occlusion | GPU memory | I/O | total | efficiency (sampling / total) |"; echo "|---|---|---|---|---|---|---|"
} >> "$out/scaling.md"
for p in $GPUS; do
  mpirun -n $p --bind-to none "$ff" $scene --subdiv 4 --samples $((512 * p)) --element f32 --backend cuda -q -o "$dest/weak$p" --stats "$out/weak$p.json" || echo "weak $p failed"
  row "$out/weak$p.json" "$out/weak1.json" "$p" >> "$out/scaling.md"
  rm -f "$dest/weak$p"
done
cat "$out/scaling.md"
tar czf /tmp/scaling.tgz -C "$out" . && find "$out" -type f -delete && mv /tmp/scaling.tgz "$out/"
