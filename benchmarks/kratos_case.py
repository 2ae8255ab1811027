"""Kratos CoSimulation cases under cosim and under Kratos's own ``MainKratosCoSim``: the same files, one machine.

Writes the two cases of ``cases.kratos_wall`` (a static and a dynamic wall in Mok's channel, Kratos's file layout),
then, alternated, runs each ``--repeat`` times (a) ``cosim run case.toml`` (a coupler and a process per solver over
127.0.0.1) and (b) Kratos's ``MainKratosCoSim.py`` unmodified in the case's folder (one process); both with one
thread per solver, timed from outside (start-up included). A third, instrumented Kratos run records the
iterations per window and every data entry at each window's end. Prints per case: iterations (total, windows
that differ), the largest difference of each interface field over its amplitude, the wall times (median,
min-max) and their ratio.

Usage: python -m benchmarks.kratos_case [--windows N] [--repeat N] [--kind static|dynamic] [--mesh coarse|mok]
                                       [--small] [--docs]
       python -m benchmarks.kratos_case --record FOLDER OUT.npz     (the instrumented Kratos run, in a process)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import fresh_directory, machine, rewrite_readme
from cases.kratos_wall.write import write_case
from cosim.results import RunResults

ROOT = Path(__file__).resolve().parent.parent
KINDS = ("static", "dynamic")
MOK_MESH = {"wall_cells": [2, 100], "wall_size": 0.0025, "far_size": 0.03}     # scenes/mok.toml's


def record(folder: Path, out: Path) -> None:
    """Kratos's own coupled analysis of the case in ``folder`` (its loop, ``Run``), recording per window the
    coupling iterations (the first solver's solves) and every solver's data at the window's end."""
    import KratosMultiphysics as KM
    from KratosMultiphysics.CoSimulationApplication.co_simulation_analysis import CoSimulationAnalysis
    os.chdir(folder)
    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)
    parameters = KM.Parameters((folder / "ProjectParametersCoSim.json").read_text())
    rows: dict[str, list] = {"iterations": []}
    solves = [0]

    class Recorded(CoSimulationAnalysis):
        def OutputSolutionStep(self) -> None:
            super().OutputSolutionStep()
            coupled = self._GetSolver()
            rows["iterations"].append(solves[0])
            solves[0] = 0
            for name, wrapper in coupled.solver_wrappers.items():
                for data in parameters["solver_settings"]["solvers"][name]["data"].keys():
                    rows.setdefault(f"{name}.{data}", []).append(wrapper.GetInterfaceData(data).GetData())

    analysis = Recorded(parameters)
    coupled = analysis._GetSolver()
    first = coupled.solver_wrappers[next(iter(coupled.solver_wrappers))]
    solve = first.SolveSolutionStep

    def counted() -> None:
        solves[0] += 1
        solve()

    first.SolveSolutionStep = counted
    analysis.Run()
    arrays: dict[str, Any] = {k: np.asarray(v) for k, v in rows.items()}
    np.savez(out, **arrays)


def timed(command: list[str], cwd: Path, log: Path) -> float:
    started = time.perf_counter()
    with open(log, "wb") as stream:
        subprocess.run(command, check=True, stdout=stream, stderr=subprocess.STDOUT, cwd=cwd,
                       env={**os.environ, "OMP_NUM_THREADS": "1"})
    return time.perf_counter() - started


def main_kratos_cosim() -> Path:
    import importlib.util
    spec = importlib.util.find_spec("KratosMultiphysics")      # found, not imported (a submodule's would import it)
    assert spec is not None and spec.submodule_search_locations
    return Path(list(spec.submodule_search_locations)[0]) / "CoSimulationApplication" / "MainKratosCoSim.py"


