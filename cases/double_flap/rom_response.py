"""How a double-flap ROM answers a change of force, against the Kratos solid it replaces.

For each POD force mode phi_k of the model, the response (u(f0 + h phi_k) - u(f0 - h phi_k)) / 2h on the
interface of the ROM and of the Kratos solid at a recorded force f0: its size ratio (ROM / solid) and the
cosine of the angle between the two. The coupling's sub-iterations step in every direction, so a ROM that
answers weak modes with large gains of its own makes the loop learn directions the solid does not have.

With ``--steps``: instead, along each step between the window's sub-iterations (the directions the
coupling actually moves the force in), the relative error of the ROM's directional response against the
solid's, ||J_rom d - J_fom d|| / ||J_fom d||.

Usage: python -m cases.double_flap.rom_response MODEL RESULTS [--window N] [--steps]
  MODEL: a trained double-flap model (.npz); RESULTS: a double-flap run's results.h5 (f0: the last call
  of window N, default the middle window)
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from cosim.results import RunResults
from rom_component import model_file
from rom_component.static.load import load_rom

ROOT = Path(__file__).resolve().parent.parent


def responses(model: Path, results: Path, window: int | None,
              steps: bool = False) -> list[Any]:
    """Per force mode: (mode index, size ratio ROM / solid, cosine); with ``steps``: per sub-iteration step of
    the window, the relative error of the ROM's response along it."""
    from kratos_solvers.solid import standalone_solid
    rom = load_rom(model, "reproducible")
    arrays, _ = model_file.load_arrays(model)
    with RunResults(results) as run:
        calls = run.calls("solid")
        window = int(np.median(calls.window)) if window is None else window
        forces = calls.inputs["force"][np.flatnonzero(calls.window == window)].reshape(-1, arrays["Phi_f"].shape[0])
    f0 = forces[-1]
    if steps:
        moves = np.diff(forces, axis=0)
        directions = moves / np.linalg.norm(moves, axis=1, keepdims=True)
    else:
        directions = arrays["Phi_f"].T
    solid = standalone_solid(ROOT / "scenes" / "double_flap" / "solid.mdpa")
    try:
        def fom(f: np.ndarray) -> np.ndarray:
            return np.ravel(solid.step(0.0, 0.008, {"force": f.reshape(-1, 2)})["displacement"]).copy()

        h = 1e-3 * np.linalg.norm(f0)
        rows: list = []
        for k, d in enumerate(directions):
            j_fom = (fom(f0 + h * d) - fom(f0 - h * d)) / (2 * h)
            j_rom = (rom(f0 + h * d) - rom(f0 - h * d)) / (2 * h)
            if steps:
                rows.append(float(np.linalg.norm(j_rom - j_fom) / np.linalg.norm(j_fom)))
            else:
                rows.append((k, float(np.linalg.norm(j_rom) / np.linalg.norm(j_fom)),
                             float(j_fom @ j_rom / (np.linalg.norm(j_fom) * np.linalg.norm(j_rom)))))
    finally:
        solid.close()
    print(f"model {model}, f0: the last call of window {window} of {results}")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("results", type=Path)
    parser.add_argument("--window", type=int)
    parser.add_argument("--steps", action="store_true", help="along the window's sub-iteration steps instead")
    args = parser.parse_args()
    if args.steps:
        errors = responses(args.model, args.results, args.window, steps=True)
        print("relative error of the ROM's response along each sub-iteration step: "
              + " ".join(f"{e:.2f}" for e in errors) + f"; median {np.median(errors):.3f}")
        return
    rows = responses(args.model, args.results, args.window)
    print(f"{'mode':>4} {'|J_rom phi| / |J_fom phi|':>26} {'cos(J_rom phi, J_fom phi)':>26}")
    for k, ratio, cosine in rows:
        print(f"{k + 1:>4} {ratio:>26.2f} {cosine:>26.3f}")
    for lo, hi in ((0, 15), (15, 30), (30, len(rows))):
        part = rows[lo:hi]
        if part:
            print(f"modes {lo + 1}-{hi}: median ratio {np.median([r[1] for r in part]):.2f}, "
                  f"median cos {np.median([r[2] for r in part]):.3f}")


if __name__ == "__main__":
    main()
