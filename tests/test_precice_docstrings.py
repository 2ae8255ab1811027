"""The ``precice`` package documents itself as pyprecice does (issue 60): every public method of ``Participant`` and
``Interface``, each class and each module function has a numpy-style docstring naming its parameters and what it
returns, and ``help()`` names the state a call needs (before initialize, after it, until finalize)."""

from __future__ import annotations

import ast
import importlib
import inspect
import pydoc
import re
import sys
from collections.abc import Callable
from types import ModuleType
from typing import Any

import pytest

from tests.conftest import ROOT

SHIM = ROOT / "precice_compat" / "participant"


def _load_precice() -> ModuleType:
    """The participant package, imported from its folder as a participant does, leaving ``sys.path`` and
    ``sys.modules`` as they were (the tests' environment has no ``precice`` of its own)."""
    def ours() -> dict[str, ModuleType]:
        return {name: module for name, module in sys.modules.items() if name == "precice" or name.startswith("precice.")}

    saved_path, saved_modules = list(sys.path), ours()
    for name in saved_modules:
        del sys.modules[name]
    sys.path.insert(0, str(SHIM))
    try:
        return importlib.import_module("precice")
    finally:
        sys.path[:] = saved_path
        for name in ours():
            del sys.modules[name]
        sys.modules.update(saved_modules)


precice = _load_precice()
CLASSES = {"Participant": precice.Participant, "Interface": precice.Interface}
FUNCTIONS = ["action_write_initial_data", "action_write_iteration_checkpoint", "action_read_iteration_checkpoint",
             "get_version_information"]
SECTIONS = ("Parameters", "Returns", "Yields", "Raises", "See Also", "Notes", "Examples", "References", "Warns")

# the state each call needs, as its help() must name it (whitespace aside)
PRECONDITIONS: dict[tuple[str, str], tuple[str, ...]] = {
    ("Participant", "initialize"): ("only once", "after the vertices"),
    ("Participant", "advance"): ("between initialize and finalize",),
    ("Participant", "finalize"): ("after the last advance", "is_coupling_ongoing() is False"),
    ("Participant", "write_data"): ("between initialize and finalize", "before initialize only"),
    ("Participant", "read_data"): ("between initialize and finalize",),
    ("Participant", "set_mesh_vertex"): ("only before initialize",),
    ("Participant", "set_mesh_vertices"): ("only before initialize",),
    ("Participant", "set_mesh_edge"): ("only before initialize",),
    ("Participant", "set_mesh_edges"): ("only before initialize",),
    ("Participant", "set_mesh_triangle"): ("only before initialize",),
    ("Participant", "set_mesh_triangles"): ("only before initialize",),
    ("Participant", "set_mesh_quad"): ("only before initialize",),
    ("Participant", "set_mesh_quads"): ("only before initialize",),
    ("Participant", "set_mesh_tetrahedron"): ("only before initialize",),
    ("Participant", "set_mesh_tetrahedra"): ("only before initialize",),
    ("Participant", "set_mesh_access_region"): ("only before initialize",),
    ("Participant", "get_mesh_vertex_ids_and_coordinates"): ("between initialize and finalize",),
    ("Participant", "write_and_map_data"): ("between initialize and finalize",),
    ("Participant", "map_and_read_data"): ("between initialize and finalize",),
    ("Participant", "write_gradient_data"): ("before finalize",),
    ("Participant", "reset_mesh"): ("refused by cosim",),
    ("Participant", "start_profiling_section"): ("accepted and ignored",),
    ("Participant", "stop_last_profiling_section"): ("accepted and ignored",),
    ("Interface", "initialize"): ("only once",),
    ("Interface", "initialize_data"): ("only once", "after initialize"),
    ("Interface", "advance"): ("between initialize_data and finalize",),
    ("Interface", "finalize"): ("after the last advance", "is_coupling_ongoing() is False"),
    ("Interface", "set_mesh_vertex"): ("before initialize",),
    ("Interface", "set_mesh_vertices"): ("before initialize",),
    ("Interface", "set_mesh_edge"): ("before initialize",),
    ("Interface", "set_mesh_triangle"): ("before initialize",),
    ("Interface", "set_mesh_triangle_with_edges"): ("before initialize",),
    ("Interface", "mark_action_fulfilled"): ("is_action_required",),
    ("Interface", "write_block_scalar_data"): ("between initialize_data and finalize", "before initialize_data only"),
    ("Interface", "write_scalar_data"): ("between initialize_data and finalize", "before initialize_data only"),
    ("Interface", "write_block_vector_data"): ("between initialize_data and finalize", "before initialize_data only"),
    ("Interface", "write_vector_data"): ("between initialize_data and finalize", "before initialize_data only"),
    ("Interface", "read_block_scalar_data"): ("between initialize_data and finalize",),
    ("Interface", "read_scalar_data"): ("between initialize_data and finalize",),
    ("Interface", "read_block_vector_data"): ("between initialize_data and finalize",),
    ("Interface", "read_vector_data"): ("between initialize_data and finalize",),
}


def public_methods(cls: type) -> list[str]:
    return sorted(name for name, member in vars(cls).items() if inspect.isfunction(member) and not name.startswith("_"))


METHODS = [(cls_name, name) for cls_name, cls in CLASSES.items() for name in public_methods(cls)]


