"""A quasi-static ROM's model file loaded for its online path."""

from __future__ import annotations

from pathlib import Path

from rom_component.model_file import ModelFileError, load_arrays
from rom_component.static.online import OnlineRom

STEP_MAP_ENTRY = "rom_component.dynamic.component:StepMapRomSolid"


def load_rom(path: str | Path, arithmetic: str = "reproducible") -> OnlineRom:
    """The online ROM stored in ``path`` (``arithmetic``: see ``OnlineRom``; ``compiled`` runs the FMU's C code)."""
    arrays, metadata = load_arrays(path)
    if metadata.get("kind") == "step-map":
        raise ModelFileError(f"model file '{path}' is a ROM with memory (a step map, dynamics.memory = true): serve it "
                             f"with rom.entry = \"{STEP_MAP_ENTRY}\"")
    try:
        if arithmetic == "compiled":
            from rom_component.static.compiled import CompiledRom
            return CompiledRom(arrays, metadata)
        return OnlineRom(arrays, metadata, arithmetic)
    except (KeyError, ValueError) as exc:
        raise ModelFileError(f"model file '{path}' is incomplete: {exc}") from None
