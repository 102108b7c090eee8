#!/usr/bin/env bash
# solve on the CPU against solve on the GPU (issue 14), on the device machine:
#     scripts/bench-solve-gpu.sh BUILD_DIR [SCENE]
# BUILD_DIR holds formfactor and solve built with CUDA; SCENE defaults to
# scenes/cornell_sphere.obj. For --subdiv 3, 4, 5 (N = 2944, 11776, 47104;
# SUBDIVS="3 4" for fewer) formfactor --element f32 --backend cuda makes the
# (sparse) file once, then solve runs with --backend cpu and --backend cuda
# (RUNS times each, default 2: the first cuda run pays for the CUDA context).
# F64=1 adds --element f64 files at --subdiv 3 and 4 (the refinement rounds).
# Writes logs, stats JSON and the table solve-gpu.md under $OUT (default
# ./bench-solve-out).
set -uo pipefail
build=${1:?usage: scripts/bench-solve-gpu.sh BUILD_DIR [SCENE]}
scene=${2:-$(dirname "$0")/../scenes/cornell_sphere.obj}
out=${OUT:-bench-solve-out}; mkdir -p "$out"
work=${WORK:-/tmp/bench-solve}; mkdir -p "$work"
runs=${RUNS:-2}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader > "$out/gpu.txt" 2>&1
nproc > "$out/cores.txt"

cases=""
for s in ${SUBDIVS:-3 4 5}; do cases="$cases s${s}_f32"; done
if [ "${F64:-0}" = 1 ]; then cases="$cases s3_f64 s4_f64"; fi

for c in $cases; do
  subdiv=${c#s}; subdiv=${subdiv%%_*}; element=${c#*_}
  ff="$work/$c.ff"
  if [ ! -s "$ff" ]; then
    /usr/bin/time -f "%e s wall" "$build/formfactor" "$scene" --subdiv "$subdiv" --element "$element" \
      --backend auto -q -o "$ff" > "$out/ff_$c.log" 2>&1 || { echo "$c: formfactor failed"; tail -5 "$out/ff_$c.log"; continue; }
  fi
  for backend in cpu cuda; do
    for r in $(seq 1 "$runs"); do
      /usr/bin/time -f "%e s wall, %M KiB max RSS" "$build/solve" "$ff" --backend "$backend" \
        --stats "$out/solve_${c}_${backend}_$r.json" -o "$work/$c.$backend.rad" > "$out/solve_${c}_${backend}_$r.log" 2>&1
      echo "$c $backend run $r: rc=$? $(tail -1 "$out/solve_${c}_${backend}_$r.log")"
    done
  done
  if [ -s "$work/$c.cuda.rad" ] && [ -s "$work/$c.cpu.rad" ]; then
    cmp -s "$work/$c.cpu.rad" "$work/$c.cuda.rad" && echo "$c: cpu and cuda files identical" ||
      echo "$c: cpu and cuda files differ (expected: sums in another order)"
  fi
  rm -f "$work/$c.cpu.rad" "$work/$c.cuda.rad"
done

# The table: the last run of each, from the stats files.
python3 - "$out" "$runs" $cases > "$out/solve-gpu.md" <<'EOF'
import json, os, sys
out, runs, cases = sys.argv[1], sys.argv[2], sys.argv[3:]
gpu = open(os.path.join(out, "gpu.txt")).read().strip()
print(f"# solve: --backend cpu against cuda ({gpu}; {open(os.path.join(out, 'cores.txt')).read().strip()} cores)\n")
print("| case | N | backend | method | iterations | rounds | residual | load s | upload s | solve s | total s |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for c in cases:
    for b in ("cpu", "cuda"):
        p = os.path.join(out, f"solve_{c}_{b}_{runs}.json")
        if not os.path.exists(p):
            print(f"| {c} | | {b} | (no stats) | | | | | | | |")
            continue
        s = json.load(open(p))
        ch = s["channels"]
        solve = max(x["seconds"] for x in ch)
        print(f"| {c} | {s['patch_count']} | {s.get('backend')} | {ch[0]['method']} | "
              f"{'/'.join(str(x['iterations']) for x in ch)} | {'/'.join(str(x.get('rounds', 0)) for x in ch)} | "
              f"{max(x['residual'] for x in ch):.2e} | {s['load_seconds']:.3f} | {s.get('upload_seconds', 0):.3f} | "
              f"{solve:.3f} | {s['total_seconds']:.3f} |")
print("\nsolve s: the slowest channel's solve (iterations, verification, rounds); total s: the whole stage.")
EOF
cat "$out/solve-gpu.md"
