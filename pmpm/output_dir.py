"""What ``--force`` may replace in an output directory: only the files a pmpm run writes.

A run writes ``particles.h5``, ``particles.xdmf``, ``history.csv``, ``summary.json`` and
``checkpoint_NNNNNN.h5``; one stopped half-way may also leave their temporary files
(``NAME.tmp.PID`` from an atomic write, ``checkpoint_NNNNNN.h5.tmp``). Anything else in
the directory (another file, any subdirectory, the case file itself) makes ``--force``
refuse, so that it never deletes what pmpm did not write.
"""
import os
import re

OUTPUT_FILES = ("particles.h5", "particles.xdmf", "history.csv", "summary.json",
                "elements.h5", "elements.xdmf")
_CHECKPOINT = re.compile(r"^checkpoint_\d+\.h5(\.tmp)?$")
_TEMPORARY = re.compile(
    r"^(" + "|".join(re.escape(name) for name in OUTPUT_FILES) + r")\.tmp\.\d+$")
_NAMED = 3  # foreign entries named in the error line


def is_run_file(directory, name):
    """Whether ``directory/name`` is a file a pmpm run writes (not a directory)."""
    if not (name in OUTPUT_FILES or _CHECKPOINT.match(name) or _TEMPORARY.match(name)):
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
            f"({', '.join(shown)}{more}); --force replaces only {', '.join(OUTPUT_FILES)} "
            f"and checkpoint_*.h5, so choose another --out or move them")


def replace_run_files(out, names):
    """Delete the run files ``names`` in ``out``; returns them in a stable order."""
    ordered = sorted(names, key=_order)
    for name in ordered:
        os.remove(os.path.join(out, name))
    return ordered
