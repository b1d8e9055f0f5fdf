"""The validated case as frozen, typed records, built once: ``CaseConfig.from_case``.

The defaults live only in the schema's ``Field`` tables: a record takes every value from
the validated case dict, where the schema filled them, and states none of its own. Each
record mirrors one schema table (``mirrors`` checks that its attributes are that table's
keys, in order) and its docstring lists them with type, unit and meaning taken from the
table. A key the schema leaves out when it is not given (``OMIT``) is ``None``. Lists
become tuples and mappings ``ReadOnlyDict``s, so nothing in a record can be changed.
"""
import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .bodies import BODY
from .contact import CONTACT, PAIR
from .fem import CONSTRAINT, CONVERT, CONVERTED, FEM, fem_bodies_on_grid
from .fields import unwrap
from .rigid import RIGID
from .schema import (DECOMPOSITION, FACES, GRID, LOAD, OUTPUT, REGION, TIME, TOP_LEVEL,
                     read_time_function)
from .windows import WINDOW

__all__ = ["BodyConfig", "CaseConfig", "ConstraintConfig", "ContactConfig", "ConvertConfig",
           "DecompositionConfig", "FACES", "FemConfig", "RigidConfig",
           "GridConfig", "LoadConfig", "OutputConfig", "PairConfig", "ReadOnlyDict",
           "RegionConfig", "TimeConfig", "TimeFunctionConfig", "WindowConfig", "frozen",
           "thawed"]


class ReadOnlyDict(Mapping):
    """A mapping that cannot be changed (unlike ``MappingProxyType``, it pickles)."""

    def __init__(self, items):
        self._items = dict(items)

    def __getitem__(self, key):
        return self._items[key]

    def __iter__(self):
        return iter(self._items)

    def __len__(self):
        return len(self._items)

    def __repr__(self):
        return f"ReadOnlyDict({self._items!r})"


def frozen(value):
    """``value`` with every list turned into a tuple and every dict into a ReadOnlyDict."""
    if isinstance(value, dict):
        return ReadOnlyDict((key, frozen(item)) for key, item in value.items())
    if isinstance(value, (list, tuple)):
        return tuple(frozen(item) for item in value)
    return value


def thawed(value):
    """The plain dicts and lists of a ``frozen`` value (for JSON, YAML, ``validate_case``)."""
    if isinstance(value, Mapping):
        return {key: thawed(item) for key, item in value.items()}
    if isinstance(value, tuple):
        return [thawed(item) for item in value]
    return value


def mirrors(fields, **extra):
    """Class decorator for a frozen dataclass whose attributes are the keys of the schema
    table ``fields`` (then the ``extra`` ones, name=doc): checks the names and writes the
    Attributes section of the docstring from the table."""
    def decorate(cls):
        names = [f.name for f in dataclasses.fields(cls)]
        if names != list(fields) + list(extra):
            raise TypeError(f"{cls.__name__}: attributes {names} are not the schema keys "
                            f"{list(fields) + list(extra)}")
        lines = [_attribute_doc(key, field) for key, field in fields.items()]
        lines += [f"{key}\n    {doc}" for key, doc in extra.items()]
        cls.__doc__ = f"{cls.__doc__}\n\nAttributes\n----------\n" + "\n".join(lines)
        return cls
    return decorate


def _attribute_doc(key, field):
    unit = f" [{field.unit}]" if field.unit else ""
    return f"{key} : {field.read.kind()}{unit}\n    {field.doc}"


def record(cls, section, **built):
    """``cls`` from a validated section: each attribute is the section's key of that name
    (None where the key was left out), frozen; ``built`` gives the attributes built
    otherwise (nested records)."""
    values = {f.name: frozen(section.get(f.name)) for f in dataclasses.fields(cls)
              if f.name not in built}
    return cls(**values, **built)


