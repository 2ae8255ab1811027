"""``run.xdmf`` beside a run's ``results.h5``: the run as ParaView (or VTK's ``vtkXdmfReader``) opens it.

The XDMF file copies nothing: it points into ``results.h5``. One temporal collection per sender's mesh (the mesh of
the component that sends the data, ``/components/<name>/meshes/<mesh>``), its nodes as vertices, and on them every
exchanged field that component sends (``/fields/<data>``, one window per time step, selected by a hyperslab), with
the initial values (``/initial/<data>``) at the run's start. A field whose rows do not hold one value per node and
component (a sender's substeps) is left out, with a comment in the file saying why.

``python -m cosim.xdmf DIR`` writes it for a run made before runs wrote it.
"""

from __future__ import annotations

import json
import os
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py

from cosim.results import FILE_NAME, Layout

XDMF_NAME = "run.xdmf"
GEOMETRY = {2: "XY", 3: "XYZ"}


def _item(parent: ET.Element, dimensions: tuple[int, ...], text: str, **attributes: str) -> ET.Element:
    item = ET.SubElement(parent, "DataItem", {"Dimensions": " ".join(map(str, dimensions)), **attributes})
    item.text = text
    return item


@dataclass(frozen=True)
class _Dataset:
    """What the XDMF text says of a dataset of ``results.h5``, read from the file once (not at every time step)."""

    path: str
    shape: tuple[int, ...]
    number_type: str
    precision: str

    @classmethod
    def of(cls, dataset: h5py.Dataset) -> _Dataset:
        return cls(f"{FILE_NAME}:/{dataset.name.lstrip('/')}", tuple(dataset.shape),
                   "Int" if dataset.dtype.kind in "iu" else "Float", str(dataset.dtype.itemsize))

    @property
    def ndim(self) -> int:
        return len(self.shape)


def _hdf(parent: ET.Element, dataset: _Dataset, shape: tuple[int, ...] | None = None) -> ET.Element:
    return _item(parent, shape or dataset.shape, dataset.path, Format="HDF", NumberType=dataset.number_type,
                 Precision=dataset.precision)


def _row(parent: ET.Element, dataset: _Dataset, row: int) -> None:
    """Row ``row`` of ``dataset`` (windows first) as a hyperslab."""
    rest = dataset.shape[1:]
    slab = ET.SubElement(parent, "DataItem", {"ItemType": "HyperSlab", "Type": "HyperSlab",
                                              "Dimensions": " ".join(map(str, rest))})
    rank = len(dataset.shape)
    start, stride, count = [row] + [0] * (rank - 1), [1] * rank, [1, *rest]
    _item(slab, (3, rank), " ".join(map(str, start + stride + count)), Format="XML")
    _hdf(slab, dataset)


def _geometry(domain: ET.Element, nodes: _Dataset, name: str) -> None:
    count, dimension = nodes.shape
    if dimension in GEOMETRY:
        _hdf(ET.SubElement(domain, "Geometry", {"Name": name, "GeometryType": GEOMETRY[dimension]}), nodes)
        return
    geometry = ET.SubElement(domain, "Geometry", {"Name": name, "GeometryType": "X_Y_Z"})   # a line: y = z = 0
    _hdf(geometry, nodes, (count,))
    for _ in range(2):
        _item(geometry, (count,), " ".join(["0"] * count), Format="XML", NumberType="Float", Precision="8")


def _attribute(grid: ET.Element, name: str, dataset: _Dataset, row: int | None) -> None:
    shape = dataset.shape[1:] if row is not None else dataset.shape
    kind = "Scalar" if len(shape) == 1 else "Vector"
    attribute = ET.SubElement(grid, "Attribute", {"Name": name, "AttributeType": kind, "Center": "Node"})
    if row is None:
        _hdf(attribute, dataset)
    else:
        _row(attribute, dataset, row)


