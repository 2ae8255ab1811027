"""FMI 3.0 both ways: the ROMs exported as FMI 3.0 Co-Simulation FMUs (array variables, the FMU state), FMI 3.0
FMUs as components, an FMU of another maker (pythonfmu3) coupled, and bad FMI 3.0 FMUs refused in one line."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from cosim.errors import ComponentError
from fmu_component.component import FmuComponent
from rom_component.fmu.export import export_fmu
from tests.conftest import ROOT
from tests.test_fmu import models, train  # noqa: F401  (the module's fixtures)
from tests.test_step_map_fmu import N, calls, model  # noqa: F401

WALLS = ROOT / "tests" / "data" / "fmi3_walls"


def started(path: Path, **parameters) -> FmuComponent:
    component = FmuComponent()
    component.instantiate({"path": str(path), **parameters})
    component.enter_initialization_mode(0.0, 10.0)
    component.exit_initialization_mode()
    return component


def fmi3(model_path: Path, folder: Path) -> Path:
    return export_fmu(model_path, folder / f"{model_path.stem}3.fmu", fmi=3)


@pytest.mark.parametrize("name", ["rbf", "qm_poly"])
def test_the_fmi3_export_validates_and_gives_the_fmi2_fmus_bits(models, name, tmp_path):  # noqa: F811
    """Array variables with their dimensions: one input, one output, (nodes, components) where a node has several
    values; the time the independent variable; a build description listing the sources; and the same bits as the
    FMI 2.0 FMU of the same model, call after call, with each window repeated by rolling back."""
    model_path, fmu2, F = models[name]
    fmu3 = fmi3(model_path, tmp_path)
    assert validate_fmu(str(fmu3)) == []
    md = read_model_description(str(fmu3))
    assert md.fmiVersion == "3.0" and md.coSimulation.canGetAndSetFMUstate
    variables = {v.name: v for v in md.modelVariables}
    assert variables["time"].causality == "independent"
    shape = [d.start for d in variables[md.modelVariables[1].name].dimensions]
    assert shape == ([101] if name == "rbf" else [20, 2])
    with zipfile.ZipFile(fmu3) as archive:
        names = archive.namelist()
        assert "binaries/x86_64-linux/solid_rom.so" in names and "sources/buildDescription.xml" in names
        build = archive.read("sources/buildDescription.xml").decode()
        assert all(f'name="{c}"' in build for c in ("solid_rom.c", "rom_runtime.c", "fmi3_rom.c"))
    two, three = started(fmu2, state="rollback"), started(fmu3, state="rollback")
    assert three.fmi_version == "3.0" and three.repeats_steps
    [input_name], [output_name] = two.inputs, two.outputs
    for k, f in enumerate(F[:60]):
        t = 0.1 * (k // 3)                         # three calls a window: the FMUs roll back for the later two
        a = two.step(t, 0.1, {input_name: f})[output_name]
        b = three.step(t, 0.1, {input_name: f.reshape(three.variables()[0].shape)})[output_name]
        assert a.ravel().tobytes() == b.ravel().tobytes()
    two.terminate()
    three.terminate()


def test_the_step_maps_fmi3_fmu_gives_the_fmi2_fmus_bits_and_its_state_round_trips(model, tmp_path):  # noqa: F811
    """The ROM with memory: its probe a local array, the history its FMU state; the same bits as the FMI 2.0 FMU
    after a take-over; a state saved, serialised and read into a new instance goes on with the same bits."""
    path, fmu2, data = model
    fmu3 = fmi3(path, tmp_path)
    assert validate_fmu(str(fmu3)) == []
    md = read_model_description(str(fmu3))
    assert [(v.name, v.causality, [d.start for d in v.dimensions]) for v in md.modelVariables] == [
        ("time", "independent", []), ("force", "input", [N]), ("displacement", "output", [N, 2]),
        ("tip", "local", [2])]
    two, three = started(fmu2), started(fmu3)
    history = {"force": data.F[40:43], "displacement": data.U[40:43].reshape(3, N, 2)}
    for component in (two, three):
        component.take_over(history, history)
    for t, f in calls(data, windows=12):
        a, b = (c.step(t, 0.1, {"force": f}) for c in (two, three))
        assert a["displacement"].tobytes() == b["displacement"].tobytes() and a["tip"].tobytes() == b["tip"].tobytes()
    saved = three.checkpoint()["fmu_state"]
    assert saved[:8].tobytes() == b"CSSTPST3"
    fresh = started(fmu3)
    fresh.restore_checkpoint({"fmu_state": saved})
    for t, f in calls(data, windows=16)[36:]:
        a, b, c = (x.step(t, 0.1, {"force": f}) for x in (two, three, fresh))
        assert a["displacement"].tobytes() == b["displacement"].tobytes() == c["displacement"].tobytes()
    for component in (two, three, fresh):
        component.terminate()


def test_fmpy_saves_restores_and_serialises_the_fmi3_state_bit_for_bit(model, tmp_path):  # noqa: F811
    """Through fmpy's own FMU3Slave: fmi3GetFMUState / fmi3SetFMUState repeat a window with the same bits, and
    fmi3SerializeFMUState / fmi3DeserializeFMUState carry the state to another instance, byte for byte."""
    from fmpy import extract
    path, _, data = model
    fmu3 = fmi3(path, tmp_path)
    md = read_model_description(str(fmu3))

    def instance() -> FMU3Slave:
        slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmu3)), modelIdentifier="step_map_rom")
        slave.instantiate()
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        return slave

    one = instance()
    for w in range(5):
        one.setFloat64([1], list(data.F[w]))
        one.doStep(currentCommunicationPoint=0.1 * w, communicationStepSize=0.1)
    state = one.getFMUState()
    one.setFloat64([1], list(data.F[5]))
    one.doStep(currentCommunicationPoint=0.5, communicationStepSize=0.1)
    first = one.getFloat64([2, 3], nValues=2 * N + 2)
    serialised = bytes(one.serializeFMUState(state))
    one.setFMUState(state)
    one.setFloat64([1], list(data.F[5]))
    one.doStep(currentCommunicationPoint=0.5, communicationStepSize=0.1)
    assert np.array(one.getFloat64([2, 3], nValues=2 * N + 2)).tobytes() == np.array(first).tobytes()
    two = instance()
    restored = two.deserializeFMUState(serialised)
    assert bytes(two.serializeFMUState(restored)) == serialised
    two.setFMUState(restored)
    two.setFloat64([1], list(data.F[5]))
    two.doStep(currentCommunicationPoint=0.5, communicationStepSize=0.1)
    assert np.array(two.getFloat64([2, 3], nValues=2 * N + 2)).tobytes() == np.array(first).tobytes()
    for slave in (one, two):
        slave.terminate()
        slave.freeInstance()


def run(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cosim", "run", *args, "--quiet"], cwd=cwd, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "OMP_NUM_THREADS": "1"})


@pytest.fixture(scope="module")
def walls(tmp_path_factory):
    """The spring wall (no FMU state) and the damped wall (its radius the FMU state) of the examples, as FMI 3.0
    FMUs built by pythonfmu3 from tests/data/fmi3_walls."""
    if shutil.which("pythonfmu3") is None and not (Path(sys.executable).parent / "pythonfmu3").exists():
        pytest.skip("pythonfmu3 is not installed (pip install '.[test]')")
    folder = tmp_path_factory.mktemp("walls")
    tool = str(Path(sys.executable).parent / "pythonfmu3")
    for script, options in (("spring_wall_fmu.py", []), ("damped_wall_fmu.py", ["--handle-state"]),
                            ("pressure_driver_fmu.py", [])):
        subprocess.run([tool, "build", "-f", str(WALLS / script), "-d", str(folder), *options], check=True,
                       capture_output=True)
    return folder / "SpringWallFmu.fmu", folder / "DampedWallFmu.fmu"


def fields(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    from cosim.results import RunResults
    with RunResults(folder / "results.h5") as results:
        return np.asarray(results.windows.iterations), np.asarray(results.fields()["section"])


def test_an_fmi3_fmu_of_another_maker_couples_and_one_that_cannot_roll_back_is_refused(walls, tmp_path):
    """pythonfmu3's FMUs against the tube's fluid, implicitly coupled. The spring wall cannot get and set its state:
    refused in one line with the reason, unless the scene vouches that it is stateless, when it couples as the
    example's Python spring wall does. The damped wall can: rolled back to each window's start through its FMU
    state, it couples as the example's Python damped wall does (same iterations, sections to the criterion)."""
    spring, damped = walls
    refused = run("examples/damped_wall/scene.toml", "--set", "components.solid.backend=fmu", "--set",
                  f"components.solid.fmu.path={spring}", "--set", "time.end=1", "--out", str(tmp_path / "refused"))
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1
    assert "cannot get and set its state (canGetAndSetFMUState is false)" in refused.stderr
    for name, fmu, scene, extra in (("spring", spring, "examples/spring_wall/scene.toml",
                                     ["--set", "components.solid.fmu.state=stateless"]),
                                    ("damped", damped, "examples/damped_wall/scene.toml", [])):
        reference = run(scene, "--set", "time.end=1", "--out", str(tmp_path / f"{name}_python"))
        coupled = run(scene, "--set", "components.solid.backend=fmu", "--set", f"components.solid.fmu.path={fmu}",
                      "--set", "time.end=1", *extra, "--out", str(tmp_path / f"{name}_fmu"))
        assert reference.returncode == 0 and coupled.returncode == 0, coupled.stderr
        (iterations, section), (their_iterations, their_section) = (fields(tmp_path / f"{name}_python"),
                                                                    fields(tmp_path / f"{name}_fmu"))
        # two runs whose solvers round differently meet the same criterion on the same fixed point: they agree to
        # the criterion's relative change of the section, not to its rounding (AVX-512 BLAS kernels differ in ulps),
        # and a window whose last change sits within that rounding of the limit may take one iteration more or less
        assert len(iterations) == len(their_iterations) and np.abs(iterations - their_iterations).max() <= 1
        limit = tomllib.loads((ROOT / scene).read_text())["coupling"]["convergence"][0]["limit"]
        np.testing.assert_allclose(their_section, section, rtol=0, atol=limit * np.abs(section).max())


