"""CaseConfig: the validated case as frozen records whose defaults are the schema's."""
import dataclasses
import pathlib
import pickle

import pytest

from pmpm.case import CaseConfig, CaseError, fill_body, load_case, load_config, validate_case
from pmpm.case.bodies import BODY
from pmpm.case.config import ReadOnlyDict, mirrors, thawed
from pmpm.case.contact import AUTO, CONTACT
from pmpm.case.fields import OMIT, REQUIRED
from pmpm.case.schema import BOUNDARY, DECOMPOSITION, OUTPUT, TIME

ROOT = pathlib.Path(__file__).resolve().parent.parent
CASE_FILES = sorted(ROOT.glob("runs/*.yaml")) + sorted(ROOT.glob("tests/cases/*.yaml"))

PLAIN = {
    "grid": {"min": [0, 0, 0], "max": [10, 10, 10], "cell": 1},
    "materials": {"steel": {"model": "elastic", "density": 7.8e-3, "E": 2e5, "nu": 0.3}},
    "bodies": [{"name": name, "material": "steel",
                "geometry": {"type": "box", "min": [1, 1, z], "max": [9, 9, z + 2]}}
               for name, z in (("a", 1), ("b", 4), ("c", 7))],
    "time": {"end": 0.1},
}


def config_of(**sections):
    return CaseConfig.from_case(validate_case({**PLAIN, **sections}, check_geometry=False))


@pytest.mark.parametrize("path", CASE_FILES, ids=lambda p: p.name)
def test_every_case_file_builds_a_config_that_matches_its_case(path):
    case = load_case(path, check_geometry=False)
    config = CaseConfig.from_case(case)
    assert thawed(config.case) == case
    assert config.time.end == case["time"]["end"] and config.time.cfl == case["time"]["cfl"]
    assert config.output.frames == case["output"]["frames"]
    assert config.contact.method == case["contact"]["method"]
    assert [b.name for b in config.bodies] == [b["name"] for b in case["bodies"]]
    assert config.grid.max == tuple(case["grid"]["max"])
    assert set(config.grid.boundary) == set(BOUNDARY)
    assert pickle.loads(pickle.dumps(config)) == config


@pytest.mark.parametrize("section, table", [("time", TIME), ("output", OUTPUT),
                                            ("decomposition", DECOMPOSITION),
                                            ("contact", CONTACT)])
def test_left_out_keys_take_the_schema_defaults(section, table):
    record = getattr(config_of(), section)
    for key, field in table.items():
        if field.default == AUTO:
            continue                  # resolved per case: test_contact_defaults_resolve
        if field.default is OMIT:
            assert getattr(record, key) is None, key
        elif field.default is not REQUIRED:
            assert thawed(getattr(record, key)) == field.default, key


@pytest.mark.parametrize("sets, release, gap", [
    ([], None, "volume"),                                         # no grid contact
    (["contact.method=2"], 0.0, "volume"),
    (["contact.method=2", "grid.shape_functions=bspline"], 0.0, "reach"),
    (["contact.method=2", "contact.release=none"], None, "volume"),
    (["contact.method=1", "contact.release=0.5", "contact.gap=reach"], 0.5, "reach")])
def test_contact_defaults_resolve_from_the_matrix(sets, release, gap):
    """contact.release and contact.gap left at auto become the release rule with the
    volume gap (reach with bspline) where grid contact is on (docs/validation/
    defaults.md); what a case names is kept."""
    case = validate_case(dict(PLAIN, contact={"pairs": [{"bodies": ["a", "b"]}]}),
                         overrides=sets, check_geometry=False)
    contact = CaseConfig.from_case(case).contact
    assert contact.release == release and contact.gap == gap
    assert all(pair.release == release for pair in contact.pairs)


JC_COPPER = {"model": "johnson_cook", "density": 8.93e-3, "E": 117e3, "nu": 0.35,
             "A": 157.0, "B": 425.0, "n": 1.0}
FLUID = {"model": "fluid", "density": 1e-3, "eos": {"type": "linear", "c0": 1500.0}}


