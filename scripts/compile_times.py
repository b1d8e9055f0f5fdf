"""Time the cold compile of the step's kernels, kernel by kernel (issue 25).

Runs ``pmpm.kernels.warmup.warm_up`` for one shape (and with ``--apic`` the affine
variants) and reports, per kernel called from Python, the wall and CPU seconds of its
compile, callees it compiled first included (so the first kernel that calls the material
update pays for it), from Numba's ``numba:compile`` events; then the total and the number
of specialisations Numba's cache holds afterwards. Numbers mean a cold compile only with an
empty cache: run it as

    NUMBA_CACHE_DIR=$(mktemp -d) NUMBA_NUM_THREADS=1 .venv/bin/python scripts/compile_times.py linear
    NUMBA_CACHE_DIR=$(mktemp -d) NUMBA_NUM_THREADS=1 .venv/bin/python scripts/compile_times.py gimp --apic
    NUMBA_CACHE_DIR=$(mktemp -d) NUMBA_NUM_THREADS=1 .venv/bin/python scripts/compile_times.py linear --fem
    NUMBA_CACHE_DIR=$(mktemp -d) NUMBA_NUM_THREADS=1 .venv/bin/python scripts/compile_times.py defaults

(``--fem``: also the FEM bodies', their couplings' and the force log's kernels;
``defaults``: ``warm_up_defaults``, what scripts/setup.sh and the test session compile)

(with a warm cache it times the loads). CPU seconds are the figure to compare on a shared
machine: wall time under load counts other people's work.
"""
import argparse
import glob
import os
import time

from numba.core import event


class CompileTimer(event.Listener):
    """Wall and CPU seconds of every outermost compile, by the kernel's qualified name."""

    def __init__(self):
        self.stack, self.wall, self.cpu = [], {}, {}

    def on_start(self, ev):
        name = ev.data["dispatcher"].py_func.__qualname__
        self.stack.append((name, time.perf_counter(), time.process_time()))

    def on_end(self, ev):
        name, wall0, cpu0 = self.stack.pop()
        if not self.stack:
            self.wall[name] = self.wall.get(name, 0.0) + time.perf_counter() - wall0
            self.cpu[name] = self.cpu.get(name, 0.0) + time.process_time() - cpu0


def cached_specialisations(cache_dir):
    """Number of compiled specialisations in Numba's cache at ``cache_dir`` (one .nbc file
    each), or None when no NUMBA_CACHE_DIR is set."""
    if not cache_dir:
        return None
    return len(glob.glob(os.path.join(cache_dir, "**", "*.nbc"), recursive=True))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("shape", nargs="?", default="linear", choices=["linear", "gimp", "bspline", "defaults"])
    parser.add_argument("--apic", action="store_true", help="also the APIC transfer variants")
    parser.add_argument("--fem", action="store_true",
                        help="also the FEM bodies', their couplings' and the force log's")
    parser.add_argument("--top", type=int, default=25, help="kernels to list")
    args = parser.parse_args()
    timer = CompileTimer()
    event.register("numba:compile", timer)
    from pmpm.kernels.shape import SHAPE_CODES
    from pmpm.kernels.warmup import ALL_COUPLINGS, warm_up, warm_up_defaults
    cpu0 = time.process_time()
    if args.shape == "defaults":
        wall = warm_up_defaults()
    else:
        wall = warm_up(SHAPE_CODES[args.shape], apic=args.apic,
                       **(ALL_COUPLINGS if args.fem else {}))
    cpu = time.process_time() - cpu0
    kinds = (", apic" if args.apic else "") + (", fem" if args.fem else "")
    print(f"warm_up({args.shape}{kinds}): {wall:.1f} s wall, "
          f"{cpu:.1f} s CPU, load average {os.getloadavg()[0]:.1f}")
    print(f"specialisations in the cache: {cached_specialisations(os.environ.get('NUMBA_CACHE_DIR'))}")
    print("   wall     CPU  kernel")
    for name in sorted(timer.cpu, key=lambda k: -timer.cpu[k])[:args.top]:
        print(f"{timer.wall[name]:7.1f} {timer.cpu[name]:7.1f}  {name}")


if __name__ == "__main__":
    main()
