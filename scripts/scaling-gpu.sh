#!/usr/bin/env bash
# The four-GPU study (issue 28) in one call: build, tests, the targets'
# own bandwidth, strong scaling at N = 47 104 and 188 416 and weak scaling
# on 1, 2 and 4 GPUs - formfactor (to /dev/shm and to the local disk),
# solve, and scene to radiosity - with byte identity across GPU counts
# checked in the same run. One MPI rank per GPU, cornell_sphere, the
# default estimator (quadrature), --element f32.
#
#   . .devdeps/setup.sh && scripts/scaling-gpu.sh
#
# Writes study.md (the tables) under $OUT (default ./scaling-out) and,
# beside it, study.tgz: results.tsv (one line per run), the stats JSON and
# the logs (the device machine returns only a few files).
# Settings (environment):
#   GPUS="1 2 4"     GPU counts (default: 1, 2, 4 up to the GPUs present)
#   STRONG="5 6"     --subdiv of the strong-scaling runs (N = 46 x 4^s: 47 104, 188 416)
#   WEAK_SUBDIV=5    --subdiv of the weak-scaling scenes ("" skips them)
#   DISK_SUBDIVS="5 6", DISK_GPUS="1 4"   which runs also write to the local disk
#   SHM=/dev/shm, DISK=/tmp/scaling-disk   where the matrices go
#   TESTS=1          build everything and run ctest -L gpu and the MPI tests first
#   BACKEND=cuda     (cpu: a dry run of the script on a machine without GPUs)
#   BUILD=1          0: use the build in BUILD_DIR as it is
#   MEM=1            also time scene to radiosity in memory (formfactor --radiosity) at each P
#   SOLVE_RANKS="2 4"  also time mpirun -n K solve --backend cpu at the smallest strong N
#   DD_MIB=4096      bytes each bandwidth measurement writes
#   RUN_TIMEOUT=120  seconds one run may take
#
# Weak scaling keeps the pairs per GPU fixed: N grows with sqrt(P). A
# --subdiv step multiplies N by 4 (P by 16), so the scenes are
# cornell_sphere with other sphere tessellations (scenes/make_cornell_sphere.py:
# N = (6 + S B) 4^s): S x B = 9 x 5, 11 x 6, 12 x 8 give 51, 72, 102 faces,
# N = 52 224, 73 728, 104 448 at --subdiv 5 - exactly N1, 1.412 N1 and
# 2 N1 (P = 2: 0.35 % fewer pairs per GPU than P = 1; P = 4 exact).
set -uo pipefail
cd "$(dirname "$0")/.."
root=$PWD
out=${OUT:-scaling-out}; mkdir -p "$out"; out=$(cd "$out" && pwd)
build=${BUILD_DIR:-/tmp/build-gpu}
backend=${BACKEND:-cuda}
shm=${SHM:-/dev/shm}/scaling-$$; disk=${DISK:-/tmp/scaling-disk}
mkdir -p "$shm" "$disk"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
exec > >(tee -a "$out/log.txt") 2>&1
trap 'rm -rf "$shm" "$disk"' EXIT
ngpu=$(nvidia-smi -L 2>/dev/null | wc -l)
if [ "$backend" = cuda ]; then
  [ "$ngpu" -gt 0 ] || { echo "no GPU"; exit 1; }
  card=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -1)
else
  card="CPU ($(nproc) cores)"
