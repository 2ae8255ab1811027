"""A scene's own modules come first: a module beside the scene, named like any package of ours or like cosim
itself, is the one a run loads, in its component's process and in the coupler's checks."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.results import RunResults
from tests.conftest import ROOT
from tests.test_layering import OURS

EXAMPLE = ROOT / "examples/spring_wall"


def scene_with_module(folder, module: str) -> None:
    """The spring-wall example copied into ``folder`` with its module renamed ``module``."""
    folder.mkdir()
    shutil.copy(EXAMPLE / "spring_wall.py", folder / f"{module}.py")
    text = (EXAMPLE / "scene.toml").read_text().replace('"spring_wall:SpringWall"', f'"{module}:SpringWall"')
    assert f'"{module}:SpringWall"' in text
    (folder / "scene.toml").write_text(text)


@pytest.mark.parametrize("module", [*OURS, "cosim_scene_modules"])
def test_a_module_beside_the_scene_is_loaded_whatever_it_is_named(tmp_path, module):
    """The class is found in the scene's module, in a process that has our packages imported (the coupler's
    checks) and in one that has not (a component's), and its instances work."""
    scene_with_module(tmp_path / "case", module)
    load = (f"cls = load_entry('{module}:SpringWall', [sys.argv[1]]); cls(); "
            "print(sys.modules[cls.__module__].__file__)")
    for imported in ("cosim.server", "coupler.run, coupler.preflight, workflow, cases"):
        code = f"import sys, {imported}; from cosim.server import load_entry; {load}"
        done = subprocess.run([sys.executable, "-P", "-c", code, str(tmp_path / "case")], cwd=tmp_path,
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip() == str((tmp_path / "case" / f"{module}.py").resolve()), imported


@pytest.mark.parametrize("module", ["workflow", "cosim"])
def test_a_run_couples_the_scene_s_module_named_like_our_package(tmp_path, module):
    """The issue's case (a copy of the spring wall named workflow.py) and the hardest name, run from the scene's
    own folder: the wall is the scene's module."""
    scene_with_module(tmp_path / "case", module)
    cosim = Path(sys.executable).with_name("cosim")       # the command a user types, from the scene's folder
    done = subprocess.run([str(cosim), "run", "scene.toml", "--out", str(tmp_path / "run"), "--quiet",
                           "--set", "time.end=0.5"], cwd=tmp_path / "case", capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    with RunResults(tmp_path / "run/results.h5") as results:
        assert results.windows.converged.all() and len(results.windows) == 5
        assert results.component("solid").attributes["backend"] == f"{module}:SpringWall"
