"""The ROM with memory (step map) as an FMI 2.0 Co-Simulation FMU: the history is the FMU's state.

The FMU holds ``modelDescription.xml``, ``binaries/linux64/step_map_rom.so``, its C sources (``sources/``: ``step_map_rom.c``, the skeleton's and the FMI 2.0 headers) and the
model's arrays in ``resources/rom.bin`` (``rom_component.dynamic.compiled.resource_bytes``).
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
from rom_component.dynamic.compiled import SOURCE, model_guid, resource_bytes
from rom_component.fmu.build import compile_binary, source_files, write_sources
from rom_component.fmu.package import description_root, pack, real_variables, scalar_names

MODEL_IDENTIFIER = "step_map_rom"


def model_description(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], guid: str,
                      components: int) -> bytes:
    """``modelDescription.xml``: the force in, the interface displacement out, the probes as locals."""
    (r_f, n_in), (n_out, r_u) = arrays["E"].shape, arrays["A"].shape
    declared = {v["name"]: v for v in metadata.get("variables", [])}
    inputs = scalar_names(metadata["input_variable"], n_in, components)
    outputs = scalar_names(metadata["output_variable"], n_out,
                           int(declared.get(metadata["output_variable"], {}).get("components", components)))
    probes = [name for probe in metadata.get("probes", []) for name in scalar_names(probe, 2, 1)]
    root, _ = description_root(MODEL_IDENTIFIER, guid,
                               f"step-map ROM of a structure with inertia: r_f={r_f}, r_u={r_u}, history of "
                               f"{metadata['history']} windows, window {metadata['dt']:g} s; the history is the "
                               "FMU's state", False, source_files(SOURCE))
    ET.SubElement(root, "DefaultExperiment", {"stepSize": repr(float(metadata["dt"]))})
    real_variables(root, inputs, outputs, probes)
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def export_step_map_fmu(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], out: Path,
                        components: int) -> Path:
    """The FMU of a step-map model; the same model gives the same bytes."""
    guid = model_guid(arrays, metadata, components)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for folder in ("sources", "resources", "binaries/linux64"):
            (root / folder).mkdir(parents=True)
        write_sources(root / "sources", SOURCE)
        (root / "resources" / "rom.bin").write_bytes(resource_bytes(arrays, metadata, guid, components))
        (root / "modelDescription.xml").write_bytes(model_description(arrays, metadata, guid, components))
        meshes = {k[len(MESH_PREFIX):]: v.tolist() for k, v in arrays.items() if k.startswith(MESH_PREFIX)}
        (root / "resources" / "interface.json").write_text(json.dumps(
            {"variables": metadata.get("variables", []), "meshes": meshes, "history_windows": int(metadata["history"]),
             "take_over": "step_map_take_over"}, sort_keys=True))
        compile_binary(root / "sources", root / "binaries" / "linux64" / f"{MODEL_IDENTIFIER}.so", SOURCE)
        return pack(root, out)
