"""The ROM with memory (step map) as an FMI 2.0 or FMI 3.0 Co-Simulation FMU: the history is the FMU's state.

The FMU holds ``modelDescription.xml``, ``binaries/<platform>/step_map_rom.so``, its C sources (``sources/``:
``step_map_rom.c``, the skeleton's and the FMI headers; FMI 3.0's ``buildDescription.xml``) and the model's arrays
in ``resources/rom.bin`` (``rom_component.dynamic.compiled.resource_bytes``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import MESH_PREFIX
from rom_component.dynamic.compiled import SOURCE, model_guid, resource_bytes
from rom_component.fmu.package import ArrayVariable, description_root, variables, write_fmu
from rom_component.fmu.skeleton import source_files

MODEL_IDENTIFIER = "step_map_rom"


def model_description(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], guid: str,
                      components: int, fmi: int = 2) -> ET.Element:
    """``modelDescription.xml``: the force in, the interface displacement out, the probes (points) as locals."""
    (r_f, n_in), (n_out, r_u) = arrays["E"].shape, arrays["A"].shape
    declared = {v["name"]: v for v in metadata.get("variables", [])}
    root = description_root(MODEL_IDENTIFIER, guid,
                            f"step-map ROM of a structure with inertia: r_f={r_f}, r_u={r_u}, history of "
                            f"{metadata['history']} windows, window {metadata['dt']:g} s; the history is the "
                            "FMU's state", False, source_files(SOURCE, fmi), fmi)
    ET.SubElement(root, "DefaultExperiment", {"stepSize": repr(float(metadata["dt"]))})
    output_components = int(declared.get(metadata["output_variable"], {}).get("components", components))
    variables(root, fmi, ArrayVariable(metadata["input_variable"], n_in, components),
              ArrayVariable(metadata["output_variable"], n_out, output_components),
              [ArrayVariable(probe, 2) for probe in metadata.get("probes", [])])
    return root


def export_step_map_fmu(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], out: Path,
                        components: int, fmi: int = 2) -> Path:
    """The FMI ``fmi`` FMU of a step-map model; the same model gives the same bytes."""
    guid = model_guid(arrays, metadata, components)
    meshes = {k[len(MESH_PREFIX):]: v.tolist() for k, v in arrays.items() if k.startswith(MESH_PREFIX)}
    interface = {"variables": metadata.get("variables", []), "meshes": meshes,
                 "history_windows": int(metadata["history"]), "take_over": "step_map_take_over"}
    return write_fmu(out, MODEL_IDENTIFIER, SOURCE, fmi, resource_bytes(arrays, metadata, guid, components),
                     model_description(arrays, metadata, guid, components, fmi), interface)
