"""How far a double-flap ROM answers the coupling's late sub-iteration steps from the solid it replaces.

The recorded solid calls of a run (forces, interface displacements, whole displacement fields) are
replayed through the ROM. Along each step between two consecutive sub-iterations of a window, from
iteration ``--from-iteration`` on (the late steps, near convergence, where the extra coupling
iterations are decided), the relative error of the ROM's change against the solid's:
|du~_rom - du~_solid| / |du~_solid| per reduced displacement (the solid's field projected on the
model's displacement modes) and ||du_rom - du_solid|| / ||du_solid|| on the interface; medians over
the steps, and the levels' errors next to them.

Usage: python -m cases.double_flap.step_error RESULTS MODEL [MODEL ...] [--windows 381-619] [--from-iteration 3]
  RESULTS: a double-flap run's results.h5 (or its directory) with the solid's calls recorded
  MODEL: trained double-flap models (.npz), each reported on one line
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from cosim.results import RunResults
from rom_component.static.load import load_rom

ROOT = Path(__file__).resolve().parent.parent


def step_errors(results: Path, model: Path, windows: tuple[int, int], first: int = 3) -> dict[str, np.ndarray]:
    """Median errors along the late steps and of the levels: per reduced displacement and on the interface."""
    rom = load_rom(model, "fast")
    a = rom.arrays
    with RunResults(results) as run:
        calls = run.calls("solid")
    keep = (calls.window >= windows[0]) & (calls.window <= windows[1])
    F = calls.inputs["force"][keep].reshape(keep.sum(), -1)
    interface = calls.outputs["displacement"][keep].reshape(keep.sum(), -1)
    reduced = (calls.outputs["displacement_field"][keep].reshape(keep.sum(), -1) - a["u_mean"]) @ a["Phi_u"]
    answers, reduced_rom = np.empty_like(interface), np.empty_like(reduced)
    for k, f in enumerate(F):        # the online path, one call at a time, as the coupling calls it
        answers[k] = rom(f)
        reduced_rom[k] = rom.reduced
    window, iteration = calls.window[keep], calls.iteration[keep]
    late = (np.diff(window) == 0) & (iteration[1:] >= first)
    if not late.any():
        raise SystemExit(f"{results}: no step from iteration {first} on in windows {windows[0]}-{windows[1]}")
    ds, dr = np.diff(reduced, axis=0)[late], np.diff(reduced_rom, axis=0)[late]
    du, dv = np.diff(interface, axis=0)[late], np.diff(answers, axis=0)[late]
    return {"steps": np.array(late.sum()),
            "reduced_steps": np.median(np.abs(dr - ds) / np.abs(ds), axis=0),
            "interface_steps": np.median(np.linalg.norm(dv - du, axis=1) / np.linalg.norm(du, axis=1)),
            "reduced_levels": np.median(np.abs(reduced_rom - reduced), axis=0) / reduced.std(axis=0),
            "interface_levels": np.median(np.linalg.norm(answers - interface, axis=1)
                                          / np.linalg.norm(interface, axis=1))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results", type=Path)
    parser.add_argument("models", type=Path, nargs="+")
    parser.add_argument("--windows", default="381-619", help="first-last window (1-based), default 381-619")
    parser.add_argument("--from-iteration", type=int, default=3, help="late steps: from this iteration on")
    args = parser.parse_args()
    try:
        low, high = (int(v) for v in args.windows.split("-"))
    except ValueError:
        parser.error(f"--windows {args.windows!r}: expected FIRST-LAST, e.g. 381-619")
    print(f"{args.results}, windows {low}-{high}, steps from iteration {args.from_iteration} on: median relative "
          "error of the ROM's change against the solid's (levels: error over the spread)")
    for model in args.models:
        e = step_errors(args.results, model, (low, high), args.from_iteration)
        print(f"{model.name}: {int(e['steps'])} steps; interface {100 * e['interface_steps']:.1f} % "
              f"(level {100 * e['interface_levels']:.3f} %)")
        print("  reduced displacements 1-{}, steps [%]: {}".format(
            len(e["reduced_steps"]), " ".join(f"{100 * v:.1f}" for v in e["reduced_steps"])))
        print("  reduced displacements, levels [% of spread]: " + " ".join(f"{100 * v:.2f}" for v in e["reduced_levels"]))


if __name__ == "__main__":
    main()
