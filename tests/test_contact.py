"""Multi-velocity grid contact (seed 001 Secs. 2-4): friction against the closed form,
momentum conservation, no interpenetration, the stick limit, and bad input."""
import csv
import json
import os

import numpy as np
import pytest
import yaml

from pmpm.case import CaseError, load_case
from pmpm.kernels import contact as kc
from pmpm.kernels.boundary import fill_face_codes
from pmpm.kernels.records import ContactSlots, NodeBlock, PairRules
from pmpm.post import read_frame
from runhelp import CASES, run_pmpm

SLIDING = os.path.join(CASES, "sliding_block.yaml")
BLOCKS = os.path.join(CASES, "two_blocks.yaml")
BLOCK_MASS = 1000.0 * 0.02 ** 3                 # each cube of two_blocks.yaml (kg)
NO_CHECK = np.full((2, 2), np.inf)              # no separation check (seed 001 Sec. 2.2)


def node_block(shape, lo, strides, n_cells, bc):
    faces = np.zeros(int(np.prod(shape)), np.uint16)
    fill_face_codes(shape, lo, strides, n_cells, bc, np.zeros(6), faces)
    return NodeBlock(shape, lo, strides, n_cells, bc, faces, np.zeros(6))


def contact_start(cnodal, slots, gvel, master, separation, rigid, method, m_tiny, shape, lo,
                  strides, n_cells, bc, cvel, cnorm, flat=0.0):
    """kc.contact_start with its records built from plain arrays."""
    record = ContactSlots(cnodal, slots, cvel, cnorm, np.zeros((0, 1, 3)), np.zeros((0, 1, 6)))
    rules = PairRules(master, np.zeros(master.shape), separation)
    kc.contact_start(record, gvel, rules, rigid, method, m_tiny,
                     node_block(shape, lo, strides, n_cells, bc), flat)


def contact_end(cnodal, cvel, cnorm, cforce, slots, gvel, gnew, friction, separation, rigid,
                skip, dt, m_tiny, shape, lo, strides, n_cells, bc, cnew, start_share=0.0):
    """kc.contact_end with its records built from plain arrays."""
    record = ContactSlots(cnodal, slots, cvel, cnorm, cforce, cnew)
    rules = PairRules(np.full(friction.shape, -1, np.int64), friction, separation)
    kc.contact_end(record, gvel, gnew, rules, rigid, skip, dt, m_tiny,
                   node_block(shape, lo, strides, n_cells, bc),
                   np.full(cnodal.shape[1], float(start_share)))


ONE_NODE = (np.array([1, 1, 1]), np.zeros(3, np.int64), np.array([1, 1, 1]),
            np.array([10 ** 6] * 3), np.zeros(6, np.int64))


@pytest.mark.parametrize("master", [1, -1])
def test_release_rule_takes_the_normal_of_the_body_that_has_a_surface_at_the_node(master):
    """A node inside body 1 (its mass gradient is round-off, here along x) that the
    outermost particles of body 0 reach, whose surface faces -z there: seed 001's
    normals follow body 1's round-off; under the release rule (flat = kc.FLAT) both
    bodies take body 0's normal, whether body 1 is the pair's master or the normals are
    averaged."""
    cnodal = np.zeros((1, 2, kc.CNODAL))
    cnodal[0, :, 0] = [0.01, 1.0]                         # body 0's fringe, body 1 inside
    cnodal[0, 0, 4:7] = [0.0, 0.0, -0.05]
    cnodal[0, 1, 4:7] = [3e-12, 0.0, 1e-13]
    masters = np.full((2, 2), master)
    found = {}
    for flat in (0.0, kc.FLAT):
        cvel, cnorm = np.empty((1, 2, 3)), np.empty((1, 2, 3))
        contact_start(cnodal, np.arange(1), np.zeros((1, 3)), masters, NO_CHECK,
                      np.zeros(2, np.bool_), 1, 0.0, *ONE_NODE, cvel, cnorm, flat)
        found[flat] = cnorm[0].copy()
    assert np.allclose(found[kc.FLAT], [[0, 0, -1], [0, 0, 1]])
    assert abs(found[0.0][1, 0]) > 0.5                   # seed 001: along the round-off


