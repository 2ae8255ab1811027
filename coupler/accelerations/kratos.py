"""Kratos's variants: updates that reproduce Kratos CoSimulationApplication's convergence accelerators bit for bit.

- ``BoundedAitken`` (``kratos-aitken``, Kratos's ``aitken``): Aitken relaxation with omega carried across windows
  and clamped, where this coupler's ``aitken`` restarts omega every window.
- ``PlainIQNILS`` (``kratos-iqn-ils``, Kratos's ``iqnils``): IQN-ILS with horizons and no filter, where this
  coupler's ``iqn-ils`` filters columns and caps their total.
- ``MultiVectorQuasiNewton`` (``kratos-mvqn``, Kratos's ``mvqn``): Bogaers's MVQN (2014), a forward Jacobian kept
  across windows.

Each does its bookkeeping when an update is asked for, that is, for iterations that have not converged: the
residual of a window's converged iteration takes no part, unlike in this coupler's own accelerations. Their
former names (``aitken-bounded``, ``iqn-ils-plain``, ``mvqn``) choose them too.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from cosim.schema import Positive, Value
from coupler.accelerations.base import ACCELERATIONS, Acceleration


@ACCELERATIONS.register("kratos-aitken", aliases=("aitken-bounded",))
class BoundedAitken(Acceleration):
    """Aitken's dynamic relaxation with omega carried from window to window and clamped.

    A window's first update takes min(omega_carried, ``initial_relaxation_max``); each later one
    omega = -omega_carried (r_prev . (r - r_prev)) / |r - r_prev|^2, clamped to [``relaxation_min``,
    ``relaxation_max``], which becomes omega_carried. omega_carried starts at ``initial_relaxation``.
    """

    SETTINGS = {"initial_relaxation": 0.1, "initial_relaxation_max": 0.45, "relaxation_min": -2.0,
                "relaxation_max": 2.0}
    HELP = {"initial_relaxation": "omega before any update",
            "initial_relaxation_max": "the most a window's first update relaxes by",
            "relaxation_min": "the least omega", "relaxation_max": "the largest omega"}

    def __init__(self, initial_relaxation: float = 0.1, initial_relaxation_max: float = 0.45,
                 relaxation_min: float = -2.0, relaxation_max: float = 2.0,
                 block_sizes: list[int] | None = None) -> None:
        super().__init__(block_sizes)
        self.omega = initial_relaxation
        self.first_max, self.low, self.high = initial_relaxation_max, relaxation_min, relaxation_max
        self._r_previous: np.ndarray | None = None

    def start_window(self) -> None:
        super().start_window()
        self._r_previous = None

    def next_iterate(self) -> np.ndarray:
        r = self.x_tilde - self.x
        previous, self._r_previous = self._r_previous, r
        if previous is None:
            return self.x + min(self.omega, self.first_max) * r
        dr = r - previous
        omega = float(-self.omega * np.inner(previous, dr) / np.inner(dr, dr))
        self.omega = min(max(omega, self.low), self.high)
        return self.x + self.omega * r

    def map_changed(self) -> None:
        self._r_previous = None


@ACCELERATIONS.register("kratos-iqn-ils", aliases=("iqn-ils-plain",))
class PlainIQNILS(Acceleration):
    """IQN-ILS with horizons and a minimum-norm least squares, no filter.

    In a window, the last ``iteration_horizon`` residuals r_i and values x~_i = H(x_i) handed to the update give
    the columns V = [r_0 - r_1, ...], W = [x~_0 - x~_1, ...] (newest first); the columns of the last
    ``timestep_horizon - 1`` windows follow them. The update is x_next = x + W c + r, c the minimum-norm
    least-squares solution of V c = -r. A window's first update is x + alpha r while no earlier window left
    columns.
    """

    SETTINGS = {"initial_relaxation": Value(0.125, low=0.0, low_open=True), "iteration_horizon": Positive(20),
                "timestep_horizon": Positive(1)}
    HELP = {"initial_relaxation": "alpha: the first update x + alpha r before any column exists",
            "iteration_horizon": "the most residuals of a window kept (their differences are the columns)",
            "timestep_horizon": "the windows whose columns are used: this one and timestep_horizon - 1 before"}

    def __init__(self, initial_relaxation: float = 0.125, iteration_horizon: int = 20, timestep_horizon: int = 1,
                 block_sizes: list[int] | None = None) -> None:
        super().__init__(block_sizes)
        self.alpha = initial_relaxation
        self._r: deque[np.ndarray] = deque(maxlen=int(iteration_horizon))
        self._xt: deque[np.ndarray] = deque(maxlen=int(iteration_horizon))
        self._old: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=max(int(timestep_horizon) - 1, 0))
        self._new: tuple[np.ndarray, np.ndarray] | None = None

    def start_window(self) -> None:
        super().start_window()
        self._r.clear()
        self._xt.clear()
        self._new = None

    def next_iterate(self) -> np.ndarray:
        r = self.x_tilde - self.x
        self._r.appendleft(r)
        self._xt.appendleft(self.x + r)     # x~ as x + r, to the last bit
        blocks = list(self._old)
        if len(self._r) > 1:
            rs, xts = list(self._r), list(self._xt)
            # rows, then transposed: the least squares sees the memory layout Kratos gives it
            self._new = (np.array([a - b for a, b in zip(rs[:-1], rs[1:])]).T,
                         np.array([a - b for a, b in zip(xts[:-1], xts[1:])]).T)
            blocks.insert(0, self._new)
        if not blocks:
            return self.x + self.alpha * r
        V = np.hstack([v for v, _ in blocks])
        W = np.hstack([w for _, w in blocks])
        c = np.linalg.lstsq(V, -r, rcond=None)[0]
        return self.x + (W @ c + r)

    def end_window(self) -> None:
        if self._new is not None and self._old.maxlen:
            self._old.appendleft(self._new)
        self._new = None

    def map_changed(self) -> None:
        self._old.clear()
        self._r.clear()
        self._xt.clear()
        self._new = None


@ACCELERATIONS.register("kratos-mvqn", aliases=("mvqn",))
class MultiVectorQuasiNewton(Acceleration):
    """MVQN: a forward Jacobian updated from the window's secant equations, kept from window to window.

    It keeps a forward Jacobian J of the residual r(x) = H(x) - x with respect to the iterate, as a dense matrix
    that lives across windows. Its prior, before any window, is -I / alpha (constant relaxation). In a window, with the
    last ``horizon`` iterates x_i and residuals r_i handed to the update (newest first) and their consecutive
    differences as columns, dX = [x_0 - x_1, ...] and dR = [r_0 - r_1, ...]:

        J_hat = J + (dR - J dX) dX^+        (dX^+: the pseudo-inverse, singular values at round-off cut)
        x_next = x - J_hat^-1 r

    A window's first update, before any difference, is x + alpha r while there is no Jacobian, and x - J^-1 r after.
    At the end of a window J becomes the last J_hat. The residual of a converged iteration takes no part, as in
    Kratos (the update is asked for only when the iteration has not converged).

    This is not the IQN-IMVJ of ``coupler.accelerations.quasi_newton`` (an inverse Jacobian mapping residual differences to
    differences of H, with a zero prior): both satisfy the secant equations of the window, but their priors and the
    matrices they hold differ, so their iterates part from the first quasi-Newton update.
    """

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
