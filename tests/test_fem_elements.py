"""The hexahedron kernels of pmpm.fem: the mean gradient against Gauss quadrature, the
patch test, rigid rotation, hourglass control, lumped masses, the stable time step."""
import numpy as np
import pytest

from pmpm.fem.elements import (STIFFNESS, VISCOUS, ElementMesh, Hourglass, element_forces,
                               lumped_masses)
from pmpm.fem.hexahedron import FACES, HOURGLASS, element_geometry, element_volumes
from pmpm.kernels.records import BodyMaterials
from pmpm.materials import layout
from pmpm.materials.state import MaterialState

#: natural coordinates of the VTK-ordered nodes
CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], np.float64)
E, RHO = 1.0e5, 5.0e-3


def unit_cube(size=1.0):
    return 0.5 * size * (CORNERS + 1.0)


def distorted(seed=1):
    """A cube with every node moved by up to 15 % of its edge (still valid)."""
    rng = np.random.default_rng(seed)
    return unit_cube(2.0) + 0.3 * rng.uniform(-1, 1, (8, 3))


def shape_gradients(xi):
    """dN_I/dxi_a (8, 3) of the trilinear shape functions at ``xi``."""
    g = np.empty((8, 3))
    for a in range(3):
        factors = [1 + CORNERS[:, d] * xi[d] for d in range(3)]
        factors[a] = CORNERS[:, a]
        g[:, a] = factors[0] * factors[1] * factors[2] / 8.0
    return g


def quadrature_mean_gradient(xe):
    """Volume integral of dN_I/dx over the element by 2x2x2 Gauss points (exact: the
    integrand is at most quadratic in each natural coordinate)."""
    total, volume = np.zeros((8, 3)), 0.0
    for gp in CORNERS / np.sqrt(3.0):
        dn = shape_gradients(gp)
        jac = xe.T @ dn                      # dx_i / dxi_a
        det = np.linalg.det(jac)
        total += dn @ np.linalg.inv(jac) * det
        volume += det
    return total, volume


def geometry(xe):
    b = np.empty((8, 3))
    volume, area = element_geometry(np.ascontiguousarray(xe), b)
    return b, volume, area


def materials(model=layout.ELASTIC):
    prm = np.zeros((1, layout.N_SLOTS))
    prm[0, [layout.RHO0, layout.E, layout.NU, layout.G, layout.K]] = [RHO, E, 0.25,
                                                                       E / 2.5, E / 1.5]
    return BodyMaterials(np.array([model], np.int64), prm, np.zeros(1, np.bool_))


def one_element_state():
    return MaterialState(np.zeros((1, 6)), np.eye(3).reshape(1, 9).copy(), np.full(1, RHO),
                         np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1),
                         np.zeros(1))


def run_element(xe, ve, kind=VISCOUS, dt=1e-6, coefficient=0.1, mat=None):
    """One call of element_forces on one element; returns (forces, state, hourglass,
    rate, bad)."""
    mesh = ElementMesh(np.ascontiguousarray(xe), np.ascontiguousarray(ve),
                       np.arange(8, dtype=np.int64)[None, :], np.zeros(1, np.int32))
    mat = mat or one_element_state()
    hg = Hourglass(np.array([kind], np.int64), np.array([coefficient]), np.zeros((1, 12)),
                   np.zeros(1))
    force = np.zeros((8, 3))
    rate, bad, _ = element_forces(mesh, mat, materials(), hg, dt, force)
    return force, mat, hg, rate, bad


def test_mean_gradient_is_the_volume_integral_of_the_shape_gradients():
    for seed in range(3):
        xe = distorted(seed)
        b, volume, _ = geometry(xe)
        exact, exact_volume = quadrature_mean_gradient(xe)
        assert volume == pytest.approx(exact_volume, rel=1e-12)
        assert np.abs(b - exact).max() < 1e-12 * np.abs(exact).max()


def test_patch_test_linear_velocity_gives_the_exact_gradient():
    """b sums to zero and sum x_I (x) b_I = V I, so any linear field v = A x + c gives
    L = A exactly, on a distorted element too."""
    xe = distorted(7)
    b, volume, _ = geometry(xe)
    assert np.abs(b.sum(axis=0)).max() < 1e-13
    assert np.abs(xe.T @ b / volume - np.eye(3)).max() < 1e-13
    grad = np.array([[0.3, -1.0, 0.2], [0.5, 0.1, -0.7], [-0.4, 0.9, 0.6]])
    ve = xe @ grad.T + np.array([2.0, -1.0, 0.5])
    assert np.abs(ve.T @ b / volume - grad).max() < 1e-13


