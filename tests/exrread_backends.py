#!/usr/bin/env python3
"""tools/exrread.py: its two readers - OpenImageIO's Python bindings and the
fallback numpy parser - give the same pixels, to the bit, and the right ones.

EXR files are written here through OpenImageIO (random values, odd sizes,
half and float, the compressions the parser knows: none, RLE, ZIPS, ZIP;
channels R, G, B, then A and a non-colour one), and each is read with both
backends and compared with what was written. A PIZ file, which only
OpenImageIO reads, must be read right by it and refused (ValueError) by the
parser. Files named on the command line (render's EXR) are compared too.
Exit 77 (skipped) where the bindings are missing: there is only one path.

    exrread_backends.py TOOLS_DIR WORK_DIR [EXTRA.exr ...]
"""
import os
import sys

import numpy as np

tools, work = sys.argv[1], sys.argv[2]
extra = sys.argv[3:]
sys.path.insert(0, tools)
import exrread  # noqa: E402

if exrread._oiio is None:
    print("skipped: OpenImageIO's Python bindings are not importable by", sys.executable)
    sys.exit(77)
oiio = exrread._oiio
os.makedirs(work, exist_ok=True)
failures = 0


def check(ok, message):
    global failures
    print(("ok: " if ok else "FAIL: ") + message)
    failures += not ok


def write(path, pixels, names, pixel_type, compression):
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, pixel_type)
    spec.channelnames = tuple(names)
    spec.attribute("compression", compression)
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec) or not out.write_image(pixels) or not out.close():
        raise RuntimeError(f"cannot write {path}: {oiio.geterror()}")


rng = np.random.default_rng(17)
cases = [  # name, width, height, channels, pixel type, compression
    ("half_zip", 67, 41, ["R", "G", "B"], oiio.HALF, "zip"),
    ("half_zips", 33, 20, ["R", "G", "B"], oiio.HALF, "zips"),
    ("half_rle", 40, 17, ["R", "G", "B"], oiio.HALF, "rle"),
    ("float_none", 19, 23, ["R", "G", "B", "A"], oiio.FLOAT, "none"),
    ("float_zip_depth", 31, 35, ["R", "G", "B", "A", "Z"], oiio.FLOAT, "zip"),
]
for name, w, h, channels, pixel_type, compression in cases:
    path = os.path.join(work, name + ".exr")
    pixels = rng.uniform(-2.0, 40.0, size=(h, w, len(channels))).astype(np.float32)
    pixels[0, 0] = 0.0
    pixels[h // 2, :, 0] = 0.0                        # runs, for RLE
    if pixel_type == oiio.HALF:
        pixels = pixels.astype(np.float16).astype(np.float32)   # what the file can hold
    write(path, pixels, channels, pixel_type, compression)
    a, names_a = exrread.read_exr(path, names=True, backend="oiio")
    b, names_b = exrread.read_exr(path, names=True, backend="numpy")
    check(names_a == channels and names_b == channels, f"{name}: channels {names_a} and {names_b}, wrote {channels}")
    check(a.dtype == np.float32 and b.dtype == np.float32 and a.shape == b.shape == pixels.shape,
          f"{name}: float32 {a.shape} and {b.shape}")
    check(np.array_equal(a, b), f"{name}: both backends give the same bits")
    check(np.array_equal(a, pixels), f"{name}: the pixels written")
    check(np.array_equal(exrread.read_exr(path), a), f"{name}: backend auto is OpenImageIO ({exrread.BACKEND})")

# PIZ: OpenImageIO reads it, the parser refuses it.
path = os.path.join(work, "half_piz.exr")
pixels = rng.uniform(0.0, 8.0, size=(24, 30, 3)).astype(np.float16).astype(np.float32)
write(path, pixels, ["R", "G", "B"], oiio.HALF, "piz")
check(np.array_equal(exrread.read_exr(path, backend="oiio"), pixels), "half_piz: OpenImageIO reads PIZ")
try:
    exrread.read_exr(path, backend="numpy")
    check(False, "half_piz: the parser should refuse PIZ")
except ValueError as e:
    check("compression" in str(e), f"half_piz: the parser refuses it ({e})")

for path in extra:
    a, names_a = exrread.read_exr(path, names=True, backend="oiio")
    b, names_b = exrread.read_exr(path, names=True, backend="numpy")
    check(names_a == names_b and a.shape == b.shape and np.array_equal(a, b),
          f"{path}: both backends agree ({a.shape[1]} x {a.shape[0]}, {','.join(names_a)})")

sys.exit(1 if failures else 0)
