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
from typing import Any

import numpy as np

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

    def __init__(self, name: str, stage: Any, solve_step: Any = None):
        self.name = name
        self.stage = stage
        self.solve_step = solve_step or (lambda: self.solver.SolveSolutionStep())
        self.window_start: float | None = None
        self.window_end = 0.0
        self.solves = 0
        self.unconverged = 0
        stage.Initialize()

    @property
    def solver(self) -> Any:
        return self.stage._GetSolver()

    def solve(self, t: float, dt: float) -> bool:
        """Solve the window [t, t + dt] once more (the first call of a window advances to it)."""
        tolerance = 1e-9 * max(1.0, abs(t) + dt)
        if self.window_start is None or abs(t - self.window_start) > tolerance:
            if self.window_start is not None and t < self.window_start:
                raise ComponentError(self.name, f"cannot step back from the window starting at "
                                                f"{self.window_start:g} s to one starting at {t:g} s")
            self.finish_window()
            current = self.stage.time
            if abs(current - t) > tolerance:
                raise ComponentError(self.name, f"asked for the window starting at {t:g} s, "
                                                f"but Kratos stands at {current:g} s")
            self.stage.time = self.solver.AdvanceInTime(current)
            if abs(self.stage.time - (t + dt)) > tolerance:
                raise ComponentError(self.name, f"time step {dt:g} s differs from Kratos's "
                                                f"{self.stage.time - current:g} s")
            self.stage.InitializeSolutionStep()
            self.solver.Predict()
            self.window_start, self.window_end = t, t + dt
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
        self.finish_window()
        self.stage.Finalize()


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
