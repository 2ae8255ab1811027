"""Drive a Kratos Multiphysics analysis stage one coupling iteration at a time.

Kratos repeats a coupling iteration by solving the same time step again from its last
iterate; it moves on only when told to. ``SteppedStage.solve(t, dt)`` does exactly that:
the first call of a window finalises the previous window, advances Kratos's time and
initialises the step; every call solves the step once more. Kratos is imported only by
the component processes that use this module.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import Component, check_inputs
from cosim.errors import ComponentError


def kratos_parameters(settings: dict[str, Any]):
    """A ``KratosMultiphysics.Parameters`` object from a plain dict."""
    import KratosMultiphysics as KM
    return KM.Parameters(json.dumps(settings))


def set_threads(count: int | None = None) -> None:
    """Kratos's OpenMP thread count: ``count``, else OMP_NUM_THREADS (set by the launcher), else 1."""
    import KratosMultiphysics as KM
    KM.ParallelUtilities.SetNumThreads(int(count or os.environ.get("OMP_NUM_THREADS", "1")))


def quiet() -> None:
    """Kratos prints warnings only."""
    import KratosMultiphysics as KM
    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)


class SteppedStage:
    """An initialised ``AnalysisStage`` advanced window by window, solved iteration by iteration."""

    def __init__(self, name: str, stage: Any, solve_step: Any = None, static: bool = False,
                 predict_first: bool = False):
        """``static``: the stage has no time history (a static solver), so it may be asked for a later window than
        the next one (a solid FOM kept beside its ROM takes a window now and then): it jumps to it, starting
        from its last solution. ``predict_first``: the solver predicts before the stage initialises the step, and
        again after, in the order Kratos's CoSimulation runs a wrapper (its coupled solver predicts in its own
        ``InitializeSolutionStep``, and its analysis loop once more)."""
        self.name = name
        self.stage = stage
        self.static = static
        self.predict_first = predict_first
        self.solve_step = solve_step or stage._GetSolver().SolveSolutionStep
        self.window_start: float | None = None
        self.window_end = 0.0
        self.solves = 0
        self.unconverged = 0
        stage.Initialize()

    @property
    def solver(self) -> Any:
        return self.stage._GetSolver()

    def solve(self, t: float, dt: float, apply_input: Callable[[], None] | None = None) -> bool:
        """Solve the window [t, t + dt] once more (the first call of a window advances to it).

        ``apply_input`` writes the coupling input into the current step's values. It runs after the step is
        advanced and predicted, right before each solve: written earlier, on a window's first call it would
        land in the previous step's values, which Kratos clones into the new step, so the ALE fluid would see
        no mesh motion between windows (the mesh velocity comes from the two steps' displacements)."""
        tolerance = 1e-9 * max(1.0, abs(t) + dt)
        if self.window_start is None or abs(t - self.window_start) > tolerance:
            if self.window_start is not None and t < self.window_start:
                raise ComponentError(self.name, f"cannot step back from the window starting at "
                                                f"{self.window_start:g} s to one starting at {t:g} s")
            self.finish_window()
            current = self.stage.time
            if self.static and t > current:
                current = t
            if abs(current - t) > tolerance:
                raise ComponentError(self.name, f"asked for the window starting at {t:g} s, "
                                                f"but Kratos stands at {current:g} s")
            self.stage.time = self.solver.AdvanceInTime(current)
            if abs(self.stage.time - (t + dt)) > tolerance:
                raise ComponentError(self.name, f"time step {dt:g} s differs from Kratos's "
                                                f"{self.stage.time - current:g} s")
            if self.predict_first:
                self.solver.Predict()
            self.stage.InitializeSolutionStep()
            self.solver.Predict()
            self.window_start, self.window_end = t, t + dt
        if apply_input is not None:
            apply_input()
        converged = bool(self.solve_step())
        self.solves += 1
        self.unconverged += not converged
        return converged

    def finish_window(self) -> None:
        """Finalise the open window, if any."""
        if self.window_start is not None:
            self.stage.FinalizeSolutionStep()
            self.stage.OutputSolutionStep()
            self.window_start = None

    def finalize(self) -> None:
        """Finalise Kratos and let go of the stage (before its model goes: Kratos crashes otherwise)."""
        self.finish_window()
        self.stage.Finalize()
        self.stage = self.solve_step = None


