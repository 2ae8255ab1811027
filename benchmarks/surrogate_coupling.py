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


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=sorted(CASES))
    parser.add_argument("--start", type=int, help="the surrogate's start_window (default: the case's)")
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    parser.add_argument("--small", action="store_true")
    args = parser.parse_args(argv)
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
    rows = {label: summary(run, start - 1) for label, run in runs.items()}
    reduction = 1.0 - rows["surrogate"]["fluid calls"] / rows["plain"]["fluid calls"]
    print(f"{args.case}: {rows['plain']['windows']} windows from window {start} (results in {out})")
    print("| | plain | surrogate |")
    print("| --- | --- | --- |")
    for key in rows["plain"]:
        print(f"| {key} | {rows['plain'][key]:.4g} | {rows['surrogate'][key]:.4g} |")
    print(f"| fluid calls saved | | {reduction:.1%} |")
    for key, value in accuracy(args.case, runs["plain"], runs["surrogate"], start - 1).items():
        print(f"| {key} | | {value:.3e} |")
    return {"rows": rows, "reduction": reduction}


if __name__ == "__main__":
    main()
