"""Stability of the tube's coupling: the Gauss-Seidel spectral radius from the components, against
theory, and the stability matrix through `cosim stability`."""

import csv
import math

import pytest

from cases.tube.stability import tube_critical_stiffness, tube_eigenvalue
from cosim.cli import main
from cosim.scene import load_scene
from coupler.scene_rules import resolve_plugins
from tests.conftest import TUBE_SCENE
from workflow.gauss_seidel import gauss_seidel_spectrum

R0 = math.sqrt(1.0 / math.pi)


def spectral_radius(*overrides):
    scene = load_scene(TUBE_SCENE, ['tube.wall_law="linear"', *overrides])
    resolve_plugins(scene)
    return gauss_seidel_spectrum(scene).radius


@pytest.mark.parametrize("dt, measured", [(0.1, 0.318), (0.01, 23.0), (0.001, 1955.0)])
def test_spectral_radius_scales_as_one_over_stiffness_and_matches_the_measured_critical_stiffness(dt, measured):
    """Plain Gauss-Seidel on the linear-wall tube diverged below stiffness factors 0.318, 23.0 and 1955 (measured)."""
    rho = spectral_radius(f"time.dt={dt}", f"time.end={dt}")
    assert rho == pytest.approx(measured, rel=2e-3)     # the critical factor is rho at factor 1
    assert spectral_radius(f"time.dt={dt}", f"time.end={dt}", "tube.stiffness_factor=10") == pytest.approx(rho / 10, rel=1e-3)


def test_spectral_radius_tends_to_the_continuum_theory_as_the_mesh_is_refined():
    theory = abs(tube_eigenvalue(1, 12500.0, 1.0, R0, 6.0, 0.1, 10.0))
    assert theory == pytest.approx(0.3659, rel=1e-3)
    assert tube_critical_stiffness(12500.0, 1.0, R0, 6.0, 0.1, 10.0) == pytest.approx(theory)
    errors = [abs(spectral_radius("time.dt=0.1", "time.end=0.1", f"tube.cells={cells}") / theory - 1.0)
              for cells in (100, 400, 1600)]
    assert errors[0] > errors[1] > errors[2] and errors[2] < 0.05


def test_the_stability_matrix_gauss_seidel_converges_exactly_where_the_spectral_radius_is_below_one(tmp_path, capsys):
    code = main(["stability", str(TUBE_SCENE), "--out", str(tmp_path), "--grid", "tube.stiffness_factor=0.1,1,10",
                 "--grid", "time.dt=0.1",
                 "--methods", "none,iqn-ils", "--windows", "5", "--quiet"])
    assert code == 0, capsys.readouterr().err
    with open(tmp_path / "spectral.csv", newline="") as stream:
        radius = {float(r["stiffness_factor"]): float(r["spectral_radius"]) for r in csv.DictReader(stream)}
    with open(tmp_path / "sweep.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 6
    for row in rows:
        factor = float(row["tube.stiffness_factor"])
        converged = row["failure"] == ""
        if '"none"' in row["coupling.acceleration"]:
            assert converged == (radius[factor] < 1.0), (factor, radius[factor], row["failure"])
            if not converged:   # named as divergence even where a component gave up first
                assert row["failure"] == "diverged" and "the coupling residual grew" in row["failure_message"]
            else:               # the residual shrinks per iteration by the computed spectral radius
                assert float(row["contraction"]) == pytest.approx(radius[factor], rel=0.1)
        else:
            assert converged, row
    assert (tmp_path / "stability.png").stat().st_size > 20_000 and (tmp_path / "contraction.png").stat().st_size > 10_000


def test_the_surrogate_quasi_newton_converges_wherever_iqn_ils_does(tmp_path, capsys):
    """The stability matrix's acceptance for iqn-surrogate: on every (stiffness, dt) where IQN-ILS converges, the
    surrogate quasi-Newton (its online surrogate in use from window 6) converges too."""
    code = main(["stability", str(TUBE_SCENE), "--out", str(tmp_path), "--grid", "tube.stiffness_factor=0.1,1,100",
                 "--grid", "time.dt=0.1,0.001",
                 "--methods", "iqn-ils,iqn-surrogate", "--windows", "12", "--quiet"])
    assert code == 0, capsys.readouterr().err
    with open(tmp_path / "sweep.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    outcome = {}
    for row in rows:
        method = "iqn-surrogate" if "iqn-surrogate" in row["coupling.acceleration"] else "iqn-ils"
        outcome[method, row["tube.stiffness_factor"], row["time.dt"]] = row["failure"] == ""
    assert len(outcome) == 12
    for (method, factor, dt), converged in outcome.items():
        if method == "iqn-ils" and converged:
            assert outcome["iqn-surrogate", factor, dt], (factor, dt)


def test_contraction_plot_of_a_sweep_without_plain_runs_says_so(tmp_path):
    """The contraction is measured on unaccelerated runs only: a sweep of accelerations alone gets a plot that says
    so, without matplotlib's empty-legend warning."""
    import warnings

    from cases.tube.stability import plot_contraction
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plot_contraction([{"coupling.acceleration": '{type="iqn-ils"}', "contraction": "0.5"}], [], tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 1000
