"""Components that own their time loop (a preCICE participant): the coupler's side.

A participant is a process that calls the coupler, where a component is called by it: it connects, says hello,
sets its meshes, calls ``initialize`` with its vertices and initial data, then ``advance`` at each window's end
with the data it wrote, and waits for the answer. ``ParticipantProxy`` turns that into the component contract
the coupling schemes drive: a coupling iteration's ``step`` answers the participant's pending ``initialize`` or
``advance`` with the read data (and whether the window is new, repeated or the last) and returns the write data of
its next ``advance``. A participant repeats a window itself when told (``repeats_steps``): it keeps its own
checkpoint, so a run with participants cannot be checkpointed for ``--resume``.

Every participant of a run connects to one ROUTER socket on loopback (``ParticipantHub``) and proves itself with
the run's token. The messages are the wire's (``cosim.protocol``), sent the other way round: the participant
asks, the coupler answers. The participant's side is ``precice_compat/participant`` (``import precice``).
"""

from __future__ import annotations

import secrets
import time
from collections import deque
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import zmq

from cosim import protocol, stop
from cosim.component import Variable
from cosim.errors import ComponentDied, ComponentError, ComponentTimeout, CosimError, ProtocolError
from cosim.launcher import ComponentProcess
from cosim.participant_ranks import RankError, RankGroup
from cosim.proxy import checked_outputs
from cosim.rundir import alive, command_line
from cosim.subcycling import MAX_SUBSTEPS, Spline

SLICE_SECONDS = 0.05
ENDPOINT_VARIABLE, TOKEN_VARIABLE, PID_VARIABLE = ("COSIM_PARTICIPANT_ENDPOINT", "COSIM_PARTICIPANT_TOKEN",
                                                   "COSIM_COUPLER_PID")


