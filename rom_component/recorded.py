"""What a training reads from a recorded run: the calls of the component a ROM learns, their snapshots, and the
interface it declared (meshes, components). Both ROM families train on these."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import SceneError
from cosim.results import Calls, RunResults


def recorded_calls(results: str | Path, spec: dict[str, Any], converged_only: bool = False) -> tuple[Calls, np.ndarray]:
    """The recorded calls of ``spec``'s component and the run's window end times; an error naming the run and the
    variable if the calls lack the force or the displacement (or field) the ROM learns."""
    with RunResults(results) as run:
        calls = run.calls(spec["component"], converged_only=converged_only)
        window_time = run.windows.time
    if spec.get("skip_first_iteration"):
        keep = (calls.iteration > 1) | calls.converged
        calls = Calls({k: v[keep] for k, v in calls.inputs.items()}, {k: v[keep] for k, v in calls.outputs.items()},
                      calls.window[keep], calls.iteration[keep], calls.converged[keep])
    learned = spec["field"] or spec["output"]
    for kind, var, arrays in (("inputs", spec["input"], calls.inputs), ("outputs", learned, calls.outputs)):
        if var not in arrays:
            raise SceneError(f"'{results}': the recorded {kind} of '{spec['component']}' have no '{var}' "
                             f"(has: {', '.join(arrays)})")
    return calls, window_time


def read_snapshots(results: str | Path, spec: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Force rows, displacement rows, window end times and window numbers of the selected calls."""
    calls, window_time = recorded_calls(results, spec, spec["converged_only"])
    learned = spec["field"] or spec["output"]
    finished = calls.window <= len(window_time)            # calls of the window in flight at a crash are left out
    times = window_time[np.minimum(calls.window, len(window_time)) - 1]
    keep = finished & (times >= spec["t_min"] - 1e-9) & (times <= spec["t_max"] + 1e-9)
    F, U = calls.inputs[spec["input"]][keep], calls.outputs[learned][keep]
    F, U = F.reshape(len(F), -1), U.reshape(len(U), -1)   # one row per call, node-major (x, y of node 0, ...)
    if len(F) < 3:
        raise SceneError(f"'{results}': only {len(F)} snapshots of '{spec['component']}' fall in "
                         f"t in [{spec['t_min']:g}, {spec['t_max']:g}]")
    return F, U, times[keep], calls.window[keep]


def read_training_set(results: Sequence[str | Path], spec: dict[str, Any]):
    """The selected calls of several runs stacked: F, U, window end times, and window labels unique across runs."""
    parts = [read_snapshots(path, spec) for path in results]
    F, U, times = (np.concatenate([part[i] for part in parts]) for i in range(3))
    offsets = np.cumsum([0] + [int(part[3].max()) + 1 for part in parts[:-1]])
    windows = np.concatenate([part[3] + offset for part, offset in zip(parts, offsets)])
    return F, U, times, windows


def read_interface(results: str | Path, spec: dict[str, Any]) -> tuple[list[dict[str, Any]], dict[str, np.ndarray]]:
    """The trained variables as the full-order component declared them (mesh, components) and their meshes."""
    with RunResults(results) as run:
        names = run.component_names()
        if spec["component"] not in names:
            return [], {}
        record = run.component(spec["component"])
    declared = {v["name"]: v for v in record.variables}
    variables = [{k: declared[name][k] for k in ("name", "mesh", "components")}
                 for name in (spec["input"], spec["output"]) if name in declared]
    meshes = {v["mesh"]: record.meshes[v["mesh"]] for v in variables if v["mesh"] in record.meshes}
    return variables, meshes


def interface_index(results: str | Path, spec: dict[str, Any]) -> np.ndarray:
    """K: the positions, in the flattened field (node-major), of the output variable's values."""
    with RunResults(results) as run:
        record = run.component(spec["component"])
    declared = {v["name"]: v for v in record.variables}
    for name in (spec["output"], spec["field"]):
        if name not in declared or declared[name]["mesh"] not in record.meshes:
            raise SceneError(f"'{results}': component '{spec['component']}' declares no mesh for '{name}'")
    output, field = declared[spec["output"]], declared[spec["field"]]
    if output["components"] != field["components"]:
        raise SceneError(f"'{results}': '{spec['output']}' and '{spec['field']}' have "
                         f"{output['components']} and {field['components']} components per node")
    from scipy.spatial import cKDTree
    nodes, field_nodes = record.meshes[output["mesh"]], record.meshes[field["mesh"]]
    distance, index = cKDTree(field_nodes).query(nodes)
    scale = float(np.ptp(field_nodes, axis=0).max()) or 1.0
    if distance.max() > 1e-9 * scale:
        raise SceneError(f"'{results}': {int((distance > 1e-9 * scale).sum())} nodes of '{spec['output']}' are not "
                         f"nodes of '{spec['field']}' (largest gap {distance.max():.3g})")
    k = output["components"]
    return (index[:, None] * k + np.arange(k)).ravel()
