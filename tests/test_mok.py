"""Mok's benchmark: the generated meshes (areas, the wall, the shared interface, the cache), the Kratos fluid's
added mass under a prescribed wall motion, and a short coupled run through real processes."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import needs_kratos

ROOT = Path(__file__).resolve().parent.parent
needs_gmsh = pytest.mark.skipif(importlib.util.find_spec("gmsh") is None,
                                reason="needs gmsh (pip install -e '.[mesh]')")
COARSE = {"wall_cells": [2, 20], "far_size": 0.06, "wall_size": 0.0125}


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    """Meshes go to one cache for this module's tests, never to the user's."""
    monkeypatch.setenv("COSIM_CACHE", str(tmp_path_factory.getbasetemp() / "mok-cache"))


def fluid_area_exact() -> float:
    """The channel minus the wall minus what lies under the ramp, the arc and the step, in closed form."""
    from kratos_solvers.mok_mesh import GEOMETRY, ramp_tangent
    g = GEOMETRY
    tx, ty = ramp_tangent(g)
    (cx, cy), r = g["arc_centre"], g["arc_radius"]

    def under_circle(x: float) -> float:      # integral of sqrt(r^2 - (x - cx)^2) dx
        u = x - cx
        return 0.5 * (u * math.sqrt(r * r - u * u) + r * r * math.asin(u / r))

    under = (0.5 * (tx - g["wall_right"]) * ty + cy * (cx - tx) + under_circle(cx) - under_circle(tx)
             + (cy + r) * (g["length"] - cx))
    wall = (g["wall_right"] - g["wall_left"]) * g["wall_height"]
    return g["length"] * g["height"] - wall - under


def test_ramp_meets_the_arc_where_the_facts_say():
    from kratos_solvers.mok_mesh import GEOMETRY, ramp_tangent
    tx, ty = ramp_tangent(GEOMETRY)
    assert abs(tx - 1.1299) < 1e-4 and abs(ty - 0.2361) < 1e-4
    assert ty / (tx - GEOMETRY["wall_right"]) == pytest.approx(0.375704, abs=1e-5)
    cx, cy = GEOMETRY["arc_centre"]
    assert math.hypot(tx - cx, ty - cy) == pytest.approx(1.0, abs=1e-12)


def test_mdpa_round_trip(tmp_path):
    from kratos_solvers.mdpa import Block, SubModelPart, read_mdpa, write_mdpa
    nodes = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1 / 3]])
    tris = Block("Element2D3N", np.array([[1, 2, 3], [1, 3, 4]]))
    edges = Block("LineCondition2D2N", np.array([[1, 2], [4, 1]]), first_id=1)
    write_mdpa(tmp_path / "m.mdpa", nodes, [tris], [edges],
               {"All": SubModelPart(np.arange(1, 5), elements=tris.ids), "Edge": SubModelPart(np.array([1, 2]),
                                                                                          conditions=np.array([1]))})
    back = read_mdpa(tmp_path / "m.mdpa")
    np.testing.assert_array_equal(back.nodes[:, :2], nodes)     # %.17g: exact
    np.testing.assert_array_equal(back.elements[0].connectivity, tris.connectivity)
    assert back.conditions[0].kind == "LineCondition2D2N"
    np.testing.assert_array_equal(back.parts["Edge"].conditions, [1])
    np.testing.assert_array_equal(back.parts["All"].elements, [1, 2])


@needs_gmsh
def test_generated_meshes_have_the_geometry_the_wall_and_one_interface():
    from kratos_solvers.mdpa import read_mdpa
    from kratos_solvers.mok_mesh import (
        CLAMPED,
        FLUID_INTERFACE,
        FLUID_VOLUME,
        SOLID_INTERFACE,
        SOLID_VOLUME,
        cell_areas,
        mok_meshes,
    )
    paths = mok_meshes()
    fluid, solid = read_mdpa(paths["fluid"]), read_mdpa(paths["solid"])

    triangles = fluid.elements[0].connectivity - 1
    areas = cell_areas(fluid.nodes[:, :2], triangles)
    assert 5000 < len(triangles) < 7500             # the reference's "about 6000"
    assert areas.min() > 0                          # every triangle counter-clockwise
    assert areas.sum() == pytest.approx(fluid_area_exact(), rel=1e-4)   # chords of the arc cut off a little

    quads = solid.elements[0].connectivity - 1
    assert solid.elements[0].kind == "TotalLagrangianElement2D4N" and quads.shape == (200, 4)
    assert len(solid.nodes) == 303
    assert cell_areas(solid.nodes[:, :2], quads).min() > 0
    assert cell_areas(solid.nodes[:, :2], quads).sum() == pytest.approx(0.005 * 0.25, rel=1e-12)
    np.testing.assert_allclose(cell_areas(solid.nodes[:, :2], quads), 0.0025 ** 2, rtol=1e-9)

    clamped = solid.coordinates(solid.parts[CLAMPED].nodes)
    np.testing.assert_allclose(clamped[:, 1], 0.0, atol=0)
    assert sorted(clamped[:, 0]) == pytest.approx([0.4965, 0.499, 0.5015], abs=1e-12)
    wall = solid.coordinates(solid.parts[SOLID_INTERFACE].nodes)
    assert len(wall) == 203 and len(solid.parts[SOLID_INTERFACE].conditions) == 203
    on_faces = np.isclose(wall[:, 0], 0.4965) | np.isclose(wall[:, 0], 0.5015) | np.isclose(wall[:, 1], 0.25)
    assert on_faces.all()
    assert len(solid.parts[SOLID_VOLUME].nodes) == 303

    # the interface nodes of both meshes are the same gmsh nodes: equal coordinates, bit for bit
    shared = fluid.coordinates(fluid.parts[FLUID_INTERFACE].nodes)
    assert {tuple(p) for p in shared} == {tuple(p) for p in wall}
    assert len(fluid.parts[FLUID_VOLUME].nodes) == len(fluid.nodes)


@needs_gmsh
def test_meshes_are_cached_by_their_fingerprint():
    from kratos_solvers.mok_mesh import mok_meshes
    first = mok_meshes(COARSE)
    stamp = first["fluid"].stat().st_mtime_ns
    again = mok_meshes(dict(COARSE))
    assert again == first and again["fluid"].stat().st_mtime_ns == stamp      # found, not rebuilt
    other = mok_meshes({**COARSE, "far_size": 0.05})
    assert other["fluid"].parent != first["fluid"].parent
    assert not [p for p in first["fluid"].parent.parent.iterdir() if p.name.startswith(".")]   # no scratch left


@needs_gmsh
@needs_kratos
def test_fluid_resists_a_wall_accelerated_from_window_to_window():
    """Added mass: a wall moved with constant acceleration a feels a force against it, proportional to a.
    (With the input written before the step advanced, the fluid saw no motion between windows: zero force.)"""
    from kratos_solvers.mok import MokFluid

    def force(acceleration: float) -> float:
        fluid = MokFluid()
        fluid.instantiate({"time": {"start": 0.0, "end": 1.0, "dt": 0.1}, "flow": {"reference_velocity": 1e-12},
                           "mesh": COARSE})
        fluid.enter_initialization_mode(0.0, 1.0)
        fluid.exit_initialization_mode()
        shape = np.zeros_like(fluid.interface_nodes)
        shape[:, 0] = (fluid.interface_nodes[:, 1] / 0.25) ** 2
        forces = [fluid.step(0.1 * k, 0.1, {"displacement": 0.5 * acceleration * (0.1 * (k + 1)) ** 2 * shape})
                  ["force"][:, 0].sum() for k in range(8)]
        fluid.close()
        return float(np.mean(forces[4:]))      # past the scheme's first-step transient

    small, large = force(0.01), force(0.02)
    assert small < 0
    assert large / small == pytest.approx(2.0, rel=0.02)
    added_mass = -small / 0.01                  # kg per metre of depth, per unit tip acceleration
    assert 10 < added_mass < 200                # some 30 to 100 times the wall's own 7.5 kg/m


@needs_gmsh
@needs_kratos
def test_short_mok_run_through_real_processes(tmp_path):
    """Ten windows on a coarse mesh: every window converges, the wall bends downstream ever faster as the inflow
    ramps up, and the recorded point A is the interface node at the wall's top right corner."""
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    out = tmp_path / "mok"
    scene = load_scene(ROOT / "scenes" / "mok.toml", [
        "time.end=1.0", f"mesh.wall_cells={COARSE['wall_cells']}", f"mesh.far_size={COARSE['far_size']}",
        f"mesh.wall_size={COARSE['wall_size']}", "output.checkpoint_every=0"])
    run_scene(scene, out, progress=False)
    with RunResults(out / "results.h5") as run:
        windows = run.windows
        assert len(windows) == 10 and windows.converged.all()
        calls = run.calls("structure", converged_only=True)
        point_a = calls.outputs["point_a"][:, 0]
        assert (point_a[1:] > 0).all() and (np.diff(point_a[1:]) > 0).all()
        interface = run.component("structure").meshes["interface"]
        corner = int(np.argmin(np.linalg.norm(interface - [0.5015, 0.25], axis=1)))
        np.testing.assert_array_equal(calls.outputs["displacement"][:, corner], calls.outputs["point_a"])
        assert windows.iterations.mean() <= 4


