"""The output directory of one run: held exclusively while the run lives, never overwritten by accident.

A run holds ``DIR/.lock`` with ``flock`` for its whole life (the kernel releases it if the
process dies), so a second run on the same directory is refused while the first one is in
progress, with or without ``--overwrite``. A directory that holds a finished or crashed run
(``results.h5``) is refused too, unless ``overwrite`` is given; then the old run's files are
removed only once the new run holds the lock. ``status.json`` tells how far the run has come
(written atomically: a reader never sees half a file); a run whose process is gone while its status
says it runs reads as ``died``. Sweeps and campaigns hold their own directories the same way (``hold``).
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import shutil
import time
from pathlib import Path
from typing import Any

from cosim.errors import CosimError
from cosim.input_file import read_input

LOCK = ".lock"
SETTLE_SECONDS = 10.0     # the longest a dead run's results writer is waited for (it writes what it was handed)
STATUS = "status.json"
RUN_FILES = ("results.h5", "run.png", STATUS, "checkpoint.npz")
RUN_FOLDERS = ("logs",)


class RunDirectoryError(CosimError):
    """The output directory holds another run."""


class RunDirectory:
    """Context manager holding ``path`` for one run."""

    def __init__(self, path: str | Path, overwrite: bool = False, status_interval: float = 0.5, resume: bool = False):
        if not str(path).strip():
            raise RunDirectoryError("the output directory (--out) is empty; name a directory")
        self.path = Path(path)
        self.overwrite = overwrite
        self.resume = resume      # the directory's run goes on from its checkpoint
        self.status_interval = status_interval
        self._lock: int | None = None
        self._last_status = 0.0

    def __enter__(self) -> RunDirectory:
        if self.resume and self.overwrite:
            raise RunDirectoryError("--resume goes on with the run in --out and --overwrite replaces it: give one")
        # a finished run is refused before the lock is taken: nothing in the directory is touched
        if self.resume and read_status(self.path).get("state") == "finished":
            raise RunDirectoryError(f"'{self.path}' holds a run that finished ({describe_run(self.path)}): "
                                    "there is nothing to resume; it is left as it is")
        fd = hold(self.path, "run")
        if self.resume:
            if not (self.path / "results.h5").exists():
                os.close(fd)
                raise RunDirectoryError(f"'{self.path}' holds no run to resume (no results.h5)")
        elif (self.path / "results.h5").exists():
            if not self.overwrite:
                os.close(fd)
                raise RunDirectoryError(f"'{self.path}' already holds a run ({describe_run(self.path)}); "
                                        "choose another --out or pass --overwrite to replace it")
            self._remove_old_run()
        self._lock = fd
        return self

    @property
    def lock(self) -> int | None:
        """The lock's file descriptor while held (a child process given it holds the directory too)."""
        return self._lock

    def __exit__(self, *exc_info: Any) -> None:
        if self._lock is not None:
            os.ftruncate(self._lock, 0)
            fcntl.flock(self._lock, fcntl.LOCK_UN)
            os.close(self._lock)
            self._lock = None

    def _remove_old_run(self) -> None:
        for name in RUN_FILES:
            (self.path / name).unlink(missing_ok=True)
        for name in RUN_FOLDERS:
            shutil.rmtree(self.path / name, ignore_errors=True)

    def status(self, state: str, force: bool = False, **fields: Any) -> None:
        """Write ``status.json`` (at most every ``status_interval`` seconds unless ``force``)."""
        now = time.monotonic()
        if not force and now - self._last_status < self.status_interval:
            return
        self._last_status = now
        document = {"state": state, "pid": os.getpid(), "updated": time.time(), **fields}
        partial = self.path / f".{STATUS}.{os.getpid()}"
        try:
            partial.write_text(json.dumps(document))
            os.replace(partial, self.path / STATUS)
        except OSError:            # a full disk: the run's own error says what happened
            partial.unlink(missing_ok=True)


