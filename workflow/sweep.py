"""Sweeps: many independent co-simulations of scene variants, run on Dask.

A sweep is a list of runs, each a list of ``--set`` overrides of one scene: the Cartesian
product of ``--grid key=v1,v2,...`` options, or one run per line of a file. Every run is an
ordinary ``cosim run`` in ``DIR/runs/<name>/`` with its own component processes; Dask
(``dask.distributed``) places one run per worker process at a time, on a local cluster or
on an existing scheduler given by address, so a sweep spans as many machines as have workers.

``DIR/sweep.csv`` gets one row per finished run as it finishes (its settings, windows
converged, mean and max coupling iterations, measured contraction per iteration, the failure
class (diverged, stalled, max-iterations, non-finite, component-error) and message, wall time); a
rerun of the same sweep skips the runs that have a row. Run names are derived from the
overrides, so the same run keeps its name across reruns and machines; ``DIR/sweep.scene`` holds
the scene's fingerprint, and a directory whose runs were made with other scene data is refused
(comments and layout of the scene file aside), so a changed scene never mixes with old runs.

Only references to this module's function and plain strings cross Dask's wire; results come
back as plain dicts of numbers and strings.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import os
import shlex
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import SceneError
from cosim.scene import read_toml

COLUMNS = ["name", "windows_converged", "windows_total", "mean_iterations", "max_iterations", "contraction",
           "failure", "failure_message", "wall_seconds"]
TABLE = "sweep.csv"
FINGERPRINT = "sweep.scene"


def scene_fingerprint(scene_path: str | Path, shared: tuple[str, ...] = ()) -> str:
    """SHA-256 of a scene file's data (its comments and layout aside) with the ``shared`` overrides applied."""
    from cosim.scene import apply_override, parse_override
    raw = read_toml(scene_path, "scene")[1]
    for item in shared:
        apply_override(raw, *parse_override(item))
    return hashlib.sha256(json.dumps(raw, sort_keys=True, default=str).encode()).hexdigest()


def shared_overrides(runs: list[SweepRun]) -> tuple[str, ...]:
    """The overrides every run has (a sweep's ``--set`` items): part of its scene, not of a grid point."""
    first, *rest = [run.overrides for run in runs] or [()]
    return tuple(item for item in first if all(item in other for other in rest))


@dataclass(frozen=True)
class SweepRun:
    """One run of a sweep: its overrides (``key=value``) and a stable name derived from them."""

    overrides: tuple[str, ...]

    @property
    def name(self) -> str:
        digest = hashlib.sha256("\n".join(self.overrides).encode()).hexdigest()[:10]
        return f"run-{digest}"

    def settings(self) -> dict[str, str]:
        return dict(item.split("=", 1) for item in self.overrides)


def grid_runs(grids: list[str], common: Sequence[str] = ()) -> list[SweepRun]:
    """The Cartesian product of ``key=v1,v2,...`` grids, each run with the ``common`` overrides first."""
    axes = []
    for text in grids:
        key, sep, values = text.partition("=")
        if not sep or not key.strip() or not values.strip():
            raise SceneError(f"--grid '{text}' is not of the form key=v1,v2,...")
        axes.append([f"{key.strip()}={value.strip()}" for value in split_values(values)])
    return [SweepRun((*common, *combination)) for combination in itertools.product(*axes)]


def split_values(values: str) -> list[str]:
    """Comma-separated values; commas inside brackets, braces or quotes (TOML arrays, tables) do not split."""
    parts, depth, quote, current = [], 0, "", ""
    for char in values:
        if quote:
            quote = "" if char == quote else quote
        elif char in "\"'":
            quote = char
        elif char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
        elif char == "," and depth == 0:
            parts.append(current)
            current = ""
            continue
        current += char
    parts.append(current)
    return [p for p in (p.strip() for p in parts) if p]


