#!/usr/bin/env python3
"""tools/ffread.py and tools/ffdump.py on a links file (the form-factor
file's layout for hierarchical radiosity), the one tests/test_lfile.c
writes: read_links gives its nodes, first_link and links with every
checksum verified, the matrix readers refuse it by kind; ffread.py
summarises it, ffdump.py lists its groups and refuses its matrix commands
with one line. Damaged copies - every single-byte change (XOR 0xff) in
process, truncations, header counts and sections through the programs -
are refused: a FormatError (ValueError) in process, one line naming the
file and exit 1 from the programs, never a traceback or a huge allocation
(children run under a 4 GiB address space limit). The file with clusters
(version 5) test_lfile leaves, where given: read_links gives its clusters
and cluster roots, every single-byte change and truncation is refused, and
damage in its cluster sections through ffread.py names the section. Exit
77 (skipped) where numpy is missing.

    tools_lfile.py TOOLS_DIR LINKS_FILE WORK_DIR [CLUSTERS_FILE]
"""
import os
import resource
import shutil
import struct
import subprocess
import sys
import tempfile

try:
    import numpy as np
except ImportError:
    print("skipped: numpy is not importable by", sys.executable)
    sys.exit(77)

tools, links_file, work = sys.argv[1], os.path.abspath(sys.argv[2]), sys.argv[3]
clusters_file = os.path.abspath(sys.argv[4]) if len(sys.argv) > 4 else None
os.makedirs(work, exist_ok=True)
os.chdir(work)
sys.path.insert(0, tools)
import ffread  # noqa: E402

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


def one_line_error(p, name, what, text=None):
    lines = p.stderr.strip().splitlines()
    ok = (p.returncode == 1 and "Traceback" not in p.stderr and len(lines) == 1 and name in lines[0]
          and (text is None or text in lines[0]))
    check(ok, f"{what}: {lines[0] if len(lines) == 1 else repr(p.stderr[-300:])} (exit {p.returncode})")


FFREAD = os.path.join(tools, "ffread.py")
FFDUMP = os.path.join(tools, "ffdump.py")

# ---- the whole file ----
h = ffread.read_header(links_file)
check(ffread.is_links(h) and not ffread.is_sparse(h) and int(h["version"]) == 4, "the header says links, version 4")
info, nodes, first_link, links = ffread.read_links(links_file, h)
check(info["cluster_count"] == 0 and all(len(a) == 0 for a in ffread.read_links(links_file, h, with_clusters=True)[4:]),
      "no clusters in version 4: empty cluster arrays")
check((info["node_count"], info["root_count"], info["leaf_count"], info["link_count"]) == (10, 2, 8, 14),
      f"counts: {info['node_count']} nodes, {info['root_count']} roots, {info['leaf_count']} leaves, "
      f"{info['link_count']} links")
check(info["link_tol"] == 0.0625 and info["error_bound"] == 1.5e-3 and info["scene_name"] == "two plates",
      "link tol, error bound and scene name")
check(len(nodes) == 10 and len(first_link) == 11 and len(links) == 14, "array lengths")
check((nodes["parent"][:2] == ffread.NO_ELEMENT).all() and (nodes["parent"][2:] == np.repeat([0, 1], 4)).all(),
      "roots first, four children each")
receivers = np.repeat(np.arange(10), np.diff(first_link.astype(np.int64)))
pairs = {(int(r), int(s)): float(f) for r, s, f in zip(receivers, links["source"], links["factor"])}
area = nodes["area"]
check(all((s, r) in pairs and abs(area[r] * f - area[s] * pairs[(s, r)]) <= 1e-15 for (r, s), f in pairs.items()),
      "links come in reciprocal pairs: A_r F_rs = A_s F_sr")
check(all((np.diff(links["source"][first_link[r]:first_link[r + 1]].astype(np.int64)) > 0).all() for r in range(10)),
      "sources ascending per receiver")
