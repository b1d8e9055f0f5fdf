"""``--restart`` against a changed case (issue 17): the checkpoint keeps the case its run
was started with; a restart may change only the end time, the output settings, the
decomposition and the title, refuses anything else with one line per changed key, and
keeps the original case text (with a note of the accepted changes) in particles.h5."""
import os

import h5py
import pytest

from clihelp import (BAR, BAR_HALF_END, assert_same_state, frame, frame_list, pmpm,
                     pmpm_lines, run_ok)
from pmpm.case.compare import (differences, may_change_on_restart, may_change_text,
                               restart_changes)
from pmpm.io import latest_checkpoint, read_checkpoint_case
from pmpm.io.checkpoint import checkpoint_problem


@pytest.fixture(scope="module")
def cut(tmp_path_factory):
    """A run of cli_bar.yaml cut at its half-time frame; tests copy it."""
    out = tmp_path_factory.mktemp("restart_case") / "cut"
    run_ok([BAR, "--out", out, "--quiet", "--set", f"time.end={BAR_HALF_END}"])
    return out


def copy_of(cut, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for name in os.listdir(cut):
        (out / name).write_bytes((cut / name).read_bytes())
    return out


def case_text(out):
    with h5py.File(out / "particles.h5", "r") as f:
        return f["case"][()].decode("utf-8")


def test_differences_name_dotted_paths():
    old = {"materials": {"steel": {"E": 200000.0, "nu": 0.3}}, "bodies": [{"v": [0, 0, 1.0]}],
           "time": {"end": 1.0, "dt_max": None}}
    new = {"materials": {"steel": {"E": 210000.0, "nu": 0.3}},
           "bodies": [{"v": [0, 0, 2.0]}, {"v": [1, 1, 1]}],
           "time": {"end": 2.0, "dt_max": 1e-5}}
    refused, allowed = restart_changes(old, new)
    assert refused == [("materials.steel.E", "200000 -> 210000"),
                       ("bodies[0].v", "[0, 0, 1] -> [0, 0, 2]"),
                       ("bodies[1]", "added ({...})"), ("time.dt_max", "none -> 1e-05")]
    assert allowed == [("time.end", "1 -> 2")]
    assert differences(new, new) == [] and differences({"a": 1}, {"a": 1.0}) == []
    assert [p for p, _, _ in differences({"a": 1, "b": 2}, {"a": 1})] == ["b"]


@pytest.mark.parametrize("path, ok", [
    ("time.end", True), ("output.frames", True), ("output.times", True),
    ("decomposition.axis", True), ("title", True), ("params.cell", True),
    ("time.cfl", False), ("time.endx", False), ("grid.cell", False), ("gravity", False),
    ("outputs.x", False)])
def test_which_keys_may_change(path, ok):
    assert may_change_on_restart(path) is ok


def test_the_checkpoint_keeps_the_case(cut):
    stored = read_checkpoint_case(latest_checkpoint(cut))
    assert stored["case"]["time"]["end"] == BAR_HALF_END
    assert stored["case"]["materials"]["copper"]["density"] == 8.93e-3
    assert stored["text"] == case_text(cut)
    assert stored["text"].rstrip().endswith(f"# --set time.end={BAR_HALF_END}")


def test_a_changed_material_is_refused_and_the_case_text_kept(cut, tmp_path):
    out = copy_of(cut, tmp_path)
    before = case_text(out)
    done = pmpm([BAR, "--out", out, "--restart", "--set", "time.end=0.005",
                 "--set", "materials.copper.density=9e-3"])
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [
        "pmpm: error: materials.copper.density: changed since the checkpoint "
        "(0.00893 -> 0.009); --restart may change only time.end, time.max_steps, "
        "grid.lost_mass_fraction, output.*, decomposition.*, title, units"]
    assert "Traceback" not in done.stderr
    assert case_text(out) == before
    assert sorted(os.listdir(out)) == sorted(os.listdir(cut))


def test_a_finer_cell_is_refused_on_2_ranks_once(cut, tmp_path):
    """The issue's --set params.cell=0.38 corrupted the heap: now one line per key."""
    out = copy_of(cut, tmp_path)
    done = pmpm([BAR, "--out", out, "--restart", "--set", "params.cell=0.5",
                 "--set", "params.v0=150"], ranks=2)
    assert done.returncode == 2, done.stderr
    lines = pmpm_lines(done.stderr)
    assert [line.split(" since")[0] for line in lines] == [
        "pmpm: error: grid.cell: changed", "pmpm: error: bodies[0].velocity: changed"], lines
    assert "(1 -> 0.5)" in lines[0] and "([0, 0, -100] -> [0, 0, -150])" in lines[1]


def test_an_added_body_is_refused(cut, tmp_path):
    out = copy_of(cut, tmp_path)
    with open(BAR, encoding="utf-8") as f:
        text = f.read()
    case = tmp_path / "cli_bar.yaml"
    case.write_text(text.replace("time:\n", "  - {name: cap, material: copper, geometry: "
                                 "{type: box, min: [-1, -1, 8], max: [1, 1, 9]}}\ntime:\n"))
    done = pmpm([case, "--out", out, "--restart", "--set", "time.end=0.005"])
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [
        "pmpm: error: bodies[1]: changed since the checkpoint (added ({...})); --restart "
        f"may change only {may_change_text()}"]


def test_allowed_changes_are_noted_beside_the_original_text(cut, tmp_path):
    out = copy_of(cut, tmp_path)
    before = case_text(out)
    run_ok([BAR, "--out", out, "--quiet", "--restart", "--set", "time.end=0.005",
            "--set", "output.history_every=3", "--set", "params.cell=1.0"])
    after = case_text(out)
    assert after.startswith(before.rstrip("\n"))
    assert after[len(before.rstrip("\n")):] == (
        "\n# --restart from checkpoint_000024.h5: time.end: 0.0025 -> 0.005; "
        "output.history_every: 5 -> 3\n")
    # the next restart compares with the case as continued, and keeps both notes
    assert read_checkpoint_case(latest_checkpoint(out))["text"] == after


# -- a corrupt newest checkpoint -------------------------------------------------------

def truncate(path):
    size = os.path.getsize(path)
    with open(path, "r+b") as f:
        f.truncate(size // 2)


def overwrite_header(path):
    with open(path, "r+b") as f:
        f.write(b"\0" * 4096)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("restart_case") / "full"
    run_ok([BAR, "--out", out, "--quiet"])
    return out


@pytest.mark.parametrize("damage", [truncate, overwrite_header])
def test_a_damaged_newest_checkpoint_falls_back_to_the_one_before(cut, uninterrupted,
                                                                    tmp_path, damage):
    out = copy_of(cut, tmp_path)
    bad = out / "checkpoint_000024.h5"
    assert sorted(n for n in os.listdir(out) if n.startswith("checkpoint_")) == [
        "checkpoint_000020.h5", "checkpoint_000024.h5"]
    damage(bad)
    done = run_ok([BAR, "--out", out, "--quiet", "--restart", "--set", "time.end=0.005"],
                  ranks=2)
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith(
        f"pmpm: warning: --restart: checkpoint '{bad}' cannot be read ("), lines
    assert lines[0].endswith("); trying the one before it")
    assert_same_state(frame(uninterrupted), frame(out), 1e-12)
    assert frame_list(out) == frame_list(uninterrupted)
    assert not bad.exists() or checkpoint_problem(bad) is None  # replaced by the run


def test_no_readable_checkpoint_is_one_error(cut, tmp_path):
    out = copy_of(cut, tmp_path)
    truncate(out / "checkpoint_000024.h5")
    overwrite_header(out / "checkpoint_000020.h5")
    done = pmpm([BAR, "--out", out, "--restart", "--set", "time.end=0.005"], ranks=2)
    assert done.returncode == 2, done.stderr
    lines = [line for line in pmpm_lines(done.stderr) if "error" in line]
    assert len(lines) == 1 and lines[0].startswith(
        f"pmpm: error: --restart: no readable checkpoint in '{out}' "
        "(checkpoint_000024.h5: "), lines
    assert "checkpoint_000020.h5: " in lines[0] and "Traceback" not in done.stderr


def test_checkpoints_are_written_beside_and_renamed(cut):
    """Atomic: a checkpoint goes to a .tmp file that is renamed once complete, and no
    temporary is left behind."""
    names = os.listdir(cut)
    assert not [n for n in names if ".tmp" in n], names
    for name in names:
        if name.startswith("checkpoint_"):
            assert checkpoint_problem(cut / name) is None
