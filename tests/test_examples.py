"""The example of one's own component (examples/spring_wall): written from the contract alone, coupled to the
tube's fluid through real processes, as the docs page "Write a component" runs it."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np

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
