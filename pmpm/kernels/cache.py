"""Keep Numba's on-disk cache honest about inlined material code.

Numba keys a cached kernel on its own source file only. The particle loops
``mpm.stress_and_forces`` and ``mpm.update_stresses`` inline the material update from
``pmpm/materials``, so an edit there would leave the cached loops running the old
material code. Before the
kernels are loaded, :func:`refresh_inlined_caches` compares a hash of the material
sources with the one the cache was built from and drops the stale cached loops.
"""
import glob
import hashlib
import os

HERE = os.path.dirname(os.path.abspath(__file__))
MATERIALS = os.path.join(os.path.dirname(HERE), "materials")
INLINING = ("mpm.stress_and_forces", "mpm.update_stresses")


def materials_digest():
    digest = hashlib.sha1()
    for path in sorted(glob.glob(os.path.join(MATERIALS, "*.py"))):
        with open(path, "rb") as handle:
            digest.update(handle.read())
    return digest.hexdigest()


def refresh_inlined_caches(cache_dir=None):
    """Delete the cached kernels that inline material code if that code changed since
    they were cached. Returns True if anything was deleted."""
    cache_dir = cache_dir or os.path.join(HERE, "__pycache__")
    stamp = os.path.join(cache_dir, "materials.sha1")
    digest = materials_digest()
    try:
        with open(stamp, encoding="ascii") as handle:
            if handle.read().strip() == digest:
                return False
    except OSError:
        pass
    removed = False
    for name in INLINING:
        for path in glob.glob(os.path.join(cache_dir, f"{name}-*.nb[ic]")):
            try:
                os.remove(path)
                removed = True
            except OSError:
                pass                         # another rank removed it first
    try:
        os.makedirs(cache_dir, exist_ok=True)
        with open(stamp, "w", encoding="ascii") as handle:
            handle.write(digest + "\n")
    except OSError:
        pass                                 # a read-only install: nothing to keep fresh
    return removed
