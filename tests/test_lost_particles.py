"""Particles leaving the grid box (issue 17): they are dropped and counted per body in
the progress lines and summary.json, and a body losing more than grid.lost_mass_fraction
of its mass stops the run (exit 1, one message from every rank count)."""
import json
import re

import pytest

from clihelp import BAR, pmpm, pmpm_lines, run_ok

RUNAWAY = ["--set", "gravity=[0, 0, -1e12]"]        # every particle out within a step
FREE_FLOOR = ["--set", "grid.boundary.z-=free"]      # the bar's first layer flies out
BAR_MASS = 624 * 8.93e-3 * 0.5 ** 3                  # particles x density x volume
FIRST_LAYER = 52                                     # of 624 particles: 8.33 % of the mass


def summary(out):
    with open(out / "summary.json", encoding="utf-8") as f:
        return json.load(f)


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_runaway_load_is_a_fault_naming_the_body(tmp_path, ranks):
    done = pmpm([BAR, "--out", tmp_path / "out", "--quiet", *RUNAWAY], ranks)
    assert done.returncode == 1, done.stderr
    assert pmpm_lines(done.stderr) == [
        "pmpm: run stopped: step 1 (t = 0 to 0.00010671): 624 particles of body 'bar' "
        "(100 % of its mass) have left the grid box, more than grid.lost_mass_fraction = 0 "
        "allows (raise it if bodies may leave the grid); no checkpoint written"]
    assert "Traceback" not in done.stderr


def test_losses_within_the_allowance_are_reported(tmp_path):
    out = tmp_path / "out"
    done = run_ok([BAR, "--out", out, *FREE_FLOOR, "--set", "grid.lost_mass_fraction=0.1"])
    progress = [line for line in done.stdout.splitlines() if line.startswith("step")]
    assert "lost" not in progress[0]
    assert progress[-1].endswith(f"lost {FIRST_LAYER}"), progress[-1]
    s = summary(out)
    bar = s["bodies"]["bar"]
    assert s["particles_lost"] == bar["lost_particles"] == FIRST_LAYER
    assert bar["n_particles"] == 624 - FIRST_LAYER
    assert bar["lost_mass"] == pytest.approx(FIRST_LAYER / 624 * BAR_MASS, rel=1e-12)
    assert bar["mass"] + bar["lost_mass"] == pytest.approx(BAR_MASS, rel=1e-12)


def test_losses_beyond_the_allowance_stop_the_run(tmp_path):
    out = tmp_path / "out"
    done = pmpm([BAR, "--out", out, "--quiet", *FREE_FLOOR,
                 "--set", "grid.lost_mass_fraction=0.05"], ranks=2)
    assert done.returncode == 1, done.stderr
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith("pmpm: run stopped: step "), lines
    # the first layer reaches z = 0 in step 24 or 25, some of it one step earlier
    match = re.search(r": (\d+) particles of body 'bar' \(([\d.]+) % of its mass\) have "
                      r"left the grid box, more than grid.lost_mass_fraction = 0.05 allows",
                      lines[0])
    assert match and 5 < float(match.group(2)) <= 8.34, lines[0]
    assert "last checkpoint: " in lines[0]


def test_a_restart_keeps_the_count_and_the_initial_mass(tmp_path):
    out = tmp_path / "out"
    allow = ["--set", "grid.lost_mass_fraction=0.2"]
    run_ok([BAR, "--out", out, "--quiet", *FREE_FLOOR, *allow])
    assert summary(out)["bodies"]["bar"]["lost_particles"] == FIRST_LAYER
    run_ok([BAR, "--out", out, "--quiet", "--restart", *FREE_FLOOR, *allow,
            "--set", "time.end=0.01"])
    bar = summary(out)["bodies"]["bar"]
    assert bar["lost_particles"] >= 2 * FIRST_LAYER   # the second layer followed
    assert summary(out)["particles_lost"] == bar["lost_particles"]
    assert bar["mass"] + bar["lost_mass"] == pytest.approx(BAR_MASS, rel=1e-12)


def test_with_exact_sums_the_lost_mass_is_the_same_bits_on_two_ranks(tmp_path):
    """The lost mass decides the grid.lost_mass_fraction fault; with grid.exact_sums it
    is summed exactly over the ranks, so a cut across the lost layer (x) gives the
    1-rank bits."""
    masses = []
    for ranks in (1, 2):
        out = tmp_path / f"out{ranks}"
        done = pmpm([BAR, "--out", out, "--quiet", *FREE_FLOOR, "--set",
                     "grid.lost_mass_fraction=0.1", "--set", "grid.exact_sums=true",
                     "--set", "decomposition.axis=x"], ranks)
        assert done.returncode == 0, done.stderr
        bar = summary(out)["bodies"]["bar"]
        assert bar["lost_particles"] == FIRST_LAYER
        masses.append(bar["lost_mass"])
    assert masses[0] == masses[1]


def test_a_rank_that_loses_nothing_adds_nothing_to_the_lost_mass(tmp_path):
    """Slabs cut along z: the layer that falls out lies on one rank, the other loses no
    particle in those steps. Its share of the lost mass is then a sum over no points,
    which numpy's bincount gives as int64 even with float weights; summed over the
    ranks with the other's float64 it was garbage (4.6e18 g), which stopped one rank
    and left the other waiting in its next collective."""
    masses = []
    for ranks in (1, 2):
        out = tmp_path / f"out{ranks}"
        done = pmpm([BAR, "--out", out, "--quiet", *FREE_FLOOR, "--set",
                     "grid.lost_mass_fraction=0.1", "--set", "decomposition.axis=z"], ranks)
        assert done.returncode == 0, done.stderr
        bar = summary(out)["bodies"]["bar"]
        assert bar["lost_particles"] == FIRST_LAYER
        masses.append(bar["lost_mass"])
    assert masses[1] == pytest.approx(masses[0], rel=1e-12)
    assert masses[0] == pytest.approx(FIRST_LAYER / 624 * BAR_MASS, rel=1e-12)