class KratosComponent(Component):
    """A component around one Kratos analysis stage with one vector input on its interface nodes.

    Subclasses build ``self.stepped`` (a ``SteppedStage``), ``self.interface`` (Kratos nodes),
    ``self.model``, ``self.settings`` and ``self.input`` (an (n, 2) array) in ``instantiate``,
    and name the Kratos variable the input goes to (``input_variable``) and how each output is
    read (``readers``).
    """

    repeats_steps = True
    input_name = ""
    solve_label = "solve"
    stepped: Any = None         # a SteppedStage once instantiated, None once closed
    model: Any = None           # the Kratos Model
    interface: Any = None       # the Kratos nodes the input goes to
    input: np.ndarray
    settings: dict[str, Any]

    def prepare(self, settings: dict[str, Any], materials: dict[str, Any]) -> tuple[Path, Path]:
        """Checks shared by the Kratos components, Kratos's logging and threads, and a private folder
        holding the materials file; returns the mesh (without .mdpa) and the materials file."""
        mesh = self.mesh_file(settings).with_suffix("")
        if not mesh.with_suffix(".mdpa").is_file():
            raise ComponentError(self.name, f"mesh '{mesh.with_suffix('.mdpa')}' does not exist")
        self.settings = settings
        quiet()
        set_threads()   # OMP_NUM_THREADS, which the launcher sets from the scene (default 1)
        self._workdir = tempfile.TemporaryDirectory(prefix=f"cosim-kratos-{self.name}-")
        path = Path(self._workdir.name) / "materials.json"
        path.write_text(json.dumps(materials))
        return mesh, path

    def mesh_file(self, settings: dict[str, Any]) -> Path:
        """The ``.mdpa`` file of the validated ``settings`` (a case that generates its mesh makes it here)."""
        return Path(settings["mesh"])

    def input_variable(self) -> Any:
        raise NotImplementedError

    def build(self, import_settings: dict[str, Any] | None = None) -> None:
        """(Re)build the model, the stepped stage and the node references; ``import_settings``: the solver's
        ``model_import_settings`` (default: the mesh file)."""
        raise NotImplementedError

    # --- checkpoints: Kratos's own restart serialisation of the model part ------------------------------------
    part_name = ""              # the model part Kratos saves and loads
    RESTART_LABEL = "checkpoint"

    def checkpoint(self) -> Any:
        """The model part serialised by Kratos (``FileSerializer``, its restart format: nodes with every buffered
        solution step, elements with their own data, the process info), the stage's time, the input and counters.
        The open window is finalised first, as the next window's first solve would."""
        import KratosMultiphysics as KM
        self.stepped.finish_window()
        stem = Path(self._workdir.name) / f"restart_{self.RESTART_LABEL}"
        serializer = KM.FileSerializer(str(stem), KM.SerializerTraceType.SERIALIZER_NO_TRACE)
        serializer.Set(KM.Serializer.SHALLOW_GLOBAL_POINTERS_SERIALIZATION)   # as Kratos's RestartUtility
        serializer.Save(self.part_name, self.model[self.part_name])
        del serializer                                  # the file is complete once the serializer is gone
        data = stem.with_suffix(".rest").read_bytes()
        stem.with_suffix(".rest").unlink()
        return {"rest": np.frombuffer(data, dtype=np.uint8).copy(), "time": self.stepped.stage.time,
                "input": self.input.copy(), "solves": self.stepped.solves, "unconverged": self.stepped.unconverged}

    def restore_checkpoint(self, state: Any) -> None:
        """A new stage loaded from the serialised model part (Kratos's ``rest`` import), at the saved time."""
        folder = Path(self._workdir.name)
        (folder / f"restart_{self.RESTART_LABEL}.rest").write_bytes(state["rest"].tobytes())
        self.stepped.finalize()
        self.stepped = self.model = None
        self.build({"input_type": "rest", "input_filename": str(folder / "restart"),
                    "restart_load_file_label": self.RESTART_LABEL, "load_restart_files_from_folder": False})
        self.stepped.stage.time = state["time"]
        self.stepped.solves, self.stepped.unconverged = state["solves"], state["unconverged"]
        self.input = state["input"]

    def readers(self) -> dict[str, Callable[[], np.ndarray]]:
        raise NotImplementedError

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {self.input_name: self.input.shape})
        if self.input_name in values:
            self.input = np.array(values[self.input_name], dtype=np.float64)

    def do_step(self, t: float, dt: float) -> None:
        if not self.stepped.solve(t, dt, lambda: set_nodal_vector(self.interface, self.input_variable(), self.input)):
            message = (f"Kratos's {self.solve_label} did not converge in {self.settings['max_iterations']} "
                       f"iterations (window starting at t = {t:g} s)")
            if self.settings["on_unconverged"] == "fail":
                raise ComponentError(self.name, message)
            self.warn(message)

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        readers = {**self.readers(), self.input_name: lambda: self.input.copy()}
        unknown = [n for n in names if n not in readers]
        if unknown:
            raise ComponentError(self.name, f"unknown variable(s) {', '.join(unknown)}")
        return {name: readers[name]() for name in names}

    def close(self) -> None:
        """Finalise Kratos; the stage goes before the model (Kratos crashes at exit otherwise)."""
        if getattr(self, "stepped", None) is not None:
            self.stepped.finalize()
            self.stepped = None
            self.model = None
            self._workdir.cleanup()


def nodal_vector(nodes: Any, variable: Any, dim: int) -> np.ndarray:
    """A vector variable on ``nodes`` as an (n, dim) array, in the container's order."""
    import KratosMultiphysics as KM
    values = np.asarray(KM.VariableUtils().GetSolutionStepValuesVector(nodes, variable, 0, dim))
    return values.reshape(-1, dim)


def set_nodal_vector(nodes: Any, variable: Any, values: np.ndarray) -> None:
    """Write an (n, dim) array into a 3-component Kratos variable (z stays 0 in 2-D)."""
    import KratosMultiphysics as KM
    full = np.zeros((values.shape[0], 3))
    full[:, :values.shape[1]] = values
    KM.VariableUtils().SetSolutionStepValuesVector(nodes, variable, KM.Vector(full.ravel()), 0)


def node_coordinates(nodes: Any, dim: int) -> np.ndarray:
    """Initial node coordinates, (n, dim)."""
    import KratosMultiphysics as KM
    return np.asarray(KM.VariableUtils().GetInitialPositionsVector(nodes, dim)).reshape(-1, dim)
