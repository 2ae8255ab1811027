"""``cosim export-fmu``: a trained solid ROM as an FMI 2.0 Co-Simulation FMU.

The FMU holds ``modelDescription.xml``, the compiled ``binaries/linux64/solid_rom.so``,
its C sources (``sources/``: ``solid_rom.c`` and the FMI 2.0 headers) and the model's
arrays in ``resources/rom.bin`` (read at instantiate; format in ``solid_rom.c``).
Scalar variables are named ``<input>[node]`` / ``<output>[node]`` (1-based nodes), with
``.x``, ``.y``, ``.z`` appended when a node carries several components.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import struct
import subprocess
import tempfile
import uuid
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

from cosim.component import MESH_PREFIX
from cosim.errors import CosimError
from rom_component.online import OnlineRom
from rom_component.persistence import load_arrays

MODEL_IDENTIFIER = "solid_rom"
SOURCE = Path(__file__).with_name("fmu") / "solid_rom.c"
HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
AXES = "xyz"
NAME_BYTES = 32
LOG_CATEGORIES = {"logEvents": "instantiation and termination (with loggingOn)",
                  "logStatusError": "every call that returns fmi2Error, with the reason"}


def scalar_names(name: str, size: int, components: int) -> list[str]:
    """FMI structured names of an array variable's scalars, node-major."""
    if components < 1 or size % components:
        raise CosimError(f"variable '{name}' of size {size} cannot hold {components} components per node")
    if components == 1:
        return [f"{name}[{node + 1}]" for node in range(size)]
    if components > len(AXES):
        raise CosimError(f"variable '{name}': at most {len(AXES)} components per node")
    return [f"{name}[{node + 1}].{AXES[c]}" for node in range(size // components) for c in range(components)]


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


def model_description(rom: OnlineRom, guid: str, components: int) -> bytes:
    """``modelDescription.xml`` built as an element tree."""
    meta = rom.metadata
    inputs = scalar_names(meta.get("input_variable", "force"), rom.n_inputs, components)
    outputs = scalar_names(meta.get("output_variable", "displacement"), rom.n_outputs, components)
    params = meta.get("params", {})
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": MODEL_IDENTIFIER, "guid": guid,
        "description": (f"solid ROM: r_f={params.get('n_force_modes')}, r_u={params.get('n_disp_modes')}, "
                        f"{meta.get('regressor')} regression, {params.get('decoder', 'linear')} decoder"),
        "generationTool": "cosim export-fmu", "variableNamingConvention": "structured",
        "numberOfEventIndicators": "0"})
    cosimulation = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": MODEL_IDENTIFIER, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "false",
        "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "false", "providesDirectionalDerivative": "false"})
    ET.SubElement(ET.SubElement(cosimulation, "SourceFiles"), "File", {"name": SOURCE.name})
    categories = ET.SubElement(root, "LogCategories")
    for name, text in LOG_CATEGORIES.items():
        ET.SubElement(categories, "Category", {"name": name, "description": text})
    variables = ET.SubElement(root, "ModelVariables")
    for vr, name in enumerate(inputs):
        scalar = ET.SubElement(variables, "ScalarVariable", {"name": name, "valueReference": str(vr),
                                                             "causality": "input", "variability": "continuous"})
        ET.SubElement(scalar, "Real", {"start": "0.0"})
    for k, name in enumerate(outputs):
        scalar = ET.SubElement(variables, "ScalarVariable", {
            "name": name, "valueReference": str(len(inputs) + k), "causality": "output",
            "variability": "continuous", "initial": "calculated"})
        ET.SubElement(scalar, "Real")
    structure = ET.SubElement(root, "ModelStructure")
    for block in ("Outputs", "InitialUnknowns"):
        unknowns = ET.SubElement(structure, block)
        for index in range(len(inputs) + 1, len(inputs) + len(outputs) + 1):
            ET.SubElement(unknowns, "Unknown", {"index": str(index)})
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def fmi_headers() -> Path:
    try:
        import fmpy
    except ImportError:
        raise CosimError("export-fmu needs fmpy for the FMI 2.0 headers (pip install '.[fmu]')") from None
    return Path(fmpy.__file__).parent / "c-code"


def write_sources(folder: Path) -> None:
    """The C source and the FMI 2.0 headers it includes, into ``folder``."""
    shutil.copy(SOURCE, folder / SOURCE.name)
    for header in HEADERS:
        shutil.copy(fmi_headers() / header, folder / header)


def compile_binary(sources: Path, target: Path, defines: tuple[str, ...] = ()) -> None:
    """Build the linux64 binary: plain flags suffice, the source fixes its floating-point contract.

    ``defines``: preprocessor names to set (``SOLID_ROM_SCALAR``: no vector types, same results)."""
    compiler = os.environ.get("CC", "cc")
    if shutil.which(compiler) is None:
        raise CosimError(f"export-fmu needs a C compiler; '{compiler}' was not found (set CC)")
    command = [compiler, "-std=c99", "-O3", "-Wall", "-Wextra", "-shared", "-fPIC", f"-I{sources}",
               *(f"-D{name}" for name in defines), str(sources / SOURCE.name), "-o", str(target)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise CosimError(f"compiling the FMU binary failed:\n{done.stderr}")


def export_fmu(model: str | Path, out: str | Path, components_per_node: int | None = None) -> Path:
    """Write the FMU for the ROM stored in ``model``; returns its path. The same model gives the same bytes."""
    arrays, metadata = load_arrays(model)
    rom = OnlineRom(arrays, metadata)
    declared = {v["name"]: v for v in metadata.get("variables", [])}
    input_components = declared.get(metadata.get("input_variable"), {}).get("components", 1)
    components = components_per_node or int(metadata.get("components_per_node", input_components))
    scalar_names("input", rom.n_inputs, components)
    scalar_names("output", rom.n_outputs, components)
    guid = model_guid(rom, components)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for folder in ("sources", "resources", "binaries/linux64"):
            (root / folder).mkdir(parents=True)
        write_sources(root / "sources")
        (root / "resources" / "rom.bin").write_bytes(resource_bytes(rom, guid, components))
        (root / "modelDescription.xml").write_bytes(model_description(rom, guid, components))
        if metadata.get("variables"):   # the meshes the solid declared, for the coupler's mappings
            meshes = {k[len(MESH_PREFIX):]: v.tolist() for k, v in arrays.items() if k.startswith(MESH_PREFIX)}
            (root / "resources" / "interface.json").write_text(
                json.dumps({"variables": metadata["variables"], "meshes": meshes}, sort_keys=True))
        compile_binary(root / "sources", root / "binaries" / "linux64" / f"{MODEL_IDENTIFIER}.so")
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    info = zipfile.ZipInfo(path.relative_to(root).as_posix(), date_time=(1980, 1, 1, 0, 0, 0))
                    info.compress_type = zipfile.ZIP_DEFLATED
                    info.external_attr = 0o644 << 16
                    archive.writestr(info, path.read_bytes())
    return out
