"""Quasi-static elastic tube wall: hoop equilibrium p r = sigma(eps) at every node.

eps = (r - r0) / r0 and a piecewise-linear law sigma = k eps + s, with
(k, s) = (E_small, 0) for |eps| < eps0, (E_large, +s0) for eps >= eps0 and
(E_large, -s0) for eps <= -eps0; ``tube.wall_law = "linear"`` keeps (E_small, 0) at every
strain (the law the stability theory covers), and ``tube.stiffness_factor`` scales the law. On each branch the equilibrium is linear in r,
so the root is exact: r = r0 (k - s) / (k - p r0). All nodes are solved at once
by computing the three candidate roots and keeping the one inside its branch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import Component, Variable, check_inputs
from cosim.errors import ComponentError
from cosim.schema import Choice, Positive, Value, validate

# the [tube] section, read by fluid and solid alike (each component package stands alone)
# the fluid holds about 670 bytes a cell (10 million cells took it past 6.7 GB), and results.h5 grows by 16 bytes
# a cell every window: a million cells is 0.7 GB in memory and 19 GB of results for 1200 windows
MAX_CELLS = 1_000_000
TUBE_SCHEMA = {"length": Positive(10.0), "cells": Value(100, low=2, high=MAX_CELLS), "a0": Positive(1.0),
               "stiffness_factor": Positive(1.0),   # scales the wall law (the solid's)
               # or "linear": sigma = E_small eps at every strain
               "wall_law": Choice("piecewise", ("piecewise", "linear"))}

SOLID_SCHEMA = {
    "tube": TUBE_SCHEMA,
    "E_small": Positive(12500.0),
    "E_large": Positive(2500.0),
    "s0": 20.0,
    "eps0": Positive(2e-3),
}


class TubeSolid(Component):
    """Section of the tube for a given pressure."""

    name = "solid"
    parameter_schema = SOLID_SCHEMA
    stateless = True        # quasi-static: the section follows the pressure of the call

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, SOLID_SCHEMA)
        tube = prm["tube"]
        self.n = tube["cells"] + 1
        self.length = tube["length"]
        self.r0 = math.sqrt(tube["a0"] / math.pi)
        factor = tube["stiffness_factor"]
        self.E_small, self.E_large = factor * prm["E_small"], factor * prm["E_large"]
        self.s0, self.eps0 = factor * prm["s0"], prm["eps0"]
        if tube["wall_law"] == "linear":    # one branch: E_small at every strain
            self.E_large, self.s0, self.eps0 = self.E_small, 0.0, math.inf
        if abs(self.E_small * self.eps0 - (self.E_large * self.eps0 + self.s0)) > 1e-9 * self.E_small * self.eps0:
            raise ComponentError(self.name, "the stress-strain law is discontinuous at eps0: "
                                            "E_small * eps0 must equal E_large * eps0 + s0")
        self.pressure = np.zeros(self.n)
        self.section = np.full(self.n, tube["a0"])

    def variables(self) -> list[Variable]:
        return [Variable("pressure", "input", self.n, mesh="axis"), Variable("section", "output", self.n, mesh="axis")]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"axis": np.linspace(0.0, self.length, self.n)[:, None]}

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {"pressure": self.n})
        if "pressure" in values:
            self.pressure = values["pressure"]

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = {"section": self.section, "pressure": self.pressure}
        return {name: np.array(known[name]) for name in names}

    def do_step(self, t: float, dt: float) -> None:
        self.section = math.pi * self.radius(self.pressure) ** 2

    def checkpoint(self) -> Any:
        """Quasi-static: the last input and output are all it holds."""
        return {"pressure": np.array(self.pressure), "section": np.array(self.section)}

    def restore_checkpoint(self, state: Any) -> None:
        self.pressure, self.section = state["pressure"], state["section"]

    def stress(self, eps: np.ndarray) -> np.ndarray:
        """The stress-strain law."""
        return np.where(np.abs(eps) < self.eps0, self.E_small * eps,
                        self.E_large * eps + np.sign(eps) * self.s0)

    def radius(self, p: np.ndarray) -> np.ndarray:
        """Exact radius solving p r = sigma((r - r0) / r0) at every node."""
        r0 = self.r0
        pr0 = p * r0
        if np.any(pr0 >= self.E_large):
            node = int(np.argmax(pr0 >= self.E_large))
            raise ComponentError(self.name, f"pressure {p[node]:.6g} at node {node} exceeds the wall's "
                                            f"limit {self.E_large / r0:.6g}: no equilibrium radius")
        r_small = r0 * self.E_small / (self.E_small - pr0)
        r_up = r0 * (self.E_large - self.s0) / (self.E_large - pr0)
        r_down = r0 * (self.E_large + self.s0) / (self.E_large - pr0)
        eps_small = r_small / r0 - 1.0
        return np.where(np.abs(eps_small) < self.eps0, r_small, np.where(eps_small > 0, r_up, r_down))