@needs_gmsh
@needs_kratos
def test_stability_matrix_on_mok_classes_gauss_seidel_as_diverged_where_iqn_ils_converges(tmp_path, capsys):
    """Added mass dominates at rho_s / rho_f = 0.5 and 10 alike: plain Gauss-Seidel diverges and is classed so,
    IQN-ILS converges (coarse mesh, three windows per run)."""
    import csv

    from cosim.cli import main
    code = main(["stability", str(ROOT / "scenes" / "mok.toml"), "--out", str(tmp_path),
                 "--grid", "components.structure.parameters.density=478,9560", "--grid", "time.dt=0.1",
                 "--methods", "none,iqn-ils", "--windows", "3", "--quiet",
                 *(arg for key, value in COARSE.items() for arg in ("--set", f"mesh.{key}={value}"))])
    assert code == 0, capsys.readouterr().err
    with open(tmp_path / "sweep.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 4
    for row in rows:
        if '"none"' in row["coupling.acceleration"]:
            assert row["failure"] == "diverged", row
        else:
            assert row["failure"] == "" and int(row["windows_converged"]) == 3, row
    matrix = (tmp_path / "matrix.md").read_text()
    assert matrix.count("diverged") == 2 and (tmp_path / "stability.png").stat().st_size > 10_000


@needs_gmsh
@needs_kratos
def test_a_mok_run_resumes_with_the_structure_s_inertia(tmp_path, monkeypatch):
    """Stopped after window 3 and resumed from Kratos's serialised model parts: the dynamic structure's velocity and
    acceleration come back with it, so the resumed run repeats the uninterrupted one's iterations and fields (to
    round-off: Kratos rebuilds its systems on load)."""
    from cosim.checkpoint import read
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from tests.test_restart import stopped_at
    overrides = ["time.end=0.8", "output.checkpoint_every=2",
                 *(f"mesh.{key}={value}" for key, value in COARSE.items())]
    scene = ROOT / "scenes" / "mok.toml"
    run_scene(load_scene(scene, overrides), tmp_path / "whole", progress=False)
    with monkeypatch.context() as patch:
        stopped_at(3, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(scene, overrides), tmp_path / "cut", progress=False)
    assert read(tmp_path / "cut" / "checkpoint.npz")[0]["windows"] == 3
    run_scene(load_scene(scene, overrides), tmp_path / "cut", progress=False, resume=True)
    with RunResults(tmp_path / "whole") as whole, RunResults(tmp_path / "cut") as cut:
        np.testing.assert_array_equal(cut.windows.iterations, whole.windows.iterations)
        a_whole = whole.calls("structure", converged_only=True).outputs["point_a"]
        a_cut = cut.calls("structure", converged_only=True).outputs["point_a"]
        assert len(a_cut) == len(a_whole) == 8
        np.testing.assert_allclose(a_cut, a_whole, rtol=0, atol=1e-9 * np.abs(a_whole).max())
        for name, values in whole.fields().items():
            assert np.abs(cut.fields()[name] - values).max() <= 1e-8 * np.abs(values).max(), name


@needs_kratos
def test_a_run_plot_that_needs_recorded_calls_is_refused_before_the_run_without_them(capsys, tmp_path):
    """Mok's plots draw point A from the structure's recorded calls: a scene that does not record them fails at
    check, with one line naming the key, instead of after 250 windows."""
    from cosim.cli import main
    code = main(["check", str(ROOT / "scenes" / "mok.toml"), "--set", "components.structure.record=false"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "'output.plots.0' ('mok') draws from the recorded calls of 'structure': set " \
           "components.structure.record = true" in err
