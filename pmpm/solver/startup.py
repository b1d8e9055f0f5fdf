"""How long this process took to reach its first step (issue 25: at most 0.7 s with a
warm kernel cache), kept in summary.json as ``startup_s``."""
import os
import time


def since_process_start():
    """{"wall", "cpu", "queued"}: seconds since this process started. The wall time counts
    from the kernel's start time of the process (/proc/self/stat, in clock ticks since
    boot: 10 ms resolution) against the boot-time clock; the CPU time is the process's
    own, user and system, of every thread; ``queued`` is the time its main thread was
    ready to run but waited for a core (/proc/self/schedstat), which only other
    processes' load causes: ``wall - queued`` is about what an idle machine would take.
    None for what /proc cannot tell."""
    wall, queued = _wall_since_start(), _queued()
    return {"wall": wall, "cpu": time.process_time(), "queued": queued,
            "wall_less_queued": None if wall is None or queued is None else wall - queued}


def _wall_since_start():
    try:
        with open("/proc/self/stat", encoding="ascii") as f:
            fields = f.read().rpartition(")")[2].split()
        ticks = int(fields[19])          # field 22 (starttime); fields[0] is field 3
        return time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def _queued():
    try:
        with open("/proc/self/schedstat", encoding="ascii") as f:
            return int(f.read().split()[1]) * 1e-9
    except (OSError, ValueError, IndexError):
        return None
