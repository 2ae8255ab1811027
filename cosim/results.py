"""The results file of a run (HDF5): written by ``ResultsStore``, read by ``RunResults``.

Layout (see DESIGN.md; ``Layout`` below is its only spelling): root attributes ``scene``,
``scene_resolved`` and ``versions``; ``/windows/{time,iterations,converged,wall_seconds}``;
``/fields/<data>``; ``/initial/<data>``; ``/residuals/{window,norm}`` (one row per coupling iteration); ``/components/<name>`` with ``compute_seconds``,
``cpu_seconds`` (the component process's CPU time) and ``roundtrip_seconds`` per call, ``final/`` arrays, ``meshes/<mesh>`` node coordinates and a
``variables`` attribute (JSON: name, causality, size, mesh, components of each variable); ``/snapshots/<name>/{inputs,outputs}/<var>``
with ``window``, ``iteration`` and ``converged`` per call. The writer appends and flushes every
window: a crash loses at most the window in flight.
"""

from __future__ import annotations

import json
import shutil
import socket
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from time import monotonic, sleep
from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.errors import CosimError, DiskFullError
from cosim.versions import versions

if TYPE_CHECKING:
    import h5py

WINDOW_COLUMNS = {"time": np.float64, "iterations": np.int32, "converged": np.bool_, "wall_seconds": np.float64}
FILE_NAME = "results.h5"
RESERVED_BYTES = 256 << 10   # kept free for HDF5's metadata (its B-trees, the attributes at close) and status.json


def _h5py() -> Any:
    """h5py, imported where a file is opened: the coupler's process builds a window's rows (``window_rows``) and
    never opens the file, so it never pays for h5py's import."""
    import h5py
    return h5py


class Layout:
    """Where everything lives in the file: the one place that spells its paths."""

    fields = "fields"
    initial = "initial"
    components = "components"
    snapshots = "snapshots"

    @staticmethod
    def window(column: str) -> str:
        return f"windows/{column}"

    @staticmethod
    def field(name: str) -> str:
        return f"fields/{name}"

    @staticmethod
    def component(name: str) -> str:
        return f"components/{name}"

    @staticmethod
    def timing(name: str, kind: str) -> str:
        return f"components/{name}/{kind}_seconds"

    @staticmethod
    def final(name: str) -> str:
        return f"components/{name}/final"

    @staticmethod
    def meshes(name: str) -> str:
        return f"components/{name}/meshes"

    @staticmethod
    def calls(name: str) -> str:
        return f"snapshots/{name}"

    @staticmethod
    def residual(column: str) -> str:
        return f"residuals/{column}"


Rows = list[tuple[str, np.ndarray]]       # one window's rows: (dataset, rows) in the order they are written


def window_rows(window: int, time: float, iterations: int, converged: bool, wall_seconds: float,
                fields: Mapping[str, np.ndarray], timings: Mapping[str, tuple[list[float], ...]],
                snapshots: Mapping[str, Mapping[str, Any]], residuals: Sequence[float]) -> Rows:
    """(dataset, rows) of window number ``window`` (from 1): its summary, converged fields, per-call timings,
    recorded calls and residual norms."""
    rows: Rows = [(Layout.window("time"), np.array([time]))]
    if len(residuals):
        rows += [(Layout.residual("window"), np.full(len(residuals), window, dtype=np.int32)),
                 (Layout.residual("norm"), np.asarray(residuals, dtype=np.float64))]
    rows += [(Layout.window("iterations"), np.array([iterations], dtype=np.int32)),
             (Layout.window("converged"), np.array([converged])),
             (Layout.window("wall_seconds"), np.array([wall_seconds]))]
    rows += [(Layout.field(name), np.asarray(value)[None]) for name, value in fields.items()]
    for name, (compute, roundtrip, *cpu) in timings.items():
        if compute:
            rows += [(Layout.timing(name, "compute"), np.array(compute)),
                     (Layout.timing(name, "roundtrip"), np.array(roundtrip))]
            rows += [(Layout.timing(name, "cpu"), np.array(cpu[0]))] if cpu else []
    for name, calls in snapshots.items():
        if not calls["window"]:
            continue
        base = Layout.calls(name)
        rows += [(f"{base}/{kind}/{var}", np.stack(values)) for kind in ("inputs", "outputs")
                 for var, values in calls[kind].items()]
        rows += [(f"{base}/window", np.array(calls["window"], dtype=np.int32)),
                 (f"{base}/iteration", np.array(calls["iteration"], dtype=np.int32)),
                 (f"{base}/converged", np.array(calls["converged"]))]
    return rows


