#!/bin/sh
# Failed runs leave no result: each fault ends with a message and a
# non-zero exit, leaves no file under the output's name (an existing good
# file of that name stays byte for byte) and no temporary file behind.
#
#   fault_runs.sh CASE BIN_DIR WORK_DIR
#
# CASE      kill       SIGKILL one rank of `mpirun -n 2 formfactor` mid-run
#                      (each rank in turn); SIGKILL solve and render mid-run
#           disk-full  a 256 KiB tmpfs (refused up front), a 16 MiB tmpfs
#                      filled while formfactor computes, a full tmpfs for
#                      solve and render
#           read-only  a tmpfs remounted read-only as the output directory
#           oom        address-space limits (ulimit -v) from too small to
#                      enough: every run fails cleanly or writes the same
#                      bytes as an unlimited run
#           limits     sizes refused up front with what they would need
# BIN_DIR   holds formfactor, solve and, when built, render.
# Exit 77 (skipped) where the case cannot be set up here: mounting a tmpfs
# needs root (CAP_SYS_ADMIN); ulimit -v cannot be combined with ASan.
# docs/reliability.md lists what each case shows.
set -u
case_name=$1 bin=$2 work=$3
ff=$bin/formfactor solve=$bin/solve render=$bin/render
[ -x "$render" ] || render=
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1
mpirun="mpirun --oversubscribe -n 2"
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1

fail() { echo "FAIL: $*"; exit 1; }
skip() { echo "SKIP: $*"; exit 77; }

# Inputs: a small form-factor file, its radiosity and picture (the "good"
# files a failed run must not touch), and a larger one that takes seconds.
"$ff" -q --subdiv 1 --samples 64 --shadow-rays 8 -o good.ff || fail "setup: formfactor"
"$solve" -q good.ff -o good.rad 2>setup.txt || fail "setup: solve: $(cat setup.txt)"
if [ -n "$render" ]; then "$render" -q good.rad -o good.png --width 64 --height 64 || fail "setup: render"; fi

# expect_failed WHAT RC ERRFILE OUTPUT GOOD [REGEX]: the run failed with a
# message (matching REGEX), OUTPUT equals GOOD, no OUTPUT.tmp-* is left.
expect_failed() {
  what=$1 rc=$2 err=$3 out=$4 good=$5 regex=${6:-.}
  [ "$rc" -ne 0 ] || fail "$what: exit 0"
  grep -Eq "$regex" "$err" || fail "$what: exit $rc, message does not match '$regex': $(cat "$err")"
  expect_untouched "$what" "$out" "$good"
  echo "ok: $what: exit $rc: $(grep -E -m1 "$regex" "$err")"
}
expect_untouched() {
  cmp -s "$2" "$3" || fail "$1: the existing $2 was changed or removed"
  for t in "$2".tmp-*; do [ -e "$t" ] && fail "$1: temporary file left: $t"; done
}

# wait_for GLOB SECONDS: until a file matching GLOB exists.
wait_for() {
  i=0
  while [ $i -lt $(($2 * 20)) ]; do
    for f in $1; do [ -e "$f" ] && return 0; done
    sleep 0.05; i=$((i + 1))
  done
  return 1
}

# mount_tmpfs DIR SIZE: a fresh tmpfs, unmounted on exit; skips without rights.
mounted=
cleanup() { for m in $mounted; do umount "$m" 2>/dev/null; done; }
trap cleanup EXIT
trap 'exit 1' HUP INT PIPE TERM # so that EXIT's cleanup runs on these too
mount_tmpfs() {
  mkdir -p "$1"
  mount -t tmpfs -o size="$2" tmpfs "$1" 2>/dev/null || skip "cannot mount a tmpfs here (needs root)"
  mounted="$mounted $1"
}

# fill DIR: writes DIR/hog until the tmpfs mounted there is full (and never
# more than 16 MiB, nor anywhere but on a mount point this script made).
fill() {
  case " $mounted " in *" $1 "*) ;; *) fail "fill: $1 is not a tmpfs of this script" ;; esac
  mountpoint -q "$1" || fail "fill: $1 is not mounted"
  dd if=/dev/zero of="$1/hog" bs=4096 count=4096 2>/dev/null
}

