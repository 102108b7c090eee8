#!/usr/bin/env python3
"""Read a radiosity form-factor file (docs/formats.md) with numpy.

    python3 tools/ffread.py formfactors     # prints a summary
    from ffread import read_formfactors     # -> (info, vertices, patches, F)
    from ffread import read_groups          # -> (names, group of each patch) or (None, None)

Versions 1 to 3 of the format; version 2 added the group table (the OBJ
groups of the patches), which version-1 files lack; version 3 the sparse
layout (`formfactor --format sparse`), which read_formfactors expands to
the dense matrix and read_rows reads a block of rows of.
"""
import os
import struct
import sys

import numpy as np

PATCH = np.dtype([("vertex_count", "<u4"), ("v", "<u4", 4), ("source_face", "<u4"),
                  ("area", "<f8"), ("normal", "<f8", 3), ("centroid", "<f8", 3),
                  ("rho", "<f8", 3), ("emission", "<f8", 3)])
HEADER = np.dtype([("magic", "S8"), ("version", "<u4"), ("header_bytes", "<u4"),
                   ("patch_count", "<u8"), ("vertex_count", "<u8"), ("element_type", "<u4"),
                   ("estimator", "<u4"), ("samples", "<u4"), ("shadow_rays", "<u4"),
                   ("seed", "<u8"), ("scene_fingerprint", "<u8"), ("subdiv", "<i4"), ("flags", "<u4"),
                   ("vertex_offset", "<u8"), ("patch_offset", "<u8"), ("matrix_offset", "<u8"),
                   ("row_checksum_offset", "<u8"), ("file_bytes", "<u8"), ("tables_checksum", "<u8"),
                   ("row_checksums_digest", "<u8"), ("scene_name", "S96"),
                   ("group_offset", "<u8"), ("group_count", "<u4"), ("layout", "<u4"),
                   ("matrix_bytes", "<u8"), ("header_checksum", "<u8")])


NAME_BYTES = 64      # one group name, NUL-padded
VERSIONS = (1, 2, 3)  # what these readers understand
TILE = 64             # columns per tile of a sparse row record
LAYOUT_SPARSE = 1
HEADER_BYTES = 256
VERTEX_BYTES = 24     # x, y, z float64
ELEMENT = {1: np.dtype("<f4"), 2: np.dtype("<f8")}


class FormatError(ValueError):
    """A damaged or foreign file: the message is "path: what is wrong"."""


def damage_message(path, e):
    """One line for a ValueError/struct.error met reading `path`: the error
    as it is when it names the file (FormatError does), else marked as
    damage."""
    msg = str(e)
    return msg if msg.startswith(path) else f"{path}: damaged file: {msg}"


def _pad8(x):
    return (x + 7) // 8 * 8


def _read(path, dtype, count, offset, what):
    """count items at offset, after checking that the file holds them (no
    allocation sized by a damaged count)."""
    dtype = np.dtype(dtype)
    size = os.path.getsize(path)
    end = offset + count * dtype.itemsize
    if offset < 0 or count < 0 or end > size:
        raise FormatError(f"{path}: the {what} ({count} x {dtype.itemsize} bytes at offset {offset}) "
                          f"lies beyond the end of the file ({size} bytes): damaged or truncated")
    a = np.fromfile(path, dtype=dtype, count=count, offset=offset)
    if len(a) != count:
        raise FormatError(f"{path}: the {what} could not be read whole (the file changed?)")
    return a


