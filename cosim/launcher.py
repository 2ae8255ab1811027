"""Start components as child processes and make sure none outlives the run.

Each child runs ``python -m cosim serve ENTRY --bind tcp://127.0.0.1:*`` in its
own session (so Ctrl-C reaches only the coupler, which then stops the children
in order), writes its stderr to a log file and reports its endpoint with a JSON
handshake line. ``Launcher`` is a context manager: on every exit path (normal
end, error, Ctrl-C, SIGTERM) it terminates, then kills, every child. Children
also exit by themselves when their parent process disappears.
"""

from __future__ import annotations

import atexit
import json
import os
import secrets
import selectors
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from cosim import stop
from cosim.component import RUN_DIR_VARIABLE
from cosim.errors import ComponentDied, ComponentError

PROJECT_ROOT = Path(__file__).resolve().parent.parent
TOKEN_VARIABLE = "COSIM_SHUTDOWN_TOKEN"   # read (and removed from its environment) by `cosim serve`

TAIL_BYTES = 1 << 24     # of a log read for its last lines (read only when a process failed)
TAIL_WIDTH = 400         # characters of a line an error quotes


@dataclass
class ComponentProcess:
    """A started component: its process, endpoint and log."""

    name: str
    popen: subprocess.Popen
    log_path: Path
    endpoint: str = ""
    token: str = ""      # the run's secret its requests carry (given in the environment, never on argv)

    @property
    def pid(self) -> int:
        return self.popen.pid

    def poll(self) -> int | None:
        return self.popen.poll()

    def stderr_tail(self, lines: int = 15, width: int = TAIL_WIDTH) -> str:
        """The last ``lines`` lines of its log, each cut to ``width`` characters (a process may print megabytes on
        one line)."""
        try:
            with open(self.log_path, "rb") as stream:
                start = max(stream.seek(0, 2) - TAIL_BYTES, 0)
                stream.seek(start)
                text = ("..." if start else "") + stream.read().decode(errors="replace")
        except OSError:
            return ""
        return "\n".join(line if len(line) <= width else f"{line[:width]}... ({len(line) - width} more characters)"
                         for line in text.splitlines()[-lines:])


