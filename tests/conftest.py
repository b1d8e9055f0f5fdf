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
#: (setup, call and teardown summed per file from ``scripts/test.sh --durations=0``,
#: 2026-12-06, warm kernel caches; refresh when files are added or grow): only the
#: shares' balance depends on them
FILE_SECONDS = {
    "test_contact_cases.py": 224, "test_shape_functions.py": 86, "test_taylor_bar.py": 78,
    "test_sphere_rolling_fem.py": 78, "test_unchanged_answers.py": 71,
    "test_fem_bodies.py": 66, "test_apic.py": 57, "test_contact.py": 56,
    "test_contact_release.py": 53, "test_fem_bending.py": 47, "test_cli.py": 42,
    "test_fem_grid_coupling.py": 42, "test_tied.py": 41, "test_hertz.py": 36,
    "test_restart.py": 30, "test_matrix.py": 29, "test_surface_contact.py": 23,
    "test_forces.py": 22, "test_memory_estimate.py": 21, "test_energy_watch.py": 21,
    "test_fuzz.py": 19, "test_parallel.py": 19, "test_history_exact.py": 17,
    "test_surface_contact_impact.py": 16, "test_water_column.py": 16, "test_damage.py": 15,
    "test_lost_particles.py": 15, "test_output_lock.py": 14, "test_faults.py": 14,
    "test_probes.py": 14, "test_conversion_step.py": 13, "test_displacement.py": 13,
    "test_planar_shock.py": 13, "test_fixed_step.py": 11, "test_wall_friction.py": 11,
    "test_fem_mesh_input.py": 11, "test_restart_case.py": 10, "test_output_fields.py": 10,
    "test_conversion.py": 10, "test_hostile_input.py": 9, "test_wave_bar.py": 9,
    "test_frame_precision.py": 8, "test_post_plots.py": 8, "test_initial_fields.py": 7,
    "test_run_size.py": 7, "test_hexmesh.py": 7, "test_fem_stability.py": 6,
    "test_loads.py": 6, "test_warmup.py": 6, "test_fem_contact.py": 6, "test_force.py": 6,
    "test_surface_contact_search.py": 5, "test_body_kind_hooks.py": 4,
    "test_communication.py": 4, "test_fem_wave_bar.py": 3, "test_kernels.py": 3,
    "test_pic.py": 3, "test_frame_blocks.py": 3, "test_ogive_plate_fem.py": 3,
    "test_mirror.py": 3, "test_xdmf_empty.py": 3, "test_case.py": 2, "test_overlap.py": 2,
    "test_startup.py": 2, "test_bad_decomposition.py": 2, "test_geometry_input.py": 2,
    "test_rigid_free_particles.py": 2, "test_wedge.py": 1, "test_contact_search_cull.py": 1,
    "test_rigid_free.py": 1, "test_config.py": 1, "test_materials.py": 1, "test_io.py": 1,
    "test_progress.py": 1, "test_cache.py": 1, "test_registry.py": 1,
    "test_exact_sums.py": 1, "test_memory_setting.py": 1, "test_case_reference.py": 1,
    "test_fem_elements.py": 1, "test_face_match.py": 1, "test_kinds.py": 1,
    "test_store.py": 1, "test_exact_sum.py": 1, "test_work_weights.py": 1,
}
OTHER_FILE_SECONDS = 2


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
