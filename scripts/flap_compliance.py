"""The double-flap solid's compliance against its ROMs': symmetry, definiteness, and change from window to window.

The Kratos solid is static and hyperelastic: its response to a small change of the interface force is a
compliance C = du/df that is symmetric (Maxwell-Betti) and positive definite. Seen through an orthonormal basis
Q of the interface's displacement modes (the work basis of ``model.force_basis = "work"``; the 9 modes of
the first model's training data), G = Q^T C Q is a 9 x 9 matrix. For each window asked for, at the converged
force of the run's window (central differences, step 1e-3 of the force's norm), this prints:
- the solid's eigenvalues of G and its asymmetry ||G - G^T|| / ||G||;
- each model's eigenvalues (real parts; "i": a complex pair), asymmetry, and ||G_rom - G|| / ||G||;
- over consecutive windows, how much the response to the force modes (the first model's POD force modes, or
  its work basis) changes from one window to the next, ROM and solid: the columns IQN-ILS reuses.

Usage: python scripts/flap_compliance.py RESULTS --windows 376,390,400 MODEL [MODEL ...] [--drift 420-432]
  RESULTS: a double-flap run's results.h5 (its recorded solid calls); MODEL: trained models (.npz)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from cosim.results import RunResults  # noqa: E402
from rom_component import persistence  # noqa: E402


def work_basis(model: Path) -> np.ndarray:
    """Orthonormal basis of the interface rows of the model's displacement modes (rows: the interface values in
    the force's order)."""
    arrays, _ = persistence.load_arrays(model)
    basis, _, _ = np.linalg.svd(arrays["A"], full_matrices=False)
    return basis


def responses(solve, f0: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Central-difference responses (k, n_out) of ``solve`` at ``f0`` along the columns of ``directions``."""
    h = 1e-3 * np.linalg.norm(f0)
    return np.array([(solve(f0 + h * d) - solve(f0 - h * d)) / (2 * h) for d in directions.T])


def describe(G: np.ndarray) -> str:
    values = np.linalg.eigvals(G)
    values = values[np.argsort(values.real)]
    big = np.abs(values).max()
    text = " ".join(f"{v.real:9.2e}" + ("i" if abs(v.imag) > 1e-3 * big else " ") for v in values)
    return f"{text}  asym {np.linalg.norm(G - G.T) / np.linalg.norm(G):.3f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path)
    parser.add_argument("models", type=Path, nargs="+")
    parser.add_argument("--windows", default="", help="windows to compare the compliance at, comma-separated")
    parser.add_argument("--drift", default="", help="FIRST-LAST: windows over which to compare the response's change")
    args = parser.parse_args()
    from solid_component.kratos import standalone_solid

    with RunResults(args.results) as run:
        calls = run.calls("solid", converged_only=True)
        forces = calls.inputs["force"].reshape(len(calls.window), -1)
        window_of = {int(w): k for k, w in enumerate(calls.window)}
    Q = work_basis(args.models[0])
    roms = {m.stem: persistence.load(m, "reproducible") for m in args.models}
    solid = standalone_solid(ROOT / "scenes" / "double_flap" / "solid.mdpa")

    def fom(f: np.ndarray) -> np.ndarray:
        return np.ravel(solid.step(0.0, 0.008, {"force": f.reshape(-1, 2)})["displacement"]).copy()

    try:
        print(f"compliance in the work basis of {args.models[0].name} (eigenvalues, m/N), at the converged force of "
              f"{args.results}'s windows")
        for w in [int(x) for x in args.windows.split(",") if x]:
            f0 = forces[window_of[w]]
            G = Q.T @ responses(fom, f0, Q).T
            print(f"window {w:>4} solid {describe(G)}")
            for name, rom in roms.items():
                G_rom = Q.T @ responses(rom, f0, Q).T
                print(f"     {name:>16} {describe(G_rom)}  error {np.linalg.norm(G_rom - G) / np.linalg.norm(G):.3f}")
        if args.drift:
            first, last = (int(x) for x in args.drift.split("-"))
            arrays, _ = persistence.load_arrays(args.models[0])
            modes = arrays["Phi_f"]
            for name, solve in [("solid", fom)] + list(roms.items()):
                J = [responses(solve, forces[window_of[w]], modes) for w in range(first, last + 1)]
                change = [np.linalg.norm(b - a) / np.linalg.norm(a) for a, b in zip(J, J[1:])]
                print(f"response to the {modes.shape[1]} force directions of {args.models[0].name}, windows "
                      f"{first}-{last}, change from one window to the next: {name} median {np.median(change):.4f}, "
                      f"largest {max(change):.4f}")
    finally:
        solid.close()


if __name__ == "__main__":
    main()
