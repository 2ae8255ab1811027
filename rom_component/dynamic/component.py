"""A step-map ROM (``rom_component.dynamic.model``) behind the component contract: a structure with inertia.

The component keeps its reduced history: the converged reduced displacements and forces of the last
windows. A window's calls all start from that history (``repeats_steps``: a call with the same ``t``
solves the window again from its start, one with a later ``t`` closes the window, whose last call was the
converged one, and moves the history on). Taking over from the full-order structure at a switch time,
it is handed the full-order run's last converged windows (``take_over``) and projects them on its bases.
Its outputs: the interface displacement, and the probes the full-order structure recorded (Mok's
``point_a`` and ``point_b``), decoded from the same reduced displacement; the whole field is rebuilt
once, at ``terminate``. Trust as for the static ROM: the window's force against the training range.
A fallback to the full-order structure cannot be offered: its state would be the switch time's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import MESH_PREFIX, Component, Variable, check_inputs
from cosim.errors import ComponentError, CosimError
from cosim.schema import Choice, FilePath, Value
from rom_component.dynamic.compiled import CompiledStepMap
from rom_component.dynamic.online import OnlineStepMap
from rom_component.envelope import trust
from rom_component.model_file import load_arrays

ARITHMETIC = ("reproducible", "compiled", "fast")
SCHEMA = {"model": FilePath(), "arithmetic": Choice("reproducible", ARITHMETIC),
          "on_out_of_range": Choice("warn", ("warn", "fail")), "range_margin": Value(0.05, low=0.0)}
HELP = {
    "model": "the step-map model file written by `cosim train` with dynamics.memory = true (.npz)",
    "arithmetic": "'reproducible': NumPy in the C code's order, bit-identical to the exported FMU; 'compiled': the "
                  "FMU's own C code in-process (the same results, faster; needs a C compiler); 'fast': BLAS products",
    "on_out_of_range": "a call outside the training range: 'warn' or 'fail' (a structure with inertia cannot fall "
                       "back to its full-order solver, whose state would be the switch time's)",
    "range_margin": "how far beyond the training range (in range widths of each reduced force) a call is still in "
                    "range",
}
TRUST_LOCALS = ("rom_excess", "rom_distance", "rom_out_of_range")
FLOAT64 = np.dtype(np.float64)
CHECKPOINTED = ("_window_time", "_dt", "_times", "_reduced", "trust_values")


class StepMapRomSolid(Component):
    """A trained step-map ROM (``model``: path of the .npz) in a dynamic structure's place."""

    name = "structure_rom"
    parameter_schema = SCHEMA
    parameter_help = HELP
    repeats_steps = True

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = self.validated(parameters)
        if not prm["model"]:
            raise ComponentError(self.name, "parameter 'model' (path of the trained .npz) is not set")
        try:
            arrays, meta = load_arrays(prm["model"])
        except CosimError as exc:
            raise ComponentError(self.name, str(exc)) from None
        if meta.get("kind") != "step-map":
            raise ComponentError(self.name, f"model '{prm['model']}' is a {meta.get('kind', 'static')} ROM, not a "
                                            "step map (train it with dynamics.memory = true)")
        self.on_out_of_range, self.range_margin = prm["on_out_of_range"], prm["range_margin"]
        self.meta, self.arrays = meta, arrays
        try:
            self.rom: OnlineStepMap | CompiledStepMap = (
                CompiledStepMap(arrays, meta) if prm["arithmetic"] == "compiled"
                else OnlineStepMap(arrays, meta, prm["arithmetic"]))
        except CosimError as exc:            # no compiler for the compiled arithmetic
            raise ComponentError(self.name, str(exc)) from None
        self.envelope = {k: v for k, v in arrays.items() if k.startswith("envelope_")}
        self.input_name, self.output_name = meta["input_variable"], meta["output_variable"]
        declared = {v["name"]: v for v in meta.get("variables", [])}
        self.placement = {name: (declared.get(name, {}).get("mesh", ""), declared.get(name, {}).get("components", 1))
                          for name in (self.input_name, self.output_name)}
        self.mesh_nodes = {k[len(MESH_PREFIX):]: v for k, v in arrays.items() if k.startswith(MESH_PREFIX)}
        self.probes = list(meta.get("probes", []))
        self.history_windows = int(meta["history"])
        self.trained_dt = float(meta["dt"])
        self.n_in, self.n_out = arrays["E"].shape[1], arrays["A"].shape[0]
        self.input_shape = self._shape(self.input_name, self.n_in)
        self.output_shape = self._shape(self.output_name, self.n_out)
        self._window_time: float | None = None
        self._dt = self.trained_dt
        self._times: list[float] = []
        self._reduced: list[np.ndarray] = []
        self.trust_values = np.zeros(3)
        self._served: dict[str, np.ndarray] | None = None
        if isinstance(self.rom, CompiledStepMap):     # one C call per served step, on fixed buffers
            self.rom.bind(self.envelope)
            outputs, n_out = self.rom.outputs, self.n_out
            self._served = {self.output_name: outputs[:n_out].reshape(self.output_shape),
                            **{name: outputs[n_out + 2 * i:n_out + 2 * i + 2] for i, name in enumerate(self.probes)},
                            **{name: self.rom.trust[i:i + 1] for i, name in enumerate(TRUST_LOCALS)}}

    def _shape(self, name: str, size: int) -> tuple[int, ...]:
        return Variable(name, "input", size, components=self.placement[name][1]).shape

    def variables(self) -> list[Variable]:
        (in_mesh, in_k), (out_mesh, out_k) = self.placement[self.input_name], self.placement[self.output_name]
        return [Variable(self.input_name, "input", self.n_in, mesh=in_mesh, components=in_k),
                Variable(self.output_name, "output", self.n_out, mesh=out_mesh, components=out_k),
                *[Variable(name, "local", 2, "m") for name in self.probes],
                *[Variable(name, "local", 1) for name in TRUST_LOCALS]]

    def meshes(self) -> dict[str, np.ndarray]:
        return self.mesh_nodes

    # --- the window's calls ------------------------------------------------------------------------
    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        force = inputs.get(self.input_name)
        if len(inputs) != 1 or type(force) is not np.ndarray or force.shape != self.input_shape:
            check_inputs(self, inputs, {self.input_name: self.input_shape})
            raise ComponentError(self.name, f"step needs the input '{self.input_name}' at every call")
        self._enter_window(t, dt)
        rom = self.rom
        rom.evaluate(force.reshape(-1))
        excess, distance = trust(rom.x, self.envelope)
        out = excess > self.range_margin
        self.trust_values = np.array((excess, distance, 1.0 if out else 0.0))
        if out:
            self._out_of_range(t, excess)
        return self._outputs()

    def _enter_window(self, t: float, dt: float) -> None:
        """A call of window ``t``: a later window than the last one's closes it."""
        if self._window_time is not None and abs(t - self._window_time) <= 1e-9 * max(1.0, abs(t)):
            return
        if abs(dt - self.trained_dt) > 1e-9 * self.trained_dt:
            raise ComponentError(self.name, f"window size {dt:g} s at t = {t:g} s: the step map was trained on "
                                            f"windows of {self.trained_dt:g} s")
        if self._window_time is not None and t < self._window_time:
            raise ComponentError(self.name, f"cannot step back from the window starting at {self._window_time:g} s "
                                            f"to one starting at {t:g} s")
        self._close_window()
        self._window_time, self._dt = t, dt

    def served_step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``step``; with the compiled arithmetic and the one input of its shape, a single C call (the window's call
        and its trust) on fixed buffers whose views are returned (sent before the next call rewrites them)."""
        served, force = self._served, inputs.get(self.input_name)
        if served is None or len(inputs) != 1 or type(force) is not np.ndarray or force.shape != self.input_shape \
                or force.dtype is not FLOAT64:
            return self.step(t, dt, inputs)
        self._enter_window(t, dt)
        assert isinstance(self.rom, CompiledStepMap)
        if self.rom.serve(self.range_margin, force.tobytes()):
            self.trust_values = self.rom.trust
            self._out_of_range(t, float(self.rom.trust[0]))
        self.trust_values = self.rom.trust
        return dict(served)

    def _out_of_range(self, t: float, excess: float) -> None:
        """A call beyond the training range: an error naming how far, or a warning the coupler folds into one line
        per window (the excess of every call is recorded as the local ``rom_excess``)."""
        message = (f"input outside the training range (a reduced force mode beyond the training data by more than "
                   f"{self.range_margin:g} of its range)")
        if self.on_out_of_range == "fail":
            raise ComponentError(self.name, f"{message} at t = {t:g} s: {excess:.3g} of its range")
        self.warn(message)

    def _outputs(self) -> dict[str, np.ndarray]:
        rom, trust_values = self.rom, self.trust_values
        probes = rom.probes
        return {self.output_name: rom.u.reshape(self.output_shape).copy(),
                **{name: probes[2 * i:2 * i + 2].copy() for i, name in enumerate(self.probes)},
                **{name: trust_values[i:i + 1].copy() for i, name in enumerate(TRUST_LOCALS)}}

    def _close_window(self) -> None:
        """The last call of the window in flight was its converged one: it joins the history."""
        if self._window_time is None:
            return
        self.rom.commit()
        self._times.append(self._window_time + self._dt)
        self._reduced.append(self.rom.z.copy())

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        raise ComponentError(self.name, "takes its inputs with step (it repeats a window from its start)")

    def do_step(self, t: float, dt: float) -> None:
        raise ComponentError(self.name, "steps with step (it repeats a window from its start)")

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = self._outputs()
        return {name: known[name] for name in names}

    # --- history --------------------------------------------------------------------------------
    def take_over(self, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, np.ndarray]) -> None:
        """Start from the full-order structure's last converged windows (rows oldest first): their forces and
        interface displacements projected on the ROM's bases. Fewer windows than the history: rest before them."""
        forces, displacements = inputs.get(self.input_name), outputs.get(self.output_name)
        if forces is None or displacements is None or len(forces) != len(displacements):
            raise ComponentError(self.name, f"take_over needs as many rows of '{self.input_name}' as of "
                                            f"'{self.output_name}'")
        n = len(forces)
        self.rom.take_over(forces.reshape(n, -1), displacements.reshape(n, -1))
        self._window_time = None

    def checkpoint(self) -> Any:
        """The history (reduced displacements and forces), the window in flight and the converged record."""
        zh, xh = self.rom.history()
        state = {name: getattr(self, name) for name in CHECKPOINTED}
        return {**state, "trust_values": np.array(self.trust_values), "z_history": zh, "x_history": xh,
                "z": np.array(self.rom.z), "x": np.array(self.rom.x)}

    def restore_checkpoint(self, state: Any) -> None:
        known = {*CHECKPOINTED, "z_history", "x_history", "z", "x"}
        for name in state:
            if name not in known:
                raise ComponentError(self.name, f"checkpoint holds '{name}', which this ROM component does not keep")
        for name in CHECKPOINTED:
            setattr(self, name, state[name])
        self._reduced = [np.asarray(z) for z in self._reduced]
        zh, xh = np.asarray(state["z_history"]), np.asarray(state["x_history"])
        if self._window_time is not None:     # the last window's converged call joins the history, as at its close
            zh = np.vstack([state["z"], zh[:-1]])
            xh = np.vstack([state["x"], xh[:-1]])
            self._times.append(self._window_time + self._dt)
            self._reduced.append(np.array(state["z"]))
            self._window_time = None
        self.rom.set_history(zh, xh)

    def terminate(self) -> dict[str, np.ndarray]:
        """Reduced displacements of every converged window and the full field rebuilt from them."""
        self._close_window()
        self._window_time = None
        self.rom.close()
        if not self._reduced:
            return {}
        reduced = np.stack(self._reduced)
        field = reduced @ self.arrays["Phi_u"].T + self.arrays["u_mean"]
        return {"time": np.array(self._times), "reduced": reduced, "full_field": field}
