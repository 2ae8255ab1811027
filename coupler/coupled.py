"""What a coupling scheme drives, declared: a component process (``cosim.proxy.ComponentProxy``), a program that
calls the coupler (``cosim.participant.ParticipantProxy``) and a schedule of backends, full order then a ROM
(``coupler.schedule.BackendSchedule``) each answer these calls and carry these attributes, so that a scheme asks
what it needs and never what it holds."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from cosim.component import Variable

Samples = tuple[np.ndarray, dict[str, np.ndarray]]      # times inside the window (0 to 1) and the values there
Call = tuple[dict[str, np.ndarray], dict[str, np.ndarray]]   # one step's inputs and outputs


class Coupled(Protocol):
    """One scene component as a coupling scheme drives it."""

    name: str
    variables: dict[str, Variable]
    # how it repeats a window under implicit coupling: its state saved and restored (by a step, where
    # step_saves_state, into saved_state), its own repetition, nothing to repeat, or why it cannot
    can_get_and_set_state: bool
    step_saves_state: bool
    saved_state: int | None
    repeats_steps: bool
    stateless: bool
    state_note: str
    # time inside a window: whether its steps read the waveforms of their inputs, and what its last step took
    reads_waveforms: bool
    substeps: Samples | None
    substep_calls: list[Call]
    # whether the last step was served by another backend than the one before (the acceleration's map changed)
    backend_changed: bool
    # the gradients its last step wrote with its data (a preCICE participant's write_gradient_data), by data item
    gradients: dict[str, np.ndarray]

    def output_names(self) -> list[str]: ...

    def mesh_of(self, name: str) -> np.ndarray: ...

    def lines_of(self, name: str) -> np.ndarray | None: ...

    def cells_of(self, name: str) -> np.ndarray | None: ...

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]: ...

    def send_step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
                  save: bool = False, free: int | None = None,
                  waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> None: ...

    def receive_step(self) -> dict[str, np.ndarray]: ...

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
             save: bool = False, free: int | None = None,
             waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> dict[str, np.ndarray]: ...

    def end_window(self, values: Mapping[str, np.ndarray]) -> None: ...

    def coupling_state(self) -> dict[str, Any] | None:
        """What a run's checkpoint keeps of it beside the component's own checkpoint (a schedule's backends and
        history), or None."""
        ...

    def restore_coupling_state(self, state: Mapping[str, Any]) -> None: ...


class SavesState(Coupled, Protocol):
    """A component whose state a scheme saves before a window and restores to repeat it
    (``can_get_and_set_state``)."""

    def get_state(self) -> int: ...

    def free_state(self, handle: int) -> None: ...
