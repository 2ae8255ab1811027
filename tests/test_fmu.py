"""FMU export of the ROM (FMI 2.0 Co-Simulation, C online path) and FMUs as solid backends."""

from __future__ import annotations

import ctypes
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from cosim.errors import ComponentError
from fmu_component.component import FmuComponent
from rom_component import model_file
from rom_component.fmu.export import export_fmu
from rom_component.static.load import load_rom
from tests.conftest import ROOT
from tests.roms import solid_rom
from tests.test_rom import smooth_data


def train(tmp_path: Path, name: str, n_in: int, n_out: int, components: int, input_name: str, output_name: str,
          **parts) -> tuple[Path, np.ndarray]:
    F, U = smooth_data(m=300, n_in=n_in, n_out=n_out, seed=len(name))
    model = solid_rom(**parts).fit(F, U)
    path = model_file.save(tmp_path / f"{name}.npz", model.online_arrays(),
                            {"regressor": model.regressor_.type_name, "params": model.settings(),
                             "input_variable": input_name, "output_variable": output_name,
                             "components_per_node": components})
    return path, F


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """An RBF tube-sized model (101 nodes), a quadratic-manifold + sparse-polynomial 2-D model, and the same with
    cubic terms (ridge fit)."""
    tmp = tmp_path_factory.mktemp("fmu")
    rbf, F_rbf = train(tmp, "rbf", 101, 101, 1, "pressure", "section", r_f=3, r_u=4)
    qm, F_qm = train(tmp, "qm_poly", 40, 30, 2, "force", "displacement", r_f=3, r_u=4,
                     decoder="quadratic", regressor="poly")
    cubic, F_cubic = train(tmp, "qm_cubic", 40, 30, 2, "force", "displacement", r_f=4, r_u=4,
                           decoder="quadratic", regressor={"type": "poly", "method": "ridge", "cubic_modes": 2})
    return {name: (model, export_fmu(model, tmp / f"{name}.fmu"), F)
            for name, model, F in (("rbf", rbf, F_rbf), ("qm_poly", qm, F_qm), ("qm_cubic", cubic, F_cubic))}


@pytest.mark.parametrize("name", ["rbf", "qm_poly"])
def test_exported_fmu_validates(models, name):
    _, fmu, _ = models[name]
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.fmiVersion == "2.0"
    assert md.coSimulation.needsExecutionTool is False and md.coSimulation.canGetAndSetFMUstate is True
    names = [v.name for v in md.modelVariables]
    if name == "rbf":
        assert names[0] == "pressure[1]" and names[-1] == "section[101]"
    else:
        assert "force[20].y" in names and "displacement[15].x" in names
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    assert all(v.start is not None for v in inputs)
    assert len(md.outputs) == len(md.initialUnknowns) == len(names) - len(inputs)
    with zipfile.ZipFile(fmu) as archive:
        files = set(archive.namelist())
    assert {"sources/solid_rom.c", "resources/rom.bin", "binaries/linux64/solid_rom.so"} <= files


@pytest.mark.parametrize("name", ["rbf", "qm_poly", "qm_cubic"])
def test_simulate_fmu_reproduces_the_python_rom(models, name):
    model, fmu, F = models[name]
    rom = load_rom(model)
    md = read_model_description(str(fmu))
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    F = F[:30] * 1.01
    table = np.zeros(len(F), dtype=[("time", np.float64)] + [(n, np.float64) for n in inputs])
    table["time"] = 0.1 * np.arange(len(F))
    for j, n in enumerate(inputs):
        table[n] = F[:, j]
    result = simulate_fmu(str(fmu), start_time=0.0, stop_time=table["time"][-1], step_size=0.1,
                          output_interval=0.1, input=table, output=outputs)
    Y = np.column_stack([result[n] for n in outputs])
    expected = rom.predict(F)
    # the output recorded at t_(k+1) comes from the step that used the inputs of t_k
    np.testing.assert_allclose(Y[1:], expected[:-1], rtol=1e-10, atol=1e-10 * np.abs(expected).max())


