"""The FMI skeleton an exported ROM is compiled with: the FMI 2.0 or FMI 3.0 entry points (``fmi2_rom.c``,
``fmi3_rom.c``, here) on the native runtime (``rom_component.native``), the FMI headers they include (fmpy's), and
the FMU binary's build."""

from __future__ import annotations

import shutil
from pathlib import Path

from cosim.errors import CosimError
from rom_component.native.build import HEADERS, RUNTIME, compile_library

ENTRY_POINTS = {2: Path(__file__).with_name("fmi2_rom.c"), 3: Path(__file__).with_name("fmi3_rom.c")}
FMI_HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
               3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}


def fmi_headers() -> Path:
    try:
        import fmpy
    except ImportError:
        raise CosimError("export-fmu needs fmpy for the FMI headers (pip install '.[fmu]')") from None
    return Path(fmpy.__file__).parent / "c-code"


def source_paths(source: Path, fmi: int = 2) -> list[Path]:
    """The C files an FMI ``fmi`` FMU of the ROM in ``source`` compiles: the ROM's, the runtime's, the entry
    points'."""
    return [source, source.with_name(RUNTIME), ENTRY_POINTS[fmi]]


def source_files(source: Path, fmi: int = 2) -> list[str]:
    """The names of ``source_paths``, as the FMU's ``sources/`` folder holds them."""
    return [path.name for path in source_paths(source, fmi)]


def write_sources(folder: Path, source: Path, fmi: int = 2) -> None:
    """The ROM's C ``source``, the skeleton's sources and headers, and the FMI headers, into ``folder``."""
    for path in (*source_paths(source, fmi), *(source.with_name(name) for name in HEADERS)):
        shutil.copy(path, folder / path.name)
    for header in FMI_HEADERS[fmi]:
        shutil.copy(fmi_headers() / header, folder / header)


def compile_binary(sources: Path, target: Path, source: Path, defines: tuple[str, ...] = (), fmi: int = 2) -> None:
    """Build the linux64 binary of the ROM in ``source`` from the FMU's ``sources`` folder (``write_sources``).

    ``defines``: preprocessor names to set (``SOLID_ROM_SCALAR``: no vector types, same results)."""
    compile_library([sources / name for name in source_files(source, fmi)], sources, target, defines,
                    needs="export-fmu", what="the FMU binary")
