"""Benchmark of the double flap: our coupler against Kratos CoSimulationApplication's own, same run.

Runs N windows of ``scenes/double_flap.toml`` through our coupler (fluid and solid as separate
processes over 127.0.0.1, one thread each) and the same case through Kratos's coupler
(``benchmarks/kratos_peer.py``, one process, one thread), one after the other on this machine,
and prints side by side (ours with the scene's settings, the authors' limits, and, unless --small,
with a 5 times tighter relative limit on the force, 1e-3): coupling iterations per window, fluid
and solid compute per call, coupler overhead per iteration (wall minus solver compute; for ours also the wire part, round
trip minus compute), wall time per window, and both flap tips' x-displacement at the last
window with the largest difference over all windows relative to the peer's tip amplitude.

Usage: python -m benchmarks.double_flap_run N [--linear-solver sparse_lu|sparse_qr] [--small] [--readme]
(--small: 3 windows, for the tests; --readme: also rewrite the README's double-flap table)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from benchmarks.common import Timing, fresh_directory, machine, rewrite_readme
from benchmarks.kratos_peer import TIPS
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.run import run_scene

ROOT = Path(__file__).resolve().parent.parent

SCENE = ROOT / "scenes" / "double_flap.toml"
DT = 0.008


TIGHT_LIMIT = "coupling.convergence.0.measures.1.limit=1e-3"   # 5 times the authors' relative limit on the force


def ours(windows: int, linear_solver: str, out: Path, overrides: tuple[str, ...] = ()) -> dict:
    scene = load_scene(SCENE, [f"time.end={windows * DT!r}",
                               f"components.solid.parameters.linear_solver={linear_solver}", *overrides])
    run_scene(scene, out, progress=False)
    with RunResults(out) as run:
        interface = run.component("solid").meshes["interface"]
        tips = {side: int(np.argmin(np.linalg.norm(interface - xy, axis=1))) for side, xy in TIPS.items()}
        displacement = run.fields()["displacement"]
        fluid, solid = run.component("fluid"), run.component("solid")
        wire = (fluid.roundtrip_seconds - fluid.compute_seconds).sum() + \
            (solid.roundtrip_seconds - solid.compute_seconds).sum()
        return {"iterations": run.windows.iterations.tolist(), "wall_seconds": run.windows.wall_seconds.tolist(),
                "fluid_compute": fluid.compute_seconds.tolist(), "solid_compute": solid.compute_seconds.tolist(),
                "wire_seconds": float(wire), "converged": bool(run.windows.converged.all()),
                **{f"tip_{side}": displacement[:, i, 0].tolist() for side, i in tips.items()}}


def peer(windows: int, linear_solver: str, out: Path) -> dict:
    path = out / "peer.json"
    with open(out / "peer.log", "wb") as log:
        subprocess.run([sys.executable, "-m", "benchmarks.kratos_peer", str(windows), str(Path(path).resolve()),
                        "--linear-solver", linear_solver], check=True, stdout=log, stderr=subprocess.STDOUT,
                       env={**os.environ, "OMP_NUM_THREADS": "1"}, cwd=ROOT)
    return json.loads(path.read_text())


def overhead(result: dict) -> float:
    """Seconds per coupling iteration spent outside the two solvers (wall minus compute)."""
    compute = sum(result["fluid_compute"]) + sum(result["solid_compute"])
    return (sum(result["wall_seconds"]) - compute) / sum(result["iterations"])


def table(runs: dict[str, dict], theirs: dict, linear_solver: str) -> list[str]:
    """Side by side: each of our runs (by label) and the peer."""
    first = next(iter(runs.values()))
    n = len(first["iterations"])
    lines = [f"machine: {machine()}",
             f"double flap, Re = 250, {n} windows of 8 ms, solid linear solver {linear_solver}; "
             "ours: 2 processes over 127.0.0.1, Kratos's: 1 process; one thread per solver",
             f"{'':46s}" + "".join(f"{label:>24s}" for label in runs) + f"{'Kratos CoSimulation':>24s}"]

    def row(label: str, values: list[str]) -> None:
        lines.append(f"{label:46s}" + "".join(f"{v:>24s}" for v in values))

    everyone = [*runs.values(), theirs]
    for until in sorted({min(n, k) for k in (10, 50, 100, n)}):
        row(f"iterations per window, windows 1-{until}", [f"{np.mean(r['iterations'][:until]):.3f}" for r in everyone])
    row("iterations, max in a window", [str(max(r["iterations"])) for r in everyone])
    for key, label in (("fluid_compute", "fluid compute per call, ms"), ("solid_compute", "solid compute per call, ms")):
        row(label, [str(Timing.of(np.array(r[key]) / 1e3)).strip() for r in everyone])
    fluid_median = float(np.median(first["fluid_compute"]))
    row("coupler overhead per iteration, ms", [f"{overhead(r) * 1e3:.2f}" for r in everyone])
    row("  as % of a fluid solve (first column's median)", [f"{100 * overhead(r) / fluid_median:.2f} %" for r in everyone])
    row("  of which on the wire (round trip - compute)",
        [f"{r['wire_seconds'] / sum(r['iterations']) * 1e3:.2f}" for r in runs.values()] + ["-"])
    row("wall per window, ms", [str(Timing.of(np.array(r["wall_seconds"]) / 1e3)).strip() for r in everyone])
    for side in TIPS:
        peer_tip = np.array(theirs[f"tip_{side}"])
        row(f"{side} tip x-displacement at t = {n * DT:g} s, mm", [f"{r[f'tip_{side}'][-1] * 1e3:.4f}" for r in everyone])
        amplitude = np.abs(peer_tip).max()
        row("  max over windows |ours - peer| / peer amplitude",
            [f"{np.abs(np.array(r[f'tip_{side}']) - peer_tip).max() / amplitude * 100:.3f} %" for r in runs.values()] + [""])
    return lines


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("windows", type=int, nargs="?", default=100)
    parser.add_argument("--linear-solver", default="sparse_lu", choices=["sparse_lu", "sparse_qr", "skyline_lu_factorization"])
    parser.add_argument("--small", action="store_true", help="3 windows (for the tests)")
    parser.add_argument("--readme", action="store_true", help="rewrite the README's double-flap table")
    args = parser.parse_args(argv)
    windows = 3 if args.small else args.windows
    out = fresh_directory("double_flap")
    theirs = peer(windows, args.linear_solver, out)
    runs = {"ours (scene)": ours(windows, args.linear_solver, out / "ours")}
    if not args.small:
        runs["ours, force 1e-3"] = ours(windows, args.linear_solver, out / "ours_1e-3", (TIGHT_LIMIT,))
    mine = runs["ours (scene)"]
    lines = table(runs, theirs, args.linear_solver)
    print("\n".join(lines))
    (out / "table.txt").write_text("\n".join(lines) + "\n")
    (out / "ours.json").write_text(json.dumps(runs))
    if args.readme:
        command = f"python -m benchmarks.double_flap_run {windows} --linear-solver {args.linear_solver} --readme"
        rewrite_readme("double-flap", lines, command)
    return {"ours": mine, "runs": runs, "peer": theirs, "out": str(out)}


if __name__ == "__main__":
    main()
