"""The FMU-style component contract with array-valued variables.

A component is a plain Python class deriving from ``Component``. It declares its
variables, accepts parameters at ``instantiate``, receives inputs by
``set_values``, advances by ``do_step`` and hands out outputs by ``get_values``.
``step`` fuses the three for the hot path. Stateful components implement
``save_state``/``restore_state``; the handles of ``get_state`` stay in the
component's process, only an integer crosses the wire. A component that cannot
snapshot its state but repeats a window by solving it again from its last iterate (as
Kratos does) declares ``repeats_steps``: a ``step`` with the same ``t`` solves the same
window again, one with a later ``t`` closes the window and moves on.

Meshes and vectors: a component declares named meshes (node coordinates, n x dim); a
variable lives on one of them with ``components`` values per node and travels as an
array of shape (n,) for one component and (n, k) for k > 1. Variables with causality
``local`` are returned by ``step`` and recorded with the component's snapshots, but
never exchanged.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import ComponentError, SceneError
from cosim.schema import validate

CAUSALITIES = ("input", "output", "local", "parameter")


@dataclass(frozen=True)
class Variable:
    """An array-valued variable: ``size`` values of one physical quantity.

    ``mesh`` names the mesh it lives on ("" for none); ``components`` is the number of
    values per node, so ``size`` = nodes x components. ``precision`` is the relative precision
    an output carries (a solver's own tolerance; 0: not declared): coupling limits below it
    cannot be met, and the coupler says so at start.
    """

    name: str
    causality: str
    size: int
    unit: str = ""
    mesh: str = ""
    components: int = 1
    precision: float = 0.0

    def __post_init__(self) -> None:
        if self.causality not in CAUSALITIES:
            raise ValueError(f"variable '{self.name}': causality {self.causality!r} not in {CAUSALITIES}")
        if self.components < 1 or self.size % self.components:
            raise ValueError(f"variable '{self.name}': size {self.size} is not a multiple of "
                             f"{self.components} components")

    @property
    def shape(self) -> tuple[int, ...]:
        """The array shape on the wire: (n,) or (n, components)."""
        return (self.size,) if self.components == 1 else (self.size // self.components, self.components)


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

    def meshes(self) -> dict[str, np.ndarray]:
        """Node coordinates, (n_nodes, dim), of each mesh the variables name, for mapping."""
        return {}

    #: a ``step`` with the same ``t`` solves that window again from the last iterate
    repeats_steps: bool = False

    #: the outputs depend on the inputs of the call alone (nothing that ``do_step`` changes carries over): implicit
    #: coupling may call it again for a window without rolling it back. Implicit coupling needs one of three
    #: answers from a component, as FMI asks ``canGetAndSetFMUstate``: ``save_state`` and ``restore_state``,
    #: ``repeats_steps``, or ``stateless``
    stateless: bool = False

    #: why the component cannot repeat a window, when it can do none of the three (an FMU that cannot get and set
    #: its state, say): implicit coupling refuses it with this reason
    state_note: str = ""

    #: variables the component has and cannot offer, with why (an FMU's Int32 input): a scene that couples one is
    #: refused with the reason
    variable_notes: dict[str, str] = {}

    #: how many of the last converged windows the component needs to be handed when it takes over from another
    #: backend during a run (a structure with inertia: its history); 0 for none
    history_windows: int = 0

    #: seconds without a request after which the server calls ``idle`` (None: never)
    idle_interval: float | None = None

    #: the ``cosim.schema`` schema of ``instantiate``'s parameters, if declared: the coupler then checks a
    #: scene's parameters against it before any process starts, naming the scene key of a bad one
    parameter_schema: dict[str, Any] | None = None

    @property
    def can_get_and_set_state(self) -> bool:
        return type(self).save_state is not Component.save_state

    @property
    def can_checkpoint(self) -> bool:
        """Whether ``checkpoint`` gives what a new process needs to go on (its own, or ``save_state``'s)."""
        return type(self).checkpoint is not Component.checkpoint or self.can_get_and_set_state

    def describe(self) -> dict[str, Any]:
        """Name, variables, meshes (as arrays ``mesh:<name>``) and capabilities."""
        description: dict[str, Any] = {
            "name": self.name,
            "variables": [asdict(v) for v in self.variables()],
            "can_get_and_set_state": self.can_get_and_set_state,
            "can_checkpoint": self.can_checkpoint,
            "repeats_steps": self.repeats_steps,
            "stateless": self.stateless,
            "history_windows": self.history_windows,
        }
        if self.state_note:
            description["state_note"] = self.state_note
        if self.variable_notes:
            description["variable_notes"] = dict(self.variable_notes)
        for name, nodes in self.meshes().items():
            description[MESH_PREFIX + name] = np.asarray(nodes, dtype=np.float64)
        for name, lines in self.lines().items():
            description[LINES_PREFIX + name] = np.asarray(lines, dtype=np.int64)
        return description

    def lines(self) -> dict[str, np.ndarray]:
        """Optional: a mesh's line elements, (m, 2) indices of its nodes, for a mapping that interpolates on the
        sender's elements (``nearest-element``); none by default."""
        return {}

    def warn(self, message: str) -> None:
        """A warning for the coupler, delivered with the reply of the current request."""
        self.__dict__.setdefault("_warnings", []).append(message)

    def take_warnings(self) -> list[str]:
        return self.__dict__.pop("_warnings", [])

    def validated(self, parameters: Mapping[str, Any]) -> dict[str, Any]:
        """``parameters`` checked against ``parameter_schema``, defaults filled in; a bad one is a
        ``ComponentError`` naming this component and the key."""
        try:
            return validate(parameters, self.parameter_schema or {})
        except SceneError as exc:
            raise ComponentError(self.name, str(exc)) from None

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

    def idle(self) -> None:
        """Work between requests, every ``idle_interval`` seconds without one; must change no result."""

    # --- data -----------------------------------------------------------
    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        raise NotImplementedError

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def end_window(self, values: Mapping[str, np.ndarray]) -> None:
        """The window converged: the last values of the inputs the scene marks ``exchange.at_window_end``. A
        solver that keeps the data it was last given (Kratos's, whose coupler writes it after the solve) ends the
        window holding them; the default ignores them."""

    def do_step(self, t: float, dt: float) -> None:
        """Advance from ``t`` to ``t + dt`` with the inputs set last."""
        raise NotImplementedError

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Set inputs, advance, return all outputs and locals: one round trip on the hot path."""
        self.set_values(inputs)
        self.do_step(t, dt)
        return self.get_values(self.output_names() + self.local_names())

    def served_step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``step`` for the component server, which encodes the outputs before it takes another request: the
        arrays returned may be the component's own buffers, rewritten by its next call (by default: ``step``)."""
        return self.step(t, dt, inputs)

    def input_at(self, name: str, time: float) -> np.ndarray:
        """Input ``name`` at ``time`` inside the window being computed, as the coupler interpolates it (a
        component that subcycles, ``cosim.subcycling``): between the steps' inputs for a Runge-Kutta stage, say."""
        window = getattr(self, "window_inputs", None)
        if window is None:
            raise ComponentError(self.name, f"input_at('{name}', {time:g}) outside a subcycled step: set "
                                            f"components.<name>.substeps or an exchange's waveform_degree")
        try:
            return window.at(name, time)
        except ComponentError as exc:
            raise ComponentError(self.name, exc.detail) from None

    def output_names(self) -> list[str]:
        return [v.name for v in self.variables() if v.causality == "output"]

    def local_names(self) -> list[str]:
        return [v.name for v in self.variables() if v.causality == "local"]

    def take_over(self, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, np.ndarray]) -> None:
        """Start from the converged inputs and outputs of the last windows another backend served (arrays of
        ``history_windows`` rows or fewer, oldest first); components with ``history_windows`` > 0 implement it."""
        raise ComponentError(self.name, "takes over no history")

    # --- state ------------------------------------------------------------
    def save_state(self) -> Any:
        """A copy of everything ``do_step`` changes (stateful components only)."""
        raise ComponentError(self.name, "cannot get and set state")

    def restore_state(self, state: Any) -> None:
        raise ComponentError(self.name, "cannot get and set state")

    def checkpoint(self) -> Any:
        """Everything a new process of this component needs to go on from here, after the last window, as a state
        tree (``cosim.checkpoint``: arrays, numbers, strings, lists and dicts; no pickle). By default the state
        ``save_state`` returns; a component with more between windows than ``do_step`` rolls back (a warm start,
        a history) overrides it."""
        if not self.can_get_and_set_state:
            raise ComponentError(self.name, "cannot checkpoint: it implements neither checkpoint nor save_state")
        return self.save_state()

    def restore_checkpoint(self, state: Any) -> None:
        """Go on from a ``checkpoint`` of an earlier process (after ``exit_initialization_mode``)."""
        self.restore_state(state)

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


RUN_DIR_VARIABLE = "COSIM_RUN_DIR"    # set by the launcher: the run's directory, for a component's own output


def run_directory() -> Path | None:
    """The directory of the run that launched this component (None when it was started otherwise): where a
    component writes output of its own (``kratos/<solver>/`` for a Kratos stage's VTK), never beside its inputs."""
    given = os.environ.get(RUN_DIR_VARIABLE)
    return Path(given) if given else None


MESH_PREFIX = "mesh:"
LINES_PREFIX = "lines:"

STATE_METHODS = "save_state(self) -> Any and restore_state(self, state: Any) -> None"


def declares_state(cls: type) -> bool:
    """Whether a component class says, by itself, how implicit coupling repeats a window with it: state
    methods, ``repeats_steps`` or ``stateless`` (an instance may still set the latter two at ``instantiate``)."""
    return (getattr(cls, "save_state", Component.save_state) is not Component.save_state
            or bool(getattr(cls, "repeats_steps", False)) or bool(getattr(cls, "stateless", False)))


def undeclared_state_message(component: str, entry: str) -> str:
    """Why implicit coupling refuses a component that does not declare how it repeats a window."""
    return (f"component '{component}' ({entry}) is coupled implicitly, which repeats each window until it converges, "
            f"but it neither implements {STATE_METHODS} nor declares stateless = True (or repeats_steps = True): add "
            "the state methods if do_step changes anything that carries over to the next window, else declare it "
            "stateless")


def check_inputs(component: Component, values: Mapping[str, np.ndarray],
                 shapes: Mapping[str, int | tuple[int, ...]]) -> None:
    """Raise a ComponentError unless ``values`` are known inputs of the declared shapes (a size means (size,))."""
    for name, value in values.items():
        if name not in shapes:
            raise ComponentError(component.name, f"'{name}' is not an input (inputs: {', '.join(shapes)})")
        shape = shapes[name]
        shape = (shape,) if isinstance(shape, int) else tuple(shape)
        actual = value.shape if isinstance(value, np.ndarray) else np.shape(value)
        if actual != shape:
            raise ComponentError(component.name, f"input '{name}' has shape {actual}, expected {shape}")
