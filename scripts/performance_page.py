"""The performance page: turn results/bench/bench.json (written by scripts/bench.py) into
a Markdown page, docs/performance.md. The page is generated whole; comparisons and
investigations live in the hand-written docs/performance-notes.md, which it links.

Where bench.json holds several repeats of a case on the same number of ranks, each
figure is their median (and the range of the rate is shown); efficiency is the median
rate on N ranks over the median rate on 1 rank.

The page ends with three sections made from their own results (:data:`SECTIONS`): the
step's ceiling (scripts/ceiling.py: each phase's time against its memory and arithmetic
bounds; a ceiling.json beside bench.json), the side by side with MPM3D-F90
(scripts/peer_side_by_side.py) and the projection to many ranks (scripts/scaling.py).
Each sits between markers, so that ``--section NAME`` replaces it alone in an existing
page without measuring the benchmarks again.

Usage: .venv/bin/python scripts/performance_page.py [results/bench/bench.json] [docs/performance.md]
       .venv/bin/python scripts/performance_page.py --section ceiling|peer|scaling [RESULTS] [docs/performance.md]
(or: scripts/bench.py --page-only --page docs/performance.md)
"""
import json
import os
import statistics
import sys
from collections import namedtuple

from _common import ROOT, write_lines

DEFAULT_JSON = os.path.join(ROOT, "results", "bench", "bench.json")
DEFAULT_PAGE = os.path.join(ROOT, "docs", "performance.md")
NOTES = "performance-notes.md"

# What each case of scripts/bench.py measures (the page falls back to the case file and
# its overrides, from bench.json, for a case not listed here).
DESCRIPTIONS = {
    "block_1M": "A 1,000,000-particle block impact: Johnson-Cook with Mie-Grueneisen "
                "pressure and bulk viscosity (`runs/bench_block.yaml`).",
    "taylor_0.38": "The Taylor bar at 0.38 mm cells, first 0.01 ms: Johnson-Cook, seed 000 "
                   "Table 2 (`runs/taylor_bar.yaml`).",
    "taylor_0.38_gimp": "The same Taylor bar with uGIMP shape functions (27 nodes, "
                        "pmpm's default; the seed case names the hats).",
    "taylor_0.38_bspline": "The same Taylor bar with quadratic B-spline shape functions "
                           "(27 nodes).",
    "taylor_tied_R2": "The Taylor bar on a tied interface grid, first 0.02 ms: a 0.38 mm "
                      "window over the bottom 3.8 mm, 0.76 mm above; the particles "
                      "entering the window are split as it runs (43 k -> 62 k).",
    "ball_contact": "The steel ball on the 1 mm plate at 0.66 mm cells, contact method 2, "
                    "first 0.03 ms (`runs/steel_ball_plate.yaml`).",
    "ball_no_contact": "The same ball and plate without contact (standard MPM), the "
                       "baseline of the contact overhead.",
    "perforation_fem_4mm": "Seed 004's oblique perforation, coarse: 4 mm plate elements "
                           "and cells, the 5.7 mm rod, the first 50 us, elements turning "
                           "into particles (`runs/ogive_plate_fem.yaml`); point-steps "
                           "(element- plus particle-steps) in the rate column. 5,544 "
                           "elements leave each step about 3 ms, mostly per-step Python "
                           "and messages: too little work to divide over ranks.",
    "perforation_fem_2mm": "The same perforation at 2 mm plate elements and cells "
                           "(39,381 elements): the case the 2-rank efficiency of issue 24 "
                           "is read from.",
}
# bench.py --small runs the block at params.edge=25: 125,000 particles, not 1,000,000
SMALL_DESCRIPTIONS = {
    "block_1M": "The block impact of `runs/bench_block.yaml` run small (`bench.py --small`, "
                "`params.edge=25`: 125,000 particles, not 1,000,000): Johnson-Cook with "
                "Mie-Grueneisen pressure and bulk viscosity.",
}
# (with, without, what the ratio is): step-time overheads computed from the medians
OVERHEADS = [("ball_contact", "ball_no_contact", "Contact (method 2) on the steel ball"),
             ("taylor_0.38_gimp", "taylor_0.38", "gimp shape functions on the Taylor bar"),
             ("taylor_0.38_bspline", "taylor_0.38", "bspline shape functions on the Taylor bar")]

