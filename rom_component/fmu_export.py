"""``cosim export-fmu``: a trained solid ROM as an FMI 2.0 Co-Simulation FMU.

The FMU holds ``modelDescription.xml``, the compiled ``binaries/linux64/solid_rom.so``,
its C sources (``sources/``: ``solid_rom.c`` and the FMI 2.0 headers) and the model's
arrays in ``resources/rom.bin`` (read at instantiate; format in ``solid_rom.c``).
Scalar variables are named ``<input>[node]`` / ``<output>[node]`` (1-based nodes), with
``.x``, ``.y``, ``.z`` appended when a node carries several components.
"""

from __future__ import annotations

import os
import shutil
import struct
import subprocess
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from cosim.errors import CosimError
from rom_component.online import OnlineRom
from rom_component.persistence import load_arrays

MODEL_IDENTIFIER = "solid_rom"
SOURCE = Path(__file__).with_name("fmu") / "solid_rom.c"
HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
AXES = "xyz"


def scalar_names(name: str, size: int, components: int) -> list[str]:
    """FMI structured names of an array variable's scalars, node-major."""
    if components < 1 or size % components:
        raise CosimError(f"variable '{name}' of size {size} cannot hold {components} components per node")
    if components == 1:
        return [f"{name}[{node + 1}]" for node in range(size)]
    if components > len(AXES):
        raise CosimError(f"variable '{name}': at most {len(AXES)} components per node")
    return [f"{name}[{node + 1}].{AXES[c]}" for node in range(size // components) for c in range(components)]


def resource_bytes(rom: OnlineRom, guid: str) -> bytes:
    """The binary resource the C code reads (little-endian)."""
    a = rom.arrays
    rbf = rom.regressor == "rbf"
    r_f, n_in = rom.E.shape
    n_out, r_u = rom.A.shape
    m = len(a["centres"]) if rbf else len(a["quad_i"])
    header = b"CSROM01\0" + guid.encode().ljust(40, b"\0")[:40]
    header += struct.pack("<8i", n_in, n_out, r_f, r_u, m, 0 if rbf else 1, 1 if rom.quadratic_decoder else 0, 0)
    parts = [rom.E, rom.e]
    parts += [a["centres"]] if rbf else []
    body = b"".join(np.ascontiguousarray(p, dtype="<f8").tobytes() for p in parts)
    if not rbf:
        body += np.ascontiguousarray(a["quad_i"], dtype="<i4").tobytes()
        body += np.ascontiguousarray(a["quad_j"], dtype="<i4").tobytes()
    tail = [rom.H, rom.A, rom.base] + ([rom.B] if rom.quadratic_decoder else [])
    body += b"".join(np.ascontiguousarray(p, dtype="<f8").tobytes() for p in tail)
    return header + body


def model_description(rom: OnlineRom, guid: str, components: int) -> str:
    meta = rom.metadata
    inputs = scalar_names(meta.get("input_variable", "force"), rom.n_inputs, components)
    outputs = scalar_names(meta.get("output_variable", "displacement"), rom.n_outputs, components)
    params = meta.get("params", {})
    description = (f"solid ROM: r_f={params.get('n_force_modes')}, r_u={params.get('n_disp_modes')}, "
                   f"{meta.get('regressor')} regression, {params.get('decoder', 'linear')} decoder")
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="2.0" modelName="{MODEL_IDENTIFIER}" guid="{guid}" '
             f'description="{escape(description)}" generationTool="cosim export-fmu" '
             'variableNamingConvention="structured" numberOfEventIndicators="0">',
             f'  <CoSimulation modelIdentifier="{MODEL_IDENTIFIER}" needsExecutionTool="false" '
             'canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false" '
             'canGetAndSetFMUstate="true" canSerializeFMUstate="false" providesDirectionalDerivative="false">',
             '    <SourceFiles><File name="solid_rom.c"/></SourceFiles>',
             '  </CoSimulation>',
             '  <ModelVariables>']
    for vr, name in enumerate(inputs):
        lines.append(f'    <ScalarVariable name="{escape(name)}" valueReference="{vr}" causality="input" '
                     f'variability="continuous"><Real start="0.0"/></ScalarVariable>')
    for k, name in enumerate(outputs):
        lines.append(f'    <ScalarVariable name="{escape(name)}" valueReference="{len(inputs) + k}" causality="output" '
                     f'variability="continuous" initial="calculated"><Real/></ScalarVariable>')
    lines.append('  </ModelVariables>')
    lines.append('  <ModelStructure>')
    indices = range(len(inputs) + 1, len(inputs) + len(outputs) + 1)
    for block in ("Outputs", "InitialUnknowns"):
        lines.append(f'    <{block}>')
        lines += [f'      <Unknown index="{i}"/>' for i in indices]
        lines.append(f'    </{block}>')
    lines += ['  </ModelStructure>', '</fmiModelDescription>', '']
    return "\n".join(lines)


def fmi_headers() -> Path:
    try:
        import fmpy
    except ImportError:
        raise CosimError("export-fmu needs fmpy for the FMI 2.0 headers (pip install '.[fmu]')") from None
    return Path(fmpy.__file__).parent / "c-code"


def compile_binary(sources: Path, target: Path) -> None:
    compiler = os.environ.get("CC", "cc")
    if shutil.which(compiler) is None:
        raise CosimError(f"export-fmu needs a C compiler; '{compiler}' was not found (set CC)")
    command = [compiler, "-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-shared", "-fPIC", f"-I{sources}",
               str(sources / SOURCE.name), "-o", str(target), "-lm"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise CosimError(f"compiling the FMU binary failed:\n{done.stderr}")


def export_fmu(model: str | Path, out: str | Path, components_per_node: int | None = None) -> Path:
    """Write the FMU for the ROM stored in ``model``; returns its path."""
    arrays, metadata = load_arrays(model)
    rom = OnlineRom(arrays, metadata)
    components = components_per_node or int(metadata.get("components_per_node", 1))
    guid = "{" + str(uuid.uuid4()) + "}"
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for folder in ("sources", "resources", "binaries/linux64"):
            (root / folder).mkdir(parents=True)
        shutil.copy(SOURCE, root / "sources" / SOURCE.name)
        for header in HEADERS:
            shutil.copy(fmi_headers() / header, root / "sources" / header)
        (root / "resources" / "rom.bin").write_bytes(resource_bytes(rom, guid))
        (root / "modelDescription.xml").write_text(model_description(rom, guid, components))
        compile_binary(root / "sources", root / "binaries" / "linux64" / f"{MODEL_IDENTIFIER}.so")
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    archive.write(path, path.relative_to(root).as_posix())
    return out
