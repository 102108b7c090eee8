#!/bin/sh
# The refinement loop end to end (formfactor --refine --reuse, solve,
# render): the split is what the stats say (N + 3 x split patches, groups
# kept), unsplit pairs are copied from the previous matrix (--reuse) to the
# rounding of F = c A, a closed scene keeps its energy balance after two
# passes (sum A (1 - rho) B = sum A E, as its rows sum to 1), and mismatched
# or foreign inputs are refused with a message and nothing written.
#   refine_loop.sh FORMFACTOR SOLVE RENDER|- PYTHON TOOLS SCENES WORKDIR
set -eu
ff=$1 solve=$2 render=$3 py=$4 tools=$5 scenes=$6 dir=$7
mkdir -p "$dir" && cd "$dir" && rm -rf ./*
export OMP_NUM_THREADS=2
fail() { echo "FAIL: $*"; exit 1; }
json_count() { tr -d '\n ' < "$1" | sed -n "s/.*\"$2\":\([0-9]*\).*/\1/p" | head -n 1; }

# The Cornell box: --subdiv 1, then one refinement pass with reuse (the
# CPU backend's: the CUDA backend computes every pair).
"$ff" --subdiv 1 -q -o ff0 --stats ff0.json
"$solve" ff0 -q -o rad0 2>/dev/null
"$ff" --refine rad0 --reuse ff0 --backend cpu -q -o ff1 --stats ff1.json
n0=$(json_count ff0.json patches)
n1=$(json_count ff1.json patches)
split=$(tr -d '\n ' < ff1.json | sed -n 's/.*"refine":{[^}]*"split":\([0-9]*\).*/\1/p')
reused=$(json_count ff1.json pairs_reused)
echo "refine: $n0 -> $n1 patches, $split split, $reused pairs reused"
[ "$n0" -eq 91 ] || fail "--subdiv 1 gave $n0 patches (80 cells, 11 more where the blocks stand)"
[ "$split" -gt 0 ] && [ "$split" -lt "$n0" ] || fail "split $split of $n0"
[ "$n1" -eq $((n0 + 3 * split)) ] || fail "$n1 patches after splitting $split of $n0"
[ "$reused" -gt 0 ] || fail "no pair reused"
"$solve" ff1 -q -o rad1 2>/dev/null
if [ "$render" != - ]; then
  "$render" rad1 -q -o rad1.png || fail "render refused the refined solution"
  "$render" rad1 -q --shading linear -o rad1_linear.png || fail "render --shading linear"
fi

# Inputs that do not belong together are refused, and nothing is left.
if "$ff" --refine rad0 --reuse ff1 -q -o bad 2>err.txt; then fail "--reuse of another mesh's matrix accepted"; fi
grep -q "not the form factors of the mesh" err.txt || { cat err.txt; fail "no clear message for a foreign --reuse"; }
if "$ff" "$scenes/closed_box.obj" --refine rad0 -q -o bad 2>err.txt; then fail "--refine of another scene accepted"; fi
grep -q "solved for another scene" err.txt || { cat err.txt; fail "no clear message for another scene"; }
if "$ff" --refine rad0 --reuse ff0 --shadow-rays 8 -q -o bad 2>err.txt; then fail "--reuse with other settings accepted"; fi
grep -q "reuse needs the same settings" err.txt || { cat err.txt; fail "no clear message for other settings"; }
if "$ff" --reuse ff0 -q -o bad 2>err.txt; then fail "--reuse without --refine accepted"; fi
[ ! -e bad ] || fail "a refused run left its output"

# A closed box (every row sums to 1): two passes, a budget, reuse.
"$ff" "$scenes/closed_box.obj" --subdiv 2 -q -o box0
"$solve" box0 -q -o boxrad0
"$ff" "$scenes/closed_box.obj" --refine boxrad0 --reuse box0 --refine-tol 0.01 --backend cpu -q -o box1 --stats box1.json
"$solve" box1 -q -o boxrad1
"$ff" "$scenes/closed_box.obj" --refine boxrad1 --reuse box1 --refine-tol 0.01 --refine-max-patches 400 -q -o box2 \
  --stats box2.json
"$solve" box2 -q -o boxrad2
b1=$(json_count box1.json patches) b2=$(json_count box2.json patches)
echo "closed box: 96 -> $b1 -> $b2 patches"
[ "$b1" -gt 96 ] && [ "$b2" -gt "$b1" ] || fail "the closed box was not refined ($b1, $b2)"
balanced=$(tr -d '\n ' < box2.json | sed -n 's/.*"balanced":\([0-9]*\).*/\1/p')
[ "$b2" -le $((400 + 3 * balanced)) ] || fail "--refine-max-patches 400 gave $b2 patches ($balanced balanced)"

if ! "$py" -c "import numpy" 2>/dev/null; then
  echo "numpy missing: the matrix checks are skipped"
  exit 0
fi
"$py" - "$tools" <<'PY' || fail "matrix checks"
import sys, struct
import numpy as np
sys.path.insert(0, sys.argv[1])
from ffread import read_formfactors

def radiosity(path):
    """B per patch and the patch records of a radiosity file (docs/formats.md)."""
    raw = open(path, "rb").read()
    n, = struct.unpack_from("<Q", raw, 16)
    patch_off, rad_off = struct.unpack_from("<QQ", raw, 120)
    from ffread import PATCH
    patches = np.frombuffer(raw, dtype=PATCH, count=n, offset=patch_off)
    B = np.frombuffer(raw, dtype="<f8", count=3 * n, offset=rad_off).reshape(n, 3)
    return patches, B

# Reuse: every pair of two unsplit patches holds the old entry.
_, _, p0, F0 = read_formfactors("ff0")
_, _, p1, F1 = read_formfactors("ff1")
old = {tuple(r["v"]): k for k, r in enumerate(p0)}
same = np.array([old.get(tuple(r["v"]), -1) for r in p1])
keep = np.nonzero(same >= 0)[0]
assert 0 < len(keep) < len(p1), len(keep)
a, b = np.meshgrid(keep, keep, indexing="ij")
new, was = F1[a, b], F0[same[a], same[b]]
err = np.abs(new - was) <= 4e-16 * np.abs(was)
assert err.all(), f"{(~err).sum()} reused entries differ, worst {np.max(np.abs(new - was))}"
# and the pairs with a split patch were computed: they are not all zero
split = np.nonzero(same < 0)[0]
assert F1[np.ix_(split, keep)].sum() > 0.1 * len(split)
print(f"reuse: {len(keep)}^2 entries of unsplit pairs equal the old matrix's")

# Energy: a closed box after two refinement passes.
for name in ("box0", "box2"):
    _, _, p, F = read_formfactors(name)
    rows = F.sum(axis=1)
    assert np.abs(rows - 1).max() < 2e-3, (name, np.abs(rows - 1).max())
    q, B = radiosity("boxrad" + name[-1])
    A, rho, E = q["area"], q["rho"][:, 0], q["emission"][:, 0]
    emitted, absorbed = (A * E).sum(), (A * (1 - rho) * B[:, 0]).sum()
    assert abs(absorbed / emitted - 1) < 2e-3, (name, absorbed / emitted)
    print(f"{name}: {len(p)} patches, max |row sum - 1| {np.abs(rows - 1).max():.2e}, "
          f"absorbed / emitted {absorbed / emitted:.6f}")
PY
echo "refine loop: ok"
