"""A participant's exports, as a configuration's ``<export:vtu|vtk|csv>`` asks: each of its meshes with the data it
writes and reads there, written by the participant itself into the export's directory (relative to where it runs).

Files are named ``<mesh>-<participant>.<stage>.<format>``: the stage is ``init`` (after initialize), ``dt<N>`` (after
window N, every ``every-n-time-windows`` windows) or ``it<K>`` (after the K-th coupling iteration, with
``every-iteration``); a ``<mesh>-<participant>.<format>.series`` (ParaView's file series, JSON) lists the files
written so far with their times. Points have three coordinates (z = 0 on a 2-D mesh); vectors of 2-D data have
three components (z = 0); the cells are the mesh's edges, triangles and tetrahedra where it has them, else one
vertex cell per point.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

VTK_CELL = {"vertices": 1, "edges": 3, "triangles": 5, "tetrahedra": 10}


@dataclass
class MeshView:
    """A mesh as an export writes it: its points, its elements by kind (rows of vertex ids) and its data."""

    points: np.ndarray
    elements: dict[str, np.ndarray] = field(default_factory=dict)
    data: dict[str, np.ndarray] = field(default_factory=dict)


def _padded(values: np.ndarray, columns: int = 3) -> np.ndarray:
    values = np.asarray(values, dtype=np.float64)
    rows = values.reshape(len(values), -1) if values.ndim > 1 else values.reshape(-1, 1)
    if rows.shape[1] in (2,) and columns == 3:
        rows = np.hstack([rows, np.zeros((len(rows), 1))])
    return rows


def _cells(mesh: MeshView) -> tuple[list[np.ndarray], list[int]]:
    """(rows of vertex ids, VTK cell type) of the mesh's highest elements; vertex cells where it has none."""
    for kind in ("tetrahedra", "triangles", "edges"):
        rows = mesh.elements.get(kind)
        if rows is not None and len(rows):
            return list(rows), [VTK_CELL[kind]] * len(rows)
    return [np.array([i]) for i in range(len(mesh.points))], [VTK_CELL["vertices"]] * len(mesh.points)


def _numbers(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) if isinstance(v, float | np.floating) else str(int(v))
                    for v in np.asarray(values).ravel())


def vtu_text(mesh: MeshView) -> str:
    """The mesh as a VTK XML unstructured grid (ASCII)."""
    cells, types = _cells(mesh)
    connectivity = np.concatenate(cells) if cells else np.zeros(0, dtype=np.int64)
    offsets = np.cumsum([len(c) for c in cells], dtype=np.int64)
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">',
             "  <UnstructuredGrid>",
             f'    <Piece NumberOfPoints="{len(mesh.points)}" NumberOfCells="{len(cells)}">',
             "      <PointData>"]
    for name, values in mesh.data.items():
        rows = _padded(values)
        lines.append(f'        <DataArray type="Float64" Name="{name}" NumberOfComponents="{rows.shape[1]}" '
                     f'format="ascii">{_numbers(rows)}</DataArray>')
    lines += ["      </PointData>", "      <Points>",
              f'        <DataArray type="Float64" NumberOfComponents="3" format="ascii">'
              f"{_numbers(_padded(mesh.points))}</DataArray>",
              "      </Points>", "      <Cells>",
              f'        <DataArray type="Int64" Name="connectivity" format="ascii">{_numbers(connectivity)}</DataArray>',
              f'        <DataArray type="Int64" Name="offsets" format="ascii">{_numbers(offsets)}</DataArray>',
              f'        <DataArray type="UInt8" Name="types" format="ascii">{_numbers(np.array(types))}</DataArray>',
              "      </Cells>", "    </Piece>", "  </UnstructuredGrid>", "</VTKFile>"]
    return "\n".join(lines) + "\n"