@pytest.mark.parametrize("start_share", [0.0, 0.5, 1.0])
def test_friction_is_limited_by_the_normal_change_the_body_keeps(start_share):
    """Method 2: body 0 slides at 3 along x while approaching at 1 along +z; the start
    correction (Eq. 25) takes the approach out, the step's forces make 0.5 of new
    approach and the end correction takes that out. Coulomb friction mu = 0.2 then
    takes mu times the end correction's normal change (0.5) plus the share of the start
    correction's (1) that reaches the body's velocities: all of it under APIC, none
    under FLIP (seed 001's limit), a FLIP/PIC blend's PIC fraction."""
    mu, dt = 0.2, 1.0
    cnodal = np.zeros((1, 2, kc.CNODAL))
    cnodal[0, :, 0] = 1.0
    cnodal[0, 0, 1:4] = [3.0, 0.0, 1.0]
    cnodal[0, 1, 1:4] = [0.0, 0.0, -1.0]
    cnodal[0, 0, 4:7] = [0.0, 0.0, 1.0]
    cnodal[0, 1, 4:7] = [0.0, 0.0, -1.0]
    gvel = np.array([[1.5, 0.0, 0.0]])
    gnew = np.array([[1.5, 0.0, 0.0, 0.0, 0.0, 0.0]])
    cforce = np.array([[[0.0, 0.0, 0.5], [0.0, 0.0, -0.5]]])
    cvel, cnorm, cnew = np.empty((1, 2, 3)), np.empty((1, 2, 3)), np.empty((1, 2, 6))
    rigid = np.zeros(2, np.bool_)
    contact_start(cnodal, np.arange(1), gvel, np.full((2, 2), -1), NO_CHECK, rigid, 2, 0.0,
                  *ONE_NODE, cvel, cnorm)
    contact_end(cnodal, cvel, cnorm, cforce, np.arange(1), gvel, gnew, np.full((2, 2), mu),
                NO_CHECK, rigid, False, dt, 0.0, *ONE_NODE, cnew, start_share)
    change = cnew[0, 0, :3] - cnodal[0, 0, 1:4] - cforce[0, 0] * dt   # contact's alone
    assert change[2] == pytest.approx(-1.5)
    assert -change[0] == pytest.approx(mu * (0.5 + start_share))


def history(out):
    with open(os.path.join(out, "history.csv"), encoding="utf-8") as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


@pytest.mark.parametrize("method", [1, 2])
def test_coulomb_friction_decelerates_a_sliding_block_at_mu_g(tmp_path, method):
    """Eq. 22 with the flat plate's normal (Sec. 2.3 choice 2): v(t) = v0 - mu g t,
    within 2.5 % of v0 at every history row (mu = 0.2, g = 10, v0 = 1 m/s, t <= 0.3 s)."""
    run_pmpm(SLIDING, tmp_path, sets=[f"contact.method={method}",
                                      "contact.pairs=[{bodies: [plate, block], normal: plate}]"])
    rows = history(tmp_path)
    error = max(abs(r["block.vx"] - (1.0 - 0.2 * 10.0 * r["time"])) for r in rows)
    assert rows[-1]["time"] == pytest.approx(0.3)
    assert error < 0.025          # elastic bodies settling under gravity: not rigid
    friction_work_closes_the_balance(tmp_path, rows)


