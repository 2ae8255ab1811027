"""``cosim serve``: put any Component class behind a ZeroMQ ROUTER socket.

The server binds, prints one JSON handshake line ``{"endpoint", "pid", "name"}``
on stdout, then answers requests until ``shutdown``, until its parent process is
gone, or until it is killed. Every reply carries the time spent inside the
component (``compute_seconds``). A malformed request gets an error reply; the
server never crashes on input.
"""

from __future__ import annotations

import hmac
import importlib
import importlib.util
import ipaddress
import json
import os
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import zmq

from cosim import protocol, stop
from cosim.checkpoint import pack, unpack
from cosim.component import Component
from cosim.errors import ComponentError, CosimError, ProtocolError
from cosim.launcher import TOKEN_VARIABLE
from cosim.subcycling import WindowInputs, split_waveforms, subcycle

PARENT_CHECK_SECONDS = 0.5


class EntryImportError(CosimError):
    """An entry's module cannot be imported (here: its own process may still find it)."""


SCENE_MODULES = "cosim_scene_modules"    # where a scene's module goes when its name is taken in this process


def _scene_module_file(name: str, folders: Sequence[Path]) -> Path | None:
    """The file of module ``name`` in the first of ``folders`` that has it (``a/b.py`` or ``a/b/__init__.py``)."""
    for folder in folders:
        path = Path(folder, *name.split("."))
        for candidate in (path.with_suffix(".py"), path / "__init__.py"):
            if candidate.is_file():
                return candidate.resolve()
    return None


def _file_of(module: ModuleType) -> Path | None:
    file = getattr(module, "__file__", None)
    return Path(file).resolve() if file else None


def _load_scene_module(name: str, path: Path) -> ModuleType | None:
    """The module ``name`` loaded from ``path``: under its own name, or, where this process has loaded another
    module of that name already (one of ours, or a library), under ``cosim_scene_modules.<name>``, so that the
    scene's module is the one loaded and shadows nothing. None if it imports what only its own process finds."""
    for key in (name, f"{SCENE_MODULES}.{name}"):
        loaded = sys.modules.get(key)
        if loaded is not None and _file_of(loaded) == path:
            return loaded
    taken = name in sys.modules or name.split(".")[0] in sys.modules
    key = f"{SCENE_MODULES}.{name}" if taken else name
    spec = importlib.util.spec_from_file_location(key, path)
    if spec is None or spec.loader is None:
        return None
    module = importlib.util.module_from_spec(spec)
    sys.modules[key] = module            # as an import would (dataclasses look their module up there)
    try:
        spec.loader.exec_module(module)
    except ImportError:                   # it imports what only its own process finds
        del sys.modules[key]
        return None
    return module


def load_entry(entry: str, folders: Sequence[Path] = ()) -> type:
    """The class named by ``"package.module:Class"``. A module with its file in one of ``folders`` (beside the
    scene) is loaded from there first, whatever is installed under its name; any other is imported."""
    module_name, sep, class_name = entry.partition(":")
    if not sep or not module_name or not class_name:
        raise CosimError(f"entry '{entry}' is not of the form 'package.module:Class'")
    module: ModuleType | None = None
    path = _scene_module_file(module_name, folders)
    if path is not None:
        module = _load_scene_module(module_name, path)
    if module is None:
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:
            raise EntryImportError(f"entry '{entry}': cannot import module '{module_name}': {exc} (a module of your "
                                   "own goes next to the scene file, or on PYTHONPATH)") from None
    cls = getattr(module, class_name, None)
    if cls is None:
        where = f" ({path})" if path is not None and _file_of(module) == path else ""
        raise CosimError(f"entry '{entry}': module '{module_name}'{where} has no '{class_name}'")
    if not (isinstance(cls, type) and issubclass(cls, Component)):
        raise CosimError(f"entry '{entry}': '{class_name}' is not a component class (a subclass of "
                         "cosim.component.Component)")
    return cls