class Launcher:
    """Starts local components and stops all of them on exit."""

    def __init__(self, log_dir: Path, startup_timeout: float = 30.0):
        self.log_dir = Path(log_dir)
        self.startup_timeout = startup_timeout
        self.processes: list[ComponentProcess] = []
        self._scratch: Path | None = None      # the processes' temporary folder (TMPDIR), removed with them

    def scratch(self, name: str) -> str:
        """A temporary folder of the process ``name`` (its TMPDIR): what it leaves there goes when the run stops,
        however the process ended."""
        if self._scratch is None:
            import tempfile
            self._scratch = Path(tempfile.mkdtemp(prefix="cosim-run-"))
        folder = self._scratch / name
        folder.mkdir(exist_ok=True)
        return str(folder)

    def __enter__(self) -> Launcher:
        atexit.register(self.stop_all)
        self._stops = stop.handling_stops()     # Ctrl-C and SIGTERM stop the run at its next safe point
        self._stops.__enter__()
        return self

    def __exit__(self, *exc_info) -> None:
        try:
            self.stop_all()
        finally:
            atexit.unregister(self.stop_all)
            self._stops.__exit__(None, None, None)

    def spawn(self, name: str, entry: str, environment: dict[str, str] | None = None,
              cores: Sequence[int] = (), import_paths: Sequence[str | Path] = ()) -> ComponentProcess:
        """Start one component with extra ``environment`` variables, on ``cores`` if given, its module looked for in
        ``import_paths`` (a scene's folder) before the installed packages; returns before its handshake."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        log_path = self.log_dir / f"{name}.log"
        env = {**os.environ, "TMPDIR": self.scratch(name), **(environment or {})}     # the scene's TMPDIR wins
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(PROJECT_ROOT), env.get("PYTHONPATH", "")]))
        token = secrets.token_hex(16)
        env[TOKEN_VARIABLE] = token
        env[RUN_DIR_VARIABLE] = str(self.log_dir.parent.resolve())
        # -P: no working directory before our packages (a scene's `cosim.py` must not run as cosim); the scene's
        # folders come first for its own modules, inside the server (--folder)
        command = [sys.executable, "-P", "-m", "cosim", "serve", entry, "--bind", "tcp://127.0.0.1:*",
                   "--name", name, "--parent-pid", str(os.getpid()),
                   *(f"--folder={folder}" for folder in import_paths)]
        with open(log_path, "wb") as log:
            popen = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log,
                                     env=env, start_new_session=True)
        process = ComponentProcess(name, popen, log_path, token=token)
        self.processes.append(process)
        if cores:
            try:
                os.sched_setaffinity(popen.pid, cores)   # before it imports its solver (its threads inherit)
            except ProcessLookupError:
                pass                                     # gone already: the handshake reports how
        return process

    def spawn_command(self, name: str, command: str, cwd: str | Path, environment: dict[str, str] | None = None,
                      cores: Sequence[int] = ()) -> ComponentProcess:
        """Start a program that connects to the coupler itself (a preCICE participant): ``command`` split as a shell
        would, in ``cwd``, its output to its log. ``environment``'s ``PYTHONPATH`` and ``LD_LIBRARY_PATH`` go before
        the inherited ones."""
        import shlex
        self.log_dir.mkdir(parents=True, exist_ok=True)
        log_path = self.log_dir / f"{name}.log"
        extra = dict(environment or {})
        env = {**os.environ, "TMPDIR": self.scratch(name), **extra}
        for name in ("PYTHONPATH", "LD_LIBRARY_PATH"):
            joined = os.pathsep.join(filter(None, [extra.get(name, ""), os.environ.get(name, "")]))
            if joined:
                env[name] = joined
        # `python3` in a participant's command is the coupler's Python (a full path names another)
        env["PATH"] = os.pathsep.join(filter(None, [str(Path(sys.executable).parent), env.get("PATH", "")]))
        try:
            argv = shlex.split(command)
        except ValueError as exc:
            raise ComponentError(name, f"its command {command!r} cannot be split into words: {exc}") from None
        if not argv:
            raise ComponentError(name, "its command is empty")
        with open(log_path, "wb") as log:
            try:
                popen = subprocess.Popen(argv, cwd=cwd, stdin=subprocess.DEVNULL, stdout=log, stderr=log, env=env,
                                         start_new_session=True)
            except OSError as exc:
                raise ComponentError(name, f"its command {argv[0]!r} cannot start in '{cwd}': "
                                           f"{exc.strerror or exc}") from None
        process = ComponentProcess(name, popen, log_path)
        self.processes.append(process)
        if cores:
            try:
                os.sched_setaffinity(popen.pid, cores)
            except ProcessLookupError:
                pass
        return process

    def handshake(self, process: ComponentProcess) -> str:
        """Wait for the component's endpoint line; errors name the component."""
        deadline = time.monotonic() + self.startup_timeout
        stdout = process.popen.stdout
        assert stdout is not None      # spawned with stdout=PIPE
        selector = selectors.DefaultSelector()
        selector.register(stdout, selectors.EVENT_READ)
        buffer = b""
        try:
            while b"\n" not in buffer:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise ComponentError(process.name, f"did not start within {self.startup_timeout:g} s "
                                                       f"(log: {process.log_path})")
                stop.check()
                if selector.select(min(remaining, 0.1)):
                    chunk = os.read(stdout.fileno(), 4096)
                    if not chunk:
                        process.popen.wait(timeout=5)
                        raise ComponentDied(process.name, process.poll(), process.stderr_tail(), str(process.log_path))
                    buffer += chunk
                elif process.poll() is not None:
                    raise ComponentDied(process.name, process.poll(), process.stderr_tail(), str(process.log_path))
        finally:
            selector.close()
        try:
            info = json.loads(buffer.split(b"\n", 1)[0])
        except ValueError:
            raise ComponentError(process.name, f"sent a malformed handshake {buffer[:200]!r}") from None
        process.endpoint = info["endpoint"]
        stdout.close()
        return process.endpoint

    def stop_all(self, grace: float = 2.0) -> None:
        """Terminate every child's process group that has a process left (the child's own children too, after
        the child itself has exited); kill those that do not exit within ``grace``."""
        for p in self.processes:
            p.poll()                    # an exited child is reaped: its group is the processes it left behind
        running = [p for p in self.processes if _group_alive(p.popen.pid)]
        for p in running:
            _signal(p.popen, signal.SIGTERM)
        deadline = time.monotonic() + grace
        for p in running:
            while _group_alive(p.popen.pid) and time.monotonic() < deadline:
                p.poll()
                time.sleep(0.01)
            if _group_alive(p.popen.pid):
                _signal(p.popen, signal.SIGKILL)
                p.popen.wait()
        for p in self.processes:
            if p.popen.stdout and not p.popen.stdout.closed:
                p.popen.stdout.close()
        if self._scratch is not None:
            import shutil
            shutil.rmtree(self._scratch, ignore_errors=True)
            self._scratch = None


def _group_alive(group: int) -> bool:
    """Whether the process group has a process left (a zombie leader not yet reaped counts)."""
    try:
        os.killpg(group, 0)
    except (ProcessLookupError, PermissionError):
        return False
    return True


def _signal(popen: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(popen.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