def test_volume_and_characteristic_length_of_a_brick():
    xe = unit_cube() * np.array([2.0, 1.0, 0.5])
    b, volume, area = geometry(xe)
    assert volume == pytest.approx(1.0, rel=1e-14)
    assert area == pytest.approx(2.0, rel=1e-14)       # the 2 x 1 face
    inverted = xe[[4, 5, 6, 7, 0, 1, 2, 3]]
    volumes = np.empty(2)
    element_volumes(np.concatenate([xe, inverted]),
                    np.array([np.arange(8), 8 + np.arange(8)], np.int64), volumes)
    assert volumes == pytest.approx([1.0, -1.0], rel=1e-14)


def test_uniform_stress_gives_the_face_tractions():
    """sigma_xx = s (tension) on a unit cube pulls each node of the x+ face by -s/4
    along x and each of the x- face by +s/4: the element's force on its nodes, which a
    traction of s on each face would balance."""
    xe = unit_cube()
    mat = one_element_state()
    mat.stress[0, 0] = 3.0
    force, *_ = run_element(xe, np.zeros((8, 3)), dt=0.0, mat=mat)
    plus = xe[:, 0] > 0.5
    assert force[plus, 0] == pytest.approx(np.full(4, -0.75), rel=1e-13)
    assert force[~plus, 0] == pytest.approx(np.full(4, 0.75), rel=1e-13)
    assert np.abs(force[:, 1:]).max() < 1e-14


@pytest.mark.parametrize("kind", [VISCOUS, STIFFNESS])
def test_rigid_rotation_gives_no_stress_and_no_hourglass_work(kind):
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        xe = distorted(11) @ q.T + rng.normal(size=3)
        spin = rng.normal(size=3)
        w = np.array([[0, -spin[2], spin[1]], [spin[2], 0, -spin[0]], [-spin[1], spin[0], 0]])
        force, mat, hg, _, bad = run_element(xe, xe @ w.T + 1.0, kind, dt=1e-3)
        assert bad == -1
        assert np.abs(mat.stress).max() < 1e-10 * E * 1e-3
        # round-off only: a unit hourglass rate would give resist ~ dt k E = 1e1
        assert abs(hg.energy[0]) < 1e-25 and np.abs(hg.resist).max() < 1e-12
        assert np.abs(force).max() < 1e-10


@pytest.mark.parametrize("kind", [VISCOUS, STIFFNESS])
def test_hourglass_work_is_zero_for_uniform_deformation_and_positive_for_a_mode(kind):
    xe = distorted(5)
    uniform = xe @ np.array([[1e-2, 2e-3, 0], [0, -3e-3, 1e-3], [4e-3, 0, 5e-3]]).T
    _, _, hg, _, _ = run_element(xe, uniform, kind, coefficient=0.1)
    assert abs(hg.energy[0]) < 1e-22
    mode = np.zeros((8, 3))
    mode[:, 0] = 1e-2 * HOURGLASS[2]                 # the xi-eta hourglass mode along x
    force, _, hg, _, _ = run_element(unit_cube(), mode, kind, coefficient=0.1)
    assert hg.energy[0] > 0
    assert np.einsum("ij,ij->", force, mode) < 0     # the force resists the mode
    assert np.abs(force.sum(axis=0)).max() < 1e-15   # and is self-balanced


def test_stable_rate_of_a_brick_bounds_its_modes_with_the_viscous_hourglass_damping():
    """A 1 x 1 x 0.25 brick, nu = 0.25, viscous hourglass k = 0.1 (issue 27: c / L_e of
    before, 4 c, was below its undamped omega_max / 2 = 4.03 c): omega^2 <= 8 (lambda S + 2 G beta) /
    (rho V^2) with S = sum |b_I|^2 = 9/16 and beta = 1/2 the largest of sum b_I b_I^T;
    damping eta = 2 k c 8 / V^(1/3); rate = (eta / 2 + sqrt(omega^2 + eta^2 / 4)) / 2."""
    xe = unit_cube() * np.array([1.0, 1.0, 0.25])
    _, mat, _, rate, _ = run_element(xe, np.zeros((8, 3)), dt=0.0)
    g, lam = E / 2.5, E / 1.5 - 2 * E / 7.5
    c = np.sqrt((E / 1.5 + 4 * E / 7.5) / RHO)        # K + 4G/3 with nu = 0.25
    volume = 0.25
    omega2 = 8 * (lam * 9 / 16 + 2 * g / 2) / (RHO * volume ** 2)
    eta = 2 * 0.1 * c * 8 / volume ** (1 / 3)
    assert rate == pytest.approx(0.5 * (0.5 * eta + np.sqrt(omega2 + 0.25 * eta ** 2)),
                                 rel=1e-12)


