"""``python -m pmpm.post RESULTS_DIR`` (issue 26): the quick-look PNGs of a run."""
import os
import subprocess
import sys

import pytest

from clihelp import BAR, ROOT, run_ok


@pytest.fixture(scope="module")
def bar_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bar") / "out"
    run_ok([BAR, "--out", out, "--quiet", "--set",
            "output.probes=[{name: tip, body: bar, point: [0, 0, 0]}]"])
    return out


def post(*args):
    return subprocess.run([sys.executable, "-m", "pmpm.post", *map(str, args)],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)


def is_png(path):
    with open(path, "rb") as f:
        return f.read(8) == b"\x89PNG\r\n\x1a\n" and os.path.getsize(path) > 5000


def test_the_plots_of_a_run_are_written_and_named(bar_run, tmp_path):
    done = post(bar_run, "--out", tmp_path, "--field", "eps_p", "--frame", "0", "--normal", "x")
    assert done.returncode == 0, done.stderr
    written = done.stdout.split()
    assert [os.path.basename(p) for p in written] == [
        "plot_energies.png", "plot_bodies.png", "plot_forces.png", "plot_probes.png",
        "plot_frame_0_eps_p.png"]
    assert all(is_png(p) for p in written)
    default = post(bar_run)
    assert default.returncode == 0, default.stderr
    assert default.stdout.split()[-1] == str(bar_run / "plot_frame_last_auto.png")
    # the plots sit beside the run's files, and --force replaces them with the run's
    run_ok([BAR, "--out", bar_run, "--quiet", "--force", "--set",
            "output.probes=[{name: tip, body: bar, point: [0, 0, 0]}]"])
    assert not list(bar_run.glob("plot_*.png"))


def test_a_folder_without_a_run_or_a_missing_field_exits_2(bar_run, tmp_path):
    done = post(tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip() == (f"pmpm.post: error: {tmp_path}: no history.csv (not a "
                                   f"pmpm run's output directory)")
    done = post(bar_run, "--field", "nope", "--out", tmp_path)
    assert done.returncode == 2 and "no field 'nope' in the frames" in done.stderr
