"""Hostile or malformed case files (issue 17): an alias bomb, collections nested too deep
(in the text, through aliases, in a --set value), a NUL byte and bytes that are not UTF-8
are refused quickly with one line naming the file (exit 2), on 1 and 2 ranks."""
import glob
import os
import subprocess
import sys

import pytest

from clihelp import BAR, ROOT, pmpm, pmpm_lines
from runhelp import RUNS
from pmpm.case import CaseError, load_case
from pmpm.case.yamlio import read_yaml_file

RANKS = [1, 2]
BOMB_MESSAGE = "YAML aliases expand beyond the limit"


def alias_bomb(levels=9):
    """A mapping of ``levels`` anchors, each a list of nine aliases of the one before:
    9**levels nodes when expanded."""
    lines = ["  a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for i in range(1, levels):
        lines.append(f"  a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def bar_with(tmp_path, data, at_line=None):
    """cli_bar.yaml as bytes with ``data`` appended, or inserted as line ``at_line``."""
    with open(BAR, "rb") as f:
        lines = f.read().splitlines(keepends=True)
    lines.insert(len(lines) if at_line is None else at_line - 1, data)
    path = tmp_path / "case.yaml"
    path.write_bytes(b"".join(lines))
    return path


def bomb_case(tmp_path):
    return bar_with(tmp_path, b"junk:\n" + alias_bomb().encode())


def test_alias_bomb_raises_case_error_quickly(tmp_path):
    path = bomb_case(tmp_path)
    code = ("import sys\nfrom pmpm.case import CaseError, load_case\n"
            "try:\n    load_case(sys.argv[1])\nexcept CaseError as err:\n"
            "    print(err)\n")
    done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True,
                          text=True, cwd=ROOT, timeout=20)
    assert done.stdout.splitlines() == [
        f"{path}: YAML aliases expand beyond the limit of 100000 nodes; refusing to load"]


def test_recursive_alias_is_refused(tmp_path):
    path = tmp_path / "loop.yaml"
    path.write_text("a: &a [1, *a]\n", encoding="utf-8")
    with pytest.raises(CaseError, match=BOMB_MESSAGE):
        load_case(path)


def test_a_few_aliases_still_load(tmp_path):
    path = tmp_path / "few.yaml"
    path.write_text(alias_bomb(levels=3), encoding="utf-8")
    data, problems = read_yaml_file(path)
    assert len(data["a2"]) == 9 and data["a2"][0][0] == ["x"] * 9 and not problems


@pytest.mark.parametrize("path", sorted(glob.glob(os.path.join(ROOT, "runs", "*.yaml"))
                                        + glob.glob(os.path.join(ROOT, "tests", "cases",
                                                                 "*.yaml"))),
                         ids=os.path.basename)
def test_shipped_case_files_pass_the_alias_limit(path):
    read_yaml_file(path)


@pytest.mark.parametrize("ranks", RANKS)
def test_alias_bomb_exits_2_with_one_line(tmp_path, ranks):
    path = bomb_case(tmp_path)
    done = pmpm([path, "--out", tmp_path / "out"], ranks=ranks, timeout=30)
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [
        f"pmpm: error: {path}: YAML aliases expand beyond the limit of 100000 nodes; "
        "refusing to load"]
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("ranks", RANKS)
@pytest.mark.parametrize("line, message", [
    (b"# caf\xff\n", "3:6: not UTF-8 text (byte 0xff)"),
    (b"# caf\x00\n", "3:6: NUL byte"),
], ids=["not utf-8", "nul"])
def test_bad_bytes_exit_2_naming_line_and_column(tmp_path, ranks, line, message):
    path = bar_with(tmp_path, line, at_line=3)
    done = pmpm([path, "--out", tmp_path / "out"], ranks=ranks)
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [f"pmpm: error: {path}:{message}"]
    assert "Traceback" not in done.stderr


def test_nul_in_a_value_names_its_column(tmp_path):
    path = tmp_path / "nul.yaml"
    path.write_bytes(b"a: 1\nb: ab\x00c\n")
    with pytest.raises(CaseError, match=r"nul\.yaml:2:6: NUL byte$"):
        load_case(path)


def test_control_character_is_a_syntax_error(tmp_path):
    path = tmp_path / "ctrl.yaml"
    path.write_bytes(b"a: 1\nb: ab\x01c\n")
    with pytest.raises(CaseError, match=r"ctrl\.yaml: YAML syntax error: unacceptable"):
        load_case(path)


# -- deep nesting: PyYAML composes recursively -------------------------------------------

def test_ten_thousand_nested_brackets_exit_2_with_one_line(tmp_path):
    path = bar_with(tmp_path, b"junk: " + b"[" * 10000 + b"]" * 10000 + b"\n")
    done = pmpm([path, "--out", tmp_path / "out"], ranks=2, timeout=30)
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [
        f"pmpm: error: {path}:35:106: YAML collections nested more than 100 deep; "
        "refusing to load"]
    assert "Traceback" not in done.stderr and "RecursionError" not in done.stderr


@pytest.mark.parametrize("text, where", [
    ("a:\n" + "".join("  " * i + "b:\n" for i in range(1, 3000)) + "  " * 3000 + "1\n",
     "101:201"),
    ("a: " + "{b: " * 5000 + "1" + "}" * 5000 + "\n", "1:400"),
    ("- " * 4000 + "1\n", "1:201"),
])
def test_deep_mappings_and_sequences_are_refused(tmp_path, text, where):
    path = tmp_path / "deep.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(CaseError) as err:
        load_case(path)
    assert err.value.problems == [
        f"{path}:{where}: YAML collections nested more than 100 deep; refusing to load"]


def test_aliases_nesting_deep_are_refused(tmp_path):
    """300 anchors, each a list holding the one before: 45,000 nodes expanded (under the
    alias limit) but 300 deep."""
    lines = ["a0: &a0 [1]"] + [f"a{i}: &a{i} [*a{i - 1}]" for i in range(1, 300)]
    path = tmp_path / "chain.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(CaseError) as err:
        load_case(path)
    assert err.value.problems == [
        f"{path}: YAML aliases nest collections more than 100 deep; refusing to load"]


def test_a_deep_set_value_is_refused():
    with pytest.raises(CaseError) as err:
        load_case(BAR, ["params.cell=" + "[" * 2000 + "]" * 2000])
    assert err.value.problems[0].endswith("YAML collections nested more than 100 deep; "
                                          "refusing to load")


def test_fifty_levels_still_load(tmp_path):
    path = bar_with(tmp_path, b"junk: " + b"[" * 50 + b"]" * 50 + b"\n")
    with pytest.raises(CaseError) as err:
        load_case(path)
    assert err.value.problems == [
        "junk: unknown key (allowed: title, params, grid, units, gravity, materials, bodies, loads, "
        "time, output, decomposition, contact)"]


def test_a_cell_whose_volume_overflows_is_refused_naming_the_key(tmp_path):
    """grid.cell = 1e308 (found by the fuzz test): its volume is not a double."""
    done = pmpm([f"{RUNS}/bench_block.yaml", "--out", tmp_path / "o", "--set",
                 "grid.cell=1e308"])
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "grid.cell: 1e+308 is too large" in done.stderr
