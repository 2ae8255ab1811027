"""A damped wall for the elastic tube: a component with state, written from the component contract alone.

Each node's radius relaxes towards the spring wall's r_eq(p) = r0 + p r0^2 / E over a time tau,
dr/dt = (r_eq(p) - r) / tau, integrated by implicit Euler over each window:

    r(t + dt) = (r(t) + dt / tau r_eq(p)) / (1 + dt / tau).

``do_step`` moves the radius on, so the radius at a window's start is state: implicit coupling calls the wall
several times for one window, and each call must start from the same radius. The component says so with
``save_state`` and ``restore_state`` (the coupler saves the state at a window's start and restores it before
each further iteration). Compare ``examples/spring_wall``, whose section follows the pressure of the call alone
and which declares ``stateless = True`` instead.

    cosim run examples/damped_wall/scene.toml --out runs/damped_wall
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import Component, Variable, check_inputs
from cosim.schema import Positive, Value, validate

SCHEMA = {
    "tube": {"length": Positive(10.0), "cells": Value(100, low=2, high=1_000_000), "a0": Positive(1.0)},
    "E": Positive(12500.0),       # the wall's modulus
    "tau": Positive(0.05),        # its relaxation time [s]
}


class DampedWall(Component):
    """Section of the tube whose radius relaxes towards the spring law of the pressure."""

    name = "solid"
    parameter_schema = SCHEMA

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, SCHEMA)
        self.n = prm["tube"]["cells"] + 1
        self.length = prm["tube"]["length"]
        self.r0 = math.sqrt(prm["tube"]["a0"] / math.pi)
        self.E, self.tau = prm["E"], prm["tau"]
        self.pressure = np.zeros(self.n)
        self.radius = np.full(self.n, self.r0)          # the state: changed by do_step

    def variables(self) -> list[Variable]:
        return [Variable("pressure", "input", self.n, mesh="axis"), Variable("section", "output", self.n, mesh="axis")]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"axis": np.linspace(0.0, self.length, self.n)[:, None]}

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {"pressure": self.n})
        if "pressure" in values:
            self.pressure = np.array(values["pressure"], dtype=np.float64)

    def do_step(self, t: float, dt: float) -> None:
        equilibrium = self.r0 + self.pressure * self.r0 ** 2 / self.E
        self.radius = (self.radius + dt / self.tau * equilibrium) / (1.0 + dt / self.tau)

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = {"section": math.pi * self.radius ** 2, "pressure": self.pressure}
        return {name: known[name].copy() for name in names}

    # --- state: what do_step changes, saved at a window's start and restored before each further iteration ---
    def save_state(self) -> Any:
        return self.radius.copy()

    def restore_state(self, state: Any) -> None:
        self.radius = state.copy()
