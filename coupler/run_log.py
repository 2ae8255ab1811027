"""A run's own logs in ``DIR/logs``, next to each component's: what the coupler did, and its convergence history
(the run directory also holds the same history in preCICE's own format: ``coupler.precice_log``).

- ``coupler.log``: one timestamped line per event: the start (scene, windows, every component's process and
  address), warnings, checkpoints, the end or the error that stopped the run.
- ``iterations.log``: a row per window: ``TimeWindow Time Iterations TotalIterations Converged`` and the value of
  every convergence measure at the window's last iteration.
- ``convergence.log``: a row per coupling iteration: ``TimeWindow Iteration``, every measure's value (as its
  ``type(data)``) and the norm of the accelerated data's residual.

``measures.json`` names each measure's column with its limit (``null`` for those without a fixed one: min-iterations,
any-of and all-of), for the convergence plot's limit lines.

The files are whitespace-separated columns under one header line, flushed every window. A resumed run first cuts
the two tables back to the checkpoint's window. The logs never stop a run: a log that cannot be written (a full
disk) stops being written, and the results file's own checks stop the run with their message.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TextIO

COUPLER, ITERATIONS, CONVERGENCE = "coupler.log", "iterations.log", "convergence.log"
MEASURES = "measures.json"
FIXED_LIMITS = ("absolute", "absolute-rms", "relative", "residual-relative")    # the measures met below a limit


class RunLog:
    """The coupler's three logs of one run (use as a context manager)."""

    def __init__(self, folder: Path, resume_after: int | None = None):
        self.folder = folder
        self.resume_after = resume_after
        self.events: TextIO | None = None
        self.iterations: TextIO | None = None
        self.convergence: TextIO | None = None
        self.broken = False          # a write failed (a full disk): the logs stop, the run goes on
        with self._guard():
            folder.mkdir(parents=True, exist_ok=True)
            self.events = open(folder / COUPLER, "a")

    @contextmanager
    def _guard(self) -> Iterator[None]:
        try:
            yield
        except OSError:
            self.broken = True

    def open_tables(self, measures: list[Any]) -> None:
        """Start (or, resuming, cut back and go on with) the two tables, a column per convergence measure."""
        labels = [m.label() for m in measures]
        with self._guard():
            if self.resume_after is not None:
                for name in (ITERATIONS, CONVERGENCE):
                    cut_table(self.folder / name, self.resume_after)
            self.iterations = _table(self.folder / ITERATIONS, ["TimeWindow", "Time", "Iterations",
                                                                "TotalIterations", "Converged", *labels])
            self.convergence = _table(self.folder / CONVERGENCE, ["TimeWindow", "Iteration", *labels,
                                                                  "ResidualNorm"])
            limits = {m.label(): m.limit if m.type_name in FIXED_LIMITS else None for m in measures}
            (self.folder / MEASURES).write_text(json.dumps(limits, indent=1) + "\n")

    def __enter__(self) -> RunLog:
        return self

    def __exit__(self, *exc_info: Any) -> None:
        for stream in (self.events, self.iterations, self.convergence):
            if stream is not None:
                with self._guard():
                    stream.close()

    def event(self, message: str) -> None:
        """One timestamped line of ``coupler.log``."""
        if self.broken or self.events is None:
            return
        stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime())
        with self._guard():
            self.events.write(f"{stamp} {message}\n")
            self.events.flush()

    def window(self, window: int, result: Any, total_iterations: int) -> None:
        """A finished window's rows in both tables."""
        if self.broken or self.iterations is None or self.convergence is None:
            return
        last = result.measure_history[-1] if result.measure_history else []
        with self._guard():
            self.iterations.write(" ".join([str(window), f"{result.time:.12g}", str(result.iterations),
                                            str(total_iterations), str(int(result.converged)),
                                            *(f"{v:.6e}" for v in last)]) + "\n")
            for i, (values, residual) in enumerate(zip(result.measure_history, result.residuals), start=1):
                self.convergence.write(" ".join([str(window), str(i), *(f"{v:.6e}" for v in values),
                                                 f"{residual:.6e}"]) + "\n")
            self.iterations.flush()
            self.convergence.flush()


def _table(path: Path, columns: list[str]) -> TextIO:
    """``path`` opened to append rows, with its header line if it is new."""
    fresh = not path.is_file() or path.stat().st_size == 0
    stream = open(path, "a")
    if fresh:
        stream.write(" ".join(columns) + "\n")
    return stream


def cut_table(path: Path, windows: int) -> None:
    """Keep the header and the rows of the first ``windows`` windows of a log table."""
    if not path.is_file():
        return
    header, *rows = path.read_text().splitlines(keepends=True)
    kept = [row for row in rows if row.split() and row.split()[0].isdigit() and int(row.split()[0]) <= windows]
    path.write_text(header + "".join(kept))


def read_table(path: Path) -> tuple[list[str], list[list[float]]]:
    """A log table's columns and rows (numbers). A table its run is writing may end in a line cut midway, and a
    damaged one may hold lines that are no rows: only whole rows of numbers, one per column, are read."""
    header, *rows = path.read_bytes().decode("utf-8", errors="replace").splitlines() or [""]
    columns = header.split()
    table = []
    for row in rows:
        fields = row.split()
        if len(fields) != len(columns):
            continue
        try:
            table.append([float(v) for v in fields])
        except ValueError:
            continue
    return columns, table


def read_limits(folder: Path) -> dict[str, float | None]:
    """Each measure's column and its limit (``measures.json``; empty if absent or damaged)."""
    try:
        limits = json.loads((folder / MEASURES).read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(limits, dict):
        return {}
    return {str(k): float(v) if isinstance(v, int | float) and not isinstance(v, bool) else None
            for k, v in limits.items()}
