#!/bin/sh
# CUDA backend, streamed rounds (--reciprocity off): rows finished and
# encoded on the GPU (compute_records) give the same file, byte for byte,
# as rows copied back and finished on the CPU (RAD_FF_FINISH=host), for
# f64 and f32 entries, with and without an --errors file, on 1 and 2
# ranks (the same bytes), and across several rounds of rows; the stats' row sums and error
# summary agree to 1e-12. Skipped (77) without a GPU.
#   formfactor_gpu_records.sh FORMFACTOR SCENE WORKDIR
set -eu
ff=$1 scene=$2 dir=$3
nvidia-smi -L >/dev/null 2>&1 || { echo "no GPU: skipped"; exit 77; }
mkdir -p "$dir" && cd "$dir"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fail=0
same() { # a, b, what
  if cmp -s "$1" "$2"; then echo "same bytes: $3"; else echo "FAIL: $3 differ"; fail=1; fi
}
check() { # name, errors (yes|no), extra args...
  name=$1 errors=$2; shift 2
  de="" he=""
  [ "$errors" = yes ] && de="--errors $name.dev.err" he="--errors $name.host.err"
  "$ff" "$scene" --backend cuda --reciprocity off -q "$@" -o "$name.dev" $de --stats "$name.dev.json"
  RAD_FF_FINISH=host "$ff" "$scene" --backend cuda --reciprocity off -q "$@" -o "$name.host" $he \
    --stats "$name.host.json"
  same "$name.dev" "$name.host" "$name"
  [ "$errors" = yes ] && same "$name.dev.err" "$name.host.err" "$name errors"
  grep -q '"backend": "cuda"' "$name.dev.json" || { echo "FAIL: $name stats do not say cuda"; fail=1; }
}
check s2_f64 no --subdiv 2
check s2_f32 yes --subdiv 2 --element f32
check s3_f64 yes --subdiv 3
# several rounds of rows (11776 rows of 11776 columns: rounds of about 1000)
check s4_f32 no --subdiv 4 --element f32
mpirun --oversubscribe -n 2 "$ff" "$scene" --backend cuda --reciprocity off -q --subdiv 3 -o ranks2
same s3_f64.dev ranks2 "1 and 2 ranks"
# ... and over several rounds: the ranks take blocks of rows in turn, so
# each round's write holds the rows in order (ff_plan.h)
mpirun --oversubscribe -n 2 "$ff" "$scene" --backend cuda --reciprocity off -q --subdiv 4 --element f32 -o ranks2_s4
same s4_f32.dev ranks2_s4 "1 and 2 ranks over several rounds"
cmp -s s3_f64.dev s4_f32.dev && { echo "FAIL: different runs agree (the test cannot tell)"; fail=1; }
# the stats: row sums and error summary computed on the GPU against the CPU's
python3 - s3_f64.dev.json s3_f64.host.json <<'PY' || fail=1
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
def walk(x, y, path=""):
    bad = 0
    if isinstance(x, dict):
        for k in x:
            if k in ("time_seconds", "phases", "seconds") or "second" in k: continue
            if k in y: bad += walk(x[k], y[k], path + "." + k)
    elif isinstance(x, list):
        for i, (u, v) in enumerate(zip(x, y)): bad += walk(u, v, "%s[%d]" % (path, i))
    elif isinstance(x, float) and isinstance(y, float):
        if abs(x - y) > 1e-12 * max(1.0, abs(x), abs(y)):
            print("FAIL: stats %s: %r vs %r" % (path, x, y)); bad += 1
    return bad
n = walk(a, b)
print("stats agree" if n == 0 else "stats differ in %d numbers" % n)
sys.exit(1 if n else 0)
PY
exit $fail
