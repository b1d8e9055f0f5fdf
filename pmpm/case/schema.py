"""The case schema: the top-level sections, their keys, units, defaults and documentation,
and the checks that relate one section to another. ``validate_case`` runs the whole
pipeline on a raw tree.
"""
import copy
import dataclasses
import math

from .contact import CONTACT, check_contact, check_gap_measure, resolve_contact_defaults
from .windows import WINDOW, check_window_bodies, check_windows
from .bodies import BODY, _body_name, check_bodies_in_grid, check_mesh_files, check_min_below_max
from .errors import CaseError, Problems, join, unknown_name
from .fem import check_fem_bodies, check_fem_keys_on_particle_bodies
from .rigid import check_free_rigid
from .fields import (INVALID, Checked, Custom, Field, Marker, Tagged, at_least, at_most,
                     boolean, boolean_or_auto, choice, defaults_of, greater, has_invalid, integer, list_of,
                     mapping, number, number_list, read_mapping, text, valid, vector)
from .materials import MATERIALS
from .overrides import apply_overrides
from .params import resolve_params, substitute
from .timestep import AUTO as AUTO_CFL, CFL_DOC, read_cfl, resolve_step_default
from .size import check_memory
from .units import SYSTEMS, check_units

FACES = ("x-", "x+", "y-", "y+", "z-", "z+")
BOUNDARY_CONDITIONS = ("fixed", "slip", "free", "symmetry")
BOUNDARY = {face: Field(choice(BOUNDARY_CONDITIONS, "boundary condition"), "free",
                        doc=f"the face at grid.{'min' if face[1] == '-' else 'max'} "
                            f"along {face[0]}")
            for face in FACES}
FRICTION = {face: Field(number(at_least(0)), 0.0, "1",
                        f"Coulomb coefficient on face {face} (a slip face only)")
            for face in FACES}
TIME = {
    "end": Field(number(greater(0)), unit="ms", doc="simulated end time"),
    "cfl": Field(Custom(read_cfl, "number in (0, 1], or `auto`"), AUTO_CFL, "1", CFL_DOC),
    "dt_max": Field(number(greater(0)), None, "ms",
                    "upper limit on the time step (none: no limit)"),
    "dt": Field(number(greater(0)), None, "ms",
                "a fixed time step instead of cfl times the stable one (seed 004 Table 6 "
                "runs at 1, 2, 3 and 4e-5 ms; none: the step follows cfl): every step "
                "takes dt, shortened only to land on an output time and on time.end. A dt "
                "above the stable step (cfl 1) at the start is refused naming this key; "
                "if the step falls below dt later (faster waves, squeezed elements) the "
                "run stops with a fault, rather than blow up; elements of bodies with "
                "fem.convert turn into particles instead when their own step falls below "
                "dt. time.cfl and time.dt_max are then unused (give dt or dt_max, not "
                "both)"),
    "pic": Field(number(at_least(0), at_most(1)), 0.0, "1",
                 "share of the grid's velocity (PIC) in the particle velocity update; the "
                 "rest is the FLIP update v + a dt. 0: pure FLIP (no damping); a few per "
                 "cent damp the noise of particles crossing cells; 1: PIC, which damps "
                 "strongly"),
    "transfer": Field(choice(("flip", "apic"), "particle-grid transfer"), "flip",
                      doc="how velocities go between particles and grid: `flip` (default) "
                          "maps the particle velocity to the nodes and updates it with the "
                          "nodal acceleration (blended by time.pic); `apic`, the affine "
                          "particle-in-cell transfer (Jiang et al. 2015, with D_p = sum_i "
                          "w_ip (x_i - x_p)(x_i - x_p)^T for the 27-node shapes): each "
                          "particle also carries a 3x3 matrix B_p (column `affine`, B_p/h^2 "
                          "in 1/ms) of the velocity field about it, scatters m_p w_ip (v_p + "
                          "B_p D_p^-1 (x_i - x_p)) and takes the grid's velocity back, so "
                          "the transfers keep angular momentum (a spinning body keeps its "
                          "spin, a frictional impact the spin its impulse gives) without "
                          "PIC's damping. Costs about 1.8 times FLIP's time in the "
                          "particle-to-grid loop and 1.4 times in the grid-to-particle loop "
                          "(the column's 72 bytes per particle are held under flip too). "
                          "Needs gimp or bspline "
                          "shape functions, time.pic 0 and no refined window (the tied "
                          "interface loses the spin); the initial velocity field's "
                          "gradient is not given to B_p (it starts at 0)"),
    "scheme": Field(choice(("usf", "musl"), "update scheme"), "usf",
                    doc="update order: `usf` updates the stresses first, from the nodal "
                        "velocities of the start of the step (seed 000 Sec. 2, seed 001 "
                        "Sec. 4); `musl` (modified update stress last) takes the nodal "
                        "forces from the start-of-step stresses, then updates the stresses "
                        "from the new particle velocities mapped back to the grid: one more "
                        "particle-to-grid pass, and it resists the cell-crossing instability "
                        "of soft bodies with free surfaces"),
    "max_steps": Field(number(greater(0)), 1e8, "steps",
                       "the most time steps a run may take, estimated before it starts as "
                       "(end - start) / first time step: a case that needs more is refused, "
                       "so that a wrong speed or end time does not start a run that cannot "
                       "finish; raise it for a run meant to be that long"),
}
REGION = {"min": Field(vector(), unit="mm", doc="lower corner of the box"),
          "max": Field(vector(), unit="mm", doc="upper corner of the box (min < max)")}


