"""The results file written by a process of its own: a finished window costs the coupler one write to a pipe.

``ResultsWriter`` (the coupler's side) starts ``python -m cosim.results_writer`` and hands it everything the file
holds as messages on the child's stdin (``cosim.protocol``'s frames, on a stream): the file's creation or
resumption, attributes, the components' descriptions, and each finished window's rows at the window's end. The
writer process wakes every ``BATCH_SECONDS``, or when the coupler rings its bell for a message it waits on (the
file's creation, a sync, the close), and appends the windows that have arrived through ``ResultsStore``, each
dataset once, then flushes. A window's write thus wakes no process. So:

- a window has left the coupler's process at its end: a coupler killed after it loses no more than the window in
  flight, since the writer reads its pipe to the end, writes what it holds and closes the file;
- a window is in the file and flushed within ``BATCH_SECONDS`` of its end;
- a window the disk has no room for is refused whole (``DiskFullError``, raised in the coupler at its next window,
  sync or close), with every window before it written;
- ``lengths`` (before a checkpoint) and ``close`` wait until everything sent is written.

After closing the file, the writer writes ``run.xdmf`` beside it (``cosim.xdmf``: the run as ParaView opens it)
and draws the run's plots (``run.png`` and the scene's own), having imported matplotlib in the background while the
run went on: the end of a run waits for the drawing only.
"""

from __future__ import annotations

import json
import os
import select
import subprocess
import sys
import threading
import traceback
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim import protocol
from cosim.errors import CosimError, DiskFullError

BATCH_SECONDS = 0.1          # the writer wakes this often (or when rung) and writes the windows that have arrived
PROMPT = frozenset({"open", "sync", "close"})    # messages the writer is woken for: the coupler waits on them
PIPE_BYTES = 1 << 20          # the pipe holds this much (Linux), some hundred windows of the tube
READ_BYTES = 1 << 20
LIVENESS_SECONDS = 0.05
PROJECT_ROOT = Path(__file__).resolve().parent.parent


