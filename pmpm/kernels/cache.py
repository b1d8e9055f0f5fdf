"""Keep Numba's on-disk cache honest about inlined code.

Numba keys a cached kernel on its own source file only. The loops of ``mpm`` and
``contact`` inline the material update from ``pmpm/materials``, the shape functions
(``shape.py``) and the boundary conditions (``boundary.py``), so an edit there would
leave the cached loops running the old code. Before the kernels are loaded,
:func:`refresh_inlined_caches` compares a hash of those sources with the one the cache
was built from and drops the stale cached loops.
"""
import glob
import hashlib
import os

HERE = os.path.dirname(os.path.abspath(__file__))
MATERIALS = os.path.join(os.path.dirname(HERE), "materials")
INLINING = ("mpm.", "contact.")
INLINED = (os.path.join(MATERIALS, "*.py"), os.path.join(HERE, "shape.py"),
           os.path.join(HERE, "boundary.py"))


def materials_digest():
    """A hash of every source the cached loops inline."""
    digest = hashlib.sha1()
    paths = sorted(path for pattern in INLINED for path in glob.glob(pattern))
    for path in paths:
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
        for path in glob.glob(os.path.join(cache_dir, f"{name}*-*.nb[ic]")):
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
