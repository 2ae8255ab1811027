"""Acceleration, convergence measures, extrapolation and mapping on known problems."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from cosim.errors import SceneError
from coupler import mapping as mapping_module
from coupler.accelerations import Acceleration
from coupler.accelerations.quasi_newton import IQNILS
from coupler.accelerations.relaxation import Aitken, ConstantRelaxation
from coupler.convergence import make_measure, resolve_measure
from coupler.extrapolation import Extrapolation
from coupler.mapping import MAPPINGS, make_mapping


def iterate(acceleration, H, x0, tol=1e-10, max_iterations=200):
    """Fixed-point iterations of H with ``acceleration``; returns (x, iterations) or (x, None)."""
    x = x0.copy()
    acceleration.start_window()
    for k in range(1, max_iterations + 1):
        xt = H(x)
        acceleration.observe(x, xt)
        if np.linalg.norm(xt - x) <= tol * max(1.0, np.linalg.norm(xt)):
            acceleration.end_window()
            return xt, k
        if not np.all(np.isfinite(xt)) or np.linalg.norm(xt) > 1e12:
            return xt, None
        x = acceleration.next_iterate()
    return x, None


def windows(acceleration, problems, limit=100):
    """Time windows of x = A x + b, one (A, b) each, starting from the last window's x; the iterations of each
    and the final x of each (every window ends, converged or not)."""
    x, iterations, solutions = np.zeros(len(problems[0][1])), [], []
    for A, b in problems:
        acceleration.start_window()
        for k in range(1, limit):  # noqa: B007 (k, the iterations taken, is read after the loop)
            x_tilde = A @ x + b
            acceleration.observe(x, x_tilde)
            if np.linalg.norm(x_tilde - x) < 1e-10 * np.linalg.norm(x_tilde):
                break
            x = acceleration.next_iterate()
        acceleration.end_window()
        iterations.append(k)
        solutions.append(x.copy())
    return iterations, solutions


@pytest.mark.parametrize("n", [5, 20, 60])
def test_iqn_ils_solves_a_linear_problem_in_at_most_n_plus_1_iterations(n):
    rng = np.random.default_rng(n)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A = Q @ np.diag(rng.uniform(-3.0, 0.9, n)) @ Q.T  # plain iteration diverges (eigenvalues down to -3)
    b = rng.standard_normal(n)
    H = lambda x: A @ x + b
    solution = np.linalg.solve(np.eye(n) - A, b)
    x, iterations = iterate(IQNILS(0.1, max_used_iterations=n + 5, filter="none"), H, np.zeros(n))
    assert iterations is not None and iterations <= n + 2  # n + 1 updates, plus the final check
    np.testing.assert_allclose(x, solution, rtol=1e-7, atol=1e-8)
    _, plain = iterate(Acceleration(), H, np.zeros(n))
    assert plain is None


def nonlinear_map():
    rng = np.random.default_rng(7)
    n = 30
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    M = Q @ np.diag(np.linspace(-2.5, -0.2, n)) @ Q.T
    b = rng.standard_normal(n)
    return (lambda x: M @ x + 0.1 * np.tanh(x) + b), n


def test_aitken_and_iqn_ils_converge_where_plain_gauss_seidel_diverges():
    H, n = nonlinear_map()
    _, plain = iterate(Acceleration(), H, np.zeros(n))
    assert plain is None
    for acceleration in (Aitken(0.3), IQNILS(0.3, max_used_iterations=50)):
        x, iterations = iterate(acceleration, H, np.zeros(n))
        assert iterations is not None, type(acceleration).__name__
        assert np.linalg.norm(H(x) - x) < 1e-8


def test_constant_relaxation_is_x_plus_omega_r():
    relaxation = ConstantRelaxation(0.25)
    relaxation.start_window()
    relaxation.observe(np.array([1.0, 2.0]), np.array([3.0, 6.0]))
    np.testing.assert_allclose(relaxation.next_iterate(), [1.5, 3.0])


def test_reused_windows_make_the_next_window_start_with_a_quasi_newton_step():
    rng = np.random.default_rng(3)
    n = 8
    A = np.diag(rng.uniform(-2.0, 0.5, n))
    b = rng.standard_normal(n)
    iqn = IQNILS(0.1, max_used_iterations=50, reused_time_windows=2, filter="qr2", filter_limit=1e-10)
    _, first = iterate(iqn, lambda x: A @ x + b, np.zeros(n))
    # a new window with a new right-hand side: the secant information of the last window still holds
    _, second = iterate(iqn, lambda x: A @ x + 2 * b, np.zeros(n))
    assert second <= 3 < first
    fresh = IQNILS(0.1, max_used_iterations=50, reused_time_windows=2, filter="qr2", filter_limit=1e-10)
    _, without_history = iterate(fresh, lambda x: A @ x + 2 * b, np.zeros(n))
    assert without_history > second


def test_reuse_zero_serves_the_previous_window_to_the_first_update_only():
    """preCICE's reused_time_windows = 0, checked against updates computed by hand."""
    iqn = IQNILS(0.5, reused_time_windows=0, filter="qr2", filter_limit=1e-6)
    iqn.start_window()
    x0, xt0 = np.array([0.0, 0.0]), np.array([1.0, 2.0])
    iqn.observe(x0, xt0)
    np.testing.assert_array_equal(iqn.next_iterate(), x0 + 0.5 * (xt0 - x0))   # no column yet: relaxation
    x1, xt1 = np.array([0.5, 1.0]), np.array([1.5, 1.0])
    iqn.observe(x1, xt1)
    v, w = (xt1 - x1) - (xt0 - x0), xt1 - xt0
    iqn.next_iterate()
    iqn.end_window()
    # next window, first iteration: the previous window's column gives a quasi-Newton step
    iqn.start_window()
    y0, yt0 = np.array([1.0, 1.0]), np.array([2.0, 0.0])
    iqn.observe(y0, yt0)
    r = yt0 - y0
    np.testing.assert_allclose(iqn.next_iterate(), yt0 + w * (-(v @ r) / (v @ v)), rtol=1e-14)
    # second iteration: only this window's column is left
    y1, yt1 = np.array([1.2, 0.5]), np.array([1.0, 0.7])
    iqn.observe(y1, yt1)
    v2, w2, r2 = (yt1 - y1) - (yt0 - y0), yt1 - yt0, yt1 - y1
    np.testing.assert_allclose(iqn.next_iterate(), yt1 + w2 * (-(v2 @ r2) / (v2 @ v2)), rtol=1e-14)
    assert iqn.columns_used == 1


