"""What ``FmuSolid`` asks of an FMU's instance, whatever its FMI version: its array variables, values in and out,
a step, its state (get, set, free, serialise), and its life."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


class FmiError(RuntimeError):
    """An FMU call that failed, with the FMU's last message."""


@dataclass(frozen=True)
class FmuVariable:
    """An array variable of the FMU: its causality, its number of values and values per node."""
    causality: str
    size: int
    components: int = 1


class FmiInstance:
    """One instance of an FMU unpacked in ``unzipped``; ``messages`` collects what it logs."""

    platform = ""                    # the binaries' folder

    def __init__(self, md: Any, unzipped: str, name: str):
        self.md, self.unzipped, self.name = md, unzipped, name
        self.messages: list[str] = []
        self.variables: dict[str, FmuVariable] = {}
        self.can_get_and_set_state = False
        self.can_serialize = False

    def instantiate(self) -> None:
        raise NotImplementedError

    @property
    def component(self) -> Any:
        """The instance's handle, as the FMU's own functions take it."""
        raise NotImplementedError

    @property
    def dll(self) -> Any:
        """The FMU's binary (ctypes)."""
        raise NotImplementedError

    def set(self, name: str, values: np.ndarray) -> None:
        raise NotImplementedError

    def get(self, name: str) -> np.ndarray:
        """The variable's values (a buffer the next call overwrites)."""
        raise NotImplementedError

    def do_step(self, t: float, dt: float) -> None:
        raise NotImplementedError

    def enter_initialization(self, start: float) -> None:
        raise NotImplementedError

    def exit_initialization(self) -> None:
        raise NotImplementedError

    def get_state(self) -> Any:
        raise NotImplementedError

    def set_state(self, state: Any) -> None:
        raise NotImplementedError

    def free_state(self, state: Any) -> None:
        raise NotImplementedError

    def serialize(self, state: Any) -> bytes:
        raise NotImplementedError

    def deserialize(self, data: bytes) -> Any:
        raise NotImplementedError

    def terminate(self) -> None:
        raise NotImplementedError
