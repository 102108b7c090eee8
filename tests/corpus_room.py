#!/usr/bin/env python3
"""Put any OBJ model inside a closed, lit room (python3 standard library only).

    corpus_room.py MODEL.obj OUT.obj [--fit F]

Writes OUT.obj and OUT.mtl (beside it): the model scaled uniformly so that
it fits in F (default 0.6) of the room's width, depth and height, centred
on the room's vertical axis and resting on its floor (its lowest vertex at
y = 0, Y up, as OBJ models and Blender's exports are), then the room.

The model's lines are kept as they are - faces, groups, `vn`, `vt`,
smoothing groups, and anything the loader may refuse - except:
  - `v` lines: x y z transformed (scale, then translate; any w or colour
    after them kept as written); `vn` need no change under a uniform
    positive scale;
  - `mtllib` and `usemtl` lines are dropped: the model gets one material,
    CorpusModel (Kd 0.6), named on a line before its first one, so a model
    whose own MTL files are missing or refused still reaches the numerics
    (its files as they are are what the `alone` runs of tests/corpus.sh read).
Three lines come before the model's, so the model's line N is line N + 3
of OUT.obj in loader messages.

The room is the one tools/make_corpus_blender.py builds in Blender: x and
z in [-2, 2], y in [0, 3], six walls facing inward, the ceiling a 1 x 1 m
light (CorpusLight, Ke 10 9 8) framed by four quads that share its corners,
so the room is closed and watertight (no T-junctions). Its `v` lines come
after the model's and its faces use negative (relative) indices, so the
model's indices, positive or negative, still mean what they meant.
Vertices are collected from every `v` line (unused ones included); a
model without any is written unscaled.
"""
import argparse
import os
import sys

ROOM = (4.0, 3.0, 4.0)  # width (x), height (y), depth (z)
LIGHT = 1.0             # side of the square light in the middle of the ceiling

MTL = """# corpus_room.py materials
newmtl CorpusModel
Kd 0.6 0.6 0.6
Ke 0 0 0

newmtl CorpusWall
Kd 0.7 0.7 0.7
Ke 0 0 0

newmtl CorpusLight
Kd 0.78 0.78 0.78
Ke 10 9 8
"""


def parse_vertex(line):
    """(x, y, z, rest) of a `v` line, or None where it is not one the loader would read."""
    parts = line.split()
    if len(parts) < 4 or parts[0] != "v":
        return None
    try:
        xyz = [float(t) for t in parts[1:4]]
    except ValueError:
        return None
    return xyz, parts[4:]


def room_faces():
    """(material, [corners]) for the room, each face wound to face its inside."""
    hx, hy, hz, hl = ROOM[0] / 2, ROOM[1], ROOM[2] / 2, LIGHT / 2
    faces = [
        ("CorpusWall", [(-hx, 0, -hz), (hx, 0, -hz), (hx, 0, hz), (-hx, 0, hz)]),       # floor
        ("CorpusWall", [(-hx, 0, -hz), (-hx, hy, -hz), (-hx, hy, hz), (-hx, 0, hz)]),   # x = -2
        ("CorpusWall", [(hx, 0, -hz), (hx, hy, -hz), (hx, hy, hz), (hx, 0, hz)]),       # x = +2
        ("CorpusWall", [(-hx, 0, -hz), (hx, 0, -hz), (hx, hy, -hz), (-hx, hy, -hz)]),   # z = -2
        ("CorpusWall", [(-hx, 0, hz), (hx, 0, hz), (hx, hy, hz), (-hx, hy, hz)]),       # z = +2
        ("CorpusLight", [(-hl, hy, -hl), (hl, hy, -hl), (hl, hy, hl), (-hl, hy, hl)]),  # the light
    ]
    outer = [(-hx, -hz), (hx, -hz), (hx, hz), (-hx, hz)]
    inner = [(-hl, -hl), (hl, -hl), (hl, hl), (-hl, hl)]
    for k in range(4):  # the ceiling around the light
        a, b = outer[k], outer[(k + 1) % 4]
        c, d = inner[(k + 1) % 4], inner[k]
        faces.append(("CorpusWall", [(a[0], hy, a[1]), (b[0], hy, b[1]), (c[0], hy, c[1]), (d[0], hy, d[1])]))
    centre = (0.0, hy / 2, 0.0)
    oriented = []
    for mat, pts in faces:
        # Newell normal against the direction to the room's centre.
        n = [0.0, 0.0, 0.0]
        for i, p in enumerate(pts):
            q = pts[(i + 1) % len(pts)]
            n[0] += (p[1] - q[1]) * (p[2] + q[2])
            n[1] += (p[2] - q[2]) * (p[0] + q[0])
            n[2] += (p[0] - q[0]) * (p[1] + q[1])
        c = [sum(p[a] for p in pts) / len(pts) for a in range(3)]
        inward = sum(n[a] * (centre[a] - c[a]) for a in range(3))
        assert inward != 0.0
        oriented.append((mat, pts if inward > 0 else pts[::-1]))
    return oriented


