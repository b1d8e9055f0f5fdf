"""The coarse validation matrix at pmpm's defaults (issue 23): each row of
scripts/matrix.py's CI_ROWS, at the resolution users run, must stay within the
tolerance its validation page states; docs/validation/matrix.md has every row under
every option at both resolutions."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "scripts"))
import matrix  # noqa: E402

from pmpm.case.schema import GRID, TIME  # noqa: E402
from pmpm.case.contact import CONTACT  # noqa: E402


def test_the_matrix_defaults_are_pmpms():
    """The first alternative of every axis is what a case that names nothing gets."""
    assert matrix.AXES["shape"]["gimp"] == [f"grid.shape_functions={GRID['shape_functions'].default}"]
    assert TIME["transfer"].default == "flip" and TIME["scheme"].default == "usf"
    assert list(matrix.AXES["transfer"])[0] == "flip" and list(matrix.AXES["scheme"])[0] == "usf"
    assert CONTACT["gap"].default == "auto" and CONTACT["release"].default == "auto"
    assert matrix.AXES["contact"]["auto"] == ["contact.release=auto", "contact.gap=auto"]
    assert list(matrix.AXES["contact"])[0] == "auto"
    assert matrix.AXES["sums"]["auto"] == [f"grid.exact_sums={GRID['exact_sums'].default}"]
    assert list(matrix.AXES["sums"])[0] == "auto"
    assert list(matrix.AXES["step"].values())[0] == [f"time.cfl={TIME['cfl'].default}"]


@pytest.mark.parametrize("name", matrix.CI_ROWS)
def test_coarse_row_passes_at_the_defaults(tmp_path, name):
    row = matrix.ROW[name]
    (variant, sets), = matrix.variants(row, defaults_only=True)
    record = matrix.run_row(row, "coarse", variant, sets, out_root=str(tmp_path))
    assert record["status"] == "ran", record.get("detail")
    failed = {k: c for k, c in record["cells"].items() if not c["pass"]}
    assert not failed, failed


def test_the_page_is_written_from_the_tracked_records(tmp_path):
    """docs/validation/matrix.md is what write_page makes of docs/validation/matrix.json:
    a sitting that re-runs some rows merges with the tracked records of the others, so
    the committed page cannot silently lose rows it held."""
    page = tmp_path / "matrix.md"
    matrix.write_page(matrix.load(), path=str(page))
    with open(matrix.PAGE, encoding="utf-8") as handle:
        assert page.read_text(encoding="utf-8") == handle.read()


def test_every_row_has_a_record_at_the_defaults():
    """The tracked records hold every row at the defaults at both resolutions, each
    naming the commit it was measured at."""
    records = matrix.load()
    have = {(r["row"], r["level"]) for r in records if r["variant"] == "defaults"}
    want = {(row.name, level) for row in matrix.ROWS for level in row.levels}
    assert want <= have, sorted(want - have)
    assert all("commit" in r for r in records)
