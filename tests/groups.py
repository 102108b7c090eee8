#!/usr/bin/env python3
"""Results by surface (issue 17): the group table of the form-factor file,
`solve --by-group` and `tools/ffdump.py`, through the programs.

    groups.py solve  FORMFACTOR SOLVE TOOLS_DIR SCENES_DIR WORKDIR
    groups.py ffdump FORMFACTOR SOLVE TOOLS_DIR SCENES_DIR WORKDIR

Both run formfactor on the built-in Cornell box (no scene argument,
--subdiv 1, one rank) and check the group table against the scene's OBJ and
MTL files, read here independently: the groups are its eight objects, in
file order, and each patch is in the group of its source face.

solve: `solve --by-group` as CSV and as .npy (equal to the bit) against
numbers computed here from the form-factor and radiosity files: patches,
area, the area-weighted mean radiosity, emitted power (the light's is its
130 x 105 opening times Ke of the MTL; every other group emits 0) and
absorbed power, sum_i A_i (1 - rho_i) (F B)_i; summed over groups, emitted
and absorbed equal the energy balance of `--stats`. Bad uses: an
extension other than .csv / .npy (exit 2), --by-group and -o naming one
file (exit 2); a file without a group table is solve_cli_by_group_no_table.

ffdump: `groups`; `group-matrix` as CSV and .npy against masked sums of the
dense matrix; reciprocity A_G F_GH = A_H F_HG to 1e-9 relative; rows of
closed scenes sum to 1: closed_box (one group, exact) within 1e-9 and
cornell_sphere (box and sphere, shadow rays) within 5 standard errors of
the group row (from formfactor --errors) and 1e-3; rows of the open
Cornell box at most 1. `matrix` (.npy and .csv) equals the dense matrix;
`heatmap` writes a PNG of the requested size. Bad uses: an --errors file
for group-matrix, a wrong extension, a file without groups.
"""
import csv
import json
import os
import re
import struct
import subprocess
import sys

try:
    import numpy as np
except ImportError:  # CI installs python3-numpy; a bare machine (the GPU one) may lack it
    print("numpy is missing: skipped")
    sys.exit(77)

mode, ff_prog, solve_prog, tools, scenes, work = sys.argv[1:7]
sys.path.insert(0, tools)
from ffread import read_formfactors, read_groups  # noqa: E402

os.makedirs(work, exist_ok=True)
os.chdir(work)
FFDUMP = [sys.executable, os.path.join(tools, "ffdump.py")]
failures = 0


def check(ok, message):
    global failures
    print(("ok: " if ok else "FAIL: ") + message)
    failures += not ok


def run(cmd, code=0):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != code:
        print(p.stdout + p.stderr)
        raise SystemExit(f"FAIL: {' '.join(map(str, cmd))}: exit {p.returncode}, expected {code}")
    return p


def rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(a), np.abs(b))
    return float(np.max(np.where(scale > 0, np.abs(a - b) / np.where(scale > 0, scale, 1), 0)))


def obj_groups(path):
    """(objects in file order, group of each face) - `g`/`o` and `f` lines."""
    objects, face_group, current = [], [], "default"
    for line in open(path):
        t = line.split()
        if t and t[0] in ("g", "o"):
            current = t[1] if len(t) > 1 else "default"
        elif t and t[0] == "f":
            if current not in objects:
                objects.append(current)
            face_group.append(current)
    return objects, face_group


def mtl_emission(path, material):
    current, ke = None, np.zeros(3)
    for line in open(path):
        t = line.split()
        if t and t[0] == "newmtl":
            current = t[1]
        elif t and t[0] == "Ke" and current == material:
            ke = np.array([float(x) for x in t[1:4]])
    return ke


def read_radiosity(path):
    head = open(path, "rb").read(256)
    assert head[:8] == b"RADRAD\r\n"
    n = struct.unpack_from("<Q", head, 16)[0]
    offset = struct.unpack_from("<Q", head, 128)[0]
    return np.fromfile(path, "<f8", 3 * n, offset=offset).reshape(n, 3)


def png_size(path):
    head = open(path, "rb").read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return struct.unpack(">II", head[16:24])


# ---- the built-in Cornell box and its group table ----
run([ff_prog, "--subdiv", "1", "-q", "-o", "cb.ff"])
h, _, patches, F = read_formfactors("cb.ff")
F = F.astype(np.float64)
names, patch_group = read_groups("cb.ff")
objects, face_group = obj_groups(os.path.join(scenes, "cornell_box.obj"))
n, A = len(patches), patches["area"]
check(int(h["version"]) in (2, 3) and n == 91, f"cb.ff: version {int(h['version'])}, N = {n}")
check(names == objects and len(objects) == 8, f"groups {names} are the box's objects {objects}")
check(names is not None and all(names[patch_group[i]] == face_group[patches["source_face"][i]] for i in range(n)),
      "every patch is in the group of its face")
G = len(names)
members = [np.flatnonzero(patch_group == g) for g in range(G)]
light = names.index("light")
light_area = 130.0 * 105.0   # the opening of scenes/cornell_box.obj: x 213..343, z 227..332 (mm)
ke = mtl_emission(os.path.join(scenes, "cornell_box.mtl"), "light")


