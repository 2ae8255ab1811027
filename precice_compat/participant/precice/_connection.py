"""A participant's connection to cosim's coupler: one request at a time, each waiting for its reply.

``cosim run`` starts a participant with ``COSIM_PARTICIPANT_ENDPOINT`` (the coupler's loopback address) and
``COSIM_PARTICIPANT_TOKEN`` (the run's secret) in its environment. A participant started by hand finds them in
``cosim-run/coupler.json`` next to its configuration, which the coupler writes (``cosim run CONFIG.xml``); the first
participant started by hand starts that coupler if none runs. While it waits, the participant checks every half second that the coupler still runs, and
stops if it is gone: a coupler's death leaves no participant behind.
"""

from __future__ import annotations

import json
import os
import stat
import time
import weakref
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import zmq

from precice import _wire

ENDPOINT = "COSIM_PARTICIPANT_ENDPOINT"
TOKEN = "COSIM_PARTICIPANT_TOKEN"
COUPLER_PID = "COSIM_COUPLER_PID"
RUN_FILE = Path("cosim-run") / "coupler.json"     # next to the configuration
SLICE_MS = 500
FIND_SECONDS = 60.0


class Error(RuntimeError):
    """A misuse of the API, or the coupling stopped: the message names the call and why."""


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, exited and not yet reaped by its parent, does not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return _proc(pid, "stat").rpartition(")")[2][1:2] != "Z"


