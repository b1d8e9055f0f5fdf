"""Shared helpers of the validation and benchmark scripts: run pmpm, read results."""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PYTHON = os.path.join(ROOT, ".venv", "bin", "python")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
sys.path.insert(0, ROOT)


def run_case(case, out, ranks=1, sets=(), quiet=True):
    """Run a case with the command line (overwriting ``out``); returns summary.json."""
    cmd = [PYTHON if os.path.exists(PYTHON) else sys.executable, "-m", "pmpm",
           os.path.join(ROOT, case), "--out", out, "--force"]
    cmd += ["--quiet"] if quiet else []
    for item in sets:
        cmd += ["--set", item]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe"] + cmd
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, env=ENV, cwd=ROOT)
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        return json.load(f)


def provenance(script):
    """Which code, when, how and where a script measured: the commit (with "with
    uncommitted changes" where pmpm/ differs from it), the UTC date, the command line of
    ``script`` (its file name under scripts/) and the machine."""
    import datetime
    import platform

    def git(*argv):
        done = subprocess.run(["git", *argv], cwd=ROOT, capture_output=True, text=True)
        return done.stdout.strip() if done.returncode == 0 else ""
    commit = git("rev-parse", "--short", "HEAD") or "unknown"
    if git("status", "--porcelain", "--untracked-files=no", "--", "pmpm"):
        commit += " with uncommitted changes"
    return {"commit": commit,
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "command": " ".join([f"python scripts/{script}"] + sys.argv[1:]),
            "machine": f"{platform.machine()} {platform.system()}, {os.cpu_count()} CPUs"}


def save_json(path, data):
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2)
    print("wrote", path)


def write_lines(path, lines, echo=False):
    """Write ``lines`` as a text file (a Markdown table, say), creating its folder; with
    ``echo`` print them too."""
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    if echo:
        print("\n".join(lines))
    print("wrote", path)


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend, or None (and a line saying so) where
    matplotlib is not installed."""
    try:
        import matplotlib
    except ImportError:
        print("matplotlib is not installed: no plot")
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, path):
    """Lay out ``fig`` and write it to ``path`` (PNG at 120 dpi)."""
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print("wrote", path)


def method_panels(plt, rows):
    """One panel per contact method found in ``rows``, side by side with a shared y axis.
    Returns the figure and a list of (axes, method, that method's rows)."""
    methods = sorted({r["method"] for r in rows})
    fig, axes = plt.subplots(1, len(methods), figsize=(6 * len(methods), 4.5), squeeze=False,
                             sharey=True)
    return fig, [(ax, m, [r for r in rows if r["method"] == m])
                 for ax, m in zip(axes[0], methods)]
