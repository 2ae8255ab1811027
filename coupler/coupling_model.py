"""A model of the coupled interface map learnt during a run: a scheme hands it every coupling iteration and may start
a window from its prediction; an acceleration may take it as its prior (``Acceleration.use_model``). The scene's
plug-in resolution makes it (``coupler.scene_rules.coupling_model``); the schemes and the run know only this."""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np


class CouplingModel(Protocol):
    """What a scheme and a run ask of a model of the coupled map x -> H(x)."""

    predicts_start: bool      # a window's first iterate is the model's prediction (where it has one)

    def start_window(self) -> None: ...

    def observe(self, x: np.ndarray, y: np.ndarray, x_tilde: np.ndarray) -> None:
        """One coupling iteration: x went into the first participant, y came out, x~ out of the second."""
        ...

    def end_window(self, converged: bool) -> None: ...

    def predict_start(self, x_last: np.ndarray, plain: np.ndarray | None = None) -> np.ndarray | None:
        """A window's first iterate from the last window's converged ``x_last`` (``plain``: the scheme's own),
        or None."""
        ...

    def checkpoint_state(self) -> dict[str, Any]: ...

    def restore_checkpoint_state(self, state: dict[str, Any]) -> None: ...

    def attributes(self, acceleration: Any) -> dict[str, float | int]:
        """What it did and cost, for the results file's attributes."""
        ...

    def close(self) -> None: ...
