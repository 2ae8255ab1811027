"""The ROM's mathematics, persistence and scikit-learn behaviour (in-process)."""

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV

from rom_component import model_file
from rom_component.reduction.decoders import PodDecoder, QuadraticManifoldDecoder
from rom_component.reduction.encoders import PodEncoder
from rom_component.reduction.manifold import quadratic_terms
from rom_component.reduction.pod import centred_pod, energy_rank
from rom_component.static.estimator import SolidRom
from rom_component.static.load import load_rom
from rom_component.static.regression import PolynomialRegression, RbfRegression, cubic_index, product_index
from tests.roms import solid_rom


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
    quadratic = QuadraticManifoldDecoder(r, regularization=1e-12)
    linear = PodDecoder(r)
    error_quadratic = np.abs(quadratic.inverse_transform(quadratic.fit_transform(U)) - U).max()
    error_linear = np.abs(linear.inverse_transform(linear.fit_transform(U)) - U).max()
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
    model = PolynomialRegression().fit(X, y[:, None])
    np.testing.assert_array_equal(np.flatnonzero(model.coefficients_[:, 0]), [0, 5, 11])
    np.testing.assert_allclose(model.predict(X)[:, 0], terms @ truth + 0.3, atol=1e-2)


def test_products_of_the_leading_modes_only_keep_the_response_linear_in_the_others():
    rng = np.random.default_rng(5)
    X = rng.standard_normal((400, 5))
    y = 1.5 * X[:, 0] ** 2 - 2.0 * X[:, 0] * X[:, 1] + 0.8 * X[:, 4] + 1e-3 * rng.standard_normal(400)
    model = PolynomialRegression(quadratic_modes=2).fit(X, y[:, None])
    assert len(model.quad_i_) == 3 and model.coefficients_.shape == (3 + 5, 1)   # x0^2, x0 x1, x1^2; 5 linear
    np.testing.assert_allclose(model.predict(X)[:, 0], y, atol=1e-2)
    far = np.zeros((2, 5))
    far[:, 3] = [10.0, 20.0]                  # far out in a weak mode: the response stays linear (here: flat)
    response = model.predict(far)[:, 0]
    assert abs(response[1] - 2 * response[0] + model.predict(np.zeros((1, 5)))[0, 0]) < 1e-9
    # the online path and the FMU's arrays take the products they are given
    F, U = smooth_data()
    rom = solid_rom(4, 4, {"type": "poly", "quadratic_modes": 2}, "quadratic").fit(F, U)
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
    leading = PolynomialRegression(quadratic_modes=2, term_scaling="global").fit(X, y[:, None])
    cross = PolynomialRegression("ridge", 2, cross_modes=1, term_scaling="global").fit(X, y[:, None], groups=windows)
    test = rng.standard_normal((200, 6)) * np.array([1.0, 0.7, 0.3, 0.1, 0.1, 0.05])
    truth = test[:, 0] + 0.5 * test[:, 1] ** 2 + 2.0 * test[:, 0] * test[:, 4] + 0.3 * test[:, 4]
    gain = lambda model: (model.predict(test + np.eye(6)[4] * 1e-3) - model.predict(test))[:, 0] / 1e-3
    true_gain = 2.0 * test[:, 0] + 0.3
    assert np.abs(gain(leading) - true_gain).max() > 1.0               # a constant gain, off by 2 |x0|
    np.testing.assert_allclose(gain(cross), true_gain, atol=2e-3)
    np.testing.assert_allclose(cross.predict(test)[:, 0], truth, atol=1e-4)
    assert cross.ridge_penalty_ <= 1e-9                                  # noise 1e-5: hardly any penalty
    noisy = y + 0.5 * rng.standard_normal(600)
    assert PolynomialRegression("ridge", 2, 1, term_scaling="global").fit(X, noisy[:, None], groups=windows) \
        .ridge_penalty_ > 100 * cross.ridge_penalty_                                    # noise 0.5: the cross-validation damps it
    rom = solid_rom(4, 4, {"type": "poly", "method": "ridge", "quadratic_modes": 2, "cross_modes": 1}, "quadratic")
    F, U = smooth_data()
    rom.fit(F, U, windows=np.arange(len(F)) // 3)
    np.testing.assert_allclose(rom.to_online().predict(F[:20] + 0.01), rom.predict(F[:20] + 0.01), atol=1e-9)
    for bad, message in (({"method": "ols"}, "'regressor.method' is 'ols'; allowed: lasso-bic, ridge"),
                         ({"cross_modes": -1}, "'regressor.cross_modes' is -1; allowed: an integer >= 0")):
        with pytest.raises(ValueError, match=message):
            solid_rom(regressor={"type": "poly", **bad}).fit(F, U)


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
    quadratic = PolynomialRegression("ridge", term_scaling="global").fit(X, y[:, None], groups=windows)
    assert np.abs(gain(quadratic) - true_gain).max() > 1.0                 # off by 1.5 x0^2 - its best constant
    for method in ("ridge", "lasso-bic"):
        cubic = PolynomialRegression(method, 2, cubic_modes=1, term_scaling="global").fit(X, y[:, None], groups=windows)
        assert len(cubic.cube_i_) == 6 and cubic.coefficients_.shape == (3 + 6 + 6, 1)
        np.testing.assert_allclose(gain(cubic), true_gain, atol=2e-3)
        np.testing.assert_allclose(cubic.predict(test)[:, 0], response(test), atol=1e-4)
    rom = solid_rom(4, 4, {"type": "poly", "method": "ridge", "quadratic_modes": 2, "cubic_modes": 2}, "quadratic")
    F, U = smooth_data()
    rom.fit(F, U, windows=np.arange(len(F)) // 3)
    assert len(rom.online_arrays()["cube_i"]) == 4 + 3 + 3                   # (0, 0, 0..3), (0, 1, 1..3), (1, 1, 1..3)
    np.testing.assert_allclose(rom.to_online().predict(F[:20] + 0.01), rom.predict(F[:20] + 0.01), atol=1e-9)
    assert "cube_i" not in solid_rom(4, 4, "poly").fit(F, U).online_arrays()   # degree 2: as before
    with pytest.raises(ValueError, match="'regressor.cubic_modes' is -1"):
        solid_rom(regressor={"type": "poly", "cubic_modes": -1}).fit(F, U)


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
    model = solid_rom(3, 4, regressor, decoder).fit(F, U)
    online = model.to_online()
    test = F[:40] + 0.01
    np.testing.assert_allclose(online.predict(test), model.predict(test), rtol=0, atol=1e-9)
    np.testing.assert_allclose(online.full_field(model.reduced_predict(test)), model.predict(test), atol=1e-12)


def test_rom_is_accurate_on_unseen_smooth_data():
    F, U = smooth_data(m=400)
    model = solid_rom(3, 4).fit(F[:300], U[:300])
    error = np.linalg.norm(model.predict(F[300:]) - U[300:], axis=1) / np.linalg.norm(U[300:] - U.mean(0), axis=1)
    assert np.median(error) < 0.05


def test_save_load_round_trips_bit_for_bit(tmp_path):
    F, U = smooth_data()
    model = solid_rom(3, 4, decoder="quadratic").fit(F, U)
    arrays = model.online_arrays()
    path = model_file.save(tmp_path / "model.npz", arrays, {"regressor": "rbf", "note": "x"})
    loaded_arrays, metadata = model_file.load_arrays(path)
    assert metadata["note"] == "x" and metadata["format"] == model_file.FORMAT
    assert set(loaded_arrays) == set(arrays)
    for name, value in arrays.items():
        assert loaded_arrays[name].dtype == value.dtype and loaded_arrays[name].tobytes() == value.tobytes(), name
    reloaded = load_rom(path)
    direct = model.to_online()
    for f in F[:20]:
        assert reloaded(f).tobytes() == direct(f).tobytes()


def test_model_files_with_pickles_or_garbage_are_refused(tmp_path):
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, metadata_json=np.frombuffer(b"{}", dtype=np.uint8), E=np.array([{"a": 1}], dtype=object))
    with pytest.raises(model_file.ModelFileError, match="array 'E' holds Python objects"):
        load_rom(pickled)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"this is not a zip file")
    with pytest.raises(model_file.ModelFileError, match="not a valid .npz"):
        load_rom(garbage)
    with pytest.raises(model_file.ModelFileError, match="does not exist"):
        load_rom(tmp_path / "missing.npz")
    with pytest.raises(model_file.ModelFileError, match="dtype object"):
        model_file.save(tmp_path / "x.npz", {"a": np.array([None], dtype=object)}, {})