unverified = ffread.read_links(links_file, h, verify=False)
check(all(np.array_equal(a, b) for a, b in zip(unverified[1:], (nodes, first_link, links))),
      "verify=False reads the same arrays")
for what, call in (("read_rows", lambda: ffread.read_rows(links_file, h, 0, 1)),
                   ("read_formfactors", lambda: ffread.read_formfactors(links_file))):
    try:
        call()
        check(False, f"{what} read a links file")
    except ffread.KindError as e:
        check("holds links, not a matrix" in str(e), f"{what} refuses it: {e}")

p = run([FFREAD, links_file])
check(p.returncode == 0 and not p.stderr and "links layout" in p.stdout and "checksums verified" in p.stdout,
      f"ffread.py summarises it: {p.stdout.splitlines()[:1]}")
p = run([FFDUMP, "groups", links_file])
check(p.returncode == 0 and not p.stderr and "floor" in p.stdout and "light" in p.stdout,
      "ffdump.py groups lists its groups")
for command in (["matrix", links_file, "-o", "out.npy"], ["group-matrix", links_file, "-o", "out.csv"]):
    one_line_error(run([FFDUMP] + command), os.path.basename(links_file), f"ffdump.py {command[0]}",
                   "holds links, not a matrix")

# ---- damaged copies ----


def refused_in_process(name):
    """1 if read_header + read_links refuse `name` with a ValueError."""
    try:
        ffread.read_links(name)
        return False
    except (ValueError, struct.error):
        return True


def refused_copy(data):
    """refused_in_process on `data` written to a file in memory where
    /dev/shm exists (thousands of small files are slow on a busy disk)."""
    with open(flip_path, "wb") as f:
        f.write(data)
    return refused_in_process(flip_path)


def sweep(name, good):
    """Every single-byte change and truncation of `good` refused in process."""
    accepted = [k for k in range(len(good))
                if not refused_copy(good[:k] + bytes([good[k] ^ 0xFF]) + good[k + 1:])]
    check(not accepted, f"{name}: every single-byte change of {len(good)} refused in process "
          f"(accepted at {accepted[:10]})")
    accepted = [n for n in range(len(good)) if not refused_copy(good[:n])]
    check(not accepted, f"{name}: every truncation refused in process (accepted at {accepted[:10]})")


scratch = tempfile.mkdtemp(prefix="tools_lfile.", dir="/dev/shm" if os.access("/dev/shm", os.W_OK) else ".")
flip_path = os.path.join(scratch, "flip.links")
good = open(links_file, "rb").read()
try:
    sweep("version 4", good)
    if clusters_file:
        sweep("version 5", open(clusters_file, "rb").read())
finally:
    shutil.rmtree(scratch, ignore_errors=True)

node_at, first_at, links_at, sums_at, _ = ffread.link_offsets(links_file, h)


def damaged(name, edit, source=None):
    data = bytearray(good if source is None else source)
    edit(data)
    with open(name, "wb") as f:
        f.write(data)
    return name


def put(fmt, offset, value):
    return lambda d: struct.pack_into(fmt, d, offset, value)


def flip(offset):
    def edit(d):
        d[offset] ^= 0x10
    return edit


