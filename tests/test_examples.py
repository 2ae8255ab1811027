"""The example of one's own component (examples/spring_wall): written from the contract alone, coupled to the
tube's fluid through real processes, as the docs page "Write a component" runs it."""

from __future__ import annotations

import math
import subprocess
import sys
import tomllib

import numpy as np
import pytest

from cosim.results import RunResults
from tests.conftest import ROOT

SCENE = ROOT / "examples/spring_wall/scene.toml"


def run(out, *settings: str) -> None:
    sets = [arg for item in settings for arg in ("--set", item)]
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(SCENE), "--out", str(out), "--quiet",
                           "--set", "time.end=4.0", *sets], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr


def test_the_spring_wall_example_couples_to_the_tube_fluid_and_keeps_its_law(tmp_path):
    run(tmp_path / "spring")
    with RunResults(tmp_path / "spring/results.h5") as results:
        assert results.windows.converged.all() and len(results.windows) == 40
        fields = results.fields()
        assert results.component("solid").attributes["backend"] == "spring_wall:SpringWall"
    pressure, section = fields["pressure"], fields["section"]
    r0, E = math.sqrt(1.0 / math.pi), 12500.0
    # the converged section is the spring law at the converged pressure, node by node
    np.testing.assert_allclose(section, math.pi * (r0 + pressure * r0 ** 2 / E) ** 2, rtol=1e-12)
    strain = np.abs(pressure).max() * r0 / E
    assert 1e-3 < strain < 1e-2                         # the flow does load the wall
    # the tube's own solid with its linear law, r = r0 E / (E - p r0), is the same wall to first order in the
    # strain: the two coupled runs differ by about the strain squared
    run(tmp_path / "tube", "components.solid.entry=solid_component.tube:TubeSolid",
        "components.solid.parameters={E_small=12500.0}", "tube.wall_law=linear")
    with RunResults(tmp_path / "tube/results.h5") as results:
        tube_section = results.fields()["section"]
    difference = np.abs(tube_section - section).max() / np.abs(section).max()
    assert 0.1 * strain ** 2 < difference < 10 * strain ** 2, (difference, strain)


DAMPED = ROOT / "examples/damped_wall/scene.toml"


def test_the_damped_wall_example_keeps_its_implicit_euler_law_window_by_window(tmp_path):
    """A component with state (save_state, restore_state): each window's iterations start from one radius."""
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(DAMPED), "--out", str(tmp_path / "run"),
                           "--quiet", "--set", "time.end=3.0"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    with RunResults(tmp_path / "run/results.h5") as results:
        assert results.windows.converged.all() and len(results.windows) == 30
        mean_iterations = results.windows.iterations.mean()
        fields = results.fields()
    r0, E, tau, dt = math.sqrt(1.0 / math.pi), 12500.0, 0.05, 0.1
    radius = np.sqrt(np.vstack([np.full((1, 101), 1.0), fields["section"]]) / math.pi)
    equilibrium = r0 + fields["pressure"] * r0 ** 2 / E
    np.testing.assert_allclose(radius[1:], (radius[:-1] + dt / tau * equilibrium) / (1 + dt / tau), rtol=1e-7)
    assert np.abs(radius - r0).max() > 1e-4 * r0              # the flow does move the wall
    assert mean_iterations < 4.0


def test_a_component_with_no_state_answer_is_refused_under_implicit_coupling(tmp_path, capsys):
    """Without state methods and without ``stateless``, ``cosim check`` refuses it, naming the methods to add."""
    from cosim.cli import main
    (tmp_path / "forgetful.py").write_text(      # the example's module, with a subclass that forgets its state
        (DAMPED.parent / "damped_wall.py").read_text() + "\n\n"
        "class ForgetfulWall(DampedWall):\n"
        "    save_state = Component.save_state\n"
        "    restore_state = Component.restore_state\n")
    scene = tmp_path / "scene.toml"
    scene.write_text(DAMPED.read_text().replace("damped_wall:DampedWall", "forgetful:ForgetfulWall"))
    code = main(["check", str(scene)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err, err
    assert "components.solid: component 'solid' (forgetful:ForgetfulWall) is coupled implicitly" in err
    assert "save_state(self) -> Any and restore_state(self, state: Any) -> None nor declares stateless = True" in err
    # an explicit scheme repeats no window: the same component is accepted there
    assert main(["check", str(scene), "--set", "coupling.scheme=serial-explicit", "--set",
                 "coupling.acceleration=none"]) == 0


def c_component(tmp_path) -> str:
    """examples/c_spring_wall built with the machine's C compiler against libzmq and msgpack-c (or a skip)."""
    import shutil
    compiler = shutil.which("cc")
    if compiler is None:
        pytest.skip("no C compiler (cc)")
    binary = tmp_path / "c_spring_wall"
    built = subprocess.run([compiler, "-O2", "-std=c99", "-D_DEFAULT_SOURCE", "-o", str(binary),
                            str(ROOT / "examples/c_spring_wall/spring_wall.c"), "-lzmq", "-lmsgpackc", "-lm"],
                           capture_output=True, text=True, timeout=120)
    if built.returncode != 0:
        pytest.skip(f"libzmq and msgpack-c are not installed (Debian: libzmq3-dev libmsgpack-dev): "
                    f"{built.stderr.strip().splitlines()[0] if built.stderr.strip() else built.returncode}")
    return str(binary)


def test_a_component_in_c_speaks_the_wire_and_couples_as_the_python_one_does(tmp_path):
    """The wire's handshake and requests are all a component needs: the spring wall in C, served by hand, gives the
    Python spring wall's run (docs/contract.md, "A component in another language")."""
    import json
    binary = c_component(tmp_path)
    process = subprocess.Popen([binary, "tcp://127.0.0.1:*"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    try:
        assert process.stdout is not None
        handshake = json.loads(process.stdout.readline())
        run(tmp_path / "c", "components.solid.entry=''", f"components.solid.address='{handshake['endpoint']}'")
        assert process.wait(timeout=30) == 0          # the run's shutdown ends it
    finally:
        if process.poll() is None:
            process.kill()
    run(tmp_path / "python")
    with RunResults(tmp_path / "c/results.h5") as c, RunResults(tmp_path / "python/results.h5") as python:
        # the C and NumPy arithmetic may round apart by an ulp, which the coupled iteration may carry: the two runs
        # meet the same criterion on the same fixed point, not the same rounding (as on AVX-512 kernels)
        assert np.abs(c.windows.iterations - python.windows.iterations).max() <= 1
        limit = tomllib.loads(SCENE.read_text())["coupling"]["convergence"][0]["limit"]
        section = python.fields()["section"]
        np.testing.assert_allclose(c.fields()["section"], section, rtol=0, atol=limit * np.abs(section).max())
        assert c.component("solid").attributes["host"] == handshake["endpoint"]


def test_the_h5py_example_reads_what_the_results_file_holds(tmp_path):
    run(tmp_path / "run", "time.end=2.0")
    done = subprocess.run([sys.executable, str(ROOT / "examples/read_results/read_results.py"), str(tmp_path / "run")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = dict(line.split(": ", 1) for line in done.stdout.splitlines())
    with RunResults(tmp_path / "run/results.h5") as results:
        assert lines["windows"] == str(len(results.windows)) == "20"
        assert lines["iterations"] == str(int(results.windows.iterations.sum()))
        assert float(lines["inlet_pressure_max"]) == results.fields()["pressure"][:, 0].max()
    assert "'solid': {'calls':" in lines["components"] and lines["dt"] == "0.1"