fi
if [ -z "${GPUS:-}" ]; then GPUS=""; for p in 1 2 4; do [ $p -le "${ngpu:-0}" ] && GPUS="$GPUS $p"; done; fi
GPUS=${GPUS# }; pmax=${GPUS##* }
date -u; echo "$card x $ngpu; $(nproc) cores; $(free -g | awk '/Mem/ {print $2}') GB memory"; uname -r
df -hT "$shm" "$disk" | sed 's/^/    /'

# --- build and tests
if [ "${BUILD:-1}" = 1 ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=${CUDA_ARCH:-90} -DRAD_WITH_RENDER=OFF \
    > "$out/cmake.log" 2>&1 || { tail -30 "$out/cmake.log"; exit 1; }
  targets="--target formfactor solve radiosity_agree"; [ "${TESTS:-1}" = 1 ] && targets=""
  t0=$(date +%s)
  cmake --build "$build" -j"$(nproc)" $targets > "$out/build.log" 2>&1 || { grep -E "error" "$out/build.log" | head -30; exit 1; }
  echo "build: $(( $(date +%s) - t0 )) s"
fi
ff=$build/formfactor solve=$build/solve
if [ "${TESTS:-1}" = 1 ]; then
  t0=$(date +%s)
  ctest --test-dir "$build" -L gpu -j4 --timeout 150 --output-on-failure > "$out/ctest_gpu.log" 2>&1
  echo "ctest -L gpu: rc=$? ($(( $(date +%s) - t0 )) s)"; grep -E "tests passed|\(Failed\)|\*\*\*Failed|Not Run" "$out/ctest_gpu.log"
  t0=$(date +%s)
  # The writes on this machine's file systems, and the MPI runs of solve
  # (TEST_REGEX for more; the CPU tests run in CI).
  ctest --test-dir "$build" -R "${TEST_REGEX:-formfactor_write|formfactor_ranks|solve_mpi|stats_json}" -LE gpu -j8 --timeout 150 \
    --output-on-failure > "$out/ctest_more.log" 2>&1
  echo "ctest (more): rc=$? ($(( $(date +%s) - t0 )) s)"; grep -E "tests passed|\(Failed\)|\*\*\*Failed|Not Run" "$out/ctest_more.log"
fi

limit=${RUN_TIMEOUT:-120} # seconds any one run may take (a hung run must not eat the call)
now() { date +%s.%N; }
since() { awk -v s="$1" -v e="$(now)" 'BEGIN { printf "%.3f", e - s }'; }
results=$out/results.tsv
printf 'kind\tname\tN\tP\tdest\tmethod\twall\tsync\tjson\tsame\n' > "$results"
record() { printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$@" >> "$results"; }
field() { grep -o "\"$2\": [0-9]*" "$1" | head -1 | sed 's/.*: //'; }

# --- the targets' own bandwidth: dd with fdatasync, one stream and four at once
# (four files, and one file at four offsets: what four ranks writing one
# file meet), DD_MIB MiB in all each time.
mib=${DD_MIB:-4096}
dd_rate() { # label, dir, streams, one_file (0|1)
  local label=$1 dir=$2 k=$3 one=$4 each=$((mib / $3)) s pids=""
  rm -f "$dir"/dd.*; sync
  s=$(now)
  for i in $(seq 0 $((k - 1))); do
    if [ "$one" = 1 ]; then
      dd if=/dev/zero of="$dir/dd.0" bs=1M count=$each seek=$((i * each)) conv=notrunc,fdatasync 2>/dev/null &
    else
      dd if=/dev/zero of="$dir/dd.$i" bs=1M count=$each conv=fdatasync 2>/dev/null &
    fi
    pids="$pids $!"
  done
  wait $pids
  local t; t=$(since "$s")
  rm -f "$dir"/dd.*
  local rate; rate=$(awk -v b=$((mib * 1048576)) -v t="$t" 'BEGIN { printf "%.2f", b / t / 1e9 }')
  echo "dd $label: $mib MiB in $t s: $rate GB/s"
  record dd "$label" 0 "$k" "$dir" "$one" "$t" 0 - "$rate"
}
dd_rate "shm, 1 stream" "$shm" 1 0
dd_rate "shm, 4 streams, 4 files" "$shm" 4 0
dd_rate "shm, 4 streams, one file" "$shm" 4 1
dd_rate "disk, 1 stream" "$disk" 1 0
dd_rate "disk, 4 streams, 4 files" "$disk" 4 0

# --- runs
# ff NAME SCENE ARGS P DEST [METHOD]: one formfactor run, timed (process wall)
ff_run() {
  local name=$1 scene=$2 args=$3 p=$4 dest=$5 method=${6:-auto} env=""
  [ "$method" = pwrite ] && env="RAD_FF_WRITE=pwrite"
  rm -f "$dest/$name"
  local s; s=$(now)
  env $env timeout "$limit" mpirun -n "$p" --bind-to none "$ff" "$scene" $args --element f32 --backend "$backend" -q \
    -o "$dest/$name" --stats "$out/$name.json" > "$out/$name.log" 2>&1 || echo "FAILED: $name: $(tail -3 "$out/$name.log")"
  wall=$(since "$s")
}
# same FILE REF: "yes" when the bytes are the same
same() { if [ "$1" = "$2" ]; then echo ref; elif cmp -s "$1" "$2"; then echo yes; else echo NO; fi; }

scene=scenes/cornell_sphere.obj
first=""
for s in ${STRONG-5 6}; do
  [ -z "$first" ] && first=$s
  n=$((46 * 4 ** s))
  echo "--- strong scaling, cornell_sphere --subdiv $s (N = $n)"
  ref=$shm/ff$s.p1 rref=$shm/rad$s.p1
  for p in $GPUS; do
    # formfactor to memory, then solve on as many GPUs from it: scene to radiosity
    ff_run "ff$s.p$p" $scene "--subdiv $s" "$p" "$shm"
    ffwall=$wall
    sm=$(same "$shm/ff$s.p$p" "$ref")
    record ff "ff$s.p$p" "$n" "$p" shm auto "$ffwall" 0 "ff$s.p$p.json" "$sm"
    sb=cpu; [ "$backend" = cuda ] && sb=cuda
    st=$(now)
    timeout "$limit" mpirun -n "$p" --bind-to none "$solve" "$shm/ff$s.p$p" -q -o "$shm/rad$s.p$p" --backend $sb \
      --stats "$out/solve$s.p$p.json" > "$out/solve$s.p$p.log" 2>&1 || echo "FAILED: solve $s $p: $(tail -3 "$out/solve$s.p$p.log")"
    swall=$(since "$st")
    rs=$(same "$shm/rad$s.p$p" "$rref")
    [ "$rs" = NO ] && "$build/tests/radiosity_agree" "$ref" "$rref" "$shm/rad$s.p$p" > /dev/null 2>&1 && rs="no, agree"
    record solve "solve$s.p$p" "$n" "$p" shm "$sb" "$swall" 0 "solve$s.p$p.json" "$rs"
    echo "P=$p: formfactor $ffwall s (bytes vs 1 GPU: $sm), solve $swall s (radiosity vs 1 GPU: $rs)"
    if [ "${MEM:-1}" = 1 ]; then
      # scene to radiosity without the file: formfactor --radiosity (the log keeps the solve's lines)
      st=$(now)
      timeout "$limit" mpirun -n "$p" --bind-to none "$ff" $scene --subdiv $s --element f32 --backend "$backend" \
        --radiosity "$shm/mem$s.p$p" --stats "$out/mem$s.p$p.json" > "$out/mem$s.p$p.log" 2>&1 ||
        echo "FAILED: --radiosity $s $p: $(tail -3 "$out/mem$s.p$p.log")"
      mwall=$(since "$st")
      ms=$(same "$shm/mem$s.p$p" "$rref")
      [ "$ms" = NO ] && "$build/tests/radiosity_agree" "$ref" "$rref" "$shm/mem$s.p$p" > /dev/null 2>&1 && ms="no, agree"
      record mem "mem$s.p$p" "$n" "$p" shm "$backend" "$mwall" 0 "mem$s.p$p.json" "$ms"
      echo "P=$p: formfactor --radiosity $mwall s (radiosity vs the two stages on 1 GPU: $ms)"
      rm -f "$shm/mem$s.p$p"
    fi
    [ $p = 1 ] || rm -f "$shm/ff$s.p$p"
  done
  # pwrite instead of a mapping, at the most GPUs: the same bytes, and what the mapping buys
  ff_run "ff$s.p$pmax.pwrite" $scene "--subdiv $s" "$pmax" "$shm" pwrite
  sm=$(same "$shm/ff$s.p$pmax.pwrite" "$ref")
  record ff "ff$s.p$pmax.pwrite" "$n" "$pmax" shm pwrite "$wall" 0 "ff$s.p$pmax.pwrite.json" "$sm"
  echo "P=$pmax, RAD_FF_WRITE=pwrite: $wall s (bytes: $sm)"
  rm -f "$shm/ff$s.p$pmax.pwrite"
  # to the local disk: the wall, then the sync that makes it durable
  case " ${DISK_SUBDIVS-5 6} " in *" $s "*)
    for p in ${DISK_GPUS-1 $pmax}; do
      sync
      ff_run "ffdisk$s.p$p" $scene "--subdiv $s" "$p" "$disk"
      ffwall=$wall
      sy=$(now); sync; sw=$(since "$sy")
      sm=$(same "$disk/ffdisk$s.p$p" "$ref")
      record ff "ffdisk$s.p$p" "$n" "$p" disk auto "$ffwall" "$sw" "ffdisk$s.p$p.json" "$sm"
      echo "P=$p to the disk: $ffwall s + sync $sw s (bytes: $sm)"
      rm -f "$disk/ffdisk$s.p$p"
    done ;;
  esac
  if [ "$s" = "$first" ]; then
    for k in ${SOLVE_RANKS-2 4}; do
      st=$(now)
      timeout "$limit" mpirun -n $k --bind-to none "$solve" "$ref" -q -o "$shm/radcpu$s.$k" --backend cpu --stats "$out/solvecpu$s.k$k.json" \
        > "$out/solvecpu$s.k$k.log" 2>&1 || echo "FAILED: mpirun -n $k solve"
      sw=$(since "$st")
      agree=$("$build/tests/radiosity_agree" "$ref" "$rref" "$shm/radcpu$s.$k" 2>&1 | tail -1)
      record solvecpu "solvecpu$s.k$k" "$n" "$k" shm cpu "$sw" 0 "solvecpu$s.k$k.json" "agree"
      echo "mpirun -n $k solve --backend cpu: $sw s ($agree)"
      rm -f "$shm/radcpu$s.$k"
    done
  fi
  rm -f "$ref" "$rref" "$shm"/rad$s.p*
done

if [ -n "${WEAK_SUBDIV-5}" ]; then
  ws=${WEAK_SUBDIV-5}
  echo "--- weak scaling: pairs per GPU fixed, --subdiv $ws"
  for p in $GPUS; do
    case $p in 1) sb="9 5" ;; 2) sb="11 6" ;; 4) sb="12 8" ;; *) echo "weak: no scene for P=$p"; continue ;; esac
    set -- $sb
    python3 scenes/make_cornell_sphere.py --segments $1 --bands $2 --name weak$p "$shm" || continue
    n=$(((6 + $1 * $2) * 4 ** ws))
    ff_run "weak$ws.p$p" "$shm/weak$p.obj" "--subdiv $ws" "$p" "$shm"
    record weak "weak$ws.p$p" "$n" "$p" shm auto "$wall" 0 "weak$ws.p$p.json" "-"
    echo "P=$p: N = $n ($1 x $2 sphere), $wall s"
    rm -f "$shm/weak$ws.p$p"
  done