@pytest.mark.parametrize("name", ["rbf", "qm_poly", "qm_cubic"])
def test_fmu_component_is_bit_identical_to_the_python_rom(models, name):
    model, fmu, F = models[name]
    rom = load_rom(model)
    component = FmuComponent()
    component.instantiate({"path": str(fmu)})
    component.enter_initialization_mode(0.0, 1.0)
    component.exit_initialization_mode()
    (input_name,) = [v.name for v in component.variables() if v.causality == "input"]
    (output_name,) = [v.name for v in component.variables() if v.causality == "output"]
    for f in F[:50] * 1.003:
        out = component.step(0.0, 0.1, {input_name: f})[output_name]
        assert out.tobytes() == rom(f).tobytes()
    component.terminate()


def test_fmu_state_round_trip(models):
    """The FMU's own state: a window repeated by rolling back (state = "rollback") gives the first call's bits,
    and a state saved, then restored after another window, gives its outputs back."""
    _, fmu, F = models["rbf"]
    component = FmuComponent()
    component.instantiate({"path": str(fmu), "state": "rollback"})
    assert component.repeats_steps and not component.stateless
    component.enter_initialization_mode(0.0, 1.0)
    component.exit_initialization_mode()
    first = component.step(0.0, 0.1, {"pressure": F[0]})["section"]
    assert component.step(0.0, 0.1, {"pressure": F[0]})["section"].tobytes() == first.tobytes()
    handle = component.fmu.get_state()
    assert not np.array_equal(component.step(0.1, 0.1, {"pressure": F[1]})["section"], first)
    component.fmu.set_state(handle)
    np.testing.assert_array_equal(component.get_values(["section"])["section"], first)
    component.fmu.free_state(handle)
    component.terminate()


def test_c_code_checks_pointers_counts_and_references(models):
    _, fmu, _ = models["rbf"]
    component = FmuComponent()
    component.instantiate({"path": str(fmu)})
    set_real, get_real = component.fmu._set, component.fmu._get
    handle = component.fmu.component
    values = (ctypes.c_double * 3)()
    refs = (ctypes.c_uint * 3)(0, 1, 5000)
    output = (ctypes.c_uint * 1)(150)
    for call, message in ((lambda: set_real(handle, None, 3, values), "NULL value reference"),
                          (lambda: set_real(handle, refs, 3, values), "value reference 5000 is out of range (0..201)"),
                          (lambda: set_real(handle, output, 1, values),
                           "section[50] (value reference 150) is an output and cannot be set"),
                          (lambda: get_real(handle, refs, 10_000, values), "10000 values requested")):
        component.fmu.slave.reset()             # an error leaves the FMU in its error state
        component.fmu.slave.enterInitializationMode()
        assert call() == 3
        assert message in component.messages[-1]
    assert get_real(None, refs, 1, values) == 3  # a NULL instance is refused, not dereferenced
    component.fmu.slave.freeInstance()


