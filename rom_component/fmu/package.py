"""What every FMU ``cosim export-fmu`` writes shares, in FMI 2.0 and in FMI 3.0: the model description's root,
its variables (FMI 2.0's scalars named by node, FMI 3.0's arrays with their dimensions), FMI 3.0's build
description, and the archive, packed so that the same files give the same bytes. Each family's FMU
(``solid_rom``, ``step_map_rom``) uses it.
"""

from __future__ import annotations

import json
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from cosim.errors import CosimError
from rom_component.fmu.skeleton import compile_binary, source_files, write_sources

AXES = "xyz"


def check_components(name: str, size: int, components: int) -> None:
    """Refuse a variable whose size is no whole number of nodes of 1 to 3 components."""
    if components < 1 or size % components:
        raise CosimError(f"variable '{name}' of size {size} cannot hold {components} components per node")
    if components > len(AXES):
        raise CosimError(f"variable '{name}': at most {len(AXES)} components per node")


def scalar_names(name: str, size: int, components: int) -> list[str]:
    """FMI structured names of an array variable's scalars, node-major: ``name[node]`` or ``name[node].x``."""
    check_components(name, size, components)
    if components == 1:
        return [f"{name}[{node + 1}]" for node in range(size)]
    return [f"{name}[{node + 1}].{AXES[c]}" for node in range(size // components) for c in range(components)]


LOG_CATEGORIES = {"logEvents": "instantiation and termination (with loggingOn)",
                  "logStatusError": "every call that returns fmi{fmi}Error, with the reason"}     # the skeleton's
PLATFORM = {2: "linux64", 3: "x86_64-linux"}        # the binaries' folder


class ArrayVariable(NamedTuple):
    """A variable of an exported ROM: ``size`` values, node-major, ``components`` per node."""
    name: str
    size: int
    components: int = 1

    def scalars(self) -> list[str]:
        """FMI 2.0's scalar names of its values."""
        return scalar_names(self.name, self.size, self.components)

    def dimensions(self) -> list[int]:
        """FMI 3.0's dimensions: (nodes, components), or (size,) with one component."""
        check_components(self.name, self.size, self.components)
        return [self.size // self.components, self.components] if self.components > 1 else [self.size]


def description_root(identifier: str, guid: str, description: str, variable_step: bool,
                     sources: Sequence[str], fmi: int = 2) -> ET.Element:
    """The ``fmiModelDescription`` element of an FMI ``fmi`` Co-Simulation FMU that can get, set and serialise its
    state, builds from the C files ``sources`` and logs in the skeleton's categories."""
    token = {"guid": guid} if fmi == 2 else {"instantiationToken": guid}
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": f"{fmi}.0", "modelName": identifier, **token, "description": description,
        "generationTool": "cosim export-fmu", "variableNamingConvention": "structured",
        **({"numberOfEventIndicators": "0"} if fmi == 2 else {})})
    step = "true" if variable_step else "false"
    if fmi == 2:
        cosimulation = ET.SubElement(root, "CoSimulation", {
            "modelIdentifier": identifier, "needsExecutionTool": "false",
            "canHandleVariableCommunicationStepSize": step, "canInterpolateInputs": "false",
            "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true", "providesDirectionalDerivative": "false"})
        files = ET.SubElement(cosimulation, "SourceFiles")
        for name in sources:
            ET.SubElement(files, "File", {"name": name})
    else:          # FMI 3.0 lists the sources in sources/buildDescription.xml
        ET.SubElement(root, "CoSimulation", {
            "modelIdentifier": identifier, "needsExecutionTool": "false", "canGetAndSetFMUState": "true",
            "canSerializeFMUState": "true", "providesDirectionalDerivatives": "false",
            "canHandleVariableCommunicationStepSize": step, "hasEventMode": "false"})
    categories = ET.SubElement(root, "LogCategories")
    for name, text in LOG_CATEGORIES.items():
        ET.SubElement(categories, "Category", {"name": name, "description": text.format(fmi=fmi)})
    return root


def variables(root: ET.Element, fmi: int, inputs: ArrayVariable, outputs: ArrayVariable,
              locals_: Sequence[ArrayVariable] = ()) -> None:
    """``ModelVariables`` and ``ModelStructure``: FMI 2.0's scalars (value references: inputs, outputs, locals in
    that order), or FMI 3.0's arrays (0 the time, 1 the input, 2 the output, 3... the locals)."""
    if fmi == 2:
        real_variables(root, inputs.scalars(), outputs.scalars(), [n for v in locals_ for n in v.scalars()])
        return
    elements = ET.SubElement(root, "ModelVariables")
    ET.SubElement(elements, "Float64", {"name": "time", "valueReference": "0", "causality": "independent",
                                        "variability": "continuous"})
    rows = [(inputs, "input"), (outputs, "output"), *((v, "local") for v in locals_)]
    for vr, (variable, causality) in enumerate(rows, start=1):
        attributes = {"name": variable.name, "valueReference": str(vr), "causality": causality,
                      "variability": "continuous"}
        attributes.update({"start": " ".join(["0"] * variable.size)} if causality == "input"
                          else {"initial": "calculated"})
        element = ET.SubElement(elements, "Float64", attributes)
        for extent in variable.dimensions():
            ET.SubElement(element, "Dimension", {"start": str(extent)})
    structure = ET.SubElement(root, "ModelStructure")
    ET.SubElement(structure, "Output", {"valueReference": "2"})
    ET.SubElement(structure, "InitialUnknown", {"valueReference": "2"})


def build_description(identifier: str, sources: Sequence[str]) -> bytes:
    """FMI 3.0's ``sources/buildDescription.xml``: the C files a tool compiles to rebuild the binary."""
    root = ET.Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    files = ET.SubElement(ET.SubElement(root, "BuildConfiguration", {"modelIdentifier": identifier}),
                          "SourceFileSet", {"language": "C99"})
    for name in sources:
        ET.SubElement(files, "SourceFile", {"name": name})
    return document(root)


def document(root: ET.Element) -> bytes:
    """An XML file's bytes, indented."""
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def real_variables(root: ET.Element, inputs: Sequence[str], outputs: Sequence[str], locals_: Sequence[str] = ()) -> None:
    """FMI 2.0's ``ModelVariables`` (value references in that order: inputs, outputs, locals) and ``ModelStructure``."""
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


def write_fmu(out: Path, identifier: str, source: Path, fmi: int, resource: bytes, description: ET.Element,
              interface: Mapping[str, Any] | None) -> Path:
    """The FMU: ``modelDescription.xml``, the C sources (with FMI 3.0's build description), the binary built from
    them, ``resources/rom.bin`` and ``resources/interface.json`` (the variables' meshes, for the coupler)."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        binaries = root / "binaries" / PLATFORM[fmi]
        for folder in (root / "sources", root / "resources", binaries):
            folder.mkdir(parents=True)
        write_sources(root / "sources", source, fmi)
        if fmi == 3:
            (root / "sources" / "buildDescription.xml").write_bytes(
                build_description(identifier, source_files(source, fmi)))
        (root / "resources" / "rom.bin").write_bytes(resource)
        (root / "modelDescription.xml").write_bytes(document(description))
        if interface is not None:
            (root / "resources" / "interface.json").write_text(json.dumps(interface, sort_keys=True))
        compile_binary(root / "sources", binaries / f"{identifier}.so", source, fmi=fmi)
        return pack(root, out)


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