def rewritten(fmu: Path, out: Path, change) -> Path:
    """A copy of ``fmu`` with its members passed through ``change(name, data) -> [(name, data), ...]``."""
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(out, "w") as target:
        for item in source.infolist():
            for name, data in change(item.filename, source.read(item.filename)):
                target.writestr(name, data)
    return out


def description_edit(old: bytes, new: bytes):
    """A change of the model description's first ``old`` to ``new`` (an element's closing tag follows its name)."""
    def change(name: str, data: bytes):
        if name == "modelDescription.xml":
            assert old in data, old
            start = data.index(old)
            data = data[:start] + new + data[start + len(old):]
            tags = old.split(b" ")[0][1:], new.split(b" ")[0][1:]
            end = data.find(b"</" + tags[0] + b">", start)
            if tags[0] != tags[1] and old.startswith(b"<") and end >= 0:     # the element's closing tag follows
                data = data[:end] + b"</" + tags[1] + b">" + data[end + len(tags[0]) + 3:]
        return [(name, data)]
    return change


def plus(member: str):
    """A change that adds ``member`` (once, beside the model description)."""
    return lambda name, data: [(name, data)] + ([(member, b"x")] if name == "modelDescription.xml" else [])


def both(first, second):
    return lambda name, data: [(n, d2) for n, d in first(name, data) for n2, d2 in second(n, d)]


