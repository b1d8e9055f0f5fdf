"""Command line: ``mpirun -n N python -m pmpm CASE.yaml [--out DIR] [--set KEY=VALUE ...]``.

Exit codes: 0 success; 2 bad input (one line per problem, naming the key, printed once);
1 a fault during the run (every rank stops with the same message); 3 interrupted by
SIGTERM or SIGINT after writing a checkpoint (continue it with --restart).
"""
import argparse
import contextlib
import os
import sys


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog="python -m pmpm", description="MPI-parallel material point method for impact.")
    parser.add_argument("case", help="case file (YAML)")
    parser.add_argument("--out", help="output directory (default: results/<case name>)")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE", help="override a dotted key, e.g. params.cell=0.38")
    parser.add_argument("--force", action="store_true",
                        help="overwrite an existing, non-empty output directory")
    parser.add_argument("--restart", action="store_true",
                        help="continue from the newest checkpoint in the output directory")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    return parser.parse_args(argv)


def parse_args_once(comm, argv):
    """Parse on every rank, but let only rank 0 print usage, help or argument errors.
    Returns (args, None), or (None, exit status) when argparse wants to exit."""
    with contextlib.ExitStack() as silence:
        if not comm.is_root:
            sink = silence.enter_context(open(os.devnull, "w"))
            silence.enter_context(contextlib.redirect_stdout(sink))
            silence.enter_context(contextlib.redirect_stderr(sink))
        try:
            return parse_args(argv), None
        except SystemExit as stop:
            return None, stop.code


def main(argv=None):
    from .comm import world
    from .app import run_case, InputError
    from .solver.interrupt import INTERRUPTED, RunInterrupted, catch_signals
    catch_signals()
    comm = world()
    args, status = parse_args_once(comm, sys.argv[1:] if argv is None else argv)
    if args is None:
        return status
    try:
        summary_path = run_case(comm, args)
    except InputError as err:
        if comm.is_root:
            for line in err.problems:
                sys.stderr.write(f"pmpm: error: {line}\n")
        return 2
    except _solver_error() as err:
        if comm.is_root:
            sys.stderr.write(f"pmpm: run stopped: {err}\n")
        return 1
    except RunInterrupted as err:
        if comm.is_root:
            sys.stderr.write(f"pmpm: {err}\n")
            sys.stderr.flush()
        return INTERRUPTED
    except BaseException:
        import traceback
        traceback.print_exc()
        sys.stderr.flush()
        if comm.size > 1:
            comm.abort("unexpected error (traceback above); stopping all ranks")
        return 1
    if comm.is_root and not args.quiet:
        print(f"pmpm: done; results in {os.path.dirname(summary_path)}")
    return 0


def _solver_error():
    from .solver.errors import SolverError
    return SolverError


if __name__ == "__main__":
    sys.exit(main())
