"""summary.json ``communication`` (issue 25): what a rank sends per step, counted by the
comm layer. One rank sends no neighbour message; two ranks exchange the shared slab
planes twice a step (mass and momentum, then forces), the same on both ranks, with
bytes equal to the planes' nodes times their columns."""
import json
import os

from clihelp import BAR, run_ok


def communication(out):
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        return json.load(f)["communication"]


def test_neighbour_messages_and_bytes_per_step(tmp_path):
    run_ok([BAR, "--out", tmp_path / "one", "--quiet", "--set", "grid.shape_functions=linear"])
    run_ok([BAR, "--out", tmp_path / "two", "--quiet", "--set", "grid.shape_functions=linear",
            "--set", "decomposition.axis=z"], 2)
    one, two = communication(tmp_path / "one"), communication(tmp_path / "two")
    assert one["neighbour"]["messages_per_step"]["largest"] == 0
    nb = two["neighbour"]
    assert nb["messages_per_step"]["mean"] == nb["messages_per_step"]["largest"] == 2.0
    # linear shapes share one node plane, clipped to the particles' cells: the bar's
    # radius 2 in 1 mm cells fills cells -2..1 in x and y, so nodes -2..2, 5 x 5; sent
    # with 8 nodal columns, then 3 force columns, of 8 bytes
    assert nb["bytes_per_step"]["largest"] == 5 * 5 * (8 + 3) * 8
    assert one["collective"]["messages_per_step"]["mean"] >= 1
