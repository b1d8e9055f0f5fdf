"""scripts/performance_page.py's generated sections: the step's ceiling (scripts/
ceiling.py's ceiling.json), the side by side with MPM3D-F90 and the projection to many
ranks, each put into an existing page in place of the one there, else at its end,
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
    performance_page.write_section("ceiling", str(ceiling), str(page))
    first = page.read_text()
    assert first.startswith("# Performance\n\nbefore\n")
    # x bound: 60 ns over the larger of the memory (10) and scalar (20) bounds
    assert "| stress | 60.0 | 400 | 390 | 10.0 | 20.0 | 7.0 | 3.0 |" in first
    CEILING["shapes"][0]["phases"][0]["ns"] = 40.0
    ceiling.write_text(json.dumps(CEILING))
    page.write_text(first + "after\n")
    performance_page.write_section("ceiling", str(ceiling), str(page))
    second = page.read_text()
    assert second.count(performance_page.start_marker("ceiling")) == 1
    assert "| stress | 40.0 |" in second and "| stress | 60.0 |" not in second
    assert second.startswith("# Performance\n\nbefore\n") and second.endswith("after\n")


def test_a_page_rewritten_without_a_ceiling_json_keeps_its_ceiling(tmp_path):
    """bench.py --page on a checkout whose results/ holds no ceiling.json (a fresh
    clone) rewrote the page without the measured ceiling; the page's own section is now
    kept as it was."""
    ceiling, page = tmp_path / "ceiling.json", tmp_path / "performance.md"
    ceiling.write_text(json.dumps(CEILING))
    page.write_text("# Performance\n\nbefore\n")
    performance_page.write_section("ceiling", str(ceiling), str(page))
    kept = performance_page.kept_section("ceiling", str(page))
    assert kept[0] == "" and kept[1] == performance_page.start_marker("ceiling")
    assert kept[-1] == performance_page.end_marker("ceiling")
    assert any(line.startswith("| stress | ") for line in kept)
    assert performance_page.kept_section("ceiling", str(tmp_path / "none.md")) == []
    page.write_text("# Performance\n")
    assert performance_page.kept_section("ceiling", str(page)) == []


PEER_ROW = {"n_particles": 21172, "n_steps": 634, "wall_s": 4.0, "step_s": 3.0,
            "particle_steps_per_s": 4.5e6, "L": 16.1, "D": 12.9, "D_widest": 13.1,
            "energy_error": 0.002}
PEER = {"cell": 0.76, "t_end": 0.08, "repeat": 3, "commit": "abc1234", "date": "2026-12-06",
        "rows": [dict(PEER_ROW, variant=name) for name in
                 ("pmpm gimp (default)", "pmpm linear", "F90 hats (default)", "F90 GIMP")],
        "ratios": {"time_f90_default_over_pmpm_default": 0.93,
                   "step_loop_f90_default_over_pmpm_default": 1.05,
                   "rate_pmpm_default_over_f90_default": 1.1,
                   "rate_pmpm_default_over_f90_gimp": 2.8}}
SCALING = {"label": "Taylor bar, 0.19 mm", "shape": "gimp", "commit": "abc1234", "date": "2026-12-06",
           "agree": {"2": 1e-15, "4": 3e-15}, "largest_ranks": 44,
           "projection": {"16": {"axis": "z", "imbalance": 1.075, "efficiency": 0.93},
                          "64": None, "256": None},
           "check": {"modelled": 0.98, "measured": 0.91}}


def test_the_side_by_side_and_the_projection_go_in_their_own_sections(tmp_path):
    peer, page = tmp_path / "peer.json", tmp_path / "performance.md"
    peer.write_text(json.dumps(PEER))
    folder = tmp_path / "scaling"
    folder.mkdir()
    (folder / "scaling_taylor_gimp.json").write_text(json.dumps(SCALING))
    page.write_text("# Performance\n\nbefore\n")
    performance_page.write_section("peer", str(peer), str(page))
    performance_page.write_section("scaling", str(folder), str(page))
    text = page.read_text()
    assert text.startswith("# Performance\n\nbefore\n")
    assert "| pmpm gimp (default) | 21172 | 634 | 4.0 | 3.0 | 4.50 |" in text
    assert "F90 default / pmpm default, whole process: 0.93" in text
    assert "| Taylor bar, 0.19 mm, gimp | `abc1234`, 2026-12-06 | 3e-15 | 93.0 % (z, imbalance " \
           "1.07) | not possible | not possible | 44 ranks | 98.0 % / 91.0 % |" in text
    SCALING["projection"]["16"]["efficiency"] = 0.5
    (folder / "scaling_taylor_gimp.json").write_text(json.dumps(SCALING))
    performance_page.write_section("scaling", str(folder), str(page))
    again = page.read_text()
    assert again.count(performance_page.start_marker("scaling")) == 1
    assert "50.0 % (z" in again and "93.0 % (z" not in again
    assert again.count(performance_page.start_marker("peer")) == 1
    kept = performance_page.kept_section("peer", str(page))
    assert kept[1] == performance_page.start_marker("peer")


def test_the_readmes_paragraph_names_both_codes_and_the_projection():
    scaling = dict(SCALING, projection={"16": {"axis": "z", "imbalance": 1.075,
                                               "efficiency": 0.93}})
    lines = performance_page.readme_summary([PEER], [scaling])
    assert lines[0] == performance_page.SUMMARY_START
    assert lines[-1] == performance_page.SUMMARY_END
    text = " ".join(lines)
    assert "at 0.76 mm to 0.08 ms pmpm 4.0 s in 634 steps against 4.0 s in 634" in text
    assert "Taylor bar, 0.19 mm, gimp: 93 %" in text


def test_a_section_whose_marker_names_another_file_is_replaced_not_added(tmp_path):
    peer, page = tmp_path / "peer.json", tmp_path / "performance.md"
    peer.write_text(json.dumps(PEER))
    old = performance_page.start_marker("peer").replace("peer_side_by_side", "peer.json")
    page.write_text(f"# Performance\n\n{old}\nstale\n{performance_page.end_marker('peer')}\n")
    performance_page.write_section("peer", str(peer), str(page))
    text = page.read_text()
    assert "stale" not in text and text.count("## Side by side with MPM3D-F90") == 1
