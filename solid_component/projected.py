"""The Kratos solid seen through a trained ROM's reduced bases: a diagnostic, not a model.

From ``from_time`` on, the force the solid gets is projected onto the ROM's force POD
basis (``project`` "force" or "both") and/or the displacement it returns is the ROM's
decoder applied to the projection of its full displacement field onto the displacement
basis (``project`` "displacement" or "both"): u_G = K u_mean + A u~ [+ B q(u~)],
u~ = Phi_u^T (u - u_mean). A ROM-FOM run's extra coupling iterations that such a run
repeats come from the bases (r_f, r_u); the rest from the regression between them.
``rom_modes`` (1-based, with a displacement projection) takes those reduced displacements from
the ROM's regression instead of the solid, to find which of them cost the iterations.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np

from cosim.errors import ComponentError
from rom_component.persistence import load
from solid_component.kratos import KratosSolid

PROJECTIONS = ("force", "displacement", "both")


class ProjectedSolid(KratosSolid):
    """``KratosSolid`` with parameters ``model`` (a ROM's .npz), ``project`` and ``from_time``."""

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        parameters = dict(parameters)
        model, project = parameters.pop("model", ""), parameters.pop("project", "both")
        self.from_time = float(parameters.pop("from_time", 0.0))
        rom_modes = [int(k) - 1 for k in parameters.pop("rom_modes", [])]
        if project not in PROJECTIONS:
            raise ComponentError(self.name, f"'project' is {project!r}; allowed: {', '.join(PROJECTIONS)}")
        if not model:
            raise ComponentError(self.name, "parameter 'model' (path of a trained ROM's .npz) is not set")
        self.rom = load(model, "reproducible")
        a = self.rom.arrays
        if rom_modes and (project == "force" or not all(0 <= k < a["A"].shape[1] for k in rom_modes)):
            raise ComponentError(self.name, f"'rom_modes' {[k + 1 for k in rom_modes]} needs a displacement "
                                            f"projection and modes in 1..{a['A'].shape[1]}")
        self.rom_modes = np.array(rom_modes, dtype=np.int64)
        if "Phi_f" not in a:
            raise ComponentError(self.name, f"model '{model}' has no force POD basis 'Phi_f'")
        self.Phi_f, self.f_mean = a["Phi_f"], a["f_mean"]
        self.Phi_u, self.u_mean, self.A, self.base = a["Phi_u"], a["u_mean"], a["A"], a["base"]
        self.B = a.get("B")
        self.project_force = project in ("force", "both")
        self.project_displacement = project in ("displacement", "both")
        self._active = False
        super().instantiate(parameters)

    def do_step(self, t: float, dt: float) -> None:
        self._active = t >= self.from_time - 1e-12
        if self._active and self.project_force:
            f = self.input.reshape(-1) - self.f_mean
            self.input = (self.f_mean + self.Phi_f @ (self.Phi_f.T @ f)).reshape(self.input.shape)
        super().do_step(t, dt)

    def readers(self) -> dict[str, Callable[[], np.ndarray]]:
        readers = super().readers()
        if self._active and self.project_displacement:
            readers["displacement"] = self._decoded
        return readers

    def _decoded(self) -> np.ndarray:
        field = super().readers()["displacement_field"]().reshape(-1)
        reduced = self.Phi_u.T @ (field - self.u_mean)
        if len(self.rom_modes):
            self.rom(self.input.reshape(-1))
            reduced[self.rom_modes] = self.rom.reduced[self.rom_modes]
        u = self.base + self.A @ reduced
        if self.B is not None:
            i, j = np.triu_indices(len(reduced))
            u = u + self.B @ (reduced[i] * reduced[j])
        return u.reshape(-1, 2)
