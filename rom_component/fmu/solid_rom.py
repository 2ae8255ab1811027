"""The quasi-static solid ROM as an FMI 2.0 Co-Simulation FMU.

The FMU holds ``modelDescription.xml``, the compiled ``binaries/linux64/solid_rom.so``,
its C sources (``sources/``: ``solid_rom.c``, the skeleton's and the FMI 2.0 headers) and the model's
arrays in ``resources/rom.bin`` (read at instantiate; format in ``solid_rom.c``).
Scalar variables are named ``<input>[node]`` / ``<output>[node]`` (1-based nodes), with
``.x``, ``.y``, ``.z`` appended when a node carries several components.
"""

from __future__ import annotations

import json
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import MESH_PREFIX
from rom_component.fmu.build import compile_binary, source_files, write_sources
from rom_component.fmu.package import description_root, pack, real_variables, scalar_names
from rom_component.static.compiled import SOURCE, model_guid, resource_bytes
from rom_component.static.online import OnlineRom

MODEL_IDENTIFIER = "solid_rom"


def model_description(rom: OnlineRom, guid: str, components: int) -> bytes:
    """``modelDescription.xml`` built as an element tree."""
    meta = rom.metadata
    inputs = scalar_names(meta.get("input_variable", "force"), rom.n_inputs, components)
    outputs = scalar_names(meta.get("output_variable", "displacement"), rom.n_outputs, components)
    root, _ = description_root(MODEL_IDENTIFIER, guid,
                               f"solid ROM: r_f={rom.E.shape[0]}, r_u={rom.A.shape[1]}, {rom.regressor} regression, "
                               f"{'quadratic' if rom.quadratic_decoder else 'linear'} decoder", True, source_files(SOURCE))
    real_variables(root, inputs, outputs)
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def export_solid_rom_fmu(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], out: Path,
                         components_per_node: int | None = None) -> Path:
    """The FMU of a quasi-static ROM; the same model gives the same bytes."""
    rom = OnlineRom(arrays, metadata)
    declared = {v["name"]: v for v in metadata.get("variables", [])}
    input_components = declared.get(metadata.get("input_variable"), {}).get("components", 1)
    components = components_per_node or int(metadata.get("components_per_node", input_components))
    scalar_names("input", rom.n_inputs, components)
    scalar_names("output", rom.n_outputs, components)
    guid = model_guid(rom, components)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for folder in ("sources", "resources", "binaries/linux64"):
            (root / folder).mkdir(parents=True)
        write_sources(root / "sources", SOURCE)
        (root / "resources" / "rom.bin").write_bytes(resource_bytes(rom, guid, components))
        (root / "modelDescription.xml").write_bytes(model_description(rom, guid, components))
        if metadata.get("variables"):   # the meshes the solid declared, for the coupler's mappings
            meshes = {k[len(MESH_PREFIX):]: v.tolist() for k, v in arrays.items() if k.startswith(MESH_PREFIX)}
            (root / "resources" / "interface.json").write_text(
                json.dumps({"variables": metadata["variables"], "meshes": meshes}, sort_keys=True))
        compile_binary(root / "sources", root / "binaries" / "linux64" / f"{MODEL_IDENTIFIER}.so", SOURCE)
        return pack(root, out)
