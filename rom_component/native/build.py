"""How the ROMs' C code is built: the compiler call, and the cache of the libraries the in-process
``arithmetic = "compiled"`` paths load (a ROM's source, the runtime and the in-process entry points; no FMI header,
hence no fmpy). The FMU export compiles the same sources with its FMI entry points through ``compile_library``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

from cosim.errors import CosimError

C_SOURCES = Path(__file__).parent      # the runtime, the ROMs' sources and the in-process entry points
RUNTIME = "rom_runtime.c"              # compiled with every ROM's source
IN_PROCESS = "in_process.c"            # the entry points of the in-process library
HEADERS = ("rom_fmu.h", "rom_arithmetic.h")
NAME_BYTES = 32         # a variable's name in a resource's header


def compile_library(files: Sequence[Path], include: Path, target: Path, defines: tuple[str, ...] = (), *,
                    needs: str, what: str) -> None:
    """Build the shared library ``target`` of the C ``files`` (headers from ``include``): plain flags suffice, the
    sources fix their floating-point contract. ``needs`` and ``what`` name the build in its errors.

    ``defines``: preprocessor names to set (``SOLID_ROM_SCALAR``: no vector types, same results)."""
    compiler = os.environ.get("CC", "cc")
    if shutil.which(compiler) is None:
        raise CosimError(f"{needs} needs a C compiler; '{compiler}' was not found (set CC)")
    command = [compiler, "-std=c99", "-O3", "-Wall", "-Wextra", "-shared", "-fPIC", f"-I{include}",
               *(f"-D{name}" for name in defines), *(str(path) for path in files), "-o", str(target)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise CosimError(f"compiling {what} failed:\n{done.stderr}")


def cache_dir() -> Path:
    """Where compiled libraries are kept: ``$COSIM_CACHE``, else ``~/.cache/cosim``."""
    return Path(os.environ.get("COSIM_CACHE") or Path.home() / ".cache" / "cosim")


def in_process_files(source: Path) -> list[Path]:
    """The C files the in-process library of the ROM in ``source`` compiles: the ROM's, the runtime's, the entry
    points'."""
    return [source, source.with_name(RUNTIME), source.with_name(IN_PROCESS)]


def library_path(source: Path, defines: tuple[str, ...] = ()) -> Path:
    """The in-process library of ``source`` for its present text, the compiler and ``defines``, built if missing."""
    compiler = os.environ.get("CC", "cc")
    files = in_process_files(source)
    text = b"".join(path.read_bytes() for path in (*files, *(source.with_name(name) for name in HEADERS)))
    digest = hashlib.sha256(text + compiler.encode() + " ".join(defines).encode()).hexdigest()[:16]
    target = cache_dir() / f"{source.stem}-{digest}.so"
    if target.is_file():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        built = Path(tmp) / target.name
        compile_library(files, source.parent, built, defines, needs='the compiled ROM (arithmetic = "compiled")',
                        what=f"the ROM's C code ({source.name})")
        os.replace(built, target)    # atomic: processes building at once all end with a whole library
    return target