def test_inverted_element_is_a_fault_and_lumped_mass_sums_to_rho_v():
    xe = distorted(2)
    *_, bad = run_element(xe[[4, 5, 6, 7, 0, 1, 2, 3]], np.zeros((8, 3)))
    assert bad == 0
    hexes = np.array([np.arange(8), np.arange(4, 12)], np.int64)
    x = np.concatenate([unit_cube(), unit_cube()[4:] + [0, 0, 1.0]])
    volumes = np.empty(2)
    element_volumes(x, hexes, volumes)
    mass = np.empty(12)
    lumped_masses(hexes, volumes, np.array([RHO, 2 * RHO]), mass)
    assert mass.sum() == pytest.approx(3 * RHO, rel=1e-14)
    assert mass[4:8] == pytest.approx(np.full(4, 3 * RHO / 8), rel=1e-14)


def test_faces_point_outward():
    """Each face's corner cross product points away from the element's centre."""
    xe = distorted(4)
    centre = xe.mean(axis=0)
    for face in FACES:
        p = xe[face]
        normal = np.cross(p[2] - p[0], p[3] - p[1])
        assert normal @ (p.mean(axis=0) - centre) > 0


def test_stiffness_resistance_turns_with_the_spin():
    """A spinning element (v = W x, no hourglass rate) keeps the length of its stored
    hourglass forces and turns them by W dt."""
    xe = distorted(9)
    w = np.array([[0, -2.0, 1.0], [2.0, 0, -0.5], [-1.0, 0.5, 0]])
    mesh = ElementMesh(xe, xe @ w.T, np.arange(8, dtype=np.int64)[None, :],
                       np.zeros(1, np.int32))
    resist = np.arange(1.0, 13.0)[None, :].copy()
    hg = Hourglass(np.array([STIFFNESS], np.int64), np.array([0.05]), resist, np.zeros(1))
    dt = 1e-4
    element_forces(mesh, one_element_state(), materials(), hg, dt, np.zeros((8, 3)))
    before = np.arange(1.0, 13.0).reshape(4, 3)
    after = hg.resist.reshape(4, 3)
    assert np.abs(after - (before + dt * before @ w.T)).max() < 1e-12 * 12
    assert np.linalg.norm(after, axis=1) == pytest.approx(np.linalg.norm(before, axis=1),
                                                           rel=1e-7)


def largest_frequency(coefficient):
    """omega_max h / c of one free unit cube with lumped masses, its stiffness (elastic,
    nu = 0.25, stiffness hourglass form) from the kernel by finite differences: one step
    of dt = 1 from rest with velocities u is the force of the displacement u."""
    def force(u):
        hg = Hourglass(np.array([STIFFNESS], np.int64), np.array([coefficient]),
                       np.zeros((1, 12)), np.zeros(1))
        f = np.zeros((8, 3))
        mesh = ElementMesh(unit_cube(), u.reshape(8, 3).copy(),
                           np.arange(8, dtype=np.int64)[None, :], np.zeros(1, np.int32))
        element_forces(mesh, one_element_state(), materials(), hg, 1.0, f)
        return f.ravel()
    eps = 1e-9
    stiffness = np.array([-force(eps * unit) / eps for unit in np.eye(24)]).T
    omega2 = np.linalg.eigvalsh(0.5 * (stiffness + stiffness.T)) / (RHO / 8)
    c = np.sqrt((E / 1.5 + 4 * E / 7.5) / RHO)
    return np.sqrt(omega2.max()) / c


def test_stiffness_hourglass_control_keeps_the_stable_step_up_to_k_01():
    """The hourglass modes stay below the element's fastest physical mode (with nu =
    0.25 that is 2.58 c / h on one free cube: the step L_e / c is stable there for cfl
    below 0.77)."""
    physical = largest_frequency(0.0)
    assert physical == pytest.approx(2.582, abs=1e-3)
    assert largest_frequency(0.1) == pytest.approx(physical, rel=1e-6)
    assert largest_frequency(0.3) > 1.1 * physical     # a stiffer control would reduce it


