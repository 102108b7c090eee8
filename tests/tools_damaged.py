#!/usr/bin/env python3
"""tools/ffread.py, tools/ffdump.py and tools/exrread.py on damaged files:
every one gives a one-line error naming the file, exit status 1 or 2, no
traceback, and nothing huge allocated (children run under a 4 GiB address
space limit, so an allocation sized by a damaged count shows up as a
MemoryError traceback instead of swapping). Form-factor files (dense and
sparse, from formfactor) are truncated, have header bytes flipped, huge
counts and offsets, a bad sparse index and bad row records; EXR files
(written here, compression NONE, and render's own when given) are
truncated, flipped, given a huge dataWindow, and given a chunk that repeats
another's line - which the numpy fallback reader must refuse, not turn
into a wrong image. Exit 77 (skipped) where numpy is missing.

    tools_damaged.py TOOLS_DIR FORMFACTOR WORK_DIR [render.exr]
"""
import os
import resource
import struct
import subprocess
import sys

try:
    import numpy as np
except ImportError:
    print("skipped: numpy is not importable by", sys.executable)
    sys.exit(77)

tools, formfactor, work = sys.argv[1], sys.argv[2], sys.argv[3]
extra_exr = sys.argv[4] if len(sys.argv) > 4 else None
os.makedirs(work, exist_ok=True)
os.chdir(work)
sys.path.insert(0, tools)
import exrread  # noqa: E402

failures = 0


def check(ok, message):
    global failures
    print(("ok: " if ok else "FAIL: ") + message)
    failures += not ok


def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def run(args):
    return subprocess.run([sys.executable] + args, capture_output=True, text=True, timeout=120,
                          preexec_fn=limit_memory)


def clean_error(p, path, what):
    lines = p.stderr.strip().splitlines()
    ok = (p.returncode in (1, 2) and "Traceback" not in p.stderr and len(lines) == 1 and path in lines[0])
    check(ok, f"{what}: {lines[0] if len(lines) == 1 else repr(p.stderr[-300:])} (exit {p.returncode})")


def damaged(src, name, edit):
    data = bytearray(open(src, "rb").read())
    data = edit(data)
    with open(name, "wb") as f:
        f.write(data)
    return name


def put(fmt, offset, value):
    def edit(d):
        struct.pack_into(fmt, d, offset, value)
        return d
    return edit


# ---- form-factor files ----
for layout in ("dense", "sparse"):
    subprocess.run([formfactor, "-q", "--subdiv", "1", "--format", layout, "-o", f"{layout}.ff"], check=True)
FF_COMMANDS = [
    ("ffread.py", lambda f: [os.path.join(tools, "ffread.py"), f]),
    ("ffdump.py groups", lambda f: [os.path.join(tools, "ffdump.py"), "groups", f]),
    ("ffdump.py matrix", lambda f: [os.path.join(tools, "ffdump.py"), "matrix", f, "-o", "out.npy"]),
    ("ffdump.py group-matrix", lambda f: [os.path.join(tools, "ffdump.py"), "group-matrix", f, "-o", "out.csv"]),
]
for layout in ("dense", "sparse"):
    for what, cmd in FF_COMMANDS:
        p = run(cmd(f"{layout}.ff"))
        check(p.returncode == 0 and not p.stderr, f"{what} reads a whole {layout} file")


def u64(d, off):
    return struct.unpack_from("<Q", d, off)[0]


sparse = open("sparse.ff", "rb").read()
index_at, matrix_at = u64(sparse, 96), u64(sparse, 88)
ff_damages = [
    ("dense", "short.ff", lambda d: d[:100], "truncated inside the header"),
    ("dense", "half.ff", lambda d: d[:len(d) // 2], "truncated to half"),
    ("sparse", "half_sparse.ff", lambda d: d[:len(d) - 64], "sparse, truncated by 64 bytes"),
    ("dense", "magic.ff", put("<B", 0, 0x51), "a flipped magic byte"),
    ("dense", "version.ff", put("<I", 8, 0x02000000), "a flipped version byte"),
    ("dense", "n_huge.ff", put("<Q", 16, 1 << 40), "a huge patch count"),
    ("sparse", "n_huge_sparse.ff", put("<Q", 16, 1 << 40), "sparse, a huge patch count"),
    ("dense", "v_huge.ff", put("<Q", 24, 1 << 40), "a huge vertex count"),
    ("dense", "element.ff", put("<I", 32, 9), "an unknown element type"),
    ("dense", "matrix_offset.ff", put("<Q", 88, 1 << 50), "a matrix offset far past the end"),
    ("dense", "groups_huge.ff", put("<I", 232, 0xFFFFFFF0), "a huge group count"),
    ("dense", "group_of_patch.ff", lambda d: put("<I", u64(d, 224) + 64 * struct.unpack_from("<I", d, 232)[0],
                                                 1000)(d), "a patch's group out of range"),
    ("sparse", "index_huge.ff", put("<Q", index_at + 8 * 5, 1 << 40), "a sparse index offset of 1 TiB"),
    ("sparse", "index_down.ff", put("<Q", index_at + 8 * 5, 8), "a sparse index going backwards"),
    ("sparse", "matrix_bytes.ff", put("<Q", 240, 1 << 40), "a sparse records' total of 1 TiB"),
    ("sparse", "tile_count.ff", put("<I", matrix_at, 1000000), "a row record with a million tiles"),
    ("sparse", "tile_number.ff", put("<I", matrix_at + 4, 999), "a row record with a tile number out of range"),
]
for src, name, edit, what in ff_damages:
    damaged(f"{src}.ff", name, edit)
    for tool, cmd in FF_COMMANDS:
        if tool == "ffdump.py groups" and name.startswith("tile_"):
            continue   # reads no matrix row, so a damaged record is none of its business
        clean_error(run(cmd(name)), name, f"{tool}, {what}")


# ---- EXR files ----
def exr_none(path, pixels, line_of_chunk=None):
    """A scanline EXR, compression NONE, HALF channels B, G, R (the file's
    sorted order); line_of_chunk(k) may say which line chunk k claims."""
    h, w, _ = pixels.shape
    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value
    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 1, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + attr("channels", "chlist", chlist)
              + attr("compression", "compression", b"\0") + attr("dataWindow", "box2i", box)
              + attr("displayWindow", "box2i", box) + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1))
              + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0")
    at = len(header) + 8 * h
    offsets, chunks = [], b""
    for y in range(h):
        data = b"".join(pixels[y, :, c].astype("<f2").tobytes() for c in (2, 1, 0))
        offsets.append(at + len(chunks))
        claimed = line_of_chunk(y) if line_of_chunk else y
        chunks += struct.pack("<ii", claimed, len(data)) + data
    with open(path, "wb") as f:
        f.write(header + struct.pack(f"<{h}Q", *offsets) + chunks)


