"""``cosim libprecice``: build and install cosim's libprecice (preCICE's C++, C and Fortran APIs), or print the
variables that point an adapter's build and run at it."""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

from cosim.command import Command
from cosim.errors import CosimError


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("install", "env"),
                        help="install: build and install the library; env: print the variables that point at it")
    parser.add_argument("--prefix", type=Path,
                        help="where it goes (lib/, include/precice/, lib/pkgconfig/, lib/cmake/precice/); default: "
                             "the Python environment cosim runs in")
    parser.add_argument("--jobs", type=int, default=2, help="parallel compile jobs (install)")


def _run(args: argparse.Namespace) -> int:
    from precice_compat.libprecice.build import default_prefix, environment, install, installed
    if args.action == "install":
        prefix = install(args.prefix, jobs=args.jobs)
        print(f"# cosim's libprecice is in {prefix}; point an adapter's build and run at it with:")
    else:
        found = installed(args.prefix)
        if found is None:
            where = args.prefix or default_prefix()
            raise CosimError(f"cosim libprecice: no cosim libprecice in {where}; build it with `cosim libprecice "
                             f"install{f' --prefix {where}' if args.prefix else ''}`")
        prefix = found
    for name, value in environment(prefix).items():
        print(f"export {name}={shlex.quote(value)}")
    return 0


libprecice = Command(
    "build the drop-in libprecice for compiled adapters", _arguments, _run,
    "Build and install cosim's libprecice: preCICE v3's C++, C and Fortran APIs (precice/precice.hpp, "
    "precice/preciceC.h, the precicef_* subroutines), served by cosim's coupler instead of preCICE. It installs as "
    "preCICE installs itself (libprecice.so.3, libprecice.pc, find_package(precice 3 CONFIG)), so an adapter "
    "builds against it unchanged; `cosim run` puts it first on the library path of the participants it starts. "
    "`env` prints PKG_CONFIG_PATH, CMAKE_PREFIX_PATH and LD_LIBRARY_PATH for `eval`. Needs a C++ compiler, CMake, "
    "pkg-config, libzmq and msgpack-c.",
    "cosim libprecice install && eval \"$(cosim libprecice env)\"")