COLUMNS = ("| ranks | runs | particles | steps | M particle-steps/s per rank | efficiency | "
           "bytes/particle | peak RSS (MB, all ranks) | compile s |")


def load(path):
    """bench.json as a dict with ``results`` (older files are a bare list of results)."""
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    return {"results": data} if isinstance(data, list) else data


def medians(results):
    """One row per (case, ranks), in the order first met: medians over the repeats."""
    groups = {}
    for r in results:
        groups.setdefault((r["case"], r["ranks"]), []).append(r)
    rows = []
    for (case, ranks), runs in groups.items():
        rates = [r["per_rank"] for r in runs]
        rows.append({"case": case, "ranks": ranks, "runs": len(runs),
                     "particles": _median(runs, "particles"), "steps": _median(runs, "steps"),
                     "per_rank": statistics.median(rates), "low": min(rates),
                     "high": max(rates), "bytes_per_particle": _median(runs, "bytes_per_particle"),
                     "peak_rss_mb": _median(runs, "peak_rss_mb"),
                     "compile_s": _median(runs, "compile_s")})
    for row in rows:
        base = next((b for b in rows if b["case"] == row["case"] and b["ranks"] == 1), None)
        row["efficiency"] = row["per_rank"] / base["per_rank"] if base and row["ranks"] > 1 else None
    return rows


def _median(runs, key):
    values = [r[key] for r in runs if r.get(key) is not None]
    return statistics.median(values) if values else None


def page(data, source="results/bench/bench.json"):
    """The Markdown page for ``data`` (as ``load`` returns it), as a list of lines."""
    rows = medians(data["results"])
    lines = header(data, source, max((r["runs"] for r in rows), default=1))
    for case in dict.fromkeys(r["case"] for r in rows):
        lines += case_section(case, [r for r in rows if r["case"] == case], data)
    lines += overhead_section(rows)
    return lines


def header(data, source, repeats):
    command = data.get("command", "python scripts/bench.py")
    made = (f"Measured at commit `{data.get('commit', 'unknown')}` on {data.get('date', 'an unknown date')}"
            f" with `{command}`")
    machine = data.get("machine")
    if machine:
        made += f", on {machine}"
    lines = ["# Performance", "",
             f"<!-- Generated by scripts/performance_page.py from {source}; do not edit by hand: "
             "regenerate with `python scripts/bench.py --page docs/performance.md` "
             "(measures first) or `--page-only` (from an existing bench.json). -->", "",
             made + ".", "",
             "One Numba thread per rank; compile time (Numba's compile or cache load) is kept "
             "apart from the stepping time. *M particle-steps/s per rank*: particles x steps / "
             "stepping wall time / ranks, in millions. *Efficiency*: the rate per rank on N "
             "ranks over the rate on 1 rank. *Bytes/particle*: the peak resident memory the "
             "run adds over the process after compilation, summed over ranks, per particle."]
    if repeats > 1:
        lines += ["", f"Each case ran up to {repeats} times, the repeats interleaved; every "
                  "figure is the median of its runs, and the rate's range follows it in "
                  "brackets."]
    return lines + ["", f"Comparisons, overheads and what was tried: [performance notes]({NOTES})."]


