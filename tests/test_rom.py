"""The ROM's mathematics, persistence and scikit-learn behaviour (in-process)."""

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV

from rom_component import persistence
from rom_component.estimator import SolidRom
from rom_component.manifold import quadratic_terms
from rom_component.pod import centred_pod, energy_rank
from rom_component.probes import ProbeFailed, ask, probe_forces
from rom_component.regression import RbfRegression, SparseQuadraticRegression, cubic_index, product_index


def smooth_data(m=300, n_in=40, n_out=30, seed=0):
    """Forces on a 3-D latent manifold and displacements a smooth nonlinear function of them."""
    rng = np.random.default_rng(seed)
    latent = rng.uniform(-1, 1, (m, 3))
    F = latent @ rng.standard_normal((3, n_in)) + 5.0
    modes = np.linalg.qr(rng.standard_normal((n_out, 4)))[0]
    Z = np.column_stack([latent[:, 0], latent[:, 1] + 0.3 * latent[:, 0] ** 2, np.sin(latent[:, 2]), latent[:, 0] * latent[:, 1]])
    return F, Z @ modes.T + 1.0


def test_pod_reproduces_rank_r_data_exactly():
    rng = np.random.default_rng(1)
    X = rng.standard_normal((50, 4)) @ rng.standard_normal((4, 80)) + rng.standard_normal(80)
    mean, modes, s = centred_pod(X, rank=4)
    np.testing.assert_allclose(modes.T @ modes, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(((X - mean) @ modes) @ modes.T + mean, X, atol=1e-12)
    assert s[4] < 1e-12 * s[0] and energy_rank(s, 0.9999) <= 4
    _, three, _ = centred_pod(X, rank=3)
    assert np.abs(((X - mean) @ three) @ three.T + mean - X).max() > 1e-3


def test_energy_rank():
    assert energy_rank(np.array([10.0, 1.0, 0.01]), 0.99) == 1  # 100 / 101.0001 = 0.9901
    assert energy_rank(np.array([10.0, 1.0, 0.01]), 0.995) == 2
    assert energy_rank(np.array([10.0, 1.0, 0.01]), 0.9999999) == 3


def test_quadratic_manifold_reproduces_data_on_a_quadratic_manifold():
    rng = np.random.default_rng(2)
    N, r, m = 60, 3, 200
    basis = np.linalg.qr(rng.standard_normal((N, r + 6)))[0]
    V, W = basis[:, :r], basis[:, r:]          # orthogonal: the quadratic part lies outside span(V)
    half = rng.uniform(-1, 1, (m // 2, r))
    Z = np.vstack([half, -half])  # a symmetric sample: no correlation between z and q(z), POD finds span(V)
    U = 2.0 + Z @ V.T + quadratic_terms(Z) @ W.T
    quadratic = SolidRom(n_force_modes=r, n_disp_modes=r, decoder="quadratic", manifold_regularization=1e-12)
    linear = SolidRom(n_force_modes=r, n_disp_modes=r, decoder="linear")
    F = Z @ rng.standard_normal((r, 20))
    quadratic.fit(F, U)
    linear.fit(F, U)
    Zu = (U - quadratic.u_mean_) @ quadratic.Phi_u_
    error_quadratic = np.abs(quadratic.decode(Zu) - U).max()
    error_linear = np.abs(linear.decode((U - linear.u_mean_) @ linear.Phi_u_) - U).max()
    assert error_linear > 0.05
    assert error_quadratic < 1e-6 * error_linear


def test_lasso_bic_recovers_the_support_of_a_sparse_quadratic():
    rng = np.random.default_rng(3)
    X = rng.standard_normal((400, 4))
    i, j = np.triu_indices(4)
    terms = np.hstack([X[:, i] * X[:, j], X])  # 10 quadratic terms, then 4 linear
    truth = np.zeros(terms.shape[1])
    truth[[0, 5, 11]] = [1.5, -2.0, 0.8]     # x0^2, x1 x3, x1
    y = terms @ truth + 0.3 + 1e-3 * rng.standard_normal(400)
    model = SparseQuadraticRegression().fit(X, y[:, None])
    np.testing.assert_array_equal(np.flatnonzero(model.coefficients[:, 0]), [0, 5, 11])
    np.testing.assert_allclose(model.predict(X)[:, 0], terms @ truth + 0.3, atol=1e-2)


def test_products_of_the_leading_modes_only_keep_the_response_linear_in_the_others():
    rng = np.random.default_rng(5)
    X = rng.standard_normal((400, 5))
    y = 1.5 * X[:, 0] ** 2 - 2.0 * X[:, 0] * X[:, 1] + 0.8 * X[:, 4] + 1e-3 * rng.standard_normal(400)
    model = SparseQuadraticRegression(quadratic_modes=2).fit(X, y[:, None])
    assert len(model.quad_i) == 3 and model.coefficients.shape == (3 + 5, 1)   # x0^2, x0 x1, x1^2; 5 linear
    np.testing.assert_allclose(model.predict(X)[:, 0], y, atol=1e-2)
    far = np.zeros((2, 5))
    far[:, 3] = [10.0, 20.0]                  # far out in a weak mode: the response stays linear (here: flat)
    response = model.predict(far)[:, 0]
    assert abs(response[1] - 2 * response[0] + model.predict(np.zeros((1, 5)))[0, 0]) < 1e-9
    # the online path and the FMU's arrays take the products they are given
    F, U = smooth_data()
    rom = SolidRom(4, 4, decoder="quadratic", regressor="poly", quadratic_modes=2).fit(F, U)
    assert len(rom.online_arrays()["quad_i"]) == 3
    np.testing.assert_allclose(rom.to_online().predict(F[:20] + 0.01), rom.predict(F[:20] + 0.01), atol=1e-9)


def test_cross_products_let_the_response_to_a_weak_mode_follow_the_leading_state():
    """A compliance that depends on the deformation: the gain of weak mode 4 grows with leading mode 0. Products
    among the 2 leading modes cannot hold it; with those of mode 0 and every mode, a ridge fit recovers it."""
    rng = np.random.default_rng(8)
    X = rng.standard_normal((600, 6)) * np.array([1.0, 0.7, 0.3, 0.1, 0.1, 0.05])
    windows = np.repeat(np.arange(100), 6)
    y = X[:, 0] + 0.5 * X[:, 1] ** 2 + 2.0 * X[:, 0] * X[:, 4] + 0.3 * X[:, 4] + 1e-5 * rng.standard_normal(600)
    np.testing.assert_array_equal(np.column_stack(product_index(6, 2)), np.column_stack(np.triu_indices(2)))
    i, j = product_index(6, 2, cross_modes=1)
    assert list(zip(i.tolist(), j.tolist())) == [(0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (0, 5), (1, 1)]
    leading = SparseQuadraticRegression(quadratic_modes=2, feature_scaling="global").fit(X, y[:, None])
    cross = SparseQuadraticRegression(2, "global", cross_modes=1, fit="ridge").fit(X, y[:, None], groups=windows)
    test = rng.standard_normal((200, 6)) * np.array([1.0, 0.7, 0.3, 0.1, 0.1, 0.05])
    truth = test[:, 0] + 0.5 * test[:, 1] ** 2 + 2.0 * test[:, 0] * test[:, 4] + 0.3 * test[:, 4]
    gain = lambda model: (model.predict(test + np.eye(6)[4] * 1e-3) - model.predict(test))[:, 0] / 1e-3
    true_gain = 2.0 * test[:, 0] + 0.3
    assert np.abs(gain(leading) - true_gain).max() > 1.0               # a constant gain, off by 2 |x0|
    np.testing.assert_allclose(gain(cross), true_gain, atol=2e-3)
    np.testing.assert_allclose(cross.predict(test)[:, 0], truth, atol=1e-4)
    assert cross.ridge_penalty <= 1e-9                                  # noise 1e-5: hardly any penalty
    noisy = y + 0.5 * rng.standard_normal(600)
    assert SparseQuadraticRegression(2, "global", 1, "ridge").fit(X, noisy[:, None], groups=windows).ridge_penalty \
        > 100 * cross.ridge_penalty                                     # noise 0.5: the cross-validation damps it
    rom = SolidRom(4, 4, decoder="quadratic", regressor="poly", quadratic_modes=2, cross_modes=1, poly_fit="ridge")
    F, U = smooth_data()
    rom.fit(F, U, windows=np.arange(len(F)) // 3)
    np.testing.assert_allclose(rom.to_online().predict(F[:20] + 0.01), rom.predict(F[:20] + 0.01), atol=1e-9)
    for bad, message in (({"poly_fit": "ols"}, "poly_fit 'ols' not in"), ({"cross_modes": -1}, "cross_modes must be"),
                         ({"poly_fit": "ridge", "secant_weight": 1.0}, "secant_weight must be 0")):
        with pytest.raises(ValueError, match=message):
            SolidRom(regressor="poly", **bad).fit(F, U)


def test_cubic_terms_let_the_gain_of_a_weak_mode_follow_the_square_of_the_leading_state():
    """A compliance along weak mode 4 that grows with the square of leading mode 0 (a softening either way):
    no product of two inputs holds it; the cubic terms of the leading mode do, with ridge and with the Lasso."""
    rng = np.random.default_rng(9)
    scales = np.array([1.0, 0.7, 0.3, 0.1, 0.1, 0.05])
    X, test = rng.standard_normal((600, 6)) * scales, rng.standard_normal((200, 6)) * scales
    windows = np.repeat(np.arange(100), 6)
    response = lambda X: X[:, 0] + 0.2 * X[:, 0] ** 3 + 0.3 * X[:, 4] + 1.5 * X[:, 0] ** 2 * X[:, 4]
    y = response(X) + 1e-5 * rng.standard_normal(600)
    i, j, k = cubic_index(3, 2)
    assert list(zip(i.tolist(), j.tolist(), k.tolist())) == [(0, 0, 0), (0, 0, 1), (0, 0, 2), (0, 1, 1), (0, 1, 2),
                                                             (1, 1, 1), (1, 1, 2)]
    assert all(len(a) == 0 for a in cubic_index(6, 0))
    gain = lambda model: (model.predict(test + np.eye(6)[4] * 1e-3) - model.predict(test))[:, 0] / 1e-3
    true_gain = 0.3 + 1.5 * test[:, 0] ** 2
    quadratic = SparseQuadraticRegression(0, "global", fit="ridge").fit(X, y[:, None], groups=windows)
    assert np.abs(gain(quadratic) - true_gain).max() > 1.0                 # off by 1.5 x0^2 - its best constant
    for fit in ("ridge", "lasso-bic"):
        cubic = SparseQuadraticRegression(2, "global", fit=fit, cubic_modes=1).fit(X, y[:, None], groups=windows)
        assert len(cubic.cube_i) == 6 and cubic.coefficients.shape == (3 + 6 + 6, 1)
        np.testing.assert_allclose(gain(cubic), true_gain, atol=2e-3)
        np.testing.assert_allclose(cubic.predict(test)[:, 0], response(test), atol=1e-4)
    rom = SolidRom(4, 4, decoder="quadratic", regressor="poly", quadratic_modes=2, cubic_modes=2, poly_fit="ridge")
    F, U = smooth_data()
    rom.fit(F, U, windows=np.arange(len(F)) // 3)
    assert len(rom.online_arrays()["cube_i"]) == 4 + 3 + 3                   # (0, 0, 0..3), (0, 1, 1..3), (1, 1, 1..3)
    np.testing.assert_allclose(rom.to_online().predict(F[:20] + 0.01), rom.predict(F[:20] + 0.01), atol=1e-9)
    assert "cube_i" not in SolidRom(4, 4, regressor="poly").fit(F, U).online_arrays()   # degree 2: as before
    with pytest.raises(ValueError, match="cubic_modes must be"):
        SolidRom(regressor="poly", cubic_modes=-1).fit(F, U)


def test_rbf_regressor_interpolates_its_centres():
    rng = np.random.default_rng(4)
    X = rng.uniform(-1, 1, (80, 3))
    Y = np.column_stack([np.sin(3 * X[:, 0]), X[:, 1] * X[:, 2]])
    rbf = RbfRegression().fit(X, Y)
    np.testing.assert_allclose(rbf.predict(X), Y, atol=1e-9)
    test = rng.uniform(-0.8, 0.8, (50, 3))
    error = np.abs(rbf.predict(test) - np.column_stack([np.sin(3 * test[:, 0]), test[:, 1] * test[:, 2]]))
    assert np.median(error) < 0.02 and error.max() < 0.3


@pytest.mark.parametrize("regressor, decoder", [("rbf", "linear"), ("rbf", "quadratic"), ("poly", "linear"),
                                                ("poly", "quadratic")])
def test_online_path_equals_offline_prediction(regressor, decoder):
    F, U = smooth_data()
    model = SolidRom(3, 4, decoder=decoder, regressor=regressor).fit(F, U)
    online = model.to_online()
    test = F[:40] + 0.01
    np.testing.assert_allclose(online.predict(test), model.predict(test), rtol=0, atol=1e-9)
    np.testing.assert_allclose(online.full_field(model.reduced_predict(test)), model.predict(test), atol=1e-12)


def test_rom_is_accurate_on_unseen_smooth_data():
    F, U = smooth_data(m=400)
    model = SolidRom(3, 4).fit(F[:300], U[:300])
    error = np.linalg.norm(model.predict(F[300:]) - U[300:], axis=1) / np.linalg.norm(U[300:] - U.mean(0), axis=1)
    assert np.median(error) < 0.05


def test_save_load_round_trips_bit_for_bit(tmp_path):
    F, U = smooth_data()
    model = SolidRom(3, 4, decoder="quadratic").fit(F, U)
    arrays = model.online_arrays()
    path = persistence.save(tmp_path / "model.npz", arrays, {"regressor": "rbf", "note": "x"})
    loaded_arrays, metadata = persistence.load_arrays(path)
    assert metadata["note"] == "x" and metadata["format"] == persistence.FORMAT
    assert set(loaded_arrays) == set(arrays)
    for name, value in arrays.items():
        assert loaded_arrays[name].dtype == value.dtype and loaded_arrays[name].tobytes() == value.tobytes(), name
    reloaded = persistence.load(path)
    direct = model.to_online()
    for f in F[:20]:
        assert reloaded(f).tobytes() == direct(f).tobytes()


def test_model_files_with_pickles_or_garbage_are_refused(tmp_path):
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, metadata_json=np.frombuffer(b"{}", dtype=np.uint8), E=np.array([{"a": 1}], dtype=object))
    with pytest.raises(persistence.ModelFileError, match="array 'E' holds Python objects"):
        persistence.load(pickled)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"this is not a zip file")
    with pytest.raises(persistence.ModelFileError, match="not a valid .npz"):
        persistence.load(garbage)
    with pytest.raises(persistence.ModelFileError, match="does not exist"):
        persistence.load(tmp_path / "missing.npz")
    with pytest.raises(persistence.ModelFileError, match="dtype object"):
        persistence.save(tmp_path / "x.npz", {"a": np.array([None], dtype=object)}, {})


def test_clone_and_grid_search_work_on_the_estimator():
    F, U = smooth_data()
    model = SolidRom(2, 2, rbf_smoothing=1e-6)
    copy = clone(model)
    assert copy.get_params() == model.get_params() and copy is not model
    search = GridSearchCV(SolidRom(), {"n_force_modes": [1, 3], "n_disp_modes": [1, 4]}, cv=3,
                          scoring="neg_mean_squared_error")
    search.fit(F, U)
    assert search.best_params_ == {"n_force_modes": 3, "n_disp_modes": 4}


def test_mode_numbers_are_capped_by_the_data_and_bad_ones_reported():
    F, U = smooth_data(m=20)
    assert SolidRom(3, 50).fit(F, U).modes == (3, 19)    # at most m - 1 modes
    for bad in (0, 2.5, True):
        with pytest.raises(ValueError, match=f"n_disp_modes must be an integer >= 1, got {bad!r}"):
            SolidRom(3, bad).fit(F, U)


@pytest.mark.parametrize("params", [{}, {"regressor": "poly"}, {"decoder": "quadratic"},
                                    {"regressor": "poly", "poly_fit": "ridge", "cross_modes": 1}])
def test_the_estimator_passes_scikit_learns_checks(params):
    from sklearn.utils.estimator_checks import check_estimator
    results = check_estimator(SolidRom(**params), on_fail=None)
    failed = [f"{r['check_name']}: {r['exception']}" for r in results if r["status"] == "failed"]
    assert len(results) > 40 and failed == []


@pytest.mark.parametrize("smoothing", [0.0, 1e-3])
def test_thin_plate_spline_matches_scipys_rbf_interpolator(smoothing):
    from scipy.interpolate import RBFInterpolator

    from rom_component.regression import RbfRegression
    rng = np.random.default_rng(5)
    X, Y = rng.standard_normal((60, 3)), rng.standard_normal((60, 4))
    X_new = rng.standard_normal((25, 3))
    ours = RbfRegression(smoothing).fit(X, Y)
    scipys = RBFInterpolator(X, Y, kernel="thin_plate_spline", degree=1, smoothing=smoothing)
    np.testing.assert_allclose(ours.predict(X_new), scipys(X_new), rtol=1e-9, atol=1e-9 * np.abs(Y).max())
    if smoothing == 0.0:
        np.testing.assert_allclose(ours.predict(X), Y, atol=1e-9)   # an interpolant


def test_one_feature_scale_for_every_term_keeps_the_online_path_and_the_fit():
    F, U = smooth_data(m=300)
    standard = SolidRom(3, 4, decoder="quadratic", regressor="poly").fit(F, U)
    single = SolidRom(3, 4, decoder="quadratic", regressor="poly", feature_scaling="global").fit(F, U)
    scale = single.regression_.feature_scale
    assert np.all(scale == scale[0]) and not np.all(standard.regression_.feature_scale == scale[0])
    np.testing.assert_allclose(single.to_online().predict(F[:20] + 0.01), single.predict(F[:20] + 0.01), atol=1e-9)
    for model in (standard, single):
        error = np.linalg.norm(model.predict(F) - U, axis=1) / np.linalg.norm(U - U.mean(0), axis=1)
        assert np.median(error) < 0.05
    with pytest.raises(ValueError, match="feature scaling"):
        SolidRom(3, 4, regressor="poly", feature_scaling="minmax").fit(F, U)


def test_the_chosen_modes_are_the_fewest_within_the_tolerance_of_the_best():
    from rom_component.selection import SelectionTable
    errors = np.array([[8.5e-3, 2.8e-3, 6.8e-4, 5.0e-4, 4.2e-4],     # r_u = 5
                       [8.4e-3, 2.7e-3, 6.6e-4, np.nan, 4.1e-4]])    # r_u = 9 (one cell not computed)
    table = SelectionTable([5, 10, 20, 30, 60], [5, 9], errors, errors / 0.2, (60, 9), (18, 4), 100, 5)
    assert table.chosen == table.best == (60, 9)                     # no tolerance: the best
    table.tolerance = 1.0                                            # within twice the best (8.2e-4)
    assert table.chosen == (20, 5) and "chosen (fewest modes within 100% of the best): r_f = 20, r_u = 5" in table.format()
    table.tolerance = 0.25                                           # 5.1e-4: r_f = 30 at r_u = 5
    assert table.chosen == (30, 5)


def test_secant_weight_trades_level_error_for_the_response_along_sub_iteration_steps():
    # along the trajectory the third force direction moves as the cube of the first, and the solid answers
    # the first with a cubic the polynomial lacks: levels alone blame the third direction for it. Fitting
    # the steps between sub-iterations too, on new windows of the same process: the steps' error falls as
    # the weight grows, and the levels' error rises
    def sample(seed, amplitude):
        rng = np.random.default_rng(seed)
        steps = 0.02 * 0.5 ** np.arange(4)[None, :, None] * rng.standard_normal((120, 4, 6))
        F = (amplitude * levels[:, None, :] + steps).reshape(-1, 6)
        return F, F @ G.T + np.outer((F @ basis[:, 0]) ** 3, C)

    rng = np.random.default_rng(3)
    basis = np.linalg.qr(rng.standard_normal((6, 6)))[0]
    G, C = rng.standard_normal((6, 6)), rng.standard_normal(6)
    a, b = np.sin(np.linspace(0, 6 * np.pi, 120)), np.cos(np.linspace(0, 6 * np.pi, 120))
    levels = np.outer(a, basis[:, 0]) + np.outer(b, basis[:, 1]) + np.outer(0.3 * a ** 3, basis[:, 2])
    windows = np.repeat(np.arange(120), 4)
    (F, U), (F_new, U_new) = sample(4, 1.0), sample(5, 1.1)
    first = np.flatnonzero(windows[1:] == windows[:-1])

    def errors(weight):
        model = SolidRom(n_force_modes=6, n_disp_modes=6, regressor="poly", decoder="linear", quadratic_modes=1,
                         feature_scaling="global", secant_weight=weight).fit(F, U, windows=windows)
        P = model.predict(F_new)
        step, step_rom = U_new[first + 1] - U_new[first], P[first + 1] - P[first]
        return (np.median(np.linalg.norm(step_rom - step, axis=1) / np.linalg.norm(step, axis=1)),
                np.linalg.norm(P - U_new, axis=1).mean() / np.linalg.norm(U_new, axis=1).mean())

    (step0, level0), (step1, level1), (step3, level3) = errors(0.0), errors(1.0), errors(3.0)
    assert step3 < step1 < 0.7 * step0
    assert level0 < level1 < level3
    with pytest.raises(ValueError, match="needs the window of each of the 480 snapshots"):
        SolidRom(regressor="poly", secant_weight=1.0).fit(F, U)
    with pytest.raises(ValueError, match="secant_weight applies to the poly regressor"):
        SolidRom(regressor="rbf", secant_weight=1.0).fit(F, U, windows=windows)


def test_probes_along_the_force_modes_fix_the_response_to_a_mode_that_moves_with_another():
    # one call a window: along the trajectory the third direction moves as the square of the first, and the
    # solid answers the first with a square too, so the recorded calls cannot tell the two apart and the fit
    # splits the response between them its own way. The solid's answers to steps along each force mode at a
    # few converged forces (probes) fix the response along the third direction, at new points of the trajectory
    rng = np.random.default_rng(3)
    basis = np.linalg.qr(rng.standard_normal((6, 6)))[0]
    G, C = rng.standard_normal((6, 6)), rng.standard_normal(6)

    def solid(F):
        return F @ G.T + np.outer((F @ basis[:, 0]) ** 2, C)

    def trajectory(phase):
        a, b = np.sin(np.linspace(0, 6 * np.pi, 240) + phase), np.cos(np.linspace(0, 6 * np.pi, 240) + phase)
        return np.outer(a, basis[:, 0]) + np.outer(b, basis[:, 1]) + np.outer(0.3 * (a ** 2 - 0.5), basis[:, 2])

    F = trajectory(0.0)
    windows = np.arange(len(F))
    forces, base = probe_forces(F, windows, n_bases=20, modes=range(3), amplitude=0.25)
    assert forces.shape == (60, 6) and np.array_equal(np.unique(base), base[::3])
    steps = forces - F[base]                                  # each along one mode, a quarter of its range
    _, modes, _ = centred_pod(F, 3)
    along = np.abs(steps @ modes)
    assert np.allclose(along.max(axis=1), np.linalg.norm(steps, axis=1))
    assert np.allclose(along.max(axis=0), 0.25 * np.ptp((F - F.mean(axis=0)) @ modes, axis=0))
    axes = np.eye(6)[:, [4, 1]]                               # along a basis of one's own: steps on its columns
    forces_b, _ = probe_forces(F, windows, n_bases=20, modes=[0, 1], amplitude=0.5, basis=axes)
    steps_b = (forces_b - F[base[::3].repeat(2)]).reshape(20, 2, 6)
    assert np.allclose(np.abs(steps_b[:, 0, 4]), 0.5 * np.ptp(F[:, 4])) and np.allclose(steps_b[:, 0, [0, 1, 2, 3, 5]], 0)
    assert np.allclose(np.abs(steps_b[:, 1, 1]), 0.5 * np.ptp(F[:, 1])) and np.allclose(steps_b[:, 1, [0, 2, 3, 4, 5]], 0)

    def response_error(F_train):
        model = SolidRom(n_force_modes=3, n_disp_modes=6, regressor="poly", decoder="linear",
                         feature_scaling="global").fit(F_train, solid(F_train))
        points, d, h = trajectory(0.1)[::10], basis[:, 2], 1e-4
        J = (model.predict(points + h * d) - model.predict(points - h * d)) / (2 * h)
        return np.median(np.linalg.norm(J - G @ d, axis=1)) / np.linalg.norm(G @ d)

    without, with_probes = response_error(F), response_error(np.vstack([F, forces]))
    assert without > 0.5 and with_probes < 1e-3              # measured: 1.00 against 3e-7

    def fails_on_the_fifth(f):
        if np.array_equal(f, forces[4]):
            raise ValueError("no convergence\nin 30 Newton iterations")
        return solid(f[None])[0], f
    with pytest.raises(ProbeFailed, match=r"^row 4: no convergence$") as failed:
        ask(fails_on_the_fifth, forces)
    assert failed.value.row == 4


def reciprocal_solid(m=400, seed=7):
    """A static solid with Maxwell-Betti reciprocity: 40 interface dofs among 60, response in 3 modes, driven by
    the force's work on them (g = V_G^T f) through a gradient map; the forces also vary, ten times more, along
    work-free directions (orthogonal to V_G) that move nothing."""
    rng = np.random.default_rng(seed)
    V = np.linalg.qr(rng.standard_normal((60, 3)))[0]
    index = rng.permutation(60)[:40]                       # the force's dofs among the field's, in force order
    V_G = V[index]
    free = np.linalg.svd(np.eye(40) - V_G @ np.linalg.pinv(V_G))[0][:, :3]   # orthogonal to V_G
    M = np.array([[2.0, 0.3, 0.0], [0.3, 1.0, 0.1], [0.0, 0.1, 0.5]])

    def solve(F):
        g = F @ V_G
        q = g @ M + np.column_stack([0.2 * g[:, 0] ** 2 + 0.1 * g[:, 1] ** 2, 0.2 * g[:, 0] * g[:, 1], 0 * g[:, 2]])
        return q @ V.T

    F = (rng.uniform(-1, 1, (m, 3)) @ np.linalg.pinv(V_G) + 10 * rng.uniform(-1, 1, (m, 3)) @ free.T + 0.5)
    return F, solve(F), solve, index, free


def test_the_work_basis_keeps_the_part_of_the_force_a_reciprocal_solid_answers():
    F, U, solve, index, free = reciprocal_solid()
    params = dict(n_force_modes=3, n_disp_modes=3, regressor="poly", feature_scaling="global", interface_index=index)
    work = SolidRom(force_basis="work", **params).fit(F[:300], U[:300])
    pod = SolidRom(**params).fit(F[:300], U[:300])
    assert work.modes == (3, 3)

    def error(model):
        return np.linalg.norm(model.predict(F[300:]) - U[300:]) / np.linalg.norm(U[300:])

    assert error(work) < 1e-3 and error(pod) > 0.3     # POD's 3 modes are the work-free directions of most variance
    # work-free changes of the force move nothing, as in the solid
    np.testing.assert_allclose(work.predict(F[300:310] + 5 * free[:, 0]), work.predict(F[300:310]), atol=1e-12)
    # the interface's response is reciprocal: d u_i / d f_j = d u_j / d f_i
    f0, h = F[300], 1e-4
    J = np.array([(work.predict((f0 + h * e)[None])[0, index] - work.predict((f0 - h * e)[None])[0, index]) / (2 * h)
                  for e in np.eye(40)]).T
    assert np.linalg.norm(J - J.T) < 1e-2 * np.linalg.norm(J)
    np.testing.assert_allclose(J @ free, 0, atol=1e-9)
    online = work.to_online(index)                     # the interface path serves the same
    np.testing.assert_allclose(online.predict(F[300:310]), work.predict(F[300:310])[:, index], atol=1e-12)
    with pytest.raises(ValueError, match=r"force_basis 'work' needs the interface's 40 columns of the 60 "
                                         r"displacement values \(interface_index\), got shape \(39,\)"):
        SolidRom(force_basis="work", **{**params, "interface_index": index[:39]}).fit(F, U)
    with pytest.raises(ValueError, match="force_basis 'bogus' not in"):
        SolidRom(force_basis="bogus").fit(F, U)


def test_the_potential_regressor_recovers_a_gradient_map_and_keeps_any_fit_reciprocal():
    from rom_component.regression import PotentialRegression
    rng = np.random.default_rng(11)
    X = rng.uniform(-1, 1, (300, 4))
    A = rng.standard_normal((4, 4))
    S = A @ A.T                                              # psi = 0.5 x'Sx + x0^3 + x0 x1 x2 - 0.3 x3 + const

    def gradient(X):
        g = X @ S
        g[:, 0] += 3 * X[:, 0] ** 2 + X[:, 1] * X[:, 2]
        g[:, 1] += X[:, 0] * X[:, 2]
        g[:, 2] += X[:, 0] * X[:, 1]
        g[:, 3] -= 0.3
        return g

    model = PotentialRegression().fit(X, gradient(X))
    test = rng.uniform(-1, 1, (50, 4))
    np.testing.assert_allclose(model.predict(test), gradient(test), atol=1e-10)
    assert model.n_parameters == 4 + 10 + 20 and model.H.shape == (4, 10 + 4 + 1)
    # data that are no gradient (a rotation in the x0-x1 plane): the fit's Jacobian stays symmetric
    Y = gradient(X) + np.column_stack([X[:, 1], -X[:, 0], 0 * X[:, :2]])
    fitted = PotentialRegression().fit(X, Y)
    x0, h = test[0], 1e-6
    J = np.array([(fitted.predict((x0 + h * e)[None]) - fitted.predict((x0 - h * e)[None]))[0] / (2 * h)
                  for e in np.eye(4)])
    assert np.abs(J - J.T).max() < 1e-8 * np.abs(J).max()
    assert np.abs(fitted.predict(X) - Y).max() > 0.5            # the rotation cannot be fitted
    with pytest.raises(ValueError, match="as many outputs as inputs"):
        PotentialRegression().fit(X, Y[:, :3])


def test_the_potential_rom_serves_a_reciprocal_solid_through_the_online_path():
    F, U, solve, index, free = reciprocal_solid()
    model = SolidRom(3, 3, regressor="potential", force_basis="work", interface_index=index).fit(F[:300], U[:300])
    assert np.linalg.norm(model.predict(F[300:]) - U[300:]) < 1e-10 * np.linalg.norm(U[300:])
    online = model.to_online(index)
    np.testing.assert_allclose(online.predict(F[300:310]), U[300:310][:, index], atol=1e-10)
    np.testing.assert_allclose(model.Phi_u_[index].T @ model.Phi_u_[index], np.eye(3), atol=1e-12)  # = work basis
    with pytest.raises(ValueError, match="regressor 'potential' needs force_basis 'work', decoder 'linear'"):
        SolidRom(3, 3, regressor="potential", interface_index=index).fit(F, U)
