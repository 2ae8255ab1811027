"""Coupler-side proxy of one component: the contract's calls over a DEALER socket.

Every request has a timeout. While waiting, the proxy checks in short slices
whether the component's process is still alive, so a dead component stops the
run within a fraction of a second with its exit code and the tail of its log.
Outputs are checked against the sizes the component declared.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import zmq

from cosim import protocol, stop
from cosim.component import LINES_PREFIX, MESH_PREFIX, Variable
from cosim.errors import ComponentDied, ComponentError, ComponentTimeout, CosimError, NonFiniteOutput, ProtocolError
from cosim.launcher import ComponentProcess

LIVENESS_SLICE_SECONDS = 0.05
_all_true = np.logical_and.reduce      # ndarray.all without its Python wrapper (every output is checked)


class ComponentProxy:
    """Talks to one served component; raises typed errors that name it."""

    def __init__(self, name: str, endpoint: str, *, process: ComponentProcess | None = None,
                 timeout: float = 60.0, context: zmq.Context | None = None, curve: str = "",
                 names: Mapping[str, str] | None = None, mesh_dimensions: int = 0):
        self.name = name
        # the scene's names of the component's variables (scene name -> the component's), translated on the wire
        self._outer = {inner: outer for outer, inner in (names or {}).items()}
        self._inner = dict(names or {})
        self.mesh_dimensions = mesh_dimensions   # its meshes seen in this many dimensions, zero-padded (0: as given)
        self.endpoint = endpoint
        self.process = process
        self.timeout = timeout
        self.curve = curve      # a key directory: the connection is CURVE-authenticated and encrypted
        self._socket = (context or zmq.Context.instance()).socket(zmq.DEALER)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.MAXMSGSIZE, protocol.MAX_MESSAGE_BYTES)
        self._socket.setsockopt(zmq.RCVTIMEO, round(LIVENESS_SLICE_SECONDS * 1000))   # a blocking receive, sliced
        self._monitor: zmq.Socket | None = None
        self._refused = ""      # why the CURVE handshake failed, once it has
        if curve:
            from cosim.curve import connect_with_curve
            try:
                self._monitor = connect_with_curve(self._socket, curve)
            except CosimError as exc:
                self._socket.close(linger=0)
                raise ComponentError(name, str(exc)) from None
        elif process is None:       # a component served by hand may speak CURVE: a plaintext handshake then fails
            from cosim.curve import watch_handshake
            self._monitor = watch_handshake(self._socket)
        self._socket.connect(endpoint)
        self._ids = itertools.count(1)
        self._token = process.token if process is not None else ""
        self._pending: tuple[int, str] | None = None
        self.variables: dict[str, Variable] = {}
        self.meshes: dict[str, np.ndarray] = {}
        self.lines: dict[str, np.ndarray] = {}
        self.can_get_and_set_state = False
        self.can_checkpoint = False
        self.repeats_steps = False
        self.stateless = False
        self.state_note = ""
        self.variable_notes: dict[str, str] = {}     # why it cannot offer some of its variables
        self.step_saves_state = False   # its server takes save and free with a step (``send_step``)
        self.saved_state: int | None = None     # the handle the last saving step returned
        self.history_windows = 0        # the converged windows it takes over from a backend before it
        self.backend_changed = False    # one process serves it throughout
        self.warnings: list[str] = []   # delivered with replies, taken by the coupler
        self.pid: int | None = process.pid if process else None
        self.compute_seconds: list[float] = []     # per step: wall time inside the component
        self.cpu_seconds: list[float] = []         # per step: the component process's CPU time
        self.roundtrip_seconds: list[float] = []
        self._sent_at = 0.0
        self.substep_count = 1          # the steps it takes per window (cosim.subcycling)
        self.reads_waveforms = False    # its steps get the waveforms of its inputs of degree >= 1
        self.records_steps = False      # it is recorded: a subcycled step returns each step's inputs
        self.substeps: tuple[np.ndarray, dict[str, np.ndarray]] | None = None     # its last step's samples
        self.substep_calls: list[tuple[dict, dict]] = []     # and each of its steps' inputs and outputs
        self.gradients: dict[str, np.ndarray] = {}           # a component writes no gradients

    # --- transport --------------------------------------------------------
    def send(self, op: str, args: Mapping[str, Any] | None = None,
             arrays: Mapping[str, np.ndarray] | None = None, timeout: float | None = None) -> None:
        """Send a request without waiting for its reply (see ``receive``); ``timeout``: how long it may wait for a
        connection to queue on."""
        if self._pending is not None:
            raise ComponentError(self.name, f"request '{op}' sent while '{self._pending[1]}' is unanswered")
        request_id = next(self._ids)
        args = dict(args or {})
        if self._inner:
            args, arrays = self._renamed(args, arrays, self._inner)
        if self._token and op != "step":     # the launched component serves the client that shows its run's token
            args["token"] = self._token
        frames = protocol.encode({"op": op, "id": request_id, "args": args}, arrays)
        self._sent_at = time.perf_counter()
        try:
            self._socket.send_multipart(frames, flags=zmq.NOBLOCK, copy=False)
        except zmq.Again:       # no connection to queue on (a remote server gone, or one that refused this client)
            self._wait(zmq.POLLOUT, op, self.timeout if timeout is None else timeout)
            self._socket.send_multipart(frames, copy=False)
        self._pending = (request_id, op)

    def _wait(self, event: int, op: str, limit: float) -> None:
        """Wait until the socket can ``event`` (POLLOUT); meanwhile watch as ``_watch`` does."""
        deadline = time.monotonic() + limit
        while not self._socket.poll(LIVENESS_SLICE_SECONDS * 1000, event):
            self._watch(op, limit, deadline)

    def _receive_frames(self, op: str, limit: float) -> list[bytes]:
        """The reply's frames: a blocking receive (as a raw ZeroMQ client's), in slices that ``_watch``."""
        deadline = time.monotonic() + limit
        while True:
            try:
                return self._socket.recv_multipart()
            except zmq.Again:
                self._watch(op, limit, deadline)

    def _watch(self, op: str, limit: float, deadline: float) -> None:
        """Between two slices of a wait: stop on Ctrl-C, on the component's death, on a failed CURVE handshake,
        and past ``deadline``."""
        try:
            stop.check()
            self._check_alive()
            if self._refused:
                raise ComponentError(self.name, self._refused)
            if self._monitor is not None:
                from cosim.curve import handshake_failure
                try:
                    handshake_failure(self._monitor, self.name, self.endpoint, self.curve)
                except ComponentError as exc:
                    self._refused = exc.detail      # no reconnection follows a refusal: every later call fails
                    raise
            if time.monotonic() > deadline:
                raise ComponentTimeout(self.name, op, limit)
        except ComponentError:
            self._pending = None
            raise

    def receive(self, timeout: float | None = None) -> tuple[dict, dict[str, np.ndarray], float]:
        """Result, arrays and compute seconds of the pending request."""
        assert self._pending is not None, "receive without send"
        request_id, op = self._pending
        frames = self._receive_frames(op, self.timeout if timeout is None else timeout)
        roundtrip = time.perf_counter() - self._sent_at
        self._pending = None
        try:
            header, arrays = protocol.decode(frames)
        except ProtocolError as exc:
            raise ComponentError(self.name, f"malformed reply to '{op}': {exc}") from None
        if header.get("id") != request_id:
            raise ComponentError(self.name, f"reply id {header.get('id')} does not match request {request_id}")
        if self._outer and header.get("ok"):
            result = header.get("result")
            if isinstance(result, dict) and isinstance(result.get("variables"), list):
                result["variables"] = [{**v, "name": self._outer.get(str(v.get("name")), v.get("name"))}
                                       if isinstance(v, dict) else v for v in result["variables"]]
            _, arrays = self._renamed({}, arrays, self._outer)
        if not header.get("ok"):
            error = header.get("error") or {}
            kind = error.get("type", "ComponentError")
            shown = "" if kind == "ComponentError" else f"{kind}: "
            log = f" (its log: {self.process.log_path})" if self.process is not None and error.get("logged") else ""
            raise ComponentError(self.name, f"'{op}' failed: {shown}{error.get('message', '')}{log}", kind=kind)
        compute = float(header.get("compute_seconds", 0.0))
        warnings = header.get("warnings")
        if warnings:
            self.warnings.extend(str(w) for w in warnings)
        if op == "step":
            self.compute_seconds.append(compute)
            self.cpu_seconds.append(float(header.get("cpu_seconds", compute)))
            self.roundtrip_seconds.append(roundtrip)
        return header.get("result") or {}, arrays, compute

    @staticmethod
    def _renamed(args: dict[str, Any], arrays: Mapping[str, np.ndarray] | None,
                 table: Mapping[str, str]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Variable names in a message translated by ``table``: array keys (``name`` or ``prefix:name``, meshes
        aside) and the names and knots a request carries."""
        def key(name: str) -> str:
            prefix, colon, rest = name.rpartition(":")
            if prefix in ("mesh", "lines"):
                return name
            return f"{prefix}{colon}{table.get(rest, rest)}"
        if "names" in args:
            args = {**args, "names": [table.get(n, n) for n in args["names"]]}
        if isinstance(args.get("knots"), dict):
            args = {**args, "knots": {table.get(n, n): k for n, k in args["knots"].items()}}
        return args, {key(name): value for name, value in (arrays or {}).items()}

    def call(self, op: str, args: Mapping[str, Any] | None = None,
             arrays: Mapping[str, np.ndarray] | None = None, timeout: float | None = None) -> tuple[dict, dict]:
        self.send(op, args, arrays, timeout)
        result, out, _ = self.receive(timeout)
        return result, out

    def _check_alive(self) -> None:
        if self.process is not None:
            code = self.process.poll()
            if code is not None:
                self._pending = None
                raise ComponentDied(self.name, code, self.process.stderr_tail(), str(self.process.log_path))

    # --- contract ---------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        result, arrays = self.call("describe")
        try:
            self.variables = {v["name"]: Variable(**v) for v in result["variables"]}
        except (TypeError, ValueError) as exc:
            raise ComponentError(self.name, f"malformed variable description: {exc}") from None
        self.meshes = {k[len(MESH_PREFIX):]: self._embedded(np.array(v)) for k, v in arrays.items()
                       if k.startswith(MESH_PREFIX)}
        self.lines = {k[len(LINES_PREFIX):]: np.array(v) for k, v in arrays.items() if k.startswith(LINES_PREFIX)}
        for variable in self.variables.values():
            if not variable.mesh:
                continue
            nodes = self.meshes.get(variable.mesh)
            if nodes is None:
                raise ComponentError(self.name, f"variable '{variable.name}' lives on mesh '{variable.mesh}', "
                                                f"which the component does not declare (meshes: {', '.join(self.meshes) or 'none'})")
            if variable.shape[0] != len(nodes):
                raise ComponentError(self.name, f"variable '{variable.name}' has {variable.shape[0]} nodes, "
                                                f"but mesh '{variable.mesh}' has {len(nodes)}")
        self.can_get_and_set_state = bool(result.get("can_get_and_set_state"))
        self.can_checkpoint = bool(result.get("can_checkpoint"))
        self.repeats_steps = bool(result.get("repeats_steps"))
        self.stateless = bool(result.get("stateless"))
        self.state_note = str(result.get("state_note", ""))
        notes = result.get("variable_notes")
        self.variable_notes = {str(k): str(v) for k, v in notes.items()} if isinstance(notes, dict) else {}
        self.step_saves_state = bool(result.get("step_saves_state"))
        self.history_windows = int(result.get("history_windows", 0))
        return result

    def _embedded(self, nodes: np.ndarray) -> np.ndarray:
        """A mesh's nodes in ``mesh_dimensions`` dimensions: zero coordinates added (a 1-D tube in the plane)."""
        if not self.mesh_dimensions or nodes.ndim != 2 or nodes.shape[1] == self.mesh_dimensions:
            return nodes
        if nodes.shape[1] > self.mesh_dimensions:
            raise ComponentError(self.name, f"its mesh has {nodes.shape[1]} dimensions, more than the "
                                            f"{self.mesh_dimensions} it is to be seen in")
        return np.hstack([nodes, np.zeros((len(nodes), self.mesh_dimensions - nodes.shape[1]))])

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        self.send_instantiate(parameters)
        self.receive_instantiate()

    def send_instantiate(self, parameters: Mapping[str, Any]) -> None:
        """The first half of ``instantiate``: the components of a run build their models at the same time."""
        self.send("instantiate", {"parameters": dict(parameters)})

    def receive_instantiate(self) -> None:
        self.receive()
        self.describe()

    def enter_initialization_mode(self, start: float, stop: float) -> None:
        self.call("enter_initialization_mode", {"start": start, "stop": stop})

    def exit_initialization_mode(self) -> None:
        self.call("exit_initialization_mode")

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        self.call("set_values", arrays=values)

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        return self.check_outputs(self.call("get_values", {"names": list(names)})[1])

    def end_window(self, values: Mapping[str, np.ndarray]) -> None:
        self.call("end_window", arrays=values)

    def do_step(self, t: float, dt: float) -> None:
        self.call("do_step", {"t": t, "dt": dt})

    def send_step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
                  save: bool = False, free: int | None = None,
                  waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> None:
        """First half of ``step``: lets the coupler run several components concurrently. With a server that
        ``step_saves_state``: ``free`` a state handle first, ``save`` the state before the step (``saved_state``).
        A component that subcycles gets its step count and ``waveforms`` (``cosim.subcycling``)."""
        args: dict[str, Any] = {"t": t, "dt": dt, "restore": restore}
        if save:
            args["save"] = True
        if free is not None:
            args["free"] = free
        if self.substep_count > 1:
            args["substeps"] = self.substep_count
            if self.records_steps:
                args["record_steps"] = True
        if waveforms:       # the knots (a few numbers) in the header, the coefficients as arrays: the last one is
            # the window-end value, which goes no other way
            inputs = {name: value for name, value in inputs.items() if name not in waveforms}
            args["knots"] = {name: knots.tolist() for name, (knots, _) in waveforms.items()}
            for name, (_, coefficients) in waveforms.items():
                inputs[f"coefficients:{name}"] = coefficients
        self.send("step", args, inputs)

    def receive_step(self) -> dict[str, np.ndarray]:
        result, arrays, _ = self.receive()
        if "state" in result:
            self.saved_state = int(result["state"])
        if "times" in result:
            return self._subcycled(np.array(result["times"], dtype=float), arrays)
        self.substeps, self.substep_calls = None, []
        return self.check_outputs(arrays)

    def _subcycled(self, times: np.ndarray, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """A subcycled step's reply: the last outputs; the samples inside the window and each step's call kept."""
        steps = {name[len("steps:"):]: arrays.pop(name) for name in list(arrays) if name.startswith("steps:")}
        given = {name[len("inputs:"):]: arrays.pop(name) for name in list(arrays) if name.startswith("inputs:")}
        if any(len(value) != len(times) + 1 for value in steps.values()):
            raise ComponentError(self.name, f"returned {', '.join(str(len(v)) for v in steps.values())} steps of "
                                            f"outputs for {len(times) + 1} steps")
        outputs = self.check_outputs({**arrays, **{name: value[-1] for name, value in steps.items()}})
        for name, value in steps.items():        # the steps inside the window go into waveforms: checked as well
            if value.dtype.kind == "f" and not np.isfinite(value).all():
                k = int(np.flatnonzero(~np.all(np.isfinite(value.reshape(len(value), -1)), axis=1))[0])
                raise NonFiniteOutput(self.name, name, value[k], f" at its step {k + 1} of {len(value)} in the window")
        samples = {name: value[:-1] for name, value in steps.items()}
        self.substeps = (times, samples) if len(times) else None
        self.substep_calls = [({name: value[k] for name, value in given.items()},
                               {name: steps[name][k] if name in steps else outputs[name] for name in outputs})
                              for k in range(len(times) + 1)] if given else []
        return outputs

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
             save: bool = False, free: int | None = None,
             waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> dict[str, np.ndarray]:
        """free_state, set_state, get_state (each optional), set_values, do_step, get_values in one round trip."""
        self.send_step(t, dt, inputs, restore, save, free, waveforms)
        return self.receive_step()

    def get_state(self) -> int:
        return int(self.call("get_state")[0]["handle"])

    def set_state(self, handle: int) -> None:
        self.call("set_state", {"handle": handle})

    def free_state(self, handle: int) -> None:
        self.call("free_state", {"handle": handle})

    def checkpoint(self) -> tuple[str, dict[str, np.ndarray]]:
        """The component's checkpoint: a JSON document and its arrays (``cosim.checkpoint``)."""
        result, arrays = self.call("checkpoint")
        return str(result["document"]), arrays

    def restore_checkpoint(self, document: str, arrays: Mapping[str, np.ndarray]) -> None:
        self.call("restore_checkpoint", {"document": document}, arrays)

    def take_over(self, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, np.ndarray]) -> None:
        """Hand the component the converged inputs and outputs of the windows before it takes over (rows oldest
        first), from the backend that served them."""
        self.call("take_over", arrays={**{f"in:{k}": v for k, v in inputs.items()},
                                       **{f"out:{k}": v for k, v in outputs.items()}})

    def terminate(self) -> dict[str, np.ndarray]:
        return {k: np.array(v) for k, v in self.call("terminate")[1].items()}

    def coupling_state(self) -> None:
        """Nothing beside the component's own checkpoint (a schedule of backends keeps more)."""
        return None

    def restore_coupling_state(self, state: Mapping[str, Any]) -> None:
        """Nothing to restore (``coupling_state`` is None)."""

    def shutdown(self, timeout: float = 2.0) -> None:
        """Stop the component."""
        self.call("shutdown", timeout=timeout)

    @property
    def closed(self) -> bool:
        return self._socket.closed

    def close(self) -> None:
        if self._socket.closed:
            return
        if self._monitor is not None:
            self._socket.disable_monitor()
            self._monitor.close(linger=0)
        self._socket.close(linger=0)

    def output_names(self) -> list[str]:
        return [v.name for v in self.variables.values() if v.causality == "output"]

    def mesh_of(self, name: str) -> np.ndarray:
        """Node coordinates of the mesh variable ``name`` lives on (empty if none)."""
        variable = self.variables[name]
        return self.meshes[variable.mesh] if variable.mesh else np.zeros((0, 1))

    def lines_of(self, name: str) -> np.ndarray | None:
        """The line elements of that mesh, if the component declares them."""
        return self.lines.get(self.variables[name].mesh)

    def cells_of(self, name: str) -> np.ndarray | None:
        """None: a component declares no cells."""
        return None

    # --- checks -------------------------------------------------------------
    def check_outputs(self, arrays: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Outputs as declared by ``describe``; a wrong name or length (naming both shapes), NaN or Inf is an error."""
        return checked_outputs(self.name, self.variables, arrays)


def checked_outputs(component: str, variables: Mapping[str, Variable],
                    arrays: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``arrays`` if each is a variable ``component`` declared, of its shape, with no NaN nor Inf; else the error that
    names the component, the variable and both shapes (or the first non-finite value)."""
    for name, value in arrays.items():
        variable = variables.get(name)
        if variable is None:
            raise ComponentError(component, f"returned '{name}', which it did not declare")
        if value.shape != variable.shape:
            raise ComponentError(component, f"output '{name}' has shape {value.shape}, "
                                            f"but the component declared shape {variable.shape}")
        if value.dtype.kind == "f" and not _all_true(np.isfinite(value), axis=None):
            raise NonFiniteOutput(component, name, value)
    return dict(arrays)
