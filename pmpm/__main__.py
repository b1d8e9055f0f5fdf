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
    parser.add_argument("--check", action="store_true",
                        help="validate the case and print its estimated particles, steps, "
                             "output and memory, then stop (nothing compiled or written)")
    parser.add_argument("--version", action=VersionAction)
    args = parser.parse_args(argv)
    if args.check and args.restart:
        parser.error("--check validates a new run; it cannot be given with --restart")
    return args


class VersionAction(argparse.Action):
    """``--version``: prints :func:`version_text` and exits, reading the packages'
    metadata only then (importing importlib.metadata took 20-30 ms of every start)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="show the version of pmpm and its libraries and exit"):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_text())
        parser.exit()


def version_text():
    """``pmpm 0.1.0 (git abc1234; numpy ..., numba ..., mpi4py ..., h5py ...)``: what
    a bug report needs, read without importing the libraries."""
    from importlib import metadata
    from . import __version__
    parts = []
    commit = _git_commit()
    if commit:
        parts.append(f"git {commit}")
    for name in ("numpy", "numba", "mpi4py", "h5py"):
        try:
            parts.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            parts.append(f"{name} missing")
    return f"pmpm {__version__} ({'; '.join(parts)})"


def _git_commit():
    """The short commit of the checkout pmpm runs from, or None (not a git checkout)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    git = os.path.join(root, ".git")
    try:
        if os.path.isfile(git):             # a worktree: "gitdir: PATH"
            with open(git, encoding="utf-8") as f:
                git = f.read().split(":", 1)[1].strip()
        with open(os.path.join(git, "HEAD"), encoding="utf-8") as f:
            head = f.read().strip()
        if head.startswith("ref: "):
            ref = head[5:]
            path = os.path.join(git, ref)
            if not os.path.exists(path):
                path = os.path.join(_common_dir(git), ref)
            head = _read_ref(path, _common_dir(git), ref)
        return head[:7] if head else None
    except (OSError, IndexError):
        return None


def _common_dir(git):
    """A worktree's shared git folder (its ``commondir``), or ``git`` itself."""
    try:
        with open(os.path.join(git, "commondir"), encoding="utf-8") as f:
            return os.path.normpath(os.path.join(git, f.read().strip()))
    except OSError:
        return git


def _read_ref(path, common, ref):
    """A branch's commit from its loose file or from packed-refs."""
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            return f.read().strip()
    with open(os.path.join(common, "packed-refs"), encoding="utf-8") as f:
        for line in f:
            if line.rstrip().endswith(" " + ref):
                return line.split()[0]
    return None


#: the variables MPI launchers set to a process's rank in the job (Open MPI, PMIx,
#: MPICH's Hydra, Slurm)
RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK", "SLURM_PROCID")


def launcher_rank():
    """This process's rank as its launcher set it, read before MPI is initialised (0
    without a launcher): the arguments and the case are checked before MPI starts, which
    costs about 0.4 s that ``--help`` and a bad input need not wait for."""
    for name in RANK_VARIABLES:
        value = os.environ.get(name, "")
        if value.isdigit():
            return int(value)
    return 0


def parse_args_once(is_root, argv):
    """Parse on every rank, but let only rank 0 print usage, help or argument errors.
    Returns (args, None), or (None, exit status) when argparse wants to exit."""
    with contextlib.ExitStack() as silence:
        if not is_root:
            sink = silence.enter_context(open(os.devnull, "w"))
            silence.enter_context(contextlib.redirect_stdout(sink))
            silence.enter_context(contextlib.redirect_stderr(sink))
        try:
            return parse_args(argv), None
        except SystemExit as stop:
            return None, stop.code


class TolerantStdout:
    """stdout that a closed reader cannot stop: after a broken pipe (``pmpm case.yaml |
    head``) further lines go nowhere and the run goes on to its end, instead of dying
    with a traceback on its next progress line."""

    def __init__(self, stream):
        self.stream, self.broken = stream, False

    def write(self, text):
        if not self.broken:
            try:
                return self.stream.write(text)
            except BrokenPipeError:
                self.drop()
        return len(text)

    def flush(self):
        if not self.broken:
            try:
                self.stream.flush()
            except BrokenPipeError:
                self.drop()

    def drop(self):
        """Point the descriptor at /dev/null, so that the interpreter's last flush at
        exit does not complain either."""
        self.broken = True
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, self.stream.fileno())
        os.close(devnull)

    def __getattr__(self, name):
        return getattr(self.stream, name)


def main(argv=None):
    from .app import InputError, load_checked_case
    from .solver.interrupt import INTERRUPTED, RunInterrupted, catch_signals
    if not isinstance(sys.stdout, TolerantStdout):
        sys.stdout = TolerantStdout(sys.stdout)
    catch_signals()
    is_root = launcher_rank() == 0
    args, status = parse_args_once(is_root, sys.argv[1:] if argv is None else argv)
    if args is None:
        return status
    try:            # every rank checks the case alike, before MPI starts
        loaded = load_checked_case(args.case, args.overrides)
    except InputError as err:
        return report_input_error(err, is_root)
    from .app import check_case, run_case
    from .comm import world
    comm = world()
    try:
        if args.check:
            lines = check_case(comm, args, loaded)
            if comm.is_root:
                print("\n".join(lines), flush=True)
            return 0
        summary_path = run_case(comm, args, loaded)
    except InputError as err:
        return report_input_error(err, comm.is_root)
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


def report_input_error(err, is_root):
    """One ``pmpm: error:`` line per problem, from rank 0 only; exit status 2."""
    if is_root:
        for line in err.problems:
            sys.stderr.write(f"pmpm: error: {line}\n")
    return 2


def _solver_error():
    from .solver.errors import SolverError
    return SolverError


if __name__ == "__main__":
    sys.exit(main())
