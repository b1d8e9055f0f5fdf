"""The case layer: parameters, overrides, validation messages, defaults, geometry fill."""
import copy
import math
import pathlib
import re

import meshio
import numpy as np
import pytest
import yaml

from pmpm.case import CaseError, fill_body, load_case, validate_case
from pmpm.case.expressions import ExpressionError, evaluate

README = pathlib.Path(__file__).resolve().parent.parent / "README.md"

TAYLOR = {
    "params": {"cell": 0.76, "v0": 190},
    "grid": {"min": [-7.6, -7.6, 0], "max": [7.6, 7.6, 27], "cell": "${cell}",
             "boundary": {"z-": "fixed"}},
    "materials": {"copper": {
        "model": "johnson_cook", "density": 8.93e-3, "E": 117e3, "nu": 0.35,
        "A": 157, "B": 425, "n": 1.0, "C": 0,
        "eos": {"type": "mie_gruneisen", "c0": 3940, "s": 1.49, "gamma0": 1.96},
        "bulk_viscosity": {"linear": 0.06, "quadratic": 1.5}}},
    "bodies": [{"name": "bar", "material": "copper",
                "geometry": {"type": "cylinder", "base": [0, 0, 0], "axis": "z",
                             "radius": 3.8, "length": 25.4},
                "velocity": [0, 0, "${-v0}"]}],
    "time": {"end": 0.08},
}


