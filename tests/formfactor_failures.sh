#!/bin/sh
# A failed run leaves nothing under the final name and keeps what was there.
#   formfactor_failures.sh FORMFACTOR SCENE WORKDIR
set -u
ff=$1 scene=$2 dir=$3
mkdir -p "$dir" && cd "$dir" || exit 1
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1
fail() { echo "FAIL: $*"; exit 1; }
rm -f out* bad.obj
echo "keep me" > out
printf 'v 0 0 0\nv 1 0 0\nf 1 2 9\n' > bad.obj
mpirun --oversubscribe -n 2 "$ff" bad.obj -o out 2> err.txt && fail "bad scene accepted"
grep -q "bad.obj:3: " err.txt || fail "no file:line message: $(cat err.txt)"
[ "$(cat out)" = "keep me" ] || fail "existing output was touched"
[ "$(grep -c 'bad.obj:3' err.txt)" -eq 1 ] || fail "the error was printed more than once"
ls out.tmp-* 2>/dev/null && fail "temporary file left behind"
"$ff" "$scene" -o no/such/dir/out -q 2> err.txt && fail "unwritable output accepted"
grep -q "no/such/dir/out" err.txt || fail "no message naming the output: $(cat err.txt)"
"$ff" --samples 0 2> err.txt; [ $? -eq 2 ] || fail "usage error did not exit 2"
"$ff" --estimator mc --shadow-rays 64 --samples 32 2> err.txt && fail "rays > samples accepted (mc)"
"$ff" --help | grep -q "usage: mpirun" || fail "--help"
echo "failures leave no output"
