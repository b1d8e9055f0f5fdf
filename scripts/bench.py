"""Speed, scaling and memory: particle-steps per second per rank on 1 and 2 ranks on
identical work, parallel efficiency, and peak memory per particle, for

- a 1,000,000-particle Johnson-Cook block impact (runs/bench_block.yaml),
- the Taylor bar at 0.38 mm cells (169,376 particles; first 0.01 ms), with the hats and
  with the 27-node gimp and bspline shape functions,
- the Taylor bar on a tied interface grid (0.38 mm window, 0.76 mm outside; 0.02 ms),
- the steel ball on the 1 mm plate at 0.66 mm with contact method 2 and without (0.03 ms),
- the Johnson-Cook block as 216,000 FEM hexahedra (runs/fem_block.yaml; element-steps,
  reported in the particle-steps column),
- the seed 004 perforation, coarse (runs/ogive_plate_fem.yaml: 4 mm and 2 mm plate
  elements and cells, the 5.7 mm rod, the first 50 us, elements converting into
  particles): point-steps (element-steps plus particle-steps) in that column, each also
  on its own in bench.json.

Writes results/bench/bench.{json,md}; bench.json also records the commit, date, command
and machine. The machine this was written for has 2 cores: more ranks than cores need
--oversubscribe (passed always) and make no sense to time.

--repeat N runs every case N times, the repeats interleaved (all cases once, then all
again), so that each case's runs spread over the same stretch of time; the page gives
medians. --page PATH then writes the performance page (scripts/performance_page.py);
--page-only writes it from an existing bench.json without measuring.

Usage: .venv/bin/python scripts/bench.py [--ranks 1 2] [--small] [--only CASE ...]
                                         [--repeat N] [--page docs/performance.md]
       .venv/bin/python scripts/bench.py --page-only [--page docs/performance.md]
"""
import argparse
import os
import sys

from _common import ROOT, provenance, run_case, save_json, write_lines
import performance_page