case $case_name in
kill)
  "$ff" -q --subdiv 3 --samples 32 --shadow-rays 8 -o mid.ff || fail "setup: formfactor mid.ff"
  for victim in 1 2; do
    cp good.ff out.ff
    $mpirun "$ff" --subdiv 3 -o out.ff > err.txt 2>&1 &
    mp=$!
    wait_for "out.ff.tmp-*" 60 || { kill -KILL $mp; fail "formfactor never opened its output"; }
    sleep 1
    pid=$(pgrep -P $mp | sort -n | sed -n "${victim}p")
    [ -n "$pid" ] || fail "no rank process under mpirun"
    kill -KILL "$pid"
    wait $mp; rc=$?
    expect_failed "formfactor, SIGKILL to rank process $victim of 2" $rc err.txt out.ff good.ff "signal 9|Killed"
  done
  # Single processes: SIGKILL at several moments; whatever was reached,
  # the old file stays or (run finished first) the new one is whole.
  "$solve" -q --method jacobi mid.ff -o whole.rad || fail "setup: solve mid.ff"
  for delay in 0.05 0.1 0.2 0.4; do
    cp good.rad out.rad
    "$solve" --method jacobi mid.ff -o out.rad > err.txt 2>&1 &
    pid=$!; sleep $delay; kill -KILL $pid 2>/dev/null; wait $pid; rc=$?
    if [ $rc -eq 0 ]; then
      cmp -s out.rad whole.rad || fail "solve: finished file differs"
      echo "ok: solve finished within ${delay} s; its file is whole"
    elif [ $rc -eq 137 ] && cmp -s out.rad whole.rad; then
      # Killed between the rename and the exit: the new file is whole.
      expect_untouched "solve, SIGKILL after ${delay} s (after its rename)" out.rad whole.rad
      echo "ok: solve killed after its rename at ${delay} s; its file is whole"
    else
      [ $rc -eq 137 ] || fail "solve: exit $rc, expected death by SIGKILL: $(cat err.txt)"
      expect_untouched "solve, SIGKILL after ${delay} s" out.rad good.rad
      echo "ok: solve, SIGKILL after ${delay} s: old file kept, no temporary"
    fi
  done
  if [ -n "$render" ]; then
    "$solve" -q mid.ff -o mid.rad || fail "setup: solve mid.ff"
    for delay in 0.2 0.5; do
      cp good.png out.png
      "$render" mid.rad -o out.png --width 2048 --height 2048 --spp 16 > err.txt 2>&1 &
      pid=$!; sleep $delay; kill -KILL $pid 2>/dev/null; wait $pid; rc=$?
      [ $rc -ne 0 ] || { echo "note: render finished within ${delay} s"; continue; }
      [ $rc -eq 137 ] || fail "render: exit $rc, expected death by SIGKILL: $(cat err.txt)"
      expect_untouched "render, SIGKILL after ${delay} s" out.png good.png
      echo "ok: render, SIGKILL after ${delay} s: old file kept, no temporary"
    done
  fi
  ;;

disk-full)
  mount_tmpfs full 256k
  cp good.ff full/out.ff
  $mpirun "$ff" --subdiv 3 --format dense -o full/out.ff > err.txt 2>&1; rc=$?
  expect_failed "formfactor --subdiv 3 --format dense into a 256 KiB file system (refused up front)" $rc err.txt \
    full/out.ff good.ff "1294 patches: full/out.ff would need .* but full has .* free; refused"
  # The sparse default's size is only bounded: more than 10x the free
  # space is refused up front; --allow-disk-overcommit runs it anyway: a
  # warning, then the write fails.
  $mpirun "$ff" --subdiv 3 -o full/out.ff > err.txt 2>&1; rc=$?
  expect_failed "formfactor --subdiv 3 (sparse, bound 50x the space) into a 256 KiB file system (refused up front)" \
    $rc err.txt full/out.ff good.ff "full has .* free, less than a tenth of that bound .*--allow-disk-overcommit"
  $mpirun "$ff" --subdiv 3 --allow-disk-overcommit -o full/out.ff > err.txt 2>&1; rc=$?
  expect_failed "formfactor --subdiv 3 --allow-disk-overcommit into a 256 KiB file system" $rc err.txt full/out.ff \
    good.ff "full/out.ff.tmp-[0-9a-f]+: (short write|write failed)"
  grep -q "full has .* free and the sparse file may need up to" err.txt || fail "no warning: $(cat err.txt)"
  umount full && mounted=
  mount_tmpfs full 16m
  cp good.ff full/out.ff
  $mpirun "$ff" --subdiv 3 --samples 256 -o full/out.ff > err.txt 2>&1 &
  mp=$!
  wait_for "full/out.ff.tmp-*" 60 || { kill -KILL $mp; fail "formfactor never opened its output"; }
  fill full
  wait $mp; rc=$?
  rm -f full/hog
  expect_failed "formfactor, disk filled while it computes" $rc err.txt full/out.ff good.ff \
    "full/out.ff.tmp-[0-9a-f]+: (short write|write failed)"
  cp good.rad full/out.rad
  [ -n "$render" ] && cp good.png full/out.png
  fill full
  "$solve" good.ff -o full/out.rad > err.txt 2>&1; rc=$?
  expect_failed "solve into a full file system" $rc err.txt full/out.rad good.rad "No space"
  if [ -n "$render" ]; then
    "$render" good.rad -o full/out.png > err.txt 2>&1; rc=$?
    expect_failed "render into a full file system" $rc err.txt full/out.png good.png \
      "full/out.png: .*(disk full|No space|cannot write)"
  fi
  ;;

