"""A full-order solid seen through a trained ROM's reduced bases: a diagnostic, not a model.

The wrapped solid (any component, by entry; default the double flap's Kratos solid) runs in this
process. From ``from_time`` on, the force it gets is projected onto the ROM's force POD basis
(``project`` "force" or "both"), and/or the displacement it returns is the ROM's decoder applied to
the projection of its full displacement field onto the displacement basis (``project``
"displacement" or "both"): u_G = K u_mean + A u~ [+ B q(u~)], u~ = Phi_u^T (u - u_mean). The extra
coupling iterations of a ROM-FOM run that such a run repeats come from the bases (r_f, r_u), the rest
from the regression between them. ``rom_modes`` (1-based, with a displacement projection) takes those
reduced displacements from the ROM's regression instead, to find which of them cost the iterations.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cosim.component import Component, Variable
from cosim.errors import ComponentError, CosimError
from cosim.server import load_entry
from rom_component.static.load import load_rom

PROJECTIONS = ("force", "displacement", "both")
OWN = ("solid", "model", "project", "from_time", "rom_modes", "field")


class ProjectedSolid(Component):
    """Parameters: ``model`` (a ROM's .npz), ``project``, ``from_time``, ``rom_modes``, ``solid`` (the wrapped
    component's entry), ``field`` (its local holding the full displacement field); the rest go to the solid."""

    name = "solid"
    repeats_steps = True    # as the Kratos solid it wraps by default; set from the wrapped solid at instantiate

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        own = {key: parameters[key] for key in OWN if key in parameters}
        project = own.get("project", "both")
        if project not in PROJECTIONS:
            raise ComponentError(self.name, f"'project' is {project!r}; allowed: {', '.join(PROJECTIONS)}")
        if not own.get("model"):
            raise ComponentError(self.name, "parameter 'model' (path of a trained ROM's .npz) is not set")
        try:
            self.rom = load_rom(own["model"], "reproducible")
            self.inner: Component = load_entry(own.get("solid", "kratos_solvers.solid:KratosSolid"))()
        except CosimError as exc:
            raise ComponentError(self.name, str(exc)) from None
        a, meta = self.rom.arrays, self.rom.metadata
        if "Phi_f" not in a:
            raise ComponentError(self.name, f"model '{own['model']}' has no force POD basis 'Phi_f'")
        r_u = a["A"].shape[1]
        self.rom_modes = np.array([int(k) - 1 for k in own.get("rom_modes", [])], dtype=np.int64)
        if len(self.rom_modes) and (project == "force" or not all(0 <= k < r_u for k in self.rom_modes)):
            raise ComponentError(self.name, f"'rom_modes' {[int(k) + 1 for k in self.rom_modes]} needs a displacement "
                                            f"projection and modes in 1..{r_u}")
        self.Phi_f, self.f_mean = a["Phi_f"], a["f_mean"]
        self.Phi_u, self.u_mean, self.A, self.base, self.B = a["Phi_u"], a["u_mean"], a["A"], a["base"], a.get("B")
        self.pairs = np.triu_indices(r_u)
        self.from_time = float(own.get("from_time", 0.0))
        self.project_force = project in ("force", "both")
        self.project_displacement = project in ("displacement", "both")
        self.input_name = meta.get("input_variable", "force")
        self.output_name = meta.get("output_variable", "displacement")
        self.field_name = own.get("field", meta.get("field_variable", "displacement_field"))
        self.inner.instantiate({key: value for key, value in parameters.items() if key not in OWN})
        self.repeats_steps = self.inner.repeats_steps
        self.force: np.ndarray | None = None
        self._active = False

    def variables(self) -> list[Variable]:
        return self.inner.variables()

    def meshes(self) -> dict[str, np.ndarray]:
        return self.inner.meshes()

    def take_warnings(self) -> list[str]:
        return super().take_warnings() + self.inner.take_warnings()

    def enter_initialization_mode(self, start: float, stop: float) -> None:
        self.inner.enter_initialization_mode(start, stop)

    def exit_initialization_mode(self) -> None:
        self.inner.exit_initialization_mode()

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        if self.input_name in values:
            self.force = np.array(values[self.input_name], dtype=np.float64)
        self.inner.set_values(values)

    def do_step(self, t: float, dt: float) -> None:
        self._active = t >= self.from_time - 1e-12
        if self._active and self.project_force and self.force is not None:
            f = self.force.reshape(-1) - self.f_mean
            self.inner.set_values({self.input_name: (self.f_mean + self.Phi_f @ (self.Phi_f.T @ f))
                                   .reshape(self.force.shape)})
        self.inner.do_step(t, dt)

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        if not (self._active and self.project_displacement and self.output_name in names):
            return self.inner.get_values(names)
        values = self.inner.get_values(list(dict.fromkeys([*names, self.field_name])))
        shape = values[self.output_name].shape
        reduced = self.Phi_u.T @ (values[self.field_name].reshape(-1) - self.u_mean)
        if len(self.rom_modes) and self.force is not None:
            self.rom(self.force.reshape(-1))
            reduced[self.rom_modes] = self.rom.reduced[self.rom_modes]
        u = self.base + self.A @ reduced
        if self.B is not None:
            u += self.B @ (reduced[self.pairs[0]] * reduced[self.pairs[1]])
        values[self.output_name] = u.reshape(shape)
        return {name: values[name] for name in names}

    @property
    def can_checkpoint(self) -> bool:
        return bool(getattr(self, "inner", None)) and self.inner.can_checkpoint

    def checkpoint(self) -> Any:
        """The wrapped solid's checkpoint and the last force and projection flag."""
        return {"inner": self.inner.checkpoint(), "force": self.force, "active": self._active}

    def restore_checkpoint(self, state: Any) -> None:
        self.inner.restore_checkpoint(state["inner"])
        self.force, self._active = state["force"], state["active"]

    def terminate(self) -> dict[str, np.ndarray]:
        return self.inner.terminate()