def write_case(tmp_path, tree, name="case.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(tree, sort_keys=False))
    return path


def load(tmp_path, tree=TAYLOR, overrides=(), **kw):
    return load_case(write_case(tmp_path, tree), overrides, **kw)


def problems_of(tmp_path, tree, overrides=()):
    with pytest.raises(CaseError) as info:
        load(tmp_path, tree, overrides)
    return info.value.problems


def edited(**changes):
    """A deep copy of TAYLOR with dotted-path changes (value None deletes the key)."""
    tree = copy.deepcopy(TAYLOR)
    for dotted, value in changes.items():
        *parents, last = [int(t) if t.isdigit() else t for t in dotted.split("__")]
        node = tree
        for key in parents:
            node = node.setdefault(key, {}) if isinstance(node, dict) else node[key]
        if value is None:
            del node[last]
        else:
            node[last] = value
    return tree


def box_body(geometry, ppc=2, name="b"):
    return {"name": name, "material": "copper", "geometry": geometry,
            "particles_per_cell": ppc, "velocity": [0.0, 0.0, 0.0]}


GRID = {"min": [-20.0, -20.0, -20.0], "max": [20.0, 20.0, 20.0], "cell": 1.0}


# --- expressions and parameters -----------------------------------------------------

@pytest.mark.parametrize("text, value", [
    ("1 + 2 * 3", 7), ("(1 + 2) * 3", 9), ("-a ** 2", -4.0), ("2 ** -1", 0.5),
    ("a / 4", 0.5), ("sqrt(16) + cos(0)", 5.0), ("sin(radians(90))", 1.0),
    ("tan(pi / 4)", 1.0), ("-(-a)", 2), ("max(a, 3) - min(1, a)", 2),
])
def test_expressions_evaluate(text, value):
    assert evaluate(text, {"a": 2}) == pytest.approx(value)


@pytest.mark.parametrize("text, message", [
    ("__import__('os')", "unknown function"), ("a.real", "not allowed"),
    ("a < 3", "not allowed"), ("lambda: 1", "not allowed"), ("b + 1", "unknown parameter 'b'"),
    ("1 / 0", "cannot evaluate"), ("sqrt(-1)", "cannot evaluate"),
    ("(-8) ** 0.5", "finite real"),
    ("10 ** 400", "cannot evaluate"), ("1 +", "invalid expression"), ("'x'", "not a number"),
])
def test_expressions_refuse(text, message):
    with pytest.raises(ExpressionError, match=re.escape(message)):
        evaluate(text, {"a": 2})


def test_params_substitute_numbers_text_and_other_params(tmp_path):
    tree = edited(title="bar at ${v0} m/s, cell ${cell * 1000} um")
    tree["params"].update(radius="${diameter / 2}", diameter=7.6)
    tree["bodies"][0]["geometry"]["radius"] = "${radius}"
    case = load(tmp_path, tree)
    assert case["params"] == {"cell": 0.76, "v0": 190, "radius": 3.8, "diameter": 7.6}
    assert case["title"] == "bar at 190 m/s, cell 760 um"
    assert case["grid"]["cell"] == 0.76
    assert case["bodies"][0]["velocity"] == [0.0, 0.0, -190.0]
    assert case["bodies"][0]["geometry"]["radius"] == 3.8


def test_params_errors_name_the_key(tmp_path):
    tree = edited(params__pi=3, params__loop="${loop2}", params__loop2="${loop + 1}")
    tree["bodies"][0]["velocity"] = [0, 0, "${-speed}"]
    problems = problems_of(tmp_path, tree)
    assert "params.pi: 'pi' is reserved (a function or constant of expressions)" in problems
    assert any(p.startswith("params: parameters refer to each other in a cycle: loop, loop2")
               for p in problems)
    assert any(p.startswith("bodies[0].velocity[2]: unknown parameter 'speed'")
               for p in problems)


# --- overrides ---------------------------------------------------------------------

def test_units_other_takes_any_consistent_system(tmp_path):
    """A case in its own consistent system (here SI values for the copper) declares
    ``units: other`` and is not range-checked."""
    tree = edited(units="other", materials__copper__density=8930.0,
                  materials__copper__E=1.17e11)
    assert load(tmp_path, tree, check_geometry=False)["units"] == "other"


def test_set_overrides_params_lists_and_new_keys(tmp_path):
    case = load(tmp_path, overrides=[
        "params.cell=0.38", "bodies.0.particles_per_cell=1", "bodies[0].velocity=[0, 0, -100]",
        "time.dt_max=1e-5", "materials.copper.E=1.1e5", "grid.boundary.x-=symmetry"])
    assert case["grid"]["cell"] == 0.38
    assert case["grid"]["max"] == [7.6, 7.6, 27.36]
    assert case["bodies"][0]["particles_per_cell"] == 1
    assert case["bodies"][0]["velocity"] == [0.0, 0.0, -100.0]
    assert case["time"]["dt_max"] == 1e-5
    assert case["materials"]["copper"]["E"] == 110000.0
    assert case["grid"]["boundary"]["x-"] == "symmetry"


def test_set_override_errors(tmp_path):
    problems = problems_of(tmp_path, TAYLOR, [
        "bodies.3.velocity=[0,0,0]", "no_equals_sign", "time.end.x=1", "time.cfl=[1,",
        "tme.end=1"])
    assert problems[0] == ("bodies[3]: --set: no item 3 (the list has 1 items, numbered "
                           "from 0)")
    assert problems[1].startswith("--set no_equals_sign: expected KEY=VALUE")
    assert problems[2].startswith("time.end: --set:")
    assert problems[3].startswith("time.cfl: --set: value '[1,': ")
    assert "tme: unknown key (did you mean 'time'?)" in problems


# --- defaults, rounding, plain output ------------------------------------------------

def test_defaults_filled(tmp_path):
    case = load(tmp_path)
    assert case["title"] == "case"
    assert case["gravity"] == [0.0, 0.0, 0.0]
    assert case["grid"]["boundary"] == {"x-": "free", "x+": "free", "y-": "free",
                                        "y+": "free", "z-": "fixed", "z+": "free"}
    assert case["time"] == {"end": 0.08, "cfl": 0.5, "dt_max": None, "dt": None, "pic": 0.0,
                            "transfer": "flip", "scheme": "usf", "max_steps": 1e8}
    assert case["output"] == {"frames": 10, "history_every": 10, "checkpoint_every": 0,
                              "checkpoints": True, "progress": True, "precision": "float64",
                              "forces": True,
                              "every": None,
                              "probes": [], "times": [], "energy_warning": 0.05, "energy_fault": 10.0}
    assert case["decomposition"] == {"axis": "auto", "rebalance_threshold": 0.2,
                                     "check_every": 50, "memory_limit_gb": None}
    assert case["loads"] == []
    copper = case["materials"]["copper"]
    assert copper["eps_dot0"] == 1e-3 and copper["T_room"] == 293.0 and copper["chi"] == 0.9
    assert "K" not in copper and "eps_fail" not in copper
    body = case["bodies"][0]
    assert body["particles_per_cell"] == 2 and body["geometry"]["inner_radius"] == 0.0


def test_grid_max_rounded_up_to_whole_cells(tmp_path):
    tree = edited(grid__max=[7.6, 7.0, 27], grid__min=[-7.6, -7.6, -0.5])
    grid = load(tmp_path, tree)["grid"]
    assert grid["max"] == [7.6, 7.6, 27.62]          # 20 cells in x, y; 37 in z


def test_result_is_plain_and_validates_to_itself(tmp_path):
    tree = edited()
    tree["bodies"].append(box_body({"type": "ogive", "tip": [0, 0, 26.5],
                                    "direction": [0, 0, 2], "length": 0.9,
                                    "diameter": 0.8, "crh": 1,
                                    "rotate": {"axis": [1, 0, 0], "angle_deg": 10}}))
    tree["loads"] = [{"name": "push", "body": "bar", "type": "force",
                      "region": {"min": [-4, -4, 20], "max": [4, 4, 26]}, "value": [0, 0, 1],
                      "time_function": {"type": "table", "t": [0, 1], "f": [0, 1]}}]
    case = load(tmp_path, tree)

    def plain(x):
        if isinstance(x, dict):
            return all(isinstance(k, str) and plain(v) for k, v in x.items())
        if isinstance(x, list):
            return all(plain(v) for v in x)
        return x is None or type(x) in (bool, int, float, str)
    assert plain(case)
    assert case["bodies"][1]["geometry"]["direction"] == [0.0, 0.0, 1.0]
    assert case["bodies"][1]["geometry"]["rotate"]["origin"] == [0.0, 0.0, 26.5]
    assert validate_case(case, tmp_path, "case") == case


def test_yaml_exponent_numbers_are_floats(tmp_path):
    path = tmp_path / "e.yaml"
    text = yaml.safe_dump(TAYLOR, sort_keys=False)
    path.write_text(text.replace("E: 117000.0", "E: 117e3").replace("density: 0.00893",
                                                                   "density: 8.93e-3"))
    assert "117e3" in path.read_text()
    copper = load_case(path)["materials"]["copper"]
    assert copper["E"] == 117e3 and copper["density"] == 8.93e-3


def test_docs_example_loads(tmp_path):
    text = README.read_text().split("## The case file", 1)[1]
    example = re.search(r"```yaml\n(.*?)```", text, re.S).group(1)
    path = tmp_path / "taylor_bar.yaml"
    path.write_text(example)
    case = load_case(path)
    assert case["grid"]["max"] == [11.4, 11.4, 27.36]
    assert len(fill_body(case["bodies"][0], case["grid"], tmp_path)[0]) == 21172


# --- error messages ------------------------------------------------------------------

@pytest.mark.parametrize("changes, expected", [
    ({"bodies__0__material": "stel"},
     "bodies[0].material: unknown material 'stel'; known: copper"),
    ({"bodies__0__geometry__radus": 1}, "bodies[0].geometry.radus: unknown key (did you "
                                        "mean 'radius'?)"),
    ({"bodies__0__geometry__radius": None}, "bodies[0].geometry.radius: missing (required)"),
    ({"bodies__0__geometry__type": "cone"},
     "bodies[0].geometry.type: unknown geometry type 'cone'; known: box, cylinder, "
     "difference, mesh, ogive, points, prism, sphere, surface, union"),
    ({"bodies__0__velocity": [0, 0]}, "bodies[0].velocity: expected a list of 3 numbers"),
    ({"bodies__0__particles_per_cell": 0},
     "bodies[0].particles_per_cell: must be >= 1, got 0"),
    ({"bodies__0__name": "bar 1"}, "bodies[0].name: 'bar 1': use letters, digits, _ and -"),
    ({"materials__copper__model": "jonson_cook"},
     "materials.copper.model: unknown model 'jonson_cook'; known: elastic, fluid, j2_linear, "
     "j2_power, johnson_cook, neo_hookean, rigid (did you mean 'johnson_cook'?)"),
    ({"materials__copper__nu": 0.5}, "materials.copper.nu: must be in (-1, 0.5), got 0.5"),
    ({"materials__copper__density": 0}, "materials.copper.density: must be > 0, got 0"),
    ({"materials__copper__n": -1}, "materials.copper.n: must be > 0, got -1"),
    ({"materials__copper__nu": None}, "materials.copper: model 'johnson_cook' needs exactly "
                                      "two of E, nu, K, G; got 1 (E)"),
    ({"materials__copper__G": 4e4}, "materials.copper: model 'johnson_cook' needs exactly "
                                    "two of E, nu, K, G; got 3 (E, nu, G)"),
    ({"materials__copper__nu": None, "materials__copper__G": 3e4},
     "materials.copper: E = 117000 and G = 30000 give nu = 0.95; need -1 < nu < 0.5"),
    ({"materials__copper__eos__type": "ideal_gas"}, "materials.copper.eos.type: unknown eos "
                                                    "type 'ideal_gas'"),
    ({"materials__copper__eos__c0": None}, "materials.copper.eos.c0: missing (required)"),
    ({"materials__copper__T_melt": 200}, "materials.copper.T_melt: must be > T_room = 293"),
    ({"materials__copper__chi": 1.5}, "materials.copper.chi: must be <= 1, got 1.5"),
    ({"materials__copper__density": 8930}, "materials.copper.density: 8930 is not a density "
                                           "in g/mm^3 (mm-ms-g"),
    ({"materials__copper__E": 1.17e11}, "materials.copper.E: 1.17e+11 is not a modulus in MPa"),
    ({"units": "m-s-kg"}, "materials.copper.density: 0.00893 is not a density in kg/m^3"),
    ({"units": "cgs"}, "units: unknown unit system 'cgs'"),
    ({"materials__copper__eos": {"type": "mie_gruneisen", "c0": 3.94, "s": 1.49,
                                 "gamma0": 1.96}},
     "materials.copper.eos.c0: 3.94 is far from the bulk sound speed"),
    ({"output__probes": [{"name": "p", "body": "rod", "point": [0, 0, 1]}]},
     "output.probes[0].body: unknown body 'rod'"),
    ({"output__probes": [{"name": "p", "body": "bar", "point": [0, 0, 1]},
                         {"name": "p", "body": "bar", "point": [0, 0, 2]}]},
     "output.probes[1].name: duplicate name 'p' (also output.probes[0])"),
    ({"bodies__0__method": "FEM"}, "bodies[0].method: unknown body method 'FEM'; known: fem, "
                                   "particles (did you mean 'fem'?)"),
    ({"bodies__0__fem": {"element_size": 1.0}}, "bodies[0].fem: a fem: block on a particle "
                                                "body would be ignored"),
    ({"grid__cell": -1}, "grid.cell: must be > 0, got -1"),
    ({"grid__max": [7.6, -8, 27]},
     "grid: min must be < max in every direction (y: -7.6 >= -8)"),
    ({"grid__boundary__z-": "wall"}, "grid.boundary.z-: unknown boundary condition 'wall'"),
    ({"time__end": None}, "time.end: missing (required)"),
    ({"time__cfl": 1.5}, "time.cfl: must be <= 1, got 1.5"),
    ({"time__scheme": "usl"}, "time.scheme: unknown update scheme 'usl'"),
    ({"grid__max": [7.6, 7.6, 20]}, "bodies[0].geometry: body extends outside the grid box "
                                    "(z from 0.19 to 25.27, grid 0 to 20.52)"),
    ({"bodies__0__geometry__radius": 0.1}, "bodies[0].geometry: no particle falls inside "
                                           "the shape"),
    ({"output__frames": 2.5}, "output.frames: expected a whole number, got float 2.5"),
    ({"output__times": [0.01, 0.1]}, "output.times[1]: must be in (0, time.end = 0.08], got 0.1"),
    ({"decomposition__axis": "w"},
     "decomposition.axis: unknown axis 'w'; known: auto, x, y, z"),
    ({"gravty": [0, 0, -1]}, "gravty: unknown key (did you mean 'gravity'?)"),
    ({"bodies": []}, "bodies: expected a list of at least 1 body,"),
])
def test_error_names_key_path(tmp_path, changes, expected):
    problems = problems_of(tmp_path, edited(**changes))
    assert any(p.startswith(expected) for p in problems), problems


def test_materials_by_model(tmp_path):
    tree = edited()
    tree["materials"].update({
        "water": {"model": "fluid", "density": 1e-3, "E": 1},
        "wall": {"model": "rigid", "density": 1, "eos": {"type": "linear", "c0": 1}},
        "soft": {"model": "elastic", "density": 1, "E": 1, "nu": 0.2, "eps_fail": 0.1},
        "al": {"model": "j2_linear", "density": 2.7e-3, "K": 7e4, "G": 2.6e4,
               "yield_stress": 300, "tangent_modulus": 1e5},
    })
    problems = problems_of(tmp_path, tree)
    assert "materials.water.eos: missing (model 'fluid' takes its pressure from an " \
           "equation of state: mie_gruneisen or linear)" in problems
    assert any(p.startswith("materials.water.E: unknown key") for p in problems)
    assert any(p.startswith("materials.wall.eos: unknown key") for p in problems)
    assert any(p.startswith("materials.soft.eps_fail: unknown key") for p in problems)
    assert "materials.al.tangent_modulus: must be < E = 69406.8" in problems


def test_all_problems_reported_together(tmp_path):
    tree = edited(bodies__0__material="stel", time__cfl=0, grid__cell="${cel}",
                  materials__copper__nu=0.7)
    tree["bodies"].append({"name": "bar", "material": "copper",
                           "geometry": {"type": "sphere", "center": [0, 0, 0], "radius": -1}})
    tree["loads"] = [{"name": "p", "body": "plate", "type": "pressure",
                      "region": {"min": [0, 0, 1], "max": [1, 1, 0]}, "value": [0, 0, 1],
                      "time_function": {"type": "table", "t": [0, 1, 1], "f": [0, 1, 2]}}]
    error = pytest.raises(CaseError, load, tmp_path, tree, ["output.frames=0"]).value
    paths = [p.split(":")[0] for p in error.problems]
    assert sorted(paths) == sorted([
        "bodies[0].material", "time.cfl", "grid.cell", "materials.copper.nu",
        "bodies[1].name", "bodies[1].geometry.radius", "loads[0].body", "loads[0].type",
        "loads[0].region", "loads[0].time_function.t", "output.frames"])
    assert str(error) == "\n".join(error.problems)


def test_duplicate_yaml_keys_and_syntax_errors(tmp_path):
    text = yaml.safe_dump(TAYLOR, sort_keys=False).replace("  v0: 190\n",
                                                           "  v0: 190\n  v0: 200\n")
    (tmp_path / "dup.yaml").write_text(text)
    with pytest.raises(CaseError, match=r"dup.yaml line 4: duplicate key 'v0'"):
        load_case(tmp_path / "dup.yaml")
    (tmp_path / "bad.yaml").write_text("grid: [1, 2\n")
    with pytest.raises(CaseError, match="YAML syntax error"):
        load_case(tmp_path / "bad.yaml")
    with pytest.raises(CaseError, match="cannot read case file"):
        load_case(tmp_path / "missing.yaml")


# --- geometry fill ---------------------------------------------------------------------

def test_taylor_bar_particle_counts(tmp_path):
    """Seed 000 Table 4: 21 172 and 169 376 particles at cells 0.76 and 0.38 (2 per cell
    per direction). Its 1 342 408 at 0.19 looks like a misprint of 1 341 408 (5024 points
    per layer times 267 layers, the count this lattice gives)."""
    for cell, expected in [(0.76, 21172), (0.38, 169376)]:
        case = load(tmp_path, overrides=[f"params.cell={cell}"])
        positions, volumes = fill_body(case["bodies"][0], case["grid"], tmp_path)
        assert len(positions) == expected
        assert volumes == pytest.approx(np.full(expected, (cell / 2) ** 3))


def test_lattice_aligned_with_grid_quarter_points():
    body = box_body({"type": "box", "min": [0, 0, 0], "max": [2, 1, 1]})
    positions, volumes = fill_body(body, GRID)
    assert len(positions) == 4 * 2 * 2
    assert sorted(set(positions[:, 0])) == [0.25, 0.75, 1.25, 1.75]
    assert np.all(volumes == 0.125)


def ogive_volume(length, diameter, crh):
    radius, rho = diameter / 2, crh * diameter
    nose = diameter * math.sqrt(crh - 0.25)
    a = rho - radius
    nose_volume = math.pi * ((rho ** 2 + a ** 2) * nose - nose ** 3 / 3
                             - a * (nose * a + rho ** 2 * math.asin(nose / rho)))
    return math.pi * radius ** 2 * (length - nose) + nose_volume


@pytest.mark.parametrize("geometry, volume, tolerance", [
    ({"type": "box", "min": [-3, -2, 1], "max": [5, 4, 2]}, 8 * 6 * 1, 0),
    ({"type": "cylinder", "base": [1, 2, -5], "axis": "x", "radius": 4, "length": 9},
     math.pi * 16 * 9, 0.01),
    ({"type": "cylinder", "base": [0, 0, 0], "axis": "y", "radius": 6, "length": 3,
      "inner_radius": 4}, math.pi * 20 * 3, 0.02),
    ({"type": "sphere", "center": [0.3, -1, 2], "radius": 5}, 4 / 3 * math.pi * 125, 0.01),
    ({"type": "ogive", "base": [0, 0, -8], "direction": [0, 0, 1], "length": 16,
      "diameter": 6, "crh": 3}, ogive_volume(16, 6, 3), 0.02),
    ({"type": "ogive", "tip": [0, 0, 10], "direction": [1, 1, 1], "length": 15,
      "diameter": 8, "crh": 0.5}, ogive_volume(15, 8, 0.5), 0.02),
])
def test_geometry_volume(geometry, volume, tolerance):
    """Particle count * d^3 against the analytic volume at d = 0.25 (4 per cell)."""
    positions, volumes = fill_body(box_body(geometry, ppc=4), GRID)
    assert volumes.sum() == pytest.approx(volume, rel=tolerance, abs=1e-9)
    assert len(np.unique(positions, axis=0)) == len(positions)


def test_ogive_nose_shape():
    geometry = {"type": "ogive", "base": [0, 0, 0], "direction": [0, 0, 1], "length": 16,
                "diameter": 6, "crh": 3}
    positions, _ = fill_body(box_body(geometry, ppc=4), GRID)
    nose_start = 16 - 6 * math.sqrt(2.75)
    radius = np.hypot(positions[:, 0], positions[:, 1])
    assert positions[:, 2].max() < 16 and positions[:, 2].min() > 0
    assert radius[positions[:, 2] < nose_start].max() == pytest.approx(3, abs=0.25)
    assert radius[positions[:, 2] > 15].max() < 1.0      # narrow near the tip


def test_rotated_box_is_exact_and_turned():
    plate = {"type": "box", "min": [-4, -4, 0], "max": [4, 4, 1]}
    rotated = dict(plate, rotate={"axis": [0, 1, 0], "angle_deg": 30, "origin": [0, 0, 0]})
    flat, _ = fill_body(box_body(plate), GRID)
    turned, _ = fill_body(box_body(rotated), GRID)
    assert len(turned) == len(flat) == 16 * 16 * 2
    back = turned @ _rotation_y(-30).T          # undo the rotation: the flat lattice again
    assert np.allclose(np.sort(back, axis=0), np.sort(flat, axis=0))


def test_rotate_origin_defaults_to_reference_point(tmp_path):
    tree = edited()
    tree["bodies"][0]["geometry"]["rotate"] = {"axis": [1, 0, 0], "angle_deg": 180}
    tree["grid"]["min"] = [-7.6, -7.6, -27.36]
    case = load(tmp_path, tree)
    assert case["bodies"][0]["geometry"]["rotate"]["origin"] == [0.0, 0.0, 0.0]
    positions, _ = fill_body(case["bodies"][0], case["grid"], tmp_path)
    assert len(positions) == 21172                  # half-offset lattice about the base
    assert positions[:, 2].max() < 0 and positions[:, 2].min() > -25.4


def _rotation_y(angle_deg):
    a = math.radians(angle_deg)
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


# --- meshes ------------------------------------------------------------------------------

def hexa_box_mesh(path, n=(4, 2, 2), size=(2.0, 1.0, 1.0)):
    """A structured hexahedral mesh of [0, size] with n cells, plus one surface quad."""
    axes = [np.linspace(0, s, k + 1) for s, k in zip(size, n)]
    points = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    node = np.arange(len(points)).reshape([k + 1 for k in n])
    i, j, k = (g.ravel() for g in np.meshgrid(*map(np.arange, n), indexing="ij"))
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0),
               (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]       # VTK order
    hexa = np.stack([node[i + a, j + b, k + c] for a, b, c in corners], axis=1)
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexa), ("quad", hexa[:1, :4])]))


