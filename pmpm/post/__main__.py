"""``python -m pmpm.post RESULTS_DIR [--frame N] [--field NAME] [--normal y] [--out DIR]``:
quick-look PNGs of a run without ParaView (pmpm.post.plots): plot_energies.png,
plot_bodies.png, plot_forces.png (forces.csv), plot_probes.png (output.probes) and
plot_frame_N_FIELD.png, beside the run's files (``--force`` replaces
them with the run's). Exit 2 with one line when RESULTS_DIR holds no run."""
import argparse
import os
import sys


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog="python -m pmpm.post", description="Quick-look plots of a pmpm run (PNG).")
    parser.add_argument("results", help="a run's output directory")
    parser.add_argument("--frame", type=int, default=-1,
                        help="frame index for the frame picture (default: the last)")
    parser.add_argument("--field", default=None,
                        help="frame field to colour by (default: von_mises, else eps_p)")
    parser.add_argument("--normal", choices=("x", "y", "z"), default="y",
                        help="the axis the frame is seen along (default y)")
    parser.add_argument("--out", default=None,
                        help="folder for the PNGs (default: RESULTS itself)")
    return parser.parse_args(argv)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    history = os.path.join(args.results, "history.csv")
    if not os.path.exists(history):
        sys.stderr.write(f"pmpm.post: error: {args.results}: no history.csv (not a pmpm "
                         f"run's output directory)\n")
        return 2
    from . import plots
    out = args.out or args.results
    os.makedirs(out, exist_ok=True)
    written = [plots.plot_energies(args.results, os.path.join(out, "plot_energies.png")),
               plots.plot_bodies(args.results, os.path.join(out, "plot_bodies.png"))]
    if os.path.exists(os.path.join(args.results, "forces.csv")):
        written.append(plots.plot_forces(args.results, os.path.join(out, "plot_forces.png")))
    probes = plots.probe_names(args.results)
    if probes:
        written.append(plots.plot_probes(args.results, os.path.join(out, "plot_probes.png"),
                                         probes))
    if os.path.exists(os.path.join(args.results, "particles.h5")):
        try:
            name = f"plot_frame_{args.frame if args.frame >= 0 else 'last'}_" \
                   f"{args.field or 'auto'}.png"
            written.append(plots.plot_frame(args.results, os.path.join(out, name),
                                            args.frame, args.field, args.normal))
        except (KeyError, IndexError) as err:
            sys.stderr.write(f"pmpm.post: error: --frame/--field: {err}\n")
            return 2
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