def read_group_csv(path):
    rows = list(csv.reader(open(path, newline="")))
    return rows[0], rows[1:]


if mode == "solve":
    run([solve_prog, "cb.ff", "-o", "cb.rad", "--by-group", "cb.csv", "--stats", "cb.json", "-q"])
    run([solve_prog, "cb.ff", "-o", "cb2.rad", "--by-group", "cb.npy", "-q"])
    header, rows = read_group_csv("cb.csv")
    check(header == ["group", "patches", "area"] + [f"{q}_{c}" for q in ("radiosity", "emitted", "absorbed")
                                                    for c in "rgb"], f"CSV header {header}")
    check([r[0] for r in rows] == objects, "CSV rows: the objects, in file order")
    num = np.array([[float(x) for x in r[1:]] for r in rows])
    B = read_radiosity("cb.rad")
    H = F @ B                                    # what each patch receives per unit area
    rho, E = patches["rho"], patches["emission"]
    want_area = np.array([A[m].sum() for m in members])
    want_b = np.array([(A[m, None] * B[m]).sum(axis=0) for m in members]) / want_area[:, None]
    want_e = np.array([(A[m, None] * E[m]).sum(axis=0) for m in members])
    want_abs = np.array([(A[m, None] * (1 - rho[m]) * H[m]).sum(axis=0) for m in members])
    check(np.array_equal(num[:, 0], [len(m) for m in members]), f"patches per group {num[:, 0].astype(int)}")
    check(rel(num[:, 1], want_area) <= 1e-12, f"areas (rel. error {rel(num[:, 1], want_area):.1e})")
    check(rel(num[:, 2:5], want_b) <= 1e-12, f"mean radiosity = sum A B / A_G (rel. {rel(num[:, 2:5], want_b):.1e})")
    check(rel(num[:, 5:8], want_e) <= 1e-12, "emitted = sum A E per group")
    check(abs(num[light, 1] - light_area) <= 1e-9 * light_area, f"light area {num[light, 1]} = 130 x 105")
    check(rel(num[light, 5:8], light_area * ke) <= 1e-12 and ke.max() > 0,
          f"light emits area x Ke = {light_area} x {ke} = {num[light, 5:8]}")
    check(np.all(np.delete(num[:, 5:8], light, axis=0) == 0), "no other group emits")
    check(rel(num[:, 8:11], want_abs) <= 1e-9,
          f"absorbed = sum A (1 - rho) (F B) per group (rel. {rel(num[:, 8:11], want_abs):.1e})")
    stats = json.load(open("cb.json"))
    for c, channel in enumerate(stats["channels"]):
        energy = channel["energy"]
        check(rel(num[:, 5 + c].sum(), energy["emitted"]) <= 1e-12 and
              rel(num[:, 8 + c].sum(), energy["absorbed"]) <= 1e-9,
              f"{channel['channel']}: groups sum to the stats' emitted {energy['emitted']:.9g} and absorbed "
              f"{energy['absorbed']:.9g}")
    a = np.load("cb.npy", allow_pickle=False)
    check(list(a.dtype.names) == ["group", "patches", "area", "radiosity", "emitted", "absorbed"],
          f"npy dtype {a.dtype}")
    check([x.decode() for x in a["group"]] == objects, "npy groups")
    flat = np.column_stack([a["patches"], a["area"], a["radiosity"], a["emitted"], a["absorbed"]])
    check(np.array_equal(flat, num), "npy = CSV, to the bit")
    # Bad uses.
    p = run([solve_prog, "cb.ff", "-o", "bad.rad", "--by-group", "cb.txt"], code=2)
    check("--by-group: 'cb.txt': the name must end in .csv or .npy" in p.stderr, "a .txt name: exit 2, said why")
    p = run([solve_prog, "cb.ff", "-o", "cb.csv", "--by-group", "cb.csv"], code=2)
    check("name the same file" in p.stderr, "--by-group and -o on one file: refused")
    # (A form-factor file without a group table: solve_cli_by_group_no_table.)