TRANSPORTS = ("tcp", "ipc")


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address, without brackets) is this machine's loopback."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_bind_address(address: str, curve: bool = False) -> None:
    """Refuse an unknown transport, and a TCP bind to anything but loopback without CURVE."""
    transport, sep, _ = address.partition("://")
    if not sep or transport not in TRANSPORTS:
        raise CosimError(f"bind address '{address}' is not of the form tcp://HOST:PORT or ipc://PATH "
                         "(transports are lower case)")
    if transport != "tcp" or curve:
        return
    if not is_loopback(address[len("tcp://"):].rsplit(":", 1)[0].strip("[]")):
        raise CosimError(f"refusing to bind '{address}' without CURVE: a non-loopback address is served only with "
                         "--curve DIR (keys from `cosim keys DIR`)")


def bind_socket(bind: str, max_bytes: int = protocol.MAX_MESSAGE_BYTES, curve: str | None = None) -> zmq.Socket:
    """A ROUTER bound to ``bind`` that drops any frame over ``max_bytes`` before allocating it; with ``curve`` (a
    key directory) a CURVE server with its key."""
    socket: zmq.Socket = zmq.Context.instance().socket(zmq.ROUTER)
    socket.setsockopt(zmq.LINGER, 1000)
    socket.setsockopt(zmq.MAXMSGSIZE, max_bytes)
    try:
        if curve:
            from cosim.curve import curve_server
            curve_server(socket, curve)
        socket.bind(bind)
    except zmq.ZMQError as exc:
        socket.close()
        raise CosimError(f"cannot bind '{bind}': {exc}") from None
    except CosimError:
        socket.close()
        raise
    return socket


