#!/usr/bin/env python3
"""Dump a form-factor file (docs/formats.md) by surface: the OBJ groups
(`g` / `o` names) that formfactor records in the file's group table.

    ffdump.py groups FORMFACTORS                      # the groups: patches, area
    ffdump.py group-matrix FORMFACTORS -o F.csv [-o F.npy]
        surface-to-surface form factors, G x G:
        F_GH = (sum_{i in G} A_i sum_{j in H} F_ij) / A_G
        (the fraction of the energy leaving surface G that arrives at H;
        A_G F_GH = A_H F_HG; a closed scene's rows sum to 1)
    ffdump.py matrix FORMFACTORS -o F.npy [-o F.csv]  # the N x N patch matrix, float64
    ffdump.py heatmap FORMFACTORS -o F.png [--pixels 1000] [--vmin X]
        the patch matrix as an image, log colour scale, patches ordered by
        group, group boundaries drawn and labelled (matplotlib)

Outputs by extension: .csv (a header row; the group matrix also a first
column of group names; the patch matrix columns `patch,group,` then one per
patch; 17 significant digits) or .npy (numpy.save: the group matrix G x G,
rows and columns in the order `groups` lists, and the patch matrix N x N,
in the file's patch order). Every output is written to a temporary name
beside it and renamed when complete, as the programs do.

The group commands need a file with a group table (version 2, from a
formfactor that records groups); `matrix` and `heatmap` read version 1 too.
A links file (version 4, hierarchical radiosity) has no matrix: `groups`
lists its leaves' groups, the matrix commands refuse it with a message
(tools/ffread.py summarises it).
This reader checks the header and the file's size, not the checksums (`solve`
checks them all before it trusts a number). Memory: `group-matrix` streams the
matrix in blocks of rows; `matrix` and `heatmap` hold it whole (8 N^2 bytes).
"""
import argparse
import csv
import io
import os
import struct
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ffread import (PATCH, FormatError, _read, damage_message, is_links, is_sparse, read_groups,  # noqa: E402
                    read_header, read_row_index, read_rows, scene_name)

FLAG_STANDARD_ERRORS = 2
BLOCK_BYTES = 64 << 20     # rows read at once by group-matrix


class DumpError(Exception):
    pass