def test_bad_fmus_get_clear_errors(models, tmp_path):
    _, fmu, _ = models["rbf"]
    garbage = tmp_path / "garbage.fmu"
    garbage.write_bytes(b"definitely not a zip")
    with pytest.raises(ComponentError, match="not a zip archive"):
        FmuComponent().instantiate({"path": str(garbage)})
    truncated = tmp_path / "truncated.fmu"
    truncated.write_bytes(fmu.read_bytes()[: fmu.stat().st_size // 2])
    with pytest.raises(ComponentError, match="not a zip archive|no valid modelDescription"):
        FmuComponent().instantiate({"path": str(truncated)})
    with pytest.raises(ComponentError, match="does not exist"):
        FmuComponent().instantiate({"path": str(tmp_path / "missing.fmu")})
    no_resource = tmp_path / "no_resource.fmu"
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(no_resource, "w") as target:
        for item in source.infolist():
            if item.filename != "resources/rom.bin":
                target.writestr(item, source.read(item.filename))
    with pytest.raises(ComponentError, match=r"failed to instantiate.*cannot open resource file '.*rom.bin'"):
        FmuComponent().instantiate({"path": str(no_resource)})
    short_resource = tmp_path / "short_resource.fmu"
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(short_resource, "w") as target:
        for item in source.infolist():
            data = source.read(item.filename)
            target.writestr(item, data[:-8] if item.filename == "resources/rom.bin" else data)
    with pytest.raises(ComponentError, match=r"bytes, the sizes in its header need"):
        FmuComponent().instantiate({"path": str(short_resource)})


@pytest.mark.parametrize(("text", "why"), [
    ("{", "Expecting property name"),
    ('{"variables": 5, "meshes": {}}', "'variables' must be a list, not a number"),
    ('{"variables": [{"name": "pressure"}], "meshes": {}}', "'variables[0]' has no key 'mesh'"),
    ("[1, 2]", "must hold an object, not a list"),
    ('{"variables": [], "meshes": {"m": [[0, "x"]]}}', "'meshes.m' must be a list of nodes"),
    ('{"variables": [{"name": "p", "mesh": "m", "components": 0}], "meshes": {}}',
     "'variables[0].components' must be an integer of at least 1, not 0"),
    ('{"variables": [{"name": "p", "mesh": "wall", "components": 1}], "meshes": {"m": [[0.0, 1.0]]}}',
     "variable 'p' is on mesh 'wall', which 'meshes' does not hold (it holds: m)"),
    ('{"variables": [], "meshes": {}, "history_windows": -1}', "'history_windows' must be an integer of at least 0"),
    ("[" * 100000 + "]" * 100000, "nested too deeply")])
def test_a_damaged_interface_json_is_named_in_one_line(models, tmp_path, text, why):
    """The FMU's resources/interface.json (meshes and variables' placement) damaged: one line naming the file."""
    fmu = models["rbf"][1]
    damaged = tmp_path / "damaged.fmu"
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(damaged, "w") as target:
        for item in source.infolist():
            if item.filename != "resources/interface.json":
                target.writestr(item, source.read(item.filename))
        target.writestr("resources/interface.json", text)
    with pytest.raises(ComponentError, match=r"resources/interface.json: .*" + re.escape(why)) as refused:
        FmuComponent().instantiate({"path": str(damaged)})
    assert "\n" not in str(refused.value)


def test_an_exceptions_whole_message_goes_on_one_line():
    from fmu_component.archive import one_line
    assert one_line(ValueError("Failed to validate modelDescription.xml:\n- line 3: missing attribute 'guid'")) == \
        "Failed to validate modelDescription.xml: - line 3: missing attribute 'guid'"
    assert one_line(OSError(": 77")) == "OSError: 77"


def test_an_fmi2_fmus_scalars_are_arrays_of_one_and_its_other_types_are_named():
    """The Reference FMUs' FMI 2.0 variables: a plain Real scalar ('x') is a variable of one value, 'a[1]', 'a[2]'
    an array of two; an Integer output is kept to the FMU with the reason (they were all refused: 'no array inputs
    or outputs')."""
    from types import SimpleNamespace

    from fmu_component.fmi2_instance import Fmi2Instance
    variables = [SimpleNamespace(name=name, type=kind, causality=causality, valueReference=vr)
                 for vr, (name, kind, causality) in enumerate([("x", "Real", "output"), ("a[1]", "Real", "input"),
                                                               ("a[2]", "Real", "input"), ("n", "Integer", "output"),
                                                               ("der(x)", "Real", "local"),
                                                               ("m[1,2]", "Real", "output")])]
    md = SimpleNamespace(modelVariables=variables,
                         coSimulation=SimpleNamespace(canGetAndSetFMUstate=True, canSerializeFMUstate=False))
    instance = Fmi2Instance(md, "test")
    assert {name: (v.causality, v.size) for name, v in instance.variables.items()} == {
        "x": ("output", 1), "a": ("input", 2), "der(x)": ("local", 1)}
    assert instance.skipped == {"n": "output 'n' is Integer; only Real (Float64) variables can be coupled",
                                "m[1,2]": "output 'm[1,2]' is an element of an array not named by node (name[i] or "
                                          "name[i].x)"}


def test_resource_uri_forms(models, tmp_path):
    """file:///path with and without a trailing slash, percent-encoded, and file://localhost/."""
    from fmpy import calloc, free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )
    _, fmu, _ = models["rbf"]
    unzipped = tmp_path / "a dir with spaces%"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unzipped)
    guid = read_model_description(str(fmu)).guid.encode()
    dll = ctypes.CDLL(str(unzipped / "binaries/linux64/solid_rom.so"))
    dll.fmi2Instantiate.restype = ctypes.c_void_p
    dll.fmi2Instantiate.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p,
                                    ctypes.c_void_p, ctypes.c_int, ctypes.c_int]
    dll.fmi2FreeInstance.argtypes = [ctypes.c_void_p]
    messages = []
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, message: messages.append(message))
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    uri = (unzipped / "resources").as_uri()
    assert "%20" in uri and "%25" in uri
    for location in (uri, uri + "/", uri.replace("file:///", "file://localhost/"), uri.replace("file:///", "file:/")):
        instance = dll.fmi2Instantiate(b"rom", 1, guid, location.encode(), ctypes.addressof(callbacks), 0, 0)
        assert instance, (location, messages)
        dll.fmi2FreeInstance(instance)
    for bad, message in ((b"http://example.invalid/resources", b"is not a file URI"),
                         ((uri + "x").encode(), b"cannot open resource file")):
        assert not dll.fmi2Instantiate(b"rom", 1, guid, bad, ctypes.addressof(callbacks), 0, 0)
        assert message in messages[-1]
    assert not dll.fmi2Instantiate(b"rom", 1, b"{wrong}", uri.encode(), ctypes.addressof(callbacks), 0, 0)
    assert b"GUID '{wrong}' does not match" in messages[-1]
    assert not dll.fmi2Instantiate(b"rom", 0, guid, uri.encode(), ctypes.addressof(callbacks), 0, 0)  # Model Exchange


