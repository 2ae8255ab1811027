"""The ROM's C code: its source (``fmu/solid_rom.c``), how it is compiled, and the binary resource of a model's
arrays it reads. The FMU export (``fmu_export``) and the compiled arithmetic in-process (``compiled``) both build
on this module, so neither imports the other.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import struct
import subprocess
import uuid
from pathlib import Path

import numpy as np

from cosim.errors import CosimError
from rom_component.online import OnlineRom

SOURCE = Path(__file__).with_name("fmu") / "solid_rom.c"
HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
NAME_BYTES = 32


def resource_bytes(rom: OnlineRom, guid: str, components: int) -> bytes:
    """The binary resource the C code reads (little-endian; format in ``solid_rom.c``)."""
    a = rom.arrays
    rbf = rom.regressor == "rbf"
    r_f, n_in = rom.E.shape
    n_out, r_u = rom.A.shape
    m = len(a["centres"]) if rbf else len(rom.qi) + len(rom.ci)
    names = [rom.metadata.get("input_variable", "force"), rom.metadata.get("output_variable", "displacement")]
    for name in names:
        if len(name.encode()) > NAME_BYTES:
            raise CosimError(f"variable name '{name}' is longer than {NAME_BYTES} bytes")
    header = b"CSROM04\0" + guid.encode().ljust(40, b"\0")[:40] + b"".join(n.encode().ljust(NAME_BYTES, b"\0")
                                                                        for n in names)
    header += struct.pack("<8i", n_in, n_out, r_f, r_u, m, 0 if rbf else 1, 1 if rom.quadratic_decoder else 0,
                          components)
    parts = [rom.E, rom.e]
    parts += [a["centres"]] if rbf else []
    body = b"".join(np.ascontiguousarray(p, dtype="<f8").tobytes() for p in parts)
    if not rbf:
        body += np.concatenate([rom.qi, rom.ci]).astype("<i4").tobytes()
        body += np.concatenate([rom.qj, rom.cj]).astype("<i4").tobytes()
        body += np.concatenate([np.full(len(rom.qi), -1), rom.ck]).astype("<i4").tobytes()   # -1: no third factor
    tail = [rom.H, rom.A.T, rom.base] + ([rom.B.T] if rom.quadratic_decoder else [])   # decoders transposed
    body += b"".join(np.ascontiguousarray(p, dtype="<f8").tobytes() for p in tail)
    return header + body


def model_guid(rom: OnlineRom, components: int) -> str:
    """A GUID derived from the model's content: the same model exports the same FMU."""
    digest = hashlib.sha256(resource_bytes(rom, "", components)).digest()
    return "{" + str(uuid.UUID(bytes=digest[:16], version=4)) + "}"


def fmi_headers() -> Path:
    try:
        import fmpy
    except ImportError:
        raise CosimError("export-fmu needs fmpy for the FMI 2.0 headers (pip install '.[fmu]')") from None
    return Path(fmpy.__file__).parent / "c-code"


def write_sources(folder: Path, source: Path = SOURCE) -> None:
    """The C source (the static ROM's, or ``source``) and the FMI 2.0 headers it includes, into ``folder``."""
    shutil.copy(source, folder / source.name)
    for header in HEADERS:
        shutil.copy(fmi_headers() / header, folder / header)


def compile_binary(sources: Path, target: Path, defines: tuple[str, ...] = (), source: Path = SOURCE) -> None:
    """Build the linux64 binary of ``source`` (in ``sources``): plain flags suffice, the source fixes its
    floating-point contract.

    ``defines``: preprocessor names to set (``SOLID_ROM_SCALAR``: no vector types, same results)."""
    compiler = os.environ.get("CC", "cc")
    if shutil.which(compiler) is None:
        raise CosimError(f"export-fmu needs a C compiler; '{compiler}' was not found (set CC)")
    command = [compiler, "-std=c99", "-O3", "-Wall", "-Wextra", "-shared", "-fPIC", f"-I{sources}",
               *(f"-D{name}" for name in defines), str(sources / source.name), "-o", str(target)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise CosimError(f"compiling the FMU binary failed:\n{done.stderr}")