@pytest.mark.parametrize("sets, materials, cfl", [
    ([], None, 0.8),                                      # particle bodies, one field
    (["time.cfl=0.3"], None, 0.3),                        # what a case names is kept
    (["time.cfl=AUTO"], None, 0.8),
    (["grid.shape_functions=bspline"], None, 0.8),
    (["grid.shape_functions=linear"], None, 0.5),        # the hats' crossings
    (["contact.method=2"], None, 0.5),                    # bodies meet
    (["grid.friction.z-=0.2", "grid.boundary.z-=slip"], None, 0.5),   # a face rubs
    ([], {"steel": JC_COPPER}, 0.8),
    ([], {"steel": {**JC_COPPER, "eps_fail": 0.9}}, 0.5),  # failure
    ([], {"steel": {**JC_COPPER, "eps_fail": 0}}, 0.8),    # 0: never fails
    ([], {"steel": {**JC_COPPER, "bulk_viscosity": {"quadratic": 1.5}}}, 0.5),  # shocks
    ([], {"steel": {**JC_COPPER, "damage": {"model": "johnson_cook", "d1": 0.54, "d2": 4.89, "d3": -3.03}}}, 0.5),
    ([], {"steel": FLUID}, 0.5)])                         # not in the matrix at 0.8
def test_the_courant_number_left_at_auto_comes_from_the_matrix(sets, materials, cfl):
    """time.cfl auto: 0.8 for particle bodies of solid materials under 27-node shapes
    without contact, failure or bulk viscosity (every matrix row of that kind keeps its
    answers there), 0.5 for the rest (docs/validation/defaults.md, "The time step")."""
    case = validate_case(dict(PLAIN, materials=materials or PLAIN["materials"]),
                         overrides=sets, check_geometry=False)
    assert CaseConfig.from_case(case).time.cfl == cfl


def test_one_body_under_a_contact_method_meets_nothing_and_takes_the_quick_step():
    case = validate_case(dict(PLAIN, bodies=PLAIN["bodies"][:1]),
                         overrides=["contact.method=2"], check_geometry=False)
    assert CaseConfig.from_case(case).time.cfl == 0.8


def test_an_fem_body_takes_the_safe_courant_number():
    config = load_config(str(ROOT / "tests" / "cases" / "sphere_on_fem_block.yaml"),
                         ["time.cfl=auto"])
    assert config.time.cfl == 0.5


def test_a_courant_number_that_is_neither_a_number_nor_auto_is_refused():
    with pytest.raises(CaseError, match=r"time\.cfl: expected a number in \(0, 1\] or auto"):
        validate_case(PLAIN, overrides=["time.cfl=fast"], check_geometry=False)
    with pytest.raises(CaseError, match=r"time\.cfl: must be <= 1"):
        validate_case(PLAIN, overrides=["time.cfl=1.5"], check_geometry=False)


def test_defaults_of_grid_and_bodies_come_from_the_schema():
    config = config_of()
    assert config.bodies[0].particles_per_cell == BODY.fields["particles_per_cell"].default
    assert dict(config.grid.boundary) == {face: f.default for face, f in BOUNDARY.items()}
    assert config.contact.separation is None and config.contact.pairs == ()
    assert config.loads == () and config.grid.windows == ()


def test_records_are_frozen():
    config = config_of()
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.time.cfl = 0.9
    with pytest.raises(TypeError):
        config.grid.boundary["z-"] = "fixed"
    with pytest.raises(TypeError):
        config.materials["steel"]["E"] = 1.0
    assert isinstance(config.output.times, tuple) and isinstance(config.gravity, tuple)
    assert isinstance(config.bodies[0].geometry, ReadOnlyDict)


def test_steel_ball_case_values():
    config = load_config(ROOT / "runs" / "steel_ball_plate.yaml", check_geometry=False)
    assert config.contact.method == 2 and config.contact.separation == 0.9
    pair = config.contact.pairs[0]
    assert pair.bodies == ("ball", "plate") and pair.normal == "ball"
    assert config.grid.boundary["x-"] == "symmetry" and config.grid.boundary["z-"] == "free"
    assert config.materials["steel"]["model"] == "j2_power"


def test_pairs_take_the_contact_rules_they_leave_out():
    contact = config_of(contact={
        "method": 1, "friction": 0.3, "normal": "stiffer", "separation": 0.9,
        "pairs": [{"bodies": ["a", "b"]},
                  {"bodies": ["a", "c"], "friction": 0.1, "normal": "c", "separation": "none"}],
    }).contact
    assert contact.pairs[0] == dataclasses.replace(contact.pairs[0], bodies=("a", "b"),
                                                   friction=0.3, normal="stiffer",
                                                   separation=0.9)
    assert (contact.pairs[1].friction, contact.pairs[1].normal) == (0.1, "c")
    assert contact.pairs[1].separation is None
    assert config_of(contact={"method": "none", "separation": "none"}).contact.separation is None


