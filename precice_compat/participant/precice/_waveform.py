"""A read data item's waveform inside the window: the B-spline the coupler built through the window's samples
(knots and coefficients), evaluated here by de Boor's algorithm (numpy only)."""

from __future__ import annotations

import numpy as np


class Waveform:
    """The B-spline with knots ``knots`` and coefficients ``coefficients`` (first axis: the basis functions) over
    the window's normalised time [0, 1]."""

    def __init__(self, knots: np.ndarray, coefficients: np.ndarray):
        self.knots = np.asarray(knots, dtype=float)
        self.coefficients = np.asarray(coefficients, dtype=float)
        self.degree = len(self.knots) - len(self.coefficients) - 1

    def __call__(self, x: float) -> np.ndarray:
        t, c, k = self.knots, self.coefficients, self.degree
        n = len(c)
        span = int(np.searchsorted(t, x, side="right")) - 1
        span = min(max(span, k), n - 1)          # x = 1 lies in the last span
        d = [c[span - k + j].copy() for j in range(k + 1)]
        for r in range(1, k + 1):
            for j in range(k, r - 1, -1):
                left, right = t[span - k + j], t[span + 1 + j - r]
                alpha = (x - left) / (right - left)
                d[j] = (1.0 - alpha) * d[j - 1] + alpha * d[j]
        return d[k]
