"""The online surrogate against the plain scheme, side by side in one invocation: iterations and fluid calls per
window after the surrogate starts, where the time goes, and the accuracy against the plain run.

Cases (the scenes' own settings, FOM-FOM):
- ``flap``: the double flap, Re = 250 over [0, 1.504] s (188 windows), surrogate from window 20; accuracy: each tip's largest
  difference from the plain run after the start, over the plain run's amplitude there;
- ``tube``: the tube on the paper's mu1 inlet table, 1200 windows, surrogate from window 100; accuracy: the inlet
  pressure's relative L2 difference from the plain run after the start.

Usage: python -m benchmarks.surrogate_coupling {flap,tube} [--start N] [--set KEY=VALUE ...] [--small]
       (a --set of a coupling.surrogate key goes to the surrogate run only)
       (--small: a few windows, for the tests)
       python -m benchmarks.surrogate_coupling {flap,tube} --start N --compare BASELINE RUN ...
       (the same table over finished runs of the case, e.g. other acceleration settings: each against the first)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.common import fresh_directory, machine
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.run import run_scene

ROOT = Path(__file__).resolve().parent.parent
CASES = {
    "flap": (ROOT / "scenes/double_flap.toml", ["time.end=1.504", "output.checkpoint_every=0"], 20),
    "tube": (ROOT / "scenes/tube_fom.toml", [f"inlet.table={ROOT / 'scenes/inlet/tube-inlet-mu1.csv'}"], 100),
}
SMALL = {"flap": (["time.end=0.12"], 8), "tube": (["time.end=3", "tube.cells=40"], 10)}


def fluid_of(run: RunResults) -> str:
    """The participant that is not the surrogate's static one (the fluid): the scene's other component."""
    scene = run.scene
    static = scene["coupling"]["surrogate"].get("static") or next(
        name for name in scene["coupling"]["participants"] if scene["components"][name].get("record"))
    return next(name for name in scene["coupling"]["participants"] if name != static)


def accuracy(case: str, plain: RunResults, online: RunResults, start: int) -> dict[str, float]:
    after = slice(start, None)
    if case == "tube":
        p0, p1 = plain.fields()["pressure"][after, 0], online.fields()["pressure"][after, 0]
        return {"inlet pressure, relative L2": float(np.linalg.norm(p1 - p0) / np.linalg.norm(p0))}
    from cases.double_flap.plots import tip_displacements
    ours, theirs = tip_displacements(online), tip_displacements(plain)
    return {f"{side} tip, max difference / amplitude": float(np.abs(ours[side][after] - theirs[side][after]).max()
                                                           / np.ptp(theirs[side][after]))
            for side in theirs}


def summary(run: RunResults, start: int) -> dict[str, float]:
    iterations = run.windows.iterations
    fluid = run.component(fluid_of(run))
    static = next(run.component(n) for n in run.component_names() if n != fluid.name)
    attributes = run.attributes
    return {"iterations per window": float(iterations[start:].mean()),
            "fluid calls": int(iterations[start:].sum()),
            "windows": len(iterations) - start,
            "wall [s]": float(attributes["wall_seconds"]),
            "fluid compute [s]": float(fluid.compute_seconds.sum()),
            "solid compute [s]": float(static.compute_seconds.sum()),
            "surrogate training [s]": float(attributes.get("surrogate_training_seconds", 0.0)),
            "coupling waited for training [s]": float(attributes.get("surrogate_waiting_seconds", 0.0)),
            "surrogate calls [s]": float(attributes.get("surrogate_call_seconds", 0.0)),
            "surrogate fallback windows": int(attributes.get("surrogate_fallback_windows", 0)),
            "unconverged windows": int(attributes.get("windows_unconverged", 0))}


def table(case: str, runs: dict[str, RunResults], start: int) -> dict:
    """Print each run's summary over the windows from ``start`` and its accuracy against the first run's."""
    rows = {label: summary(run, start - 1) for label, run in runs.items()}
    baseline, *others = list(runs)
    print("| | " + " | ".join(runs) + " |")
    print("|" + " --- |" * (len(runs) + 1))
    for key in rows[baseline]:
        print(f"| {key} | " + " | ".join(f"{rows[label][key]:.4g}" for label in runs) + " |")
    reductions = {label: 1.0 - rows[label]["fluid calls"] / rows[baseline]["fluid calls"] for label in others}
    print("| fluid calls saved | | " + " | ".join(f"{reductions[label]:.1%}" for label in others) + " |")
    differences = {label: accuracy(case, runs[baseline], runs[label], start - 1) for label in others}
    for key in differences[others[0]]:
        print(f"| {key} | | " + " | ".join(f"{differences[label][key]:.3e}" for label in others) + " |")
    return {"rows": rows, "reductions": reductions}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=sorted(CASES))
    parser.add_argument("--start", type=int, help="the surrogate's start_window (default: the case's)")
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    parser.add_argument("--small", action="store_true")
    parser.add_argument("--compare", nargs="+", metavar="RUN", help="finished run folders: the first is the baseline")
    args = parser.parse_args(argv)
    if args.compare:
        if len(args.compare) < 2:
            parser.error("--compare needs a baseline run and at least one other")
        runs = {Path(path).name: RunResults(Path(path) / "results.h5") for path in args.compare}
        print(f"{args.case}: windows from window {args.start or CASES[args.case][2]}")
        return table(args.case, runs, args.start or CASES[args.case][2])
    scene, overrides, start = CASES[args.case]
    if args.small:
        overrides, start = overrides + SMALL[args.case][0], SMALL[args.case][1]
    start = args.start or start
    # settings of the surrogate's own table go to the surrogate run only; the rest to both
    own = [o for o in args.overrides if o.startswith("coupling.surrogate.")]
    overrides = overrides + [o for o in args.overrides if o not in own]
    out = fresh_directory(f"surrogate_{args.case}")
    print(f"machine: {machine()}")
    runs = {}
    for label, extra in (("plain", []), ("surrogate", [f"coupling.surrogate.start_window={start}", *own])):
        run_scene(load_scene(scene, overrides + extra), out / label, progress=False)
        runs[label] = RunResults(out / label / "results.h5")
    # the surrogate is used from window `start` on: the windows after its start are rows start - 1 onwards
    print(f"{args.case}: {len(runs['plain'].windows.iterations) - start + 1} windows from window {start} "
          f"(results in {out})")
    result = table(args.case, runs, start)
    return {"rows": result["rows"], "reduction": result["reductions"]["surrogate"], "out": out}


if __name__ == "__main__":
    main()
