"""Compile (or load) the step's kernels once before any test, for the hats and for the
default shape functions (with the APIC transfer's variants), so that the first
command-line test on a fresh clone does not spend its time limit in Numba.

``--shard I/N`` runs only the I-th of N shares of the test files (whole files, so a
module's fixtures run once), shared out by their measured cost: scripts/test.sh runs the
serial tests as one share per core side by side."""
import os

import pytest

from pmpm.kernels.warmup import warm_up_defaults

#: seconds per test file, serial tests in one process on a loaded 2-core machine (refresh
#: with ``pytest --durations=0``): only the shares' balance depends on them (two shares
#: on an idle machine: 1068 and 913 s)
FILE_SECONDS = {
    "test_contact_cases.py": 180, "test_taylor_bar.py": 175, "test_shape_functions.py": 140,
    "test_unchanged_answers.py": 125, "test_matrix.py": 115, "test_hertz.py": 95,
    "test_tied.py": 90, "test_apic.py": 60, "test_parallel.py": 50, "test_restart.py": 45,
    "test_fem_bodies.py": 40, "test_materials.py": 36, "test_fuzz.py": 35,
    "test_contact_release.py": 30, "test_surface_contact.py": 28, "test_case.py": 25,
    "test_fem_grid_coupling.py": 25, "test_water_column.py": 23, "test_conversion.py": 23,
    "test_contact.py": 22, "test_wave_bar.py": 16, "test_lost_particles.py": 16,
    "test_sphere_rolling_fem.py": 14, "test_ogive_plate_fem.py": 14,
    "test_wall_friction.py": 12, "test_fem_bending.py": 70,
    "test_surface_contact_search.py": 10, "test_damage.py": 20, "test_forces.py": 30,
    "test_geometry_input.py": 15, "test_frame_precision.py": 15, "test_displacement.py": 20,
    "test_rigid_free_particles.py": 40, "test_probes.py": 30, "test_post_plots.py": 15,
    "test_frame_blocks.py": 20, "test_warmup.py": 25,
}
OTHER_FILE_SECONDS = 5


def pytest_addoption(parser):
    parser.addoption("--shard", default=None, metavar="I/N",
                     help="run only the I-th (1-based) of N shares of the test files")


def pytest_sessionstart(session):
    warm_up_defaults()


def parse_shard(text):
    try:
        index, count = (int(part) for part in text.split("/"))
    except ValueError:
        index = count = 0
    if not 1 <= index <= count:
        raise pytest.UsageError(f"--shard {text!r}: give I/N with 1 <= I <= N, e.g. 1/2")
    return index, count


def share_files(files, count):
    """Longest first, each file to the share with the least so far: {file: share}."""
    loads, share = [0.0] * count, {}
    for name in sorted(files, key=lambda f: (-FILE_SECONDS.get(f, OTHER_FILE_SECONDS), f)):
        lightest = loads.index(min(loads))
        share[name] = lightest + 1
        loads[lightest] += FILE_SECONDS.get(name, OTHER_FILE_SECONDS)
    return share


def pytest_collection_modifyitems(config, items):
    text = config.getoption("--shard")
    if not text:
        return
    index, count = parse_shard(text)
    share = share_files({os.path.basename(item.fspath) for item in items}, count)
    kept = [item for item in items if share[os.path.basename(item.fspath)] == index]
    dropped = [item for item in items if share[os.path.basename(item.fspath)] != index]
    if dropped:
        config.hook.pytest_deselected(items=dropped)
    items[:] = kept
