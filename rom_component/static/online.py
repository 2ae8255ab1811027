"""The ROM's online stage: arrays only, a fixed short sequence of dense operations.

Interface path of one call (f: interface forces):
    x   = E f - e                       encoder with input scaling folded in (r_f)
    z   = [phi(|x - c_i|^2), x, 1]      RBF kernel values   (regressor "rbf")
        = [q(x), c(x), x, 1]            unique quadratic terms x_i x_j, and cubic terms (x_i x_j) x_k
                                        if the model has them (regressor "poly")
    u~  = H z                           reduced displacements (r_u)
    u_G = base + A u~ [+ B q(u~)]       interface displacements: base = K u_mean,
                                        A = K Phi_u, B = K Phi_bar (quadratic manifold)
All buffers are preallocated; the full field u_mean + Phi_u u~ + Phi_bar q(u~) is
rebuilt only on request (``full_field``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from rom_component.envelope import trust
from rom_component.model_check import REQUIRED
from rom_component.static.portable_log import thin_plate_terms

TINY = 1e-300


ENVELOPE_KEYS = {"envelope_low", "envelope_high", "envelope_mean", "envelope_precision", "envelope_max_distance"}


class OnlineRom:
    """Evaluates a trained ROM from its arrays (see ``rom_component.model_file``).

    ``arithmetic="reproducible"`` (default) fixes the order of every floating-point
    operation so that the C code of the exported FMU gives bit-identical results:
    long dot products are numpy's pairwise row sums (mirrored in ``solid_rom.c``), short
    ones sequential sums, and the kernel uses the FMU's own logarithm
    (``rom_component.static.portable_log``). Results then also depend neither on the BLAS build
    and its threads nor on the platform's libm. ``arithmetic="fast"`` uses BLAS matrix-vector products instead.
    """

    def __init__(self, arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any],
                 arithmetic: str = "reproducible"):
        missing = set(REQUIRED) - set(arrays)
        if missing:      # (a model file's arrays were checked whole when it was read: model_file.load_arrays)
            raise ValueError(f"ROM arrays lack {sorted(missing)}")
        if arithmetic not in ("reproducible", "fast"):
            raise ValueError(f"arithmetic {arithmetic!r} not in ('reproducible', 'fast')")
        self.arithmetic = arithmetic
        self.arrays = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
        self.metadata = dict(metadata)
        a = self.arrays
        self.E, self.e, self.H, self.A, self.base = a["E"], a["e"], a["H"], a["A"], a["base"]
        self.regressor = self.metadata["regressor"]
        self.quadratic_decoder = "B" in a
        self.envelope = {k: a[k] for k in ENVELOPE_KEYS} if ENVELOPE_KEYS <= set(a) else None
        self.n_inputs, self.n_outputs = self.E.shape[1], self.A.shape[0]
        r_f, r_u = self.E.shape[0], self.A.shape[1]
        reproducible = arithmetic == "reproducible"
        if self.regressor == "rbf":
            centres = a["centres"]
            if reproducible:
                self.centres_t = np.ascontiguousarray(centres.T)
            else:
                self.minus_2c = -2.0 * centres
                self.c2 = np.einsum("ij,ij->i", centres, centres)
            m = len(centres)
        else:
            self.qi, self.qj = a["quad_i"], a["quad_j"]
            empty = np.zeros(0, dtype=self.qi.dtype)
            self.ci, self.cj, self.ck = (a.get(f"cube_{n}", empty) for n in "ijk")
            self._m2 = len(self.qi)
            m = self._m2 + len(self.ci)
        if self.H.shape != (r_u, m + r_f + 1):
            raise ValueError(f"ROM array 'H' has shape {self.H.shape}, expected ({r_u}, {m + r_f + 1})")
        self._r_f = r_f
        self._z = np.zeros(m + r_f + 1)
        self._z[-1] = 1.0
        self._kernel = self._z[:m]
        self._x_slot = self._z[m:m + r_f]
        self._d2 = np.empty(m)       # squared distances to the centres (fast: also their log)
        if self.quadratic_decoder:
            self.B = a["B"]
            self.ui, self.uj = np.triu_indices(r_u)
        if reproducible:             # preallocated products and transposed decoder matrices
            self._d = np.empty(m)
            self._E_products = np.empty_like(self.E)
            self._H_products = np.empty_like(self.H)
            self._A_t = np.ascontiguousarray(self.A.T)
            self._A_products = np.empty_like(self._A_t)
            if self.quadratic_decoder:
                self._B_t = np.ascontiguousarray(self.B.T)
                self._B_products = np.empty_like(self._B_t)
        else:
            self._log = np.empty(m)
        self.reduced = np.zeros(r_u)
        self._evaluate = self._reproducible if reproducible else self._fast

    def __call__(self, f: np.ndarray) -> np.ndarray:
        """Interface displacements for interface forces ``f``; sets ``self.reduced``."""
        return self._evaluate(f)

    def _fast(self, f: np.ndarray) -> np.ndarray:
        x = self.E @ f
        x -= self.e
        if self.regressor == "rbf":
            d2 = self.minus_2c @ x
            d2 += self.c2
            d2 += x @ x
            np.maximum(d2, TINY, out=d2)
            np.log(d2, out=self._log)
            np.multiply(d2, self._log, out=self._kernel)
        else:
            self._polynomial_terms(x)
        self._x_slot[:] = x
        reduced = self.H @ self._z
        self.reduced = reduced
        u = self.A @ reduced
        u += self.base
        if self.quadratic_decoder:
            u += self.B @ (reduced[self.ui] * reduced[self.uj])
        return u

    def _reproducible(self, f: np.ndarray) -> np.ndarray:
        x = np.multiply(self.E, f, out=self._E_products).sum(axis=1)   # pairwise row sums
        x -= self.e
        if self.regressor == "rbf":
            d, d2 = self._d, self._d2
            np.subtract(x[0], self.centres_t[0], out=d2)                # |x - c|^2, sequential over r_f
            np.multiply(d2, d2, out=d2)
            for k in range(1, self._r_f):
                np.subtract(x[k], self.centres_t[k], out=d)
                np.multiply(d, d, out=d)
                np.add(d2, d, out=d2)
            self._kernel[:] = thin_plate_terms(d2)                       # d2 log d2, the FMU's own log
        else:
            self._polynomial_terms(x)
        self._x_slot[:] = x
        reduced = np.multiply(self.H, self._z, out=self._H_products).sum(axis=1)
        self.reduced = reduced
        u = np.multiply(self._A_t, reduced[:, None], out=self._A_products).sum(axis=0)  # sequential over r_u
        u += self.base
        if self.quadratic_decoder:
            q = reduced[self.ui] * reduced[self.uj]
            u += np.multiply(self._B_t, q[:, None], out=self._B_products).sum(axis=0)
        return u

    def _polynomial_terms(self, x: np.ndarray) -> None:
        """The products x_i x_j, then the cubic terms (x_i x_j) x_k, into the kernel slot of z."""
        np.multiply(x[self.qi], x[self.qj], out=self._kernel[:self._m2])
        if len(self.ci):
            cubic = self._kernel[self._m2:]
            np.multiply(x[self.ci], x[self.cj], out=cubic)
            np.multiply(cubic, x[self.ck], out=cubic)

    def trust(self) -> tuple[float, float]:
        """(excess, distance) of the last call's reduced force against the training envelope (NaN if none)."""
        if self.envelope is None:
            return math.nan, math.nan
        return trust(np.array(self._x_slot), self.envelope)

    def predict(self, F: np.ndarray) -> np.ndarray:
        """Interface displacements for force rows ``F`` (m, N): one call per row."""
        return np.stack([self(f) for f in np.atleast_2d(F)])

    def full_field(self, reduced: np.ndarray) -> np.ndarray:
        """Full displacement fields u_mean + Phi_u u~ (+ Phi_bar q(u~)) for rows of u~."""
        reduced = np.atleast_2d(reduced)
        U = reduced @ self.arrays["Phi_u"].T + self.arrays["u_mean"]
        if "Phi_bar" in self.arrays:
            i, j = np.triu_indices(reduced.shape[1])
            U += (reduced[:, i] * reduced[:, j]) @ self.arrays["Phi_bar"].T
        return U
