"""Keep Numba's on-disk cache honest about the code a cached kernel compiles in.

Numba keys a cached kernel on its own source file only, but a kernel compiles in every
``@njit`` function it calls and freezes every module-level constant it reads (the
material update, the shape functions, the boundary conditions, the APIC moments, the
slot numbers of ``materials/layout.py``), which live in other modules. An edit there
would leave the cached kernel running the old code.

Before the kernels load, :func:`refresh_kernel_caches` finds every module of the package
whose source caches kernels (``cache=True``), follows its imports inside the package
transitively (its import statements parsed with :mod:`ast`) and hashes the sources of every module it reaches,
its own included. A manifest beside the cache keeps, for each such module, the hash its
cached kernels were built from; where it differs, that module's cached files are deleted
and Numba compiles them afresh. There is no hand-kept list: a new module is watched as
soon as a kernel module imports it, and a new kernel module as soon as it says
``cache=True``.

Start-up cost: the manifest also keeps the size and modification time of every source of
the package; while none changed (every start but the first after an edit) the check costs
a directory walk and a ``stat`` per file, about a millisecond. After an edit it reads and
parses the import statements of the kernel modules and of what they import, some tens of
milliseconds.
"""
import ast
import hashlib
import json
import os
import re

PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = "kernel-sources.json"
CACHES = re.compile(rb"cache\s*=\s*True")


def refresh_kernel_caches(root=PACKAGE):
    """Delete the cached kernels of every module of the package at ``root`` whose sources,
    or the sources of a module it imports (transitively), changed since they were cached.
    Returns the dotted names of the modules whose caches were deleted (an empty list when
    nothing changed, the common case)."""
    sources = package_sources(root)
    stamp = fingerprint(sources)
    manifest_path = manifest_file(root)
    old = read_manifest(manifest_path)
    if old.get("fingerprint") == stamp:
        return []
    digests = kernel_digests(sources)
    stale = sorted(name for name, digest in digests.items()
                   if old.get("digests", {}).get(name) != digest)
    dropped = [name for name in stale if drop_cached(sources[name])]
    write_manifest(manifest_path, {"fingerprint": stamp, "digests": digests})
    return dropped


def package_sources(root):
    """Dotted module name -> source path of every ``.py`` file of the package at ``root``
    (a package as its ``__init__.py``)."""
    base = os.path.dirname(root)
    sources = {}
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders if d != "__pycache__")
        package = os.path.relpath(folder, base).replace(os.sep, ".")
        for file in files:
            if file.endswith(".py"):
                stem = file[:-3]
                name = package if stem == "__init__" else f"{package}.{stem}"
                sources[name] = os.path.join(folder, file)
    return sources


def fingerprint(sources):
    """A hash of the name, size and modification time of every source: equal hashes mean
    nothing was edited, without reading a file."""
    digest = hashlib.sha1()
    for name in sorted(sources):
        status = os.stat(sources[name])
        digest.update(f"{name} {status.st_size} {status.st_mtime_ns}\n".encode())
    return digest.hexdigest()


def kernel_digests(sources):
    """Dotted name -> hash of the sources it depends on, for each module that caches
    kernels: its own source and that of every package module it imports, transitively."""
    texts = {}

    def text(name):
        if name not in texts:
            with open(sources[name], "rb") as handle:
                texts[name] = handle.read()
        return texts[name]

    graph = {}
    kernels = [name for name in sorted(sources) if CACHES.search(text(name))]
    return {name: digest_of(reached(name, graph, text, sources), text)
            for name in kernels}


def reached(start, graph, text, sources):
    """The modules ``start`` imports directly or through others, itself included;
    ``graph`` memoises each module's direct imports."""
    seen, todo = {start}, [start]
    while todo:
        name = todo.pop()
        if name not in graph:
            graph[name] = imports_of(name, text(name), sources)
        for other in graph[name] - seen:
            seen.add(other)
            todo.append(other)
    return seen


