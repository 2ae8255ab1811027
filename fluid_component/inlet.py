"""Inlet velocity signals of the tube: the Duffing oscillator, or a (time, velocity) table."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import SceneError

DUFFING_DEFAULTS = {"a": -1.0, "b": 0.0, "c": -0.002, "d": -1.0, "e": -0.02, "P": 360.0,
                    "g": 1.0 / 60.0, "u0": 10.0, "du0": 0.0}


class DuffingInlet:
    """v_in(t) = g u(t) + h with u'' = a u + b u^2 + c u^3 + d + P cos(f t) + e u'."""

    def __init__(self, f: float, h: float, start: float, stop: float, **constants: float):
        k = {**DUFFING_DEFAULTS, **constants}
        self.g, self.h = k["g"], h

        def rhs(t: float, y: np.ndarray) -> list[float]:
            u, du = y
            return [du, k["a"] * u + k["b"] * u**2 + k["c"] * u**3 + k["d"] + k["P"] * np.cos(f * t) + k["e"] * du]

        # the oscillator starts at t = 0 whatever the run's start time
        from scipy.integrate import solve_ivp  # here: a scene's check imports this module, not SciPy
        solution = solve_ivp(rhs, (0.0, max(stop, start) + 1.0), [k["u0"], k["du0"]], method="DOP853",
                             rtol=1e-10, atol=1e-10, dense_output=True)
        if not solution.success:
            raise SceneError(f"inlet: the Duffing oscillator failed to integrate: {solution.message}")
        self._u = solution.sol

    def __call__(self, t: float) -> float:
        return float(self.g * self._u(t)[0] + self.h)


class TableInlet:
    """Linear interpolation in a CSV of (time, velocity) rows.

    Lines starting with '#' are comments; a comment 'initial velocity at t=T: V' adds
    the row (T, V). A header line of names is skipped. The table must cover the run.
    """

    _INITIAL = re.compile(r"at\s+t\s*=\s*([-+0-9.eE]+)\s*:\s*([-+0-9.eE]+)")

    def __init__(self, path: str | Path, start: float, stop: float):
        path = Path(path)
        try:
            lines = path.read_text().splitlines()
        except OSError as exc:
            raise SceneError(f"inlet.table: cannot read '{path}': {exc.strerror}") from None
        except UnicodeDecodeError as exc:
            raise SceneError(f"inlet.table: '{path}' is not a text (CSV) file: byte 0x{exc.object[exc.start]:02x} "
                             f"at offset {exc.start}") from None
        rows: list[tuple[float, float]] = []
        header_allowed = True
        for number, line in enumerate(lines, 1):
            text = line.strip()
            if not text:
                continue
            if text.startswith("#"):
                match = self._INITIAL.search(text)
                if match:
                    rows.append((float(match.group(1)), float(match.group(2))))
                continue
            fields = [f.strip() for f in text.replace(";", ",").split(",")]
            try:
                t, v = float(fields[0]), float(fields[1])
            except (ValueError, IndexError):
                if not header_allowed:
                    raise SceneError(f"inlet.table: '{path}' line {number} is not 'time, velocity': {text!r}") from None
                header_allowed = False  # one header line of names at most
                continue
            header_allowed = False
            rows.append((t, v))
        if len(rows) < 2:
            raise SceneError(f"inlet.table: '{path}' has fewer than two (time, velocity) rows")
        table = np.array(sorted(rows))
        self.time, self.velocity = table[:, 0], table[:, 1]
        if np.any(np.diff(self.time) <= 0):
            raise SceneError(f"inlet.table: '{path}' has repeated times")
        eps = 1e-9 * max(1.0, abs(stop))
        if self.time[0] > start + eps or self.time[-1] < stop - eps:
            raise SceneError(f"inlet.table: '{path}' covers t in [{self.time[0]:g}, {self.time[-1]:g}], "
                             f"but the run needs [{start:g}, {stop:g}]")

    def __call__(self, t: float) -> float:
        return float(np.interp(t, self.time, self.velocity))


def make_inlet(parameters: Mapping[str, Any], start: float, stop: float):
    """The inlet signal the parameters ask for: a table if ``table`` is set, else Duffing."""
    if parameters.get("table"):
        return TableInlet(parameters["table"], start, stop)
    constants = {k: parameters[k] for k in DUFFING_DEFAULTS if k in parameters}
    return DuffingInlet(parameters["f"], parameters["h"], start, stop, **constants)
