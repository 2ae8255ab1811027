"""What ``FmuComponent`` asks of an FMU's instance, whatever its FMI version: its array variables, values in and out,
a step, its state (get, set, free, serialise), and its life."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

WARNING = 1  # fmi2Warning, fmi3Warning: the worst status that is not an error


class FmiError(RuntimeError):
    """An FMU call that failed, with the FMU's last message."""


@dataclass(frozen=True)
class FmuVariable:
    """An array variable of the FMU: its causality, its number of values and values per node."""
    causality: str
    size: int
    components: int = 1


class FmiInstance:
    """One instance of an FMU, described by its model description ``md``: fmpy's ``slave``, made by ``instantiate``
    from the folder the FMU is unpacked in; ``messages`` collects what it logs."""

    platform = ""                    # the binaries' folder

    def __init__(self, md: Any, name: str):
        self.md, self.name = md, name
        self.messages: list[str] = []
        self.variables: dict[str, FmuVariable] = {}
        self.skipped: dict[str, str] = {}     # inputs and outputs that cannot be coupled, and why
        self.can_get_and_set_state = False
        self.can_serialize = False

    slave: Any = None

    def instantiate(self, unzipped: str) -> None:
        raise NotImplementedError

    def _check(self, status: int, call: str) -> None:
        """An error status (worse than a warning) raised with the FMU's last message."""
        if status > WARNING:
            raise FmiError(f"{call} returned status {status}: {self.messages[-1] if self.messages else 'no message'}")

    @property
    def component(self) -> Any:
        """The instance's handle, as the FMU's own functions take it."""
        return self.slave.component

    @property
    def dll(self) -> Any:
        """The FMU's binary (ctypes)."""
        return self.slave.dll

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
        self.slave.exitInitializationMode()

    def restart(self, start: float) -> None:
        """Reset the instance (as if instantiated anew) and initialise it at ``start``: FMI's way back in time for
        an FMU without a state to restore."""
        try:
            self.slave.reset()
            self.enter_initialization(start)
            self.exit_initialization()
        except Exception as exc:        # fmpy raises its own exception type for an FMU's error status
            raise FmiError(f"{exc} ({self.messages[-1] if self.messages else 'no message'})") from None

    def get_state(self) -> Any:
        return self.slave.getFMUState()

    def set_state(self, state: Any) -> None:
        self.slave.setFMUState(state)

    def free_state(self, state: Any) -> None:
        self.slave.freeFMUState(state)

    def serialize(self, state: Any) -> bytes:
        raise NotImplementedError

    def deserialize(self, data: bytes) -> Any:
        raise NotImplementedError

    def terminate(self) -> None:
        self.slave.terminate()
        self.slave.freeInstance()