BOMB = (b'<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;">'
        b'<!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;">]>\n')


def bad_fmus(good: Path, folder: Path) -> dict[str, tuple[Path, str]]:
    """Bad FMI 3.0 FMUs made from a good one: what each is, and what its refusal must say."""
    symlink = folder / "symlink.fmu"
    shutil.copy(good, symlink)
    with zipfile.ZipFile(symlink, "a") as archive:
        link = zipfile.ZipInfo("resources/link")
        link.external_attr = 0o120777 << 16
        archive.writestr(link, "/etc/passwd")
    truncated = folder / "truncated.fmu"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    return {
        "zip-slip": (rewritten(good, folder / "slip.fmu", plus("../../escaped.txt")),
                     "whose path leaves the folder it unpacks to"),
        "absolute path": (rewritten(good, folder / "absolute.fmu", plus("/tmp/escaped")),
                          "whose path leaves the folder it unpacks to"),
        "symbolic link": (symlink, "that is a link"),
        "XML bomb": (rewritten(good, folder / "bomb.fmu",
                               description_edit(b'<?xml version=\'1.0\' encoding=\'UTF-8\'?>\n', BOMB)),
                     "with a DTD or entities"),
        "missing binary": (rewritten(good, folder / "nobinary.fmu",
                                     lambda n, d: [] if n.startswith("binaries/") else [(n, d)]),
                           "has no x86_64-linux binary"),
        "FMI 4.0": (rewritten(good, folder / "fmi4.fmu", description_edit(b'fmiVersion="3.0"', b'fmiVersion="4.0"')),
                    "FMI 4.0"),
        "no Co-Simulation": (rewritten(good, folder / "me.fmu", description_edit(b"<CoSimulation", b"<ModelExchange")),
                             "without Co-Simulation"),
        "dimensions against the scene": (rewritten(good, folder / "dims.fmu", description_edit(
            b'<Dimension start="101" />\n    </Float64>\n    <Float64 name="section"',
            b'<Dimension start="50" />\n    </Float64>\n    <Float64 name="section"')),
            "pressure"),
        "structural dimension": (rewritten(good, folder / "structural.fmu", both(
            description_edit(b'<Dimension start="101" />', b'<Dimension valueReference="9" />'),
            description_edit(b"<ModelVariables>", b'<ModelVariables>\n    <UInt64 name="n" valueReference="9" '
                                                  b'causality="structuralParameter" variability="fixed" '
                                                  b'start="101" />'))), "structural parameter"),
        "integer input": (rewritten(good, folder / "int.fmu", description_edit(
            b'<Float64 name="pressure" valueReference="1" causality="input" variability="continuous"',
            b'<Int32 name="pressure" valueReference="1" causality="input" variability="discrete"')), "only Float64"),
        "truncated archive": (truncated, "not a zip archive"),
        "missing resource": (rewritten(good, folder / "noresource.fmu",
                                       lambda n, d: [] if n == "resources/rom.bin" else [(n, d)]),
                             "cannot open resource file"),
        "identifier leaving the folder": (rewritten(good, folder / "identifier.fmu", description_edit(
            b'modelIdentifier="solid_rom"', b'modelIdentifier="../../../tmp/escaped"')),
            "has the modelIdentifier '../../../tmp/escaped', not a C name"),
        "wrong token": (rewritten(good, folder / "token.fmu", description_edit(b'instantiationToken="{',
                                                                               b'instantiationToken="{0')),
                        "does not match the resource"),
    }