PROBE = {
    "name": Field(Custom(_body_name, "string of letters, digits, _, -"),
                  doc="the probe's name: its history goes to probe_NAME.csv"),
    "body": Field(text(), doc="the body it samples: its particles, or an FEM body's "
                              "nodes (position and velocity; the stress columns read NaN)"),
    "point": Field(vector(), None, unit="mm",
                   doc="the body's particle (or FE node) nearest this point at the start is "
                       "followed (ties: the lower id); the same on any number of ranks. "
                       "A probe names one of point, id and region"),
    "id": Field(integer(at_least(0)), None,
                doc="the id of the particle (or FE node) to follow, as in the frames' "
                    "`id` column (or elements.h5's node ids)"),
    "region": Field(mapping(REGION), None, unit="mm",
                    doc="a tagged group: the body's particles (or FE nodes) inside this "
                        "box at the start, wherever they go; the row holds their "
                        "mass-weighted means (von_mises: the mean of their von Mises "
                        "stresses)"),
    "fixed": Field(boolean(), False,
                   doc="true: a gauge fixed in space: at every history row the body's "
                       "particle (or FE node) nearest `point` then is sampled, instead of "
                       "following one (with point only)"),
}
PROBE_TARGETS = ("point", "id", "region")
OUTPUT = {
    "frames": Field(integer(at_least(1)), 10,
                    doc="particle frames written after the initial one, equally spaced in "
                        "time; the initial and the final state are always frames"),
    "history_every": Field(integer(at_least(1)), 10, "steps",
                           "steps between rows of history.csv"),
    "checkpoint_every": Field(integer(at_least(0)), 0, "steps",
                              "steps between checkpoints; 0: at every frame (every run "
                              "also ends with a checkpoint)"),
    "checkpoints": Field(boolean(), True,
                         doc="write checkpoints (false: none during the run or at its end, "
                             "to save disk; a SIGTERM or SIGINT still writes one so that "
                             "the run can be continued)"),
    "progress": Field(boolean(), True, doc="print progress lines (rank 0)"),
    "precision": Field(choice(("float64", "float32"), "frame precision"), "float64",
                       doc="floating-point precision of the frames (particles.h5, "
                           "elements.h5): `float32` halves them on disk (about 7 "
                           "significant digits); checkpoints stay float64, so a restart "
                           "is exact either way"),
    "forces": Field(boolean(), True,
                    doc="write forces.csv at every history row: the contact force on each "
                        "body from each other body (x, y, z, normal, tangential), the "
                        "reaction of each constrained grid face and of each FEM body's "
                        "constrained nodes, as the mean force since the previous row "
                        "(force units: g mm/ms^2 = N in mm-ms-g), so that a column "
                        "integrated over time is the impulse; and per pair and face the "
                        "energy its friction has dissipated since the start, summed in "
                        "history.csv's dissipated (false: neither is measured; "
                        "dissipated reads NaN)"),
    "every": Field(number(greater(0)), None, "ms",
                   "a frame at every multiple of this time, besides `frames` (given "
                   "without `frames`, only these and the final frame are written)"),
    "probes": Field(list_of(mapping(PROBE), 0, "probe"), [],
                    doc="points followed through the run, or gauges fixed in space: at "
                        "every history row probe_NAME.csv gets its position, velocity, stress, eps_p, "
                        "pressure and von Mises stress"),
    "times": Field(number_list(0), [], "ms",
                   "extra frame times, each in (0, time.end], written besides the equally "
                   "spaced ones"),
    "energy_warning": Field(number(at_least(0)), 0.05, "1",
                            "warn (once) when the energy balance (kinetic + internal + "
                            "gravitational, less the work of loads) has grown by more than "
                            "this fraction since the start, and when it has lost more than "
                            "this fraction (plastic work and hourglass energy are no loss: "
                            "they stay in the internal energy); 0: never"),
    "energy_fault": Field(number(at_least(0)), 10.0, "1",
                          "stop the run as a fault (exit 1) when the energy balance has "
                          "grown by more than this fraction since the start (10: to 11 "
                          "times the energy the run was given): numerical energy that "
                          "large (an unstable step, contact pushing bodies apart) leaves "
                          "no answer worth keeping, and an instability passes any bound "
                          "within steps; the hats' known gains (+69 % on the vibrating "
                          "bar, +101 % on the two bars parting at 0.25 mm) stay below "
                          "it; 0: never"),
}
DECOMPOSITION = {
    "axis": Field(choice(("auto", "x", "y", "z"), "axis"), "auto",
                  doc="axis the grid is cut into slabs of coarse cells along (`auto`: the "
                      "one that balances the work best)"),
    "rebalance_threshold": Field(number(greater(0)), 0.2, "1",
                                 "the slabs are moved when the weighted imbalance, max/mean "
                                 "work per rank - 1, exceeds it: a particle counts 1, an FEM "
                                 "element (by its centroid) what its step costs in "
                                 "particle-steps of the case's shape functions, a fixed "
                                 "table per element formulation (pmpm.solver.work_weights; "
                                 "summary.json: `element_weights`, `slabs.imbalance`)"),
    "check_every": Field(integer(at_least(1)), 50, "steps", "steps between balance checks"),
    "memory_limit_gb": Field(number(greater(0)), None, "GB",
                             "memory the run may use on this machine, all its ranks "
                             "together (none: the machine's available memory); a case "
                             "estimated (from its bodies' volumes, before they are filled) "
                             "to need more is refused"),
}
TIME_FUNCTIONS = {
    "constant": {},
    "ramp": {"t_rise": Field(number(greater(0)), unit="ms",
                             doc="rises linearly from 0 at t = 0 to 1 at t_rise, then "
                                 "stays 1")},
    "table": {"t": Field(number_list(2), unit="ms",
                         doc="times, strictly increasing, as many as f"),
              "f": Field(number_list(2), unit="1",
                         doc="factors at the times t: piecewise linear between them, held "
                             "at the end values outside them")},
}
def _check_table(function, path, problems):
    """A table's t and f have the same length and t increases strictly."""
    if not valid(function, "t", "f"):
        return function
    t, f = function["t"], function["f"]
    if len(t) != len(f):
        problems.add(path, f"t and f must have the same length (got {len(t)} and {len(f)})")
    elif any(b <= a for a, b in zip(t, t[1:])):
        problems.add(join(path, "t"), "times must increase strictly")
    return function


