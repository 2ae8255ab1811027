"""The ROM behind the component contract, in the solid's place.

Inputs and outputs carry the names the model was trained on (for the tube:
``pressure`` in, ``section`` out). Per call only the interface path runs; the reduced
displacements of each window's last call (the converged one) are kept, and the full
displacement field is rebuilt once, at ``terminate``, for the results file.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import MESH_PREFIX, Component, Variable, check_inputs
from cosim.errors import ComponentError, CosimError
from cosim.schema import Choice, FilePath, Value
from rom_component.static.load import load_rom

ARITHMETIC = ("reproducible", "compiled", "fast")   # compiled: the FMU's C code in-process, same results
ROM_SCHEMA = {"model": FilePath(), "arithmetic": Choice("reproducible", ARITHMETIC),
              "on_out_of_range": Choice("warn", ("warn", "fail", "fallback")),
              "range_margin": Value(0.05, low=0.0),
              "transient_calls": Value(0, low=0), "transient_margin": Value(0.0, low=0.0),
              "keep_warm": Value(0.0, low=0.0)}
ROM_HELP = {
    "model": "the model file written by `cosim train` (.npz)",
    "arithmetic": "'reproducible': bit-identical to the exported FMU; 'compiled': the FMU's own C code in-process "
                  "(the same results, faster; needs a C compiler); 'fast': BLAS products (not bit-identical)",
    "on_out_of_range": "a call outside the training range: 'warn', 'fail', or 'fallback' (the full-order solid, "
                       "kept running, takes the window)",
    "range_margin": "how far beyond the training range (in range widths of each reduced force) a call is still in "
                    "range",
    "transient_calls": "a window's first calls that are out of range only beyond transient_margin (the coupling's "
                       "first updates overshoot and come back)",
    "transient_margin": "the margin of those first calls",
    "keep_warm": "between calls, repeat the last one every keep_warm seconds (0: never) to keep the ROM's data in "
                 "the caches (the machine evicts them within milliseconds); changes no result",
}
TRUST_LOCALS = ("rom_excess", "rom_distance", "rom_out_of_range")
# what a checkpoint carries over: everything a call changes that a later call or terminate reads
CHECKPOINTED = ("force", "displacement", "trust_values", "_last_reduced", "_calls_in_window", "_window_time", "_times",
                "_reduced", "_dt", "_margin", "keep_warm_calls", "keep_warm_seconds")
FLOAT64 = np.dtype(np.float64)


class RomSolid(Component):
    """A trained solid ROM (``model`` parameter: path of the .npz)."""

    name = "solid_rom"
    parameter_schema = ROM_SCHEMA
    stateless = True        # quasi-static: the displacement follows the force of the call
    parameter_help = ROM_HELP

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = self.validated(parameters)
        if not prm["model"]:
            raise ComponentError(self.name, "parameter 'model' (path of the trained .npz) is not set")
        try:
            self.rom = load_rom(prm["model"], prm["arithmetic"])
        except CosimError as exc:   # a bad model file, or no compiler for the compiled arithmetic
            raise ComponentError(self.name, str(exc)) from None
        self.on_out_of_range, self.range_margin = prm["on_out_of_range"], prm["range_margin"]
        self.transient_calls, self.transient_margin = prm["transient_calls"], prm["transient_margin"]
        if self.transient_calls and self.transient_margin < self.range_margin:
            raise ComponentError(self.name, f"'transient_margin' is {self.transient_margin:g}, below 'range_margin' "
                                            f"{self.range_margin:g}: the first calls would answer to a stricter limit")
        self._calls_in_window = 0
        self.trust_values = np.array([0.0, 0.0, 0.0])   # excess, distance, out of range (0 or 1)
        meta = self.rom.metadata
        self.input_name = meta.get("input_variable", "pressure")
        self.output_name = meta.get("output_variable", "section")
        declared = {v["name"]: v for v in meta.get("variables", [])}   # as the full-order solid declared them
        self.placement = {name: (declared.get(name, {}).get("mesh", ""), declared.get(name, {}).get("components", 1))
                          for name in (self.input_name, self.output_name)}
        self.mesh_nodes = {k[len(MESH_PREFIX):]: v for k, v in self.rom.arrays.items() if k.startswith(MESH_PREFIX)}
        self.input_shape = Variable(self.input_name, "input", self.rom.n_inputs,
                                    components=self.placement[self.input_name][1]).shape
        self.output_shape = Variable(self.output_name, "output", self.rom.n_outputs,
                                     components=self.placement[self.output_name][1]).shape
        self.force = np.zeros(self.rom.n_inputs)
        self.displacement = self.rom(np.zeros(self.rom.n_inputs))  # at rest until the first step
        self._window_time: float | None = None
        self._times: list[float] = []
        self._reduced: list[np.ndarray] = []
        self._last_reduced: np.ndarray | None = None
        self.idle_interval = prm["keep_warm"] or None
        served = getattr(self.rom, "served", None)     # the compiled arithmetic: one C call per served step
        self._served = served
        if served is not None:
            self._served_outputs = {self.output_name: served.displacement.reshape(self.output_shape),
                                    **{name: served.trust[i:i + 1] for i, name in enumerate(TRUST_LOCALS)}}
        self._warm_input: np.ndarray | None = None
        self.keep_warm_calls, self.keep_warm_seconds = 0, 0.0
        self._margin = self.range_margin          # the last served call's

    def variables(self) -> list[Variable]:
        (in_mesh, in_k), (out_mesh, out_k) = self.placement[self.input_name], self.placement[self.output_name]
        return [Variable(self.input_name, "input", self.rom.n_inputs, mesh=in_mesh, components=in_k),
                Variable(self.output_name, "output", self.rom.n_outputs, mesh=out_mesh, components=out_k),
                *[Variable(name, "local", 1) for name in TRUST_LOCALS]]

    def meshes(self) -> dict[str, np.ndarray]:
        return self.mesh_nodes

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {self.input_name: self.input_shape})
        if self.input_name in values:
            self.force = np.ravel(values[self.input_name])

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        known = {self.output_name: self.displacement.reshape(self.output_shape),
                 self.input_name: self.force.reshape(self.input_shape),
                 **{name: self.trust_values[i:i + 1] for i, name in enumerate(TRUST_LOCALS)}}
        return {name: np.array(known[name]) for name in names}

    def _count_call(self, t: float) -> float:
        """Count a call of window ``t`` (closing the last window at a new ``t``); the range margin it answers to."""
        if t != self._window_time:
            if self._window_time is not None:
                self._keep_converged()
            self._calls_in_window, self._window_time = 1, t
        else:
            self._calls_in_window += 1
        return self.transient_margin if self._calls_in_window <= self.transient_calls else self.range_margin

    def do_step(self, t: float, dt: float) -> None:
        margin = self._count_call(t)
        rom = self.rom
        self.displacement = rom(self.force)
        self._last_reduced = rom.reduced
        excess, distance = rom.trust()
        out = excess > margin
        self.trust_values = np.array((excess, distance, 1.0 if out else 0.0))
        if out:
            self._out_of_range(margin)
        self._dt, self._warm_input = dt, self.force

    def idle(self) -> None:
        """The last call again, its results dropped: the ROM's own state after it is the same as before."""
        if self._warm_input is None:
            return
        started = time.perf_counter()
        if self._served is not None and self._warm_input is self._served.force:
            self._served.call(self._margin, None)     # the served call itself, on the input it holds: same results
        else:
            self.rom(self._warm_input)
            self.rom.trust()
        self.keep_warm_seconds += time.perf_counter() - started
        self.keep_warm_calls += 1

    # step and do_step are kept short on purpose: in a coupled run the ROM wakes once per call with cold
    # caches, where each Python function call and temporary costs microseconds (benchmarks/flap_rom_call.py)
    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        force = inputs.get(self.input_name)
        if len(inputs) == 1 and type(force) is np.ndarray and force.shape == self.input_shape:
            self.force = force.reshape(-1)      # the served case: the one input, of its shape
        else:
            self.set_values(inputs)             # anything else is checked name by name
        self.do_step(t, dt)
        trust = self.trust_values    # a fresh array each call: its slices are the outputs
        return {self.output_name: self.displacement.reshape(self.output_shape),
                TRUST_LOCALS[0]: trust[0:1], TRUST_LOCALS[1]: trust[1:2], TRUST_LOCALS[2]: trust[2:3]}

    def served_step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``step``; with the compiled arithmetic and the one input of its shape, a single C call on fixed buffers
        whose views are returned (the server sends them before the next call rewrites them)."""
        served, force = self._served, inputs.get(self.input_name)
        if served is None or len(inputs) != 1 or type(force) is not np.ndarray or force.shape != self.input_shape \
                or force.dtype is not FLOAT64:
            return self.step(t, dt, inputs)
        margin = self._count_call(t)
        out = served.call(margin, force.tobytes())    # bytes: the cheapest way to hand the input to C
        self._margin = margin
        self.force = self._warm_input = served.force
        self.displacement, self._last_reduced, self.trust_values = served.displacement, served.reduced, served.trust
        self._dt = dt
        if out:
            self._out_of_range(margin)
        return dict(self._served_outputs)

    def _out_of_range(self, margin: float) -> None:
        """A call out of range: a warning, an error, or (fallback) nothing here: the coupler acts on the flag."""
        message = (f"input outside the training range (a reduced force mode beyond the training data by more than "
                   f"{margin:g} of its range)")
        if self.on_out_of_range == "fail":
            raise ComponentError(self.name, message)
        if self.on_out_of_range == "warn":
            self.warn(message)

    def _keep_converged(self) -> None:
        if self.on_out_of_range == "fallback" and self.trust_values[2] > 0:
            return   # the solid FOM took this window over: the ROM's state is not the window's
        assert self._window_time is not None and self._last_reduced is not None   # a window has been served
        self._times.append(self._window_time + self._dt)
        self._reduced.append(self._last_reduced.copy())    # the served call's buffer is rewritten by the next

    def checkpoint(self) -> Any:
        """The last call's input, outputs and trust, the window's call count, and the converged history that
        ``terminate`` rebuilds the full field from."""
        state = {name: getattr(self, name) for name in CHECKPOINTED if hasattr(self, name)}
        return {name: np.array(value) if isinstance(value, np.ndarray) else value for name, value in state.items()}

    def restore_checkpoint(self, state: Any) -> None:
        for name, value in state.items():
            if name not in CHECKPOINTED:
                raise ComponentError(self.name, f"checkpoint holds '{name}', which this ROM component does not keep")
            setattr(self, name, value)

    def terminate(self) -> dict[str, np.ndarray]:
        """Reduced displacements of every converged window and the full field rebuilt from them."""
        if self._last_reduced is not None:
            self._keep_converged()
            self._last_reduced = None
        final = {"keep_warm_calls": np.array([self.keep_warm_calls]),
                 "keep_warm_seconds": np.array([self.keep_warm_seconds])} if self.idle_interval else {}
        if not self._reduced:
            return final
        reduced = np.stack(self._reduced)
        return {**final, "time": np.array(self._times), "reduced": reduced, "full_field": self.rom.full_field(reduced)}