class ParticipantHub:
    """The run's socket for participants: binds loopback, routes each participant's messages to its proxy."""

    def __init__(self, bind: str = "tcp://127.0.0.1:*", context: zmq.Context | None = None):
        self.socket = (context or zmq.Context.instance()).socket(zmq.ROUTER)
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.setsockopt(zmq.MAXMSGSIZE, protocol.MAX_MESSAGE_BYTES)
        self.socket.bind(bind)
        self.endpoint = self.socket.getsockopt_string(zmq.LAST_ENDPOINT)
        self.token = secrets.token_hex(16)
        self.identities: dict[str, bytes] = {}           # participant name -> its connection
        self.queues: dict[str, deque] = {}               # name -> its requests not yet taken
        self.expected: set[str] = set()                  # the participants the run has (their proxies)
        self.announced: list[Path] = []                  # rendezvous files written for participants started by hand
        self.groups: dict[str, RankGroup] = {}           # a parallel participant's ranks
        self.launched: dict[str, str] = {}               # name -> the token of the participant the coupler started

    def announce(self, path: Path) -> None:
        """Write where the coupler listens, and the token, into ``path`` for participants started by hand (only
        the owner may read it); it is removed when the hub closes."""
        import json
        import os
        try:
            other = json.loads(path.read_text()).get("pid")
        except (OSError, ValueError, AttributeError):
            other = None
        if isinstance(other, int) and other != os.getpid() and alive(other) and "cosim" in command_line(other):
            raise CosimError(f"another coupler (pid {other}) serves the participants started by hand of this "
                             f"configuration ({path}): stop it, or wait for its run to end")
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f".{path.name}.{os.getpid()}")
        descriptor = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(descriptor, "w") as stream:
            json.dump({"endpoint": self.endpoint, "token": self.token, "pid": os.getpid()}, stream)
        os.replace(partial, path)
        self.announced.append(path)

    def environment(self, name: str) -> dict[str, str]:
        """What the participant ``name``, started by the coupler, finds in its environment to reach it: a token of
        its own, so that it cannot say hello as another participant."""
        import os
        token = self.launched.setdefault(name, secrets.token_hex(16))
        return {ENDPOINT_VARIABLE: self.endpoint, TOKEN_VARIABLE: token, PID_VARIABLE: str(os.getpid())}

    def poll(self, timeout: float) -> None:
        """Take what has arrived within ``timeout`` seconds and queue it by participant."""
        if not self.socket.poll(timeout * 1000):
            return
        while True:
            try:
                identity, *frames = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            try:
                header, arrays = protocol.decode(frames)
            except ProtocolError as exc:
                self.reply(identity, None, error=f"malformed message: {exc}")
                continue
            given = header.get("args")
            args: dict[str, Any] = given if isinstance(given, dict) else {}
            token = args.get("token")
            started_as = next((n for n, known in self.launched.items() if known == token), None)
            if token != self.token and started_as is None:
                self.reply(identity, header.get("id"), error="refused: this coupler serves the participants of its "
                                                           "own run (a wrong or missing token)")
                continue
            name, rank = self._sender(identity)
            claimed = str(args.get("participant", "")) if name is None else name
            if started_as is not None and claimed != started_as and header.get("op") in ("hello", "error"):
                message = (f"this process was started as participant '{started_as}' and says "
                           f"{header.get('op')} as '{claimed}' (the run's participants: "
                           f"{', '.join(sorted(self.expected))})")
                self.reply(identity, header.get("id"), error=message)
                self.queues.setdefault(started_as, deque()).append(({"op": "error", "args": {"message": message}}, {}))
                continue
            if header.get("op") == "error" and name is None:      # a participant's misuse before its hello
                name = str(args.get("participant", ""))
                self.queues.setdefault(name, deque()).append((header, arrays))
                continue
            if header.get("op") == "hello" and name is None:
                name = str(args.get("participant", ""))
                refused = self._hello(name, identity, args)
                if refused:
                    self.reply(identity, header.get("id"), error=refused)
                    continue
                rank = self.groups[name].rank_of(identity) if name in self.groups else None
            if name is None:
                self.reply(identity, header.get("id"), error="say hello first")
                continue
            group = self.groups.get(name)
            if group is None or rank is None:
                self.queues.setdefault(name, deque()).append((header, arrays))
                continue
            if header.get("op") == "error":          # one rank's misuse stops the run with its line
                message = f"rank {rank}: {args.get('message', 'failed')}"
                self.queues.setdefault(name, deque()).append(({**header, "args": {**args, "message": message}}, {}))
                continue
            try:
                whole = group.add(rank, header, arrays)
            except RankError as exc:
                whole = ({"op": "error", "args": {"message": str(exc)}}, {})
            if whole is not None:
                self.queues.setdefault(name, deque()).append(whole)

    def _sender(self, identity: bytes) -> tuple[str | None, int | None]:
        """The participant (and rank, of a parallel one) a connection belongs to."""
        for name, group in self.groups.items():
            rank = group.rank_of(identity)
            if rank is not None:
                return name, rank
        return next((n for n, known in self.identities.items() if known == identity), None), None

    def _hello(self, name: str, identity: bytes, args: Mapping[str, Any]) -> str:
        """Admit a participant's (or a rank's) hello; the reason it is refused, if it is."""
        if name not in self.expected:
            return f"this run has no participant '{name}' (its participants: {', '.join(sorted(self.expected))})"
        rank, size = args.get("rank", 0), args.get("size", 1)
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in (rank, size)) or not 0 <= rank < size:
            return f"participant '{name}' said it is rank {rank!r} of {size!r}"
        group = self.groups.get(name)
        if size == 1 and group is None:
            if name in self.identities:
                return f"a participant named '{name}' is connected already"
            self.identities[name] = identity
            return ""
        if group is None:
            if name in self.identities:
                return f"a participant named '{name}' is connected already"
            group = self.groups[name] = RankGroup(name, size)
        if group.size != size:
            return f"rank {rank} of participant '{name}' says there are {size} ranks; rank 0 said {group.size}"
        pid = args.get("pid", 0)
        try:
            group.join(rank, identity, pid if isinstance(pid, int) and not isinstance(pid, bool) else 0)
        except RankError as exc:
            return str(exc)
        if rank == 0:
            self.identities[name] = identity
        return ""

    def answer(self, name: str, request_id: Any, result: Mapping[str, Any] | None = None,
               arrays: Mapping[str, np.ndarray] | None = None, error: str = "") -> None:
        """Answer a participant's request: each of a parallel participant's ranks its own part."""
        group = self.groups.get(name)
        if group is None:
            self.reply(self.identities[name], request_id, result, arrays, error)
        elif error:
            for identity, rank_id in zip(group.identities, group.ids):
                if identity is not None:
                    self.reply(identity, rank_id, error=error)
        else:
            for identity, rank_id, rank_result, part in group.split(result or {}, arrays):
                self.reply(identity, rank_id, rank_result, part)

    def rank_pids(self, name: str) -> list[int]:
        """The processes of a parallel participant's ranks (none for a serial one)."""
        group = self.groups.get(name)
        return list(group.pids) if group is not None else []

    def take(self, name: str) -> tuple[dict[str, Any], dict[str, np.ndarray]] | None:
        queue = self.queues.get(name)
        return queue.popleft() if queue else None

    def reply(self, identity: bytes, request_id: Any, result: Mapping[str, Any] | None = None,
              arrays: Mapping[str, np.ndarray] | None = None, error: str = "") -> None:
        header: dict[str, Any] = {"id": request_id, "ok": not error}
        if error:
            header["error"] = {"type": "ComponentError", "message": error, "component": "coupler"}
        else:
            header["result"] = dict(result or {})
        self.socket.send_multipart([identity, *protocol.encode(header, arrays)], copy=False)

    def close(self) -> None:
        for path in self.announced:
            path.unlink(missing_ok=True)
        self.socket.close(linger=0)


