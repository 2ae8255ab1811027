"""Interface quasi-Newton accelerations, as preCICE's.

- ``IQNILS``: interface quasi-Newton with an inverse Jacobian from least squares (Degroote et al. 2009), columns
  of reused time windows, a cap on used columns, QR1 / QR1-absolute / QR2 filtering of nearly dependent columns.
  With several data blocks the least-squares norm is scaled per block (``block_sizes``) by a preconditioner
  (``coupler.accelerations.preconditioners``).
- ``IQNIMVJ``: interface quasi-Newton with a multi-vector Jacobian kept across windows (Lindner et al. 2015).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

import numpy as np

from cosim.schema import Choice, Positive, Value
from coupler.accelerations.base import ACCELERATIONS, FILTERS, MAP_CHANGES, RELAXATION, Acceleration
from coupler.accelerations.preconditioners import PRECONDITIONERS, Preconditioner
from coupler.linalg import QR, column_norms, norm


@ACCELERATIONS.register("iqn-ils")
class IQNILS(Acceleration):
    """Interface quasi-Newton, inverse Jacobian by least squares (IQN-ILS), as preCICE does it.

    Columns (V: residual differences, W: differences of H(x)) are kept newest first, per
    window. ``reused_time_windows = 0`` keeps the previous window's columns for the first
    update of the next window only (better than a relaxation step), then drops them; ``k > 0``
    keeps the columns of the last k windows. The total is capped at ``max_used_iterations``
    (and at the number of unknowns) by deleting the oldest columns for good. Before each solve
    a column whose part orthogonal to the newer ones is at round-off is dropped, then the
    filter (QR1: |R_ii| < limit ||R||_F, QR1-absolute: |R_ii| < limit, QR2: |R_ii| < limit ||v_i||)
    removes nearly dependent columns one at a time, never the only one. Reused columns that go
    stale (the map changed, as when the tube's wall switches branch) are dropped: when a window's
    first update built on them is longer than ``stale_step_ratio`` residuals (it is then not
    taken), or when an update makes the residual worse. (A looser test of the residual, a
    doubling, lets the tube's amplitude x4 stall in some windows; this one costs iterations where
    residuals jump without the map changing, as in the stiffest corner of the stability matrix.)
    """

    ROUNDOFF = 1e3 * np.finfo(float).eps

    SETTINGS = {"initial_relaxation": RELAXATION, "max_used_iterations": Positive(50),
                "reused_time_windows": Value(0, low=0), "filter": Choice("qr2", FILTERS),
                "filter_limit": Value(1e-3, low=0.0, high=1.0, low_open=True, high_open=True),
                "stale_step_ratio": Value(2.0, low=0.0),
                "on_map_change": Choice("drop-span", MAP_CHANGES),
                "preconditioner": Choice("value", PRECONDITIONERS), "freeze_after": Value(0, low=0),
                "count_emptied_windows": True}
    HELP = {
        "initial_relaxation": "the relaxation of a window's first update, before any column exists",
        "max_used_iterations": "the most columns (differences of iterates) the least squares keeps",
        "reused_time_windows": "the earlier windows whose columns are reused",
        "filter": "how columns that make the least squares ill-conditioned are dropped: QR1 (relative), QR1 "
                  "(absolute), QR2, or none",
        "filter_limit": "the filter's limit",
        "stale_step_ratio": "reused columns go stale (the map changed): they are dropped when a window's first "
                            "update, built on them, is longer than this many residuals, or when an update makes "
                            "the residual worse (0: never)",
        "on_map_change": "a participant's backend changed (ROM and solid FOM): 'drop-span' drops the difference "
                         "that spans the change, 'drop-all' every column too",
        "preconditioner": "with several data items, the weight of each in the least squares: one over the norm of "
                          "its values at the window's start ('value'), none ('constant'), one over its residual's "
                          "norm ('residual') or over the sum of its residual's shares in the window ('residual-sum'; "
                          "after the first window replaced when a weight changes by an order of magnitude)",
        "freeze_after": "the weights stay those of this window from then on (0: never)",
        "count_emptied_windows": "an earlier window whose columns the filter or max_used_iterations all removed "
                                 "still counts among reused_time_windows (false: it is dropped, so the windows "
                                 "reused are those with columns, as preCICE's IQN-ILS)",
    }

    def __init__(self, initial_relaxation: float, max_used_iterations: int = 50, reused_time_windows: int = 0,
                 filter: str = "qr2", filter_limit: float = 1e-3, stale_step_ratio: float = 2.0,
                 on_map_change: str = "drop-span", preconditioner: str = "value", freeze_after: int = 0,
                 count_emptied_windows: bool = True, block_sizes: list[int] | None = None) -> None:
        super().__init__()
        if filter not in FILTERS:
            raise ValueError(f"filter {filter!r} not in {FILTERS}")
        if on_map_change not in MAP_CHANGES:
            raise ValueError(f"on_map_change {on_map_change!r} not in {MAP_CHANGES}")
        self.on_map_change = on_map_change
        self.initial = initial_relaxation
        self.max_columns = max_used_iterations
        self.reused = reused_time_windows
        self.count_emptied_windows = count_emptied_windows
        self.filter, self.limit = filter, filter_limit
        self.block_sizes = block_sizes
        # columns per window, newest window first; each window's columns newest first
        self._windows: deque[tuple[list[np.ndarray], list[np.ndarray]]] = deque()
        self._drop_previous = False   # reuse 0: the previous window's columns go after the first update
        self._r_previous: np.ndarray | None = None
        self._xt_previous: np.ndarray | None = None
        self.preconditioner = Preconditioner(preconditioner, block_sizes, freeze_after)
        self._weights: np.ndarray | None = None
        self.columns_used = 0
        self.columns_filtered = 0
        self.columns_dropped = 0    # for max_used_iterations, the windows reused, or a stale regime
        self.stale_step_ratio = stale_step_ratio
        self.stale_windows = 0
        self.maps_changed = 0
        self._last_norm = 0.0

    def start_window(self) -> None:
        super().start_window()
        self._windows.appendleft(([], []))
        self._drop_previous = self.reused == 0 and len(self._windows) > 1
        self._r_previous = self._xt_previous = None
        self.preconditioner.start_window()

    def observe(self, x: np.ndarray, x_tilde: np.ndarray) -> None:
        super().observe(x, x_tilde)
        r = x_tilde - x
        if self._r_previous is not None or any(V for V, _ in self._windows):
            self._weights = self.preconditioner.update(x_tilde, r)
        size = norm(r)
        if self.iteration > 1 and self.stale_step_ratio > 0 and size > self._last_norm:
            self._forget_old_windows()   # an update built on reused columns made the residual worse
        self._last_norm = size
        if self._r_previous is not None:
            V, W = self._windows[0]
            V.insert(0, r - self._r_previous)
            W.insert(0, x_tilde - self._xt_previous)
            self._cap(min(self.max_columns, x.size))
        self._r_previous, self._xt_previous = r, x_tilde.copy()

    def column_counts(self) -> tuple[int, int, int]:
        """The columns held now, and those the filter deleted and those dropped so far (preCICE's QNColumns,
        DeletedQNColumns and DroppedQNColumns, the last two summed over the run)."""
        return sum(len(V) for V, _ in self._windows), self.columns_filtered, self.columns_dropped

    def regrid(self, transform: Callable[[np.ndarray], np.ndarray], block_sizes: list[int]) -> None:
        """Every column (of this window and the reused ones) resampled; no column spans the change."""
        super().regrid(transform, block_sizes)
        for V, W in self._windows:
            V[:] = [transform(v) for v in V]
            W[:] = [transform(w) for w in W]
        self._r_previous = self._xt_previous = None
        self.preconditioner.regrid(block_sizes)
        self._cap(min(self.max_columns, sum(block_sizes)))     # no more columns than unknowns

    def _cap(self, limit: int) -> None:
        """Delete the oldest columns beyond ``limit``."""
        excess = sum(len(V) for V, _ in self._windows) - limit
        for V, W in reversed(self._windows):
            while excess > 0 and V:
                V.pop()
                W.pop()
                excess -= 1
                self.columns_dropped += 1
        self._drop_emptied()

    def _drop_emptied(self) -> None:
        """Earlier windows left without columns go, unless they count among the reused ones."""
        if not self.count_emptied_windows:
            current, *earlier = self._windows
            self._windows = deque([current, *(window for window in earlier if window[0])])

    def _columns(self) -> tuple[list[np.ndarray], list[np.ndarray], list[tuple[int, int]]]:
        """All columns newest first, and where each is kept (window, index)."""
        V, W, origin = [], [], []
        for w, (window_V, window_W) in enumerate(self._windows):
            V += window_V
            W += window_W
            origin += [(w, j) for j in range(len(window_V))]
        return V, W, origin

    def _remove(self, where: tuple[int, int]) -> None:
        window, j = where
        V, W = self._windows[window]
        del V[j], W[j]
        self.columns_filtered += 1
        self._drop_emptied()

    def next_iterate(self) -> np.ndarray:
        r = self.x_tilde - self.x
        proposal = None
        while proposal is None:
            fit = self._secant_fit(r)
            if fit is None:
                proposal = self.x + self.initial * r
                break
            c, _, W = fit
            proposal = self.x_tilde + W @ c
            if self._stale(proposal, r):
                self._forget_old_windows()
                proposal = None
        if self._drop_previous:
            while len(self._windows) > 1:
                self.columns_dropped += len(self._windows.pop()[0])
            self._drop_previous = False
        return proposal

    def _secant_fit(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """c minimising ||V c + r|| (weighted per block) over the columns left by the filters, and V and W as
        matrices; None when there is no column."""
        kept = self._filtered(weighted=True)
        if kept is None:
            return None
        qr, Vm, Wm = kept
        rhs = -(qr.Q.T @ (r if self._weights is None else r * self._weights))
        return qr.solve(rhs), Vm, Wm

    def _filtered(self, weighted: bool) -> tuple[QR, np.ndarray, np.ndarray] | None:
        """The QR factorisation of V (its rows weighted per block if ``weighted``), V and W as matrices, over
        the columns left once the filters dropped theirs (for good, one at a time); None when none is left."""
        V, W, origin = self._columns()
        Vm = np.stack(V, axis=1) if V else None
        while Vm is not None:
            scaled = Vm if not weighted or self._weights is None else Vm * self._weights[:, None]
            qr = QR(scaled)
            bad = self._filtered_column(qr, scaled)
            if bad is None:
                self.columns_used = len(W)
                return qr, Vm, np.stack(W, axis=1)
            self._remove(origin[bad])
            V, W, origin = self._columns()        # the removal may have dropped an emptied window
            Vm = np.stack(V, axis=1) if V else None
        self.columns_used = 0
        return None

    def _forget_old_windows(self) -> None:
        """The columns of earlier windows describe another regime (the wall switched branch, say): drop them."""
        if len(self._windows) > 1 and any(V for V, _ in list(self._windows)[1:]):
            self.stale_windows += 1
        while len(self._windows) > 1:
            self.columns_dropped += len(self._windows.pop()[0])

    def map_changed(self) -> None:
        """No column spans the change (its difference would mix the two maps' outputs); with
        ``on_map_change = "drop-all"`` every column of the old map goes too, and the next update is a
        relaxation step."""
        self.maps_changed += 1
        self._r_previous = self._xt_previous = None
        if self.on_map_change == "drop-all":
            self._windows = deque([([], [])])
            self._drop_previous = False
            self._last_norm = 0.0

    def _stale(self, proposal: np.ndarray, r: np.ndarray) -> bool:
        """The first update of a window, built on reused columns, that jumps far beyond the residual.

        Columns of earlier windows that no longer describe the map (the wall switched branch of its
        law, say) show as a step many times the residual; the step is then not taken.
        """
        if self.stale_step_ratio <= 0 or self.iteration != 1 or len(self._windows) < 2:
            return False
        if not any(V for V, _ in list(self._windows)[1:]):
            return False
        return norm(proposal - self.x_tilde) > self.stale_step_ratio * norm(r)

    def _filtered_column(self, qr: QR, Vm: np.ndarray) -> int | None:
        """Index of the first column to remove: at round-off, or (with others left) caught by the filter."""
        diagonal = np.abs(qr.diagonal)
        norms = column_norms(Vm)
        bad = diagonal <= self.ROUNDOFF * max(float(norms.max()), np.finfo(float).tiny)
        if len(diagonal) > 1:
            if self.filter == "qr2":
                bad |= diagonal < self.limit * norms
            elif self.filter == "qr1":
                bad |= diagonal < self.limit * norm(qr.R)
            elif self.filter == "qr1-absolute":
                bad |= diagonal < self.limit
        hits = np.flatnonzero(bad)
        return int(hits[0]) if hits.size else None

    def end_window(self) -> None:
        self.preconditioner.end_window()
        keep = max(self.reused, 1)   # reuse 0 keeps the last window for the next window's first update
        while len(self._windows) > keep:
            self.columns_dropped += len(self._windows.pop()[0])


@ACCELERATIONS.register("iqn-imvj")
class IQNIMVJ(IQNILS):
    """Interface quasi-Newton with a multi-vector Jacobian (Lindner et al. 2015), as preCICE's IQN-IMVJ.

    The inverse Jacobian J (mapping residual differences to differences of H) is kept as a
    matrix across windows: within a window J = J_prev + (W - J_prev V) V^+ with the window's
    own columns (filtered as in IQN-ILS), the update is x_tilde - J r, and at the end of the
    window J becomes J_prev. In the first window it is IQN-ILS without reuse.
    ``restart_windows = k > 0`` starts the Jacobian afresh every k windows (preCICE's RS-ZERO
    restart), for maps that drift.
    """

    SETTINGS = {"initial_relaxation": RELAXATION, "max_used_iterations": Positive(50),
                "filter": Choice("qr2", FILTERS),
                "filter_limit": Value(1e-3, low=0.0, high=1.0, low_open=True, high_open=True),
                "restart_windows": Value(0, low=0), "on_map_change": Choice("drop-span", MAP_CHANGES)}
    HELP = {**IQNILS.HELP,
            "max_used_iterations": "the most columns of the current window the Jacobian's update takes",
            "restart_windows": "start the Jacobian afresh every this many windows (0: never; preCICE's RS-ZERO)",
            "on_map_change": "a participant's backend changed: 'drop-span' drops the difference that spans the "
                             "change, 'drop-all' the Jacobian too"}

    def __init__(self, initial_relaxation: float, max_used_iterations: int = 50, filter: str = "qr2",
                 filter_limit: float = 1e-3, restart_windows: int = 0, on_map_change: str = "drop-span",
                 block_sizes: list[int] | None = None) -> None:
        super().__init__(initial_relaxation, max_used_iterations, 1, filter, filter_limit, stale_step_ratio=0.0,
                         on_map_change=on_map_change)
        self.jacobian: np.ndarray | None = None
        self.restart_windows = restart_windows
        self.windows_since_restart = 0

    def _columns(self) -> tuple[list[np.ndarray], list[np.ndarray], list[tuple[int, int]]]:
        V, W = self._windows[0]
        return list(V), list(W), [(0, j) for j in range(len(V))]

    def _update(self, r: np.ndarray) -> np.ndarray | None:
        """J r with this window's columns (filtered), or None when there is neither J_prev nor a column."""
        kept = self._filtered(weighted=False)
        if kept is None:
            return None if self.jacobian is None else self.jacobian @ r
        qr, Vm, Wm = kept
        pinv_r = qr.solve(qr.Q.T @ r)
        if self.jacobian is None:
            return Wm @ pinv_r
        return self.jacobian @ r + (Wm - self.jacobian @ Vm) @ pinv_r

    def map_changed(self) -> None:
        super().map_changed()
        if self.on_map_change == "drop-all":
            self.jacobian, self.windows_since_restart = None, 0

    def regrid(self, transform: Callable[[np.ndarray], np.ndarray], block_sizes: list[int]) -> None:
        """The Jacobian of the old grid starts afresh (as at a restart); the window's columns are resampled."""
        super().regrid(transform, block_sizes)
        self.jacobian, self.windows_since_restart = None, 0

    def next_iterate(self) -> np.ndarray:
        r = self.x_tilde - self.x
        update = self._update(r)
        return self.x + self.initial * r if update is None else self.x_tilde - update

    def end_window(self) -> None:
        V, W, _ = self._columns()
        if V:
            Vm, Wm = np.stack(V, axis=1), np.stack(W, axis=1)
            keep = np.abs(QR(Vm).diagonal) > self.ROUNDOFF * max(float(column_norms(Vm).max()), np.finfo(float).tiny)
            if keep.any():
                Vm, Wm = Vm[:, keep], Wm[:, keep]
                pinv = np.linalg.pinv(Vm)
                previous = self.jacobian if self.jacobian is not None else np.zeros((Wm.shape[0], Vm.shape[0]))
                self.jacobian = previous + (Wm - previous @ Vm) @ pinv
        self._windows.clear()
        self.windows_since_restart += 1
        if self.restart_windows and self.windows_since_restart >= self.restart_windows:
            self.jacobian, self.windows_since_restart = None, 0