fi

# --- the tables
python3 - "$results" "$out" "$card" "$ngpu" <<'PY' > "$out/study.md"
import json, os, sys
results, out, card, ngpu = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
rows = [l.rstrip("\n").split("\t") for l in open(results)][1:]
def load(name):
    try:
        return json.load(open(os.path.join(out, name)))
    except Exception:
        return {}
def t(j, key):
    return j.get("time_seconds", {}).get(key, float("nan"))
dd = {r[1]: float(r[9]) for r in rows if r[0] == "dd"}
print("# The four-GPU study (issue 28): %s x %s" % (card, ngpu))
print()
print("`scripts/scaling-gpu.sh`; cornell_sphere, default estimator, `--element f32`, one rank per GPU "
      "(`mpirun -n P --bind-to none`). Walls are the process's (mpirun included); phases are the slowest "
      "rank's (`--stats`). I/O: what the ranks waited for their writes (the rest is behind the kernels); "
      "write: the writes in flight.")
print()
print("## The targets' bandwidth (dd, conv=fdatasync)")
print()
print("| target | GB/s |")
print("|---|---|")
for k, v in dd.items():
    print("| %s | %.2f |" % (k, v))
ffs = [r for r in rows if r[0] == "ff" and r[4] == "shm" and r[5] == "auto"]
ns = sorted({int(r[2]) for r in ffs})
def fmt(xs, f="%.2f"):
    return " / ".join(f % x for x in xs)
