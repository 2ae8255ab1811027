"""Relaxation of implicit coupling iterations.

- ``ConstantRelaxation``: x + omega r, with r = x_tilde - x.
- ``Aitken``: dynamic relaxation (Irons and Tuck), omega reset to at most the initial relaxation in every window.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from coupler.accelerations.base import ACCELERATIONS, RELAXATION, Acceleration


@ACCELERATIONS.register("constant")
class ConstantRelaxation(Acceleration):
    """Constant under-relaxation: x <- x + omega (x~ - x)."""

    SETTINGS = {"relaxation": RELAXATION}
    HELP = {"relaxation": "the relaxation factor omega: x <- x + omega (x~ - x)"}

    def __init__(self, relaxation: float, block_sizes: list[int] | None = None) -> None:
        super().__init__()
        self.omega = relaxation

    def next_iterate(self) -> np.ndarray:
        return self.x + self.omega * (self.x_tilde - self.x)


@ACCELERATIONS.register("aitken")
class Aitken(Acceleration):
    """Aitken's dynamic relaxation: omega from the last two residuals, restarted every window."""

    SETTINGS = {"initial_relaxation": RELAXATION}
    HELP = {"initial_relaxation": "the relaxation factor of a window's first update, whence Aitken adapts it"}

    def __init__(self, initial_relaxation: float, block_sizes: list[int] | None = None) -> None:
        super().__init__()
        self.initial = initial_relaxation
        self.omega = initial_relaxation
        self._r_previous: np.ndarray | None = None

    def start_window(self) -> None:
        super().start_window()
        self.map_changed()

    def map_changed(self) -> None:
        """Forget the last residual; omega back to at most the initial relaxation (as in each new window)."""
        self._r_previous = None
        self.omega = np.sign(self.omega) * min(abs(self.omega), self.initial) or self.initial

    def next_iterate(self) -> np.ndarray:
        r = self.x_tilde - self.x
        if self._r_previous is not None:
            dr = r - self._r_previous
            denominator = float(dr @ dr)
            if denominator > 0.0:
                self.omega = -self.omega * float(self._r_previous @ dr) / denominator
        self._r_previous = r
        return self.x + self.omega * r

    def regrid(self, transform: Callable[[np.ndarray], np.ndarray], block_sizes: list[int]) -> None:
        super().regrid(transform, block_sizes)
        if self._r_previous is not None:
            self._r_previous = transform(self._r_previous)