def tampered(source, target, **changes):
    """A copy of the model file ``source`` with arrays replaced, added (values) or removed (None)."""
    with np.load(source) as data:
        arrays = {name: data[name] for name in data.files}
    for name, value in changes.items():
        if value is None:
            arrays.pop(name)
        else:
            arrays[name] = value
    with open(target, "wb") as stream:
        np.savez_compressed(stream, **arrays)
    return target


@pytest.mark.parametrize("change, message", [
    (lambda a: {"envelope_precision": a["envelope_precision"][:2]},
     r"array 'envelope_precision' has shape \(2, 3\), expected \(3, 3\) \(r_f = 3, r_u = 4"),
    (lambda a: {"envelope_precision": a["envelope_precision"].ravel()[:5].copy()}, r"'envelope_precision' has shape \(5,\)"),
    (lambda a: {"H": np.where(np.arange(a["H"].size).reshape(a["H"].shape) == 7, np.nan, a["H"])},
     r"array 'H' holds 1 values that are not finite"),
    (lambda a: {"A": a["A"].astype(np.float32)}, r"array 'A' is float32; expected float64"),
    (lambda a: {"centres": a["centres"][:, :2].copy()}, r"array 'centres' has shape \(\d+, 2\), expected \(\d+, 3\)"),
    (lambda a: {"base": None}, r"it lacks the array 'base'"),
    (lambda a: {"E": None}, r"it lacks the array 'E'"),
    (lambda a: {"extra": np.zeros(3)}, r"it holds an unknown array 'extra.npy'"),
])
def test_a_model_with_wrong_arrays_is_refused_when_loaded_and_never_exported(models, tmp_path, capsys, change,
                                                                            message):
    import re

    from cosim.cli import main
    source = models["rbf"][0]
    with np.load(source) as data:
        arrays = {name: data[name] for name in data.files}
    bad = tampered(source, tmp_path / "bad.npz", **change(arrays))
    for arithmetic in ("reproducible", "compiled"):
        with pytest.raises(model_file.ModelFileError, match=message):
            load_rom(bad, arithmetic)
    assert main(["export-fmu", str(bad), "--out", str(tmp_path / "bad.fmu")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and re.search(message, err), err
    assert not (tmp_path / "bad.fmu").exists()


def test_a_model_file_is_read_with_a_size_cap_before_anything_is_decompressed(models, tmp_path):
    import io
    import zipfile

    from rom_component.model_check import MAX_MODEL_BYTES
    source = models["rbf"][0]
    bomb = tmp_path / "bomb.npz"
    bomb.write_bytes(source.read_bytes())
    header = io.BytesIO()                      # a known name whose header declares 2 GiB (the data never follow)
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (1 << 28,)})
    with zipfile.ZipFile(bomb, "a") as archive:
        archive.writestr("Phi_bar.npy", header.getvalue() + b"\0" * 64)
    with pytest.raises(model_file.ModelFileError, match=rf"array 'Phi_bar' declares 2,147,483,648 bytes; a model "
                                                          rf"holds at most {MAX_MODEL_BYTES:,} in all"):
        model_file.load_arrays(bomb)


