#!/usr/bin/env python3
"""Hierarchical radiosity against the full matrix at equal leaves (issue 26).

For each --link-tol: formfactor --method hierarchical -> solve gives B_h on
the hierarchy's leaves; formfactor --refine of that solution with nothing
split (--refine-tol 1e5) computes the full matrix of the very same leaves,
and solve gives B_f. The error is max |B_h - B_f| / max B_f over leaves and
channels, held against the bound the links file records (--stats
error_bound), with links, leaves and times.

    tools/hier_study.py --build BUILD [--scene S] [--tols 1e-2,1e-3,...] [--uniform | --sized]
                        [--subdiv D] [--oracle O] [--passes P] [--clusters C] [--json OUT]
                        [--check]   (exit 1 unless the error falls monotonically
                                     and every bound covers its error)
"""
import argparse
import json
import os
import struct
import subprocess
import sys
import tempfile
import time

try:
    import numpy as np
except ImportError:
    print("SKIP: needs numpy")
    sys.exit(77)


def read_radiosity(path):
    """B (N x 3), the patches' areas, whether they emit and their normals (N x 3)."""
    head = open(path, "rb").read(256)
    if head[:8] != b"RADRAD\r\n":
        raise SystemExit(f"{path}: not a radiosity file")
    n = struct.unpack_from("<Q", head, 16)[0]
    patches_at, offset = struct.unpack_from("<QQ", head, 120)
    rec = np.fromfile(path, "<f8", 16 * n, offset=patches_at).reshape(n, 16)
    area, emits = rec[:, 3], (rec[:, 13:16] > 0).any(axis=1)
    return np.fromfile(path, "<f8", 3 * n, offset=offset).reshape(n, 3), area, emits, rec[:, 4:7]


def errors(h, f):
    """The largest and the area-weighted RMS |B_h - B_f| over leaves and channels, both over the
    mean radiosity of the leaves that do not emit (area-weighted, brightest channel): the scale
    the links' error bound is given in, and the image's relative RMSE's."""
    (Bh, area, emits, _), (Bf, _, _, _) = h, f
    keep = ~emits if (~emits).any() else np.ones(len(area), bool)
    mean = float(np.sum(area[keep] * Bf[keep].max(axis=1)) / np.sum(area[keep]))
    d = np.abs(Bh - Bf)
    rms = float(np.sqrt(np.sum(area[:, None] * d ** 2) / (3 * np.sum(area))))
    return float(d.max()) / mean, rms / mean


def facing_bias(h, f):
    """The largest relative difference, over the six ways a leaf can face (its normal's largest axis and
    its sign), between the area-weighted mean radiosity (channels summed) of the leaves that face that
    way in two solutions of the same leaves (read_radiosity's); ways holding less than 1 % of the area
    left out. Clusters whose faces face apart, given one irradiance, move light between these
    (docs/hierarchy.md)."""
    (Bh, area, _, normal), (Bf, _, _, _) = h, f
    bh, bf = Bh.sum(axis=1), Bf.sum(axis=1)
    axis = np.abs(normal).argmax(axis=1)
    way = 2 * axis + (normal[np.arange(len(axis)), axis] < 0)
    worst = 0.0
    for w in range(6):
        m = way == w
        if area[m].sum() < 0.01 * area.sum() or not (bf[m] * area[m]).sum() > 0:
            continue
        worst = max(worst, abs(float((bh[m] * area[m]).sum() / (bf[m] * area[m]).sum()) - 1.0))
    return worst


def dark_excess(h, f):
    """The light a solution puts on the leaves that the full matrix of the same leaves leaves dark (the
    brightest channel under a tenth of the mean radiosity of the leaves that do not emit): their
    area-weighted mean B (brightest channel) minus the full matrix's, over that mean. A cluster that gives
    faces hidden at close range (above a lamp, behind a panel) the irradiance of its open faces puts
    light there that the open ones lack (docs/hierarchy.md, "Clusters partly hidden")."""
    (Bh, area, emits, _), (Bf, _, _, _) = h, f
    bh, bf = Bh.max(axis=1), Bf.max(axis=1)
    keep = ~emits if (~emits).any() else np.ones(len(area), bool)
    mean = float(np.sum(area[keep] * bf[keep]) / np.sum(area[keep]))
    dark = keep & (bf < 0.1 * mean)
    if not dark.any():
        return 0.0
    return float(np.sum(area[dark] * (bh[dark] - bf[dark])) / np.sum(area[dark])) / mean


