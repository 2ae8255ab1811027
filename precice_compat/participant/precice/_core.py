"""What both of preCICE's APIs do, against cosim's coupler: meshes, data buffers, time within a window, the
checkpoint protocol.

The coupler drives a participant as it drives any component: a coupling iteration hands the participant its read
data and takes its write data. Here that is the reply to the participant's ``initialize`` or window-ending
``advance`` (the read data, and whether the window is new, repeated, or the last), and the participant's next
window-ending ``advance`` (its write data). Steps shorter than the window stay local. A read inside the window
evaluates the data's waveform there: the window-end value (``waveform-degree`` 0), else the B-spline the coupler
sent through the window's samples. With ``substeps``, the data written at each step inside the window is kept as a
sample, and all go with the window's end.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from precice._connection import Connection, Error, find_coupler
from precice._export import Exports, MeshView
from precice._waveform import Waveform

LINE = np.array([0.0, 0.0, 1.0, 1.0])     # the knots of the line through a window's start and end
EPSILON = 1e-9        # relative tolerance of times: a step that reaches the window's end to this ends it


class Core:
    """One participant's coupling state; ``api`` names the calls in messages (``Participant`` or ``Interface``)."""

    def __init__(self, api: str, name: str, config: str, rank: int, size: int):
        self.api = api
        self.name = str(name)
        self.config = Path(str(config)).resolve()
        endpoint, token, pid = find_coupler(self.config)
        self.connection = Connection(endpoint, token, pid)
        if not isinstance(name, str) or not name:
            raise self.fail("__init__", f"the participant's name must be a non-empty string, got {name!r}")
        if isinstance(rank, bool) or not isinstance(rank, (int, np.integer)) or \
                isinstance(size, bool) or not isinstance(size, (int, np.integer)):
            raise self.fail("__init__", f"rank and size must be integers, got {rank!r} and {size!r}")
        if size < 1 or not 0 <= rank < size:
            raise self.fail("__init__", f"rank {rank} of size {size}: the rank goes from 0 to size - 1")
        self.rank, self.size = int(rank), int(size)
        if not self.config.is_file():
            raise self.fail("__init__", f"the configuration '{config}' does not exist")
        self.setup, _ = self._request("hello", {"participant": name, "config": str(self.config), "api": api,
                                                "pid": os.getpid(), "rank": self.rank, "size": self.size})
        self.meshes: dict[str, dict[str, Any]] = self.setup["meshes"]
        self.write = {(d["mesh"], d["data"]): d for d in self.setup["write"]}
        self.read = {(d["mesh"], d["data"]): d for d in self.setup["read"]}
        self.vertices: dict[str, list[np.ndarray]] = {mesh: [] for mesh in self.meshes}
        # a provided mesh's elements, for the coupler's projection and cell mappings: kind -> blocks of vertex ids
        self.elements: dict[str, dict[str, list[np.ndarray]]] = {mesh: {} for mesh in self.meshes}
        self.received_vertices: dict[str, np.ndarray] = {}   # received meshes accessed directly: from initialize
        self.regions: dict[str, np.ndarray] = {}             # their access regions, (dimensions, 2): min and max
        self.accumulated: set[str] = set()      # data written just in time this window (zeroed when it ends)
        self.written: dict[str, np.ndarray] = {}
        self.gradients: dict[str, np.ndarray] = {}     # data -> its gradients written (vertices x dim*components)
        self.received: dict[str, np.ndarray] = {}
        self.waveforms: dict[str, Waveform] = {}       # read data of degree >= 1: its window's interpolant
        self.starts: dict[str, np.ndarray] = {}        # each read data item's value at the window's start
        self.substep_data = sorted(data for (_, data), spec in self.write.items() if spec.get("substeps"))
        self.samples: list[tuple[float, dict[str, np.ndarray]]] = []    # (normalised time, write data) per substep
        self.window = float(self.setup["window"])
        self.window_start = float(self.setup["start"])
        self.elapsed = 0.0         # the steps taken in the window: the window's size is what is left at its start
        self._computing_since = (time.perf_counter(), time.process_time())
        self.state = "constructed"         # -> initialized -> finalized
        self.ongoing = True
        self.window_complete = False
        self.write_checkpoint = False
        self.read_checkpoint = False
        self.asked_write = self.asked_read = False     # the v3 API's requires_*_checkpoint asked since the exchange
        self.read_available = False
        self.exports = Exports(self.name, list(self.setup.get("exports") or []), Path.cwd())
        self.windows_done = 0

    # --- errors ---------------------------------------------------------------------------------------------------
    def fail(self, call: str, why: str) -> Error:
        """The error of a misuse, told to the coupler first (its run stops with this line, not a traceback)."""
        message = f"{self.api}.{call}: {why}"
        self.connection.tell("error", {"message": message, "participant": self.name})
        return Error(message)

    def _request(self, op: str, args: dict[str, Any] | None = None,
                 arrays: dict[str, np.ndarray] | None = None) -> Any:
        return self.connection.request(op, args, arrays)

    # --- meshes ---------------------------------------------------------------------------------------------------
    def mesh(self, call: str, mesh: Any, provided: bool = False) -> dict[str, Any]:
        if not isinstance(mesh, str) or mesh not in self.meshes:
            known = ", ".join(sorted(self.meshes)) or "none"
            raise self.fail(call, f"participant '{self.name}' uses no mesh {mesh!r} (its meshes: {known})")
        if provided and not self.meshes[mesh]["provided"]:
            raise self.fail(call, f"mesh '{mesh}' is received from another participant, not provided by '{self.name}'")
        return self.meshes[mesh]

    def add_vertices(self, call: str, mesh: str, positions: Any) -> np.ndarray:
        info = self.mesh(call, mesh, provided=True)
        if self.state != "constructed":
            raise self.fail(call, "vertices are set before initialize, not after")
        points = np.asarray(positions, dtype=np.float64)
        dimensions = int(info["dimensions"])
        if points.ndim == 1 and points.size == dimensions:
            points = points.reshape(1, dimensions)
        if points.ndim != 2 or points.shape[1] != dimensions:
            raise self.fail(call, f"positions of shape {tuple(np.shape(positions))} on mesh '{mesh}' of {dimensions} "
                                  f"dimensions; expected (n, {dimensions})")
        if not np.isfinite(points).all():
            raise self.fail(call, f"positions on mesh '{mesh}' are not finite")
        first = sum(len(block) for block in self.vertices[mesh])
        self.vertices[mesh].append(points.copy())
        return np.arange(first, first + len(points))

    def connect(self, call: str, mesh: str, vertices: Any, per_element: int) -> np.ndarray:
        """Edges, triangles, quads and tetrahedra (``per_element`` vertex ids each; a quad when ``call`` names
        one), checked against the mesh's vertices and sent with them at initialize for the mappings that project
        or interpolate in cells. As preCICE, a triangle brings its edges, a quad its edges and two triangles, a
        tetrahedron its edges. The rows of vertex ids."""
        self.mesh(call, mesh, provided=True)
        if self.state != "constructed":
            raise self.fail(call, "connectivity is set before initialize, not after")
        ids = np.asarray(vertices)
        if ids.size % per_element:
            raise self.fail(call, f"{ids.size} vertex ids do not make elements of {per_element}")
        rows = self._ids(call, mesh, ids).reshape(-1, per_element)
        if (np.diff(np.sort(rows, axis=1), axis=1) == 0).any():
            raise self.fail(call, "an element repeats a vertex")
        kinds = self.elements[mesh]
        if per_element == 4 and "quad" in call:
            kinds.setdefault("edges", []).append(rows[:, [0, 1, 1, 2, 2, 3, 3, 0]].reshape(-1, 2))
            kinds.setdefault("triangles", []).append(rows[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3))
            return rows
        pairs = [(i, j) for i in range(per_element) for j in range(i + 1, per_element)]
        kinds.setdefault("edges", []).append(rows[:, np.array(pairs).ravel()].reshape(-1, 2))
        if per_element > 2:
            kinds.setdefault("triangles" if per_element == 3 else "tetrahedra", []).append(rows)
        return rows

    def vertex_count(self, mesh: str) -> int:
        if not self.meshes[mesh]["provided"]:
            return len(self.received_vertices.get(mesh, ()))
        return sum(len(block) for block in self.vertices[mesh])

    # --- direct access to a received mesh ---------------------------------------------------------------------------
    def direct(self, call: str, mesh: Any) -> dict[str, Any]:
        info = self.mesh(call, mesh)
        if info["provided"] or not info.get("direct_access"):
            raise self.fail(call, f"mesh '{mesh}' is not a received mesh with direct access (give its "
                                  "<receive-mesh> api-access=\"true\")")
        if self.size > 1:
            raise self.fail(call, f"direct access from a parallel participant ({self.size} ranks) is not "
                                  "supported by cosim")
        return info

    def set_access_region(self, call: str, mesh: str, box: Any) -> None:
        """The box (min and max of each coordinate in turn) of the received mesh's vertices this participant sees."""
        info = self.direct(call, mesh)
        if self.state != "constructed":
            raise self.fail(call, "the access region is set before initialize")
        dimensions = int(info["dimensions"])
        flat = np.asarray(box, dtype=np.float64).ravel()
        if flat.shape != (2 * dimensions,) or not np.isfinite(flat).all():
            raise self.fail(call, f"the bounding box has {flat.size} values; expected {2 * dimensions} finite ones "
                                  "(min and max of each coordinate)")
        bounds = flat.reshape(dimensions, 2)
        if (bounds[:, 0] > bounds[:, 1]).any():
            raise self.fail(call, "the bounding box has a minimum above its maximum")
        self.regions[mesh] = bounds

    def region_vertices(self, call: str, mesh: str) -> tuple[np.ndarray, np.ndarray]:
        """The ids and coordinates of the received mesh's vertices inside the access region."""
        self.direct(call, mesh)
        if self.state != "initialized":
            raise self.fail(call, "a received mesh's vertices are known after initialize")
        if mesh not in self.regions:
            raise self.fail(call, f"no access region is set on mesh '{mesh}' (set_mesh_access_region before "
                                  "initialize)")
        points, bounds = self.received_vertices[mesh], self.regions[mesh]
        inside = np.flatnonzero(((points >= bounds[:, 0]) & (points <= bounds[:, 1])).all(axis=1))
        return inside, points[inside]

    # --- just-in-time mapping: data at coordinates given then, on a received mesh's nearest vertex -----------------
    def _just_in_time(self, call: str, mesh: Any, direction: str, coordinates: Any) -> tuple[np.ndarray, np.ndarray]:
        """The received mesh's vertex ids in the access region nearest each of ``coordinates`` (and the points)."""
        info = self.direct(call, mesh)
        if direction not in info.get("just_in_time", []):
            raise self.fail(call, f"no just-in-time {direction} mapping is configured on mesh '{mesh}' (a "
                                  f"<mapping:nearest-neighbor direction=\"{direction}\"> with "
                                  f"{'from' if direction == 'read' else 'to'}=\"{mesh}\" alone)")
        dimensions = int(info["dimensions"])
        points = np.asarray(coordinates, dtype=np.float64)
        if points.ndim == 1 and points.size == dimensions:
            points = points.reshape(1, dimensions)
        if points.ndim != 2 or points.shape[1] != dimensions or not np.isfinite(points).all():
            raise self.fail(call, f"coordinates of shape {points.shape} on mesh '{mesh}' of {dimensions} dimensions; "
                                  f"expected finite (n, {dimensions})")
        ids, vertices = self.region_vertices(call, mesh)
        if not len(ids):
            raise self.fail(call, f"the access region of mesh '{mesh}' holds no vertex to map to")
        nearest = np.empty(len(points), dtype=np.int64)
        for start in range(0, len(points), 256):         # a block of points against every vertex at a time
            block = points[start:start + 256]
            distances = ((block[:, None, :] - vertices[None, :, :]) ** 2).sum(axis=2)
            nearest[start:start + 256] = ids[np.argmin(distances, axis=1)]
        return nearest, points

    def map_and_read(self, call: str, mesh: str, data: str, coordinates: Any, relative_read_time: float) -> np.ndarray:
        """The data at ``coordinates``: the value at the nearest vertex of the received mesh (consistent)."""
        nearest, _ = self._just_in_time(call, mesh, "read", coordinates)
        return self.read_values(call, mesh, data, nearest, relative_read_time)

    def write_and_map(self, call: str, mesh: str, data: str, coordinates: Any, values: Any) -> None:
        """Values at ``coordinates`` added to the nearest vertices of the received mesh (conservative); what a
        window gathers goes at its end, and the next window starts from zero."""
        nearest, points = self._just_in_time(call, mesh, "write", coordinates)
        spec = self.write.get((mesh, data))
        if spec is None:
            raise self.fail(call, f"participant '{self.name}' writes no data '{data}' on mesh '{mesh}'")
        dimensions = int(spec["dimensions"])
        expected = (len(points),) if dimensions == 1 else (len(points), dimensions)
        array = np.asarray(values, dtype=np.float64)
        if array.shape != expected and array.size == int(np.prod(expected)):
            array = array.reshape(expected)
        if array.shape != expected or not np.isfinite(array).all():
            raise self.fail(call, f"values of shape {array.shape} for {len(points)} points; expected finite "
                                  f"{expected}")
        buffer = self._buffer(mesh, data, spec)
        if data not in self.accumulated:
            buffer = np.zeros_like(buffer)
            self.accumulated.add(data)
        np.add.at(buffer, nearest, array)
        self.written[data] = buffer

    def coordinates(self, mesh: str) -> np.ndarray:
        blocks = self.vertices[mesh]
        dimensions = int(self.meshes[mesh]["dimensions"])
        return np.concatenate(blocks) if blocks else np.zeros((0, dimensions))

    # --- data ---------------------------------------------------------------------------------------------------
    def _ids(self, call: str, mesh: str, ids: Any) -> np.ndarray:
        vertex_ids = np.asarray(ids)
        if vertex_ids.size and vertex_ids.dtype.kind not in "iu":
            raise self.fail(call, f"vertex ids must be integers, got {vertex_ids.dtype}")
        vertex_ids = vertex_ids.astype(np.int64).ravel()
        count = self.vertex_count(mesh)
        bad = vertex_ids[(vertex_ids < 0) | (vertex_ids >= count)]
        if bad.size:
            raise self.fail(call, f"vertex id {int(bad[0])} is not on mesh '{mesh}' ({count} vertices: ids 0 to "
                                  f"{count - 1})")
        return vertex_ids

    def write_values(self, call: str, mesh: str, data: str, ids: Any, values: Any) -> None:
        self.mesh(call, mesh)
        spec = self.write.get((mesh, data))
        if spec is None:
            writes = ", ".join(f"{d} on {m}" for m, d in sorted(self.write)) or "none"
            raise self.fail(call, f"participant '{self.name}' writes no data '{data}' on mesh '{mesh}' (it writes: {writes})")
        if self.state == "constructed" and not self.meshes[mesh]["provided"]:
            raise self.fail(call, f"data on the received mesh '{mesh}' is written after initialize (its vertices "
                                  "come with it)")
        if self.state == "constructed" and data not in self.setup["initial"]:
            raise self.fail(call, f"'{data}' is written before initialize only as initial data, and the exchange of "
                            f"'{data}' has no initialize=\"true\"")
        if self.state == "finalized":
            raise self.fail(call, "the participant was finalized")
        vertex_ids = self._ids(call, mesh, ids)
        dimensions = int(spec["dimensions"])
        array = np.asarray(values, dtype=np.float64)
        expected = (len(vertex_ids),) if dimensions == 1 else (len(vertex_ids), dimensions)
        if array.shape != expected and array.size == int(np.prod(expected)) and (dimensions == 1 or array.ndim == 1):
            array = array.reshape(expected)     # as pyprecice: any N values of scalar data, or a flat vector block
        if array.shape != expected:
            kind = "scalar" if dimensions == 1 else "vector"
            raise self.fail(call, f"values of shape {array.shape} for {len(vertex_ids)} vertices of {kind} data "
                                  f"'{data}'; expected {expected}")
        if not np.isfinite(array).all():
            raise self.fail(call, f"values of '{data}' are not finite")
        buffer = self.written.get(data)
        if buffer is None or len(buffer) != self.vertex_count(mesh):
            buffer = self.written[data] = np.zeros((self.vertex_count(mesh),) + expected[1:])
        buffer[vertex_ids] = array

    def write_gradients(self, call: str, mesh: str, data: str, ids: Any, gradients: Any) -> None:
        if not self.setup.get("experimental"):
            raise self.fail(call, "gradient data is preCICE's experimental API: unlock it with <precice-configuration "
                                  "experimental=\"true\"> in the configuration")
        self.mesh(call, mesh)
        spec = self.write.get((mesh, data))
        if spec is None or not spec.get("gradient"):
            raise self.fail(call, f"'{data}' on mesh '{mesh}' takes no gradients: no nearest-neighbor-gradient "
                                  "mapping maps it (requires_gradient_data_for() is False)")
        if self.state == "finalized":
            raise self.fail(call, "the participant was finalized")
        vertex_ids = self._ids(call, mesh, ids)
        columns = int(self.meshes[mesh]["dimensions"]) * int(spec["dimensions"])
        array = np.asarray(gradients, dtype=np.float64)
        if array.shape != (len(vertex_ids), columns):
            raise self.fail(call, f"gradients of shape {array.shape} for {len(vertex_ids)} vertices of '{data}'; "
                                  f"expected ({len(vertex_ids)}, {columns}): each component's d/dx, d/dy...")
        if not np.isfinite(array).all():
            raise self.fail(call, f"gradients of '{data}' are not finite")
        count = self.vertex_count(mesh)
        buffer = self.gradients.get(data)
        if buffer is None or len(buffer) != count:
            buffer = self.gradients[data] = np.zeros((count, columns))
        buffer[vertex_ids] = array

    def read_values(self, call: str, mesh: str, data: str, ids: Any, relative_read_time: float | None) -> np.ndarray:
        self.mesh(call, mesh)
        spec = self.read.get((mesh, data))
        if spec is None:
            reads = ", ".join(f"{d} on {m}" for m, d in sorted(self.read)) or "none"
            raise self.fail(call, f"participant '{self.name}' reads no data '{data}' on mesh '{mesh}' (it reads: {reads})")
        if self.state != "initialized":
            raise self.fail(call, "data is read after initialize" if self.state == "constructed"
                            else "the participant was finalized")
        vertex_ids = self._ids(call, mesh, ids)
        if relative_read_time is not None:
            remaining = self.remaining()
            if not np.isfinite(relative_read_time) or relative_read_time < 0 \
                    or relative_read_time > remaining * (1 + EPSILON) + EPSILON * self.window:
                shown, limit = _distinct(relative_read_time, remaining)
                raise self.fail(call, f"relative_read_time {shown} is outside the step (0 to {limit}, what is left of "
                                "the window)")
            moment = (self.elapsed + relative_read_time) / self.window
            waveform = self.waveforms.get(data)
            if waveform is not None and moment < 1.0 - EPSILON:
                return waveform(moment)[vertex_ids]
        values = self.received.get(data)
        dimensions = int(spec["dimensions"])
        if values is None:
            values = np.zeros((self.vertex_count(mesh),) if dimensions == 1 else (self.vertex_count(mesh), dimensions))
        return values[vertex_ids].copy()

    # --- time and the coupling ------------------------------------------------------------------------------------
    def remaining(self) -> float:
        return max(self.window - self.elapsed, 0.0)

    def initialize(self, call: str) -> None:
        if self.state != "constructed":
            raise self.fail(call, "initialize is called once" if self.state == "initialized"
                            else "the participant was finalized")
        for mesh, info in self.meshes.items():
            if info["provided"] and not self.vertex_count(mesh):
                raise self.fail(call, f"mesh '{mesh}' has no vertices: set them before initialize")
        arrays = {"mesh:" + mesh: self.coordinates(mesh) for mesh, info in self.meshes.items() if info["provided"]}
        for mesh, kinds in self.elements.items():
            for kind, blocks in kinds.items():
                arrays[f"{kind}:{mesh}"] = np.unique(np.sort(np.concatenate(blocks), axis=1), axis=0)
        for (mesh, data), spec in self.write.items():
            if data in self.setup["initial"]:
                arrays["data:" + data] = self._buffer(mesh, data, spec)
        arrays.update(self._gradient_arrays())
        self.state = "initialized"
        self._exchange("initialize", {}, arrays)
        if self.exports:
            self.exports.initialized(self.window_start, self._views())

    def _views(self) -> dict[str, MeshView]:
        """Each mesh whose vertices this participant knows, with its elements and the data it writes and reads there
        (what an export writes)."""
        views = {}
        for mesh, info in self.meshes.items():
            points = self.coordinates(mesh) if info["provided"] else self.received_vertices.get(mesh)
            if points is None or not len(points):
                continue
            elements = {kind: np.concatenate(blocks) for kind, blocks in self.elements[mesh].items() if blocks}
            if "edges" in elements:                     # a triangle brings its edges: each once, sorted
                elements["edges"] = np.unique(np.sort(elements["edges"], axis=1), axis=0)
            values = {name: self._buffer(mesh, name, spec) for (where, name), spec in self.write.items()
                      if where == mesh}
            values.update({name: self.received[name] for (where, name) in self.read
                           if where == mesh and name in self.received})
            order = [name for name in info.get("data", []) if name in values]     # the mesh's <use-data> order
            data = {name: values[name] for name in [*order, *(n for n in values if n not in order)]}
            views[mesh] = MeshView(points, elements, data)
        return views

    def _gradient_arrays(self) -> dict[str, np.ndarray]:
        """The gradients written so far, for the coupler (each data item's, on all its mesh's vertices)."""
        return {"gradient:" + data: self.gradients[data] for (mesh, data) in self.write
                if data in self.gradients and len(self.gradients[data]) == self.vertex_count(mesh)}

    def _buffer(self, mesh: str, data: str, spec: dict[str, Any]) -> np.ndarray:
        count = self.vertex_count(mesh)
        dimensions = int(spec["dimensions"])
        shape = (count,) if dimensions == 1 else (count, dimensions)
        buffer = self.written.get(data)
        return buffer if buffer is not None and buffer.shape == shape else np.zeros(shape)

    def _exchange(self, op: str, args: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        """Send the window's end (or the initialisation) and take the coupler's answer: the read data of the
        window to compute, and whether it is a new window, the same one again, or none (the end)."""
        result, received = self._request(op, args, arrays)
        for name, value in received.items():
            if name.startswith("mesh:"):           # a received mesh this participant accesses directly
                self.received_vertices[name[len("mesh:"):]] = np.asarray(value, dtype=np.float64)
        data = {name[len("data:"):]: value for name, value in received.items() if name.startswith("data:")}
        if data or result["ongoing"]:
            self.received = data
        else:       # the end: reads give the last window's end values, as preCICE's do
            result = {**result, "knots": {}, "lines": []}
        self.waveforms = {name: Waveform(np.array(knots), received["coefficients:" + name])
                          for name, knots in (result.get("knots") or {}).items()}
        for name in result.get("lines") or []:      # the line from the window's start (sent once a window) to its end
            self.starts[name] = received.get("start:" + name, self.starts.get(name))
            self.waveforms[name] = Waveform(LINE, np.stack([self.starts[name], self.received[name]]))
        self.samples = []
        self.ongoing = bool(result["ongoing"])
        self.window_complete = bool(result["window_complete"])
        self.write_checkpoint = bool(result["write_checkpoint"])
        self.read_checkpoint = bool(result["read_checkpoint"])
        self.asked_write = self.asked_read = False
        self.window_start = float(result["window_start"])
        self.window = float(result.get("window", self.window))
        self.elapsed = 0.0
        self.read_available = True
        self._computing_since = (time.perf_counter(), time.process_time())

    def advance(self, call: str, dt: Any) -> None:
        if self.state != "initialized":
            raise self.fail(call, "advance before initialize" if self.state == "constructed"
                            else "the participant was finalized")
        if not self.ongoing:
            raise self.fail(call, "the coupling is over (is_coupling_ongoing() is False): call finalize")
        try:
            step = float(dt)
        except (TypeError, ValueError):
            raise self.fail(call, f"the step {dt!r} is not a number") from None
        remaining = self.remaining()
        if not np.isfinite(step) or step <= 0:
            raise self.fail(call, f"the step {dt!r} must be positive")
        if step > remaining * (1 + EPSILON) + EPSILON * self.window:
            shown, limit = _distinct(step, remaining)
            raise self.fail(call, f"the step {shown} is longer than what is left of the window, {limit} "
                            "(get_max_time_step_size())")
        self.elapsed += step
        self.write_checkpoint = self.read_checkpoint = self.window_complete = False
        if self.remaining() > EPSILON * self.window:
            self.read_available = False
            if self.substep_data:                   # a step inside the window: its data is a sample, sent later
                self.samples.append((self.elapsed / self.window, {
                    data: self._buffer(mesh, data, spec).copy() for (mesh, data), spec in self.write.items()
                    if data in self.substep_data}))
            return
        arrays = {"data:" + data: self._buffer(mesh, data, spec) for (mesh, data), spec in self.write.items()}
        arrays.update(self._gradient_arrays())
        wall, cpu = self._computing_since
        args: dict[str, Any] = {"compute_seconds": time.perf_counter() - wall, "cpu_seconds": time.process_time() - cpu}
        if self.samples:
            args["times"] = [moment for moment, _ in self.samples]
            for data in self.substep_data:
                arrays["substeps:" + data] = np.stack([sample[data] for _, sample in self.samples])
        self._exchange("advance", args, arrays)
        if self.exports:
            self.windows_done += self.window_complete
            self.exports.iterated(self.window_start, self.windows_done, self.window_complete, self._views())
        for data in self.accumulated:         # a just-in-time write gathers a window's values from zero
            self.written.pop(data, None)
        self.accumulated.clear()

    def release(self) -> None:
        """What preCICE's destructor does for a participant that did not call ``finalize``: one whose coupling is
        over is finalized; any other has its connection closed (the coupler names it). Never raises: it runs when the
        participant is collected or its interpreter exits."""
        if self.state == "finalized":
            return
        try:
            if self.state == "initialized" and not self.ongoing:
                self.finalize("finalize")
            else:
                self.state = "finalized"
                self.connection.close()
        except Exception:
            pass

    def finalize(self, call: str) -> None:
        if self.state == "finalized":
            return
        if self.state == "initialized" and self.ongoing:
            raise self.fail(call, "finalize while the coupling goes on: advance until is_coupling_ongoing() is False")
        self.state = "finalized"
        self._request("finalize")
        self.connection.close()


def _distinct(a: float, b: float) -> tuple[str, str]:
    """``a`` and ``b`` as short as they read apart (``%g``, or every digit where ``%g`` shows them equal)."""
    short = (f"{a:g}", f"{b:g}")
    return short if short[0] != short[1] or a == b else (repr(float(a)), repr(float(b)))
