"""Regressors from reduced forces to reduced displacements, with input/output scaling.

- ``RbfRegression``: thin-plate-spline RBF with a linear tail (the system of
  ``scipy.interpolate.RBFInterpolator``, solved here so that its weights are ours to export).
- ``SparseQuadraticRegression``: degree-2 polynomial (optionally with the cubic terms of the leading
  ``cubic_modes`` inputs) whose terms are chosen per output by a Lasso-LARS path with the BIC
  (``sklearn.linear_model.LassoLarsIC``), or fitted on all its terms by ridge regression with the
  penalty cross-validated over whole windows (``fit = "ridge"``).

Both expose ``online_arrays()``: the arrays of the evaluation
u~ = H z with z = [kernel values or polynomial terms, x, 1], in the scaled input space.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist
from scipy.special import xlogy

from rom_component.manifold import quadratic_index

SCALINGS = ("global", "standard", "minmax", "none")
REGRESSORS = ("rbf", "poly")
POLY_FITS = ("lasso-bic", "ridge")
# ridge penalties tried, per snapshot, with the terms scaled as for the Lasso: from a mere conditioning of the
# normal equations to a damping of every term weaker than a thousandth of the strongest
RIDGE_PENALTIES = np.logspace(-12, -6, 13)


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


def thin_plate_kernel(d2: np.ndarray) -> np.ndarray:
    """phi(r) = r^2 log r written in the squared distance: 0.5 d2 log d2 (0 at d2 = 0)."""
    return 0.5 * xlogy(d2, d2)


class RbfRegression:
    """Thin-plate-spline RBF interpolation with a linear polynomial tail.

    Solves the symmetric saddle-point system [[K + s I, P], [P^T, 0]] [w; c] = [Y; 0] with
    K_ij = phi(|x_i - x_j|), P = [1, x] (the system ``scipy.interpolate.RBFInterpolator``
    solves for ``kernel="thin_plate_spline", degree=1``), keeping the weights so the online
    path and the FMU evaluate the same interpolant.
    """

    kind = "rbf"

    def __init__(self, smoothing: float = 0.0):
        self.smoothing = smoothing

    def fit(self, X: np.ndarray, Y: np.ndarray) -> RbfRegression:
        from scipy.linalg import LinAlgError, solve
        _, keep = np.unique(X, axis=0, return_index=True)  # repeated centres make the system singular
        keep.sort()
        X, Y = X[keep], Y[keep]
        m, d = X.shape
        if m < d + 1:
            raise ValueError(f"thin-plate-spline regression on {d} reduced forces needs at least {d + 1} distinct "
                             f"snapshots, got {m}")
        P = np.hstack([np.ones((m, 1)), X])
        lhs = np.zeros((m + d + 1, m + d + 1))
        lhs[:m, :m] = thin_plate_kernel(cdist(X, X, "sqeuclidean"))
        lhs[:m, :m][np.diag_indices(m)] += self.smoothing
        lhs[:m, m:] = P
        lhs[m:, :m] = P.T
        rhs = np.vstack([Y, np.zeros((d + 1, Y.shape[1]))])
        try:
            coefficients = solve(lhs, rhs, assume_a="sym")
        except LinAlgError:
            raise ValueError(f"the {m} reduced force vectors are affinely dependent (they lie on a hyperplane "
                             f"of their {d}-dimensional space): the thin-plate-spline system is singular") from None
        self.centres = X
        self.weights, self.tail = coefficients[:m], coefficients[m:]
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        kernel = thin_plate_kernel(cdist(X, self.centres, "sqeuclidean"))
        return kernel @ self.weights + self.tail[0] + X @ self.tail[1:]

    def online_arrays(self) -> dict[str, np.ndarray]:
        """Centres and H = [0.5 w; tail on x; constant]^T for u~ = H [d2 log d2, x, 1]."""
        H = np.vstack([0.5 * self.weights, self.tail[1:], self.tail[:1]]).T
        return {"centres": self.centres.copy(), "H": np.ascontiguousarray(H)}


class SparseQuadraticRegression:
    """u~_k = c_k + sum over a subset of {x_i, x_i x_j} of the terms.

    ``quadratic_modes`` = q limits the products to the leading q reduced forces (i, j < q; default: all):
    the response stays linear in the weaker modes, which matters once the coupling drives the inputs
    beyond the training data (a product of two weak modes grows fast outside their small range).
    ``cross_modes`` = c adds the products of the leading c reduced forces with every reduced force: the
    response to a weak mode then depends on the state of the leading ones (a geometrically nonlinear
    solid's compliance depends on its deformation), still linear in the weak modes for a given state.
    ``fit``: "lasso-bic" chooses the terms per output (the paper's sparse polynomial); "ridge" keeps every
    term, one least-squares fit of all outputs with a ridge penalty chosen by 5-fold cross-validation
    (over whole windows when the windows are given).
    """

    kind = "poly"

    def __init__(self, quadratic_modes: int = 0, feature_scaling: str = "standard", cross_modes: int = 0,
                 fit: str = "lasso-bic", cubic_modes: int = 0):
        if feature_scaling not in ("standard", "global"):
            raise ValueError(f"feature scaling {feature_scaling!r} not in ('standard', 'global')")
        if fit not in POLY_FITS:
            raise ValueError(f"poly fit {fit!r} not in {POLY_FITS}")
        self.quadratic_modes = quadratic_modes
        self.feature_scaling = feature_scaling
        self.cross_modes = cross_modes
        self.fit_method = fit
        self.cubic_modes = cubic_modes

    def fit(self, X: np.ndarray, Y: np.ndarray, groups: np.ndarray | None = None) -> SparseQuadraticRegression:
        """Least squares on the rows (X, Y); ``groups``: the window of each row (ridge's cross-validation)."""
        from sklearn.linear_model import LassoLarsIC
        self.n_inputs = X.shape[1]
        self.quad_i, self.quad_j = product_index(self.n_inputs, self.quadratic_modes, self.cross_modes)
        self.cube_i, self.cube_j, self.cube_k = cubic_index(self.n_inputs, self.cubic_modes)
        n_products = len(self.quad_i) + len(self.cube_i)
        features = self.features(X)
        self.feature_mean = features.mean(axis=0)
        self.feature_scale = features.std(axis=0)
        self.feature_scale[self.feature_scale == 0] = 1.0
        if self.feature_scaling == "global":
            # one scale for every term (that of the strongest linear term): the Lasso then weighs a weak
            # mode's term by its size, instead of inflating it to the strongest one's
            self.feature_scale = np.full_like(self.feature_scale, self.feature_scale[n_products])
        Phi = (features - self.feature_mean) / self.feature_scale
        self.y_mean, self.y_scale = Y.mean(axis=0), Y.std(axis=0)
        self.y_scale[self.y_scale == 0] = 1.0
        Ys = (Y - self.y_mean) / self.y_scale
        n_terms = Phi.shape[1]
        noise = None
        if len(X) <= n_terms + 1:  # the BIC needs a noise estimate the data cannot give
            noise = max(float(np.var(Ys)) * 1e-6, 1e-12)
        coefficients = np.zeros((n_terms, Y.shape[1]))
        self.ridge_penalty: float | None = None
        if self.fit_method == "ridge":
            coefficients = self._ridge(Phi, Ys, groups)
        else:
            for k in range(Y.shape[1]):
                model = LassoLarsIC(criterion="bic", fit_intercept=True, noise_variance=noise)
                model.fit(Phi, Ys[:, k])
                coefficients[:, k] = model.coef_
        self.coefficients = coefficients
        self.n_selected = (coefficients != 0).sum(axis=0)
        return self

    def _ridge(self, Phi: np.ndarray, Ys: np.ndarray, groups: np.ndarray | None) -> np.ndarray:
        """Coefficients (terms, outputs) of the ridge fit whose penalty has the least cross-validated error."""
        from sklearn.linear_model import Ridge
        from sklearn.model_selection import GridSearchCV, GroupKFold, KFold
        m = len(Phi)
        folds = min(5, m if groups is None else len(np.unique(groups)))
        if folds < 2:
            unit = "snapshots" if groups is None else "windows"
            raise ValueError(f"the ridge fit cross-validates over at least 2 {unit}, got {folds}")
        cv = GroupKFold(folds) if groups is not None else KFold(folds, shuffle=True, random_state=0)
        search = GridSearchCV(Ridge(fit_intercept=False, solver="cholesky"), {"alpha": m * RIDGE_PENALTIES},
                              cv=cv, scoring="neg_mean_squared_error")
        search.fit(Phi, Ys, groups=groups)     # Phi and Ys are centred: no intercept to fit
        self.ridge_penalty = float(search.best_params_["alpha"] / m)
        return np.array(search.best_estimator_.coef_, dtype=np.float64).reshape(Ys.shape[1], -1).T

    def features(self, X: np.ndarray) -> np.ndarray:
        """[x_i x_j, (x_i x_j) x_k, x]: the products, the cubic terms (none unless cubic_modes), the inputs."""
        cubic = X[:, self.cube_i] * X[:, self.cube_j] * X[:, self.cube_k]
        return np.hstack([X[:, self.quad_i] * X[:, self.quad_j], cubic, X])

    def predict(self, X: np.ndarray) -> np.ndarray:
        Phi = (self.features(X) - self.feature_mean) / self.feature_scale
        return Phi @ self.coefficients * self.y_scale + self.y_mean

    def online_arrays(self) -> dict[str, np.ndarray]:
        """H for u~ = H [q(x), x, 1] with feature and output scaling folded in."""
        C = self.coefficients / self.feature_scale[:, None] * self.y_scale[None, :]
        constant = self.y_mean - self.feature_mean @ C
        H = np.vstack([C, constant[None]]).T
        arrays = {"H": np.ascontiguousarray(H), "quad_i": self.quad_i, "quad_j": self.quad_j}
        if len(self.cube_i):        # a degree-2 model's arrays stay those of the format without cubic terms
            arrays.update(cube_i=self.cube_i, cube_j=self.cube_j, cube_k=self.cube_k)
        return arrays


def product_index(n: int, quadratic_modes: int = 0, cross_modes: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i <= j) of the products x_i x_j of n inputs: both among the leading ``quadratic_modes``
    (0: all n), or one among the leading ``cross_modes``; in the order of ``np.triu_indices``."""
    q = n if quadratic_modes <= 0 else min(quadratic_modes, n)
    i, j = quadratic_index(n)
    keep = (j < q) | (i < cross_modes)
    return i[keep], j[keep]


def cubic_index(n: int, cubic_modes: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index triples (i <= j <= k) of the cubic terms x_i x_j x_k of n inputs whose two lower indices are among
    the leading ``cubic_modes`` (0: none): the cubes and squares of the leading modes, and their pairwise products
    times every input; in lexicographic order."""
    c = min(max(cubic_modes, 0), n)
    i, j = np.triu_indices(c)
    counts = n - j
    k = np.concatenate([np.arange(b, n) for b in j]) if c else np.zeros(0, dtype=np.intp)
    return np.repeat(i, counts), np.repeat(j, counts), k


def make_regression(kind: str, smoothing: float = 0.0, quadratic_modes: int = 0, feature_scaling: str = "standard",
                    cross_modes: int = 0, poly_fit: str = "lasso-bic", cubic_modes: int = 0):
    if kind == "rbf":
        return RbfRegression(smoothing)
    if kind == "poly":
        return SparseQuadraticRegression(quadratic_modes, feature_scaling, cross_modes, poly_fit, cubic_modes)
    raise ValueError(f"regressor {kind!r} not in {REGRESSORS}")
