"""The ``cosim`` command line: ``serve`` here, every other subcommand from the package that owns
it, found through the entry-point group ``cosim.commands`` (so ``cosim`` imports nothing above it)."""

from __future__ import annotations

import argparse
import sys
from importlib.metadata import entry_points

from cosim.command import GROUP, Command
from cosim.errors import CosimError


def _serve_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("entry", help="package.module:Class")
    parser.add_argument("--bind", default="tcp://127.0.0.1:*", help="address to bind (default: loopback, any port)")
    parser.add_argument("--name", help="component name used in messages")
    parser.add_argument("--parent-pid", type=int, help="exit when this process is no longer the parent")


def _serve(args: argparse.Namespace) -> int:
    from cosim.server import serve
    return serve(args.entry, args.bind, args.name, args.parent_pid)


def commands() -> dict[str, Command]:
    """Every registered subcommand by name, ``serve`` included."""
    found = {"serve": Command("serve one component over ZeroMQ", _serve_arguments, _serve)}
    for point in sorted(entry_points(group=GROUP), key=lambda p: p.name):
        found.setdefault(point.name, point.load())
    return found


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cosim", description="Partitioned co-simulation with black-box components.")
    sub = p.add_subparsers(dest="command", required=True)
    for name, command in commands().items():
        command.arguments(sub.add_parser(name, help=command.help))
        sub.choices[name].set_defaults(func=command.run)
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
