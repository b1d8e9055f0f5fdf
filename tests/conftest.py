"""Compile (or load) the step's kernels once before any test, for the hats and for the
default shape functions (with the APIC transfer's variants), so that the first
command-line test on a fresh clone does not spend its time limit in Numba.

``--shard I/N`` runs only the I-th of N shares of the test files (whole files, so a
module's fixtures run once), shared out by their measured cost: scripts/test.sh runs the
serial tests as one share per core side by side."""
import os

import pytest

from pmpm.kernels.warmup import warm_up_defaults

#: seconds per test file with both shares running side by side on the 2-core machine
#: (from ``pytest --durations=100`` of each share, 2026-12-03; refresh when files are
#: added): only the shares' balance depends on them
FILE_SECONDS = {
    "test_contact_cases.py": 369, "test_shape_functions.py": 168, "test_taylor_bar.py": 148,
    "test_apic.py": 113, "test_fem_bodies.py": 89, "test_tied.py": 84,
    "test_contact.py": 80, "test_hertz.py": 76, "test_matrix.py": 69,
    "test_fem_bending.py": 64, "test_parallel.py": 62, "test_contact_release.py": 57,
    "test_output_lock.py": 53, "test_ogive_plate_fem.py": 52, "test_unchanged_answers.py": 52,
    "test_water_column.py": 42, "test_conversion.py": 41, "test_wall_friction.py": 39,
    "test_energy_watch.py": 38, "test_materials.py": 36.0, "test_restart.py": 36,
    "test_forces.py": 35, "test_probes.py": 35, "test_fem_grid_coupling.py": 34,
    "test_fuzz.py": 33, "test_surface_contact.py": 31, "test_lost_particles.py": 26,
    "test_case.py": 25.0, "test_cli.py": 22, "test_frame_precision.py": 20,
    "test_post_plots.py": 20, "test_wave_bar.py": 18, "test_damage.py": 17,
    "test_memory_estimate.py": 16, "test_sphere_rolling_fem.py": 16, "test_hostile_input.py": 15,
    "test_geometry_input.py": 15.0, "test_fem_mesh_input.py": 14, "test_hexmesh.py": 12,
    "test_faults.py": 12, "test_surface_contact_search.py": 12, "test_pic.py": 12,
    "test_frame_blocks.py": 12, "test_force.py": 11, "test_fem_contact.py": 10,
    "test_displacement.py": 10, "test_fem_wave_bar.py": 9, "test_communication.py": 8,
    "test_run_size.py": 8, "test_output_fields.py": 6, "test_warmup.py": 6,
    "test_loads.py": 5, "test_rigid_free_particles.py": 5, "test_surface_contact_impact.py": 5,
    "test_fixed_step.py": 5, "test_startup.py": 3,
    # files the table lacked, from the 2026-12-04 run scaled to the table's (its shares
    # ran beside other jobs, 1.33 times slower over the files both have)
    "test_planar_shock.py": 31, "test_restart_case.py": 21, "test_conversion_step.py": 20,
    "test_initial_fields.py": 14, "test_fem_stability.py": 8,
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
