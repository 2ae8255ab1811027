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
    """The action of writing initial data before ``initialize_data``.

    Returns
    -------
    str
        ``"write-initial-data"``, for ``Interface.is_action_required`` and ``Interface.mark_action_fulfilled``.
    """
    return WRITE_INITIAL_DATA


def action_write_iteration_checkpoint() -> str:
    """The action of saving the solver's state at the start of an implicit window.

    Returns
    -------
    str
        ``"write-iteration-checkpoint"``, for ``Interface.is_action_required`` and ``Interface.mark_action_fulfilled``.
    """
    return WRITE_ITERATION_CHECKPOINT


def action_read_iteration_checkpoint() -> str:
    """The action of restoring the solver's saved state when a window is computed again.

    Returns
    -------
    str
        ``"read-iteration-checkpoint"``, for ``Interface.is_action_required`` and ``Interface.mark_action_fulfilled``.
    """
    return READ_ITERATION_CHECKPOINT


class Interface:
    """A preCICE v2 participant (pyprecice 2.5's ``precice.Interface``), coupled by cosim's coupler.

    preCICE 2's API: meshes and data by integer ids (``get_mesh_id``, ``get_data_id``), the checkpoints and initial
    data as actions (``is_action_required``, ``mark_action_fulfilled``), and the first exchange in
    ``initialize_data``. A solver calls ``initialize``, writes any initial data, ``initialize_data``, then
    computes, writes, ``advance`` and reads while ``is_coupling_ongoing()``, and ``finalize``. Every misuse raises
    ``precice.Error`` with one line that names the call and why; the coupler's run stops with the same line.

    Parameters
    ----------
    solver_name : str
        The participant's name, as the configuration's ``<participant name="...">`` gives it.
    configuration_file_name : str
        Path of the preCICE configuration (XML) the coupler runs.
    solver_process_index : int
        This process's rank, from 0 to ``solver_process_size - 1``.
    solver_process_size : int
        How many processes (ranks) the participant runs as; 1 for a serial solver.
    communicator : object, optional
        pyprecice's MPI communicator; accepted and ignored by cosim.

    Raises
    ------
    precice.Error
        An empty name; a rank or size that is no integer, or a rank outside 0 to ``size - 1``; a configuration
        file that does not exist; no coupler to connect to; or the coupler refusing the participant.

    Notes
    -----
    The first call: every other method needs the object. Where cosim differs from preCICE:

    - No libprecice is linked: the participant connects to cosim's coupler, as ``precice.Participant`` does (see
      its help), and the constructor waits for the coupler's answer.
    - ``communicator`` is not used, nor is MPI: each rank connects to the coupler on its own, and the coupler
      joins a participant's ranks into one.
    - The ids are cosim's: the participant's meshes numbered from 0 in the order of their names, its data (each
      mesh and data pair it writes or reads) likewise. Ask for them by name; do not assume preCICE's numbers.
    - ``initialize`` exchanges nothing: the meshes and the initial data go at ``initialize_data``, which is
      always called.
    - A participant collected without ``finalize`` is finalized as preCICE's destructor does if its coupling is
      over; otherwise its connection is closed and the coupler names it.
    """

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
        """The spatial dimensions of the configuration.

        Returns
        -------
        int
            2 or 3, the number of coordinates of each vertex.

        Notes
        -----
        Any time.
        """
        return int(self._core.setup["dimensions"])

    def has_mesh(self, mesh_name: str) -> bool:
        """Whether the participant uses (provides or receives) a mesh of that name.

        Parameters
        ----------
        mesh_name : str
            The mesh's name in the configuration.

        Returns
        -------
        bool
            True for a mesh the participant uses.

        Notes
        -----
        Any time.
        """
        return mesh_name in self._mesh_ids

    def get_mesh_id(self, mesh_name: str) -> int:
        """The id of a mesh the participant uses, for the calls that take a ``mesh_id``.

        Parameters
        ----------
        mesh_name : str
            The mesh's name in the configuration.

        Returns
        -------
        int
            The mesh's id: cosim numbers the participant's meshes from 0 in the order of their names.

        Raises
        ------
        precice.Error
            The participant uses no mesh of that name.

        Notes
        -----
        Any time; usually before setting the mesh's vertices.
        """
        self._core.mesh("get_mesh_id", mesh_name)
        return self._mesh_ids[mesh_name]

    def _mesh(self, call: str, mesh_id: Any) -> str:
        for name, number in self._mesh_ids.items():
            if number == mesh_id and not isinstance(mesh_id, bool):
                return name
        known = ", ".join(f"{number} {name}" for name, number in self._mesh_ids.items())
        raise self._core.fail(call, f"no mesh has id {mesh_id!r} (ids: {known})")

    def has_data(self, data_name: str, mesh_id: int) -> bool:
        """Whether the participant writes or reads a data item of that name on a mesh.

        Parameters
        ----------
        data_name : str
            The data's name in the configuration.
        mesh_id : int
            The mesh's id, from ``get_mesh_id``.

        Returns
        -------
        bool
            True for data the participant writes or reads on that mesh.

        Raises
        ------
        precice.Error
            No mesh has that id.

        Notes
        -----
        Any time.
        """
        return (self._mesh("has_data", mesh_id), data_name) in self._data_ids

    def get_data_id(self, data_name: str, mesh_id: int) -> int:
        """The id of a data item on a mesh, for the calls that write or read data.

        Parameters
        ----------
        data_name : str
            The data's name in the configuration.
        mesh_id : int
            The mesh's id, from ``get_mesh_id``.

        Returns
        -------
        int
            The data's id: cosim numbers the (mesh, data) pairs the participant writes or reads from 0, in order.

        Raises
        ------
        precice.Error
            No mesh has that id, or the participant neither writes nor reads that data on it.

        Notes
        -----
        Any time.
        """
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
        """Add one vertex to a mesh the participant provides.

        Parameters
        ----------
        mesh_id : int
            The provided mesh's id.
        position : array_like
            The vertex's coordinates, ``get_dimensions()`` finite values.

        Returns
        -------
        int
            The vertex's id: the vertices of a mesh count from 0 in the order they are set (per rank).

        Raises
        ------
        precice.Error
            An unknown mesh id or a received mesh, a call after ``initialize_data``, or a position of the wrong size
            or not finite.

        Notes
        -----
        Call before initialize (cosim takes vertices until ``initialize_data``, which sends them).
        """
        return int(self._core.add_vertices("set_mesh_vertex", self._mesh("set_mesh_vertex", mesh_id), position)[0])

    def set_mesh_vertices(self, mesh_id: int, positions: Any) -> np.ndarray:
        """Add vertices to a mesh the participant provides.

        Parameters
        ----------
        mesh_id : int
            The provided mesh's id.
        positions : array_like
            The vertices' coordinates, of shape (n, dimensions); a single vertex's may be flat.

        Returns
        -------
        numpy.ndarray
            The n vertex ids, in the order of ``positions``, following those of the vertices set before.

        Raises
        ------
        precice.Error
            An unknown mesh id or a received mesh, a call after ``initialize_data``, or positions of the wrong shape
            or not finite.

        Notes
        -----
        Call before initialize (cosim takes vertices until ``initialize_data``, which sends them).
        """
        return self._core.add_vertices("set_mesh_vertices", self._mesh("set_mesh_vertices", mesh_id), positions)

    def get_mesh_vertex_size(self, mesh_id: int) -> int:
        """The number of vertices of a mesh: those set on a provided mesh.

        Parameters
        ----------
        mesh_id : int
            The mesh's id.

        Returns
        -------
        int
            The vertices set so far on a provided mesh; on a received mesh, those the coupler sent for it (none
            without direct access, which this v2 API does not offer).

        Raises
        ------
        precice.Error
            No mesh has that id.

        Notes
        -----
        Any time.
        """
        return self._core.vertex_count(self._mesh("get_mesh_vertex_size", mesh_id))

    def is_mesh_connectivity_required(self, mesh_id: int) -> bool:
        """Whether a mapping of the configuration uses the mesh's connectivity (edges, triangles).

        Parameters
        ----------
        mesh_id : int
            The mesh's id.

        Returns
        -------
        bool
            True when a projection or cell-interpolation mapping uses this mesh; then set its elements.

        Raises
        ------
        precice.Error
            No mesh has that id.

        Notes
        -----
        Any time; ask before ``initialize``, when the elements can still be set.
        """
        mesh = self._mesh("is_mesh_connectivity_required", mesh_id)
        return bool(self._core.meshes[mesh].get("connectivity", False))

    def set_mesh_edge(self, mesh_id: int, first_vertex_id: int, second_vertex_id: int) -> int:
        """Add an edge between two vertices of a provided mesh.

        Parameters
        ----------
        mesh_id : int
            The provided mesh's id.
        first_vertex_id, second_vertex_id : int
            The ids of the edge's two vertices, as ``set_mesh_vertices`` gave them.

        Returns
        -------
        int
            The edge's id, for ``set_mesh_triangle``: a mesh's edges count from 0 in the order they are set.

        Raises
        ------
        precice.Error
            An unknown mesh id or a received mesh, a call after ``initialize_data``, an id that is not a vertex of the
            mesh, or the same vertex twice.

        Notes
        -----
        Call before initialize, after setting the vertices.
        """
        mesh = self._mesh("set_mesh_edge", mesh_id)
        self._core.connect("set_mesh_edge", mesh, [first_vertex_id, second_vertex_id], 2)
        edges = self._edges.setdefault(mesh, [])
        edges.append((int(first_vertex_id), int(second_vertex_id)))
        return len(edges) - 1

    def set_mesh_triangle(self, mesh_id: int, first_edge_id: int, second_edge_id: int, third_edge_id: int) -> None:
        """Add a triangle made of three edges of a provided mesh.

        Parameters
        ----------
        mesh_id : int
            The provided mesh's id.
        first_edge_id, second_edge_id, third_edge_id : int
            The ids of the triangle's edges, as ``set_mesh_edge`` gave them.

        Raises
        ------
        precice.Error
            An unknown mesh id or a received mesh, an id that is not an edge of the mesh, edges that do not close
            a triangle, or a call after ``initialize_data``.

        Notes
        -----
        Call before initialize, after setting the edges.
        """
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
        """Add a triangle of three vertices to a provided mesh, with its three edges.

        Parameters
        ----------
        mesh_id : int
            The provided mesh's id.
        *vertex_ids : int
            The ids of the triangle's three corners (pyprecice's ``first_vertex_id``, ``second_vertex_id``,
            ``third_vertex_id``).

        Raises
        ------
        precice.Error
            An unknown mesh id or a received mesh, a call after ``initialize_data``, other than three ids, an id that
            is not a vertex of the mesh, or a vertex repeated.

        Notes
        -----
        Call before initialize, after setting the vertices.
        """
        self._core.connect("set_mesh_triangle_with_edges", self._mesh("set_mesh_triangle_with_edges", mesh_id),
                           list(vertex_ids), 3)

    # --- steering ---------------------------------------------------------------------------------------------------
    def initialize(self) -> float:
        """Start the coupling: the first step of preCICE 2's two-step initialization.

        Returns
        -------
        float
            The size of the first time window, the longest first step.

        Raises
        ------
        precice.Error
            A second call.

        Notes
        -----
        Call only once, after setting the meshes' vertices, before ``initialize_data``. In cosim it exchanges
        nothing: it raises the write-initial-data action where the configuration has initial data, and the vertices
        and data go at ``initialize_data``.
        """
        if self._initialized:
            raise self._core.fail("initialize", "initialize is called once")
        self._initialized = True
        self._pending[WRITE_INITIAL_DATA] = bool(self._core.setup["initial"])
        return self._core.window

    def initialize_data(self) -> None:
        """Send the meshes and the initial data, and receive the first window's data.

        Raises
        ------
        precice.Error
            A call before ``initialize``, a second call, or initial data required and not marked written
            (``mark_action_fulfilled(action_write_initial_data())``), or a provided mesh without vertices.

        Notes
        -----
        Call only once, after initialize and, where ``is_action_required(action_write_initial_data())``, after writing
        the initial data and marking that action fulfilled; before ``advance``. cosim requires it always, with or
        without initial data: preCICE 2's first exchange happens here. Then ask ``is_action_required`` for the
        write-iteration-checkpoint action.
        """
        if not self._initialized:
            raise self._core.fail("initialize_data", "initialize_data after initialize")
        if self._pending[WRITE_INITIAL_DATA]:
            raise self._core.fail("initialize_data", "the initial data is written first: is_action_required("
                                  "action_write_initial_data()) is True and not marked fulfilled")
        self._core.initialize("initialize_data")
        self._actions()

    def advance(self, computed_timestep_length: float) -> float:
        """Advance the coupling by the solver's step; a step that ends the time window exchanges the data.

        Parameters
        ----------
        computed_timestep_length : float
            The size of the step just computed: positive, at most what the last ``advance`` (or ``initialize``)
            returned.

        Returns
        -------
        float
            What is left of the time window, the longest next step; 0.0 once the coupling is over.

        Raises
        ------
        precice.Error
            A call before ``initialize_data`` or after ``finalize``, a checkpoint action required and not marked
            fulfilled, once the coupling is over, or a step that is not a positive number or that is longer than what
            is left of the window.

        Notes
        -----
        Call between initialize_data and finalize, while ``is_coupling_ongoing()``, after computing the step and
        writing its data, and after marking the required checkpoint actions fulfilled. Then ask
        ``is_action_required`` for the checkpoint actions of what comes next.
        """
        if self._core.state == "constructed":
            raise self._core.fail("advance", "advance before initialize and initialize_data")
        for action in (WRITE_ITERATION_CHECKPOINT, READ_ITERATION_CHECKPOINT):
            if self._pending[action]:
                raise self._core.fail("advance", f"the action {action} is required and not marked fulfilled")
        self._core.advance("advance", computed_timestep_length)
        self._actions()
        return self._core.remaining() if self._core.ongoing else 0.0

    def finalize(self) -> None:
        """End the coupling and close the connection to the coupler.

        Raises
        ------
        precice.Error
            A call while the coupling goes on (after ``initialize_data``, with ``is_coupling_ongoing()`` True).

        Notes
        -----
        Call after the last advance, once is_coupling_ongoing() is False (or before ``initialize_data``, to give up).
        A second call does nothing; calls that write or read data raise ``precice.Error`` after it.
        """
        self._core.finalize("finalize")

    def _actions(self) -> None:
        self._pending[WRITE_ITERATION_CHECKPOINT] = self._core.write_checkpoint
        self._pending[READ_ITERATION_CHECKPOINT] = self._core.read_checkpoint

    # --- status -----------------------------------------------------------------------------------------------------
    def is_action_required(self, action: str) -> bool:
        """Whether the solver must do an action now (write initial data, save or restore its state).

        Parameters
        ----------
        action : str
            One of ``action_write_initial_data()``, ``action_write_iteration_checkpoint()`` and
            ``action_read_iteration_checkpoint()``.

        Returns
        -------
        bool
            True while the action is required and not yet marked fulfilled.

        Raises
        ------
        precice.Error
            Another string.

        Notes
        -----
        Ask for the initial data after ``initialize``, for the checkpoints after ``initialize_data`` and after each
        ``advance``.
        """
        if action not in ACTIONS:
            raise self._core.fail("is_action_required", f"unknown action {action!r} (the action_*() functions give them)")
        return self._pending[action]

    def mark_action_fulfilled(self, action: str) -> None:
        """Tell the coupling that the solver did a required action.

        Parameters
        ----------
        action : str
            One of the ``action_*()`` strings.

        Raises
        ------
        precice.Error
            Another string, or an action that is not required now.

        Notes
        -----
        Only while ``is_action_required(action)`` is True, after doing it: writing the initial data before
        ``initialize_data``, saving or restoring the state before the next ``advance`` (which refuses to run while a
        checkpoint action is pending).
        """
        if action not in ACTIONS:
            raise self._core.fail("mark_action_fulfilled", f"unknown action {action!r}")
        if not self._pending[action]:
            raise self._core.fail("mark_action_fulfilled", f"the action {action} is not required now")
        self._pending[action] = False

    def is_coupling_ongoing(self) -> bool:
        """Whether the coupled run goes on: False once the last window's ``advance`` has returned.

        Returns
        -------
        bool
            True until the coupling's end time (or number of windows) is reached.

        Notes
        -----
        Any time; True before ``initialize``. Loop ``advance`` while it is True, then call ``finalize``.
        """
        return self._core.ongoing

    def is_time_window_complete(self) -> bool:
        """Whether the last ``advance`` completed a time window (and, when implicit, its iterations converged).

        Returns
        -------
        bool
            True after an ``advance`` that moved on to a new window; False otherwise.

        Notes
        -----
        Meaningful after ``initialize_data``.
        """
        return self._core.window_complete

    def is_read_data_available(self) -> bool:
        """Whether new data came to read: the last exchange brought it.

        Returns
        -------
        bool
            True after ``initialize_data`` and after an ``advance`` that ended a window; False before
            ``initialize_data``, after a step inside the window, and after ``finalize``.

        Notes
        -----
        Any time.
        """
        return self._core.state == "initialized" and self._core.read_available

    def is_write_data_required(self, computed_timestep_length: float) -> bool:
        """Whether a step of this size ends the time window, so that its ``advance`` sends the written data.

        Parameters
        ----------
        computed_timestep_length : float
            The size of the step about to be computed.

        Returns
        -------
        bool
            True when the step reaches what is left of the window.

        Notes
        -----
        Meaningful after ``initialize``, before the step's ``advance``.
        """
        return self._core.remaining() - float(computed_timestep_length) <= 1e-9 * self._core.window

    # --- data -------------------------------------------------------------------------------------------------------
    def _write(self, call: str, data_id: int, ids: Any, values: Any) -> None:
        mesh, data = self._data(call, data_id)
        self._core.write_values(call, mesh, data, ids, values)

    def _read(self, call: str, data_id: int, ids: Any) -> np.ndarray:
        mesh, data = self._data(call, data_id)
        return self._core.read_values(call, mesh, data, ids, None)

    def write_block_scalar_data(self, data_id: int, vertex_ids: Any, values: Any) -> None:
        """Write scalar data's values at vertices, for the next exchange.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant writes.
        vertex_ids : array_like of int
            The ids of the vertices written.
        values : array_like
            One value a vertex.

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not write, an id not on the mesh, values of the wrong
            shape or not finite, a write before ``initialize_data`` that is not initial data, or a call after
            ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize, before the ``advance`` that sends it; before initialize_data only
        as initial data (where ``is_action_required(action_write_initial_data())``) on a provided mesh. A value
        written stays until written again; vertices never written send zeros.
        """
        self._write("write_block_scalar_data", data_id, vertex_ids, values)

    def write_scalar_data(self, data_id: int, vertex_id: int, value: float) -> None:
        """Write scalar data's value at one vertex, for the next exchange.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant writes.
        vertex_id : int
            The vertex's id.
        value : float
            Its value.

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not write, an id not on the mesh, values of the wrong
            shape or not finite, a write before ``initialize_data`` that is not initial data, or a call after
            ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize, before the ``advance`` that sends it; before initialize_data only
        as initial data (where ``is_action_required(action_write_initial_data())``) on a provided mesh. A value
        written stays until written again; vertices never written send zeros.
        """
        self._write("write_scalar_data", data_id, [vertex_id], [value])

    def write_block_vector_data(self, data_id: int, vertex_ids: Any, values: Any) -> None:
        """Write vector data's values at vertices, for the next exchange.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant writes.
        vertex_ids : array_like of int
            The ids of the vertices written.
        values : array_like
            Their values, of shape (n, dimensions), or a flat block of n x dimensions.

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not write, an id not on the mesh, values of the wrong
            shape or not finite, a write before ``initialize_data`` that is not initial data, or a call after
            ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize, before the ``advance`` that sends it; before initialize_data only
        as initial data (where ``is_action_required(action_write_initial_data())``) on a provided mesh. A value
        written stays until written again; vertices never written send zeros.
        """
        self._write("write_block_vector_data", data_id, vertex_ids, values)

    def write_vector_data(self, data_id: int, vertex_id: int, value: Any) -> None:
        """Write vector data's value at one vertex, for the next exchange.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant writes.
        vertex_id : int
            The vertex's id.
        value : array_like
            Its value, ``get_dimensions()`` components.

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not write, an id not on the mesh, values of the wrong
            shape or not finite, a write before ``initialize_data`` that is not initial data, or a call after
            ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize, before the ``advance`` that sends it; before initialize_data only
        as initial data (where ``is_action_required(action_write_initial_data())``) on a provided mesh. A value
        written stays until written again; vertices never written send zeros.
        """
        self._write("write_vector_data", data_id, [vertex_id], np.asarray(value, dtype=np.float64)[None])

    def read_block_scalar_data(self, data_id: int, vertex_ids: Any) -> np.ndarray:
        """Read scalar data's values at vertices.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant reads.
        vertex_ids : array_like of int
            The ids of the vertices read.

        Returns
        -------
        numpy.ndarray
            One value a vertex, of shape (n,).

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not read, an id not on the mesh, or a call before
            ``initialize_data`` or after ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize. preCICE 2's API reads at the window's end: the values the last
        exchange brought (after the last ``advance``, the last window's).
        """
        return self._read("read_block_scalar_data", data_id, vertex_ids)

    def read_scalar_data(self, data_id: int, vertex_id: int) -> float:
        """Read scalar data's value at one vertex.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant reads.
        vertex_id : int
            The vertex's id.

        Returns
        -------
        float
            Its value.

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not read, an id not on the mesh, or a call before
            ``initialize_data`` or after ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize. preCICE 2's API reads at the window's end: the values the last
        exchange brought (after the last ``advance``, the last window's).
        """
        return float(self._read("read_scalar_data", data_id, [vertex_id])[0])

    def read_block_vector_data(self, data_id: int, vertex_ids: Any) -> np.ndarray:
        """Read vector data's values at vertices.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant reads.
        vertex_ids : array_like of int
            The ids of the vertices read.

        Returns
        -------
        numpy.ndarray
            Their values, of shape (n, dimensions).

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not read, an id not on the mesh, or a call before
            ``initialize_data`` or after ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize. preCICE 2's API reads at the window's end: the values the last
        exchange brought (after the last ``advance``, the last window's).
        """
        return self._read("read_block_vector_data", data_id, vertex_ids)

    def read_vector_data(self, data_id: int, vertex_id: int) -> np.ndarray:
        """Read vector data's value at one vertex.

        Parameters
        ----------
        data_id : int
            The data's id, from ``get_data_id``; data the participant reads.
        vertex_id : int
            The vertex's id.

        Returns
        -------
        numpy.ndarray
            Its value, of shape (dimensions,).

        Raises
        ------
        precice.Error
            An unknown data id or data the participant does not read, an id not on the mesh, or a call before
            ``initialize_data`` or after ``finalize``.

        Notes
        -----
        Call between initialize_data and finalize. preCICE 2's API reads at the window's end: the values the last
        exchange brought (after the last ``advance``, the last window's).
        """
        return self._read("read_vector_data", data_id, [vertex_id])[0]