def two_columns(kind: str) -> IQNILS:
    """Columns (newest first) v1 = (0, 1e-4, 0) and v2 = (1, 0, 0): orthogonal, of very different size."""
    iqn = IQNILS(0.5, filter=kind, filter_limit=1e-3)
    iqn.start_window()
    x = np.zeros(3)
    for r in ([0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1e-4, 1.0]):
        iqn.observe(x, np.array(r))
    return iqn


def test_qr1_and_qr2_filters_differ_on_a_small_independent_column():
    qr1, qr2 = two_columns("qr1"), two_columns("qr2")
    step1, step2 = qr1.next_iterate(), qr2.next_iterate()
    assert (qr1.columns_used, qr1.columns_filtered) == (1, 1)   # |R_11| = 1e-4 < 1e-3 ||R||_F
    assert (qr2.columns_used, qr2.columns_filtered) == (2, 0)   # orthogonal: |R_11| = ||v_1||
    assert not np.allclose(step1, step2)


@pytest.mark.parametrize("kind", ["qr1", "qr1-absolute", "qr2", "none"])
def test_zero_and_duplicate_columns_never_break_the_solve(kind):
    iqn = IQNILS(0.5, filter=kind, filter_limit=1e-3)
    iqn.start_window()
    x = np.zeros(2)
    for xt in ([1.0, 0.0], [1.0, 0.0], [2.0, 1.0], [3.0, 2.0]):   # a zero column, then two equal ones
        iqn.observe(x, np.array(xt))
        step = iqn.next_iterate()
        assert np.isfinite(step).all()
    assert iqn.columns_used == 1


def test_columns_beyond_max_used_iterations_are_deleted_for_good():
    iqn = IQNILS(0.5, max_used_iterations=2, filter="qr2", filter_limit=1e-3)
    iqn.start_window()
    x = np.zeros(4)
    for xt in np.eye(4):
        iqn.observe(x, xt)
    assert sum(len(V) for V, _ in iqn._windows) == 2
    iqn.observe(x, np.eye(4)[2])    # repeats the newest: a zero column that the filter drops
    iqn.next_iterate()
    assert iqn.columns_used == 1    # the deleted older columns do not come back


@pytest.mark.parametrize("kind", ["qr1", "qr1-absolute", "qr2"])
def test_filters_drop_a_repeated_secant_column(kind):
    iqn = IQNILS(0.5, filter=kind, filter_limit=1e-8)
    iqn.start_window()
    x = np.array([0.0, 0.0, 0.0])
    for xt in ([1.0, 0.0, 0.0], [2.0, 1.0, 0.0], [3.0, 2.0, 0.0]):
        iqn.observe(x, np.array(xt))
    # the two residual differences are equal: one of them must go
    iqn.next_iterate()
    assert iqn.columns_filtered == 1 and iqn.columns_used == 1


def measure(table: dict):
    return make_measure(resolve_measure({"data": "x", **table}, "m"))


def test_convergence_measures():
    old, new = np.array([1.0, 1.0]), np.array([1.0, 1.1])
    rel = measure({"type": "relative", "limit": 0.1})
    assert rel.measure(old, new) and rel.value == pytest.approx(0.1 / np.linalg.norm(new))
    absolute = measure({"type": "absolute", "limit": 0.05})
    assert not absolute.measure(old, new) and absolute.value == pytest.approx(0.1)
    rms = measure({"type": "absolute-rms", "limit": 0.08})
    assert rms.measure(old, new) and rms.value == pytest.approx(0.1 / np.sqrt(2))
    residual = measure({"type": "residual-relative", "limit": 0.5})
    residual.start_window()
    assert not residual.measure(old, new) and residual.value == 1.0
    assert residual.measure(old, np.array([1.0, 1.04])) and residual.value == pytest.approx(0.4)


