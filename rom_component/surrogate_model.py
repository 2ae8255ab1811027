"""The solid ROM as the coupler's online surrogate of a quasi-static participant (``cosim.surrogate_models``).

The coupler's surrogate (``coupler.surrogate``) fits it on the calls a run has made so far, and asks it
for the response and its derivative in closed form (``SolidRom.jacobian``); it never serves a call.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from rom_component.estimator import SolidRom, resolve_parts

# small, smooth and cheap to refit while the run goes on: a ridge polynomial (an RBF's dense system grows as the
# cube of the calls) on a few modes; its derivative, not its last digit, is what the coupler uses
DEFAULT_MODEL: dict[str, dict[str, Any]] = {"encoder": {"type": "pod", "modes": 8},
                 "regressor": {"type": "poly", "method": "ridge"},
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
