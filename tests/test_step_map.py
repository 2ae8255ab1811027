"""The step-map ROM of a structure with inertia, on a structure whose step map is known: a chain of masses and
springs integrated by Newmark's average acceleration, whose windows are repeated with perturbed forces as a
coupling's sub-iterations repeat them."""

import numpy as np
import pytest

from benchmarks.newmark_chain import DT, chain, newmark_calls
from rom_component.dynamic.model import StepMapRom, UnstableModel, WindowData, companion_radius, holdout, stabilised


def test_a_linear_structure_s_step_map_is_learned_to_round_off():
    """Newmark on a linear structure is the two-step map z+ = W (x+ + 2 x0 + x-) + A1 z0 + A2 z- in the full
    coordinates: with every mode kept, a rollout over unseen windows repeats the structure to 1e-8."""
    data = newmark_calls()
    model = StepMapRom(force_modes=12, disp_modes=12, history=2, ridge=0.0).fit(data, 120)
    assert model.validation_error(data, 121, 160) < 1e-8
    # undamped, non-dissipative: every eigenvalue of the linear part on the unit circle
    assert model.map_.radius == pytest.approx(1.0, abs=1e-6)


def test_sub_iterations_identify_the_instantaneous_response():
    """The calls of one window differ only in the force: the map's response to it, W in the full coordinates, is
    the structure's (M / (beta dt^2) + K)^-1."""
    data = newmark_calls()
    model = StepMapRom(force_modes=12, disp_modes=12, history=2, ridge=0.0).fit(data, 120)
    M, K = chain()
    exact = np.linalg.inv(M / (0.25 * DT ** 2) + K)
    encoder, decoder = model.bases_.encoder, model.bases_.decoder
    # W_f in the full coordinates: decoder modes @ W_f @ encoder's Jacobian
    full = decoder.components_[:, :12] @ model.map_.W_f @ encoder.jacobian()[:12]
    np.testing.assert_allclose(full, exact, atol=1e-9 * np.abs(exact).max())


def test_holdout_chooses_enough_history_and_modes():
    """One window of displacement history cannot carry a structure's velocity, nor two force modes its load:
    the hold-out, run over whole unseen windows, prefers two windows and every mode."""
    data = newmark_calls()
    rows = holdout(data, 120, {"force_modes": [2, 12], "disp_modes": [12], "history": [1, 2], "ridge": [0.0],
                               "quadratic_modes": [0]}, 0.25)
    best = min(rows, key=lambda row: row.error)
    assert best.settings["history"] == 2 and best.settings["force_modes"] == 12 and best.error < 1e-8
    assert all(row.error > 1e3 * best.error for row in rows if row is not best)


def test_stabilisation_scales_every_eigenvalue_exactly():
    rng = np.random.default_rng(1)
    A = rng.standard_normal((3, 6))
    radius = companion_radius(A)
    assert radius > 1.0
    scaled, before, after = stabilised(A, 0.9)
    assert before == pytest.approx(radius) and after == pytest.approx(0.9, rel=1e-12)
    same, _, untouched = stabilised(A, 2 * radius)
    assert same is A and untouched == pytest.approx(radius)


def test_a_growing_free_response_is_refused():
    """Quadratic terms fitted on noise-free data can run away under a held force: such a model is refused."""
    data = newmark_calls()
    model = StepMapRom(force_modes=12, disp_modes=12, history=2, ridge=0.0).fit(data, 120)
    step = model.map_
    step.Q = np.full((12, 3), 1e3)          # a strongly growing quadratic term on the leading two modes
    step.quadratic_modes = 2
    step.pairs = np.triu_indices(2)
    x, z, xc, zc = model.bases_.reduced(12, 12)
    with pytest.raises(UnstableModel, match="free response grows"):
        model.check_free_response(xc[120], zc, xc, 120)


def test_window_data_needs_one_converged_call_per_window_in_order():
    data = newmark_calls(windows=4)
    with pytest.raises(ValueError, match="one converged call per window"):
        WindowData(data.F, data.U, data.window, np.zeros(len(data.window), dtype=bool))
