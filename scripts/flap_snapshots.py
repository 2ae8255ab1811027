"""Write tests/data/flap_snapshots.npz: real double-flap solid calls for the tests, compressed losslessly
enough by POD.

Takes every ``--every``-th recorded solid call of a double-flap FOM-FOM run with t <= ``--t-max`` and
stores the forces (530 values) in their leading 60 POD modes and the displacement fields (3610 values)
in their leading 30 (mean, modes and coefficients in float32; the energy left out is printed), with
each call's window and the interface index K of the 530 interface values in the field.

Usage: python -m scripts.flap_snapshots runs/campaign/fom/runs/run-d3cece0ee6/results.h5 (Re = 178.6) [--every 2] [--t-max 3.0]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from rom_component.recorded import interface_index, read_snapshots
from rom_component.reduction.pod import centred_pod
from rom_component.static.train import load_config

ROOT = Path(__file__).resolve().parent.parent


def compress(X: np.ndarray, rank: int) -> tuple[dict[str, np.ndarray], float]:
    mean, modes, s = centred_pod(X, rank)
    left_out = float(np.sum(s[rank:] ** 2) / np.sum(s ** 2))
    coefficients = (X - mean) @ modes
    return {"mean": mean.astype(np.float32), "modes": modes.astype(np.float32),
            "coefficients": coefficients.astype(np.float32)}, left_out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results")
    parser.add_argument("--every", type=int, default=2)
    parser.add_argument("--t-max", type=float, default=3.0)
    parser.add_argument("--out", default=str(ROOT / "tests" / "data" / "flap_snapshots.npz"))
    args = parser.parse_args()
    config = load_config(ROOT / "rom_configs" / "double_flap_rom.toml", [f"snapshots.t_max={args.t_max}"])
    F, U, times, windows = read_snapshots(args.results, config["snapshots"])
    keep = slice(None, None, args.every)
    F, U, windows = F[keep], U[keep], windows[keep]
    force, force_left = compress(F, 60)
    field, field_left = compress(U, 30)
    arrays = {**{f"force_{k}": v for k, v in force.items()}, **{f"field_{k}": v for k, v in field.items()},
              "window": windows.astype(np.int32),
              "interface_index": interface_index(args.results, config["snapshots"]).astype(np.int32)}
    np.savez_compressed(args.out, **arrays)  # type: ignore[arg-type]  # numpy's stub takes allow_pickle for a keyword
    print(f"{len(F)} calls (t <= {times.max():g} s, every {args.every}); energy left out: forces {force_left:.1e}, "
          f"fields {field_left:.1e}; wrote {args.out} ({Path(args.out).stat().st_size / 1e6:.2f} MB)")


if __name__ == "__main__":
    main()
