from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar

import pytest

ROOT = Path(__file__).resolve().parent.parent
TUBE_SCENE = ROOT / "scenes" / "tube_fom.toml"
REFERENCE = ROOT / "scenes" / "inlet"  # copies of shared/reference/tube-inlet-mu*.csv


T = TypeVar("T")

#: the double flap's solvers; the tube needs none of Kratos, and a tube-only install skips these tests
needs_kratos = pytest.mark.skipif(importlib.util.find_spec("KratosMultiphysics") is None,
                                  reason="needs Kratos Multiphysics (pip install -e '.[kratos]')")


def participant_module(name: str) -> ModuleType:
    """A module of the preCICE participant package (``precice_compat/participant/precice/``), loaded from its file:
    the package is installed where the participants run, not in the tests' environment."""
    path = ROOT / "precice_compat" / "participant" / "precice" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"precice_participant.{name}", path)
    assert spec is not None and spec.loader is not None, path
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def wait_for(condition: Callable[[], T], what: str, timeout: float = 60.0, poll: float = 0.05) -> T:
    """Poll ``condition`` until it returns something truthy; fail naming ``what`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(poll)


def windows_done(out_dir: Path) -> int:
    """Windows finished so far by the run writing ``out_dir`` (from its status file)."""
    from cosim.rundir import read_status
    return int(read_status(out_dir).get("windows_completed", 0))


@pytest.fixture(autouse=True)
def benchmark_runs_in_tmp(tmp_path_factory, monkeypatch) -> None:
    """Benchmarks' small modes write under the tests' temporary directory, never into the checkout."""
    monkeypatch.setenv("COSIM_BENCH_DIR", str(tmp_path_factory.getbasetemp() / "bench"))


@pytest.fixture
def tube_scene_path() -> Path:
    return TUBE_SCENE


def children_of(pid: int) -> list[int]:
    """Pids of processes whose parent is ``pid`` (Linux /proc), leaving out Python's own multiprocessing
    resource tracker (started by Dask's local cluster in the sweep tests; it exits with its parent)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z" and "resource_tracker" not in cmdline(int(entry)):
                found.append(int(entry))
    return found


def cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def alive_with(text: str) -> list[int]:
    """Pids of live processes whose command line contains ``text``."""
    pids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit() and text in cmdline(int(entry)):
            try:
                with open(f"/proc/{entry}/stat") as f:
                    state = f.read().rsplit(")", 1)[1].split()[0]
            except OSError:
                continue
            if state != "Z":
                pids.append(int(entry))
    return pids


#: tests that race a run against the clock (a signal or a kill at a window, a timeout) or pin cores and time runs:
#: `make test` runs them alone after the rest has run on two workers (pytest-xdist), so no other test's load
#: shifts their timing
SERIAL_MODULES = ("test_faults.py", "test_benchmarks.py")
SERIAL_TESTS = ("test_a_campaign_stopped_midway_goes_on_from_its_runs_checkpoints",
                "test_an_interrupted_sweep_resumes_without_redoing_finished_runs",
                "test_a_run_killed_in_a_window_resumes_from_its_checkpoint_bit_for_bit",
                "test_killed_solid_stops_the_run_and_keeps_finished_windows",
                "test_hanging_component_times_out_and_is_killed", "test_ctrl_c_stops_every_component",
                "test_a_remote_component_that_disappears_stops_the_run_within_its_timeout_naming_it")


def pytest_configure(config: pytest.Config) -> None:
    import signal
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        # started in the background by a shell without job control: the runs the tests start would inherit the
        # ignored SIGINT, and the tests that stop them with it would wait for nothing
        signal.signal(signal.SIGINT, signal.default_int_handler)
    config.addinivalue_line("markers", "serial: races a run against the clock; `make test` runs it alone")
    config.addinivalue_line("markers", "benchmark: holds a benchmark's small mode to a generous bound on a cost ratio "
                                       "(a regression of several times fails it; it is no timed assertion)")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if item.path.name in SERIAL_MODULES or item.originalname in SERIAL_TESTS:  # type: ignore[attr-defined]
            item.add_marker(pytest.mark.serial)


@contextmanager
def served_by_hand(entry: str, bind: str = "tcp://127.0.0.1:*", curve: Path | None = None,
                   prefix: tuple[str, ...] = (), cwd: Path = ROOT, script: bool = False) -> Iterator[dict]:
    """``cosim serve ENTRY --bind BIND [--curve DIR]`` by hand, as a user starts it (on another machine); yields
    its handshake line (endpoint, pid) and stops it at the end. ``script``: through the ``cosim`` console script
    (which, unlike ``python -m``, puts no working directory on the import path)."""
    cosim = [str(Path(sys.executable).with_name("cosim"))] if script else [sys.executable, "-m", "cosim"]
    process = subprocess.Popen([*prefix, *cosim, "serve", entry, "--bind", bind,
                                *(["--curve", str(curve)] if curve else [])], cwd=cwd, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None
        line = process.stdout.readline()       # the server prints its handshake once it is bound
        assert line, process.stderr.read() if process.stderr else ""
        yield json.loads(line)
    finally:
        if process.poll() is None:
            process.terminate()
        process.wait(timeout=10)


def fmpy_slave(fmu: Path, instance: str = "fmu") -> tuple[Any, dict[str, int]]:
    """An FMI 2.0 Co-Simulation FMU instantiated and initialised at t = 0 by fmpy, an importer of its own, and its
    value references by name."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    md = read_model_description(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=instance)
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    return slave, {v.name: v.valueReference for v in md.modelVariables}
