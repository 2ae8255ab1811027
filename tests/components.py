"""Deliberately faulty components for failure tests (served in real processes)."""

from __future__ import annotations

import time


from solid_component.tube import TubeSolid


class WrongLengthSolid(TubeSolid):
    """Declares 101 sections but returns 100."""

    def get_values(self, names):
        return {name: value[:-1] for name, value in super().get_values(names).items()}


class HangingSolid(TubeSolid):
    """Stops answering in its third window."""

    def do_step(self, t, dt):
        if t >= 0.2:
            time.sleep(3600)
        super().do_step(t, dt)


class CrashingSolid(TubeSolid):
    """Exits the process with code 7 at t >= 0.3."""

    def do_step(self, t, dt):
        if t >= 0.3:
            import os
            os._exit(7)
        super().do_step(t, dt)