def friction_work_closes_the_balance(out, rows):
    """The friction work (history.csv's dissipated = forces.csv's plate/block.dissipated)
    is mu m g times the distance the block slid, within 2 % (measured -0.6 % with
    method 1, -0.08 % with method 2), and with it kinetic + internal + dissipated - the
    work of gravity stays within 2 % of the energy the bodies were given at every row
    (measured 1.2 % and 0.03 %; without it 84 % goes unaccounted by the end)."""
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        m = {name: b["mass"] for name, b in json.load(f)["bodies"].items()}
    forces = np.genfromtxt(os.path.join(out, "forces.csv"), delimiter=",", names=True,
                           deletechars="")
    first, last = rows[0], rows[-1]
    slid = last["block.x"] - first["block.x"]
    assert last["dissipated"] == pytest.approx(0.2 * 10.0 * m["block"] * slid, rel=0.02)
    assert forces["plate/block.dissipated"][-1] == pytest.approx(last["dissipated"],
                                                                 rel=1e-12)
    for r in rows:
        fell = sum(m[b] * (r[f"{b}.z"] - first[f"{b}.z"]) for b in ("plate", "block"))
        balance = r["total"] + r["dissipated"] + 10.0 * fell - first["total"]
        assert abs(balance) < 0.02 * first["total"], r["time"]


def test_without_friction_the_block_keeps_its_speed_and_without_contact_it_sticks(tmp_path):
    run_pmpm(SLIDING, tmp_path / "free", sets=["params.mu=0",
                                               "contact.pairs=[{bodies: [plate, block], "
                                               "normal: plate}]"])
    assert all(abs(r["block.vx"] - 1.0) < 0.01 for r in history(tmp_path / "free"))
    run_pmpm(SLIDING, tmp_path / "none", sets=["contact.method=none"])
    late = [r["block.vx"] for r in history(tmp_path / "none") if r["time"] > 0.1]
    assert abs(np.mean(late)) < 0.3            # one shared field: welded to the plate


@pytest.mark.parametrize("method", [1, 2])
def test_colliding_cubes_conserve_momentum_and_do_not_interpenetrate(tmp_path, method):
    """Unequal speeds (+2 and -1 m/s), free box, no gravity: the total momentum stays
    put to round-off through contact and separation, and at every frame the left cube's
    particles stay behind the right cube's."""
    run_pmpm(BLOCKS, tmp_path, sets=[f"contact.method={method}", "params.v_right=-1.0",
                                     "output.frames=20"])
    rows = history(tmp_path)
    momentum = [BLOCK_MASS * (r["left.vx"] + r["right.vx"]) for r in rows]
    assert np.ptp(momentum) < 1e-12 * BLOCK_MASS * 3.0
    assert rows[-1]["left.vx"] < rows[-1]["right.vx"]          # they came apart
    for frame in range(21):
        f = read_frame(tmp_path, frame)
        left = f["x"][f["body"] == 0, 0].max()
        right = f["x"][f["body"] == 1, 0].min()
        assert left < right, f"interpenetration at frame {frame}"


def test_stick_in_every_direction_gives_the_shared_field():
    """The contact force of Eqs. 17 and 21 with unlimited friction at an approaching node
    moves every body with the centre of mass, and the forces on the bodies cancel."""
    rng = np.random.default_rng(5)
    n_slots, nb = 40, 2
    cnodal = np.zeros((n_slots, nb, kc.CNODAL))
    cnodal[:, :, 0] = rng.uniform(0.5, 2.0, (n_slots, nb))
    cnodal[:, :, 1:4] = cnodal[:, :, :1] * rng.normal(size=(n_slots, nb, 3))
    cnodal[:, 0, 4:7] = [1.0, 0.1, 0.0]                   # body 0 faces +x, body 1 -x
    cnodal[:, 1, 4:7] = [-1.0, 0.2, 0.0]
    cnodal[:, 0, 1] = cnodal[:, 0, 0] * 3.0               # and they approach along x
    cnodal[:, 1, 1] = -cnodal[:, 1, 0] * 3.0
    cforce = rng.normal(size=(n_slots, nb, 3))
    mass = cnodal[:, :, 0].sum(axis=1)
    gvel = cnodal[:, :, 1:4].sum(axis=1) / mass[:, None]
    dt = 1e-3
    gnew = np.zeros((n_slots, 6))
    gnew[:, 3:] = cforce.sum(axis=1) / mass[:, None]
    gnew[:, :3] = gvel + gnew[:, 3:] * dt
    geometry = (np.array([n_slots, 1, 1]), np.zeros(3, np.int64), np.array([1, 1, 1]),
                np.array([10 ** 6] * 3), np.zeros(6, np.int64))
    slots = np.arange(n_slots)
    cvel, cnorm = np.empty((n_slots, nb, 3)), np.empty((n_slots, nb, 3))
    rigid = np.zeros(nb, np.bool_)
    contact_start(cnodal, slots, gvel, np.full((nb, nb), -1), NO_CHECK, rigid, 1, 0.0,
                     *geometry, cvel, cnorm)
    assert np.allclose(cnorm[:, 0], -cnorm[:, 1])                 # collinear (Eq. 10)
    cnew = np.empty((n_slots, nb, 6))
    contact_end(cnodal, cvel, cnorm, cforce, slots, gvel, gnew, np.full((nb, nb), 1e30),
                   NO_CHECK, rigid, False, dt, 0.0, *geometry, cnew)
    assert np.allclose(cnew[:, 0, :3], gnew[:, :3]) and np.allclose(cnew[:, 1, :3], gnew[:, :3])
    momentum_change = (cnodal[:, :, :1] * cnew[:, :, 3:]).sum(axis=1)
    assert np.allclose(momentum_change, cforce.sum(axis=1), rtol=0, atol=1e-10)


