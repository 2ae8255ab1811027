"""The solid ROM as a scikit-learn estimator: ``fit(F, U)``, ``predict(F)``.

Snapshots are rows (scikit-learn convention): F (m, N) interface forces, U (m, N_u)
displacements. Encoder: centred POD of F with ``n_force_modes`` modes. Decoder:
centred POD of U with ``n_disp_modes`` modes, linear or with a quadratic manifold.
Regression from scaled reduced forces to reduced displacements: thin-plate-spline
RBF or a BIC-sparse quadratic polynomial.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin

from rom_component.manifold import fit_quadratic_manifold, quadratic_terms
from rom_component.online import OnlineRom
from rom_component.pod import centred_pod
from rom_component.regression import Scaling, make_regression


class SolidRom(RegressorMixin, BaseEstimator):
    """POD - regression - POD (optionally quadratic-manifold) reduced model of a solid."""

    def __init__(self, n_force_modes: int = 3, n_disp_modes: int = 9, decoder: str = "linear",
                 regressor: str = "rbf", input_scaling: str = "global", manifold_regularization: float = 1e-6,
                 rbf_smoothing: float = 0.0):
        self.n_force_modes = n_force_modes
        self.n_disp_modes = n_disp_modes
        self.decoder = decoder
        self.regressor = regressor
        self.input_scaling = input_scaling
        self.manifold_regularization = manifold_regularization
        self.rbf_smoothing = rbf_smoothing

    def fit(self, F: np.ndarray, U: np.ndarray) -> "SolidRom":
        F, U = _check_rows(F, "F"), _check_rows(U, "U")
        if len(F) != len(U):
            raise ValueError(f"F has {len(F)} snapshots but U has {len(U)}")
        if self.decoder not in ("linear", "quadratic"):
            raise ValueError(f"decoder {self.decoder!r} not in ('linear', 'quadratic')")
        limit = min(len(F) - 1, F.shape[1]), min(len(U) - 1, U.shape[1])
        for name, value, top in (("n_force_modes", self.n_force_modes, limit[0]),
                                 ("n_disp_modes", self.n_disp_modes, limit[1])):
            if not 1 <= value <= top:
                raise ValueError(f"{name} = {value} is outside 1..{top} for {len(F)} snapshots")
        self.f_mean_, modes, self.force_singular_values_ = centred_pod(F)
        self.Phi_f_ = modes[:, :self.n_force_modes]
        self.u_mean_, modes, self.disp_singular_values_ = centred_pod(U)
        self.Phi_u_ = modes[:, :self.n_disp_modes]
        Zu = (U - self.u_mean_) @ self.Phi_u_
        self.Phi_bar_ = None
        if self.decoder == "quadratic":
            residual = (U - self.u_mean_) - Zu @ self.Phi_u_.T
            self.Phi_bar_, offset = fit_quadratic_manifold(Zu, residual, self.manifold_regularization)
            self.u_mean_ = self.u_mean_ + offset  # the decoder's reference point
        Zf = (F - self.f_mean_) @ self.Phi_f_
        self.scaling_ = Scaling(self.input_scaling).fit(Zf)
        self.regression_ = make_regression(self.regressor, self.rbf_smoothing).fit(self.scaling_(Zf), Zu)
        self.n_features_in_ = F.shape[1]
        return self

    def encode(self, F: np.ndarray) -> np.ndarray:
        return self.scaling_((np.atleast_2d(F) - self.f_mean_) @ self.Phi_f_)

    def reduced_predict(self, F: np.ndarray) -> np.ndarray:
        return self.regression_.predict(self.encode(F))

    def decode(self, Zu: np.ndarray) -> np.ndarray:
        U = Zu @ self.Phi_u_.T + self.u_mean_
        if self.Phi_bar_ is not None:
            U += quadratic_terms(Zu) @ self.Phi_bar_.T
        return U

    def predict(self, F: np.ndarray) -> np.ndarray:
        return self.decode(self.reduced_predict(F))

    def online_arrays(self, interface_index: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Arrays of the online interface path; ``interface_index`` selects u_G = K u (default: all)."""
        K = slice(None) if interface_index is None else np.asarray(interface_index)
        scale, shift = self.scaling_.scale, self.scaling_.shift
        arrays = {
            "E": np.ascontiguousarray((self.Phi_f_ / scale).T),
            "e": (self.f_mean_ @ self.Phi_f_ + shift) / scale,
            "A": np.ascontiguousarray(self.Phi_u_[K]),
            "base": self.u_mean_[K].copy(),
            "u_mean": self.u_mean_, "Phi_u": self.Phi_u_,
            "f_mean": self.f_mean_, "Phi_f": self.Phi_f_,
            "force_singular_values": self.force_singular_values_,
            "disp_singular_values": self.disp_singular_values_,
        }
        if self.Phi_bar_ is not None:
            arrays["B"] = np.ascontiguousarray(self.Phi_bar_[K])
            arrays["Phi_bar"] = self.Phi_bar_
        arrays.update(self.regression_.online_arrays())
        return arrays

    def to_online(self, interface_index: np.ndarray | None = None) -> OnlineRom:
        return OnlineRom(self.online_arrays(interface_index), {"regressor": self.regressor, **self.get_params()})


def _check_rows(X: np.ndarray, name: str) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array of snapshot rows, got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return X
