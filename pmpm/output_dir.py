"""What ``--force`` may replace in an output directory: only the files a pmpm run writes.

A run writes ``particles.h5``, ``particles.xdmf``, ``history.csv``, ``forces.csv``, ``summary.json``,
with FEM bodies ``elements.h5``, ``elements.xdmf`` and ``bodies.xdmf``,
``checkpoint_NNNNNN.h5`` and ``probe_NAME.csv`` (``output.probes``), and ``python -m
pmpm.post`` adds ``plot_*.png``; one stopped half-way may also leave their temporary files
(``NAME.tmp.PID`` from an atomic write, ``checkpoint_NNNNNN.h5.tmp``). Anything else in
the directory (another file, any subdirectory, the case file itself) makes ``--force``
refuse, so that it never deletes what pmpm did not write.
"""
import os
import re

OUTPUT_FILES = ("particles.h5", "particles.xdmf", "history.csv", "summary.json",
                "elements.h5", "elements.xdmf", "bodies.xdmf", "forces.csv")
_CHECKPOINT = re.compile(r"^checkpoint_\d+\.h5(\.tmp)?$")
_DERIVED = re.compile(r"^(probe_[A-Za-z0-9_-]+\.csv(\.tmp\.\d+)?|plot_[A-Za-z0-9_.-]+\.png)$")
_TEMPORARY = re.compile(
    r"^(" + "|".join(re.escape(name) for name in OUTPUT_FILES) + r")\.tmp\.\d+$")
_NAMED = 3  # foreign entries named in the error line


def is_run_file(directory, name):
    """Whether ``directory/name`` is a file a pmpm run writes (not a directory)."""
    if not (name in OUTPUT_FILES or _CHECKPOINT.match(name) or _TEMPORARY.match(name)
            or _DERIVED.match(name)):
        return False
    path = os.path.join(directory, name)
    return os.path.islink(path) or not os.path.isdir(path)


def _order(name):
    """The run's files in OUTPUT_FILES order, then checkpoints, then temporaries."""
    if name in OUTPUT_FILES:
        return (0, OUTPUT_FILES.index(name), name)
    return (1 if _CHECKPOINT.match(name) else 2, 0, name)


def _inside(path, directory):
    path, directory = os.path.realpath(path), os.path.realpath(directory)
    return os.path.commonpath([path, directory]) == directory


def force_problem(out, case_path, names):
    """The one-line reason ``--force`` may not replace ``out`` (holding ``names``), or None."""
    if case_path is not None and _inside(case_path, out):
        return (f"--out: '{out}' holds the case file '{case_path}'; --force replaces only "
                f"a run's output files, so choose another --out")
    foreign = sorted(name for name in names if not is_run_file(out, name))
    if not foreign:
        return None
    shown = [name + ("/" if os.path.isdir(os.path.join(out, name)) else "")
             for name in foreign[:_NAMED]]
    more = f" and {len(foreign) - _NAMED} more" if len(foreign) > _NAMED else ""
    return (f"--out: '{out}' holds files that are not a pmpm run's output "
            f"({', '.join(shown)}{more}); --force replaces only {', '.join(OUTPUT_FILES)}, "
            f"checkpoint_*.h5, probe_*.csv and plot_*.png, so choose another --out or move "
            f"them")


def replace_run_files(out, names):
    """Delete the run files ``names`` in ``out``; returns them in a stable order."""
    ordered = sorted(names, key=_order)
    for name in ordered:
        os.remove(os.path.join(out, name))
    return ordered


#: The lock a run holds on its output directory for its whole life (rank 0 creates it
#: atomically before anything is written and removes it at exit).
LOCK_NAME = "pmpm.lock"


def lock_path(out):
    return os.path.join(out, LOCK_NAME)


def _holder_text():
    import socket
    import time
    return (f"pid {os.getpid()} on {socket.gethostname()} since "
            f"{time.strftime('%Y-%m-%d %H:%M:%S')}\n")


def _read_holder(path):
    """(pid, host, the holder's line) of a lock file; pid None when it cannot be read."""
    try:
        with open(path, encoding="utf-8") as handle:
            line = handle.read().strip()
        words = line.split()
        return int(words[1]), words[3], line
    except (OSError, ValueError, IndexError):
        return None, None, "holder unknown"


def _is_dead(pid, host):
    """Whether the lock's holder is a process of this host that no longer runs."""
    import socket
    if pid is None or host != socket.gethostname():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:
        return False
    return False


def acquire_lock(out):
    """Create ``out/pmpm.lock`` atomically (O_EXCL). Returns (problem line or None,
    warning line or None): a lock held by a live run (or one on another host) is a
    problem naming it; a stale lock of a dead run on this host is named and replaced."""
    path, warning = lock_path(out), None
    for _ in range(2):
        try:
            handle = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            pid, host, holder = _read_holder(path)
            if not _is_dead(pid, host):
                return (f"--out: '{out}' is in use by another pmpm run ({holder}; lock "
                        f"file {path}); wait for it to end, choose another --out, or "
                        f"delete the lock if that run is dead"), None
            warning = (f"--out: replacing the stale lock {path} of a run that is no "
                       f"longer running ({holder})")
            try:
                os.remove(path)
            except FileNotFoundError:
                pass
            except OSError as err:
                return f"--out: cannot remove the stale lock {path}: {err.strerror}", None
            continue
        except OSError as err:
            return (f"--out: cannot write in output directory '{out}': "
                    f"{err.strerror or err}"), None
        with os.fdopen(handle, "w", encoding="utf-8") as f:
            f.write(_holder_text())
        return None, warning
    return f"--out: cannot take the lock {path} (another run keeps taking it)", None


def release_lock(out):
    """Remove ``out/pmpm.lock`` when this process holds it."""
    path = lock_path(out)
    pid, _, _ = _read_holder(path)
    if pid == os.getpid():
        try:
            os.remove(path)
        except OSError:
            pass