def test_combinators_any_of_and_all_of():
    """Kratos's relative_norm_previous_residual: absolute RMS or relative, 5e-3."""
    members = [{"type": "absolute-rms", "limit": 5e-3}, {"type": "relative", "limit": 5e-3}]
    any_of, all_of = measure({"type": "any-of", "measures": members}), measure({"type": "all-of", "measures": members})
    small_values = (np.full(100, 1e-3), np.full(100, 1.003e-3))     # rms 3e-6 met, relative 3e-3 met
    large_change = (np.full(100, 1.0), np.full(100, 1.004))         # rms 4e-3 met, relative 4e-3 met
    rms_only = (np.full(100, 1e-4), np.full(100, 2e-4))              # rms 1e-4 met, relative 0.5 not
    relative_only = (np.full(100, 100.0), np.full(100, 100.1))      # rms 0.1 not, relative 1e-3 met
    neither = (np.full(100, 1.0), np.full(100, 1.1))                # rms 0.1, relative 0.09
    for (old, new), expected_any, expected_all in [(small_values, True, True), (large_change, True, True),
                                                   (rms_only, True, False), (relative_only, True, False),
                                                   (neither, False, False)]:
        assert any_of.measure(old, new) is expected_any
        assert all_of.measure(old, new) is expected_all
    assert "any-of(absolute-rms" in any_of.summary()


def test_a_setting_that_does_not_belong_to_the_plugin_is_an_error():
    from cosim.errors import SceneError
    from coupler.accelerations import resolve_acceleration
    with pytest.raises(SceneError, match="unknown key 'coupling.acceleration.filter'"):
        resolve_acceleration({"type": "aitken", "filter": "qr2"})
    with pytest.raises(SceneError, match="known accelerations: none, constant, aitken, iqn-ils"):
        resolve_acceleration({"type": "newton"})
    assert resolve_acceleration("aitken") == {"type": "aitken", "data": [], "initial_relaxation": 0.5}
    with pytest.raises(SceneError, match="known accelerations: .*, kratos-aitken, kratos-iqn-ils, kratos-mvqn$"):
        resolve_acceleration("iqn-ils-bounded")
    with pytest.raises(SceneError, match="'m.measures.1.limit' is -1.0"):
        resolve_measure({"data": "x", "type": "any-of", "measures": [{"type": "relative", "limit": 1e-3},
                                                                    {"type": "relative", "limit": -1}]}, "m")


@pytest.mark.parametrize("former, name", [("aitken-bounded", "kratos-aitken"), ("iqn-ils-plain", "kratos-iqn-ils"),
                                          ("mvqn", "kratos-mvqn")])
def test_a_former_acceleration_name_is_an_alias_of_the_same_class_and_settings(former, name):
    """A scene naming a Kratos variant by its former name gets the same class and settings; its resolved table keeps
    the name it gave (what a run records stays as it was)."""
    from coupler.accelerations import ACCELERATIONS, make_acceleration, resolve_acceleration
    assert ACCELERATIONS.get(former) is ACCELERATIONS.get(name) is ACCELERATIONS.lookup(former, "a")
    assert ACCELERATIONS.aliases_of(name) == [former] and former not in ACCELERATIONS.names()
    old, new = resolve_acceleration(former), resolve_acceleration(name)
    assert old == {**new, "type": former}
    assert type(make_acceleration(old, [3])) is ACCELERATIONS.get(name)


def test_a_registry_refuses_an_alias_that_is_already_a_name():
    from cosim.registry import Registry
    registry: Registry[object] = Registry("thing")
    registry.register("a", aliases=("b",))(type("A", (), {}))
    for name, aliases in (("b", ()), ("c", ("a",)), ("c", ("b",))):
        with pytest.raises(ValueError, match="is registered twice"):
            registry.register(name, aliases)(type("C", (), {}))
    assert registry.names() == ["a"] and registry.get("b").__name__ == "A"


def test_extrapolation_is_exact_for_polynomials_of_its_order():
    for order, f in ((0, lambda t: 3.0), (1, lambda t: 2 * t + 1), (2, lambda t: t * t - t)):
        extrapolation = Extrapolation(order)
        for t in range(5):
            extrapolation.store(np.array([f(t)]))
        if order < 2:
            assert extrapolation.predict()[0] == pytest.approx(f(5))
    quadratic = Extrapolation(2)
    for t in range(3):
        quadratic.store(np.array([float(t * t)]))
    # preCICE's second-order formula 2.5 x_n - 2 x_{n-1} + 0.5 x_{n-2}
    assert quadratic.predict()[0] == pytest.approx(2.5 * 4 - 2 * 1 + 0)


