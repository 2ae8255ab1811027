"""Any FMI 2.0 or FMI 3.0 Co-Simulation FMU as a component (loaded with fmpy), its version read from its model
description.

FMI 2.0's scalar variables named ``name[node]`` or ``name[node].x|y|z`` are gathered into the array variables
``name`` (node-major); FMI 3.0's ``Float64`` array variables are the component's variables as they are
(``fmi2_instance``, ``fmi3_instance``). The archive is checked before anything of it is used (``archive``).

How it repeats a window under implicit coupling (``state``):
- ``auto`` (default): stateless if the FMU's ``resources/interface.json`` says so (a quasi-static ROM from
  ``cosim export-fmu``), else rolled back to the window's start through the FMU state (get at a window's first
  call, set before each later one) if the FMU can get and set it, else it cannot repeat a window: implicit
  coupling refuses it, with the reason;
- ``rollback``: through the FMU state (an FMU that cannot is refused);
- ``stateless``: never rolled back (the user vouches that its outputs depend on its inputs alone).

An FMU whose ``interface.json`` declares ``history_windows`` (a ROM with memory, from ``cosim export-fmu`` of a
step-map model) is handed a full-order run's last windows at a switch through the function the file names
(``take_over``). Its ``local`` variables (probe points) are read as locals.
"""

from __future__ import annotations

import atexit
import ctypes
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import Component, Variable, check_inputs
from cosim.errors import ComponentError
from cosim.schema import Choice, FilePath
from fmu_component.archive import (
    UNPACK_ROOT,
    FmuArchiveError,
    check_archive,
    read_description,
    unpack,
    unpack_directory,
)
from fmu_component.fmi2_instance import Fmi2Instance
from fmu_component.fmi3_instance import Fmi3Instance
from fmu_component.instance import FmiError, FmiInstance
from fmu_component.interface_file import read_interface

__all__ = ["FmuComponent", "UNPACK_ROOT"]

STATES = ("auto", "rollback", "stateless")
FMU_SCHEMA = {"path": FilePath(), "state": Choice("auto", STATES)}
FMU_HELP = {"path": "any FMI 2.0 or FMI 3.0 Co-Simulation FMU (for example from `cosim export-fmu`)",
            "state": "how implicit coupling repeats a window: auto (the FMU's own declaration, else its state), "
                     "rollback (through the FMU state), stateless (never rolled back)"}
INSTANCES: dict[str, type[FmiInstance]] = {"2.0": Fmi2Instance, "3.0": Fmi3Instance}


