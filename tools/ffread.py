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


def read_header(path):
    h = np.fromfile(path, dtype=HEADER, count=1)
    if len(h) != 1 or h[0]["magic"] != b"RADFF\r\n\x1a":
        raise ValueError(f"{path}: not a form-factor file")
    h = h[0]
    if int(h["version"]) not in VERSIONS:
        raise ValueError(f"{path}: format version {int(h['version'])}, this reader knows {VERSIONS}")
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
    raw = np.fromfile(path, dtype=f"S{NAME_BYTES}", count=g, offset=int(h["group_offset"]))
    names = [bytes(x).decode("utf-8", errors="replace") for x in raw]
    patch_group = np.fromfile(path, dtype="<u4", count=n, offset=int(h["group_offset"]) + NAME_BYTES * g)
    if len(names) != g or len(patch_group) != n or (n and patch_group.max() >= g):
        raise ValueError(f"{path}: damaged group table")
    return names, patch_group


def is_sparse(h):
    return int(h["version"]) >= 3 and int(h["layout"]) == LAYOUT_SPARSE


def read_rows(path, h, begin, end):
    """Rows [begin, end) of F as a dense (end - begin) x N array, either layout."""
    n = int(h["patch_count"])
    element = np.dtype("<f4" if h["element_type"] == 1 else "<f8")
    moff = int(h["matrix_offset"])
    if not is_sparse(h):
        return np.fromfile(path, dtype=element, count=(end - begin) * n,
                           offset=moff + begin * n * element.itemsize).reshape(end - begin, n)
    offsets = np.fromfile(path, dtype="<u8", count=n + 1, offset=int(h["row_checksum_offset"]))
    start, stop = int(offsets[begin]), int(offsets[end])
    raw = np.fromfile(path, dtype=np.uint8, count=stop - start, offset=moff + start).tobytes()
    F = np.zeros((end - begin, n), dtype=element)
    for r in range(end - begin):
        rec = raw[int(offsets[begin + r]) - start:int(offsets[begin + r + 1]) - start]
        count = int(np.frombuffer(rec, "<u4", 1)[0])
        tiles = np.frombuffer(rec, "<u4", count, 4)
        at = (4 + 4 * count + 7) // 8 * 8
        for t in tiles:
            j0 = int(t) * TILE
            j1 = min(j0 + TILE, n)
            F[r, j0:j1] = np.frombuffer(rec, element, j1 - j0, at)
            at += (j1 - j0) * element.itemsize
    return F


def read_formfactors(path):
    h = read_header(path)
    n, v = int(h["patch_count"]), int(h["vertex_count"])
    vertices = np.fromfile(path, dtype="<f8", count=3 * v, offset=int(h["vertex_offset"])).reshape(v, 3)
    patches = np.fromfile(path, dtype=PATCH, count=n, offset=int(h["patch_offset"]))
    F = read_rows(path, h, 0, n)
    return h, vertices, patches, F


if __name__ == "__main__":
    h, vertices, patches, F = read_formfactors(sys.argv[1])
    A = patches["area"]
    rows = F.sum(axis=1)
    G = A[:, None] * F
    recip = np.abs(G - G.T).max() / G.max() if G.max() > 0 else 0.0  # all zeros: nothing to compare
    print(f"N = {len(A)}, samples {h['samples']}, shadow rays {h['shadow_rays']}, "
          f"{'sparse' if is_sparse(h) else 'dense'} layout")
    print(f"row sums: min {rows.min():.6f} max {rows.max():.6f} mean {rows.mean():.6f}")
    print(f"reciprocity max |A_i F_ij - A_j F_ji| / max(A_i F_ij) = {recip:.3e}")
    names, _ = read_groups(sys.argv[1], h)
    print(f"groups: {', '.join(names)}" if names else "groups: none recorded (a version-1 file has no group table)")
