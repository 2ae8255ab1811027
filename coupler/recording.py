"""Recording of every call of a marked component: the ROM's training set.

Every call gives a row for every variable any of the component's backends declares: a
variable the serving backend does not return (a local only the ROM reports, say) is
recorded as NaN, so that all datasets of a component keep one row per call.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np


class CallRecorder:
    """Buffers one window of calls (inputs, outputs, window, iteration, converged)."""

    def __init__(self, shapes: Mapping[str, Mapping[str, tuple[int, ...]]] | None = None) -> None:
        """``shapes``: {"inputs": {name: shape}, "outputs": {name: shape}} of every variable to record."""
        self.shapes = {kind: dict((shapes or {}).get(kind, {})) for kind in ("inputs", "outputs")}
        self.clear()

    def clear(self) -> None:
        self.calls: dict[str, Any] = {"inputs": {}, "outputs": {}, "window": [], "iteration": [], "converged": []}

    def record(self, window: int, iteration: int, inputs: Mapping[str, np.ndarray],
               outputs: Mapping[str, np.ndarray]) -> None:
        for kind, arrays in (("inputs", inputs), ("outputs", outputs)):
            for name, value in arrays.items():
                self.calls[kind].setdefault(name, []).append(np.array(value, dtype=np.float64))
            for name, shape in self.shapes[kind].items():
                if name not in arrays:
                    self.calls[kind].setdefault(name, []).append(np.full(shape, np.nan))
        self.calls["window"].append(window)
        self.calls["iteration"].append(iteration)
        self.calls["converged"].append(False)

    def mark_converged(self, iteration: int) -> None:
        """Flag the calls of ``iteration`` (the window's last) as converged."""
        for i, it in enumerate(self.calls["iteration"]):
            if it == iteration:
                self.calls["converged"][i] = True

    def take(self) -> dict[str, Any]:
        calls = self.calls
        self.clear()
        return calls