def _check_region(load, path, problems):
    if valid(load, "region"):
        check_min_below_max(load["region"], join(path, "region"), problems)
    return load


TIME_FUNCTION_DOCS = {
    "constant": "1 at all times",
    "ramp": "linear from 0 at t = 0 to 1 at t_rise, then 1",
    "table": "piecewise linear through the points (t, f), held at the end values outside them",
}
read_time_function = Checked(Tagged(TIME_FUNCTIONS, "time function", {}, TIME_FUNCTION_DOCS),
                             _check_table)
LOAD = {
    "name": Field(text(), doc="unique among loads"),
    "body": Field(text(), doc="the loaded body's name"),
    "type": Field(choice(("traction", "force"), "load type"),
                  doc="`traction`: value is a stress, and each selected particle gets "
                      "value * vol^(2/3) (its face area); `force`: value is a total force, "
                      "shared equally among the selected particles"),
    "region": Field(mapping(REGION), unit="mm",
                    doc="the particles of body inside this box at t = 0 are loaded (one "
                        "that selects no particle is an error when the run starts)"),
    "value": Field(vector(), unit="MPa or N", doc="the traction or the total force"),
    "time_function": Field(read_time_function, {"type": "constant"},
                           doc="scales value in time: `constant` (1), `ramp` or `table`"),
}
read_load = Checked(mapping(LOAD), _check_region)