class ComponentServer:
    """Dispatches decoded requests to a component instance."""

    def __init__(self, component: Component, token: str = ""):
        self.component = component
        # a launched component's run secret: a client is served once one of its requests carries it. Without one
        # (served by hand), the first client that asks more than a ping is served, and no other
        self.token = token
        self.owner: bytes | None = None      # the one client served
        c = component
        self.handlers: dict[str, Callable[[dict, dict], Any]] = {
            "describe": lambda a, arr: {**c.describe(), "step_saves_state": True},
            "instantiate": lambda a, arr: c.instantiate(a.get("parameters", {})),
            "enter_initialization_mode": lambda a, arr: c.enter_initialization_mode(protocol.number(a, "start"),
                                                                                    protocol.number(a, "stop")),
            "exit_initialization_mode": lambda a, arr: c.exit_initialization_mode(),
            "set_values": lambda a, arr: c.set_values(real_inputs(arr)),
            "get_values": lambda a, arr: c.get_values(a["names"]),
            "do_step": lambda a, arr: c.do_step(protocol.number(a, "t"), protocol.number(a, "dt")),
            "end_window": lambda a, arr: c.end_window(real_inputs(arr)),
            "step": self._step,
            "get_state": lambda a, arr: {"handle": c.get_state()},
            "set_state": lambda a, arr: c.set_state(a["handle"]),
            "free_state": lambda a, arr: c.free_state(a["handle"]),
            "checkpoint": self._checkpoint,
            "restore_checkpoint": lambda a, arr: c.restore_checkpoint(unpack(json.loads(a["document"]), arr)),
            "take_over": self._take_over,
            "terminate": lambda a, arr: c.terminate(),
            "ping": lambda a, arr: {"pid": os.getpid()},
            "shutdown": self._shutdown,
        }

    def _checkpoint(self, args: dict, arrays: dict) -> dict[str, Any]:
        document, state_arrays = pack(self.component.checkpoint())
        return {"document": json.dumps(document), **state_arrays}

    def _take_over(self, args: dict, arrays: dict) -> None:
        inputs = {name[len("in:"):]: value for name, value in arrays.items() if name.startswith("in:")}
        outputs = {name[len("out:"):]: value for name, value in arrays.items() if name.startswith("out:")}
        self.component.take_over(inputs, outputs)

    def _shutdown(self, args: dict, arrays: dict) -> None:
        """Stop serving (the client was admitted: see ``admit``)."""

    def admit(self, peer: bytes, op: str, args: dict) -> None:
        """Serve ``peer``'s request only if it is the one client this component serves (or it becomes that client
        now); a refusal is an error reply naming why."""
        if peer == self.owner:
            return
        if self.owner is not None:
            raise ProtocolError(f"'{op}' refused: this component serves another client (the run that "
                                f"{'launched' if self.token else 'first reached'} it)")
        if self.token:
            if not hmac.compare_digest(str(args.get("token", "")), self.token):
                raise ProtocolError(f"'{op}' refused: only the run that launched this component may drive it")
            self.owner = peer
        elif op != "ping":          # served by hand: anyone may ping; the first to ask more is the client
            self.owner = peer

    def _step(self, args: dict, arrays: dict) -> Any:
        """``step``, with the state handling of an implicit window fused in: ``free`` a state handle, ``restore``
        one, ``save`` the state before stepping (its handle is the result's ``state``)."""
        component = self.component
        free, restore = args.get("free"), args.get("restore")
        if free is not None:
            component.free_state(free)
        if restore is not None:
            component.set_state(restore)
        saved = component.get_state() if args.get("save") else None
        t, dt = protocol.number(args, "t"), protocol.number(args, "dt")
        inputs, splines = split_waveforms(real_inputs(arrays), args.get("knots") or {})
        substeps = int(args.get("substeps") or 1)
        if substeps > 1 or splines:
            outputs = subcycle(component, t, dt, WindowInputs(t, dt, inputs, splines, substeps), substeps,
                               bool(args.get("record_steps")))
        else:
            outputs = component.served_step(t, dt, inputs)
        return outputs if saved is None else {**outputs, "state": saved}

    def handle(self, frames: list, peer: bytes = b"") -> tuple[list, bool]:
        """Reply frames for one request from the client ``peer`` (its routing id), and whether to stop serving."""
        request_id = None
        try:
            header, arrays = protocol.decode(frames)
            request_id = header.get("id")
            op = header.get("op")
            if op not in protocol.OPS:
                raise ProtocolError(f"unknown op {op!r}")
            args = header.get("args") or {}
            if not isinstance(args, dict):
                raise ProtocolError("'args' is not a map")
            self.admit(peer, str(op), args)
            start, cpu = time.perf_counter(), time.process_time()
            result = self.handlers[op](args, arrays)
            compute, cpu = time.perf_counter() - start, time.process_time() - cpu
            stop = op == "shutdown"   # only once the handler accepted it
        except Exception as exc:  # every failure becomes an error reply
            logged = not isinstance(exc, (CosimError, KeyError, ValueError, TypeError))
            if logged:
                traceback.print_exc(file=sys.stderr)
            kind = type(exc).__name__
            message = f"missing argument {exc}" if isinstance(exc, KeyError) else \
                exc.detail if isinstance(exc, ComponentError) else str(exc)
            return protocol.error_reply(request_id, kind, message, self.component.name, logged), False
        values: dict[str, Any] = {}
        out_arrays: dict[str, np.ndarray] = {}
        if isinstance(result, dict):
            for key, value in result.items():
                (out_arrays if isinstance(value, np.ndarray) else values)[key] = value
        reply = {"id": request_id, "ok": True, "result": values, "compute_seconds": compute, "cpu_seconds": cpu}
        warnings = self.component.take_warnings()
        if warnings:
            reply["warnings"] = warnings
        return protocol.encode(reply, out_arrays), stop