def sections(doc: str) -> dict[str, str]:
    """A numpy docstring's sections, by title (``summary`` for what comes before the first)."""
    found: dict[str, list[str]] = {"summary": []}
    current = "summary"
    lines = doc.splitlines()
    for i, line in enumerate(lines):
        underline = lines[i + 1].strip() if i + 1 < len(lines) else ""
        if line.strip() in SECTIONS and underline and set(underline) == {"-"}:
            current = line.strip()
            found[current] = []
            continue
        if set(line.strip()) == {"-"} and i and lines[i - 1].strip() == current:
            continue
        found[current].append(line)
    return {title: "\n".join(body) for title, body in found.items()}


def documented_parameters(body: str) -> set[str]:
    """The names a Parameters section lists: its unindented ``name : type`` lines (``a, b : type`` lists two)."""
    names: set[str] = set()
    for line in body.splitlines():
        if line and not line[0].isspace():
            names.update(name.strip().lstrip("*") for name in line.split(" : ")[0].split(","))
    return names


def returns_something(function: Callable[..., Any]) -> bool:
    annotation = inspect.signature(function).return_annotation
    return annotation not in (None, "None", inspect.Signature.empty)


def check_function(function: Callable[..., Any], where: str, skip_self: bool) -> None:
    doc = inspect.getdoc(function)
    assert doc, f"{where} has no docstring"
    summary = doc.splitlines()[0]
    assert summary.strip() and summary.rstrip().endswith("."), f"{where}: its summary line {summary!r}"
    parts = sections(doc)
    parameters = [p for p in inspect.signature(function).parameters.values() if not (skip_self and p.name == "self")]
    if parameters:
        assert "Parameters" in parts, f"{where} has parameters and no Parameters section"
        missing = {p.name for p in parameters} - documented_parameters(parts["Parameters"])
        assert not missing, f"{where}: Parameters leaves out {sorted(missing)}"
    if returns_something(function):
        assert "Returns" in parts and parts["Returns"].strip(), f"{where} returns a value and has no Returns section"
    else:
        assert "Returns" not in parts, f"{where} returns nothing and has a Returns section"


@pytest.mark.parametrize(("cls_name", "name"), METHODS, ids=[f"{c}.{n}" for c, n in METHODS])
def test_every_public_method_has_a_numpy_docstring(cls_name: str, name: str) -> None:
    check_function(getattr(CLASSES[cls_name], name), f"{cls_name}.{name}", skip_self=True)


@pytest.mark.parametrize("cls_name", CLASSES)
def test_each_class_documents_its_constructor(cls_name: str) -> None:
    cls = CLASSES[cls_name]
    doc = inspect.getdoc(cls)
    assert doc and doc.splitlines()[0].rstrip().endswith("."), f"{cls_name} has no summary line"
    parts = sections(doc)
    wanted = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    assert "Parameters" in parts, f"{cls_name}'s docstring has no Parameters section for its constructor"
    missing = set(wanted) - documented_parameters(parts["Parameters"])
    assert not missing, f"{cls_name}: Parameters leaves out {sorted(missing)}"
    assert "Notes" in parts and "communicator" in parts["Notes"], f"{cls_name}: what cosim does with the communicator"


@pytest.mark.parametrize("name", FUNCTIONS)
def test_module_functions_are_documented(name: str) -> None:
    check_function(getattr(precice, name), f"precice.{name}", skip_self=False)


@pytest.mark.parametrize(("cls_name", "name"), sorted(PRECONDITIONS),
                         ids=[f"{c}.{n}" for c, n in sorted(PRECONDITIONS)])
def test_help_names_the_state_a_call_needs(cls_name: str, name: str) -> None:
    method = getattr(CLASSES[cls_name], name)
    shown = " ".join(pydoc.render_doc(method, renderer=pydoc.plaintext).split())
    assert "Notes" in shown, f"help({cls_name}.{name}) has no Notes"
    for phrase in PRECONDITIONS[(cls_name, name)]:
        assert phrase in shown.replace("``", ""), f"help({cls_name}.{name}) does not say {phrase!r}"


def test_the_preconditions_cover_the_steering_data_and_mesh_calls() -> None:
    """The calls the issue names are among those whose precondition is checked, and every one checked exists."""
    named = {"initialize", "advance", "finalize", "write_data", "read_data", "set_mesh_vertices",
             "set_mesh_access_region", "get_mesh_vertex_ids_and_coordinates"}
    assert named <= {name for cls_name, name in PRECONDITIONS if cls_name == "Participant"}
    for cls_name, name in PRECONDITIONS:
        assert name in public_methods(CLASSES[cls_name]), f"{cls_name}.{name}"


def test_help_of_write_data_is_not_empty() -> None:
    """The issue's example: help(precice.Participant.write_data) names its parameters."""
    shown = pydoc.render_doc(precice.Participant.write_data, renderer=pydoc.plaintext)
    for parameter in ("mesh_name", "data_name", "vertex_ids", "values"):
        assert re.search(rf"^\s*{parameter} :", shown, re.MULTILINE), parameter


@pytest.mark.parametrize("module", ["__init__", "_participant", "_interface"])
def test_docstring_lines_fit_the_line_length(module: str) -> None:
    """Every docstring line of the public modules, with its indent, within ruff's 120 characters."""
    path = SHIM / "precice" / f"{module}.py"
    lines = path.read_text().splitlines()
    tree = ast.parse("\n".join(lines))
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef) and ast.get_docstring(node) is not None:
            first = node.body[0]
            for number in range(first.lineno, (first.end_lineno or first.lineno) + 1):
                assert len(lines[number - 1]) <= 120, f"{path.name}:{number} has {len(lines[number - 1])} characters"
