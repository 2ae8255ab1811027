"""The FMU-style component contract with array-valued variables.

A component is a plain Python class deriving from ``Component``. It declares its
variables, accepts parameters at ``instantiate``, receives inputs by
``set_values``, advances by ``do_step`` and hands out outputs by ``get_values``.
``step`` fuses the three for the hot path. Stateful components implement
``save_state``/``restore_state``; the handles of ``get_state`` stay in the
component's process, only an integer crosses the wire.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from cosim.errors import ComponentError

CAUSALITIES = ("input", "output", "parameter")


@dataclass(frozen=True)
class Variable:
    """An array-valued variable: ``size`` values of one physical quantity."""

    name: str
    causality: str
    size: int
    unit: str = ""

    def __post_init__(self) -> None:
        if self.causality not in CAUSALITIES:
            raise ValueError(f"variable '{self.name}': causality {self.causality!r} not in {CAUSALITIES}")


class Component:
    """Base class of every component; subclasses fill in the physics."""

    #: name used in messages until the scene gives one
    name: str = "component"

    def __init__(self) -> None:
        self._states: dict[int, Any] = {}
        self._next_handle = 1

    # --- description ---------------------------------------------------
    def variables(self) -> list[Variable]:
        """The component's variables (available after ``instantiate``)."""
        raise NotImplementedError

    def coordinates(self) -> np.ndarray:
        """Interface node coordinates, shape (n_nodes, dim), for mapping."""
        return np.zeros((0, 1))

    @property
    def can_get_and_set_state(self) -> bool:
        return type(self).save_state is not Component.save_state

    def describe(self) -> dict[str, Any]:
        """Name, variables, interface coordinates and capabilities."""
        return {
            "name": self.name,
            "variables": [asdict(v) for v in self.variables()],
            "coordinates": np.asarray(self.coordinates(), dtype=np.float64),
            "can_get_and_set_state": self.can_get_and_set_state,
        }

    # --- life cycle -----------------------------------------------------
    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        """Read parameters and allocate."""

    def enter_initialization_mode(self, start: float, stop: float) -> None:
        """Prepare to run on [start, stop]."""

    def exit_initialization_mode(self) -> None:
        """Initial values are final."""

    def terminate(self) -> dict[str, np.ndarray]:
        """End of the run; may return arrays for the results file."""
        return {}

    # --- data -----------------------------------------------------------
    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        raise NotImplementedError

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def do_step(self, t: float, dt: float) -> None:
        """Advance from ``t`` to ``t + dt`` with the inputs set last."""
        raise NotImplementedError

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Set inputs, advance, return all outputs: one round trip on the hot path."""
        self.set_values(inputs)
        self.do_step(t, dt)
        return self.get_values(self.output_names())

    def output_names(self) -> list[str]:
        return [v.name for v in self.variables() if v.causality == "output"]

    # --- state ------------------------------------------------------------
    def save_state(self) -> Any:
        """A copy of everything ``do_step`` changes (stateful components only)."""
        raise ComponentError(self.name, "cannot get and set state")

    def restore_state(self, state: Any) -> None:
        raise ComponentError(self.name, "cannot get and set state")

    def get_state(self) -> int:
        handle = self._next_handle
        self._next_handle += 1
        self._states[handle] = self.save_state()
        return handle

    def set_state(self, handle: int) -> None:
        self.restore_state(self._state(handle))

    def free_state(self, handle: int) -> None:
        self._state(handle)
        del self._states[handle]

    def _state(self, handle: int) -> Any:
        if handle not in self._states:
            raise ComponentError(self.name, f"unknown state handle {handle}")
        return self._states[handle]


def check_inputs(component: Component, values: Mapping[str, np.ndarray], sizes: Mapping[str, int]) -> None:
    """Raise a ComponentError unless ``values`` are known inputs of the declared sizes."""
    for name, value in values.items():
        if name not in sizes:
            raise ComponentError(component.name, f"'{name}' is not an input (inputs: {', '.join(sizes)})")
        if np.shape(value) != (sizes[name],):
            raise ComponentError(
                component.name, f"input '{name}' has shape {np.shape(value)}, expected ({sizes[name]},)")