class FormFactors:
    """A form-factor file, its patch table and group table; the matrix read in blocks of rows."""

    def __init__(self, path):
        self.path = path
        h = read_header(path)   # checks the sizes against the file (FormatError)
        self.header = h
        self.n = n = int(h["patch_count"])
        self.version = int(h["version"])
        self.errors = bool(int(h["flags"]) & FLAG_STANDARD_ERRORS)
        self.links = is_links(h)
        self.scene = scene_name(h)
        self.patches = _read(path, PATCH, n, int(h["patch_offset"]), "patch table")
        self.area = self.patches["area"].astype(np.float64)
        if not np.isfinite(self.area).all() or (self.area <= 0).any():
            raise FormatError(f"{path}: damaged patch table (an area not finite and positive)")
        self.names, self.patch_group = read_groups(path, h)
        if is_sparse(h):
            read_row_index(path, h)   # checked before any command trusts it (N + 1 numbers)

    def require_groups(self):
        if self.names is None:
            why = ("a form-factor file of version 1, from a formfactor before the group table"
                   if self.version < 2 else "written without groups")
            raise DumpError(f"{self.path}: has no group table ({why}): run formfactor again")

    def group_areas(self):
        return np.bincount(self.patch_group, weights=self.area, minlength=len(self.names))

    def group_matrix(self):
        """F_GH = (sum_{i in G} A_i sum_{j in H} F_ij) / A_G, streaming blocks of rows."""
        self.require_matrix()
        self.require_groups()
        if self.errors:
            raise DumpError(f"{self.path}: holds standard errors of form factors (formfactor --errors), "
                            "not form factors: there is no surface matrix to make of them")
        g, n = len(self.names), self.n
        onehot = np.zeros((n, g))
        onehot[np.arange(n), self.patch_group] = 1.0
        interchange = np.zeros((g, g))           # sum_{i in G} A_i sum_{j in H} F_ij
        rows = max(1, BLOCK_BYTES // max(1, 8 * n))
        for i0 in range(0, n, rows):
            i1 = min(n, i0 + rows)
            to_groups = self.rows(i0, i1) @ onehot
            np.add.at(interchange, self.patch_group[i0:i1], self.area[i0:i1, None] * to_groups)
        return interchange / self.group_areas()[:, None]

    def require_matrix(self):
        if self.links:
            raise DumpError(f"{self.path}: holds links, not a matrix (hierarchical radiosity, form-factor "
                            "layout 2): there is no patch matrix to dump; tools/ffread.py summarises it")

    def rows(self, begin, end):
        """Rows [begin, end) as float64, from either layout (docs/formats.md)."""
        self.require_matrix()
        return np.asarray(read_rows(self.path, self.header, begin, end), dtype=np.float64)

    def dense(self):
        return self.rows(0, self.n)


def fmt(x):
    return format(float(x), ".17g")


def write_atomic(path, write, binary):
    """Writes through a temporary beside `path`, renamed over it when complete."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, temp = tempfile.mkstemp(prefix=os.path.basename(path) + ".tmp-", dir=folder)
    try:
        with os.fdopen(fd, "wb" if binary else "w", newline=None if binary else "") as f:
            write(f)
        os.chmod(temp, 0o666 & ~current_umask())
        os.replace(temp, path)
    except BaseException:
        try:
            os.unlink(temp)
        except OSError:
            pass
        raise


def current_umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def kind_of(path, allowed):
    ext = os.path.splitext(path)[1].lower()
    if ext not in allowed:
        raise DumpError(f"{path}: the name must end in {' or '.join(allowed)}")
    return ext


def save_npy(path, array):
    write_atomic(path, lambda f: np.save(f, array, allow_pickle=False), binary=True)


def cmd_groups(ff, args):
    ff.require_groups()
    counts = np.bincount(ff.patch_group, minlength=len(ff.names))
    areas = ff.group_areas()
    emitted = np.zeros((len(ff.names), 3))
    np.add.at(emitted, ff.patch_group, ff.area[:, None] * ff.patches["emission"])
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["index", "group", "patches", "area", "emitted_r", "emitted_g", "emitted_b"])
    for k, name in enumerate(ff.names):
        w.writerow([k, name, int(counts[k]), fmt(areas[k])] + [fmt(e) for e in emitted[k]])
    sys.stdout.write(out.getvalue())


def cmd_group_matrix(ff, args):
    kinds = [kind_of(p, (".csv", ".npy")) for p in args.output]
    M = ff.group_matrix()
    for path, kind in zip(args.output, kinds):
        if kind == ".npy":
            save_npy(path, M)
        else:
            def write(f):
                w = csv.writer(f, lineterminator="\n")
                w.writerow(["group"] + ff.names)
                for name, row in zip(ff.names, M):
                    w.writerow([name] + [fmt(x) for x in row])
            write_atomic(path, write, binary=False)


def cmd_matrix(ff, args):
    kinds = [kind_of(p, (".csv", ".npy")) for p in args.output]
    F = ff.dense()
    for path, kind in zip(args.output, kinds):
        if kind == ".npy":
            save_npy(path, F)
        else:
            labels = ff.names if ff.names is not None else None

            def write(f):
                w = csv.writer(f, lineterminator="\n")
                w.writerow(["patch", "group"] + [str(j) for j in range(ff.n)])
                for i, row in enumerate(F):
                    group = labels[ff.patch_group[i]] if labels is not None else ""
                    w.writerow([i, group] + [fmt(x) for x in row])
            write_atomic(path, write, binary=False)


def cmd_heatmap(ff, args):
    for path in args.output:
        kind_of(path, (".png",))
    ff.require_matrix()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.colors import LogNorm
    except ImportError as e:
        raise DumpError(f"heatmap needs matplotlib (Debian: python3-matplotlib): {e}")
    n = ff.n
    if ff.names is not None:
        order = np.argsort(ff.patch_group, kind="stable")
        names, groups = ff.names, ff.patch_group[order]
    else:
        order, names, groups = np.arange(n), ["(no groups recorded)"], np.zeros(n, dtype=np.uint32)
    M = ff.dense()[order][:, order]
    positive = M[M > 0]
    vmax = positive.max() if positive.size else 1.0
    vmin = args.vmin if args.vmin else (max(positive.min(), vmax * 1e-12) if positive.size else 1e-12)
    if not vmin < vmax:
        vmin = vmax / 10
    masked = np.ma.masked_less_equal(M, 0)
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_bad("white")
    inches = args.pixels / 100.0
    fig = plt.figure(figsize=(inches, inches), dpi=100)
    ax = fig.add_axes([0.15, 0.15, 0.69, 0.74])
    im = ax.imshow(masked, cmap=cmap, norm=LogNorm(vmin=vmin, vmax=vmax), interpolation="nearest",
                   extent=(-0.5, n - 0.5, n - 0.5, -0.5))
    counts = np.bincount(groups, minlength=len(names))
    edges = np.concatenate([[0], np.cumsum(counts)])
    for e in edges[1:-1]:
        ax.axhline(e - 0.5, color="red", linewidth=0.6)
        ax.axvline(e - 0.5, color="red", linewidth=0.6)
    shown = [k for k in range(len(names)) if counts[k] > 0]
    centres = [(edges[k] + edges[k + 1] - 1) / 2 for k in shown]
    size = max(3.0, min(8.0, 400.0 / max(1, len(shown)))) * args.pixels / 1000.0
    ax.set_xticks(centres)
    labels = [names[k] if len(names[k]) <= 20 else names[k][:19] + "\u2026" for k in shown]
    ax.set_xticklabels(labels, rotation=90, fontsize=size)
    ax.set_yticks(centres)
    ax.set_yticklabels(labels, fontsize=size)
    ax.tick_params(length=0)
    what = "standard error of F_ij" if ff.errors else "F_ij"
    ax.set_title(f"{os.path.basename(ff.path)} ({ff.scene}): {what}, N = {n}, row i to column j\n"
                 f"patches ordered by group; white: 0", fontsize=9 * args.pixels / 1000.0)
    cax = fig.add_axes([0.87, 0.15, 0.025, 0.74])
    fig.colorbar(im, cax=cax).ax.tick_params(labelsize=8 * args.pixels / 1000.0)
    for path in args.output:
        write_atomic(path, lambda f: fig.savefig(f, format="png", dpi=100), binary=True)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(prog="ffdump.py", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("groups", help="list the groups: index, name, patches, area, emitted power (CSV on stdout)")
    s.add_argument("formfactors")
    s.set_defaults(run=cmd_groups)
    for name, run, help_text in (("group-matrix", cmd_group_matrix, "surface-to-surface form factors F_GH"),
                                 ("matrix", cmd_matrix, "the patch matrix F_ij, float64")):
        s = sub.add_parser(name, help=help_text)
        s.add_argument("formfactors")
        s.add_argument("-o", "--output", action="append", required=True, help="FILE.csv or FILE.npy (repeatable)")
        s.set_defaults(run=run)
    s = sub.add_parser("heatmap", help="the patch matrix as a PNG, log scale, ordered by group")
    s.add_argument("formfactors")
    s.add_argument("-o", "--output", action="append", required=True, help="FILE.png (repeatable)")
    s.add_argument("--pixels", type=int, default=1000, help="width and height of the image (default 1000)")
    s.add_argument("--vmin", type=float, default=0.0,
                   help="smallest value of the colour scale (default: the smallest positive entry, "
                        "at least 1e-12 of the largest)")
    s.set_defaults(run=cmd_heatmap)
    args = p.parse_args(argv)
    if getattr(args, "pixels", 100) < 100:
        p.error("--pixels must be at least 100")
    path = args.formfactors
    try:
        args.run(FormFactors(path), args)
    except DumpError as e:
        print(f"ffdump.py: {e}", file=sys.stderr)
        return 1
    except OSError as e:   # the input or an output
        print(f"ffdump.py: {e.filename or path}: {e.strerror or e}", file=sys.stderr)
        return 1
    except (ValueError, struct.error) as e:   # FormatError, and numpy on what slipped past the checks
        print(f"ffdump.py: {damage_message(path, e)}", file=sys.stderr)
        return 1
    except MemoryError:
        print(f"ffdump.py: {path}: out of memory (`matrix` and `heatmap` hold 8 N^2 bytes)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