def _proc(pid: int | str, what: str) -> str:
    """``/proc/<pid>/<what>`` ('' where there is none: another system, or the process is gone)."""
    try:
        return Path(f"/proc/{pid}/{what}").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def _running(path: Path) -> tuple[str, str, int] | None:
    """(endpoint, token, pid) of the live cosim coupler ``path`` names, or None (no file, or a stale one). A file
    that another user could have written is not trusted: an error says so."""
    try:
        status = path.lstat()
    except OSError:
        return None
    if not stat.S_ISREG(status.st_mode) or status.st_uid != os.getuid() or status.st_mode & 0o022:
        raise Error(f"{path} is not trusted: it {'is not a regular file' if not stat.S_ISREG(status.st_mode) else 'belongs to another user' if status.st_uid != os.getuid() else 'can be written by others'}, "
                    "so it may name another's coupler; remove it, or run in a folder of your own")
    try:
        found = json.loads(path.read_text())
        pid = int(found["pid"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    command = _proc(pid, "cmdline")
    if not _alive(pid) or (command and "cosim" not in command):     # gone, or the pid is another program's now
        return None
    endpoint = str(found.get("endpoint", ""))
    if not _listens(pid, endpoint):         # another run's coupler, or a file that names the wrong address
        return None
    return endpoint, str(found.get("token", "")), pid


def _listens(pid: int, endpoint: str) -> bool:
    """Whether process ``pid`` listens at the TCP ``endpoint`` (tcp://host:port), from /proc; True where /proc
    cannot tell (another system)."""
    port = endpoint.rpartition(":")[2]
    if not endpoint.startswith("tcp://") or not port.isdigit():
        return False
    tables = [_proc("self", "net/tcp"), _proc("self", "net/tcp6")]
    if not any(tables):
        return True
    inodes = {fields[9] for table in tables for fields in (line.split() for line in table.splitlines()[1:])
              if len(fields) > 9 and fields[3] == "0A" and int(fields[1].rpartition(":")[2], 16) == int(port)}
    try:
        links = [os.readlink(entry) for entry in Path(f"/proc/{pid}/fd").iterdir()]
    except OSError:
        return True             # another user's process: its sockets cannot be read here
    return any(link == f"socket:[{inode}]" for link in links for inode in inodes)


def find_coupler(config: Path) -> tuple[str, str, int]:
    """The coupler's (endpoint, token, pid): from the environment ``cosim run`` gives a participant it starts; else
    from ``cosim-run/coupler.json`` next to the configuration, starting the coupler first if none runs (the first
    participant started by hand does, with the ``cosim`` command on PATH or in ``$COSIM``)."""
    if os.environ.get(ENDPOINT):
        return os.environ[ENDPOINT], os.environ.get(TOKEN, ""), int(os.environ.get(COUPLER_PID) or os.getppid())
    folder = config.parent / RUN_FILE.parent
    rendezvous = config.parent / RUN_FILE
    found = _running(rendezvous)
    if found:
        return found
    import fcntl
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)          # one participant starts the coupler; the other waits for it
        found = _running(rendezvous)
        started = _start_coupler(config, folder) if found is None else None
        deadline = time.monotonic() + FIND_SECONDS
        while found is None:
            time.sleep(0.05)
            found = _running(rendezvous)
            if found is None and started is not None and started.poll() is not None:
                raise Error(f"the coupler started for {config} stopped (exit code {started.returncode}) before it "
                            f"listened: {_last_line(folder / 'coupler.log')}")
            if found is None and time.monotonic() > deadline:
                raise Error(f"the coupler started for {config} did not answer within {FIND_SECONDS:g} s (its log: "
                            f"{folder / 'coupler.log'})")
    return found


def _last_line(log: Path) -> str:
    """The last line a log holds (the coupler's error when it stopped at start-up)."""
    try:
        lines = [line.strip() for line in log.read_text(errors="replace").splitlines() if line.strip()]
    except OSError:
        return f"(no log at {log})"
    return lines[-1] if lines else f"(nothing in {log})"


def _start_coupler(config: Path, folder: Path) -> Any:
    """``cosim run CONFIG --out cosim-run/runs/<time>`` in a session of its own, its output in cosim-run's log."""
    import shutil
    import subprocess
    import sys
    cosim = os.environ.get("COSIM") or shutil.which("cosim")
    if not cosim:
        raise Error(f"no cosim coupler runs for {config}, and no `cosim` command starts one: put cosim on PATH or "
                    f"set COSIM=/path/to/cosim, or start `cosim run {config}` first")
    out = folder / "runs" / f"{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}"
    with open(folder / "coupler.log", "ab") as log:
        started = subprocess.Popen([cosim, "run", str(config), "--out", str(out), "--quiet"],
                                   stdin=subprocess.DEVNULL, stdout=log, stderr=log, start_new_session=True)
    print(f"cosim: started the coupler for {config.name}; its run goes to {out}", file=sys.stderr)
    return started


OPEN: weakref.WeakSet[Connection] = weakref.WeakSet()     # closed (their messages sent) before an exit on an error


class Connection:
    """Requests to the coupler; a reply that says ``ok: false`` raises ``Error`` with the coupler's message."""

    def __init__(self, endpoint: str, token: str, coupler_pid: int):
        self.context = zmq.Context()
        OPEN.add(self)
        self.socket = self.context.socket(zmq.DEALER)
        self.socket.setsockopt(zmq.LINGER, 1000)
        self.socket.setsockopt(zmq.RCVTIMEO, SLICE_MS)
        self.socket.connect(endpoint)
        self.token = token
        self.coupler_pid = coupler_pid
        self._ids = 0

    def request(self, op: str, args: Mapping[str, Any] | None = None,
                arrays: Mapping[str, np.ndarray] | None = None) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Send ``op`` and wait for its reply, however long the coupling takes, while the coupler lives."""
        self._ids += 1
        body = dict(args or {})
        body["token"] = self.token
        self.socket.send_multipart(_wire.encode({"op": op, "id": self._ids, "args": body}, arrays))
        while True:
            try:
                frames = self.socket.recv_multipart()
            except zmq.Again:
                if not _alive(self.coupler_pid):
                    raise Error(f"{op}: the cosim coupler (pid {self.coupler_pid}) is gone; the coupling "
                                "stopped") from None
                continue
            header, received = _wire.decode(frames)
            if header.get("id") != self._ids:
                continue          # a late reply to a request given up on
            if not header.get("ok"):
                raise Error(str((header.get("error") or {}).get("message", f"the coupler refused {op}")))
            return header.get("result") or {}, received

    def tell(self, op: str, args: Mapping[str, Any] | None = None) -> None:
        """A message that wants no reply (the participant's own error, before it raises)."""
        self._ids += 1
        body = dict(args or {})
        body["token"] = self.token
        try:
            self.socket.send_multipart(_wire.encode({"op": op, "id": self._ids, "args": body}), zmq.NOBLOCK)
        except zmq.ZMQError:
            pass

    def close(self) -> None:
        """Close the socket, its queued messages sent first (LINGER: at most a second)."""
        OPEN.discard(self)
        if not self.socket.closed:
            self.socket.close()
            self.context.term()