def real_inputs(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Inputs as they must come over the wire: every variable is real, float64 (FMI's Real)."""
    for name, value in arrays.items():
        if value.dtype != np.float64:
            raise ProtocolError(f"input '{name}' is {value.dtype}; every variable is float64")
    return arrays


def run_idle(component: Component) -> None:
    """The component's idle work; if it fails, one line on stderr and no more idle calls (it is optional)."""
    try:
        component.idle()
    except Exception as exc:
        print(f"{component.name}: idle work failed, stopped: {exc}", file=sys.stderr)
        component.idle_interval = None


def serve(entry: str, bind: str, name: str | None = None, parent_pid: int | None = None,
          curve: str | None = None, folders: Sequence[Path] = ()) -> int:
    """Serve ``entry`` on ``bind`` until shutdown (with ``curve``, a key directory: CURVE on); the modules of
    ``folders`` (a scene's folder), then of the working directory, come before the installed ones. Returns the exit
    code."""
    check_bind_address(bind, curve=bool(curve))
    with stop.handling_stops():   # SIGTERM (the launcher's stop) ends the loop: atexit and finally blocks run
        return _serve(entry, bind, name, parent_pid, curve, [*folders, Path.cwd()])


def _exit_with_parent(parent_pid: int, name: str) -> None:
    """A component stuck in a step cannot see from the serving loop that its coupler is gone: this thread does,
    and ends the process a few checks later if the loop has not (no component outlives its run)."""
    while os.getppid() == parent_pid:
        time.sleep(PARENT_CHECK_SECONDS)
    time.sleep(4 * PARENT_CHECK_SECONDS)
    print(f"{name}: parent process {parent_pid} is gone while a request was being served; exiting", file=sys.stderr)
    sys.stderr.flush()
    os._exit(1)


def _serve(entry: str, bind: str, name: str | None, parent_pid: int | None, curve: str | None,
           folders: Sequence[Path]) -> int:
    sys.path[:0] = [str(folder) for folder in folders]   # what the scene's module imports beside it comes first too
    component = load_entry(entry, folders)()
    if name:
        component.name = name
    server = ComponentServer(component, os.environ.pop(TOKEN_VARIABLE, ""))
    authenticator = None
    if curve:     # the handler that checks client keys runs before the socket takes any connection
        from cosim.curve import start_authenticator
        authenticator = start_authenticator(curve)
    try:
        socket = bind_socket(bind, curve=curve)
    except CosimError:
        if authenticator is not None:
            authenticator.stop()
        raise
    endpoint = socket.getsockopt_string(zmq.LAST_ENDPOINT)
    sys.stdout.write(json.dumps({"endpoint": endpoint, "pid": os.getpid(), "name": component.name,
                                 "curve": bool(curve)}) + "\n")
    sys.stdout.flush()
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # later prints go to the log, not the handshake pipe
    if parent_pid is not None:
        import threading
        threading.Thread(target=_exit_with_parent, args=(parent_pid, component.name), daemon=True).start()
    parent_checked = time.monotonic()
    timeout_ms = -1
    try:
        while True:
            stop.check()
            interval = component.idle_interval
            wait = PARENT_CHECK_SECONDS if interval is None else min(interval, PARENT_CHECK_SECONDS)
            if round(wait * 1000) != timeout_ms:       # a blocking receive with a timeout: no poll per request
                timeout_ms = max(1, round(wait * 1000))
                socket.setsockopt(zmq.RCVTIMEO, timeout_ms)
            try:
                identity, *frames = socket.recv_multipart()
            except zmq.Again:
                if interval is not None:
                    run_idle(component)
                if time.monotonic() - parent_checked >= PARENT_CHECK_SECONDS:
                    parent_checked = time.monotonic()
                    if parent_pid is not None and os.getppid() != parent_pid:
                        print(f"{component.name}: parent process {parent_pid} is gone; exiting", file=sys.stderr)
                        return 3
                continue
            reply, done = server.handle(frames, identity)
            socket.send_multipart([identity, *reply], copy=False)
            if done:
                return 0
    finally:
        socket.close()
        if authenticator is not None:
            authenticator.stop()