elif mode == "ffdump":
    # groups
    p = run(FFDUMP + ["groups", "cb.ff"])
    rows = list(csv.reader(p.stdout.splitlines()))
    check([r[1] for r in rows[1:]] == objects and [int(r[2]) for r in rows[1:]] == [len(m) for m in members],
          "ffdump groups: names and patch counts")
    # group-matrix, against masked sums of the dense matrix
    run(FFDUMP + ["group-matrix", "cb.ff", "-o", "cbg.csv", "-o", "cbg.npy"])
    M = np.load("cbg.npy", allow_pickle=False)
    header, rows = read_group_csv("cbg.csv")
    Mc = np.array([[float(x) for x in r[1:]] for r in rows])
    AG = np.array([A[m].sum() for m in members])
    want = np.array([[(A[mg, None] * F[np.ix_(mg, mh)]).sum() / AG[g] for mh in members]
                     for g, mg in enumerate(members)])
    check(header == ["group"] + objects and [r[0] for r in rows] == objects, "group-matrix CSV: names on both axes")
    check(M.shape == (G, G) and np.array_equal(M, Mc), "group-matrix: .npy = .csv, to the bit")
    check(rel(M, want) <= 1e-12, f"F_GH = sum_(i in G) A_i sum_(j in H) F_ij / A_G (rel. {rel(M, want):.1e})")
    AM = AG[:, None] * M
    check(rel(AM, AM.T) <= 1e-9, f"reciprocity A_G F_GH = A_H F_HG (rel. {rel(AM, AM.T):.1e})")
    check(M.sum(axis=1).max() <= 1 + 1e-9 and M.sum(axis=1).min() > 0.5,
          f"open box: rows {M.sum(axis=1).min():.4f} .. {M.sum(axis=1).max():.6f}, at most 1")
    ceiling = names.index("ceiling")
    check(M[light, light] == 0 and M[light, ceiling] == 0 and M[ceiling, light] == 0 and M[light].min() == 0,
          "the light and the ceiling around it (one plane) do not see each other: exactly 0")
    # closed scenes
    run([ff_prog, os.path.join(scenes, "closed_box.obj"), "--subdiv", "1", "-q", "-o", "box.ff"])
    run(FFDUMP + ["group-matrix", "box.ff", "-o", "box.npy"])
    Mb = np.load("box.npy")
    check(Mb.shape == (1, 1) and abs(Mb[0, 0] - 1) <= 1e-9, f"closed_box: one group, F = 1 - {1 - Mb[0, 0]:.1e}")
    run([ff_prog, os.path.join(scenes, "cornell_sphere.obj"), "--subdiv", "1", "-q", "-o", "cs.ff",
         "--errors", "cs.err"])
    run(FFDUMP + ["group-matrix", "cs.ff", "-o", "cs.npy"])
    Ms = np.load("cs.npy")
    _, _, ps, _ = read_formfactors("cs.ff")
    sigma = read_formfactors("cs.err")[3].astype(np.float64)
    sn, spg = read_groups("cs.ff")
    As = ps["area"]
    # sigma of a group's row sum: sum_(i in G) A_i (sum_j F_ij) / A_G, entries independent
    sig_g = np.array([np.sqrt(((As[spg == g] ** 2) * (sigma[spg == g] ** 2).sum(axis=1)).sum()) /
                      As[spg == g].sum() for g in range(len(sn))])
    dev = np.abs(Ms.sum(axis=1) - 1)
    check(sn == ["box", "sphere"] and np.all(dev <= 5 * sig_g + 1e-6) and np.all(dev <= 1e-3),
          f"cornell_sphere: groups {sn}, |row - 1| = {dev} within 5 x sigma {sig_g} + 1e-6 and 1e-3")
    AMs = np.array([As[spg == g].sum() for g in range(len(sn))])[:, None] * Ms
    check(rel(AMs, AMs.T) <= 1e-9, f"cornell_sphere: reciprocity (rel. {rel(AMs, AMs.T):.1e})")
    # matrix
    run(FFDUMP + ["matrix", "cb.ff", "-o", "cbm.npy", "-o", "cbm.csv"])
    D = np.load("cbm.npy", allow_pickle=False)
    check(D.dtype == np.float64 and np.array_equal(D, F), "matrix .npy equals the dense matrix")
    rows = list(csv.reader(open("cbm.csv", newline="")))
    check(rows[0][:2] == ["patch", "group"] and len(rows) == n + 1 and
          [r[1] for r in rows[1:]] == [names[g] for g in patch_group], "matrix CSV: patch and group columns")
    check(np.array_equal(np.array([[float(x) for x in r[2:]] for r in rows[1:]]), F), "matrix CSV equals it too")
    # heatmap
    for f in ("heat.png", "heat640.png"):
        if os.path.exists(f):
            os.remove(f)
    run(FFDUMP + ["heatmap", "cb.ff", "-o", "heat.png"])
    run(FFDUMP + ["heatmap", "cs.ff", "--pixels", "640", "-o", "heat640.png"])
    check(png_size("heat.png") == (1000, 1000), f"heat map: PNG {png_size('heat.png')}, 1000 x 1000 by default")
    check(png_size("heat640.png") == (640, 640), f"heat map --pixels 640: PNG {png_size('heat640.png')}")
    check(not [f for f in os.listdir(".") if re.search(r"\.tmp-", f)], "no temporaries left")
    # Bad uses: nothing written, a message.
    p = run(FFDUMP + ["group-matrix", "cs.err", "-o", "err.csv"], code=1)
    check("standard errors" in p.stderr and not os.path.exists("err.csv"), "group-matrix of an --errors file: refused")
    p = run(FFDUMP + ["group-matrix", "cb.ff", "-o", "cbg.txt"], code=1)
    check("must end in .csv or .npy" in p.stderr and not os.path.exists("cbg.txt"), "a .txt name: refused")
    p = run(FFDUMP + ["groups", "no-such-file"], code=1)
    check("no-such-file" in p.stderr, "a missing file: named")
else:
    raise SystemExit(f"unknown mode {mode}")

sys.exit(1 if failures else 0)
