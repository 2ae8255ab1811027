"""What watches a run (``coupler.run.Run``): the results file's windows, the coupler's logs, the status file and
the progress bar, each told of the run's steps in the order they are listed."""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

from cosim.results_writer import ResultsWriter
from cosim.rundir import RunDirectory
from cosim.scene import Scene, TimeGrid
from coupler.precice_log import PreciceLogs
from coupler.recording import CallRecorder
from coupler.run_log import RunLog
from coupler.schemes import CouplingScheme, WindowResult


class Run(Protocol):
    """What an observer reads of the run it watches (``coupler.run.Run``)."""

    scene: Scene
    time: TimeGrid
    n_windows: int
    identity: dict[str, Any]
    saved: Any                  # the checkpoint it resumed from, or None
    scheme: CouplingScheme | None
    backends: Sequence[Any]
    participants: dict[str, Any] | None     # each scene component's driven object (a backend or their schedule)
    recorders: dict[str, CallRecorder]
    windows: int
    iterations: int
    unconverged: int
    wall: float
    coupling: float


class RunObserver:
    """A run's watcher: every step is told, none is needed (the defaults do nothing)."""

    def starting(self, run: Run) -> None:
        """Before any process starts."""

    def event(self, message: str) -> None:
        """Something the run did (a component's process, a checkpoint)."""

    def first_window(self, run: Run) -> None:
        """The components are up and the scheme built: the windows begin."""

    def window_computed(self, run: Run, result: WindowResult, seconds: float) -> None:
        """A window ended (``seconds`` of wall time), before anything else happens."""

    def window_reported(self, run: Run, window: int, result: WindowResult, iterations: int) -> None:
        """The same window again, while the next window's first component computes: what can wait."""

    def warning(self, message: str) -> None:
        """A component's or the scheme's warning, with its window."""

    def windows_done(self, run: Run) -> None:
        """The last window has been reported, or the loop stopped."""

    def stopped(self, run: Run) -> None:
        """Every window done, the components terminated and the results file closed."""

    def finished(self, run: Run) -> None:
        """After ``stopped``, the components' processes gone and the logs closed."""

    def failed(self, run: Run, error: Exception) -> None:
        """The run stopped on ``error`` after ``run.windows`` windows."""

    def interrupted(self, run: Run) -> None:
        """Ctrl-C or SIGTERM stopped the run."""


class ResultsWindows(RunObserver):
    """Each window's values, timings, recorded calls and residuals into the results file."""

    def __init__(self, store: ResultsWriter):
        self.store = store

    def window_computed(self, run: Run, result: WindowResult, seconds: float) -> None:
        assert run.scheme is not None
        self.store.append_window(result.time, result.iterations, result.converged, seconds, run.scheme.values,
                                 {b.name: _take_timings(b.client) for b in run.backends},
                                 {n: r.take() for n, r in run.recorders.items()}, result.residuals)


class CouplerLogs(RunObserver):
    """``logs/coupler.log`` (events) and the iteration and convergence tables."""

    def __init__(self, log: RunLog):
        self.log = log

    def starting(self, run: Run) -> None:
        self.log.event(f"{'resumed after window ' + str(run.windows) if run.saved is not None else 'started'}: "
                       f"scene {run.scene.source} ({run.identity['scene_sha256'][:12]}), {run.n_windows} windows of "
                       f"{run.time.dt:g} s from t = {run.time.start:g}")

    def event(self, message: str) -> None:
        self.log.event(message)

    def first_window(self, run: Run) -> None:
        assert run.scheme is not None
        self.log.open_tables(run.scheme.measures)

    def window_reported(self, run: Run, window: int, result: WindowResult, iterations: int) -> None:
        self.log.window(window, result, iterations)

    def warning(self, message: str) -> None:
        self.log.event(message)

    def stopped(self, run: Run) -> None:
        self.log.event(f"finished: {run.windows} windows, {run.iterations} coupling iterations "
                       f"(mean {run.iterations / max(run.windows, 1):.3f} per window)")

    def failed(self, run: Run, error: Exception) -> None:
        self.log.event(f"failed after {run.windows} windows: {error}")

    def interrupted(self, run: Run) -> None:
        self.log.event(f"interrupted after {run.windows} windows")


