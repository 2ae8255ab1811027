"""PNG plots of a run: a monitored field value over time and coupling iterations per window.

Drawn on matplotlib's Agg canvas with a fixed layout, without pyplot: the run's end waits for the drawing alone
(the results writer imports matplotlib while the run goes on, ``import_matplotlib``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.results import RunResults


def import_matplotlib() -> None:
    """Load what ``plot_run`` draws with (ahead of time, in the background)."""
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401
    import matplotlib.ticker  # noqa: F401


def plot_run(results: str | Path, png: str | Path, output: Mapping[str, Any]) -> Path:
    """Two panels: ``output.plot_field`` value number ``output.plot_index`` (node-major) over time, and
    iterations per window."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with RunResults(results) as run:
        windows = run.windows
        fields = run.fields()
    time, iterations = windows.time, windows.iterations
    field = output.get("plot_field") or next(iter(sorted(fields)), "")
    index = int(output.get("plot_index", 0))
    values = fields[field].reshape(len(fields[field]), -1)[:, index] if field in fields else np.zeros(0)
    label = f"{output.get('plot_label') or f'{field}[{index}]'} [{output.get('plot_unit') or 'dimensionless'}]"
    figure = Figure(figsize=(9, 6))
    FigureCanvasAgg(figure)
    top, bottom = figure.subplots(2, 1, sharex=True)
    figure.subplots_adjust(left=0.1, right=0.98, top=0.97, bottom=0.09, hspace=0.08)
    top.plot(time[:len(values)], values, lw=1.0)
    top.set_ylabel(label)
    top.grid(alpha=0.3)
    iterations_panel(bottom, time, iterations)
    figure.savefig(png, dpi=110)
    return Path(png)


def plot_finished_run(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """``run.png`` of a run that has ended (``cosim plot DIR --run``), drawn from its ``results.h5`` with the scene's
    ``output`` settings, into ``out`` (default ``DIR/run.png``)."""
    import json

    from cosim.errors import CosimError
    from cosim.rundir import RUN_FILES
    run_dir = Path(run_dir)
    results = run_dir / "results.h5"
    target = Path(out) if out else run_dir / "run.png"
    if target.suffix.lower() != ".png" or target.resolve() in {(run_dir / name).resolve() for name in RUN_FILES
                                                               if name != "run.png"}:
        raise CosimError(f"--out '{target}': the run plot is written as a PNG (default: DIR/run.png)")
    if not results.is_file():
        raise CosimError(f"'{results}' does not exist: '{run_dir}' holds no run's results")
    try:
        with RunResults(results) as run:
            scene = json.loads(run.attributes.get("scene_resolved", "{}"))
    except (OSError, ValueError) as exc:
        raise CosimError(f"cannot read '{results}' (a run still writing it?): {exc}") from None
    output = scene.get("output", {}) if isinstance(scene, dict) else {}
    return plot_run(results, target, output if isinstance(output, dict) else {})


def iterations_panel(axis: Any, time: np.ndarray, iterations: np.ndarray) -> None:
    """Coupling iterations per window over time, with their mean (the lower panel of every run plot)."""
    from matplotlib.ticker import MaxNLocator
    axis.plot(time, iterations, lw=0.8, drawstyle="steps-mid")
    mean = iterations.mean() if iterations.size else float("nan")
    axis.axhline(mean, color="k", ls="--", lw=0.8, label=f"mean {mean:.2f}")
    axis.set_ylabel("coupling iterations per window [count]")
    axis.yaxis.set_major_locator(MaxNLocator(integer=True))     # a count: whole ticks
    axis.set_xlabel("time [s]")
    axis.legend(loc="upper right")
    axis.grid(alpha=0.3)
