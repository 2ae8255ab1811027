"""PNG plots of a run: a monitored field value over time and coupling iterations per window."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.results import RunResults


def plot_run(results: str | Path, png: str | Path, output: Mapping[str, Any]) -> Path:
    """Two panels: ``output.plot_field`` value number ``output.plot_index`` (node-major) over time, and
    iterations per window."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with RunResults(results) as run:
        windows = run.windows
        fields = run.fields()
    time, iterations = windows.time, windows.iterations
    field = output.get("plot_field") or next(iter(sorted(fields)), "")
    index = int(output.get("plot_index", 0))
    values = fields[field].reshape(len(fields[field]), -1)[:, index] if field in fields else np.zeros(0)
    label = f"{output.get('plot_label') or f'{field}[{index}]'} [{output.get('plot_unit') or 'dimensionless'}]"
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, constrained_layout=True)
    top.plot(time[:len(values)], values, lw=1.0)
    top.set_ylabel(label)
    top.grid(alpha=0.3)
    iterations_panel(bottom, time, iterations)
    figure.savefig(png, dpi=110)
    plt.close(figure)
    return Path(png)


def iterations_panel(axis: Any, time: np.ndarray, iterations: np.ndarray) -> None:
    """Coupling iterations per window over time, with their mean (the lower panel of every run plot)."""
    axis.plot(time, iterations, lw=0.8, drawstyle="steps-mid")
    mean = iterations.mean() if iterations.size else float("nan")
    axis.axhline(mean, color="k", ls="--", lw=0.8, label=f"mean {mean:.2f}")
    axis.set_ylabel("coupling iterations per window [count]")
    from matplotlib.ticker import MaxNLocator
    axis.yaxis.set_major_locator(MaxNLocator(integer=True))     # a count: whole ticks
    axis.set_xlabel("time [s]")
    axis.legend(loc="upper right")
    axis.grid(alpha=0.3)
