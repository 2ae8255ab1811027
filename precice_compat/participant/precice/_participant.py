"""preCICE v3's ``precice.Participant``, as pyprecice 3 offers it, on cosim's coupler."""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from precice._core import Core


class Participant:
    """A preCICE v3 participant (pyprecice 3's ``precice.Participant``), coupled by cosim's coupler.

    A solver couples in preCICE's order: define its meshes (vertices, connectivity, access regions), write any
    initial data, ``initialize``, then compute, write, ``advance`` and read while ``is_coupling_ongoing()``, and
    ``finalize``. Every misuse raises ``precice.Error`` with one line that names the call and why; the coupler's run
    stops with the same line.

    Parameters
    ----------
    participant_name : str
        The participant's name, as the configuration's ``<participant name="...">`` gives it.
    configuration_file_name : str
        Path of the preCICE configuration (XML) the coupler runs.
    solver_process_index : int
        This process's rank, from 0 to ``solver_process_size - 1``.
    solver_process_size : int
        How many processes (ranks) the participant runs as; 1 for a serial solver.
    communicator : object, optional
        pyprecice's MPI communicator (``mpi4py.MPI.Intracomm``); accepted and ignored by cosim.

    Raises
    ------
    precice.Error
        An empty name; a rank or size that is no integer, or a rank outside 0 to ``size - 1``; a configuration
        file that does not exist; no coupler to connect to; or the coupler refusing the participant.

    Notes
    -----
    The first call: every other method needs the object. Where cosim differs from preCICE:

    - No libprecice is linked: the participant connects to cosim's coupler. ``cosim run`` tells a participant it
      starts where the coupler is; one started by hand finds it through ``cosim-run/coupler.json`` next to the
      configuration, and the first one started by hand starts a coupler if none runs. The constructor waits for
      the coupler's answer (the participant's meshes, data and time window).
    - ``communicator`` is not used, nor is MPI: each rank connects to the coupler on its own, and the coupler
      joins a participant's ranks into one (each rank keeps its own vertex ids, from 0).
    - A participant collected, or whose interpreter exits, without ``finalize`` is finalized as preCICE's
      destructor does if its coupling is over; otherwise its connection is closed and the coupler names it.
    """

    def __init__(self, participant_name: str, configuration_file_name: str, solver_process_index: int,
                 solver_process_size: int, communicator: Any = None):
        self._core = Core("Participant", participant_name, configuration_file_name, solver_process_index,
                          solver_process_size)
        weakref.finalize(self, self._core.release)     # as preCICE's destructor: finalized if finalize was not called

    # --- steering -------------------------------------------------------------------------------------------------
    def initialize(self) -> None:
        """Start the coupling: send the meshes and the initial data, and receive the first window's data.

        Raises
        ------
        precice.Error
            A second call, a call after ``finalize``, or a provided mesh without vertices.

        Notes
        -----
        Call only once, after the vertices of every provided mesh are set (``set_mesh_vertices``), with their
        connectivity and access regions, and after writing the initial data where ``requires_initial_data()``;
        before ``advance``. It returns with the first window's data (the coupler may wait for the other
        participants first): then ``get_max_time_step_size``, ``read_data`` and ``requires_writing_checkpoint``
        tell the first window.
        """
        self._core.initialize("initialize")

    def advance(self, computed_timestep_length: float) -> None:
        """Advance the coupling by the solver's step; a step that ends the time window exchanges the data.

        Parameters
        ----------
        computed_timestep_length : float
            The size of the step just computed: positive, at most ``get_max_time_step_size()``.

        Raises
        ------
        precice.Error
            A call before ``initialize`` or after ``finalize``, once the coupling is over, or a step that is not a
            positive number or that is longer than what is left of the window.

        Notes
        -----
        Call between initialize and finalize, while ``is_coupling_ongoing()``, after computing the step and writing
        its data. A step shorter than what is left of the window stays local (with ``substeps``, the data written
        is kept as a sample); the step that ends the window sends the written data to the coupler and waits for the
        next window's data. Then ask ``requires_reading_checkpoint`` whether the window is repeated. As preCICE
        does, an implicit coupling refuses an ``advance`` after one that asked for a checkpoint (the window's start,
        or a window repeated) where ``requires_writing_checkpoint`` (or ``requires_reading_checkpoint``) was not
        asked since.
        """
        core = self._core
        for due, asked, call in ((core.write_checkpoint, core.asked_write, "requires_writing_checkpoint"),
                                 (core.read_checkpoint, core.asked_read, "requires_reading_checkpoint")):
            if due and not asked:
                kind = "written" if call == "requires_writing_checkpoint" else "read"
                raise core.fail("advance", f"the iteration checkpoint was not {kind}: the implicit coupling asks "
                                           f"for one here, and {call}() was not called since the last advance")
        core.advance("advance", computed_timestep_length)

    def finalize(self) -> None:
        """End the coupling and close the connection to the coupler.

        Raises
        ------
        precice.Error
            A call while the coupling goes on (after ``initialize``, with ``is_coupling_ongoing()`` True).

        Notes
        -----
        Call after the last advance, once is_coupling_ongoing() is False (or before ``initialize``, to give up).
        A second call does nothing; calls that write or read data raise ``precice.Error`` after it.
        """
        self._core.finalize("finalize")

    # --- status -----------------------------------------------------------------------------------------------------
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
            True after an ``advance`` that moved on to a new window; False before, after a step inside the
            window, and after an ``advance`` that repeats the window.

        Notes
        -----
        Meaningful after ``initialize``.
        """
        return self._core.window_complete

    def get_max_time_step_size(self) -> float:
        """The longest step the solver may take next: what is left of the current time window.

        Returns
        -------
        float
            The time from the participant's time to the window's end.

        Notes
        -----
        Meaningful after ``initialize`` (before it, the first window's size). A solver takes the smaller of its own
        step and this one, so that its steps meet the window's end.
        """
        return self._core.remaining()

    def requires_initial_data(self) -> bool:
        """Whether the participant writes initial data before ``initialize``.

        Returns
        -------
        bool
            True when an exchange this participant writes has ``initialize="true"`` in the configuration.

        Notes
        -----
        Ask before ``initialize``; then write that data with ``write_data``.
        """
        return bool(self._core.setup["initial"])

    def requires_writing_checkpoint(self) -> bool:
        """Whether the solver saves its state now: an implicit window starts.

        Returns
        -------
        bool
            True after ``initialize`` or an ``advance`` that starts a window of an implicit coupling.

        Notes
        -----
        Ask after ``initialize`` and after each ``advance``, before computing the next step; False before
        ``initialize`` and in an explicit coupling.
        """
        self._core.asked_write = True
        return self._core.write_checkpoint

    def requires_reading_checkpoint(self) -> bool:
        """Whether the solver restores the state it saved: the window did not converge and is computed again.

        Returns
        -------
        bool
            True after an ``advance`` that ended a window whose coupling iterations go on.

        Notes
        -----
        Ask after each ``advance``; False before ``initialize``, after a step inside the window, and in an
        explicit coupling.
        """
        self._core.asked_read = True
        return self._core.read_checkpoint

    # --- meshes -----------------------------------------------------------------------------------------------------
    def get_mesh_dimensions(self, mesh_name: str) -> int:
        """The spatial dimensions of a mesh the participant provides or receives.

        Parameters
        ----------
        mesh_name : str
            The mesh's name in the configuration.

        Returns
        -------
        int
            2 or 3, the number of coordinates of each vertex.

        Raises
        ------
        precice.Error
            The participant uses no mesh of that name.

        Notes
        -----
        Any time.
        """
        return int(self._core.mesh("get_mesh_dimensions", mesh_name)["dimensions"])

    def get_data_dimensions(self, mesh_name: str, data_name: str) -> int:
        """The number of components of a data item on a mesh: 1 for scalar data, the mesh's dimensions for vector.

        Parameters
        ----------
        mesh_name : str
            The mesh's name in the configuration.
        data_name : str
            The data's name in the configuration.

        Returns
        -------
        int
            The components of each vertex's value.

        Raises
        ------
        precice.Error
            The participant uses no such mesh, or neither writes nor reads that data on it.

        Notes
        -----
        Any time.
        """
        self._core.mesh("get_data_dimensions", mesh_name)
        spec = self._core.write.get((mesh_name, data_name)) or self._core.read.get((mesh_name, data_name))
        if spec is None:
            raise self._core.fail("get_data_dimensions", f"no data '{data_name}' on mesh '{mesh_name}' for participant '{self._core.name}'")
        return int(spec["dimensions"])

    def set_mesh_vertex(self, mesh_name: str, position: Any) -> int:
        """Add one vertex to a mesh the participant provides.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        position : array_like
            The vertex's coordinates, ``get_mesh_dimensions(mesh_name)`` finite values.

        Returns
        -------
        int
            The vertex's id, for ``write_data`` and ``read_data``: the vertices of a mesh count from 0 in the order
            they are set (per rank).

        Raises
        ------
        precice.Error
            An unknown or received mesh, a call after ``initialize``, or a position of the wrong size or not
            finite.

        Notes
        -----
        Call only before initialize.
        """
        return int(self._core.add_vertices("set_mesh_vertex", mesh_name, position)[0])

    def set_mesh_vertices(self, mesh_name: str, positions: Any) -> np.ndarray:
        """Add vertices to a mesh the participant provides.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        positions : array_like
            The vertices' coordinates, of shape (n, dimensions); a single vertex's may be flat.

        Returns
        -------
        numpy.ndarray
            The n vertex ids, in the order of ``positions``, following those of the vertices set before.

        Raises
        ------
        precice.Error
            An unknown or received mesh, a call after ``initialize``, or positions of the wrong shape or not
            finite.

        Notes
        -----
        Call only before initialize.
        """
        return self._core.add_vertices("set_mesh_vertices", mesh_name, positions)

    def get_mesh_vertex_size(self, mesh_name: str) -> int:
        """The number of vertices of a mesh: those set, or on a received mesh those in the access region.

        Parameters
        ----------
        mesh_name : str
            The mesh's name.

        Returns
        -------
        int
            On a provided mesh, the vertices set so far. On a received mesh with direct access, its vertices inside
            the access region once initialized; 0 before ``initialize`` or without an access region.

        Raises
        ------
        precice.Error
            The participant uses no mesh of that name.

        Notes
        -----
        Any time; a received mesh's vertices are known after ``initialize``.
        """
        info = self._core.mesh("get_mesh_vertex_size", mesh_name)
        if not info["provided"]:        # a received mesh: its vertices in the access region, once initialized
            if self._core.state != "initialized" or mesh_name not in self._core.regions:
                return 0
            return len(self._core.region_vertices("get_mesh_vertex_size", mesh_name)[0])
        return self._core.vertex_count(mesh_name)

    def requires_mesh_connectivity_for(self, mesh_name: str) -> bool:
        """Whether a mapping of the configuration uses the mesh's connectivity (edges, triangles, tetrahedra).

        Parameters
        ----------
        mesh_name : str
            The mesh's name.

        Returns
        -------
        bool
            True when a projection or cell-interpolation mapping uses this mesh; then set its elements.

        Raises
        ------
        precice.Error
            The participant uses no mesh of that name.

        Notes
        -----
        Any time; ask before ``initialize``, when the elements can still be set.
        """
        return bool(self._core.mesh("requires_mesh_connectivity_for", mesh_name).get("connectivity", False))

    def _connectivity(self, call: str, mesh_name: str, vertices: Any, per_element: int) -> None:
        self._core.connect(call, mesh_name, vertices, per_element)

    def set_mesh_edge(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int) -> None:
        """Add an edge between two vertices of a provided mesh.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        first_vertex_id, second_vertex_id : int
            The ids of the edge's two vertices, as ``set_mesh_vertices`` gave them.

        Raises
        ------
        precice.Error
            An unknown or received mesh, a call after ``initialize``, an id that is not a vertex of the mesh, or
            the same vertex twice.

        Notes
        -----
        Call only before initialize, after setting the vertices. cosim checks the elements and sends them with the
        vertices at ``initialize``, for the mappings that project or interpolate in cells.
        """
        self._connectivity("set_mesh_edge", mesh_name, [first_vertex_id, second_vertex_id], 2)

    def set_mesh_edges(self, mesh_name: str, vertices: Any) -> None:
        """Add edges to a provided mesh, two vertex ids each.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        vertices : array_like
            The edges' vertex ids: of shape (n, 2), or flat, two after two.

        Raises
        ------
        precice.Error
            As ``set_mesh_edge``, or a number of ids that is not even.

        Notes
        -----
        Call only before initialize, after setting the vertices.
        """
        self._connectivity("set_mesh_edges", mesh_name, vertices, 2)

    def set_mesh_triangle(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int,
                          third_vertex_id: int) -> None:
        """Add a triangle of three vertices to a provided mesh (with its three edges).

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        first_vertex_id, second_vertex_id, third_vertex_id : int
            The ids of the triangle's corners.

        Raises
        ------
        precice.Error
            An unknown or received mesh, a call after ``initialize``, an id that is not a vertex of the mesh, or a
            vertex repeated.

        Notes
        -----
        Call only before initialize, after setting the vertices.
        """
        self._connectivity("set_mesh_triangle", mesh_name, [first_vertex_id, second_vertex_id, third_vertex_id], 3)

    def set_mesh_triangles(self, mesh_name: str, vertices: Any) -> None:
        """Add triangles to a provided mesh, three vertex ids each.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        vertices : array_like
            The triangles' corner ids: of shape (n, 3), or flat, three after three.

        Raises
        ------
        precice.Error
            As ``set_mesh_triangle``, or a number of ids that is not a multiple of 3.

        Notes
        -----
        Call only before initialize, after setting the vertices.
        """
        self._connectivity("set_mesh_triangles", mesh_name, vertices, 3)

    def set_mesh_quad(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int, third_vertex_id: int,
                      fourth_vertex_id: int) -> None:
        """Add a quadrilateral of four vertices to a provided mesh (with its edges, and split in two triangles).

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        first_vertex_id, second_vertex_id, third_vertex_id, fourth_vertex_id : int
            The ids of the quad's corners, in order around it.

        Raises
        ------
        precice.Error
            An unknown or received mesh, a call after ``initialize``, an id that is not a vertex of the mesh, or a
            vertex repeated.

        Notes
        -----
        Call only before initialize, after setting the vertices. cosim splits the quad along the diagonal from the
        first to the third corner.
        """
        self._connectivity("set_mesh_quad", mesh_name,
                           [first_vertex_id, second_vertex_id, third_vertex_id, fourth_vertex_id], 4)

    def set_mesh_quads(self, mesh_name: str, vertices: Any) -> None:
        """Add quadrilaterals to a provided mesh, four vertex ids each.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        vertices : array_like
            The quads' corner ids, in order around each: of shape (n, 4), or flat, four after four.

        Raises
        ------
        precice.Error
            As ``set_mesh_quad``, or a number of ids that is not a multiple of 4.

        Notes
        -----
        Call only before initialize, after setting the vertices.
        """
        self._connectivity("set_mesh_quads", mesh_name, vertices, 4)

    def set_mesh_tetrahedron(self, mesh_name: str, first_vertex_id: int, second_vertex_id: int,
                             third_vertex_id: int, fourth_vertex_id: int) -> None:
        """Add a tetrahedron of four vertices to a provided mesh, with its six edges.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        first_vertex_id, second_vertex_id, third_vertex_id, fourth_vertex_id : int
            The ids of the tetrahedron's corners.

        Raises
        ------
        precice.Error
            An unknown or received mesh, a call after ``initialize``, an id that is not a vertex of the mesh, or a
            vertex repeated.

        Notes
        -----
        Call only before initialize, after setting the vertices.
        """
        self._connectivity("set_mesh_tetrahedron", mesh_name,
                           [first_vertex_id, second_vertex_id, third_vertex_id, fourth_vertex_id], 4)

    def set_mesh_tetrahedra(self, mesh_name: str, vertices: Any) -> None:
        """Add tetrahedra to a provided mesh, four vertex ids each.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.
        vertices : array_like
            The tetrahedra's corner ids: of shape (n, 4), or flat, four after four.

        Raises
        ------
        precice.Error
            As ``set_mesh_tetrahedron``, or a number of ids that is not a multiple of 4.

        Notes
        -----
        Call only before initialize, after setting the vertices.
        """
        self._connectivity("set_mesh_tetrahedra", mesh_name, vertices, 4)

    def reset_mesh(self, mesh_name: str) -> None:
        """preCICE's experimental remeshing: refused by cosim, which keeps a mesh's vertices for the whole run.

        Parameters
        ----------
        mesh_name : str
            The provided mesh's name.

        Raises
        ------
        precice.Error
            Always: an unknown mesh, or the refusal itself.

        Notes
        -----
        In preCICE, called after ``initialize`` between windows to redefine a provided mesh; refused by cosim
        whenever it is called.
        """
        self._core.mesh("reset_mesh", mesh_name)
        raise self._core.fail("reset_mesh", f"remeshing is not supported by cosim: mesh '{mesh_name}' keeps the "
                                            "vertices it had at initialize for the whole run")

    def set_mesh_access_region(self, mesh_name: str, bounding_box: Any) -> None:
        """The box of a received mesh whose vertices this participant accesses directly (without a mapping).

        Parameters
        ----------
        mesh_name : str
            The received mesh's name; its ``<receive-mesh>`` has ``api-access="true"``.
        bounding_box : array_like
            2 x dimensions finite values, the minimum and maximum of each coordinate in turn:
            ``[x_min, x_max, y_min, y_max(, z_min, z_max)]``.

        Raises
        ------
        precice.Error
            A mesh that is not received with direct access, a call after ``initialize``, a box of the wrong size,
            not finite or with a minimum above its maximum, or a participant of several ranks.

        Notes
        -----
        Call only before initialize. Then, after it, ``get_mesh_vertex_ids_and_coordinates`` gives the vertices in
        the box. cosim refuses direct access from a parallel participant (``solver_process_size`` above 1).
        """
        self._core.set_access_region("set_mesh_access_region", mesh_name, bounding_box)

    def get_mesh_vertex_ids_and_coordinates(self, mesh_name: str) -> tuple[np.ndarray, np.ndarray]:
        """The ids and coordinates of a received mesh's vertices inside the access region.

        Parameters
        ----------
        mesh_name : str
            The received mesh's name, accessed directly.

        Returns
        -------
        ids : numpy.ndarray
            The vertices' ids, for ``write_data`` and ``read_data`` on that mesh.
        coordinates : numpy.ndarray
            Their coordinates, of shape (n, dimensions).

        Raises
        ------
        precice.Error
            A mesh not received with direct access, a call before ``initialize`` or after ``finalize``, or no
            access region set.

        Notes
        -----
        Call between initialize and finalize, after ``set_mesh_access_region`` before ``initialize``.
        """
        return self._core.region_vertices("get_mesh_vertex_ids_and_coordinates", mesh_name)

    # --- data -------------------------------------------------------------------------------------------------------
    def write_data(self, mesh_name: str, data_name: str, vertex_ids: Any, values: Any) -> None:
        """Write the values of a data item at vertices of a mesh, for the next exchange.

        Parameters
        ----------
        mesh_name : str
            The mesh's name: a provided mesh, or a received one accessed directly.
        data_name : str
            The name of data the participant writes on that mesh.
        vertex_ids : array_like of int
            The ids of the vertices written.
        values : array_like
            Their values: n values for scalar data (a column (n, 1) too); (n, dimensions) or a flat block of n x
            dimensions for vector data.

        Raises
        ------
        precice.Error
            Data the participant does not write on that mesh, an id not on the mesh, values of the wrong shape or
            not finite, a write before ``initialize`` that is not initial data, or a call after ``finalize``.

        Notes
        -----
        Call between initialize and finalize, before the ``advance`` that sends it; before initialize only as
        initial data (``requires_initial_data()``, the exchange's ``initialize="true"``) on a provided mesh. A
        value written stays until written again; vertices never written send zeros.
        """
        self._core.write_values("write_data", mesh_name, data_name, vertex_ids, values)

    def read_data(self, mesh_name: str, data_name: str, vertex_ids: Any, relative_read_time: float) -> np.ndarray:
        """Read a data item's values at vertices of a mesh, at a time within the current step.

        Parameters
        ----------
        mesh_name : str
            The mesh's name: a provided mesh, or a received one accessed directly.
        data_name : str
            The name of data the participant reads on that mesh.
        vertex_ids : array_like of int
            The ids of the vertices read.
        relative_read_time : float
            The time to read at, from the participant's time: 0 to ``get_max_time_step_size()``; the step's size
            reads at its end.

        Returns
        -------
        numpy.ndarray
            Shape (n,) for scalar data, (n, dimensions) for vector data.

        Raises
        ------
        precice.Error
            Data the participant does not read on that mesh, an id not on the mesh, a time outside the rest of
            the window, or a call before ``initialize`` or after ``finalize``.

        Notes
        -----
        Call between initialize and finalize. Inside the window the data's waveform is evaluated: the window's
        end value with ``waveform-degree="0"``, else the B-spline through the window's samples. After the last
        ``advance`` it gives the last window's end values, as preCICE does.
        """
        return self._core.read_values("read_data", mesh_name, data_name, vertex_ids, float(relative_read_time))

    def requires_gradient_data_for(self, mesh_name: str, data_name: str) -> bool:
        """Whether the participant writes this data's gradients too (``write_gradient_data``).

        Parameters
        ----------
        mesh_name : str
            The mesh's name.
        data_name : str
            The data's name.

        Returns
        -------
        bool
            True where a ``nearest-neighbor-gradient`` mapping maps this data from this mesh.

        Raises
        ------
        precice.Error
            The participant uses no mesh of that name.

        Notes
        -----
        Any time.
        """
        self._core.mesh("requires_gradient_data_for", mesh_name)
        return bool(self._core.write.get((mesh_name, data_name), {}).get("gradient"))

    def write_gradient_data(self, mesh_name: str, data_name: str, vertex_ids: Any, gradients: Any) -> None:
        """Write a data item's spatial gradients at vertices, for a ``nearest-neighbor-gradient`` mapping.

        Parameters
        ----------
        mesh_name : str
            The mesh's name.
        data_name : str
            The data's name.
        vertex_ids : array_like of int
            The ids of the vertices written.
        gradients : array_like
            One row a vertex, of shape (n, mesh dimensions x data components): the first component's d/dx, d/dy
            (and d/dz), then the next component's (the layout preCICE 3.4.1 reads; pyprecice's own docstring
            shows another).

        Raises
        ------
        precice.Error
            A configuration without ``experimental="true"``, data that takes no gradients, an id not on the
            mesh, gradients of the wrong shape or not finite, or a call after ``finalize``.

        Notes
        -----
        Only where ``requires_gradient_data_for`` is True; any time before finalize, with the data's values (those
        written before ``initialize`` go with the initial data).
        """
        self._core.write_gradients("write_gradient_data", mesh_name, data_name, vertex_ids, gradients)

    def write_and_map_data(self, mesh_name: str, data_name: str, coordinates: Any, values: Any) -> None:
        """Write values at coordinates of your own, mapped just in time onto a received mesh (conservative).

        Parameters
        ----------
        mesh_name : str
            The received mesh's name, accessed directly.
        data_name : str
            The name of data the participant writes on it.
        coordinates : array_like
            The points, of shape (n, dimensions).
        values : array_like
            Their values: (n,) for scalar data, (n, components) for vector data.

        Raises
        ------
        precice.Error
            A mesh without direct access or without a just-in-time write mapping, data the participant does not
            write, an access region without vertices, arrays of the wrong shape or not finite, or a call before
            ``initialize`` or after ``finalize``.

        Notes
        -----
        Call between initialize and finalize, with an access region set before ``initialize``. cosim adds each
        value to the received mesh's nearest vertex in the access region (a ``nearest-neighbor`` mapping
        ``direction="write"`` without ``from``); what a window gathers goes at its end, and the next window starts
        from zero. Other just-in-time mappings are refused when the configuration is read.
        """
        self._core.write_and_map("write_and_map_data", mesh_name, data_name, coordinates, values)

    def map_and_read_data(self, mesh_name: str, data_name: str, coordinates: Any,
                          relative_read_time: float) -> np.ndarray:
        """Read a data item at coordinates of your own, mapped just in time from a received mesh (consistent).

        Parameters
        ----------
        mesh_name : str
            The received mesh's name, accessed directly.
        data_name : str
            The name of data the participant reads on it.
        coordinates : array_like
            The points, of shape (n, dimensions).
        relative_read_time : float
            The time to read at, from the participant's time: 0 to ``get_max_time_step_size()``.

        Returns
        -------
        numpy.ndarray
            The values at the points: (n,) for scalar data, (n, components) for vector data.

        Raises
        ------
        precice.Error
            A mesh without direct access or without a just-in-time read mapping, data the participant does not
            read, an access region without vertices, coordinates of the wrong shape or not finite, a time outside
            the rest of the window, or a call before ``initialize`` or after ``finalize``.

        Notes
        -----
        Call between initialize and finalize, with an access region set before ``initialize``. cosim gives each
        point the value of the received mesh's nearest vertex in the access region (a ``nearest-neighbor`` mapping
        ``direction="read"`` without ``to``).
        """
        return self._core.map_and_read("map_and_read_data", mesh_name, data_name, coordinates,
                                       float(relative_read_time))

    # --- profiling (accepted: cosim times every call itself) ---------------------------------------------------------
    def start_profiling_section(self, event_name: str) -> None:
        """Open a user-defined profiling section: accepted and ignored by cosim.

        Parameters
        ----------
        event_name : str
            The section's name.

        Notes
        -----
        Any time. preCICE records the section among its profiling events; cosim keeps no user sections (it
        measures each participant's compute time itself).
        """
        pass

    def stop_last_profiling_section(self) -> None:
        """Close the last profiling section opened: accepted and ignored by cosim.

        Notes
        -----
        Any time, after ``start_profiling_section``; cosim does nothing.
        """
        pass
