#!/bin/sh
# formfactor --format sparse (docs/formats.md, version 3): the same numbers
# as the dense file, bit for bit, in a file a fraction of its size; the same
# bytes for 1-3 ranks, with --reciprocity on and off; solve (every method,
# --errors, --by-group) and tools/ffdump.py read it to the same results; a
# damaged one is refused.
#   sparse_file.sh FORMFACTOR SOLVE PYTHON TOOLS SCENE WORKDIR
set -eu
ff=$1 solve=$2 py=$3 tools=$4 scene=$5 dir=$6
mkdir -p "$dir" && cd "$dir" && rm -f ./*.ff ./*.err ./*.rad ./*.csv
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fail() { echo "FAIL: $*"; exit 1; }
args="$scene --subdiv 2 -q"
"$ff" $args --format dense -o dense.ff --errors dense.err
"$ff" $args --format sparse -o sparse.ff --errors sparse.err --stats sparse.json
grep -q '"format": "sparse"' sparse.json || fail "stats do not record the format"
for p in 2 3; do
  mpirun --oversubscribe -n $p "$ff" $args --format sparse -o on$p.ff --errors on$p.err
  cmp sparse.ff on$p.ff && cmp sparse.err on$p.err || fail "$p ranks wrote other bytes"
  mpirun --oversubscribe -n $p "$ff" $args --format sparse --reciprocity off -o off$p.ff
  cmp sparse.ff off$p.ff || fail "$p ranks, --reciprocity off, wrote other bytes"
done
"$ff" $args --format sparse --element f32 -o sparse32.ff
# The numbers, through tools/ffread.py (numpy; where it is missing - the
# device machine's Debian python - the solve checks below still compare them).
numpy=yes; "$py" -c "import numpy" 2>/dev/null || numpy=
if [ -z "$numpy" ]; then
  echo "numpy missing: the entry-by-entry comparison is skipped"
else "$py" - "$tools" <<'PY' || fail "the sparse files' numbers differ from the dense ones"
import os, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from ffread import read_formfactors
def F(path):
    h, _, _, F = read_formfactors(path)
    return h, F
for dense, sparse in (("dense.ff", "sparse.ff"), ("dense.err", "sparse.err")):
    hd, d = F(dense)
    hs, s = F(sparse)
    assert int(hd["version"]) == 2 and int(hs["version"]) == 3 and int(hs["layout"]) == 1
    assert d.dtype == s.dtype and np.array_equal(d.view(np.uint8), s.view(np.uint8)), dense
    ratio = os.path.getsize(dense) / os.path.getsize(sparse)
    print(f"{dense}: {os.path.getsize(dense)} bytes, {sparse}: {os.path.getsize(sparse)} ({ratio:.2f}x smaller)")
    assert ratio > 2.5, ratio
h32, s32 = F("sparse32.ff")
assert s32.dtype == np.float32 and np.array_equal(s32, F("dense.ff")[1].astype(np.float32))
PY
fi
"$solve" dense.ff --errors dense.err -q -o dense.rad
"$solve" sparse.ff --errors sparse.err -q -o sparse.rad
cmp dense.rad sparse.rad || fail "solve gives other radiosities from the sparse file"
# solve keeps the sparse file's tiles as they are (never the dense matrix):
# every method sums the same entries in the same order, so the same bits.
for m in jacobi gauss-seidel cg; do
  "$solve" dense.ff -q --method $m -o dense_$m.rad --by-group dense_$m.csv
  "$solve" sparse.ff -q --method $m -o sparse_$m.rad --by-group sparse_$m.csv
  cmp dense_$m.rad sparse_$m.rad && cmp dense_$m.csv sparse_$m.csv || fail "solve --method $m differs on the sparse file"
done
if [ -n "$numpy" ]; then
  "$py" "$tools/ffdump.py" group-matrix dense.ff -o dense.csv
  "$py" "$tools/ffdump.py" group-matrix sparse.ff -o sparse.csv
  cmp dense.csv sparse.csv || fail "ffdump group-matrix differs"
fi
# Damage: a cut file and a flipped record byte are refused by name.
size=$(wc -c < sparse.ff)
head -c $((size - 100)) sparse.ff > cut.ff
if "$solve" cut.ff -q -o cut.rad 2> cut.log; then fail "solve accepted a truncated file"; fi
grep -q "cut.ff: truncated" cut.log || fail "truncation message: $(cat cut.log)"
[ ! -e cut.rad ] || fail "solve left cut.rad"
"$py" - <<'PY'
import struct
b = bytearray(open("sparse.ff", "rb").read())
moff = struct.unpack_from("<Q", b, 88)[0]
b[moff + 4096] ^= 0x40
open("flip.ff", "wb").write(bytes(b))
PY
if "$solve" flip.ff -q -o flip.rad 2> flip.log; then fail "solve accepted a damaged record"; fi
grep -q "checksum mismatch" flip.log || fail "damage message: $(cat flip.log)"
echo "sparse files: same numbers, same bytes for 1-3 ranks, read by solve and ffdump"
