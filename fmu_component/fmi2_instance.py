"""An FMI 2.0 Co-Simulation FMU's instance as ``FmuComponent`` drives it (fmpy's ``FMU2Slave``).

Scalar variables named ``name[node]`` or ``name[node].x|y|z`` are gathered into the array variables ``name``
(node-major). The hot path calls the FMU's raw ``fmi2SetReal``/``fmi2DoStep``/``fmi2GetReal`` with preallocated
ctypes arrays.
"""

from __future__ import annotations

import ctypes
import re
import sys
from typing import Any

import numpy as np

from fmu_component.instance import FmiInstance, FmuVariable

NAME = re.compile(r"^(?P<name>[A-Za-z_]\w*)\[(?P<node>\d+)\](?:\.(?P<axis>[xyz]))?$")

# fmpy's logger proxy keeps the last logger it was given in a global of its native library, for every FMU of the
# process: the logger is one function that lives as long as the process, and hands each message to the messages
# of the instance that wrote it
_LISTENERS: dict[str, list[str]] = {}
_LOGGER: Any = None


def _process_logger() -> Any:
    """The process's one FMI 2.0 logger (made once, never freed)."""
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


class Fmi2Instance(FmiInstance):
    """FMI 2.0: scalar variables named by node, gathered into arrays."""

    platform = "linux64"

    def __init__(self, md, name: str):
        super().__init__(md, name)
        self.can_get_and_set_state = bool(md.coSimulation.canGetAndSetFMUstate)
        self.can_serialize = bool(md.coSimulation.canSerializeFMUstate)
        found: dict[tuple[str, str], list[tuple[int, int, int]]] = {}
        for v in md.modelVariables:
            if v.causality not in ("input", "output", "local"):
                continue
            if v.type != "Real":
                if v.causality != "local":
                    self.skipped[v.name] = (f"{v.causality} '{v.name}' is {v.type}; only Real (Float64) variables "
                                            "can be coupled")
                continue
            match = NAME.match(v.name)
            if match:          # node-major arrays: name[node] or name[node].x
                axis = "xyz".index(match["axis"]) if match["axis"] else 0
                found.setdefault((match["name"], v.causality), []).append((int(match["node"]), axis,
                                                                          v.valueReference))
            elif "[" not in v.name:      # a scalar: an array of one value
                found.setdefault((v.name, v.causality), []).append((1, 0, v.valueReference))
            elif v.causality != "local":
                self.skipped[v.name] = (f"{v.causality} '{v.name}' is an element of an array not named by node "
                                        "(name[i] or name[i].x)")
        self._buffers: dict[str, tuple[Any, ctypes.c_size_t, Any, np.ndarray]] = {}
        self._refs: dict[str, np.ndarray] = {}
        for (variable, causality), entries in found.items():
            entries.sort()
            self.variables[variable] = FmuVariable(causality, len(entries))    # values per node: interface.json
            self._refs[variable] = np.array([vr for _, _, vr in entries], dtype=np.uint32)

    def instantiate(self, unzipped: str) -> None:
        from fmpy.fmi2 import FMU2Slave
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=unzipped,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=self.name)
        self.slave.instantiate(callbacks=self._callbacks())
        self._bind_raw()

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

    def _bind_raw(self) -> None:
        from fmpy.fmi2 import fmi2Component, fmi2Real, fmi2ValueReference
        dll = self.slave.dll
        pointer_vr, pointer_real = ctypes.POINTER(fmi2ValueReference), ctypes.POINTER(fmi2Real)
        self._set, self._get, self._do_step = dll.fmi2SetReal, dll.fmi2GetReal, dll.fmi2DoStep
        for function in (self._set, self._get):
            function.argtypes = [fmi2Component, pointer_vr, ctypes.c_size_t, pointer_real]
            function.restype = ctypes.c_int
        self._do_step.argtypes = [fmi2Component, fmi2Real, fmi2Real, ctypes.c_int]
        self._do_step.restype = ctypes.c_int
        for name, refs in self._refs.items():
            values = np.zeros(len(refs))
            self._buffers[name] = (refs.ctypes.data_as(pointer_vr), ctypes.c_size_t(len(refs)),
                                   values.ctypes.data_as(pointer_real), values)

    def value_references(self, name: str) -> list[int]:
        """The scalars of array variable ``name``, node-major."""
        return [int(vr) for vr in self._refs[name]]

    def set(self, name: str, values: np.ndarray) -> None:
        refs, count, data, buffer = self._buffers[name]
        np.copyto(buffer, values)
        self._check(self._set(self.slave.component, refs, count, data), "fmi2SetReal")

    def get(self, name: str) -> np.ndarray:
        refs, count, data, buffer = self._buffers[name]
        self._check(self._get(self.slave.component, refs, count, data), "fmi2GetReal")
        return buffer

    def do_step(self, t: float, dt: float) -> None:
        self._check(self._do_step(self.slave.component, t, dt, 1), "fmi2DoStep")

    def enter_initialization(self, start: float) -> None:
        self.slave.setupExperiment(startTime=start)
        self.slave.enterInitializationMode()

    def serialize(self, state: Any) -> bytes:
        return bytes(self.slave.serializeFMUstate(state))

    def deserialize(self, data: bytes) -> Any:
        return self.slave.deSerializeFMUstate(data)