def test_skip_separating_leaves_bodies_that_separated_at_the_start_of_the_step():
    """Two bodies at a node that separate at the start of the step and approach only in
    the trial velocities at its end: ``skip_separating`` leaves them uncorrected (a
    correction there would do positive work on the particles, whose velocities still
    separate: the elastic rings gained 20-30 % of their energy so); without it Eq. 12
    alone corrects them. Bodies approaching from the start are corrected either way."""
    nb, dt = 2, 1e-3
    cnodal = np.zeros((1, nb, kc.CNODAL))
    cnodal[0, :, 0] = [1.0, 1.0]
    cnodal[0, 0, 4:7], cnodal[0, 1, 4:7] = [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]
    cforce = np.zeros((1, nb, 3))
    cforce[0, 0, 0], cforce[0, 1, 0] = 3000.0, -3000.0    # turned round within the step
    geometry = (np.array([1, 1, 1]), np.zeros(3, np.int64), np.array([1, 1, 1]),
                np.array([10 ** 6] * 3), np.zeros(6, np.int64))
    gvel, gnew = np.zeros((1, 3)), np.zeros((1, 6))
    rigid, slots = np.zeros(nb, np.bool_), np.arange(1)
    cvel, cnorm, cnew = np.empty((1, nb, 3)), np.empty((1, nb, 3)), np.empty((1, nb, 6))

    def end_velocities(start_vx, method):
        cnodal[0, 0, 1], cnodal[0, 1, 1] = start_vx, -start_vx
        contact_start(cnodal, slots, gvel, np.full((nb, nb), -1), NO_CHECK, rigid, method,
                         0.0, *geometry, cvel, cnorm)
        contact_end(cnodal, cvel, cnorm, cforce, slots, gvel, gnew, np.zeros((nb, nb)),
                       NO_CHECK, rigid, skip, dt, 0.0, *geometry, cnew)
        return cnew[0, 0, 0], cnew[0, 1, 0]

    skip = True
    assert end_velocities(-1.0, 2) == pytest.approx((2.0, -2.0))     # separating at start
    for method in (1, 2):                                            # approaching at start
        assert end_velocities(1.0, method) == pytest.approx((0.0, 0.0), abs=1e-12)
    skip = False
    for method in (1, 2):
        assert end_velocities(-1.0, method) == pytest.approx((0.0, 0.0), abs=1e-12)
        assert end_velocities(1.0, method) == pytest.approx((0.0, 0.0), abs=1e-12)