def _senders(scene: dict[str, Any], file: h5py.File) -> dict[tuple[str, str], list[str]]:
    """(sender, mesh) -> the data it sends that ``results.h5`` holds as fields."""
    meshes: dict[tuple[str, str], list[str]] = {}
    fields = file.get(Layout.fields, {})
    for exchange in scene.get("exchange", []):
        data, sender = exchange["data"], exchange["from"]
        if data not in fields or Layout.component(sender) not in file:
            continue
        variables = json.loads(file[Layout.component(sender)].attrs.get("variables", "[]"))
        mesh = next((v.get("mesh", "") for v in variables if v["name"] == data), "")
        if mesh and f"{Layout.meshes(sender)}/{mesh}" in file:
            names = meshes.setdefault((sender, mesh), [])
            if data not in names:
                names.append(data)
    return meshes


def xdmf_document(results: Path) -> bytes:
    """The XDMF text of the run whose results file is ``results``."""
    with h5py.File(results, "r") as file:
        scene = json.loads(file.attrs["scene_resolved"]) if "scene_resolved" in file.attrs else {}
        start = float(scene.get("time", {}).get("start", 0.0))
        times = file[Layout.window("time")][:]
        root = ET.Element("Xdmf", {"Version": "2.0"})
        domain = ET.SubElement(root, "Domain")
        for (sender, mesh), names in _senders(scene, file).items():
            nodes = _Dataset.of(file[f"{Layout.meshes(sender)}/{mesh}"])
            ET.SubElement(domain, "Topology", {"Name": f"{sender}/{mesh}", "TopologyType": "Polyvertex",
                                               "NumberOfElements": str(nodes.shape[0]), "NodesPerElement": "1"})
            _geometry(domain, nodes, f"{sender}/{mesh}")
            series = ET.SubElement(domain, "Grid", {"Name": f"{sender}/{mesh}", "GridType": "Collection",
                                                    "CollectionType": "Temporal"})
            fields = {}
            for name in names:
                dataset = _Dataset.of(file[Layout.field(name)])
                if dataset.ndim not in (2, 3) or dataset.shape[1] != nodes.shape[0]:
                    series.append(ET.Comment(f" '{name}': rows of shape {dataset.shape[1:]} are not one value per "
                                             f"node of the {nodes.shape[0]} of mesh '{mesh}' (substeps): left out "))
                    continue
                fields[name] = dataset
            initial = {n: _Dataset.of(file[f"{Layout.initial}/{n}"]) for n in fields if f"{Layout.initial}/{n}" in file}
            steps: list[tuple[float, int | None]] = [(start, None)] if initial and len(initial) == len(fields) else []
            steps += [(float(t), window) for window, t in enumerate(times)]
            for time, window in steps:
                grid = ET.SubElement(series, "Grid", {"Name": f"{sender}/{mesh} t={time:.12g}", "GridType": "Uniform"})
                ET.SubElement(grid, "Time", {"Value": repr(time)})
                for kind in ("Topology", "Geometry"):     # the mesh's, once for the whole series
                    ET.SubElement(grid, kind, {"Reference": "XML"}).text = \
                        f'/Xdmf/Domain/{kind}[@Name="{sender}/{mesh}"]'
                for name, dataset in fields.items():
                    if window is None:
                        _attribute(grid, name, initial[name], None)
                    elif window < dataset.shape[0]:
                        _attribute(grid, name, dataset, window)
    ET.indent(root)
    return b'<?xml version="1.0"?>\n<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n' + ET.tostring(root) + b"\n"


def write_xdmf(results: str | Path) -> Path:
    """Write ``run.xdmf`` beside ``results`` (atomically) and return its path."""
    results = Path(results)
    target = results.parent / XDMF_NAME
    partial = target.with_name(f".{XDMF_NAME}.{os.getpid()}")
    partial.write_bytes(xdmf_document(results))
    partial.replace(target)
    return target


def main(argv: list[str] | None = None) -> int:
    """``python -m cosim.xdmf DIR``."""
    from cosim.errors import CosimError
    from cosim.results import RunResults
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m cosim.xdmf RUN_DIR", file=sys.stderr)
        return 2
    try:
        with RunResults(args[0]) as run:
            path = run.path
        print(write_xdmf(path))
    except CosimError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
