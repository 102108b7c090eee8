#!/usr/bin/env python3
"""The unoccluded form factors of a run against QUADPACK (scipy), pair by
pair: is each entry within its reported error?

    python3 tools/quadpack_check.py build/formfactor [SCENE.obj] [--subdiv S] [--pairs K]

Runs `formfactor --shadow-rays 0 --errors` (every entry unoccluded, with
the bound of its quadrature), picks the K pairs that are hardest for a
quadrature (those whose patches touch or come closest, relative to their
size) and integrates each again with scipy.integrate.dblquad over the
smaller patch of Lambert's closed-form point-to-polygon factor (clipped
to the front half-space, as formfactor does), to epsabs 1e-13 and epsrel
1e-11. Prints, per pair, F from formfactor, F from QUADPACK, their
difference, and the reported error; then how many differences exceed
the reported error. Needs numpy and scipy (not the test suite).
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy import integrate

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ffread import read_formfactors  # noqa: E402


def point_polygon(x, n, poly, poly_normal):
    """F from a differential area at x (normal n) to the polygon (Lambert),
    over the part in front of x's tangent plane; 0 behind poly's plane."""
    if np.dot(poly_normal, x - poly[0]) <= 0.0:
        return 0.0
    clipped = []
    m = len(poly)
    for k in range(m):
        a, b = poly[k], poly[(k + 1) % m]
        ha, hb = np.dot(n, a - x), np.dot(n, b - x)
        if ha >= 0:
            clipped.append(a)
        if (ha >= 0) != (hb >= 0):
            clipped.append(a + (b - a) * (ha / (ha - hb)))
    s = 0.0
    for k in range(len(clipped)):
        ra, rb = clipped[k] - x, clipped[(k + 1) % len(clipped)] - x
        c = np.cross(ra, rb)
        cl = np.linalg.norm(c)
        if cl > 0:
            s += np.arctan2(cl, np.dot(ra, rb)) * np.dot(n, c) / cl
    return abs(s) / (2 * np.pi)


def g_quadpack(q, nq, p, np_):
    """G = integral over q of F(y -> p), q fanned into triangles mapped
    from the unit triangle."""
    total, err = 0.0, 0.0
    for t in range(1, len(q) - 1):
        o, e1, e2 = q[0], q[t] - q[0], q[t + 1] - q[0]
        jac = np.linalg.norm(np.cross(e1, e2))

        def f(v, u):
            return jac * point_polygon(o + u * e1 + v * e2, nq, p, np_)

        val, e = integrate.dblquad(f, 0, 1, 0, lambda u: 1 - u, epsabs=1e-13, epsrel=1e-11)
        total, err = total + val, err + e
    return total, err


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("formfactor")
    ap.add_argument("scene", nargs="?", default=None)
    ap.add_argument("--subdiv", type=int, default=1)
    ap.add_argument("--pairs", type=int, default=40)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        ff, errs = os.path.join(tmp, "ff"), os.path.join(tmp, "err")
        cmd = [a.formfactor] + ([a.scene] if a.scene else []) + ["--subdiv", str(a.subdiv), "--shadow-rays", "0",
                                                                "-q", "-o", ff, "--errors", errs]
        subprocess.run(cmd, check=True)
        _, verts, patches, F = read_formfactors(ff)
        E = read_formfactors(errs)[3]
    polys = []
    for p in patches:
        idx = [p["v"][k] for k in range(p["vertex_count"])]
        polys.append(np.array([verts[i] for i in idx], dtype=float))
    n = len(patches)
    radius = np.array([max(np.linalg.norm(v - v.mean(0)) for v in [poly]) for poly in polys])
    centre = np.array([poly.mean(0) for poly in polys])
    # Hardness: closest vertex-to-vertex distance over the smaller radius.
    cand = []
    for i in range(n):
        for j in range(i + 1, n):
            if F[i, j] <= 0:
                continue
            if np.linalg.norm(centre[i] - centre[j]) > 2 * (radius[i] + radius[j]):
                continue
            d = min(np.linalg.norm(x - y) for x in polys[i] for y in polys[j])
            cand.append((d / min(radius[i], radius[j]), i, j))
    cand.sort()
    worse = 0
    print("%5s %5s %18s %18s %10s %10s" % ("i", "j", "F formfactor", "F quadpack", "|diff|", "reported"))
    for _, i, j in cand[: a.pairs]:
        q, p = (i, j) if patches[i]["area"] <= patches[j]["area"] else (j, i)
        g, gerr = g_quadpack(polys[q], patches[q]["normal"], polys[p], patches[p]["normal"])
        f_ref = g / patches[i]["area"]
        diff = abs(F[i, j] - f_ref)
        worse += diff > E[i, j] + gerr / patches[i]["area"] + 1e-15
        print("%5d %5d %18.12e %18.12e %10.2e %10.2e" % (i, j, F[i, j], f_ref, diff, E[i, j]))
    print("%d of %d pairs differ from QUADPACK by more than their reported error" % (worse, min(a.pairs, len(cand))))
    return 1 if worse else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
