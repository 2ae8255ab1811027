"""Encoders: interface forces to the regressor's reduced, scaled input coordinates."""

from __future__ import annotations

import numpy as np

from cosim.schema import Choice, Value
from rom_component.parts import ENCODERS, Encoder
from rom_component.reduction.pod import centred_pod

SCALINGS = ("global", "standard", "minmax", "none")


class Scaling:
    """Affine input scaling x_s = (x - shift) / scale.

    ``global`` divides every coordinate by one number (the RMS of the first
    coordinate), keeping the POD geometry in which small modes have small ranges;
    ``standard`` and ``minmax`` scale each coordinate on its own, which inflates the
    weakest modes (noise) to the size of the strongest.
    """

    def __init__(self, kind: str):
        if kind not in SCALINGS:
            raise ValueError(f"scaling {kind!r} not in {SCALINGS}")
        self.kind = kind

    def fit(self, X: np.ndarray) -> Scaling:
        r = X.shape[1]
        if self.kind == "none":
            self.shift, self.scale = np.zeros(r), np.ones(r)
        elif self.kind == "global":
            self.shift = np.zeros(r)
            rms = float(np.sqrt(np.mean(X[:, 0] ** 2))) if len(X) else 1.0
            self.scale = np.full(r, rms if rms > 0 else 1.0)
        elif self.kind == "standard":
            self.shift = X.mean(axis=0)
            std = X.std(axis=0)
            self.scale = np.where(std > 0, std, 1.0)
        else:
            lo, hi = X.min(axis=0), X.max(axis=0)
            self.shift = lo
            self.scale = np.where(hi > lo, hi - lo, 1.0)
        return self

    def __call__(self, X: np.ndarray) -> np.ndarray:
        return (X - self.shift) / self.scale


@ENCODERS.register("pod")
class PodEncoder(Encoder):
    """Centred POD of the force snapshots, truncated to ``modes``, then an affine scaling of the coordinates.

    The number of modes is capped by the data (``modes_``: at most m - 1 and the snapshot width).
    """

    SETTINGS = {"modes": Value(3, low=1), "scaling": Choice("global", SCALINGS)}
    HELP = {
        "modes": "r_f, the number of force modes (capped by the data: at most snapshots - 1)",
        "scaling": "'global': every reduced force divided by one number (the first mode's RMS), keeping the POD "
                   "geometry; 'standard' or 'minmax': each on its own, which inflates the weak modes; 'none'",
    }

    def __init__(self, modes: int = 3, scaling: str = "global"):
        self.modes = modes
        self.scaling = scaling

    def fit(self, F: np.ndarray) -> PodEncoder:
        self.modes_ = min(self.modes, len(F) - 1, F.shape[1])
        self.mean_, modes, self.singular_values_ = centred_pod(F)
        self.components_ = modes[:, :self.modes_]
        self.scaling_ = Scaling(self.scaling).fit((F - self.mean_) @ self.components_)
        return self

    def transform(self, F: np.ndarray) -> np.ndarray:
        return self.scaling_((np.atleast_2d(F) - self.mean_) @ self.components_)

    def jacobian(self) -> np.ndarray:
        """E of x = E f - e: the modes divided by the scaling, (r_f, N_f)."""
        return (self.components_ / self.scaling_.scale).T

    def online_arrays(self) -> dict[str, np.ndarray]:
        """E and e of x = E f - e, the mean and modes, and every singular value."""
        scale, shift = self.scaling_.scale, self.scaling_.shift
        return {"E": np.ascontiguousarray((self.components_ / scale).T),
                "e": (self.mean_ @ self.components_ + shift) / scale,
                "f_mean": self.mean_, "Phi_f": self.components_, "force_singular_values": self.singular_values_}