def test_hexahedral_mesh_fill_matches_box(tmp_path):
    hexa_box_mesh(tmp_path / "block.vtu")
    geometry = {"type": "mesh", "file": "block.vtu", "scale": 2.0, "translate": [1, 0, -1]}
    positions, _ = fill_body(box_body(geometry), GRID, tmp_path)
    same_box, _ = fill_body(box_body({"type": "box", "min": [1, 0, -1], "max": [5, 2, 1]}),
                            GRID)
    assert len(positions) == 8 * 4 * 4
    assert np.array_equal(positions, same_box)


def test_tetra_mesh_fill_matches_brute_force(tmp_path):
    vertices = np.array([[0.1, 0.2, 0.0], [6.0, 0.5, 0.3], [0.4, 5.2, 0.1], [0.3, 0.1, 4.9]])
    meshio.write(tmp_path / "tet.msh", meshio.Mesh(vertices, [("tetra", [[0, 1, 2, 3]])]),
                 file_format="gmsh22")
    geometry = {"type": "mesh", "file": "tet.msh", "scale": 1.0, "translate": [0, 0, 0]}
    positions, _ = fill_body(box_body(geometry), GRID, tmp_path)
    lattice = np.stack(np.meshgrid(*[np.arange(-1, 7, 0.5) + 0.25] * 3, indexing="ij"),
                       axis=-1).reshape(-1, 3)
    lam = np.linalg.solve((vertices[1:] - vertices[0]).T, (lattice - vertices[0]).T).T
    inside = lattice[np.all(lam >= 0, axis=1) & (lam.sum(axis=1) <= 1)]
    assert len(positions) == len(inside) > 100
    assert np.array_equal(positions, inside)


