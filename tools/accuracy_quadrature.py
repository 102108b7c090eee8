#!/usr/bin/env python3
"""What accuracy costs in time, for the quadrature estimator against the
Monte Carlo ones (docs/accuracy.md, "The quadrature estimator").

    python3 tools/accuracy_quadrature.py build/formfactor [--out docs] [--repeats 3]

Unoccluded: two unit squares (parallel at distance 1, C-11; perpendicular
on a shared edge, C-14) and the closed box at --subdiv 3 (rows sum to 1),
against --quad-rtol (quadrature) and --samples (mc, auto). Occluded:
cornell_sphere --subdiv 2, worst and RMS |row sum - 1| against
--shadow-rays. Time: form factors + visibility from --stats (median of
--repeats runs). Writes accuracy_quadrature.json and .png into --out.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ffread import read_formfactors  # noqa: E402

MTL = "newmtl grey\nKd 0.5 0.5 0.5\n"
PARALLEL = "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nv 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 5 6 7 8\n"
PERPENDICULAR = "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nv 0 0 1\nv 1 0 1\nf 1 5 6 2\n"
EXACT = {"C-11 parallel": 0.19982489569838738, "C-14 perpendicular": 0.20004377607540315}


def run(ff, scene, args, tmp, repeats):
    out, stats = os.path.join(tmp, "ff"), os.path.join(tmp, "stats.json")
    times = []
    for _ in range(repeats):
        subprocess.run([ff, scene, "-q", "-o", out, "--stats", stats, "--threads", "2"] + args, check=True)
        t = json.load(open(stats))["time_seconds"]
        times.append(t["form_factors"] + t["visibility"])
    return float(np.median(times)), read_formfactors(out)[3]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("formfactor")
    ap.add_argument("--out", default="docs")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scenes", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes"))
    ap.add_argument("--plot-only", action="store_true", help="redraw the plot from OUT/accuracy_quadrature.json")
    a = ap.parse_args()
    rows = []
    if a.plot_only:
        rows = json.load(open(os.path.join(a.out, "accuracy_quadrature.json")))
        return plot(rows, a.out)
    with tempfile.TemporaryDirectory() as tmp:
        open(os.path.join(tmp, "s.mtl"), "w").write(MTL)
        cases = {}
        for name, text in (("C-11 parallel", PARALLEL), ("C-14 perpendicular", PERPENDICULAR)):
            path = os.path.join(tmp, name.split()[0] + ".obj")
            open(path, "w").write(text)
            cases[name] = path
        cases["closed box N = 384"] = os.path.join(a.scenes, "closed_box.obj")

        def error(name, F):
            if name in EXACT:
                return float(abs(F[0, 1] - EXACT[name]))
            return float(np.abs(F.sum(axis=1) - 1).max())

        for name, scene in cases.items():
            extra = ["--subdiv", "3"] if "box" in name else []
            for rtol in [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]:
                t, F = run(a.formfactor, scene, extra + ["--quad-rtol", str(rtol)], tmp, a.repeats)
                rows.append({"case": name, "estimator": "quadrature", "setting": f"--quad-rtol {rtol:g}",
                             "seconds": t, "error": error(name, F)})
            for est in ("mc", "auto"):
                for k in [512, 4096, 32768]:
                    errs, ts = [], []
                    for seed in (1, 2, 3):
                        t, F = run(a.formfactor, scene, extra + ["--estimator", est, "--samples", str(k),
                                                                 "--seed", str(seed)], tmp, 1)
                        errs.append(error(name, F))
                        ts.append(t)
                    rows.append({"case": name, "estimator": est, "setting": f"--samples {k}",
                                 "seconds": float(np.median(ts)), "error": float(np.mean(errs))})
        sphere = os.path.join(a.scenes, "cornell_sphere.obj")
        occluded = [("quadrature", ["--shadow-rays", str(r)]) for r in (8, 32, 128, 512)]
        occluded += [("quadrature", ["--target-error", str(e)]) for e in (1e-3, 1e-4)]
        occluded += [("mc", ["--estimator", "mc"]), ("auto", ["--estimator", "auto"]),
                     ("mc", ["--estimator", "mc", "--samples", "8192", "--shadow-rays", "512"])]
        for est, args in occluded:
            t, F = run(a.formfactor, sphere, ["--subdiv", "2"] + args, tmp, a.repeats)
            d = F.sum(axis=1) - 1
            rows.append({"case": "cornell_sphere N = 736 (occluded)", "estimator": est, "setting": " ".join(args),
                         "seconds": t, "error": float(np.abs(d).max()), "rms": float(np.sqrt((d ** 2).mean()))})
    json.dump(rows, open(os.path.join(a.out, "accuracy_quadrature.json"), "w"), indent=1)
    for r in rows:
        rms = f" rms {r['rms']:.2e}" if "rms" in r else ""
        print(f"| {r['case']} | {r['estimator']} | {r['setting']} | {r['seconds'] * 1e3:.1f} | {r['error']:.2e}{rms} |")
    return plot(rows, a.out)


def plot(rows, out):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, 4, figsize=(18, 4.2))
        for ax, case in zip(axes, [c for c in dict.fromkeys(r["case"] for r in rows)]):
            for est, style in (("quadrature", "o-"), ("quadrature --target-error", "d:"), ("mc", "s--"), ("auto", "^--")):
                pts = [(r["seconds"], max(r["error"], 1e-17)) for r in rows if r["case"] == case and
                       (r["estimator"] + (" --target-error" if r["setting"].startswith("--target-error") else "")) == est]
                if pts:
                    x, y = zip(*pts)
                    ax.loglog(x, y, style, label=est)
            ax.set_title(case, fontsize=9)
            ax.set_xlabel("form factors + visibility (s, 2 threads)")
            ax.grid(True, which="both", alpha=0.3)
        axes[0].set_ylabel("|F - exact|, or worst |row sum - 1|")
        axes[0].legend()
        fig.tight_layout()
        fig.savefig(os.path.join(out, "accuracy_quadrature.png"), dpi=90)
    except ImportError:
        print("matplotlib missing: no plot (Debian: python3-matplotlib)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
