"""How a ROM's C source (``fmu/*.c``) is built: the FMI headers it includes, the compiler call, and the cache of
compiled libraries the in-process ``arithmetic = "compiled"`` path loads. The FMU exports and the families' compiled
paths both build on this module, so neither imports the other.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from cosim.errors import CosimError

C_SOURCES = Path(__file__).parent      # the C sources of the exported FMUs
SKELETON = {2: ("rom_runtime.c", "fmi2_rom.c"), 3: ("rom_runtime.c", "fmi3_rom.c")}   # compiled with a ROM's source
OWN_HEADERS = ("rom_fmu.h", "rom_arithmetic.h")
HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
           3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
NAME_BYTES = 32         # a variable's name in a resource's header


def fmi_headers() -> Path:
    try:
        import fmpy
    except ImportError:
        raise CosimError("export-fmu needs fmpy for the FMI headers (pip install '.[fmu]')") from None
    return Path(fmpy.__file__).parent / "c-code"


def source_files(source: Path, fmi: int = 2) -> list[str]:
    """The C files an FMI ``fmi`` FMU of the ROM in ``source`` compiles: the ROM's, then the skeleton's."""
    return [source.name, *SKELETON[fmi]]


def write_sources(folder: Path, source: Path, fmi: int = 2) -> None:
    """The ROM's C ``source``, the skeleton's sources and headers, and the FMI headers, into ``folder``."""
    for name in (*source_files(source, fmi), *OWN_HEADERS):
        shutil.copy(source.with_name(name), folder / name)
    for header in HEADERS[fmi]:
        shutil.copy(fmi_headers() / header, folder / header)


def compile_binary(sources: Path, target: Path, source: Path, defines: tuple[str, ...] = (), fmi: int = 2) -> None:
    """Build the linux64 binary of the ROM in ``source`` with the skeleton (in ``sources``): plain flags suffice, the
    sources fix their floating-point contract.

    ``defines``: preprocessor names to set (``SOLID_ROM_SCALAR``: no vector types, same results)."""
    compiler = os.environ.get("CC", "cc")
    if shutil.which(compiler) is None:
        raise CosimError(f"export-fmu needs a C compiler; '{compiler}' was not found (set CC)")
    command = [compiler, "-std=c99", "-O3", "-Wall", "-Wextra", "-shared", "-fPIC", f"-I{sources}",
               *(f"-D{name}" for name in defines), *(str(sources / name) for name in source_files(source, fmi)),
               "-o", str(target)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise CosimError(f"compiling the FMU binary failed:\n{done.stderr}")


def cache_dir() -> Path:
    """Where compiled libraries are kept: ``$COSIM_CACHE``, else ``~/.cache/cosim``."""
    return Path(os.environ.get("COSIM_CACHE") or Path.home() / ".cache" / "cosim")


def library_path(source: Path, defines: tuple[str, ...] = ()) -> Path:
    """The compiled library of ``source`` for its present text, the compiler and ``defines``, built if missing."""
    compiler = os.environ.get("CC", "cc")
    text = b"".join(source.with_name(name).read_bytes() for name in (*source_files(source), *OWN_HEADERS))
    digest = hashlib.sha256(text + compiler.encode() + " ".join(defines).encode()).hexdigest()[:16]
    target = cache_dir() / f"{source.stem}-{digest}.so"
    if target.is_file():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        sources = Path(tmp)
        write_sources(sources, source)
        built = sources / target.name
        compile_binary(sources, built, source, defines)
        os.replace(built, target)    # atomic: processes building at once all end with a whole library
    return target
