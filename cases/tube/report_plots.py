"""The tube's own report plot, the ``tube`` hook of ``cosim.report_plots``: hoop stress against
strain from the converged fields, over the wall's law as the run's solid had it."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from solid_component.tube import TubeSolid

TUBE_SOLID = "solid_component.tube:TubeSolid"


def wall_law(scene: dict[str, Any]) -> Callable[[np.ndarray], np.ndarray] | None:
    """The hoop stress of a strain as the scene's solid computes it (its parameters, ``tube.stiffness_factor`` and
    ``tube.wall_law`` included), or None when the solid is not the tube's own (its law is not known here)."""
    solid = scene.get("components", {}).get("solid", {})
    if solid.get("entry") != TUBE_SOLID:
        return None
    wall = TubeSolid()
    wall.instantiate({**solid.get("parameters", {}), "tube": scene["tube"]})
    return wall.stress


def stress_strain(run, reference, out: Path) -> list[Path]:
    """Hoop stress p r against strain (r - r0) / r0 of both runs (nothing without their pressure and section)."""
    if not {"pressure", "section"} <= set(run.fields):
        return []
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r0 = math.sqrt(float(run.scene["tube"].get("a0", 1.0)) / math.pi)
    fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
    predicted = run.predicted()
    strains = []
    for source, mask, size, colour, label in (
            (reference, ~predicted, 2.0, "0.6", f"FOM-FOM '{reference.label}', before the switch"),
            (run, predicted, 1.0, "tab:blue", f"ROM-FOM '{run.label}', ROM windows")):
        r = np.sqrt(source.fields["section"][mask] / math.pi)
        strains.append(((r - r0) / r0).ravel())
        ax.scatter(strains[-1], (source.fields["pressure"][mask] * r).ravel(), s=size, c=colour, label=label)
    law = wall_law(run.scene)
    title = f"Tube wall: the states ROM-FOM '{run.label}' and FOM-FOM '{reference.label}' visited"
    if law is not None:
        extent = 1.2 * float(np.abs(np.concatenate(strains)).max())
        eps = np.linspace(-extent, extent, 400)
        ax.plot(eps, law(eps), "k-", lw=0.8, label="the wall's law, as the run's solid had it")
    else:
        title += f"\n(the solid's law is not drawn: its component is {run.scene['components']['solid'].get('entry')})"
    ax.set_xlabel("hoop strain (r - r0) / r0 [dimensionless]")
    ax.set_ylabel("hoop stress p r [dimensionless]")
    ax.set_title(title, fontsize=10)
    ax.legend(markerscale=5, fontsize=8)
    path = out / f"stress_strain_{run.label}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]
