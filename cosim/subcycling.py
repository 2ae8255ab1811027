"""A component that subcycles: the steps it takes inside a coupling window, served in one step request.

With ``components.<name>.substeps = N`` the coupler's step request carries the window [t, t + dt], the inputs at
its end and, for inputs of waveform degree >= 1, their B-spline across the window (knots and coefficients over the
normalised time [0, 1], as the coupler builds it). The server then steps the component N times by dt / N, each time
with the inputs interpolated at the step's end (the window-end values at the last), and answers with the last
outputs, the outputs at the steps inside the window (the samples a reader's waveform goes through), and every
step's inputs (each step is a call of its own in the recording). Inside a step, ``Component.input_at(name, time)``
gives an input anywhere in the window (a Runge-Kutta stage, say).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from cosim.errors import ComponentError, ProtocolError

EPSILON = 1e-9       # relative: a time this close to the window's end is its end
MAX_SUBSTEPS = 10_000   # steps a window at most: a window's waveform is interpolated through every one of them


class Spline:
    """A B-spline over the window's normalised time: knots and coefficients (first axis: the basis functions),
    evaluated by de Boor's algorithm (numpy alone: a cheap component's process need not import scipy)."""

    def __init__(self, knots: np.ndarray, coefficients: np.ndarray):
        self.knots, self.coefficients = np.asarray(knots, dtype=float), np.asarray(coefficients, dtype=float)
        self.degree = len(self.knots) - len(self.coefficients) - 1

    def __call__(self, x: float) -> np.ndarray:
        return np.array(self.at(np.array([x]))[0])

    def at(self, xs: np.ndarray) -> np.ndarray:
        """The spline at each of ``xs`` (first axis; x = 1 lies in the last span): de Boor's operations on every
        point at once."""
        t, c, k = self.knots, self.coefficients, self.degree
        xs = np.asarray(xs, dtype=float)
        spans = np.minimum(np.maximum(np.searchsorted(t, xs, side="right") - 1, k), len(c) - 1)
        d = [c[spans - k + j] for j in range(k + 1)]
        tail = (slice(None),) + (None,) * (c.ndim - 1)      # a point's alpha over its values' axes
        for r in range(1, k + 1):
            for j in range(k, r - 1, -1):
                left, right = t[spans - k + j], t[spans + 1 + j - r]
                alpha = ((xs - left) / (right - left))[tail]
                d[j] = (1.0 - alpha) * d[j - 1] + alpha * d[j]
        return d[k]


class WindowInputs:
    """A window's inputs in time: the end values, and the interpolants of those of degree >= 1."""

    def __init__(self, t: float, dt: float, inputs: Mapping[str, np.ndarray],
                 splines: Mapping[str, tuple[np.ndarray, np.ndarray]], substeps: int = 1):
        self.t, self.dt, self.inputs = t, dt, inputs
        self.splines = {name: Spline(knots, coefficients) for name, (knots, coefficients) in splines.items()}
        ends = np.arange(1, substeps) / substeps
        # each input at the ends of the steps inside the window
        self.steps = {name: spline.at(ends) for name, spline in self.splines.items()} if substeps > 1 else {}

    def at_step(self, name: str, k: int, substeps: int) -> np.ndarray:
        """Input ``name`` at the end of step ``k`` of ``substeps``."""
        if k == substeps - 1 or name not in self.steps:
            return self.inputs[name]
        return self.steps[name][k]

    def at(self, name: str, time: float) -> np.ndarray:
        """Input ``name`` at absolute ``time`` in the window."""
        if name not in self.inputs:
            raise ComponentError("", f"reads '{name}', which is not one of its inputs ({', '.join(self.inputs)})")
        relative = (time - self.t) / self.dt
        if relative < -EPSILON or relative > 1 + EPSILON:
            raise ComponentError("", f"reads '{name}' at t = {time:g}, outside its window [{self.t:g}, "
                                     f"{self.t + self.dt:g}]")
        spline = self.splines.get(name)
        if spline is None or relative >= 1 - EPSILON:
            return self.inputs[name]
        return spline(min(max(relative, 0.0), 1.0))


def split_waveforms(arrays: Mapping[str, np.ndarray], knots: Any) -> tuple[dict[str, np.ndarray], dict[str, tuple]]:
    """A step request's inputs, and its interpolants: their knots from the request's header (``knots``: name ->
    numbers), their coefficients from its arrays (``coefficients:NAME``, the last of which is the input's value at
    the window's end)."""
    inputs = {name: value for name, value in arrays.items() if ":" not in name}
    if not isinstance(knots, dict):
        raise ProtocolError("argument 'knots' must map input names to lists of numbers")
    splines = {}
    for name, values in knots.items():
        coefficients = arrays.get(f"coefficients:{name}")
        if coefficients is None or not isinstance(values, list) or not 1 <= len(values) - len(coefficients) - 1 <= 3:
            raise ProtocolError(f"the waveform of input '{name}' is not a B-spline of degree 1 to 3")
        splines[name] = (np.array(values, dtype=float), coefficients)
        inputs[name] = coefficients[-1]        # a clamped B-spline's last coefficient: the window-end value
    return inputs, splines


def subcycle(component: Any, t: float, dt: float, window: WindowInputs, substeps: int,
             record: bool = False) -> dict[str, np.ndarray]:
    """``substeps`` steps of ``component`` across [t, t + dt]: ``steps:NAME``, each output at every step (the last
    at the window's end), ``times`` (the steps' ends inside the window), and with ``record`` ``inputs:NAME`` (every
    step's inputs, one row each)."""
    step = dt / substeps
    outputs: list[dict[str, np.ndarray]] = []
    inputs: list[dict[str, np.ndarray]] = []
    component.window_inputs = window
    try:
        for k in range(substeps):
            start, end = t + k * step, (t + dt if k == substeps - 1 else t + (k + 1) * step)
            given = {name: window.at_step(name, k, substeps) for name in window.inputs}
            returned = component.served_step(start, end - start, given)
            outputs.append({name: np.array(value) for name, value in returned.items()})
            inputs.append(given)
    finally:
        component.window_inputs = None
    # every step's outputs in one array a variable, the window's end last; the times inside it in the header
    result: dict[str, Any] = {f"steps:{name}": np.stack([o[name] for o in outputs]) for name in outputs[-1]} \
        if substeps > 1 else dict(outputs[-1])
    result["times"] = [k / substeps for k in range(1, substeps)]
    if record:
        for name in inputs[-1]:
            result[f"inputs:{name}"] = np.stack([i[name] for i in inputs])
    return result
