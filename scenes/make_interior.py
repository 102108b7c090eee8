#!/usr/bin/env python3
"""Writes an interior of about N triangles (issue 27's large scenes):

    scenes/make_interior.py --triangles 100000 --out /tmp/interior_1e5

gives /tmp/interior_1e5.obj, .mtl and .camera (a view from the front wall,
for render and tools/image_study.py): a closed 8 x 3 x 6 room (faces
inward, walls tessellated), three ceiling lights, four tables (thin legs),
eight chairs, two shelves of books (many small boxes), and tessellated
curved objects - spheres, vases (cylinders with a lip) and tori - resting
on the tables and the floor (touching, so contact cutting has work). All
triangles; every object its own `o` group. The tessellation grows with N,
the furniture does not, so from 10^4 to 10^6 triangles the scene is the
same interior drawn ever finer, as exported models are. Deterministic:
the same arguments give the same bytes. Sizes: docs/performance.md and
scenes/README.md."""
import argparse
import math
import sys


class Obj:
    def __init__(self):
        self.verts = []
        self.rows = []  # (group, material, [v1, v2, v3]) 1-based
        self.group = "default"
        self.mtl = "white"

    def v(self, x, y, z):
        self.verts.append((x, y, z))
        return len(self.verts)

    def tri(self, a, b, c):
        self.rows.append((self.group, self.mtl, (a, b, c)))

    def quad(self, a, b, c, d):
        self.tri(a, b, c)
        self.tri(a, c, d)

    def grid(self, origin, du, dv, nu, nv):
        """A parallelogram origin + s du + t dv split into nu x nv cells, 2 triangles each,
        wound so that du x dv is the normal."""
        idx = [[self.v(origin[0] + du[0] * i / nu + dv[0] * j / nv, origin[1] + du[1] * i / nu + dv[1] * j / nv,
                       origin[2] + du[2] * i / nu + dv[2] * j / nv) for j in range(nv + 1)] for i in range(nu + 1)]
        for i in range(nu):
            for j in range(nv):
                self.quad(idx[i][j], idx[i + 1][j], idx[i + 1][j + 1], idx[i][j + 1])

    def box(self, x0, y0, z0, x1, y1, z1, bottom=False, n=1):
        """Axis-aligned box, faces outward, each side an n x n grid; no bottom unless asked
        (it rests on something)."""
        sx, sy, sz = x1 - x0, y1 - y0, z1 - z0
        self.grid((x0, y1, z0), (0, 0, sz), (sx, 0, 0), n, n)       # top, +y
        if bottom:
            self.grid((x0, y0, z0), (sx, 0, 0), (0, 0, sz), n, n)   # -y
        self.grid((x0, y0, z0), (0, sy, 0), (sx, 0, 0), n, n)       # -z
        self.grid((x0, y0, z1), (sx, 0, 0), (0, sy, 0), n, n)       # +z
        self.grid((x0, y0, z0), (0, 0, sz), (0, sy, 0), n, n)       # -x
        self.grid((x1, y0, z0), (0, sy, 0), (0, 0, sz), n, n)       # +x

    def revolve(self, profile, cx, cz, segments):
        """A surface of revolution about the vertical axis through (cx, cz): profile is a
        list of (radius, y) from bottom to top, faces outward; a zero radius closes a pole."""
        rings = []
        for r, y in profile:
            if r == 0:
                rings.append([self.v(cx, y, cz)])
            else:
                rings.append([self.v(cx + r * math.cos(2 * math.pi * k / segments), y,
                                     cz + r * math.sin(2 * math.pi * k / segments)) for k in range(segments)])
        for a, b in zip(rings, rings[1:]):
            for k in range(segments):
                k1 = (k + 1) % segments
                if len(a) == 1:
                    self.tri(a[0], b[k], b[k1])
                elif len(b) == 1:
                    self.tri(a[k], b[0], a[k1])
                else:
                    self.quad(a[k], b[k], b[k1], a[k1])

    def sphere(self, cx, cy, cz, r, segments):
        rings = max(3, segments // 2)
        prof = [(r * math.sin(math.pi * i / rings), cy - r * math.cos(math.pi * i / rings)) for i in range(rings + 1)]
        prof[0], prof[-1] = (0, cy - r), (0, cy + r)
        self.revolve(prof, cx, cz, segments)

    def vase(self, cx, y0, cz, r, h, segments):
        steps = max(4, segments // 4)
        prof = [(0, y0)] + [(r * (0.6 + 0.4 * math.sin(math.pi * (0.15 + 0.85 * i / steps))), y0 + h * i / steps)
                            for i in range(steps + 1)] + [(0, y0 + h)]
        self.revolve(prof, cx, cz, segments)

    def torus(self, cx, cy, cz, R, r, segments):
        """Lying flat, resting on y = cy - r."""
        m = max(4, segments // 2)
        ring = [[self.v(cx + (R + r * math.cos(2 * math.pi * j / m)) * math.cos(2 * math.pi * k / segments),
                        cy + r * math.sin(2 * math.pi * j / m),
                        cz + (R + r * math.cos(2 * math.pi * j / m)) * math.sin(2 * math.pi * k / segments))
                 for j in range(m)] for k in range(segments)]
        for k in range(segments):
            k1 = (k + 1) % segments
            for j in range(m):
                j1 = (j + 1) % m
                self.quad(ring[k][j], ring[k][j1], ring[k1][j1], ring[k1][j])


def build(target):
    o = Obj()
    W, H, D = 8.0, 3.0, 6.0
    # How fine: the curved objects take most triangles; walls and boxes grow as sqrt.
    curved = 4 * 3 + 6       # spheres, vases, tori on tables, plus floor pieces
    seg = max(8, int(math.sqrt(max(target - 4000, 1000) / (curved * 1.4))))
    wall = max(2, int(math.sqrt(target) / 16))
    fine = max(1, wall // 4)
    o.mtl = "white"
    o.group = "floor"
    o.grid((0, 0, 0), (0, 0, D), (W, 0, 0), wall * 4, wall * 3)
    o.group = "ceiling"
    o.grid((0, H, 0), (W, 0, 0), (0, 0, D), wall * 4, wall * 3)
    o.group = "wall_back"
    o.grid((0, 0, D), (0, H, 0), (W, 0, 0), wall * 2, wall * 4)
    o.group = "wall_front"
    o.grid((0, 0, 0), (W, 0, 0), (0, H, 0), wall * 4, wall * 2)
    o.mtl = "red"
    o.group = "wall_left"
    o.grid((0, 0, 0), (0, H, 0), (0, 0, D), wall * 2, wall * 3)
    o.mtl = "green"
    o.group = "wall_right"
    o.grid((W, 0, 0), (0, 0, D), (0, H, 0), wall * 3, wall * 2)
    o.mtl = "light"
    for i, x in enumerate((2.0, 4.0, 6.0)):
        o.group = f"light_{i}"
        y = H - 0.01
        a, b, c, d = o.v(x - 0.4, y, 2.6), o.v(x + 0.4, y, 2.6), o.v(x + 0.4, y, 3.4), o.v(x - 0.4, y, 3.4)
        o.quad(a, b, c, d)
    tables = [(1.0, 1.0), (4.6, 1.0), (1.0, 3.6), (4.6, 3.6)]
    top_y = 0.75
    for ti, (x, z) in enumerate(tables):
        o.mtl = "wood"
        o.group = f"table_{ti}"
        o.box(x, top_y - 0.04, z, x + 2.2, top_y, z + 1.2, bottom=True, n=fine)
        for lx, lz in ((x + 0.05, z + 0.05), (x + 2.1, z + 0.05), (x + 0.05, z + 1.1), (x + 2.1, z + 1.1)):
            o.box(lx, 0.0, lz, lx + 0.05, top_y - 0.04, lz + 0.05, n=1)  # thin legs, touching floor and top
        # curved objects resting on the top
        o.mtl = "white"
        o.group = f"sphere_{ti}"
        o.sphere(x + 0.5, top_y + 0.2, z + 0.6, 0.2, seg)
        o.mtl = "blue"
        o.group = f"vase_{ti}"
        o.vase(x + 1.2, top_y, z + 0.6, 0.15, 0.45, seg)
        o.mtl = "yellow"
        o.group = f"torus_{ti}"
        o.torus(x + 1.8, top_y + 0.06, z + 0.6, 0.18, 0.06, seg)
        # two chairs per table: seat, back, legs
        for ci, cz in enumerate((z - 0.55, z + 1.25)):
            o.mtl = "wood"
            o.group = f"chair_{ti}_{ci}"
            cx = x + 0.8
            o.box(cx, 0.45, cz, cx + 0.5, 0.49, cz + 0.5, bottom=True, n=fine)
            back_z = cz if ci == 0 else cz + 0.46
            o.box(cx, 0.49, back_z, cx + 0.5, 0.95, back_z + 0.04, n=fine)
            for lx, lz in ((cx, cz), (cx + 0.46, cz), (cx, cz + 0.46), (cx + 0.46, cz + 0.46)):
                o.box(lx, 0.0, lz, lx + 0.04, 0.45, lz + 0.04, n=1)
    # shelves along the back wall, full of books (many small boxes)
    for si, x in enumerate((0.3, 5.2)):
        o.mtl = "wood"
        o.group = f"shelf_{si}"
        for level in range(4):
            y = 0.3 + 0.5 * level
            o.box(x, y, 5.5, x + 2.4, y + 0.03, 5.95, bottom=True, n=fine)
        o.mtl = "red" if si == 0 else "blue"
        o.group = f"books_{si}"
        for level in range(4):
            y = 0.33 + 0.5 * level
            bx = x + 0.02
            k = 0
            while bx < x + 2.3:
                w = 0.03 + 0.02 * ((k * 7 + level * 3 + si) % 4)
                h = 0.25 + 0.05 * ((k * 5 + level) % 4)
                o.box(bx, y, 5.55, bx + w, y + h, 5.9, n=1)
                bx += w + 0.005
                k += 1
    # floor pieces: two big spheres and a vase resting on the floor
    o.mtl = "white"
    o.group = "floor_sphere_0"
    o.sphere(7.2, 0.35, 0.8, 0.35, seg)
    o.group = "floor_sphere_1"
    o.sphere(7.3, 0.25, 2.2, 0.25, seg)
    o.mtl = "blue"
    o.group = "floor_vase"
    o.vase(7.3, 0.0, 4.2, 0.3, 0.9, seg)
    o.mtl = "yellow"
    o.group = "floor_torus"
    o.torus(3.9, 0.1, 5.0, 0.4, 0.1, seg)
    return o


# From the front wall at eye height, across the tables to the shelves; the
# lights are on the ceiling, above the view.
CAMERA = """# Camera for scenes/make_interior.py's room (units m)
eye 4 1.7 0.25
look_at 4 0.9 5
up 0 1 0
fov_y 65
"""

MTL = """newmtl white
Kd 0.75 0.75 0.75
newmtl red
Kd 0.63 0.065 0.05
newmtl green
Kd 0.14 0.45 0.091
newmtl blue
Kd 0.1 0.2 0.6
newmtl yellow
Kd 0.7 0.6 0.1
newmtl wood
Kd 0.45 0.3 0.15
newmtl light
Kd 0 0 0
Ke 12 12 12
"""


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--triangles", type=int, default=10000, help="about how many triangles [10000]")
    p.add_argument("--out", required=True, help="writes OUT.obj, OUT.mtl and OUT.camera")
    a = p.parse_args(argv)
    o = build(a.triangles)
    name = a.out.rsplit("/", 1)[-1]
    with open(a.out + ".mtl", "w") as f:
        f.write(MTL)
    with open(a.out + ".obj", "w") as f:
        f.write(f"# {name}: scenes/make_interior.py --triangles {a.triangles}; {len(o.rows)} triangles\n")
        f.write(f"mtllib {name}.mtl\n")
        f.write("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in o.verts))
        group = mtl = None
        out = []
        for g, m, (i, j, k) in o.rows:
            if g != group:
                out.append(f"o {g}\n")
                group = g
            if m != mtl:
                out.append(f"usemtl {m}\n")
                mtl = m
            out.append(f"f {i} {j} {k}\n")
        f.write("".join(out))
    with open(a.out + ".camera", "w") as f:
        f.write(CAMERA)
    print(f"{a.out}.obj: {len(o.rows)} triangles, {len(o.verts)} vertices")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
