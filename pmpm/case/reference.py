"""The case-file reference, ``docs/case-file.md``, generated from the schema tables.

    python -m pmpm.case.reference > docs/case-file.md
    python -m pmpm.case.reference --write

Every table of keys is walked from ``schema.TOP_LEVEL`` through the readers that hold
nested tables (``Nested``, ``ListOf``, ``NamedItems`` and the tagged readers, which
pick a table by ``type`` or ``model``); the prose around the tables is in ``NOTES``.
"""
import pathlib
import sys
from dataclasses import dataclass

from .expressions import CONSTANTS, FUNCTIONS
from .fields import OMIT, REQUIRED, ListOf, Marker, NamedItems, Nested, defaults_of, unwrap
from .schema import TOP_LEVEL

DOC_PATH = pathlib.Path(__file__).resolve().parents[2] / "docs" / "case-file.md"
COMMAND = "python -m pmpm.case.reference --write"


@dataclass(frozen=True)
class Section:
    """One table of the reference: the keys at ``path``; for a tagged mapping, those of
    one ``variant`` (``"type: box"``), which ``doc`` describes."""
    path: str
    fields: dict
    variant: str = ""
    doc: str = ""


def sections(path="", fields=TOP_LEVEL):
    """The table at ``path`` and every table nested in it, each once, in schema order."""
    seen, unique = set(), []
    for section in _walk(path, fields):
        if (section.path, section.variant) not in seen:
            seen.add((section.path, section.variant))
            unique.append(section)
    return unique


def _walk(path, fields):
    yield Section(path, fields)
    yield from _nested(path, fields)


def _nested(path, fields):
    for key, field in fields.items():
        yield from _sections_of(f"{path}.{key}" if path else key, unwrap(field.read))


def _sections_of(path, reader):
    if isinstance(reader, Nested):
        yield from _walk(path, reader.fields)
    elif isinstance(reader, ListOf):
        yield from _sections_of(path + "[i]", unwrap(reader.item))
    elif isinstance(reader, NamedItems):
        yield from _sections_of(path + ".NAME", unwrap(reader.item))
    elif hasattr(reader, "fields_of"):
        yield from _tagged(path, reader)


def _tagged(path, reader):
    """The tag and common keys, then one table per variant, then what they nest."""
    tag = reader.fields_of(next(iter(reader.variants)))[reader.tag]
    yield Section(path, {reader.tag: tag, **reader.common})
    own = {kind: {key: field for key, field in reader.fields_of(kind).items()
                  if key != reader.tag and key not in reader.common}
           for kind in reader.variants}
    for kind, fields in own.items():
        yield Section(path, fields, f"{reader.tag}: {kind}", reader.variant_doc(kind))
    for fields in own.values():
        yield from _nested(path, fields)
    yield from _nested(path, reader.common)


# --- Markdown ---------------------------------------------------------------------------

def render_default(field):
    """The default column: required, - (left out), or the value as YAML would show it."""
    default = field.default
    if default is REQUIRED:
        return "required"
    if default is OMIT:
        return "-"
    if isinstance(default, Marker):
        return default.name
    reader = unwrap(field.read)
    if isinstance(reader, Nested) and default == defaults_of(reader.fields) and default:
        return "all defaults"
    return f"`{_yaml(default)}`"


def _yaml(value):
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, list):
        return "[" + ", ".join(_yaml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_yaml(v)}" for k, v in value.items()) + "}"
    return str(value)


def table(fields):
    """A Markdown table of ``fields``: key | type | default | unit | description."""
    if not fields:
        return "No other keys.\n"
    rows = ["| key | type | default | unit | description |", "|---|---|---|---|---|"]
    rows += [f"| `{key}` | {field.read.kind()} | {render_default(field)} | {field.unit} | "
             f"{field.doc} |" for key, field in fields.items()]
    return "\n".join(rows) + "\n"


def heading(section):
    if section.variant:
        return f"#### `{section.path}` with `{section.variant}`"
    return f"### `{section.path}`" if section.path else "### Top level"


def render_section(section):
    parts = [heading(section), ""]
    note = _sentence(section.doc) if section.variant else NOTES.get(section.path, "")
    if note:
        parts += [note.strip(), ""]
    parts.append(table(section.fields))
    return "\n".join(parts)


def _sentence(doc):
    return doc[:1].upper() + doc[1:] + "." if doc else ""


def reference():
    """The whole reference page (Markdown)."""
    intro = INTRO.format(command=COMMAND, functions=" ".join(FUNCTIONS),
                         constants=" ".join(CONSTANTS))
    return intro.lstrip() + "\n" + "\n".join(render_section(s) for s in sections())


