"""The general hooks a transfer of material between body kinds uses (issue 24 Sec. 1):
the FEM kind's removal of elements, which raises ``elements_changed`` for the couplings
that keep the mesh's free faces; the particle kind's ``add_particles``; and the warm-up's
kernels, declared by the registry's parts rather than named in the warm-up. None of
these knows the conversion rule that uses them (pmpm.solver.conversion)."""
import os

import numpy as np
import pytest

from runhelp import CASES, RUNS, set_up
from test_conversion import TAYLOR, free_faces_from_scratch


def test_removing_elements_takes_their_mass_off_and_raises_the_event_once():
    """Elements taken out of the mesh with no rule at all: their mass leaves the nodes
    (all of it, to round-off), the nodes no element uses go, the kind raises
    ``elements_changed`` once, and through it surface contact's segments become the
    free faces of what is left."""
    sim = set_up(TAYLOR)
    fem = sim.elements
    heard = []
    fem.when_elements_change(lambda: heard.append(fem.n_elements))
    mass, n_nodes = fem.mass.sum(), len(fem.x)
    chosen = fem.centroids()[:, 2] < 3.0
    removed = fem.element_mass[chosen].sum()
    fem.remove_elements(chosen)
    assert heard == [fem.n_elements] and 0 < fem.n_elements < len(chosen)
    assert abs(fem.mass.sum() - (mass - removed)) < 1e-13 * mass
    assert len(fem.x) < n_nodes and np.all(fem.mass > 0)
    segments = {tuple(r) for r in np.sort(fem.node_id[sim.surface.face_nodes], axis=1)}
    assert segments == free_faces_from_scratch(fem)


def test_particles_handed_over_are_appended_whole():
    from pmpm.particles.store import COLUMNS, empty_column
    sim = set_up(TAYLOR)
    points = sim.points
    columns = {name: empty_column(name, 3) for name in COLUMNS}
    columns["id"][:] = [7, 8, 9]
    columns["mass"][:] = 1.0
    assert points.add_particles(columns) == 3
    assert points.n == 3 and list(points.particles.id) == [7, 8, 9]
    assert points.particles.mass.sum() == 3.0


#: FEM cases and the parts each builds: surface contact, node contact, grid coupling,
#: conversion (whose particles meet the mesh through surface contact), the force log
HOOK_CASES = [os.path.join(CASES, name) for name in
              ("fem_taylor_convert.yaml", "striker_on_fem_bar.yaml",
               "fem_block_on_fem_plate.yaml", "fem_grid_bounce.yaml",
               "rigid_particle_on_fem_plate.yaml")] + \
    [os.path.join(RUNS, "ogive_plate_fem.yaml")]


#: the perforation as the paper's AFEMP: both bodies and their converted particles on
#: the grid (no surface contact built)
AFEMP = [os.path.join(RUNS, "ogive_plate_fem.yaml"), "contact.coupling=grid",
         "contact.method=1"]


@pytest.mark.parametrize("case", HOOK_CASES + [AFEMP],
                         ids=lambda c: os.path.basename(c) if isinstance(c, str) else "afemp")
def test_the_warm_up_takes_the_kernels_of_every_part_the_case_builds(case):
    """Every part the simulation builds whose entry declares kernels declares them for
    this case (and the warm-up's keywords say so), and the FEM kind's kernels are
    taken: what a part would call in the steps is compiled before them."""
    from pmpm.kernels.warmup import ALL_COUPLINGS, kernels_of
    from pmpm.solver.registry import PARTS, no_kernels
    sim = set_up(case) if isinstance(case, str) else set_up(case[0], case[1:])
    config = sim.config
    keywords = kernels_of(config)
    assert set(ALL_COUPLINGS) <= set(keywords) and keywords["fem"]
    checked = 0
    for entry in PARTS:
        if entry.warms is no_kernels or entry.name not in sim.parts:
            continue
        declared = entry.warms(config)
        assert declared and all(keywords[name] for name in declared), entry.name
        checked += 1
    assert checked > 0


def test_conversion_alone_asks_for_surface_contact_and_its_kernels():
    """An FEM body alone, whose elements may become particles: no particle body and no
    surface coupling named, yet surface contact is built and warmed (its particles meet
    what is left of the mesh), and the body's particles take the spacing of the
    elements' sub-cells."""
    from pmpm.kernels.warmup import kernels_of
    sim = set_up(TAYLOR)
    assert kernels_of(sim.config)["surface"] and sim.surface is not None
    assert sim.bodies.born_spacing[0] == pytest.approx(1.52 / 2 / 1.52)
    assert sim.bodies.half_width[0] == 0.5 * sim.bodies.born_spacing[0]
