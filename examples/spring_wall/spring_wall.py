"""A linear spring wall for the elastic tube, written from the component contract alone.

Each node of the wall is a spring of stiffness E / r0 on the radius: r = r0 + p r0^2 / E, so the section
a = pi r^2 follows the fluid's pressure p node by node. It is the small-strain limit of the tube solid's
wall law (hoop equilibrium p r = E (r - r0) / r0 with r ~ r0 on the left).

    cosim run examples/spring_wall/scene.toml --out runs/spring_wall

The scene names it by ``entry = "spring_wall:SpringWall"``: a module next to the scene is found.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import Component, Variable, check_inputs
from cosim.schema import Positive, Value, validate

# the parameters this component takes, checked by `cosim run` and `cosim check` before any process starts
SCHEMA = {
    "tube": {"length": Positive(10.0), "cells": Value(100, low=2, high=1_000_000), "a0": Positive(1.0),
             "stiffness_factor": Positive(1.0), "wall_law": "piecewise"},   # the scene's [tube] section
    "E": Positive(12500.0),       # the wall's modulus
}


class SpringWall(Component):
    """Section of the tube for a given pressure, one linear spring per node."""

    name = "solid"
    parameter_schema = SCHEMA
    stateless = True        # the section follows the pressure of the call: nothing carries over between windows

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, SCHEMA)
        self.n = prm["tube"]["cells"] + 1                       # the fluid's nodes: one mesh, no mapping
        self.length = prm["tube"]["length"]
        self.r0 = math.sqrt(prm["tube"]["a0"] / math.pi)
        self.E = prm["E"] * prm["tube"]["stiffness_factor"]
        self.pressure = np.zeros(self.n)
        self.section = np.full(self.n, prm["tube"]["a0"])

    def variables(self) -> list[Variable]:
        return [Variable("pressure", "input", self.n, mesh="axis"), Variable("section", "output", self.n, mesh="axis")]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"axis": np.linspace(0.0, self.length, self.n)[:, None]}

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {"pressure": self.n})        # a wrong name or shape is a named error
        if "pressure" in values:
            self.pressure = np.array(values["pressure"], dtype=np.float64)

    def do_step(self, t: float, dt: float) -> None:
        radius = self.r0 + self.pressure * self.r0 ** 2 / self.E
        self.section = math.pi * radius ** 2

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = {"section": self.section, "pressure": self.pressure}
        return {name: known[name].copy() for name in names}