h, w = 4, 5
pixels = (np.arange(h * w * 3, dtype=np.float32).reshape(h, w, 3) + 1) / 8   # exact in half
exr_none("good.exr", pixels)
image = exrread.read_exr("good.exr", backend="numpy")
check(np.array_equal(image, pixels), "the numpy reader reads the test EXR right")
if exrread._oiio is not None:
    check(np.array_equal(exrread.read_exr("good.exr", backend="oiio"), pixels), "so does OpenImageIO")
exr_none("repeat.exr", pixels, lambda y: 1 if y == 2 else y)
exr_none("outside.exr", pixels, lambda y: 99 if y == 2 else y)


def exrread_cli(backend, name):
    """python3 tools/exrread.py NAME, the numpy backend by hiding OpenImageIO."""
    hide = "sys.modules['OpenImageIO'] = None; " if backend == "numpy" else ""
    script = os.path.join(tools, "exrread.py")
    return ["-c", f"import runpy, sys; {hide}sys.argv = [{script!r}, {name!r}]; "
                  f"runpy.run_path({script!r}, run_name='__main__')"]


def numpy_refuses(path, what):
    try:
        exrread.read_exr(path, backend="numpy")
        check(False, f"numpy reader, {what}: read without an error")
    except ValueError as e:
        check(str(e).startswith(path + ":"), f"numpy reader, {what}: {e}")
    except Exception as e:   # noqa: BLE001 - anything else is the failure tested for
        check(False, f"numpy reader, {what}: {type(e).__name__}: {e}")


numpy_refuses("repeat.exr", "a chunk repeating another's line")
numpy_refuses("outside.exr", "a chunk claiming a line outside the image")
good = open("good.exr", "rb").read()
dw = good.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
exr_damages = [("good.exr", "short.exr", lambda d: d[:20], "truncated inside the header"),
               ("good.exr", "half.exr", lambda d: d[:len(d) // 2], "truncated to half"),
               ("good.exr", "last.exr", lambda d: d[:len(d) - 3], "truncated by 3 bytes"),
               ("good.exr", "magic.exr", put("<B", 0, 0x77), "a flipped magic byte"),
               ("good.exr", "window.exr", put("<i", dw + 8, 1 << 30), "a dataWindow a billion pixels wide"),
               ("good.exr", "tall.exr", put("<i", dw + 12, 1 << 28), "a dataWindow 2^28 lines tall"),
               ("good.exr", "attr.exr", put("<i", good.index(b"chlist\0") + 7, 1 << 30),
                "an attribute size past the end"),
               ("good.exr", "chunk_size.exr", lambda d: put("<i", struct.unpack_from(
                   "<Q", d, len(d) - 4 * (8 + 30) - 8 * 4 + 0)[0] + 4, 1 << 30)(d), "a chunk size past the end")]
if extra_exr:   # render's own: ZIP, 16 lines a chunk
    rd = open(extra_exr, "rb").read()
    with open("render.exr", "wb") as f:
        f.write(rd)
    exr_damages += [("render.exr", "render_half.exr", lambda d: d[:len(d) // 2], "render's EXR truncated"),
                    ("render.exr", "render_zip.exr", lambda d: d[:-200] + bytes(200), "render's EXR, last chunk zeroed")]
for src, name, edit, what in exr_damages:
    damaged(src, name, edit)
    numpy_refuses(name, what)
    for backend in ["numpy"] + (["oiio"] if exrread._oiio is not None else []):
        p = run(exrread_cli(backend, name))
        if backend == "oiio" and p.returncode == 0:   # OpenImageIO may read past some damage: its call
            check("Traceback" not in p.stderr, f"exrread.py (oiio), {what}: read, no traceback")
        else:
            clean_error(p, name, f"exrread.py ({backend}), {what}")
for name in ("repeat.exr", "outside.exr"):
    clean_error(run(exrread_cli("numpy", name)), name, f"exrread.py (numpy), {name}")

print(f"{failures} failures")
sys.exit(1 if failures else 0)
