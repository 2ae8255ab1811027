"""Multi-vector quasi-Newton (MVQN, Bogaers et al. 2014), the update of Kratos CoSimulation's ``mvqn``.

It keeps a forward Jacobian J of the residual r(x) = H(x) - x with respect to the iterate, as a dense matrix
that lives across windows. Its prior, before any window, is -I / alpha (constant relaxation). In a window, with the
last ``horizon`` iterates x_i and residuals r_i handed to the update (newest first) and their consecutive
differences as columns, dX = [x_0 - x_1, ...] and dR = [r_0 - r_1, ...]:

    J_hat = J + (dR - J dX) dX^+        (dX^+: the pseudo-inverse, singular values at round-off cut)
    x_next = x - J_hat^-1 r

A window's first update, before any difference, is x + alpha r while there is no Jacobian, and x - J^-1 r after.
At the end of a window J becomes the last J_hat. The residual of a converged iteration takes no part, as in
Kratos (the update is asked for only when the iteration has not converged).

This is not the IQN-IMVJ of ``coupler.acceleration`` (an inverse Jacobian mapping residual differences to
differences of H, with a zero prior): both satisfy the secant equations of the window, but their priors and the
matrices they hold differ, so their iterates part from the first quasi-Newton update.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from cosim.schema import Positive, Value
from coupler.acceleration import ACCELERATIONS, Acceleration


@ACCELERATIONS.register("mvqn")
class MultiVectorQuasiNewton(Acceleration):
    """MVQN: a forward Jacobian updated from the window's secant equations, kept from window to window."""

    SETTINGS = {"initial_relaxation": Value(0.125, low=0.0, low_open=True), "horizon": Positive(15)}
    HELP = {"initial_relaxation": "alpha: the first update x + alpha r, and the prior Jacobian -I / alpha",
            "horizon": "the most iterates (and residuals) of a window the update takes, newest first"}

    def __init__(self, initial_relaxation: float = 0.125, horizon: int = 15,
                 block_sizes: list[int] | None = None) -> None:
        super().__init__(block_sizes)
        self.alpha = initial_relaxation
        self.horizon = int(horizon)
        self.jacobian: np.ndarray | None = None       # J, kept across windows
        self.updated: np.ndarray | None = None        # J_hat of the window's last update
        self._x: deque[np.ndarray] = deque(maxlen=self.horizon)
        self._r: deque[np.ndarray] = deque(maxlen=self.horizon)

    def start_window(self) -> None:
        super().start_window()
        self._x.clear()
        self._r.clear()

    def next_iterate(self) -> np.ndarray:
        r = self.x_tilde - self.x
        self._x.appendleft(self.x.copy())
        self._r.appendleft(r)
        if len(self._r) == 1:
            if self.jacobian is None:
                return self.x + self.alpha * r
            return self.x + np.linalg.solve(self.jacobian, -r)
        if self.jacobian is None:
            self.jacobian = -np.identity(r.size) / self.alpha
        dR = np.stack([a - b for a, b in zip(list(self._r)[:-1], list(self._r)[1:])], axis=1)
        dX = np.stack([a - b for a, b in zip(list(self._x)[:-1], list(self._x)[1:])], axis=1)
        pseudo_inverse = np.linalg.lstsq(dX, np.identity(r.size), rcond=-1)[0]
        self.updated = self.jacobian + (dR - self.jacobian @ dX) @ pseudo_inverse
        return self.x + np.linalg.solve(self.updated, -r)

    def end_window(self) -> None:
        if self.jacobian is not None and self.updated is not None:
            self.jacobian = self.updated.copy()

    def map_changed(self) -> None:
        """The map changed (a ROM took over from the solver it approximates): no difference spans the change, and
        the Jacobian learnt on the old map stays as the prior (dropping it cost a ROM-FOM run of the dynamic wall
        8.1 iterations a window where keeping it cost 4.6; the FOM-FOM run took 2.1)."""
        self._x.clear()
        self._r.clear()

    def regrid(self, transform, block_sizes: list[int]) -> None:  # type: ignore[no-untyped-def]
        super().regrid(transform, block_sizes)
        self.jacobian = self.updated = None       # a matrix of the old grid's size
        self._x.clear()
        self._r.clear()
