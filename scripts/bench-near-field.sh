#!/usr/bin/env bash
# Issue 29 on the device machine, in one go: build (Release), the GPU and
# form-factor tests, then the cost per pair of real meshes against the
# 2944-patch cornell_sphere, on the GPU and on the CPU, for this tree and
# (where OLD_SRC names a tarball of an older tree, e.g. main before the
# change: git archive --prefix=oldsrc/ REV | gzip) for that one too.
#   . .devdeps/setup.sh && scripts/bench-near-field.sh
# STAGES picks what runs (default "build test time"); SCENES the scenes
# timed (default below); CPU_SCENES those also timed on the CPU backend;
# LIMIT the seconds one run may take (default 150); VARIANTS builds of
# this tree with other CUDA flags ("label=-DFF_CUDA_NEAR_LANES=8 ...",
# space-separated, flags joined by commas), timed on SCENES as "label". summary.txt (the
# table: patches, facing pairs, form-factor and visibility seconds, ns per
# pair), ctest.log and the build logs go to $OUT; each run's log and stats
# JSON to $WORK/runs.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-bench-out}; mkdir -p "$out"
build=${BUILD_DIR:-$PWD/build-gpu}
old_build=${OLD_BUILD_DIR:-$PWD/build-gpu-old}
work=${WORK:-/tmp/near-field}; mkdir -p "$work/runs"
stages=" ${STAGES:-build test time} "
limit=${LIMIT:-150}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
exec > >(tee -a "$out/summary.txt") 2>&1
date -u; nvidia-smi --query-gpu=name,memory.total --format=csv,noheader; nproc
corpus=tests/data/corpus
scenes=${SCENES:-"scenes/cornell_sphere.obj:3 $corpus/suzanne_table.obj:0 $corpus/text.obj:0 $corpus/torus.obj:0 $corpus/suzanne_subsurf.obj:0"}
cpu_scenes=${CPU_SCENES:-"scenes/cornell_sphere.obj:3 $corpus/suzanne_table.obj:0 $corpus/torus.obj:0"}

if [[ "$stages" == *" build "* ]]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} > "$out/cmake.log" 2>&1 ||
    { tail -30 "$out/cmake.log"; exit 1; }
  cmake --build "$build" -j"$(nproc)" --target formfactor solve test_cuda test_bvh test_near_faces test_quadrature \
    test_pair_fuzz test_hard_cases test_formfactor > "$out/build.log" 2>&1 ||
    { grep -E "error|Error" "$out/build.log" | head -30; exit 1; }
  if [ -n "${OLD_SRC:-}" ] && [ -f "$OLD_SRC" ]; then
    rm -rf "$work/oldsrc" && tar -xzf "$OLD_SRC" -C "$work"
    cmake -S "$work/oldsrc" -B "$old_build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} \
      > "$out/cmake_old.log" 2>&1 && cmake --build "$old_build" -j"$(nproc)" --target formfactor > "$out/build_old.log" 2>&1 ||
      echo "old tree: build failed (see build_old.log)"
  fi
fi

for variant in ${VARIANTS:-}; do
  [[ "$stages" == *" build "* ]] || break
  label=${variant%%=*} flags=${variant#*=}
  cmake -S . -B "$build-$label" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} \
    -DCMAKE_CUDA_FLAGS="${flags//,/ }" > "$work/cmake-$label.log" 2>&1 &&
    cmake --build "$build-$label" -j"$(nproc)" --target formfactor > "$work/build-$label.log" 2>&1 ||
    echo "variant $label: build failed"
done

if [[ "$stages" == *" test "* ]]; then
  ctest --test-dir "$build" -R "formfactor_cuda|formfactor_gpu|bvh|near_faces|quadrature|pair_fuzz|hard_cases|formfactor_cpu" \
    --output-on-failure -V > "$out/ctest.log" 2>&1
  echo "ctest rc=$?"; grep -E "tests passed|\(Failed\)|Test +#" "$out/ctest.log" | head -30
  grep -E "check failed|differ beyond|rows differ" "$out/ctest.log" | head -20
fi

# One run: label, binary, scene:subdiv, backend.
run() {
  local label=$1 bin=$2 spec=$3 backend=$4
  local scene=${spec%:*} subdiv=${spec##*:} name
  name=$(basename "$scene" .obj)_s${subdiv}_${backend}_$label
  timeout "$limit" "$bin" "$scene" --subdiv "$subdiv" --backend "$backend" --element f32 \
    --stats "$work/runs/$name.json" -o "$work/$name.ff" > "$work/runs/$name.log" 2>&1
  local rc=$?
  rm -f "$work/$name.ff"
  python3 - "$work/runs/$name.json" "$name" "$rc" <<'EOF'
import json, sys
path, name, rc = sys.argv[1], sys.argv[2], int(sys.argv[3])
try:
    d = json.load(open(path))
except Exception:
    print("%-44s rc=%d (no stats%s)" % (name, rc, ", timed out" if rc == 124 else "")); sys.exit()
def find(d, key):
    if isinstance(d, dict):
        if key in d: return d[key]
        for v in d.values():
            r = find(v, key)
            if r is not None: return r
    return None
n = find(d, "patch_count") or find(d, "patches")
pairs = (find(d, "pairs") or 0) - (find(d, "pairs_culled") or 0)
ff = find(d, "form_factors") or find(d, "kernel_seconds") or 0
vis = find(d, "visibility") or find(d, "visibility_seconds") or 0
total = find(d, "total") or 0
print("%-44s rc=%d N=%s facing pairs=%d  form factors %.3f s  visibility %.3f s  total %.3f s  %.1f ns/pair (ff+vis)  %.1f ns/pair (ff)  samples %s  rays %s  near %s" %
      (name, rc, n, pairs, ff, vis, total, 1e9 * (ff + vis) / max(pairs, 1), 1e9 * ff / max(pairs, 1),
       find(d, "samples"), find(d, "rays"), find(d, "pairs_near")))
EOF
}

if [[ "$stages" == *" time "* ]]; then
  for spec in $scenes; do
    run new "$build/formfactor" "$spec" cuda
    [ -x "$old_build/formfactor" ] && run old "$old_build/formfactor" "$spec" cuda
    for variant in ${VARIANTS:-}; do
      label=${variant%%=*}
      [ -x "$build-$label/formfactor" ] && run "$label" "$build-$label/formfactor" "$spec" cuda
    done
  done
  for spec in $cpu_scenes; do
    run new "$build/formfactor" "$spec" cpu
    [ -x "$old_build/formfactor" ] && run old "$old_build/formfactor" "$spec" cpu
  done
fi
