#!/usr/bin/python3
"""What accuracy costs in time: error against compute time for each estimator.

    python3 tools/accuracy_study.py [BUILD_DIR] [options]   (writes OUT/accuracy.md, .png, .json, .csv)

One command regenerates docs/accuracy.md and its plots. It runs
BUILD_DIR/formfactor (default BUILD_DIR: build) and records, for each
estimator (mc, qmc, auto), sample count K and shadow-ray count R, the error
against the compute time (form factors + visibility, and the whole run, from
--stats). Three legs:

1. Closed forms (no shadow rays; these cases have no occluder), several seeds:
     parallel       unit squares facing each other at distance 1: F = 0.199824896
     perpendicular  unit squares sharing an edge at 90 degrees:    F = 0.200043776
     closure        closed unit box, --subdiv 2 (96 patches):       every row sums to 1
                    (error: RMS over rows of |row sum - 1|)
2. The paper's scene, scenes/cornell_sphere.obj at --subdiv 2 (N = 736; --subdiv 3
   gives N = 2944), against a reference matrix computed once with many samples
   (see reference() below for how, and why not simply `auto`): relative
   Frobenius error of F and max |row sum - 1| (the scene is closed), per
   estimator and K (with R = K/16, the paper's ratio 32/512), and a sweep of R
   at K = 512.
3. The final image: each matrix of leg 2 is solved (`solve`) and rendered
   (`render`, linear EXR, the scene's camera) and compared with the render of
   the reference matrix: RMSE of linear radiance over pixels and channels.
   When BUILD_DIR has no `render` (it needs OpenImageIO), the radiosity files
   are packed into OUT/accuracy_radiosity.tar.xz instead, and
       python3 tools/accuracy_study.py BUILD_WITH_RENDER --images-from DIR --out DIR
   finishes the leg later on a machine that has it (the image depends on the
   matrix only, not on where it was computed).

Options:
  --backend B[,B]   cpu | cuda | cpu,cuda (default cpu). With two, every run is
                    timed on each; errors come from the first (the backends draw
                    the same samples; the study checks their matrices agree).
  --threads T       CPU threads for formfactor, solve and render (default 1)
  --quick           a tiny sweep for smoke tests (--subdiv 1, few K, 2 seeds)
  --subdiv S        cornell_sphere subdivision (default 2; --quick: 1)
  --ref-samples K   reference samples per pair (default 2^18 when the reference
                    runs on cuda, 2^15 on the CPU, 2^13 with --quick)
  --out DIR         where accuracy.md/.png/.json/.csv go (default docs/)
  --images-from DIR finish the image leg of an earlier run (its accuracy.json and
                    accuracy_radiosity.tar.xz in DIR); runs no formfactor
  --no-closed-forms skip leg 1 (its rows are then missing from the outputs)

Time (measured 2026-11-22 on an H200 machine, 16 cores; the full sweep
extrapolated from a --quick --subdiv 2 run there): the full sweep with
--backend cpu,cuda --threads 16 takes about 6-7 minutes (closed forms ~4 min,
mostly process start-up of ~0.7 s per formfactor run; reference on the GPU
~10 s; cornell_sphere ~2 min for both backends); cpu alone about 5, cuda alone
about 4.5. With `analytic` (added later) the cpu,cuda sweep takes about 9
minutes: more than one 8-10 minute device call, so run `--backend cpu` and
`--backend cuda` (or `--estimators` subsets) in separate calls. --subdiv 3 (N = 2944) fits only with --backend cuda. --quick takes
about 1 minute on one core of a 2-core VM, 2 minutes on the H200 machine.

Progress goes to stderr. Needs numpy and matplotlib (Debian: python3-numpy,
python3-matplotlib). EXR files are read with OpenImageIO's Python module when
it is there, else tools/exrread.py (numpy + zlib), else `oiiotool --dumpdata`.
"""
import argparse
import csv
import datetime
import json
import math
import os
import shlex
import shutil
import socket
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from ffread import HEADER, read_formfactors  # noqa: E402

ESTIMATORS = ["mc", "qmc", "auto", "analytic"]
MTL = "newmtl grey\nKd 0.5 0.5 0.5\n"
PARALLEL = ("mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
            "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 5 6 7 8\n")
PERPENDICULAR = ("mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
                 "v 0 0 1\nv 0 1 1\nf 1 4 6 5\n")
EXACT = {"parallel": 0.199824895698, "perpendicular": 0.200043776075}
CASES = ["parallel", "perpendicular", "closure"]
SPHERE = os.path.join(ROOT, "scenes", "cornell_sphere.obj")
CAMERA = os.path.join(ROOT, "scenes", "cornell_sphere.camera")
RENDER_ARGS = ["--width", "256", "--height", "256", "--spp", "4", "--camera", CAMERA]
SOLVE_ARGS = ["--max-iter", "5000"]
PAPER_K, PAPER_R = 512, 32

PLANS = {
    "full": {"closed_samples": [16, 64, 256, 1024, 4096], "closed_seeds": [1, 2, 3, 4, 5, 6],
             "closed_timing_seeds": 2,  # seeds per point on a second backend (timing only)
             "sphere_samples": [64, 256, 512, 1024, 4096, 16384], "ray_sweep": [0, 8, 32, 128, 512],
             "ray_sweep_samples": 512, "sphere_seeds": [1, 2], "subdiv": 2, "ref_seeds": [101, 102]},
    "quick": {"closed_samples": [16, 256], "closed_seeds": [1, 2], "closed_timing_seeds": 1,
              "sphere_samples": [64, 512, 4096], "ray_sweep": [0, 8, 32, 128],
              "ray_sweep_samples": 512, "sphere_seeds": [1, 2], "subdiv": 1, "ref_seeds": [101, 102]},
}

T0 = time.monotonic()


def log(msg):
    print(f"[{time.monotonic() - T0:7.1f} s] {msg}", file=sys.stderr, flush=True)


# ---------------------------------------------------------------- machine ---

def machine_info():
    info = {"node": socket.gethostname(), "nproc": os.cpu_count(), "cpu": None, "gpu": None, "os": None}
    try:
        with open("/etc/os-release") as f:
            for line in f:
                if line.startswith("PRETTY_NAME="):
                    info["os"] = line.split("=", 1)[1].strip().strip('"')
    except OSError:
        pass
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    if shutil.which("nvidia-smi"):
        try:
            out = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"],
                                 capture_output=True, text=True, timeout=30).stdout.strip().splitlines()
            if out:
                info["gpu"] = f"{len(out)} x {out[0]}" if len(out) > 1 else out[0]
        except (OSError, subprocess.SubprocessError):
            pass
    return info


def machine_line(m):
    s = f"`{m['node']}`, {m['nproc']} cores"
    if m.get("cpu"):
        s += f" ({m['cpu']})"
    if m.get("gpu"):
        s += f", GPU {m['gpu']}"
    if m.get("os"):
        s += f", {m['os']}"
    return s


