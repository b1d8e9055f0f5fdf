"""pmpm.kernels.cache: a cached kernel is dropped when any package module it imports,
directly or not, is edited, and only then (issue 24). Each test works on a copy of the
package's sources in a temporary folder, with stand-in cache files where Numba would put
the real ones."""
import os
import shutil
import time

import pytest

from pmpm.kernels import cache


@pytest.fixture
def package(tmp_path):
    """A copy of pmpm's sources (no caches), checked once so its manifest exists."""
    root = tmp_path / "pmpm"
    shutil.copytree(cache.PACKAGE, root, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    cache.refresh_kernel_caches(str(root))
    return root


def cached(root, module, function="kernel"):
    """Stand-in cache files (index and data) for one kernel of ``module`` (a path under
    the package, without .py), where Numba's locators would put them."""
    folder = cache.cache_dir_of(str(root / f"{module}.py"))
    stem = os.path.basename(module)
    files = [os.path.join(folder, f"{stem}.{function}-10.py311.nbi"),
             os.path.join(folder, f"{stem}.{function}-10.py311.1.nbc")]
    for path in files:
        with open(path, "w") as handle:
            handle.write("x")
    return files


def edit(path, text="\n# edited\n"):
    with open(path, "a") as handle:
        handle.write(text)


KERNEL_MODULES = ("kernels/mpm", "kernels/contact", "kernels/affine", "kernels/tied",
                  "kernels/surface_contact", "fem/elements", "materials/eos")


def cache_all(root):
    return {module: cached(root, module) for module in KERNEL_MODULES}


def kept(files):
    return all(os.path.exists(path) for path in files)


def gone(files):
    return not any(os.path.exists(path) for path in files)


def test_an_edit_to_an_inlined_module_drops_its_users_and_keeps_the_rest(package):
    files = cache_all(package)
    assert cache.refresh_kernel_caches(str(package)) == []          # nothing edited
    assert all(kept(f) for f in files.values())
    edit(package / "kernels" / "affine.py")                          # not on the old list
    assert cache.refresh_kernel_caches(str(package)) == [
        "pmpm.kernels.affine", "pmpm.kernels.contact", "pmpm.kernels.mpm"]
    assert gone(files["kernels/mpm"]) and gone(files["kernels/contact"])
    for module in ("kernels/tied", "kernels/surface_contact", "fem/elements", "materials/eos"):
        assert kept(files[module]), module
    assert cache.refresh_kernel_caches(str(package)) == []          # recorded: once only


def test_an_edit_to_the_slot_layout_reaches_the_fem_and_mpm_loops(package):
    """layout.py holds only constants, which Numba freezes into every kernel that reads
    them: no kernel lives there, yet its edit must drop them."""
    files = cache_all(package)
    edit(package / "materials" / "layout.py")
    dropped = cache.refresh_kernel_caches(str(package))
    assert {"pmpm.kernels.mpm", "pmpm.fem.elements", "pmpm.materials.eos"} <= set(dropped)
    assert gone(files["fem/elements"]) and gone(files["materials/eos"])
    for module in ("kernels/tied", "kernels/surface_contact", "kernels/contact"):
        assert kept(files[module]), module        # they read no material slot


def test_a_new_module_is_watched_without_a_list(package):
    kernels = package / "kernels"
    (kernels / "helper.py").write_text("from numba import njit\n\n\n@njit\n"
                                       "def twice(x):\n    return 2 * x\n")
    (kernels / "user.py").write_text(
        "from numba import njit\n\n\ndef build():\n    from .helper import (\n"
        "        twice)\n    return twice\n\n\n@njit(cache=True)\ndef kernel(x):\n"
        "    return x\n")
    cache.refresh_kernel_caches(str(package))
    user, tied = cached(package, "kernels/user"), cached(package, "kernels/tied")
    assert cache.refresh_kernel_caches(str(package)) == []
    edit(kernels / "helper.py")
    assert cache.refresh_kernel_caches(str(package)) == ["pmpm.kernels.user"]
    assert gone(user) and kept(tied)


def test_a_touch_without_an_edit_keeps_every_cache(package):
    files = cache_all(package)
    later = time.time_ns() + 10**9
    for module in ("kernels/affine", "materials/tensors"):
        os.utime(package / f"{module}.py", ns=(later, later))
    assert cache.refresh_kernel_caches(str(package)) == []
    assert all(kept(f) for f in files.values())


def test_without_a_manifest_every_cached_kernel_is_dropped(package):
    """Caches of unknown provenance (an older pmpm, a lost manifest) are not trusted."""
    files = cache_all(package)
    os.remove(cache.manifest_file(str(package)))
    dropped = cache.refresh_kernel_caches(str(package))
    assert set(dropped) == {"pmpm." + m.replace("/", ".") for m in KERNEL_MODULES}
    assert all(gone(f) for f in files.values())


def test_the_import_forms_are_followed():
    sources = {name: name.replace(".", "/") + ".py" for name in
               ("pmpm.a.b", "pmpm.a.c", "pmpm.a.d", "pmpm.e.f", "pmpm.g", "pmpm.h")}
    sources["pmpm.a"] = "pmpm/a/__init__.py"
    text = (b'"""Its docstring:\nfrom the nodes to the points.\nimport what it needs.\n"""\n'
            b"import numpy as np\nfrom . import c\nfrom .d import (x,\n    y)\n"
            b"from ..e.f import z\nimport pmpm.g\n\n\ndef late():\n"
            b"    from .. import h\n# from .nothing import w\n")
    assert cache.imports_of("pmpm.a.b", text, sources) == {
        "pmpm.a", "pmpm.a.c", "pmpm.a.d", "pmpm.e.f", "pmpm.g", "pmpm.h"}


def test_the_real_loops_depend_on_what_they_inline():
    sources = cache.package_sources(cache.PACKAGE)

    def text(name):
        with open(sources[name], "rb") as handle:
            return handle.read()

    graph = {}
    mpm = cache.reached("pmpm.kernels.mpm", graph, text, sources)
    assert {"pmpm.kernels.affine", "pmpm.kernels.shape", "pmpm.kernels.boundary",
            "pmpm.materials.kernels", "pmpm.materials.layout"} <= mpm
    elements = cache.reached("pmpm.fem.elements", graph, text, sources)
    assert {"pmpm.fem.hexahedron", "pmpm.fem.stability", "pmpm.materials.kernels"} <= elements
    assert "pmpm.kernels.mpm" not in elements


def test_the_check_at_start_up_is_cheap(package):
    """Every run pays the check when nothing changed: a walk and a stat per file (1.4 ms
    here, the best of several tries on a loaded machine; reading and parsing the kernel
    modules' imports after an edit takes 20 to 60 ms)."""
    cache.refresh_kernel_caches(str(package))
    spent = []
    for _ in range(7):
        started = time.perf_counter()
        cache.refresh_kernel_caches(str(package))
        spent.append(time.perf_counter() - started)
    assert min(spent) < 0.01
