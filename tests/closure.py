#!/usr/bin/env python3
"""Closure and reciprocity of the default (quadrature) form factors, through
the formfactor program:

  - the closed box (a convex room: no shadow rays, every entry by
    quadrature) at --subdiv 0..3: every row sums to 1 within 1e-9 (the
    issue's bar is 1e-6; measured 2e-11), and A_i F_ij = A_j F_ji to the bit;
  - cornell_sphere --subdiv 2 (closed, occluded: the visible fractions are
    estimated): every row within 5 of its standard errors, sqrt(sum sigma^2),
    plus 1e-6, of 1 and within 1e-2, and the mean row sum within 1e-4 of 1;
    at --subdiv 3 (the paper's workload) every row within 1e-3 of 1;
  - a touching, partly hidden pair of the built-in box converges as its
    shadow rays grow (below).

    closure.py FORMFACTOR SCENES_DIR WORKDIR
"""
import os
import subprocess
import sys

try:
    import numpy as np
except ImportError:  # the device machine's /usr/bin/python3 has none
    print("skipped: no numpy")
    sys.exit(77)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from ffread import read_formfactors  # noqa: E402

ff, scenes, work = sys.argv[1:4]
os.makedirs(work, exist_ok=True)
failures = 0


def check(ok, message):
    global failures
    print(("ok: " if ok else "FAIL: ") + message)
    failures += not ok


def run(scene, subdiv, errors=False):
    out = os.path.join(work, f"{scene}_{subdiv}")
    cmd = [ff, os.path.join(scenes, scene + ".obj"), "--subdiv", str(subdiv), "-q", "-o", out]
    if errors:
        cmd += ["--errors", out + ".err"]
    subprocess.run(cmd, check=True)
    _, _, patches, F = read_formfactors(out)
    E = read_formfactors(out + ".err")[3].astype(np.float64) if errors else None
    return patches["area"], F, E


for subdiv in range(4):
    A, F, _ = run("closed_box", subdiv)
    worst = np.abs(F.sum(axis=1) - 1).max()
    G = A[:, None] * F
    check(worst <= 1e-9, f"closed_box --subdiv {subdiv} (N = {len(A)}): worst |row sum - 1| = {worst:.2e} <= 1e-9")
    check(np.abs(G - G.T).max() <= 1e-15 * G.max(), f"closed_box --subdiv {subdiv}: A_i F_ij = A_j F_ji")

A, F, E = run("cornell_sphere", 2, errors=True)
rows = F.sum(axis=1)
sigma = np.sqrt((E ** 2).sum(axis=1))
z = np.abs(rows - 1) / (sigma + 1e-6)
check(z.max() <= 5, f"cornell_sphere --subdiv 2: worst |row sum - 1| = {np.abs(rows - 1).max():.2e}, "
      f"at most {z.max():.2f} of its standard errors (<= 5)")
check(np.abs(rows - 1).max() <= 1e-2, f"cornell_sphere --subdiv 2: worst |row sum - 1| <= 1e-2 (measured 1.2e-3)")
check(abs(rows.mean() - 1) <= 1e-4, f"cornell_sphere --subdiv 2: mean row sum {rows.mean():.7f} within 1e-4 of 1")
# The paper's workload, at default settings: the bar is 1e-3
# (measured 4.4e-4 ... 7.6e-4 over seeds 1-5).
A, F, _ = run("cornell_sphere", 3)
worst = np.abs(F.sum(axis=1) - 1).max()
check(worst <= 1e-3, f"cornell_sphere --subdiv 3 (N = {len(A)}): worst |row sum - 1| = {worst:.2e} <= 1e-3")
# A touching pair partly hidden: the built-in Cornell box at --subdiv 1, a
# left-wall patch (normal +x) and the floor patch it touches, behind the
# short block (the case: a cosine-weighted ray caster gives 0.1375 -
# 0.1405; Monte Carlo gave 0.096 - 0.159 depending on samples and seed). As
# the shadow rays grow, the reported error must fall (monotonically) and
# every estimate stay within 4 of its errors of the 8192-ray one. The
# pair is the issue's, on the faces as they are (--contacts keep: cut, the
# floor patch there is a different piece).
estimates = []
for rays in (32, 128, 512, 2048, 8192):
    out = os.path.join(work, f"box_{rays}")
    subprocess.run([ff, "--subdiv", "1", "--contacts", "keep", "--shadow-rays", str(rays), "-q", "-o", out, "--errors", out + ".err"],
                   check=True)
    _, _, patches, F = read_formfactors(out)
    E = read_formfactors(out + ".err")[3]
    n, c = patches["normal"], patches["centroid"]
    wall = [i for i in range(len(c)) if n[i][0] > 0.9 and c[i][1] < 200 and c[i][2] < 200]
    floor = [j for j in range(len(c)) if n[j][1] > 0.9 and c[j][1] < 1 and c[j][0] < 200 and c[j][2] < 200]
    i, j = wall[0], floor[0]
    estimates.append((rays, float(F[i, j]), float(E[i, j])))
ref, ref_error = estimates[-1][1], estimates[-1][2]
print("touching, partly hidden pair: " + ", ".join(f"R={r}: {f:.4f} +- {e:.4f}" for r, f, e in estimates))
check(0.13 < ref < 0.15, f"touching pair converges to {ref:.4f} +- {ref_error:.4f} (ray caster: 0.1375 - 0.1405)")
check(all(a[2] > b[2] for a, b in zip(estimates, estimates[1:])), "its reported error falls as the rays grow")
check(all(abs(f - ref) <= 4 * e + 4 * ref_error for _, f, e in estimates), "every estimate within 4 errors of the last")
sys.exit(1 if failures else 0)