def read_header(path):
    """The header, after checking it against the file: magic, version,
    sizes, and that every section it names lies inside the file."""
    size = os.path.getsize(path)
    if size < HEADER_BYTES:
        raise FormatError(f"{path}: {size} bytes, shorter than the {HEADER_BYTES}-byte header: "
                          "not a form-factor file, or truncated")
    h = np.fromfile(path, dtype=HEADER, count=1)
    if len(h) != 1 or h[0]["magic"] != b"RADFF\r\n\x1a":
        raise FormatError(f"{path}: not a form-factor file")
    h = h[0]
    if int(h["version"]) not in VERSIONS:
        raise FormatError(f"{path}: format version {int(h['version'])}, this reader knows {VERSIONS}")
    if int(h["header_bytes"]) != HEADER_BYTES:
        raise FormatError(f"{path}: header size {int(h['header_bytes'])}, expected {HEADER_BYTES}: damaged header")
    if int(h["file_bytes"]) != size:
        raise FormatError(f"{path}: {size} bytes, the header says {int(h['file_bytes'])} (truncated or damaged)")
    if int(h["element_type"]) not in ELEMENT:
        raise FormatError(f"{path}: element type {int(h['element_type'])} (expected 1 = float32 or "
                          "2 = float64): damaged header")
    n, v = int(h["patch_count"]), int(h["vertex_count"])
    if n < 1 or v < 3:
        raise FormatError(f"{path}: {n} patches, {v} vertices (at least 1 and 3): damaged header")
    layout = int(h["layout"]) if int(h["version"]) >= 3 else 0
    if layout not in (0, LAYOUT_SPARSE):
        raise FormatError(f"{path}: matrix layout {layout} (expected 0 = dense or 1 = sparse): damaged header")
    g = group_count(h)
    if g > n:
        raise FormatError(f"{path}: {g} groups for {n} patches: damaged header")
    el = ELEMENT[int(h["element_type"])].itemsize
    sections = [("vertex table", int(h["vertex_offset"]), VERTEX_BYTES * v),
                ("patch table", int(h["patch_offset"]), PATCH.itemsize * n)]
    if g:
        sections.append(("group table", int(h["group_offset"]), NAME_BYTES * g + 4 * n))
    if layout == LAYOUT_SPARSE:
        sections += [("matrix records", int(h["matrix_offset"]), int(h["matrix_bytes"])),
                     ("row index", int(h["row_checksum_offset"]), 8 * (n + 1) + 8 * n)]
    else:
        sections += [("matrix", int(h["matrix_offset"]), n * n * el),
                     ("row checksums", int(h["row_checksum_offset"]), 8 * n)]
    for what, offset, nbytes in sections:
        if offset < HEADER_BYTES or offset + nbytes > size:
            raise FormatError(f"{path}: the {what} ({nbytes} bytes at offset {offset}) does not lie within "
                              f"the file ({size} bytes): damaged header or truncated file")
    return h


def group_count(h):
    """Entries of the group table: 0 for version 1 (no table) and for files without groups."""
    return int(h["group_count"]) if int(h["version"]) >= 2 else 0


def read_groups(path, h=None):
    """The group table: (list of G names, uint32 array of each patch's group), or (None, None)."""
    h = read_header(path) if h is None else h
    g, n = group_count(h), int(h["patch_count"])
    if g == 0:
        return None, None
    raw = _read(path, f"S{NAME_BYTES}", g, int(h["group_offset"]), "group names")
    names = [bytes(x).decode("utf-8", errors="replace") for x in raw]
    patch_group = _read(path, "<u4", n, int(h["group_offset"]) + NAME_BYTES * g, "patches' groups")
    if n and patch_group.max() >= g:
        raise FormatError(f"{path}: damaged group table (a patch's group {int(patch_group.max())} >= {g} groups)")
    return names, patch_group


def is_sparse(h):
    return int(h["version"]) >= 3 and int(h["layout"]) == LAYOUT_SPARSE


def read_row_index(path, h):
    """The sparse layout's N + 1 record offsets, checked: 0 first, ascending
    in multiples of 8, the records' total last, no record longer than a
    full row's."""
    n = int(h["patch_count"])
    el = ELEMENT[int(h["element_type"])].itemsize
    offsets = _read(path, "<u8", n + 1, int(h["row_checksum_offset"]), "row index").astype(np.int64)
    tiles = (n + TILE - 1) // TILE
    longest = _pad8(4 + 4 * tiles) + _pad8(n * el)
    steps = np.diff(offsets)
    if (offsets[0] != 0 or offsets[-1] != int(h["matrix_bytes"]) or (offsets % 8).any() or (steps < 8).any()
            or (steps > longest).any()):
        raise FormatError(f"{path}: damaged row index (offsets must start at 0, ascend in steps of 8 to "
                          f"{longest} bytes and end at the records' total, {int(h['matrix_bytes'])})")
    return offsets


