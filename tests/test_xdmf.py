"""run.xdmf: every run opens in ParaView's XDMF reader (VTK's vtkXdmfReader), with the fields of results.h5."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cosim.results import ResultsStore, RunResults
from cosim.scene import load_scene
from cosim.xdmf import XDMF_NAME, main, write_xdmf
from coupler.run import run_scene
from tests.conftest import TUBE_SCENE
from tests.xdmf_check import assert_xdmf_holds_the_run, read_xdmf


def test_a_tube_run_writes_run_xdmf_that_vtk_reads_with_the_fields_of_results_h5(tmp_path):
    run_scene(load_scene(TUBE_SCENE, ["time.end=0.5"]), tmp_path / "tube", progress=False)
    series = read_xdmf(tmp_path / "tube" / XDMF_NAME)
    with RunResults(tmp_path / "tube") as run:
        times = run.windows.time
    assert sorted(series) == pytest.approx([0.0, *times])          # the initial values, then every window
    assert set(series[0.0]) == {"fluid/axis", "solid/axis"}
    assert assert_xdmf_holds_the_run(tmp_path / "tube") == 2 * (len(times) + 1)


def test_meshes_of_two_and_three_dimensions_with_vectors_and_substeps(tmp_path):
    """2-D vectors come out padded with z = 0, as ParaView shows them; a substep field is left out and said so."""
    rng = np.random.default_rng(1)
    store = ResultsStore(tmp_path / "results.h5", "")
    store.set_attributes(scene_resolved=json.dumps({"time": {"start": 0.5}, "exchange": [
        {"data": "Force", "from": "A", "to": "B"}, {"data": "Disp", "from": "B", "to": "A"},
        {"data": "T", "from": "B", "to": "A"}, {"data": "Steps", "from": "B", "to": "A"}]}))
    plane, space = rng.random((5, 2)), rng.random((4, 3))
    store.write_description("A", [{"name": "Force", "mesh": "plane", "components": 2}], {"plane": plane})
    store.write_description("B", [{"name": n, "mesh": "space", "components": k} for n, k in (("Disp", 3), ("T", 1), ("Steps", 1))],
                            {"space": space})
    store.write_initial({"Force": np.ones((5, 2)), "Disp": np.zeros((4, 3)), "T": np.zeros(4),
                         "Steps": np.zeros((2, 4))})
    windows = [{"Force": rng.random((5, 2)), "Disp": rng.random((4, 3)), "T": rng.random(4),
                "Steps": rng.random((2, 4))} for _ in range(3)]
    for number, values in enumerate(windows, start=1):
        store.append_window(0.5 + 0.25 * number, 2, True, 0.0, values, {}, {})
    store.close()
    path = write_xdmf(tmp_path / "results.h5")
    assert "'Steps': rows of shape (2, 4)" in path.read_text()
    series = read_xdmf(path)
    assert sorted(series) == [0.5, 0.75, 1.0, 1.25]
    points, data = series[1.0]["A/plane"]
    np.testing.assert_array_equal(points[:, :2], plane)
    np.testing.assert_array_equal(data["Force"][:, :2], windows[1]["Force"])
    np.testing.assert_array_equal(data["Force"][:, 2], 0.0)
    points, data = series[1.25]["B/space"]
    np.testing.assert_array_equal(points, space)
    assert set(data) == {"Disp", "T"}
    np.testing.assert_array_equal(data["Disp"], windows[2]["Disp"])
    np.testing.assert_array_equal(data["T"], windows[2]["T"])
    np.testing.assert_array_equal(series[0.5]["A/plane"][1]["Force"][:, :2], 1.0)


def test_the_command_writes_it_for_an_older_run_and_refuses_what_is_not_a_run(tmp_path, capsys):
    run_scene(load_scene(TUBE_SCENE, ["time.end=0.2"]), tmp_path / "old", progress=False)
    (tmp_path / "old" / XDMF_NAME).unlink()
    assert main([str(tmp_path / "old")]) == 0
    assert (tmp_path / "old" / XDMF_NAME).is_file()
    assert main([str(tmp_path / "nothing")]) == 2
    assert capsys.readouterr().err.startswith("error: no results file at")


def test_the_docs_picture_script_renders_the_run_from_its_xdmf(tmp_path):
    """scripts/render_xdmf.py (the docs' picture) draws the field's colours from run.xdmf: the two ends of the
    tube's pressure range, red and blue, are both on the picture."""
    import subprocess
    import sys

    import matplotlib.image

    from tests.conftest import ROOT
    run_scene(load_scene(TUBE_SCENE, ["time.end=0.5"]), tmp_path / "tube", progress=False)
    done = subprocess.run([sys.executable, "-m", "scripts.render_xdmf", str(tmp_path / "tube"), "--field", "pressure",
                           "--out", str(tmp_path / "tube.png"), "--size", "400", "200"], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    if done.returncode != 0 and ("OpenGL" in done.stderr or "EGL" in done.stderr or "GLX" in done.stderr):
        pytest.skip(f"VTK cannot render off screen here: {done.stderr.strip().splitlines()[-1]}")
    assert done.returncode == 0, done.stderr
    picture = matplotlib.image.imread(tmp_path / "tube.png")[..., :3]
    assert picture.shape == (200, 400, 3)
    pixels = picture[:, :280]                  # left of the colour bar: the mesh alone
    red = (pixels[..., 0] > 0.8) & (pixels[..., 1] < 0.3) & (pixels[..., 2] < 0.3)
    blue = (pixels[..., 2] > 0.8) & (pixels[..., 0] < 0.3) & (pixels[..., 1] < 0.3)
    assert red.sum() > 20 and blue.sum() > 20
    from scripts.render_xdmf import main as render_main
    assert render_main([str(tmp_path), "--field", "pressure", "--out", str(tmp_path / "none.png")]) == 2
