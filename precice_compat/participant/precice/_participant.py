"""preCICE v3's ``precice.Participant``, as pyprecice 3 offers it, on cosim's coupler."""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from precice._core import Core


class Participant:
    """``Participant(participant_name, configuration_file_name, solver_process_index, solver_process_size)``."""

    def __init__(self, participant_name: str, configuration_file_name: str, solver_process_index: int,
                 solver_process_size: int, communicator: Any = None):
        self._core = Core("Participant", participant_name, configuration_file_name, solver_process_index,
                          solver_process_size)
        weakref.finalize(self, self._core.release)     # as preCICE's destructor: finalized if finalize was not called

    # --- steering -------------------------------------------------------------------------------------------------
    def initialize(self) -> None:
        self._core.initialize("initialize")

    def advance(self, computed_timestep_length: float) -> None:
        self._core.advance("advance", computed_timestep_length)

    def finalize(self) -> None:
        self._core.finalize("finalize")

    # --- status -----------------------------------------------------------------------------------------------------
    def is_coupling_ongoing(self) -> bool:
        return self._core.ongoing

    def is_time_window_complete(self) -> bool:
        return self._core.window_complete

    def get_max_time_step_size(self) -> float:
        return self._core.remaining()

    def requires_initial_data(self) -> bool:
        return bool(self._core.setup["initial"])

    def requires_writing_checkpoint(self) -> bool:
        return self._core.write_checkpoint

    def requires_reading_checkpoint(self) -> bool:
        return self._core.read_checkpoint

    # --- meshes -----------------------------------------------------------------------------------------------------
    def get_mesh_dimensions(self, mesh_name: str) -> int:
        return int(self._core.mesh("get_mesh_dimensions", mesh_name)["dimensions"])

    def get_data_dimensions(self, mesh_name: str, data_name: str) -> int:
        self._core.mesh("get_data_dimensions", mesh_name)
        spec = self._core.write.get((mesh_name, data_name)) or self._core.read.get((mesh_name, data_name))
        if spec is None:
            raise self._core.fail("get_data_dimensions", f"no data '{data_name}' on mesh '{mesh_name}' for participant '{self._core.name}'")
        return int(spec["dimensions"])

    def set_mesh_vertex(self, mesh_name: str, position: Any) -> int:
        return int(self._core.add_vertices("set_mesh_vertex", mesh_name, position)[0])

    def set_mesh_vertices(self, mesh_name: str, positions: Any) -> np.ndarray:
        return self._core.add_vertices("set_mesh_vertices", mesh_name, positions)

    def get_mesh_vertex_size(self, mesh_name: str) -> int:
        info = self._core.mesh("get_mesh_vertex_size", mesh_name)
        if not info["provided"]:        # a received mesh: its vertices in the access region, once initialized
            if self._core.state != "initialized" or mesh_name not in self._core.regions:
                return 0
            return len(self._core.region_vertices("get_mesh_vertex_size", mesh_name)[0])
        return self._core.vertex_count(mesh_name)

    def requires_mesh_connectivity_for(self, mesh_name: str) -> bool:
        return bool(self._core.mesh("requires_mesh_connectivity_for", mesh_name).get("connectivity", False))

    def _connectivity(self, call: str, mesh_name: str, vertices: Any, per_element: int) -> None:
        self._core.connect(call, mesh_name, vertices, per_element)

    def set_mesh_edge(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int) -> None:
        self._connectivity("set_mesh_edge", mesh_name, [first_vertex_id, second_vertex_id], 2)

    def set_mesh_edges(self, mesh_name: str, vertices: Any) -> None:
        self._connectivity("set_mesh_edges", mesh_name, vertices, 2)

    def set_mesh_triangle(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int,
                          third_vertex_id: int) -> None:
        self._connectivity("set_mesh_triangle", mesh_name, [first_vertex_id, second_vertex_id, third_vertex_id], 3)

    def set_mesh_triangles(self, mesh_name: str, vertices: Any) -> None:
        self._connectivity("set_mesh_triangles", mesh_name, vertices, 3)

    def set_mesh_quad(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int, third_vertex_id: int,
                      fourth_vertex_id: int) -> None:
        self._connectivity("set_mesh_quad", mesh_name,
                           [first_vertex_id, second_vertex_id, third_vertex_id, fourth_vertex_id], 4)

    def set_mesh_quads(self, mesh_name: str, vertices: Any) -> None:
        self._connectivity("set_mesh_quads", mesh_name, vertices, 4)

    def set_mesh_tetrahedron(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int,
                             third_vertex_id: int, fourth_vertex_id: int) -> None:
        self._connectivity("set_mesh_tetrahedron", mesh_name,
                           [first_vertex_id, second_vertex_id, third_vertex_id, fourth_vertex_id], 4)

    def set_mesh_tetrahedra(self, mesh_name: str, vertices: Any) -> None:
        self._connectivity("set_mesh_tetrahedra", mesh_name, vertices, 4)

    def reset_mesh(self, mesh_name: str) -> None:
        """preCICE's experimental remeshing: refused by cosim (a mesh keeps its vertices for the whole run)."""
        self._core.mesh("reset_mesh", mesh_name)
        raise self._core.fail("reset_mesh", f"remeshing is not supported by cosim: mesh '{mesh_name}' keeps the "
                                            "vertices it had at initialize for the whole run")

    def set_mesh_access_region(self, mesh_name: str, bounding_box: Any) -> None:
        self._core.set_access_region("set_mesh_access_region", mesh_name, bounding_box)

    def get_mesh_vertex_ids_and_coordinates(self, mesh_name: str) -> tuple[np.ndarray, np.ndarray]:
        return self._core.region_vertices("get_mesh_vertex_ids_and_coordinates", mesh_name)

    # --- data -------------------------------------------------------------------------------------------------------
    def write_data(self, mesh_name: str, data_name: str, vertex_ids: Any, values: Any) -> None:
        self._core.write_values("write_data", mesh_name, data_name, vertex_ids, values)

    def read_data(self, mesh_name: str, data_name: str, vertex_ids: Any, relative_read_time: float) -> np.ndarray:
        return self._core.read_values("read_data", mesh_name, data_name, vertex_ids, float(relative_read_time))

    def requires_gradient_data_for(self, mesh_name: str, data_name: str) -> bool:
        """Whether a nearest-neighbor-gradient mapping maps this data from this mesh: then write its gradients
        (``write_gradient_data``) with its values."""
        self._core.mesh("requires_gradient_data_for", mesh_name)
        return bool(self._core.write.get((mesh_name, data_name), {}).get("gradient"))

    def write_gradient_data(self, mesh_name: str, data_name: str, vertex_ids: Any, gradients: Any) -> None:
        """The data's gradients at the vertices: an array of one row a vertex, the first component's d/dx, d/dy (and
        d/dz), then the next component's (the layout preCICE 3.4.1 reads); only where ``requires_gradient_data_for``
        is True, in a configuration with ``experimental="true"``."""
        self._core.write_gradients("write_gradient_data", mesh_name, data_name, vertex_ids, gradients)

    def write_and_map_data(self, mesh_name: str, data_name: str, coordinates: Any, values: Any) -> None:
        self._core.write_and_map("write_and_map_data", mesh_name, data_name, coordinates, values)

    def map_and_read_data(self, mesh_name: str, data_name: str, coordinates: Any,
                          relative_read_time: float) -> np.ndarray:
        return self._core.map_and_read("map_and_read_data", mesh_name, data_name, coordinates,
                                       float(relative_read_time))

    # --- profiling (accepted: cosim times every call itself) ---------------------------------------------------------
    def start_profiling_section(self, event_name: str) -> None:
        pass

    def stop_last_profiling_section(self) -> None:
        pass
