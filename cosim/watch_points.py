"""Watch points: a component's data at one point of one of its meshes, window by window, in preCICE's
``precice-<participant>-watchpoint-<name>.log`` format, which preCICE users' plot scripts read.

A watch point takes the values of the mesh's vertex nearest its coordinate (preCICE interpolates on the nearest
element; cosim keeps no elements), from each window's last recorded call of the component (its converged or
accepted iteration; of a component that subcycles, its last step): every variable the component reads or writes on
that mesh, at each window's end. The results writer writes them once the run's file
is closed, into the run's directory.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import SceneError
from cosim.results import RunResults


def file_name_part(name: str) -> bool:
    """Whether ``name`` can stand inside a file name in the run's folder: not empty, no separator, no NUL, not a
    folder's own name."""
    return bool(name) and "/" not in name and "\0" not in name and name not in (".", "..")


def check(points: Any, components: Mapping[str, Mapping[str, Any]], source: str) -> None:
    """``output.watch_points``: tables of ``component`` (recorded), ``mesh``, ``name`` and ``coordinate``."""
    if not isinstance(points, list):
        raise SceneError(f"{source}: 'output.watch_points' must be a list of tables")
    for i, point in enumerate(points):
        where = f"output.watch_points.{i}"
        if not isinstance(point, dict) or set(point) != {"component", "mesh", "name", "coordinate"}:
            raise SceneError(f"{source}: '{where}' must be a table of component, mesh, name and coordinate")
        spec = components.get(point["component"])
        if spec is None:
            raise SceneError(f"{source}: '{where}.component' is {point['component']!r}, not a component")
        if not spec["record"]:
            raise SceneError(f"{source}: '{where}' watches '{point['component']}', whose calls are not recorded: set "
                             f"components.{point['component']}.record = true")
        if not isinstance(point["name"], str) or not file_name_part(point["name"]):
            raise SceneError(f"{source}: '{where}.name' is {point['name']!r}: a watch point's name becomes a file "
                             "name (precice-<component>-watchpoint-<name>.log), so no '/' and not '..'")
        coordinate = point["coordinate"]
        if not isinstance(coordinate, list) or not coordinate or \
                not all(isinstance(v, int | float) and not isinstance(v, bool) for v in coordinate):
            raise SceneError(f"{source}: '{where}.coordinate' must be a list of numbers")


def write(results: str | Path, folder: str | Path, points: Sequence[Mapping[str, Any]]) -> list[Path]:
    """Write every watch point's log into ``folder``; returns the files. A component swapped for a ROM or an FMU is
    watched through the process that served it: its calls are the component's, its meshes and variables its own."""
    written = []
    with RunResults(results) as run:
        times = run.windows.time
        processes = [run.component(name) for name in run.component_names()]
        for point in points:
            component, mesh = point["component"], point["mesh"]
            record = next((r for r in processes if r.attributes.get("participant", r.name) == component
                           and mesh in r.meshes), None)
            if record is None or component not in run.recorded():
                continue            # the component gave no such mesh (a swapped participant declares its own)
            nodes = record.meshes[mesh]
            coordinate = np.asarray(point["coordinate"], dtype=float)
            width = min(nodes.shape[1], len(coordinate))
            nearest = int(np.argmin(np.linalg.norm(nodes[:, :width] - coordinate[:width], axis=1)))
            calls = run.calls(component)
            # each window's last call: its converged (or accepted) iteration, and of a component that subcycles, the
            # last step
            last = np.flatnonzero(np.append(calls.window[1:] != calls.window[:-1], True)) if len(calls.window) \
                else np.zeros(0, dtype=int)
            calls = calls.select(last)
            columns = ["Time", *(f"Coordinate{k}" for k in range(nodes.shape[1]))]
            values = [np.asarray(times)[calls.window - 1, None],            # windows count from 1
                      np.repeat(nodes[nearest][None], len(calls), axis=0)]
            for variable in record.variables:
                if variable.get("mesh") != mesh:
                    continue
                source = calls.inputs if variable["causality"] == "input" else calls.outputs
                data = source.get(variable["name"])
                if data is None:
                    continue
                at = data.reshape(len(data), len(nodes), -1)[:, nearest, :]
                columns += [variable["name"]] if at.shape[1] == 1 else \
                    [f"{variable['name']}{k}" for k in range(at.shape[1])]
                values.append(at)
            table = np.hstack(values)
            path = Path(folder) / f"precice-{component}-watchpoint-{point['name']}.log"
            with open(path, "w") as stream:
                stream.write("  ".join(f"{c:>22}" for c in columns) + "\n")
                for row in table:
                    stream.write("  ".join(f"{v:>22.16e}" for v in row) + "\n")
            written.append(path)
    return written
