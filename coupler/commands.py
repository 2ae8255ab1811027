"""The coupler's subcommands ``cosim run`` and ``cosim sweep`` (registered in pyproject.toml under
``cosim.commands``)."""

from __future__ import annotations

import argparse

from cosim.command import Command


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--out", default="runs/latest", help="output directory (default: runs/latest)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace a finished run in --out (never one in progress)")


def _run(args: argparse.Namespace) -> int:
    from coupler.run import run_scene
    from cosim.scene import load_scene

    scene = load_scene(args.scene, args.set or [])
    summary = run_scene(scene, args.out, progress=not args.quiet, overwrite=args.overwrite)
    unconverged = f" ({summary.unconverged} did not converge)" if summary.unconverged else ""
    print(f"{summary.windows} windows{unconverged}, {summary.iterations} coupling iterations "
          f"(mean {summary.mean_iterations:.3f} per window), wall {summary.wall_seconds:.2f} s; "
          f"results in {summary.out_dir / 'results.h5'}")
    return 0


def _sweep_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                        help="values of one key; the sweep runs the Cartesian product of all --grid options")
    parser.add_argument("--runs", metavar="FILE", help="one run per line: KEY=VALUE items separated by spaces")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value in every run")
    parser.add_argument("--out", required=True, help="sweep directory: sweep.csv and runs/<name>/")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler (tcp://host:port) instead")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _sweep(args: argparse.Namespace) -> int:
    from coupler.sweep import file_runs, grid_runs, run_sweep
    from cosim.errors import SceneError

    if bool(args.grid) == bool(args.runs):
        raise SceneError("give --grid options or a --runs file (one of them)")
    if args.workers < 1:
        raise SceneError(f"--workers is {args.workers}; allowed: an integer >= 1")
    common = args.set or []
    runs = grid_runs(args.grid, common) if args.grid else file_runs(args.runs, common)
    table = run_sweep(args.scene, runs, args.out, args.workers, args.scheduler, progress=not args.quiet)
    print(f"{len(runs)} runs; table in {table}")
    return 0


run = Command("run a scene", _arguments, _run)
sweep = Command("run many variants of a scene on Dask (a local cluster or a scheduler)", _sweep_arguments, _sweep)
