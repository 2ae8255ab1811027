"""Quadratic manifold decoder (Geelen, Wright, Willcox 2023).

u ~ u_mean + c + Phi u~ + Phi_bar q(u~), where q(u~) holds the r(r+1)/2 unique products
u~_i u~_j (i <= j) and (c, Phi_bar) fit the residual E of the linear POD reconstruction by
regularised least squares: min ||E - c - Phi_bar Q||^2 + gamma ||Phi_bar||^2.
"""

from __future__ import annotations

import numpy as np


def quadratic_index(r: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), i <= j, of the unique quadratic terms of r coordinates."""
    i, j = np.triu_indices(r)
    return i, j


def quadratic_terms(Z: np.ndarray) -> np.ndarray:
    """Unique products of the columns of ``Z`` (m, r): shape (m, r(r+1)/2)."""
    i, j = quadratic_index(Z.shape[1])
    return Z[:, i] * Z[:, j]


def product_derivative(z: np.ndarray, *index: np.ndarray) -> np.ndarray:
    """d/dz of the products prod_k z[index[k]] (one term per entry of the index arrays): (terms, len(z))."""
    terms, n = len(index[0]), len(z)
    D = np.zeros((terms, n))
    rows = np.arange(terms)
    for k in range(len(index)):      # the product rule over the (two or three) factors
        others = np.ones(terms)
        for m in range(len(index)):
            if m != k:
                others = others * z[index[m]]
        np.add.at(D, (rows, index[k]), others)
    return D


def fit_quadratic_manifold(Z: np.ndarray, residual: np.ndarray, regularization: float) -> tuple[np.ndarray, np.ndarray]:
    """Phi_bar (N, r(r+1)/2) and an offset c (N,) with residual ~ c + Phi_bar q(z).

    The offset is needed because centred snapshots leave the mean of q(z) in the
    residual; with it, data lying exactly on a quadratic manifold are reproduced.
    Only Phi_bar is regularised (gamma times the mean diagonal of the Gram matrix).
    """
    Q = quadratic_terms(Z)
    q_mean = Q.mean(axis=0)
    Qc = Q - q_mean
    gram = Qc.T @ Qc
    scale = np.trace(gram) / max(len(gram), 1)
    gram[np.diag_indices_from(gram)] += regularization * scale
    # least squares: exact where the Gram matrix is regular, the minimum-norm fit where it is not
    phi_bar = np.linalg.lstsq(gram, Qc.T @ (residual - residual.mean(axis=0)), rcond=None)[0].T
    offset = residual.mean(axis=0) - phi_bar @ q_mean
    return phi_bar, offset