read-only)
  mount_tmpfs ro 1m
  cp good.ff ro/out.ff && cp good.rad ro/out.rad
  [ -n "$render" ] && cp good.png ro/out.png
  mount -o remount,ro ro || skip "cannot remount the tmpfs read-only"
  $mpirun "$ff" --subdiv 1 --samples 64 -o ro/out.ff > err.txt 2>&1; rc=$?
  expect_failed "formfactor (2 ranks) into a read-only directory" $rc err.txt ro/out.ff good.ff "ro/out.ff.*[Rr]ead.only"
  "$solve" good.ff -o ro/out.rad > err.txt 2>&1; rc=$?
  expect_failed "solve into a read-only directory" $rc err.txt ro/out.rad good.rad "ro/out.rad.*Read-only"
  if [ -n "$render" ]; then
    "$render" good.rad -o ro/out.png > err.txt 2>&1; rc=$?
    expect_failed "render into a read-only directory" $rc err.txt ro/out.png good.png "ro/out.png: cannot write"
  fi
  ;;

oom)
  # ASan reserves terabytes of address space: ulimit -v and ASan exclude each other.
  grep -q __asan_init "$solve" && skip "ASan build: address-space limits do not apply"
  # sweep WHAT GOOD REFERENCE OUTPUT "LIMITS (KiB)" COMMAND...: each limited run
  # fails cleanly (exit 1..127, message, old file kept) or writes REFERENCE's bytes.
  sweep() {
    label=$1 good=$2 ref=$3 out=$4 limits=$5; shift 5
    oom=0
    for kib in $limits; do
      cp "$good" "$out"
      (ulimit -v "$kib" && exec "$@") > err.txt 2>&1; rc=$?
      if [ $rc -eq 0 ]; then
        cmp -s "$out" "$ref" || fail "$label, ulimit -v $kib: finished but its file differs from the unlimited run"
        echo "ok: $label, ulimit -v $kib: finished, same bytes as without a limit"
        continue
      fi
      [ $rc -lt 128 ] || fail "$label, ulimit -v $kib: died of signal $((rc - 128)): $(cat err.txt)"
      grep -q "out of memory" err.txt && oom=$((oom + 1))
      expect_failed "$label, ulimit -v $kib" $rc err.txt "$out" "$good" \
        "out of memory|cannot create a device|error while loading shared libraries|[Rr]esource temporarily unavailable"
    done
    [ $oom -gt 0 ] || fail "$label: no limit produced an 'out of memory' message"
  }
  "$ff" -q --subdiv 4 --estimator mc --samples 1 --shadow-rays 0 -o ref.ff || fail "setup: formfactor ref.ff"
  sweep "formfactor --subdiv 4" good.ff ref.ff out.ff "200000 400000 500000 1000000" \
    "$ff" -q --subdiv 4 --estimator mc --samples 1 --shadow-rays 0 -o out.ff
  "$ff" -q --subdiv 3 --samples 32 --shadow-rays 8 -o mid.ff || fail "setup: formfactor mid.ff"
  "$solve" -q mid.ff -o ref.rad || fail "setup: solve mid.ff"
  sweep "solve (1294 patches)" good.rad ref.rad out.rad "8000 16000 64000" \
    "$solve" -q mid.ff -o out.rad
  if [ -n "$render" ]; then
    "$render" -q ref.rad -o ref.png --width 4096 --height 4096 --spp 1 || fail "setup: render ref.png"
    sweep "render 4096x4096" good.png ref.png out.png "500000 600000 1000000" \
      "$render" -q ref.rad -o out.png --width 4096 --height 4096 --spp 1
  fi
  ;;

limits)
  cp good.ff out.ff
  start=$(date +%s)
  "$ff" --subdiv 12 -o out.ff > err.txt 2>&1; rc=$?
  [ $(($(date +%s) - start)) -le 5 ] || fail "--subdiv 12 was not refused up front"
  expect_failed "formfactor --subdiv 12 (Cornell box)" $rc err.txt out.ff good.ff \
    "334537984 patches: out.ff would need 795 PiB \(N\^2 x 8 bytes\) and each rank about .* of memory, but .*; refused"
  # 130 triangles x 4^12 = 2181038080 patches: beyond the format.
  awk 'BEGIN { for (i = 0; i < 130; i++) printf "v %d 0 0\nv %d 1 0\nv %d 0 1\nf %d %d %d\n", i, i, i, 3*i+1, 3*i+2, 3*i+3 }' \
    > many.obj
  "$ff" many.obj --subdiv 12 -o out.ff > err.txt 2>&1; rc=$?
  expect_failed "formfactor --subdiv 12 (130 triangles)" $rc err.txt out.ff good.ff \
    "2181038080 patches: .* but more than the format's limit of 2147483647 patches; refused"
  "$ff" --subdiv 13 -o out.ff > err.txt 2>&1; rc=$?
  [ $rc -eq 2 ] || fail "--subdiv 13: exit $rc, expected 2 (usage)"
  expect_failed "formfactor --subdiv 13" $rc err.txt out.ff good.ff "not an integer in \[0, 12\]"
  if [ -n "$render" ]; then
    cp good.png out.png
    "$render" good.rad -o out.png --width 100000 > err.txt 2>&1; rc=$?
    expect_failed "render --width 100000" $rc err.txt out.png good.png "width"
  fi
  ;;

*) fail "unknown case '$case_name'" ;;
esac
echo "fault_runs $case_name: passed"
