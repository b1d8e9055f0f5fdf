"""Keep Numba's on-disk cache honest about inlined code.

Numba keys a cached kernel on its own source file only. The loops of ``mpm`` and
``contact`` inline the material update from ``pmpm/materials``, the shape functions
(``shape.py``) and the boundary conditions (``boundary.py``), so an edit there would
leave the cached loops running the old code. Before the kernels are loaded,
:func:`refresh_inlined_caches` compares a hash of those sources with the one the cache
was built from and drops the stale cached loops. The FEM element loop
(``pmpm/fem/elements.py``) inlines the material update too, and the hexahedron geometry
and the stable step (``pmpm/fem/hexahedron.py``, ``stability.py``): it is dropped with them.
"""
import glob
import hashlib
import os

HERE = os.path.dirname(os.path.abspath(__file__))
MATERIALS = os.path.join(os.path.dirname(HERE), "materials")
FEM = os.path.join(os.path.dirname(HERE), "fem")
INLINING = ("mpm.", "contact.")
FEM_INLINING = ("elements.",)
INLINED = (os.path.join(MATERIALS, "*.py"), os.path.join(HERE, "shape.py"),
           os.path.join(HERE, "boundary.py"), os.path.join(FEM, "hexahedron.py"),
           os.path.join(FEM, "stability.py"))


def materials_digest():
    """A hash of every source the cached loops inline."""
    digest = hashlib.sha1()
    paths = sorted(path for pattern in INLINED for path in glob.glob(pattern))
    for path in paths:
        with open(path, "rb") as handle:
            digest.update(handle.read())
    return digest.hexdigest()


def refresh_inlined_caches(cache_dir=None, fem_cache_dir=None):
    """Delete the cached kernels that inline material code (or the element's geometry
    and stable step) if that code changed since they were cached. Returns True if
    anything was deleted."""
    fem_cache_dir = fem_cache_dir or cache_dir or os.path.join(FEM, "__pycache__")
    cache_dir = cache_dir or os.path.join(HERE, "__pycache__")
    stamp = os.path.join(cache_dir, "materials.sha1")
    digest = materials_digest()
    try:
        with open(stamp, encoding="ascii") as handle:
            if handle.read().strip() == digest:
                return False
    except OSError:
        pass
    removed = drop_cached(cache_dir, INLINING)
    removed = drop_cached(fem_cache_dir, FEM_INLINING) or removed
    try:
        os.makedirs(cache_dir, exist_ok=True)
        with open(stamp, "w", encoding="ascii") as handle:
            handle.write(digest + "\n")
    except OSError:
        pass                                 # a read-only install: nothing to keep fresh
    return removed


def drop_cached(cache_dir, names):
    """Delete the cached kernels of the modules ``names`` in ``cache_dir``; returns
    whether any was."""
    removed = False
    for name in names:
        for path in glob.glob(os.path.join(cache_dir, f"{name}*-*.nb[ic]")):
            try:
                os.remove(path)
                removed = True
            except OSError:
                pass                         # another rank removed it first
    return removed
