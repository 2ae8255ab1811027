"""The coupler's small linear algebra, bit for bit as NumPy and SciPy compute it, without their wrappers' cost:
the QR factorisation and triangular solve of the quasi-Newton accelerations (``numpy.linalg.qr``, reduced;
``scipy.linalg.solve_triangular``), the small solves of the RBF mappings' polynomial (``numpy.linalg.solve``) and the 2-norms of the measures and residuals (``numpy.linalg.norm``).

The coupled runs amplify a difference in the last bit until an iteration count changes, so the arithmetic is
theirs exactly. An acceleration refactorises a matrix of some tens of columns at every coupling iteration, and again after each
column its filter drops; the wrappers' checks, copies and dispatch took as long as LAPACK itself. Here the same
LAPACK routines run on the same operands (NumPy's ``qr_r_raw`` and ``qr_reduced`` gufuncs, SciPy's ``dtrtrs``
with the arguments ``solve_triangular`` passes), and a filter that only needs R does not form Q. Where NumPy no
longer has those gufuncs, ``numpy.linalg.qr`` serves.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

_FACTOR: Any = None
_Q: Any = None
_SOLVE: Any = None
_LAPACK: Any = None
try:
    from numpy.linalg import _umath_linalg
    _FACTOR, _Q = _umath_linalg.qr_r_raw, _umath_linalg.qr_reduced
    _SOLVE = (_umath_linalg.solve1, _umath_linalg.solve)
except (ImportError, AttributeError):     # another NumPy: its public qr and solve, the same arithmetic
    pass


class QR:
    """The reduced QR factorisation of a real matrix (m x n): R's diagonal at once, R and Q when asked for."""

    def __init__(self, matrix: np.ndarray):
        self._q: np.ndarray | None = None
        self._r: np.ndarray | None = None
        self.diagonal: np.ndarray
        if _FACTOR is None:
            self._q, self._r = np.linalg.qr(matrix)
            self.diagonal = np.diagonal(self._r).copy()
            return
        self._raw = matrix.astype(np.float64, copy=True)      # overwritten by the Householder form
        self._tau = _FACTOR(self._raw, signature="d->d")
        self.diagonal = np.diagonal(self._raw).copy()

    @property
    def R(self) -> np.ndarray:
        if self._r is None:
            self._r = np.triu(self._raw[:min(self._raw.shape), :])
        return self._r

    @property
    def Q(self) -> np.ndarray:
        if self._q is None:
            self._q = _Q(self._raw, self._tau, signature="dd->d")
        return self._q

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with R x = b, as ``solve_upper(self.R, b)`` (LAPACK reads R's upper triangle only)."""
        n = self._raw.shape[1] if self._r is None else 0
        if n and n <= self._raw.shape[0] and self._raw.flags.c_contiguous:    # R's rows, as C-ordered as triu's R
            return solve_upper(self._raw[:n], b)
        return solve_upper(self.R, b)


def solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with a x = b for a real square ``a``, as ``numpy.linalg.solve(a, b)`` computes it (its gufunc; a singular
    ``a`` raises ``LinAlgError`` as NumPy's does)."""
    if _SOLVE is None:
        return np.linalg.solve(a, b)
    x = (_SOLVE[0] if b.ndim == 1 else _SOLVE[1])(a, b, signature="dd->d")
    if not np.isfinite(x).all():        # singular, or operands not finite: NumPy's own call says which
        return np.linalg.solve(a, b)
    return x


def norm(x: np.ndarray) -> float:
    """The 2-norm (Frobenius for a matrix) as ``numpy.linalg.norm(x)`` computes it for a real array."""
    flat = x.ravel(order="K")
    return math.sqrt(flat.dot(flat))


def column_norms(matrix: np.ndarray) -> np.ndarray:
    """Each column's 2-norm, as ``numpy.linalg.norm(matrix, axis=0)`` computes them for a real matrix."""
    return np.sqrt(np.add.reduce(matrix * matrix, axis=0))


def load() -> Any:
    """SciPy's LAPACK, imported on first use (a run imports it while its components start)."""
    global _LAPACK
    if _LAPACK is None:
        from scipy.linalg import lapack
        _LAPACK = lapack
    return _LAPACK


def solve_upper(R: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with R x = b for an upper triangular R, as ``scipy.linalg.solve_triangular(R, b)``."""
    lapack = _LAPACK or load()
    if R.flags.f_contiguous:
        x, info = lapack.dtrtrs(R, b)
    else:                           # the transposed system, as solve_triangular solves a C-ordered matrix's
        x, info = lapack.dtrtrs(R.T, b, lower=1, trans=1)
    if info > 0:
        raise np.linalg.LinAlgError(f"singular matrix: resolution failed at diagonal {info - 1}")
    return x
