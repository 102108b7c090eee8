#!/bin/sh
# Paths and inputs a careless script or a hostile file would use (issue 16),
# through the three programs: each ends with a clear error or a correct
# result, no signal, no hang, no file touched but the named output.
#   hostile_files.sh BIN_DIR WORKDIR      (BIN_DIR holds formfactor, solve,
#   render; render's cases are skipped where it was not built)
set -u
bin=$1 dir=$2
ff=$bin/formfactor solve=$bin/solve render=$bin/render
[ -x "$render" ] || render=
scenes=$(cd "$(dirname "$0")/../scenes" && pwd)
rm -rf "$dir" && mkdir -p "$dir" && cd "$dir" || exit 1
export OMP_NUM_THREADS=2
fail() { echo "FAIL: $*"; exit 1; }
ok() { echo "ok: $*"; }
# refused CASE EXPECTED_RC REGEX CMD...: the command exits EXPECTED_RC with
# a message matching REGEX, within 20 s (no hang), not killed by a signal.
refused() {
  what=$1 want=$2 regex=$3; shift 3
  timeout 20 "$@" > out.txt 2> err.txt; rc=$?
  [ $rc -eq 124 ] && fail "$what: hung"
  [ $rc -eq "$want" ] || fail "$what: exit $rc, expected $want: $(cat err.txt)"
  grep -Eq -e "$regex" err.txt || fail "$what: message does not match '$regex': $(cat err.txt)"
  ok "$what: exit $rc: $(grep -E -e "$regex" err.txt | head -1)"
}
no_temporaries() { for t in *.tmp-*; do [ -e "$t" ] && fail "$1: temporary left: $t"; done; return 0; }

"$ff" -q -o ff.good || fail "the built-in box"
"$solve" ff.good -q -o rad.good || fail "solve"
[ -n "$render" ] && { "$render" rad.good -q -o img.png --width 64 --height 64 || fail "render"; }

# 1. Device outputs: written in place, never replaced. /dev/null itself, and
# a private copy of it where mknod is allowed (root: CI).
"$ff" -q -o /dev/null --stats /dev/null || fail "formfactor -o /dev/null"
"$solve" ff.good -q -o /dev/null --stats /dev/null || fail "solve -o /dev/null"
[ -c /dev/null ] || fail "/dev/null is no longer a character device"
if mknod null.png c 1 3 2>/dev/null; then
  "$ff" -q -o null.png || fail "formfactor into a device copy"
  "$solve" ff.good -q -o null.png || fail "solve into a device copy"
  [ -n "$render" ] && { "$render" rad.good -q -o null.png --width 64 --height 64 || fail "render into a device copy"; }
  [ -c null.png ] || fail "the device copy became a $(stat -c %F null.png)"
  ok "a device given as -o is written in place by all three programs and stays a device"
  rm -f null.png
else
  echo "skip: mknod not permitted (not root): device copies not tested"
fi
mkfifo fifo
refused "formfactor -o FIFO" 2 "fifo: is a FIFO" "$ff" -q -o fifo
refused "solve -o directory" 2 "is a directory" "$solve" ff.good -q -o .
[ -n "$render" ] && refused "render -o FIFO" 2 "is a FIFO" "$render" rad.good -q -o fifo

# 2. Two roles naming one file, refused before any work.
cp ff.good keep.ff
refused "formfactor -o x --stats x" 2 "-o and --stats name the same file" "$ff" -o x --stats x
refused "formfactor -o x --stats ./x" 2 "-o and --stats name the same file" "$ff" -o x --stats ./x
cp "$scenes/cornell_box.obj" "$scenes/cornell_box.mtl" . || fail "copying the Cornell box"
if [ -f cornell_box.obj ]; then
  cp cornell_box.obj obj.keep && cp cornell_box.mtl mtl.keep
  refused "formfactor scene.obj -o scene.obj" 2 "the scene and -o name the same file" "$ff" cornell_box.obj -o cornell_box.obj
  refused "formfactor scene.obj -o scene.mtl" 1 "and -o name the same file \(cornell_box.mtl\)" "$ff" cornell_box.obj -o cornell_box.mtl
  cmp -s cornell_box.obj obj.keep && cmp -s cornell_box.mtl mtl.keep || fail "the scene was changed"