def test_nearest_neighbour_mappings():
    rng = np.random.default_rng(1)
    source = rng.uniform(size=(40, 2))
    target = source[rng.permutation(40)] + 1e-6
    forces = rng.standard_normal((40, 2))
    nearest = {"type": "nearest-neighbour", "constraint": "consistent"}
    consistent = make_mapping(nearest, source, target, (40, 2), (40, 2), "test")
    back = make_mapping(nearest, target, source, (40, 2), (40, 2), "test")
    np.testing.assert_array_equal(back(consistent(forces)), forces)
    coarse = source[::4]
    conservative = make_mapping({**nearest, "constraint": "conservative"}, source, coarse, (40, 2), (10, 2), "test")
    np.testing.assert_allclose(conservative(forces).sum(axis=0), forces.sum(axis=0), rtol=1e-14)
    constant = np.tile([1.5, -2.0], (10, 1))
    np.testing.assert_allclose(make_mapping(nearest, coarse, source, (10, 2), (40, 2), "test")(constant),
                               np.tile([1.5, -2.0], (40, 1)))
    with pytest.raises(SceneError, match=r"identity mapping needs equal shapes, got \(80,\) and \(20,\)"):
        make_mapping({"type": "identity"}, source, coarse, (80,), (20,), "test")


def test_iqn_imvj_learns_the_jacobian_of_a_linear_problem_across_windows():
    """x = A x + b with b changing per window: after one window IMVJ has A's inverse Jacobian, IQN-ILS (reuse 0) not."""
    from coupler.accelerations.quasi_newton import IQNILS, IQNIMVJ
    rng = np.random.default_rng(0)
    n = 20
    A = rng.standard_normal((n, n))
    A *= -3.0 / np.linalg.norm(A, 2)     # plain fixed-point iteration diverges
    loads = rng.standard_normal((6, n))
    counts = {}
    for name, acceleration in (("ils", IQNILS(0.1, reused_time_windows=0)), ("imvj", IQNIMVJ(0.1))):
        counts[name], solutions = windows(acceleration, [(A, b) for b in loads])
        for x, b in zip(solutions, loads):
            np.testing.assert_allclose(x, np.linalg.solve(np.eye(n) - A, b), rtol=1e-8, atol=1e-9)
    assert counts["imvj"][0] == counts["ils"][0] > 10          # the first window: the same method
    assert counts["imvj"][1:] == [2] * 5                      # then one exact quasi-Newton step and the check
    assert max(counts["ils"][1:]) > 10
    iterations, _ = windows(IQNIMVJ(0.1, restart_windows=3), [(A, b) for b in loads])  # RS-ZERO every 3rd window
    assert iterations[1:3] == [2, 2] and iterations[3] > 10 and iterations[4:] == [2, 2]


def test_a_scheme_with_the_acceleration_predictor_starts_from_the_next_update():
    """predictor = "acceleration": a window's first iterate is the update the acceleration proposes after convergence."""
    from coupler.accelerations.relaxation import ConstantRelaxation
    from coupler.schemes import CouplingScheme
    class Served:                  # a participant that no backend change reaches (the scheme's arithmetic alone)
        backend_changed = False
    scheme = CouplingScheme([Served(), Served()], [], accelerated=["f"], predictor="acceleration")
    scheme.values = {"f": np.array([1.0, 1.0])}
    scheme._extrapolation.store(scheme.values["f"])
    scheme.acceleration = ConstantRelaxation(0.5)
    scheme.acceleration.start_window()
    scheme._observe(np.array([1.0, 1.0]), np.array([3.0, 5.0]))
    scheme._predict_next_window(converged=True)
    np.testing.assert_allclose(scheme._predicted()["f"], [2.0, 3.0])   # x + 0.5 (x_tilde - x)
    np.testing.assert_allclose(scheme._predicted()["f"], [1.0, 1.0])   # used once; then the last values


def test_iqn_ils_drops_reused_columns_when_the_map_changes():
    """x = A x + b: after five windows A jumps (a wall switching branch); the old columns are dropped, not trusted."""
    rng = np.random.default_rng(3)
    n = 12
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    stiff, soft = Q @ np.diag(np.linspace(-0.5, -2.0, n)) @ Q.T, Q @ np.diag(np.linspace(-5.0, -40.0, n)) @ Q.T
    results = {}
    for ratio in (2.0, 0.0):
        iqn = IQNILS(0.01, reused_time_windows=8, stale_step_ratio=ratio)
        problems = [(stiff if window < 5 else soft, rng.standard_normal(n) * (1.0 + window)) for window in range(10)]
        iterations = windows(iqn, problems, limit=200)[0]
        results[ratio] = (iqn.stale_windows, iterations)
    stale, iterations = results[2.0]
    assert stale >= 1 and max(iterations) < 199
    assert results[0.0][0] == 0      # with the check off nothing is dropped


def switched_window(acceleration, A, B, b, switch_after, tell, limit=200):
    """One window of x = H(x): H(x) = A x + b for the first ``switch_after`` calls, then B x + b (a ROM's
    window the solid FOM finishes). ``tell``: call ``map_changed`` at the switch. Iterations after it."""
    x = np.zeros(len(b))
    acceleration.start_window()
    for k in range(1, limit):
        if k == switch_after + 1 and tell:
            acceleration.map_changed()
        x_tilde = (A if k <= switch_after else B) @ x + b
        acceleration.observe(x, x_tilde)
        if k > switch_after and np.linalg.norm(x_tilde - x) < 1e-10 * np.linalg.norm(x_tilde):
            return k - switch_after
        x = acceleration.next_iterate()
    return None


