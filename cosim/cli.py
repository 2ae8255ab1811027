"""The ``cosim`` command line: run, serve."""

from __future__ import annotations

import argparse
import sys

from cosim.errors import CosimError


def _run(args: argparse.Namespace) -> int:
    from coupler.run import run_scene  # the application layer; cosim itself does not depend on it
    from cosim.scene import load_scene

    scene = load_scene(args.scene, args.set or [])
    summary = run_scene(scene, args.out, progress=not args.quiet)
    print(f"{summary.windows} windows, {summary.iterations} coupling iterations "
          f"(mean {summary.mean_iterations:.3f} per window), wall {summary.wall_seconds:.2f} s; "
          f"results in {summary.out_dir / 'results.h5'}")
    return 0


def _serve(args: argparse.Namespace) -> int:
    from cosim.server import serve
    return serve(args.entry, args.bind, args.name, args.parent_pid)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cosim", description="Partitioned co-simulation with black-box components.")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene")
    run.add_argument("scene", help="scene file (TOML)")
    run.add_argument("--out", default="runs/latest", help="output directory (default: runs/latest)")
    run.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=_run)
    serve = sub.add_parser("serve", help="serve one component over ZeroMQ")
    serve.add_argument("entry", help="package.module:Class")
    serve.add_argument("--bind", default="tcp://127.0.0.1:*", help="address to bind (default: loopback, any port)")
    serve.add_argument("--name", help="component name used in messages")
    serve.add_argument("--parent-pid", type=int, help="exit when this process is no longer the parent")
    serve.set_defaults(func=_serve)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        return args.func(args)
    except CosimError as exc:
        print(f"cosim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"cosim {args.command}: interrupted; components stopped", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
