"""With exact sums (grid.exact_sums) the output columns that are sums over the ranks are
the same bits on 2 ranks as on 1: history.csv (energies, per-body centroid, velocity,
energies), forces.csv (contact pairs, grid faces), the probes (a followed point, a
region's mass-weighted means) and summary.json's sums. Each rank adds its terms
exactly and the ranks' partials are rounded once (pmpm.kernels.exact_sum). Without
exact sums the same runs part (the particles themselves do: tests/test_exact_sums_mpi.py);
before the output was summed exactly, history.csv's ``dissipated`` and forces.csv
parted here too although the particles did not, and so did the loads' work."""
import json
import os
import shutil

import pytest

from clihelp import CASES, ROOT, run_ok

#: two spheres meeting across the x slab plane (grid contact method 2, symmetry faces),
#: in contact from step 20 or so of about 100
HERTZ = (os.path.join(CASES, "hertz.yaml"),
         ["params.ratio=1", "params.R=3", "params.gap=0.1", "decomposition.axis=x",
          "time.end=0.004",
          "output.probes=[{name: tip, body: lower, point: [0, 0, -0.3]}, "
          "{name: cap, body: upper, region: {min: [0, 0, 0], max: [2, 2, 1.5]}}]"])
#: a block bouncing off a grid-coupled FEM plate that spans the slab plane (CFEMP),
#: in contact from step 60 or so of 158
BOUNCE = (os.path.join(CASES, "fem_grid_bounce.yaml"),
          ["params.tilt=0.5", "time.end=0.002", "output.history_every=2",
           "output.probes=[{name: corner, body: block, point: [0.012, 0.006, 0.018]}, "
           "{name: middle, body: plate, region: {min: [0.014, 0, 0.012], "
           "max: [0.026, 0.02, 0.02]}}]"])
#: summary.json's keys that depend on the rank count or the clock
NOT_SUMS = {"ranks", "wall_s", "step_wall_s", "compile_s", "first_step_s", "startup_s",
            "particle_steps_per_s", "particle_steps_per_s_per_rank", "element_steps_per_s",
            "elements_per_rank", "slabs", "memory", "communication"}


def run_both(tmp_path, case, sets):
    outs = []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        args = [case, "--out", out, "--quiet", "--force"]
        for item in sets:
            args += ["--set", item]
        run_ok(args, ranks)
        outs.append(out)
    return outs


def summary_sums(out):
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as handle:
        summary = json.load(handle)
    return {key: value for key, value in summary.items() if key not in NOT_SUMS}


@pytest.mark.parametrize("case, sets, probes", [
    (*HERTZ, ("tip", "cap")), (*BOUNCE, ("corner", "middle"))], ids=["hertz", "bounce"])
def test_output_files_are_the_same_bits_on_two_ranks(tmp_path, case, sets, probes):
    one, two = run_both(tmp_path, case, sets)
    for name in ("history.csv", "forces.csv", *(f"probe_{p}.csv" for p in probes)):
        first, second = ((out / name).read_bytes() for out in (one, two))
        assert first == second, f"{name} differs on 2 ranks from 1"
    assert summary_sums(one) == summary_sums(two)
    forces = (one / "forces.csv").read_text().splitlines()
    last = [float(v) for v in forces[-1].split(",")]
    assert len(forces) > 50 and abs(last[4]) > 0.0     # the bodies press on each other


def test_the_loads_work_is_the_same_bits_on_two_ranks(tmp_path):
    """A traction on the end of an FEM bar whose loaded nodes both slabs hold (cut
    along y): the loads' work over the steps (summary.json's energy balance) is summed
    exactly too; summed per rank it parted in the last bits."""
    case = os.path.join(ROOT, "runs", "fem_wave_bar.yaml")
    sets = ["params.element=1", "params.width=6", "params.length=30", "time.end=0.01",
            "output.times=[]", "grid.exact_sums=true", "decomposition.axis=y"]
    one, two = run_both(tmp_path, case, sets)
    assert (one / "history.csv").read_bytes() == (two / "history.csv").read_bytes()
    assert summary_sums(one) == summary_sums(two)
    assert summary_sums(one)["energy"]["total"] > 0.0   # the traction's work: the only source
    with open(os.path.join(two, "summary.json"), encoding="utf-8") as handle:
        assert json.load(handle)["slabs"]["bounds"] == [0, 3, 6]


def test_a_restart_on_two_ranks_continues_the_exact_sums(tmp_path):
    """A restart keeps the exact sums themselves (the force log's and the loads' bins):
    from a checkpoint between two history rows (step 75 of rows 70 and 77), on 2 ranks,
    the files are those of the uninterrupted 1-rank run to the bit."""
    case, sets = HERTZ
    sets = sets[:-1] + ["output.history_every=7", "output.checkpoint_every=25"]
    args = [case, "--quiet"] + [item for s in sets for item in ("--set", s)]
    whole, cut = tmp_path / "whole", tmp_path / "cut"
    run_ok(args + ["--out", whole])
    shutil.copytree(whole, cut)
    *earlier, last = sorted(cut.glob("checkpoint_*.h5"))
    assert earlier[-1].name == "checkpoint_000075.h5"
    os.remove(last)                                 # the run's last: restart from step 75
    run_ok(args + ["--out", cut, "--restart"], 2)
    for name in ("history.csv", "forces.csv"):
        assert (whole / name).read_bytes() == (cut / name).read_bytes(), name
    assert summary_sums(whole) == summary_sums(cut)
