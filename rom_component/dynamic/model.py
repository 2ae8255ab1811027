"""A ROM of a structure with inertia: a learned discrete-time step map in reduced coordinates.

A dynamic structure's displacement at the end of a window depends on the window's force and on the
structure's state at its start (its displacement, velocity and acceleration), which a history of
converged windows carries. In reduced coordinates (x: a POD of the forces, scaled; z: a POD of the
displacement field)::

    z_{n+1} = W (x_{n+1} + 2 x_n + x_{n-1}) + sum_{k=1..p} A_k z_{n+1-k} + c   [+ Q q(z_n)]

with q(z_n) the products of the leading ``quadratic_modes`` coordinates of the last state (a
geometrically nonlinear structure). The force enters only through Newmark's weighted sum: for a linear
structure under Newmark's average acceleration, M (u_{n+1} - 2 u_n + u_{n-1}) / dt^2 +
K (u_{n+1} + 2 u_n + u_{n-1}) / 4 = (f_{n+1} + 2 f_n + f_{n-1}) / 4, so the map with p = 2 is exact in the
full coordinates. Fixing the weights 1 : 2 : 1 matters in a coupled run: the fluid's force carries the
added mass, - m_a (u_{n+1} - 2 u_n + u_{n-1}) / dt^2, so an error in how a map weighs past forces against
the present one is multiplied by m_a / (m dt^2) in the loop (on Mok's benchmark, a map with every force
weight free ran away within 6 s of taking over, while its open-loop error was the same: see the research
notebook).

Training pairs carry the sub-iterations' meaning: a coupling iteration solves a window again from the
same start state with another force, so every recorded call of window n+1 is a pair (history of the
converged windows before it, the call's force) -> the call's displacement. The fit is a ridge least
squares (scikit-learn's ``Ridge``). The linear part's stability is checked at fit: the spectral radius of
the companion matrix of A_1..A_p is reported, and a model above ``max_radius`` is stabilised by scaling A_k
by s^k (every eigenvalue times s, exactly); a free response that still grows (a held force for 2000
windows: the quadratic terms, or a radius of 1 on a real eigenvalue) is refused.

Before the first window the structure is at rest: the history is the reduced coordinates of zero force
and zero displacement.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sklearn.linear_model import Ridge

from rom_component.model_check import companion_radius
from rom_component.reduction.decoders import PodDecoder
from rom_component.reduction.encoders import PodEncoder

FORCE_HISTORY = 2   # Newmark's weighted sum x+ + 2 x0 + x- spans the window and the two before it


class UnstableModel(ValueError):
    """A fitted step map whose free response grows."""


@dataclass
class WindowData:
    """Recorded calls of a dynamic structure, in window order.

    ``F`` (m, N_f) forces and ``U`` (m, N_u) displacement fields of every call; ``window`` (m,) the window
    each belongs to (1 = the first window of the run); ``converged`` (m,) each window's last, converged call.
    """

    F: np.ndarray
    U: np.ndarray
    window: np.ndarray
    converged: np.ndarray

    def __post_init__(self) -> None:
        self.window = np.asarray(self.window, dtype=np.int64)
        self.converged = np.asarray(self.converged, dtype=bool)
        windows = self.window[self.converged]
        if len(windows) == 0 or np.any(np.diff(windows) != 1) or windows[0] != 1:
            raise ValueError("the recorded calls must hold one converged call per window, windows 1, 2, ... in "
                             f"order (got converged windows {windows[:5].tolist()}...)")

    @property
    def windows(self) -> int:
        return int(self.window[self.converged][-1])

    def converged_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """Converged forces and fields of windows 0 (rest: zeros), 1, ..., W."""
        F = np.vstack([np.zeros((1, self.F.shape[1])), self.F[self.converged]])
        U = np.vstack([np.zeros((1, self.U.shape[1])), self.U[self.converged]])
        return F, U

    def select(self, first: int, last: int) -> np.ndarray:
        """The calls of windows ``first`` to ``last`` (inclusive)."""
        return (self.window >= first) & (self.window <= last)


def lagged(sequence: np.ndarray, window: np.ndarray, lags: int) -> np.ndarray:
    """Rows [s[w-1], s[w-2], ..., s[w-lags]] for each window w (index 0 repeated before the start): (m, lags*r)."""
    index = np.maximum(window[:, None] - np.arange(1, lags + 1)[None, :], 0)
    return sequence[index].reshape(len(window), -1)


def quadratic_pairs(k: int) -> tuple[np.ndarray, np.ndarray]:
    """The index pairs (i <= j) of the unique products of ``k`` coordinates."""
    return np.triu_indices(k)


@dataclass
class StepMap:
    """The fitted map's matrices in reduced units (z, x); see the module's docstring."""

    W_f: np.ndarray          # (r_u, r_f), on Newmark's weighted sum x+ + 2 x0 + x-
    A: np.ndarray            # (r_u, p r_u): [A_1 ... A_p]
    Q: np.ndarray            # (r_u, k (k + 1) / 2)
    c: np.ndarray            # (r_u,)
    quadratic_modes: int = 0
    radius: float = 0.0              # spectral radius of the linear part as fitted
    radius_served: float = 0.0       # after stabilisation
    pairs: tuple[np.ndarray, np.ndarray] = field(init=False)
    B: np.ndarray = field(init=False)   # [2 W_f, W_f]: the weights of the last two windows' forces

    def __post_init__(self) -> None:
        self.pairs = quadratic_pairs(self.quadratic_modes)
        self.B = np.hstack([2 * self.W_f, self.W_f])

    @property
    def history(self) -> int:
        return self.A.shape[1] // max(self.A.shape[0], 1)

    def step(self, x: np.ndarray, z_history: np.ndarray, x_history: np.ndarray) -> np.ndarray:
        """z_{n+1} for the reduced force ``x`` and the histories (newest first), (p, r_u) and (2, r_f)."""
        z = self.W_f @ x + self.A @ z_history.ravel() + self.c
        z += self.B @ x_history.ravel()
        if self.quadratic_modes:
            last = z_history[0, :self.quadratic_modes]
            z += self.Q @ (last[self.pairs[0]] * last[self.pairs[1]])
        return z

    def companion_radius(self) -> float:
        return companion_radius(self.A)


def stabilised(A: np.ndarray, max_radius: float) -> tuple[np.ndarray, float, float]:
    """[A_1 ... A_p] with every companion eigenvalue scaled by s = max_radius / radius if the radius exceeds
    ``max_radius`` (A_k -> s^k A_k); the radius before and after."""
    radius = companion_radius(A)
    if radius <= max_radius:
        return A, radius, radius
    r = A.shape[0]
    s = max_radius / radius
    scales = np.repeat(s ** np.arange(1, A.shape[1] // r + 1), r)
    A = A * scales[None, :]
    return A, radius, companion_radius(A)


class StepMapRom:
    """A POD encoder of forces, a POD decoder of the displacement field, and a step map between them.

    ``fit(data)`` on a ``WindowData``; ``rollout`` runs the map over a sequence of converged forces from a
    history, as the component does in a coupled run once each window has converged.
    """

    def __init__(self, force_modes: int = 8, disp_modes: int = 6, history: int = 2, ridge: float = 1e-8,
                 quadratic_modes: int = 0, max_radius: float = 1.0):
        self.force_modes, self.disp_modes, self.history = force_modes, disp_modes, history
        self.ridge, self.quadratic_modes, self.max_radius = ridge, quadratic_modes, max_radius

    def settings(self) -> dict[str, Any]:
        return {"force_modes": self.force_modes, "disp_modes": self.disp_modes, "history": self.history,
                "ridge": self.ridge, "quadratic_modes": self.quadratic_modes, "max_radius": self.max_radius}

    def fit(self, data: WindowData, last_window: int | None = None, bases: Bases | None = None) -> StepMapRom:
        """Fit on the calls of windows 1 to ``last_window`` (default: all); ``bases``: PODs already fitted on
        those calls (the hold-out reuses them across its grid)."""
        if self.history < 1:
            raise ValueError(f"history {self.history}: the map needs at least the last window's displacement")
        last = data.windows if last_window is None else last_window
        rows = data.select(1, last)
        self.bases_ = bases or Bases(data, rows, self.force_modes, self.disp_modes)
        x, z, xc, zc = self.bases_.reduced(self.force_modes, self.disp_modes)
        x, z, window = x[rows], z[rows], data.window[rows]
        if self.quadratic_modes > z.shape[1]:
            raise ValueError(f"quadratic_modes {self.quadratic_modes} exceeds the {z.shape[1]} displacement modes")
        r_f, r_u, k = x.shape[1], z.shape[1], self.quadratic_modes
        x_history = lagged(xc, window, 2)
        forcing = x + 2 * x_history[:, :r_f] + x_history[:, r_f:]
        last_z = lagged(zc, window, 1)[:, :k]
        i, j = quadratic_pairs(k)
        scale = self.bases_.z_scale
        features = np.hstack([forcing, lagged(zc, window, self.history) / scale, last_z[:, i] * last_z[:, j] / scale ** 2])
        ridge = Ridge(alpha=self.ridge * len(z), fit_intercept=True, solver="svd").fit(features, z / scale)
        W, A, Q = np.split(ridge.coef_, [r_f, r_f + self.history * r_u], axis=1)
        W, Q = W * scale, Q / scale
        A, radius, served = stabilised(A, self.max_radius)
        self.map_ = StepMap(W, A, Q, ridge.intercept_ * scale, k, radius, served)
        self.check_free_response(xc[last], zc, xc, last)
        return self

    @property
    def modes(self) -> tuple[int, int]:
        return min(self.force_modes, self.bases_.x_all.shape[1]), min(self.disp_modes, self.bases_.z_all.shape[1])

    def rollout(self, x: np.ndarray, z_history: np.ndarray, x_history: np.ndarray) -> np.ndarray:
        """Reduced displacements of consecutive windows driven by the reduced forces ``x`` (n, r_f), each window's
        answer joining the history (newest first: (p, r_u) and (q, r_f))."""
        step = self.map_
        z_history, x_history = z_history.copy(), x_history.copy()
        Z = np.empty((len(x), step.W_f.shape[0]))
        for n, x_n in enumerate(x):       # a recurrence: each window needs the last one's answer
            Z[n] = step.step(x_n, z_history, x_history)
            z_history = np.vstack([Z[n], z_history[:-1]])
            x_history = np.vstack([x_n, x_history[:-1]])
        return Z

    def history_before(self, zc: np.ndarray, xc: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
        """The histories a call of ``window`` starts from, from converged reduced rows of windows 0, 1, ..."""
        z_history = zc[np.maximum(window - 1 - np.arange(self.history), 0)]
        x_history = xc[np.maximum(window - 1 - np.arange(FORCE_HISTORY), 0)]
        return z_history, x_history

    def check_free_response(self, x_hold: np.ndarray, zc: np.ndarray, xc: np.ndarray, last: int,
                            windows: int = 2000) -> None:
        """Hold the last converged force for ``windows`` windows from the last state: refuse a model whose
        response leaves ten times the training range."""
        z_history, x_history = self.history_before(zc, xc, last + 1)
        with np.errstate(over="ignore", invalid="ignore"):
            Z = self.rollout(np.repeat(x_hold[None, :], windows, axis=0), z_history, x_history)
        span = float(np.ptp(zc, axis=0).max()) or 1.0
        grown = np.abs(Z - zc[last]).max() if np.isfinite(Z).all() else np.inf
        if grown > 10 * span:
            raise UnstableModel(f"the step map's free response grows to {grown:.3g} (training range {span:.3g}) "
                                f"under a held force over {windows} windows (linear part's spectral radius "
                                f"{self.map_.radius_served:.6f}, quadratic modes {self.quadratic_modes})")

    def validation_error(self, data: WindowData, first: int, last: int) -> float:
        """The field error e of a rollout over windows ``first`` to ``last`` driven by the recorded converged forces,
        started from the recorded history: mean_t ||U - U_rom|| / mean_t ||U||."""
        x, z, xc, zc = self.bases_.reduced(*self.modes, data=data)
        Z = self.rollout(xc[first:last + 1], *self.history_before(zc, xc, first))
        U = data.converged_rows()[1][first:last + 1]
        U_rom = self.bases_.decoder.inverse_transform_modes(Z)
        return float(np.linalg.norm(U - U_rom, axis=1).mean() / max(np.linalg.norm(U, axis=1).mean(), 1e-300))


class _Decoder(PodDecoder):
    def inverse_transform_modes(self, Z: np.ndarray) -> np.ndarray:
        return Z @ self.components_[:, :Z.shape[1]].T + self.mean_


class Bases:
    """The force and displacement PODs of a block of calls, at the largest mode counts a grid asks for."""

    def __init__(self, data: WindowData, rows: np.ndarray, force_modes: int, disp_modes: int):
        self.encoder = PodEncoder(modes=force_modes).fit(data.F[rows])
        self.decoder = _Decoder(modes=disp_modes)
        self.decoder.fit_transform(data.U[rows])
        self._data = data
        self.x_all, self.z_all, self.xc_all, self.zc_all = self._reduce(data)
        self.z_scale = float(np.sqrt(np.mean(self.z_all[:, 0] ** 2))) or 1.0

    def _reduce(self, data: WindowData) -> tuple[np.ndarray, ...]:
        Fc, Uc = data.converged_rows()
        return (self.encoder.transform(data.F), self.z_of(data.U), self.encoder.transform(Fc), self.z_of(Uc))

    def z_of(self, U: np.ndarray) -> np.ndarray:
        return (U - self.decoder.mean_) @ self.decoder.components_

    def reduced(self, force_modes: int, disp_modes: int, data: WindowData | None = None) -> tuple[np.ndarray, ...]:
        """x, z of every call and xc, zc of every converged window (0 = rest), truncated."""
        arrays = (self.x_all, self.z_all, self.xc_all, self.zc_all) if data is None or data is self._data \
            else self._reduce(data)
        r_f, r_u = min(force_modes, arrays[0].shape[1]), min(disp_modes, arrays[1].shape[1])
        return arrays[0][:, :r_f], arrays[1][:, :r_u], arrays[2][:, :r_f], arrays[3][:, :r_u]


@dataclass
class HoldoutRow:
    settings: dict[str, Any]
    error: float
    radius: float
    refused: str = ""


def holdout(data: WindowData, last_window: int, grid: dict[str, Sequence[Any]], fraction: float,
            max_radius: float = 1.0) -> list[HoldoutRow]:
    """Every combination of ``grid`` fitted on the first windows and scored by a rollout over the last
    ``fraction`` of windows 1 to ``last_window`` (whole windows, driven by their recorded forces)."""
    split = max(2, int(round(last_window * (1 - fraction))))
    if split >= last_window:
        raise ValueError(f"a hold-out of {fraction:g} of {last_window} windows leaves none to test")
    keys = list(grid)
    combos = np.array(np.meshgrid(*[np.arange(len(grid[k])) for k in keys], indexing="ij")).reshape(len(keys), -1).T
    bases = Bases(data, data.select(1, split), max(grid["force_modes"]), max(grid["disp_modes"]))
    rows = []
    for combo in combos:
        settings = {k: grid[k][i] for k, i in zip(keys, combo)}
        model = StepMapRom(**settings, max_radius=max_radius)
        try:
            model.fit(data, split, bases=bases)
        except UnstableModel as exc:
            rows.append(HoldoutRow(settings, np.inf, np.nan, str(exc)))
            continue
        rows.append(HoldoutRow(settings, model.validation_error(data, split + 1, last_window), model.map_.radius))
    return rows
