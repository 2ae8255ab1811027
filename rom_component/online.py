"""The ROM's online stage: arrays only, a fixed short sequence of dense operations.

Interface path of one call (f: interface forces):
    x   = E f - e                       encoder with input scaling folded in (r_f)
    z   = [phi(|x - c_i|^2), x, 1]      RBF kernel values   (regressor "rbf")
        = [q(x), x, 1]                  unique quadratic terms (regressor "poly")
    u~  = H z                           reduced displacements (r_u)
    u_G = base + A u~ [+ B q(u~)]       interface displacements: base = K u_mean,
                                        A = K Phi_u, B = K Phi_bar (quadratic manifold)
All buffers are preallocated; the full field u_mean + Phi_u u~ + Phi_bar q(u~) is
rebuilt only on request (``full_field``).
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

TINY = 1e-300
REQUIRED = {"E", "e", "H", "A", "base", "u_mean", "Phi_u"}


class OnlineRom:
    """Evaluates a trained ROM from its arrays (see ``rom_component.persistence``)."""

    def __init__(self, arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any]):
        missing = REQUIRED - set(arrays)
        if missing:
            raise ValueError(f"ROM arrays lack {sorted(missing)}")
        self.arrays = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
        self.metadata = dict(metadata)
        a = self.arrays
        self.E, self.e, self.H, self.A, self.base = a["E"], a["e"], a["H"], a["A"], a["base"]
        self.regressor = self.metadata["regressor"]
        self.quadratic_decoder = "B" in a
        self.n_inputs, self.n_outputs = self.E.shape[1], self.A.shape[0]
        r_f, r_u = self.E.shape[0], self.A.shape[1]
        if self.regressor == "rbf":
            centres = a["centres"]
            self.minus_2c = -2.0 * centres
            self.c2 = np.einsum("ij,ij->i", centres, centres)
            m = len(centres)
        else:
            self.qi, self.qj = a["quad_i"], a["quad_j"]
            m = len(self.qi)
        if self.H.shape != (r_u, m + r_f + 1):
            raise ValueError(f"ROM array 'H' has shape {self.H.shape}, expected ({r_u}, {m + r_f + 1})")
        self._m, self._r_f = m, r_f
        self._z = np.zeros(m + r_f + 1)
        self._z[-1] = 1.0
        self._kernel = self._z[:m]
        self._x_slot = self._z[m:m + r_f]
        self._log = np.empty(m)
        if self.quadratic_decoder:
            self.B = a["B"]
            self.ui, self.uj = np.triu_indices(r_u)
        self.reduced = np.zeros(r_u)

    def __call__(self, f: np.ndarray) -> np.ndarray:
        """Interface displacements for interface forces ``f``; sets ``self.reduced``."""
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
            np.multiply(x[self.qi], x[self.qj], out=self._kernel)
        self._x_slot[:] = x
        reduced = self.H @ self._z
        self.reduced = reduced
        u = self.A @ reduced
        u += self.base
        if self.quadratic_decoder:
            u += self.B @ (reduced[self.ui] * reduced[self.uj])
        return u

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