class ResultsStore:
    """Appends rows to growable datasets; one ``append_window`` per time window."""

    def __init__(self, path: str | Path, scene_text: str):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self.file = _h5py().File(self.path, "w-")  # never truncate an existing file
        except FileExistsError:
            raise CosimError(f"'{self.path}' exists; a run never overwrites another") from None
        self._columns: dict[str, _GrowingDataset] = {}
        self._windows_written = 0
        try:
            self.file.attrs["scene"] = scene_text
            self.file.attrs["versions"] = json.dumps(versions())
            self.file.attrs["host"] = socket.gethostname()
            self.file.attrs["windows_completed"] = 0
            for name, dtype in WINDOW_COLUMNS.items():  # present (empty) even if no window finishes
                self._append(Layout.window(name), np.zeros(0, dtype=dtype))
            self.file.flush()
        except OSError:      # a full disk at start: leave no half-made file behind
            self.file.close()
            self.path.unlink(missing_ok=True)
            raise

    @classmethod
    def resume(cls, path: str | Path, lengths: Mapping[str, int], windows: int) -> ResultsStore:
        """The results file of a run going on from a checkpoint: every growing dataset cut back to its length at
        the checkpoint (``lengths``, from ``lengths()`` then), those made after it removed."""
        store = cls.__new__(cls)
        store.path = Path(path)
        try:
            store.file = _h5py().File(store.path, "r+")
        except OSError as exc:
            raise CosimError(f"cannot open '{store.path}' to go on with it: {exc}") from None
        store._columns = {}
        grown: list[str] = []
        store.file.visititems(lambda name, item: grown.append(name) if isinstance(item, _h5py().Dataset)
                              and item.maxshape[0] is None else None)
        for name in grown:
            if name not in lengths:
                del store.file[name]
                continue
            if store.file[name].shape[0] < lengths[name]:
                store.file.close()
                raise CosimError(f"'{store.path}': dataset '{name}' holds {store.file[name].shape[0]} rows, fewer "
                                 f"than the checkpoint's {lengths[name]}")
            store._columns[name] = _GrowingDataset.reopen(store.file[name], lengths[name])
        missing = sorted(set(lengths) - set(store._columns))
        if missing:
            store.file.close()
            raise CosimError(f"'{store.path}' lacks dataset '{missing[0]}' that the checkpoint counts")
        store._windows_written = windows
        store.file.attrs["windows_completed"] = windows
        store.file.flush()
        return store

    def lengths(self) -> dict[str, int]:
        """Rows of every growing dataset (a checkpoint's record of where the file stood)."""
        return {name: column.length for name, column in self._columns.items()}

    # --- growable datasets ----------------------------------------------------
    def _append(self, name: str, rows: np.ndarray) -> None:
        column = self._columns.get(name)
        if column is None:
            self._columns[name] = _GrowingDataset(self.file, name, np.asarray(rows))
        else:
            column.append(rows)

    # --- run content -------------------------------------------------------------
    def add_component(self, name: str, pid: int | None, host: str, backend: str, endpoint: str = "",
                      **attributes: Any) -> None:
        group = self.file.require_group(Layout.component(name))
        group.attrs.update({"pid": -1 if pid is None else pid, "host": host, "backend": backend, "endpoint": endpoint,
                            **attributes})

    def append_window(self, time: float, iterations: int, converged: bool, wall_seconds: float,
                      fields: Mapping[str, np.ndarray],
                      timings: Mapping[str, tuple[list[float], ...]],
                      snapshots: Mapping[str, Mapping[str, Any]], residuals: Sequence[float] = ()) -> None:
        """One window: its summary, converged fields, per-call timings, recorded calls and residual norms."""
        self.append_windows([window_rows(self._windows_written + 1, time, iterations, converged, wall_seconds,
                                         fields, timings, snapshots, residuals)])

    def append_windows(self, windows: Sequence[Rows]) -> None:
        """Windows' rows (``window_rows``), each dataset's rows of every window written at once, then flushed.

        A window is written whole or not at all: one the disk has no room for is refused (``DiskFullError``)
        before any of it is written, every window before it written, so every dataset holds the same windows
        whenever a run stops.
        """
        if not windows:
            return
        if not self._has_room(windows):
            for window in windows:          # as many whole windows as the disk holds, one at a time
                if not self._has_room([window]):
                    raise DiskFullError(self._no_room([window]))
                self.append_windows([window])
            return
        merged: dict[str, list[np.ndarray]] = {}
        for window in windows:
            for name, value in window:
                merged.setdefault(name, []).append(value)
        for name, values in merged.items():
            self._append(name, values[0] if len(values) == 1 else np.concatenate(values))
        self._windows_written += len(windows)
        self.file.attrs["windows_completed"] = self._windows_written   # true after a crash too
        self.file.flush()

    @property
    def windows_written(self) -> int:
        return self._windows_written

    def _needed_bytes(self, windows: Sequence[Rows]) -> int:
        """Bytes the file may grow by when ``windows`` are appended, HDF5's reserve included."""
        needed = RESERVED_BYTES
        counts: dict[str, int] = {}
        first: dict[str, np.ndarray] = {}
        for window in windows:
            for name, value in window:
                counts[name] = counts.get(name, 0) + len(value)
                first.setdefault(name, value)
        for name, count in counts.items():
            column = self._columns.get(name)
            needed += column.bytes_to_append(count) if column else \
                _GrowingDataset.first_bytes(np.repeat(np.asarray(first[name])[:1], count, axis=0))
        return needed

    def _has_room(self, windows: Sequence[Rows]) -> bool:
        return shutil.disk_usage(self.path.parent).free >= self._needed_bytes(windows)

    def _no_room(self, windows: Sequence[Rows]) -> str:
        """Why the next window is refused: the free bytes against those it needs."""
        free = shutil.disk_usage(self.path.parent).free
        return (f"no room for window {self._windows_written + 1} in '{self.path.parent}': {free:,} bytes free, the "
                f"window needs up to {self._needed_bytes(windows):,}; the {self._windows_written} windows before it "
                "are kept")

    def write_description(self, component: str, variables: list[dict[str, Any]],
                          meshes: Mapping[str, np.ndarray]) -> None:
        """A component's variables (as JSON) and mesh coordinates."""
        self.file.require_group(Layout.component(component)).attrs["variables"] = json.dumps(variables)
        self._write_arrays(Layout.meshes(component), meshes)

    def write_initial(self, values: Mapping[str, np.ndarray]) -> None:
        """Data values before the first window."""
        self._write_arrays(Layout.initial, values)

    def write_final(self, component: str, arrays: Mapping[str, np.ndarray]) -> None:
        """What a component hands back at terminate."""
        self._write_arrays(Layout.final(component), arrays)

    def _write_arrays(self, group: str, arrays: Mapping[str, np.ndarray]) -> None:
        for name, value in arrays.items():
            path = f"{group}/{name}"
            if path in self.file:
                del self.file[path]
            self.file.create_dataset(path, data=value)
        self.file.flush()

    def set_attributes(self, **attributes: Any) -> None:
        """Root attributes of the run."""
        self.file.attrs.update(attributes)

    def add_to_attributes(self, **increments: float) -> None:
        """Add to root attributes (counts and totals; an absent one counts from 0)."""
        for name, value in increments.items():
            self.file.attrs[name] = self.file.attrs.get(name, 0) + value

    def close(self) -> None:
        if self.file.id.valid:
            self.file.close()


