"""Prediction of a window's first iterate from the converged values of earlier windows."""

from __future__ import annotations

from collections import deque
from typing import cast

import numpy as np

COEFFICIENTS = {0: (1.0,), 1: (2.0, -1.0), 2: (2.5, -2.0, 0.5)}


class Extrapolation:
    """Order 0 repeats the last value; order 1 is linear, order 2 the preCICE quadratic."""

    def __init__(self, order: int) -> None:
        if order not in COEFFICIENTS:
            raise ValueError(f"extrapolation order {order} not in {sorted(COEFFICIENTS)}")
        self.order = order
        self._history: deque[np.ndarray] = deque(maxlen=order + 1)

    def store(self, value: np.ndarray) -> None:
        """Record a window's converged value."""
        self._history.appendleft(np.array(value, copy=True))

    def predict(self) -> np.ndarray:
        available = len(self._history)
        coefficients = COEFFICIENTS[min(self.order, available - 1)]
        return cast(np.ndarray, sum(c * v for c, v in zip(coefficients, self._history)))
