#!/bin/sh
# solve --backend cuda on files of links: the shaped solve on the GPU
# (solve/shaped_cuda.cu) against the CPU's (solve/shaped.c), through the
# program, on hierarchical cornell_sphere (uniform leaves at link-tol
# 1e-2, and clusters):
#   - at --tol 1e-12 the radiosity agrees within 1e-9 of max B (the GPU
#     sweeps Jacobi, the CPU Gauss-Seidel: each stops within 1e-12 of the
#     exact B of the same operator; a point factor may round to the other
#     float where the GPU's atan2 differs in the last bit);
#   - the log and the stats say cuda, and the stats name the device;
#   - cuda twice: the same bytes;
#   - auto, these files being below its threshold: the CPU's bytes;
#   - --shape off: cuda has nothing to do, the flat bytes of cpu.
# Skipped (77) without a GPU.
#   shaped_backends.sh FORMFACTOR SOLVE RADIOSITY_CLOSE SCENE WORKDIR
set -u
ff=$1 solve=$2 close=$3 scene=$4 dir=$5
nvidia-smi -L >/dev/null 2>&1 || { echo "no GPU: skipped"; exit 77; }
mkdir -p "$dir" && cd "$dir" || exit 1
fail=0
check() { # name formfactor-options...
  name=$1
  shift
  "$ff" "$scene" --method hierarchical "$@" -q -o "$name.ff" || { echo "FAIL: $name: formfactor"; fail=1; return; }
  "$solve" "$name.ff" --tol 1e-12 --backend cpu -o "$name.cpu.rad" --stats "$name.cpu.json" 2>"$name.cpu.log" ||
    { echo "FAIL: $name: solve --backend cpu"; cat "$name.cpu.log"; fail=1; return; }
  "$solve" "$name.ff" --tol 1e-12 --backend cuda -o "$name.cuda.rad" --stats "$name.cuda.json" 2>"$name.cuda.log" ||
    { echo "FAIL: $name: solve --backend cuda"; cat "$name.cuda.log"; fail=1; return; }
  grep "shaped:" "$name.cpu.log" "$name.cuda.log"
  grep -q "shaped:.*backend cuda" "$name.cuda.log" || { echo "FAIL: $name: the log does not say cuda"; fail=1; }
  grep -q '"backend": "cuda"' "$name.cuda.json" || { echo "FAIL: $name: the stats do not say cuda"; fail=1; }
  grep -q '"device": null' "$name.cuda.json" && { echo "FAIL: $name: the stats name no device"; fail=1; }
  "$close" "$name.cpu.rad" "$name.cuda.rad" 1e-9 || { echo "FAIL: $name: cuda and cpu differ"; fail=1; }
  "$solve" "$name.ff" --tol 1e-12 --backend cuda -q -o "$name.again.rad" || { echo "FAIL: $name: cuda again"; fail=1; }
  cmp "$name.cuda.rad" "$name.again.rad" || { echo "FAIL: $name: cuda twice differs"; fail=1; }
  "$solve" "$name.ff" --tol 1e-12 --backend auto -q -o "$name.auto.rad" || { echo "FAIL: $name: auto"; fail=1; }
  cmp "$name.cpu.rad" "$name.auto.rad" || { echo "FAIL: $name: auto is not the CPU's below its threshold"; fail=1; }
  "$solve" "$name.ff" --shape off --backend cpu -q -o "$name.flat.cpu.rad" &&
    "$solve" "$name.ff" --shape off --backend cuda -q -o "$name.flat.cuda.rad" ||
    { echo "FAIL: $name: --shape off"; fail=1; return; }
  cmp "$name.flat.cpu.rad" "$name.flat.cuda.rad" || { echo "FAIL: $name: --shape off differs under cuda"; fail=1; }
}
check uniform --subdiv 3 --uniform-leaves --link-tol 1e-2
check clusters --subdiv 3 --clusters on --link-tol 3e-2
[ "$fail" -eq 0 ] && echo "the shaped solve on the GPU agrees with the CPU's"
exit "$fail"