fi
refused "solve ff -o ff" 2 "the form-factor file and -o name the same file" "$solve" keep.ff -o keep.ff
refused "solve ff -o r --stats r" 2 "-o and --stats name the same file" "$solve" keep.ff -o r --stats r
cmp -s keep.ff ff.good || fail "solve changed its input"
[ -n "$render" ] && refused "render r -o r" 2 "the radiosity file and -o name the same file" "$render" rad.good -o rad.good
ln -s keep.ff alias.ff
refused "solve through a symlink to its output" 2 "name the same file" "$solve" alias.ff -o keep.ff
[ -e x ] || [ -e r ] && fail "an output appeared after a refusal"

# 7. -o '' refused at once.
refused "formfactor -o ''" 2 "-o: empty file name" "$ff" -o ''
refused "solve -o ''" 2 "-o: empty file name" "$solve" ff.good -o ''
[ -n "$render" ] && refused "render -o ''" 2 "-o: empty file name" "$render" rad.good -o ''

# 4. A symlink planted at the old predictable temporary name is not
# followed: the file it points to stays as it was.
echo precious > victim
for p in $(seq $$ $(($$ + 50))); do ln -sf victim "out.ff.tmp-$p"; done
"$ff" -q -o out.ff || fail "formfactor beside planted symlinks"
[ "$(cat victim)" = precious ] || fail "a planted symlink was written through"
rm -f out.ff.tmp-*
ok "symlinks planted at the old temporary names: not followed"

# 5. mtllib naming a device, a FIFO, a directory or a system file.
tri='v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n'
printf "mtllib /dev/zero\n$tri" > zero.obj
refused "mtllib /dev/zero" 1 "/dev/zero: is a character device; inputs are regular files" "$ff" zero.obj -q -o z
printf "mtllib fifo\n$tri" > fifo.obj
refused "mtllib FIFO (no hang)" 1 "fifo: is a FIFO; inputs are regular files" "$ff" fifo.obj -q -o z
printf "mtllib .\n$tri" > dir.obj
refused "mtllib a directory" 1 "is a directory; inputs are regular files" "$ff" dir.obj -q -o z
{ printf 'newmtl w\nKd 0.5 0.5 0.5\n'; i=0; while [ $i -lt 3000 ]; do
    echo "root:\$6\$secret$i:19000:0:99999:7:::"; echo "key$i 1"; i=$((i + 1)); done; } > shadow.mtl
printf "mtllib shadow.mtl\nusemtl w\n$tri" > shadow.obj
"$ff" shadow.obj -o s 2> err.txt || fail "a scene whose mtllib is full of junk"
grep -q secret err.txt && fail "file content echoed: $(grep secret err.txt | head -2)"
[ "$(wc -l < err.txt)" -le 40 ] || fail "$(wc -l < err.txt) lines of warnings for a junk mtllib"
grep -q "more warnings not shown" err.txt || fail "no summary of the hidden warnings"
"$ff" shadow.obj -o s -q 2> err.txt || fail "-q run"
[ -s err.txt ] && fail "-q printed: $(head -3 err.txt)"
ok "a junk mtllib: $(grep -c . err.txt) lines with -q, nothing echoed, warnings summarised"
mkdir -p sub && printf "mtllib ../shadow.mtl\nusemtl w\n$tri" > sub/up.obj
"$ff" sub/up.obj -o up 2> err.txt || fail "an mtllib in the parent folder: $(cat err.txt)"
grep -q "mtllib '../shadow.mtl' lies outside the scene's folder" err.txt || fail "no warning for ../: $(head -3 err.txt)"
ok "an mtllib outside the scene's folder: read, with a warning"

