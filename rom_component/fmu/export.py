"""``cosim export-fmu``: a trained ROM, of either family, as an FMI 2.0 Co-Simulation FMU."""

from __future__ import annotations

from pathlib import Path

from rom_component.model_file import load_arrays


def export_fmu(model: str | Path, out: str | Path, components_per_node: int | None = None) -> Path:
    """Write the FMU for the ROM stored in ``model``; returns its path. The same model gives the same bytes."""
    arrays, metadata = load_arrays(model)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if metadata.get("kind") == "step-map":      # a ROM with memory: its history is the FMU's state
        from rom_component.fmu.step_map_rom import export_step_map_fmu
        declared = {v["name"]: v for v in metadata.get("variables", [])}
        components = components_per_node or int(declared.get(metadata["input_variable"], {}).get("components", 1))
        return export_step_map_fmu(arrays, metadata, out, components)
    from rom_component.fmu.solid_rom import export_solid_rom_fmu
    return export_solid_rom_fmu(arrays, metadata, out, components_per_node)