class ResultsWriter:
    """The coupler's handle on the writer process; the calls of ``ResultsStore`` that a run makes."""

    def __init__(self, path: str | Path, log: str | Path, scene_text: str = "",
                 resume: tuple[Mapping[str, int], int] | None = None, plots: bool = True, lock: int | None = None):
        """Start the writer on ``path`` (created from ``scene_text``, or with ``resume`` = (lengths, windows) cut
        back to a checkpoint); ``plots``: the run will ask for its plots at ``close``; ``lock``: the run directory's
        lock, which the writer holds too, so that a run killed midway keeps its directory until its writer is done.
        Returns at once: ``ready`` waits for the file."""
        self.path = Path(path)
        self.log = Path(log)
        self.log.parent.mkdir(parents=True, exist_ok=True)
        environment = {**os.environ, "PYTHONPATH": os.pathsep.join(
            filter(None, [str(PROJECT_ROOT), os.environ.get("PYTHONPATH", "")]))}
        bell, self._bell = os.pipe()     # rung for the messages that want an answer now (the writer sleeps)
        try:
            with open(self.log, "ab") as stderr:
                self.process = subprocess.Popen(
                    [sys.executable, "-P", "-m", "cosim.results_writer", str(self.path), "--bell", str(bell)],
                    stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr, env=environment,
                    pass_fds=(bell,) if lock is None else (bell, lock),
                    start_new_session=True)   # Ctrl-C reaches the coupler only
        finally:
            os.close(bell)
        assert self.process.stdin is not None and self.process.stdout is not None
        self._input, self._output = self.process.stdin.fileno(), self.process.stdout.fileno()
        _widen(self._input)
        os.set_blocking(self._input, False)      # a full pipe rings the bell rather than wait for the writer's turn
        os.set_blocking(self._bell, False)
        self._replies = protocol.StreamReader()
        self._pending: list[dict[str, Any]] = []
        self.windows = resume[1] if resume else 0      # windows handed over (after an error: those written)
        self._closed = False      # close sent
        self._stopped = False     # the writer waited for
        self._send("open", {"path": str(self.path), "scene": scene_text, "plots": plots,
                            "resume": {"lengths": dict(resume[0]), "windows": resume[1]} if resume else None})

    # --- the file's content ---------------------------------------------------------------------------------------
    def ready(self) -> None:
        """Wait until the file is created (or cut back to the checkpoint); its error if it cannot be."""
        self._reply("open")

    def set_attributes(self, **attributes: Any) -> None:
        self._send("attributes", {"attributes": attributes})

    def add_to_attributes(self, **increments: float) -> None:
        self._send("add_to_attributes", {"attributes": increments})

    def add_component(self, name: str, pid: int | None, host: str, backend: str, endpoint: str = "",
                      **attributes: Any) -> None:
        self._send("component", {"name": name, "pid": pid, "host": host, "backend": backend, "endpoint": endpoint,
                                 **attributes})

    def write_description(self, component: str, variables: list[dict[str, Any]],
                          meshes: Mapping[str, np.ndarray]) -> None:
        self._send("description", {"component": component, "variables": json.dumps(variables)}, meshes)

    def write_initial(self, values: Mapping[str, np.ndarray]) -> None:
        self._send("initial", {}, values)

    def write_final(self, component: str, arrays: Mapping[str, np.ndarray]) -> None:
        self._send("final", {"component": component}, arrays)

    def append_window(self, time: float, iterations: int, converged: bool, wall_seconds: float,
                      fields: Mapping[str, np.ndarray], timings: Mapping[str, tuple[list[float], ...]],
                      snapshots: Mapping[str, Mapping[str, Any]], residuals: Sequence[float] = ()) -> None:
        """Hand one finished window over (``ResultsStore.append_window``); an error the writer met since the last
        call (a full disk) is raised here."""
        from cosim.results import window_rows
        rows = window_rows(self.windows + 1, time, iterations, converged, wall_seconds, fields, timings,
                           snapshots, residuals)
        self._send("window", {}, dict(rows))
        self.windows += 1
        self._check()

    def lengths(self) -> dict[str, int]:
        """Rows of every growing dataset once everything sent is written (a checkpoint's record)."""
        self._send("sync", {})
        return dict(self._reply("sync")["lengths"])

    def close(self, plots: Mapping[str, Any] | None = None, wait: bool = True) -> None:
        """Write what is left, close the file and, with ``plots`` ({"png", "output", "hooks", "folder"}), draw
        them; with ``wait``, wait for the writer to be done (else ``wait_closed`` does)."""
        if not self._closed:
            self._closed = True
            try:
                self._send("close", {"plots": dict(plots) if plots else None})
            except CosimError:
                self._stop()
                raise
        if wait:
            self.wait_closed()

    def wait_closed(self) -> None:
        """Wait for the writer to close the file and draw (after ``close(wait=False)``); raise its error."""
        if self._stopped:
            return
        try:
            self._reply("close")
        finally:
            self._stop()

    def abandon(self) -> None:
        """Let the writer finish on its own (it writes what it holds and closes the file at its pipe's end)."""
        self._closed = True
        self._stop()

    # --- the pipes ---------------------------------------------------------------------------------------------------
    def _send(self, op: str, args: Mapping[str, Any], arrays: Mapping[str, np.ndarray] | None = None) -> None:
        """Put a message in the pipe; one that wants an answer (or a pipe found full) rings the writer's bell."""
        if self._stopped:       # the writer has stopped on an error already raised: nothing more reaches the file
            raise CosimError(f"results: the writer of '{self.path}' has stopped")
        view = memoryview(protocol.to_stream(protocol.encode({"op": op, "args": dict(args)}, arrays)))
        try:
            while view:
                try:
                    view = view[os.write(self._input, view):]
                except BlockingIOError:
                    self._ring()
                    while not select.select([], [self._input], [], LIVENESS_SECONDS)[1]:
                        if self.process.poll() is not None:
                            raise BrokenPipeError from None
            if op in PROMPT:
                self._ring()
        except BrokenPipeError:
            raise self._died() from None

    def _ring(self) -> None:
        try:
            os.write(self._bell, b"\0")
        except BlockingIOError:      # rung many times already, unanswered: the writer wakes anyway
            pass

    def _check(self) -> None:
        """Raise an error the writer reported, without waiting."""
        self._read(0.0)
        self._raise_error()

    def _raise_error(self) -> None:
        """Raise the first error the writer reported, once."""
        for i, reply in enumerate(self._pending):
            if "error" in reply:
                del self._pending[i]
                self.windows = int(reply.get("windows", self.windows))     # what the file holds
                raise self._error(reply)

    def _reply(self, op: str) -> dict[str, Any]:
        """Wait for the reply to ``op`` (an error the writer reported first is raised)."""
        while True:
            self._raise_error()
            for i, reply in enumerate(self._pending):
                if reply.get("reply") == op:
                    del self._pending[i]
                    return reply
            if not self._read(LIVENESS_SECONDS) and self.process.poll() is not None:
                raise self._died()

    def _read(self, timeout: float) -> bool:
        """Take the replies that have arrived within ``timeout``; False when none did."""
        if not select.select([self._output], [], [], timeout)[0]:
            return False
        data = os.read(self._output, READ_BYTES)
        if not data:
            self.process.wait()
            raise self._died()
        for frames in self._replies.feed(data):
            self._pending.append(protocol.decode(frames)[0])
        return True

    def _error(self, reply: Mapping[str, Any]) -> CosimError:
        kind, message = reply.get("kind", ""), str(reply["error"])
        if kind == "DiskFullError":
            return DiskFullError(message)
        if kind == "CosimError":
            return CosimError(message)
        return CosimError(f"the results file's writer failed: {kind}: {message} (its log: {self.log})")

    def _died(self) -> CosimError:
        code = self.process.wait()
        try:
            tail = self.log.read_text(errors="replace").strip().splitlines()[-3:]
        except OSError:
            tail = []
        said = f": {' | '.join(tail)}" if tail else ""
        return CosimError(f"the results file's writer (pid {self.process.pid}) exited with code {code} while "
                          f"'{self.path}' was written{said} (its log: {self.log})")

    def _stop(self) -> None:
        if self._stopped:
            return
        self._stopped = True
        os.close(self._bell)
        for stream in (self.process.stdin, self.process.stdout):
            if stream is not None:
                try:
                    stream.close()
                except OSError:
                    pass
        self.process.wait()