def unpacked_folders() -> set[str]:
    import tempfile

    from fmu_component.component import UNPACK_ROOT
    root = Path(tempfile.gettempdir()) / UNPACK_ROOT
    return {p.name for p in root.iterdir()} if root.is_dir() else set()


def test_an_fmus_unpacked_files_go_whatever_stops_it(models, tmp_path):
    """A failed start-up, a stop by SIGTERM and a SIGKILL (cleaned at the next start) leave no folder behind."""
    import os
    import signal

    from cosim.launcher import Launcher
    from cosim.proxy import ComponentProxy
    from tests.conftest import wait_for
    _, fmu, _ = models["rbf"]
    before = unpacked_folders()
    no_binary = tmp_path / "no_binary.fmu"
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(no_binary, "w") as target:
        for item in source.infolist():
            if not item.filename.startswith("binaries/"):
                target.writestr(item, source.read(item.filename))
    with pytest.raises(ComponentError, match="has no linux64 binary"):
        FmuComponent().instantiate({"path": str(no_binary)})
    assert unpacked_folders() == before
    import tempfile
    with Launcher(tmp_path / "logs") as launcher:
        for stop in (signal.SIGTERM, signal.SIGKILL):      # in the system's temporary folder: the FMU's own cleanup
            process = launcher.spawn("fmu", "fmu_component.component:FmuComponent",
                                     {"TMPDIR": tempfile.gettempdir()})
            proxy = ComponentProxy("fmu", launcher.handshake(process), process=process)
            proxy.instantiate({"path": str(fmu)})
            mine = {name for name in unpacked_folders() - before if name.startswith(f"{process.pid}-")}
            assert len(mine) == 1
            os.kill(process.pid, stop)
            process.popen.wait(timeout=30)
            proxy.close()
            if stop == signal.SIGTERM:
                assert not mine & unpacked_folders()
        assert mine <= unpacked_folders()        # SIGKILL: no process can clean up after itself ...
        FmuComponent().instantiate({"path": str(fmu)})   # ... the next FMU instance does
        wait_for(lambda: not mine & unpacked_folders(), "the killed instance's folder to go")
        process = launcher.spawn("killed", "fmu_component.component:FmuComponent")    # in the run's own TMPDIR
        proxy = ComponentProxy("killed", launcher.handshake(process), process=process)
        proxy.instantiate({"path": str(fmu)})
        scratch = Path(launcher.scratch("killed"))
        assert any(scratch.rglob("*.so"))
        os.kill(process.pid, signal.SIGKILL)
        process.popen.wait(timeout=30)
        proxy.close()
    assert not scratch.exists()         # the run's temporary folder goes with its processes


