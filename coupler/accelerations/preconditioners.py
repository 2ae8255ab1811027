"""Preconditioners of the quasi-Newton least squares: a weight per data block, as preCICE's.

With several data items accelerated together (a parallel scheme's forces and displacements), their residuals have
different units and sizes; the least squares and the QR filters then work on each block scaled by a weight.
Each class gives the weights at every iteration (``update``), from the values or the residuals it sees:

- ``value``: one over the norm of each block's values, taken at the window's first iteration;
- ``constant``: no scaling (every weight 1);
- ``residual``: one over the norm of each block's residual at the current iteration;
- ``residual-sum``: one over the sum, over the window's iterations so far, of each block's share of the residual
  (its residual's norm over the whole residual's norm). In the first window the weights follow the sums at every
  iteration; from then on they are replaced only when one of them changes by more than an order of magnitude.

The quasi-Newton methods update the weights at the iterations that have a column to fit (from the first window's
second iteration on), as preCICE's do: its first iteration is a plain relaxation.

``freeze_after = k > 0`` keeps the weights of the k-th window for the rest of the run (preCICE's freeze-after).
A block whose norm is zero keeps its weight (1 at first).
"""

from __future__ import annotations

import numpy as np

from coupler.linalg import norm

PRECONDITIONERS = ("value", "constant", "residual", "residual-sum")


class Preconditioner:
    """The weights of one quasi-Newton acceleration's least squares, per data block."""

    def __init__(self, kind: str, block_sizes: list[int] | None, freeze_after: int = 0) -> None:
        if kind not in PRECONDITIONERS:
            raise ValueError(f"preconditioner {kind!r} not in {PRECONDITIONERS}")
        self.kind = kind
        self.freeze_after = freeze_after
        self.windows = 0
        self.regrid(block_sizes)

    def regrid(self, block_sizes: list[int] | None) -> None:
        """The blocks changed size (a producer's substeps changed): the weights are taken afresh."""
        self.block_sizes = block_sizes
        self.active = len(block_sizes or ()) > 1 and self.kind != "constant"
        self._block_weights = np.ones(len(block_sizes or ()))
        self._sums = np.zeros(len(block_sizes or ()))
        self.weights: np.ndarray | None = None
        self._fresh = True

    @property
    def frozen(self) -> bool:
        return self.freeze_after > 0 and self.windows >= self.freeze_after and self.weights is not None

    def start_window(self) -> None:
        self._sums[:] = 0.0
        self._fresh = True

    def end_window(self) -> None:
        self.windows += 1

    def update(self, x_tilde: np.ndarray, residual: np.ndarray) -> np.ndarray | None:
        """The weights for this iteration's least squares (None: no scaling)."""
        if not self.active or self.frozen:
            return self.weights
        fresh, self._fresh = self._fresh, False
        if self.kind == "value":
            if fresh:
                self._block_weights[:] = 1.0
                self._take(self._norms(x_tilde))
        elif self.kind == "residual":
            self._take(self._norms(residual))
        else:
            norms = self._norms(residual)
            total = float(np.sqrt(np.sum(norms ** 2)))
            if total > 0:
                self._sums += norms / total
                if self.weights is None or self.windows == 0 or self._changed_by_an_order(self._sums):
                    self._take(self._sums)
            elif self.weights is None:
                self._take(np.zeros_like(norms))
        return self.weights

    def _norms(self, vector: np.ndarray) -> np.ndarray:
        ends = np.cumsum([0, *(self.block_sizes or ())])
        return np.array([norm(vector[a:b]) for a, b in zip(ends[:-1], ends[1:])])

    def _changed_by_an_order(self, scales: np.ndarray) -> bool:
        current = 1.0 / self._block_weights
        given = scales > 0
        ratio = scales[given] / current[given]
        return bool(np.any((ratio > 10.0) | (ratio < 0.1)))

    def _take(self, scales: np.ndarray) -> None:
        """Weights one over ``scales`` where they are above zero; a block at zero keeps its weight."""
        given = scales > 0
        self._block_weights[given] = 1.0 / scales[given]
        self.weights = np.repeat(self._block_weights, self.block_sizes or ())
