"""The FE nodes' one-pass kernels (pmpm.fem.nodes, issue 25) against the whole-array
NumPy rules they replaced, to the bit: the velocity update with constraints, the grid
faces' conditions, and the force log's reactions per body support and per face."""
import numpy as np

from pmpm.fem.nodes import advance_and_hold, first_outside, hold_at_faces
from pmpm.solver.fem_bodies import face_arrays

#: a fixed face x-, slip faces z- and x+, a symmetry face y+ (as constrained_faces
#: lists them: axis, side, plane, fixed)
FACES = [(0, -1, 0.0, True), (0, 1, 4.0, False), (1, 1, 4.0, False), (2, -1, 0.0, False)]
TOL = 1e-9


def reference_hold(x, v, faces, movable, dt, tol):
    for d, side, plane, fixed in faces:
        gap = side * (plane - x[:, d])
        at = movable & (gap <= tol)
        if fixed:
            v[at] = 0.0
        else:
            v[at & ((gap >= -tol) | (side * v[:, d] > 0)), d] = 0.0
        if dt is not None:
            crossing = movable & ~at & (side * v[:, d] * dt > gap)
            v[crossing, d] = side * gap[crossing] / dt


def reference_face_of(faces, impulses, x, tol):
    out = np.full(impulses.shape, -1, np.int64)
    for d, side, _, _ in faces:
        out[side * impulses[:, d] < 0.0, d] = 2 * d + (side > 0)
    for d, side, plane, fixed in faces:
        if fixed:
            at = side * (plane - x[:, d]) <= tol
            for e in range(3):
                if e != d:
                    out[at & (out[:, e] < 0), e] = 2 * d + (side > 0)
    return out


def reference_step(x, v, force, mass, fixed_dof, movable, counted, body, dt, support,
                   face):
    before = v.copy()
    v[:] = np.where(fixed_dof, 0.0, v + force * (dt * (1.0 / mass))[:, None])
    free = v.copy()
    reference_hold(x, v, FACES, movable, dt, TOL)
    counted = counted & ((v != free).any(axis=1) | fixed_dof.any(axis=1))   # held nodes
    imp = mass[counted, None] * (v[counted] - before[counted]) - dt * force[counted]
    on_support = fixed_dof[counted].any(axis=1)
    np.add.at(support, body[counted][on_support], imp[on_support])
    face_of = reference_face_of(FACES, imp, x[counted], TOL)
    rest = ~on_support
    for d in range(3):
        faces = face_of[rest, d]
        hit = faces >= 0
        np.add.at(face[:, d], faces[hit], imp[rest, d][hit])


def nodes(n=4000, seed=3):
    """Nodes in and around the box [0, 4]^3, a quarter exactly on a face plane."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-0.2, 4.2, (n, 3))
    on = rng.integers(0, 3, n)
    snap = rng.random(n) < 0.25
    x[snap, on[snap]] = np.where(rng.random(snap.sum()) < 0.5, 0.0, 4.0)
    v = rng.normal(0.0, 50.0, (n, 3))
    force = rng.normal(0.0, 1e3, (n, 3))
    mass = rng.uniform(0.5, 2.0, n)
    fixed_dof = rng.random((n, 3)) < 0.05
    movable = rng.random(n) < 0.9
    counted = movable & (rng.random(n) < 0.8)
    body = rng.integers(0, 3, n).astype(np.int32)
    return x, v, force, mass, fixed_dof, movable, counted, body


def test_advance_and_hold_matches_the_numpy_rules_to_the_bit():
    x, v, force, mass, fixed_dof, movable, counted, body = nodes()
    dt = 2e-3
    v_ref, support_ref, face_ref = v.copy(), np.zeros((3, 3)), np.zeros((6, 4))
    reference_step(x, v_ref, force, mass, fixed_dof, movable, counted, body, dt,
                   support_ref, face_ref)
    support, face = np.zeros((3, 3)), np.zeros((6, 4))
    advance_and_hold(x, v, force, mass, fixed_dof, movable, *face_arrays(FACES), dt, TOL,
                     True, counted, body, support, face)
    assert np.array_equal(v, v_ref)
    assert np.array_equal(support, support_ref)
    assert np.array_equal(face, face_ref)
    assert np.count_nonzero(face[:, :3]) >= 6 and np.count_nonzero(support) == 9


def test_nodes_that_nothing_holds_give_no_reaction():
    """Free nodes inside the box: m (v - v_before) - dt f is round-off for them (it was
    summed into the faces' reactions before), and the log now adds nothing."""
    x, v, force, mass, _, _, counted, body = nodes(seed=11)
    x = np.clip(x, 1.0, 3.0)
    n = len(x)
    support, face = np.zeros((3, 3)), np.zeros((6, 4))
    advance_and_hold(x, v, force, mass, np.zeros((n, 3), np.bool_), np.ones(n, np.bool_),
                     *face_arrays(FACES), 1e-4, TOL, True, counted, body, support, face)
    assert not support.any() and not face.any()


def test_without_a_force_log_the_velocities_are_the_same_and_nothing_is_summed():
    x, v, force, mass, fixed_dof, movable, counted, body = nodes(seed=5)
    logged, support, face = v.copy(), np.zeros((3, 3)), np.zeros((6, 4))
    advance_and_hold(x, logged, force, mass, fixed_dof, movable, *face_arrays(FACES),
                     1e-3, TOL, True, counted, body, support, face)
    empty = np.zeros((0, 3))
    advance_and_hold(x, v, force, mass, fixed_dof, movable, *face_arrays(FACES), 1e-3,
                     TOL, False, counted, body, empty, empty)
    assert np.array_equal(v, logged)


def test_hold_at_faces_without_a_step_matches_the_numpy_rule():
    x, v, _, _, _, movable, _, _ = nodes(seed=7)
    ref = v.copy()
    reference_hold(x, ref, FACES, movable, None, TOL)
    hold_at_faces(x, v, movable, *face_arrays(FACES), 0.0, TOL)
    assert np.array_equal(v, ref)
    assert not np.array_equal(v, nodes(seed=7)[1])      # some node was held


def test_first_outside_is_the_first_node_beyond_the_box():
    x = np.full((5, 3), 2.0)
    lo, hi = np.zeros(3), np.full(3, 4.0)
    assert first_outside(x, lo, hi, TOL) == -1
    x[3, 2] = 4.0 + 0.5 * TOL                          # on the face within tolerance
    assert first_outside(x, lo, hi, TOL) == -1
    x[4, 1], x[2, 0] = -1.0, 4.1
    assert first_outside(x, lo, hi, TOL) == 2