CASES = {
    "block_1M": ("runs/bench_block.yaml", []),
    "taylor_0.38": ("runs/taylor_bar.yaml", ["params.cell=0.38", "time.end=0.01",
                                             "output.frames=1"]),
    # the same bar with the 27-node shape functions (issue 14): gimp is pmpm's default,
    # the seed case names the papers' hats
    "taylor_0.38_gimp": ("runs/taylor_bar.yaml", ["params.cell=0.38", "time.end=0.01",
                                                  "output.frames=1",
                                                  "grid.shape_functions=gimp"]),
    "taylor_0.38_bspline": ("runs/taylor_bar.yaml", ["params.cell=0.38", "time.end=0.01",
                                                     "output.frames=1",
                                                     "grid.shape_functions=bspline"]),
    # tied interface grid: 0.38 mm window over the bottom 3.8 mm, 0.76 mm above; the
    # particles entering the window are split as it runs (43 k -> 62 k)
    "taylor_tied_R2": ("runs/taylor_bar.yaml", ["params.ratio=2", "params.refined=3.8",
                                                "time.end=0.02", "output.frames=1"]),
    # FEM bodies (issue 16): the Johnson-Cook block as 60^3 = 216,000 hexahedra of 1 mm
    "fem_block_216k": ("runs/fem_block.yaml", ["params.edge=60", "params.element=1.0",
                                               "output.frames=1"]),
    # an MPM sphere on an FEM plate of 1.6 m elements (8 cells), particle-to-surface
    # contact (ICFEMP, issue 16), the first 0.2 s of runs/sphere_rolling_fem.yaml
    "sphere_fem_R8": ("runs/sphere_rolling_fem.yaml", ["params.R=8", "time.end=200",
                                                      "output.frames=1"]),
    # seed 004 Sec. 4.2 coarse (issue 24 Speed): elements and the particles they become
    "perforation_fem_4mm": ("runs/ogive_plate_fem.yaml", [
        "params.cell=4", "params.plate_element=4", "params.rod_element=5.7",
        "time.end=0.05", "output.frames=1"]),
    # the same at 2 mm (39,381 elements): the 4 mm case's 5,544 elements leave each step
    # about 3 ms, mostly per-step Python and messages, too little work to divide
    "perforation_fem_2mm": ("runs/ogive_plate_fem.yaml", [
        "params.cell=2", "params.plate_element=2", "params.rod_element=5.7",
        "time.end=0.05", "output.frames=1"]),
    # contact overhead (issue 3): the same particles with and without method 2
    "ball_contact": ("runs/steel_ball_plate.yaml", ["params.method=2", "time.end=0.03",
                                                    "output.frames=1"]),
    "ball_no_contact": ("runs/steel_ball_plate.yaml", ["params.method=0", "time.end=0.03",
                                                       "output.frames=1"]),
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--small", action="store_true", help="125k-particle block (quick)")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "bench"))
    parser.add_argument("--only", nargs="+", choices=sorted(CASES), help="these cases only")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each case, interleaved")
    parser.add_argument("--page", metavar="PATH", help="write the performance page here "
                        "(e.g. docs/performance.md)")
    parser.add_argument("--page-only", action="store_true", help="no measuring: write the page "
                        "(default docs/performance.md) from the existing bench.json")
    args = parser.parse_args()
    json_path = os.path.join(args.out, "bench.json")
    if args.page_only and not os.path.exists(json_path):
        parser.error(f"--page-only: no {json_path}; run the benchmarks first")
    if not args.page_only:
        measure_all(args, json_path)
    if args.page or args.page_only:
        performance_page.write_page(json_path, args.page or performance_page.DEFAULT_PAGE)


def measure_all(args, json_path):
    chosen = {name: spec for name, spec in CASES.items() if not args.only or name in args.only}
    cases = {name: {"file": case, "set": list(sets) + (["params.edge=25"] if args.small and
                                                        "block" in name else [])}
             for name, (case, sets) in chosen.items()}
    results = []
    for repeat in range(args.repeat):
        for name, spec in cases.items():
            for ranks in args.ranks:
                out = os.path.join(args.out, f"{name}_{ranks}")
                results.append(dict(measure(name, spec["file"], spec["set"], ranks, out),
                                    repeat=repeat))
    add_efficiency(results)
    save_json(json_path, dict(provenance("bench.py"), cases=cases, results=results))
    write_table(os.path.join(args.out, "bench.md"), results)


def measure(name, case, sets, ranks, out):
    s = run_case(case, out, ranks, sets)
    memory = s.get("memory", {})
    elements = s.get("n_elements", 0) if not s["n_particles"]["initial"] else 0
    element_rate = s.get("element_steps_per_s", 0.0) / ranks
    particle_rate = s["particle_steps_per_s"] / ranks
    # a body of elements alone: element-steps; one that converts: element- plus particle-steps
    per_rank = element_rate + particle_rate if elements else s["particle_steps_per_s_per_rank"]
    return {"case": name, "ranks": ranks,
            "particles": elements or s["n_particles"]["initial"],
            "steps": s["n_steps"], "step_wall_s": s["step_wall_s"], "compile_s": s["compile_s"],
            "per_rank": per_rank, "element_steps_per_rank": element_rate,
            "particle_steps_per_rank": particle_rate,
            # per initial particle or element (summary.json's bytes_per_point)
            "bytes_per_particle": memory.get("bytes_per_point",
                                             memory.get("bytes_per_particle")),
            "peak_rss_mb": memory.get("peak_rss_mb_total")}


def add_efficiency(results):
    for r in results:
        base = next((b for b in results if b["case"] == r["case"] and b["ranks"] == 1
                     and b.get("repeat") == r.get("repeat")), None)
        r["efficiency"] = r["per_rank"] / base["per_rank"] if base else None


def write_table(path, results):
    lines = ["| case | ranks | particles | steps | M particle-steps/s per rank | efficiency | "
             "bytes/particle | peak RSS (MB, all ranks) | compile s |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        eff = f"{100 * r['efficiency']:.0f} %" if r["efficiency"] else "-"
        bpp = f"{r['bytes_per_particle']:.0f}" if r["bytes_per_particle"] else "-"
        rss = f"{r['peak_rss_mb']:.0f}" if r["peak_rss_mb"] else "-"
        lines.append(f"| {r['case']} | {r['ranks']} | {r['particles']} | {r['steps']} | "
                     f"{r['per_rank'] / 1e6:.2f} | {eff} | {bpp} | {rss} | {r['compile_s']:.1f} |")
    write_lines(path, lines, echo=True)


if __name__ == "__main__":
    main()
