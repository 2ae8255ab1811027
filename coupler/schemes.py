"""Coupling schemes: serial-explicit, parallel-explicit, serial-implicit (Gauss-Seidel), parallel-implicit
(Jacobi), and multi (Jacobi over two or more participants).

A scheme advances all participants through one time window (``advance``) and
reports iterations, convergence, residual measures and the window's values of
every exchanged data item. Data values are kept on the producer's nodes and mapped
when sent. In implicit schemes stateful participants are rolled back with
``set_state`` (fused into the step request) before every repeated iteration.

Waveforms (``coupler.waveform``): a producer that steps several times in a window (a participant with
``substeps``) sends its samples with the window's end. An iterate is then, per data item, the window-end value
(``values``) and the substeps' samples (``series``: normalised times and values). A reader of degree >= 1 gets the
interpolant through the window's start, the samples and the end. The acceleration works on every sample of the
window, concatenated per item (samples, then the end), on the time grid of the producer's latest iteration; the
convergence measures, the extrapolation and the predictors on the window-end values alone. Without substeps an
iterate is its end values, and everything is as it was.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeGuard

import numpy as np

from cosim.checkpoint import object_state, restore_object
from cosim.errors import (
    ComponentDied,
    ComponentError,
    ComponentTimeout,
    ConvergenceError,
    DivergenceError,
    StalledError,
)
from cosim.registry import Registry
from coupler.accelerations import Acceleration
from coupler.convergence import ConvergenceMeasure, window_converged
from coupler.coupled import Coupled, SavesState
from coupler.coupling_model import CouplingModel
from coupler.extrapolation import Extrapolation
from coupler.linalg import norm
from coupler.mapping import Mapping as InterfaceMapping
from coupler.recording import CallRecorder
from coupler.waveform import coefficients, resampling

SCHEMES: Registry[CouplingScheme] = Registry("coupling scheme")


def stalled(residuals: Sequence[float], last: int = 10) -> bool:
    """The residual has not decreased over the last ``last`` iterations (by a factor 2) after falling by 1e3."""
    if len(residuals) < 2 * last:
        return False
    before, recent = min(residuals[:-last]), min(residuals[-last:])
    return recent > 0.5 * before and before < 1e-3 * residuals[0]


@dataclass
class Exchange:
    """One data item sent from ``source`` to ``target`` through ``mapping``."""

    data: str
    source: Coupled
    target: Coupled
    mapping: InterfaceMapping
    degree: int = 0           # the reader's interpolant in time across the window (coupler.waveform)
    substeps: bool = False    # the producer's samples inside the window are sent
    at_window_end: bool = False   # the receiver gets the window's last values when it converges


LINE = np.array([0.0, 0.0, 1.0, 1.0])     # the knots of the line through a window's start and end
Series = dict[str, tuple[np.ndarray, np.ndarray]]    # data -> (normalised times inside the window, samples there)


@dataclass
class WindowResult:
    time: float
    iterations: int
    converged: bool
    measures: dict[str, float] = field(default_factory=dict)
    message: str = ""   # why an accepted window did not converge
    residuals: list[float] = field(default_factory=list)   # ||H(x) - x|| of the accelerated data, per iteration
    measure_history: list[list[float]] = field(default_factory=list)   # every measure's value, per iteration


class CouplingScheme:
    """Common parts: data values, sending, recording."""

    implicit = True
    many_participants = False     # couples two or more participants (else exactly two)
    takes_first_iterate_zero = False      # honours ``first_iterate_zero``
    measuring = 1       # the participant that measures and accelerates, in preCICE's terms (its logs name it)

    def __init__(self, participants: Sequence[Coupled], exchanges: Sequence[Exchange],
                 measures: Sequence[ConvergenceMeasure] = (), acceleration: Acceleration | None = None,
                 accelerated: Sequence[str] = (), max_iterations: int = 50, on_max_iterations: str = "fail",
                 extrapolation_order: int = 0, recorders: Mapping[str, CallRecorder] | None = None,
                 divergence_factor: float = 1e3, predictor: str = "none", model: CouplingModel | None = None):
        self.participants = tuple(participants)
        self.first, self.second = self.participants[:2]
        self.exchanges = list(exchanges)
        self.measures = list(measures)
        self.acceleration = acceleration or Acceleration()
        self.accelerated = list(accelerated)
        self.max_iterations = max_iterations
        self.on_max_iterations = on_max_iterations
        self.recorders = dict(recorders or {})
        self.values: dict[str, np.ndarray] = {}
        self.series: Series = {}                  # the last window's substep samples, per data item
        self._window_start: dict[str, np.ndarray] = {}    # the window's start values (the last window's ends)
        self._start_gradients: dict[str, np.ndarray] = {}   # and the gradients written with them
        self._start_mapped: dict[int, tuple[np.ndarray, np.ndarray]] = {}   # an exchange's start: (it, mapped)
        self._with_substeps = {e.data for e in exchanges if e.substeps}    # data whose samples are exchanged
        self._grid: dict[str, np.ndarray] = {}    # the accelerated data's times inside the window, as the
                                                  # acceleration's columns hold them
        self.divergence_factor = divergence_factor
        self.window = 0
        self.iteration = 0
        self.t = self.dt = 0.0
        self._residuals: list[float] = []   # ||H(x) - x|| of the accelerated data, per iteration
        self._measure_history: list[list[float]] = []
        self._extrapolation = Extrapolation(extrapolation_order)
        self.predictor = predictor
        self._next_start: dict[str, np.ndarray] | None = None   # the acceleration's estimate for the next window
        self._state: dict[str, int] = {}      # each stateful participant's state at the window's start
        self._to_free: dict[str, int] = {}    # states of the last window, freed with the next step
        self.model = model      # a model of the coupled map learnt during the run (coupler.coupling_model), or None
        self._deferred: Callable[[], None] | None = None
        self.first_iterate_zero: list[str] = []   # data whose initial values the measures and the acceleration
                                                  # take as zero in the first window's first iteration

    def checkpoint_state(self) -> dict[str, Any]:
        """Everything the scheme carries from one window to the next, as a state tree (``cosim.checkpoint``): the
        window counter, the data values, the extrapolation's history, the predictor's start, the acceleration's
        columns or Jacobian, the measures' and the backend schedules' state. Taken between windows."""
        return {"window": self.window, "values": self.values, "next_start": self._next_start,
                "series": {"times": {name: pair[0] for name, pair in self.series.items()},
                           "samples": {name: pair[1] for name, pair in self.series.items()}},
                "grid": self._grid,
                "extrapolation": object_state(self._extrapolation),
                "acceleration": object_state(self.acceleration, skip=("model",)),
                "model": self.model.checkpoint_state() if self.model is not None else None,
                "measures": [object_state(m) for m in self.measures],
                "schedules": {p.name: kept for p in self.participants
                              if (kept := p.coupling_state()) is not None}}

    def restore_checkpoint_state(self, state: Mapping[str, Any]) -> None:
        """Go on from ``checkpoint_state`` of an earlier run of the same scene (after ``initialize``)."""
        self.window = state["window"]
        self.values = dict(state["values"])
        stored = state.get("series") or {"times": {}, "samples": {}}
        self.series = {name: (times, stored["samples"][name]) for name, times in stored["times"].items()}
        self._grid = dict(state.get("grid") or {})
        self._next_start = state["next_start"]
        restore_object(self._extrapolation, state["extrapolation"])
        restore_object(self.acceleration, state["acceleration"])
        if self.model is not None:
            self.model.restore_checkpoint_state(state["model"])
        for measure, measure_state in zip(self.measures, state["measures"]):
            restore_object(measure, measure_state)
        for p in self.participants:
            if p.coupling_state() is not None:
                p.restore_coupling_state(state["schedules"][p.name])

    def defer(self, work: Callable[[], None]) -> None:
        """Work for once the next window's first request is out, while a component computes (the run's log rows
        and status of the window before)."""
        self._deferred = work

    def run_deferred(self) -> None:
        work, self._deferred = self._deferred, None
        if work is not None:
            work()

    def sent_by(self, proxy) -> list[str]:
        """Names of the data items ``proxy`` produces."""
        return [e.data for e in self.exchanges if e.source is proxy]

    def initialize(self) -> None:
        """Initial data values from the producers (after initialization mode)."""
        for proxy in self.participants:
            names = self.sent_by(proxy)
            if names:
                self.values.update({k: np.array(v) for k, v in proxy.get_values(names).items()})
        if not self.accelerated:
            self.accelerated = self.default_accelerated()
        if self.accelerated:
            self._extrapolation.store(self._stack(self.values, self.accelerated))

    def default_accelerated(self) -> list[str]:
        """Data the acceleration works on when the scene names none."""
        return []

    def _predicted(self) -> dict[str, np.ndarray]:
        """Data values for the first iteration: the last ones, accelerated data extrapolated."""
        values = dict(self.values)
        if self._next_start is not None:
            values.update(self._next_start)
            self._next_start = None
        else:
            values.update(self._split(self._extrapolation.predict(), self.accelerated))
        if self.model is not None and self.model.predicts_start and self.accelerated:
            plain = self._stack(values, self.accelerated)
            start = self.model.predict_start(self._stack(self.values, self.accelerated), plain)
            if start is not None:
                values.update(self._split(start, self.accelerated))
        return values

    def _predict_next_window(self, converged: bool) -> None:
        """With ``predictor = "acceleration"``: one more update from the converged iteration's data.

        The update is what the acceleration would have proposed had the window gone on: its
        estimate of the fixed point, better than the last value (the solvers are not called).
        """
        if converged and self.predictor == "acceleration" and self.accelerated:
            self._next_start = self._next_iterate(self.accelerated)[0]

    @staticmethod
    def _stateful(proxy: Coupled) -> TypeGuard[SavesState]:
        """A component whose state the scheme saves and restores (a schedule of backends never is one)."""
        return proxy.can_get_and_set_state

    # --- helpers ------------------------------------------------------------
    def inputs_for(self, target: Coupled, values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {e.data: self._corrected(e, e.mapping(values[e.data]), self._gradients(e))
                for e in self.exchanges if e.target is target}

    @staticmethod
    def _gradients(e: Exchange) -> np.ndarray | None:
        """The gradients the source's last step wrote of ``e``'s data, where ``e``'s mapping takes them (only
        preCICE participants write gradients)."""
        return e.source.gradients.get(e.data) if e.mapping.takes_gradients else None

    @staticmethod
    def _corrected(e: Exchange, mapped: np.ndarray, gradients: np.ndarray | None) -> np.ndarray:
        """Mapped values of one time plus what ``gradients`` add through a gradient mapping."""
        if gradients is None:
            return mapped
        return mapped + e.mapping.correction(gradients, mapped.shape)    # type: ignore[attr-defined]

    def _mapped_start(self, e: Exchange, start: np.ndarray) -> np.ndarray:
        """The window's start values mapped for ``e`` and corrected by the gradients written with them: mapped once
        a window (the start does not change between its iterations)."""
        cached = self._start_mapped.get(id(e))
        if cached is None or cached[0] is not start:
            cached = self._start_mapped[id(e)] = (start, e.mapping(start))
        end = self._gradients(e)
        return cached[1] if end is None else self._corrected(e, cached[1], self._start_gradients.get(e.data, end))

    def _corrected_in_time(self, e: Exchange, mapped: np.ndarray) -> np.ndarray:
        """Samples in time, each mapped, from the window's start to its end, corrected by the gradients written
        with them: the start's from the window before, the others' the last written (the end's)."""
        end = self._gradients(e)
        if end is None:
            return mapped
        start = self._start_gradients.get(e.data, end)
        return np.stack([self._corrected(e, sample, start if k == 0 else end) for k, sample in enumerate(mapped)])


    def block_sizes(self, names: Sequence[str]) -> list[int]:
        return [self.values[n].size * (1 + len(self._grid.get(n, ()))) for n in names]

    def waveforms_for(self, target: Coupled, values: Mapping[str, np.ndarray], series: Series,
                      inputs: Mapping[str, np.ndarray]) -> dict[str, Any]:
        """``{"waveforms": {data: (knots, coefficients)}}`` for a target that reads in time (a participant), for its
        data of degree >= 1: the B-spline through the window's start, the samples and the end, on its mesh
        (``inputs``: ``inputs_for(target, values)``, the end mapped)."""
        if not target.reads_waveforms:
            return {}
        waveforms = {}
        for e in self.exchanges:
            if e.target is not target or e.degree < 1:
                continue
            start, end = self._window_start.get(e.data, values[e.data]), values[e.data]
            if e.data not in series:       # start and end: the line through them, the end as ``inputs`` has it
                waveforms[e.data] = (LINE, np.stack([self._mapped_start(e, start), inputs[e.data]]))
                continue
            times, samples = series[e.data]
            mapped = self._corrected_in_time(e, e.mapping.in_time(np.concatenate([start[None], samples, end[None]])))
            waveforms[e.data] = coefficients(times, mapped, e.degree)
        return {"waveforms": waveforms} if waveforms else {}

    def _take_series(self, proxy: Coupled, series: Series) -> None:
        """The substep samples ``proxy``'s last step sent, into ``series`` (its data without samples leave it)."""
        sent = proxy.substeps
        for name in self.sent_by(proxy):
            series.pop(name, None)
        if sent:
            times, samples = sent
            series.update({name: (times, value) for name, value in samples.items() if name in self._with_substeps})

    def _degree(self, name: str) -> int:
        return max((e.degree for e in self.exchanges if e.data == name), default=0)

    def _on_grid(self, values: Mapping[str, np.ndarray], series: Series, name: str,
                 times: np.ndarray) -> np.ndarray:
        """The samples of ``name`` at ``times`` inside the window: its own where the grids agree, else its waveform
        (start, samples, end; the reader's degree) evaluated there."""
        own = series.get(name)
        if own is not None and np.array_equal(own[0], times):
            return own[1]
        inner, samples = own if own is not None else (np.zeros(0), values[name][None][:0])
        known = np.concatenate([[0.0], inner, [1.0]])
        stacked = np.concatenate([self._window_start.get(name, values[name])[None], samples, values[name][None]])
        matrix = resampling(known, self._degree(name), times)
        return (matrix @ stacked.reshape(len(known), -1)).reshape((len(times),) + stacked.shape[1:])

    def _iterates(self, values: Mapping[str, np.ndarray], series: Series, out: Mapping[str, np.ndarray],
                  out_series: Series, names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """x and H(x) of the accelerated data as vectors: with substeps, every sample on the time grid of the
        producer's output (the acceleration's columns brought onto it when it changed), then the end."""
        grid = {name: out_series[name][0] for name in names if name in out_series}
        if not grid and not self._grid:
            return self._stack(values, names), self._stack(out, names)
        if set(grid) != set(self._grid) or any(not np.array_equal(grid[n], self._grid[n]) for n in grid):
            self._regrid(grid, names)
        x = np.concatenate([part for name in names for part in (
            (self._on_grid(values, series, name, grid[name]).ravel(),) if name in grid else ()) + (values[name].ravel(),)])
        x_tilde = np.concatenate([part for name in names for part in (
            (out_series[name][1].ravel(),) if name in grid else ()) + (out[name].ravel(),)])
        return x, x_tilde

    def _regrid(self, grid: dict[str, np.ndarray], names: Sequence[str]) -> None:
        """The accelerated data's time grid changed: the acceleration's columns (differences of iterates of one
        window: zero at its start) resampled onto the new grid, item by item."""
        old = {name: self._grid.get(name, np.zeros(0)) for name in names}
        new = {name: grid.get(name, np.zeros(0)) for name in names}
        sizes = {name: self.values[name].size for name in names}

        def transform(vector: np.ndarray) -> np.ndarray:
            parts, start = [], 0
            for name in names:
                count = len(old[name]) + 1
                block = vector[start:start + count * sizes[name]].reshape(count, sizes[name])
                start += count * sizes[name]
                matrix = resampling(np.concatenate([[0.0], old[name], [1.0]]), max(self._degree(name), 1),
                                    np.concatenate([new[name], [1.0]]))[:, 1:]
                parts.append((matrix @ block).ravel())
            return np.concatenate(parts)

        self._grid = {name: times for name, times in grid.items()}
        self.acceleration.regrid(transform, self.block_sizes(names))

    def _unstack(self, vector: np.ndarray, names: Sequence[str]) -> tuple[dict[str, np.ndarray], Series]:
        """Inverse of ``_iterates``' vector: end values, and samples on the grid."""
        if not self._grid:
            return self._split(vector, names), {}
        values, series, start = {}, {}, 0
        for name in names:
            shape, size = self.values[name].shape, self.values[name].size
            times = self._grid.get(name)
            if times is not None:
                series[name] = (times, vector[start:start + len(times) * size].reshape((len(times),) + shape))
                start += len(times) * size
            values[name] = vector[start:start + size].reshape(shape)
            start += size
        return values, series

    @staticmethod
    def _stack(values: Mapping[str, np.ndarray], names: Sequence[str]) -> np.ndarray:
        """The named arrays as one flat vector (a copy)."""
        return np.concatenate([values[n].ravel() for n in names]) if len(names) > 1 else values[names[0]].ravel().copy()

    def _split(self, vector: np.ndarray, names: Sequence[str]) -> dict[str, np.ndarray]:
        """Inverse of ``_stack``: each array back in its own shape."""
        out, start = {}, 0
        for name in names:
            shape = self.values[name].shape
            size = self.values[name].size
            out[name] = vector[start:start + size].reshape(shape)
            start += size
        return out

    def _record(self, proxy: Coupled, iteration: int, inputs: Mapping[str, np.ndarray],
                outputs: Mapping[str, np.ndarray]) -> None:
        recorder = self.recorders.get(proxy.name)
        if recorder is None:
            return
        steps = proxy.substep_calls
        if steps:        # a component or a participant that subcycles: each of its steps is a call
            for step_inputs, step_outputs in steps:
                recorder.record(self.window, iteration, step_inputs, step_outputs)
        else:
            recorder.record(self.window, iteration, inputs, outputs)

    def _save_states(self) -> None:
        """A window begins: each stateful participant's state is saved, by its first step where its server takes
        ``save`` with a step, else by ``get_state``."""
        for proxy in self.participants:
            if self._stateful(proxy) and not proxy.step_saves_state:
                self._state[proxy.name] = proxy.get_state()

    def _free_states(self) -> None:
        """A window ends: the saved states go, with the next window's first step where the server takes ``free``
        with a step (``release_states`` frees them before a checkpoint and at the end)."""
        for proxy in self.participants:
            handle = self._state.pop(proxy.name, None)
            if handle is not None and self._stateful(proxy):
                if proxy.step_saves_state:
                    self._to_free[proxy.name] = handle
                else:
                    proxy.free_state(handle)

    def release_states(self) -> None:
        """Free the states still held for the step that would have freed them (between windows)."""
        for proxy in self.participants:
            handle = self._to_free.pop(proxy.name, None)
            if handle is not None and self._stateful(proxy):
                proxy.free_state(handle)

    def _step_options(self, proxy: Coupled, iteration: int) -> dict[str, Any]:
        """The state handling a step of ``iteration`` carries: the window's state restored from the second
        iteration on; at the first, the state saved and the previous window's freed (a server that takes them)."""
        if not self._stateful(proxy):
            return {}
        if iteration > 1:
            return {"restore": self._state.get(proxy.name)}
        if proxy.step_saves_state:
            return {"save": True, "free": self._to_free.pop(proxy.name, None)}
        return {}

    def _stepped(self, proxy: Coupled, iteration: int) -> None:
        """After a step's reply: the window's saved state, from the first iteration's step."""
        if iteration == 1 and self._stateful(proxy) and proxy.step_saves_state:
            self._state[proxy.name] = proxy.saved_state    # type: ignore[assignment]

    def position(self) -> str:
        """Where the scheme is: window, its time interval and the iteration (for messages)."""
        return f"window {self.window} (t = {self.t:g} to {self.t + self.dt:g}), iteration {self.iteration}"

    def _begin(self, t: float, dt: float) -> None:
        self._window_start = dict(self.values)
        self._start_mapped.clear()
        self._start_gradients = {e.data: g for e in self.exchanges if (g := self._gradients(e)) is not None}
        self.window += 1
        self.t, self.dt = t, dt
        self.iteration = 0
        self._residuals = []
        self._measure_history = []

    def _observe(self, x: np.ndarray, x_tilde: np.ndarray) -> None:
        """Hand one iterate to the acceleration and keep its residual norm; a participant whose backend
        changed (ROM and solid FOM) changed the map."""
        self._residuals.append(norm(x_tilde - x))
        self._measure_history.append([m.value for m in self.measures])
        if any(proxy.backend_changed for proxy in self.participants):
            self.acceleration.map_changed()
        self.acceleration.observe(x, x_tilde)

    def _next_iterate(self, accelerated: Sequence[str]) -> tuple[dict[str, np.ndarray], Series]:
        proposal = self.acceleration.next_iterate()
        if not np.isfinite(proposal).all():
            error = DivergenceError(f"the acceleration produced non-finite values (residual norms of this window: "
                                    f"{', '.join(f'{r:.3e}' for r in self._residuals)})")
            error.where = self.position()
            raise error
        return self._unstack(proposal, accelerated)

    def _begin_implicit_window(self) -> dict[str, np.ndarray]:
        """Save states, reset acceleration and measures; the first iterate's data values."""
        self._save_states()
        if self.model is not None:
            self.model.start_window()
        self.acceleration.start_window()
        for m in self.measures:
            m.start_window()
        return self._predicted()

    def _end_implicit_window(self, values: dict[str, np.ndarray], series: Series, t: float, iterations: int,
                             converged: bool) -> WindowResult:
        self.acceleration.end_window()
        if self.model is not None:
            self.model.end_window(converged)
        self._free_states()
        self.values = values
        self.series = series
        return self._finish(t, iterations, converged)

    def _finish(self, t: float, iterations: int, converged: bool) -> WindowResult:
        message = ""
        if converged:
            for recorder in self.recorders.values():
                recorder.mark_converged(iterations)
        elif self.implicit:
            measures = ", ".join(m.summary() for m in self.measures)
            first, last = (self._residuals[0], self._residuals[-1]) if self._residuals else (0.0, 0.0)
            where = f"window {self.window} (t = {self.t:g} to {t:g})"
            error: ConvergenceError | None
            if last > self.divergence_factor * first:
                error = DivergenceError(f"diverged: the coupling residual grew from {first:.3e} to {last:.3e} "
                                        f"in {iterations} iterations ({measures})")
            elif self.on_max_iterations == "fail" and stalled(self._residuals):
                floor = min(self._residuals)
                error = StalledError(f"stalled: the coupling residual stopped decreasing at {floor:.3e} "
                                     f"({floor / max(first, 1e-300):.1e} of the first) and did not meet the limits in "
                                     f"{iterations} iterations; the limits ask for more precision than the data carry "
                                     f"(a residual-relative measure suits such cases): {measures}")
            elif self.on_max_iterations == "fail":
                error = ConvergenceError(f"did not converge in {iterations} iterations: {measures}")
            else:
                error = None
                message = f"{where} did not converge in {iterations} iterations: {measures}"
            if error is not None:
                error.where = where
                error.residuals = list(self._residuals)
                raise error
        for e in self.exchanges:
            if e.at_window_end:
                e.target.end_window({e.data: e.mapping(self.values[e.data])})
        if self.accelerated:
            self._extrapolation.store(self._stack(self.values, self.accelerated))
        return WindowResult(t, iterations, converged, {m.data: m.value for m in self.measures}, message,
                            list(self._residuals), list(self._measure_history))

    def advance(self, t: float, dt: float) -> WindowResult:
        """One time window; a component that fails on inputs of a growing coupling residual is divergence."""
        try:
            return self._advance(t, dt)
        except (ComponentDied, ComponentTimeout):
            raise
        except ComponentError as exc:
            growth = self._residuals
            if len(growth) >= 2 and all(b > a for a, b in zip(growth, growth[1:])) and growth[-1] > 2.0 * growth[0]:
                error = DivergenceError(f"diverged: the coupling residual grew from {growth[0]:.3e} to {growth[-1]:.3e} "
                                        f"in {len(growth)} iterations, then {exc}")
                error.where = self.position()
                error.residuals = list(growth)
                raise error from exc
            raise

    def _advance(self, t: float, dt: float) -> WindowResult:
        raise NotImplementedError


@SCHEMES.register("serial-explicit")
class SerialExplicit(CouplingScheme):
    """First participant, then second, once per window."""

    implicit = False

    def _advance(self, t: float, dt: float) -> WindowResult:
        self._begin(t, dt)
        self.iteration = 1
        for proxy in self.participants:
            inputs = self.inputs_for(proxy, self.values)
            proxy.send_step(t, dt, inputs, **self.waveforms_for(proxy, self.values, self.series, inputs))
            self.run_deferred()
            outputs = proxy.receive_step()
            self._record(proxy, 1, inputs, outputs)
            self.values.update({k: outputs[k] for k in self.sent_by(proxy)})
            self._take_series(proxy, self.series)
        return self._finish(t + dt, 1, True)


@SCHEMES.register("parallel-explicit")
class ParallelExplicit(CouplingScheme):
    """Both participants once per window, concurrently, each on the other's values of the window before."""

    implicit = False

    def _advance(self, t: float, dt: float) -> WindowResult:
        self._begin(t, dt)
        self.iteration = 1
        proxies = self.participants
        inputs = {p.name: self.inputs_for(p, self.values) for p in proxies}
        for p in proxies:
            p.send_step(t, dt, inputs[p.name], **self.waveforms_for(p, self.values, self.series, inputs[p.name]))
        self.run_deferred()
        outputs: dict[str, np.ndarray] = {}
        series = dict(self.series)
        for p in proxies:
            returned = p.receive_step()
            self._record(p, 1, inputs[p.name], returned)
            outputs.update({k: returned[k] for k in self.sent_by(p)})
            self._take_series(p, series)
        self.values.update(outputs)
        self.series = series
        return self._finish(t + dt, 1, True)


@SCHEMES.register("serial-implicit")
class SerialImplicit(CouplingScheme):
    """Gauss-Seidel: first participant, then second, iterated on the second's data."""

    def default_accelerated(self) -> list[str]:
        return self.sent_by(self.second)

    def _advance(self, t: float, dt: float) -> WindowResult:
        self._begin(t, dt)
        forward, feedback = self.sent_by(self.first), self.sent_by(self.second)
        accelerated = self.accelerated
        values = self._begin_implicit_window()
        series: Series = {}          # the predicted iterate has no samples inside the window
        converged = False
        for iteration in range(1, self.max_iterations + 1):
            self.iteration = iteration
            inputs_first = self.inputs_for(self.first, values)
            self.first.send_step(t, dt, inputs_first, **self._step_options(self.first, iteration),
                                 **self.waveforms_for(self.first, values, series, inputs_first))
            self.run_deferred()
            out_first = self.first.receive_step()
            self._stepped(self.first, iteration)
            self._take_series(self.first, series)
            inputs_second = self.inputs_for(self.second, out_first)
            self.second.send_step(t, dt, inputs_second, **self._step_options(self.second, iteration),
                                  **self.waveforms_for(self.second, out_first, series, inputs_second))
            self._record(self.first, iteration, inputs_first, out_first)    # while the second computes
            out_second = self.second.receive_step()
            out_series: Series = {}
            self._take_series(self.second, out_series)
            self._stepped(self.second, iteration)
            self._record(self.second, iteration, inputs_second, out_second)
            converged = window_converged(self.measures, [
                m.measure(values[m.data], out_first[m.data] if m.data in forward else out_second[m.data])
                for m in self.measures])
            values.update({k: out_first[k] for k in forward})
            x, x_tilde = self._iterates(values, series, out_second, out_series, accelerated)
            if self.model is not None:
                self.model.observe(x, self._stack(out_first, forward), x_tilde)
            self._observe(x, x_tilde)
            values.update({k: out_second[k] for k in feedback})
            series.update({k: v for k, v in out_series.items() if k in feedback})
            for name in feedback:
                if name not in out_series:
                    series.pop(name, None)
            if converged or iteration == self.max_iterations:
                break
            proposed, proposed_series = self._next_iterate(accelerated)
            values.update(proposed)
            series.update(proposed_series)
        self._predict_next_window(converged)
        return self._end_implicit_window(values, series, t + dt, iteration, converged)


@SCHEMES.register("parallel-implicit")
class ParallelImplicit(CouplingScheme):
    """Jacobi: both participants step concurrently on the previous iterate."""

    takes_first_iterate_zero = True

    def default_accelerated(self) -> list[str]:
        return list(dict.fromkeys(e.data for e in self.exchanges))

    def _advance(self, t: float, dt: float) -> WindowResult:
        self._begin(t, dt)
        names = list(dict.fromkeys(e.data for e in self.exchanges))
        accelerated = self.accelerated
        values = self._begin_implicit_window()
        series: Series = {}          # the predicted iterate has no samples inside the window
        converged = False
        proxies = self.participants
        for iteration in range(1, self.max_iterations + 1):
            self.iteration = iteration
            inputs = {}
            for p in proxies:       # each participant computes while the coupler maps the next one's inputs
                inputs[p.name] = self.inputs_for(p, values)
                p.send_step(t, dt, inputs[p.name], **self._step_options(p, iteration),
                            **self.waveforms_for(p, values, series, inputs[p.name]))
            self.run_deferred()
            outputs = {}
            out_series: Series = {}
            for p in proxies:
                returned = p.receive_step()
                self._stepped(p, iteration)
                self._record(p, iteration, inputs[p.name], returned)
                outputs.update(returned)
                self._take_series(p, out_series)
            new = {k: outputs[k] for k in names}
            seen = values
            if self.window == 1 and iteration == 1 and self.first_iterate_zero:
                seen = {k: np.zeros_like(v) if k in self.first_iterate_zero else v for k, v in values.items()}
            converged = window_converged(self.measures, [m.measure(seen[m.data], new[m.data]) for m in self.measures])
            self._observe(*self._iterates(seen, series, new, out_series, accelerated))
            values.update(new)
            series = out_series
            if converged or iteration == self.max_iterations:
                break
            proposed, proposed_series = self._next_iterate(accelerated)
            values.update(proposed)
            series.update(proposed_series)
        self._predict_next_window(converged)
        return self._end_implicit_window(values, series, t + dt, iteration, converged)


@SCHEMES.register("multi")
class Multi(ParallelImplicit):
    """Jacobi over two or more participants: all step concurrently on the previous iterate, and the measures and
    the acceleration work on all exchanged data (preCICE's fully implicit multi-coupling). With two participants
    it is parallel-implicit."""

    many_participants = True
    measuring = 0       # the controller
