"""The quasi-Newton update's cost, hot and on emptied caches: the updates of a tube run replayed.

A coupled run calls the acceleration right after a round trip, on caches the components (and a VM's other
tenants) have emptied. This replays the IQN-ILS updates of a tube FOM-FOM run (every ``observe`` and
``next_iterate`` in order, recorded in-process) three ways: back to back (hot), after 16 MB of other data went
through the caches before each update (cold), and as the run itself timed them. It checks that the replay gives
the run's bits.

Usage: python -m benchmarks.acceleration_update [--small]   (--small: 6 s of the tube, for the tests)
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from benchmarks.common import ROOT, Timing, fresh_directory, machine
from cosim.scene import load_scene
from coupler.accelerations import make_acceleration
from coupler.accelerations.quasi_newton import IQNILS
from coupler.run import run_scene

SCENE = ROOT / "scenes" / "tube_fom.toml"


def record(end: float) -> tuple[list[tuple[str, Any]], dict, list[int], list[float]]:
    """The calls the run made on its acceleration, its settings and block sizes, and each update's time in it."""
    calls: list[tuple[str, Any]] = []
    seen: dict[str, Any] = {}
    timed: list[float] = []
    observe, update, start, end_window = (IQNILS.observe, IQNILS.next_iterate,
                                          IQNILS.start_window, IQNILS.end_window)

    def recording_observe(self, x, x_tilde):
        calls.append(("observe", (x.copy(), x_tilde.copy())))
        return observe(self, x, x_tilde)

    def recording_update(self):
        started = time.perf_counter()
        proposal = update(self)
        timed.append(time.perf_counter() - started)
        calls.append(("next_iterate", proposal.copy()))
        return proposal

    def recording_start(self):
        seen.setdefault("block_sizes", self.block_sizes)
        calls.append(("start_window", None))
        return start(self)

    def recording_end(self):
        calls.append(("end_window", None))
        return end_window(self)

    patched = {"observe": recording_observe, "next_iterate": recording_update, "start_window": recording_start,
               "end_window": recording_end}
    try:
        for name, method in patched.items():
            setattr(IQNILS, name, method)
        scene = load_scene(SCENE, [f"time.end={end:g}"])
        run_scene(scene, fresh_directory("acceleration_update") / "run", progress=False)
    finally:
        for name, method in zip(patched, (observe, update, start, end_window)):
            setattr(IQNILS, name, method)
    return calls, dict(scene["coupling"]["acceleration"]), seen.get("block_sizes") or [], timed


def replay(calls: list[tuple[str, Any]], settings: dict, block_sizes: list[int], flush: np.ndarray | None
           ) -> tuple[list[float], bool]:
    """Each update's time on a fresh acceleration fed the same calls, and whether it gave the run's bits."""
    accel = make_acceleration(settings, block_sizes)
    times, same = [], True
    for kind, value in calls:
        if kind == "observe":
            accel.observe(*value)
        elif kind == "next_iterate":
            if flush is not None:
                flush += 1.0
            started = time.perf_counter()
            proposal = accel.next_iterate()
            times.append(time.perf_counter() - started)
            same = same and np.array_equal(proposal, value)
        else:
            getattr(accel, kind)()
    return times, same


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="6 s of the tube (for the tests)")
    args = parser.parse_args(argv)
    print(f"machine: {machine()}")
    calls, settings, block_sizes, in_run = record(6.0 if args.small else 120.0)
    hot, same_hot = replay(calls, settings, block_sizes, None)
    cold, same_cold = replay(calls, settings, block_sizes, np.ones(16 * 2**20 // 8))
    rows = {"hot": Timing.of(np.array(hot)), "caches emptied (16 MB)": Timing.of(np.array(cold)),
            "in the run": Timing.of(np.array(in_run))}
    print(f"\n{len(hot)} IQN-ILS updates of the tube FOM-FOM run, us per update: median [IQR]")
    for label, timing in rows.items():
        print(f"  {label:<26}{timing}")
    print(f"  the replays give the run's bits: {same_hot and same_cold}")
    return {"rows": rows, "same": same_hot and same_cold, "updates": len(hot)}


if __name__ == "__main__":
    main()
