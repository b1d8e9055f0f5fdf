"""``--force`` (issue 17): it replaces only the files a pmpm run writes and says which,
refuses an --out holding the case file or anything else, and deletes nothing before every
rank has read its input."""
import os
import shutil

from clihelp import BAR, pmpm, pmpm_lines, run_ok

SHORT = ["--set", "time.end=0.0025"]


def reproducer(tmp_path):
    """The issue's scratch directory: the case file and a user's sub/keep.dat."""
    scratch = tmp_path / "scratch"
    (scratch / "sub").mkdir(parents=True)
    case = scratch / "case.yaml"
    shutil.copy(BAR, case)
    (scratch / "sub" / "keep.dat").write_text("x\n")
    return scratch, case


def assert_untouched(scratch, case):
    assert sorted(os.listdir(scratch)) == ["case.yaml", "sub"]
    assert (scratch / "sub" / "keep.dat").read_text() == "x\n"
    with open(BAR, encoding="utf-8") as f:
        assert case.read_text() == f.read()


def test_force_refuses_out_holding_the_case_file(tmp_path):
    scratch, case = reproducer(tmp_path)
    done = pmpm([case, "--out", scratch, "--force", *SHORT])
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [
        f"pmpm: error: --out: '{scratch}' holds the case file '{case}'; --force replaces "
        "only a run's output files, so choose another --out"]
    assert "Traceback" not in done.stderr
    assert_untouched(scratch, case)


def test_force_refuses_out_holding_the_case_file_on_2_ranks_once(tmp_path):
    scratch, case = reproducer(tmp_path)
    done = pmpm([case, "--out", scratch, "--force", *SHORT], ranks=2)
    assert done.returncode == 2, done.stderr
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith(f"pmpm: error: --out: '{scratch}' holds"), \
        done.stderr
    assert "Traceback" not in done.stderr
    assert_untouched(scratch, case)


def test_force_replaces_a_previous_run_and_says_so(tmp_path):
    out = tmp_path / "out"
    run_ok([BAR, "--out", out, "--quiet", *SHORT])
    before = sorted(os.listdir(out))
    assert "summary.json" in before and any(n.startswith("checkpoint_") for n in before)
    stale = out / "checkpoint_999999.h5"   # a later checkpoint of an older, longer run
    shutil.copy(out / [n for n in before if n.startswith("checkpoint_")][0], stale)
    done = run_ok([BAR, "--out", out, "--force", "--quiet", *SHORT])
    said = [line for line in done.stdout.splitlines() if line.startswith("pmpm: --force:")]
    assert len(said) == 1, done.stdout
    assert said[0].startswith("pmpm: --force: replacing particles.h5, particles.xdmf, "
                              "history.csv, summary.json, forces.csv, checkpoint_")
    assert "checkpoint_999999.h5" in said[0] and said[0].endswith(f" in {out}")
    assert not stale.exists()
    assert sorted(os.listdir(out)) == before


def test_force_refuses_a_foreign_file_and_names_it(tmp_path):
    out = tmp_path / "out"
    run_ok([BAR, "--out", out, "--quiet", *SHORT])
    (out / "notes.txt").write_text("mine\n")
    before = sorted(os.listdir(out))
    done = pmpm([BAR, "--out", out, "--force", *SHORT])
    assert done.returncode == 2, done.stderr
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"pmpm: error: --out: '{out}' holds files that are not a "
                               "pmpm run's output (notes.txt); --force replaces only ")
    assert sorted(os.listdir(out)) == before
    assert (out / "notes.txt").read_text() == "mine\n"


def test_force_names_at_most_three_foreign_entries(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for name in ("a.txt", "b.txt", "c.txt", "d.txt"):
        (out / name).write_text("x\n")
    (out / "summary.json").mkdir()           # a directory is never a run's file
    done = pmpm([BAR, "--out", out, "--force", *SHORT])
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr)[0].startswith(
        f"pmpm: error: --out: '{out}' holds files that are not a pmpm run's output "
        "(a.txt, b.txt, c.txt and 2 more)")
    assert len(os.listdir(out)) == 5