#: The most cells a grid box may hold: node indices are 64-bit integers.
MAX_GRID_CELLS = 1e18


#: The largest cell edge: a cell's volume must be a finite double (pmpm is
#: unit-agnostic, so no physical bound is implied).
MAX_CELL = 1e100


def _check_grid(grid, path, problems):
    if valid(grid, "cell") and grid["cell"] > MAX_CELL:
        problems.add(join(path, "cell"), f"{grid['cell']:g} is too large: a cell's volume "
                     f"must be a finite number (at most {MAX_CELL:g})")
        grid["cell"] = INVALID
    if check_min_below_max(grid, path, problems) and valid(grid, "cell"):
        cells = [(b - a) / grid["cell"] for a, b in zip(grid["min"], grid["max"])]
        if not all(math.isfinite(n) for n in cells) or math.prod(cells) > MAX_GRID_CELLS:
            problems.add(join(path, "max"), "the grid box holds " + " x ".join(
                f"{n:.3g}" for n in cells) + f" cells of grid.cell = {grid['cell']:g}, "
                f"more than the {MAX_GRID_CELLS:.0e} its node indices can count")
            grid["max"] = INVALID
            return grid
        grid["max"] = rounded_max(grid["min"], grid["max"], grid["cell"])
        check_windows(grid, path, problems)
    _check_friction_faces(grid, path, problems)
    return grid


def _check_friction_faces(grid, path, problems):
    """Friction only on slip faces (a fixed face already stops the material, a free one
    does not touch it, a symmetry plane has none)."""
    if not isinstance(grid, dict):
        return
    friction, boundary = grid.get("friction"), grid.get("boundary")
    if not isinstance(friction, dict) or not isinstance(boundary, dict):
        return
    for face, mu in friction.items():
        condition = boundary.get(face)
        if isinstance(mu, (int, float)) and mu > 0 and condition != "slip":
            problems.add(join(join(path, "friction"), face),
                         f"friction {mu:g} on a {condition} face; only a slip face takes "
                         f"friction (set grid.boundary.{face}: slip)")


def rounded_max(low, high, cell):
    """``high`` moved up so that ``high - low`` is a whole number of cells (the result is
    tidied to 12 significant digits: the solver takes round((max - min) / cell) cells)."""
    cells = [math.ceil((b - a) / cell - 1e-9) for a, b in zip(low, high)]
    return [float(f"{a + n * cell:.12g}") for a, n in zip(low, cells)]


