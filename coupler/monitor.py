"""Watching a run, while it runs or after: ``cosim status DIR`` and ``cosim plot DIR --convergence``.

Both read what the run writes as it goes, never ``results.h5`` (which its run holds open): ``status.json``
(windows done, the time, the counts, the last window's measures) and the coupler's logs
(``coupler.run_log``: ``logs/iterations.log`` and ``logs/convergence.log``).
"""

from __future__ import annotations

import time
from pathlib import Path

from cosim.errors import CosimError
from cosim.rundir import read_status
from coupler.run_log import CONVERGENCE, ITERATIONS, read_table


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
    started, ran = status.get("started"), done - int(status.get("windows_at_start", 0))
    if started and ran > 0:
        seconds = max(float(status.get("updated", time.time())) - float(started), 1e-9)
        rate = ran / seconds
        line = f"rate {rate:.3g} windows/s over {seconds:.1f} s"
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
        lines.append(f"wall {status['wall_seconds']:.2f} s")
    return lines


RUN_FILES = ("run.png", "results.h5", "status.json", "checkpoint.npz")    # what a run writes itself


def plot_convergence(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """A PNG of the run's convergence history: every measure and the residual norm at every coupling iteration,
    and the iterations of every window; returns its path (default ``DIR/convergence.png``)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.ticker import MaxNLocator

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
    columns, rows = read_table(path)
    iterations_log = run_dir / "logs" / ITERATIONS
    windows = read_table(iterations_log)[1] if iterations_log.is_file() else []
    if len(columns) < 3 or not rows:
        raise CosimError(f"'{path}' holds no iteration yet")
    table = np.array(rows)
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6), sharex=False, gridspec_kw={"height_ratios": [2, 1]})
    step = np.arange(1, len(table) + 1)
    for i, name in enumerate(columns[2:], start=2):
        values = table[:, i]
        shown = values > 0
        top.semilogy(step[shown], values[shown], ".-", markersize=2, linewidth=0.6, label=name)
    starts = step[table[:, 1] == 1]
    if len(starts) <= 60:
        for x in starts:
            top.axvline(x, color="0.85", linewidth=0.5, zorder=0)
    top.set_xlabel("coupling iteration (all windows)")
    top.set_ylabel("measure")
    top.xaxis.set_major_locator(MaxNLocator(integer=True))
    top.legend(fontsize=8)
    top.set_title(f"{run_dir.name}: convergence, {len(windows)} windows, {len(table)} iterations")
    if windows:
        counts = np.array(windows)
        bottom.plot(counts[:, 0], counts[:, 2], ".-", markersize=2, linewidth=0.6)
        bottom.set_xlabel("time window")
        bottom.set_ylabel("iterations")
        bottom.yaxis.set_major_locator(MaxNLocator(integer=True))
        bottom.xaxis.set_major_locator(MaxNLocator(integer=True))
    figure.tight_layout()
    figure.savefig(target, dpi=110)
    plt.close(figure)
    return target
