"""Watching a run, while it runs or after: ``cosim status DIR`` and ``cosim plot DIR --convergence``.

Both read what the run writes as it goes, never ``results.h5`` (which its run holds open): ``status.json``
(windows done, the time, the counts, the last window's measures) and the coupler's logs
(``coupler.run_log``: ``logs/iterations.log`` and ``logs/convergence.log``).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from cosim.errors import CosimError
from cosim.rundir import read_status
from coupler.run_log import CONVERGENCE, ITERATIONS, read_limits, read_table


def status_lines(run_dir: str | Path) -> list[str]:
    """Where the run in ``run_dir`` stands, in a few lines."""
    run_dir = Path(run_dir)
    status = read_status(run_dir)
    if not status:
        raise CosimError(f"'{run_dir}' holds no run (no status.json)")
    state, done, total = status.get("state", "?"), int(status.get("windows_completed", 0)), status.get("windows_total")
    share = f" ({100 * done / total:.0f} %)" if total else ""
    at = f", t = {status['time']:g}" if "time" in status else ""
    of = f" of {total}" if total is not None else ""        # a damaged file may have lost the total, or the pid
    lines = [f"{run_dir}: {state}, {done}{of} windows{share}{at}"]
    if state == "died":
        pid = f" {status['pid']}" if "pid" in status else ""
        lines[0] += f" (its process{pid} is gone without saying why: killed, or the machine stopped)"
    started = status.get("coupling_started", status.get("started"))
    ran = done - int(status.get("windows_at_start", 0))
    if started and ran > 0:
        seconds = status.get("coupling_seconds") or float(status.get("updated", time.time())) - float(started)
        rate = ran / max(seconds, 1e-9)
        line = f"rate {rate:.3g} windows/s over the coupling's {seconds:.2f} s"
        if state == "running" and total:
            left = (total - done) / rate
            eta = time.strftime("%H:%M:%S", time.localtime(time.time() + left))
            line += f", about {left:.0f} s left (done near {eta})"
        lines.append(line)
    if status.get("iterations_total") and done:
        last = f", the last window {status['last_iterations']}" if "last_iterations" in status else ""
        lines.append(f"coupling iterations: {status['iterations_total']}, mean {status['iterations_total'] / done:.3f} "
                     f"per window{last}")
    if status.get("measures"):
        lines.append("last measures: " + ", ".join(f"{k} {v:.3e}" for k, v in status["measures"].items()))
    if state == "failed" and status.get("error"):
        lines.append(f"error: {str(status['error']).splitlines()[0]}")
    if state == "finished" and "wall_seconds" in status:
        lines.append(f"elapsed {status['wall_seconds']:.2f} s (start-up and close included)")
    return lines


RUN_FILES = ("run.png", "results.h5", "status.json", "checkpoint.npz")    # what a run writes itself


def plot_convergence(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """A PNG of the run's convergence history: every measure at every coupling iteration with its limit (dashed), the
    residual norm on its own axis, both broken between windows, and the iterations of every window; returns its
    path (default ``DIR/convergence.png``)."""
    run_dir = Path(run_dir)
    path = run_dir / "logs" / CONVERGENCE
    if not path.is_file():
        raise CosimError(f"'{path}' does not exist: the run has written no coupling iteration yet (or ran before "
                         "the coupler wrote convergence logs)")
    target = Path(out) if out else run_dir / "convergence.png"
    written = target.resolve()          # where it lands, through any link
    if target.suffix.lower() != ".png" or (written.parent == run_dir.resolve() and written.name in RUN_FILES):
        raise CosimError(f"--out '{target}': the convergence plot is written as a PNG of its own, not over "
                         f"{'a file of the run' if target.suffix.lower() == '.png' else 'a ' + (target.suffix or 'file without suffix')} "
                         "(default: DIR/convergence.png)")
    figure = convergence_figure(run_dir)
    import matplotlib.pyplot as plt
    figure.savefig(target, dpi=110)
    plt.close(figure)
    return target


def convergence_figure(run_dir: Path) -> Any:
    """The figure of ``plot_convergence`` (matplotlib, Agg), from the run's logs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.ticker import MaxNLocator

    path = run_dir / "logs" / CONVERGENCE
    columns, rows = read_table(path)
    iterations_log = run_dir / "logs" / ITERATIONS
    windows = read_table(iterations_log)[1] if iterations_log.is_file() else []
    if len(columns) < 3 or not rows:
        raise CosimError(f"'{path}' holds no iteration yet")
    table = np.array(rows)
    limits = read_limits(run_dir / "logs")
    step = np.arange(1, len(table) + 1, dtype=float)
    breaks = np.flatnonzero(np.diff(table[:, 0]) != 0) + 1          # each window's first row: the lines break there

    def broken(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        shown = np.where(values > 0, values, np.nan)                 # a log axis: zeros and below are not drawn
        return np.insert(step, breaks, np.nan), np.insert(shown, breaks, np.nan)

    has_residual = columns[-1] == "ResidualNorm"
    # every measure but min-iterations (its value counts iterations, not a residual); a limit line where it is fixed
    measures = [(i, name) for i, name in enumerate(columns[2:len(columns) - has_residual], start=2)
                if not name.startswith("min-iterations(")]
    panels = 2 + has_residual
    figure, axes = plt.subplots(panels, 1, figsize=(9, 2.6 * panels + 0.6),
                                gridspec_kw={"height_ratios": [2] + [1] * (panels - 1)})
    top = axes[0]
    for i, name in measures:
        line, = top.semilogy(*broken(table[:, i]), ".-", markersize=2, linewidth=0.6, label=name)
        limit = limits.get(name)
        if limit is not None and limit > 0:
            top.axhline(limit, color=line.get_color(), linestyle="--", linewidth=0.9, label=f"{name} limit {limit:g}")
    top.set_xlabel("coupling iteration, counted over all windows (lines break between windows)")
    top.set_ylabel("convergence measure")
    top.xaxis.set_major_locator(MaxNLocator(integer=True))
    top.legend(fontsize=7, ncol=2)
    top.set_title(f"{run_dir.name}: convergence, {len(windows)} windows, {len(table)} iterations")
    if has_residual:
        middle = axes[1]
        middle.semilogy(*broken(table[:, -1]), ".-", markersize=2, linewidth=0.6, color="0.3")
        middle.set_xlabel("coupling iteration, counted over all windows")
        middle.set_ylabel("residual norm\n||H(x) - x||")
        middle.xaxis.set_major_locator(MaxNLocator(integer=True))
    bottom = axes[-1]
    if windows:
        counts = np.array(windows)
        bottom.plot(counts[:, 0], counts[:, 2], ".-", markersize=2, linewidth=0.6)
    bottom.set_xlabel("time window")
    bottom.set_ylabel("iterations")
    bottom.yaxis.set_major_locator(MaxNLocator(integer=True))
    bottom.xaxis.set_major_locator(MaxNLocator(integer=True))
    figure.tight_layout()
    return figure
