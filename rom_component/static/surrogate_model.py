"""The solid ROM as the coupler's online surrogate of a quasi-static participant (``cosim.surrogate_models``).

The coupler's surrogate (``coupler.surrogate``) fits it on the calls a run has made so far, and asks it
for the response and its derivative in closed form (``SolidRom.jacobian``); it never serves a call.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from rom_component.static.estimator import SolidRom, resolve_parts

# cheap to refit while the run goes on, and chosen for its derivative: on the double flap's sub-iteration secants
# (docs/notebook/2026-12-02-rom-accelerated-coupling.md) 32 force modes, 8 displacement modes and a ridge polynomial
# with the products of the 2 leading modes only predict a secant to 3.9 % (median); the ROM's default parts (3 modes,
# RBF) to 29 %, 8 force modes to 29 %, 16 modes with all products to 630 %
DEFAULT_MODEL: dict[str, dict[str, Any]] = {"encoder": {"type": "pod", "modes": 32},
                                            "regressor": {"type": "poly", "method": "ridge", "quadratic_modes": 2},
                                            "decoder": {"type": "linear", "modes": 8}}


class RomResponse:
    """u = S(f) of a participant, learnt from its calls: ``fit``, ``predict``, ``jacobian``."""

    def __init__(self, model: Mapping[str, Any] | None = None, where: str = "coupling.surrogate.model") -> None:
        given = dict(model or {})
        table = {kind: given.get(kind, DEFAULT_MODEL[kind]) for kind in DEFAULT_MODEL}
        for kind in DEFAULT_MODEL:      # a part table without type keeps the default part, its settings added
            if isinstance(given.get(kind), Mapping) and "type" not in given[kind]:
                table[kind] = {**DEFAULT_MODEL[kind], **given[kind]}
        unknown = set(given) - set(DEFAULT_MODEL)
        if unknown:
            raise ValueError(f"'{where}.{sorted(unknown)[0]}' is not a ROM part (encoder, regressor, decoder)")
        self.settings = resolve_parts(table, where)
        self.rom: SolidRom | None = None

    def fit(self, inputs: np.ndarray, outputs: np.ndarray, windows: np.ndarray) -> RomResponse:
        self.rom = SolidRom.from_settings(self.settings).fit(inputs, outputs, windows=windows)
        return self

    def predict(self, f: np.ndarray) -> np.ndarray:
        assert self.rom is not None
        return np.asarray(self.rom.predict(f[None, :])[0])

    def jacobian(self, f: np.ndarray) -> np.ndarray:
        assert self.rom is not None
        return self.rom.jacobian(f)

    def jacobian_factors(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The derivative as two thin factors (decoder; regressor times encoder)."""
        assert self.rom is not None
        return self.rom.jacobian_factors(f)