INTRO = """
# The case file

<!-- Generated from the schema in pmpm/case/ by `{command}`; do not edit by hand. -->

A case is one YAML file. `python -m pmpm CASE.yaml` reads it, applies the `--set`
overrides, substitutes the parameters, checks every key and value, fills the defaults,
and only then starts computing. If anything is wrong it prints one line per problem, all
of them at once, each naming the key path, and exits with status 2:

```
bodies[1].material: unknown material 'stel'; known: copper, steel (did you mean 'steel'?)
grid.boundary.z-: unknown boundary condition 'fixd'; known: fixed, free, slip, symmetry (did you mean 'fixed'?)
```

Unknown keys are errors (with a "did you mean" when a known key is close), so a typo
never falls back silently to a default.

## Exit codes and what each refusal means

| exit | when | the line names |
|---|---|---|
| 0 | the run reached `time.end` | |
| 2 | bad input, found before anything is computed: a key's value, a body outside the grid box or overlapping another, a run too large for `time.max_steps`, the memory or the disk | the key path |
| 2 | the output directory: not empty without `--force` or `--restart`, holding what a run did not write, in use by another run (its lock `DIR/pmpm.lock` names the holder's pid, host and start), or not writable | `--out` |
| 2 | an FEM body's mesh file: a node that is not finite, a hexahedron naming a node the file does not have (negative indices too), nodes at the same place that are not merged, a hexahedron listed twice, no hexahedra, other volume cells beside them, an inverted element | `bodies[i].geometry.file` and the node or hexahedron |
| 2 | an FEM body: nodes outside the grid box at the start; more than 1e8 elements; an `hourglass_coefficient` above 0.5; met on the grid by some particle bodies and by surface contact by others; a pair of FEM bodies on the grid under a contact.method other than 1, or in node-to-surface contact while one meets particle bodies on the grid | `bodies[i].geometry`, `bodies[i].fem.*`, `contact.*coupling` |
| 1 | a fault during the run (NaN, failed constitutive update, non-positive density or element volume, a body lost out of the grid box, an FE node beyond a free face, an energy balance grown past `output.energy_fault`) | the step, and the point, element or node |
| 3 | interrupted by SIGTERM or SIGINT: every rank finishes its step and a checkpoint is written; `--restart` continues it (under `mpirun`, mpirun itself reports 1 when it was signalled) | the checkpoint |

Warnings (the run goes on): the energy balance grown past `output.energy_warning`; an
FEM body met on the grid (CFEMP) with elements wider than 1.5 cells, naming the ratio
(particles leak between its nodes); particles meeting an FEM body by surface contact
(ICFEMP) at a `time.cfl` above 0.5 (the contact's energy error grows with the step); a
stale lock of a run that is no longer running, replaced.

## Units

pmpm is unit-agnostic: a case uses one consistent system. The unit column below names
each quantity's unit in the system of the shipped cases, **mm, ms, g**: stress in MPa,
velocity in mm/ms (= m/s), acceleration in mm/ms^2, density in g/mm^3, force in N,
energy in mJ, specific heat in mJ/(g K) (= J/(kg K)), temperature in K. `1` marks a pure
number, `cells` a multiple of the cell size, `steps` a number of time steps; an empty
unit, something that is not a physical quantity.

## Types and defaults

*number* is an integer or a decimal (`117e3`, `1.5e-3` and `8.93e-3` are numbers);
*int* is a whole number; *vector* is a list of three numbers `[x, y, z]`; a list of
back-quoted words means one of them. A default "required" means the key must be given;
"-" means it may be left out and is then absent from the validated case.

## Parameters and expressions

```yaml
params:
  cell: 0.38
  diameter: 10
  radius: "${{diameter / 2}}"            # a parameter may use other parameters
title: "steel ball, cell ${{cell}} mm"   # ${{...}} inside text is replaced by its value's text
```

- `params:` maps names (letters, digits, `_`; not starting with a digit) to numbers, or
  to `"${{expr}}"` over other parameters, resolved in dependency order (a cycle is an
  error).
- Anywhere else, a string that is exactly `"${{expr}}"` becomes the number `expr`
  evaluates to; `${{expr}}` inside a longer string is replaced by the number's text.
  Quote such strings in YAML (`"${{-v0}}"`).
- `expr` may use numbers, parameter names, the constants `{constants}`,
  `+ - * / **`, parentheses, unary minus and the functions `{functions}` (angles in
  radians). Nothing else is evaluated (no Python `eval`); these names cannot be
  parameters.
- An unknown parameter name is an error naming the key where it was used.

## Overrides: `--set KEY=VALUE`

`--set` changes any key before the parameters are substituted, so a sweep only needs
`--set params.NAME=VALUE`. KEY is a dotted path; list items are numbered from 0 and may
be written either way. VALUE is read as YAML.

```
python -m pmpm taylor.yaml --set params.cell=0.38 --set time.end=0.01
python -m pmpm taylor.yaml --set "bodies[0].velocity=[0, 0, -150]" --set grid.boundary.z-=slip
```

Missing mappings along the path are created (`--set time.dt_max=1e-5`); list items must
exist. A key that the schema does not know is reported like a typo in the file.

## Reference

`[i]` is an item of a list, `NAME` a key of a mapping of names.
"""

