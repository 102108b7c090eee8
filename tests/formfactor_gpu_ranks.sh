#!/bin/sh
# CUDA backend: 1 and 2 ranks sharing one GPU write identical bytes, and the
# stats show the GPU ran. Skipped (77) without a GPU.
#   formfactor_gpu_ranks.sh FORMFACTOR SCENE WORKDIR
set -eu
ff=$1 scene=$2 dir=$3
nvidia-smi -L >/dev/null 2>&1 || { echo "no GPU: skipped"; exit 77; }
mkdir -p "$dir" && cd "$dir"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
args="$scene --subdiv 2 --backend cuda -q"
mpirun --oversubscribe -n 1 "$ff" $args -o gpu1 --stats gpu1.json
mpirun --oversubscribe -n 2 "$ff" $args -o gpu2 --stats gpu2.json
cmp gpu1 gpu2 || { echo "FAIL: 1 and 2 GPU ranks differ"; exit 1; }
grep -q '"backend": "cuda"' gpu2.json || { echo "FAIL: stats do not say cuda"; exit 1; }
echo "identical bytes for 1 and 2 ranks on the GPU"
