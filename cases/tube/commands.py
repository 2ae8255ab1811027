"""``cosim stability``: the elastic tube's stability matrix (registered in pyproject.toml under ``cosim.commands``)."""

from __future__ import annotations

import argparse

from cosim.command import Command
from coupler.commands import _numbers, _scheduler, _scheduler_arguments


def _stability_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="the tube scene (TOML)")
    parser.add_argument("--out", required=True,
                        help="directory: sweep.csv, spectral.csv, stability.png, contraction.png, runs/")
    parser.add_argument("--factors", default="0.1,0.3,1,10,100", help="stiffness factors (default 0.1,0.3,1,10,100)")
    parser.add_argument("--dts", default="0.1,0.01,0.001", help="time steps (default 0.1,0.01,0.001)")
    parser.add_argument("--methods", default="none,constant,aitken,iqn-ils,iqn-ils-reuse0,iqn-imvj,iqn-surrogate",
                        help="accelerations (default: all seven; iqn-surrogate with the online surrogate from window 6)")
    parser.add_argument("--wall-law", default="linear", choices=["linear", "piecewise"],
                        help="the tube wall's law: 'linear' keeps the small-strain modulus at every strain, as the "
                             "theory assumes; 'piecewise' is the scene's (default linear)")
    parser.add_argument("--windows", type=int, default=20, help="windows per run (default 20)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value in every run")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    _scheduler_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _stability(args: argparse.Namespace) -> int:
    import csv
    from pathlib import Path

    from cases.tube.stability import MATRIX_KEYS, METHODS, matrix_runs, plot_contraction, plot_matrix, spectral_table
    from cosim.errors import SceneError
    from coupler.sweep import run_sweep

    factors, dts = _numbers(args.factors, "--factors"), _numbers(args.dts, "--dts")
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise SceneError(f"--methods names {', '.join(unknown)}; known: {', '.join(METHODS)}")
    if args.windows < 1:
        raise SceneError(f"--windows is {args.windows}; allowed: an integer >= 1")
    out = Path(args.out)
    common = args.set or []
    spectra = spectral_table(args.scene, factors, dts, args.wall_law, common)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "spectral.csv", "w", newline="") as stream:
        writer = csv.DictWriter(stream, ["stiffness_factor", "dt", "spectral_radius", "theory"])
        writer.writeheader()
        writer.writerows(spectra)
    table = run_sweep(args.scene, matrix_runs(factors, dts, methods, args.windows, args.wall_law, common), out,
                      args.workers, _scheduler(args), progress=not args.quiet, keys=MATRIX_KEYS)
    with open(table, newline="") as stream:
        rows = list(csv.DictReader(stream))
    plot_matrix(rows, spectra, methods, factors, dts, out / "stability.png")
    plot_contraction(rows, spectra, out / "contraction.png")
    print(f"{len(rows)} runs; {table}, {out / 'spectral.csv'}, {out / 'stability.png'}, {out / 'contraction.png'}")
    return 0


stability = Command(
    "the tube's stability matrix: stiffness x time step per method, against theory",
    _stability_arguments, _stability,
    "Run the tube for every stiffness factor x time step x acceleration method as a sweep on Dask, compute the "
    "plain Gauss-Seidel spectral radius of each (stiffness, time step) from finite-difference Jacobians of the "
    "real fluid and solid, and draw the matrix of mean iterations with both rho = 1 boundaries.",
    "cosim stability scenes/tube_fom.toml --out runs/stability --factors 0.3,1,3 --dts 0.1,0.01")
