"""``cosim export-fmu``: a trained solid ROM as an FMI 2.0 Co-Simulation FMU.

The FMU holds ``modelDescription.xml``, the compiled ``binaries/linux64/solid_rom.so``,
its C sources (``sources/``: ``solid_rom.c`` and the FMI 2.0 headers) and the model's
arrays in ``resources/rom.bin`` (read at instantiate; format in ``solid_rom.c``).
Scalar variables are named ``<input>[node]`` / ``<output>[node]`` (1-based nodes), with
``.x``, ``.y``, ``.z`` appended when a node carries several components.
"""

from __future__ import annotations

import json
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from cosim.component import MESH_PREFIX
from cosim.errors import CosimError
from rom_component.native import SOURCE, compile_binary, model_guid, resource_bytes, write_sources
from rom_component.online import OnlineRom
from rom_component.persistence import load_arrays

MODEL_IDENTIFIER = "solid_rom"
AXES = "xyz"
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






def model_description(rom: OnlineRom, guid: str, components: int) -> bytes:
    """``modelDescription.xml`` built as an element tree."""
    meta = rom.metadata
    inputs = scalar_names(meta.get("input_variable", "force"), rom.n_inputs, components)
    outputs = scalar_names(meta.get("output_variable", "displacement"), rom.n_outputs, components)
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": MODEL_IDENTIFIER, "guid": guid,
        "description": (f"solid ROM: r_f={rom.E.shape[0]}, r_u={rom.A.shape[1]}, {rom.regressor} regression, "
                        f"{'quadratic' if rom.quadratic_decoder else 'linear'} decoder"),
        "generationTool": "cosim export-fmu", "variableNamingConvention": "structured",
        "numberOfEventIndicators": "0"})
    cosimulation = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": MODEL_IDENTIFIER, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "false",
        "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true", "providesDirectionalDerivative": "false"})
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








def export_fmu(model: str | Path, out: str | Path, components_per_node: int | None = None) -> Path:
    """Write the FMU for the ROM stored in ``model``; returns its path. The same model gives the same bytes."""
    arrays, metadata = load_arrays(model)
    if metadata.get("kind") == "step-map":      # a ROM with memory: its history is the FMU's state
        from rom_component.step_map_native import export_step_map_fmu
        declared = {v["name"]: v for v in metadata.get("variables", [])}
        components = components_per_node or int(declared.get(metadata["input_variable"], {}).get("components", 1))
        out = Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        return export_step_map_fmu(arrays, metadata, out, components)
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