# 3. Coordinates beyond float range: a clear error, no crash.
for big in 1e39 1e100 1e154; do
  printf "v 0 0 0\nv $big 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n" > big.obj
  refused "coordinate $big" 1 "big.obj:2: coordinate $big beyond the supported range" "$ff" big.obj -q -o z
done

# 8. Misleading messages.
printf 'newmtl l\nKd 0.5 0.5 0.5\nKe 1e308 1 1\n' > ke.mtl
printf "mtllib ke.mtl\nusemtl l\n$tri" > ke.obj
refused "Ke 1e308" 1 "ke.mtl:3: Ke 1e308 out of range" "$ff" ke.obj -q -o z
mkdir -p somedir
[ -n "$render" ] && refused "render DIRECTORY" 1 "somedir: is a directory; inputs are regular files" "$render" somedir -q -o d.png
refused "solve DIRECTORY" 1 "somedir: is a directory; inputs are regular files" "$solve" somedir -q -o d.rad
printf "v 0 0 0\rv 1 0 0\rv 0 1 0\rv 0 0 1\rf 1 2 3\rf 1 3 4\rf 1 4 2\rf 2 4 3\r" > cr.obj
"$ff" cr.obj -q -o cr.ff || fail "CR-only line endings: $(cat err.txt)"
ok "CR-only line endings read"

# 7. Numbers parsed strictly.
refused "--seed 2^64" 2 "--seed: '18446744073709551616' is not an integer in \[0, 18446744073709551615\]" \
  "$ff" --seed 18446744073709551616
refused "--threads 0" 2 "--threads: '0' is not an integer in \[1, 1024\]" "$ff" --threads 0
refused "--max-samples 0" 2 "--max-samples: '0' is not an integer in \[1," "$ff" --max-samples 0
refused "--samples 5x" 2 "--samples: '5x' is not an integer" "$ff" --samples 5x
refused "solve --max-iter 0" 2 "--max-iter: '0' is not an integer in \[1," "$solve" ff.good --max-iter 0

# 6. Interrupted runs leave no temporary, for each catchable signal the
# issue names: formfactor while it computes (its temporary exists from the
# start), render while it writes a large PNG.
for sig in TERM INT HUP QUIT USR1 ALRM PIPE XCPU; do
  cp ff.good sig.ff
  "$ff" --subdiv 2 --shadow-rays 4096 -q -o sig.ff > /dev/null 2>&1 &
  pid=$!
  n=0; while [ $n -lt 200 ] && ! ls sig.ff.tmp-* > /dev/null 2>&1; do sleep 0.05; n=$((n + 1)); done
  ls sig.ff.tmp-* > /dev/null 2>&1 || { kill -KILL $pid; fail "formfactor never opened its output"; }
  kill -$sig $pid; wait $pid; rc=$?
  [ $rc -gt 128 ] || fail "formfactor, SIG$sig: exit $rc, expected death by the signal"
  no_temporaries "formfactor, SIG$sig"
  cmp -s sig.ff ff.good || fail "formfactor, SIG$sig: the old output was touched"
done
ok "formfactor: SIGTERM INT HUP QUIT USR1 ALRM PIPE XCPU mid-run: no temporary, the old output kept"
if [ -n "$render" ]; then
  for sig in TERM USR1 XCPU; do
    cp img.png sig.png
    "$render" rad.good -q -o sig.png --width 8192 --height 8192 > /dev/null 2>&1 &
    pid=$!
    n=0; while [ $n -lt 400 ] && ! ls sig.png.tmp-* > /dev/null 2>&1; do sleep 0.02; n=$((n + 1)); done
    kill -$sig $pid 2>/dev/null; wait $pid; rc=$?
    no_temporaries "render, SIG$sig"
    cmp -s sig.png img.png || [ $rc -eq 0 ] || fail "render, SIG$sig: the old output was touched"
  done
  ok "render: SIGTERM USR1 XCPU while writing: no temporary left"
fi
echo "hostile paths and inputs: all refused or handled"
