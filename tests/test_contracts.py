"""docs/CONTRACTS.md matches the code: the particle columns, the kernel records' fields,
the material kernel's signature, and the phases a body kind and a coupling answer."""
import inspect
import os
import re

from pmpm.kernels import records
from pmpm.materials.kernels import update_stress, update_stress_columns
from pmpm.particles import Particles
from pmpm.solver.couplings import Coupling
from pmpm.solver.fem_bodies import FemBodies
from pmpm.solver.fem_grid import FemGridNodes
from pmpm.solver.kinds import BodyKind
from pmpm.solver.particle_bodies import ParticleBodies

PAGE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs",
                    "CONTRACTS.md")
with open(PAGE, encoding="utf-8") as handle:
    TEXT = handle.read()


def section(title):
    start = TEXT.index(f"## {title}")
    end = TEXT.find("\n## ", start + 1)
    return TEXT[start:end if end > 0 else None]


def test_every_particle_column_is_documented_with_its_width_and_type():
    text = section("Column stores")
    for name, (dtype, width) in Particles.COLUMNS.items():
        shape = "(n,3)" if width == 3 else f"(n,{width})" if width > 1 else "(n,)"
        code = {"float64": "f8", "int64": "i8", "int32": "i4"}[dtype.__name__]
        assert re.search(rf"\b{name} {re.escape(shape)} {code}\b", text), name


def test_the_record_table_lists_each_record_s_fields_in_order():
    rows = re.findall(r"^\| `(\w+)`[^|]*\| (.+) \|$", section("Kernel records"), re.M)
    assert len(rows) == len(records.__all__)
    for name, fields in rows:
        listed = [f.strip().split(" ")[0] for f in re.split(r",(?![^()]*\))", fields)]
        assert list(getattr(records, name)._fields) == listed, name


def test_the_material_kernel_signature_is_the_documented_one():
    documented = re.search(r"c = update_stress\((.*)\)", TEXT).group(1)
    columns = re.search(r"c = update_stress_columns\((.*)\)", TEXT).group(1)
    assert [p.strip() for p in columns.split(",")] == \
        list(inspect.signature(update_stress_columns.py_func).parameters)
    assert [p.strip() for p in documented.split(",")] == \
        list(inspect.signature(update_stress.py_func).parameters)


def test_the_documented_hooks_and_phases_exist():
    step = section("The step")
    for hook in re.findall(r"`(after_\w+)`", step) + ["view"]:
        assert hasattr(Coupling, hook), hook
    kind_part = step[step.index("A **body kind**"):step.index("A **coupling**")]
    kinds = (ParticleBodies, FemBodies, FemGridNodes)
    names = {"BodyKind", "Stepper", "LevelState"} | {k.__name__ for k in kinds}
    for phase in re.findall(r"`(\w+)(?:\.py)?`", kind_part):
        if phase not in names and phase != "kinds":
            assert any(hasattr(kind, phase) for kind in kinds), phase
    for flag in ("on_grid", "owns_nodes", "follows_slabs", "rebalances"):
        assert f"`{flag}`" in kind_part and hasattr(BodyKind, flag), flag
