#!/usr/bin/env python3
"""The --stats files of formfactor and solve are valid JSON (core/rad_json):

  - formfactor on a copy of the Cornell box whose file name needs escaping
    (a quote, a backslash, a tab, a control character, UTF-8), then solve
    on a form-factor file with such a name;
  - both documents parse with Python's json module, strictly: no NaN or
    Infinity literals, no raw control characters, valid UTF-8;
  - the names come back exactly as given, and a few keys the docs promise
    (docs/solve.md, formfactor --help) are there with sensible values;
  - both programs' --help name the option as --stats FILE.json.

    stats_json.py FORMFACTOR SOLVE SCENES_DIR WORKDIR
"""
import json
import os
import shutil
import subprocess
import sys

ff, solve, scenes, work = (os.path.abspath(a) for a in sys.argv[1:5])
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = 0

# A quote, a backslash, a tab, U+0001 and an e-acute (2 bytes of UTF-8).
SCENE = 'we"ird\\na\tme\x01-\u00e9.obj'
FORMFACTORS = 'f"f\\1\x02\u00e9'


def check(ok, message):
    global failures
    print(("ok: " if ok else "FAIL: ") + message)
    failures += not ok


def refuse_constant(name):
    raise ValueError(f"{name} is not JSON")


def load(path):
    """The document at path, parsed strictly; None (and a failure) if it is not JSON."""
    try:
        with open(path, "rb") as f:
            data = f.read()
        return json.loads(data.decode("utf-8"), parse_constant=refuse_constant)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        check(False, f"{path}: {e}")
        return None


def run(cmd):
    result = subprocess.run(cmd, cwd=work, capture_output=True, text=True)
    check(result.returncode == 0, " ".join(repr(c) for c in cmd) + f": exit {result.returncode} {result.stderr}")


for prog in (ff, solve):
    text = subprocess.run([prog, "--help"], capture_output=True, text=True).stdout
    check("--stats FILE.json" in text, f"{os.path.basename(prog)} --help names --stats FILE.json")

shutil.copy(os.path.join(scenes, "cornell_box.obj"), os.path.join(work, SCENE))
shutil.copy(os.path.join(scenes, "cornell_box.mtl"), work)
run([ff, SCENE, "--subdiv", "1", "--samples", "16", "-q", "-o", FORMFACTORS, "--stats", "ff.json"])
run([solve, FORMFACTORS, "-q", "-o", "radiosity", "--stats", "solve.json"])

stats = load(os.path.join(work, "ff.json"))
if stats is not None:
    check(stats.get("program") == "formfactor", "formfactor: program")
    check(stats.get("scene") == SCENE, f"formfactor: scene {stats.get('scene')!r} == {SCENE!r}")
    check(stats.get("output") == FORMFACTORS, f"formfactor: output {stats.get('output')!r}")
    # The built-in box at --subdiv 1: 80 patches, 91 with its floor cut along the blocks (--contacts cut).
    check(stats.get("patches") == 91, f"formfactor: patches {stats.get('patches')} == 91")
    check(stats.get("contacts") == "cut", f"formfactor: contacts {stats.get('contacts')!r} == 'cut'")
    check(stats.get("subdiv_only", 0) is None, "formfactor: subdiv_only is null")
    check(len(stats.get("scene_fingerprint", "")) == 16, "formfactor: a 16-digit fingerprint")
    check(isinstance(stats.get("pairs"), int) and stats["pairs"] > 0, "formfactor: pairs")
    check(isinstance(stats.get("standard_error"), dict) and "worst" in stats["standard_error"],
          "formfactor: standard_error with its worst entry")
    per_rank = stats.get("per_rank", [])
    # One rank's rows: a block [0, 91) on the CPU; streamed blocks from row 0 where a GPU computes them.
    rows_named = (per_rank[0].get("row_range") == [0, 91] or per_rank[0].get("row_blocks", {}).get("first") == 0
                  if len(per_rank) == 1 else False)
    check(len(per_rank) == 1 and per_rank[0].get("rows") == 91 and rows_named and "time_seconds" in per_rank[0],
          "formfactor: per_rank: one rank, its 91 rows from row 0, its times")
    times = stats.get("time_seconds", {})
    check(all(isinstance(times.get(k), float) and times[k] >= 0 for k in ("load", "form_factors", "total")),
          "formfactor: time_seconds")

stats = load(os.path.join(work, "solve.json"))
if stats is not None:
    check(stats.get("input") == FORMFACTORS, f"solve: input {stats.get('input')!r} == {FORMFACTORS!r}")
    check(stats.get("output") == "radiosity", "solve: output")
    check(stats.get("errors", 0) is None, "solve: errors is null")
    check(stats.get("patch_count") == 91 and stats.get("grey") is False, "solve: 91 patches, colour")
    check(stats.get("converged") is True, "solve: converged")
    channels = stats.get("channels", [])
    check([c.get("channel") for c in channels] == ["red", "green", "blue"], "solve: channels red, green, blue")
    check(all(len(c.get("history", [])) == c.get("iterations", -1) + 1 for c in channels),
          "solve: a residual for every iterate")
    check(all(c.get("energy", {}).get("emitted", 0) > 0 for c in channels), "solve: energy balance")

sys.exit(1 if failures else 0)
