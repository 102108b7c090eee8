#!/usr/bin/env python3
"""Writes a closed unit cube whose six inward faces are each an n x n grid
of cells split into two triangles: the furnace (every face Kd rho, Ke 1, so
that B = 1 / (1 - rho) everywhere) at a size clustering has to handle
(issue 27's closed-scene checks).

    make_closed_room.py --triangles 100000 --rho 0.9 --out /tmp/room
    -> /tmp/room.obj and /tmp/room.mtl, 12 n^2 triangles (n = the nearest
       grid that gives about --triangles)
"""
import argparse
import math
import sys


def main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--triangles", type=int, default=1728, help="about how many triangles [1728]")
    p.add_argument("--rho", type=float, default=0.9, help="every face's reflectance [0.9]")
    p.add_argument("--out", required=True, help="writes OUT.obj and OUT.mtl")
    a = p.parse_args(argv)
    n = max(1, round(math.sqrt(a.triangles / 12)))
    vertices, faces = [], []

    def grid(origin, u, v, flip):
        first = len(vertices) + 1
        for i in range(n + 1):
            for j in range(n + 1):
                vertices.append([origin[k] + u[k] * i / n + v[k] * j / n for k in range(3)])
        at = lambda i, j: first + i * (n + 1) + j
        for i in range(n):
            for j in range(n):
                a0, b0, c0, d0 = at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)
                faces.extend([(a0, c0, b0), (a0, d0, c0)] if flip else [(a0, b0, c0), (a0, c0, d0)])

    # u x v points into the cube unless flipped
    grid((0, 0, 0), (1, 0, 0), (0, 1, 0), False)  # floor, +z
    grid((0, 0, 1), (1, 0, 0), (0, 1, 0), True)   # ceiling, -z
    grid((0, 0, 0), (0, 1, 0), (0, 0, 1), False)  # x = 0, +x
    grid((1, 0, 0), (0, 1, 0), (0, 0, 1), True)   # x = 1, -x
    grid((0, 0, 0), (0, 0, 1), (1, 0, 0), False)  # y = 0, +y
    grid((0, 1, 0), (0, 0, 1), (1, 0, 0), True)   # y = 1, -y
    name = a.out.rsplit("/", 1)[-1]
    with open(a.out + ".mtl", "w") as f:
        f.write(f"newmtl wall\nKd {a.rho} {a.rho} {a.rho}\nKe 1 1 1\n")
    with open(a.out + ".obj", "w") as f:
        f.write(f"# closed unit cube of {len(faces)} triangles, inward, the furnace at rho {a.rho}\n")
        f.write(f"mtllib {name}.mtl\n")
        for x in vertices:
            f.write("v %.17g %.17g %.17g\n" % tuple(x))
        f.write("usemtl wall\n")
        for t in faces:
            f.write("f %d %d %d\n" % t)
    print(f"{a.out}.obj: {len(faces)} triangles, {len(vertices)} vertices")


if __name__ == "__main__":
    main(sys.argv[1:])