@pytest.mark.parametrize("method", [1, 2])
def test_separation_check_leaves_bodies_with_a_gap_between_them_uncorrected(method):
    """Two bodies approaching at a node: corrected (their normal velocities meet) when
    their particles' mean positions there are 2/3 of a cell apart along the normal, as
    touching surfaces are; left alone when 1.25 cells apart (a gap of about half a cell);
    without the check (the paper's detection) corrected in both cases."""
    nb, dt = 2, 1e-3
    cnodal = np.zeros((1, nb, kc.CNODAL))
    cnodal[0, :, 0] = [1.0, 3.0]
    cnodal[0, 0, 1], cnodal[0, 1, 1] = 1.0, -3.0          # +1 and -1 m/s along x
    cnodal[0, 0, 4:7], cnodal[0, 1, 4:7] = [1.0, 0.0, 0.0], [-3.0, 0.0, 0.0]
    geometry = (np.array([1, 1, 1]), np.zeros(3, np.int64), np.array([1, 1, 1]),
                np.array([10 ** 6] * 3), np.zeros(6, np.int64))
    gvel = cnodal[:, :, 1:4].sum(axis=1) / cnodal[:, :, 0].sum(axis=1)[:, None]
    gnew = np.concatenate([gvel, np.zeros((1, 3))], axis=1)
    rigid, slots = np.zeros(nb, np.bool_), np.arange(1)
    cvel, cnorm, cnew = np.empty((1, nb, 3)), np.empty((1, nb, 3)), np.empty((1, nb, 6))

    def end_vx(apart, limit):
        cnodal[0, 0, 7] = -cnodal[0, 0, 0] * apart / 2      # mass-weighted offsets (cells)
        cnodal[0, 1, 7] = cnodal[0, 1, 0] * apart / 2
        separation = np.full((nb, nb), limit)
        contact_start(cnodal, slots, gvel, np.full((nb, nb), -1), separation, rigid,
                         method, 0.0, *geometry, cvel, cnorm)
        contact_end(cnodal, cvel, cnorm, np.zeros((1, nb, 3)), slots, gvel, gnew,
                       np.zeros((nb, nb)), separation, rigid, False, dt, 0.0, *geometry, cnew)
        return cnew[0, 0, 0], cnew[0, 1, 0]

    centre_of_mass = (1.0 - 3.0) / 4.0
    assert end_vx(2 / 3, 0.8) == pytest.approx((centre_of_mass, centre_of_mass))
    assert end_vx(1.25, 0.8) == pytest.approx((1.0, -1.0))
    for apart in (2 / 3, 1.25):
        assert end_vx(apart, np.inf) == pytest.approx((centre_of_mass, centre_of_mass))


BAD_CONTACT = [
    ({"method": 3}, "contact.method: must be none, 1 or 2"),
    ({"method": 2, "friction": -0.1}, "contact.friction: must be >= 0"),
    ({"method": 2, "pairs": [{"bodies": ["left", "ghost"]}]},
     "contact.pairs[0].bodies[1]: unknown body 'ghost'"),
    ({"method": 2, "pairs": [{"bodies": ["left", "right"], "friction": -1}]},
     "contact.pairs[0].friction: must be >= 0"),
    ({"method": 2, "pairs": [{"bodies": ["left", "right"], "normal": "plate"}]},
     "contact.pairs[0].normal: must be average, stiffer or one of the pair's bodies"),
    ({"method": 2, "pairs": [{"bodies": ["left", "left"]}]},
     "contact.pairs[0].bodies: a body cannot be in contact with itself"),
    ({"method": 2, "separation": 0}, "contact.separation: must be > 0"),
    ({"method": 2, "skip_separating": "sometimes"},
     "contact.skip_separating: expected true, false or auto"),
    ({"method": 2, "pairs": [{"bodies": ["left", "right"], "separation": -0.5}]},
     "contact.pairs[0].separation: must be > 0"),
]


@pytest.mark.parametrize("contact, message", BAD_CONTACT)
def test_bad_contact_input_names_the_key(tmp_path, contact, message):
    with open(BLOCKS, encoding="utf-8") as f:
        tree = yaml.safe_load(f)
    tree["contact"] = contact
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(tree))
    with pytest.raises(CaseError) as info:
        load_case(path)
    assert any(line.startswith(message) for line in info.value.problems), info.value.problems


