"""What every acceleration of implicit coupling iterations shares: the base class, the registry, shared settings.

An acceleration works on the fixed-point map x -> H(x). Every method sees, per iteration, the iterate ``x`` that
went into the map and the result ``x_tilde = H(x)`` (``observe``), and proposes the next iterate
(``next_iterate``). ``start_window``/``end_window`` bracket each time window; ``map_changed`` says that a
participant's backend changed (ROM and full-order solver). The families register their classes in modules of
their own, which ``coupler.accelerations`` imports.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from cosim.registry import Registry
from cosim.schema import Value

ACCELERATIONS: Registry[Acceleration] = Registry("acceleration")
FILTERS = ("qr1", "qr1-absolute", "qr2", "none")
MAP_CHANGES = ("drop-span", "drop-all")
COMMON: dict[str, Any] = {"data": []}   # the data items accelerated (default: the scheme's choice)
RELAXATION = Value(0.5, low=0.0, high=1.0, low_open=True)

@ACCELERATIONS.register("none")
class Acceleration:
    """Plain fixed-point iteration (no acceleration); base class."""

    SETTINGS: dict = {}
    HELP: dict[str, str] = {}

    def __init__(self, block_sizes: list[int] | None = None) -> None:
        self.block_sizes = block_sizes
        self.x = np.zeros(0)           # the window's last iterate and the fixed-point map's value there,
        self.x_tilde = np.zeros(0)     # set by observe before any update
        self.iteration = 0

    def use_model(self, model: Any) -> None:
        """The run's model of the coupled map (``coupler.coupling_model``), for an acceleration that takes it as its
        prior; the others leave it."""

    def start_window(self) -> None:
        self.iteration = 0

    def observe(self, x: np.ndarray, x_tilde: np.ndarray) -> None:
        self.x, self.x_tilde = x, x_tilde
        self.iteration += 1

    def next_iterate(self) -> np.ndarray:
        return self.x_tilde.copy()

    def end_window(self) -> None:
        pass

    def map_changed(self) -> None:
        """A participant's backend changed (ROM and full-order solver): the map x -> H(x) is another one.

        Called before the first ``observe`` under the new map; what was learnt of the old map goes."""

    def regrid(self, transform: Callable[[np.ndarray], np.ndarray], block_sizes: list[int]) -> None:
        """The iterates' samples in time moved to another grid (a producer's substeps changed): every vector kept
        goes through ``transform``, which resamples a difference of iterates onto the new grid; ``block_sizes``
        are the data items' new sizes. Called before the first ``observe`` on the new grid."""
        self.block_sizes = block_sizes


def resolve_acceleration(table: object, where: str = "coupling.acceleration", source: str = "") -> dict:
    """A scene's acceleration table checked against the chosen class's settings, defaults filled in."""
    return ACCELERATIONS.settings(table, where, source, common=COMMON)


def make_acceleration(settings: dict, block_sizes: list[int]) -> Acceleration:
    """The acceleration resolved ``settings`` name (``data`` is the scheme's business)."""
    return ACCELERATIONS.create({k: v for k, v in settings.items() if k != "data"}, block_sizes=block_sizes)