def test_an_fmu_that_cannot_serialise_its_state_is_named_when_checkpointed(models, tmp_path):
    path = models["rbf"][1]
    component = FmuComponent()
    component.instantiate({"path": str(path)})
    component.enter_initialization_mode(0.0, 1.0)
    component.exit_initialization_mode()
    assert component.can_checkpoint and component.describe()["can_checkpoint"]
    state = component.checkpoint()
    component.restore_checkpoint(state)              # the exported FMU serialises its state (magic, sizes checked)
    assert state["fmu_state"][:8].tobytes() == b"CSROMST3"
    component.can_serialize = False                  # as an FMU whose modelDescription says it cannot
    assert not component.describe()["can_checkpoint"]
    with pytest.raises(ComponentError, match=r"FMU '.*rbf.fmu' cannot serialise its state \(canSerializeFMUstate"):
        component.checkpoint()
    component.terminate()


def test_a_serialised_state_of_another_model_or_not_finite_is_refused_and_set_state_leaves_an_error(models,
                                                                                                  tmp_path):
    from fmpy.fmi1 import FMICallException

    from tests.conftest import fmpy_slave
    _, fmu, F = models["rbf"]
    other_path, _ = train(tmp_path, "rbf", 101, 101, 1, "pressure", "section", r_f=3, r_u=3)   # same sizes
    other = export_fmu(other_path, tmp_path / "other.fmu")
    mine, refs = fmpy_slave(fmu, "rom")
    theirs, _ = fmpy_slave(other, "rom")
    inputs = [refs[f"pressure[{i + 1}]"] for i in range(101)]
    mine.setReal(inputs, list(F[0]))
    mine.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.1)
    state = mine.getFMUState()
    serialised = bytes(mine.serializeFMUstate(state))
    assert serialised[:8] == b"CSROMST3"
    with pytest.raises(FMICallException):
        theirs.deSerializeFMUstate(serialised)                  # another model's state
    header = 8 + 40 + 16
    values = np.frombuffer(serialised[header:], dtype=np.float64).copy()
    values[3] = np.nan
    with pytest.raises(FMICallException):
        mine.deSerializeFMUstate(serialised[:header] + values.tobytes())
    with pytest.raises(FMICallException):
        mine.setReal(inputs[:1], [float("nan")])                # an error: the instance is in its error state
    with pytest.raises(FMICallException):
        mine.setReal(inputs, list(F[1]))
    mine.setFMUState(state)                                     # the state saved before the error: going on
    mine.setReal(inputs, list(F[1]))
    mine.doStep(currentCommunicationPoint=0.1, communicationStepSize=0.1)
    mine.freeFMUState(state)
    mine.terminate()
    mine.freeInstance()
    theirs.freeInstance()


def test_an_fmu_logs_safely_after_an_fmu_component_of_the_same_process_is_gone(models, tmp_path):
    """fmpy's logger proxy keeps one logger for the whole process: a component's logger must outlive it (a freed
    one crashed the next FMU that logged an error). Run in its own process: a crash must not take the tests."""
    import subprocess
    import sys
    _, fmu, _ = models["rbf"]
    script = f"""
import gc
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi1 import FMICallException
from fmu_component.component import FmuComponent
component = FmuComponent()
component.instantiate({{"path": {str(fmu)!r}}})
component.enter_initialization_mode(0.0, 1.0)
component.exit_initialization_mode()
component.terminate()
del component
gc.collect()
md = read_model_description({str(fmu)!r})
slave = FMU2Slave(guid=md.guid, unzipDirectory=extract({str(fmu)!r}), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="after")
slave.instantiate()
try:
    slave.deSerializeFMUstate(b"not a state")
except FMICallException:
    print("refused")
"""
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "refused", (done.returncode, done.stderr[-2000:])
