#!/usr/bin/env python3
"""Contact cutting (core/rad_contact.h) through the formfactor program, on
tests/data/contact_room.obj: a closed unit room holding a cube with a bottom
and a cube without one, both resting on the floor, and a slab passing
through the x = 1 wall.

  - --contacts cut (the default), --subdiv 2: every patch inside the room
    (centroid in [0,1]^3; the slab's part outside the room sees no
    enclosure and is left out) has a row sum within 5 of its standard
    errors, sqrt(sum sigma^2), plus 1e-6, of 1, and within 2e-3 of 1; no
    patch lies under a cube's footprint or inside the slab's cross-section
    of the wall; the cube's bottom (pressed on the floor) has no patches;
    the floor's visible area is 1 - 2 x 0.2 x 0.2 to 1e-12;
  - --contacts keep: the same check fails (patches straddling or under a
    footprint, or pressed on the floor, have rows far below 1: the worst is
    below 0.9), so the first check can fail;
  - the stats JSON records the choice ("contacts": "cut" / "keep").

    contact_closure.py FORMFACTOR DATA_DIR WORKDIR
"""
import json
import os
import subprocess
import sys

try:
    import numpy as np
except ImportError:  # the device machine's Debian python: CTest counts 77 as skipped
    print("numpy missing: skipped")
    sys.exit(77)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from ffread import read_formfactors  # noqa: E402

ff, data, work = sys.argv[1:4]
os.makedirs(work, exist_ok=True)
failures = 0
# Footprints on the floor (x, z ranges) and the slab's cross-section of the x = 1 wall (y, z ranges).
CUBE = ((0.15, 0.35), (0.15, 0.35))
OPEN_CUBE = ((0.6, 0.8), (0.2, 0.4))
SLAB_IN_WALL = ((0.5, 0.6), (0.55, 0.85))


def check(ok, message):
    global failures
    print(("ok: " if ok else "FAIL: ") + message)
    failures += not ok


def run(contacts):
    out = os.path.join(work, f"contact_room_{contacts}")
    cmd = [ff, os.path.join(data, "contact_room.obj"), "--subdiv", "2", "--contacts", contacts, "-q", "-o", out,
           "--errors", out + ".err", "--stats", out + ".json"]
    subprocess.run(cmd, check=True)
    _, _, patches, F = read_formfactors(out)
    E = read_formfactors(out + ".err")[3].astype(np.float64)
    with open(out + ".json") as f:
        stats = json.load(f)
    return patches, F, E, stats


def inside(c, box):
    (a0, a1), (b0, b1) = box
    return a0 < c[0] < a1 and b0 < c[1] < b1


for contacts in ("cut", "keep"):
    patches, F, E, stats = run(contacts)
    check(stats.get("contacts") == contacts, f"{contacts}: stats record contacts {stats.get('contacts')!r}")
    c = patches["centroid"]
    room = np.all((c >= -1e-12) & (c <= 1 + 1e-12), axis=1)
    rows = F.sum(axis=1)[room]
    sigma = np.sqrt((E ** 2).sum(axis=1))[room]
    worst = np.abs(rows - 1).max()
    z = (np.abs(rows - 1) / (sigma + 1e-6)).max()
    closed = z <= 5 and worst <= 2e-3
    print(f"{contacts}: N = {len(c)}, {room.sum()} inside the room, worst |row sum - 1| = {worst:.2e} "
          f"({z:.2f} standard errors), lowest row {rows.min():.4f}")
    floor = np.abs(c[:, 1]) < 1e-12
    floor &= np.abs(patches["normal"][:, 1] - 1) < 1e-12
    wall = (np.abs(c[:, 0] - 1) < 1e-12) & (np.abs(patches["normal"][:, 0] + 1) < 1e-12)
    under = [i for i in np.flatnonzero(floor) if inside(c[i][[0, 2]], CUBE) or inside(c[i][[0, 2]], OPEN_CUBE)]
    in_slab = [i for i in np.flatnonzero(wall) if inside(c[i][[1, 2]], SLAB_IN_WALL)]
    pressed = np.flatnonzero(floor == 0)[np.abs(c[floor == 0][:, 1]) < 1e-12]
    if contacts == "cut":
        check(closed, "cut: every row inside the room sums to 1 (within 5 standard errors + 1e-6, and 2e-3)")
        check(not under, f"cut: no floor patch centroid under a footprint ({len(under)})")
        check(not in_slab, f"cut: no wall patch centroid inside the slab ({len(in_slab)})")
        check(len(pressed) == 0, f"cut: no downward patch pressed on the floor ({len(pressed)}: the cube's bottom)")
        area = patches["area"][floor].sum()
        check(abs(area - (1 - 2 * 0.04)) <= 1e-12, f"cut: visible floor area {area:.15f} = 0.92")
    else:
        check(not closed and rows.min() < 0.9,
              f"keep: rows under and across the footprints fall short (lowest {rows.min():.3f} < 0.9)")
        check(len(under) > 0 and len(pressed) > 0, "keep: floor patches under the footprints, the cube's bottom")

sys.exit(1 if failures else 0)
