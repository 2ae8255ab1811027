"""The ``cosim`` command line: ``serve`` here, every other subcommand from the package that owns
it, found through the entry-point group ``cosim.commands`` (so ``cosim`` imports nothing above it)."""

from __future__ import annotations

import argparse
import sys
import textwrap
from importlib.metadata import entry_points

from cosim.command import GROUP, Command
from cosim.errors import CosimError

DISTRIBUTION = "cosim-rom-fsi"


def _serve_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("entry", help="the component class, package.module:Class")
    parser.add_argument("--bind", default="tcp://127.0.0.1:*", help="address to bind (default: loopback, any port)")
    parser.add_argument("--name", help="component name used in messages")
    parser.add_argument("--parent-pid", type=int, help="exit when this process is no longer the parent")


def _serve(args: argparse.Namespace) -> int:
    from cosim.server import serve
    return serve(args.entry, args.bind, args.name, args.parent_pid)


def commands() -> dict[str, Command]:
    """Every registered subcommand by name, ``serve`` included."""
    found = {"serve": Command(
        "serve one component over ZeroMQ", _serve_arguments, _serve,
        "Serve one component (a class of the component contract) over ZeroMQ, as the coupler launches each "
        "component; by hand, to couple a component the scene names by address. Binds to loopback only.",
        "cosim serve my_solid:MySolid --bind tcp://127.0.0.1:5555")}
    for point in sorted(entry_points(group=GROUP), key=lambda p: p.name):
        found.setdefault(point.name, point.load())
    return found


def version() -> str:
    """The installed distribution's version."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed
    try:
        return installed(DISTRIBUTION)
    except PackageNotFoundError:
        return "unknown (not installed)"


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cosim", description="Partitioned co-simulation with black-box components.")
    p.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    sub = p.add_subparsers(dest="command", required=True)
    for name, command in commands().items():
        epilog = f"example:\n  {command.example}" if command.example else None
        description = textwrap.fill(command.description or command.help, 100)
        command.arguments(sub.add_parser(name, help=command.help, description=description, epilog=epilog,
                                         formatter_class=argparse.RawDescriptionHelpFormatter))
        sub.choices[name].set_defaults(func=command.run)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one subcommand; its exit code: 0, 2 for bad input (one line on stderr), 130 when interrupted."""
    command = "cosim"
    try:
        args = parser().parse_args(argv)     # Ctrl-C while the commands load is an interruption too
        command = f"cosim {args.command}"
        return _call(args)
    except KeyboardInterrupt:
        print(f"{command}: interrupted; components stopped", file=sys.stderr)
        return 130


def _call(args: argparse.Namespace) -> int:
    if isinstance(getattr(args, "out", None), str) and not args.out.strip():
        print(f"cosim {args.command}: error: --out is empty; name a directory or file", file=sys.stderr)
        return 2
    try:
        return args.func(args)
    except CosimError as exc:
        print(f"cosim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:   # the file system said no: a full disk, a path under a file, no permission
        where = f" '{exc.filename}'" if exc.filename else ""
        print(f"cosim {args.command}: error:{where} {exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