@pytest.mark.parametrize("kind", ["iqn-ils", "iqn-imvj"])
def test_a_changed_map_starts_the_quasi_newton_afresh(kind):
    """The difference spanning a change of map (a ROM's window the solid FOM finishes) mixes the two maps'
    outputs: kept, it stalls the quasi-Newton on the new map; dropped, the old map's columns still help
    (the maps are near); with every column dropped it has its n + 1 property on the new map."""
    from coupler.accelerations.quasi_newton import IQNIMVJ
    rng = np.random.default_rng(11)
    n = 10
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = Q @ np.diag(rng.uniform(-3.0, -0.2, n)) @ Q.T
    B = A + 0.5 * rng.standard_normal((n, n)) / np.sqrt(n)        # the other backend: near, not equal
    b = rng.standard_normal(n)

    def make(policy):
        if kind == "iqn-ils":
            return IQNILS(0.1, reused_time_windows=2, filter="none", on_map_change=policy)
        return IQNIMVJ(0.1, filter="none", on_map_change=policy)

    after = {}
    for policy, tell in (("drop-all", True), ("drop-span", True), ("blind", False)):
        acceleration = make("drop-span" if policy == "blind" else policy)
        switched_window(acceleration, A, A, b, 0, False)   # a window of the old map first: reused columns / Jacobian
        acceleration.end_window()
        after[policy] = switched_window(acceleration, A, B, b, 4, tell)
        assert acceleration.maps_changed == int(tell)
    assert after["drop-all"] is not None and after["drop-all"] <= n + 2
    assert after["drop-span"] is not None and after["drop-span"] <= 2 * n
    assert after["blind"] is None or after["blind"] > 2 * n
    with pytest.raises(ValueError, match="on_map_change 'forget' not in"):
        IQNILS(0.1, on_map_change="forget")


@pytest.mark.parametrize(("count_emptied_windows", "used"), [(True, 1), (False, 2)])
def test_a_window_the_filter_emptied_counts_among_the_reused_unless_asked_as_precice(count_emptied_windows, used):
    """Windows A, B, C of one column each, B's a multiple of C's: the filter empties B. Reusing two windows, the
    fourth window's first update takes C's column alone, or (as preCICE, which drops emptied windows) C's and A's."""
    acceleration = IQNILS(0.1, reused_time_windows=2, stale_step_ratio=0.0, filter="qr2",
                          count_emptied_windows=count_emptied_windows)
    x = np.zeros(3)
    for first, second in ([1, 0, 0], [1, 1, 0]), ([0, 0, 1], [0, 0, 2]), ([5, 0, 0], [5, 0, 3]):
        acceleration.start_window()
        acceleration.observe(x, np.array(first, float))
        acceleration.next_iterate()
        acceleration.observe(x, np.array(second, float))
        acceleration.next_iterate()
        acceleration.end_window()
    acceleration.start_window()
    acceleration.observe(x, np.array([1.0, 2.0, 3.0]))
    acceleration.next_iterate()
    assert acceleration.columns_used == used and acceleration.columns_filtered == 1


RBF_BASES = ["compact-polynomial-c0", "compact-polynomial-c2", "compact-polynomial-c4", "compact-polynomial-c6"]


@pytest.mark.parametrize("basis", RBF_BASES)
def test_each_compact_rbf_basis_reproduces_linear_fields_and_its_transpose_conserves_the_sum(basis):
    """Wendland's C0 to C6 with the linear polynomial: a linear field is mapped exactly (consistent), and the
    conservative form keeps the total (forces)."""
    rng = np.random.default_rng(5)
    source, target = rng.random((60, 2)), rng.random((45, 2))
    linear = 1.0 + 2.0 * source[:, 0] - 3.0 * source[:, 1]
    settings = {"type": "rbf", "support_radius": 0.5, "basis": basis}
    consistent = make_mapping({**settings, "constraint": "consistent"}, source, target, (60,), (45,), "test")
    np.testing.assert_allclose(consistent(linear), 1.0 + 2.0 * target[:, 0] - 3.0 * target[:, 1], atol=1e-10)
    forces = rng.standard_normal(60)
    conservative = make_mapping({**settings, "constraint": "conservative"}, source, target, (60,), (45,), "test")
    assert conservative(forces).sum() == pytest.approx(forces.sum(), rel=1e-10)


def test_an_rbf_with_a_dead_axis_maps_as_on_the_other_axes_alone():
    """preCICE's y-dead on a 2-D interface: the mapping of the x coordinates alone (preCICE 3.4.1's own values
    agree with it to 2e-12, thin-plate splines on these vertices)."""
    a, b, field = rbf_probe(False)
    dead = make_mapping({"type": "rbf", "basis": "thin-plate-splines", "dead_axes": "y"}, a, b, (25,), (15,), "t")
    alone = make_mapping({"type": "rbf", "basis": "thin-plate-splines"}, a[:, :1], b[:, :1], (25,), (15,), "t")
    both = make_mapping({"type": "rbf", "basis": "thin-plate-splines"}, a, b, (25,), (15,), "t")
    np.testing.assert_array_equal(dead(field), alone(field))
    assert np.abs(dead(field) - both(field)).max() > 0.1


