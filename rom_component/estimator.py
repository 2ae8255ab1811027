"""The solid ROM as a scikit-learn estimator: ``fit(F, U)``, ``predict(F)``.

Snapshots are rows (scikit-learn convention): F (m, N) interface forces, U (m, N_u)
displacements. Encoder: centred POD of F with ``n_force_modes`` modes. Decoder:
centred POD of U with ``n_disp_modes`` modes, linear or with a quadratic manifold.
Regression from scaled reduced forces to reduced displacements: thin-plate-spline
RBF, or a BIC-sparse quadratic polynomial (or one fitted on all its terms by cross-validated ridge,
``poly_fit = "ridge"``, the windows of the snapshots grouping its cross-validation).
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from rom_component.envelope import fit_envelope
from rom_component.manifold import fit_quadratic_manifold, quadratic_terms
from rom_component.online import OnlineRom
from rom_component.pod import centred_pod
from rom_component.regression import POLY_FITS, REGRESSORS, Scaling, make_regression


class SolidRom(RegressorMixin, BaseEstimator):
    """POD - regression - POD (optionally quadratic-manifold) reduced model of a solid.

    ``fit(X, y)``: X the force snapshots (m, N), y the displacements (m, N_u) or (m,).
    The numbers of modes are capped by what the data hold (``n_force_modes_``,
    ``n_disp_modes_`` are the ones used): at most m - 1 and at most the width of X or y.
    """

    def __init__(self, n_force_modes: int = 3, n_disp_modes: int = 9, decoder: str = "linear",
                 regressor: str = "rbf", input_scaling: str = "global", manifold_regularization: float = 1e-6,
                 rbf_smoothing: float = 0.0, quadratic_modes: int = 0, feature_scaling: str = "standard",
                 cross_modes: int = 0, poly_fit: str = "lasso-bic", cubic_modes: int = 0):
        self.n_force_modes = n_force_modes
        self.n_disp_modes = n_disp_modes
        self.decoder = decoder
        self.regressor = regressor
        self.input_scaling = input_scaling
        self.manifold_regularization = manifold_regularization
        self.rbf_smoothing = rbf_smoothing
        self.quadratic_modes = quadratic_modes
        self.feature_scaling = feature_scaling
        self.cross_modes = cross_modes
        self.poly_fit = poly_fit
        self.cubic_modes = cubic_modes

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True     # displacement fields: many outputs per snapshot
        tags.target_tags.single_output = True
        tags.input_tags.sparse = False
        # the sparse polynomial is a least-squares fit through r_f <= n_features reduced forces, not an
        # interpolant: on check_estimator's 10-feature linear data projected to 3 modes it scores below 0.5
        tags.regressor_tags.poor_score = self.regressor == "poly"
        return tags

    def check_params(self) -> None:
        """Raise ValueError naming the first setting out of its range (fit calls it; cosim train before reading)."""
        for name in ("n_force_modes", "n_disp_modes"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if self.regressor not in REGRESSORS:
            raise ValueError(f"regressor {self.regressor!r} not in {REGRESSORS}")
        if self.decoder not in ("linear", "quadratic"):
            raise ValueError(f"decoder {self.decoder!r} not in ('linear', 'quadratic')")
        for name in ("quadratic_modes", "cross_modes", "cubic_modes"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
                raise ValueError(f"{name} must be an integer >= 0{' (0: all)' * (name == 'quadratic_modes')}, "
                                 f"got {value!r}")
        if self.poly_fit not in POLY_FITS:
            raise ValueError(f"poly_fit {self.poly_fit!r} not in {POLY_FITS}")
        for name in ("manifold_regularization", "rbf_smoothing"):
            value = getattr(self, name)
            if not isinstance(value, numbers.Real) or not np.isfinite(float(value)) or value < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")

    def fit(self, X: np.ndarray, y: np.ndarray, windows: np.ndarray | None = None) -> SolidRom:
        """Fit on force rows ``X`` and displacement rows ``y``; ``windows``: the window of each row, the ridge
        fit's cross-validation groups (without them it cross-validates over snapshots)."""
        self.check_params()
        F, U = validate_data(self, X, y, multi_output=True, y_numeric=True, dtype=np.float64,
                             ensure_min_samples=2)
        self.single_output_ = U.ndim == 1
        U = U[:, None] if self.single_output_ else U
        self.n_force_modes_ = min(self.n_force_modes, len(F) - 1, F.shape[1])
        self.n_disp_modes_ = min(self.n_disp_modes, len(U) - 1, U.shape[1])
        self.f_mean_, modes, self.force_singular_values_ = centred_pod(F)
        self.Phi_f_ = modes[:, :self.n_force_modes_]
        self.u_mean_, modes, self.disp_singular_values_ = centred_pod(U)
        self.Phi_u_ = modes[:, :self.n_disp_modes_]
        Zu = (U - self.u_mean_) @ self.Phi_u_
        self.Phi_bar_ = None
        if self.decoder == "quadratic":
            residual = (U - self.u_mean_) - Zu @ self.Phi_u_.T
            self.Phi_bar_, offset = fit_quadratic_manifold(Zu, residual, self.manifold_regularization)
            self.u_mean_ = self.u_mean_ + offset  # the decoder's reference point
        Zf = (F - self.f_mean_) @ self.Phi_f_
        self.scaling_ = Scaling(self.input_scaling).fit(Zf)
        X = self.scaling_(Zf)
        regression = make_regression(self.regressor, self.rbf_smoothing, self.quadratic_modes, self.feature_scaling,
                                     self.cross_modes, self.poly_fit, self.cubic_modes)
        if self.regressor == "poly":     # the windows group the ridge fit's cross-validation
            self.regression_ = regression.fit(X, Zu, groups=None if windows is None else np.asarray(windows))
        else:
            self.regression_ = regression.fit(X, Zu)
        self.envelope_ = fit_envelope(X)   # where the ROM has seen data (its trust range)
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

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Displacement rows for force rows ``X``."""
        check_is_fitted(self)
        F = validate_data(self, X, reset=False, dtype=np.float64)
        U = self.decode(self.reduced_predict(F))
        return U[:, 0] if self.single_output_ else U

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
        arrays.update(self.envelope_)
        return arrays

    def to_online(self, interface_index: np.ndarray | None = None) -> OnlineRom:
        return OnlineRom(self.online_arrays(interface_index), {"regressor": self.regressor, **self.get_params()})

    @property
    def modes(self) -> tuple[int, int]:
        """(r_f, r_u) used by the fitted model."""
        check_is_fitted(self)
        return self.n_force_modes_, self.n_disp_modes_
