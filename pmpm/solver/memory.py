"""Resident memory of this process (Linux), for the summary's memory figures, and the
allocator setting that hands freed particle columns back to the system."""
import ctypes
import os
import resource

M_MMAP_THRESHOLD = -3           # glibc's mallopt parameters
M_TRIM_THRESHOLD = -1
MMAP_THRESHOLD = 128 * 1024     # bytes: glibc's initial value
LARGEST_THRESHOLD = 32 << 20    # bytes: the most glibc's own rule raises it to


def return_freed_memory_to_os(threshold=MMAP_THRESHOLD):
    """Keep glibc's mmap threshold at ``threshold`` (128 KiB by default) so that every
    large array lives in its own mapping and goes back to the system when freed.

    By default glibc raises the threshold to the size of each large block freed (up to
    32 MiB): a particle column replaced by its sorted or migrated copy then leaves its
    old block in the heap, where the next copy may not fit, and the resident size grows
    by about a store's worth over the run (Taylor bar at 0.38 mm: 570 bytes per particle
    against 437 with the threshold held). Returns True where the setting took (glibc)."""
    try:        # the process's own symbols, libc's among them: ctypes.util.find_library
        libc = ctypes.CDLL(None)    # would run ldconfig, 30 ms of every start (issue 25)
        done = bool(libc.mallopt(M_MMAP_THRESHOLD, int(threshold)))
        if threshold > MMAP_THRESHOLD:      # and keep what is freed below it, as glibc's
            done &= bool(libc.mallopt(M_TRIM_THRESHOLD, 2 * int(threshold)))  # own rule
        return done
    except (OSError, AttributeError):
        return False


def threshold_for_fe_nodes(n_nodes):
    """The mmap threshold for a rank that holds ``n_nodes`` FE nodes: four node vectors'
    worth (n x 3 doubles each), at least 128 KiB and at most 32 MiB.

    A step of FEM bodies and their contacts makes many temporaries over the nodes and
    the faces; below the threshold each is a fresh mapping that the system zero-fills
    page by page. The 2 mm perforation (44,000 nodes on one rank) took 4.9 million page
    faults and 7.5 s of system time in a 27 s step loop at 128 KiB; at this rule's
    4.2 MiB, 0.44 million and 0.8 s, and the loop 20.6 s (peak memory +5 %). Particle
    columns smaller than the threshold may then stay in the heap when replaced: a run
    of particles alone keeps 128 KiB."""
    return int(min(LARGEST_THRESHOLD, max(MMAP_THRESHOLD, 4 * 24 * int(n_nodes))))


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


def memory_summary(world, baseline, n_particles, n_elements=0):
    """Peak memory over all ranks and what the run added per particle: the sum over ranks
    of (peak - baseline), where the baseline is taken after imports and kernel compilation
    and before any particle exists. ``bytes_per_particle`` over the initial particles
    (None in a run that starts with none), ``bytes_per_point`` over the initial particles
    and FEM elements together."""
    peak = peak_rss_bytes()
    added = world.sum(max(peak - baseline, 0))
    return {"peak_rss_mb_total": world.sum(peak) / 2 ** 20,
            "peak_rss_mb_max_rank": world.max(peak) / 2 ** 20,
            "baseline_rss_mb_total": world.sum(baseline) / 2 ** 20,
            "bytes_per_particle": added / n_particles if n_particles else None,
            "bytes_per_point": added / max(n_particles + n_elements, 1)}