def test_clone_and_grid_search_work_on_the_estimator():
    F, U = smooth_data()
    model = solid_rom(2, 2, {"type": "rbf", "smoothing": 1e-6})
    copy = clone(model)
    assert copy.settings() == model.settings() and copy is not model and copy.encoder is not model.encoder
    search = GridSearchCV(SolidRom(PodEncoder(), RbfRegression(), PodDecoder()),
                          {"encoder__modes": [1, 3], "decoder__modes": [1, 4]}, cv=3, scoring="neg_mean_squared_error")
    search.fit(F, U)
    assert search.best_params_ == {"encoder__modes": 3, "decoder__modes": 4}


def test_mode_numbers_are_capped_by_the_data_and_bad_ones_reported():
    F, U = smooth_data(m=20)
    assert solid_rom(3, 50).fit(F, U).modes == (3, 19)    # at most m - 1 modes
    for bad, message in ((0, "'decoder.modes' is 0; allowed: an integer >= 1"),
                         (2.5, "'decoder.modes' must be an integer"), (True, "'decoder.modes' must be an integer")):
        with pytest.raises(ValueError, match=message):
            solid_rom(3, bad).fit(F, U)
    with pytest.raises(ValueError, match="regressor must be one of the registered regressors"):
        SolidRom(regressor=PodEncoder()).fit(F, U)


