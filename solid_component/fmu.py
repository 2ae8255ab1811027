"""Any FMI 2.0 Co-Simulation FMU as a solid component (loaded with fmpy).

The FMU's scalar variables named ``name[node]`` or ``name[node].x|y|z`` are gathered
into the array variables ``name`` (node-major). The hot path calls the FMU's raw
``fmi2SetReal``/``fmi2DoStep``/``fmi2GetReal`` with preallocated ctypes arrays.
By default the FMU is taken as stateless (its outputs depend on its inputs only, as a
quasi-static solid's); ``stateful = true`` uses ``fmi2GetFMUstate``/``fmi2SetFMUstate``.
An FMU whose ``resources/interface.json`` declares ``history_windows`` (a ROM with memory, from
``cosim export-fmu`` of a step-map model) carries a history from window to window: the component
repeats a window by rolling the FMU back to the window's start (``fmi2GetFMUstate`` at its first call,
``fmi2SetFMUstate`` before each later one), and hands it a full-order run's last windows at a switch
through the function the file names (``take_over``). Its ``local`` variables (probe points) are read as locals.
"""

from __future__ import annotations

import atexit
import ctypes
import json
import os
import re
import shutil
import sys
import tempfile
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import Component, Variable, check_inputs
from cosim.errors import ComponentError
from cosim.schema import FilePath

FMU_SCHEMA = {"path": FilePath(), "stateful": False}
FMU_HELP = {"path": "any FMI 2.0 Co-Simulation FMU (for example from `cosim export-fmu`)",
            "stateful": "true: roll the FMU back with fmi2GetFMUstate/fmi2SetFMUstate between iterations"}
NAME = re.compile(r"^(?P<name>[A-Za-z_]\w*)\[(?P<node>\d+)\](?:\.(?P<axis>[xyz]))?$")
WARNING = 1  # fmi2Warning: the worst status that is not an error


UNPACK_ROOT = "cosim-fmu"   # under the system's temporary folder: one folder per FMU instance, named by pid


def unpack_directory() -> Path:
    """A new folder to unpack an FMU into, named after this process; folders of processes that died
    without removing theirs (killed by SIGKILL) are removed first."""
    root = Path(tempfile.gettempdir()) / UNPACK_ROOT
    root.mkdir(exist_ok=True)
    for folder in root.iterdir():
        pid = folder.name.partition("-")[0]
        if pid.isdigit() and not Path(f"/proc/{pid}").exists():
            shutil.rmtree(folder, ignore_errors=True)
    return Path(tempfile.mkdtemp(prefix=f"{os.getpid()}-", dir=root))


# fmpy's logger proxy keeps the last logger it was given in a global of its native library, for every FMU of the
# process: the logger is one function that lives as long as the process, and hands each message to the messages
# of the instance that wrote it
_LISTENERS: dict[str, list[str]] = {}
_LOGGER: Any = None


def _process_logger() -> Any:
    """The process's one FMI logger (made once, never freed)."""
    global _LOGGER
    if _LOGGER is None:
        from fmpy.fmi2 import fmi2CallbackLoggerTYPE

        def logger(environment, instance, status, category, message):
            name = instance.decode(errors="replace") if instance else "?"
            text = message.decode(errors="replace") if message else ""
            _LISTENERS.get(name, []).append(text)
            print(f"FMU {name} [status {status}]: {text}", file=sys.stderr)
        _LOGGER = fmi2CallbackLoggerTYPE(logger)
    return _LOGGER