NOTES = {
    "grid": "The background grid: a box of cubic cells.",
    "grid.boundary": """
Each face of the grid box: `fixed` (every velocity component zero), `slip` (the normal
component zero), `free` (nothing), `symmetry` (a symmetry plane for half and quarter
models: a `slip` face at which bodies are also cut, so a sphere centred on two symmetry
planes fills as a quarter sphere).""",
    "grid.windows[i]": """
A window is a box of coarse cells whose cells are refined `ratio` times. Particles
inside it map to its grid, the others to the coarse grid; its face nodes are tied to the
coarse cell faces they lie on (seed 000 Eqs. 17-24), where coarse particles are beside
them. Bodies are filled at the window's spacing `cell / ratio / particles_per_cell`
inside it. A coarse particle that enters a window is split into ratio^3 particles; the
time step follows the finest cell that holds particles. Windows may not overlap or touch,
and tied face nodes are never contact nodes, so a window should cover the whole contact
zone.""",
    "materials.NAME": """
Each material is `NAME: {model: MODEL, density: ..., ...}`; the model fixes which keys are
accepted. The solid models (all but `fluid` and `rigid`) need exactly two of the elastic
constants `E`, `nu`, `K`, `G`, which must give -1 < nu < 0.5; `T_melt` must exceed
`T_room` and `tangent_modulus` be below E. The keys and defaults come from
`pmpm/materials/catalog.py`: a model added there is accepted and documented here.""",
    "bodies[i]": """
A body is filled with particles on a lattice of spacing d = `grid.cell /
particles_per_cell` at `grid.min + (i + 1/2) d`, keeping the points inside the shape;
each particle gets volume d^3 and mass density * d^3. A body must get at least one
particle, and all of them must lie inside the grid box. A `points` body is not filled:
its particles are its file's points, with the file's volumes (or spacing^3).""",
    "bodies[i].geometry": """
A rotated body is filled on a lattice in its own frame, anchored at the geometry's
reference point, and then rotated: a box whose sides are whole multiples of d gets
exactly side/d particles along each side at any angle. Besides the built-in shapes, a
body may be a volume mesh (`mesh`), a closed STL or OBJ surface (`surface`), a point file
(`points`: CSV, HDF5 or a VTU cloud), or a `union` or `difference` of built-in shapes,
e.g. a plate with a hole:

```yaml
geometry: {type: difference, of: [{type: box, min: [-5, -5, -2], max: [5, 5, 2]},
                                  {type: cylinder, base: [0, 0, -3], axis: z, radius: 3,
                                   length: 6}]}
```""",
    "loads[i]": "A traction or force on the particles of one body inside a box.",
    "contact": """
With `method` 1 or 2 every body has its own nodal velocity field at the nodes that
particles of two or more bodies reach, and every pair of bodies is in contact; normals
come from each body's mass gradient (Eq. 9). At a node where more than two bodies meet,
each body is in contact with the centre of mass of all of them, with the rules of its pair
with the heaviest other body there. Contact with a rigid body works against its
velocity: the prescribed one, or, in the axes `rigid.free` names on a particle body, its
own, which then changes by its weight and the opposite of what the others took. Without `separation` two bodies are in contact at every node both
reach, as soon as they approach, so surfaces up to about a cell apart push on each other;
with linear shape functions and 2 particles per cell, touching flat surfaces are 2/3 to 1
cell apart by the separation measure, so 0.9 keeps them and leaves alone gaps wider than
about 0.2 cell.""",
}


def main(argv):
    text = reference()
    if "--write" in argv:
        DOC_PATH.parent.mkdir(parents=True, exist_ok=True)
        DOC_PATH.write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main(sys.argv[1:])