class ParticipantProxy:
    """One participant as the coupling schemes see a component (the calls of ``ComponentProxy`` they make)."""

    can_get_and_set_state = False
    can_checkpoint = False         # it keeps its state to itself
    repeats_steps = True           # told to, it reads its own checkpoint and computes the window again
    stateless = False
    step_saves_state = False
    history_windows = 0
    curve = ""
    saved_state: int | None = None
    reads_waveforms = True         # its reads inside a window evaluate the waveform the step carries
    state_note = ""
    backend_changed = False        # it serves itself throughout

    def __init__(self, name: str, hub: ParticipantHub, process: ComponentProcess | None = None,
                 timeout: float = 120.0, startup_timeout: float = 60.0):
        self.name = name
        self.hub = hub
        self.process = process
        self.timeout = timeout
        self.startup_timeout = startup_timeout
        self.endpoint = hub.endpoint
        hub.expected.add(name)
        self.pid: int | None = process.pid if process else None
        self.variables: dict[str, Variable] = {}
        self.meshes: dict[str, np.ndarray] = {}
        self.elements: dict[str, dict[str, np.ndarray]] = {}     # mesh -> edges, triangles, tetrahedra
        self._received: list[str] = []      # received meshes it accesses directly (their vertices go with initialize)
        self.warnings: list[str] = []
        self.compute_seconds: list[float] = []
        self.cpu_seconds: list[float] = []
        self.roundtrip_seconds: list[float] = []
        self._pending: dict[str, Any] | None = None     # the request the participant waits on
        self._initial: dict[str, np.ndarray] = {}
        self.gradients: dict[str, np.ndarray] = {}    # data -> the gradients its last write carried (n x dim*k)
        self._written: list[str] = []       # the data it writes: every window-ending advance carries them
        self._window: tuple[float, float] | None = None   # (t, dt) of the last step answered
        self._sent_at = 0.0
        self._closed = False
        self.substeps: tuple[np.ndarray, dict[str, np.ndarray]] | None = None   # its last advance's samples
        self.substep_calls: list[tuple[dict, dict]] = []    # and its steps as calls, for the recording
        self._sent: tuple[dict[str, np.ndarray], dict[str, tuple]] = ({}, {})    # the last step's inputs, waveforms
        self.setup: dict[str, Any] = {}

    # --- waiting for the participant -----------------------------------------------------------------------------
    def _next(self, what: str, limit: float) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The participant's next request, waited for up to ``limit`` seconds while its process lives."""
        deadline = time.monotonic() + limit
        while True:
            taken = self.hub.take(self.name)
            if taken is not None:
                header, arrays = taken
                if header.get("op") == "error":     # the participant's own misuse, in one line, before it raises
                    raise ComponentError(self.name, one_line((header.get("args") or {}).get("message", "failed")))
                return header, arrays
            stop.check()
            gone = [(rank, pid) for rank, pid in enumerate(self.hub.rank_pids(self.name)) if pid and not alive(pid)]
            if gone:
                self.hub.poll(SLICE_SECONDS)
                if self.hub.queues.get(self.name):
                    continue
                ranks = " and ".join(str(rank) for rank, _ in gone)
                pids = ", ".join(str(pid) for _, pid in gone)
                raise ComponentError(self.name, f"its rank{'s' if len(gone) > 1 else ''} {ranks} (pid{'s' if len(gone) > 1 else ''} "
                                                f"{pids}) {'are' if len(gone) > 1 else 'is'} gone while the coupler "
                                                f"waited for {what}")
            if self.process is None and self.pid and not alive(self.pid):     # started by hand, and gone
                self.hub.poll(SLICE_SECONDS)
                if self.hub.queues.get(self.name):
                    continue
                raise ComponentError(self.name, f"its process (pid {self.pid}) is gone while the coupler waited for "
                                                f"{what}")
            if self.process is not None and self.process.poll() is not None:
                self.hub.poll(SLICE_SECONDS)        # what it said before it exited (its misuse) comes first
                if self.hub.queues.get(self.name):
                    continue
                code = self.process.poll()
                said = one_line(self.process.stderr_tail(1))    # a Python participant's error: its message's line
                if code == 0:
                    raise ComponentError(self.name, f"exited (code 0) while the coupler waited for {what} "
                                                    f"(its log: {self.process.log_path})")
                died = ComponentDied(self.name, code, "", str(self.process.log_path))
                if said:
                    died.detail += f"; it said: {said}"
                raise died
            if time.monotonic() > deadline:
                error = ComponentTimeout(self.name, what, limit)
                error.detail = f"did not call {what} within {limit:g} s" + (
                    f" (its log: {self.process.log_path})" if self.process is not None else "")
                raise error
            self.hub.poll(SLICE_SECONDS)

    def _answer(self, result: Mapping[str, Any], arrays: Mapping[str, np.ndarray] | None = None) -> None:
        pending, self._pending = self._pending, None
        if pending is None:
            raise ComponentError(self.name, "no request of the participant waits for an answer")
        self.hub.answer(self.name, pending.get("id"), result, arrays)

    # --- the start ----------------------------------------------------------------------------------------------
    def connect(self) -> None:
        """Wait for the participant's hello (its constructor)."""
        header, _ = self._next("its hello (the Participant's constructor)", self.startup_timeout)
        if header.get("op") != "hello":
            raise ComponentError(self.name, f"sent '{header.get('op')}' before its hello")
        self._pending = header
        pid = (header.get("args") or {}).get("pid", self.pid or 0)
        if isinstance(pid, bool) or not isinstance(pid, int) or pid < 0:
            raise ComponentError(self.name, f"its hello gave the pid {str(pid)[:40]!r}, not a process number")
        self.pid = pid or self.pid

    def call(self, op: str, args: Mapping[str, Any] | None = None, timeout: float | None = None) -> tuple[dict, dict]:
        """``ping`` (cosim check's probe of a component served by hand) has no meaning here."""
        raise ComponentError(self.name, f"a participant takes no '{op}' request")

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        """Answer the hello with the participant's setup (``parameters["setup"]``: its meshes, the data it writes
        and reads, the window, the time), then wait for its ``initialize``: its vertices and initial data."""
        self.setup = dict(parameters.get("setup") or {})
        if self._pending is None:
            self.connect()
        self._answer(self.setup)
        header, arrays = self._next("initialize", self.startup_timeout)
        if header.get("op") != "initialize":
            raise ComponentError(self.name, f"called '{header.get('op')}' where initialize was expected")
        self._pending = header
        self.meshes = {name[len("mesh:"):]: value for name, value in arrays.items() if name.startswith("mesh:")}
        for mesh, vertices in self.meshes.items():
            dimensions = int((self.setup.get("meshes") or {}).get(mesh, {}).get("dimensions", 0))
            if vertices.dtype != np.float64 or vertices.ndim != 2 or (dimensions and vertices.shape[1] != dimensions):
                raise ComponentError(self.name, f"gave the vertices of mesh '{mesh}' as {vertices.dtype} of shape "
                                                f"{vertices.shape}; expected float64 of shape (n, "
                                                f"{dimensions or 'dim'})")
            if not np.isfinite(vertices).all():
                raise ComponentError(self.name, f"gave vertices of mesh '{mesh}' that are not finite")
        self.elements = self._elements(arrays)
        self._initial = {name[len("data:"):]: value for name, value in arrays.items() if name.startswith("data:")}
        self._declare()
        self._take_gradients(arrays)

    def _declare(self) -> None:
        """Its variables: the data it writes and reads, on the meshes it provides (and those it accesses directly,
        once ``link`` gave their vertices)."""
        variables = []
        meshes = self.setup.get("meshes") or {}
        for causality, key in (("output", "write"), ("input", "read")):
            for spec in self.setup.get(key, []):
                nodes = self.meshes.get(spec["mesh"])
                if nodes is None and meshes.get(spec["mesh"], {}).get("direct_access"):
                    continue                        # a received mesh: declared when linked
                if nodes is None:
                    raise ComponentError(self.name, f"gave no vertices of mesh '{spec['mesh']}', on which it "
                                                    f"{'writes' if causality == 'output' else 'reads'} "
                                                    f"'{spec['data']}'")
                dimensions = int(spec["dimensions"])
                variables.append(Variable(spec["data"], causality, len(nodes) * dimensions, mesh=spec["mesh"],
                                          components=dimensions))
        self.variables = {v.name: v for v in variables}
        self.check_outputs(self._initial)
        self._written = sorted(v.name for v in variables if v.causality == "output")

    def link(self, providers: Mapping[str, ParticipantProxy]) -> None:
        """The received meshes it accesses directly, from the participants that provide them: their vertices are
        sent with the answer to its initialize, and the data it writes or reads on them declared."""
        for mesh, info in (self.setup.get("meshes") or {}).items():
            if info.get("provided") or not info.get("direct_access"):
                continue
            provider = providers.get(info.get("from", ""))
            if provider is None or mesh not in provider.meshes:
                raise ComponentError(self.name, f"accesses mesh '{mesh}' directly, which participant "
                                                f"'{info.get('from')}' does not give")
            self.meshes[mesh] = provider.meshes[mesh]
            self._received.append(mesh)
        if self._received:
            self._declare()

    def enter_initialization_mode(self, start: float, stop: float) -> None:
        pass

    def exit_initialization_mode(self) -> None:
        pass

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        """The participant's initial data (zeros for data it wrote none of)."""
        return {name: np.array(self._initial[name]) if name in self._initial else np.zeros(self.variables[name].shape)
                for name in names}

    # --- the coupling -------------------------------------------------------------------------------------------
    def send_step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
                  save: bool = False, free: int | None = None,
                  waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> None:
        """Answer the pending ``initialize`` or ``advance``: the window [t, t + dt] to compute with ``inputs`` (the
        window-end values) and ``waveforms`` (data of degree >= 1: the B-spline's knots and coefficients across the
        window), as a new window or the last one again."""
        repeat = self._window is not None and abs(self._window[0] - t) <= 1e-9 * max(1.0, abs(t))
        first = self._pending is not None and self._pending.get("op") == "initialize"
        implicit = bool(self.setup.get("implicit", True))
        self._window = (t, dt)
        self._sent_at = time.perf_counter()
        self._sent = (dict(inputs), dict(waveforms or {}))
        arrays = {f"data:{name}": np.asarray(value) for name, value in inputs.items()}
        if first:
            arrays.update({f"mesh:{mesh}": self.meshes[mesh] for mesh in self._received})
        knots, lines = {}, []
        for name, (knot_vector, coefficients) in (waveforms or {}).items():
            if len(coefficients) == 2:      # the line from the window's start to its end: the start goes once a
                lines.append(name)          # window (the participant keeps it), the end is the data already sent
                if not repeat:
                    arrays[f"start:{name}"] = coefficients[0]
            else:
                knots[name] = knot_vector.tolist()
                arrays[f"coefficients:{name}"] = coefficients
        self._answer({"ongoing": True, "window_complete": not repeat and not first, "window_start": t, "window": dt,
                      "write_checkpoint": implicit and not repeat, "read_checkpoint": repeat, "knots": knots,
                      "lines": lines}, arrays)

    def receive_step(self) -> dict[str, np.ndarray]:
        """The write data of the participant's next window-ending ``advance``."""
        header, arrays = self._next("advance", self.timeout)
        roundtrip = time.perf_counter() - self._sent_at
        op = header.get("op")
        if op != "advance":
            self._pending = header
            raise ComponentError(self.name, f"called '{op}' in the middle of the coupling (window "
                                            f"{self._window}), where advance was expected")
        self._pending = header
        args = header.get("args") or {}
        outputs = {name[len("data:"):]: value for name, value in arrays.items() if name.startswith("data:")}
        missing = [name for name in self._written if name not in outputs]
        if missing:
            raise ComponentError(self.name, f"its advance carried no '{missing[0]}'")
        self._take_gradients(arrays)
        self.substeps = self._samples(args.get("times"), arrays)
        self.substep_calls = self._calls(outputs) if self.substeps else []
        compute = _seconds(args.get("compute_seconds"), roundtrip)
        self.compute_seconds.append(compute)
        self.cpu_seconds.append(_seconds(args.get("cpu_seconds"), compute))
        self.roundtrip_seconds.append(roundtrip)
        return self.check_outputs(outputs)

    def _take_gradients(self, arrays: Mapping[str, np.ndarray]) -> None:
        """The gradients a write carried (``write_gradient_data``): per vertex, each component's d/dx, d/dy (, d/dz)
        (float64, finite, one row a vertex of the data's mesh)."""
        for key, value in arrays.items():
            if not key.startswith("gradient:"):
                continue
            name = key[len("gradient:"):]
            variable = self.variables.get(name)
            if variable is None or variable.causality != "output":
                raise ComponentError(self.name, f"sent gradients of '{name}', which it does not write")
            nodes = len(self.meshes[variable.mesh])
            columns = self.meshes[variable.mesh].shape[1] * variable.components
            if value.dtype != np.float64 or value.shape != (nodes, columns) or not np.isfinite(value).all():
                raise ComponentError(self.name, f"sent gradients of '{name}' as {value.dtype} of shape {value.shape}"
                                                f"; expected finite float64 of shape ({nodes}, {columns})")
            self.gradients[name] = value

    def _calls(self, outputs: Mapping[str, np.ndarray]) -> list[tuple[dict, dict]]:
        """Its steps inside the window as calls: at each sample's time, the inputs as their waveforms give them
        there and the samples it wrote; then the window's end."""
        assert self.substeps is not None
        times, samples = self.substeps
        inputs, waveforms = self._sent
        at = {name: Spline(knots, coefficients).at(times) for name, (knots, coefficients) in waveforms.items()}
        calls = [({name: at[name][k] if name in at else value for name, value in inputs.items()},
                  {name: value[k] for name, value in samples.items()}) for k in range(len(times))]
        return calls + [(inputs, dict(outputs))]

    def _samples(self, given: Any, arrays: Mapping[str, np.ndarray]) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
        """The samples an advance carries from the participant's steps inside the window (data with substeps):
        their normalised times (in its header), strictly inside (0, 1) and increasing, and each data item's values
        there."""
        if given is None:
            return None
        try:
            times = np.asarray(given, dtype=float)
        except (TypeError, ValueError):
            raise ComponentError(self.name, f"its substeps' times {given!r} are not numbers") from None
        if times.size >= MAX_SUBSTEPS:
            raise ComponentError(self.name, f"took {times.size + 1:,} steps in the window {self._window}; cosim "
                                            f"interpolates a window through at most {MAX_SUBSTEPS:,} steps")
        if times.ndim != 1 or not (np.all(np.diff(times) > 0) and times.size and 0 < times[0] and times[-1] < 1):
            raise ComponentError(self.name, f"its substeps' times {np.round(times, 6).tolist()} are not increasing "
                                            "inside the window")
        samples = {}
        for name in self._written:
            stacked = arrays.get(f"substeps:{name}")
            if stacked is None:
                continue
            expected = (len(times),) + self.variables[name].shape
            if stacked.shape != expected or not np.isfinite(stacked).all():
                raise ComponentError(self.name, f"its substeps of '{name}' have shape {stacked.shape} (expected "
                                                f"{expected}) or are not finite")
            samples[name] = stacked
        return (times, samples) if samples else None

    def end_window(self, values: Mapping[str, np.ndarray]) -> None:
        """A participant keeps its data to itself (refused for it at set-up: ``exchange.at_window_end``)."""

    def coupling_state(self) -> None:
        """Nothing: the program keeps its own state."""
        return None

    def restore_coupling_state(self, state: Mapping[str, Any]) -> None:
        """Nothing to restore (``coupling_state`` is None)."""

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
             save: bool = False, free: int | None = None,
             waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> dict[str, np.ndarray]:
        self.send_step(t, dt, inputs, waveforms=waveforms)
        return self.receive_step()

    def check_outputs(self, arrays: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Write data as the participant's setup and its mesh declare it: float64 (preCICE's data are doubles);
        another type, a wrong shape, NaN or Inf is an error."""
        for name, value in arrays.items():
            if value.dtype != np.float64:
                raise ComponentError(self.name, f"wrote '{name}' as {value.dtype}; preCICE's data are float64")
        return checked_outputs(self.name, self.variables, arrays)

    # --- the end ------------------------------------------------------------------------------------------------
    def terminate(self) -> dict[str, np.ndarray]:
        """The coupling is over: answer the last ``advance`` so, and take the participant's ``finalize``."""
        if self._pending is None or self._pending.get("op") not in ("advance", "initialize"):
            return {}
        t, dt = self._window or (0.0, 0.0)
        self._answer({"ongoing": False, "window_complete": True, "window_start": t + dt, "window": dt,
                      "write_checkpoint": False, "read_checkpoint": False})
        header, _ = self._next("finalize", self.timeout)
        if header.get("op") != "finalize":
            raise ComponentError(self.name, f"called '{header.get('op')}' after the coupling ended, where finalize "
                                            "was expected")
        self._pending = header
        self._answer({})
        return {}

    def shutdown(self, timeout: float = 2.0) -> None:
        """Wait for the participant's process to exit by itself (the launcher stops it after that)."""
        if self._pending is not None and self.hub.identities.get(self.name) is not None:
            try:        # a participant still waiting (the run failed): the coupling is over
                self.hub.answer(self.name, self._pending.get("id"),
                                error="the coupling stopped (the run failed or was interrupted)")
            except zmq.ZMQError:
                pass
            self._pending = None
        if self.process is not None:
            deadline = time.monotonic() + timeout
            while self.process.poll() is None and time.monotonic() < deadline:
                time.sleep(0.01)

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        self._closed = True

    def take_over(self, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, np.ndarray]) -> None:
        raise CosimError(f"participant '{self.name}' cannot take a participant over from another backend")

    def output_names(self) -> list[str]:
        return [v.name for v in self.variables.values() if v.causality == "output"]

    def mesh_of(self, name: str) -> np.ndarray:
        variable = self.variables[name]
        return self.meshes[variable.mesh] if variable.mesh else np.zeros((0, 1))

    def lines_of(self, name: str) -> np.ndarray | None:
        """The edges the participant gave on that variable's mesh (a triangle's and a tetrahedron's among them)."""
        return self.elements.get(self.variables[name].mesh, {}).get("edges")

    def cells_of(self, name: str) -> np.ndarray | None:
        """Its cells: triangles on a 2-D mesh; tetrahedra on a 3-D one, else its triangles (a surface, for a
        projection)."""
        mesh = self.variables[name].mesh
        elements = self.elements.get(mesh, {})
        if self.meshes[mesh].shape[1] == 2:
            return elements.get("triangles")
        return elements.get("tetrahedra", elements.get("triangles"))

    def _elements(self, arrays: Mapping[str, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
        """The edges, triangles and tetrahedra sent with the vertices (``edges:MESH``, ...), checked."""
        elements: dict[str, dict[str, np.ndarray]] = {}
        for key, ids in arrays.items():
            kind, _, mesh = key.partition(":")
            if kind not in ELEMENTS:
                continue
            width = ELEMENTS[kind]
            count = len(self.meshes.get(mesh, ()))
            if mesh not in self.meshes or ids.dtype != np.int64 or ids.ndim != 2 or ids.shape[1] != width \
                    or (ids.size and (ids.min() < 0 or ids.max() >= count)):
                raise ComponentError(self.name, f"gave {kind} of mesh '{mesh}' as {ids.dtype} of shape {ids.shape}; "
                                                f"expected int64 rows of {width} ids of its {count} vertices")
            elements.setdefault(mesh, {})[kind] = ids
        return elements


def _seconds(value: Any, default: float) -> float:
    """A time a participant reports, if it is a finite number of seconds, else ``default`` (it is only recorded)."""
    if isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value):
        return float(value)
    return default


ELEMENTS = {"edges": 2, "triangles": 3, "tetrahedra": 4}     # the connectivity a participant sends: ids per element
MAX_MESSAGE = 400      # characters of a participant's message that an error line carries


def one_line(message: Any) -> str:
    """A message a participant sent, as one line of an error: its lines joined, at most ``MAX_MESSAGE`` characters."""
    text = " ".join(str(message).split())
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE - 3] + "..."