def git_commit():
    try:
        rev = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=10)
        if rev.returncode != 0:
            return None
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=30).stdout.strip()
        return rev.stdout.strip() + ("+uncommitted changes" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return None


def command_line():
    """The command as run, with machine-local folders named by their role
    (BUILD, OUT, IMAGES) and folders inside the repository made relative,
    so the recorded command reads the same on every machine."""
    roles = {"--out": "OUT", "--images-from": "IMAGES"}
    parts, previous = ["python3"], None
    for k, a in enumerate(sys.argv):
        if k == 0:
            a = os.path.relpath(os.path.abspath(a), ROOT)
        elif os.path.isabs(a):
            rel = os.path.relpath(a, ROOT)
            a = rel if not rel.startswith("..") else roles.get(previous, "BUILD")
        parts.append(a)
        previous = a
    return " ".join(shlex.quote(a) for a in parts)


# ----------------------------------------------------------------- runner ---

class Runner:
    def __init__(self, build, threads, work):
        self.build, self.threads, self.work = build, threads, work
        self.env = dict(os.environ, OMP_NUM_THREADS=str(threads))
        self.count = 0

    def prog(self, name):
        return os.path.join(self.build, name)

    def formfactor(self, scene, args, backend, out):
        stats = os.path.join(self.work, "stats.json")
        # dense files: write_matrix_like rewrites their rows in place
        cmd = [self.prog("formfactor"), scene, "-q", "--threads", str(self.threads), "--backend", backend,
               "--format", "dense", "-o", out, "--stats", stats] + [str(a) for a in args]
        t = time.monotonic()
        p = subprocess.run(cmd, capture_output=True, text=True, env=self.env)
        wall = time.monotonic() - t
        if p.returncode != 0:
            raise RuntimeError(f"{shlex.join(cmd)} failed ({p.returncode}):\n{p.stderr}")
        with open(stats) as f:
            s = json.load(f)
        self.count += 1
        ts = s["time_seconds"]
        return {"compute_s": ts["form_factors"] + ts["visibility"], "total_s": ts["total"], "wall_s": wall,
                "gpus_visible": s.get("gpus_visible"), "patches": s.get("patches")}

    def solve(self, ff, out):
        """-> "converged", "unconverged" (exit 3: file written, marked so) or "refused: why" (no file)."""
        p = subprocess.run([self.prog("solve"), ff, "-o", out, "-q"] + SOLVE_ARGS, capture_output=True,
                           text=True, env=self.env)
        if p.returncode in (0, 3):
            return "converged" if p.returncode == 0 else "unconverged"
        if p.returncode == 1 and not os.path.exists(out):   # e.g. a row sums to more than 1.5
            why = p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "exit 1"
            return "refused: " + why.split(": ", 2)[-1].replace(ff + ": ", "")
        raise RuntimeError(f"solve {ff} failed ({p.returncode}):\n{p.stderr}")

    def render(self, rad, out):
        p = subprocess.run([self.prog("render"), rad, "-o", out, "-q"] + RENDER_ARGS, capture_output=True,
                           text=True, env=self.env)
        if p.returncode != 0:
            raise RuntimeError(f"render {rad} failed ({p.returncode}):\n{p.stderr}")


# ---------------------------------------------------------------- EXR I/O ---

def exr_reader():
    """Returns (name, function path -> float64 array h x w x c, channels in one fixed order)."""
    try:
        import OpenImageIO as oiio  # noqa: F401

        def read_oiio(path):
            buf = oiio.ImageBuf(path)
            return np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float64)
        return "OpenImageIO (Python)", read_oiio
    except ImportError:
        pass
    from exrread import read_exr

    def read_numpy(path):
        try:
            return read_exr(path).astype(np.float64)
        except ValueError:
            if shutil.which("oiiotool"):
                return read_oiiotool(path)
            raise
    return "tools/exrread.py (numpy)", read_numpy


def read_oiiotool(path):
    import re
    txt = subprocess.run(["oiiotool", "--dumpdata", path], capture_output=True, text=True, check=True).stdout
    rows = [(int(m.group(1)), int(m.group(2)), [float(v) for v in m.group(3).split()])
            for m in re.finditer(r"Pixel \((\d+), (\d+)\):(.*)", txt)]
    w = max(r[0] for r in rows) + 1
    h = max(r[1] for r in rows) + 1
    img = np.zeros((h, w, len(rows[0][2])))
    for x, y, v in rows:
        img[y, x] = v
    return img   # R, G, B, as OpenImageIO and exrread give them


# ------------------------------------------------- writing a matrix file ---

HASH_SEED = np.uint64(0xcbf29ce484222325)
HASH_PRIME = np.uint64(0x100000001b3)