def copper_block(n, kind, alternate):
    """n^3 distorted copper elements (Johnson-Cook + Mie-Grueneisen + bulk viscosity)
    with random velocities, as two bodies with identical materials: all elements in
    body 0, or (``alternate``) every other one in body 1, so that no block of
    pmpm.fem.lanes.LANES elements has a single body and every element goes through the
    scalar path."""
    from pmpm.materials.catalog import pack
    rng = np.random.default_rng(5)
    idx = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)
    x = 0.5 * np.indices((n + 1,) * 3).reshape(3, -1).T
    x += 0.04 * rng.uniform(-1, 1, x.shape)
    i, j, k = np.indices((n, n, n)).reshape(3, -1)
    hexes = np.stack([idx[i + a, j + b, k + c] for a, b, c in CORNERS.clip(0).astype(int)],
                     axis=1).astype(np.int64)
    v = np.array([0.0, 0.0, -190.0]) + 20.0 * rng.normal(size=x.shape)
    code, row = pack({"model": "johnson_cook", "density": 8.93e-3, "E": 117.0e3, "nu": 0.35,
                      "A": 157.0, "B": 425.0, "n": 1.0,
                      "eos": {"type": "mie_gruneisen", "c0": 3940.0, "s": 1.49,
                              "gamma0": 1.96},
                      "bulk_viscosity": {"quadratic": 1.5, "linear": 0.06}})
    m = len(hexes)
    body = (np.arange(m) % 2 if alternate else np.zeros(m)).astype(np.int32)
    bodies = BodyMaterials(np.array([code, code], np.int64), np.stack([row, row]),
                           np.zeros(2, np.bool_))
    state = MaterialState(np.zeros((m, 6)), np.tile(np.eye(3).ravel(), (m, 1)),
                          np.full(m, row[layout.RHO0]), np.zeros(m), np.zeros(m),
                          np.full(m, 293.0), np.zeros(m), np.zeros(m), np.zeros(m))
    hg = Hourglass(np.array([kind, kind], np.int64), np.array([0.1, 0.1]), np.zeros((m, 12)),
                   np.zeros(m))
    return ElementMesh(x, v, hexes, body), state, bodies, hg


@pytest.mark.parametrize("kind", [VISCOUS, STIFFNESS])
def test_lane_blocks_give_the_scalar_paths_answers_to_the_bit(kind):
    """Blocks of one body go lane by lane (SIMD, pmpm.fem.lanes), mixed blocks element by
    element; both must do each element's arithmetic in the same order: forces, rates,
    contributions, material state and hourglass columns over a few yielding steps equal
    to the bit (7^3 = 343 elements: 21 full blocks and a partial one)."""
    runs = []
    for alternate in (False, True):
        mesh, state, bodies, hg = copper_block(7, kind, alternate)
        m = len(mesh.hexes)
        outputs = []
        for _ in range(4):
            force, rates, parts = np.zeros_like(mesh.x), np.zeros(m), np.zeros((m, 8, 3))
            rate, bad, why = element_forces(mesh, state, bodies, hg, 2e-5, force, rates,
                                            parts, np.arange(m))
            assert bad == -1
            outputs += [np.array([rate]), force, rates, parts]
            mesh.x[:] += 2e-5 * mesh.v
        runs.append(outputs + list(state) + [hg.resist, hg.energy])
    assert runs[0][-1].max() > 0.0 and runs[0][4 * 4 + 3].max() > 0.0   # energy, eps_p
    for lanes_path, scalar_path in zip(*runs):
        assert np.array_equal(lanes_path, scalar_path)


def test_the_volumes_from_the_faces_are_the_mean_gradients_to_round_off():
    """FemBodies.volumes (the conversion check's, every step) takes each element's volume
    from its faces: exact for the trilinear hexahedron, as the mean gradient's."""
    from pmpm.fem.hexahedron import boundary_volumes, element_volumes
    cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                     [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], np.float64)
    rng = np.random.default_rng(7)
    m = 2000
    x = (cube[None] + 0.3 * rng.standard_normal((m, 8, 3))).reshape(-1, 3)
    x[:3 * 8] *= -1.0                           # three elements turned inside out
    hexes = np.arange(8 * m, dtype=np.int64).reshape(m, 8)
    by_gradient, by_faces = np.empty(m), np.empty(m)
    element_volumes(x, hexes, by_gradient)
    boundary_volumes(x, hexes, by_faces)
    assert (by_gradient[:3] < 0).all()
    np.testing.assert_allclose(by_faces, by_gradient, rtol=0, atol=1e-14)