def _incline_sets(mu, angle_deg):
    a = np.radians(angle_deg)
    return [f"params.mu={mu}", "params.v0=0", "time.end=0.25",
            f"gravity=[{10 * np.sin(a)}, 0, {-10 * np.cos(a)}]",
            "contact.pairs=[{bodies: [plate, block], normal: plate}]"]


@pytest.mark.parametrize("mu", [0.1, 0.3])
def test_a_block_slides_down_an_inclined_plate_at_g_sin_minus_mu_g_cos(tmp_path, mu):
    """Issue 15: the plate under tilted gravity (30 deg), contact method 2 with the plate's
    normal. Measured +0.02 % (mu 0.1) and +0.09 % (mu 0.3); the issue asks 2 %."""
    run_pmpm(SLIDING, tmp_path, sets=_incline_sets(mu, 30))
    rows = history(tmp_path)
    t = np.array([r["time"] for r in rows])
    v = np.array([r["block.vx"] for r in rows])
    exact = 10 * (np.sin(np.radians(30)) - mu * np.cos(np.radians(30)))
    assert np.polyfit(t, v, 1)[0] == pytest.approx(exact, rel=0.02)


def test_a_damped_block_on_an_inclined_plate_with_mu_above_tan_a_does_not_creep(tmp_path):
    """mu 0.7 > tan 30 deg. The block and the plate start unstressed and ring under
    gravity. Undamped (pure FLIP) the block creeps 3 mm in 0.15 s (1.5 mm with time.pic
    0.1); with time.pic 0.3 it stays put after the first 0.1 s (measured: under
    0.05 um). That damping removes the creep points to the ringing (a block on a
    vibrating slope slips while its normal force dips below W tan a / mu); the normal
    force's history was not measured."""
    run_pmpm(SLIDING, tmp_path, sets=_incline_sets(0.7, 30) + ["time.pic=0.3"])
    rows = [r for r in history(tmp_path) if r["time"] > 0.1]
    assert np.ptp([r["block.x"] for r in rows]) < 1e-6        # m: 1 um; sliding: 20 mm


@pytest.mark.parametrize("transfer", ["flip", "apic"])
def test_three_blocks_meeting_keep_momentum_under_method_2(tmp_path, transfer):
    """two_blocks.yaml's cubes head on along x and a third falling onto the gap between
    them (gimp, method 2 and the release rule, the defaults): momentum is kept to
    round-off through the three-body contact nodes. APIC takes the start correction into
    the particles' velocities: before the start was balanced it lost 5e-4 of the bodies'
    momentum along z, and 1.7e-4 with the balance made before the release rule undid
    some of the corrections (measured 7e-12 now; FLIP 1e-12 throughout)."""
    with open(BLOCKS, encoding="utf-8") as f:
        tree = yaml.safe_load(f)
    tree["grid"].update({"min": [-0.02, -0.02, -0.01], "max": [0.08, 0.04, 0.08],
                         "shape_functions": "gimp"})
    for body in tree["bodies"]:
        body["geometry"]["min"][2] += 0.01
        body["geometry"]["max"][2] += 0.01
    tree["bodies"].append({"name": "top", "material": "soft", "velocity": [0, 0, -2.0],
                           "geometry": {"type": "box", "min": [0.018, 0, 0.034],
                                        "max": [0.042, 0.02, 0.054]}})
    tree["time"]["transfer"] = transfer
    case = tmp_path / "three.yaml"
    case.write_text(yaml.safe_dump(tree))
    run_pmpm(str(case), tmp_path / "out")
    rows = history(tmp_path / "out")
    with open(tmp_path / "out" / "summary.json", encoding="utf-8") as f:
        mass = {b: f_b["mass"] for b, f_b in json.load(f)["bodies"].items()}
    assert sorted(mass) == ["left", "right", "top"]
    momentum = np.array([[sum(m * r[f"{b}.v{c}"] for b, m in mass.items()) for c in "xyz"]
                         for r in rows])
    assert np.ptp([r["top.vz"] for r in rows]) > 0.5     # the top block was stopped
    scale = sum(mass.values()) * 2.0                     # kg m/s
    assert np.abs(momentum - momentum[0]).max() < 1e-10 * scale