def compare(case: Path, ours: Path, peer: Path) -> dict:
    """Iterations and interface fields of our run against Kratos's recorded one."""
    kratos = np.load(peer)
    with RunResults(ours / "results.h5") as run:
        iterations = run.windows.iterations.astype(int)
        scene = run.scene
        fields = {}
        for exchange in scene["exchange"]:
            source = scene["components"][exchange["from"]]["parameters"]["fields"]
            data = next(f["data"] for f in source if f["name"] == exchange["data"])
            ours_values = np.asarray(run.fields()[exchange["data"]])
            theirs = kratos[f"{exchange['from']}.{data}"].reshape(ours_values.shape)
            amplitude = float(np.abs(theirs).max())
            fields[f"{exchange['from']}.{data}"] = float(np.abs(ours_values - theirs).max()) / amplitude
    theirs_iterations = kratos["iterations"].astype(int)
    return {"iterations": iterations.tolist(), "kratos_iterations": theirs_iterations.tolist(),
            "windows_differing": int((iterations != theirs_iterations).sum()), "fields": fields}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=40)
    parser.add_argument("--repeat", type=int, default=3, help="timed runs of each, alternated")
    parser.add_argument("--kind", choices=KINDS, action="append")
    parser.add_argument("--small", action="store_true", help="5 windows, one timed run each (for the tests)")
    parser.add_argument("--mesh", choices=("coarse", "mok"), default="coarse",
                        help="the tests' coarse mesh, or the resolution of scenes/mok.toml")
    parser.add_argument("--docs", action="store_true", help="rewrite the table in docs/kratos.md")
    parser.add_argument("--record", nargs=2, metavar=("FOLDER", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.record:
        record(Path(args.record[0]).resolve(), Path(args.record[1]).resolve())
        return {}
    windows, repeat = (5, 1) if args.small else (args.windows, args.repeat)
    out = fresh_directory("kratos_case")
    lines = [f"machine: {machine()}",
             f"{windows} windows of 0.1 s, {args.mesh} mesh; ours: coupler + 2 solver processes over 127.0.0.1; "
             f"Kratos's MainKratosCoSim: 1 process; one thread per solver; {repeat} timed run(s) each, alternated"]
    results = {}
    for kind in args.kind or KINDS:
        folder = out / kind
        case = write_case(folder, kind, windows, None if args.mesh == "coarse" else MOK_MESH)
        walls: dict[str, list[float]] = {"ours": [], "kratos": []}
        for k in range(repeat):
            walls["ours"].append(timed([sys.executable, "-m", "cosim", "run", str(case), "--out",
                                        str(out / f"{kind}_ours_{k}"), "--quiet"], folder, out / f"{kind}_ours_{k}.log"))
            walls["kratos"].append(timed([sys.executable, str(main_kratos_cosim())], folder,
                                         out / f"{kind}_kratos_{k}.log"))
        peer = out / f"{kind}_kratos.npz"
        timed([sys.executable, "-m", "benchmarks.kratos_case", "--record", str(folder), str(peer)], ROOT,
              out / f"{kind}_record.log")
        result = {**compare(case, out / f"{kind}_ours_0", peer), "walls": walls}
        results[kind] = result
        ours_wall, kratos_wall = np.median(walls["ours"]), np.median(walls["kratos"])
        lines += ["", f"{kind} wall",
                  f"  iterations, ours / Kratos            {sum(result['iterations']):>8} / {sum(result['kratos_iterations'])}"
                  f"   (windows that differ: {result['windows_differing']} of {windows})",
                  *(f"  max |ours - Kratos| / amplitude, {name:<14} {value:.2e}" for name, value in result["fields"].items()),
                  f"  wall s, ours   median {ours_wall:7.2f}  (min {min(walls['ours']):.2f}, max {max(walls['ours']):.2f})",
                  f"  wall s, Kratos median {kratos_wall:7.2f}  (min {min(walls['kratos']):.2f}, max {max(walls['kratos']):.2f})",
                  f"  ratio Kratos / ours (medians)         {kratos_wall / ours_wall:.2f}"]
    print("\n".join(lines))
    (out / "table.txt").write_text("\n".join(lines) + "\n")
    (out / "results.json").write_text(json.dumps(results))
    if args.docs:
        rewrite_readme(f"kratos-{args.mesh}", lines, f"python -m benchmarks.kratos_case --windows {windows} "
                       f"--repeat {repeat} --mesh {args.mesh} --docs")
    return {**results, "out": str(out)}


if __name__ == "__main__":
    main()
