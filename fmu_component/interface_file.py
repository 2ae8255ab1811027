"""``resources/interface.json`` of an FMU exported by ``cosim export-fmu``: where its variables live for the coupler.

The file is an object with:
- ``variables``: a list of ``{"name": str, "mesh": str, "components": int >= 1}``;
- ``meshes``: ``{mesh name: [[x, y(, z)], ...]}`` (finite coordinates, one row per node);
- ``history_windows`` (int >= 0), ``stateless`` (bool) and ``take_over`` (the C function that takes a history over).

``read_interface`` returns it checked, or raises ``ValueError`` with one line naming the key and what it holds.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Interface:
    """What the file says: each variable's mesh and values per node, the meshes' nodes, and the ROM's memory."""

    placement: dict[str, tuple[str, int]] = field(default_factory=dict)
    meshes: dict[str, np.ndarray] = field(default_factory=dict)
    history_windows: int = 0
    stateless: bool = False
    take_over: str = ""


def _kind(value: Any) -> str:
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean", type(None): "null"}.get(
        type(value), "a number" if isinstance(value, int | float) else type(value).__name__)


def _integer(value: Any, key: str, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise ValueError(f"'{key}' must be an integer of at least {least}, not {json.dumps(value)[:60]}")
    return value


def read_interface(text: str) -> Interface:
    """The checked contents of an ``interface.json`` (``ValueError``: one line naming the key at fault)."""
    try:
        document = json.loads(text)
    except RecursionError:
        raise ValueError("nested too deeply") from None
    if not isinstance(document, dict):
        raise ValueError(f"must hold an object, not {_kind(document)}")
    interface = Interface(history_windows=_integer(document.get("history_windows", 0), "history_windows", 0))
    stateless = document.get("stateless", False)
    if not isinstance(stateless, bool):
        raise ValueError(f"'stateless' must be true or false, not {json.dumps(stateless)[:60]}")
    interface.stateless = stateless
    take_over = document.get("take_over", "")
    if not isinstance(take_over, str):
        raise ValueError(f"'take_over' must be a function's name, not {_kind(take_over)}")
    interface.take_over = take_over
    for key in ("variables", "meshes"):
        if key not in document:
            raise ValueError(f"no key '{key}'")
    variables, meshes = document["variables"], document["meshes"]
    if not isinstance(variables, list):
        raise ValueError(f"'variables' must be a list, not {_kind(variables)}")
    for index, entry in enumerate(variables):
        where = f"variables[{index}]"
        if not isinstance(entry, dict):
            raise ValueError(f"'{where}' must be an object, not {_kind(entry)}")
        for key in ("name", "mesh", "components"):
            if key not in entry:
                raise ValueError(f"'{where}' has no key '{key}'")
        if not isinstance(entry["name"], str) or not isinstance(entry["mesh"], str):
            raise ValueError(f"'{where}': 'name' and 'mesh' must be strings")
        interface.placement[entry["name"]] = (entry["mesh"], _integer(entry["components"], f"{where}.components", 1))
    if not isinstance(meshes, dict):
        raise ValueError(f"'meshes' must be an object of mesh names to node lists, not {_kind(meshes)}")
    for name, nodes in meshes.items():
        try:
            array = np.array(nodes, dtype=np.float64)
        except (TypeError, ValueError):
            array = np.empty(0)
        if array.ndim != 2 or not 1 <= array.shape[1] <= 3 or not np.isfinite(array).all():
            raise ValueError(f"'meshes.{name}' must be a list of nodes of 1 to 3 finite coordinates each")
        interface.meshes[name] = array
    for name, (mesh, _) in interface.placement.items():
        if mesh and mesh not in interface.meshes:
            raise ValueError(f"variable '{name}' is on mesh '{mesh}', which 'meshes' does not hold "
                             f"(it holds: {', '.join(interface.meshes) or 'none'})")
    return interface