@pytest.mark.parametrize("dimensions", [2, 3])
def test_cell_interpolation_is_exact_on_linear_fields_inside_the_cells_and_conserves_sums(dimensions):
    """Triangles (2-D) or tetrahedra (3-D) of a Delaunay mesh: a linear field interpolated exactly at points inside
    them, whatever cell the search meets first; points outside take the nearest node; the conservative form keeps
    the total."""
    from scipy.spatial import Delaunay
    rng = np.random.default_rng(3)
    source = rng.random((80, dimensions))
    cells = Delaunay(source).simplices
    inside = 0.2 + 0.6 * rng.random((50, dimensions))
    outside = np.full((1, dimensions), 1.5)
    target = np.vstack([inside, outside])
    slope = np.arange(1.0, dimensions + 1.0)
    settings = {"type": "cell-interpolation", "constraint": "consistent"}
    mapping = make_mapping(settings, source, target, (80,), (51,), "t", source_cells=cells)
    field = 2.0 + source @ slope
    mapped = mapping(field)
    np.testing.assert_allclose(mapped[:50], 2.0 + inside @ slope, atol=1e-12)
    corner = np.argmin(np.linalg.norm(source - outside, axis=1))
    # the node's own value, copied: exact (recomputed as a 3-term dot, not the matrix-vector product's row, it
    # differs in the last bit on some BLAS kernels, as OpenBLAS's Katmai one)
    assert mapped[50] == field[corner]
    forces = rng.standard_normal(51)
    conservative = make_mapping({**settings, "constraint": "conservative"}, target, source, (51,), (80,), "t",
                                target_cells=cells)
    assert conservative(forces).sum() == pytest.approx(forces.sum(), rel=1e-12)


def test_a_nearest_projection_onto_a_3d_surfaces_triangles_is_exact_on_linear_fields():
    """A tilted plane's triangles (preCICE's nearest-projection in 3-D): points off the plane take the linear
    field at their projection onto it; a point beyond the surface, with no edges given, its nearest node; the
    conservative form keeps the total."""
    from scipy.spatial import Delaunay
    x, y = (g.ravel() for g in np.meshgrid(np.linspace(0, 1, 6), np.linspace(0, 1, 6)))
    nodes = np.column_stack([x, y, 0.3 * x + 0.2 * y])
    triangles = Delaunay(nodes[:, :2]).simplices
    normal = np.array([-0.3, -0.2, 1.0]) / np.linalg.norm([-0.3, -0.2, 1.0])
    rng = np.random.default_rng(9)
    on_plane = rng.uniform(0.1, 0.9, (30, 2))
    on_plane = np.column_stack([on_plane, 0.3 * on_plane[:, 0] + 0.2 * on_plane[:, 1]])
    points = np.vstack([on_plane + 0.05 * normal, [[1.5, 1.5, 0.5]]])
    field = lambda p: 1.0 + p[:, 0] + 2.0 * p[:, 1] + 3.0 * p[:, 2]      # noqa: E731
    mapping = make_mapping({"type": "nearest-element", "constraint": "consistent"}, nodes, points, (36,), (31,),
                           "t", source_cells=triangles)
    mapped = mapping(field(nodes))
    np.testing.assert_allclose(mapped[:30], field(on_plane), atol=1e-12)
    assert mapped[30] == field(nodes)[np.argmin(np.linalg.norm(nodes - points[30], axis=1))]
    forces = rng.standard_normal(31)
    conservative = make_mapping({"type": "nearest-element", "constraint": "conservative"}, points, nodes, (31,),
                                (36,), "t", target_cells=triangles)
    assert conservative(forces).sum() == pytest.approx(forces.sum(), rel=1e-12)


def test_element_mappings_without_elements_refuse_or_take_the_nearest_node_as_asked():
    rng = np.random.default_rng(4)
    source, target = rng.random((20, 2)), rng.random((7, 2))
    for kind in ("nearest-element", "cell-interpolation"):
        with pytest.raises(SceneError, match="needs the line elements"):
            make_mapping({"type": kind, "constraint": "consistent"}, source, target, (20,), (7,), "t")
        mapped = make_mapping({"type": kind, "constraint": "consistent", "without_elements": "nearest-node"},
                              source, target, (20,), (7,), "t")(np.arange(20.0))
        nearest = np.argmin(np.linalg.norm(target[:, None] - source[None], axis=2), axis=1)
        np.testing.assert_array_equal(mapped, nearest)


