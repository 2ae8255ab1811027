"""Two components that cost next to nothing, for measuring the coupler and the wire alone: a linear pressure law
(the "fluid": p = p_ref + k (a_ref - a), node by node) and a linear spring (the "solid": a = a0 + p / s). Their
fixed point is a = (a0 + (p_ref + k a_ref) / s) / (1 + k / s); coupled implicitly they converge in a few
iterations a window."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import Component, Variable, check_inputs
from cosim.schema import Positive, Value, validate

SCHEMA = {"nodes": Value(101, low=1, high=1_000_000), "stiffness": Positive(4.0), "reference": Positive(1.0),
          "amplitude": Value(0.1)}


class _Trivial(Component):
    input_name = output_name = ""
    parameter_schema = SCHEMA
    stateless = True

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, SCHEMA)
        self.n, self.k, self.reference, self.amplitude = prm["nodes"], prm["stiffness"], prm["reference"], prm["amplitude"]
        self.x = np.full(self.n, self.reference)
        self.y = np.full(self.n, self.reference)
        self.nodes = np.linspace(0.0, 1.0, self.n)[:, None]

    def variables(self) -> list[Variable]:
        return [Variable(self.input_name, "input", self.n, mesh="line"),
                Variable(self.output_name, "output", self.n, mesh="line")]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"line": self.nodes}

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {self.input_name: self.n})
        if self.input_name in values:
            self.x = values[self.input_name]

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = {self.input_name: self.x, self.output_name: self.y}
        return {name: np.array(known[name]) for name in names}


class LinearPressure(_Trivial):
    """p = p_ref(t) + k (a_ref - a): a pressure that falls as the section opens, driven by a sine in time."""

    name, input_name, output_name = "fluid", "section", "pressure"

    def do_step(self, t: float, dt: float) -> None:
        self.y = self.reference * (1.0 + self.amplitude * np.sin(t + dt)) + self.k * (self.reference - self.x)


class LinearSpring(_Trivial):
    """a = a_ref + p / s: a section that opens with the pressure."""

    name, input_name, output_name = "solid", "pressure", "section"

    def do_step(self, t: float, dt: float) -> None:
        self.y = self.reference + (self.x - self.reference) / self.k


SCENE = """
name = "two trivial components"
[time]
end = {end}
dt = 0.01
[components.fluid]
entry = "benchmarks.trivial_components:LinearPressure"
[components.solid]
entry = "benchmarks.trivial_components:LinearSpring"
[[exchange]]
data = "pressure"
from = "fluid"
to = "solid"
[[exchange]]
data = "section"
from = "solid"
to = "fluid"
[coupling]
participants = ["fluid", "solid"]
[[coupling.convergence]]
data = "section"
type = "relative"
limit = 1e-10
[coupling.acceleration]
type = "iqn-ils"
data = ["section"]
"""
