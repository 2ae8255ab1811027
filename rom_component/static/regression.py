"""Regressors from the encoder's reduced forces to the decoder's reduced displacements (ROM parts).

- ``rbf``, ``RbfRegression``: thin-plate-spline RBF with a linear tail (the system of
  ``scipy.interpolate.RBFInterpolator``, solved here so that its weights are ours to export).
- ``poly``, ``PolynomialRegression``: degree-2 polynomial (optionally with the cubic terms of the leading
  ``cubic_modes`` inputs) whose terms are chosen per output by a Lasso-LARS path with the BIC
  (``sklearn.linear_model.LassoLarsIC``), or fitted on all its terms by ridge regression with the
  penalty cross-validated over whole windows (``method = "ridge"``).

Both expose ``online_arrays()``: the arrays of the evaluation
u~ = H z with z = [kernel values or polynomial terms, x, 1], in the scaled input space.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
from scipy.spatial.distance import cdist
from scipy.special import xlogy

from cosim.schema import Choice, Value
from rom_component.parts import REGRESSORS, Regressor
from rom_component.reduction.manifold import product_derivative, quadratic_index

POLY_METHODS = ("lasso-bic", "ridge")
# ridge penalties tried, per snapshot, with the terms scaled as for the Lasso: from a mere conditioning of the
# normal equations to a damping of every term weaker than a thousandth of the strongest
RIDGE_PENALTIES = np.logspace(-12, -6, 13)


def thin_plate_kernel(d2: np.ndarray) -> np.ndarray:
    """phi(r) = r^2 log r written in the squared distance: 0.5 d2 log d2 (0 at d2 = 0)."""
    return 0.5 * xlogy(d2, d2)


@REGRESSORS.register("rbf")
class RbfRegression(Regressor):
    """Thin-plate-spline RBF interpolation with a linear polynomial tail.

    Solves the symmetric saddle-point system [[K + s I, P], [P^T, 0]] [w; c] = [Y; 0] with
    K_ij = phi(|x_i - x_j|), P = [1, x] (the system ``scipy.interpolate.RBFInterpolator``
    solves for ``kernel="thin_plate_spline", degree=1``), keeping the weights so the online
    path and the FMU evaluate the same interpolant.
    """

    SETTINGS = {"smoothing": Value(0.0, low=0.0)}
    HELP = {"smoothing": "s added to the kernel's diagonal: 0 interpolates; a little smooths between "
                         "near-duplicate sub-iterations"}

    def __init__(self, smoothing: float = 0.0):
        self.smoothing = smoothing

    def fit(self, X: np.ndarray, Y: np.ndarray, groups: np.ndarray | None = None) -> RbfRegression:
        from scipy.linalg import LinAlgError, LinAlgWarning, solve
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
        self.notes_: list[str] = []      # what the fit has to say (cosim train prints it)
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", LinAlgWarning)
                coefficients = solve(lhs, rhs, assume_a="sym")
            for warning in caught:
                if issubclass(warning.category, LinAlgWarning):
                    rcond = re.search(r"rcond\s*=\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)", str(warning.message))
                    self.notes_.append(
                        f"the thin-plate-spline system of {m} snapshots is ill-conditioned (rcond "
                        f"{float(rcond.group(1)) if rcond else float('nan'):.1e}): sub-iterations of one window give "
                        f"nearly equal reduced forces; model.regressor.smoothing > 0 (it is {self.smoothing:g}) "
                        "regularises it, and the training error above says how well it fits")
        except LinAlgError:
            raise ValueError(f"the {m} reduced force vectors are affinely dependent (they lie on a hyperplane "
                             f"of their {d}-dimensional space): the thin-plate-spline system is singular") from None
        self.centres_ = X
        self.weights_, self.tail_ = coefficients[:m], coefficients[m:]
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        kernel = thin_plate_kernel(cdist(X, self.centres_, "sqeuclidean"))
        return kernel @ self.weights_ + self.tail_[0] + X @ self.tail_[1:]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """sum_i w_i (log d2_i + 1) (x - c_i)^T + the linear tail: d/dx of 0.5 d2 log d2 is (log d2 + 1)(x - c)."""
        offsets = x[None, :] - self.centres_
        d2 = np.einsum("ij,ij->i", offsets, offsets)
        slope = np.where(d2 > 0, np.log(np.where(d2 > 0, d2, 1.0)) + 1.0, 0.0)
        return self.weights_.T @ (slope[:, None] * offsets) + self.tail_[1:].T

    def online_arrays(self) -> dict[str, np.ndarray]:
        """Centres and H = [0.5 w; tail on x; constant]^T for u~ = H [d2 log d2, x, 1]."""
        H = np.vstack([0.5 * self.weights_, self.tail_[1:], self.tail_[:1]]).T
        return {"centres": self.centres_.copy(), "H": np.ascontiguousarray(H)}


@REGRESSORS.register("poly")
class PolynomialRegression(Regressor):
    """u~_k = c_k + sum over a subset of {x_i, x_i x_j, x_i x_j x_l} of the terms.

    ``quadratic_modes`` = q limits the products to the leading q reduced forces (i, j < q; default: all):
    the response stays linear in the weaker modes, which matters once the coupling drives the inputs
    beyond the training data (a product of two weak modes grows fast outside their small range).
    ``cross_modes`` = c adds the products of the leading c reduced forces with every reduced force: the
    response to a weak mode then depends on the state of the leading ones (a geometrically nonlinear
    solid's compliance depends on its deformation), still linear in the weak modes for a given state.
    ``method``: "lasso-bic" chooses the terms per output (the paper's sparse polynomial); "ridge" keeps every
    term, one least-squares fit of all outputs with a ridge penalty chosen by 5-fold cross-validation
    (over whole windows when the windows are given).
    """

    SETTINGS = {"method": Choice("lasso-bic", POLY_METHODS), "quadratic_modes": Value(0, low=0),
                "cross_modes": Value(0, low=0), "cubic_modes": Value(0, low=0),
                "term_scaling": Choice("standard", ("standard", "global"))}
    HELP = {
        "method": "'lasso-bic': the terms chosen per output by Lasso-LARS with the BIC (the paper's); 'ridge': "
                  "every term, the penalty cross-validated over whole windows",
        "quadratic_modes": "the products x_i x_j of the leading quadratic_modes reduced forces only (0: all)",
        "cross_modes": "also the products of the leading cross_modes reduced forces with every reduced force",
        "cubic_modes": "the cubic terms x_i x_j x_k with i <= j among the leading cubic_modes and k >= j any "
                       "(0: none): the response along the coupling's sub-iteration steps in the weak modes",
        "term_scaling": "'standard': each term to unit variance before the fit; 'global': one scale for every "
                        "term (that of the strongest linear term), so that a weak mode's term keeps its size",
    }

    def __init__(self, method: str = "lasso-bic", quadratic_modes: int = 0, cross_modes: int = 0,
                 cubic_modes: int = 0, term_scaling: str = "standard"):
        self.method = method
        self.quadratic_modes = quadratic_modes
        self.cross_modes = cross_modes
        self.cubic_modes = cubic_modes
        self.term_scaling = term_scaling

    @property
    def windows_group_fit(self) -> bool:
        """Whether fit cross-validates over the windows it is given (the ridge fit)."""
        return self.method == "ridge"

    def fit(self, X: np.ndarray, Y: np.ndarray, groups: np.ndarray | None = None) -> PolynomialRegression:
        """Least squares on the rows (X, Y); ``groups``: the window of each row (ridge's cross-validation)."""
        from sklearn.linear_model import LassoLarsIC
        self.n_inputs_ = X.shape[1]
        self.quad_i_, self.quad_j_ = product_index(self.n_inputs_, self.quadratic_modes, self.cross_modes)
        self.cube_i_, self.cube_j_, self.cube_k_ = cubic_index(self.n_inputs_, self.cubic_modes)
        n_products = len(self.quad_i_) + len(self.cube_i_)
        features = self.features(X)
        self.feature_mean_ = features.mean(axis=0)
        self.feature_scale_ = features.std(axis=0)
        self.feature_scale_[self.feature_scale_ == 0] = 1.0
        if self.term_scaling == "global":
            # one scale for every term (that of the strongest linear term): the Lasso then weighs a weak
            # mode's term by its size, instead of inflating it to the strongest one's
            self.feature_scale_ = np.full_like(self.feature_scale_, self.feature_scale_[n_products])
        Phi = (features - self.feature_mean_) / self.feature_scale_
        self.y_mean_, self.y_scale_ = Y.mean(axis=0), Y.std(axis=0)
        self.y_scale_[self.y_scale_ == 0] = 1.0
        Ys = (Y - self.y_mean_) / self.y_scale_
        n_terms = Phi.shape[1]
        noise = None
        if len(X) <= n_terms + 1:  # the BIC needs a noise estimate the data cannot give
            noise = max(float(np.var(Ys)) * 1e-6, 1e-12)
        coefficients = np.zeros((n_terms, Y.shape[1]))
        self.ridge_penalty_: float | None = None
        if self.method == "ridge":
            coefficients = self._ridge(Phi, Ys, groups)
        else:
            for k in range(Y.shape[1]):
                model = LassoLarsIC(criterion="bic", fit_intercept=True, noise_variance=noise)
                model.fit(Phi, Ys[:, k])
                coefficients[:, k] = model.coef_
        self.coefficients_ = coefficients
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
        self.ridge_penalty_ = float(search.best_params_["alpha"] / m)
        return np.array(search.best_estimator_.coef_, dtype=np.float64).reshape(Ys.shape[1], -1).T

    def features(self, X: np.ndarray) -> np.ndarray:
        """[x_i x_j, (x_i x_j) x_k, x]: the products, the cubic terms (none unless cubic_modes), the inputs."""
        cubic = X[:, self.cube_i_] * X[:, self.cube_j_] * X[:, self.cube_k_]
        return np.hstack([X[:, self.quad_i_] * X[:, self.quad_j_], cubic, X])

    def predict(self, X: np.ndarray) -> np.ndarray:
        Phi = (self.features(X) - self.feature_mean_) / self.feature_scale_
        return Phi @ self.coefficients_ * self.y_scale_ + self.y_mean_

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """The terms' derivatives (product rule) through the fitted coefficients and scalings."""
        D = np.vstack([product_derivative(x, self.quad_i_, self.quad_j_),
                       product_derivative(x, self.cube_i_, self.cube_j_, self.cube_k_), np.eye(len(x))])
        return (self.coefficients_ * self.y_scale_).T @ (D / self.feature_scale_[:, None])

    def online_arrays(self) -> dict[str, np.ndarray]:
        """H for u~ = H [q(x), x, 1] with feature and output scaling folded in."""
        C = self.coefficients_ / self.feature_scale_[:, None] * self.y_scale_[None, :]
        constant = self.y_mean_ - self.feature_mean_ @ C
        H = np.vstack([C, constant[None]]).T
        arrays = {"H": np.ascontiguousarray(H), "quad_i": self.quad_i_, "quad_j": self.quad_j_}
        if len(self.cube_i_):        # a degree-2 model's arrays stay those of the format without cubic terms
            arrays.update(cube_i=self.cube_i_, cube_j=self.cube_j_, cube_k=self.cube_k_)
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