@dataclass
class Windows:
    """Per-window summary rows."""

    time: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    wall_seconds: np.ndarray

    def __len__(self) -> int:
        return len(self.time)


@dataclass
class ComponentRecord:
    """One component (process) of a run: its attributes and per-call timings."""

    name: str
    attributes: dict[str, Any]
    compute_seconds: np.ndarray
    roundtrip_seconds: np.ndarray
    final: dict[str, np.ndarray]
    variables: list[dict[str, Any]]
    meshes: dict[str, np.ndarray]
    cpu_seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))   # the process's CPU time, per call


@dataclass
class Calls:
    """Recorded calls of one component: one row per call (every sub-iteration)."""

    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    window: np.ndarray
    iteration: np.ndarray
    converged: np.ndarray

    def __len__(self) -> int:
        return len(self.window)

    def select(self, rows: np.ndarray) -> Calls:
        """The calls at ``rows`` (indices or a mask)."""
        return Calls({k: v[rows] for k, v in self.inputs.items()}, {k: v[rows] for k, v in self.outputs.items()},
                     self.window[rows], self.iteration[rows], self.converged[rows])


class RunResults:
    """A run's results file, opened read-only: ``RunResults(DIR or DIR/results.h5)``."""

    def __init__(self, path: str | Path):
        path = Path(path)
        self.path = path / FILE_NAME if path.is_dir() else path
        if not self.path.is_file():
            raise CosimError(f"no results file at '{self.path}'")
        if not _h5py().is_hdf5(self.path):
            raise CosimError(f"'{self.path}' is not an HDF5 results file")
        from cosim.rundir import SETTLE_SECONDS, settling
        deadline = monotonic() + SETTLE_SECONDS
        while True:
            try:
                self.file = _h5py().File(self.path, "r")
                break
            except BlockingIOError:
                # a dead run's writer finishing the windows it was handed: whole within seconds
                if not settling(self.path.parent) or monotonic() > deadline:
                    raise CosimError(f"'{self.path}' is being written by a run in progress; read it once the run "
                                     "has stopped") from None
                sleep(0.02)
            except OSError as exc:
                raise CosimError(f"cannot read '{self.path}': it is truncated or damaged ({exc})") from None

    def __enter__(self) -> RunResults:
        return self

    def __exit__(self, *exc_info: Any) -> None:
        self.close()

    def close(self) -> None:
        if self.file.id.valid:
            self.file.close()

    # --- the run ------------------------------------------------------------
    @property
    def attributes(self) -> dict[str, Any]:
        return {k: (v.item() if hasattr(v, "item") else v) for k, v in self.file.attrs.items()}

    @property
    def scene(self) -> dict[str, Any]:
        """The resolved scene (after --set), or the scene text parsed."""
        if "scene_resolved" in self.file.attrs:
            return json.loads(self.file.attrs["scene_resolved"])
        import tomllib
        return tomllib.loads(self.file.attrs["scene"])

    @property
    def windows(self) -> Windows:
        return Windows(*(self.file[Layout.window(c)][:] for c in WINDOW_COLUMNS))

    def fields(self) -> dict[str, np.ndarray]:
        """Converged value of each exchanged data item, one row per window."""
        return {k: v[:] for k, v in self.file.get(Layout.fields, {}).items()}

    def initial(self) -> dict[str, np.ndarray]:
        return {k: v[:] for k, v in self.file.get(Layout.initial, {}).items()}

    # --- components -----------------------------------------------------------
    def component_names(self) -> list[str]:
        return list(self.file.get(Layout.components, {}))

    def component(self, name: str) -> ComponentRecord:
        if Layout.component(name) not in self.file:
            raise CosimError(f"'{self.path}' has no component '{name}' (has: {', '.join(self.component_names())})")
        group = self.file[Layout.component(name)]
        timings = [self.file[p][:] if p in self.file else np.zeros(0)
                   for p in (Layout.timing(name, "compute"), Layout.timing(name, "roundtrip"),
                             Layout.timing(name, "cpu"))]
        final = {k: v[:] for k, v in self.file.get(Layout.final(name), {}).items()}
        attributes = {k: (v.item() if getattr(v, "size", 0) == 1 else v.tolist() if hasattr(v, "tolist") else v)
                      for k, v in group.attrs.items()}
        variables = json.loads(attributes.pop("variables", "[]"))
        meshes = {k: v[:] for k, v in self.file.get(Layout.meshes(name), {}).items()}
        return ComponentRecord(name, attributes, timings[0], timings[1], final, variables, meshes,
                               timings[2] if len(timings[2]) == len(timings[0]) else timings[0])

    # --- snapshots --------------------------------------------------------------
    def recorded(self) -> list[str]:
        """Components whose calls were recorded."""
        return list(self.file.get(Layout.snapshots, {}))

    def residuals(self) -> tuple[np.ndarray, np.ndarray]:
        """(window, norm) per coupling iteration: ||H(x) - x|| of the accelerated data (empty if none)."""
        if Layout.residual("norm") not in self.file:
            return np.zeros(0, dtype=np.int32), np.zeros(0)
        return self.file[Layout.residual("window")][:], self.file[Layout.residual("norm")][:]

    def calls(self, name: str, converged_only: bool = False) -> Calls:
        """Recorded calls of ``name`` (only each window's converged one if ``converged_only``)."""
        if Layout.calls(name) not in self.file:
            raise CosimError(f"'{self.path}' has no recorded calls of '{name}' (recorded: "
                             f"{', '.join(self.recorded()) or 'none'}; set record = true in the scene)")
        group = self.file[Layout.calls(name)]
        converged = group["converged"][:]
        keep = converged if converged_only else slice(None)
        arrays = {kind: {var: data[:][keep] for var, data in group.get(kind, {}).items()}
                  for kind in ("inputs", "outputs")}
        return Calls(arrays["inputs"], arrays["outputs"], group["window"][:][keep], group["iteration"][:][keep],
                     converged[keep])


