"""Typed errors of the runtime; each names where the problem is."""

from __future__ import annotations


class CosimError(Exception):
    """Base class of every error raised by the runtime."""


class SceneError(CosimError):
    """A scene file (or a --set override) is invalid; the message names the key."""


class ProtocolError(CosimError):
    """A message on the wire is malformed."""


class ComponentError(CosimError):
    """A component reported an error, or broke its contract."""

    def __init__(self, component: str, message: str, kind: str = "ComponentError"):
        super().__init__(f"component '{component}': {message}")
        self.component = component
        self.kind = kind


class ComponentDied(ComponentError):
    """A component process exited while the run needed it."""

    def __init__(self, component: str, exit_code: int | None, stderr_tail: str):
        detail = f"process exited with code {exit_code}"
        if stderr_tail.strip():
            detail += "; last lines of its stderr:\n" + stderr_tail.rstrip()
        super().__init__(component, detail, kind="ComponentDied")
        self.exit_code = exit_code
        self.stderr_tail = stderr_tail


class ComponentTimeout(ComponentError):
    """A component did not answer within its timeout."""

    def __init__(self, component: str, op: str, seconds: float):
        super().__init__(component, f"no reply to '{op}' within {seconds:g} s", kind="ComponentTimeout")
        self.op = op
        self.seconds = seconds


class ConvergenceError(CosimError):
    """The coupling iterations of a time window did not converge."""
