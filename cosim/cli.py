"""The ``cosim`` command line: ``serve`` here, every other subcommand from the package that owns
it, found through the entry-point group ``cosim.commands`` (so ``cosim`` imports nothing above it)."""

from __future__ import annotations

import argparse
import sys
import textwrap
import warnings
from pathlib import Path

from cosim.command import GROUP, Command
from cosim.errors import CosimError
from cosim.registry import entry_points

DISTRIBUTION = "cosim-rom-fsi"
# the commands in the order of a user's work: check and run a case, watch it, train and export a ROM, weigh it, run
# many; serving a component by hand and its keys last (others' commands after these, by name)
ORDER = ("check", "run", "status", "plot", "train", "export-fmu", "report", "sweep", "campaign", "stability",
         "libprecice", "serve", "keys")


def _serve_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("entry", help="the component class, package.module:Class")
    parser.add_argument("--bind", default="tcp://127.0.0.1:*", help="address to bind (default: loopback, any port)")
    parser.add_argument("--name", help="component name used in messages")
    parser.add_argument("--parent-pid", type=int, help="exit when this process is no longer the parent")
    parser.add_argument("--curve", metavar="DIR", help="CURVE on, with the server key of DIR (from `cosim keys DIR`); "
                        "only the clients whose public keys are in DIR/clients are answered; needed for a "
                        "non-loopback --bind")
    parser.add_argument("--folder", action="append", default=[], type=Path, metavar="DIR",
                        help="a folder whose modules come before the installed ones (a scene's folder; repeatable; "
                        "the working directory comes after them)")


def _serve(args: argparse.Namespace) -> int:
    from cosim.server import serve
    return serve(args.entry, args.bind, args.name, args.parent_pid, args.curve, args.folder)


def _keys_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", help="the key directory to create (existing keys are never overwritten)")


def _keys(args: argparse.Namespace) -> int:
    from cosim.curve import make_keys
    for path in make_keys(args.dir):
        print(f"wrote {path}")
    print(f"the serving machine needs {args.dir}/server.key_secret and {args.dir}/clients/; the coupler's machine "
          f"{args.dir}/client.key_secret and {args.dir}/server.key")
    return 0


def commands(only: str | None = None) -> dict[str, Command]:
    """Every registered subcommand by name, ``serve`` included; with ``only``, that one alone if it exists (its
    package alone is imported: a component's ``cosim serve`` loads none of the others)."""
    found = {"serve": Command(
        "serve one component over ZeroMQ", _serve_arguments, _serve,
        "Serve one component (a class of the component contract) over ZeroMQ, as the coupler launches each "
        "component; by hand, to couple a component the scene names by address (components.NAME.address). Binds "
        "to loopback only, unless CURVE is on (--curve DIR; the scene then sets components.NAME.curve = DIR).",
        "cosim serve my_solid:MySolid --bind tcp://0.0.0.0:5555 --curve keys"),
             "keys": Command(
        "make CURVE key pairs for remote components", _keys_arguments, _keys,
        "Make a server and a client CURVE key pair (pyzmq's zmq.auth) in a new directory, the client authorised "
        "by the server: `cosim serve ... --curve DIR` on the machine that serves a component, and "
        "components.NAME.curve = DIR in the coupler's scene.",
        "cosim keys keys")}
    if only in found:
        return {only: found[only]}
    points = sorted(entry_points(group=GROUP), key=lambda p: p.name)
    if only in {point.name for point in points}:
        points = [point for point in points if point.name == only]
    for point in points:
        found.setdefault(point.name, point.load())
    rank = {name: i for i, name in enumerate(ORDER)}
    return dict(sorted(found.items(), key=lambda item: (rank.get(item[0], len(ORDER)), item[0])))


def version() -> str:
    """The installed distribution's version."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed
    try:
        return installed(DISTRIBUTION)
    except PackageNotFoundError:
        return "unknown (not installed)"


def parser(only: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser: every subcommand, or ``only`` that one when it is one (``main`` builds the parser
    of the subcommand it is given, so that a command imports its own package only)."""
    p = argparse.ArgumentParser(prog="cosim", description="Partitioned co-simulation with black-box components.")
    p.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    sub = p.add_subparsers(dest="command", required=True)
    for name, command in commands(only).items():
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
        given = sys.argv[1:] if argv is None else argv
        # Ctrl-C while the commands load is an interruption too
        args = parser(given[0] if given and not given[0].startswith("-") else None).parse_args(argv)
        command = f"cosim {args.command}"
        with warnings.catch_warnings():
            # NumPy's arithmetic warnings (an overflow while a run diverges) are not printed: the run checks its
            # values and states what failed in its one line
            warnings.simplefilter("ignore", RuntimeWarning)
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