def read_rows(path, h, begin, end):
    """Rows [begin, end) of F as a dense (end - begin) x N array, either layout."""
    n = int(h["patch_count"])
    if not 0 <= begin <= end <= n:
        raise ValueError(f"rows [{begin}, {end}) of {n}")
    element = ELEMENT[int(h["element_type"])]
    moff = int(h["matrix_offset"])
    if not is_sparse(h):
        return _read(path, element, (end - begin) * n, moff + begin * n * element.itemsize,
                     "matrix rows").reshape(end - begin, n)
    offsets = read_row_index(path, h)
    start, stop = int(offsets[begin]), int(offsets[end])
    raw = _read(path, np.uint8, stop - start, moff + start, "matrix records").tobytes()
    tile_total = (n + TILE - 1) // TILE
    F = np.zeros((end - begin, n), dtype=element)
    for r in range(end - begin):
        rec = raw[int(offsets[begin + r]) - start:int(offsets[begin + r + 1]) - start]
        count = int(np.frombuffer(rec, "<u4", 1)[0])
        if count > tile_total or 4 + 4 * count > len(rec):
            raise FormatError(f"{path}: row {begin + r}: {count} tiles stored, the row has {tile_total}: "
                              "damaged record")
        tiles = np.frombuffer(rec, "<u4", count, 4).astype(np.int64)
        if count and (tiles[-1] >= tile_total or (np.diff(tiles) <= 0).any()):
            raise FormatError(f"{path}: row {begin + r}: tile numbers not ascending below {tile_total}: "
                              "damaged record")
        widths = np.minimum(tiles * TILE + TILE, n) - tiles * TILE
        at = _pad8(4 + 4 * count)
        if len(rec) != at + _pad8(int(widths.sum()) * element.itemsize):
            raise FormatError(f"{path}: row {begin + r}: record of {len(rec)} bytes does not match its "
                              f"{count} tiles: damaged record")
        for t, w in zip(tiles, widths):
            j0 = int(t) * TILE
            F[r, j0:j0 + int(w)] = np.frombuffer(rec, element, int(w), at)
            at += int(w) * element.itemsize
    return F


def read_formfactors(path):
    h = read_header(path)
    n, v = int(h["patch_count"]), int(h["vertex_count"])
    vertices = _read(path, "<f8", 3 * v, int(h["vertex_offset"]), "vertex table").reshape(v, 3)
    patches = _read(path, PATCH, n, int(h["patch_offset"]), "patch table")
    counts = patches["vertex_count"]
    if ((counts != 3) & (counts != 4)).any():
        raise FormatError(f"{path}: damaged patch table (a patch with {int(counts[(counts != 3) & (counts != 4)][0])} "
                          "vertices; 3 or 4)")
    used = np.where(np.arange(4)[None, :] < counts[:, None], patches["v"], 0)
    if (used >= v).any():
        raise FormatError(f"{path}: damaged patch table (a vertex index >= {v} vertices)")
    F = read_rows(path, h, 0, n)
    return h, vertices, patches, F


def main(argv):
    if len(argv) != 2:
        print("usage: ffread.py FORMFACTORS", file=sys.stderr)
        return 2
    path = argv[1]
    try:
        h, vertices, patches, F = read_formfactors(path)
        names, _ = read_groups(path, h)
    except OSError as e:
        print(f"ffread.py: {path}: {e.strerror or e}", file=sys.stderr)
        return 1
    except (ValueError, struct.error) as e:   # FormatError, and numpy on what slipped past the checks
        print(f"ffread.py: {damage_message(path, e)}", file=sys.stderr)
        return 1
    except MemoryError:
        print(f"ffread.py: {path}: out of memory for its matrix", file=sys.stderr)
        return 1
    A = patches["area"]
    rows = F.sum(axis=1)
    G = A[:, None] * F
    recip = np.abs(G - G.T).max() / G.max() if G.max() > 0 else 0.0  # all zeros: nothing to compare
    print(f"N = {len(A)}, samples {h['samples']}, shadow rays {h['shadow_rays']}, "
          f"{'sparse' if is_sparse(h) else 'dense'} layout")
    print(f"row sums: min {rows.min():.6f} max {rows.max():.6f} mean {rows.mean():.6f}")
    print(f"reciprocity max |A_i F_ij - A_j F_ji| / max(A_i F_ij) = {recip:.3e}")
    print(f"groups: {', '.join(names)}" if names else "groups: none recorded (a version-1 file has no group table)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
