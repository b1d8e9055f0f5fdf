"""Resident memory of this process (Linux), for the summary's memory figures."""
import os
import resource


def current_rss_bytes():
    """Resident set size now, from /proc/self/statm (0 where unavailable)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def peak_rss_bytes():
    """High-water mark of the resident set size (ru_maxrss is in KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def memory_summary(world, baseline, n_particles):
    """Peak memory over all ranks and what the run added per particle: the sum over ranks
    of (peak - baseline), where the baseline is taken after imports and kernel compilation
    and before any particle exists."""
    peak = peak_rss_bytes()
    added = world.sum(max(peak - baseline, 0))
    return {"peak_rss_mb_total": world.sum(peak) / 2 ** 20,
            "peak_rss_mb_max_rank": world.max(peak) / 2 ** 20,
            "baseline_rss_mb_total": world.sum(baseline) / 2 ** 20,
            "bytes_per_particle": added / max(n_particles, 1)}