def fmt(x):
    return repr(float(x))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model")
    ap.add_argument("out")
    ap.add_argument("--fit", type=float, default=0.6, help="share of the room the model may fill (default 0.6)")
    a = ap.parse_args()
    if not 0 < a.fit <= 1:
        ap.error("--fit must be in (0, 1]")
    # latin-1: every byte maps to one character and back, so whatever the
    # model holds (UTF-8, UTF-16, NUL bytes) is written back unchanged.
    with open(a.model, encoding="latin-1", newline="") as f:
        lines = f.read().splitlines(keepends=True)
    verts = [v for v in (parse_vertex(l) for l in lines) if v]
    lo = [min(v[0][k] for v in verts) for k in range(3)] if verts else [0.0] * 3
    hi = [max(v[0][k] for v in verts) for k in range(3)] if verts else [0.0] * 3
    scales = [a.fit * ROOM[k] / (hi[k] - lo[k]) for k in range(3) if hi[k] > lo[k]]
    s = min(scales) if scales else 1.0
    shift = (-s * 0.5 * (lo[0] + hi[0]), -s * lo[1], -s * 0.5 * (lo[2] + hi[2]))

    base = os.path.splitext(os.path.basename(a.out))[0]
    out = [f"# {os.path.basename(a.model)} in a closed lit room (tests/corpus_room.py)\n",
           f"mtllib {base}.mtl\n", "usemtl CorpusModel\n"]
    for line in lines:
        key = line.split(None, 1)[0] if line.strip() else ""
        if key in ("mtllib", "usemtl"):
            continue
        v = parse_vertex(line)
        if v:
            xyz, rest = v
            end = "\r\n" if line.endswith("\r\n") else "\n"
            line = "v " + " ".join(fmt(s * xyz[k] + shift[k]) for k in range(3)) + "".join(" " + t for t in rest) + end
        out.append(line)
    if out and not out[-1].endswith("\n"):
        out.append("\n")
    out.append("o CorpusRoom\n")
    for mat, pts in room_faces():
        out.append(f"usemtl {mat}\n")
        for p in pts:
            out.append("v " + " ".join(fmt(x) for x in p) + "\n")
        out.append("f " + " ".join(str(-len(pts) + i) for i in range(len(pts))) + "\n")
    with open(a.out, "w", encoding="latin-1", newline="") as f:
        f.write("".join(out))
    with open(os.path.join(os.path.dirname(os.path.abspath(a.out)), base + ".mtl"), "w") as f:
        f.write(MTL)
    print(f"{a.out}: {len(verts)} model vertices, scale {s:.6g}, shift {shift[0]:.6g} {shift[1]:.6g} {shift[2]:.6g}",
          file=sys.stderr)


if __name__ == "__main__":
    main()
