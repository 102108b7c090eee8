#!/usr/bin/env python3
"""Closure and reciprocity of the default (quadrature) form factors, through
the formfactor program:

  - the closed box (a convex room: no shadow rays, every entry by
    quadrature) at --subdiv 0..3: every row sums to 1 within 1e-9 (the
    issue's bar is 1e-6; measured 2e-11), and A_i F_ij = A_j F_ji to the bit;
  - cornell_sphere --subdiv 2 (closed, occluded: the visible fractions are
    estimated): every row within 5 of its standard errors, sqrt(sum sigma^2),
    plus 1e-6, of 1 and within 1e-2 (measured 6e-3), and the mean row sum
    within 1e-4 of 1.

    closure.py FORMFACTOR SCENES_DIR WORKDIR
"""
import os
import subprocess
import sys

import numpy as np

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
check(np.abs(rows - 1).max() <= 1e-2, f"cornell_sphere --subdiv 2: worst |row sum - 1| <= 1e-2 (measured 6e-3)")
check(abs(rows.mean() - 1) <= 1e-4, f"cornell_sphere --subdiv 2: mean row sum {rows.mean():.7f} within 1e-4 of 1")
sys.exit(1 if failures else 0)
