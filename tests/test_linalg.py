"""The accelerations' QR and triangular solve, and the RBF mappings' small solves, give NumPy's and SciPy's bits (the coupled runs amplify any
difference in the last bit until an iteration count changes)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_triangular

from coupler.linalg import QR, column_norms, norm, solve, solve_upper


@pytest.mark.parametrize("rows, columns", [(101, 1), (101, 8), (101, 37), (6, 6), (5, 9)])
@pytest.mark.parametrize("order", ["C", "F"])
def test_qr_and_solve_are_numpys_and_scipys_bit_for_bit(rows, columns, order):
    rng = np.random.default_rng(rows * 100 + columns)
    matrix = np.asarray(rng.standard_normal((rows, columns)) * np.logspace(0, -6, columns), order=order)
    Q, R = np.linalg.qr(matrix)
    qr = QR(matrix)
    assert np.array_equal(qr.diagonal, np.diag(R))
    assert np.array_equal(qr.R, R) and np.array_equal(qr.Q, Q)
    assert np.array_equal(column_norms(matrix), np.linalg.norm(matrix, axis=0))
    assert norm(matrix) == np.linalg.norm(matrix) and norm(matrix[:, 0]) == np.linalg.norm(matrix[:, 0])
    if rows >= columns:
        b = rng.standard_normal(columns)
        assert np.array_equal(QR(matrix).solve(b), solve_triangular(R, b, check_finite=False))   # R not formed
        assert np.array_equal(solve_upper(np.asfortranarray(R), b),
                              solve_triangular(np.asfortranarray(R), b, check_finite=False))


def test_a_singular_triangle_is_refused():
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        solve_upper(np.array([[1.0, 2.0], [0.0, 0.0]]), np.ones(2))


@pytest.mark.parametrize("shape", [(3,), (3, 2), (4, 1)])
def test_solve_is_numpys_bit_for_bit_and_refuses_a_singular_matrix(shape):
    rng = np.random.default_rng(len(shape) * 10 + shape[0])
    a = np.triu(rng.standard_normal((shape[0], shape[0]))) + 3 * np.eye(shape[0])
    b = rng.standard_normal(shape)
    assert np.array_equal(solve(a, b), np.linalg.solve(a, b))
    assert np.array_equal(solve(a.T, b), np.linalg.solve(a.T, b))      # a transposed view, as the mapping passes R.T
    with pytest.raises(np.linalg.LinAlgError, match="[Ss]ingular"), np.errstate(invalid="ignore"):
        solve(np.zeros_like(a), b)