def test_bad_fmi3_fmus_are_refused_in_one_line(models, tmp_path):  # noqa: F811
    """Fourteen bad FMI 3.0 FMUs, each in the tube's scene: exit 2, one line naming what is wrong, no traceback,
    nothing unpacked outside its folder."""
    model_path, _, _ = models["rbf"]
    good = fmi3(model_path, tmp_path)
    escaped = [Path("/tmp/escaped"), tmp_path.parent.parent / "escaped.txt"]
    for what, (fmu, message) in bad_fmus(good, tmp_path).items():
        done = run("scenes/tube_fom.toml", "--set", "components.solid.backend=fmu", "--set",
                   f"components.solid.fmu.path={fmu}", "--set", "time.end=0.2", "--out", str(tmp_path / what))
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(lines) == 1 and "Traceback" not in done.stderr, (what, done.stderr)
        assert message in lines[0], (what, lines[0])
    assert not any(path.exists() for path in escaped)


def test_a_truncated_or_foreign_fmi3_state_is_refused_when_restored(model, models, tmp_path):  # noqa: F811
    """A checkpoint's FMU state cut short, or another FMU's: one line naming it, the component left usable."""
    path, _, data = model
    fmu3 = fmi3(path, tmp_path)
    component = started(fmu3)
    component.step(0.0, 0.1, {"force": data.F[0]})
    saved = component.checkpoint()["fmu_state"]
    other = started(fmi3(models["rbf"][0], tmp_path)).checkpoint()["fmu_state"]
    for state, message in ((saved[:-8], "a state of"), (saved[:40], "not a serialised state of this FMU"),
                           (other, "not a serialised state of this FMU")):
        with pytest.raises(ComponentError, match="refused the serialised state of the checkpoint") as caught:
            component.restore_checkpoint({"fmu_state": state})
        assert message in str(caught.value) and "\n" not in str(caught.value)
    component.restore_checkpoint({"fmu_state": saved})
    component.terminate()


DRIVEN_WALL = """
[time]
end = 1.0
dt = 0.1

[tube]
length = 10.0
cells = 100
a0 = 1.0

[components.driver]
entry = "fmu_component.component:FmuComponent"
parameters = {{ path = "{fmu}" }}

[components.solid]
entry = "solid_component.tube:TubeSolid"
sections = ["tube"]
parameters = {{ E_small = 12500.0, E_large = 2500.0, s0 = 20.0, eps0 = 2e-3 }}

[[exchange]]
data = "pressure"
from = "driver"
to = "solid"

[coupling]
scheme = "serial-explicit"
participants = ["driver", "solid"]
"""


def test_an_fmu_with_outputs_alone_drives_a_solver_one_way_and_its_other_variables_stay_its_own(walls, tmp_path):
    """An FMU with no Float64 input (the Reference FMUs' BouncingBall, Dahlquist, VanDerPol) drives the tube's wall
    one way; its Int32 input, which the scene does not couple, does not refuse it (as the Reference Feedthrough's
    Float32 input did). The wall receives the FMU's signal at each window's end."""
    driver = walls[0].parent / "PressureDriverFmu.fmu"
    (tmp_path / "scene.toml").write_text(DRIVEN_WALL.format(fmu=driver))
    done = run(str(tmp_path / "scene.toml"), "--out", str(tmp_path / "run"))
    assert done.returncode == 0, done.stderr
    from cosim.results import RunResults
    with RunResults(tmp_path / "run" / "results.h5") as results:
        times, pressure = results.windows.time, results.fields()["pressure"]
    expected = 50.0 * np.sin(2.0 * np.pi * 2.0 * times)[:, None] * (1.0 - np.arange(101) / 100.0)
    np.testing.assert_allclose(pressure, expected, rtol=0, atol=1e-12 * 50.0)
    assert len(times) == 10 and np.ptp(pressure) > 50.0       # the signal did go through the coupling