def hash_rows(words):
    """rad_hash64 (core/rad_hash.c) of each row of a (rows, n) uint64 array, all rows at once."""
    h = np.full(words.shape[0], HASH_SEED, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for k in range(words.shape[1]):
            h ^= words[:, k]
            h *= HASH_PRIME
            h ^= h >> np.uint64(29)
    return h


def hash_bytes(data):
    n = len(data) // 8
    h = int(hash_rows(np.frombuffer(data[:8 * n], dtype="<u8").reshape(1, n))[0])
    for b in data[8 * n:]:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def write_matrix_like(template, F, out):
    """Writes F into a copy of form-factor file `template` (same patches), with fresh checksums."""
    buf = bytearray(open(template, "rb").read())
    h = np.frombuffer(bytes(buf[:256]), dtype=HEADER)[0]
    n, moff, coff = int(h["patch_count"]), int(h["matrix_offset"]), int(h["row_checksum_offset"])
    if int(h["element_type"]) != 2:
        raise ValueError(f"{template}: expected float64 elements")
    old = np.frombuffer(bytes(buf[moff:moff + 8 * n * n]), dtype="<u8").reshape(n, n)
    stored = np.frombuffer(bytes(buf[coff:coff + 8 * n]), dtype="<u8")
    if not np.array_equal(hash_rows(old), stored):   # our rad_hash64 must reproduce formfactor's
        raise RuntimeError("row checksums of the template do not match: rad_hash64 reimplementation is off")
    rows = np.ascontiguousarray(F, dtype="<f8")
    buf[moff:moff + 8 * n * n] = rows.tobytes()
    table = hash_rows(rows.view("<u8")).astype("<u8").tobytes()
    buf[coff:coff + 8 * n] = table
    buf[120:128] = np.uint64(hash_bytes(table)).astype("<u8").tobytes()
    buf[248:256] = np.uint64(hash_bytes(bytes(buf[:248]))).astype("<u8").tobytes()
    with open(out, "wb") as f:
        f.write(buf)


# --------------------------------------------------------- leg 1: closed ---

def closed_forms(runner, plan, backends, work):
    with open(os.path.join(work, "s.mtl"), "w") as f:
        f.write(MTL)
    scenes = {"closure": os.path.join(ROOT, "scenes", "closed_box.obj")}
    for name, text in (("parallel", PARALLEL), ("perpendicular", PERPENDICULAR)):
        scenes[name] = os.path.join(work, name + ".obj")
        with open(scenes[name], "w") as f:
            f.write(text)
    runs = []
    out = os.path.join(work, "ff")
    for bi, backend in enumerate(backends):
        seeds = plan["closed_seeds"] if bi == 0 else plan["closed_seeds"][:plan["closed_timing_seeds"]]
        for case in CASES:
            for est in ESTIMATORS:
                for k in plan["closed_samples"]:
                    errs = []
                    for seed in seeds:
                        args = ["--estimator", est, "--samples", k, "--shadow-rays", 0, "--seed", seed]
                        if case == "closure":
                            args += ["--subdiv", 2]
                        r = runner.formfactor(scenes[case], args, backend, out)
                        F = read_formfactors(out)[3]
                        if case == "closure":
                            err = math.sqrt(np.mean((F.sum(axis=1) - 1.0) ** 2))
                        else:
                            err = float(F[0, 1] - EXACT[case])
                        errs.append(err)
                        runs.append(dict(part=case, backend=backend, estimator=est, samples=k, shadow_rays=0,
                                         seed=seed, error=err, **r))
                    log(f"closed {backend:4s} {case:13s} {est:4s} K={k:5d}: "
                        f"rms error {math.sqrt(np.mean(np.square(errs))):.3e}")
    return runs


def aggregate_closed(runs, backends):
    rows = []
    for case in CASES:
        for est in ESTIMATORS:
            ks = sorted({r["samples"] for r in runs if r["part"] == case and r["estimator"] == est})
            for k in ks:
                sel = [r for r in runs if r["part"] == case and r["estimator"] == est and r["samples"] == k]
                prim = [r for r in sel if r["backend"] == backends[0]]
                row = {"case": case, "estimator": est, "K": k, "seeds": len(prim),
                       "rms_error": math.sqrt(np.mean([r["error"] ** 2 for r in prim])), "time": {}}
                row["time"] = median_times(sel, backends)
                rows.append(row)
    return rows


def median_times(runs, backends):
    """Per backend that has runs among `runs`: median compute and total seconds."""
    times = {}
    for b in backends:
        rb = [r for r in runs if r["backend"] == b]
        if rb:
            times[b] = {"compute_s": float(np.median([r["compute_s"] for r in rb])),
                        "total_s": float(np.median([r["total_s"] for r in rb]))}
    return times


# ------------------------------------------------------ leg 2: reference ---

def reference(runner, plan, args, backend, work):
    """The reference matrix, and an estimate of its own error.

    Not simply `auto` with many samples: a reference made with the estimator
    under test would hide that estimator's own bias (before d464ced, `auto`
    with shadow rays was biased on partly occluded near pairs: a sphere facet
    beside the wall it nearly touches kept a third of its form factor). Not
    simply `qmc` with rays either: point pairs converge slowly where patches
    touch (every room corner). So, per seed s:
        A  = auto, K_ref pairs, no shadow rays   (near pairs in closed form)
        Q  = qmc,  K_ref pairs, K_ref shadow rays
        Q0 = qmc,  K_ref pairs, no shadow rays   (the same point pairs as Q)
        H_s = A * (Q / Q0)  where Q0 > 0,  else A
    Q/Q0 is the G-weighted visible fraction of the pair seen by K_ref rays (it
    is exactly 1 where no ray was blocked), applied to A's unoccluded
    integral; it is pair-symmetric, so H_s keeps reciprocity. The reference
    is the mean of H over two seeds; its error is estimated as
    ||H_1 - H_2||_F / 2 (the error of a mean of two).
    """
    kref = args.ref_samples
    seeds = plan["ref_seeds"]
    subdiv = ["--subdiv", args.subdiv]
    H, info = [], {"samples": kref, "shadow_rays": kref, "seeds": seeds, "backend": backend, "runs": []}
    template = os.path.join(work, "ref_template")
    for s in seeds:
        mats = {}
        for name, est, rays in (("A", "auto", 0), ("Q", "qmc", kref), ("Q0", "qmc", 0)):
            out = os.path.join(work, f"ref_{name}")
            r = runner.formfactor(SPHERE, subdiv + ["--estimator", est, "--samples", kref, "--shadow-rays", rays,
                                                    "--seed", s], backend, out)
            info["runs"].append(dict(name=name, estimator=est, samples=kref, shadow_rays=rays, seed=s, **r))
            log(f"reference seed {s}: {est} K={kref} R={rays} on {backend}: compute {r['compute_s']:.2f} s, "
                f"wall {r['wall_s']:.1f} s")
            mats[name] = read_formfactors(out)[3]
            if name == "A" and s == seeds[0]:
                os.replace(out, template)
        A, Q, Q0 = mats["A"], mats["Q"], mats["Q0"]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where((Q0 > 0) & (Q != Q0), Q / Q0, 1.0)
        H.append(A * ratio)
        if s == seeds[0]:
            info["occluded_entries"] = int(np.count_nonzero(ratio != 1.0))
            info["nonzero_entries"] = int(np.count_nonzero(A))
            info["qmc_rays_matrix"] = Q   # compared with the reference below
            info["auto_norays_matrix"] = A
        del mats
    F = np.mean(H, axis=0)
    norm = np.linalg.norm(F)
    rs = F.sum(axis=1)
    info.update({
        "patches": int(F.shape[0]),
        "error_of_mean": float(np.linalg.norm(H[0] - H[1]) / 2 / norm),
        "error_single_seed": float(np.linalg.norm(H[0] - H[1]) / math.sqrt(2) / norm),
        "rowsum_max_abs": float(np.abs(rs - 1).max()),
        "rowsum_rms": float(math.sqrt(np.mean((rs - 1) ** 2))),
    })
    AF = read_formfactors(template)[2]["area"][:, None] * F
    info["reciprocity"] = float(np.abs(AF - AF.T).max() / AF.max())
    info["qmc_rays_vs_ref"] = float(np.linalg.norm(info.pop("qmc_rays_matrix") - F) / norm)
    info["auto_norays_vs_ref"] = float(np.linalg.norm(info.pop("auto_norays_matrix") - F) / norm)
    path = os.path.join(work, "ref_ff")
    write_matrix_like(template, F, path)
    log(f"reference: N = {F.shape[0]}, estimated error {info['error_of_mean']:.2e} (single seed "
        f"{info['error_single_seed']:.2e}), max |row sum - 1| {info['rowsum_max_abs']:.2e}")
    return F, path, info


# ---------------------------------------------------------- leg 2 and 3 ---

def sphere_configs(plan):
    cfg = []
    for k in plan["sphere_samples"]:
        cfg.append((k, max(1, k // 16), "K"))
    for r in plan["ray_sweep"]:
        key = (plan["ray_sweep_samples"], r)
        if key not in [(c[0], c[1]) for c in cfg]:
            cfg.append((plan["ray_sweep_samples"], r, "R"))
    return cfg


def sphere_sweep(runner, plan, args, backends, Fref, images, work):
    """Leg 2 (matrix errors) and, when images is not None, leg 3 (its solve and render / archive)."""
    runs = []
    norm = np.linalg.norm(Fref)
    first = {}   # (est, K, R) -> seed-1 matrix of the first backend, to check the others against
    cfgs = sphere_configs(plan)
    total = len(backends) * len(cfgs) * len(ESTIMATORS) * len(plan["sphere_seeds"])
    out = os.path.join(work, "ff")
    i = 0
    for bi, backend in enumerate(backends):
        for est in ESTIMATORS:
            for k, rays, _ in cfgs:
                for seed in plan["sphere_seeds"]:
                    i += 1
                    r = runner.formfactor(SPHERE, ["--subdiv", args.subdiv, "--estimator", est, "--samples", k,
                                                   "--shadow-rays", rays, "--seed", seed], backend, out)
                    F = read_formfactors(out)[3]
                    rs = F.sum(axis=1)
                    rec = dict(part="sphere", backend=backend, estimator=est, samples=k, shadow_rays=rays,
                               seed=seed, frob_rel=float(np.linalg.norm(F - Fref) / norm),
                               rowsum_max_abs=float(np.abs(rs - 1).max()),
                               rowsum_rms=float(math.sqrt(np.mean((rs - 1) ** 2))), **r)
                    key = (est, k, rays)
                    if seed == plan["sphere_seeds"][0]:
                        if bi == 0:
                            first[key] = F.copy()
                        elif key in first:
                            rec["max_abs_diff_vs_first_backend"] = float(np.abs(F - first[key]).max())
                    msg = ""
                    if bi == 0 and images is not None:
                        msg = images.add(rec, out)
                    runs.append(rec)
                    log(f"[{i}/{total}] sphere {backend:4s} {est:4s} K={k:5d} R={rays:4d} seed {seed}: compute "
                        f"{r['compute_s'] * 1e3:9.1f} ms, frob {rec['frob_rel']:.3e}, row sum "
                        f"{rec['rowsum_max_abs']:.3e}{msg}")
    return runs


class Images:
    """Leg 3: solve + render each matrix, or keep its radiosity file for later."""

    def __init__(self, runner, work, ref_ff):
        self.runner, self.work = runner, work
        self.raddir = os.path.join(work, "radiosity")
        os.makedirs(self.raddir, exist_ok=True)
        self.can_render = os.access(runner.prog("render"), os.X_OK)
        self.reader_name, self.reader = exr_reader()
        status = runner.solve(ref_ff, os.path.join(self.raddir, "reference.rad"))
        if status != "converged":
            raise RuntimeError(f"solve of the reference matrix: {status}")
        self.ref_img = None
        if self.can_render:
            self.ref_img = self.render(os.path.join(self.raddir, "reference.rad"))
            self.ref_mean = float(self.ref_img.mean())
            self.cross_check()

    def render(self, rad):
        exr = os.path.join(self.work, "img.exr")
        self.runner.render(rad, exr)
        return self.reader(exr)

    def cross_check(self):
        """When oiiotool is there too, the reader must agree with it on the reference image."""
        self.cross = None
        if shutil.which("oiiotool") and self.reader_name.startswith("tools/"):
            exr = os.path.join(self.work, "img.exr")
            self.runner.render(os.path.join(self.raddir, "reference.rad"), exr)
            d = float(np.abs(read_oiiotool(exr) - self.reader(exr)).max())
            self.cross = d
            if d > 1e-6:
                raise RuntimeError(f"EXR reader disagrees with oiiotool by {d}")

    def add(self, rec, ff):
        name = (f"{rec['estimator']}_K{rec['samples']}_R{rec['shadow_rays']}_s{rec['seed']}.rad")
        rad = os.path.join(self.raddir, name)
        rec["solve"] = self.runner.solve(ff, rad)
        if rec["solve"].startswith("refused"):
            return f", solve {rec['solve']}"
        rec["radiosity"] = name
        if not self.can_render:
            return ""
        img = self.render(rad)
        os.remove(rad)
        rec["image_rmse"] = float(math.sqrt(np.mean((img - self.ref_img) ** 2)))
        rec["image_rmse_rel"] = rec["image_rmse"] / self.ref_mean
        return f", image RMSE {rec['image_rmse_rel']:.3e} of mean" + ("" if rec["solve"] == "converged"
                                                                        else " (solve unconverged)")

    def archive(self, path):
        with tarfile.open(path, "w:xz") as tar:
            for name in sorted(os.listdir(self.raddir)):
                tar.add(os.path.join(self.raddir, name), arcname=name)


def aggregate_sphere(runs, backends, cfgs):
    rows = []
    for est in ESTIMATORS:
        for k, rays, sweep in cfgs:
            sel = [r for r in runs if r["estimator"] == est and r["samples"] == k and r["shadow_rays"] == rays]
            prim = [r for r in sel if r["backend"] == backends[0]]
            if not prim:
                continue
            row = {"estimator": est, "K": k, "R": rays, "sweep": sweep, "seeds": len(prim),
                   "frob_rel": math.sqrt(np.mean([r["frob_rel"] ** 2 for r in prim])),
                   "rowsum_max_abs": float(np.mean([r["rowsum_max_abs"] for r in prim])),
                   "rowsum_rms": math.sqrt(np.mean([r["rowsum_rms"] ** 2 for r in prim])), "time": {}}
            imgs = [r for r in prim if "image_rmse" in r]
            if imgs:
                row["image_rmse"] = math.sqrt(np.mean([r["image_rmse"] ** 2 for r in imgs]))
                row["image_rmse_rel"] = math.sqrt(np.mean([r["image_rmse_rel"] ** 2 for r in imgs]))
            notes = []
            refused = [r for r in prim if r.get("solve", "").startswith("refused")]
            if refused:
                row["solve_refused"] = len(refused)
                notes.append(f"{len(refused)} of {len(prim)} seeds refused by solve"
                             + (" (a row sums to > 1.5)" if "more than 1.5" in refused[0]["solve"] else ""))
            unconv = [r for r in prim if r.get("solve") == "unconverged"]
            if unconv:
                notes.append(f"{len(unconv)} of {len(prim)} seeds: solve did not converge")
            if notes:
                row["image_note"] = "; ".join(notes)
            row["time"] = median_times(sel, backends)
            rows.append(row)
    return rows


# ------------------------------------------------------------------ plots ---

STYLE = {"mc": ("o", "C0"), "qmc": ("s", "C1"), "auto": ("d", "C2"), "analytic": ("^", "C3")}
LINES = ["-", "--", ":"]


def plot_closed(rows, backends, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, case in zip(axes, CASES):
        for bi, b in enumerate(backends):
            for est in ESTIMATORS:
                pts = [(max(r["time"][b]["compute_s"], 1e-6), r["rms_error"]) for r in rows
                       if r["case"] == case and r["estimator"] == est and b in r["time"]]
                if pts:
                    m, c = STYLE[est]
                    ax.loglog(*zip(*pts), marker=m, color=c, ls=LINES[bi], label=f"{est} ({b})")
        ax.set_title(case)
        ax.set_xlabel("compute time per run (s; --stats resolves 1e-6)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("RMS error over seeds")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_sphere(rows, backends, ref, path, n):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    have_img = any("image_rmse_rel" in r for r in rows)
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    panels = [(axes[0, 0], "frob_rel", "relative Frobenius error of F"),
              (axes[0, 1], "rowsum_max_abs", "max |row sum - 1| (mean over seeds)"),
              (axes[1, 0], "image_rmse_rel", "image RMSE / mean radiance")]
    for ax, key, label in panels:
        for bi, b in enumerate(backends):
            for est in ESTIMATORS:
                sel = [r for r in rows if r["estimator"] == est and r["sweep"] == "K" and b in r["time"] and key in r]
                pts = [(r["time"][b]["compute_s"], r[key], r["K"]) for r in sel]
                if pts:
                    m, c = STYLE[est]
                    ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker=m, color=c, ls=LINES[bi],
                              label=f"{est} ({b})")
                    partial = [(p[0], p[1]) for p, r in zip(pts, sel) if key.startswith("image") and r.get("image_note")]
                    if partial:
                        ax.plot(*zip(*partial), marker=m, ls="", ms=11, mfc="none", mec="k")
                    if bi == 0:
                        for p in pts:
                            ax.annotate(str(p[2]), (p[0], p[1]), fontsize=6, xytext=(3, 3),
                                        textcoords="offset points")
        if key == "frob_rel":
            ax.axhline(ref["error_of_mean"], color="grey", ls="-.", lw=1, label="reference's own error")
        ax.set_xlabel("compute time per run (s)")
        ax.set_ylabel(label)
        ax.set_title(f"{label}, R = K/16 (labels: K)", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    if have_img:
        axes[1, 0].text(0.02, 0.02, "circled: some seeds refused by solve or unconverged (mean of the rest)",
                        fontsize=7, transform=axes[1, 0].transAxes)
    else:
        axes[1, 0].text(0.5, 0.5, "image leg not rendered in this run", ha="center", va="center",
                        transform=axes[1, 0].transAxes)
    ax = axes[1, 1]
    ks = sorted({r["K"] for r in rows if r["sweep"] == "R" or r["K"] == PAPER_K})
    sweep_k = PAPER_K if PAPER_K in ks else (ks[0] if ks else None)
    rs = sorted({r["R"] for r in rows if r["K"] == sweep_k})
    for est in ESTIMATORS:
        pts = sorted([(r["R"], r["frob_rel"], r.get("image_rmse_rel")) for r in rows
                      if r["estimator"] == est and r["K"] == sweep_k], key=lambda p: p[0])
        if pts:
            m, c = STYLE[est]
            x = [rs.index(p[0]) for p in pts]
            ax.semilogy(x, [p[1] for p in pts], marker=m, color=c, label=f"{est}: matrix")
            img = [(xi, p[2]) for xi, p in zip(x, pts) if p[2] is not None]
            if img:
                ax.semilogy(*zip(*img), marker=m, color=c, ls="--", label=f"{est}: image")
    ax.set_xticks(range(len(rs)))
    ax.set_xticklabels([str(r) for r in rs])
    ax.set_xlabel(f"shadow rays R per pair (K = {sweep_k})")
    ax.set_ylabel("relative error")
    ax.set_title("shadow rays at fixed K (solid: Frobenius of F; dashed: image RMSE / mean)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.suptitle(f"cornell_sphere, N = {n}: error against compute time ({backends[0]} timings solid)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# -------------------------------------------------------------- markdown ---

def fmt_ms(s):
    ms = s * 1e3
    if ms < 0.001:
        return "< 0.001"   # --stats has 1 microsecond resolution
    return f"{ms:.3f}" if ms < 1 else f"{ms:.2f}" if ms < 10 else f"{ms:.1f}" if ms < 100 else f"{ms:.0f}"


def provenance(meta, what="this table"):
    return (f"*{what}: `{meta['command']}` on {machine_line(meta['machine'])}, {meta['date']}"
            + (f", commit {meta['commit']}" if meta.get("commit") else "") + ".*")


def closed_table(rows, backends):
    head = "| case | estimator | K |" + "".join(f" {b} compute (ms) | {b} total (ms) |" for b in backends)
    head += " RMS error |"
    lines = [head, "|" + "---|" * (4 + 2 * len(backends))]
    for r in rows:
        cells = "".join((f" {fmt_ms(r['time'][b]['compute_s'])} | {fmt_ms(r['time'][b]['total_s'])} |"
                         if b in r["time"] else " | |") for b in backends)
        lines.append(f"| {r['case']} | {r['estimator']} | {r['K']} |{cells} {r['rms_error']:.2e} |")
    return lines


def sphere_table(rows, backends, sweep):
    head = "| estimator | K | R |" + "".join(f" {b} compute (ms) | {b} total (ms) |" for b in backends)
    head += " rel. Frobenius error | max \\|row sum - 1\\| | image RMSE | image RMSE / mean |"
    lines = [head, "|" + "---|" * (7 + 2 * len(backends))]
    for r in sorted(rows, key=lambda r: (ESTIMATORS.index(r["estimator"]), r["K"], r["R"])):
        if (sweep == "K" and r["sweep"] != "K") or (sweep == "R" and r["K"] != PAPER_K):
            continue
        cells = "".join((f" {fmt_ms(r['time'][b]['compute_s'])} | {fmt_ms(r['time'][b]['total_s'])} |"
                         if b in r["time"] else " | |") for b in backends)
        img = f" {r['image_rmse']:.2e} | {r['image_rmse_rel']:.2e} |" if "image_rmse" in r else " - | - |"
        if r.get("image_note"):
            img = img[:-1] + f"({r['image_note']}) |"
        paper = " **(paper)**" if (r["K"], r["R"]) == (PAPER_K, PAPER_R) else ""
        lines.append(f"| {r['estimator']} | {r['K']} | {r['R']}{paper} |{cells} {r['frob_rel']:.2e} | "
                     f"{r['rowsum_max_abs']:.2e} |{img}")
    return lines


def facts(res):
    """Numbers the recommendation rests on, computed from whatever run produced res."""
    rows, b = res["sphere_rows"], res["meta"]["backends"][0]
    out = []
    by = {(r["estimator"], r["K"], r["R"]): r for r in rows}

    def image(r):
        s = f"{r['image_rmse_rel'] * 100:.2g} %" if "image_rmse_rel" in r else "-"
        return s + (f" ({r['image_note']})" if r.get("image_note") else "")

    def desc(r):
        s = (f"F off by {r['frob_rel'] * 100:.2g} % (Frobenius), worst row sum off by "
             f"{r['rowsum_max_abs'] * 100:.2g} %")
        if res["images"]["status"] == "rendered":
            s += f", image RMSE / mean {image(r)}"
        return s + f", {fmt_ms(r['time'][b]['compute_s'])} ms ({b})"
    for est in ESTIMATORS:
        r = by.get((est, PAPER_K, PAPER_R))
        if r:
            out.append(f"- paper's setting, `{est}`: {desc(r)}")
    for est in ESTIMATORS:
        sw = sorted([r for r in rows if r["estimator"] == est and r["K"] == PAPER_K], key=lambda r: r["R"])
        if len(sw) > 1:
            rendered = res["images"]["status"] == "rendered"
            parts = ", ".join(f"R={r['R']}: {r['frob_rel'] * 100:.2g} %" + (f" / {image(r)}" if rendered else "")
                              for r in sw)
            out.append(f"- K = {PAPER_K}, `{est}`, error of F" + (" / image RMSE over mean" if rendered else "")
                       + f" by shadow rays: {parts}")
    kmax = max(r["K"] for r in rows if r["sweep"] == "K")
    for est in ESTIMATORS:
        r = by.get((est, kmax, max(1, kmax // 16)))
        if r:
            out.append(f"- largest K ({kmax}, R = {r['R']}), `{est}`: {desc(r)}")
    out.append(f"- the reference's own estimated error: {res['reference']['error_of_mean']:.1e} (Frobenius, "
               "relative); errors near it are not resolved")
    return out


# The recommendation below was written from the full run of 2026-11-22
# (H200 machine, 16 cores, --backend cpu,cuda --threads 16, cornell_sphere
# --subdiv 2, N = 736, reference K = 2^18; images rendered afterwards on the
# 2-core VM with --images-from), after the near-pair shadow-ray fix (d464ced).
# The generated list of numbers above it is recomputed on every run; this
# prose is not, so it says when it was written.
RECOMMENDATION = """\
> Written from the full run of 2026-11-22 (the numbers above); where a later run
> contradicts it, the numbers win and this needs rewriting.

- **Use `auto` (the default) for everything.** At the paper's 512 pairs and 32
  rays it is the most accurate estimator at the same cost: F off by 1.8 %
  (Frobenius), the worst row of a closed scene 6.8 %, the image 1.1 % of the mean
  radiance, for 62 ms on 16 CPU cores or 1 ms of GPU (N = 736). `qmc` at the same
  setting: 7.4 % / 35 % / 2.9 %; `mc`: 16 % / 79 % / 5.3 %. Its error keeps
  falling with K: 0.3 % / 0.7 % / 0.17 % at K = 16384 (1.8 s on 16 cores, 13 ms of
  GPU). Wherever patches touch - every room corner - point pairs sample a 1/r^2
  singularity and their error barely falls with K (closed forms: perpendicular,
  closure; `mc`'s worst row is still 20 % off at K = 16384); `auto` integrates
  those pairs' inner integral in closed form.
- **Ask for accuracy, not samples: `--target-error E`.** Each pair keeps sampling
  (doubling) until the standard error of its entries is below E, so effort goes to
  the pairs that need it (docs/performance.md: at N = 2944, `--samples 64
  --target-error 1e-3` refines 17 k of 4.3 M pairs and costs 6 ms of GPU, less than
  the fixed 512 / 32). The stats report every entry's error (`standard_error`) and
  `--errors FILE` stores them; `test_errors` checks them against the spread over 256
  seeds (ratio 0.94-1.08 for `auto` and far pairs).
- **`qmc`** when you want plain point pairs everywhere (no closed forms): it beats
  `mc` at every K from 256 up at about 1.5-2x its time per sample, but not `auto`.
  Its reported standard error is an upper bound (about 2x the true spread).
- **`mc` only to reproduce the paper** (its estimator, corrected). At the paper's
  setting some cornell_sphere rows sum to more than 1.5 (the 1/r^2 peak between the
  sphere and the wall it nearly touches, and wall corners) and `solve` refuses such
  matrices (one of two seeds at N = 736; `qmc` at K = 64 too). For `mc` at a shared
  edge the variance is infinite and its reported error understates it (0.67 of the
  spread, `test_errors`).
- **Shadow rays at K = 512**: without rays (R = 0) rows behind the sphere count both
  the sphere and the wall behind it, sum to more than 1.5, and `solve` refuses the
  matrix (every estimator). For `auto`, 8 rays give F 2.7 % off, 32 give 1.8 %, 128
  give 1.7 %; the image is 1.1 % off for all of them. Beyond 32 rays the point-pair
  noise dominates: K is the lever, not R.
- **What the paper's 512 pairs / 32 rays buy** (N = 736, `auto`): a matrix 1.8 %
  off whose rows `solve` accepts and an image 1.1 % off, for 62 ms on 16 cores or
  1 ms of GPU. With the paper's own estimator (`mc`) the same budget gives 16 % and
  5.3 %, and a matrix `solve` may refuse.
- History: until d464ced `auto` weighed a near pair's shadow rays by the sample's
  near-field term instead of G, which biased partly occluded near pairs (sphere
  facets beside a wall: F 0.23 instead of 0.65; the first version of this study
  found it, and the reference below was built to be immune to it).
"""


def write_markdown(res, out_dir):
    meta = res["meta"]
    backends = meta["backends"]
    L = ["# What accuracy costs in time", "",
         "Generated by `" + meta["command"] + "` (tools/accuracy_study.py; run it again to regenerate this",
         "file, `accuracy.png`, `accuracy_sphere.png`, and the raw per-run numbers in `accuracy.json` and",
         "`accuracy.csv`).", "",
         f"- machine: {machine_line(meta['machine'])}",
         f"- date: {meta['date']}" + (f"; commit {meta['commit']}" if meta.get("commit") else ""),
         f"- backends: {', '.join(backends)}; CPU threads per run: {meta['threads']}"
         + ("; **--quick** (a smoke-test sweep, not the study)" if meta["quick"] else ""),
         "- time: *compute* is `form_factors + visibility` of `--stats` (median over seeds), *total* is",
         "  `total` (the whole run: setup, compute, GPU copies, writing the file). Errors come from the",
         f"  first backend ({backends[0]})" + (": the backends draw the same samples, and the matrices of the"
                                               " others are checked against it below." if len(backends) > 1 else "."),
         "  On cuda, *total* includes creating the CUDA context (~0.1 s)." if "cuda" in backends else "",
         ""]
    if res.get("closed_rows"):
        p = res["plan"]
        L += ["## Closed forms", "",
              f"{p['closed_seeds_n']} seeds per point ({backends[0]}), no shadow rays (these cases have no "
              "occluder). Error is the", "RMS over seeds of F - exact for the two closed forms, and the RMS over "
              "rows of", "|row sum - 1| for the closed box at `--subdiv 2` (96 patches).", "",
              "The two-patch cases take microseconds (`--stats` resolves 1 us), so their times show only"
              " overhead;", "the closure rows are the ones to read for time."
              + (f" Second backend: timed over the first {p['closed_timing_seeds']} seed(s)."
                 if len(backends) > 1 else ""), "",
              "![error against time, closed forms](accuracy.png)", "", provenance(meta), ""]
        L += closed_table(res["closed_rows"], backends)
        L.append("")
    ref = res["reference"]
    n = ref["patches"]
    L += [f"## The paper's scene: cornell_sphere, N = {n} (`--subdiv {meta['subdiv']}`)", "",
          "Errors against a reference matrix computed once. Matrix error: ||F - F_ref||_F / ||F_ref||_F",
          "(RMS over seeds) and the worst |row sum - 1| (the scene is closed, so every exact row sums to 1;",
          f"mean over seeds). {res['plan']['sphere_seeds_n']} seeds per point. The K sweep uses R = K/16 shadow "
          f"rays (the paper's ratio, 32 of 512); the R sweep holds K = {PAPER_K}.", "",
          "![error against time, cornell_sphere](accuracy_sphere.png)", "",
          "### The reference", "",
          f"K_ref = {ref['samples']} point pairs per pair, on {ref['backend']}, seeds "
          f"{', '.join(map(str, ref['seeds']))}. Not `auto` alone: a reference made with the estimator under",
          "test would hide its own bias (as `auto`'s shadow rays on partly occluded near pairs had one until",
          "d464ced, below); not `qmc` alone: point pairs converge slowly where patches touch. Per seed, the reference",
          "is `auto` without shadow rays (near pairs in closed form) times the G-weighted visible fraction",
          "of each pair, taken from `qmc` with K_ref pairs and K_ref shadow rays divided by `qmc` with the",
          "same pairs and no rays (exactly 1 where no ray was blocked); the two seeds are averaged.", "",
          f"- its own error, estimated from the two seeds: **{ref['error_of_mean']:.1e}** relative Frobenius "
          f"(one seed: {ref['error_single_seed']:.1e})",
          f"- its rows: max |row sum - 1| = {ref['rowsum_max_abs']:.1e}, RMS {ref['rowsum_rms']:.1e}; "
          f"reciprocity max |A_i F_ij - A_j F_ji| / max A_i F_ij = {ref['reciprocity']:.1e}",
          f"- {ref['occluded_entries']} of {ref['nonzero_entries']} nonzero entries are partly occluded; "
          f"ignoring occlusion (`auto`, R = 0) is {ref['auto_norays_vs_ref']:.1e} off, and `qmc` with "
          f"K_ref rays alone {ref['qmc_rays_vs_ref']:.1e}",
          f"- cost: {sum(r['compute_s'] for r in ref['runs']):.1f} s compute, "
          f"{sum(r['wall_s'] for r in ref['runs']):.1f} s wall ({len(ref['runs'])} runs)", ""]
    if len(backends) > 1:
        diffs = [r["max_abs_diff_vs_first_backend"] for r in res["sphere_runs"]
                 if "max_abs_diff_vs_first_backend" in r]
        if diffs:
            L += [f"Matrices of {', '.join(backends[1:])} against {backends[0]} (seed {res['plan']['first_seed']},"
                  f" every setting): max |difference| {max(diffs):.1e}.", ""]
    img = res["images"]
    L += ["### Matrix and image error against samples (R = K/16)", "", provenance(meta)]
    if img.get("provenance"):
        L.append(provenance(img["provenance"], "image columns"))
    L.append("")
    L += sphere_table(res["sphere_rows"], backends, "K")
    L += ["", f"### Shadow rays at K = {PAPER_K}", "", provenance(meta)]
    if img.get("provenance"):
        L.append(provenance(img["provenance"], "image columns"))
    L.append("")
    L += sphere_table(res["sphere_rows"], backends, "R")
    L += ["", "### The final image", ""]
    if img["status"] == "rendered":
        L += [f"Each matrix of the tables above (first backend) is solved (`solve {' '.join(SOLVE_ARGS)}`) and "
              "rendered", f"(`render {' '.join(os.path.relpath(a, ROOT) if a == CAMERA else a for a in RENDER_ARGS)}"
              " -o x.exr`: linear half-float EXR,",
              "smooth shading, the scene's camera), and compared with the render of the reference matrix:",
              "RMSE of linear radiance over all pixels and the three channels (RMS over seeds), also divided",
              f"by the reference image's mean ({img['ref_mean']:.4g}). EXR files read with {img['reader']}."
              " Half floats round to 2^-11 relative, so image errors below about 3e-4 of the mean are",
              "rounding. Against time: the compute-time columns (`solve` and `render` take milliseconds and",
              "do not depend on the estimator).", ""]
    else:
        L += [f"Not rendered in this run: {img['status']}.", ""]
    L += ["## Which estimator for which need", "",
          "Numbers from this run (cornell_sphere, first backend):", ""]
    L += facts(res)
    L += ["", RECOMMENDATION.rstrip(), ""]
    with open(os.path.join(out_dir, "accuracy.md"), "w") as f:
        f.write("\n".join(L))


def write_csv(res, out_dir):
    cols = ["part", "backend", "estimator", "samples", "shadow_rays", "seed", "compute_s", "total_s", "wall_s",
            "error", "frob_rel", "rowsum_max_abs", "rowsum_rms", "image_rmse", "image_rmse_rel",
            "solve", "max_abs_diff_vs_first_backend", "patches", "node", "date"]
    with open(os.path.join(out_dir, "accuracy.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in res.get("closed_runs", []) + res["reference"]["runs_csv"] + res["sphere_runs"]:
            w.writerow(dict(r, node=res["meta"]["machine"]["node"], date=res["meta"]["date"]))


def write_outputs(res, out_dir):
    os.makedirs(out_dir, exist_ok=True)
    backends = res["meta"]["backends"]
    if res.get("closed_rows"):
        plot_closed(res["closed_rows"], backends, os.path.join(out_dir, "accuracy.png"))
    plot_sphere(res["sphere_rows"], backends, res["reference"], os.path.join(out_dir, "accuracy_sphere.png"),
                res["reference"]["patches"])
    write_markdown(res, out_dir)
    write_csv(res, out_dir)
    with open(os.path.join(out_dir, "accuracy.json"), "w") as f:
        json.dump(res, f, indent=1)
    log(f"wrote {out_dir}/accuracy.md, " + ("accuracy.png, " if res.get("closed_rows") else "")
        + "accuracy_sphere.png, accuracy.json, accuracy.csv")


# ------------------------------------------------------------------- main ---

def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0], formatter_class=argparse.RawTextHelpFormatter,
                                 epilog="Details: the docstring at the top of tools/accuracy_study.py.")
    ap.add_argument("build", nargs="?", default="build", help="build folder with formfactor, solve, render")
    ap.add_argument("--backend", default="cpu", help="cpu | cuda | cpu,cuda (default cpu)")
    ap.add_argument("--threads", type=int, default=1, help="CPU threads per run (default 1)")
    ap.add_argument("--quick", action="store_true", help="tiny sweep for smoke tests")
    ap.add_argument("--subdiv", type=int, default=None, help="cornell_sphere subdivision (default 2; quick 1)")
    ap.add_argument("--ref-samples", type=int, default=None, help="reference samples per pair")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs"), help="output folder (default docs/)")
    ap.add_argument("--images-from", metavar="DIR", help="finish the image leg of an earlier run in DIR")
    ap.add_argument("--no-closed-forms", action="store_true", help="skip the closed-form leg")
    ap.add_argument("--estimators", default=",".join(ESTIMATORS),
                    help="comma-separated subset of " + ",".join(ESTIMATORS) + " (default: all; a full\n"
                    "cpu,cuda sweep of all four takes ~9 min on the GPU machine, more than one\n"
                    "device call: split it by backend or by estimators)")
    a = ap.parse_args()
    chosen = [e.strip() for e in a.estimators.split(",") if e.strip()]
    if not chosen or any(e not in ESTIMATORS for e in chosen):
        ap.error("--estimators takes a subset of " + ",".join(ESTIMATORS))
    ESTIMATORS[:] = [e for e in ESTIMATORS if e in chosen]  # the sweep's order
    a.backends = [b.strip() for b in a.backend.split(",") if b.strip()]
    if not a.backends or any(b not in ("cpu", "cuda") for b in a.backends) or len(set(a.backends)) != len(a.backends):
        ap.error("--backend takes cpu, cuda or cpu,cuda")
    if a.threads < 1:
        ap.error("--threads must be >= 1")
    a.plan = PLANS["quick" if a.quick else "full"]
    if a.subdiv is None:
        a.subdiv = a.plan["subdiv"]
    a.ref_backend = "cuda" if "cuda" in a.backends else "cpu"
    if a.ref_samples is None:
        a.ref_samples = 8192 if a.quick else (1 << 18 if a.ref_backend == "cuda" else 1 << 15)
    a.build = os.path.abspath(a.build)
    a.out = os.path.abspath(a.out)
    return a


def finish_images(a):
    """--images-from: render the radiosity files an earlier run archived, fill in the image columns."""
    src = os.path.abspath(a.images_from)
    with open(os.path.join(src, "accuracy.json")) as f:
        res = json.load(f)
    runner = Runner(a.build, a.threads, None)
    if not os.access(runner.prog("render"), os.X_OK):
        sys.exit(f"{runner.prog('render')} not found: --images-from needs a build with render (OpenImageIO)")
    with tempfile.TemporaryDirectory() as work:
        runner.work = work
        with tarfile.open(os.path.join(src, "accuracy_radiosity.tar.xz")) as tar:
            tar.extractall(work)
        reader_name, reader = exr_reader()

        def render(rad):
            exr = os.path.join(work, "img.exr")
            runner.render(os.path.join(work, rad), exr)
            return reader(exr)
        ref = render("reference.rad")
        mean = float(ref.mean())
        todo = [r for r in res["sphere_runs"] if r.get("radiosity")]
        for i, r in enumerate(todo, 1):
            img = render(r["radiosity"])
            r["image_rmse"] = float(math.sqrt(np.mean((img - ref) ** 2)))
            r["image_rmse_rel"] = r["image_rmse"] / mean
            log(f"[{i}/{len(todo)}] image {r['radiosity']}: RMSE {r['image_rmse_rel']:.3e} of mean")
    meta = {"command": command_line(), "machine": machine_info(), "commit": git_commit(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
    res["images"] = {"status": "rendered", "reader": reader_name, "ref_mean": mean, "provenance": meta}
    cfgs = [tuple(c) for c in res["plan"]["configs"]]
    res["sphere_rows"] = aggregate_sphere(res["sphere_runs"], res["meta"]["backends"], cfgs)
    write_outputs(res, a.out)
    if os.path.abspath(src) == a.out:
        os.remove(os.path.join(src, "accuracy_radiosity.tar.xz"))


def main():
    a = parse_args()
    if a.images_from:
        finish_images(a)
        return
    for prog in ("formfactor", "solve"):
        if not os.access(os.path.join(a.build, prog), os.X_OK):
            sys.exit(f"{os.path.join(a.build, prog)} not found: build first")
    plan = a.plan
    meta = {"command": command_line(), "machine": machine_info(), "commit": git_commit(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "backends": a.backends, "threads": a.threads, "quick": a.quick, "subdiv": a.subdiv}
    log(f"accuracy study: {meta['command']}")
    log(f"machine: {machine_line(meta['machine'])}")
    res = {"meta": meta}
    with tempfile.TemporaryDirectory(prefix="accuracy-") as work:
        runner = Runner(a.build, a.threads, work)
        if not a.no_closed_forms:
            res["closed_runs"] = closed_forms(runner, plan, a.backends, work)
            res["closed_rows"] = aggregate_closed(res["closed_runs"], a.backends)
        Fref, ref_ff, ref = reference(runner, plan, a, a.ref_backend, work)
        ref["runs_csv"] = [dict(r, part="sphere_reference", backend=ref["backend"]) for r in ref["runs"]]
        res["reference"] = ref
        images = Images(runner, work, ref_ff)
        cfgs = sphere_configs(plan)
        res["sphere_runs"] = sphere_sweep(runner, plan, a, a.backends, Fref, images, work)
        res["sphere_rows"] = aggregate_sphere(res["sphere_runs"], a.backends, cfgs)
        res["plan"] = dict(plan, configs=cfgs, closed_seeds_n=len(plan["closed_seeds"]),
                           sphere_seeds_n=len(plan["sphere_seeds"]), first_seed=plan["sphere_seeds"][0],
                           ref_samples=a.ref_samples)
        os.makedirs(a.out, exist_ok=True)
        if images.can_render:
            res["images"] = {"status": "rendered", "reader": images.reader_name, "ref_mean": images.ref_mean,
                             "oiiotool_cross_check_max_diff": getattr(images, "cross", None)}
        else:
            arch = os.path.join(a.out, "accuracy_radiosity.tar.xz")
            images.archive(arch)
            res["images"] = {"status": f"no render in {a.build} (it needs OpenImageIO); the radiosity files "
                                       "are in accuracy_radiosity.tar.xz: finish with `python3 "
                                       "tools/accuracy_study.py BUILD_WITH_RENDER --images-from DIR --out DIR`"}
            log(f"no render: radiosity files packed into {arch} ({os.path.getsize(arch) / 1e6:.1f} MB)")
    write_outputs(res, a.out)
    log(f"done: {runner.count} formfactor runs")


if __name__ == "__main__":
    main()
