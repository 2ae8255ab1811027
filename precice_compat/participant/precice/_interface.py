"""preCICE v2's ``precice.Interface``, as pyprecice 2.5 offers it, on cosim's coupler: ids instead of names,
actions instead of ``requires_*``, and the initial data exchanged by ``initialize_data``."""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from precice._core import Core

WRITE_INITIAL_DATA = "write-initial-data"
WRITE_ITERATION_CHECKPOINT = "write-iteration-checkpoint"
READ_ITERATION_CHECKPOINT = "read-iteration-checkpoint"
ACTIONS = (WRITE_INITIAL_DATA, WRITE_ITERATION_CHECKPOINT, READ_ITERATION_CHECKPOINT)


def action_write_initial_data() -> str:
    return WRITE_INITIAL_DATA


def action_write_iteration_checkpoint() -> str:
    return WRITE_ITERATION_CHECKPOINT


def action_read_iteration_checkpoint() -> str:
    return READ_ITERATION_CHECKPOINT


class Interface:
    """``Interface(solver_name, configuration_file_name, solver_process_index, solver_process_size)``."""

    def __init__(self, solver_name: str, configuration_file_name: str, solver_process_index: int,
                 solver_process_size: int, communicator: Any = None):
        self._core = Core("Interface", solver_name, configuration_file_name, solver_process_index, solver_process_size)
        weakref.finalize(self, self._core.release)     # as preCICE's destructor: finalized if finalize was not called
        self._mesh_ids = {name: i for i, name in enumerate(sorted(self._core.meshes))}
        pairs = sorted(set(self._core.write) | set(self._core.read))
        self._data_ids: dict[tuple[str, str], int] = {pair: i for i, pair in enumerate(pairs)}
        self._initialized = False       # initialize() done; the exchange itself waits for initialize_data()
        self._edges: dict[str, list[tuple[int, int]]] = {}     # v2's edge ids, per mesh, for set_mesh_triangle
        self._pending = {WRITE_INITIAL_DATA: False, WRITE_ITERATION_CHECKPOINT: False,
                         READ_ITERATION_CHECKPOINT: False}

    # --- ids --------------------------------------------------------------------------------------------------------
    def get_dimensions(self) -> int:
        return int(self._core.setup["dimensions"])

    def has_mesh(self, mesh_name: str) -> bool:
        return mesh_name in self._mesh_ids

    def get_mesh_id(self, mesh_name: str) -> int:
        self._core.mesh("get_mesh_id", mesh_name)
        return self._mesh_ids[mesh_name]

    def _mesh(self, call: str, mesh_id: Any) -> str:
        for name, number in self._mesh_ids.items():
            if number == mesh_id and not isinstance(mesh_id, bool):
                return name
        known = ", ".join(f"{number} {name}" for name, number in self._mesh_ids.items())
        raise self._core.fail(call, f"no mesh has id {mesh_id!r} (ids: {known})")

    def has_data(self, data_name: str, mesh_id: int) -> bool:
        return (self._mesh("has_data", mesh_id), data_name) in self._data_ids

    def get_data_id(self, data_name: str, mesh_id: int) -> int:
        mesh = self._mesh("get_data_id", mesh_id)
        if (mesh, data_name) not in self._data_ids:
            raise self._core.fail("get_data_id", f"participant '{self._core.name}' has no data '{data_name}' on mesh '{mesh}'")
        return self._data_ids[(mesh, data_name)]

    def _data(self, call: str, data_id: Any) -> tuple[str, str]:
        for pair, number in self._data_ids.items():
            if number == data_id and not isinstance(data_id, bool):
                return pair
        raise self._core.fail(call, f"no data has id {data_id!r}")

    # --- meshes -----------------------------------------------------------------------------------------------------
    def set_mesh_vertex(self, mesh_id: int, position: Any) -> int:
        return int(self._core.add_vertices("set_mesh_vertex", self._mesh("set_mesh_vertex", mesh_id), position)[0])

    def set_mesh_vertices(self, mesh_id: int, positions: Any) -> np.ndarray:
        return self._core.add_vertices("set_mesh_vertices", self._mesh("set_mesh_vertices", mesh_id), positions)

    def get_mesh_vertex_size(self, mesh_id: int) -> int:
        return self._core.vertex_count(self._mesh("get_mesh_vertex_size", mesh_id))

    def is_mesh_connectivity_required(self, mesh_id: int) -> bool:
        mesh = self._mesh("is_mesh_connectivity_required", mesh_id)
        return bool(self._core.meshes[mesh].get("connectivity", False))

    def set_mesh_edge(self, mesh_id: int, first_vertex_id: int, second_vertex_id: int) -> int:
        mesh = self._mesh("set_mesh_edge", mesh_id)
        self._core.connect("set_mesh_edge", mesh, [first_vertex_id, second_vertex_id], 2)
        edges = self._edges.setdefault(mesh, [])
        edges.append((int(first_vertex_id), int(second_vertex_id)))
        return len(edges) - 1

    def set_mesh_triangle(self, mesh_id: int, first_edge_id: int, second_edge_id: int, third_edge_id: int) -> None:
        """A triangle of three edges (v2's ids, from set_mesh_edge)."""
        mesh = self._mesh("set_mesh_triangle", mesh_id)
        edges = self._edges.get(mesh, [])
        ids = [first_edge_id, second_edge_id, third_edge_id]
        for edge in ids:
            if isinstance(edge, bool) or not isinstance(edge, int | np.integer) or not 0 <= edge < len(edges):
                raise self._core.fail("set_mesh_triangle", f"edge id {edge!r} is not an edge of mesh '{mesh}' "
                                      f"({len(edges)} edges)")
        corners = sorted({vertex for edge in ids for vertex in edges[edge]})
        if len(corners) != 3:
            raise self._core.fail("set_mesh_triangle", f"edges {ids} do not close a triangle")
        self._core.connect("set_mesh_triangle", mesh, corners, 3)

    def set_mesh_triangle_with_edges(self, mesh_id: int, *vertex_ids: int) -> None:
        self._core.connect("set_mesh_triangle_with_edges", self._mesh("set_mesh_triangle_with_edges", mesh_id),
                           list(vertex_ids), 3)

    # --- steering ---------------------------------------------------------------------------------------------------
    def initialize(self) -> float:
        if self._initialized:
            raise self._core.fail("initialize", "initialize is called once")
        self._initialized = True
        self._pending[WRITE_INITIAL_DATA] = bool(self._core.setup["initial"])
        return self._core.window

    def initialize_data(self) -> None:
        if not self._initialized:
            raise self._core.fail("initialize_data", "initialize_data after initialize")
        if self._pending[WRITE_INITIAL_DATA]:
            raise self._core.fail("initialize_data", "the initial data is written first: is_action_required("
                                  "action_write_initial_data()) is True and not marked fulfilled")
        self._core.initialize("initialize_data")
        self._actions()

    def advance(self, computed_timestep_length: float) -> float:
        if self._core.state == "constructed":
            raise self._core.fail("advance", "advance before initialize and initialize_data")
        for action in (WRITE_ITERATION_CHECKPOINT, READ_ITERATION_CHECKPOINT):
            if self._pending[action]:
                raise self._core.fail("advance", f"the action {action} is required and not marked fulfilled")
        self._core.advance("advance", computed_timestep_length)
        self._actions()
        return self._core.remaining() if self._core.ongoing else 0.0

    def finalize(self) -> None:
        self._core.finalize("finalize")

    def _actions(self) -> None:
        self._pending[WRITE_ITERATION_CHECKPOINT] = self._core.write_checkpoint
        self._pending[READ_ITERATION_CHECKPOINT] = self._core.read_checkpoint

    # --- status -----------------------------------------------------------------------------------------------------
    def is_action_required(self, action: str) -> bool:
        if action not in ACTIONS:
            raise self._core.fail("is_action_required", f"unknown action {action!r} (the action_*() functions give them)")
        return self._pending[action]

    def mark_action_fulfilled(self, action: str) -> None:
        if action not in ACTIONS:
            raise self._core.fail("mark_action_fulfilled", f"unknown action {action!r}")
        if not self._pending[action]:
            raise self._core.fail("mark_action_fulfilled", f"the action {action} is not required now")
        self._pending[action] = False

    def is_coupling_ongoing(self) -> bool:
        return self._core.ongoing

    def is_time_window_complete(self) -> bool:
        return self._core.window_complete

    def is_read_data_available(self) -> bool:
        return self._core.state == "initialized" and self._core.read_available

    def is_write_data_required(self, computed_timestep_length: float) -> bool:
        return self._core.remaining() - float(computed_timestep_length) <= 1e-9 * self._core.window

    # --- data -------------------------------------------------------------------------------------------------------
    def _write(self, call: str, data_id: int, ids: Any, values: Any) -> None:
        mesh, data = self._data(call, data_id)
        self._core.write_values(call, mesh, data, ids, values)

    def _read(self, call: str, data_id: int, ids: Any) -> np.ndarray:
        mesh, data = self._data(call, data_id)
        return self._core.read_values(call, mesh, data, ids, None)

    def write_block_scalar_data(self, data_id: int, vertex_ids: Any, values: Any) -> None:
        self._write("write_block_scalar_data", data_id, vertex_ids, values)

    def write_scalar_data(self, data_id: int, vertex_id: int, value: float) -> None:
        self._write("write_scalar_data", data_id, [vertex_id], [value])

    def write_block_vector_data(self, data_id: int, vertex_ids: Any, values: Any) -> None:
        self._write("write_block_vector_data", data_id, vertex_ids, values)

    def write_vector_data(self, data_id: int, vertex_id: int, value: Any) -> None:
        self._write("write_vector_data", data_id, [vertex_id], np.asarray(value, dtype=np.float64)[None])

    def read_block_scalar_data(self, data_id: int, vertex_ids: Any) -> np.ndarray:
        return self._read("read_block_scalar_data", data_id, vertex_ids)

    def read_scalar_data(self, data_id: int, vertex_id: int) -> float:
        return float(self._read("read_scalar_data", data_id, [vertex_id])[0])

    def read_block_vector_data(self, data_id: int, vertex_ids: Any) -> np.ndarray:
        return self._read("read_block_vector_data", data_id, vertex_ids)

    def read_vector_data(self, data_id: int, vertex_id: int) -> np.ndarray:
        return self._read("read_vector_data", data_id, [vertex_id])[0]
