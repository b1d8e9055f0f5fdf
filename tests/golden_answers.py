"""Fingerprints of the final state of coarse versions of every case in runs/ (and of the
test cases that exercise windows that follow a body), on 1 and on 2 ranks.

``tests/golden/answers.json`` holds fingerprints made on the code before a change that
must not move any answer (a restructure, a speed-up); ``test_unchanged_answers.py``
checks the code against it bit for bit. Re-write it only on purpose, when a change is
meant to move answers, and say so in the commit:

    .venv/bin/python tests/golden_answers.py --write
"""
import hashlib
import json
import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from runhelp import CASES, ROOT, RUNS, run_pmpm  # noqa: E402

GOLDEN = os.path.join(ROOT, "tests", "golden", "answers.json")

#: name -> (case file, --set overrides): each a few seconds, covering USF and MUSL,
#: contact methods 1 and 2 with and without the separation check, friction, tied
#: windows (fixed and following a body, with splitting), loads and gravity, the hats and
#: gimp.
COARSE = {
    "bench_block": (f"{RUNS}/bench_block.yaml",
                    ["params.edge=10", "params.cell=2", "time.end=0.004"]),
    "ogive_plate": (f"{RUNS}/ogive_plate.yaml",
                    ["params.ppc_rod=1", "params.ppc_plate=1", "time.end=0.006"]),
    "ogive_plate_window": (f"{RUNS}/ogive_plate.yaml",
                           ["params.ppc_rod=1", "params.ppc_plate=1", "params.ratio=2",
                            "time.end=0.003"]),
    "planar_shock": (f"{CASES}/planar_shock.yaml", []),
    "rings": (f"{RUNS}/rings.yaml", ["params.cell=5", "time.end=0.6", "output.times=[]"]),
    "rings_usf_method1": (f"{RUNS}/rings.yaml",
                          ["params.cell=5", "params.method=1", "time.scheme=usf",
                           "time.end=0.6", "output.times=[]"]),
    "sphere_rolling": (f"{RUNS}/sphere_rolling.yaml",
                       ["params.cell=800", "params.radius=1600", "time.end=300"]),
    "steel_ball_plate": (f"{RUNS}/steel_ball_plate.yaml",
                         ["params.cell=2", "params.plate_radius=16",
                          "params.cells_below=8", "time.end=0.03"]),
    "steel_ball_plate_window": (f"{RUNS}/steel_ball_plate.yaml",
                                ["params.cell=2", "params.plate_radius=16",
                                 "params.cells_below=6", "params.ratio=2",
                                 "params.window=8", "params.window_below=4",
                                 "time.end=0.02"]),
    "taylor_bar": (f"{RUNS}/taylor_bar.yaml", ["params.cell=1.52", "params.refined=4.56",
                                              "time.end=0.02"]),
    "taylor_bar_window": (f"{RUNS}/taylor_bar.yaml",
                          ["params.cell=1.52", "params.ratio=2", "params.refined=4.56",
                           "time.end=0.01"]),
    "wave_bar": (f"{RUNS}/wave_bar.yaml",
                 ["params.cell=1", "params.width=2", "time.end=0.01", "output.times=[]"]),
    "wave_bar_window": (f"{RUNS}/wave_bar.yaml",
                        ["params.cell=1", "params.width=2", "params.ratio=2",
                         "time.end=0.01", "output.times=[]"]),
    "window_follow": (f"{CASES}/window_follow.yaml", []),
    # the default 27-node shapes (the cases above name the hats, except planar_shock)
    # at the step its fingerprint was made at (time.cfl auto takes 0.8 here since
    # 2026-12-06)
    "taylor_bar_gimp": (f"{RUNS}/taylor_bar.yaml",
                        ["params.cell=1.52", "params.refined=4.56", "time.end=0.02",
                         "grid.shape_functions=gimp", "time.cfl=0.5"]),
    "rings_gimp": (f"{RUNS}/rings.yaml", ["params.cell=5", "time.end=0.6", "output.times=[]",
                                          "grid.shape_functions=gimp"]),
}

RANKS = (1, 2)


def fingerprint(out_dir):
    """sha256 of the final x, v and stress (rows by particle id), and a few numbers to
    say how far apart two runs are when the hashes differ."""
    from pmpm.post import read_frame
    frame = read_frame(out_dir)
    digest = hashlib.sha256()
    for key in ("id", "x", "v", "stress"):
        digest.update(np.ascontiguousarray(frame[key]).tobytes())
    return {"sha256": digest.hexdigest(), "n": int(len(frame["id"])),
            "time": frame["time"],
            "x_sum": float(frame["x"].sum()), "v_sum": float(frame["v"].sum())}


def run_fingerprint(name, ranks, work_dir):
    case, sets = COARSE[name]
    out = os.path.join(work_dir, f"{name}_{ranks}")
    run_pmpm(case, out, ranks=ranks, sets=sets)
    return fingerprint(out)


def write_all():
    answers = {}
    with tempfile.TemporaryDirectory() as work:
        for name in COARSE:
            answers[name] = {str(r): run_fingerprint(name, r, work) for r in RANKS}
            print(name, answers[name]["1"]["n"], "particles", flush=True)
    os.makedirs(os.path.dirname(GOLDEN), exist_ok=True)
    with open(GOLDEN, "w", encoding="utf-8") as f:
        json.dump(answers, f, indent=1, sort_keys=True)
        f.write("\n")


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit(__doc__)
    write_all()