def test_loads_windows_and_time_functions():
    config = config_of(
        loads=[{"name": "push", "body": "a", "type": "force", "value": [0, 0, 1],
                "region": {"min": [0, 0, 0], "max": [10, 10, 3]},
                "time_function": {"type": "table", "t": [0, 1], "f": [0, 1]}},
               {"name": "pull", "body": "b", "type": "traction", "value": [0, 0, -1],
                "region": {"min": [0, 0, 4], "max": [10, 10, 6]}}],
        grid={**PLAIN["grid"], "windows": [{"min": [0, 0, 0], "max": [5, 5, 5], "ratio": 2,
                                            "follow": "a"}]})
    push, pull = config.loads
    assert push.time_function.t == (0.0, 1.0) and push.time_function.t_rise is None
    assert pull.time_function.type == "constant" and pull.region.max == (10.0, 10.0, 6.0)
    window = config.grid.windows[0]
    assert (window.ratio, window.follow, window.max) == (2, "a", (5.0, 5.0, 5.0))


def test_fill_body_takes_the_read_only_case():
    config = config_of()
    positions, _ = fill_body(config.case["bodies"][0], config.case["grid"])
    assert len(positions) == 8 * 8 * 2 * 8


def test_a_record_whose_attributes_drift_from_the_schema_is_refused():
    with pytest.raises(TypeError, match="schema keys"):
        @mirrors(TIME)
        @dataclasses.dataclass(frozen=True)
        class Drifted:
            end: float
            cfl: float


def test_fem_and_rigid_parts_are_records():
    """An FEM body's ``fem`` is a FemConfig (its ``convert`` and ``constraints``
    records, absent criteria None), a particle body's None; ``rigid`` a RigidConfig."""
    bodies = [dict(PLAIN["bodies"][0], method="fem",
                   fem={"element_size": 2.0, "hourglass": "viscous",
                        "convert": {"eps_p": 0.9},
                        "constraints": [{"region": {"min": [0, 0, 0], "max": [10, 10, 1.5]},
                                         "fix": ["z"]}]}),
              PLAIN["bodies"][1]]
    fem_body, particle_body = config_of(bodies=bodies).bodies
    assert fem_body.is_fem and not particle_body.is_fem
    assert particle_body.fem is None and particle_body.convert is None
    fem = fem_body.fem
    assert (fem.element_size, fem.element, fem.hourglass) == (2.0, "reduced", "viscous")
    assert fem.hourglass_coefficient == 0.1                       # the schema's default
    assert fem_body.convert is fem.convert
    assert (fem.convert.eps_p, fem.convert.volume_ratio, fem.convert.step_ratio,
            fem.convert.particles_per_direction) == (0.9, None, None, 2)
    (held,) = fem.constraints
    assert held.fix == ("z",) and held.node_set is None and held.region["max"][2] == 1.5
    assert fem_body.rigid.free == () and fem_body.free_axes == ()
    with pytest.raises(dataclasses.FrozenInstanceError):
        fem.element_size = 1.0
    assert pickle.loads(pickle.dumps(fem_body)) == fem_body


def test_a_wrong_fem_key_is_still_refused_naming_it():
    bodies = [dict(PLAIN["bodies"][0], method="fem",
                   fem={"element_size": 2.0, "convert": {"eps_q": 0.9}})]
    with pytest.raises(Exception) as error:
        config_of(bodies=bodies)
    assert "bodies[0].fem.convert" in str(error.value) and "eps_q" in str(error.value)


def test_exact_sums_auto_is_on_where_bodies_can_touch():
    """``grid.exact_sums: auto`` (the default) resolves to a bool: on with two bodies
    and a contact method (or an FEM body), off for one body or no contact method;
    true and false are kept as given."""
    ball = load_config(ROOT / "runs" / "steel_ball_plate.yaml", check_geometry=False)
    bar = load_config(ROOT / "runs" / "taylor_bar.yaml", check_geometry=False)
    assert ball.grid.exact_sums is True and bar.grid.exact_sums is False
    assert load_config(ROOT / "runs" / "steel_ball_plate.yaml", ["contact.method=none"],
                       check_geometry=False).grid.exact_sums is False
    assert load_config(ROOT / "runs" / "taylor_bar.yaml", ["grid.exact_sums=true"],
                       check_geometry=False).grid.exact_sums is True
    with pytest.raises(CaseError, match="grid.exact_sums"):
        load_config(ROOT / "runs" / "taylor_bar.yaml", ["grid.exact_sums=sometimes"],
                    check_geometry=False)