def vtk_text(mesh: MeshView, title: str) -> str:
    """The mesh as a legacy VTK unstructured grid (ASCII)."""
    cells, types = _cells(mesh)
    lines = ["# vtk DataFile Version 2.0", title, "ASCII", "DATASET UNSTRUCTURED_GRID",
             f"POINTS {len(mesh.points)} double"]
    lines += [_numbers(row) for row in _padded(mesh.points)]
    lines.append(f"CELLS {len(cells)} {sum(len(c) + 1 for c in cells)}")
    lines += [f"{len(c)} {_numbers(c)}" for c in cells]
    lines.append(f"CELL_TYPES {len(cells)}")
    lines += [str(t) for t in types]
    if mesh.data:
        lines.append(f"POINT_DATA {len(mesh.points)}")
    for name, values in mesh.data.items():
        rows = _padded(values)
        if rows.shape[1] == 1:
            lines += [f"SCALARS {name} double 1", "LOOKUP_TABLE default"]
        else:
            lines.append(f"VECTORS {name} double")
        lines += [_numbers(row) for row in rows]
    return "\n".join(lines) + "\n"


def csv_text(mesh: MeshView) -> str:
    """The mesh's points and data as semicolon-separated columns, a header line first."""
    dimensions = mesh.points.shape[1]
    header = ["PosX", "PosY", "PosZ"][:dimensions]
    columns = [mesh.points]
    for name, values in mesh.data.items():
        rows = np.asarray(values, dtype=np.float64).reshape(len(mesh.points), -1)
        header += [name] if rows.shape[1] == 1 else [f"{name}{axis}" for axis in "XYZ"[:rows.shape[1]]]
        columns.append(rows)
    table = np.hstack(columns) if columns else np.zeros((0, 0))
    return ";".join(header) + "\n" + "".join(";".join(repr(float(v)) for v in row) + "\n" for row in table)


class Exports:
    """The exports of one participant: what its configuration asks, written when it is due."""

    def __init__(self, participant: str, specs: list[dict[str, Any]], folder: Path):
        self.participant, self.specs, self.folder = participant, specs, folder
        self.iterations = 0
        self.series: dict[Path, list[tuple[str, float]]] = {}

    def __bool__(self) -> bool:
        return bool(self.specs)

    def initialized(self, time: float, meshes: Mapping[str, MeshView]) -> None:
        for spec in self.specs:
            self._write(spec, "init", time, meshes)

    def iterated(self, time: float, window: int, complete: bool, meshes: Mapping[str, MeshView]) -> None:
        """After a coupling iteration (``complete``: the last of window number ``window``, which ends at ``time``)."""
        self.iterations += 1
        for spec in self.specs:
            if spec.get("every_iteration"):
                self._write(spec, f"it{self.iterations}", time, meshes)
            if complete and window % int(spec.get("every_n_time_windows", 1)) == 0:
                self._write(spec, f"dt{window}", time, meshes)

    def _write(self, spec: dict[str, Any], stage: str, time: float, meshes: Mapping[str, MeshView]) -> None:
        kind = spec["format"]
        folder = self.folder / spec.get("directory", ".")
        folder.mkdir(parents=True, exist_ok=True)
        for mesh, view in meshes.items():
            stem = f"{mesh}-{self.participant}"
            name = f"{stem}.{stage}.{kind}"
            text = (vtu_text(view) if kind == "vtu" else vtk_text(view, f"{stem} {stage}") if kind == "vtk"
                    else csv_text(view))
            _write_atomically(folder / name, text)
            if stage.startswith("it"):
                continue
            series = folder / f"{stem}.{kind}.series"
            records = self.series.setdefault(series, [])
            records.append((name, float(f"{time:.12g}")))
            _write_atomically(series, json.dumps({"file-series-version": "1.0", "files": [
                {"name": file, "time": moment} for file, moment in records]}, indent=1) + "\n")


def _write_atomically(path: Path, text: str) -> None:
    partial = path.with_name(f".{path.name}.{os.getpid()}")
    partial.write_text(text)
    partial.replace(path)
