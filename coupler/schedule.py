"""A participant served by different backends over time: the full-order solver until a
switch time, then its ROM. Only stateless (quasi-static) backends can be switched.

With a ``fallback`` (the full-order backend, kept running), a call the ROM flags as out of its
training range (local ``rom_out_of_range``) is computed again by the full-order backend,
whose outputs are used, and the full-order backend serves the rest of that window; the
windows where that happened are counted. A backend that needs a history to take over (``history_windows``:
a structure with inertia) is handed, before its first call, the converged inputs and outputs of the last
windows the backend before it served. ``backend_changed`` says whether the last call was served
by another backend than the call before it (the coupling scheme then tells its acceleration that
the map changed)."""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.errors import SceneError
from cosim.proxy import ComponentProxy
from coupler.coupled import Call, Samples


class BackendSchedule:
    """One scene component served by several backends in turn, driven as any other (``coupler.coupled.Coupled``):
    picks the backend by window time."""

    can_get_and_set_state = False     # only stateless backends are switched
    step_saves_state = False
    saved_state: int | None = None
    state_note = ""
    reads_waveforms = False           # its backends read the window's end
    substeps: Samples | None = None   # and take one step a window
    substep_calls: list[Call] = []
    gradients: dict[str, np.ndarray] = {}     # its backends write none

    def __init__(self, name: str, stages: Sequence[tuple[float, ComponentProxy]],
                 fallback: ComponentProxy | None = None):
        self.name = name
        self.fallback = fallback
        self.fallback_windows: set[float] = set()
        self._sent_inputs: tuple[float, float, Mapping[str, np.ndarray]] | None = None
        self.stages = sorted(stages, key=lambda stage: stage[0])
        first = self.stages[0][1]
        for _, proxy in self.stages[1:]:
            mine = {(v.name, v.causality, v.size, v.components) for v in first.variables.values()
                    if v.causality != "local"}
            theirs = {(v.name, v.causality, v.size, v.components) for v in proxy.variables.values()
                      if v.causality != "local"}
            if mine != theirs:
                raise SceneError(f"components.{name}: backends '{first.name}' and '{proxy.name}' declare different "
                                 f"variables: {sorted(mine)} vs {sorted(theirs)}")
            for variable in (v for v in first.variables.values() if v.causality != "local"):
                mine_nodes, theirs_nodes = first.mesh_of(variable.name), proxy.mesh_of(variable.name)
                if mine_nodes.shape != theirs_nodes.shape or not np.allclose(mine_nodes, theirs_nodes):
                    raise SceneError(f"components.{name}: backends '{first.name}' and '{proxy.name}' place "
                                     f"'{variable.name}' on different meshes ({len(mine_nodes)} and "
                                     f"{len(theirs_nodes)} nodes)")
        for _, proxy in self.stages:
            if proxy.can_get_and_set_state:
                raise SceneError(f"components.{name}: backend '{proxy.name}' is stateful; "
                                 "only stateless backends can be switched during a run")
        self.variables = first.variables
        self.meshes = first.meshes
        self.repeats_steps = any(proxy.repeats_steps for _, proxy in self.stages)
        self.stateless = all(proxy.stateless for _, proxy in self.stages)
        self._sent: ComponentProxy | None = None
        self._served: ComponentProxy | None = None   # the backend whose outputs the last call returned
        self.backend_changed = False
        # what a backend with a history takes over: the last windows' converged calls, and the call in flight
        keep = max((proxy.history_windows for _, proxy in self.stages), default=0)
        self._converged: deque[tuple[dict[str, np.ndarray], dict[str, np.ndarray]]] = deque(maxlen=keep)
        self._last_call: tuple[float, dict[str, np.ndarray], dict[str, np.ndarray]] | None = None
        self._taken_over: set[str] = set()

    def coupling_state(self) -> dict[str, Any]:
        """What the schedule carries between windows: the windows that fell back, and the backend that served
        the last call (a change of backend at the next call tells the acceleration its map changed)."""
        return {"fallback_windows": set(self.fallback_windows),
                "served": None if self._served is None else self._served.name,
                "converged": list(self._converged), "last_call": self._last_call, "taken_over": set(self._taken_over)}

    def restore_coupling_state(self, state: Mapping[str, Any]) -> None:
        backends = {proxy.name: proxy for _, proxy in self.stages}
        if self.fallback is not None:
            backends[self.fallback.name] = self.fallback
        self.fallback_windows = set(state["fallback_windows"])
        self._served = None if state["served"] is None else backends[state["served"]]
        self.backend_changed = False
        self._converged.extend(tuple(pair) for pair in state.get("converged", []))
        last = state.get("last_call")
        self._last_call = None if last is None else (float(last[0]), dict(last[1]), dict(last[2]))
        self._taken_over = set(state.get("taken_over", set()))

    def active(self, t: float) -> ComponentProxy:
        """The backend serving the window that starts at ``t``."""
        current = self.stages[0][1]
        for start, proxy in self.stages:
            if t >= start - 1e-9 * max(1.0, abs(start)):
                current = proxy
        return current

    def end_window(self, values: Mapping[str, np.ndarray]) -> None:
        """To the backend that served the window."""
        backend = self._served or self._sent
        if backend is not None:
            backend.end_window(values)

    def mesh_of(self, name: str) -> np.ndarray:
        return self.stages[0][1].mesh_of(name)

    def lines_of(self, name: str) -> np.ndarray | None:
        return self.stages[0][1].lines_of(name)

    def cells_of(self, name: str) -> np.ndarray | None:
        return self.stages[0][1].cells_of(name)

    def output_names(self) -> list[str]:
        return self.stages[0][1].output_names()

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        return self.stages[0][1].get_values(names)

    def send_step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
                  save: bool = False, free: int | None = None,
                  waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> None:
        """To the backend that serves ``t`` (no state to save, no waveforms: a schedule has neither)."""
        # once a window has fallen back, the full-order backend serves the rest of it (one map per window)
        self._sent = self.fallback if self.fallback is not None and t in self.fallback_windows else self.active(t)
        self._sent_inputs = (t, dt, inputs)
        if self._converged.maxlen:
            self._hand_over_history(t, self._sent)
        self._sent.send_step(t, dt, inputs, restore)

    def _hand_over_history(self, t: float, backend: ComponentProxy) -> None:
        """Close the last window (its last call was the converged one) and hand a backend that serves for the first
        time, after another, the windows it needs."""
        if self._last_call is not None and self._last_call[0] != t:
            self._converged.append(self._last_call[1:])
            self._last_call = None
        if backend.history_windows and backend.name not in self._taken_over \
                and self._served is not None and self._served is not backend and self._converged:
            inputs = {name: np.stack([call[0][name] for call in self._converged]) for name in self._converged[0][0]}
            outputs = {name: np.stack([call[1][name] for call in self._converged]) for name in self._converged[0][1]}
            backend.take_over(inputs, outputs)
            self._taken_over.add(backend.name)

    def receive_step(self) -> dict[str, np.ndarray]:
        assert self._sent is not None and self._sent_inputs is not None, "receive_step before send_step"
        outputs = self._sent.receive_step()
        flag = outputs.get("rom_out_of_range")
        if self.fallback is not None and self._sent is not self.fallback and flag is not None and flag[0] > 0:
            t, dt, inputs = self._sent_inputs
            self.fallback_windows.add(t)
            outputs = {**outputs, **self.fallback.step(t, dt, inputs)}   # the ROM's trust stays on record
            served = self.fallback
        else:
            served = self._sent
        self.backend_changed = self._served is not None and served is not self._served
        self._served = served
        if self._converged.maxlen:
            t, _, inputs = self._sent_inputs
            exchanged = {v.name for v in self.variables.values() if v.causality == "output"}
            self._last_call = (t, {k: np.array(v) for k, v in inputs.items()},
                               {k: np.array(v) for k, v in outputs.items() if k in exchanged})
        return outputs

    def step(self, t: float, dt: float, inputs: Mapping[str, np.ndarray], restore: int | None = None,
             save: bool = False, free: int | None = None,
             waveforms: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> dict[str, np.ndarray]:
        self.send_step(t, dt, inputs, restore)
        return self.receive_step()
