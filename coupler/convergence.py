"""Convergence measures of implicit coupling, as in preCICE.

Each measure compares the new value of one exchanged data item with its previous
value (for data fed back to the first participant: the value the participant used):
- ``relative``: ||new - old|| / ||new|| < limit
- ``absolute``: ||new - old|| < limit
- ``residual-relative``: ||new - old|| / ||new - old||_first iteration of the window < limit
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

KINDS = ("relative", "absolute", "residual-relative")


@dataclass
class ConvergenceMeasure:
    data: str
    kind: str
    limit: float
    value: float = field(default=np.inf, init=False)
    _first: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"convergence measure type {self.kind!r} not in {KINDS}")

    def start_window(self) -> None:
        self._first = 0.0

    def measure(self, old: np.ndarray, new: np.ndarray) -> bool:
        """Update ``value`` from one iteration; True if the measure is met."""
        difference = float(np.linalg.norm(new - old))
        if self.kind == "absolute":
            self.value = difference
        elif self.kind == "relative":
            scale = float(np.linalg.norm(new))
            self.value = difference / scale if scale > 0 else (0.0 if difference == 0 else np.inf)
        else:
            if self._first == 0.0:
                self._first = difference
            self.value = difference / self._first if self._first > 0 else 0.0
        return self.value < self.limit
