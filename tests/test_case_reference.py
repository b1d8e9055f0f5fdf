"""docs/case-file.md is generated from the schema, and every key in it is documented."""
import subprocess
import sys

import pytest

from pmpm.case.reference import COMMAND, DOC_PATH, reference, sections
from pmpm.materials import catalog

SECTIONS = sections()


def test_docs_case_file_is_generated_from_the_schema():
    assert DOC_PATH.is_file(), f"{DOC_PATH} is missing; write it with `{COMMAND}`"
    assert DOC_PATH.read_text(encoding="utf-8") == reference(), (
        f"docs/case-file.md differs from what the schema generates; regenerate it with "
        f"`{COMMAND}` and commit it")


def test_module_prints_the_reference():
    done = subprocess.run([sys.executable, "-m", "pmpm.case.reference"], capture_output=True,
                          text=True, check=True, cwd=DOC_PATH.parent.parent)
    assert done.stdout == reference()


@pytest.mark.parametrize("section", SECTIONS, ids=lambda s: f"{s.path}|{s.variant}")
def test_every_field_has_one_line_of_doc_and_a_type(section):
    for key, field in section.fields.items():
        assert field.doc.strip(), f"{section.path}.{key}: no doc"
        assert "\n" not in field.doc, f"{section.path}.{key}: doc is more than one line"
        assert field.read.kind(), f"{section.path}.{key}: reader says nothing of its type"


def test_every_variant_is_described():
    for section in SECTIONS:
        assert not section.variant or section.doc, f"{section.path} {section.variant}"


@pytest.mark.parametrize("path", [
    "", "grid", "grid.boundary", "grid.windows[i]", "materials.NAME",
    "materials.NAME.eos", "materials.NAME.bulk_viscosity", "bodies[i]",
    "bodies[i].geometry", "bodies[i].geometry.rotate", "loads[i]", "loads[i].region",
    "loads[i].time_function", "time", "output", "decomposition", "contact",
    "contact.pairs[i]"])
def test_every_section_is_in_the_reference(path):
    assert path in {section.path for section in SECTIONS}


def test_every_material_model_and_geometry_type_has_its_table():
    variants = {(section.path, section.variant) for section in SECTIONS}
    for model in catalog.MODELS:
        assert ("materials.NAME", f"model: {model}") in variants
    for kind in ("box", "cylinder", "sphere", "ogive", "mesh", "prism", "surface", "points",
                 "union", "difference"):
        assert ("bodies[i].geometry", f"type: {kind}") in variants


def test_units_of_some_keys():
    units = {(s.path, s.variant, key): f.unit for s in SECTIONS for key, f in s.fields.items()}
    assert units["time", "", "end"] == "ms"
    assert units["grid", "", "cell"] == "mm"
    assert units["bodies[i]", "", "velocity"] == "mm/ms"
    assert units["materials.NAME", "model: johnson_cook", "A"] == "MPa"
    assert units["materials.NAME", "model: johnson_cook", "density"] == "g/mm^3"
    assert units["contact", "", "separation"] == "cells"