def union_of(tagged):
    """One table with the keys of every type of a ``Tagged`` reader."""
    tagged = unwrap(tagged)
    table = {}
    for kind in tagged.variants:
        table.update(tagged.fields_of(kind))
    return table


@mirrors(TIME)
@dataclass(frozen=True)
class TimeConfig:
    """End time and time-step control (``time:``); ``dt_max`` None: no limit; ``dt``
    None: the step follows cfl, else it is fixed."""
    end: float
    cfl: float
    dt_max: float | None
    dt: float | None
    pic: float
    transfer: str
    scheme: str
    max_steps: float


@mirrors(OUTPUT)
@dataclass(frozen=True)
class OutputConfig:
    """Particle frames, history rows, checkpoints (``output:``)."""
    frames: int
    history_every: int
    checkpoint_every: int
    checkpoints: bool
    progress: bool
    precision: str
    forces: bool
    every: float
    probes: tuple
    times: tuple
    energy_warning: float
    energy_fault: float


@mirrors(DECOMPOSITION)
@dataclass(frozen=True)
class DecompositionConfig:
    """How the grid and the particles are shared among MPI ranks (``decomposition:``)."""
    axis: str
    rebalance_threshold: float
    check_every: int
    memory_limit_gb: float = None


@mirrors(WINDOW)
@dataclass(frozen=True)
class WindowConfig:
    """A refined window (``grid.windows[i]``); ``follow`` None: it does not move."""
    min: tuple
    max: tuple
    ratio: int
    follow: str | None


@mirrors(GRID)
@dataclass(frozen=True)
class GridConfig:
    """The background grid (``grid:``). ``boundary`` maps each face of ``FACES`` (x-, x+,
    y-, y+, z-, z+) to its condition name: fixed, slip, free or symmetry; ``friction`` each
    face to its Coulomb coefficient (0: none; only slip faces have one)."""
    min: tuple
    max: tuple
    cell: float
    shape_functions: str
    boundary: ReadOnlyDict
    friction: ReadOnlyDict
    windows: tuple
    exact_sums: bool
    lost_mass_fraction: float

    @classmethod
    def from_case(cls, grid, exact_sums=None):
        """``exact_sums``: the resolved ``grid.exact_sums`` (see :func:`exact_sums_on`)."""
        return record(cls, grid, windows=tuple(record(WindowConfig, w) for w in grid["windows"]),
                      exact_sums=grid.get("exact_sums") if exact_sums is None else exact_sums)


@mirrors(PAIR)
@dataclass(frozen=True)
class PairConfig:
    """The contact rules of one pair of bodies (``contact.pairs[i]``), resolved: a key the
    pair leaves out is the contact section's. ``separation`` None: no check."""
    bodies: tuple
    friction: float
    normal: str
    separation: float | None
    release: float | None
    coupling: str

    @classmethod
    def from_case(cls, pair, contact):
        inherited = {key: contact.get(key)
                     for key in ("friction", "normal", "separation", "release", "coupling")}
        return record(cls, {**inherited, **pair})


@mirrors(CONTACT)
@dataclass(frozen=True)
class ContactConfig:
    """Multi-body grid contact (``contact:``). ``method`` is 0 (none), 1 or 2;
    ``separation`` None: no separation check (left out or ``none``)."""
    method: int
    friction: float
    skip_separating: bool | str   # true, false or "auto"
    normal: str
    separation: float | None
    release: float | None
    gap: str
    coupling: str
    pairs: tuple

    @classmethod
    def from_case(cls, contact):
        pairs = tuple(PairConfig.from_case(pair, contact) for pair in contact["pairs"])
        return record(cls, contact, pairs=pairs)


@mirrors(REGION)
@dataclass(frozen=True)
class RegionConfig:
    """A box (``loads[i].region``)."""
    min: tuple
    max: tuple


@mirrors(union_of(read_time_function))
@dataclass(frozen=True)
class TimeFunctionConfig:
    """The factor a load is scaled with in time (``loads[i].time_function``); the keys of
    the other types are None."""
    type: str
    t_rise: float | None
    t: tuple | None
    f: tuple | None


