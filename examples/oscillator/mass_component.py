"""One mass of the two-mass oscillator as a cosim component that subcycles (``components.<name>.substeps``).

The coupler steps it ``substeps`` times a window; ``input_at`` gives the neighbour's displacement anywhere in the
window (its waveform), where the integrator asks for it. The mass's velocity is a local variable: recorded with
``record = true``, it gives the energy.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from integrators import INTEGRATORS, START, acceleration

from cosim.component import Component, Variable, check_inputs
from cosim.schema import Choice, validate

SCHEMA = {"side": Choice("Left", ("Left", "Right")), "integrator": Choice("newmark", tuple(INTEGRATORS))}


class Mass(Component):
    name = "mass"
    parameter_schema = SCHEMA

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, SCHEMA)
        other = "Right" if prm["side"] == "Left" else "Left"
        self.write, self.read = f"Displacement-{prm['side']}", f"Displacement-{other}"
        self.integrate = INTEGRATORS[prm["integrator"]]
        self.u, self.v = START[prm["side"]], 0.0
        self.a = acceleration(self.u, START[other])      # at rest at t = 0: both displacements known
        self.neighbour = np.array([START[other]])

    def variables(self) -> list[Variable]:
        return [Variable(self.write, "output", 1, mesh="point"), Variable(self.read, "input", 1, mesh="point"),
                Variable("velocity", "local", 1)]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"point": np.zeros((1, 2))}

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {self.read: 1})
        if self.read in values:
            self.neighbour = np.array(values[self.read], dtype=float)

    def do_step(self, t: float, dt: float) -> None:
        def neighbour(s: float) -> float:
            if getattr(self, "window_inputs", None) is None:        # not subcycled: the step's end value
                return float(self.neighbour[0])
            return float(self.input_at(self.read, t + s)[0])
        self.u, self.v, self.a = self.integrate(self.u, self.v, self.a, dt, neighbour)

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = {self.write: np.array([self.u]), "velocity": np.array([self.v]), self.read: self.neighbour}
        return {name: known[name].copy() for name in names}

    def save_state(self) -> Any:
        return (self.u, self.v, self.a)

    def restore_state(self, state: Any) -> None:
        self.u, self.v, self.a = state
