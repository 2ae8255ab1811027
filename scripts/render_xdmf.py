"""Render a run's ``run.xdmf`` with VTK, as ParaView would show it: each sender's mesh at one window, its nodes
coloured by a field; a mesh on a line (the tube's axis) is drawn as the field's profile, warped by it across.

Usage: python -m scripts.render_xdmf RUN_DIR --out PNG [--field NAME] [--time T] [--size W H]
(the docs' picture: ``python -m scripts.render_xdmf runs/getting-started --field pressure --out
docs/img/tube-in-vtk.png`` after the getting-started run). Needs VTK's Python wheel (``pip install vtk``) and
an OpenGL it can render off screen with (EGL or OSMesa, no display needed).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np


def render(run_dir: Path, out: Path, field: str, time: float | None = None, size: tuple[int, int] = (900, 420)) -> Path:
    """Draw ``field`` at ``time`` (default: the last window) from ``run_dir/run.xdmf`` into the PNG ``out``."""
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (the OpenGL back end)
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
    from vtkmodules.vtkFiltersCore import vtkAppendPolyData
    from vtkmodules.vtkFiltersGeneral import vtkWarpScalar
    from vtkmodules.vtkFiltersGeometry import vtkGeometryFilter
    from vtkmodules.vtkIOImage import vtkPNGWriter
    from vtkmodules.vtkIOXdmf2 import vtkXdmfReader
    from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor
    from vtkmodules.vtkRenderingCore import (
        vtkActor,
        vtkPolyDataMapper,
        vtkRenderer,
        vtkRenderWindow,
        vtkTextActor,
        vtkWindowToImageFilter,
    )

    reader = vtkXdmfReader()
    reader.SetFileName(str(run_dir / "run.xdmf"))
    reader.UpdateInformation()
    times = reader.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.TIME_STEPS()) or (0.0,)
    shown = times[-1] if time is None else min(times, key=lambda t: abs(t - time))
    reader.UpdateTimeStep(shown)
    blocks = reader.GetOutputDataObject(0)
    merged = vtkAppendPolyData()
    line = True
    for index in range(blocks.GetNumberOfBlocks()):
        block = blocks.GetBlock(index)
        if block.GetPointData().GetArray(field) is None:
            continue
        surface = vtkGeometryFilter()
        surface.SetInputData(block)
        surface.Update()
        points = np.array([block.GetPoint(i) for i in range(block.GetNumberOfPoints())])
        line = line and bool(np.all(points[:, 1:] == 0.0))
        merged.AddInputData(surface.GetOutput())
    if merged.GetNumberOfInputConnections(0) == 0:
        raise SystemExit(f"error: no mesh of '{run_dir / 'run.xdmf'}' holds the field '{field}'")
    merged.Update()
    data = merged.GetOutput()
    data.GetPointData().SetActiveScalars(field)
    low, high = data.GetPointData().GetArray(field).GetRange()
    source: Any = merged
    if line:                          # the profile: the field's value across the line, scaled to a third of its length
        warp = vtkWarpScalar()
        warp.SetInputConnection(merged.GetOutputPort())
        warp.SetNormal(0.0, 1.0, 0.0)
        warp.UseNormalOn()
        length = data.GetBounds()[1] - data.GetBounds()[0]
        warp.SetScaleFactor(length / 3.0 / max(abs(low), abs(high), 1e-300))
        source = warp
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(source.GetOutputPort())
    mapper.SetScalarRange(low, high)
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray(field)
    actor = vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetPointSize(6)
    actor.GetProperty().SetRenderPointsAsSpheres(True)
    renderer = vtkRenderer()
    renderer.SetBackground(1.0, 1.0, 1.0)
    renderer.AddActor(actor)
    bar = vtkScalarBarActor()
    bar.SetLookupTable(mapper.GetLookupTable())
    bar.SetTitle(field)
    bar.SetNumberOfLabels(4)
    bar.SetLabelFormat("%-#6.3g")
    bar.SetWidth(0.08)
    for text in (bar.GetTitleTextProperty(), bar.GetLabelTextProperty()):
        text.SetColor(0.1, 0.1, 0.1)
    renderer.AddViewProp(bar)
    title = vtkTextActor()
    across = ", drawn across the line by its value" if line else ""
    title.SetInput(f"{run_dir.name}/run.xdmf in VTK: {field} at t = {shown:g}{across}")
    title.GetTextProperty().SetColor(0.1, 0.1, 0.1)
    title.GetTextProperty().SetFontSize(18)
    title.SetPosition(12, size[1] - 30)
    renderer.AddViewProp(title)
    window = vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.AddRenderer(renderer)
    window.SetSize(*size)
    camera = renderer.GetActiveCamera()          # looking down z at the x-y plane
    camera.SetPosition(0.0, 0.0, 1.0)
    camera.SetFocalPoint(0.0, 0.0, 0.0)
    camera.SetViewUp(0.0, 1.0, 0.0)
    renderer.ResetCamera()
    camera.Zoom(0.85)
    window.Render()
    image = vtkWindowToImageFilter()
    image.SetInput(window)
    image.Update()
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = vtkPNGWriter()
    writer.SetFileName(str(out))
    writer.SetInputConnection(image.GetOutputPort())
    writer.Write()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--field", required=True, help="an exchanged field, as results.h5's /fields names it")
    parser.add_argument("--time", type=float, help="the window nearest this time (default: the last)")
    parser.add_argument("--size", type=int, nargs=2, default=(900, 420), metavar=("W", "H"))
    args = parser.parse_args(argv)
    if not (args.run_dir / "run.xdmf").is_file():
        print(f"error: '{args.run_dir / 'run.xdmf'}' does not exist", file=sys.stderr)
        return 2
    print(f"wrote {render(args.run_dir, args.out, args.field, args.time, tuple(args.size))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
