#!/usr/bin/env python3
"""Read a radiosity form-factor file (docs/formats.md) with numpy.

    python3 tools/ffread.py formfactors     # prints a summary
    from ffread import read_formfactors     # -> (info, vertices, patches, F)
    from ffread import read_groups          # -> (names, group of each patch) or (None, None)
    from ffread import read_links           # links layout -> (info, nodes, first_link, links)
    read_links(path, with_clusters=True)    # -> (info, nodes, first_link, links, clusters, cluster_roots)

Versions 1 to 5 of the format; version 2 added the group table (the OBJ
groups of the patches), which version-1 files lack; version 3 the sparse
layout (`formfactor --format sparse`), which read_formfactors expands to
the dense matrix and read_rows reads a block of rows of; version 4 the
links layout (hierarchical radiosity: element trees over the patches and
the links between their nodes, no matrix), which read_links reads and
is_links tells apart (read_rows and read_formfactors refuse it); version 5
the links layout with clusters (a tree of clusters above the roots, whose
ids follow the nodes': links at and from clusters), which read_links reads
too (empty cluster arrays for version 4).
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


# The links layout's counts, bytes 192-223 of the header (the scene name
# has the 64 bytes before them; in version 5, 60 bytes and then the u32
# cluster count at byte 188).
LINK_HEADER = np.dtype([("node_count", "<u4"), ("root_count", "<u4"), ("link_count", "<u8"),
                        ("link_tol", "<f8"), ("error_bound", "<f8")])
LINK_HEADER_OFFSET = 192
CLUSTER_COUNT_OFFSET = 188
VERSION_CLUSTERS = 5
NODE = np.dtype([("parent", "<u4"), ("first_child", "<u4"), ("leaf", "<u4"), ("root", "<u4"),
                 ("level", "<u4"), ("vertex_count", "<u4"), ("v", "<u4", 4), ("area", "<f8")])
CLUSTER = np.dtype([("parent", "<u4"), ("first_child", "<u4"), ("child_count", "<u4"), ("root_begin", "<u4"),
                    ("root_end", "<u4"), ("pad", "<u4"), ("area", "<f8")])
LINK = np.dtype([("source", "<u4"), ("error", "<f4"), ("factor", "<f8")])
NO_ELEMENT = 0xFFFFFFFF
BLOCK_LINKS = 65536   # links per checksum of the links layout

NAME_BYTES = 64      # one group name, NUL-padded
VERSIONS = (1, 2, 3, 4, 5)  # what these readers understand
TILE = 64             # columns per tile of a sparse row record
LAYOUT_SPARSE = 1
LAYOUT_LINKS = 2
ALIGN = 64
HEADER_BYTES = 256
VERTEX_BYTES = 24     # x, y, z float64
ELEMENT = {1: np.dtype("<f4"), 2: np.dtype("<f8")}


class FormatError(ValueError):
    """A damaged or foreign file: the message is "path: what is wrong"."""


class KindError(ValueError):
    """A whole file of the other kind (links where a matrix was asked for,
    or the reverse): "path: holds ..."."""


def damage_message(path, e):
    """One line for a ValueError/struct.error met reading `path`: the error
    as it is when it names the file (FormatError does), else marked as
    damage."""
    msg = str(e)
    return msg if msg.startswith(path) else f"{path}: damaged file: {msg}"


def _pad8(x):
    return (x + 7) // 8 * 8


def _align(x):
    return (x + ALIGN - 1) // ALIGN * ALIGN


HASH_SEED = 0xcbf29ce484222325
_FNV_PRIME = 0x100000001b3
_MASK = (1 << 64) - 1


def rad_hash64(data, h=HASH_SEED):
    """core/rad_hash.h's checksum: FNV-1a over 8-byte little-endian words
    (each folded, h ^= h >> 29), then byte-wise over the tail. Pure Python:
    about 10 MB/s."""
    data = bytes(data)
    words = len(data) // 8
    for w in np.frombuffer(data, "<u8", words).tolist():
        h = ((h ^ w) * _FNV_PRIME) & _MASK
        h ^= h >> 29
    for b in data[8 * words:]:
        h = ((h ^ b) * _FNV_PRIME) & _MASK
    return h


def scene_name(h):
    """The header's scene name (in the links layout its first 64 bytes, with
    clusters its first 60)."""
    name = bytes(h["scene_name"])
    if is_links(h):
        name = name[:CLUSTER_COUNT_OFFSET - 128 if int(h["version"]) >= VERSION_CLUSTERS else LINK_HEADER_OFFSET - 128]
    return name.split(b"\0")[0].decode("utf-8", errors="replace")


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
    layout = int(h["layout"]) if int(h["version"]) >= 3 else 0
    if layout == LAYOUT_LINKS and (int(h["version"]) < 4 or int(h["element_type"]) != 2):
        raise FormatError(f"{path}: the links layout needs version 4 or 5 and element type 2, not version "
                          f"{int(h['version'])} and element type {int(h['element_type'])}: damaged header")
    if int(h["element_type"]) not in ELEMENT:
        raise FormatError(f"{path}: element type {int(h['element_type'])} (expected 1 = float32 or "
                          "2 = float64): damaged header")
    n, v = int(h["patch_count"]), int(h["vertex_count"])
    if n < 1 or v < 3:
        raise FormatError(f"{path}: {n} patches, {v} vertices (at least 1 and 3): damaged header")
    if layout not in (0, LAYOUT_SPARSE, LAYOUT_LINKS):
        raise FormatError(f"{path}: matrix layout {layout} (expected 0 = dense, 1 = sparse or 2 = links): "
                          "damaged header")
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
    elif layout == LAYOUT_LINKS:
        sections += link_sections(path, h, size)
    else:
        sections += [("matrix", int(h["matrix_offset"]), n * n * el),
                     ("row checksums", int(h["row_checksum_offset"]), 8 * n)]
    for what, offset, nbytes in sections:
        if offset < HEADER_BYTES or offset + nbytes > size:
            raise FormatError(f"{path}: the {what} ({nbytes} bytes at offset {offset}) does not lie within "
                              f"the file ({size} bytes): damaged header or truncated file")
    return h


def link_counts(path, h):
    """The links layout's counts and settings (header bytes 192-223, and
    the cluster count: byte 188 in version 5, 0 before) as a dict."""
    c = np.fromfile(path, dtype=LINK_HEADER, count=1, offset=LINK_HEADER_OFFSET)
    if len(c) != 1:
        raise FormatError(f"{path}: the header could not be read whole (the file changed?)")
    counts = {k: c[0][k].item() for k in LINK_HEADER.names}
    clusters = 0
    if int(h["version"]) >= VERSION_CLUSTERS:
        clusters = int(np.fromfile(path, dtype="<u4", count=1, offset=CLUSTER_COUNT_OFFSET)[0])
    counts["cluster_count"] = clusters
    return counts


def link_layout(path, h):
    """The links layout's section offsets as the counts imply
    (docs/formats.md, "The links layout"): a dict of node_at, cluster_at and
    roots_at (0 without clusters), first_at, links_at, sums_at, the
    sections before the links as (name, begin, end) spans, each up to the
    next section, the number of checksums, and the counts."""
    c = link_counts(path, h)
    nodes, roots, clusters, count = c["node_count"], c["root_count"], c["cluster_count"], c["link_count"]
    node_at = int(h["matrix_offset"])
    after = _align(node_at + NODE.itemsize * nodes)
    cluster_at = roots_at = 0
    if clusters:
        cluster_at = after
        roots_at = _align(cluster_at + CLUSTER.itemsize * clusters)
        after = _align(roots_at + 4 * roots)
    first_at = after
    links_at = _align(first_at + 8 * (nodes + clusters + 1))
    sums_at = _align(links_at + LINK.itemsize * count)
    starts = [("node table", node_at)]
    if clusters:
        starts += [("cluster table", cluster_at), ("cluster roots", roots_at)]
    starts += [("first_link table", first_at)]
    spans = [(what, begin, starts[k + 1][1] if k + 1 < len(starts) else links_at)
             for k, (what, begin) in enumerate(starts)]
    checksums = len(spans) + (count + BLOCK_LINKS - 1) // BLOCK_LINKS
    return dict(node_at=node_at, cluster_at=cluster_at, roots_at=roots_at, first_at=first_at, links_at=links_at,
                sums_at=sums_at, sections=spans, checksums=checksums, counts=c)


def link_spans(lay):
    """Every checksummed span of the links layout (link_layout's), in the
    checksum table's order: the sections before the links, then each block
    of BLOCK_LINKS links; each up to the next. Only for counts that
    read_header has checked against the file."""
    count, links_at, sums_at = lay["counts"]["link_count"], lay["links_at"], lay["sums_at"]
    blocks = (count + BLOCK_LINKS - 1) // BLOCK_LINKS
    return lay["sections"] + [(f"links {b * BLOCK_LINKS}..{min(count, (b + 1) * BLOCK_LINKS) - 1}",
                               links_at + b * BLOCK_LINKS * LINK.itemsize,
                               sums_at if b == blocks - 1 else links_at + (b + 1) * BLOCK_LINKS * LINK.itemsize)
                              for b in range(blocks)]


def link_offsets(path, h):
    """(node table, first_link, links, checksum table) offsets and the
    counts (link_layout has the clusters' too)."""
    l = link_layout(path, h)
    return l["node_at"], l["first_at"], l["links_at"], l["sums_at"], l["counts"]


def link_sections(path, h, size):
    """The links layout's sections for read_header's bounds check, after
    the counts are checked to make trees of quadtrees over the patches
    (and, with clusters, a cluster tree over their roots)."""
    l = link_layout(path, h)
    c = l["counts"]
    n, nodes, roots, count = int(h["patch_count"]), c["node_count"], c["root_count"], c["link_count"]
    clusters = c["cluster_count"]
    if not (1 <= roots <= nodes < NO_ELEMENT and (nodes - roots) % 4 == 0 and n == roots + (nodes - roots) // 4 * 3):
        raise FormatError(f"{path}: {nodes} nodes, {roots} roots and {n} leaves do not make trees of quadtrees: "
                          "damaged header")
    if int(h["version"]) >= VERSION_CLUSTERS and not 1 <= clusters < 2 * roots:
        raise FormatError(f"{path}: {clusters} clusters over {roots} roots (version 5: 1 to 2 x roots - 1): "
                          "damaged header")
    if nodes + clusters >= NO_ELEMENT:
        raise FormatError(f"{path}: {nodes} nodes and {clusters} clusters, more than the link ids: damaged header")
    if LINK.itemsize * count > size or l["sums_at"] != int(h["row_checksum_offset"]):
        raise FormatError(f"{path}: {count} links do not fit the file's sections: damaged header or truncated file")
    sections = [("node table", l["node_at"], NODE.itemsize * nodes)]
    if clusters:
        sections += [("cluster table", l["cluster_at"], CLUSTER.itemsize * clusters),
                     ("cluster roots", l["roots_at"], 4 * roots)]
    return sections + [("first_link table", l["first_at"], 8 * (nodes + clusters + 1)),
                       ("links", l["links_at"], LINK.itemsize * count),
                       ("links' checksums", l["sums_at"], 8 * l["checksums"])]


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


def is_links(h):
    return int(h["version"]) >= 4 and int(h["layout"]) == LAYOUT_LINKS


def refuse_links(path, h):
    if is_links(h):
        raise KindError(f"{path}: holds links, not a matrix (hierarchical radiosity, form-factor layout 2): "
                        "read it with read_links")


def read_links(path, h=None, verify=True, with_clusters=False):
    """The links layout: (info, nodes, first_link, links) - info a dict of
    the counts (cluster_count too), link_tol, error_bound and scene name;
    nodes an array of NODE, first_link of uint64 (ids + 1, the ids being
    the nodes then the clusters: cluster c is id node_count + c), links of
    LINK (CSR by receiver: id r's links are links[first_link[r]:first_link[r
    + 1]]; a source is an id). with_clusters: (info, nodes, first_link,
    links, clusters, cluster_roots), clusters an array of CLUSTER and
    cluster_roots of uint32 (the roots in cluster order), both empty in a
    file without clusters (version 4).
    verify: check every checksum (the header's, the tables', the checksum
    table's digest, each section's and block's; pure Python, ~10 MB/s)
    before trusting a number; always: first_link from 0 to the link count
    without decreasing, sources and parents in range, each patch one leaf,
    the cluster roots each root once and clusters' parents before them.
    FormatError for a damaged file, KindError for a matrix file."""
    h = read_header(path) if h is None else h
    if not is_links(h):
        raise KindError(f"{path}: holds a matrix, not links (read it with read_rows or read_formfactors)")
    lay = link_layout(path, h)
    c = lay["counts"]
    node_at, first_at, links_at, sums_at = lay["node_at"], lay["first_at"], lay["links_at"], lay["sums_at"]
    nodes_n, count, n = c["node_count"], c["link_count"], int(h["patch_count"])
    clusters_n, roots = c["cluster_count"], c["root_count"]
    ids = nodes_n + clusters_n
    if verify:
        head = _read(path, np.uint8, 256, 0, "header").tobytes()
        if rad_hash64(head[:248]) != struct.unpack_from("<Q", head, 248)[0]:
            raise FormatError(f"{path}: header checksum mismatch: the file is corrupted")
        tables = _read(path, np.uint8, node_at - 256, 256, "tables").tobytes()
        if rad_hash64(tables) != int(h["tables_checksum"]):
            raise FormatError(f"{path}: vertex/patch table checksum mismatch: the file is corrupted")
    # each section (block) with the padding after it up to the next
    spans = link_spans(lay)
    sums = _read(path, "<u8", len(spans), sums_at, "links' checksums")
    if verify and rad_hash64(sums.tobytes()) != int(h["row_checksums_digest"]):
        raise FormatError(f"{path}: links' checksum table is corrupted (or the file was not completely written)")
    for k, (what, begin, end) in enumerate(spans):
        if verify and rad_hash64(_read(path, np.uint8, end - begin, begin, what).tobytes()) != int(sums[k]):
            raise FormatError(f"{path}: {what}: checksum mismatch: the file is corrupted")
    nodes = _read(path, NODE, nodes_n, node_at, "node table")
    clusters = _read(path, CLUSTER, clusters_n, lay["cluster_at"], "cluster table")
    cluster_roots = _read(path, "<u4", roots if clusters_n else 0, lay["roots_at"], "cluster roots")
    first_link = _read(path, "<u8", ids + 1, first_at, "first_link table")
    links = _read(path, LINK, count, links_at, "links")
    if first_link[0] != 0 or first_link[-1] != count or (np.diff(first_link.astype(np.int64)) < 0).any():
        raise FormatError(f"{path}: damaged first_link table (not from 0 to {count} without decreasing)")
    if count and int(links["source"].max()) >= ids:
        raise FormatError(f"{path}: damaged links (a source beyond {nodes_n} nodes and {clusters_n} clusters)")
    index = np.arange(nodes_n)
    parent = nodes["parent"].astype(np.int64)
    roots = c["root_count"]
    if (parent[:roots] != NO_ELEMENT).any() or (parent[roots:] >= index[roots:]).any():
        raise FormatError(f"{path}: damaged node table (roots not first, or a parent not before its child)")
    leaf = nodes["leaf"][nodes["first_child"] == NO_ELEMENT].astype(np.int64)
    if len(leaf) != n or not np.array_equal(np.sort(leaf), np.arange(n)):
        raise FormatError(f"{path}: damaged node table (the leaves are not each patch once)")
    if clusters_n:
        if not np.array_equal(np.sort(cluster_roots.astype(np.int64)), np.arange(roots)):
            raise FormatError(f"{path}: damaged cluster roots (not each root once)")
        cparent = clusters["parent"].astype(np.int64)
        begin, end = clusters["root_begin"].astype(np.int64), clusters["root_end"].astype(np.int64)
        if (cparent[0] != NO_ELEMENT or (cparent[1:] >= np.arange(1, clusters_n)).any()
                or (begin >= end).any() or (end > roots).any()):
            raise FormatError(f"{path}: damaged cluster table (cluster 0 not the root, a parent not before its "
                              "child, or a root range empty or beyond the roots)")
    info = dict(c, leaf_count=n, scene_name=scene_name(h))
    if with_clusters:
        return info, nodes, first_link, links, clusters, cluster_roots
    return info, nodes, first_link, links


def leaf_row_sums(nodes, first_link, links, clusters=None, cluster_roots=None):
    """Each node's sum of F over its own and its ancestors' links - the
    clusters holding its root included - (the row sums of the leaves'
    implied matrix, at the leaves)."""
    ids = len(first_link) - 1
    receivers = np.repeat(np.arange(ids), np.diff(first_link.astype(np.int64)))
    own_all = np.bincount(receivers, weights=links["factor"], minlength=ids)
    own = own_all[:len(nodes)]
    total = own.copy()
    if clusters is not None and len(clusters):
        # clusters' sums from cluster 0 down (parents come first), then the roots'
        ctotal = own_all[len(nodes):].copy()
        for c in range(1, len(clusters)):
            ctotal[c] += ctotal[int(clusters["parent"][c])]
        for c in np.nonzero(clusters["child_count"] == 0)[0]:
            at = cluster_roots[int(clusters["root_begin"][c]):int(clusters["root_end"][c])].astype(np.int64)
            total[at] += ctotal[c]
    parent = nodes["parent"].astype(np.int64)
    for level in range(1, int(nodes["level"].max()) + 1 if len(nodes) else 0):
        at = np.nonzero(nodes["level"] == level)[0]
        total[at] = own[at] + total[parent[at]]
    return total


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
    refuse_links(path, h)
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
    refuse_links(path, h)
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


def print_links(path, h):
    """The summary of a links file (the errors go to main's handlers)."""
    info, nodes, first_link, links, clusters, cluster_roots = read_links(path, h, with_clusters=True)
    names, _ = read_groups(path, h)
    leaves = nodes["first_child"] == NO_ELEMENT
    rows = leaf_row_sums(nodes, first_link, links, clusters, cluster_roots)[leaves]
    levels = int(nodes["level"].max())
    print(f"N = {info['leaf_count']} leaves, {info['node_count']} nodes ({info['root_count']} roots, "
          f"{levels + 1} levels), {info['cluster_count']} clusters, {info['link_count']} links, links layout; "
          f"link tol {info['link_tol']:g}, error bound {info['error_bound']:g}")
    print(f"row sums at the leaves: min {rows.min():.6f} max {rows.max():.6f} mean {rows.mean():.6f}")
    print(f"checksums verified; {NODE.itemsize} bytes per node, {CLUSTER.itemsize} per cluster, "
          f"{LINK.itemsize} per link")
    print(f"groups: {', '.join(names)}" if names else "groups: none recorded")
    return 0


def main(argv):
    if len(argv) != 2:
        print("usage: ffread.py FORMFACTORS", file=sys.stderr)
        return 2
    path = argv[1]
    try:
        h = read_header(path)
        if is_links(h):
            return print_links(path, h)
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