GRID = {
    "min": Field(vector(), unit="mm", doc="lower corner of the grid box"),
    "max": Field(vector(), unit="mm",
                 doc="upper corner of the grid box; rounded up so that max - min is a "
                     "whole number of cells (the rounded value is stored)"),
    "cell": Field(number(greater(0)), unit="mm", doc="cell size h (cubic cells)"),
    "shape_functions": Field(
        choice(("linear", "gimp", "bspline"), "shape function"), "gimp",
        doc="`gimp` (default): uniform GIMP, the hat smoothed over the particle's width "
            "(cell / particles_per_cell), 27 nodes; `bspline`: quadratic B-splines, 27 "
            "nodes; `linear`: trilinear hats on 8 nodes (seed 000 Eq. 5; the seed cases "
            "in runs/ use them, as the papers did). The 27-node shapes have continuous "
            "gradients, so particles crossing cells keep the energy (USF, cfl 0.5: "
            "vibrating bar +0.4 % against +69 % with hats; a shock in copper +1.2 % "
            "against +18 %), at about 4 times the hats' cost per particle. gimp is the "
            "default because it also holds the bar's period across tied windows and the "
            "shock's plateau to 2 %, where bspline is 0.9 % and 3.7 % off; "
            "docs/validation/vibrating_bar.md"),
    "boundary": Field(mapping(BOUNDARY), defaults_of(BOUNDARY),
                      doc="the condition on each face of the grid box"),
    "friction": Field(mapping(FRICTION), defaults_of(FRICTION),
                      doc="Coulomb friction on slip faces, e.g. `{z-: 0.3}`: such a face is "
                          "a wall the material may leave; where it presses on it, its "
                          "tangential velocity changes by at most mu times the normal "
                          "change, so a block slides decelerating at mu g or sticks "
                          "(docs/validation/wall_friction.md)"),
    "windows": Field(list_of(mapping(WINDOW), 0, "window"), [],
                     doc="refined sub-grids tied to the coarse grid (seed 000 Secs. 3-4)"),
    "exact_sums": Field(boolean_or_auto(), "auto",
                        doc="sums that do not depend on the rank count, so that a run on "
                            "N ranks gives the one-rank answer to the bit however long it "
                            "runs and through contact decisions: the particles' "
                            "contributions to each node (grid contact's per-body fields "
                            "and surface contact's grid sums too) are added by cell layer "
                            "along the slab axis, then by particle id, and the FE nodes "
                            "ranks share by element id (pmpm.kernels.layered); an `auto` "
                            "slab axis is then the axis two ranks would cut, on any number "
                            "of ranks that admits it. Refined windows too (their ties are "
                            "added after the sums, in the one-rank order), and grid-coupled "
                            "FE nodes (their own layered sums, added to the particles' "
                            "once both are complete). `auto` (the "
                            "default): on where bodies can touch (two bodies or more with "
                            "a contact method, or an FEM body), where contact decisions "
                            "would turn round-off into different answers; off otherwise, "
                            "where N ranks differ from one by round-off that stays "
                            "round-off. Costs 10 to 20 % of the step loop (Taylor bar, "
                            "0.90 at 0.76 mm, 0.79-0.81 at 0.38 mm, hats and gimp; "
                            "docs/performance-notes.md)"),
    "lost_mass_fraction": Field(number(at_least(0), at_most(1)), 0.0, "1",
                                "share of each body's initial mass that may leave the grid "
                                "box (its particles are dropped, and counted in the progress "
                                "lines and summary.json); more stops the run with a fault "
                                "naming the body (a body of converted elements, "
                                "NAME_converted: a share of its FEM body's initial mass). 0: "
                                "the first particle to leave stops it; perforation cases "
                                "allow a little for fragments"),
}
read_grid = Checked(mapping(GRID), _check_grid)
CASE_FILE_NAME = Marker("the case file's name without .yaml")
TOP_LEVEL = {
    "title": Field(text(), CASE_FILE_NAME, doc="the case's name, shown in outputs"),
    "params": Field(Custom(lambda value, path, problems: value, "mapping name: number"), {},
                    doc="parameters for ${...} expressions"),
    "grid": Field(read_grid, doc="the background grid"),
    "units": Field(choice(SYSTEMS, "unit system"), "mm-ms-g",
                   doc="the case's consistent unit system: mm-ms-g (stress MPa, velocity "
                       "m/s, energy mJ), m-s-kg (SI), or other; densities, moduli and "
                       "sound speeds outside the range real materials span in it are "
                       "refused (pmpm.case.units; other: not checked)"),
    "gravity": Field(vector(), [0.0, 0.0, 0.0], "mm/ms^2",
                     "body acceleration (Earth: 9.81e-3 mm/ms^2)"),
    "materials": Field(MATERIALS, doc="the materials by name (at least one)"),
    "bodies": Field(list_of(BODY, 1, "body"), doc="the bodies filled with particles"),
    "loads": Field(list_of(read_load, 0, "load"), [],
                   doc="tractions and forces on the particles of a body"),
    "time": Field(mapping(TIME), doc="end time and time-step control"),
    "output": Field(mapping(OUTPUT), defaults_of(OUTPUT),
                    doc="particle frames, history rows, checkpoints"),
    "decomposition": Field(mapping(DECOMPOSITION), defaults_of(DECOMPOSITION),
                           doc="how the grid and the particles are shared among MPI ranks"),
    "contact": Field(mapping(CONTACT), defaults_of(CONTACT),
                     doc="multi-body grid contact (seed 001 Secs. 2-4)"),
}


