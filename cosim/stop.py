"""Ctrl-C and SIGTERM as requests to stop, acted on at safe points.

A Python signal handler that raises runs at whatever bytecode the main thread is at, and an
exception raised inside a finalizer there (h5py and ZeroMQ objects are freed all the time) is
printed and dropped: the run then went on as if never asked to stop, and a window could be
written in part. While ``handling_stops`` is active, SIGINT and SIGTERM only record the request;
``check`` raises it (``KeyboardInterrupt``, or ``SystemExit(128 + signal)``) where the coupler can
stop cleanly: between windows, and in every wait for a component. A second signal raises at once,
so a coupler stuck elsewhere can still be stopped.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_requested: int | None = None
_deferred = 0            # inside ``deferred()``: ``check`` raises nothing (a second signal still stops at once)


def _record(signum: int, frame: object) -> None:
    global _requested
    if _requested is not None:      # asked twice: stop now
        _raise(signum)
    _requested = signum


def _raise(signum: int) -> None:
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise SystemExit(128 + signum)


def pending() -> bool:
    """Whether a stop was asked for and not yet raised (a run writes its checkpoint before it stops)."""
    return _requested is not None


@contextmanager
def deferred() -> Iterator[None]:
    """Work that a stop must not cut short (the checkpoint a stop asks for): ``check`` waits until it is done."""
    global _deferred
    _deferred += 1
    try:
        yield
    finally:
        _deferred -= 1


def check() -> None:
    """Raise the stop that was asked for, if any (not inside ``deferred``)."""
    global _requested
    if _requested is not None and not _deferred:
        signum, _requested = _requested, None
        _raise(signum)


@contextmanager
def handling_stops() -> Iterator[None]:
    """SIGINT and SIGTERM are recorded, not raised, inside the block (main thread only; elsewhere a no-op)."""
    global _requested
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _record) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        _requested = None
