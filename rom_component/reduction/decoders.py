"""Decoders: the regressor's reduced displacement coordinates to the displacement field."""

from __future__ import annotations

import numpy as np

from cosim.schema import Value
from rom_component.parts import DECODERS, Decoder
from rom_component.reduction.manifold import (
    fit_quadratic_manifold,
    product_derivative,
    quadratic_index,
    quadratic_terms,
)
from rom_component.reduction.pod import centred_pod

MODES_HELP = "r_u, the number of displacement modes (capped by the data: at most snapshots - 1)"


@DECODERS.register("linear")
class PodDecoder(Decoder):
    """Centred POD of the displacement snapshots: u = u_mean + Phi u~."""

    SETTINGS = {"modes": Value(9, low=1)}
    HELP = {"modes": MODES_HELP}

    def __init__(self, modes: int = 9):
        self.modes = modes

    def fit_transform(self, U: np.ndarray) -> np.ndarray:
        """Fit on the displacement rows ``U``; their reduced coordinates, the regressor's targets."""
        self.modes_ = min(self.modes, len(U) - 1, U.shape[1])
        self.mean_, modes, self.singular_values_ = centred_pod(U)
        self.components_ = modes[:, :self.modes_]
        return (U - self.mean_) @ self.components_

    def inverse_transform(self, Z: np.ndarray) -> np.ndarray:
        return Z @ self.components_.T + self.mean_

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """The modes Phi: the decoder is affine."""
        return self.components_

    def online_arrays(self, K: slice | np.ndarray = slice(None)) -> dict[str, np.ndarray]:
        """A and base of u_G = base + A u~ on the rows ``K`` (the served output), the full field's mean and modes."""
        return {"A": np.ascontiguousarray(self.components_[K]), "base": self.mean_[K].copy(),
                "u_mean": self.mean_, "Phi_u": self.components_, "disp_singular_values": self.singular_values_}


@DECODERS.register("quadratic")
class QuadraticManifoldDecoder(PodDecoder):
    """u = u_mean + Phi u~ + Phi_bar q(u~): the POD plus a quadratic manifold fitted to its residual
    (``rom_component.reduction.manifold``)."""

    SETTINGS = {"modes": Value(9, low=1), "regularization": Value(1e-6, low=0.0)}
    HELP = {"modes": MODES_HELP,
            "regularization": "the ridge penalty on Phi_bar, relative to the mean diagonal of its Gram matrix"}

    def __init__(self, modes: int = 9, regularization: float = 1e-6):
        self.modes = modes
        self.regularization = regularization

    def fit_transform(self, U: np.ndarray) -> np.ndarray:
        Z = super().fit_transform(U)
        residual = (U - self.mean_) - Z @ self.components_.T
        self.manifold_, offset = fit_quadratic_manifold(Z, residual, self.regularization)
        self.mean_ = self.mean_ + offset          # the decoder's reference point
        return Z

    def inverse_transform(self, Z: np.ndarray) -> np.ndarray:
        return super().inverse_transform(Z) + quadratic_terms(Z) @ self.manifold_.T

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Phi + Phi_bar dq/dz, with d(z_i z_j)/dz = z_j e_i + z_i e_j."""
        return self.components_ + self.manifold_ @ product_derivative(z, *quadratic_index(len(z)))

    def online_arrays(self, K: slice | np.ndarray = slice(None)) -> dict[str, np.ndarray]:
        return {**super().online_arrays(K), "B": np.ascontiguousarray(self.manifold_[K]), "Phi_bar": self.manifold_}
