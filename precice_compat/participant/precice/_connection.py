"""A participant's connection to cosim's coupler: one request at a time, each waiting for its reply.

``cosim run`` starts a participant with ``COSIM_PARTICIPANT_ENDPOINT`` (the coupler's loopback address) and
``COSIM_PARTICIPANT_TOKEN`` (the run's secret) in its environment. A participant started by hand finds them in
``cosim-run/coupler.json`` of the configuration's exchange directory, which the coupler writes (``cosim run``
on the configuration). While it waits, the participant checks every half second that the coupler still runs, and
stops if it is gone: a coupler's death leaves no participant behind.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import zmq

from precice import _wire

ENDPOINT = "COSIM_PARTICIPANT_ENDPOINT"
TOKEN = "COSIM_PARTICIPANT_TOKEN"
COUPLER_PID = "COSIM_COUPLER_PID"
RUN_FILE = Path("cosim-run") / "coupler.json"
SLICE_MS = 500
FIND_SECONDS = 60.0


class Error(RuntimeError):
    """A misuse of the API, or the coupling stopped: the message names the call and why."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def find_coupler(exchange_directories: list) -> tuple[str, str, int]:
    """The coupler's (endpoint, token, pid): from the environment ``cosim run`` gives a participant it starts, or
    from ``cosim-run/coupler.json`` in one of ``exchange_directories`` (waited for up to a minute)."""
    if os.environ.get(ENDPOINT):
        return os.environ[ENDPOINT], os.environ.get(TOKEN, ""), int(os.environ.get(COUPLER_PID) or os.getppid())
    deadline = time.monotonic() + FIND_SECONDS
    files = [Path(folder) / RUN_FILE for folder in exchange_directories]
    while True:
        for path in files:
            try:
                found = json.loads(path.read_text())
            except (OSError, ValueError):
                continue
            if _alive(int(found.get("pid", 0))):
                return str(found["endpoint"]), str(found.get("token", "")), int(found["pid"])
        if time.monotonic() > deadline:
            written = " or ".join(map(str, files))
            raise Error(f"no cosim coupler runs for this configuration: start it with `cosim run CONFIG.xml` (it "
                        f"writes {written}), or run the case with `cosim run CASE.toml`")
        time.sleep(0.1)


class Connection:
    """Requests to the coupler; a reply that says ``ok: false`` raises ``Error`` with the coupler's message."""

    def __init__(self, endpoint: str, token: str, coupler_pid: int):
        self.context = zmq.Context()
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
        self.socket.close()
        self.context.term()