class FmuComponent(Component):
    """A Co-Simulation FMU behind the component contract."""

    name = "solid_fmu"
    parameter_schema = FMU_SCHEMA
    parameter_help = FMU_HELP
    #: an FMU repeats a window by rolling back, unless ``instantiate`` finds it stateless or unable to (the coupler
    #: checks what the instance describes)
    repeats_steps = True

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = self.validated(parameters)
        if not prm["path"]:
            raise ComponentError(self.name, "parameter 'path' (the FMU file) is not set")
        path = self.path = Path(prm["path"])
        try:
            check_archive(path)
            md = read_description(path)
            self.fmu = INSTANCES[md.fmiVersion](md, self.name)
        except (FmuArchiveError, FmiError) as exc:
            raise ComponentError(self.name, f"FMU '{path}' {exc}" if isinstance(exc, FmuArchiveError)
                                 else f"FMU '{path}': {exc}") from None
        self.fmi_version = md.fmiVersion
        self.can_serialize = self.fmu.can_serialize
        if prm["state"] == "rollback" and not self.fmu.can_get_and_set_state:
            raise ComponentError(self.name, f"FMU '{path}' cannot get and set its state (canGetAndSetFMUState is "
                                            "false), so it cannot be rolled back (state = \"rollback\")")
        kinds = {causality: {n: v for n, v in self.fmu.variables.items() if v.causality == causality}
                 for causality in ("input", "output", "local")}
        self.inputs, self.outputs, self.locals = kinds["input"], kinds["output"], kinds["local"]
        self.variable_notes = dict(self.fmu.skipped)
        if not self.inputs and not self.outputs:       # outputs alone drive a solver; inputs alone take its data
            expected = ("Real inputs or outputs, scalars or arrays named 'force[1].x' or 'pressure[1]'"
                        if self.fmi_version == "2.0" else "Float64 inputs or outputs")
            skipped = "; ".join(self.fmu.skipped.values())
            raise ComponentError(self.name, f"FMU '{path}' has no array inputs or outputs (expected {expected})"
                                 + (f": {skipped}" if skipped else ""))
        self.unzipped = str(unpack_directory())
        atexit.register(shutil.rmtree, self.unzipped, ignore_errors=True)
        try:
            self._start(path, md.coSimulation.modelIdentifier)
        except ComponentError:
            shutil.rmtree(self.unzipped, ignore_errors=True)
            raise
        self._read_interface(Path(self.unzipped) / "resources")
        self._choose_state(prm["state"])

    def _start(self, path: Path, identifier: str) -> None:
        """The checked archive unpacked, its binary found, the FMU instantiated."""
        try:
            unpack(path, Path(self.unzipped))
        except Exception as exc:
            raise ComponentError(self.name, f"FMU '{path}' cannot be extracted: {exc}") from None
        binary = Path(self.unzipped) / "binaries" / self.fmu.platform / f"{identifier}.so"
        if not binary.is_file():
            raise ComponentError(self.name, f"FMU '{path}' has no {self.fmu.platform} binary ({binary.name})")
        self.messages = self.fmu.messages
        try:
            self.fmu.instantiate(self.unzipped)
        except Exception as exc:
            raise ComponentError(self.name, f"FMU '{path}' failed to instantiate ({exc}): "
                                            f"{'; '.join(self.messages) or 'the FMU logged nothing'}") from None

    def _read_interface(self, resources: Path) -> None:
        """Meshes and components per node of the variables, from resources/interface.json if present."""
        self.placement = {name: ("", v.components) for name, v in self.fmu.variables.items()}
        self.mesh_nodes: dict[str, np.ndarray] = {}
        self.declared_stateless = False
        self.history_windows = 0
        self._window: tuple[float, Any] | None = None     # the window in flight and the state it starts from
        described = resources / "interface.json"
        if described.is_file():
            try:
                interface = read_interface(described.read_text())
            except (ValueError, UnicodeDecodeError) as exc:
                raise ComponentError(self.name, f"FMU '{self.path}': resources/interface.json: {exc}") from None
            self.history_windows, self.declared_stateless = interface.history_windows, interface.stateless
            take_over = interface.take_over
            self.placement.update({name: where for name, where in interface.placement.items()
                                   if name in self.placement})
            self.mesh_nodes = interface.meshes
            if self.history_windows:
                self._bind_take_over(take_over)

    def _choose_state(self, state: str) -> None:
        """Stateless, rolled back through the FMU state (``repeats_steps``), or neither (with the reason)."""
        self.repeats_steps = False
        if state == "stateless" or (state == "auto" and self.declared_stateless and not self.history_windows):
            self.stateless = True
        elif state == "rollback" or self.history_windows or self.fmu.can_get_and_set_state:
            if not self.fmu.can_get_and_set_state:
                raise ComponentError(self.name, f"FMU '{self.path}' keeps a history but cannot get and set its state")
            self.repeats_steps = True
        else:
            self.state_note = (f"FMU '{self.path}' cannot get and set its state (canGetAndSetFMUState is false), so "
                               "it cannot be rolled back to a window's start for implicit coupling; set its "
                               "state = \"stateless\" if its outputs depend on its inputs alone, or couple it "
                               "explicitly")

    def meshes(self) -> dict[str, np.ndarray]:
        return self.mesh_nodes

    def _bind_take_over(self, symbol: str) -> None:
        function = getattr(self.fmu.dll, symbol, None) if symbol else None
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
        if not self._take_over(self.fmu.component, n, forces.ctypes.data, displacements.ctypes.data):
            raise ComponentError(self.name, "the FMU refused the history it was handed")
        self._release_window()

    def _release_window(self) -> None:
        if self._window is not None:
            self.fmu.free_state(self._window[1])
            self._window = None

    def _roll_back(self, t: float) -> None:
        """Keep the state a window starts from at its first call, go back to it at every later one."""
        if self._window is not None and abs(t - self._window[0]) <= 1e-9 * max(1.0, abs(t)):
            self.fmu.set_state(self._window[1])
            return
        self._release_window()
        self._window = (t, self.fmu.get_state())

    # --- contract -----------------------------------------------------------
    def variables(self) -> list[Variable]:
        return [Variable(n, v.causality, v.size, mesh=self.placement[n][0], components=self.placement[n][1])
                for group in (self.inputs, self.outputs, self.locals) for n, v in group.items()]

    def enter_initialization_mode(self, start: float, stop: float) -> None:
        self.fmu.enter_initialization(start)

    def exit_initialization_mode(self) -> None:
        self.fmu.exit_initialization()

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        if not hasattr(self, "_input_shapes"):   # the declared inputs do not change after instantiate
            self._input_shapes = {v.name: v.shape for v in self.variables() if v.causality == "input"}
        check_inputs(self, values, self._input_shapes)
        try:
            for name, value in values.items():
                self.fmu.set(name, np.ravel(value))
        except FmiError as exc:
            raise ComponentError(self.name, str(exc)) from None

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        out = {}
        try:
            for name in names:
                values, components = self.fmu.get(name), self.placement[name][1]
                out[name] = (values if components == 1 else values.reshape(-1, components)).copy()
        except FmiError as exc:
            raise ComponentError(self.name, str(exc)) from None
        return out

    def do_step(self, t: float, dt: float) -> None:
        try:
            self.fmu.do_step(t, dt)
        except FmiError as exc:
            raise ComponentError(self.name, str(exc)) from None
        self._clock = t + dt

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The hot path: set, step, get, with the names it returns worked out once."""
        if not hasattr(self, "_returned"):
            self._returned = self.output_names() + self.local_names()
        if self.repeats_steps:        # rolled back to the window's start at each later call
            self._roll_back(t)
        elif self.stateless:
            self._start_at(t)
        self.set_values(inputs)
        self.do_step(t, dt)
        return self.get_values(self._returned)

    def _start_at(self, t: float) -> None:
        """A stateless FMU asked for a window again: FMI's steps only go forward, so the instance is reset and
        initialised at the window's start (its outputs depend on its inputs alone: nothing is to be replayed)."""
        clock = getattr(self, "_clock", None)
        if clock is not None and t < clock - 1e-9 * max(1.0, abs(t)):
            try:
                self.fmu.restart(t)
            except FmiError as exc:
                raise ComponentError(self.name, f"could not start again at t = {t:g} to repeat a window: {exc}") \
                    from None

    @property
    def can_checkpoint(self) -> bool:
        return bool(getattr(self, "can_serialize", False))

    def checkpoint(self) -> Any:
        """The FMU's own serialised state and its time."""
        if not self.can_serialize:
            raise ComponentError(self.name, f"FMU '{self.path}' cannot serialise its state (canSerializeFMUstate is "
                                            "false): a run with it cannot be checkpointed")
        state = self.fmu.get_state()
        try:
            serialized = self.fmu.serialize(state)
        finally:
            self.fmu.free_state(state)
        return {"fmu_state": np.frombuffer(serialized, dtype=np.uint8).copy()}

    def restore_checkpoint(self, state: Any) -> None:
        self._release_window()
        if not self.can_serialize:
            raise ComponentError(self.name, f"FMU '{self.path}' cannot serialise its state (canSerializeFMUstate is "
                                            "false)")
        try:
            restored = self.fmu.deserialize(state["fmu_state"].tobytes())
        except Exception as exc:
            raise ComponentError(self.name, f"FMU '{self.path}' refused the serialised state of the checkpoint "
                                            f"({exc}): {self.messages[-1] if self.messages else 'no message'}") from None
        try:
            self.fmu.set_state(restored)
        finally:
            self.fmu.free_state(restored)

    def terminate(self) -> dict[str, np.ndarray]:
        self._release_window()
        self.fmu.terminate()
        shutil.rmtree(self.unzipped, ignore_errors=True)
        return {}
