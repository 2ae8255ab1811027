"""The step-map ROM's online path in NumPy, with its history (``rom_component.dynamic.model``).

``evaluate(f)`` is a window's call from the history, which it leaves as it is; ``commit()`` moves the
window's last call into the history; ``take_over`` builds a history from a full-order run's converged
windows. ``arithmetic="reproducible"`` runs every sum in the order of the C code (``native/step_map_rom.c``):
long dot products as NumPy's pairwise row sums, the decoder as a sum over the reduced coordinates in order,
so the FMU and the in-process C path (``rom_component.dynamic.compiled.CompiledStepMap``) give the same bits;
``"fast"`` uses BLAS products.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from rom_component.dynamic.compiled import rest_history


class OnlineStepMap:
    """Arrays of a step-map model file in use; the history at rest until told otherwise."""

    def __init__(self, arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], arithmetic: str = "reproducible"):
        if arithmetic not in ("reproducible", "fast"):
            raise ValueError(f"arithmetic {arithmetic!r} not in ('reproducible', 'fast')")
        self.reproducible = arithmetic == "reproducible"
        a = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
        self.E, self.e, self.W, self.A, self.Q, self.c = a["E"], a["e"], a["W_f"], a["W_z"], a["W_q"], a["c"]
        self.base, self.p0 = a["base"], a["p0"]
        self.At, self.Pt = np.ascontiguousarray(a["A"].T), np.ascontiguousarray(a["P"].T)
        self.Ap = np.ascontiguousarray(np.linalg.pinv(a["A"]))
        self.p, self.k = int(metadata["history"]), int(metadata["quadratic_modes"])
        self.qi, self.qj = np.triu_indices(self.k)
        z_rest, x_rest = rest_history(a)
        self.zh = np.tile(z_rest, (self.p, 1))         # newest first
        self.xh = np.tile(x_rest, (2, 1))
        self.x, self.z = np.zeros(len(self.e)), np.zeros(len(self.c))
        self.u, self.probes = np.zeros(len(self.base)), np.zeros(len(self.p0))

    def _rows(self, M: np.ndarray, v: np.ndarray) -> np.ndarray:
        """M v: NumPy's pairwise row sums of the products (the C code's order), or BLAS."""
        return np.multiply(M, v).sum(axis=1) if self.reproducible else M @ v

    def _columns(self, Mt: np.ndarray, z: np.ndarray, add: np.ndarray) -> np.ndarray:
        """Mt^T z + add: the products summed over the reduced coordinates in order, or BLAS."""
        return np.multiply(Mt, z[:, None]).sum(axis=0) + add if self.reproducible else z @ Mt + add

    def encode(self, f: np.ndarray) -> np.ndarray:
        return self._rows(self.E, f) - self.e

    def evaluate(self, f: np.ndarray) -> None:
        """A window's call from the history: ``x``, ``z``, ``u`` and ``probes``."""
        x = self.encode(f)
        s = (x + 2.0 * self.xh[0]) + self.xh[1]
        z = self._rows(self.W, s) + self._rows(self.A, self.zh.ravel())
        z += self.c
        if self.k:
            last = self.zh[0]
            z += self._rows(self.Q, last[self.qi] * last[self.qj])
        self.x, self.z = x, z
        self.u = self._columns(self.At, z, self.base)
        self.probes = self._columns(self.Pt, z, self.p0) if len(self.p0) else self.probes

    def commit(self) -> None:
        """The last call's z and x join the history."""
        self.zh = np.vstack([self.z, self.zh[:-1]])
        self.xh = np.vstack([self.x, self.xh[:-1]])

    def history(self) -> tuple[np.ndarray, np.ndarray]:
        return self.zh.copy(), self.xh.copy()

    def set_history(self, zh: np.ndarray, xh: np.ndarray) -> None:
        self.zh, self.xh = np.array(zh, dtype=np.float64), np.array(xh, dtype=np.float64)

    def take_over(self, forces: np.ndarray, displacements: np.ndarray) -> None:
        """Forces (n, N_f) and interface displacements (n, N_u) of converged windows, oldest first, each encoded or
        projected (z = A^+ (u - base)) and committed in turn."""
        for f, u in zip(forces, displacements):
            self.x = self.encode(f)
            self.z = self._rows(self.Ap, u - self.base)
            self.commit()

    def close(self) -> None:
        """Nothing to free (the compiled path's counterpart frees its C instance)."""