def run(cmd, env=None):
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        sys.stderr.write(r.stderr)
        raise SystemExit(f"failed ({r.returncode}): {' '.join(cmd)}")
    return time.perf_counter() - t0


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--build", default="build", help="where formfactor and solve are [build]")
    p.add_argument("--formfactor", default=None, help="formfactor program [BUILD/formfactor]")
    p.add_argument("--solve", default=None, help="solve program [BUILD/solve]")
    p.add_argument("--solve-tol", default="1e-10", help="both solves' --tol [1e-10]")
    p.add_argument("--max-error", type=float, default=None,
                   help="exit 1 if some error exceeds this (the exactness test at --link-tol 0)")
    p.add_argument("--scene", default=None, help="OBJ (default: the built-in Cornell box)")
    p.add_argument("--tols", default="1e-2,3e-3,1e-3,3e-4,1e-4")
    p.add_argument("--subdiv", type=int, default=None, help="finest level (formfactor --subdiv)")
    p.add_argument("--oracle", default="auto", help="formfactor --oracle [auto]")
    p.add_argument("--passes", type=int, default=None)
    p.add_argument("--clusters", default=None, help="formfactor --clusters (auto, on, off)")
    p.add_argument("--cluster-cone", default=None, help="formfactor --cluster-cone (degrees)")
    p.add_argument("--cluster-open", default=None, help="formfactor --cluster-open (openness spread)")
    p.add_argument("--max-rms", type=float, default=None,
                   help="exit 1 if, at some tolerance, the area-weighted RMS error (relative to the mean "
                        "radiosity, as reported) exceeds this")
    p.add_argument("--max-facing-bias", type=float, default=None,
                   help="exit 1 if, at some tolerance, the leaves facing one of the six axis directions are "
                        "brighter or darker on average than the full matrix's by more than this (relative)")
    p.add_argument("--max-dark-excess", type=float, default=None,
                   help="exit 1 if, at some tolerance, the leaves the full matrix leaves dark are brighter than "
                        "its by more than this on average (relative to the mean radiosity; dark_excess)")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--json", default=None)
    p.add_argument("--check", action="store_true")
    p.add_argument("--shape-gain", type=float, default=None,
                   help="with --flat: exit 1 unless the shaped solve's RMS error is below the flat one's by this "
                        "factor at every tolerance")
    p.add_argument("--max-imbalance", type=float, default=None,
                   help="exit 1 unless solve's energy balance (--stats) is within this, relative, at every "
                        "tolerance, and the shaped solve ran (a closed scene: emitted = absorbed)")
    p.add_argument("--flat", action="store_true",
                   help="also solve with --shape off and report that error beside (error_flat, rms_flat)")
    p.add_argument("--uniform", action="store_true",
                   help="formfactor --uniform-leaves: every tolerance on the same leaves (the --subdiv mesh), "
                        "whose full matrix is computed once")
    p.add_argument("--sized", action="store_true",
                   help="formfactor --sized-leaves: every tolerance on the same leaves (each face split to the "
                        "largest face's leaf size), whose full matrix is computed once")
    a = p.parse_args(argv)
    ff = a.formfactor or os.path.join(a.build, "formfactor")
    solve = a.solve or os.path.join(a.build, "solve")
    env = dict(os.environ)
    if a.threads:
        env["OMP_NUM_THREADS"] = str(a.threads)
    scene = [a.scene] if a.scene else []
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for tol in a.tols.split(","):
            lk, st = os.path.join(work, "h.ff"), os.path.join(work, "h.json")
            hr, fr = os.path.join(work, "h.rad"), os.path.join(work, "f.rad")
            full = os.path.join(work, "f.ff")
            cmd = [ff, *scene, "--method", "hierarchical", "--link-tol", tol, "--oracle", a.oracle, "-q",
                   "-o", lk, "--stats", st]
            if a.subdiv is not None:
                cmd += ["--subdiv", str(a.subdiv)]
            if a.passes:
                cmd += ["--passes", str(a.passes)]
            if a.uniform:
                cmd += ["--uniform-leaves"]
            if a.sized:
                cmd += ["--sized-leaves"]
            if a.clusters:
                cmd += ["--clusters", a.clusters]
            if a.cluster_cone:
                cmd += ["--cluster-cone", a.cluster_cone]
            if a.cluster_open:
                cmd += ["--cluster-open", a.cluster_open]
            t_links = run(cmd, env)
            sst = os.path.join(work, "s.json")
            # closure off: the links against the full matrix of the same leaves, which solve
            # leaves as it is (closure would balance only the links' rows; docs/hierarchy.md)
            t_solve = run([solve, lk, "-q", "--closure", "off", "--tol", a.solve_tol, "-o", hr, "--stats", sst], env)
            sstats = json.load(open(sst))
            if a.flat:
                run([solve, lk, "-q", "--closure", "off", "--tol", a.solve_tol, "--shape", "off", "-o", hr + ".flat"],
                    env)
            stats = json.load(open(st))
            if not ((a.uniform or a.sized) and rows):
                t_full = run([ff, *scene, "--refine", hr, "--refine-tol", "1e5", "-q", "-o", full], env)
                t_full += run([solve, full, "-q", "--tol", a.solve_tol, "-o", fr], env)
            h, f = read_radiosity(hr), read_radiosity(fr)
            err, rms = errors(h, f)
            bias = facing_bias(h, f)
            dark = dark_excess(h, f)
            flat = errors(read_radiosity(hr + ".flat"), f) if a.flat else (None, None)
            rows.append({"link_tol": float(tol), "leaves": stats["leaves"], "elements": stats["elements"],
                         "links": stats["links"], "links_per_leaf": stats["links_per_leaf"],
                         "error": err, "rms": rms, "bound": stats["error_bound"], "seconds": t_links + t_solve,
                         "seconds_full": t_full, "error_flat": flat[0], "rms_flat": flat[1],
                         "imbalance": sstats["balance"]["imbalance"], "shaped": sstats["shaped"],
                         "facing_bias": bias, "dark_excess": dark})
            r = rows[-1]
            print(f"link-tol {tol:>6}: {r['leaves']:7d} leaves {r['links']:9d} links ({r['links_per_leaf']:.1f}/leaf) "
                  f"error {err:.3e} (rms {rms:.2e}) bound {r['bound']:.3e} imbalance {r['imbalance']:.1e}  {r['seconds']:.2f} s "
                  f"(full {t_full:.2f} s) facing bias {bias:.2e} dark excess {dark:.2e}"
                  + (f"  flat: error {flat[0]:.3e} (rms {flat[1]:.2e})" if a.flat else ""), flush=True)
    if a.json:
        json.dump(rows, open(a.json, "w"), indent=1)
    ok = True

    def at_most(key, limit, what):
        """FAIL lines for the rows whose `key` is over `limit` (not a number counts as over)."""
        nonlocal ok
        if limit is None:
            return
        for r in rows:
            if not r[key] <= limit:
                print(f"FAIL: link-tol {r['link_tol']}: {what(r[key])} (at most {limit:.1e})")
                ok = False

    at_most("error", a.max_error, lambda v: f"error {v:.3e}")
    if a.max_imbalance is not None:
        for r in rows:
            ends = (r["shaped"] or {}).get("ends", 0)
            if not (abs(r["imbalance"]) <= a.max_imbalance and ends > 0):
                print(f"FAIL: link-tol {r['link_tol']}: imbalance {r['imbalance']:.2e} (at most {a.max_imbalance:.0e}), "
                      f"{ends} shaped link ends (want some)")
                ok = False
    at_most("rms", a.max_rms, lambda v: f"rms error {v:.3e}")
    at_most("dark_excess", a.max_dark_excess,
            lambda v: f"the leaves the full matrix leaves dark are brighter by {v:.3e} of the mean radiosity")
    at_most("facing_bias", a.max_facing_bias,
            lambda v: f"the leaves facing one way are {100 * v:.2f} % off the full matrix's on average")
    if a.shape_gain is not None:
        if not a.flat:
            raise SystemExit("--shape-gain needs --flat")
        for r in rows:
            if not r["rms_flat"] >= a.shape_gain * r["rms"]:
                print(f"FAIL: link-tol {r['link_tol']}: the shaped solve's RMS error {r['rms']:.3e}, flat "
                      f"{r['rms_flat']:.3e}: not {a.shape_gain}x lower")
                ok = False
    if a.check:
        for x, y in zip(rows, rows[1:]):
            if not y["error"] < x["error"]:
                print(f"FAIL: error does not fall from link-tol {x['link_tol']} to {y['link_tol']}")
                ok = False
        for r in rows:
            if not r["bound"] >= r["error"]:
                print(f"FAIL: link-tol {r['link_tol']}: bound {r['bound']:.3e} below the error {r['error']:.3e}")
                ok = False
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