cases = [("half.links", lambda d: d.__delitem__(slice(len(d) // 2, None)), "truncated to half"),
         ("short.links", lambda d: d.__delitem__(slice(len(d) - 8, None)), "truncated by 8 bytes"),
         ("nodes_huge.links", put("<I", 192, 0xFFFFFFF0), "a huge node count"),
         ("links_huge.links", put("<Q", 200, 1 << 50), "a huge link count"),
         ("roots.links", put("<I", 196, 6), "counts that make no quadtrees"),
         ("layout.links", put("<I", 236, 7), "an unknown layout"),
         ("node.links", flip(node_at + 48 * 3 + 8), "a node's leaf changed"),
         ("first.links", flip(first_at + 8 * 4), "a first_link entry changed"),
         ("link.links", flip(links_at + 16 * 5 + 9), "a factor changed"),
         ("padding.links", flip(first_at - 8), "padding after the node table changed"),
         ("sums.links", flip(sums_at + 8), "the checksum table changed"),
         ("name.links", flip(130), "the scene name changed (header checksum)")]
# ffdump.py groups reads no links and, as for matrices, checks no checksums:
# it is given the header's damage only (a few, to keep the test fast).
for name, edit, what in cases:
    damaged(name, edit)
    one_line_error(run([FFREAD, name]), name, f"ffread.py, {what}")
    if name in ("half.links", "nodes_huge.links", "links_huge.links"):
        one_line_error(run([FFDUMP, "groups", name]), name, f"ffdump.py groups, {what}")

# ---- with clusters (version 5) ----
if clusters_file:
    hc = ffread.read_header(clusters_file)
    check(ffread.is_links(hc) and int(hc["version"]) == 5, "the clusters file says links, version 5")
    info, nodes, first_link, links, clusters, cluster_roots = ffread.read_links(clusters_file, hc, with_clusters=True)
    check((info["node_count"], info["root_count"], info["cluster_count"], info["leaf_count"], info["link_count"])
          == (9, 5, 5, 8, 16) and info["scene_name"] == "strip of plates",
          f"counts with clusters: {info}")
    check(len(clusters) == 5 and cluster_roots.tolist() == [3, 0, 4, 1, 2] and len(first_link) == 15,
          "cluster table, cluster roots (3 0 4 1 2) and first_link over 14 ids")
    check(clusters["parent"].tolist() == [ffread.NO_ELEMENT, 0, 0, 2, 2] and
          clusters["child_count"].tolist() == [2, 0, 2, 0, 0] and clusters["area"].tolist() == [5.5, 2.25, 3.25, 1.5, 1.75],
          "clusters' parents, children and areas")
    area = np.concatenate([nodes["area"], clusters["area"]])
    receivers = np.repeat(np.arange(14), np.diff(first_link.astype(np.int64)))
    pairs = {(int(r), int(s)): float(f) for r, s, f in zip(receivers, links["source"], links["factor"])}
    check(any(s >= 9 for _, s in pairs) and any(r >= 9 for r, _ in pairs) and
          all((s, r) in pairs and abs(area[r] * f - area[s] * pairs[(s, r)]) <= 1e-15 for (r, s), f in pairs.items()),
          "links at and from clusters, reciprocal with the clusters' areas")
    four = ffread.read_links(clusters_file, hc)
    check(len(four) == 4 and np.array_equal(four[2], first_link), "read_links without with_clusters: 4 arrays")
    p = run([FFREAD, clusters_file])
    check(p.returncode == 0 and not p.stderr and "5 clusters" in p.stdout and "checksums verified" in p.stdout,
          f"ffread.py summarises it: {p.stdout.splitlines()[:1]}")
    lay = ffread.link_layout(clusters_file, hc)
    source = open(clusters_file, "rb").read()
    for name, edit, what, text in (
            ("ctable.links", flip(lay["cluster_at"] + 32 + 8), "a cluster's field changed", "cluster table"),
            ("croots.links", flip(lay["roots_at"] + 4), "a cluster root changed", "cluster roots"),
            ("cpad.links", flip(lay["roots_at"] + 4 * 5 + 2), "the cluster roots' padding changed", "cluster roots"),
            ("ccount.links", put("<I", 188, 0xFFFFFFF0), "a huge cluster count", "clusters"),
            ("czero.links", put("<I", 188, 0), "no clusters in version 5", "clusters")):
        damaged(name, edit, source)
        one_line_error(run([FFREAD, name]), name, f"ffread.py, {what}", text)

print(f"{failures} failures")
sys.exit(1 if failures else 0)
