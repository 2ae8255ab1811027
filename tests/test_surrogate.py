"""The online interface surrogate (coupler.surrogate) and the quasi-Newton that takes its Jacobian as a prior."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.checkpoint import pack, unpack
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.accelerations.quasi_newton import IQNILS
from coupler.accelerations.surrogate import IQNSurrogate
from coupler.surrogate import InterfaceSurrogate
from tests.conftest import ROOT
from tests.test_coupler_math import iterate

SETTINGS = {"start_window": 4, "retrain_every": 50, "training_lag": 1, "memory": 20, "rcond": 1e-8,
            "free_response_order": 1}


class FixedJacobian:
    """A surrogate that answers a fixed Jacobian of H (the acceleration's view of one)."""

    def __init__(self, J: np.ndarray) -> None:
        self.J = J
        self.current: tuple[np.ndarray, np.ndarray] | None = (np.zeros(len(J)), np.zeros(len(J)))

    def jacobian_factors(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.J.copy(), np.eye(len(self.J))


def linear_problem(n: int = 12, seed: int = 3):
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A = Q @ np.diag(rng.uniform(-4.0, 0.8, n)) @ Q.T      # strongly coupled: plain iteration diverges
    b = rng.standard_normal(n)
    return A, b, np.linalg.solve(np.eye(n) - A, b)


def test_with_the_exact_jacobian_the_first_update_is_newtons_step_to_the_solution():
    A, b, solution = linear_problem()
    acceleration = IQNSurrogate(0.1, filter="none")
    acceleration.use_model(FixedJacobian(A))
    x, iterations = iterate(acceleration, lambda x: A @ x + b, np.zeros(len(b)))
    assert iterations == 2                       # one update, then the check
    np.testing.assert_allclose(x, solution, rtol=1e-10, atol=1e-10)


def test_without_a_surrogate_it_is_iqn_ils_to_the_last_bit():
    A, b, _ = linear_problem()
    plain, prior_free = IQNILS(0.1, filter="none"), IQNSurrogate(0.1, filter="none")
    x1, k1 = iterate(plain, lambda x: A @ x + b, np.zeros(len(b)))
    x2, k2 = iterate(prior_free, lambda x: A @ x + b, np.zeros(len(b)))
    assert k1 == k2 and np.array_equal(x1, x2)


def test_without_a_surrogate_and_two_data_blocks_it_is_preconditioned_iqn_ils_to_the_last_bit():
    """The surrogate passes IQN-ILS's preconditioner and the data blocks on (the blocks were once taken for it)."""
    A, b, _ = linear_problem()
    blocks = [len(b) // 2, len(b) - len(b) // 2]
    plain = IQNILS(0.1, filter="none", preconditioner="residual-sum", block_sizes=blocks)
    prior_free = IQNSurrogate(0.1, filter="none", preconditioner="residual-sum", block_sizes=blocks)
    x1, k1 = iterate(plain, lambda x: A @ x + b, np.zeros(len(b)))
    x2, k2 = iterate(prior_free, lambda x: A @ x + b, np.zeros(len(b)))
    assert prior_free.preconditioner.active and prior_free.preconditioner.kind == "residual-sum"
    assert k1 == k2 and np.array_equal(x1, x2)


@pytest.mark.parametrize("wrong", [lambda A: -3.0 * A, lambda A: A + 2.0 * np.eye(len(A)), lambda A: A.T @ A])
def test_a_wrong_surrogate_costs_iterations_never_the_solution(wrong):
    """A deliberately wrong Jacobian: the window falls back to IQN-ILS and still converges to the fixed point."""
    A, b, solution = linear_problem()
    acceleration = IQNSurrogate(0.1, filter="none")
    acceleration.use_model(FixedJacobian(wrong(A)))
    x, iterations = iterate(acceleration, lambda x: A @ x + b, np.zeros(len(b)))
    assert iterations is not None
    np.testing.assert_allclose(x, solution, rtol=1e-8, atol=1e-8)
    assert acceleration.fallback_windows == 1


class LinearStatic:
    """A static model fitted by least squares (an exact model of a linear participant)."""

    def fit(self, inputs, outputs, windows):
        X = np.hstack([inputs, np.ones((len(inputs), 1))])
        self.coef = np.linalg.lstsq(X, outputs, rcond=None)[0]
        return self

    def predict(self, f):
        return f @ self.coef[:-1] + self.coef[-1]

    def jacobian(self, f):
        return self.coef[:-1].T.copy()

    def jacobian_factors(self, f):
        return self.jacobian(f), np.eye(len(f))


def coupled_windows(surrogate: InterfaceSurrogate, S, D, forcing, windows: int, iterations: int = 4):
    """Serial windows of x (force) -> y = S x (static) -> x~ = D y + c(t) (dynamic), relaxed iterations."""
    x = np.zeros(S.shape[1])
    for n in range(1, windows + 1):
        surrogate.start_window()
        c = forcing(n)
        for _ in range(iterations):
            y = S @ x
            x_tilde = D @ y + c
            surrogate.observe(x, y, x_tilde)
            x = x + 0.3 * (x_tilde - x) + 0.01 * np.sin(np.arange(len(x)) * n)   # a few varied sub-iterations
        surrogate.end_window(True)
    surrogate.start_window()      # the next window: a training due now is taken into use
    return x


def test_the_surrogate_learns_a_linear_coupled_map_and_predicts_its_fixed_point():
    """Static S (fitted), dynamic D (secant pairs) and a forcing linear in time (free response extrapolated): the
    Jacobian is D S and the predicted start is the next window's fixed point."""
    rng = np.random.default_rng(0)
    n = 6
    S = 0.5 * rng.standard_normal((n, n))
    D = 0.5 * rng.standard_normal((n, n))
    base, slope = rng.standard_normal(n), rng.standard_normal(n)
    forcing = lambda k: base + 0.1 * k * slope
    surrogate = InterfaceSurrogate(SETTINGS, True, LinearStatic)
    x_last = coupled_windows(surrogate, S, D, forcing, 8)
    try:
        assert surrogate.ready and surrogate.trainings == 1
        y = S @ x_last
        np.testing.assert_allclose(surrogate.jacobian(x_last, y), D @ S, rtol=1e-8, atol=1e-10)
        # the converged window's dynamic call is the last one seen; its fixed point for window 9:
        start = surrogate.predict_start(x_last)
        assert start is not None
        # the surrogate's forcing estimate extrapolates the free response of the last calls (not converged ones
        # here), so check the fixed-point property of what it solved instead: x = D S x + c0 for one c0
        c0 = start - D @ (S @ start)
        expected = np.linalg.solve(np.eye(n) - D @ S, c0)
        np.testing.assert_allclose(start, expected, rtol=1e-9, atol=1e-9)
    finally:
        surrogate.close()


def test_the_surrogate_state_round_trips_through_a_checkpoint():
    rng = np.random.default_rng(1)
    n = 5
    S, D = 0.4 * rng.standard_normal((n, n)), 0.4 * rng.standard_normal((n, n))
    surrogate = InterfaceSurrogate(SETTINGS, False, LinearStatic)
    x = coupled_windows(surrogate, S, D, lambda k: np.full(n, 0.2 * k), 7)
    document, arrays = pack(surrogate.checkpoint_state())
    restored = InterfaceSurrogate(SETTINGS, False, LinearStatic)
    restored.restore_checkpoint_state(unpack(document, arrays))
    try:
        y = D @ x
        assert restored.window == surrogate.window and restored.trainings == surrogate.trainings
        np.testing.assert_array_equal(restored.jacobian(x, y), surrogate.jacobian(x, y))
        np.testing.assert_array_equal(restored.predict_start(x), surrogate.predict_start(x))
    finally:
        surrogate.close()
        restored.close()


def test_a_tube_run_with_the_online_surrogate_converges_every_window_to_the_plain_runs_answer(tmp_path):
    """FOM-FOM tube with the online ROM surrogate: every window meets the criterion on full-order outputs, and
    the inlet pressure stays within 1e-3 of the plain run's (the criterion's own spread is 1e-4 per window)."""
    from coupler.run import run_scene
    common = ["time.end=4", "tube.cells=40"]
    run_scene(load_scene(ROOT / "scenes/tube_fom.toml", common), tmp_path / "plain", progress=False)
    run_scene(load_scene(ROOT / "scenes/tube_fom.toml", [*common, "coupling.surrogate.start_window=10",
                                                          "coupling.surrogate.retrain_every=10"]),
              tmp_path / "surrogate", progress=False)
    plain, online = RunResults(tmp_path / "plain/results.h5"), RunResults(tmp_path / "surrogate/results.h5")
    assert online.windows.converged.all()
    p0, p1 = plain.fields()["pressure"][:, 0], online.fields()["pressure"][:, 0]
    assert np.linalg.norm(p1 - p0) / np.linalg.norm(p0) < 1e-3
    attributes = online.attributes
    assert attributes["surrogate_trainings"] >= 3 and attributes["surrogate_updates"] > 0
    assert online.scene["coupling"]["acceleration"]["type"] == "iqn-surrogate"


@pytest.mark.parametrize("overrides, message", [
    (["coupling.surrogate.retrain_every=5"], "without 'coupling.surrogate.start_window'"),
    (["coupling.predictor=\"surrogate\""], "no 'coupling.surrogate' table"),
    (["coupling.surrogate.start_window=3", "coupling.surrogate.static=\"pump\""], "'coupling.surrogate.static' is 'pump'"),
    (["coupling.surrogate.start_window=3", "coupling.surrogate.memory=0"], "coupling.surrogate.memory"),
    (["coupling.surrogate.start_window=3", "coupling.surrogate.training_windows=1"],
     "'coupling.surrogate.training_windows' is 1; allowed: 0 \\(every call so far\\) or at least 2"),
    (["coupling.surrogate.start_window=3", "coupling.surrogate.model.bogus=1"],
     "'coupling.surrogate.model.bogus' is not a ROM part"),
    (["coupling.surrogate.start_window=3", "coupling.surrogate.model_type=\"nothing\""],
     "'coupling.surrogate.model_type': no surrogate model 'nothing'"),
])
def test_bad_surrogate_tables_are_named_before_a_run_starts(overrides, message):
    from cosim.errors import SceneError
    from coupler.run import prepare
    with pytest.raises(SceneError, match=message):
        prepare(load_scene(ROOT / "scenes/tube_fom.toml", overrides))


def test_an_exact_oracle_start_saves_iterations_on_the_tube(capsys, tmp_path):
    """The floor benchmark's small case: a start at the converged value needs fewer iterations than the plain
    start, and a start 10 % of the window's change away about as many as plain."""
    from benchmarks.coupling_floor import main
    main(["scenes/tube_fom.toml", "--out", str(tmp_path / "floor"), "--eps", "0", "0.1", "--skip", "5",
          "--set", "time.end=3", "--set", "tube.cells=40"])
    rows = {line.split("|")[1].strip(): float(line.split("|")[2]) for line in capsys.readouterr().out.splitlines()
            if line.startswith("| plain") or line.startswith("| oracle")}
    assert rows["oracle eps=0"] < rows["plain"] - 0.5
    assert rows["oracle eps=0.1"] > rows["oracle eps=0"]



@pytest.mark.parametrize("start", [0, 1])
def test_the_surrogate_from_window_1_waits_for_two_windows_of_calls_and_window_0_is_none(tmp_path, start):
    from coupler.run import run_scene
    run_scene(load_scene(ROOT / "scenes/tube_fom.toml", ["time.end=2", "tube.cells=40",
                                                         f"coupling.surrogate.start_window={start}",
                                                         "coupling.surrogate.retrain_every=4"]),
              tmp_path / "run", progress=False)
    with RunResults(tmp_path / "run/results.h5") as run:
        assert run.windows.converged.all()
        assert run.attributes.get("surrogate_trainings", 0) == (4 if start else 0)


def test_a_failed_training_stops_the_run_in_one_line_with_its_status_failed(tmp_path, monkeypatch):
    import json

    from cosim.errors import CosimError
    from coupler.run import run_scene
    from rom_component.static.surrogate_model import RomResponse

    def failing(self, inputs, outputs, windows):
        raise ValueError("the fit could not be made")
    monkeypatch.setattr(RomResponse, "fit", failing)
    with pytest.raises(CosimError) as caught:
        run_scene(load_scene(ROOT / "scenes/tube_fom.toml", ["time.end=2", "tube.cells=40",
                                                             "coupling.surrogate.start_window=5"]),
                  tmp_path / "run", progress=False)
    assert str(caught.value).endswith("coupling.surrogate: the static model's training on the calls of windows 1 to "
                                      "3 failed: the fit could not be made")
    assert json.loads((tmp_path / "run" / "status.json").read_text())["state"] == "failed"
