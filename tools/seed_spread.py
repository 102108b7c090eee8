#!/usr/bin/env python3
"""Are the reported standard errors honest? Runs formfactor with S seeds and
compares every entry's spread with the error the run reported for it.

    python3 tools/seed_spread.py FORMFACTOR SCENE.obj [--subdiv S] [--seeds 64]
                                 [--max-beyond-3 0.01] [--max-beyond-6 0] [--json out.json]
                                 [--ff-args "more formfactor options"]

For seed s and entry e (only entries some seed gave a nonzero error, i.e.
the pairs whose visibility was sampled), z = (F_se - m_-s,e) / sqrt(sigma_se^2
+ v_-s,e / (S - 1)), where m_-s,e and v_-s,e are the mean and variance of the
other seeds' values (leave-one-out: the reference does not contain the value
it judges). Exits 1 when more than --max-beyond-3 of all (seed, entry)
values have |z| > 3, or more than --max-beyond-6 (a fraction; 0 = none) have
|z| > 6 (docs/accuracy.md, "Are the errors honest?").
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("formfactor")
    ap.add_argument("scene")
    ap.add_argument("--subdiv", type=int, default=1)
    ap.add_argument("--seeds", type=int, default=64)
    ap.add_argument("--max-beyond-3", type=float, default=0.01)
    ap.add_argument("--max-beyond-6", type=float, default=0.0)
    ap.add_argument("--json")
    ap.add_argument("--ff-args", default="", help="more formfactor options, one string")
    a = ap.parse_args()
    values, errors = [], []
    with tempfile.TemporaryDirectory() as tmp:
        ff, err = os.path.join(tmp, "ff"), os.path.join(tmp, "err")
        for seed in range(1, a.seeds + 1):
            subprocess.run([a.formfactor, a.scene, "--subdiv", str(a.subdiv), "--seed", str(seed), "-q", "-o", ff,
                            "--errors", err] + a.ff_args.split(), check=True)
            _, _, patches, F = read_formfactors(ff)
            values.append(F.astype(np.float64))
            errors.append(read_formfactors(err)[3].astype(np.float64))
    F, E = np.array(values), np.array(errors)
    S = F.shape[0]
    # Entries whose value varies with the seed (F.std() > 0 is not enough:
    # the mean of 64 equal numbers may be an ulp off, and an entry exact to
    # its last bits reports an error of that order).
    sampled = (E > 0).any(axis=0) & (F.max(axis=0) > F.min(axis=0))
    total = F.sum(axis=0)
    rest_mean = (total[None] - F) / (S - 1)
    rest_var = ((F ** 2).sum(axis=0)[None] - F ** 2 - (S - 1) * rest_mean ** 2) / (S - 2)
    # The leave-one-out mean is itself rounded: a few ulps of it are no signal.
    ulps = 8 * np.spacing(np.abs(rest_mean))
    denom = np.sqrt(E ** 2 + np.maximum(rest_var, 0) / (S - 1) + ulps ** 2)
    z = np.where(denom > 0, (F - rest_mean) / np.where(denom > 0, denom, 1), 0.0)[:, sampled]
    count = z.size
    beyond3 = float((np.abs(z) > 3).sum()) / max(count, 1)
    beyond6 = float((np.abs(z) > 6).sum()) / max(count, 1)
    spread = F.std(axis=0, ddof=1)[sampled]
    median_error = np.median(E[:, sampled], axis=0)
    ratio = np.median(median_error / np.where(spread > 0, spread, np.inf)) if count else 0.0
    result = {"scene": a.scene, "subdiv": a.subdiv, "seeds": S, "ff_args": a.ff_args,
              "entries_sampled": int(sampled.sum()), "values": int(count),
              "beyond_3_sigma": beyond3, "beyond_6_sigma": beyond6, "max_abs_z": float(np.abs(z).max()) if count else 0,
              "sd_z": float(z.std()) if count else 0, "median_reported_over_spread": float(ratio)}
    worst = np.argsort(-np.abs(z).max(axis=0))[:5]
    idx = np.flatnonzero(sampled)
    n = F.shape[1]
    result["worst"] = [{"row": int(idx[w] // n), "column": int(idx[w] % n), "max_abs_z": float(np.abs(z[:, w]).max()),
                        "mean": float(F[:, idx[w] // n, idx[w] % n].mean()),
                        "spread": float(F[:, idx[w] // n, idx[w] % n].std(ddof=1)),
                        "median_error": float(np.median(E[:, idx[w] // n, idx[w] % n]))} for w in worst]
    if os.environ.get("SEED_SPREAD_DUMP") and count:
        w = worst[0]
        r, c = idx[w] // n, idx[w] % n
        for k in range(S):
            print(f"seed {k + 1}: F {F[k, r, c]:.6g} error {E[k, r, c]:.3g} z {z[k, w]:.2f}", file=sys.stderr)
    print(json.dumps(result))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)
    ok = beyond3 <= a.max_beyond_3 and beyond6 <= a.max_beyond_6
    if not ok:
        print(f"seed_spread: FAIL: {beyond3:.4%} beyond 3 sigma (max {a.max_beyond_3:.2%}), "
              f"{beyond6:.4%} beyond 6 sigma (max {a.max_beyond_6:.2%})", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
