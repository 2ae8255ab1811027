"""The quasi-static solid ROM as an FMI 2.0 or FMI 3.0 Co-Simulation FMU.

The FMU holds ``modelDescription.xml``, the compiled ``binaries/<platform>/solid_rom.so``,
its C sources (``sources/``: ``solid_rom.c``, the skeleton's and the FMI headers; FMI 3.0's
``buildDescription.xml``) and the model's arrays in ``resources/rom.bin`` (read at instantiate;
format in ``solid_rom.c``). FMI 2.0's scalar variables are named ``<input>[node]`` / ``<output>[node]``
(1-based nodes), with ``.x``, ``.y``, ``.z`` appended when a node carries several components; FMI 3.0
has the input and the output as arrays of (nodes, components).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import MESH_PREFIX
from rom_component.fmu.package import ArrayVariable, check_components, description_root, variables, write_fmu
from rom_component.fmu.skeleton import source_files
from rom_component.static.compiled import SOURCE, model_guid, resource_bytes
from rom_component.static.online import OnlineRom

MODEL_IDENTIFIER = "solid_rom"


def model_description(rom: OnlineRom, guid: str, components: int, fmi: int = 2) -> ET.Element:
    """``modelDescription.xml``: the force in, the interface displacement out."""
    meta = rom.metadata
    root = description_root(MODEL_IDENTIFIER, guid,
                            f"solid ROM: r_f={rom.E.shape[0]}, r_u={rom.A.shape[1]}, {rom.regressor} regression, "
                            f"{'quadratic' if rom.quadratic_decoder else 'linear'} decoder", True,
                            source_files(SOURCE, fmi), fmi)
    variables(root, fmi, ArrayVariable(meta.get("input_variable", "force"), rom.n_inputs, components),
              ArrayVariable(meta.get("output_variable", "displacement"), rom.n_outputs, components))
    return root


def export_solid_rom_fmu(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], out: Path,
                         components_per_node: int | None = None, fmi: int = 2) -> Path:
    """The FMI ``fmi`` FMU of a quasi-static ROM; the same model gives the same bytes."""
    rom = OnlineRom(arrays, metadata)
    declared = {v["name"]: v for v in metadata.get("variables", [])}
    input_components = declared.get(metadata.get("input_variable"), {}).get("components", 1)
    components = components_per_node or int(metadata.get("components_per_node", input_components))
    check_components("input", rom.n_inputs, components)
    check_components("output", rom.n_outputs, components)
    guid = model_guid(rom, components)
    interface = None
    if metadata.get("variables"):   # the meshes the solid declared, for the coupler's mappings
        meshes = {k[len(MESH_PREFIX):]: v.tolist() for k, v in arrays.items() if k.startswith(MESH_PREFIX)}
        interface = {"variables": metadata["variables"], "meshes": meshes, "stateless": True}
    return write_fmu(out, MODEL_IDENTIFIER, SOURCE, fmi, resource_bytes(rom, guid, components),
                     model_description(rom, guid, components, fmi), interface)
