"""Physics checks of the tube solvers (in-process)."""

import math

import numpy as np
import pytest

from cosim.errors import ComponentError, SceneError
from fluid_component.inlet import DuffingInlet, TableInlet
from fluid_component.tube import TubeFluid
from solid_component.tube import TubeSolid
from tests.conftest import REFERENCE


def make_fluid(**inlet):
    fluid = TubeFluid()
    fluid.instantiate({"inlet": inlet} if inlet else {})
    fluid.enter_initialization_mode(0.0, 12.0)
    return fluid


def test_rigid_wall_gives_plug_flow_and_implicit_euler_pressure_gradient():
    fluid = make_fluid()
    dt, a0 = 0.1, np.ones(101)
    for n in range(5):
        t = n * dt
        v_old = fluid.inlet(t)
        p = fluid.step(t, dt, {"section": a0})["pressure"]
        v_new = fluid.inlet(t + dt)
        np.testing.assert_allclose(fluid.v, v_new, rtol=0, atol=1e-11)
        gradient = np.diff(p) / fluid.dx
        np.testing.assert_allclose(gradient, -(v_new - v_old) / dt, rtol=1e-9, atol=1e-10)
        assert p[-1] == pytest.approx(0.0, abs=1e-12)


def test_moving_wall_conserves_mass_through_the_faces():
    """Interior volume change equals inflow minus outflow (plus the stabilisation flux)."""
    fluid = make_fluid()
    x = np.linspace(0, 10, 101)
    dt = 0.1
    a_new = 1.0 + 0.01 * np.sin(np.pi * x / 10)
    a_old = fluid.a.copy()
    p = fluid.step(0.0, dt, {"section": a_new})["pressure"]
    v, a = fluid.v, a_new
    alpha = 1.0 / (6.0 + fluid.dx / dt)
    mass_face = 0.5 * (a[:-1] + a[1:]) * 0.5 * (v[:-1] + v[1:])
    stab_face = -alpha * np.diff(p)  # stabilisation flux through each face
    volume_change = fluid.dx * np.sum(a[1:-1] - a_old[1:-1]) / dt
    net_outflow = (mass_face[-1] + stab_face[-1]) - (mass_face[0] + stab_face[0])
    assert volume_change == pytest.approx(-net_outflow, rel=1e-8)
    assert volume_change > 0.01  # the wall really moved


def test_newton_converges_quadratically():
    fluid = make_fluid()
    a = 1.0 + 0.02 * np.linspace(0, 1, 101)
    v, p = fluid.v.copy(), fluid.p.copy()
    norms = []
    for _ in range(4):
        r = fluid.residual(v, p, a, fluid.a, fluid.v, fluid.inlet(0.1), 0.1)
        norms.append(np.linalg.norm(r))
        from scipy.linalg import solve_banded
        d = solve_banded((4, 4), fluid._jacobian_band(v, a, 0.1).copy(), r)
        v, p = v - d[0::2], p - d[1::2]
    assert norms[2] < 1e-3 * norms[1] ** 2 / norms[0] * 10 or norms[2] < 1e-12
    assert norms[3] < 1e-10 * norms[0]


@pytest.mark.parametrize("p, branch", [(10.0, "linear"), (-30.0, "linear"), (100.0, "upper"), (-150.0, "lower")])
def test_solid_returns_the_exact_root_on_each_branch(p, branch):
    solid = TubeSolid()
    solid.instantiate({})
    pressure = np.full(101, p)
    section = solid.step(0.0, 0.1, {"pressure": pressure})["section"]
    r = np.sqrt(section / math.pi)
    eps = (r - solid.r0) / solid.r0
    expected = {"linear": np.abs(eps) < 2e-3, "upper": eps >= 2e-3, "lower": eps <= -2e-3}[branch]
    assert expected.all()
    sigma = {"linear": 12500 * eps, "upper": 2500 * eps + 20, "lower": 2500 * eps - 20}[branch]
    np.testing.assert_allclose(pressure * r, sigma, rtol=1e-13)


def test_solid_law_is_continuous_and_monotone_across_branches():
    solid = TubeSolid()
    solid.instantiate({"tube": {"cells": 1000}})
    p = np.linspace(-200, 200, 1001)
    r = solid.radius(p)
    assert np.all(np.diff(r) > 0)
    np.testing.assert_allclose(p * r, solid.stress(r / solid.r0 - 1), rtol=1e-10, atol=1e-9)


def test_solid_refuses_a_pressure_with_no_equilibrium():
    solid = TubeSolid()
    solid.instantiate({})
    pressure = np.zeros(101)
    pressure[17] = 1e4
    with pytest.raises(ComponentError, match="node 17"):
        solid.step(0.0, 0.1, {"pressure": pressure})


def test_duffing_inlet_is_converged_and_starts_like_the_published_signal():
    accurate = DuffingInlet(2.0, 6.0, 0.0, 20.0)
    from scipy.integrate import solve_ivp
    f = 2.0
    rhs = lambda t, y: [y[1], -y[0] - 0.002 * y[0] ** 3 - 1 + 360 * np.cos(f * t) - 0.02 * y[1]]
    reference = solve_ivp(rhs, (0, 20), [10, 0], method="DOP853", rtol=1e-13, atol=1e-13, dense_output=True)
    times = np.linspace(0, 20, 201)
    np.testing.assert_allclose([accurate(t) for t in times], reference.sol(times)[0] / 60 + 6, atol=1e-8)
    assert accurate(0.0) == pytest.approx(10 / 60 + 6, abs=1e-14)
    table = TableInlet(REFERENCE / "tube-inlet-mu1.csv", 0.0, 120.0)
    early = table.time <= 0.5  # the published table repeats its value at t = 0.5, 4.5 and 75.2
    np.testing.assert_allclose([accurate(t) for t in table.time[early]], table.velocity[early], atol=2e-4)


def test_table_inlet_interpolates_and_checks_coverage(tmp_path):
    path = tmp_path / "inlet.csv"
    path.write_text("# measured\ntime,velocity\n0,1\n1,3\n2,2\n")
    inlet = TableInlet(path, 0.0, 2.0)
    assert inlet(0.5) == pytest.approx(2.0) and inlet(1.5) == pytest.approx(2.5)
    with pytest.raises(SceneError, match=r"covers t in \[0, 2\], but the run needs \[0, 5\]"):
        TableInlet(path, 0.0, 5.0)
    path.write_text("time,velocity\n0,1\n1,x\n")
    with pytest.raises(SceneError, match="line 3"):
        TableInlet(path, 0.0, 1.0)


def test_fluid_rejects_unknown_parameters():
    with pytest.raises(SceneError, match="unknown key 'inlet.ff'; did you mean 'inlet.f'"):
        TubeFluid().instantiate({"inlet": {"ff": 1.0}})
