"""The experimental coupled surrogate's IQN: IQN-ILS with the surrogate's Jacobian as its prior (IQN-ILSM)."""

from __future__ import annotations

from typing import Any

import numpy as np

from cosim.schema import Choice, Value
from coupler.accelerations.base import ACCELERATIONS
from coupler.accelerations.quasi_newton import IQNILS
from coupler.linalg import norm

CORRECTIONS = ("secant", "none")


@ACCELERATIONS.register("iqn-surrogate")
class IQNSurrogate(IQNILS):
    """IQN-ILS whose inverse Jacobian has the coupled surrogate's as its prior (IQN-ILSM, as CoCoNuT).

    With M = (J_S - I)^-1 from the surrogate's Jacobian J_S of H (``coupler.surrogate``) at the iterate, the
    inverse Jacobian of the residual is N = M + (dX - M V) V^+ (dX = W - V: the iterates' differences), which
    maps every column of V exactly as the secant equations ask and falls back to M elsewhere; the update is
    x - N r. With M = -I it is IQN-ILS. ``correction = "none"`` takes the surrogate's Newton step x - M r alone.
    Before the surrogate is trained, and for the rest of a window in which a surrogate step made the residual
    worse, the update is IQN-ILS's (the surrogate may cost iterations, never the criterion). A surrogate step longer
    than ``max_step_ratio`` times IQN-ILS's step from the same iterate (or the residual, if longer) is not taken
    (IQN-ILS's is): a stale surrogate's step can carry a solver out of its domain (the double flap's solid mesh
    failed after one).
    """

    SETTINGS = {**IQNILS.SETTINGS, "correction": Choice("secant", CORRECTIONS),
                "max_step_ratio": Value(5.0, low=1.0)}
    HELP = {**IQNILS.HELP,
            "correction": "'secant': the surrogate's inverse Jacobian corrected by the secant columns (IQN-ILSM); "
                          "'none': the surrogate's Newton step alone",
            "max_step_ratio": "a surrogate step longer than this many times IQN-ILS's step from the same iterate (or "
                              "the residual, if longer) is replaced by IQN-ILS's"}

    def __init__(self, initial_relaxation: float, max_used_iterations: int = 50, reused_time_windows: int = 0,
                 filter: str = "qr2", filter_limit: float = 1e-3, stale_step_ratio: float = 2.0,
                 on_map_change: str = "drop-span", preconditioner: str = "value", freeze_after: int = 0,
                 count_emptied_windows: bool = True, correction: str = "secant", max_step_ratio: float = 5.0,
                 block_sizes: list[int] | None = None) -> None:
        super().__init__(initial_relaxation, max_used_iterations, reused_time_windows, filter, filter_limit,
                         stale_step_ratio, on_map_change, preconditioner, freeze_after, count_emptied_windows,
                         block_sizes=block_sizes)
        self.correction = correction
        self.max_step_ratio = max_step_ratio
        self.rejected_steps = 0
        self.model: Any = None          # the run's coupled surrogate (use_model): jacobian(x, y), current (x, y)
        self._plain = False             # this window fell back to IQN-ILS
        self._surrogate_step = False    # the last update was the surrogate's
        self.surrogate_updates = 0
        self.fallback_windows = 0

    def use_model(self, model: Any) -> None:
        self.model = model

    def start_window(self) -> None:
        super().start_window()
        self._plain = self._surrogate_step = False

    def observe(self, x: np.ndarray, x_tilde: np.ndarray) -> None:
        worse = self.iteration >= 1 and norm(x_tilde - x) > self._last_norm
        if self._surrogate_step and worse and not self._plain:
            self._plain = True
            self.fallback_windows += 1
        super().observe(x, x_tilde)

    def _prior(self) -> Any:
        """M: v -> (J_S - I)^-1 v at the current iterate, or None (no surrogate, or not in use in this window).

        J_S = U G has thin factors (rank k), so M v = -(v + U (I_k - G U)^-1 G v) (Woodbury)."""
        if self._plain or self.model is None or self.model.current is None:
            return None
        factors = self.model.jacobian_factors(*self.model.current)
        if factors is None:
            return None
        U, G = factors
        if U.shape[0] != self.x.size or G.shape[1] != self.x.size or not (np.isfinite(U).all() and np.isfinite(G).all()):
            return None
        from scipy.linalg import LinAlgError, lu_factor, lu_solve
        inner = np.eye(U.shape[1]) - G @ U
        try:
            lu = lu_factor(inner, check_finite=False)
        except (LinAlgError, ValueError):
            return None
        if not np.isfinite(lu[0]).all() or np.abs(np.diag(lu[0])).min() <= 1e-12 * np.abs(np.diag(lu[0])).max():
            return None
        return lambda v: -(v + U @ lu_solve(lu, G @ v, check_finite=False))

    def next_iterate(self) -> np.ndarray:
        M = self._prior()
        self._surrogate_step = False
        if M is None:
            return super().next_iterate()
        proposal = self._surrogate_proposal(M)
        plain = super().next_iterate()        # IQN-ILS's update from the same columns (and its housekeeping)
        reach = max(float(np.linalg.norm(plain - self.x)), float(np.linalg.norm(self.x_tilde - self.x)))
        if np.linalg.norm(proposal - self.x) > self.max_step_ratio * reach:
            self.rejected_steps += 1
            return plain
        self._surrogate_step = True
        self.surrogate_updates += 1
        return proposal

    def _surrogate_proposal(self, M: Any) -> np.ndarray:
        """x - N r with the surrogate's prior M and the secant columns (filtered as IQN-ILS filters them)."""
        r = self.x_tilde - self.x
        step = M(r)
        fit = self._secant_fit(r) if self.correction == "secant" else None
        if fit is not None:
            c, V, W = fit                         # c = -V^+ r
            step = step - (W - V - M(V)) @ c      # + (dX - M V) V^+ r, dX = W - V
        return self.x - step