class FmuSolid(Component):
    """A Co-Simulation FMU behind the component contract."""

    name = "solid_fmu"
    parameter_schema = FMU_SCHEMA
    parameter_help = FMU_HELP

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = self.validated(parameters)
        if not prm["path"]:
            raise ComponentError(self.name, "parameter 'path' (the FMU file) is not set")
        path = Path(prm["path"])
        if not path.is_file():
            raise ComponentError(self.name, f"FMU '{path}' does not exist")
        if not zipfile.is_zipfile(path):
            raise ComponentError(self.name, f"FMU '{path}' is not a zip archive (corrupt or truncated)")
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        try:
            md = read_model_description(str(path))
        except Exception as exc:  # fmpy raises several types for a bad model description
            raise ComponentError(self.name, f"FMU '{path}' has no valid modelDescription.xml: {exc}") from None
        if md.fmiVersion != "2.0" or md.coSimulation is None:
            raise ComponentError(self.name, f"FMU '{path}' is FMI {md.fmiVersion} "
                                            f"{'without' if md.coSimulation is None else 'with'} Co-Simulation; "
                                            "an FMI 2.0 Co-Simulation FMU is needed")
        self.stateful = prm["stateful"]
        self.stateless = not self.stateful      # a history FMU repeats its steps instead (interface.json)
        self.path = path
        self.can_serialize = bool(md.coSimulation.canSerializeFMUstate)
        if self.stateful and not md.coSimulation.canGetAndSetFMUstate:
            raise ComponentError(self.name, f"FMU '{path}' cannot get and set its state (stateful = true)")
        self.inputs = self._group(md, "input")
        self.outputs = self._group(md, "output")
        self.locals = self._group(md, "local")
        if not self.inputs or not self.outputs:
            raise ComponentError(self.name, f"FMU '{path}' has no array-named inputs or outputs "
                                            "(expected scalar names like 'force[1].x' or 'pressure[1]')")
        self.unzipped = str(unpack_directory())
        atexit.register(shutil.rmtree, self.unzipped, ignore_errors=True)
        try:
            extract(str(path), self.unzipped)
        except Exception as exc:
            shutil.rmtree(self.unzipped, ignore_errors=True)
            raise ComponentError(self.name, f"FMU '{path}' cannot be extracted: {exc}") from None
        binary = Path(self.unzipped) / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
        if not binary.is_file():
            shutil.rmtree(self.unzipped, ignore_errors=True)
            raise ComponentError(self.name, f"FMU '{path}' has no linux64 binary ({binary.name})")
        self.messages: list[str] = []
        try:
            self.slave = FMU2Slave(guid=md.guid, unzipDirectory=self.unzipped,
                                   modelIdentifier=md.coSimulation.modelIdentifier, instanceName=self.name)
            self.slave.instantiate(callbacks=self._callbacks())
        except Exception as exc:
            shutil.rmtree(self.unzipped, ignore_errors=True)
            raise ComponentError(self.name, f"FMU '{path}' failed to instantiate ({exc}): "
                                            f"{'; '.join(self.messages) or 'the FMU logged nothing'}") from None
        self._bind_raw()
        self._read_interface(Path(self.unzipped) / "resources")

    def _read_interface(self, resources: Path) -> None:
        """Meshes and components per node of the variables, from resources/interface.json if present."""
        self.placement = {name: ("", 1) for name in [*self.inputs, *self.outputs, *self.locals]}
        self.mesh_nodes: dict[str, np.ndarray] = {}
        described = resources / "interface.json"
        self._window: tuple[float, Any] | None = None     # a history FMU: the window in flight and its start state
        if described.is_file():
            interface = json.loads(described.read_text())
            self.history_windows = int(interface.get("history_windows", 0))
            if self.history_windows:
                self.repeats_steps = True
                self._bind_take_over(str(interface.get("take_over", "")))
            for v in interface["variables"]:
                if v["name"] in self.placement:
                    self.placement[v["name"]] = (v["mesh"], int(v["components"]))
            self.mesh_nodes = {k: np.array(v, dtype=np.float64) for k, v in interface["meshes"].items()}

    def meshes(self) -> dict[str, np.ndarray]:
        return self.mesh_nodes

    def _bind_take_over(self, symbol: str) -> None:
        function = getattr(self.slave.dll, symbol, None) if symbol else None
        if function is None:
            raise ComponentError(self.name, f"FMU '{self.path}' declares a history but no take-over function "
                                            f"('{symbol}' is not in its binary)")
        function.restype = ctypes.c_int
        function.argtypes = [ctypes.c_void_p, ctypes.c_int32, ctypes.c_void_p, ctypes.c_void_p]
        self._take_over = function

    def take_over(self, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, np.ndarray]) -> None:
        """The FMU's history from a full-order run's converged windows (rows oldest first)."""
        if not self.history_windows:
            return super().take_over(inputs, outputs)     # refused: this FMU keeps no history
        (input_name,), (output_name,) = list(self.inputs), list(self.outputs)
        forces, displacements = inputs.get(input_name), outputs.get(output_name)
        if forces is None or displacements is None or len(forces) != len(displacements):
            raise ComponentError(self.name, f"take_over needs as many rows of '{input_name}' as of '{output_name}'")
        n = len(forces)
        forces = np.ascontiguousarray(forces.reshape(n, -1), dtype=np.float64)
        displacements = np.ascontiguousarray(displacements.reshape(n, -1), dtype=np.float64)
        if not self._take_over(self.slave.component, n, forces.ctypes.data, displacements.ctypes.data):
            raise ComponentError(self.name, "the FMU refused the history it was handed")
        self._release_window()

    def _release_window(self) -> None:
        if self._window is not None:
            self.slave.freeFMUState(self._window[1])
            self._window = None

    def _roll_back(self, t: float) -> None:
        """A history FMU: keep the state a window starts from at its first call, go back to it at every later one."""
        if self._window is not None and abs(t - self._window[0]) <= 1e-9 * max(1.0, abs(t)):
            self.slave.setFMUState(self._window[1])
            return
        self._release_window()
        self._window = (t, self.slave.getFMUState())

    def _callbacks(self):
        """FMI callbacks whose logger keeps the FMU's messages (and writes them to the log)."""
        from fmpy import calloc, free
        from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions
        _LISTENERS[self.name] = self.messages      # made before the instance, which may log as it starts
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = _process_logger()
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            from fmpy.logging import addLoggerProxy
            addLoggerProxy(ctypes.byref(callbacks))  # formats the FMU's printf-style arguments
        except Exception:  # without the proxy, messages arrive unformatted
            pass
        self._callback_struct = callbacks  # must outlive the instance
        return callbacks

    @staticmethod
    def _group(md, causality: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Array name -> (value references in node-major order, values buffer)."""
        found: dict[str, list[tuple[int, int, int]]] = {}
        for v in md.modelVariables:
            match = NAME.match(v.name)
            if v.causality == causality and v.type == "Real" and match:
                axis = "xyz".index(match["axis"]) if match["axis"] else 0
                found.setdefault(match["name"], []).append((int(match["node"]), axis, v.valueReference))
        groups = {}
        for name, entries in found.items():
            entries.sort()
            refs = np.array([vr for _, _, vr in entries], dtype=np.uint32)
            groups[name] = (refs, np.zeros(len(refs)))
        return groups

    def _bind_raw(self) -> None:
        from fmpy.fmi2 import fmi2Component, fmi2Real, fmi2ValueReference
        dll = self.slave.dll
        pointer_vr, pointer_real = ctypes.POINTER(fmi2ValueReference), ctypes.POINTER(fmi2Real)
        self._set = dll.fmi2SetReal
        self._get = dll.fmi2GetReal
        self._do_step = dll.fmi2DoStep
        for function in (self._set, self._get):
            function.argtypes = [fmi2Component, pointer_vr, ctypes.c_size_t, pointer_real]
            function.restype = ctypes.c_int
        self._do_step.argtypes = [fmi2Component, fmi2Real, fmi2Real, ctypes.c_int]
        self._do_step.restype = ctypes.c_int
        self._pointers = {name: (refs.ctypes.data_as(pointer_vr), ctypes.c_size_t(len(refs)),
                                 values.ctypes.data_as(pointer_real))
                          for name, (refs, values) in {**self.inputs, **self.outputs, **self.locals}.items()}

    def _check(self, status: int, call: str) -> None:
        if status > WARNING:
            last = self.messages[-1] if self.messages else "no message"
            raise ComponentError(self.name, f"{call} returned status {status}: {last}")

    # --- contract -----------------------------------------------------------
    def variables(self) -> list[Variable]:
        return [Variable(n, causality, len(r), mesh=self.placement[n][0], components=self.placement[n][1])
                for causality, group in (("input", self.inputs), ("output", self.outputs), ("local", self.locals))
                for n, (r, _) in group.items()]

    def enter_initialization_mode(self, start: float, stop: float) -> None:
        self.slave.setupExperiment(startTime=start)
        self.slave.enterInitializationMode()

    def exit_initialization_mode(self) -> None:
        self.slave.exitInitializationMode()

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        if not hasattr(self, "_input_shapes"):   # the declared inputs do not change after instantiate
            self._input_shapes = {v.name: v.shape for v in self.variables() if v.causality == "input"}
        check_inputs(self, values, self._input_shapes)
        for name, value in values.items():
            np.copyto(self.inputs[name][1], np.ravel(value))
            refs, count, data = self._pointers[name]
            self._check(self._set(self.slave.component, refs, count, data), "fmi2SetReal")

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        out = {}
        for name in names:
            refs, count, data = self._pointers[name]
            self._check(self._get(self.slave.component, refs, count, data), "fmi2GetReal")
            components = self.placement[name][1]
            values = (self.outputs.get(name) or self.locals.get(name) or self.inputs[name])[1]
            out[name] = (values if components == 1 else values.reshape(-1, components)).copy()
        return out

    def do_step(self, t: float, dt: float) -> None:
        self._check(self._do_step(self.slave.component, t, dt, 1), "fmi2DoStep")

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The hot path: set, step, get, with the names it returns worked out once."""
        if not hasattr(self, "_returned"):
            self._returned = self.output_names() + self.local_names()
        if self.history_windows:
            self._roll_back(t)
        self.set_values(inputs)
        self.do_step(t, dt)
        return self.get_values(self._returned)

    @property
    def can_get_and_set_state(self) -> bool:
        return bool(getattr(self, "stateful", False))

    def save_state(self) -> Any:
        return self.slave.getFMUState()

    def restore_state(self, state: Any) -> None:
        self.slave.setFMUState(state)

    @property
    def can_checkpoint(self) -> bool:
        return bool(getattr(self, "can_serialize", False))

    def checkpoint(self) -> Any:
        """The FMU's own serialised state (``fmi2SerializeFMUstate``) and its time."""
        if not self.can_serialize:
            raise ComponentError(self.name, f"FMU '{self.path}' cannot serialise its state (canSerializeFMUstate is "
                                            "false): a run with it cannot be checkpointed")
        state = self.slave.getFMUState()
        try:
            serialized = self.slave.serializeFMUstate(state)
        finally:
            self.slave.freeFMUState(state)
        return {"fmu_state": np.frombuffer(bytes(serialized), dtype=np.uint8).copy()}

    def restore_checkpoint(self, state: Any) -> None:
        self._release_window()
        if not self.can_serialize:
            raise ComponentError(self.name, f"FMU '{self.path}' cannot serialise its state (canSerializeFMUstate is "
                                            "false)")
        restored = self.slave.deSerializeFMUstate(state["fmu_state"].tobytes())
        try:
            self.slave.setFMUState(restored)
        finally:
            self.slave.freeFMUState(restored)

    def terminate(self) -> dict[str, np.ndarray]:
        self._release_window()
        self.slave.terminate()
        self.slave.freeInstance()
        shutil.rmtree(self.unzipped, ignore_errors=True)
        return {}
