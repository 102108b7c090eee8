#!/bin/sh
# Byte-identical output for 1, 2 and 3 MPI ranks (and for a repeated run),
# in the native and the paper format.
#   formfactor_ranks.sh FORMFACTOR SCENE WORKDIR
set -eu
ff=$1 scene=$2 dir=$3
mkdir -p "$dir" && cd "$dir"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1
args="$scene --subdiv 1 --samples 64 --shadow-rays 16 -q"
for p in 1 2 3; do
  mpirun --oversubscribe -n $p "$ff" $args -o ranks$p --stats ranks$p.json
  mpirun --oversubscribe -n $p "$ff" $args -o paper$p --format paper
done
"$ff" $args -o ranks1again            # a plain run (solo: no MPI at all), again
for f in ranks2 ranks3 ranks1again; do
  cmp ranks1 $f || { echo "FAIL: $f differs from ranks1"; exit 1; }
done
cmp paper1 paper2 && cmp paper1 paper3 || { echo "FAIL: paper-format files differ"; exit 1; }
# The paper format is int32 N then N*N float64, nothing else.
n=$(od -An -t d4 -N4 paper1 | tr -d ' ')
size=$(wc -c < paper1)
[ "$size" -eq $((4 + 8 * n * n)) ] || { echo "FAIL: paper file is $size bytes for N=$n"; exit 1; }
grep -q '"ranks": 3' ranks3.json || { echo "FAIL: stats do not record 3 ranks"; exit 1; }
echo "identical bytes for 1, 2, 3 ranks (N=$n)"

# Reciprocity: each unordered pair computed once and copied (on), or both
# entries computed (off): the same bytes, with 1, 2 and 3 ranks; every
# entry is computed or copied, and "on" computes N + N(N-1)/2 of them.
field() { grep -o "\"$2\": [0-9]*" "$1" | head -1 | sed 's/.*: //'; }
for p in 1 3; do
  mpirun --oversubscribe -n $p "$ff" $args --reciprocity off -o off$p --stats off$p.json
  cmp ranks1 off$p || { echo "FAIL: --reciprocity off with $p rank(s) differs"; exit 1; }
  [ "$(field off$p.json pairs)" -eq $((n * n)) ] && [ "$(field off$p.json pairs_mirrored)" -eq 0 ] ||
    { echo "FAIL: --reciprocity off: counts"; exit 1; }
done
for p in 1 2 3; do
  mpirun --oversubscribe -n $p "$ff" $args --reciprocity on -o on$p --stats on$p.json
  cmp ranks1 on$p || { echo "FAIL: --reciprocity on with $p rank(s) differs"; exit 1; }
  grep -q '"reciprocity": "on"' on$p.json || { echo "FAIL: stats do not record reciprocity on"; exit 1; }
  computed=$(field on$p.json pairs) mirrored=$(field on$p.json pairs_mirrored)
  [ $((computed + mirrored)) -eq $((n * n)) ] && [ "$computed" -eq $((n + n * (n - 1) / 2)) ] ||
    { echo "FAIL: --reciprocity on, $p rank(s): $computed computed + $mirrored copied for N=$n"; exit 1; }
done
# More ranks than a tiny scene has rows to spare (some ranks hold one row or none).
printf 'newmtl g\nKd 0.5 0.5 0.5\n' > tiny.mtl
printf 'mtllib tiny.mtl\nusemtl g\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nv 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 5 6 7 8\n' > tiny.obj
"$ff" tiny.obj --samples 64 -q --reciprocity off -o tiny1
mpirun --oversubscribe -n 4 "$ff" tiny.obj --samples 64 -q --reciprocity on -o tiny4
cmp tiny1 tiny4 || { echo "FAIL: 4 ranks on 2 patches differ"; exit 1; }
echo "identical bytes with --reciprocity on and off"

# The stats add up over ranks: the same counts for 1 and 3 ranks.
for key in pairs pairs_mirrored rays rays_occluded samples; do
  [ "$(field on1.json $key)" -eq "$(field on3.json $key)" ] ||
    { echo "FAIL: stats: $key is $(field on1.json $key) with 1 rank, $(field on3.json $key) with 3"; exit 1; }
done

# --target-error: the same bytes (matrix and --errors file) for 1 rank
# computing both entries and 3 ranks computing each pair once.
"$ff" $args --target-error 0.002 --reciprocity off -o target1 --errors target1.err --stats target1.json
mpirun --oversubscribe -n 3 "$ff" $args --target-error 0.002 --reciprocity on -o target3 --errors target3.err
cmp target1 target3 && cmp target1.err target3.err || { echo "FAIL: --target-error differs with ranks"; exit 1; }
[ "$(field target1.json pairs_refined)" -gt 0 ] || { echo "FAIL: --target-error refined no pair"; exit 1; }
cmp ranks1 target1 >/dev/null 2>&1 && { echo "FAIL: --target-error changed nothing"; exit 1; }
echo "identical bytes with --target-error"

# Streamed rows over several rounds (--reciprocity off): each rank takes
# blocks of rows in turn, so every collective write appends the ranks'
# blocks in row order: the same bytes (matrix and --errors file) for 1, 2
# and 3 ranks. A floor of 8192 patches under one ceiling patch: rounds of
# 96 MiB of doubles hold 1535 rows, so 6 rounds on one rank and 2 or 3 on
# several; almost every pair faces away (culled), so it takes seconds.
cat > floor.obj <<'OBJ'
mtllib tiny.mtl
usemtl g
g floor
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 2 0 0
v 2 1 0
f 1 2 3 4
f 2 5 6 3
g ceiling
v 0 0 1
v 2 0 1
v 2 1 1
v 0 1 1
f 7 10 9 8
OBJ
floor="floor.obj --subdiv 6 --subdiv-only floor --samples 16 --shadow-rays 1 -q"
for p in 1 2 3; do
  mpirun --oversubscribe -n $p "$ff" $floor --reciprocity off -o floor$p --errors floor$p.err --stats floor$p.json
done
for p in 2 3; do
  cmp floor1 floor$p && cmp floor1.err floor$p.err ||
    { echo "FAIL: --reciprocity off over several rounds: $p ranks differ from one"; exit 1; }
done
n=$(field floor1.json patches)
size=$(grep -o '"size": [0-9]*' floor1.json | head -1 | sed 's/.*: //')
[ "$n" -eq 8193 ] && [ "$size" -lt "$n" ] ||
  { echo "FAIL: floor: N=$n in rounds of $size rows: not several rounds"; exit 1; }
for p in 2 3; do
  rows=$(grep -o '"rows": [0-9]*' floor$p.json | sed 's/.*: //' | awk '{ s += $1 } END { print s }')
  [ "$rows" -eq "$n" ] || { echo "FAIL: floor, $p ranks: the ranks' rows add up to $rows, not $n"; exit 1; }
done
"$ff" $floor -o floor_on
cmp floor1 floor_on || { echo "FAIL: floor: --reciprocity off and on differ"; exit 1; }
echo "identical bytes for 1, 2, 3 ranks streaming rows over several rounds"