def _widen(fd: int) -> None:
    """Give the pipe ``PIPE_BYTES`` where the system allows (Linux): the writer may lag that far behind."""
    import fcntl
    try:
        fcntl.fcntl(fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), PIPE_BYTES)
    except OSError:
        pass


# --- the writer process --------------------------------------------------------------------------------------------
class _Writer:
    """Applies the coupler's messages to a ``ResultsStore``; windows are batched."""

    def __init__(self, replies: int):
        self.replies = replies
        self.store: Any = None
        self.failed: dict[str, Any] | None = None     # the error that stopped the writing
        self.windows: list[Any] = []          # windows received, not written yet
        self.plots = False
        self._importer: threading.Thread | None = None

    def reply(self, header: dict[str, Any]) -> None:
        data = memoryview(protocol.to_stream(protocol.encode(header)))
        try:
            while data:
                data = data[os.write(self.replies, data):]
        except BrokenPipeError:     # the coupler is gone: nobody to tell
            pass

    def fail(self, exc: BaseException) -> None:
        """Report an error; the windows after it are dropped (the file keeps whole windows), the rest goes on."""
        kind = "DiskFullError" if isinstance(exc, DiskFullError) else "CosimError" if isinstance(exc, CosimError) \
            else type(exc).__name__
        if isinstance(exc, OSError) and not isinstance(exc, CosimError):
            kind, message = "CosimError", f"cannot write '{getattr(self.store, 'path', '')}': {exc.strerror or exc}"
        else:
            message = str(exc)
        if kind not in ("DiskFullError", "CosimError"):
            traceback.print_exc(file=sys.stderr)
        self.failed = {"error": message, "kind": kind,
                       "windows": self.store.windows_written if self.store is not None else 0}
        self.windows = []
        self.reply(self.failed)

    def write_windows(self) -> None:
        if self.windows and self.store is not None and not self.failed:
            windows, self.windows = self.windows, []
            try:
                self.store.append_windows(windows)
            except Exception as exc:
                self.fail(exc)
            self._import_plotting()
        self.windows = []

    def handle(self, header: dict[str, Any], arrays: dict[str, np.ndarray]) -> bool:
        """Apply one message; False once the writer is done (``close``)."""
        op, args = str(header.get("op")), header.get("args") or {}
        if op == "window":
            if not self.failed:
                self.windows.append(list(arrays.items()))
            return True
        self.write_windows()        # in order: what was sent before this message is written first
        if op == "open":
            self.open(args)
        elif op == "sync":
            self.reply(self.failed or {"reply": "sync", "lengths": self.store.lengths()})
        elif op == "close":
            self.close(args.get("plots"))
            return False
        elif self.store is not None:
            try:
                self.apply(op, args, arrays)
            except Exception as exc:
                if not self.failed:        # a failed run's last attributes are best effort
                    self.fail(exc)
        return True

    def open(self, args: dict[str, Any]) -> None:
        from cosim.results import ResultsStore
        self.plots = bool(args.get("plots"))
        try:
            resume = args.get("resume")
            if resume:
                self.store = ResultsStore.resume(args["path"], resume["lengths"], resume["windows"])
            else:
                self.store = ResultsStore(args["path"], args.get("scene", ""))
        except OSError as exc:
            self.fail(CosimError(f"cannot create '{args['path']}': {exc.strerror or exc}"))
            return
        except Exception as exc:
            self.fail(exc)
            return
        self.reply({"reply": "open"})

    def apply(self, op: str, args: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        store = self.store
        if op == "attributes":
            store.set_attributes(**args["attributes"])
        elif op == "add_to_attributes":
            store.add_to_attributes(**args["attributes"])
        elif op == "component":
            store.add_component(**args)
        elif op == "description":
            store.write_description(args["component"], json.loads(args["variables"]), arrays)
        elif op == "initial":
            store.write_initial(arrays)
        elif op == "final":
            store.write_final(args["component"], arrays)
        else:
            raise CosimError(f"unknown message {op!r}")

    def close(self, plots: dict[str, Any] | None) -> None:
        if self.store is not None:
            try:
                self.store.close()
                from cosim.xdmf import write_xdmf
                write_xdmf(self.store.path)
            except Exception as exc:
                if not self.failed:
                    self.fail(exc)
        if plots and not self.failed and self.store is not None:
            try:
                draw_plots(plots)
            except Exception as exc:
                self.fail(exc)
                return
        self.reply({"reply": "close"})

    def _import_plotting(self) -> None:
        """Import what drawing the plots needs, in the background, once the run is under way."""
        if self.plots and self._importer is None:
            self._importer = threading.Thread(target=_import_plotting, daemon=True)
            self._importer.start()


def _import_plotting() -> None:
    import cosim.plots  # noqa: F401
    cosim.plots.import_matplotlib()


def draw_plots(plots: Mapping[str, Any]) -> None:
    """``run.png`` and the scene's own run plots (``cosim.run_plots`` entry points by name)."""
    from cosim.plots import plot_run
    from cosim.registry import entry_points
    results = Path(plots["folder"]) / "results.h5"
    if plots["png"]:
        plot_run(results, plots["png"], plots["output"])
    if plots["output"].get("watch_points"):
        from cosim.watch_points import write as write_watch_points
        write_watch_points(results, plots["folder"], plots["output"]["watch_points"])
    available = {e.name: e for e in entry_points(group="cosim.run_plots")}
    for name in plots.get("hooks") or ():
        available[name].load()(results, Path(plots["folder"]))


def serve(commands: int, bell: int, replies: int) -> int:
    """Apply the messages read from ``commands`` until ``close`` or the pipe's end, every ``BATCH_SECONDS`` or when
    ``bell`` rings (the coupler waits on the message); replies go to ``replies``."""
    writer = _Writer(replies)
    reader = protocol.StreamReader()
    os.set_blocking(commands, False)
    try:
        while True:
            if select.select([bell], [], [], BATCH_SECONDS)[0]:
                os.read(bell, 4096)      # an empty read: the coupler is gone; its pipe is read to the end below
            while True:
                try:
                    data = os.read(commands, READ_BYTES)
                except BlockingIOError:
                    break
                if not data:            # the coupler closed the pipe or died: what it sent is written, the file closed
                    writer.write_windows()
                    writer.close(None)
                    return 0
                for frames in reader.feed(data):
                    header, arrays = protocol.decode(frames)
                    if not writer.handle(header, arrays):
                        return 0
            writer.write_windows()
    finally:
        if writer.store is not None:
            writer.store.close()


def main() -> int:
    """``python -m cosim.results_writer RESULTS.h5 --bell FD``: the path names the run in a process list (the file
    is the one the coupler's ``open`` message names); FD is the read end of the coupler's bell."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)     # the coupler decides when the run stops
    bell = int(sys.argv[sys.argv.index("--bell") + 1])
    replies = os.dup(sys.stdout.fileno())
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())   # whatever a library prints goes to the log, not the replies
    return serve(sys.stdin.fileno(), bell, replies)


if __name__ == "__main__":
    sys.exit(main())