class PreciceFormatLogs(RunObserver):
    """The iteration and convergence logs of an implicit run in preCICE's format, in the run directory
    (``coupler.precice_log``); like the coupler's logs, they never stop a run."""

    def __init__(self, folder: Path, resume_after: int | None):
        self.folder, self.resume_after = folder, resume_after
        self.logs: PreciceLogs | None = None
        self.counted = (0, 0)       # the acceleration's deleted and dropped columns at the last window's end

    def first_window(self, run: Run) -> None:
        scheme = run.scheme
        if scheme is None or not scheme.implicit:
            return
        meshes: dict[str, str] = {}
        for e in scheme.exchanges:
            meshes.setdefault(e.data, getattr(getattr(e.source, "variables", {}).get(e.data), "mesh", ""))
        served = {id(client): name for name, client in (run.participants or {}).items()}
        names = [served.get(id(p), p.name) for p in scheme.participants]     # a swapped participant keeps its name
        counts = getattr(scheme.acceleration, "column_counts", None)
        if counts is not None:
            self.counted = counts()[1:]
        try:
            self.logs = PreciceLogs(self.folder, names, names[scheme.measuring], scheme.measures, meshes,
                                    counts is not None, self.resume_after)
        except OSError:
            self.logs = None

    def window_reported(self, run: Run, window: int, result: WindowResult, iterations: int) -> None:
        if self.logs is None or run.scheme is None:
            return
        columns = (0, 0, 0)
        counts = getattr(run.scheme.acceleration, "column_counts", None)
        if counts is not None:
            held, deleted, dropped = counts()
            columns = (held, deleted - self.counted[0], dropped - self.counted[1])
            self.counted = (deleted, dropped)
        try:
            self.logs.window(window, result, iterations, columns)
        except OSError:
            self.logs = None

    def finished(self, run: Run) -> None:
        self._close()

    def failed(self, run: Run, error: Exception) -> None:
        self._close()

    def interrupted(self, run: Run) -> None:
        self._close()

    def _close(self) -> None:
        if self.logs is not None:
            self.logs.close()
            self.logs = None


class StatusFile(RunObserver):
    """``status.json``: where the run stands, for ``cosim status`` (the rate counts from the first window's start)."""

    def __init__(self, directory: RunDirectory, n_windows: int):
        self.directory, self.n_windows = directory, n_windows
        self.started, self.windows_at_start = time.time(), 0
        self.coupling_started: float | None = None      # the first window's start: the rate counts from it
        self.measure_names: list[str] = []

    def starting(self, run: Run) -> None:
        self.directory.status("starting", force=True, windows_total=self.n_windows, windows_completed=run.windows)
        self.started, self.windows_at_start = time.time(), run.windows

    def first_window(self, run: Run) -> None:
        assert run.scheme is not None
        self.measure_names = [m.label() for m in run.scheme.measures]
        self.coupling_started = time.time()

    def window_reported(self, run: Run, window: int, result: WindowResult, iterations: int) -> None:
        self.directory.status("running", windows_total=self.n_windows, windows_completed=window, time=result.time,
                              iterations_total=iterations, started=self.started,
                              coupling_started=self.coupling_started,
                              windows_at_start=self.windows_at_start, last_iterations=result.iterations,
                              measures=dict(zip(self.measure_names, result.measure_history[-1]))
                              if result.measure_history else {})

    def finished(self, run: Run) -> None:
        self.directory.status("finished", force=True, windows_total=self.n_windows, windows_completed=run.windows,
                              windows_unconverged=run.unconverged, wall_seconds=run.wall,
                              coupling_seconds=run.coupling, iterations_total=run.iterations,
                              started=self.started, coupling_started=self.coupling_started,
                              windows_at_start=self.windows_at_start,
                              time=run.time.window_start(run.windows))

    def failed(self, run: Run, error: Exception) -> None:
        self.directory.status("failed", force=True, windows_total=self.n_windows, windows_completed=run.windows,
                              error=str(error))

    def interrupted(self, run: Run) -> None:
        self.directory.status("interrupted", force=True, windows_total=self.n_windows,
                              windows_completed=run.windows)


class ProgressBar(RunObserver):
    """The terminal's progress bar (``enabled``), and the warnings printed above it (or alone without it)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.bar: Any = None

    def first_window(self, run: Run) -> None:
        if not self.enabled:
            return
        from tqdm import tqdm
        # smoothing 0: the rate shown is the coupling's, windows since the first one's start over the time since
        self.bar = tqdm(total=run.n_windows, unit="win", dynamic_ncols=True, mininterval=0.25, smoothing=0)
        if run.windows:
            self.bar.update(run.windows)

    def window_reported(self, run: Run, window: int, result: WindowResult, iterations: int) -> None:
        if self.bar is not None:
            self.bar.update(1)
            measures = " ".join(f"{k}={v:.1e}" for k, v in result.measures.items())
            self.bar.set_postfix_str(f"t={result.time:.2f} it={result.iterations} mean={iterations / window:.2f} "
                                     f"{measures}", refresh=False)

    def warning(self, message: str) -> None:
        if self.bar is not None:
            self.bar.write(message, file=sys.stderr)
        else:
            print(message, file=sys.stderr)

    def windows_done(self, run: Run) -> None:
        if self.bar is not None:
            self.bar.close()


def _take_timings(proxy: Any) -> tuple[list[float], list[float], list[float]]:
    compute, roundtrip, cpu = proxy.compute_seconds, proxy.roundtrip_seconds, proxy.cpu_seconds
    proxy.compute_seconds, proxy.roundtrip_seconds, proxy.cpu_seconds = [], [], []
    return compute, roundtrip, cpu
