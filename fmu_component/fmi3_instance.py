"""An FMI 3.0 Co-Simulation FMU's instance as ``FmuComponent`` drives it (fmpy's ``FMU3Slave``).

Its ``Float64`` variables of causality input, output and local are the component's variables, each array whole
(its fixed ``Dimension``s; (nodes, components) when the last has 1 to 3). The hot path calls the FMU's raw
``fmi3SetFloat64``/``fmi3DoStep``/``fmi3GetFloat64`` with preallocated ctypes arrays.
"""

from __future__ import annotations

import ctypes
import math
import sys
from typing import Any

import numpy as np

from fmu_component.instance import FmiError, FmiInstance, FmuVariable

COUPLED = ("input", "output", "local")


class Fmi3Instance(FmiInstance):
    """FMI 3.0: array variables moved whole."""

    platform = "x86_64-linux"

    def __init__(self, md, name: str):
        super().__init__(md, name)
        self.can_get_and_set_state = bool(md.coSimulation.canGetAndSetFMUstate)   # fmpy names it as FMI 2.0 does
        self.can_serialize = bool(md.coSimulation.canSerializeFMUstate)
        self._refs: dict[str, int] = {}
        for v in md.modelVariables:
            if v.causality not in COUPLED:
                continue
            if v.type != "Float64":     # the FMU's own business unless the scene couples it (then refused)
                if v.causality != "local":
                    self.skipped[v.name] = f"{v.causality} '{v.name}' is {v.type}; only Float64 variables can be coupled"
                continue
            extents = []
            for dimension in v.dimensions:
                if dimension.start is None:
                    raise FmiError(f"{v.causality} '{v.name}' has a dimension set by a structural parameter; only "
                                   "fixed dimensions (Dimension start) are supported")
                extents.append(int(dimension.start))
            size = math.prod(extents) if extents else 1
            if size < 1:
                raise FmiError(f"{v.causality} '{v.name}' has dimensions {extents}: no values")
            components = extents[-1] if len(extents) >= 2 and 1 <= extents[-1] <= 3 else 1
            self.variables[v.name] = FmuVariable(v.causality, size, components)
            self._refs[v.name] = v.valueReference

    def instantiate(self, unzipped: str) -> None:
        from fmpy.fmi3 import FMU3Slave
        self.slave = FMU3Slave(guid=self.md.guid, unzipDirectory=unzipped,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=self.name)
        messages = self.messages

        def log(environment, status, category, message):
            text = message.decode(errors="replace") if isinstance(message, bytes) else str(message or "")
            messages.append(text)
            print(f"FMU {self.name} [status {status}]: {text}", file=sys.stderr)
        self.slave.instantiate(logMessage=log)
        self._bind_raw()

    def _bind_raw(self) -> None:
        dll = self.slave.dll
        vr_pointer, real_pointer = ctypes.POINTER(ctypes.c_uint32), ctypes.POINTER(ctypes.c_double)
        self._set, self._get, self._do_step = dll.fmi3SetFloat64, dll.fmi3GetFloat64, dll.fmi3DoStep
        for function in (self._set, self._get):
            function.argtypes = [ctypes.c_void_p, vr_pointer, ctypes.c_size_t, real_pointer, ctypes.c_size_t]
            function.restype = ctypes.c_int
        self._do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_bool,
                                  ctypes.POINTER(ctypes.c_bool), ctypes.POINTER(ctypes.c_bool),
                                  ctypes.POINTER(ctypes.c_bool), real_pointer]
        self._do_step.restype = ctypes.c_int
        self._step_out = (ctypes.c_bool(), ctypes.c_bool(), ctypes.c_bool(), ctypes.c_double())
        self._step_refs = tuple(ctypes.byref(x) for x in self._step_out)
        # per variable: its reference and values as pointers, their count, the values, the reference's array
        self._buffers: dict[str, tuple[Any, Any, ctypes.c_size_t, np.ndarray, np.ndarray]] = {}
        for name, vr in self._refs.items():
            ref, values = np.array([vr], dtype=np.uint32), np.zeros(self.variables[name].size)
            self._buffers[name] = (ref.ctypes.data_as(vr_pointer), values.ctypes.data_as(real_pointer),
                                   ctypes.c_size_t(values.size), values, ref)

    def set(self, name: str, values: np.ndarray) -> None:
        ref, data, count, buffer, _ = self._buffers[name]
        np.copyto(buffer, values)
        self._check(self._set(self.slave.component, ref, 1, data, count), "fmi3SetFloat64")

    def get(self, name: str) -> np.ndarray:
        ref, data, count, buffer, _ = self._buffers[name]
        self._check(self._get(self.slave.component, ref, 1, data, count), "fmi3GetFloat64")
        return buffer

    def do_step(self, t: float, dt: float) -> None:
        self._check(self._do_step(self.slave.component, t, dt, False, *self._step_refs), "fmi3DoStep")
        _, terminate, early, last = self._step_out
        if terminate.value or early.value:
            raise FmiError(f"fmi3DoStep from t = {t:g} {'asked to terminate' if terminate.value else 'returned early'}"
                           f" at t = {last.value:g}: {self.messages[-1] if self.messages else 'no message'}")

    def enter_initialization(self, start: float) -> None:
        self.slave.enterInitializationMode(startTime=start)

    def serialize(self, state: Any) -> bytes:
        return bytes(self.slave.serializeFMUState(state))

    def deserialize(self, data: bytes) -> Any:
        return self.slave.deserializeFMUState(data)