def case_section(case, rows, data):
    small = "params.edge=25" in data.get("cases", {}).get(case, {}).get("set", [])
    text = (SMALL_DESCRIPTIONS.get(case) if small else None) or DESCRIPTIONS.get(case)
    lines = ["", f"## {case}", "", text or _case_line(case, data), "",
             COLUMNS, "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        rate = f"{r['per_rank'] / 1e6:.2f}"
        if r["runs"] > 1:
            rate += f" ({r['low'] / 1e6:.2f}-{r['high'] / 1e6:.2f})"
        lines.append(f"| {r['ranks']} | {r['runs']} | {_int(r['particles'])} | {_int(r['steps'])} | "
                     f"{rate} | {_percent(r['efficiency'])} | {_int(r['bytes_per_particle'])} | "
                     f"{_int(r['peak_rss_mb'])} | {_fixed(r['compile_s'])} |")
    return lines


def overhead_section(rows):
    lines = []
    for with_, without, what in OVERHEADS:
        pairs = [(a, b) for a in rows for b in rows
                 if a["case"] == with_ and b["case"] == without and a["ranks"] == b["ranks"]]
        for a, b in pairs:
            if not lines:
                lines = ["", "## Overheads", "",
                         "Step time per particle-step with the feature over the time without it "
                         "(the same particles; medians where there are repeats), minus one.", "",
                         "| what | ranks | overhead |", "|---|---|---|"]
            overhead = b["per_rank"] / a["per_rank"] - 1
            lines.append(f"| {what} | {a['ranks']} | {'+' if overhead >= 0 else ''}{_percent(overhead)} |")
    return lines


def _case_line(case, data):
    spec = data.get("cases", {}).get(case)
    if not spec:
        return f"Case `{case}` of scripts/bench.py."
    sets = " ".join(f"--set {s}" for s in spec.get("set", []))
    return f"`{spec['file']}` {sets}".rstrip() + "."


def _int(value):
    return "-" if value is None else f"{value:,.0f}"


def _fixed(value):
    return "-" if value is None else f"{value:.1f}"


def _percent(value):
    return "-" if value is None else f"{100 * value:.0f} %"


#: the README's generated performance table sits between these lines
README_START = "<!-- performance table: generated by scripts/performance_page.py -->"
README_END = "<!-- end of the generated performance table -->"
#: the cases the README shows, in order, and how it names them
README_CASES = {"taylor_0.38_gimp": "Taylor bar, 0.38 mm, gimp (the default)",
                "taylor_0.38": "Taylor bar, 0.38 mm, linear (hats)",
                "taylor_0.38_bspline": "Taylor bar, 0.38 mm, bspline",
                "ball_contact": "steel ball on a plate, contact method 2, linear",
                "block_1M": "Johnson-Cook block, linear",
                "fem_block_216k": "the block as FEM hexahedra of 1 mm (element-steps)",
                "perforation_fem_4mm": "seed 004 perforation, 4 mm, elements turning into "
                                       "particles (point-steps)",
                "perforation_fem_2mm": "seed 004 perforation, 2 mm (point-steps)"}


def readme_table(data):
    """The README's performance table: medians of the cases it shows, from ``data``."""
    rows = medians(data["results"])
    lines = [README_START, "",
             f"Measured at commit `{data.get('commit', 'unknown')}` on "
             f"{data.get('date', 'an unknown date')}"
             + (f", on {data['machine']}" if data.get("machine") else "")
             + f" (`{data.get('command', 'python scripts/bench.py')}`; medians of "
             f"interleaved repeats):", "",
             "| case | particles | M particle-steps/s per rank, 1 rank | 2 ranks | efficiency |",
             "|---|---|---|---|---|"]
    for case, name in README_CASES.items():
        one = next((r for r in rows if r["case"] == case and r["ranks"] == 1), None)
        two = next((r for r in rows if r["case"] == case and r["ranks"] == 2), None)
        if one is None:
            continue
        rate2 = "-" if two is None else f"{two['per_rank'] / 1e6:.2f}"
        efficiency = _percent(two["efficiency"]) if two else "-"
        lines.append(f"| {name} | {_int(one['particles'])} | {one['per_rank'] / 1e6:.2f} | "
                     f"{rate2} | {efficiency} |")
    return lines + ["", README_END]


def write_readme_table(json_path, readme_path):
    """Replace the generated table between the README's markers (which must be there)."""
    with open(readme_path, encoding="utf-8") as f:
        text = f.read()
    start, end = text.index(README_START), text.index(README_END) + len(README_END)
    table = "\n".join(readme_table(load(json_path)))
    with open(readme_path, "w", encoding="utf-8") as f:
        f.write(text[:start] + table + text[end:])


#: A generated section of the page: its title (in its markers), the results file it is
#: made from (beside bench.json by default) and the function that turns that file's data
#: and its path into the section's Markdown lines (its heading first). Each sits between
#: its markers, so that ``--section NAME`` replaces it alone in an existing page without
#: measuring the benchmarks again, and a page rewritten from bench.json keeps the
#: sections whose results are not on this machine (a fresh clone has no results/).
Section = namedtuple("Section", "title default render")


def start_marker(name):
    s = SECTIONS[name]
    return f"{marker_head(name)} from {os.path.basename(s.default)} -->"


def marker_head(name):
    """What every start marker of section ``name`` begins with, whatever results file it
    names (the page is found by this, so that a renamed file does not add a second)."""
    return f"<!-- {SECTIONS[name].title}: generated by scripts/performance_page.py"


def end_marker(name):
    return f"<!-- end of {SECTIONS[name].title} -->"


def ceiling_table(data):
    """The machine's rates and, per shape, each phase's time per particle-step against
    its bounds, from scripts/ceiling.py's ``data`` (Markdown lines)."""
    r = data["machine"]
    lines = [f"Machine: {r['cpu']}, one thread. STREAM copy {r['copy_GBs']:.1f} GB/s, triad "
             f"{r['triad_GBs']:.1f} GB/s (256 MB arrays; triad on 4 MB: "
             f"{r['triad_4MB_GBs']:.0f} GB/s). Multiply-adds: scalar "
             f"{r['scalar_plain_GFs']:.1f} GFlop/s ({r['scalar_fastmath_GFs']:.1f} with fastmath), "
             f"SIMD {r['simd_plain_GFs']:.1f} GFlop/s ({r['simd_fastmath_GFs']:.1f} with fastmath).",
             "",
             "Per particle-step: *ns* the phase's CPU time over the particles (median of "
             f"{data['shapes'][0]['repeats']} calls from one state); *bytes* and *flops* "
             "counted from the kernels (scripts/ceiling.py, `COUNTS`); *memory ns* bytes over "
             "the copy bandwidth, *scalar ns* and *SIMD ns* flops over the better scalar and "
             "SIMD rates; *x bound* the time over the larger of the memory and scalar bounds. "
             "*weights* is part of each particle pass (here the stress pass's, with gradients).",
             ""]
    for s in data["shapes"]:
        lines += [f"**{s['shape']}** ({s['particles']:,} particles, {s['nodes']:,} nodes): the "
                  f"whole step {s['step_ns']:.0f} ns of CPU a particle-step "
                  f"({s['step_M_per_s']:.2f} M particle-steps/s).", "",
                  "| phase | ns | bytes | flops | memory ns | scalar ns | SIMD ns | x bound |",
                  "|---|---|---|---|---|---|---|---|"]
        for p in s["phases"]:
            bound = max(p["memory_ns"], p["scalar_ns"])
            lines.append(f"| {p['phase']} | {p['ns']:.1f} | {p['bytes']:.0f} | {p['flops']:.0f} "
                         f"| {p['memory_ns']:.1f} | {p['scalar_ns']:.1f} | {p['simd_ns']:.1f} "
                         f"| {p['ns'] / bound:.1f} |")
        lines.append("")
    return lines


def ceiling_section(data, source):
    """The page's section on the step's ceiling."""
    case = data.get("case", {})
    sets = " ".join(f"--set {s}" for s in case.get("set", []))
    return ["## The step's ceiling", "",
            f"Measured at commit `{data.get('commit', 'unknown')}` on "
            f"{data.get('date', 'an unknown date')} with `{data.get('command', 'python scripts/ceiling.py')}` "
            f"({source}): `{case.get('file', '?')}` {sets}, the hats, then gimp, each phase "
            "called as the step calls it on the state of the running bar; what the figures "
            f"say: [performance notes]({NOTES}), \"The step's ceiling\".", ""] \
        + ceiling_table(data)


def peer_section(sittings, source):
    """The side by side with MPM3D-F90 (scripts/peer_side_by_side.py's jsons, one per
    cell)."""
    from peer_side_by_side import table
    lines = ["## Side by side with MPM3D-F90", "",
             f"`scripts/peer_side_by_side.py` ({source}): the seed group's Fortran code built "
             "with -O3 -march=native, its Taylor input adapted to `runs/taylor_bar.yaml`, each "
             "code at its own defaults (pmpm: gimp, `time.cfl: auto`; MPM3D-F90: the hats, "
             "MUSL, `dtscale` 0.8) and in the other's shapes; one process on one core each. "
             "How it was built and adapted: "
             f"[performance notes]({NOTES}#side-by-side-with-mpm3d-f90-issue-25).", ""]
    for data in sittings:
        lines += [f"Measured at commit `{data.get('commit', 'unknown')}` on "
                  f"{data.get('date', 'an unknown date')} with "
                  f"`{data.get('command', 'python scripts/peer_side_by_side.py')}`:", ""] \
            + table(data) + [""]
    return lines


def scaling_section(runs, source):
    """The projection to many ranks (scripts/scaling.py's jsons, one per case)."""
    lines = ["## Projected to many ranks", "",
             f"`scripts/scaling.py` ({source}): each case run on 1, 2, 4 and 8 ranks "
             "(oversubscribed: the answers and the counted messages, not the times), a "
             "model fitted (cost per particle-step and per step on one rank, counted "
             "messages and bytes per shared plane, the slabs' imbalance from pmpm's own "
             "cutting rule, a stated network: 1.5 us, 12 GB/s) and projected to the "
             "target size. The fixed and per-particle costs are fitted to two short 1-rank "
             "runs on a shared machine, so a projection moves by several points from one "
             "run to the next; the 2-rank check is as noisy. Measured on 16 real cores the "
             "0.19 mm bar ran at 53-54 %: "
             f"[performance notes]({NOTES}#measured-on-16-cores-2026-12-04).", "",
             "| case | commit, date | answers on 2-8 ranks against 1 | 16 ranks | 64 ranks | "
             "256 ranks | slabs admit | 2 ranks: model / measured here |",
             "|---|---|---|---|---|---|---|---|"]
    for data in runs:
        cells = []
        for ranks in ("16", "64", "256"):
            p = data["projection"].get(ranks)
            cells.append("not possible" if p is None else
                         f"{100 * p['efficiency']:.1f} % ({p['axis']}, imbalance "
                         f"{p['imbalance']:.2f})")
        check = data.get("check")
        checked = "-" if not check else (f"{100 * check['modelled']:.1f} % / "
                                         f"{100 * check['measured']:.1f} %")
        lines.append(f"| {data.get('label', '?')}, {data.get('shape', '?')} | "
                     f"`{data.get('commit', 'unknown')}`, "
                     f"{data.get('date', '?')} | {max(data['agree'].values()):.0e} | "
                     + " | ".join(cells) + f" | {data['largest_ranks']} ranks | {checked} |")
    return lines + [""]


def load_jsons(path, prefix):
    """The jsons of folder ``path`` whose names start with ``prefix``, in name order
    (None if there are none), or the one file ``path``."""
    if os.path.isdir(path):
        names = sorted(n for n in os.listdir(path) if n.startswith(prefix)
                       and n.endswith(".json"))
        return [load_json(os.path.join(path, n)) for n in names] or None
    return [load_json(path)]


def load_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


SECTIONS = {
    "ceiling": Section("the step's ceiling",
                       os.path.join(ROOT, "results", "bench", "ceiling.json"),
                       lambda path: ceiling_section(load_json(path), _source(path))),
    "peer": Section("the side by side with MPM3D-F90",
                    os.path.join(ROOT, "results", "peer_side_by_side"),
                    lambda path: peer_section(load_jsons(path, "peer"), _source(path))),
    "scaling": Section("the projection to many ranks",
                       os.path.join(ROOT, "results", "scaling"),
                       lambda path: scaling_section(load_jsons(path, "scaling_"),
                                                    _source(path))),
}


#: the README's lines on the side by side and the projection sit between these lines
SUMMARY_START = "<!-- side by side and projection: generated by scripts/performance_page.py -->"
SUMMARY_END = "<!-- end of the side by side and projection -->"


def readme_summary(sittings, scaling):
    """The README's paragraph on the side by side (``sittings``, its jsons, one per
    cell) and the projection (``scaling``, the scaling jsons), between its markers."""
    compared = []
    for peer in sittings:
        by = {r["variant"]: r for r in peer["rows"]}
        mine, theirs = by["pmpm gimp (default)"], by["F90 hats (default)"]
        compared.append(f"at {peer['cell']} mm to {peer['t_end']} ms pmpm "
                        f"{mine['wall_s']:.1f} s in {mine['n_steps']:.0f} steps against "
                        f"{theirs['wall_s']:.1f} s in {theirs['n_steps']:.0f} (L "
                        f"{mine['L']:.2f} and {theirs['L']:.2f} mm, D {mine['D']:.2f} and "
                        f"{theirs['D']:.2f} mm)")
    projected = "; ".join(f"{d['label'].split(' (')[0]}, {d['shape']}: "
                          f"{100 * d['projection']['16']['efficiency']:.0f} %"
                          for d in scaling if d["projection"].get("16"))
    return [SUMMARY_START, "",
            "Against MPM3D-F90, the seed group's Fortran code, each at its defaults on the "
            f"Taylor bar, whole process on one core each ({sittings[0]['date'][:10]}): "
            + "; ".join(compared) + ". Projected strong-scaling efficiency at 16 ranks "
            f"(`scripts/scaling.py`): {projected}. Both in "
            "[docs/performance.md](docs/performance.md).", "", SUMMARY_END]


def write_readme_summary(readme_path):
    """Replace the README's paragraph between its markers, where the side by side and
    the scaling results are here."""
    peer, folder = SECTIONS["peer"].default, SECTIONS["scaling"].default
    if not (present(peer) and present(folder)):
        return
    with open(readme_path, encoding="utf-8") as f:
        text = f.read()
    start, end = text.index(SUMMARY_START), text.index(SUMMARY_END) + len(SUMMARY_END)
    summary = "\n".join(readme_summary(load_jsons(peer, "peer"),
                                        load_jsons(folder, "scaling_")))
    with open(readme_path, "w", encoding="utf-8") as f:
        f.write(text[:start] + summary + text[end:])


def section_lines(name, path):
    """Section ``name`` made from ``path``, between its markers, after an empty line."""
    return ["", start_marker(name), ""] + SECTIONS[name].render(path) + [end_marker(name)]


def write_section(name, path, page_path):
    """Put section ``name``, made from ``path``, into the page ``page_path``: in place of
    the one already there, else at its end."""
    section = "\n".join(section_lines(name, path)[1:])
    with open(page_path, encoding="utf-8") as f:
        text = f.read()
    start, end = marker_head(name), end_marker(name)
    if start in text:
        text = text[:text.index(start)] + section + text[text.index(end) + len(end):]
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    with open(page_path, "w", encoding="utf-8") as f:
        f.write(text)
    print("wrote", page_path)
    if name != "ceiling" and os.path.abspath(page_path) == os.path.abspath(DEFAULT_PAGE):
        write_readme_summary(os.path.join(ROOT, "README.md"))


def kept_section(name, page_path):
    """Section ``name`` of the page already at ``page_path`` (lines, markers included,
    after an empty line), or none."""
    if not os.path.exists(page_path):
        return []
    with open(page_path, encoding="utf-8") as f:
        text = f.read()
    start, end = marker_head(name), end_marker(name)
    if start not in text or end not in text:
        return []
    return [""] + text[text.index(start):text.index(end) + len(end)].split("\n")


def present(path):
    """Whether a section's results are here (a file, or a folder with jsons)."""
    if os.path.isdir(path):
        return any(n.endswith(".json") for n in os.listdir(path))
    return os.path.exists(path)


def _source(path):
    inside = os.path.abspath(path).startswith(ROOT + os.sep)
    return os.path.relpath(path, ROOT) if inside else os.path.abspath(path)


def write_page(json_path, page_path):
    """Read ``json_path`` and write the page to ``page_path`` (with the ceiling of a
    ceiling.json beside it, the side by side and the projection from their results, or
    the page's own sections where those are not here), and the README's tables."""
    lines = page(load(json_path), _source(json_path))
    for name, spec in SECTIONS.items():
        path = spec.default
        if name == "ceiling":
            path = os.path.join(os.path.dirname(os.path.abspath(json_path)), "ceiling.json")
        lines += section_lines(name, path) if present(path) else kept_section(name, page_path)
    write_lines(page_path, lines)
    readme = os.path.join(ROOT, "README.md")
    if os.path.abspath(page_path) == os.path.abspath(DEFAULT_PAGE):
        write_readme_table(json_path, readme)
        write_readme_summary(readme)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--section"]:
        name = sys.argv[2] if len(sys.argv) > 2 else ""
        if name not in SECTIONS:
            sys.exit(f"performance_page.py: --section: expected one of "
                     f"{', '.join(SECTIONS)}, got {name!r}")
        write_section(name, *(sys.argv[3:5] + [SECTIONS[name].default, DEFAULT_PAGE][
            len(sys.argv[3:5]):]))
    else:
        write_page(*(sys.argv[1:3] + [DEFAULT_JSON, DEFAULT_PAGE][len(sys.argv[1:3]):]))