@mirrors(LOAD)
@dataclass(frozen=True)
class LoadConfig:
    """A traction or force on the particles of one body inside a box (``loads[i]``)."""
    name: str
    body: str
    type: str
    region: RegionConfig
    value: tuple
    time_function: TimeFunctionConfig

    @classmethod
    def from_case(cls, load):
        return record(cls, load, region=record(RegionConfig, load["region"]),
                      time_function=record(TimeFunctionConfig, load["time_function"]))


@mirrors(CONVERT)
@dataclass(frozen=True)
class ConvertConfig:
    """When an FEM body's elements turn into particles (``bodies[i].fem.convert``); a
    criterion left out is None."""
    eps_p: float | None
    volume_ratio: float | None
    step_ratio: float | None
    failed: bool
    particles_per_direction: int


@mirrors(CONSTRAINT)
@dataclass(frozen=True)
class ConstraintConfig:
    """Velocity components held at zero on some nodes of an FEM body
    (``bodies[i].fem.constraints[j]``): ``region`` or ``node_set`` chooses them."""
    region: ReadOnlyDict | None
    node_set: str | None
    fix: tuple


@mirrors(FEM)
@dataclass(frozen=True)
class FemConfig:
    """An FEM body's mesh and elements (``bodies[i].fem``, completed by the schema:
    ``element_size`` and the hourglass defaults filled in); ``convert`` None: elements
    never convert; ``hourglass`` and ``hourglass_coefficient`` None for the
    ``assumed_strain`` element."""
    convert: ConvertConfig | None
    element_size: float
    element: str
    hourglass: str | None
    hourglass_coefficient: float | None
    constraints: tuple

    @classmethod
    def from_case(cls, fem):
        convert = fem.get("convert")
        return record(cls, fem,
                      convert=record(ConvertConfig, convert) if convert else None,
                      constraints=tuple(record(ConstraintConfig, c)
                                        for c in fem.get("constraints") or ()))


@mirrors(RIGID)
@dataclass(frozen=True)
class RigidConfig:
    """The motion of a body of a ``rigid`` material (``bodies[i].rigid``)."""
    free: tuple


@mirrors(BODY.fields, born_of="for a body the case does not list but the solver adds "
                               "(:func:`converted_bodies`): the FEM body whose elements' "
                               "particles it holds; None for the case's bodies")
@dataclass(frozen=True)
class BodyConfig:
    """A body (``bodies[i]``); ``geometry`` is the validated geometry mapping, read-only
    (its keys depend on its type: see the reference); ``fem`` None for a particle body."""
    name: str
    material: str
    geometry: ReadOnlyDict
    particles_per_cell: int
    velocity: tuple
    temperature: float | str | None
    method: str
    fem: FemConfig | None
    rigid: RigidConfig
    born_of: str | None = None

    @classmethod
    def from_case(cls, body):
        fem = FemConfig.from_case(body["fem"]) if body["method"] == "fem" else None
        return record(cls, body, fem=fem, rigid=record(RigidConfig, body.get("rigid") or {}))

    @property
    def is_fem(self):
        """Whether the body is a mesh of hexahedra (``method: fem``), not particles."""
        return self.method == "fem"

    @property
    def free_axes(self):
        """The translation components a rigid body leaves free (``rigid.free``)."""
        return self.rigid.free or ()

    @property
    def convert(self):
        """The conversion rules of an FEM body's elements, or None."""
        return self.fem.convert if self.is_fem else None

    @property
    def born_spacing(self):
        """The lattice spacing of the particles an FEM body's elements may become
        (``fem.convert``: element size / particles per direction), or None: the body
        never holds particles born of elements (the solver reads this, not ``convert``,
        to size those particles and to let them meet the mesh)."""
        if self.convert is None:
            return None
        return float(self.fem.element_size) / self.convert.particles_per_direction


