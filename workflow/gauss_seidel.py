"""Stability of plain Gauss-Seidel coupling, computed from the components themselves.

Serial-implicit coupling without acceleration iterates x -> H(x) on the data the second
participant sends back (for the tube: the section); it converges where the spectral radius
of the Jacobian dH/dx is below 1, and its error shrinks by that factor per iteration. The
Jacobian is built column by column by finite differences of the real components, in this
process, around the scene's initial state: each column restores the first participant's
state, perturbs one value, and runs both participants through one window.

The tube's continuum theory and its stability matrix are in ``cases.tube.stability``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cosim.scene import Scene
from cosim.server import load_entry


@dataclass
class Spectrum:
    """The Gauss-Seidel iteration's Jacobian around a state, and its spectral radius."""

    jacobian: np.ndarray
    eigenvalues: np.ndarray

    @property
    def radius(self) -> float:
        return float(np.abs(self.eigenvalues).max())


def gauss_seidel_spectrum(scene: Scene, relative_step: float = 1e-7) -> Spectrum:
    """dH/dx of one window of serial-implicit coupling at the scene's start, by finite differences."""
    from coupler.mapping import make_mapping

    coupling = scene["coupling"]
    time = scene["time"]
    components = {}
    for name in coupling["participants"]:
        component = load_entry(scene["components"][name]["entry"])()
        component.instantiate(scene.component_parameters(name))
        component.enter_initialization_mode(time["start"], time["end"])
        component.exit_initialization_mode()
        components[name] = component
    first, second = (components[name] for name in coupling["participants"])
    variables = {name: {v.name: v for v in c.variables()} for name, c in components.items()}
    meshes = {name: c.meshes() for name, c in components.items()}

    def mapping(exchange: dict) -> Any:
        source, target, data = exchange["from"], exchange["to"], exchange["data"]
        out_var, in_var = variables[source][data], variables[target][data]
        mapping_settings = exchange["mapping"] if isinstance(exchange["mapping"], dict) else {"type": exchange["mapping"]}
        return make_mapping(mapping_settings, meshes[source].get(out_var.mesh, np.zeros((0, 1))),
                            meshes[target].get(in_var.mesh, np.zeros((0, 1))), out_var.shape, in_var.shape, data)

    names = coupling["participants"]
    forward = [(e["data"], mapping(e)) for e in scene["exchange"] if e["from"] == names[0]]
    feedback = [(e["data"], mapping(e)) for e in scene["exchange"] if e["from"] == names[1]]
    t, dt = time["start"], time["dt"]
    x0 = {data: np.asarray(second.get_values([data])[data], dtype=float) for data, _ in feedback}
    first_state = first.save_state() if first.can_get_and_set_state else None
    second_state = second.save_state() if second.can_get_and_set_state else None

    def H(x: dict[str, np.ndarray]) -> np.ndarray:
        if first_state is not None:
            first.restore_state(first_state)
        if second_state is not None:
            second.restore_state(second_state)
        out_first = first.step(t, dt, {data: m(x[data]) for data, m in feedback})
        out_second = second.step(t, dt, {data: m(out_first[data]) for data, m in forward})
        return np.concatenate([np.ravel(out_second[data]) for data, _ in feedback])

    base = np.concatenate([x0[data].ravel() for data, _ in feedback])
    shapes = [(data, x0[data].shape, x0[data].size) for data, _ in feedback]

    def unstack(vector: np.ndarray) -> dict[str, np.ndarray]:
        out, start = {}, 0
        for data, shape, size in shapes:
            out[data] = vector[start:start + size].reshape(shape)
            start += size
        return out

    h0 = H(unstack(base))
    steps = relative_step * np.maximum(np.abs(base), 1e-3 * max(float(np.abs(base).max()), 1e-12))
    jacobian = np.empty((base.size, base.size))
    for j in range(base.size):   # one column per black-box evaluation
        x = base.copy()
        x[j] += steps[j]
        jacobian[:, j] = (H(unstack(x)) - h0) / steps[j]
    return Spectrum(jacobian, np.linalg.eigvals(jacobian))
