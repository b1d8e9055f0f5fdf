"""The command line of DESIGN.md "The run contract", run as users run it: bad input (exit 2,
one line per problem naming its key, printed once), the output directory rules, and the
files of a successful run, on 1 and 2 ranks."""
import json
import os
import re
import subprocess
import sys

import h5py
import numpy as np
import pytest

from clihelp import BAR, ENV, ROOT, pmpm, pmpm_lines, read_history, run_ok, frame_list

RANKS = [1, 2]
LOAD_NOWHERE = ("loads=[{name: push, body: bar, type: force, value: [0, 0, 1],"
                " region: {min: [5, 5, 5], max: [6, 6, 6]}}]")


def bar_without(tmp_path, line):
    """cli_bar.yaml with one line removed, written into tmp_path."""
    with open(BAR, encoding="utf-8") as f:
        text = f.read()
    assert line in text
    path = tmp_path / "case.yaml"
    path.write_text(text.replace(line + "\n", ""), encoding="utf-8")
    return path


def bad_input_cases(tmp_path):
    """name -> (case file, --set items, the problem lines expected, as regexes)."""
    (tmp_path / "garbage.msh").write_text("not a mesh\n")
    case = tmp_path / "bar.yaml"
    case.write_text(open(BAR, encoding="utf-8").read(), encoding="utf-8")
    return {
        "unknown material": (case, ["bodies.0.material=steel"],
                             [r"bodies\[0\]\.material: unknown material 'steel'"]),
        "missing parameter": (bar_without(tmp_path, "    A: 157.0"), [],
                              [r"materials\.copper\.A: missing"]),
        "body outside grid": (case, ["bodies.0.geometry.base=[0,0,8]"],
                              [r"bodies\[0\]\.geometry: body extends outside the grid"]),
        "missing mesh file": (case, ["bodies.0.geometry={type: mesh, file: nothing.msh}"],
                              [r"bodies\[0\]\.geometry\.file: cannot read 'nothing\.msh'"]),
        "unreadable mesh": (case, ["bodies.0.geometry={type: mesh, file: garbage.msh}"],
                            [r"bodies\[0\]\.geometry\.file: cannot read 'garbage\.msh'"]),
        "bad --set": (case, ["time..end=1"], [r"--set time\.\.end=1: expected KEY=VALUE"]),
        "--set list item": (case, ["bodies.3.name=x"], [r"bodies\[3\]: --set: no item 3"]),
        "unknown key": (case, ["time.endd=1"], [r"time\.endd: unknown key \(did you mean 'end'\?\)"]),
        "empty load region": (case, [LOAD_NOWHERE],
                              [r"loads\[0\]\.region: selects no particle of body 'bar'"]),
        "several at once": (case, ["bodies.0.material=steel", "time.cfl=2", "output.frame=3"],
                            [r"bodies\[0\]\.material: unknown material",
                             r"time\.cfl: ", r"output\.frame: unknown key"]),
    }


#: Problems found at different stages (case loading, --set, geometry fill, load
#: assignment): each must be printed once on 2 ranks too.
ON_TWO_RANKS = ["several at once", "bad --set", "unreadable mesh", "empty load region"]
BAD_INPUT = [(name, 1) for name in [
    "unknown material", "missing parameter", "body outside grid", "missing mesh file",
    "unreadable mesh", "bad --set", "--set list item", "unknown key", "empty load region",
    "several at once"]] + [(name, 2) for name in ON_TWO_RANKS]


@pytest.mark.parametrize("name, ranks", BAD_INPUT)
def test_bad_input_exits_2_with_one_line_per_problem(tmp_path, name, ranks):
    case, sets, expected = bad_input_cases(tmp_path)[name]
    out = tmp_path / "out"
    done = pmpm([case, "--out", out] + [x for item in sets for x in ("--set", item)], ranks)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    lines = pmpm_lines(done.stderr)
    assert len(lines) == len(expected), lines
    for line, pattern in zip(sorted(lines), sorted(expected)):
        assert line.startswith("pmpm: error: "), line
        assert re.search(pattern, line), f"{line!r} !~ {pattern!r}"
    assert done.stdout == ""
    assert not out.exists() or not any(out.iterdir()), "wrote output"


