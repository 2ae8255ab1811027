"""Reading a run's run.xdmf as ParaView does (VTK's vtkXdmfReader), and holding it against results.h5."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cosim.results import RunResults
from cosim.xdmf import XDMF_NAME


def read_xdmf(path: Path) -> dict[float, dict[str, tuple[np.ndarray, dict[str, np.ndarray]]]]:
    """time -> block name -> (points, point data) as VTK's XDMF reader gives them (skips where VTK is missing)."""
    xdmf = pytest.importorskip("vtkmodules.vtkIOXdmf2", reason="VTK's Python wheel (pip install vtk) reads XDMF")
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

    reader = xdmf.vtkXdmfReader()
    reader.SetFileName(str(path))
    reader.UpdateInformation()
    times = reader.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.TIME_STEPS()) or ()
    series = {}
    for time in times:
        reader.UpdateTimeStep(time)
        blocks = reader.GetOutputDataObject(0)
        step = {}
        for index in range(blocks.GetNumberOfBlocks()):
            block = blocks.GetBlock(index)
            name = blocks.GetMetaData(index).Get(blocks.NAME())
            data = block.GetPointData()
            step[name] = (vtk_to_numpy(block.GetPoints().GetData()).copy(),
                          {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i)).copy()
                           for i in range(data.GetNumberOfArrays())})
        series[float(time)] = step
    return series


def padded(values: np.ndarray) -> np.ndarray:
    """Coordinates or vectors as VTK holds them: three columns, zeros after the given ones."""
    values = values.reshape(len(values), -1)
    return np.hstack([values, np.zeros((len(values), 3 - values.shape[1]))]) if values.shape[1] < 3 else values


def assert_xdmf_holds_the_run(run_dir: Path) -> int:
    """Every field VTK reads from ``run_dir/run.xdmf`` equals ``results.h5``'s at every time, on its sender's mesh
    nodes; returns the number of (time, field) pairs compared."""
    series = read_xdmf(run_dir / XDMF_NAME)
    with RunResults(run_dir) as run:
        fields, initial, times = run.fields(), run.initial(), run.windows.time
        meshes = {f"{name}/{mesh}": nodes for name in run.component_names()
                  for mesh, nodes in run.component(name).meshes.items()}
    assert len(series) in (len(times), len(times) + 1), (sorted(series), times)
    compared = 0
    for time, step in series.items():
        window = int(np.argmin(abs(times - time))) if len(times) else -1
        at_start = len(series) == len(times) + 1 and time == min(series)
        for block, (points, data) in step.items():
            np.testing.assert_array_equal(points, padded(meshes[block]))
            for name, values in data.items():
                expected = initial[name] if at_start else fields[name][window]
                np.testing.assert_array_equal(values.reshape(len(points), -1), padded(expected)
                                              if expected.ndim == 2 else expected.reshape(len(points), -1))
                compared += 1
    assert compared, f"'{run_dir / XDMF_NAME}' holds no field"
    return compared