def top_level_fields(default_title):
    """The top-level table with the title's default: the case file's name."""
    return {**TOP_LEVEL, "title": dataclasses.replace(TOP_LEVEL["title"], default=default_title)}


def validate_case(raw, case_dir=".", default_title="case", overrides=(),
                  check_geometry=True, problems=None):
    """Validated case dict from the raw YAML tree ``raw`` (see ``load_case``)."""
    problems = problems if problems is not None else Problems()
    if not isinstance(raw, dict):
        raise CaseError(list(problems.lines) + ["(case): expected a mapping of sections "
                                                "(grid, materials, bodies, time, ...)"])
    tree = copy.deepcopy(raw)
    apply_overrides(tree, overrides, problems)
    params = resolve_params(tree.get("params"), problems)
    tree = {k: (v if k == "params" else substitute(v, params, problems, k))
            for k, v in tree.items()}
    case = read_mapping(tree, "", top_level_fields(default_title), problems)
    case["params"] = params
    check_references(case, problems)
    check_units(case, problems)
    check_transfer(case, problems)
    check_fixed_step(case, problems)
    bodies = [] if case["bodies"] is INVALID else case["bodies"]
    if check_geometry and valid(case["grid"], "min", "max", "cell", "windows", "boundary"):
        if _fits_in_memory(case, bodies, case_dir, problems):
            check_bodies_in_grid(bodies, case["grid"], case_dir, problems)
    else:
        check_mesh_files(bodies, case_dir, problems)
    check_fem_bodies(case, case_dir, check_geometry, problems)
    check_fem_keys_on_particle_bodies(tree.get("bodies"), case["bodies"], problems)
    frames_from_every(tree.get("output"), case["output"])
    check_free_rigid(case, problems)
    problems.raise_if_any()
    resolve_contact_defaults(case)
    resolve_step_default(case)
    return case


def frames_from_every(raw, output):
    """``output.every`` given without ``output.frames``: the frames are the multiples of
    ``every`` (and the final state), not those besides the default count of frames."""
    if isinstance(raw, dict) and "every" in raw and "frames" not in raw and \
            valid(output, "every") and output["every"] is not None:
        output["frames"] = 1


def _fits_in_memory(case, bodies, case_dir, problems):
    """The memory estimate before any body is filled (a case of 1e10 particles would
    otherwise be filled here, on every rank, until memory runs out)."""
    whole = {i: b for i, b in enumerate(bodies)
             if b is not INVALID and not has_invalid(b["geometry"], b["particles_per_cell"])}
    decomposition = case["decomposition"]
    if not whole or not valid(decomposition, "memory_limit_gb"):
        return True
    return check_memory(whole, case["grid"], decomposition["memory_limit_gb"], case_dir,
                        problems)


def check_references(case, problems):
    """Names are unique and every name referred to exists."""
    bodies = [] if case["bodies"] is INVALID else case["bodies"]
    loads = [] if case["loads"] is INVALID else case["loads"]
    materials = case["materials"]
    body_names = _unique_names(bodies, "bodies", problems)
    _unique_names(loads, "loads", problems)
    for i, body in enumerate(bodies):
        if materials is not INVALID and valid(body, "material") \
                and body["material"] not in materials:
            problems.add(join(join("bodies", i), "material"),
                         unknown_name("material", body["material"], materials))
    _check_output_times(case, problems)
    _check_probes(case, body_names, problems)
    if all(valid(body, "name") for body in bodies):
        check_contact(case["contact"], body_names, problems)
        check_gap_measure(case["contact"], case["grid"], problems)
        check_window_bodies(case["grid"], body_names, problems)
    names_complete = all(valid(body, "name") for body in bodies)
    for i, load in enumerate(loads):
        if valid(load, "body") and names_complete and load["body"] not in body_names:
            problems.add(join(join("loads", i), "body"),
                         unknown_name("body", load["body"], body_names))


