"""``cosim run``: the coupler's subcommand (registered in pyproject.toml under ``cosim.commands``)."""

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


run = Command("run a scene", _arguments, _run)
