"""Convergence measures of implicit coupling, as preCICE and Kratos express them.

Each measure compares the new value of one exchanged data item with its previous
value (for data fed back to the first participant: the value the participant used);
r = new - old, n = the number of values. Measures are plug-ins chosen by name:

- ``relative``: ||r|| / ||new|| < limit
- ``absolute``: ||r|| < limit
- ``absolute-rms``: ||r|| / sqrt(n) < limit
- ``residual-relative``: ||r|| / ||r of the window's first iteration|| < limit
- ``any-of`` / ``all-of``: combinators of ``measures`` (tables as above; ``data`` is
  inherited), met when any / all of them are met. Kratos's
  ``relative_norm_previous_residual`` is ``any-of`` an ``absolute-rms`` and a ``relative``.

The scene's list of measures must all be met (``all-of``, as in preCICE), unless one with ``suffices = true`` is
met: that one alone ends the window (preCICE's suffices). ``window_converged`` says which.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cosim.errors import SceneError
from cosim.registry import Registry
from cosim.schema import Required, Value
from coupler.linalg import norm

MEASURES: Registry[ConvergenceMeasure] = Registry("convergence measure")
COMMON = {"data": Required(str), "suffices": Value(False)}
LIMIT = Value(low=0.0, low_open=True)


class ConvergenceMeasure:
    """One measure on one data item; ``value`` is its last value."""

    SETTINGS: dict[str, Any] = {"limit": LIMIT}
    HELP = {"limit": "the measure is met below this value"}
    type_name = ""

    def __init__(self, data: str, limit: float = math.inf):
        self.data = data
        self.limit = limit
        self.value = math.inf
        self.suffices = False

    def start_window(self) -> None:
        """A new time window begins."""

    def measure(self, old: np.ndarray, new: np.ndarray) -> bool:
        """Update ``value`` from one iteration; True if the measure is met."""
        self.value = self.evaluate(norm(new - old), old, new)
        return self.value < self.limit

    def evaluate(self, difference: float, old: np.ndarray, new: np.ndarray) -> float:
        raise NotImplementedError

    def label(self) -> str:
        """The measure as the coupler's logs and status name it: ``type(data)``."""
        return f"{self.type_name}({self.data})"

    def summary(self) -> str:
        return f"{self.data} {self.type_name} {self.value:.3e} (limit {self.limit:g})"


@MEASURES.register("absolute")
class Absolute(ConvergenceMeasure):
    """The 2-norm of the change between two iterates."""

    def evaluate(self, difference: float, old: np.ndarray, new: np.ndarray) -> float:
        return difference


@MEASURES.register("absolute-rms")
class AbsoluteRms(ConvergenceMeasure):
    """The root mean square of the change between two iterates (the 2-norm over the square root of the size)."""

    def evaluate(self, difference: float, old: np.ndarray, new: np.ndarray) -> float:
        return difference / math.sqrt(max(new.size, 1))


@MEASURES.register("relative")
class Relative(ConvergenceMeasure):
    """The change between two iterates over the new iterate's 2-norm."""

    def evaluate(self, difference: float, old: np.ndarray, new: np.ndarray) -> float:
        scale = norm(new)
        return difference / scale if scale > 0 else (0.0 if difference == 0 else math.inf)


@MEASURES.register("residual-relative")
class ResidualRelative(ConvergenceMeasure):
    """The change between two iterates over the window's first change."""

    def __init__(self, data: str, limit: float = math.inf):
        super().__init__(data, limit)
        self._first = 0.0

    def start_window(self) -> None:
        self._first = 0.0

    def evaluate(self, difference: float, old: np.ndarray, new: np.ndarray) -> float:
        if self._first == 0.0:
            self._first = difference
        return difference / self._first if self._first > 0 else 0.0


@MEASURES.register("min-iterations")
class MinIterations(ConvergenceMeasure):
    """Met from a window's ``iterations``-th coupling iteration on (preCICE's min-iteration-convergence-measure and
    min-iterations): the other measures alone cannot end a window earlier."""

    SETTINGS = {"iterations": Value(1, low=1)}
    HELP = {"iterations": "the coupling iterations every window takes at least"}

    def __init__(self, data: str, iterations: int = 1):
        super().__init__(data, float(iterations) - 0.5)
        self.iterations = int(iterations)
        self._count = 0

    def start_window(self) -> None:
        self._count = 0

    def measure(self, old: np.ndarray, new: np.ndarray) -> bool:
        self._count += 1
        self.value = float(self.iterations - self._count)       # iterations still to go (met at 0 and below)
        return self._count >= self.iterations

    def summary(self) -> str:
        return f"{self.data} {self.type_name} {self._count} of at least {self.iterations}"


class Combination(ConvergenceMeasure):
    """Met when ``combine`` of the member measures' results holds; ``value`` is the member value nearest its limit."""

    SETTINGS = {"measures": Required(list)}
    HELP = {"measures": "the member measures, tables with type and limit (their data is the combination's)"}
    combine = all

    def __init__(self, data: str, measures: list[dict[str, Any]]):
        super().__init__(data)
        self.members = [make_measure(m) for m in measures]

    @classmethod
    def check_settings(cls, settings: dict, where: str, source: str) -> None:
        items = settings["measures"]
        if not items:
            raise SceneError(f"{source + ': ' if source else ''}'{where}.measures' is empty")
        settings["measures"] = [resolve_measure({"data": settings["data"], **_table(m, f"{where}.measures.{i}", source)},
                                                f"{where}.measures.{i}", source) for i, m in enumerate(items)]

    def start_window(self) -> None:
        for member in self.members:
            member.start_window()

    def measure(self, old: np.ndarray, new: np.ndarray) -> bool:
        met = [member.measure(old, new) for member in self.members]
        ratios = [m.value / m.limit for m in self.members]
        nearest = self.members[int(np.argmin(ratios))]
        self.value, self.limit = nearest.value, nearest.limit
        return type(self).combine(met)

    def summary(self) -> str:
        inner = ", ".join(m.summary().removeprefix(f"{m.data} ") for m in self.members)
        return f"{self.data} {self.type_name}({inner})"


@MEASURES.register("any-of")
class AnyOf(Combination):
    """Met when any of its member measures is met."""

    combine = any


@MEASURES.register("all-of")
class AllOf(Combination):
    """Met when all of its member measures are met."""

    combine = all


def _table(value: Any, where: str, source: str) -> dict:
    if not isinstance(value, dict):
        raise SceneError(f"{source + ': ' if source else ''}'{where}' must be a table, got {value!r}")
    return value


def resolve_measure(table: Any, where: str, source: str = "") -> dict[str, Any]:
    """A measure's table checked against its class's settings, defaults filled in."""
    return MEASURES.settings(table, where, source, common=COMMON)


def make_measure(settings: dict[str, Any]) -> ConvergenceMeasure:
    """A measure from resolved settings."""
    measure = MEASURES.create({k: v for k, v in settings.items() if k != "suffices"})
    measure.suffices = bool(settings.get("suffices", False))
    return measure


def window_converged(measures: list[ConvergenceMeasure], met: list[bool]) -> bool:
    """A window's measures, each met or not: all are met, or one that suffices is."""
    return all(met) or any(m and measure.suffices for measure, m in zip(measures, met))