@pytest.mark.parametrize("parts", [{}, {"regressor": PolynomialRegression()},
                                   {"decoder": QuadraticManifoldDecoder()},
                                   {"regressor": PolynomialRegression("ridge", cross_modes=1)}])
def test_the_estimator_passes_scikit_learns_checks(parts):
    from sklearn.utils.estimator_checks import check_estimator
    results = check_estimator(SolidRom(**parts), on_fail=None)
    failed = [f"{r['check_name']}: {r['exception']}" for r in results if r["status"] == "failed"]
    assert len(results) > 40 and failed == []


@pytest.mark.parametrize("smoothing", [0.0, 1e-3])
def test_thin_plate_spline_matches_scipys_rbf_interpolator(smoothing):
    from scipy.interpolate import RBFInterpolator

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
    standard = solid_rom(3, 4, "poly", "quadratic").fit(F, U)
    single = solid_rom(3, 4, {"type": "poly", "term_scaling": "global"}, "quadratic").fit(F, U)
    scale = single.regressor_.feature_scale_
    assert np.all(scale == scale[0]) and not np.all(standard.regressor_.feature_scale_ == scale[0])
    np.testing.assert_allclose(single.to_online().predict(F[:20] + 0.01), single.predict(F[:20] + 0.01), atol=1e-9)
    for model in (standard, single):
        error = np.linalg.norm(model.predict(F) - U, axis=1) / np.linalg.norm(U - U.mean(0), axis=1)
        assert np.median(error) < 0.05
    with pytest.raises(ValueError, match="'regressor.term_scaling' is 'minmax'"):
        solid_rom(3, 4, {"type": "poly", "term_scaling": "minmax"}).fit(F, U)


def test_the_chosen_modes_are_the_fewest_within_the_tolerance_of_the_best():
    from rom_component.static.selection import SelectionTable
    errors = np.array([[8.5e-3, 2.8e-3, 6.8e-4, 5.0e-4, 4.2e-4],     # r_u = 5
                       [8.4e-3, 2.7e-3, 6.6e-4, np.nan, 4.1e-4]])    # r_u = 9 (one cell not computed)
    table = SelectionTable([5, 10, 20, 30, 60], [5, 9], errors, errors / 0.2, (60, 9), (18, 4), 100, 5)
    assert table.chosen == table.best == (60, 9)                     # no tolerance: the best
    table.tolerance = 1.0                                            # within twice the best (8.2e-4)
    assert table.chosen == (20, 5) and "chosen (fewest modes within 100% of the best): r_f = 20, r_u = 5" in table.format()
    table.tolerance = 0.25                                           # 5.1e-4: r_f = 30 at r_u = 5
    assert table.chosen == (30, 5)


def test_the_holdout_plot_gives_each_curve_its_own_colour_and_keeps_the_legend_off_the_curves():
    """The tube's table: 7 r_u for 2 splits, 14 curves, more than matplotlib's 10 default colours."""
    from rom_component.static.selection import SelectionTable
    from rom_component.static.training_plots import _pyplot, holdout_figure
    plt = _pyplot()
    errors = np.linspace(1e-3, 1e-1, 7 * 6).reshape(7, 6)
    tables = {split: SelectionTable([1, 2, 3, 4, 5, 6], [1, 3, 5, 7, 9, 11, 13], errors, errors, (3, 9), (2, 5),
                                    100, 20, split) for split in ("windows", "snapshots")}
    fig = holdout_figure(plt, tables)
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert len(lines) == 14
    for split, style in (("windows", "-"), ("snapshots", "--")):
        mine = [line for line in lines if line.get_label().endswith(split)]
        assert len(mine) == 7 and {line.get_linestyle() for line in mine} == {style}
        assert len({tuple(line.get_color()) for line in mine}) == 7          # one colour per r_u
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1                           # beside the axes, not over them
    assert "best r_f = 3" in ax.get_title()
    plt.close(fig)