def test_mesh_errors_name_the_file_key(tmp_path):
    (tmp_path / "garbage.msh").write_text("not a mesh\n")
    meshio.write(tmp_path / "flat.vtu", meshio.Mesh(np.eye(3), [("triangle", [[0, 1, 2]])]))
    tree = edited()
    for name, file in [("g", "garbage.msh"), ("f", "flat.vtu"), ("m", "missing.vtu")]:
        tree["bodies"].append(box_body({"type": "mesh", "file": file}, name=name))
    problems = problems_of(tmp_path, tree)
    assert any(p.startswith("bodies[1].geometry.file: cannot read 'garbage.msh': ")
               for p in problems)
    assert ("bodies[2].geometry.file: cannot read 'flat.vtu': no tetra or hexahedron cells "
            "(found: triangle)") in problems
    assert "bodies[3].geometry.file: cannot read 'missing.vtu': no such file" in problems
    with pytest.raises(CaseError, match="body 'g' geometry.file: cannot read 'garbage.msh'"):
        fill_body(box_body({"type": "mesh", "file": "garbage.msh", "scale": 1.0,
                            "translate": [0, 0, 0]}, name="g"), GRID, tmp_path)


def test_fill_is_fast_for_a_million_particles(tmp_path):
    import time
    case = load(tmp_path, overrides=["params.cell=0.19"], check_geometry=False)
    start = time.perf_counter()
    positions, _ = fill_body(case["bodies"][0], case["grid"], tmp_path)
    assert len(positions) == 1341408
    assert time.perf_counter() - start < 5.0


def test_symmetry_planes_cut_the_body_into_a_quarter_model():
    from pmpm.case import fill_body
    grid = {"min": [-5.0, 0.0, 0.0], "max": [5.0, 5.0, 5.0], "cell": 0.5,
            "boundary": {"y-": "symmetry", "z-": "symmetry"}}
    body = {"name": "ball", "particles_per_cell": 2,
            "geometry": {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 3.0}}
    quarter, _ = fill_body(body, grid)
    assert quarter[:, 1:].min() > 0.0
    grid_full = dict(grid, min=[-5.0, -5.0, -5.0], boundary={})
    whole, _ = fill_body(body, grid_full)
    assert len(whole) == 4 * len(quarter)
