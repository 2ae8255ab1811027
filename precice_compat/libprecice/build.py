"""Building and finding cosim's libprecice: preCICE v3's C++, C and Fortran APIs served by cosim's coupler.

``cosim libprecice install`` builds the library from the sources beside this module with CMake and installs it as
preCICE installs itself, by default into the Python environment cosim runs in (``sys.prefix``): ``lib/libprecice.so.3``,
``include/precice/``, ``lib/pkgconfig/libprecice.pc`` and ``lib/cmake/precice/``. An adapter then builds against it
unchanged (pkg-config or ``find_package(precice 3 CONFIG)``), and ``cosim run`` puts its ``lib`` first on the library
path of every participant it starts, so an adapter built against preCICE itself runs on it too.

It needs a C++ compiler, CMake, pkg-config, libzmq and msgpack-c (Debian: ``g++ cmake pkg-config libzmq3-dev
libmsgpack-dev``); the rest of cosim needs none of them.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from cosim.errors import CosimError

SOURCE = Path(__file__).resolve().parent
LIBRARY = "libprecice.so.3"
MARK = "served by cosim"          # in the installed libprecice.pc: a prefix whose libprecice is cosim's
PACKAGES = "g++ cmake pkg-config libzmq3-dev libmsgpack-dev"


def default_prefix() -> Path:
    """Where the library goes unless told: the Python environment cosim runs in."""
    return Path(sys.prefix)


def installed(prefix: Path | None = None) -> Path | None:
    """The prefix holding cosim's libprecice (``prefix``, else the default one), or None if it is not there."""
    prefix = Path(prefix) if prefix is not None else default_prefix()
    pc = prefix / "lib" / "pkgconfig" / "libprecice.pc"
    try:
        ours = MARK in pc.read_text()
    except OSError:
        return None
    return prefix if ours and (prefix / "lib" / LIBRARY).exists() else None


def environment(prefix: Path) -> dict[str, str]:
    """The variables that point an adapter's build and its run at the library under ``prefix``."""
    def first(name: str, value: Path) -> str:
        return os.pathsep.join(dict.fromkeys(filter(None, [str(value), *os.environ.get(name, "").split(os.pathsep)])))
    return {"PKG_CONFIG_PATH": first("PKG_CONFIG_PATH", prefix / "lib" / "pkgconfig"),
            "CMAKE_PREFIX_PATH": first("CMAKE_PREFIX_PATH", prefix),
            "LD_LIBRARY_PATH": first("LD_LIBRARY_PATH", prefix / "lib")}


def missing_tools() -> list[str]:
    """The build's tools and libraries this machine lacks (empty: it can build)."""
    missing = [tool for tool in ("cmake", "pkg-config") if shutil.which(tool) is None]
    if not any(shutil.which(c) for c in (os.environ.get("CXX", ""), "c++", "g++", "clang++") if c):
        missing.append("a C++ compiler")
    if shutil.which("pkg-config"):
        for module, name in (("libzmq", "libzmq"), ("msgpack-c msgpack", "msgpack-c")):
            found = any(subprocess.run(["pkg-config", "--exists", m], capture_output=True).returncode == 0
                        for m in module.split())
            if not found:
                missing.append(name)
    return missing


def install(prefix: Path | None = None, build: Path | None = None, jobs: int = 2, quiet: bool = False) -> Path:
    """Configure, build and install the library into ``prefix`` (a build folder kept under it for the next build);
    the prefix. A missing tool or a failed step is a CosimError naming it."""
    prefix = (Path(prefix) if prefix is not None else default_prefix()).resolve()
    missing = missing_tools()
    if missing:
        raise CosimError(f"cosim libprecice: this machine lacks {', '.join(missing)} (Debian: apt-get install "
                         f"{PACKAGES})")
    build = Path(build) if build is not None else prefix / "share" / "cosim-libprecice" / "build"
    build.mkdir(parents=True, exist_ok=True)
    log = build / "build.log"
    steps = [["cmake", "-S", str(SOURCE), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
              f"-DCMAKE_INSTALL_PREFIX={prefix}", "-DCMAKE_INSTALL_LIBDIR=lib"],
             ["cmake", "--build", str(build), "--parallel", str(max(1, jobs))],
             ["cmake", "--install", str(build)]]
    with open(log, "w") as stream:
        for step in steps:
            if not quiet:
                print(" ".join(step[:3]), "...", file=sys.stderr)
            stream.write("$ " + " ".join(step) + "\n")
            stream.flush()
            done = subprocess.run(step, stdout=stream, stderr=subprocess.STDOUT)
            if done.returncode:
                raise CosimError(f"cosim libprecice: `{' '.join(step[:3])}` failed (exit {done.returncode}): "
                                 f"{_last_error(log)} (the whole log: {log})")
    return prefix


def _last_error(log: Path) -> str:
    """The build log's first line that says error, else its last line."""
    lines = [line.strip() for line in log.read_text(errors="replace").splitlines() if line.strip()]
    errors = [line for line in lines if "error" in line.lower()]
    return (errors or lines or ["no output"])[0][:300]
