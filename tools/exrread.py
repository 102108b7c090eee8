#!/usr/bin/env python3
"""Read an OpenEXR file into a numpy array.

    python3 tools/exrread.py image.exr          # prints size, channels, min/mean/max
    from exrread import read_exr                # -> float32 array (height, width, channels)

Two readers behind one function:

  - OpenImageIO's own Python bindings (Debian: python3-openimageio, which
    scripts/install-deps.sh installs), used whenever `import OpenImageIO`
    works: every flat EXR that OpenImageIO reads (tiled or scanline, any
    compression: PIZ, PXR24, B44, DWA too; the first part of a multi-part
    file), through the library `render` writes with;
  - a fallback parser with numpy and zlib only, for a Python without the
    bindings (a virtual environment, another distribution). It is enough
    for what `render` writes (RGB half float, ZIP compression) and the
    other simple cases: scanline images (not tiled, not deep, one part),
    HALF / FLOAT / UINT channels without subsampling, compression NONE,
    RLE, ZIPS or ZIP; anything else, and any damaged file (truncated,
    sizes past the end, a chunk's line repeated or missing), raises
    ValueError naming the file and what is wrong (install the
    bindings, or tools/accuracy_study.py falls back to `oiiotool
    --dumpdata`).

read_exr(path, backend="auto" | "oiio" | "numpy") picks one ("auto": the
bindings when importable); BACKEND says which "auto" takes. Both give the
same float32 values (tests/exrread_backends.py checks they agree to the
bit). Channels come back as R, G, B (then A, then any others) - the file
keeps them sorted by name, B, G, R, and OpenImageIO's reader reorders them
likewise; read_exr(..., names=True) also returns the names.
"""
import struct
import sys
import zlib

import numpy as np

try:
    import OpenImageIO as _oiio
except ImportError:     # the fallback parser below
    _oiio = None

BACKEND = "oiio" if _oiio is not None else "numpy"

_PIXEL = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
_LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16}   # NONE, RLE, ZIPS, ZIP


# zlib inflates at most 1032:1, RLE 64:1: a dataWindow whose pixels would
# need more than this many bytes per byte of file is damaged, refused before
# the image is allocated.
_MAX_INFLATION = 1040
_REQUIRED = ("channels", "compression", "dataWindow")


def _cstring(buf, pos):
    end = buf.find(b"\0", pos)
    if end < 0:
        raise ValueError("truncated header (a name without its NUL)")
    return buf[pos:end].decode("latin-1"), end + 1


def _header(buf):
    if buf[:4] != b"\x76\x2f\x31\x01":
        raise ValueError("not an OpenEXR file")
    flags = struct.unpack_from("<I", buf, 4)[0]
    if flags & 0x200 or flags & 0x800 or flags & 0x1000:
        raise ValueError("tiled, deep or multi-part EXR: not supported here")
    pos, attrs = 8, {}
    while pos < len(buf) and buf[pos] != 0:
        name, pos = _cstring(buf, pos)
        kind, pos = _cstring(buf, pos)
        size = struct.unpack_from("<i", buf, pos)[0]
        pos += 4
        if size < 0 or pos + size > len(buf):
            raise ValueError(f"attribute {name}: size {size} runs past the end of the file")
        attrs[name] = (kind, buf[pos:pos + size])
        pos += size
    if pos >= len(buf):
        raise ValueError("truncated header (no end of the attribute list)")
    for name in _REQUIRED:
        if name not in attrs:
            raise ValueError(f"the header lacks the required attribute {name}")
    return attrs, pos + 1


def _channels(raw):
    out, pos = [], 0
    while pos < len(raw) and raw[pos] != 0:
        name, pos = _cstring(raw, pos)
        ptype, _linear, xs, ys = struct.unpack_from("<iB3xii", raw, pos)
        pos += 16
        if ptype not in _PIXEL or xs != 1 or ys != 1:
            raise ValueError(f"channel {name}: pixel type {ptype}, sampling {xs}x{ys} not supported")
        out.append((name, _PIXEL[ptype]))
    if not out:
        raise ValueError("no channels")
    return out


def _undo_predictor_and_interleave(data):
    t = np.frombuffer(data, dtype=np.uint8)
    t = np.cumsum(t.astype(np.int64) - 128, dtype=np.int64)   # t[i] = t[i-1] + d[i] - 128
    t = ((t + 128) & 0xFF).astype(np.uint8)                   # first byte is stored as is
    out = np.empty_like(t)
    half = (len(t) + 1) // 2
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


def _inflate(data, expected):
    """zlib, never more than expected + 1 bytes (a damaged chunk is no bomb)."""
    d = zlib.decompressobj()
    return d.decompress(data, expected + 1)


def _rle_decode(data, expected):
    out, pos = bytearray(), 0
    while pos < len(data) and len(out) < expected:
        count = struct.unpack_from("<b", data, pos)[0]
        pos += 1
        if count < 0:
            out += data[pos:pos - count]
            pos -= count
        else:
            out += data[pos:pos + 1] * (count + 1)
            pos += 1
    return bytes(out)