def check_fixed_step(case, problems):
    """A fixed step (time.dt) replaces the step control: dt_max beside it would be
    ignored."""
    time = case["time"]
    if valid(time, "dt", "dt_max") and time["dt"] is not None and time["dt_max"] is not None:
        problems.add("time.dt", f"give time.dt (a fixed step, {time['dt']:g}) or "
                     f"time.dt_max (a limit on the cfl step, {time['dt_max']:g}), not both")


def check_transfer(case, problems):
    """APIC needs a shape whose D_p is invertible everywhere (not the hat), takes the
    grid's velocity itself (no FLIP/PIC blend) and is not yet served across the tied
    interface of a refined window."""
    time, grid = case["time"], case["grid"]
    if not valid(time, "transfer") or time["transfer"] != "apic":
        return
    if valid(time, "pic") and time["pic"] > 0:
        problems.add("time.transfer", f"apic takes the grid's velocity itself; it does not "
                     f"blend with time.pic = {time['pic']:g} (set time.pic: 0)")
    if valid(grid, "shape_functions") and grid["shape_functions"] == "linear":
        problems.add("time.transfer", "apic needs grid.shape_functions gimp or bspline: "
                     "the hat's D_p is singular where a particle sits on a node")
    if valid(grid, "windows") and any(w.get("ratio", 1) != 1 for w in grid["windows"]
                                      if isinstance(w, dict)):
        problems.add("time.transfer", "apic does not keep angular momentum across a tied "
                     "window's interface yet (a spinning cube half under a ratio-2 window "
                     "keeps 35 % in two turns, FLIP 78 %): remove grid.windows or use flip")


#: The most frames a run may write: each is a group of particles.h5 and a grid of the
#: XDMF, and the output schedule lists them all before the run starts.
MAX_FRAMES = 1_000_000


def _check_output_times(case, problems):
    output = case["output"]
    if valid(output, "frames") and output["frames"] > MAX_FRAMES:
        problems.add("output.frames", f"{output['frames']:.6g} frames: at most {MAX_FRAMES:,} "
                     f"(each is a group of particles.h5)")
    if not (valid(case["output"], "times") and valid(case["time"], "end")):
        return
    end = case["time"]["end"]
    for i, t in enumerate(case["output"]["times"]):
        if not 0 < t <= end:
            problems.add(f"output.times[{i}]", f"must be in (0, time.end = {end:g}], got {t:g}")


def _check_probes(case, body_names, problems):
    """Probe names unique; each samples a body that exists."""
    if not valid(case["output"], "probes"):
        return
    probes = case["output"]["probes"]
    _unique_names(probes, "output.probes", problems)
    bodies = {b["name"]: b for b in case["bodies"] if valid(b, "name")} \
        if case["bodies"] is not INVALID else {}
    for i, probe in enumerate(probes):
        _check_probe_target(probe, join("output.probes", i), problems)
        if not valid(probe, "body"):
            continue
        path = join(join("output.probes", i), "body")
        body = bodies.get(probe["body"])
        if body is None:
            problems.add(path, unknown_name("body", probe["body"], body_names))


def _check_probe_target(probe, path, problems):
    """A probe names exactly one of point, id and region; fixed goes with point."""
    if probe is INVALID or not isinstance(probe, dict):
        return
    named = [key for key in PROBE_TARGETS if probe.get(key) is not None]
    if len(named) != 1:
        problems.add(path, f"give exactly one of point, id and region to say what the "
                           f"probe samples, got {', '.join(named) if named else 'none'}")
    if probe.get("fixed") is True and probe.get("point") is None:
        problems.add(join(path, "fixed"), "a fixed gauge samples at `point`: give point")
    if valid(probe, "region") and probe["region"] is not None:
        check_min_below_max(probe["region"], join(path, "region"), problems)


def _unique_names(items, section, problems):
    first = {}
    for i, item in enumerate(items):
        if not valid(item, "name"):
            continue
        name = item["name"]
        if name in first:
            problems.add(join(join(section, i), "name"),
                         f"duplicate name {name!r} (also {section}[{first[name]}])")
        first.setdefault(name, i)
    return first
