"""Probe the double flap's Kratos solid along the force modes of its training data, for a ROM's training set.

A ROM fitted to the recorded calls alone answers the weak force modes with gains of its own: along the run
those modes move with the strong ones, so the data do not fix the response to each. The solid is static (each
call a nonlinear solve for the given force; nothing carried from call to call), so it can be asked directly:
at BASES converged forces of the training data, one call per POD force mode k, at the force plus AMPLITUDE
times mode k's training range (a random sign), for the modes MODES (by default 16-60: the response to the 15
leading ones the recorded calls fix). With ``snapshots.probes`` a ROM trains on these calls next to the
recorded ones (``cosim train``). Measured: the ROM then answers the weak modes as the solid does, and the
coupling needs more iterations (README, "Probes of the solid along the weak force modes").

Writes an .npz (no pickle): ``force`` (p, 530), ``<field>`` (p, 3610) and ``displacement`` (p, 530), and per
probe the ``time`` and ``window`` of its base call. First it re-solves the base forces and checks that the
solid gives back the recorded fields (the calls do not depend on the calls before them).

Usage: python scripts/flap_probes.py RESULTS [RESULTS ...] --out PROBES.npz [--t-max 3.0] [--bases 30]
                                     [--modes 16-60] [--amplitude 0.25] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from rom_component.probes import ProbeFailed, ask, probe_forces, save_probes  # noqa: E402
from rom_component.train import load_config, read_training_set  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="+", help="double-flap runs whose recorded solid calls are the training set")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--t-max", type=float, default=3.0, help="training calls: windows ending at or before (s)")
    parser.add_argument("--bases", type=int, default=30, help="converged forces to probe around, evenly spread")
    parser.add_argument("--modes", default="16-60", help="POD force modes to probe along, FIRST-LAST (1: the leading "
                        "one; the default leaves out the 15 leading, whose response the recorded calls fix)")
    parser.add_argument("--amplitude", type=float, default=0.25, help="step along mode k: this times its range")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--along", type=Path, help="a trained model (.npz): probe along its force basis (Phi_f, "
                        "such as the work basis of model.force_basis = 'work') instead of the forces' POD modes")
    args = parser.parse_args(argv)
    from solid_component.kratos import standalone_solid

    spec = load_config(ROOT / "scenes" / "double_flap_rom.toml", [f"snapshots.t_max={args.t_max}"])["snapshots"]
    F, U, times, windows = read_training_set(args.results, spec)
    try:
        first, last = (int(k) for k in args.modes.split("-"))
    except ValueError:
        parser.error(f"--modes is {args.modes!r}; give FIRST-LAST, e.g. 16-60")
    basis = None
    if args.along:
        from rom_component.persistence import load_arrays
        basis = load_arrays(args.along)[0]["Phi_f"]
        if not last <= basis.shape[1]:
            parser.error(f"--modes {args.modes} goes beyond the {basis.shape[1]} directions of {args.along}")
    forces, base = probe_forces(F, windows, args.bases, range(first - 1, last), args.amplitude, args.seed, basis)
    solid = standalone_solid(ROOT / "scenes" / "double_flap" / "solid.mdpa")
    try:
        def solve(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            out = solid.step(0.0, 0.008, {"force": f.reshape(-1, 2)})
            field = solid.get_values(["displacement_field"])["displacement_field"]
            return np.ravel(out["displacement"]).copy(), np.ravel(field).copy()

        again = np.unique(base)[:5]
        try:
            drift = float(np.abs(ask(solve, F[again])[1] - U[again]).max() / np.abs(U[again]).max())
        except ProbeFailed as exc:
            raise SystemExit(f"flap_probes: the solid failed to re-solve the recorded call of window "
                             f"{windows[again[exc.row]]}: {exc.reason}") from None
        print(f"re-solved {len(again)} recorded calls: largest difference {drift:.2e} of the largest displacement")
        if drift > 1e-4:   # the Newton solve's own tolerance: it starts from the last call's state
            raise SystemExit("the solid does not give back its recorded calls: probes would not be its calls")
        started = time.perf_counter()
        try:
            displacement, field = ask(solve, forces)
        except ProbeFailed as exc:
            raise SystemExit(f"flap_probes: the solid failed on the probe at window {windows[base[exc.row]]}, mode "
                             f"{first + exc.row % (last - first + 1)}: {exc.reason}") from None
        seconds = time.perf_counter() - started
    finally:
        solid.close()
    save_probes(args.out, forces, {"displacement": displacement, "displacement_field": field}, times[base],
                windows[base])
    n_bases = len(np.unique(base))
    print(f"{len(forces)} probes ({n_bases} bases x {len(forces) // n_bases} modes, amplitude {args.amplitude} of "
          f"each mode's range) in {seconds:.0f} s ({1e3 * seconds / len(forces):.1f} ms a call): {args.out}")


if __name__ == "__main__":
    main()
