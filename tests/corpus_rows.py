#!/usr/bin/env python3
"""Row sums of a form-factor file against their standard errors (tests/corpus.sh).

    corpus_rows.py FORMFACTORS ERRORS [--closed TOL]

For every row i, S_i = sum_j F_ij and sigma_i = sqrt(sum_j e_ij^2) from
the --errors file (the entries' standard errors, treated as independent).
Checks S_i <= 1 + 3 sigma_i + 1e-6 (no patch sends out more than all its
light) and, with --closed TOL (a closed scene: every patch sees only
faces), |S_i - 1| <= TOL + 3 sigma_i. Prints one summary line (worst row
above 1 in sigmas, min and max row sum, the worst rows) and exits 1 on a
violation, 77 without numpy. Reads rows in blocks, so large files fit.
"""
import argparse
import os
import sys

try:
    import numpy as np
except ImportError:
    print("numpy missing: skipped")
    sys.exit(77)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from ffread import read_header, read_rows  # noqa: E402

BLOCK = 256


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ff")
    ap.add_argument("err")
    ap.add_argument("--closed", type=float, default=None)
    a = ap.parse_args()
    h, he = read_header(a.ff), read_header(a.err)
    n = int(h["patch_count"])
    if int(he["patch_count"]) != n:
        print(f"FAIL: {a.err} has {int(he['patch_count'])} rows, {a.ff} {n}")
        return 1
    sums = np.zeros(n)
    sigma = np.zeros(n)
    for b in range(0, n, BLOCK):
        e = min(n, b + BLOCK)
        F = read_rows(a.ff, h, b, e).astype(np.float64)
        E = read_rows(a.err, he, b, e).astype(np.float64)
        if not np.all(np.isfinite(F)) or not np.all(np.isfinite(E)):
            print(f"FAIL: non-finite entries in rows {b}..{e - 1}")
            return 1
        if (F < 0).any():
            i, j = np.unravel_index(np.argmin(F), F.shape)
            print(f"FAIL: negative entry F[{b + i}][{j}] = {F[i, j]:.3g}")
            return 1
        sums[b:e] = F.sum(axis=1)
        sigma[b:e] = np.sqrt((E * E).sum(axis=1))
    over = sums - (1 + 3 * sigma + 1e-6)
    bad = np.flatnonzero(over > 0)
    status = 0
    worst = int(np.argmax(sums)) if n else 0
    line = (f"rows {n}: sum min {sums.min():.6f} max {sums.max():.6f} (row {worst}, sigma {sigma[worst]:.2e})"
            if n else "rows 0")
    if len(bad):
        status = 1
        top = bad[np.argsort(-sums[bad])][:3]
        line += f"; FAIL: {len(bad)} rows above 1 + 3 sigma: " + ", ".join(
            f"row {i} sum {sums[i]:.6f} sigma {sigma[i]:.2e}" for i in top)
    if a.closed is not None and n:
        off = np.abs(sums - 1) - (a.closed + 3 * sigma)
        open_rows = np.flatnonzero(off > 0)
        if len(open_rows):
            status = 1
            top = open_rows[np.argsort(-np.abs(sums[open_rows] - 1))][:3]
            line += f"; FAIL: closed scene, {len(open_rows)} rows off 1 by more than {a.closed:g} + 3 sigma: " + \
                ", ".join(f"row {i} sum {sums[i]:.6f} sigma {sigma[i]:.2e}" for i in top)
    print(line)
    return status


if __name__ == "__main__":
    sys.exit(main())