def hold(path: Path, what: str) -> int:
    """Create ``path`` and lock its ``.lock`` (a file descriptor the caller closes); refused while another
    process holds it."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd = os.open(path / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise RunDirectoryError(f"cannot use '{path}' as the {what}'s directory: {exc.strerror or exc}") from None
    try:
        _lock_or_wait_for_writer(fd)
    except BlockingIOError:
        holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "?"
        os.close(fd)
        raise RunDirectoryError(f"'{path}' is in use by a {what} in progress (pid {holder}); "
                                "choose another --out") from None
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)     # who holds it, for the message above
    except OSError as exc:        # a full disk
        os.close(fd)
        raise RunDirectoryError(f"cannot use '{path}' as the {what}'s directory: {exc.strerror}") from None
    return fd


def _lock_or_wait_for_writer(fd: int) -> None:
    """Lock ``fd``; if a run whose process is gone still holds it, its results writer is writing the windows it was
    handed (``cosim.results_writer``): wait for it, up to ``SETTLE_SECONDS``. BlockingIOError if still held."""
    deadline = time.monotonic() + SETTLE_SECONDS
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except BlockingIOError:
            holder = os.pread(fd, 64, 0).decode(errors="replace").strip()
            if alive(int(holder) if holder.isdigit() else None) or time.monotonic() > deadline:
                raise
            time.sleep(0.02)


def settling(path: str | Path) -> bool:
    """Whether the run in ``path`` died and its results writer is still writing (it holds the directory's lock for
    the run whose pid the lock names, and that process is gone): its files are whole within seconds."""
    try:
        fd = os.open(Path(path) / LOCK, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    except BlockingIOError:
        holder = os.pread(fd, 64, 0).decode(errors="replace").strip()
        return holder.isdigit() and not alive(int(holder))
    finally:
        os.close(fd)


MAX_STATUS_BYTES = 1 << 20


def read_status(path: str | Path) -> dict[str, Any]:
    """The last ``status.json`` of the run in ``path`` ({} if there is none yet). A run whose process is
    gone while its status still says it is starting or running is reported as ``"died"``."""
    try:
        status = json.loads(read_input(Path(path) / STATUS, "status", MAX_STATUS_BYTES))
    except (CosimError, ValueError, RecursionError):
        return {}
    if not isinstance(status, dict):
        return {}                   # damaged: a status is a table
    status = _well_formed(status)
    if status.get("state") in ("starting", "running") and not alive(status.get("pid")):
        status["state"] = "died"
    return status


COUNTS = ("windows_completed", "windows_total", "windows_at_start", "iterations_total", "last_iterations",
          "windows_unconverged", "pid")
TIMES = ("time", "started", "updated", "wall_seconds", "coupling_started", "coupling_seconds")


def _well_formed(status: dict[str, Any]) -> dict[str, Any]:
    """``status`` without the fields a damaged file got wrong: counts that are not whole numbers, times that are
    not finite numbers, a state or an error that is not text, measures that are not finite numbers."""
    def number(value: Any) -> bool:
        return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    kept = {k: v for k, v in status.items() if k not in (*COUNTS, *TIMES, "state", "error", "measures")}
    kept.update({k: int(status[k]) for k in COUNTS if number(status.get(k)) and float(status[k]).is_integer()
                 and status[k] >= 0})
    kept.update({k: float(status[k]) for k in TIMES if number(status.get(k))})
    kept.update({k: status[k] for k in ("state", "error") if isinstance(status.get(k), str)})
    measures = status.get("measures")
    if isinstance(measures, dict):
        kept["measures"] = {str(k): float(v) for k, v in measures.items() if number(v)}
    return kept


def alive(pid: Any) -> bool:
    """Whether a process of this pid runs on this machine (a zombie, dead and not yet reaped, does not)."""
    if not isinstance(pid, int) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return not zombie(pid)


def command_line(pid: int) -> str:
    """The command line ``pid`` runs (Linux's /proc; "cosim" where it cannot be told, so as to trust it)."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return "cosim"


def zombie(pid: int) -> bool:
    """Whether ``pid`` has exited and waits for its parent to reap it (Linux's /proc; False where there is none)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rfind(")") + 2:][:1] == "Z"


def describe_run(path: str | Path) -> str:
    """What the run in ``path`` came to, in a few words, from its status file."""
    status = read_status(path)
    state = status.get("state")
    done = status.get("windows_completed", 0)
    total = status.get("windows_total")
    of = f" of {total}" if total is not None else ""
    if state == "finished":
        return f"finished, {done} windows"
    if state == "failed":
        error = str(status.get("error", "")).splitlines()[0][:160] if status.get("error") else ""
        return f"failed after {done}{of} windows" + (f": {error}" if error else "")
    if state == "interrupted":
        return f"interrupted after {done}{of} windows"
    if state == "died":
        pid = f" (pid {status['pid']})" if "pid" in status else ""
        return f"its process{pid} died after {done}{of} windows"
    return "results.h5 without a status"
