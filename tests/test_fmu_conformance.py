"""The exported FMU against the FMI 2.0 rules: state machine, Initialization Mode outputs, refused
values, states freed with the instance, log categories and loggingOn; its binary rebuilt from its
own sources (fmpy.build, gcc -O3 -march=native) loads without libm and is bit-identical."""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.validation import validate_fmu

from fmu_component.component import FmuComponent
from rom_component.fmu.export import export_fmu
from rom_component.fmu.skeleton import source_paths
from rom_component.static.compiled import SOURCE
from rom_component.static.load import load_rom
from tests.test_fmu import models, train  # noqa: F401  (the module's fixture)

N = 101   # the rbf model's inputs and outputs


class Host:
    """An FMU instance driven through raw fmi2 calls, with counted allocations and kept messages."""

    def __init__(self, fmu: Path, logging_on: bool = False):
        self.md = read_model_description(str(fmu))
        self.unzipped = extract(str(fmu))
        self.messages: list[tuple[str, str]] = []
        self.allocated = self.freed = 0
        libc = ctypes.CDLL(None)
        libc.calloc.restype, libc.calloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t, ctypes.c_size_t]
        libc.free.argtypes = [ctypes.c_void_p]

        def allocate(count, size):
            self.allocated += 1
            return libc.calloc(count, size)

        def free(pointer):
            if pointer:
                self.freed += 1
            libc.free(pointer)

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(
            lambda env, name, status, category, message: self.messages.append((category.decode(), message.decode())))
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(allocate)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.callbacks = callbacks
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzipped,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="rom")
        self.slave.instantiate(callbacks=callbacks, loggingOn=logging_on)
        self.dll, self.c = self.slave.dll, self.slave.component

    def status(self, function: str, *args) -> int:
        """The raw status of an fmi2 call (fmpy's wrappers raise on errors)."""
        return getattr(self.dll, function)(self.c, *args)

    def set(self, values: np.ndarray, first: int = 0) -> int:
        refs = (ctypes.c_uint * len(values))(*range(first, first + len(values)))
        return self.status("fmi2SetReal", refs, ctypes.c_size_t(len(values)),
                           (ctypes.c_double * len(values))(*values))

    def get_outputs(self) -> np.ndarray:
        return np.array(self.slave.getReal(list(range(N, 2 * N))))

    def close(self) -> None:
        self.slave.freeInstance()
        shutil.rmtree(self.unzipped, ignore_errors=True)


@pytest.fixture
def rbf(models):  # noqa: F811
    return models["rbf"]


def test_state_machine_refuses_calls_out_of_turn(rbf):
    host = Host(rbf[1])
    try:
        assert host.status("fmi2DoStep", ctypes.c_double(0.0), ctypes.c_double(0.1), 1) == 3
        assert host.messages[-1][1] == ("fmi2DoStep is not allowed in the instantiated state "
                                        "(before EnterInitializationMode)")
        host.slave.reset()
        assert host.status("fmi2Terminate") == 3
        assert host.messages[-1][1].startswith("fmi2Terminate is not allowed in the instantiated state")
        host.slave.reset()
        host.slave.setupExperiment(startTime=0.0)
        host.slave.enterInitializationMode()
        host.slave.exitInitializationMode()
        host.slave.doStep(0.0, 0.1)
        host.slave.terminate()
        assert host.set(np.ones(3)) == 3
        assert host.messages[-1][1] == "fmi2SetReal is not allowed in the terminated state"
        assert host.status("fmi2DoStep", ctypes.c_double(0.1), ctypes.c_double(0.1), 1) == 3
        assert "error state" in host.messages[-1][1]
    finally:
        host.close()


def test_outputs_in_initialization_mode_follow_the_inputs_set_there(rbf):
    model, fmu, F = rbf
    rom = load_rom(model)
    host = Host(fmu)
    try:
        host.slave.setupExperiment(startTime=0.0)
        host.slave.enterInitializationMode()
        assert host.set(F[7]) == 0
        assert host.get_outputs().tobytes() == rom(F[7]).tobytes()
    finally:
        host.close()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_inputs_and_bad_step_sizes_are_refused_with_the_variable_named(rbf, bad):
    host = Host(rbf[1])
    try:
        host.slave.setupExperiment(startTime=0.0)
        host.slave.enterInitializationMode()
        values = np.zeros(3)
        values[2] = bad
        assert host.set(values) == 3
        assert host.messages[-1] == ("logStatusError", f"fmi2SetReal: pressure[3] = {bad:g} is not finite")
        for step in (0.0, bad, -0.1):
            host.slave.reset()
            host.slave.enterInitializationMode()
            host.slave.exitInitializationMode()
            assert host.status("fmi2DoStep", ctypes.c_double(0.0), ctypes.c_double(step), 1) == 3
            assert host.messages[-1][1] == f"fmi2DoStep: step size {step:g} is not a positive finite number"
    finally:
        host.close()


