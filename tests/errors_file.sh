#!/bin/sh
# formfactor --errors writes a second file beside the matrix: same format,
# float32, flag bit 1; solve refuses it with a clear message and leaves
# nothing behind; --no-errors and --errors together are a usage error.
#   errors_file.sh FORMFACTOR SOLVE WORKDIR
set -eu
ff=$1 solve=$2 dir=$3
mkdir -p "$dir" && cd "$dir" && rm -f m m.err out.rad
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
"$ff" --subdiv 1 --samples 64 -q -o m --errors m.err --stats m.json
[ -s m ] && [ -s m.err ] || { echo "FAIL: files missing"; exit 1; }
grep -q '"standard_error": {"max"' m.json || { echo "FAIL: no error summary in the stats"; exit 1; }
if "$solve" m.err -o out.rad 2> solve.log; then echo "FAIL: solve accepted an errors file"; exit 1; fi
grep -q "standard errors" solve.log || { echo "FAIL: solve's message: $(cat solve.log)"; exit 1; }
[ ! -e out.rad ] || { echo "FAIL: solve left out.rad"; exit 1; }
"$solve" m -o out.rad -q || { echo "FAIL: solve refused the matrix itself"; exit 1; }
if "$ff" --subdiv 1 -q -o m2 --errors m2.err --no-errors 2> usage.log; then echo "FAIL: contradiction accepted"; exit 1; fi
grep -q "contradict" usage.log || { echo "FAIL: usage message: $(cat usage.log)"; exit 1; }
"$ff" --subdiv 1 --samples 64 -q -o m3 --no-errors --stats m3.json
grep -q '"standard_error": null' m3.json || { echo "FAIL: --no-errors still summarised errors"; exit 1; }
cmp m m3 || { echo "FAIL: --no-errors changed the matrix"; exit 1; }
# Two names for one file, or a folder as the errors file: refused before
# any work, and no matrix is left behind.
if "$ff" --subdiv 1 -q -o m4 --errors ./m4 2> same.log; then echo "FAIL: same file accepted"; exit 1; fi
grep -q "same file" same.log || { echo "FAIL: same-file message: $(cat same.log)"; exit 1; }
mkdir -p errdir
if "$ff" --subdiv 1 -q -o m5 --errors errdir 2> dir.log; then echo "FAIL: a folder as the errors file"; exit 1; fi
grep -q "is a directory" dir.log || { echo "FAIL: folder message: $(cat dir.log)"; exit 1; }
[ ! -e m4 ] && [ ! -e m5 ] || { echo "FAIL: a matrix was left behind by a failed run"; exit 1; }
ls | grep -q "tmp-" && { echo "FAIL: temporary files left: $(ls | grep tmp-)"; exit 1; }
echo "errors file written, refused by solve; --no-errors leaves the matrix unchanged; bad names refused"