def test_cell_interpolation_outside_the_cells_projects_onto_the_lines():
    """A unit square of two triangles and its four edges; a point beside it takes the interpolation at its
    projection onto the nearest edge (preCICE's fallback to nearest-projection)."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    cells = np.array([[0, 1, 2], [0, 2, 3]])
    lines = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    target = np.array([[0.25, 0.5], [1.5, 0.25]])
    mapped = make_mapping({"type": "cell-interpolation"}, square, target, (4,), (2,), "t", source_lines=lines,
                          source_cells=cells)(square @ [1.0, 10.0])
    np.testing.assert_allclose(mapped, [0.25 + 5.0, 1.0 + 2.5], atol=1e-12)


def rbf_probe(collinear: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The vertices and field of tests/data/precice_rbf_reference.json (25 -> 15 vertices, on a line if asked)."""
    rng = np.random.default_rng(4)
    a, b = rng.uniform(0, 1, (25, 2)), rng.uniform(0.1, 0.9, (15, 2))
    if collinear:
        a[:, 1] = b[:, 1] = 0.5
    return a, b, np.sin(3 * a[:, 0]) + a[:, 1] ** 2 + 0.3


PRECICE_RBF = json.loads((Path(__file__).parent / "data" / "precice_rbf_reference.json").read_text())["cases"]


@pytest.mark.parametrize("case", PRECICE_RBF, ids=lambda c: "-".join(
    [c["basis"], c["polynomial"], c["constraint"]] + ["collinear"] * c["collinear"]))
def test_each_rbf_basis_and_polynomial_maps_as_precice_does(case):
    """Every basis function preCICE lists, with its polynomial separate, on or off, consistent and conservative:
    the values preCICE 3.4.1 itself mapped (its Gaussian cut off at a support radius, its compact thin-plate spline,
    Wendland's C8), to round-off."""
    a, b, field = rbf_probe(case["collinear"])
    settings = {key: case[key] for key in ("basis", "polynomial", "constraint", "support_radius", "shape_parameter")
                if key in case}
    mapping = make_mapping({"type": "rbf", **settings}, a, b, (25,), (15,), "test")
    np.testing.assert_allclose(mapping(field), case["mapped"], rtol=0, atol=1e-10)


@pytest.mark.parametrize("constraint", ["consistent", "conservative"])
@pytest.mark.parametrize("polynomial", ["separate", "on", "off"])
def test_an_rbf_mapping_maps_alike_with_dense_and_with_sparse_factors(polynomial, constraint, monkeypatch):
    """Small meshes map with dense kernel matrices and a dense LU, larger ones with sparse matrices and a sparse LU:
    the same map to round-off, on preCICE's reference case."""
    a, b, field = rbf_probe(False)
    settings = {"type": "rbf", "basis": "compact-polynomial-c2", "support_radius": 0.6, "polynomial": polynomial,
                "constraint": constraint}
    dense = make_mapping(settings, a, b, (25,), (15,), "test")
    monkeypatch.setattr(mapping_module, "DENSE_VALUES", 0)
    sparse = make_mapping(settings, a, b, (25,), (15,), "test")
    assert isinstance(dense.matrix.B, np.ndarray) and not isinstance(sparse.matrix.B, np.ndarray)
    values = np.column_stack([field, field ** 2])
    np.testing.assert_allclose(dense(values), sparse(values), rtol=0, atol=1e-12 * np.abs(sparse(values)).max())


@pytest.mark.parametrize("polynomial", ["separate", "on"])
@pytest.mark.parametrize("basis", ["thin-plate-splines", "gaussian", "compact-tps-c2", "compact-polynomial-c8"])
def test_an_rbf_with_its_polynomial_is_exact_on_linear_fields_and_conserves_sums(basis, polynomial):
    rng = np.random.default_rng(11)
    source, target = rng.random((40, 3)), rng.random((30, 3))
    settings = {"type": "rbf", "basis": basis, "polynomial": polynomial,
                **({"shape_parameter": 3.0} if basis == "gaussian" else {}),
                **({"support_radius": 0.9} if basis.startswith("compact") else {})}
    linear = 1.0 - source @ [2.0, 0.5, 3.0]
    mapped = make_mapping(settings, source, target, (40,), (30,), "test")(linear)
    np.testing.assert_allclose(mapped, 1.0 - target @ [2.0, 0.5, 3.0], atol=1e-8)
    forces = rng.standard_normal((40, 3))
    conservative = make_mapping({**settings, "constraint": "conservative"}, source, target, (40, 3), (30, 3), "test")
    np.testing.assert_allclose(conservative(forces).sum(axis=0), forces.sum(axis=0), rtol=1e-10)


