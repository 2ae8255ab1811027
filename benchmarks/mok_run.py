"""Benchmark of Mok's case: our coupler against Kratos CoSimulationApplication's own, same meshes, same run.

Runs ``scenes/mok.toml`` through ``cosim run`` (coupler, fluid and structure as three processes over
127.0.0.1, one thread per solver) and the same case through Kratos's coupler (``benchmarks/mok_peer.py``,
one process, one thread), one after the other on this machine, each as a subprocess whose wall and CPU
time (its own and its children's) are measured from outside. Prints side by side: iterations per window,
wall and CPU time, compute per solver call, and point A's maximum, its time and its last value, with
the largest difference between the two histories.

Usage: python -m benchmarks.mok_run [WINDOWS] [--repeat N] [--small] [--docs]
(--small: 5 windows on a coarse mesh, for the tests; --docs: also rewrite the table in docs/mok.md)
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.common import Timing, fresh_directory, machine, rewrite_readme
from cosim.results import RunResults

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "mok.toml"
DT = 0.1
COARSE = {"wall_cells": [2, 20], "wall_size": 0.0125, "far_size": 0.06}


def measured(command: list[str], log: Path) -> tuple[float, float]:
    """(wall, CPU) seconds of ``command`` run to its end, its children's CPU included."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    with open(log, "wb") as stream:
        subprocess.run(command, check=True, stdout=stream, stderr=subprocess.STDOUT, cwd=ROOT,
                       env={**os.environ, "OMP_NUM_THREADS": "1"})
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def ours(windows: int, mesh: dict, out: Path) -> dict:
    settings = [f"time.end={windows * DT!r}", *(f"mesh.{k}={json.dumps(v)}" for k, v in mesh.items())]
    command = [sys.executable, "-m", "cosim", "run", str(SCENE), "--out", str(out), "--quiet",
               *(arg for s in settings for arg in ("--set", s))]
    wall, cpu = measured(command, out.with_suffix(".log"))
    with RunResults(out / "results.h5") as run:
        calls = run.calls("structure", converged_only=True)
        return {"iterations": run.windows.iterations.tolist(), "converged": run.windows.converged.tolist(),
                "wall_seconds": run.windows.wall_seconds.tolist(),
                "fluid_compute": run.component("fluid").compute_seconds.tolist(),
                "solid_compute": run.component("structure").compute_seconds.tolist(),
                "point_a": calls.outputs["point_a"].tolist(), "wall": wall, "cpu": cpu}


def peer(windows: int, mesh: dict, out: Path) -> dict:
    path = out / "peer.json"
    command = [sys.executable, "-m", "benchmarks.mok_peer", str(windows), str(path.resolve()), "--mesh", json.dumps(mesh)]
    wall, cpu = measured(command, out / "peer.log")
    return {**json.loads(path.read_text()), "wall": wall, "cpu": cpu}


def table(runs: dict[str, list[dict]], windows: int, mesh: dict) -> list[str]:
    lines = [f"machine: {machine()}",
             f"Mok, {windows} windows of {DT:g} s, mesh {json.dumps(mesh) if mesh else 'of the scene'}; ours: "
             f"3 processes over 127.0.0.1, Kratos's: 1 process; one thread per solver; {len(runs['ours'])} run(s) each",
             f"{'':48s}{'ours (IQN-ILS)':>22s}{'Kratos (MVQN)':>22s}"]

    def row(label: str, values: list[str]) -> None:
        lines.append(f"{label:48s}" + "".join(f"{v:>22s}" for v in values))

    first = {name: results[0] for name, results in runs.items()}
    row("windows converged", [f"{sum(r['converged'])} of {len(r['converged'])}" for r in first.values()])
    row("coupling iterations per window, mean", [f"{np.mean(r['iterations']):.3f}" for r in first.values()])
    row("coupling iterations, max in a window", [str(max(r["iterations"])) for r in first.values()])
    for key, label in (("wall", "wall time, s"), ("cpu", "CPU time (all processes), s")):
        values = {name: np.array([r[key] for r in results]) for name, results in runs.items()}
        row(label + (" median [min, max]" if len(runs["ours"]) > 1 else ""),
            [f"{np.median(v):.1f} [{v.min():.1f}, {v.max():.1f}]" if len(v) > 1 else f"{v[0]:.1f}"
             for v in values.values()])
    row("  ratio Kratos / ours (medians)",
        ["", f"{np.median([r['wall'] for r in runs['kratos']]) / np.median([r['wall'] for r in runs['ours']]):.2f}"])
    for key, label in (("fluid_compute", "fluid compute per call, ms"), ("solid_compute", "structure compute per call, ms")):
        row(label, [str(Timing.of(np.array(r[key]) / 1e3)).strip() for r in first.values()])
    a = {name: np.array(r["point_a"])[:, 0] * 100 for name, r in first.items()}
    row("point A max x-displacement, cm", [f"{v.max():.3f}" for v in a.values()])
    row("  at t, s", [f"{(int(np.argmax(v)) + 1) * DT:.1f}" for v in a.values()])
    row(f"point A at t = {windows * DT:g} s, cm", [f"{v[-1]:.3f}" for v in a.values()])
    n = min(len(v) for v in a.values())
    difference = np.abs(a["ours"][:n] - a["kratos"][:n]).max() / max(np.abs(a["kratos"]).max(), 1e-300)
    row("  max over windows |ours - Kratos| / Kratos max", [f"{difference * 100:.3f} %", ""])
    return lines


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("windows", type=int, nargs="?", default=250)
    parser.add_argument("--repeat", type=int, default=1, help="runs of each, alternated (default 1)")
    parser.add_argument("--small", action="store_true", help="5 windows on a coarse mesh (for the tests)")
    parser.add_argument("--docs", action="store_true", help="rewrite the table in docs/mok.md")
    args = parser.parse_args(argv)
    windows, mesh = (5, COARSE) if args.small else (args.windows, {})
    out = fresh_directory("mok")
    runs: dict[str, list[dict]] = {"ours": [], "kratos": []}
    for k in range(args.repeat):
        runs["ours"].append(ours(windows, mesh, out / f"ours_{k}"))
        runs["kratos"].append(peer(windows, mesh, out))
    lines = table(runs, windows, mesh)
    print("\n".join(lines))
    (out / "table.txt").write_text("\n".join(lines) + "\n")
    (out / "runs.json").write_text(json.dumps(runs))
    if args.docs:
        rewrite_readme("mok", lines, f"python -m benchmarks.mok_run {windows} --repeat {args.repeat} --docs")
    return {**runs, "out": str(out)}


if __name__ == "__main__":
    main()
