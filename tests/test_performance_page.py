"""scripts/performance_page.py's section on the step's ceiling (scripts/ceiling.py's
ceiling.json): put into an existing page in place of the one there, else at its end,
without touching the rest of the page."""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "scripts"))
import performance_page  # noqa: E402

PHASE = {"phase": "stress", "ns": 60.0, "bytes": 400.0, "flops": 390.0, "memory_ns": 10.0,
         "scalar_ns": 20.0, "simd_ns": 7.0}
CEILING = {"machine": {"cpu": "test CPU", "copy_GBs": 40.0, "triad_GBs": 41.0,
                       "triad_4MB_GBs": 130.0, "scalar_plain_GFs": 16.0,
                       "scalar_fastmath_GFs": 17.0, "simd_plain_GFs": 50.0,
                       "simd_fastmath_GFs": 48.0},
           "case": {"file": "runs/taylor_bar.yaml", "set": ["params.cell=0.38"]},
           "shapes": [{"shape": "linear", "particles": 100, "nodes": 50, "repeats": 3,
                       "step_ns": 130.0, "step_M_per_s": 7.7, "phases": [PHASE]}]}


def test_the_ceiling_replaces_its_own_section_and_nothing_else(tmp_path):
    ceiling, page = tmp_path / "ceiling.json", tmp_path / "performance.md"
    ceiling.write_text(json.dumps(CEILING))
    page.write_text("# Performance\n\nbefore\n")
    performance_page.write_ceiling(str(ceiling), str(page))
    first = page.read_text()
    assert first.startswith("# Performance\n\nbefore\n")
    # x bound: 60 ns over the larger of the memory (10) and scalar (20) bounds
    assert "| stress | 60.0 | 400 | 390 | 10.0 | 20.0 | 7.0 | 3.0 |" in first
    CEILING["shapes"][0]["phases"][0]["ns"] = 40.0
    ceiling.write_text(json.dumps(CEILING))
    page.write_text(first + "after\n")
    performance_page.write_ceiling(str(ceiling), str(page))
    second = page.read_text()
    assert second.count(performance_page.CEILING_START) == 1
    assert "| stress | 40.0 |" in second and "| stress | 60.0 |" not in second
    assert second.startswith("# Performance\n\nbefore\n") and second.endswith("after\n")


def test_a_page_rewritten_without_a_ceiling_json_keeps_its_ceiling(tmp_path):
    """bench.py --page on a checkout whose results/ holds no ceiling.json (a fresh
    clone) rewrote the page without the measured ceiling; the page's own section is now
    kept as it was."""
    ceiling, page = tmp_path / "ceiling.json", tmp_path / "performance.md"
    ceiling.write_text(json.dumps(CEILING))
    page.write_text("# Performance\n\nbefore\n")
    performance_page.write_ceiling(str(ceiling), str(page))
    kept = performance_page.kept_ceiling(str(page))
    assert kept[0] == "" and kept[1] == performance_page.CEILING_START
    assert kept[-1] == performance_page.CEILING_END
    assert any(line.startswith("| stress | ") for line in kept)
    assert performance_page.kept_ceiling(str(tmp_path / "none.md")) == []
    page.write_text("# Performance\n")
    assert performance_page.kept_ceiling(str(page)) == []
