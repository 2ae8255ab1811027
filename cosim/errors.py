"""Typed errors of the runtime; each names where the problem is.

An error raised while a time window is being computed carries the window, its time and
the coupling iteration (``where``), set by the run driver.
"""

from __future__ import annotations


class CosimError(Exception):
    """Base class of every error raised by the runtime."""

    where: str = ""

    def __str__(self) -> str:
        message = super().__str__()
        return f"{self.where}: {message}" if self.where else message


class SceneError(CosimError):
    """A scene file (or a --set override) is invalid; the message names the key."""


class ProtocolError(CosimError):
    """A message on the wire is malformed."""


class ComponentError(CosimError):
    """A component reported an error, or broke its contract."""

    def __init__(self, component: str, message: str, kind: str = "ComponentError"):
        super().__init__(message)
        self.component = component
        self.detail = message
        self.kind = kind

    def __str__(self) -> str:
        where = f" in {self.where}" if self.where else ""
        return f"component '{self.component}'{where}: {self.detail}"


class ComponentDied(ComponentError):
    """A component process exited while the run needed it."""

    def __init__(self, component: str, exit_code: int | None, stderr_tail: str, log: str = ""):
        detail = f"process exited with code {exit_code}"
        if exit_code is not None and exit_code < 0:
            import signal
            try:
                name = signal.Signals(-exit_code).name
            except ValueError:
                name = f"signal {-exit_code}"
            detail = f"process was killed by {name} (exit code {exit_code})"
        lines = stderr_tail.strip().splitlines()
        refused = exit_code == 2 and lines and lines[-1].startswith("cosim serve: error: ")
        if refused:      # `cosim serve` refused its input in one line: that line is the message
            detail = f"did not start: {lines[-1].removeprefix('cosim serve: error: ')}"
        elif log:
            detail += f" (its log: {log})"
        if stderr_tail.strip() and not refused:
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


class NonFiniteOutput(ComponentError):
    """A component returned NaN or Inf."""

    def __init__(self, component: str, variable: str, values, where: str = "") -> None:
        import numpy as np
        bad = np.flatnonzero(~np.isfinite(values))
        super().__init__(component, f"output '{variable}'{where} is not finite: {values.flat[bad[0]]} at index {bad[0]} "
                                    f"({len(bad)} of {values.size} values)", kind="NonFiniteOutput")
        self.variable = variable


class ConvergenceError(CosimError):
    """The coupling iterations of a time window did not converge; ``where`` names the window, ``residuals`` holds
    its coupling residual per iteration."""

    where: str = ""
    residuals: list[float]


class DivergenceError(ConvergenceError):
    """The coupling residual of a time window grew by orders of magnitude."""


class StalledError(ConvergenceError):
    """The coupling residual stopped decreasing before the limits were met: the limits ask for more
    precision than the exchanged data carry (a solver's own tolerance, round-off)."""


class DiskFullError(CosimError):
    """The results' file system has no room for the next window."""
