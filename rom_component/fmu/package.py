"""What every FMU ``cosim export-fmu`` writes shares: scalar variable names of array variables, the
``ScalarVariable`` elements of ``modelDescription.xml``, and the archive, packed so that the same files give the
same bytes. Each family's FMU (``solid_rom``, ``step_map_rom``) uses it.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Sequence
from pathlib import Path

from cosim.errors import CosimError

AXES = "xyz"


def scalar_names(name: str, size: int, components: int) -> list[str]:
    """FMI structured names of an array variable's scalars, node-major: ``name[node]`` or ``name[node].x``."""
    if components < 1 or size % components:
        raise CosimError(f"variable '{name}' of size {size} cannot hold {components} components per node")
    if components == 1:
        return [f"{name}[{node + 1}]" for node in range(size)]
    if components > len(AXES):
        raise CosimError(f"variable '{name}': at most {len(AXES)} components per node")
    return [f"{name}[{node + 1}].{AXES[c]}" for node in range(size // components) for c in range(components)]


LOG_CATEGORIES = {"logEvents": "instantiation and termination (with loggingOn)",
                  "logStatusError": "every call that returns fmi2Error, with the reason"}     # the skeleton's


def description_root(identifier: str, guid: str, description: str, variable_step: bool,
                     sources: Sequence[str]) -> tuple[ET.Element, ET.Element]:
    """The ``fmiModelDescription`` element of a Co-Simulation FMU that can get, set and serialise its state, builds
    from the C files ``sources`` and logs in the skeleton's categories, and its ``CoSimulation`` element."""
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": identifier, "guid": guid, "description": description,
        "generationTool": "cosim export-fmu", "variableNamingConvention": "structured",
        "numberOfEventIndicators": "0"})
    cosimulation = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": identifier, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true" if variable_step else "false", "canInterpolateInputs": "false",
        "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true", "providesDirectionalDerivative": "false"})
    files = ET.SubElement(cosimulation, "SourceFiles")
    for name in sources:
        ET.SubElement(files, "File", {"name": name})
    categories = ET.SubElement(root, "LogCategories")
    for name, text in LOG_CATEGORIES.items():
        ET.SubElement(categories, "Category", {"name": name, "description": text})
    return root, cosimulation


def real_variables(root: ET.Element, inputs: Sequence[str], outputs: Sequence[str], locals_: Sequence[str] = ()) -> None:
    """``ModelVariables`` (value references in that order: inputs, outputs, locals) and ``ModelStructure``."""
    variables = ET.SubElement(root, "ModelVariables")
    for vr, name in enumerate(inputs):
        scalar = ET.SubElement(variables, "ScalarVariable", {"name": name, "valueReference": str(vr),
                                                             "causality": "input", "variability": "continuous"})
        ET.SubElement(scalar, "Real", {"start": "0.0"})
    for k, name in enumerate([*outputs, *locals_]):
        scalar = ET.SubElement(variables, "ScalarVariable", {
            "name": name, "valueReference": str(len(inputs) + k), "causality": "output" if k < len(outputs) else "local",
            "variability": "continuous", "initial": "calculated"})
        ET.SubElement(scalar, "Real")
    structure = ET.SubElement(root, "ModelStructure")
    for block in ("Outputs", "InitialUnknowns"):
        unknowns = ET.SubElement(structure, block)
        for index in range(len(inputs) + 1, len(inputs) + len(outputs) + 1):
            ET.SubElement(unknowns, "Unknown", {"index": str(index)})


def pack(folder: Path, out: Path) -> Path:
    """The FMU archive of ``folder``'s files, in name order with fixed dates and modes (reproducible bytes)."""
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                info = zipfile.ZipInfo(path.relative_to(folder).as_posix(), date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                archive.writestr(info, path.read_bytes())
    return out
