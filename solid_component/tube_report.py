"""The tube's own report plot, registered under ``cosim.report_plots``: hoop stress against
strain from the converged fields, over the wall's law."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from solid_component.tube import SOLID_SCHEMA


def stress_strain(run, reference, out: Path) -> list[Path]:
    """Hoop stress p r against strain (r - r0) / r0 of both runs; nothing for other scenes."""
    if "tube" not in run.scene or not {"pressure", "section"} <= set(run.fields):
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
    law: dict[str, Any] = {k: v.default if hasattr(v, "default") else v for k, v in SOLID_SCHEMA.items() if k != "tube"}
    law.update(run.scene.get("components", {}).get("solid", {}).get("parameters", {}))
    E1, E2, s0, e0 = law["E_small"], law["E_large"], law["s0"], law["eps0"]
    extent = 1.2 * max(float(np.abs(np.concatenate(strains)).max()), 2 * e0)
    eps = np.linspace(-extent, extent, 400)
    ax.plot(eps, np.where(np.abs(eps) < e0, E1 * eps, E2 * eps + np.sign(eps) * s0), "k-", lw=0.8,
            label="the wall's law")
    ax.set_xlabel("hoop strain (r - r0) / r0 [dimensionless]")
    ax.set_ylabel("hoop stress p r [dimensionless]")
    ax.set_title(f"Tube wall: the states ROM-FOM '{run.label}' and FOM-FOM '{reference.label}' visited")
    ax.legend(markerscale=5, fontsize=8)
    path = out / f"stress_strain_{run.label}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]