@pytest.mark.parametrize("method", [1, 2])
def test_three_bodies_at_a_node_keep_momentum_through_the_contact(method):
    """Three bodies at a node, each approaching the centre of mass along its own normal
    (not opposite pairs): each is corrected against the centre of mass, and without the
    balance their corrections summed to a net force (found with an FEM rod, its plate
    and the plate's converted particles at one node). The contact now keeps momentum to
    round-off at three bodies, and two bodies are corrected as before (bit for bit).
    Method 2's start correction likewise (before its balance: a net change of a third of
    the largest body's momentum at three bodies)."""
    rng = np.random.default_rng(7)
    dt = 1e-3
    for nb in (2, 3):
        cnodal = np.zeros((1, nb, kc.CNODAL))
        cnodal[0, :, 0] = rng.uniform(0.5, 2.0, nb)
        normals = rng.normal(size=(nb, 3))
        if nb == 2:
            normals[1] = -normals[0]
        cnodal[0, :, 4:7] = normals
        cnodal[0, :, 1:4] = normals * cnodal[0, :, :1] * rng.uniform(1, 3, (nb, 1))
        cforce = rng.normal(size=(1, nb, 3))
        mass = cnodal[0, :, 0].sum()
        gvel = cnodal[0, :, 1:4].sum(axis=0, keepdims=True) / mass
        gnew = np.zeros((1, 6))
        gnew[0, 3:] = cforce[0].sum(axis=0) / mass
        gnew[0, :3] = gvel[0] + gnew[0, 3:] * dt
        rigid = np.zeros(nb, np.bool_)
        cvel, cnorm, cnew = np.empty((1, nb, 3)), np.empty((1, nb, 3)), np.empty((1, nb, 6))
        contact_start(cnodal, np.arange(1), gvel, np.full((nb, nb), -1), NO_CHECK, rigid,
                      method, 0.0, *ONE_NODE, cvel, cnorm)
        if method == 2:
            kc.balance_start(ContactSlots(cnodal, np.arange(1), cvel, cnorm, cforce, cnew),
                             rigid, 0.0, node_block(*ONE_NODE))
        started = (cnodal[0, :, :1] * cvel[0] - cnodal[0, :, 1:4]).sum(0)
        assert np.abs(started).max() < 1e-12 * np.abs(cnodal[0, :, 1:4]).max()
        if method == 2:                                         # the start correction acted
            assert np.abs(cvel[0] - cnodal[0, :, 1:4] / cnodal[0, :, :1]).max() > 1e-2
        contact_end(cnodal, cvel, cnorm, cforce, np.arange(1), gvel, gnew,
                    np.zeros((nb, nb)), NO_CHECK, rigid, False, dt, 0.0, *ONE_NODE, cnew)
        change = (cnodal[0, :, :1] * (cnew[0, :, 3:] - cforce[0] / cnodal[0, :, :1])).sum(0)
        assert np.abs(change).max() < 1e-12 * np.abs(cforce).max()
        moved = cnew[0, :, :3] - (cnodal[0, :, 1:4] + cforce[0] * dt) / cnodal[0, :, :1]
        assert np.abs(moved).max() > 1e-3                       # the contact acted


@pytest.mark.parametrize("skip, words", [("auto", ", parting frictionless pairs left alone"),
                                         ("true", ", parting pairs left alone"),
                                         ("false", "")])
def test_the_start_line_names_how_parting_bodies_are_treated(skip, words):
    """The start line (pmpm.case.contact.describe_contact) ends with what
    contact.skip_separating does, so a run says whether method 2 pushed parting bodies."""
    from pmpm.case.contact import describe_contact
    from pmpm.case.loader import load_config
    config = load_config(os.path.join(CASES, "two_bars.yaml"),
                         [f"contact.skip_separating={skip}"])
    assert describe_contact(config.contact) == (
        "contact: method 2, release rule (0 cells, volume gap)" + words)
