"""``cosim export-fmu``: a trained ROM, of either family, as an FMI 2.0 or FMI 3.0 Co-Simulation FMU."""

from __future__ import annotations

from pathlib import Path

from cosim.errors import CosimError
from rom_component.model_file import load_arrays

FMI_VERSIONS = (2, 3)


def export_fmu(model: str | Path, out: str | Path, components_per_node: int | None = None, fmi: int = 2) -> Path:
    """Write the FMI ``fmi`` FMU for the ROM stored in ``model``; returns its path. The same model gives the same
    bytes."""
    if fmi not in FMI_VERSIONS:
        raise CosimError(f"FMI version {fmi} is not one this export writes: {', '.join(map(str, FMI_VERSIONS))}")
    arrays, metadata = load_arrays(model)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if metadata.get("kind") == "step-map":      # a ROM with memory: its history is the FMU's state
        from rom_component.fmu.step_map_rom import export_step_map_fmu
        declared = {v["name"]: v for v in metadata.get("variables", [])}
        components = components_per_node or int(declared.get(metadata["input_variable"], {}).get("components", 1))
        return export_step_map_fmu(arrays, metadata, out, components, fmi)
    from rom_component.fmu.solid_rom import export_solid_rom_fmu
    return export_solid_rom_fmu(arrays, metadata, out, components_per_node, fmi)
