"""A participant's exports, as a configuration's ``<export:vtu|vtk|csv>`` asks, in the files preCICE 3.4.1 writes:
each mesh the participant knows, with every data item of the mesh, written by the participant itself into the
export's directory (relative to where it runs).

- Names: ``<mesh>-<participant>.<stage>.<format>``; the stage is ``init`` (after initialize), ``dt<N>`` (after window
  N, every ``every-n-time-windows`` windows; below 1: neither init nor windows) or ``it<K>`` (after the K-th
  ``advance``, with ``every-iteration``, which then replaces the windows' files).
- A time-window exporter of vtu or vtk keeps ``<mesh>-<participant>.<format>.series`` (ParaView's file series, one
  line of JSON) listing its files with their times; every-iteration and csv exporters keep none.
- Contents: a ``Rank`` array (0: cosim's participants are served as one) and then the mesh's data in its
  ``<use-data>`` order, as last written or received; a 2-D mesh's points and vectors get a zero third component.
  Cells are the mesh's triangles, edges (a triangle's own included) and tetrahedra in vtu; a legacy vtk file of a
  2-D mesh holds its edges alone. Numbers as preCICE prints them: six significant digits in vtu and csv, 17 in vtk.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

VTK_CELL = {"edges": 3, "triangles": 5, "tetrahedra": 10}


@dataclass
class MeshView:
    """A mesh as an export writes it: its points, its elements by kind (rows of vertex ids) and its data (in the
    mesh's order; a 1-D array for scalar data, one row a vertex for vector data)."""

    points: np.ndarray
    elements: dict[str, np.ndarray] = field(default_factory=dict)
    data: dict[str, np.ndarray] = field(default_factory=dict)


def _g(value: float) -> str:
    return f"{float(value):g}"


def _e(value: float) -> str:
    return f"{float(value):.17e}"


def _three(points: np.ndarray) -> np.ndarray:
    return np.hstack([points, np.zeros((len(points), 3 - points.shape[1]))]) if points.shape[1] < 3 else points


def _cells(mesh: MeshView, kinds: Sequence[str]) -> list[tuple[int, np.ndarray]]:
    """(VTK type, vertex ids) of the mesh's elements of ``kinds``, in that order."""
    return [(VTK_CELL[kind], row) for kind in kinds for row in mesh.elements.get(kind, np.zeros((0, 2), int))]


def vtu_text(mesh: MeshView) -> str:
    """The mesh as preCICE's vtu exporter writes it (XML unstructured grid, ASCII)."""
    cells = _cells(mesh, ("triangles", "edges", "tetrahedra"))
    out = ['<?xml version="1.0"?>', '<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">',
           "   <UnstructuredGrid>", f'      <Piece NumberOfPoints="{len(mesh.points)}" NumberOfCells="{len(cells)}" > ',
           "         <Points> ",
           '            <DataArray type="Float64" Name="Position" NumberOfComponents="3" format="ascii"> ']
    out += ["               " + "".join(f"{_g(v)}  " for v in row) for row in _three(mesh.points)]
    out += ["            </DataArray>", "         </Points> ", "", "         <Cells>",
            '            <DataArray type="Int32" Name="connectivity" NumberOfComponents="1" format="ascii">',
            "               " + "".join(f"{int(v)}  " for _, row in cells for v in row),
            "            </DataArray> ",
            '            <DataArray type="Int32" Name="offsets" NumberOfComponents="1" format="ascii">',
            "               " + "".join(f"{int(v)}  " for v in np.cumsum([len(row) for _, row in cells])),
            "            </DataArray>",
            '            <DataArray type="UInt8"  Name="types" NumberOfComponents="1" format="ascii">',
            "               " + "".join(f"{kind}  " for kind, _ in cells),
            "            </DataArray>", "         </Cells>"]
    scalars = ["Rank", *(name for name, values in mesh.data.items() if np.ndim(values) == 1)]
    vectors = [name for name, values in mesh.data.items() if np.ndim(values) > 1]
    out.append(f'         <PointData Scalars="{"".join(n + " " for n in scalars)}"'
               + (f' Vectors="{"".join(n + " " for n in vectors)}"' if vectors else "") + ">")
    out += ['            <DataArray type="UInt32" Name="Rank" NumberOfComponents="1" format="ascii">',
            "               " + "0 " * len(mesh.points), "            </DataArray>"]
    for name, values in mesh.data.items():
        array = np.asarray(values, dtype=np.float64)
        if array.ndim == 1:
            out += [f'            <DataArray type="Float64" Name="{name}" NumberOfComponents="1" format="ascii">',
                    "               " + "".join(f"{_g(v)} " for v in array)]
        else:
            out += [f'            <DataArray type="Float64" Name="{name}" NumberOfComponents="3" format="ascii">',
                    "               " + "".join(" ".join(_g(v) for v in row) + (" 0.0" if len(row) == 2 else "")
                                                + "  " for row in array)]
        out.append("            </DataArray>")
    out += ["         </PointData> ", "      </Piece>", "   </UnstructuredGrid> ", "</VTKFile>"]
    return "\n".join(out) + "\n"


def vtk_text(mesh: MeshView) -> str:
    """The mesh as preCICE's legacy vtk exporter writes it (ASCII; a 2-D mesh's edges alone)."""
    dimensions = mesh.points.shape[1]
    cells = _cells(mesh, ("edges",) if dimensions == 2 else ("tetrahedra", "triangles", "edges"))
    out = ["# vtk DataFile Version 2.0", "", "ASCII", "", "DATASET UNSTRUCTURED_GRID", "",
           f"POINTS {len(mesh.points)} double ", ""]
    out += ["  ".join(_e(v) for v in row) for row in _three(mesh.points)]
    out += ["", f"CELLS {len(cells)} {sum(len(row) + 1 for _, row in cells)}", ""]
    out += [f"{len(row)} " + "".join(f"{int(v)} " for v in row) for _, row in cells]
    out += ["", f"CELL_TYPES {len(cells)}", ""]
    out += [str(kind) for kind, _ in cells]
    out += ["", f"POINT_DATA {len(mesh.points)}", "", "SCALARS Rank unsigned_int", "LOOKUP_TABLE default",
            "0 " * len(mesh.points), ""]
    for name, values in mesh.data.items():
        array = np.asarray(values, dtype=np.float64)
        if array.ndim == 1:
            out += [f"SCALARS {name} double", "LOOKUP_TABLE default", *(_e(v) for v in array), ""]
        else:
            out += [f"VECTORS {name} double",
                    *(" ".join(_e(v) for v in row) + (" 0" if len(row) == 2 else "") for row in array), ""]
    return "\n".join(out) + "\n"


def csv_text(mesh: MeshView) -> str:
    """The mesh's points and data as preCICE's csv exporter writes them: ``;``-separated, a header line first."""
    dimensions = mesh.points.shape[1]
    header = ["PosX", "PosY", "PosZ"][:dimensions] + ["Rank"]
    columns = [mesh.points, np.zeros((len(mesh.points), 1))]
    for name, values in mesh.data.items():
        array = np.asarray(values, dtype=np.float64).reshape(len(mesh.points), -1)
        header += [name] if array.shape[1] == 1 else [f"{name}{axis}" for axis in "XYZ"[:array.shape[1]]]
        columns.append(array)
    table = np.hstack(columns)
    return ";".join(header) + "\n" + "".join(";".join(_g(v) for v in row) + "\n" for row in table)


def _time(value: float) -> str:
    """A time as preCICE's series file prints it: the shortest text that reads back, ``0`` and ``1`` bare."""
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


class Exports:
    """The exports of one participant: what its configuration asks, written when they are due."""

    def __init__(self, participant: str, specs: list[dict[str, Any]], folder: Path):
        self.participant, self.specs, self.folder = participant, specs, folder
        self.iterations = 0
        self.series: dict[Path, list[tuple[str, float]]] = {}

    def __bool__(self) -> bool:
        return bool(self.specs)

    def initialized(self, time: float, meshes: Mapping[str, MeshView]) -> None:
        for spec in self.specs:
            if spec.get("every_iteration") or int(spec.get("every_n_time_windows", 1)) >= 1:
                self._write(spec, "init", time, meshes)

    def iterated(self, time: float, window: int, complete: bool, meshes: Mapping[str, MeshView]) -> None:
        """After an ``advance`` that ends a coupling iteration (``complete``: the last of window number ``window``,
        which ends at ``time``)."""
        self.iterations += 1
        for spec in self.specs:
            if spec.get("every_iteration"):
                self._write(spec, f"it{self.iterations}", time, meshes)
                continue
            every = int(spec.get("every_n_time_windows", 1))
            if complete and every >= 1 and window % every == 0:
                self._write(spec, f"dt{window}", time, meshes)

    def _write(self, spec: dict[str, Any], stage: str, time: float, meshes: Mapping[str, MeshView]) -> None:
        kind = spec["format"]
        folder = self.folder / spec.get("directory", ".")
        folder.mkdir(parents=True, exist_ok=True)
        for mesh, view in meshes.items():
            stem = f"{mesh}-{self.participant}"
            name = f"{stem}.{stage}.{kind}"
            text = vtu_text(view) if kind == "vtu" else vtk_text(view) if kind == "vtk" else csv_text(view)
            _write_atomically(folder / name, text)
            if kind == "csv" or spec.get("every_iteration"):
                continue
            series = folder / f"{stem}.{kind}.series"
            records = self.series.setdefault(series, [])
            records.append((name, time))
            files = ", ".join(f'{{ "name" : "{file}", "time" : {_time(moment)} }}' for file, moment in records)
            _write_atomically(series, f'{{ "file-series-version" : "1.0", "files" : [ {files} ] }}')


def _write_atomically(path: Path, text: str) -> None:
    partial = path.with_name(f".{path.name}.{os.getpid()}")
    partial.write_text(text)
    partial.replace(path)