class _GrowingDataset:
    """A dataset grown by whole rows through h5py's low-level API (about 4x faster per append)."""

    def __init__(self, file: h5py.File, name: str, rows: np.ndarray):
        rows = np.ascontiguousarray(rows)
        if rows.ndim == 0:
            rows = rows[None]
        self.name, self.row_shape, self.dtype = name, rows.shape[1:], rows.dtype
        self.chunk_rows, self.chunk_bytes = _chunking(rows)
        self.dataset = file.create_dataset(name, data=rows, maxshape=(None, *self.row_shape),
                                           chunks=(self.chunk_rows, *self.row_shape))
        self.length = len(rows)

    @classmethod
    def reopen(cls, dataset: h5py.Dataset, length: int) -> _GrowingDataset:
        """A dataset of an existing file, cut to ``length`` rows."""
        column = cls.__new__(cls)
        column.name, column.row_shape, column.dtype = dataset.name.lstrip("/"), dataset.shape[1:], dataset.dtype
        column.chunk_rows = dataset.chunks[0]
        column.chunk_bytes = column.chunk_rows * max(1, int(np.prod(column.row_shape, dtype=np.int64))) \
            * dataset.dtype.itemsize
        column.dataset = dataset
        dataset.resize(length, axis=0)
        column.length = length
        return column

    @staticmethod
    def first_bytes(rows: np.ndarray) -> int:
        """Bytes the file grows by when a dataset is made of ``rows`` (whole chunks)."""
        chunk_rows, chunk_bytes = _chunking(np.atleast_1d(rows))
        return -(-max(len(np.atleast_1d(rows)), 1) // chunk_rows) * chunk_bytes

    def bytes_to_append(self, count: int) -> int:
        """Bytes the file grows by when ``count`` rows are appended (the chunks they start)."""
        chunks = lambda rows: -(-rows // self.chunk_rows)  # noqa: E731
        return (chunks(self.length + count) - chunks(self.length)) * self.chunk_bytes

    def append(self, rows: np.ndarray) -> None:
        rows = np.ascontiguousarray(rows, dtype=self.dtype)
        if rows.ndim == 0:
            rows = rows[None]
        if rows.shape[1:] != self.row_shape:
            raise ValueError(f"results '{self.name}': row shape {rows.shape[1:]} differs from {self.row_shape}")
        count = len(rows)
        if count == 0:
            return
        dataset_id = self.dataset.id
        dataset_id.set_extent((self.length + count, *self.row_shape))
        file_space = dataset_id.get_space()
        file_space.select_hyperslab((self.length, *([0] * len(self.row_shape))), rows.shape)
        dataset_id.write(_h5py().h5s.create_simple(rows.shape), file_space, rows)
        self.length += count


def _chunking(rows: np.ndarray) -> tuple[int, int]:
    """(rows, bytes) of one chunk of a dataset of such rows: about 64 KiB, at most 4096 rows."""
    row_bytes = max(1, int(np.prod(rows.shape[1:], dtype=np.int64)) * rows.dtype.itemsize)
    chunk_rows = max(1, min(4096, (1 << 16) // row_bytes))
    return chunk_rows, chunk_rows * row_bytes
