"""The last window of a Kratos FSI run as a picture: fluid speed on the deformed fluid mesh and the deformed solid,
from the arrays the fluid and solid components hand back at terminate (shared by the Kratos cases' run plots)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np


def plot_last_window(finals: Mapping[str, Mapping[str, np.ndarray]], time: float, path: Path,
                     figsize: tuple[float, float] = (11, 3.2), window: tuple[float, float, float, float] | None = None
                     ) -> Path | None:
    """Write ``path``; ``window`` (x0, x1, y0, y1) zooms in. None when no component handed back a fluid mesh."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.tri import Triangulation

    fluid = next((f for f in finals.values() if "triangles" in f), None)
    solid = next((f for f in finals.values() if "quads" in f), None)
    if fluid is None:
        return None
    figure, axis = plt.subplots(figsize=figsize, constrained_layout=True)
    speed = np.linalg.norm(fluid["velocity"], axis=1)
    mesh = Triangulation(fluid["nodes"][:, 0], fluid["nodes"][:, 1], fluid["triangles"])
    shading = axis.tripcolor(mesh, speed, shading="gouraud", cmap="viridis")
    figure.colorbar(shading, ax=axis, label="fluid velocity magnitude [m/s]", pad=0.01)
    if solid is not None:
        deformed = solid["nodes"] + solid["displacement_field"]
        axis.add_collection(PolyCollection(deformed[solid["quads"]], facecolor="0.85", edgecolor="0.4", lw=0.2))
    axis.set_title(f"last window, t = {time:g} s: deformed fluid mesh and solid")
    axis.set_aspect("equal")
    if window is not None:
        axis.set_xlim(window[0], window[1])
        axis.set_ylim(window[2], window[3])
    axis.set_xlabel("x [m]")
    axis.set_ylabel("y [m]")
    figure.savefig(path, dpi=130)
    plt.close(figure)
    return path