@pytest.mark.parametrize(("settings", "message"), [
    ({"basis": "compact-tps-c2"}, "missing key 'm.support_radius' (the compact-tps-c2 basis needs a support radius)"),
    ({"basis": "multiquadrics"}, "missing key 'm.shape_parameter'"),
    ({"basis": "gaussian"}, "takes a shape_parameter or a support_radius, one of them"),
    ({"basis": "gaussian", "shape_parameter": 1.0, "support_radius": 1.0}, "one of them"),
    ({"basis": "cubic"}, "'m.basis' is 'cubic'"),
])
def test_an_rbf_basis_without_its_parameter_is_refused_naming_the_key(settings, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        MAPPINGS.settings({"type": "rbf", **settings}, "m")


@pytest.mark.parametrize("line", ["axis", "diagonal"])
def test_an_rbf_mapping_from_collinear_vertices_drops_the_dead_axis(line):
    """Vertices on a line (preCICE's fake fluid), to vertices off it: the polynomial keeps the constant and the one
    direction the line spans (a linear field along it is exact), where the system was singular or mismatched."""
    s = np.linspace(0.0, 1.0, 59)
    source = np.column_stack([s, np.zeros_like(s)]) if line == "axis" else np.column_stack([s, s])
    rng = np.random.default_rng(7)
    target = rng.random((20, 2))
    along = source[:, 0] if line == "axis" else source[:, 0] + source[:, 1]
    mapped = make_mapping({"type": "rbf", "support_radius": 0.3, "constraint": "consistent"}, source, target,
                          (59,), (20,), "test")(2.0 + 5.0 * along)
    expected = 2.0 + 5.0 * (target[:, 0] if line == "axis" else 2.0 * target[:, 0])   # the line's own coordinate
    on_line = target.copy()
    on_line[:, 1] = 0.0 if line == "axis" else on_line[:, 0]
    back = make_mapping({"type": "rbf", "support_radius": 0.3, "constraint": "consistent"}, source, on_line,
                        (59,), (20,), "test")(2.0 + 5.0 * along)
    assert np.isfinite(mapped).all()
    np.testing.assert_allclose(back, expected, atol=1e-9)


# --- the quasi-Newton preconditioners: a weight per data block --------------------------------------------------
def two_block_problem(scale):
    """x = A x + b for two blocks of 4 unknowns, the second in units ``scale`` times smaller."""
    rng = np.random.default_rng(3)
    Q, _ = np.linalg.qr(rng.standard_normal((8, 8)))
    A = Q @ np.diag(np.linspace(-2.0, 0.5, 8)) @ Q.T
    S = np.diag([1.0] * 4 + [scale] * 4)
    return (lambda x: S @ (A @ np.linalg.solve(S, x)) + S @ np.arange(8.0)), S


@pytest.mark.parametrize("preconditioner", ["value", "residual"])
def test_a_preconditioned_iqn_ils_does_not_see_the_units_of_each_data_block(preconditioner):
    """Weights one over each block's norm make the least squares, hence every iterate, the same whatever unit a block
    is in; with no weights ('constant') the block in the large unit dominates and the iterates differ."""
    def iterates(kind, scale):
        H, S = two_block_problem(scale)
        acceleration = IQNILS(0.5, filter="none", preconditioner=kind, block_sizes=[4, 4])
        x, seen = np.zeros(8), []
        acceleration.start_window()
        for _ in range(6):
            acceleration.observe(x, H(x))
            x = acceleration.next_iterate()
            seen.append(np.linalg.solve(S, x))
        return np.array(seen)
    np.testing.assert_allclose(iterates(preconditioner, 1e-6), iterates(preconditioner, 1.0), rtol=1e-6, atol=1e-9)
    assert not np.allclose(iterates("constant", 1e-6), iterates("constant", 1.0), rtol=1e-3)


def test_the_residual_sum_preconditioner_sums_each_blocks_share_of_the_residual_over_the_window():
    """Weights 1 / sum over the window's iterations of |r_i| / |r|: in the first window at every iteration; from
    then on replaced only when one changes by an order of magnitude, and summed afresh each window."""
    from coupler.accelerations.preconditioners import Preconditioner
    p = Preconditioner("residual-sum", [2, 1])
    p.start_window()
    r = np.array([3.0, 0.0, 4.0])                      # shares 0.6 and 0.8
    np.testing.assert_allclose(p.update(r, r), [1 / 0.6, 1 / 0.6, 1 / 0.8])
    np.testing.assert_allclose(p.update(r, r), [1 / 1.2, 1 / 1.2, 1 / 1.6])        # the first window: each time
    p.end_window()
    p.start_window()                                   # summed afresh: 0.6 is half of 1.2, kept
    s = np.array([7.0, 0.0, 24.0])                     # shares 0.28 and 0.96
    for _ in range(16):                                # sums 0.28 k, 0.96 k: within an order of magnitude to k = 16
        np.testing.assert_allclose(p.update(s, s), [1 / 1.2, 1 / 1.2, 1 / 1.6])
    np.testing.assert_allclose(p.update(s, s), [1 / 4.76, 1 / 4.76, 1 / 16.32])   # k = 17: 10.2 times, taken
    p.end_window()
    p.start_window()                                   # summed afresh: 0.8 is a 20th of 16.32, taken
    np.testing.assert_allclose(p.update(r, r), [1 / 0.6, 1 / 0.6, 1 / 0.8])
    zero = np.zeros(3)                                 # no residual: the weights stay
    np.testing.assert_allclose(p.update(zero, zero), [1 / 0.6, 1 / 0.6, 1 / 0.8])


def test_frozen_preconditioner_weights_stay_those_of_the_window_it_froze_at():
    from coupler.accelerations.preconditioners import Preconditioner
    p = Preconditioner("residual", [1, 1], freeze_after=1)
    p.start_window()
    np.testing.assert_allclose(p.update(np.ones(2), np.array([2.0, 4.0])), [0.5, 0.25])
    p.end_window()
    p.start_window()
    np.testing.assert_allclose(p.update(np.ones(2), np.array([8.0, 1.0])), [0.5, 0.25])