def imports_of(name, source, sources):
    """The package modules the module ``name`` (source text ``source``) imports, at any
    depth of its code: ``import a.b``, ``from .a import b`` (``b`` a module or a name of
    ``a``), ``from . import b``."""
    is_package = sources[name].endswith("__init__.py")
    package = name if is_package else name.rpartition(".")[0]
    found = set()
    for node in import_statements(source):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = absolute(node.module, node.level, package)
            targets = [base] + [f"{base}.{alias.name}" for alias in node.names]
        else:
            continue
        found.update(target for target in targets if target in sources)
    found.discard(name)
    return found


def import_statements(source):
    """The import statements of ``source`` (bytes), at any indentation: each line that
    starts with ``from`` or ``import``, with its continuation lines, parsed alone (some
    thirty times faster than parsing the whole module). A docstring's line that merely
    starts with those words does not parse and is skipped; one that does parse can only
    add a dependency, never hide one."""
    lines = source.decode("utf-8").splitlines()
    for number, line in enumerate(lines):
        statement = line.lstrip()
        if not statement.startswith(("from ", "import ")):
            continue
        while (statement.count("(") > statement.count(")") or statement.endswith("\\")) \
                and number + 1 < len(lines):
            number += 1
            statement += "\n" + lines[number]
        try:
            yield from ast.parse(statement).body
        except SyntaxError:
            continue


def absolute(module, level, package):
    """The dotted name that ``from <level dots><module> import`` means inside
    ``package``."""
    if level == 0:
        return module
    parts = package.split(".")
    parts = parts[:len(parts) - (level - 1)]
    return ".".join(parts + ([module] if module else []))


def digest_of(names, text):
    """A hash of the named modules' sources, in name order."""
    digest = hashlib.sha1()
    for name in sorted(names):
        digest.update(name.encode() + b"\0" + text(name) + b"\0")
    return digest.hexdigest()


def cache_dir_of(path):
    """The folder where Numba caches the kernels of the source file ``path``, found with
    Numba's own locators (``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the source if
    writable, else the user's cache folder); None if Numba could cache there nowhere."""
    from numba.core import caching
    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl   # renamed in 0.6x
    for locator in impl._locator_classes:
        found = locator.from_function(_probe, path)
        if found is not None:
            return found.get_cache_path()
    return None


def _probe():
    """A stand-in function for Numba's cache locators, which read only its line number."""


def drop_cached(path):
    """Delete the cached kernels of the module whose source is ``path`` (Numba names them
    ``<module>.<function>-<line>.pyXY[.N].nb[ic]``); returns whether any was."""
    folder = cache_dir_of(path)
    if folder is None or not os.path.isdir(folder):
        return False
    prefix = os.path.basename(path)[:-3] + "."
    removed = False
    for file in os.listdir(folder):
        if file.startswith(prefix) and file.endswith((".nbi", ".nbc")):
            try:
                os.remove(os.path.join(folder, file))
                removed = True
            except OSError:
                pass                         # another rank removed it first
    return removed


def manifest_file(root):
    """The manifest's path: beside the cache of the package's ``__init__.py``."""
    folder = cache_dir_of(os.path.join(root, "__init__.py"))
    return None if folder is None else os.path.join(folder, MANIFEST)


def read_manifest(path):
    """The manifest's content; empty if it is missing or unreadable (then every module
    that caches kernels counts as changed)."""
    try:
        with open(path, encoding="ascii") as handle:
            return json.load(handle)
    except (OSError, TypeError, ValueError):
        return {}


def write_manifest(path, content):
    """Write the manifest atomically (the ranks of one run check at once); a read-only
    install keeps none."""
    if path is None:
        return
    partial = f"{path}.{os.getpid()}"
    try:
        with open(partial, "w", encoding="ascii") as handle:
            json.dump(content, handle, indent=0, sort_keys=True)
        os.replace(partial, path)
    except OSError:
        pass
