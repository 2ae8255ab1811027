"""Deliberately faulty components for failure tests (served in real processes)."""

from __future__ import annotations

import math
import threading

import numpy as np

from cosim.component import Variable
from rom_component.static.component import RomSolid
from solid_component.tube import TubeSolid


class WrongLengthSolid(TubeSolid):
    """Declares 101 sections but returns 100."""

    def get_values(self, names):
        return {name: value[:-1] for name, value in super().get_values(names).items()}


class HangingSolid(TubeSolid):
    """Stops answering in its third window."""

    def do_step(self, t, dt):
        if t >= 0.2:
            threading.Event().wait()   # never set: hangs until killed
        super().do_step(t, dt)


class LateHangingSolid(TubeSolid):
    """Stops answering in its 41st window (t >= 4): forty windows go to the results file before."""

    def do_step(self, t, dt):
        if t >= 4.0 - 1e-9:
            threading.Event().wait()   # never set: hangs until killed
        super().do_step(t, dt)


class CrashingSolid(TubeSolid):
    """Exits the process with code 7 at t >= 0.3, leaving a temporary folder behind (its path in the environment's
    CRASH_NOTE file, if set), after printing CRASH_SAYS times the letter x on one line of its stderr (if set)."""

    def do_step(self, t, dt):
        if t >= 0.3:
            import os
            import sys
            import tempfile
            folder = tempfile.mkdtemp(prefix="left-behind-")
            if os.environ.get("CRASH_NOTE"):
                with open(os.environ["CRASH_NOTE"], "w") as note:
                    note.write(folder)
            if os.environ.get("CRASH_SAYS"):
                print("x" * int(os.environ["CRASH_SAYS"]), file=sys.stderr, flush=True)
            os._exit(7)
        super().do_step(t, dt)


class NanSolid(TubeSolid):
    """Returns NaN at node 5 from its window that starts at t = 0.2 on."""

    def do_step(self, t, dt):
        super().do_step(t, dt)
        if t >= 0.2 - 1e-12:
            self.section = self.section.copy()
            self.section[5] = float("nan")


class OverflowingSolid(TubeSolid):
    """Sections of 1e160 and up: the coupler's residual norm overflows (NumPy warns) before the fluid fails."""

    def do_step(self, t, dt):
        self._calls = getattr(self, "_calls", 0) + 1
        self.section = np.full(self.n, 1e150 * 10.0 ** (10 * self._calls))


class DivergingSolid(TubeSolid):
    """Within a window, the k-th call returns a0 (1 + 1e-3 10^k): a residual growing tenfold per iteration."""

    def do_step(self, t, dt):
        if t != getattr(self, "_t", None):
            self._t, self._calls = t, 0
        self._calls += 1
        self.section = np.full(self.n, math.pi * self.r0 ** 2 * (1.0 + 1e-3 * 10.0 ** self._calls))


class WarningSolid(TubeSolid):
    """Reports, as Kratos's Newton does when it hits its cap, in every call of its second window."""

    def do_step(self, t, dt):
        super().do_step(t, dt)
        if abs(t - 0.1) < 1e-12:
            self.warn("Newton hit its iteration cap (25)")


class CountingRom(RomSolid):
    """The ROM component with one more local, ``keep_warm_calls``: its idle calls so far."""

    def variables(self):
        return [*super().variables(), Variable("keep_warm_calls", "local", 1)]

    def get_values(self, names):
        counted = {"keep_warm_calls": np.array([float(self.keep_warm_calls)])}
        return {**super().get_values([n for n in names if n not in counted]),
                **{n: counted[n] for n in names if n in counted}}


class FailingIdleSolid(TubeSolid):
    """Asks for idle calls every millisecond and fails in each."""

    idle_interval = 0.001

    def idle(self):
        raise RuntimeError("idle work broke")


class RaisingSolid(TubeSolid):
    """Raises an unexpected error (a bug of its own) at t >= 0.3."""

    def do_step(self, t, dt):
        if t >= 0.3:
            raise ZeroDivisionError("a bug in the solid")
        super().do_step(t, dt)


class JitterSolid(TubeSolid):
    """Sections off by a relative 1e-12, in alternating sign from call to call: a solver converged to its tolerance,
    whose answers differ in the digits it does not resolve. No exact fixed point exists, whatever the rounding of the
    machine's BLAS (the tube's own solid may land on one, and then a limit of 1e-16 is met)."""

    def do_step(self, t, dt):
        super().do_step(t, dt)
        self._calls = getattr(self, "_calls", 0) + 1
        self.section = self.section * (1.0 + 1e-12 * (-1.0) ** self._calls)
