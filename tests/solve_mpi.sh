#!/bin/sh
# mpirun -n K solve (docs/solve.md, "Across ranks"): on dense and sparse
# files of the built-in Cornell box (--subdiv 2) and of cornell_sphere.obj
# (--subdiv 1), and on two copies of the box made non-reciprocal (ff_skew:
# one CG still accepts, one it refuses, so auto and cg fall back), every
# method with 2 and 3 ranks agrees with one process within what the
# residuals allow (radiosity_agree: (omega_1 + omega_K) ||E|| / (1 - c) per
# channel, ~1e-9 ||E|| at the default tolerance 1e-10); one rank under
# mpirun gives the same bytes as a plain run; the CG check's numbers
# (reciprocity, margin, the fallback's reason) and the row sums are the
# same bits for every rank count; --by-group agrees to 1e-7 of each column's largest value; a bad
# file is refused by name, once, with nothing written.
#   solve_mpi.sh FORMFACTOR SOLVE RADIOSITY_AGREE FF_SKEW SCENE WORKDIR
set -eu
ff=$1 solve=$2 agree=$3 skew=$4 scene=$5 dir=$6
mkdir -p "$dir" && cd "$dir" && rm -f ./*.ff ./*.err ./*.rad ./*.csv ./*.json ./*.log
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fail() { echo "FAIL: $*"; exit 1; }
run() { mpirun --oversubscribe -n "$@"; }
# The value of "key" in a stats file, as written (one line per channel).
values() { grep -oE "\"$2\": (\"[^\"]*\"|[^,]*)" "$1"; }

"$ff" --subdiv 2 -q --format dense -o box_dense.ff --errors box_dense.err
"$ff" --subdiv 2 -q --format sparse -o box_sparse.ff
"$ff" "$scene" --subdiv 1 -q --format dense -o sphere_dense.ff
"$ff" "$scene" --subdiv 1 -q --format sparse -o sphere_sparse.ff
"$skew" box_sparse.ff skew_sparse.ff 0.02   # CG check ratio ~0.03: CG runs
"$skew" box_dense.ff skew_dense.ff 0.3      # ratio ~1.3: CG refused

for f in box_dense box_sparse sphere_dense sphere_sparse skew_sparse skew_dense; do
  for m in jacobi gauss-seidel cg auto; do
    base="${f}_$m" opts="-q --method $m"
    "$solve" $f.ff $opts -o $base.rad --stats $base.json --by-group $base.csv 2> $base.log
    run 1 "$solve" $f.ff $opts -o ${base}_1.rad --stats ${base}_1.json --by-group ${base}_1.csv
    cmp $base.rad ${base}_1.rad && cmp $base.csv ${base}_1.csv ||
      fail "$f, $m: one rank under mpirun differs from a plain run"
    for p in 2 3; do
      run $p "$solve" $f.ff $opts -o ${base}_$p.rad --stats ${base}_$p.json --by-group ${base}_$p.csv > ${base}_$p.log 2>&1 ||
        fail "$f, $m, $p ranks: exit $?: $(cat ${base}_$p.log)"
      cmp $base.log ${base}_$p.log || fail "$f, $m, $p ranks: other warnings than one process: $(cat ${base}_$p.log)"
      echo "$f, $m, $p ranks:"
      "$agree" $f.ff $base.rad ${base}_$p.rad || fail "$f, $m: $p ranks disagree with one process"
      grep -q "\"ranks\": $p" ${base}_$p.json || fail "$f, $m: stats do not record $p ranks"
      rows=$(grep -o '"rank_rows": \[[0-9, ]*\]' ${base}_$p.json | tr -dc '0-9,' | tr ',' '+')
      [ "$(($rows))" -eq "$(grep -o '"patch_count": [0-9]*' $base.json | tr -dc 0-9)" ] ||
        fail "$f, $m: rank_rows do not add up to the patch count"
      for key in reciprocity margin fallback row_sums; do
        [ "$(values $base.json $key)" = "$(values ${base}_$p.json $key)" ] ||
          fail "$f, $m, $p ranks: $key differs: $(values ${base}_$p.json $key) vs $(values $base.json $key)"
      done
      awk -F, -v tol=1e-7 'NR == FNR && FNR > 1 { for (k = 2; k <= NF; k++) { a[FNR, k] = $k; m[k] = (($k < 0 ? -$k : $k) > m[k]) ? ($k < 0 ? -$k : $k) : m[k] } next }
        FNR > 1 { for (k = 2; k <= NF; k++) { d = a[FNR, k] - $k; if (d < 0) d = -d; if (d > tol * m[k]) { print "column " k ", row " FNR ": " a[FNR, k] " vs " $k; bad = 1 } } }
        END { exit bad }' $base.csv ${base}_$p.csv || fail "$f, $m, $p ranks: --by-group differs"
    done
  done
done

grep -q '"fallback": "matrix not reciprocal enough for CG' skew_dense_auto_3.json &&
  grep -q '"method": "cg", "fallback": null' skew_sparse_cg_3.json || fail "the skewed copies: not the CG checks expected"

# --errors: the same row-sum judgement with 1 and 3 ranks.
"$solve" box_dense.ff -q --errors box_dense.err -o e1.rad --stats e1.json
run 3 "$solve" box_dense.ff -q --errors box_dense.err -o e3.rad --stats e3.json
[ "$(values e1.json row_sums)" = "$(values e3.json row_sums)" ] && grep -q '"rule": "errors"' e3.json ||
  fail "--errors with 3 ranks: $(values e3.json row_sums)"

# Not converged: exit 3 from every rank, the file written and marked so.
set +e
run 2 "$solve" box_sparse.ff -q --method jacobi --max-iter 3 -o unconverged.rad 2> unconverged.log
code=$?
set -e
[ "$code" -eq 3 ] && [ -s unconverged.rad ] || fail "unconverged with 2 ranks: exit $code"
# (Said once, by rank 0. Its last line may be lost: mpirun ends the job,
# output forwarding included, as soon as a rank exits non-zero.)
[ "$(grep -c "red: not converged: residual" unconverged.log)" -eq 1 ] || fail "unconverged: $(cat unconverged.log)"

# A damaged file: refused by name, once, exit 1, nothing written. A
# flipped byte in the last row's record (held by the last rank), and a cut
# file (found by every rank as it opens it; rank 0 says so).
size=$(wc -c < box_sparse.ff)
head -c $((size - 100)) box_sparse.ff > cut.ff
dd if=box_dense.ff of=flip.ff bs=1M 2>/dev/null
n=333 # the built-in box at --subdiv 2 (its floor cut along the blocks)
# the dense matrix starts at the matrix offset (header byte 88); flip a byte of row n - 1
moff=$(od -An -t u8 -j 88 -N 8 box_dense.ff | tr -d ' ')
off=$((moff + (n - 1) * n * 8 + 17))
printf '\377' | dd of=flip.ff bs=1 seek=$off conv=notrunc 2>/dev/null
for bad in cut flip; do
  for p in 1 3; do
    set +e
    run $p "$solve" $bad.ff -q -o $bad$p.rad --stats $bad$p.json 2> $bad$p.log
    code=$?
    set -e
    [ "$code" -eq 1 ] || fail "$bad.ff with $p ranks: exit $code"
    [ ! -e $bad$p.rad ] && [ ! -e $bad$p.json ] || fail "$bad.ff with $p ranks left an output"
    [ "$(grep -c "^solve: error: $bad.ff: " $bad$p.log)" -eq 1 ] || fail "$bad.ff with $p ranks: $(cat $bad$p.log)"
  done
  [ "$(grep '^solve:' ${bad}1.log)" = "$(grep '^solve:' ${bad}3.log)" ] || fail "$bad.ff: other messages with 3 ranks"
  echo "$bad.ff: $(grep '^solve:' ${bad}3.log)"
done
echo "solve across ranks: every method within its bound, one rank the same bytes, damaged files refused"
