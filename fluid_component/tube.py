"""1-D incompressible flow in an elastic tube (Degroote et al. 2008), node-based finite volumes.

Unknowns v, p at n = cells + 1 nodes; input: cross-section ``section`` at the nodes;
output: ``pressure``. Implicit Euler, central face averages for the convective and
pressure fluxes, pressure stabilisation alpha (p[i-1] - 2 p[i] + p[i+1]) in the
continuity equation with alpha = a0 / (v_ref + dx/dt). Per call, Newton's method on
the 2n equations with an analytic Jacobian stored as a band (4 sub-, 4
super-diagonals with v and p interleaved) and solved by ``scipy.linalg.solve_banded``.

Boundary conditions: v(0) = v_in(t); p0 - 2 p1 + p2 = 0; outlet velocity linearly
extrapolated; outlet pressure 0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import Component, Variable, check_inputs
from cosim.errors import ComponentError
from cosim.schema import Choice, FilePath, Positive, Value, validate
from fluid_component.inlet import DUFFING_DEFAULTS, make_inlet

# the fluid holds about 670 bytes a cell (10 million cells took it past 6.7 GB), and results.h5 grows by 16 bytes
# a cell every window: a million cells is 0.7 GB in memory and 19 GB of results for 1200 windows
MAX_CELLS = 1_000_000
TUBE_SCHEMA = {"length": Positive(10.0), "cells": Value(100, low=2, high=MAX_CELLS), "a0": Positive(1.0),
               "stiffness_factor": Positive(1.0),   # scales the wall law (the solid's)
               # or "linear": sigma = E_small eps at every strain
               "wall_law": Choice("piecewise", ("piecewise", "linear"))}
FLUID_SCHEMA = {
    "tube": TUBE_SCHEMA,
    "inlet": {"f": 2.0, "h": 6.0, "table": FilePath(), **DUFFING_DEFAULTS},
    "rho": Positive(1.0),
    "v_ref": Value(6.0, low=0.0),
    "newton_tolerance": Value(1e-10, low=0.0, high=1.0, low_open=True, high_open=True),
    "newton_max_iterations": Positive(30),
}
BAND = 4  # sub- and super-diagonals of the interleaved Jacobian
STALL_FACTOR = 1e3  # a residual within this factor of the tolerance that stops falling is at round-off


class TubeFluid(Component):
    """The tube's flow solver."""

    name = "fluid"
    parameter_schema = FLUID_SCHEMA

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, FLUID_SCHEMA, prefix="")
        tube = prm["tube"]
        self.n = tube["cells"] + 1
        self.length = tube["length"]
        self.dx = self.length / tube["cells"]
        self.a0 = tube["a0"]
        self.rho = prm["rho"]
        self.v_ref = prm["v_ref"]
        self.tolerance = prm["newton_tolerance"]
        self.max_iterations = prm["newton_max_iterations"]
        self.inlet_parameters = prm["inlet"]
        self.newton_iterations = 0
        self._build_pattern()

    def variables(self) -> list[Variable]:
        return [Variable("section", "input", self.n, mesh="axis"), Variable("pressure", "output", self.n, mesh="axis",
                                                                            precision=self.tolerance)]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"axis": np.linspace(0.0, self.length, self.n)[:, None]}

    def enter_initialization_mode(self, start: float, stop: float) -> None:
        self.inlet = make_inlet(self.inlet_parameters, start, stop)
        self.t = start
        self.a = np.full(self.n, self.a0)
        self.v = np.full(self.n, self.inlet(start))
        self.p = np.zeros(self.n)
        self.section = self.a.copy()
        self._guess = (self.v.copy(), self.p.copy())

    # --- contract -----------------------------------------------------------
    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {"section": self.n})
        if "section" in values:
            section = np.array(values["section"], dtype=np.float64)
            if section.min() <= 0.0:
                node = int(np.argmin(section))
                raise ComponentError(self.name, f"input 'section' is {section[node]:.4g} at node {node}: "
                                                "a cross-section must be positive")
            self.section = section

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = {"pressure": self.p, "section": self.a}
        return {name: known[name].copy() for name in names}

    def do_step(self, t: float, dt: float) -> None:
        v, p = self.solve(self.section, self.a, self.v, self.inlet(t + dt), dt)
        self.v, self.p, self.a, self.t = v, p, self.section.copy(), t + dt

    def save_state(self) -> Any:
        return (self.t, self.v.copy(), self.p.copy(), self.a.copy())

    def restore_state(self, state: Any) -> None:
        t, v, p, a = state
        self.t, self.v, self.p, self.a = t, v.copy(), p.copy(), a.copy()

    def checkpoint(self) -> Any:
        """The rolled-back state, the last input and Newton's warm start (the last solve, kept across windows)."""
        return {"state": self.save_state(), "section": self.section.copy(), "guess": list(self._guess),
                "newton_iterations": self.newton_iterations}

    def restore_checkpoint(self, state: Any) -> None:
        self.restore_state(state["state"])
        self.section = state["section"]
        self._guess = tuple(state["guess"])
        self.newton_iterations = state["newton_iterations"]

    # --- numerics -------------------------------------------------------------
    def _build_pattern(self) -> None:
        """Row and column indices of the Jacobian's nonzeros (v_k at 2k, p_k at 2k+1)."""
        n = self.n
        i = np.arange(1, n - 1)
        V, P = 2 * i, 2 * i + 1
        rows = [np.repeat(V, 5), np.repeat(P, 6)]
        cols = [np.stack([V - 2, V, V + 2, P - 2, P + 2], 1).ravel(),
                np.stack([V - 2, V, V + 2, P - 2, P, P + 2], 1).ravel()]
        last = 2 * (n - 1)
        rows.append(np.array([0, 1, 1, 1, last, last, last, last + 1]))
        cols.append(np.array([0, 1, 3, 5, last, last - 2, last - 4, last + 1]))
        self._rows, self._cols = np.concatenate(rows), np.concatenate(cols)
        self._boundary_values = np.array([1.0, 1.0, -2.0, 1.0, 1.0, -2.0, 1.0, 1.0])
        self._band = np.zeros((2 * BAND + 1, 2 * n))
        self._band_index = (BAND + self._rows - self._cols, self._cols)

    def residual(self, v: np.ndarray, p: np.ndarray, a: np.ndarray, a_old: np.ndarray,
                 v_old: np.ndarray, v_in: float, dt: float) -> np.ndarray:
        """The 2n equations, interleaved (momentum at 2i, continuity at 2i+1)."""
        c = self.dx / dt
        alpha = self.a0 / (self.v_ref + c)
        af = 0.5 * (a[:-1] + a[1:])
        vf = 0.5 * (v[:-1] + v[1:])
        mass = af * vf
        momentum_flux = mass * vf
        r = np.empty(2 * self.n)
        r[2:-2:2] = (c * (a[1:-1] * v[1:-1] - a_old[1:-1] * v_old[1:-1]) + np.diff(momentum_flux)
                     + a[1:-1] * (p[2:] - p[:-2]) / (2.0 * self.rho))
        r[3:-2:2] = c * (a[1:-1] - a_old[1:-1]) + np.diff(mass) - alpha * (p[:-2] - 2.0 * p[1:-1] + p[2:])
        r[0] = v[0] - v_in
        r[1] = p[0] - 2.0 * p[1] + p[2]
        r[-2] = v[-1] - 2.0 * v[-2] + v[-3]
        r[-1] = p[-1]
        return r

    def _jacobian_band(self, v: np.ndarray, a: np.ndarray, dt: float) -> np.ndarray:
        c = self.dx / dt
        alpha = self.a0 / (self.v_ref + c)
        af = 0.5 * (a[:-1] + a[1:])
        w = af * 0.5 * (v[:-1] + v[1:])  # d(momentum flux)/dv on both sides of a face
        ai = a[1:-1]
        zeros = np.zeros_like(ai)
        half_rho = 0.5 / self.rho
        momentum = np.stack([-w[:-1], c * ai + w[1:] - w[:-1], w[1:], -ai * half_rho, ai * half_rho], 1)
        continuity = np.stack([-0.5 * af[:-1], 0.5 * (af[1:] - af[:-1]), 0.5 * af[1:],
                               zeros - alpha, zeros + 2.0 * alpha, zeros - alpha], 1)
        values = np.concatenate([momentum.ravel(), continuity.ravel(), self._boundary_values])
        self._band[self._band_index] = values
        return self._band

    def solve(self, a: np.ndarray, a_old: np.ndarray, v_old: np.ndarray, v_in: float,
              dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Velocity and pressure at the new time level for the cross-section ``a``.

        Newton's method stops at the relative tolerance, or where round-off stops it: once
        the residual is within ``STALL_FACTOR`` of the tolerance and no longer falls by half per
        iteration, the iterate is as good as floating point allows and is accepted.
        """
        v, p = (g.copy() for g in self._guess)
        r = self.residual(v, p, a, a_old, v_old, v_in, dt)
        reference = max(float(np.linalg.norm(r)), 1e-3 * self.dx / dt * float(np.linalg.norm(a)))
        history: list[float] = []
        for iteration in range(self.max_iterations + 1):
            norm = float(np.linalg.norm(r)) / reference
            history.append(norm)
            stalled = len(history) > 2 and norm > 0.5 * history[-2] and norm <= STALL_FACTOR * self.tolerance
            if norm <= self.tolerance or stalled:
                self.newton_iterations = iteration
                self._guess = (v, p)
                return v.copy(), p.copy()
            if not math.isfinite(norm) or iteration == self.max_iterations:
                break
            from scipy.linalg import solve_banded  # here: a scene's check imports this module, not SciPy
            delta = solve_banded((BAND, BAND), self._jacobian_band(v, a, dt), r,
                                 check_finite=False)
            v = v - delta[0::2]
            p = p - delta[1::2]
            r = self.residual(v, p, a, a_old, v_old, v_in, dt)
        shown = ", ".join(f"{h:.2e}" for h in history[:3]) + ", ..., " + ", ".join(f"{h:.2e}" for h in history[-2:])
        raise ComponentError(self.name, f"Newton did not converge in {self.max_iterations} iterations: relative "
                                        f"residuals {shown} (tolerance {self.tolerance:g}), min section {a.min():.4g}")