def imported_modules(args):
    """(CompletedProcess, the modules ``python -m pmpm ARGS`` imported)."""
    env = dict(os.environ, **ENV)
    done = subprocess.run([sys.executable, "-X", "importtime", "-m", "pmpm", *map(str, args)],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=60)
    names = {line.split("|")[-1].strip() for line in done.stderr.splitlines()
             if line.startswith("import time:")}
    return done, names


#: a bad input of each stage before MPI: (arguments, the text the error line must hold)
QUICK_EXITS = {
    "help": (["--help"], "usage:"),
    "argument error": (["--bogus", BAR], "--bogus"),
    "invalid case": (["{bad}"], "bad: unknown key"),
    "misspelt key": ([BAR, "--set", "time.endd=1"], "time.endd: unknown key"),
    "unknown material": ([BAR, "--set", "bodies[0].material=coper"],
                         "bodies[0].material: unknown material 'coper'"),
    "yaml syntax error": (["{broken}"], "YAML syntax error"),
}


@pytest.mark.parametrize("kind", list(QUICK_EXITS))
def test_help_and_bad_input_stop_before_mpi_and_numba_load(tmp_path, kind):
    """Issue 25: --help and a bad input answer within 0.5 s. Starting MPI costs about
    0.4 s and importing numba 0.2 s, so neither may happen before the arguments and the
    case have been checked, nor h5py (0.05 s); the error names the key (measured with
    scripts/startup.py: --help 0.04 s of CPU, a misspelt key or an unknown material
    0.13 s, a YAML syntax error 0.12 s, the wall time about twice that at a load of 8 on
    the 2-core machine)."""
    (tmp_path / "bad.yaml").write_text("bad: x\n")
    (tmp_path / "broken.yaml").write_text("title: broken\ngrid: {min: [0, 0, 0]\n")
    args, needle = QUICK_EXITS[kind]
    args = [str(tmp_path / "bad.yaml") if a == "{bad}" else
            str(tmp_path / "broken.yaml") if a == "{broken}" else a for a in args]
    done, names = imported_modules(args)
    assert done.returncode == (0 if kind == "help" else 2), done.stderr[-2000:]
    assert needle in (done.stdout if kind == "help" else done.stderr)
    assert "pmpm.__main__" in names or "pmpm" in names
    assert "mpi4py.MPI" not in names
    assert "numba" not in names
    assert "h5py" not in names
    assert "importlib.metadata" not in names          # --version's only (20-30 ms)


@pytest.mark.parametrize("ranks", RANKS)
def test_command_line_errors_are_printed_once(tmp_path, ranks):
    done = pmpm(["--bogus", BAR], ranks)
    assert done.returncode == 2
    assert done.stderr.count("unrecognized arguments: --bogus") == 1
    done = pmpm([tmp_path / "absent.yaml"], ranks)
    assert done.returncode == 2
    assert pmpm_lines(done.stderr) == [
        f"pmpm: error: {tmp_path / 'absent.yaml'}: cannot read case file: No such file or directory"]


@pytest.mark.parametrize("ranks", RANKS)
def test_existing_output_is_kept_without_force(tmp_path, ranks):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine\n")
    before = os.stat(out / "notes.txt")
    done = pmpm([BAR, "--out", out], ranks)
    assert done.returncode == 2
    assert pmpm_lines(done.stderr) == [
        f"pmpm: error: --out: output directory '{out}' exists and is not empty; "
        "use --force to overwrite it or --restart to continue it"]
    assert sorted(os.listdir(out)) == ["notes.txt"]
    after = os.stat(out / "notes.txt")
    assert (after.st_mtime_ns, after.st_size) == (before.st_mtime_ns, before.st_size)


