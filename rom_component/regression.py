"""Regressors from reduced forces to reduced displacements, with input/output scaling.

- ``RbfRegression``: thin-plate-spline RBF with a linear tail (``scipy.interpolate.RBFInterpolator``).
- ``SparseQuadraticRegression``: degree-2 polynomial whose terms are chosen per output by
  a Lasso-LARS path with the BIC (``sklearn.linear_model.LassoLarsIC``).

Both expose ``online_arrays()``: the arrays of the evaluation
u~ = H z with z = [kernel values or quadratic terms, x, 1], in the scaled input space.
"""

from __future__ import annotations

import numpy as np

from rom_component.manifold import quadratic_index, quadratic_terms

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

    def fit(self, X: np.ndarray) -> "Scaling":
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


class RbfRegression:
    """Thin-plate-spline RBF interpolation with a linear polynomial tail."""

    kind = "rbf"

    def __init__(self, smoothing: float = 0.0):
        self.smoothing = smoothing

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "RbfRegression":
        from scipy.interpolate import RBFInterpolator
        _, keep = np.unique(X, axis=0, return_index=True)  # repeated centres make the system singular
        keep.sort()
        X, Y = X[keep], Y[keep]
        self.interpolator = RBFInterpolator(X, Y, kernel="thin_plate_spline", degree=1, smoothing=self.smoothing)
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        return self.interpolator(X)

    def online_arrays(self) -> dict[str, np.ndarray]:
        """Centres and H = [0.5 w_kernel; tail on x; constant]^T for u~ = H [phi(d^2), x, 1]."""
        rbf = self.interpolator
        if rbf.epsilon != 1.0 or rbf.powers.shape[0] != rbf.y.shape[1] + 1:
            raise ValueError("unexpected RBFInterpolator configuration")
        m = rbf.y.shape[0]
        weights = rbf._coeffs[:m]          # kernel weights, (m, r_u)
        tail = rbf._coeffs[m:]             # monomials 1, x_1 .. x_r of (x - shift) / scale
        order = np.argmax(rbf.powers[1:], axis=1)  # which coordinate each linear monomial holds
        linear = np.zeros((rbf.y.shape[1], weights.shape[1]))
        linear[order] = tail[1:] / rbf._scale[order, None]
        constant = tail[0] - (rbf._shift[order] / rbf._scale[order]) @ tail[1:]
        # phi(d) = d^2 log d = 0.5 d^2 log d^2
        H = np.vstack([0.5 * weights, linear, constant[None]]).T
        return {"centres": np.array(rbf.y), "H": np.ascontiguousarray(H)}


class SparseQuadraticRegression:
    """u~_k = c_k + sum over a BIC-selected subset of {x_i, x_i x_j} of the terms."""

    kind = "poly"

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "SparseQuadraticRegression":
        from sklearn.linear_model import LassoLarsIC
        self.n_inputs = X.shape[1]
        features = self.features(X)
        self.feature_mean = features.mean(axis=0)
        self.feature_scale = features.std(axis=0)
        self.feature_scale[self.feature_scale == 0] = 1.0
        Phi = (features - self.feature_mean) / self.feature_scale
        self.y_mean, self.y_scale = Y.mean(axis=0), Y.std(axis=0)
        self.y_scale[self.y_scale == 0] = 1.0
        Ys = (Y - self.y_mean) / self.y_scale
        n_terms = Phi.shape[1]
        noise = None
        if len(X) <= n_terms + 1:  # the BIC needs a noise estimate the data cannot give
            noise = max(float(np.var(Ys)) * 1e-6, 1e-12)
        coefficients = np.zeros((n_terms, Y.shape[1]))
        for k in range(Y.shape[1]):
            model = LassoLarsIC(criterion="bic", fit_intercept=True, noise_variance=noise)
            model.fit(Phi, Ys[:, k])
            coefficients[:, k] = model.coef_
        self.coefficients = coefficients
        self.n_selected = (coefficients != 0).sum(axis=0)
        return self

    @staticmethod
    def features(X: np.ndarray) -> np.ndarray:
        return np.hstack([quadratic_terms(X), X])

    def predict(self, X: np.ndarray) -> np.ndarray:
        Phi = (self.features(X) - self.feature_mean) / self.feature_scale
        return Phi @ self.coefficients * self.y_scale + self.y_mean

    def online_arrays(self) -> dict[str, np.ndarray]:
        """H for u~ = H [q(x), x, 1] with feature and output scaling folded in."""
        C = self.coefficients / self.feature_scale[:, None] * self.y_scale[None, :]
        constant = self.y_mean - self.feature_mean @ C
        H = np.vstack([C, constant[None]]).T
        i, j = quadratic_index(self.n_inputs)
        return {"H": np.ascontiguousarray(H), "quad_i": i, "quad_j": j}


def make_regression(kind: str, smoothing: float = 0.0):
    if kind == "rbf":
        return RbfRegression(smoothing)
    if kind == "poly":
        return SparseQuadraticRegression()
    raise ValueError(f"regressor {kind!r} not in ('rbf', 'poly')")
