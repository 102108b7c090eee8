#!/bin/sh
# The output, written by every rank at once and in the background
# (formfactor/ff_writer.h): the same bytes through a mapping or through
# pwrite (RAD_FF_WRITE=pwrite), on the work folder's file system and on
# /dev/shm (tmpfs), for 1, 2 and 3 ranks, 1, 2 and 4 threads (a write cut
# into slices among four writer threads), in one round or many
# (--reciprocity off: blocks of rows taken in turn, each block written
# while the next is computed), in the dense, sparse and paper formats, with
# an --errors file beside the matrix; /dev/null takes the writes too. The
# stats say how the bytes went ("write_method": map on a tmpfs).
#   formfactor_write.sh FORMFACTOR SCENE WORKDIR
set -eu
ff=$1 scene=$2 dir=$3
mkdir -p "$dir" && cd "$dir" && rm -f ./*.ff ./*.err ./*.json
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OMP_WAIT_POLICY=passive
shm=""
if [ -d /dev/shm ] && [ -w /dev/shm ]; then
  shm=$(mktemp -d /dev/shm/formfactor_write.XXXXXX)
  trap 'rm -rf "$shm"' EXIT
fi
fail() { echo "FAIL: $*"; exit 1; }
# Cheap form factors (one sample, no shadow rays): the test is about the
# bytes, 69 MB of them at N = 2944 in float64.
args="$scene --subdiv 3 --estimator mc --samples 1 --shadow-rays 0 --backend cpu -q"
# run NAME RANKS THREADS METHOD DEST ARGS...: one run, its file DEST/NAME
run() {
  name=$1 p=$2 threads=$3 method=$4 dest=$5
  shift 5
  env OMP_NUM_THREADS="$threads" RAD_FF_WRITE="$method" mpirun -n "$p" "$ff" $args "$@" -o "$dest/$name" \
    --stats "$name.json" || fail "$name: exit $?"
}
# same REF NAME DEST WHAT: NAME's bytes are REF's; then NAME is removed
same() {
  cmp "$1" "$3/$2" || fail "$4: differs from $1"
  echo "same bytes: $4"
  rm -f "$3/$2"
}
dests=.
[ -n "$shm" ] && dests=". $shm"

# Dense float64: one rank, one thread, pwrite, each pair once: the reference.
env OMP_NUM_THREADS=1 RAD_FF_WRITE=pwrite "$ff" $args --format dense -o ref_dense.ff --stats ref.json
grep -q '"write_method": "pwrite"' ref.json || fail "RAD_FF_WRITE=pwrite: the stats do not say pwrite"
for d in $dests; do
  # one round of 2944 rows, cut among four writer threads
  run a.ff 1 4 auto "$d" --format dense --reciprocity off
  same ref_dense.ff a.ff "$d" "dense, 1 rank, 4 threads, one round, $d"
  # many rounds (blocks of 184 rows in turn), each written behind the next
  run b.ff 2 2 auto "$d" --format dense --reciprocity off
  same ref_dense.ff b.ff "$d" "dense, 2 ranks x 2 threads, streamed, $d"
  run c.ff 3 1 pwrite "$d" --format dense --reciprocity off
  same ref_dense.ff c.ff "$d" "dense, 3 ranks, streamed, pwrite, $d"
  run e.ff 2 4 auto "$d" --format dense --reciprocity on
  same ref_dense.ff e.ff "$d" "dense, 2 ranks x 4 threads, each pair once, $d"
done
if [ -n "$shm" ] && [ "$(stat -f -c %T "$shm")" = tmpfs ]; then
  run m.ff 2 2 auto "$shm" --format dense --reciprocity off
  grep -q '"write_method": "map"' m.ff.json || fail "a tmpfs is written through a mapping, but the stats say otherwise"
  rm -f "$shm/m.ff"
  echo "a tmpfs is written through a mapping"
fi

# Sparse float32 (the default format) with its --errors file.
"$ff" $args --element f32 -o ref_sparse.ff --errors ref_sparse.err
for d in $dests; do
  run s.ff 3 2 auto "$d" --element f32 --reciprocity off --errors "$d/s.err"
  cmp ref_sparse.err "$d/s.err" || fail "sparse errors file, 3 ranks, $d"
  rm -f "$d/s.err"
  same ref_sparse.ff s.ff "$d" "sparse f32 and its errors file, 3 ranks x 2 threads, streamed, $d"
  run t.ff 2 4 pwrite "$d" --element f32 --reciprocity on
  same ref_sparse.ff t.ff "$d" "sparse f32, 2 ranks, each pair once, pwrite, $d"
done

# The paper's format: int32 N, then N x N float64.
"$ff" $args --format paper -o ref_paper.ff
run p.ff 2 4 auto . --format paper --reciprocity off
same ref_paper.ff p.ff . "paper format, 2 ranks x 4 threads, streamed"

# A device written in place.
env OMP_NUM_THREADS=2 mpirun -n 2 "$ff" $args --reciprocity off -o /dev/null || fail "-o /dev/null, 2 ranks"
echo "ok: -o /dev/null, 2 ranks"