def test_force_overwrites(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("{}\n")  # a run's file; anything else is refused
    run_ok([BAR, "--out", out, "--force", "--quiet", "--set", "time.end=0.0025"])
    assert (out / "summary.json").read_text() != "{}\n"


def test_output_that_is_a_file_is_refused(tmp_path):
    out = tmp_path / "out"
    out.write_text("a file\n")
    done = pmpm([BAR, "--out", out, "--force"])
    assert done.returncode == 2
    assert pmpm_lines(done.stderr) == [f"pmpm: error: --out: '{out}' exists and is not a directory"]
    assert out.read_text() == "a file\n"


def test_default_output_is_results_stem_in_the_working_directory(tmp_path):
    run_ok([BAR, "--quiet", "--set", "time.end=0.0025"], cwd=tmp_path)
    assert (tmp_path / "results" / "cli_bar" / "summary.json").exists()


def check_summary(summary, ranks):
    assert summary["ranks"] == ranks
    assert summary["n_particles"] == {"initial": 624, "final": 624}
    assert summary["n_steps"] == 48
    assert summary["t_end"] == pytest.approx(0.005, rel=1e-12)
    for key in ("wall_s", "compile_s", "particle_steps_per_s"):
        assert isinstance(summary[key], float) and summary[key] >= 0, key
    startup = summary["startup_s"]      # process start to the first step (issue 25)
    assert 0 < startup["wall_less_queued"] <= startup["wall"]
    assert 0 < startup["cpu"] and 0 <= startup["queued"] <= startup["wall"]
    assert startup["wall"] >= summary["compile_s"] * 0.99   # it holds the kernels' load
    # every step counts (the warm-up compiled the kernels before the first)
    assert summary["particle_steps_per_s"] == pytest.approx(
        624 * 48 / summary["step_wall_s"], rel=1e-12)
    energy = summary["energy"]
    assert set(energy) >= {"kinetic", "internal", "total"}
    assert energy["total"] == pytest.approx(energy["kinetic"] + energy["internal"])
    bar = summary["bodies"]["bar"]
    assert set(bar) >= {"mass", "n_particles", "centroid", "velocity", "bbox_min", "bbox_max"}
    assert bar["n_particles"] == 624
    assert bar["mass"] == pytest.approx(624 * 8.93e-3 * 0.5 ** 3)
    for key in ("centroid", "velocity", "bbox_min", "bbox_max"):
        assert len(bar[key]) == 3, key
    assert all(lo < c < hi for lo, c, hi in zip(bar["bbox_min"], bar["centroid"], bar["bbox_max"]))
    assert bar["velocity"][2] < 0


def check_history(out):
    header, rows = read_history(out)
    assert header == ["step", "time", "dt", "kinetic", "internal", "total", "dissipated",
                      "bar.x", "bar.y", "bar.z", "bar.vx", "bar.vy", "bar.vz",
                      "bar.kinetic", "bar.internal", "bar.plastic", "bar.hourglass"]
    # one body: its energies are the totals
    assert np.allclose(rows[:, 13:15], rows[:, 3:5], rtol=1e-12, atol=0)
    assert np.abs(rows[:, 6]).max() < 1e-9 * rows[0, 3]     # a slip wall dissipates nothing
    steps = rows[:, 0]
    assert steps[0] == 0 and steps[-1] == 48
    assert (steps[1:] > steps[:-1]).all() and (rows[1:, 1] > rows[:-1, 1]).all()
    assert {0, 5, 10, 45, 48} <= set(steps.astype(int))


def check_particles(out):
    frames = frame_list(out)
    assert [t for t, _ in frames] == pytest.approx([0.0, 0.0025, 0.005], rel=1e-12, abs=1e-15)
    assert frames[0][1] == 0 and frames[-1][1] == 48
    with h5py.File(out / "particles.h5", "r") as f:
        assert "case" in f and "run_stats" in f.attrs
        for name in ("000000", "000002"):
            group = f["frames"][name]
            assert group["x"].shape == (624, 3) and group["stress"].shape == (624, 6)
            assert group["stress"].attrs["components"] == "xx,yy,zz,xy,yz,zx"
            for column in ("v", "eps_p", "density", "mass", "body", "id"):
                assert len(group[column]) == 624, column
    xdmf = (out / "particles.xdmf").read_text()
    assert xdmf.count("particles.h5:/frames/") >= 3


def check_progress(stdout):
    """Not on a terminal: a line at each 5 % of the run, ending with 100 %."""
    percents = [float(m) for m in re.findall(r"^step .* (\d+\.\d)%", stdout, re.M)]
    assert percents[-1] == 100.0
    assert len(percents) == 20
    for k, percent in enumerate(percents, start=1):
        assert 5 * k <= percent < 5 * k + 5


@pytest.mark.parametrize("ranks", RANKS)
def test_successful_run_writes_the_contract_files(tmp_path, ranks):
    out = tmp_path / "out"
    done = run_ok([BAR, "--out", out], ranks)
    with open(out / "summary.json", encoding="utf-8") as f:
        check_summary(json.load(f), ranks)
    check_history(out)
    check_particles(out)
    check_progress(done.stdout)
    assert done.stdout.rstrip().endswith(f"pmpm: done; results in {out}")
    assert pmpm_lines(done.stderr) == []


def test_quiet_prints_nothing(tmp_path):
    done = run_ok([BAR, "--out", tmp_path / "out", "--quiet", "--set", "time.end=0.0025"])
    assert done.stdout == ""


def test_output_progress_false_silences_the_progress_lines(tmp_path):
    """The case key output.progress (not only --quiet) turns the progress lines off."""
    done = run_ok([BAR, "--out", tmp_path / "out", "--set", "time.end=0.0025",
                   "--set", "output.progress=false"])
    assert not re.findall(r"^step ", done.stdout, re.M)
    assert done.stdout.rstrip().endswith("results in " + str(tmp_path / "out"))


@pytest.mark.parametrize("ranks", RANKS)
def test_check_validates_and_estimates_without_writing_or_compiling(tmp_path, ranks):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("{}\n")
    done = pmpm([BAR, "--check", "--out", out], ranks)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == f"pmpm: check: {BAR} is valid"
    assert re.match(r"pmpm: 624 particles; about \d+ steps", lines[1]), lines
    assert re.match(r"pmpm: memory about [\d.]+ [kM]B in all on %d rank" % ranks, lines[2])
    assert lines[3] == f"pmpm: output to {out} (not empty: the run needs --force to " \
                       "replace it or --restart to continue)"
    assert sorted(os.listdir(out)) == ["summary.json"]
    assert (out / "summary.json").read_text() == "{}\n"
    bad = pmpm([BAR, "--check", "--set", "time.cfl=2"], ranks)
    assert bad.returncode == 2
    assert pmpm_lines(bad.stderr) == ["pmpm: error: time.cfl: must be <= 1, got 2"]


def test_check_counts_the_elements_and_their_output(tmp_path):
    case = os.path.join(os.path.dirname(BAR), "block_on_fem_plate.yaml")
    done = pmpm([case, "--check", "--out", tmp_path / "out"])
    assert done.returncode == 0, done.stderr
    assert "pmpm: 36 elements in 1 FEM body" in done.stdout.splitlines()
    assert not (tmp_path / "out").exists()


def test_version_names_pmpm_and_its_libraries():
    done = pmpm(["--version"])
    assert done.returncode == 0
    assert re.match(r"pmpm \d+\.\d+\.\d+ \(.*numpy [\d.]+; numba [\d.]+; mpi4py [\d.]+; "
                    r"h5py [\d.]+\)$", done.stdout.strip()), done.stdout


def test_a_run_piped_into_head_finishes_without_a_traceback(tmp_path):
    """`pmpm case.yaml | head -1`: the reader goes away after the first line; the run
    goes on to its end and writes its results, with no BrokenPipeError traceback."""
    import subprocess
    import sys
    from clihelp import ENV, ROOT
    script = (f"{sys.executable} -m pmpm {BAR} --out {tmp_path / 'out'} "
              f"--set output.history_every=1 | head -1; exit ${{PIPESTATUS[0]}}")
    done = subprocess.run(["bash", "-c", script], capture_output=True, text=True, cwd=ROOT,
                          env={**os.environ, **ENV}, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr
    assert done.stdout.startswith("pmpm: 624 particles")
    assert os.path.exists(tmp_path / "out" / "summary.json")