def test_free_instance_frees_states_the_importer_did_not_free(rbf):
    host = Host(rbf[1])
    for _ in range(3):
        host.slave.getFMUState()
    kept = host.slave.getFMUState()
    host.slave.freeFMUState(kept)
    host.close()
    assert host.allocated == host.freed > 0


def test_every_log_category_used_is_declared_and_logging_on_is_honoured(rbf):
    used = {c for path in source_paths(SOURCE, 2)
            for c in re.findall(r'"(log[A-Z]\w+)"', path.read_text())}
    declared = {c.name for c in read_model_description(str(rbf[1])).logCategories}
    assert used == declared == {"logEvents", "logStatusError"}
    quiet, verbose = Host(rbf[1], logging_on=False), Host(rbf[1], logging_on=True)
    try:
        assert quiet.messages == []
        assert verbose.messages[0][0] == "logEvents" and verbose.messages[0][1].startswith("instantiated: 101 inputs")
        quiet.slave.setDebugLogging(True, ["logEvents"])
        quiet.slave.setupExperiment(startTime=0.0)
        quiet.slave.enterInitializationMode()
        quiet.slave.exitInitializationMode()
        quiet.slave.terminate()
        assert quiet.messages[-1] == ("logEvents", "terminated at t = 0")
    finally:
        quiet.close()
        verbose.close()


def test_model_description_is_byte_stable_and_valid(rbf, tmp_path):
    model, fmu, _ = rbf
    again = export_fmu(model, tmp_path / "again.fmu")
    with zipfile.ZipFile(fmu) as a, zipfile.ZipFile(again) as b:
        assert a.read("modelDescription.xml") == b.read("modelDescription.xml")
        assert a.read("resources/rom.bin") == b.read("resources/rom.bin")
    assert validate_fmu(str(again)) == []


def rebuilt(fmu: Path, tmp_path: Path, how: str) -> Path:
    """The FMU with its binary rebuilt from its own sources/."""
    unzipped = tmp_path / f"unzipped_{how}"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unzipped)
    binary = unzipped / "binaries" / "linux64" / "solid_rom.so"
    binary.unlink()
    if how == "fmpy":
        from fmpy.build import build_platform_binary
        (tmp_path / "build").mkdir(parents=True)
        build_platform_binary(unzipped, tmp_path / "build")
    else:
        description = ET.fromstring((unzipped / "modelDescription.xml").read_bytes())
        listed = [f.get("name") for f in description.iterfind("CoSimulation/SourceFiles/File")]
        subprocess.run(["gcc", "-O3", "-march=native", "-shared", "-fPIC", f"-I{unzipped / 'sources'}",
                        *(str(unzipped / "sources" / name) for name in listed), "-o", str(binary)], check=True)
    assert binary.is_file()
    undefined = subprocess.run(["nm", "-D", "--undefined-only", str(binary)], capture_output=True, text=True,
                               check=True).stdout.split()
    assert "log" not in undefined and not any(s.startswith("log@") for s in undefined)
    needed = subprocess.run(["readelf", "-d", str(binary)], capture_output=True, text=True, check=True).stdout
    assert "libm.so" not in needed
    out = tmp_path / f"{how}.fmu"
    with zipfile.ZipFile(out, "w") as archive:
        for path in sorted(unzipped.rglob("*")):
            if path.is_file():
                archive.write(path, path.relative_to(unzipped).as_posix())
    return out


@pytest.mark.parametrize("how", ["fmpy", "gcc-O3-native"])
def test_a_binary_rebuilt_from_sources_is_bit_identical_without_libm(models, tmp_path, how):  # noqa: F811
    if shutil.which("cmake" if how == "fmpy" else "gcc") is None:
        pytest.skip(f"{how} needs a build tool that is not installed")
    for name in ("rbf", "qm_poly"):
        model, fmu, F = models[name]
        rom = load_rom(model)
        component = FmuComponent()
        component.instantiate({"path": str(rebuilt(fmu, tmp_path / name, how))})
        component.enter_initialization_mode(0.0, 1.0)
        component.exit_initialization_mode()
        [input_name], [output_name] = component.inputs, component.outputs
        for f in F[:100]:
            assert component.step(0.0, 0.1, {input_name: f})[output_name].tobytes() == rom(f).tobytes()
        component.terminate()