def converted_bodies(case, bodies):
    """For each FEM body of ``bodies`` that converts and meets some body on the grid
    (``fem_bodies_on_grid``), a particle body of its material named NAME_converted that
    takes the particles its elements become (``born_of``), appended to the case's bodies.

    On the grid they must be a body of their own. In their FEM body's own field at a
    grid node they would take a share of its FE nodes' forces that the nodes never take
    back (an FE node takes from the grid only the contact correction of its field), so
    momentum would not be kept (seed 004's perforation: 0.2 % of the rod's momentum in
    the first step after a conversion). As a body of their own they meet the mesh they
    came from, and every other body, through the multi-velocity grid contact, as
    particles that surface contact keeps out of their own mesh's faces under IAFEMP."""
    on_grid = fem_bodies_on_grid(case)
    return tuple(BodyConfig(name=body.name + CONVERTED, material=body.material,
                            geometry=frozen({"type": "converted"}),
                            particles_per_cell=body.particles_per_cell,
                            velocity=(0.0, 0.0, 0.0), temperature=body.temperature,
                            method="particles", fem=None, rigid=record(RigidConfig, {}),
                            born_of=body.name)
                 for body in bodies if body.convert is not None and body.name in on_grid)


@mirrors(TOP_LEVEL, case="the whole validated case, read-only (``thawed(config.case)`` is "
                         "the plain dict, for ``fill_body`` and for output files)")
@dataclass(frozen=True)
class CaseConfig:
    """The validated case as records. ``materials`` maps each material name to its
    validated mapping, read-only (``pmpm.materials.catalog.pack`` takes it as it is)."""
    title: str
    params: ReadOnlyDict
    grid: GridConfig
    units: str
    gravity: tuple
    materials: ReadOnlyDict
    bodies: tuple
    loads: tuple
    time: TimeConfig
    output: OutputConfig
    decomposition: DecompositionConfig
    contact: ContactConfig
    case: ReadOnlyDict

    @classmethod
    def from_case(cls, case):
        """The records of a validated case dict (``load_case``, ``validate_case``)."""
        return record(
            cls, case, grid=GridConfig.from_case(case["grid"], exact_sums_on(case)),
            bodies=with_converted(tuple(BodyConfig.from_case(body)
                                        for body in case["bodies"]), case),
            loads=tuple(LoadConfig.from_case(load) for load in case["loads"]),
            time=record(TimeConfig, case["time"]), output=record(OutputConfig, case["output"]),
            decomposition=record(DecompositionConfig, case["decomposition"]),
            contact=ContactConfig.from_case(case["contact"]), case=frozen(case))


def converted_into(bodies):
    """(nb,) int64: per body of ``bodies`` (BodyConfig) the index of the particle body
    that takes its converted elements' particles (:func:`converted_bodies`), or -1 where
    they stay in the body."""
    names = [body.name for body in bodies]
    into = np.full(len(bodies), -1, np.int64)
    for i, body in enumerate(bodies):
        if body.born_of:
            into[names.index(body.born_of)] = i
    return into


def with_converted(bodies, case):
    """The case's bodies, then the particle bodies the solver adds for their converted
    elements (:func:`converted_bodies`; only where contact is met on the grid)."""
    if case["contact"].get("method", 0) == 0:
        return bodies
    return bodies + converted_bodies(case, bodies)


def exact_sums_on(case):
    """``grid.exact_sums`` resolved: ``auto`` is on where bodies can touch (two bodies or
    more with a contact method, or an FEM body: surface, node or grid coupling), where
    a contact decision would turn the sums' round-off into a different answer on another
    rank count."""
    value = case["grid"].get("exact_sums", "auto")
    if value != "auto":
        return bool(value)
    bodies = case["bodies"]
    fem = any(body.get("method") == "fem" for body in bodies)
    return len(bodies) > 1 and (case["contact"].get("method", 0) > 0 or fem)