def read_exr(path, names=False, backend="auto"):
    """The image as float32 (height, width, channels), channels R, G, B first."""
    if backend == "auto":
        backend = BACKEND
    if backend == "oiio":
        if _oiio is None:
            raise ImportError("OpenImageIO's Python bindings are not installed (Debian: python3-openimageio)")
        image, channels = _read_oiio(path)
    elif backend == "numpy":
        image, channels = _read_numpy(path)
    else:
        raise ValueError(f"unknown backend {backend!r} (auto, oiio or numpy)")
    # EXR stores channels sorted by name (B, G, R); give them back as R, G, B
    # (then A), the order every image tool uses, and the others after.
    order = sorted(range(len(channels)), key=lambda c: (_RGBA.index(channels[c])
                                                        if channels[c] in _RGBA else len(_RGBA), c))
    image = image[:, :, order]
    if names:
        return image, [channels[c] for c in order]
    return image


def _read_oiio(path):
    with open(path, "rb"):   # a missing file raises OSError, as with the parser
        pass
    inp = _oiio.ImageInput.open(path)
    if inp is None:
        raise ValueError(f"{path}: OpenImageIO cannot read it: {_oiio.geterror()}")
    try:
        spec = inp.spec()
        if spec.deep or spec.depth > 1:
            raise ValueError(f"{path}: deep or volume image: not supported here")
        pixels = inp.read_image(0, 0, 0, spec.nchannels, _oiio.FLOAT)
        if pixels is None:
            raise ValueError(f"{path}: OpenImageIO: {inp.geterror()}")
        channels = list(spec.channelnames)
    finally:
        inp.close()
    image = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    return image, channels


def _read_numpy(path):
    with open(path, "rb") as f:
        buf = f.read()
    try:
        return _parse_numpy(buf)
    except (ValueError, struct.error, IndexError, zlib.error) as e:
        raise ValueError(f"{path}: {e}") from None


def _parse_numpy(buf):
    """The image of an EXR file's bytes; ValueError (or struct.error) says
    what is wrong."""
    attrs, pos = _header(buf)
    channels = _channels(attrs["channels"][1])
    if len(attrs["compression"][1]) != 1:
        raise ValueError("damaged compression attribute")
    compression = attrs["compression"][1][0]
    if compression not in _LINES_PER_CHUNK:
        raise ValueError(f"compression {compression} not supported here")
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"][1])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    line_bytes = width * sum(dt.itemsize for _, dt in channels)
    if width < 1 or height < 1 or height * line_bytes > _MAX_INFLATION * len(buf):
        raise ValueError(f"dataWindow ({x0}, {y0}) - ({x1}, {y1}): {width} x {height} pixels do not fit in a "
                         f"file of {len(buf)} bytes (damaged header)")
    per_chunk = _LINES_PER_CHUNK[compression]
    chunks = (height + per_chunk - 1) // per_chunk
    if pos + 8 * chunks > len(buf):
        raise ValueError(f"the offset table of {chunks} chunks runs past the end of the file (truncated)")
    offsets = struct.unpack_from(f"<{chunks}Q", buf, pos)
    image = np.zeros((height, width, len(channels)), dtype=np.float32)
    seen = np.zeros(chunks, dtype=bool)   # each chunk's first line exactly once
    for offset in offsets:
        if offset + 8 > len(buf):
            raise ValueError(f"chunk offset {offset} is past the end of the file ({len(buf)} bytes; truncated?)")
        y, size = struct.unpack_from("<ii", buf, offset)
        if not y0 <= y <= y1 or (y - y0) % per_chunk:
            raise ValueError(f"the chunk at offset {offset} starts at line {y}, not a chunk's first line "
                             f"of {y0}..{y1}")
        k = (y - y0) // per_chunk
        if seen[k]:
            raise ValueError(f"the chunk at offset {offset} repeats line {y} (another chunk has it; "
                             "one of the image's chunks is missing)")
        seen[k] = True
        if size < 0 or offset + 8 + size > len(buf):
            raise ValueError(f"the chunk of line {y} ({size} bytes at offset {offset}) runs past the end "
                             "of the file (truncated?)")
        data = buf[offset + 8:offset + 8 + size]
        lines = min(per_chunk, y1 - y + 1)
        expected = lines * line_bytes
        if size < expected:       # stored raw when compressing did not help
            if compression in (2, 3):
                data = _undo_predictor_and_interleave(_inflate(data, expected))
            elif compression == 1:
                data = _undo_predictor_and_interleave(_rle_decode(data, expected))
        if len(data) != expected:
            raise ValueError(f"chunk at line {y} has {len(data)} bytes, expected {expected}")
        p = 0
        for line in range(lines):
            for c, (_, dt) in enumerate(channels):
                n = width * dt.itemsize
                image[y - y0 + line, :, c] = np.frombuffer(data[p:p + n], dtype=dt)
                p += n
    # `chunks` offsets, none repeated: every chunk was there.
    return image, [name for name, _ in channels]


_RGBA = ("R", "G", "B", "A")


def main(argv):
    if len(argv) != 2:
        print("usage: exrread.py IMAGE.exr", file=sys.stderr)
        return 2
    try:
        img, chans = read_exr(argv[1], names=True)
    except OSError as e:
        print(f"exrread.py: {argv[1]}: {e.strerror or e}", file=sys.stderr)
        return 1
    except (ValueError, ImportError, MemoryError) as e:
        msg = str(e) or type(e).__name__
        print(f"exrread.py: {msg if msg.startswith(argv[1]) else f'{argv[1]}: {msg}'}", file=sys.stderr)
        return 1
    print(f"{img.shape[1]} x {img.shape[0]}, channels {','.join(chans)} (read with {BACKEND})")
    for c, name in enumerate(chans):
        v = img[:, :, c]
        print(f"  {name}: min {v.min():.6g} mean {v.mean():.6g} max {v.max():.6g}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
