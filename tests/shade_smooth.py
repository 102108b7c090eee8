#!/usr/bin/env python3
"""Shade Smooth (issue 30): Blender's UV sphere exported with Shade Smooth
(tests/data/corpus/uv_sphere.obj: `s 1` on the sphere's faces) is drawn
smooth, as Cycles draws it, not in terraced bands: render finds the
scene's OBJ, reads its smoothing groups and blends corners across the
edges of faces in one group (render/shade.h).

    shade_smooth.py BIN_DIR DATA_DIR TOOLS_DIR WORK_DIR

Checks: render says how many faces are in smoothing groups; without the
OBJ (moved away) it draws creases as before and says nothing; on the
sphere's pixels the steps between neighbouring rows (the bands' edges)
shrink with the groups: the mean |second difference| down the image falls
to at most half. Exit 77 (skipped) without numpy.
"""
import os
import re
import shutil
import subprocess
import sys


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def run(args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"{' '.join(args)}: exit {r.returncode}: {r.stderr}")
    return r.stderr


def main(argv):
    try:
        import numpy as np
    except ImportError:
        print("skipped: no numpy")
        return 77
    bin_dir, data, tools, work = (os.path.abspath(a) for a in argv[1:5])
    sys.path.insert(0, tools)
    from exrread import read_exr

    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    for ext in ("obj", "mtl"):
        shutil.copy(os.path.join(data, "uv_sphere." + ext), work)
    os.chdir(work)
    run([os.path.join(bin_dir, "formfactor"), "uv_sphere.obj", "--shadow-rays", "4", "-o", "s.ff"])
    run([os.path.join(bin_dir, "solve"), "s.ff", "-o", "s.rad"])
    size = ["--width", "160", "--height", "160", "--spp", "4"]
    err = run([os.path.join(bin_dir, "render"), "s.rad", "-o", "smooth.exr"] + size)
    said = re.search(r"shading: (\d+) of (\d+) faces of uv_sphere.obj are in smoothing groups", err)
    if not said or not 0 < int(said.group(1)) < int(said.group(2)):
        fail(f"render does not say it read the smoothing groups (the sphere's, not the room's): {err}")
    os.rename("uv_sphere.obj", "moved.obj")
    err = run([os.path.join(bin_dir, "render"), "s.rad", "-o", "creased.exr"] + size)
    if "smoothing groups" in err:
        fail(f"smoothing groups without the OBJ: {err}")

    smooth, creased = read_exr("smooth.exr"), read_exr("creased.exr")
    # The sphere is the only blue surface; rows inside it, away from its rim.
    r, b = creased[..., 0], creased[..., 2]
    mask = b > 1.15 * r
    inner = mask[2:, :] & mask[1:-1, :] & mask[:-2, :]
    if inner.sum() < 200:
        fail(f"the sphere covers only {int(inner.sum())} pixels")
    def steps(img):
        y = 0.2126 * img[..., 0] + 0.7152 * img[..., 1] + 0.0722 * img[..., 2]
        d2 = np.abs(y[2:, :] - 2 * y[1:-1, :] + y[:-2, :])
        return float(d2[inner].mean()) / float(y[1:-1, :][inner].mean())
    s_smooth, s_creased = steps(smooth), steps(creased)
    print(f"mean |second difference| down the sphere, relative: creased {s_creased:.4g}, smooth {s_smooth:.4g}")
    if not s_smooth <= 0.6 * s_creased:
        fail(f"the sphere is not smoother with its smoothing groups: {s_smooth:.4g} against {s_creased:.4g}")
    print("ok: Shade Smooth is drawn smooth")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