def file_runs(path: str | Path, common: Sequence[str] = ()) -> list[SweepRun]:
    """One run per non-empty, non-comment line of ``path``: ``key=value`` items separated by spaces."""
    try:
        lines = Path(path).read_text().splitlines()
    except OSError as exc:
        raise SceneError(f"cannot read the run list '{path}': {exc.strerror}") from None
    runs = []
    for number, line in enumerate(lines, 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        items = shlex.split(line)
        bad = [item for item in items if "=" not in item]
        if bad:
            raise SceneError(f"{path}:{number}: '{bad[0]}' is not of the form key=value")
        runs.append(SweepRun((*common, *items)))
    return runs


def check_scheduler(address: str | None, insecure: bool = False) -> None:
    """A Dask scheduler to reach: ``tls://`` (Dask's own TLS settings), loopback ``tcp://``, or any ``tcp://``
    only when ``insecure``: Dask's tcp carries pickles, unencrypted and unauthenticated."""
    from cosim.server import is_loopback
    if address is None:
        return
    transport, sep, rest = address.partition("://")
    if not sep or transport not in ("tcp", "tls") or not rest:
        raise SceneError(f"--scheduler '{address}' is not of the form tls://HOST:PORT or tcp://HOST:PORT")
    host = rest.rsplit(":", 1)[0].strip("[]")
    if transport == "tcp" and not insecure and not is_loopback(host):
        raise SceneError(f"--scheduler '{address}': Dask's tcp:// is neither encrypted nor authenticated, and its "
                         "messages carry pickles; use tls:// (Dask's distributed.comm.tls settings) or pass "
                         "--insecure-scheduler on a network you trust")


def check_runs(scene_path: str, runs: list[SweepRun]) -> None:
    """Every variant must load and name known plug-ins before anything runs (errors name the run)."""
    from cosim.scene import load_scene
    from coupler.preflight import check_parameters
    from coupler.scene_rules import resolve_plugins
    if not runs:
        raise SceneError("the sweep has no runs")
    names = [run.name for run in runs]
    if len(set(names)) != len(names):
        raise SceneError("the sweep lists the same run twice")
    for run in runs:
        try:
            scene = load_scene(scene_path, list(run.overrides))
            resolve_plugins(scene)
            check_parameters(scene)
        except SceneError as exc:
            raise SceneError(f"run {run.name} ({' '.join(run.overrides)}): {exc}") from None


def run_one(scene_path: str, overrides: list[str], out_dir: str) -> dict[str, Any]:
    """Run one variant (on a Dask worker); a row of the sweep table, whatever happened. A run in ``out_dir`` that
    stopped midway after a checkpoint is resumed."""
    from cosim.errors import (
        ComponentError,
        ConvergenceError,
        CosimError,
        DivergenceError,
        NonFiniteOutput,
        StalledError,
    )
    from cosim.scene import load_scene
    from coupler.restart import resumable
    from coupler.run import run_scene

    started = time.perf_counter()
    failure, message, failed_residuals = "", "", []   # type: str, str, list[float]
    try:
        scene = load_scene(scene_path, overrides)
        resumed = False
        if resumable(out_dir):     # a run stopped midway goes on from its checkpoint
            from cosim.checkpoint import CheckpointError
            try:
                run_scene(scene, out_dir, progress=False, resume=True)
                resumed = True
            except CheckpointError:          # another scene or other versions: it runs again from its start
                pass
        if not resumed:
            run_scene(scene, out_dir, progress=False, overwrite=True)
    except NonFiniteOutput as exc:
        failure, message = "non-finite", str(exc)
    except DivergenceError as exc:
        failure, message, failed_residuals = "diverged", str(exc), getattr(exc, "residuals", [])
    except StalledError as exc:
        failure, message, failed_residuals = "stalled", str(exc), getattr(exc, "residuals", [])
    except ConvergenceError as exc:
        failure, message, failed_residuals = "max-iterations", str(exc), getattr(exc, "residuals", [])
    except ComponentError as exc:
        failure, message = "component-error", str(exc)
    except CosimError as exc:
        failure, message = "error", str(exc)
    return _row(out_dir, failure, message, failed_residuals, time.perf_counter() - started)


def finished_row(out_dir: str | Path) -> dict[str, Any] | None:
    """The table row of the run that finished in ``out_dir`` (its ``status.json`` says so), else None: a run
    whose row was never written (the sweep stopped between the two) is taken as it is, not run again."""
    try:
        status = json.loads((Path(out_dir) / "status.json").read_text())
    except (OSError, ValueError):
        return None
    if status.get("state") != "finished":
        return None
    return _row(out_dir, "", "", [], float(status.get("wall_seconds", float("nan"))))


def _row(out_dir: str | Path, failure: str, message: str, failed_residuals: list, wall_seconds: float) -> dict:
    from cosim.results import RunResults
    row: dict[str, Any] = {"windows_converged": 0, "windows_total": 0, "mean_iterations": float("nan"), "max_iterations": 0,
           "contraction": contraction([failed_residuals])}
    results = Path(out_dir) / "results.h5"
    if results.is_file():
        with RunResults(results) as run:
            windows = run.windows
            iterations = windows.iterations
            total = int(run.attributes.get("windows_completed", len(windows)))
            row.update(windows_converged=int(windows.converged.sum()), windows_total=total,
                       mean_iterations=float(iterations.mean()) if len(iterations) else float("nan"),
                       max_iterations=int(iterations.max()) if len(iterations) else 0)
            window, norm = run.residuals()
            per_window = [norm[window == w] for w in np.unique(window)]
            per_window.append(np.asarray(failed_residuals))
            row["contraction"] = contraction(per_window)
    row.update(failure=failure, failure_message=message.replace("\n", " "), wall_seconds=wall_seconds)
    return row


def read_rows(table: Path, runs: list[SweepRun]) -> list[dict[str, str]]:
    """The table's rows of ``runs`` (a table may hold rows of earlier sweeps into the same directory)."""
    names = {run.name for run in runs}
    with open(table, newline="") as stream:
        return [row for row in csv.DictReader(stream) if row["name"] in names]


def contraction(per_window: list) -> float:
    """Measured contraction per iteration: the median over windows (two iterations or more) of
    (r_last / r_first)^(1 / (k - 1)), r the coupling residual norms of a window's k iterations."""
    rates = [(r[-1] / r[0]) ** (1.0 / (len(r) - 1)) for r in map(np.asarray, per_window) if len(r) >= 2 and r[0] > 0]
    return float(np.median(rates)) if rates else float("nan")


class SweepTable:
    """``DIR/sweep.csv``: one row per finished run, appended and flushed as runs finish; with a scene
    ``fingerprint``, a table whose rows were made with another version of the scene is refused."""

    def __init__(self, path: Path, setting_keys: list[str], fingerprint: str | None = None):
        self.path = path
        self.columns = [*COLUMNS[:1], *setting_keys, *COLUMNS[1:]]
        self.done: dict[str, dict[str, str]] = {}
        if path.is_file():
            with open(path, newline="") as stream:
                reader = csv.DictReader(stream)
                if reader.fieldnames != self.columns:
                    raise SceneError(f"'{path}' belongs to a sweep with other settings "
                                     f"({', '.join(reader.fieldnames or [])}); use another --out")
                self.done = {row["name"]: row for row in reader}
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            with open(path, "w", newline="") as stream:
                csv.writer(stream).writerow(self.columns)
        if fingerprint is not None:
            stamp = path.with_name(FINGERPRINT)
            made_with = stamp.read_text().strip() if stamp.is_file() else None
            if self.done and made_with not in (None, fingerprint):
                raise SceneError(f"'{path.parent}' holds runs made with other scene data (the scene changed "
                                 f"since they ran); use another --out")
            if made_with != fingerprint:
                stamp.write_text(fingerprint + "\n")

    def forget(self, names: set[str]) -> None:
        """Drop the rows of these runs (they will run again), rewriting the table."""
        if not names & set(self.done):
            return
        for name in names:
            self.done.pop(name, None)
        partial = self.path.with_name(self.path.name + ".partial")
        with open(partial, "w", newline="") as stream:
            writer = csv.DictWriter(stream, self.columns)
            writer.writeheader()
            writer.writerows(self.done.values())
        partial.replace(self.path)

    def add(self, run: SweepRun, row: dict[str, Any]) -> None:
        values = {"name": run.name, **run.settings(), **row}
        with open(self.path, "a", newline="") as stream:
            csv.DictWriter(stream, self.columns, extrasaction="ignore").writerow(values)
        self.done[run.name] = {k: str(v) for k, v in values.items()}


def every_key(runs: list[SweepRun]) -> list[str]:
    """Every key any run sets, in first-seen order: a row tells its run's whole settings."""
    return list(dict.fromkeys(key for run in runs for key in run.settings()))


def setting_keys(runs: list[SweepRun]) -> list[str]:
    """The keys that vary between runs (or all keys if none varies), in first-seen order."""
    keys: dict[str, set[str]] = {}
    for run in runs:
        for key, value in run.settings().items():
            keys.setdefault(key, set()).add(value)
    varying = [k for k, values in keys.items() if len(values) > 1]
    return varying or list(keys)


def run_sweep(scene_path: str, runs: list[SweepRun], out: str | Path, workers: int = 2,
              scheduler: str | None = None, progress: bool = True,
              on_row: Callable[[SweepRun, dict], None] | None = None, keys: list[str] | None = None) -> Path:
    """Run every run not yet in ``out/sweep.csv`` on Dask; returns the table's path.

    ``keys`` are the settings the table shows (default: every key a run sets). ``out`` is held for
    the whole sweep: a second sweep into it is refused while this one runs.
    """
    from cosim.rundir import hold
    out = Path(out)
    check_runs(scene_path, runs)
    lock = hold(out, "sweep")
    try:
        return _run_sweep(scene_path, runs, out, workers, scheduler, progress, on_row, keys)
    finally:
        os.close(lock)


def _run_sweep(scene_path: str, runs: list[SweepRun], out: Path, workers: int, scheduler: str | None,
               progress: bool, on_row: Callable[[SweepRun, dict], None] | None, keys: list[str] | None) -> Path:
    table = SweepTable(out / TABLE, keys or every_key(runs), scene_fingerprint(scene_path, shared_overrides(runs)))
    for run in runs:
        row = None if run.name in table.done else finished_row(out / "runs" / run.name)
        if row is not None:
            table.add(run, row)
    pending = [run for run in runs if run.name not in table.done]
    if not pending:
        return table.path
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                  host="127.0.0.1", dashboard_address="127.0.0.1:0")
    bar = _progress(len(runs), len(runs) - len(pending), progress)
    try:
        with Client(scheduler or cluster) as client:
            futures = {client.submit(run_one, str(Path(scene_path).resolve()), list(run.overrides),
                                     str((out / "runs" / run.name).resolve()), key=f"cosim-{run.name}", pure=False): run
                       for run in pending}
            for future in as_completed(futures):
                run = futures[future]
                row = future.result()
                table.add(run, row)
                if on_row is not None:
                    on_row(run, row)
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix_str(f"{run.name}: {row['failure'] or 'converged'}", refresh=False)
    finally:
        if bar is not None:
            bar.close()
        if cluster is not None:
            cluster.close()
    return table.path


def _progress(total: int, done: int, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm
    return tqdm(total=total, initial=done, unit="run", dynamic_ncols=True)