print()
print("## Strong scaling, formfactor to /dev/shm (the paper's form)")
print()
print("| N | GPUs | formfactor wall | start (load, mesh, setup, CUDA) | form factors | visibility | GPU→host | I/O | write (in flight) | GB written | write rate | speed-up | same bytes |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for n in ns:
    rs = sorted((r for r in ffs if int(r[2]) == n), key=lambda r: int(r[3]))
    js = [load(r[8]) for r in rs]
    walls = [float(r[6]) for r in rs]
    gb = [j.get("written_bytes", 0) / 1e9 for j in js]
    rate = [g / max(t(j, "write"), 1e-9) for g, j in zip(gb, js)]
    start = [t(j, "load") + t(j, "subdivide") + t(j, "setup") + t(j, "cuda_start") for j in js]
    print("| %d | %s | %s s | %s | %s | %s | %s | %s | %s | %s | %s GB/s | %s | %s |" % (
        n, " / ".join(r[3] for r in rs), fmt(walls), fmt(start), fmt([t(j, "form_factors") for j in js]),
        fmt([t(j, "visibility") for j in js]), fmt([t(j, "gpu_memory") for j in js]), fmt([t(j, "io") for j in js]),
        fmt([t(j, "write") for j in js]), fmt(gb, "%.1f"), fmt(rate, "%.1f"),
        fmt([walls[0] / w for w in walls]), " / ".join(r[9] for r in rs)))
pw = [r for r in rows if r[0] == "ff" and r[5] == "pwrite"]
if pw:
    print()
    print("pwrite instead of a mapping (`RAD_FF_WRITE=pwrite`), the most GPUs, /dev/shm:")
    print()
    print("| N | GPUs | wall (map) | wall (pwrite) | write in flight (map / pwrite) | same bytes |")
    print("|---|---|---|---|---|---|")
    for r in pw:
        m = [x for x in ffs if x[2] == r[2] and x[3] == r[3]]
        jm, jp = (load(m[0][8]) if m else {}), load(r[8])
        print("| %s | %s | %s s | %s s | %.2f / %.2f s | %s |" % (r[2], r[3], m[0][6] if m else "-", r[6],
              t(jm, "write"), t(jp, "write"), r[9]))
dk = [r for r in rows if r[0] == "ff" and r[4] == "disk"]
if dk:
    print()
    print("## formfactor to the local disk")
    print()
    print("| N | GPUs | wall | sync after | wall + sync | GB | the disk's time for the bytes (dd, 1 stream) | ratio | same bytes |")
    print("|---|---|---|---|---|---|---|---|---|")
    rate = dd.get("disk, 1 stream", float("nan"))
    for r in dk:
        j = load(r[8]); gb = j.get("written_bytes", 0) / 1e9
        wall, sy = float(r[6]), float(r[7])
        print("| %s | %s | %.2f s | %.2f s | %.2f s | %.1f | %.2f s | %.2f | %s |" % (
            r[2], r[3], wall, sy, wall + sy, gb, gb / rate, (wall + sy) / (gb / rate), r[9]))
sv = [r for r in rows if r[0] == "solve"]
if sv:
    print()
    print("## solve on P GPUs (`mpirun -n P solve --backend cuda`), and scene → radiosity (formfactor, then solve, on P GPUs)")
    print()
    print("| N | GPUs | solve wall | solve load (rank 0) | solve upload | solve speed-up | scene → radiosity | speed-up | radiosity, same bytes |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in ns:
        rs = sorted((r for r in sv if int(r[2]) == n), key=lambda r: int(r[1].rsplit("p", 1)[1]))
        fr = {r[3]: float(r[6]) for r in ffs if int(r[2]) == n}
        e2e = []
        for r in rs:
            p = r[1].rsplit("p", 1)[1]
            e2e.append(fr.get(p, float("nan")) + float(r[6]))
        loads = [load(r[8]).get("load_seconds", float("nan")) for r in rs]
        ups = [load(r[8]).get("upload_seconds", float("nan")) for r in rs]
        sw = [float(r[6]) for r in rs]
        print("| %d | %s | %s s | %s s | %s s | %s | %s s | %s | %s |" % (n, " / ".join(r[1].rsplit("p", 1)[1] for r in rs),
              fmt(sw), fmt(loads), fmt(ups), fmt([sw[0] / w for w in sw]), fmt(e2e), fmt([e2e[0] / e for e in e2e]),
              " / ".join(r[9] for r in rs)))
mm = [r for r in rows if r[0] == "mem"]
if mm:
    print()
    print("## Scene → radiosity without the file (`mpirun -n P formfactor --radiosity`, one GPU per rank)")
    print()
    print("| N | GPUs | wall | speed-up | the two stages through /dev/shm | in memory vs two stages | radiosity, same bytes as the two stages on one GPU |")
    print("|---|---|---|---|---|---|---|")
    for n in ns:
        rs = sorted((r for r in mm if int(r[2]) == n), key=lambda r: int(r[3]))
        if not rs: continue
        fr = {r[3]: float(r[6]) for r in ffs if int(r[2]) == n}
        so = {r[1].rsplit("p", 1)[1]: float(r[6]) for r in sv if int(r[2]) == n}
        two = [fr.get(r[3], float("nan")) + so.get(r[3], float("nan")) for r in rs]
        mw = [float(r[6]) for r in rs]
        print("| %d | %s | %s s | %s | %s s | %s | %s |" % (n, " / ".join(r[3] for r in rs), fmt(mw),
              fmt([mw[0] / w for w in mw]), fmt(two), fmt([t2 / w for t2, w in zip(two, mw)]),
              " / ".join(r[9] for r in rs)))
sc = [r for r in rows if r[0] == "solvecpu"]
if sc:
    print()
    print("`mpirun -n K solve --backend cpu` (rows split over CPU ranks, for reference): " +
          ", ".join("N = %s, K = %s: %s s" % (r[2], r[3], r[6]) for r in sc))
wk = [r for r in rows if r[0] == "weak"]
if wk:
    print()
    print("## Weak scaling (pairs per GPU fixed: N grows with √P)")
    print()
    print("| GPUs | N | pairs per GPU (vs 1) | formfactor wall | start (load, mesh, setup, CUDA) | form factors | visibility | GPU→host | I/O | efficiency (wall) | kernel time per GPU (vs 1) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    base = None
    for r in sorted(wk, key=lambda r: int(r[3])):
        j = load(r[8]); n, p, wall = int(r[2]), int(r[3]), float(r[6])
        k = t(j, "form_factors") + t(j, "visibility")
        per = n * n / p
        if base is None: base = (per, wall, k)
        start = t(j, "load") + t(j, "subdivide") + t(j, "setup") + t(j, "cuda_start")
        print("| %d | %d | %.4f | %.2f s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |" % (
            p, n, per / base[0], wall, start, t(j, "form_factors"), t(j, "visibility"), t(j, "gpu_memory"),
            t(j, "io"), base[1] / wall * per / base[0], k / base[2]))
    print()
    print("The scenes differ in their sphere (more, smaller sphere faces as P grows), so the work per pair is "
          "not the same: where the kernel time per GPU falls below 1, the wall efficiency flatters.")
PY
cat "$out/study.md"
# The device returns few files: everything in one archive, the table beside it.
tar czf /tmp/scaling-study.tgz -C "$out" . && find "$out" -type f ! -name study.md -delete &&
  mv /tmp/scaling-study.tgz "$out/study.tgz"
