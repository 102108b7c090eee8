#!/usr/bin/env python3
"""Read a radiosity form-factor file (docs/formats.md) with numpy.

    python3 tools/ffread.py formfactors     # prints a summary
    from ffread import read_formfactors     # -> (info, vertices, patches, F)
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
                   ("row_checksums_digest", "<u8"), ("scene_name", "S96"), ("reserved", "S24"),
                   ("header_checksum", "<u8")])


def read_formfactors(path):
    h = np.fromfile(path, dtype=HEADER, count=1)[0]
    assert h["magic"] == b"RADFF\r\n\x1a", "not a form-factor file"
    n, v = int(h["patch_count"]), int(h["vertex_count"])
    vertices = np.fromfile(path, dtype="<f8", count=3 * v, offset=int(h["vertex_offset"])).reshape(v, 3)
    patches = np.fromfile(path, dtype=PATCH, count=n, offset=int(h["patch_offset"]))
    element = "<f4" if h["element_type"] == 1 else "<f8"
    F = np.fromfile(path, dtype=element, count=n * n, offset=int(h["matrix_offset"])).reshape(n, n)
    return h, vertices, patches, F


if __name__ == "__main__":
    h, vertices, patches, F = read_formfactors(sys.argv[1])
    A = patches["area"]
    rows = F.sum(axis=1)
    G = A[:, None] * F
    recip = np.abs(G - G.T).max() / G.max() if G.max() > 0 else 0.0  # all zeros: nothing to compare
    print(f"N = {len(A)}, samples {h['samples']}, shadow rays {h['shadow_rays']}")
    print(f"row sums: min {rows.min():.6f} max {rows.max():.6f} mean {rows.mean():.6f}")
    print(f"reciprocity max |A_i F_ij - A_j F_ji| / max(A_i F_ij) = {recip:.3e}")