def test_the_trust_plot_puts_windows_inside_the_range_at_zero_and_says_when_none_left_it():
    from types import SimpleNamespace

    from rom_component.report.plots import _pyplot, trust_figure
    plt = _pyplot()
    e = np.linspace(1e-3, 2e-3, 6)
    inside = SimpleNamespace(label="in", trust=np.array([np.nan, 0.0, 0.0, 0.0, 0.0, 0.0]))
    fig = trust_figure(plt, inside, {"_e": e})
    ax = fig.axes[0]
    points = np.vstack([c.get_offsets() for c in ax.collections])
    assert len(points) == 5 and np.all(points[:, 0] == 0.0) and np.allclose(points[:, 1], e[1:])
    assert ax.get_title() == "in: the ROM never left its training range"
    plt.close(fig)
    beyond = SimpleNamespace(label="out", trust=np.array([0.0, 0.0, 0.3, 2.0, 0.0, 12.0]))
    fig = trust_figure(plt, beyond, {"_e": e, "rom_fallback_windows": 2})
    ax = fig.axes[0]
    inside_points, beyond_points = (c.get_offsets() for c in ax.collections)
    assert np.all(inside_points[:, 0] == 0.0) and len(inside_points) == 3
    assert np.allclose(beyond_points[:, 0], [0.3, 2.0, 12.0])
    assert ax.get_xscale() == "symlog" and "2 windows fell back" in ax.get_title()
    plt.close(fig)


def test_a_curve_hidden_under_a_bit_identical_one_says_so_in_the_legend():
    from types import SimpleNamespace

    from rom_component.report.plots import _pyplot, iterations_figure, noted_labels
    assert noted_labels([("a", np.ones(3)), ("b", np.ones(3)), ("c", np.ones(3) + 1e-12)]) == \
        ["a", "b (identical to a: hidden under it)", "c"]
    plt = _pyplot()
    time = np.linspace(0.1, 1.0, 10)

    def run(label, iterations):
        return SimpleNamespace(label=label, time=time, iterations=np.asarray(iterations),
                               predicted=lambda: time > 0.5, switch_time=0.5)
    reference = SimpleNamespace(label="fom", time=time, iterations=np.full(10, 3))
    e = np.linspace(1e-3, 2e-3, 10)
    items = [(run("rom", np.full(10, 3)), reference, {"_e": e}),
             (run("fmu", np.full(10, 3)), reference, {"_e": e.copy()}),
             (run("rom_rf10", np.full(10, 4)), reference, {"_e": 2 * e})]
    fig = iterations_figure(plt, "fom", items)
    for ax in fig.axes:
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert labels == ["rom", "fmu (identical to rom: hidden under it)", "rom_rf10"]
    plt.close(fig)


@pytest.mark.parametrize("regressor, decoder", [("rbf", "linear"), ("rbf", "quadratic"),
                                                ({"type": "poly", "cubic_modes": 2}, "linear"),
                                                ({"type": "poly", "method": "ridge", "cross_modes": 2}, "quadratic")])
def test_the_closed_form_jacobian_matches_central_differences(regressor, decoder):
    """d u / d f through decoder, regressor and encoder, against central differences of predict (error O(h^2))."""
    F, U = smooth_data()
    model = solid_rom(3, 4, regressor, decoder).fit(F, U, windows=np.arange(len(F)) // 4)
    f = F[7] + 0.3 * (F[8] - F[7])          # between snapshots: the RBF's kernel is smooth there
    J = model.jacobian(f)
    assert J.shape == (U.shape[1], F.shape[1])
    h = 1e-5 * np.linalg.norm(F.std(axis=0))
    steps = h * np.eye(F.shape[1])
    differences = (model.predict(f + steps) - model.predict(f - steps)).T / (2 * h)
    assert np.linalg.norm(J - differences) <= 1e-6 * np.linalg.norm(J)
    assert np.linalg.norm(J) > 0


def test_the_jacobians_factors_are_thin_and_multiply_to_it():
    F, U = smooth_data()
    model = solid_rom(5, 3, {"type": "poly", "method": "ridge", "quadratic_modes": 2}).fit(F, U)
    left, right = model.jacobian_factors(F[3])
    assert left.shape == (U.shape[1], 3) and right.shape == (3, F.shape[1])
    np.testing.assert_allclose(left @ right, model.jacobian(F[3]), rtol=1e-12, atol=1e-14)



def test_an_ill_conditioned_spline_system_is_explained_not_warned_raw():
    """Sub-iterations of one window give nearly equal reduced forces: scipy's LinAlgWarning becomes a note."""
    import warnings

    from rom_component.static.regression import RbfRegression
    x = np.concatenate([np.linspace(0.0, 1.0, 20), np.linspace(0.0, 1.0, 20) + 1e-13])[:, None]
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no raw warning may escape
        fitted = RbfRegression(smoothing=0.0).fit(x, np.sin(x))
    assert len(fitted.notes_) == 1 and "thin-plate-spline system of 40 snapshots is ill-conditioned" in fitted.notes_[0]
    assert "model.regressor.smoothing > 0 (it is 0)" in fitted.notes_[0]
    assert RbfRegression(smoothing=1e-3).fit(x, np.sin(x)).notes_ == []
