"""The ParaView recipe as a script: a smokelab run's ``run.pvd`` as a slice,
the obstacles' surface and a volume rendering, each saved as a PNG.

    smokelab run slab-box --paraview --out runs/slab
    xvfb-run pvbatch paraview_views.py runs/slab/run.pvd --out views/

Options: ``--gas NAME`` (default: the first gas in the file), ``--size WxH``
(default 640x480). Writes ``slice.png``, ``obstacle.png`` (runs with
obstacles) and ``volume.png`` into ``--out`` at the last time step; the
same steps in the GUI are the functions below, one filter each. Prints
one line ``REPORT {json}``: the arrays, the time shown and, per image, the
share of pixels that differ from the background.
"""

import argparse
import json
from pathlib import Path

from paraview.simple import (
    CellDatatoPointData,
    ColorBy,
    Contour,
    CreateView,
    Delete,
    GetAnimationScene,
    GetColorTransferFunction,
    Hide,
    PVDReader,
    ResetCamera,
    SaveScreenshot,
    Show,
    Slice,
)
from vtkmodules.vtkIOImage import vtkPNGReader
from vtkmodules.util.numpy_support import vtk_to_numpy

#: The views' background; a pixel that differs from it shows data.
BACKGROUND = [0.1, 0.1, 0.12]


def new_view(size):
    """A render view of ``size`` pixels on the background, looking along −z
    (the simulation is y up)."""
    view = CreateView("RenderView")
    view.ViewSize = list(size)
    view.OrientationAxesVisibility = 0
    view.UseColorPaletteForBackground = 0
    view.Background = BACKGROUND
    view.CameraPosition = [0.0, 0.0, 1.0]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [0.0, 1.0, 0.0]
    return view


# ANCHOR: slice
def slice_view(reader, gas, size):
    """*Slice* through the middle of the box, normal z, coloured by ``gas``."""
    view = new_view(size)
    cut = Slice(Input=reader)
    cut.SliceType = "Plane"
    cut.SliceType.Origin = centre(reader)
    cut.SliceType.Normal = [0.0, 0.0, 1.0]
    display = Show(cut, view)
    ColorBy(display, ("CELLS", gas))
    display.RescaleTransferFunctionToDataRange(True, False)
    ResetCamera(view)
    return view
# ANCHOR_END: slice


# ANCHOR: obstacle
def obstacle_view(reader, gas, size):
    """The obstacles' surface: *Cell Data to Point Data* first (a contour
    of the cell data comes out distorted), then a *Contour* of
    ``obstacle`` at 0, with the slice of ``gas`` behind it."""
    view = slice_view(reader, gas, size)
    points = CellDatatoPointData(Input=reader)
    surface = Contour(Input=points)
    surface.ContourBy = ["POINTS", "obstacle"]
    surface.Isosurfaces = [0.0]
    display = Show(surface, view)
    ColorBy(display, None)
    display.Opacity = 0.35
    view.CameraPosition = [1.0, 0.6, 1.6]
    ResetCamera(view)
    return view
# ANCHOR_END: obstacle


# ANCHOR: volume
def volume_view(reader, gas, size):
    """A *Volume* representation of ``gas``."""
    view = new_view(size)
    display = Show(reader, view)
    display.SetRepresentationType("Volume")
    ColorBy(display, ("CELLS", gas))
    display.RescaleTransferFunctionToDataRange(True, False)
    GetColorTransferFunction(gas).ApplyPreset("Black-Body Radiation", True)
    ResetCamera(view)
    return view
# ANCHOR_END: volume


def centre(reader):
    """The centre of the data's bounds."""
    low_high = reader.GetDataInformation().GetBounds()
    return [(low_high[2 * a] + low_high[2 * a + 1]) / 2 for a in range(3)]


def shown(path: Path) -> float:
    """The share of the PNG's pixels that differ from the background."""
    png = vtkPNGReader()
    png.SetFileName(str(path))
    png.Update()
    image = png.GetOutput()
    rgb = vtk_to_numpy(image.GetPointData().GetScalars())[:, :3] / 255.0
    return float((abs(rgb - BACKGROUND).max(axis=1) > 0.04).mean())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pvd", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--gas")
    parser.add_argument("--size", default="640x480")
    args = parser.parse_args()
    size = [int(n) for n in args.size.split("x")]
    reader = PVDReader(FileName=str(args.pvd))
    scene = GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.AnimationTime = reader.TimestepValues[-1]
    reader.UpdatePipeline(reader.TimestepValues[-1])
    arrays = sorted(reader.CellData.keys())
    gas = args.gas or next(a for a in arrays if a not in ("vel", "obstacle"))
    args.out.mkdir(parents=True, exist_ok=True)
    views = {"slice": slice_view, "volume": volume_view}
    if "obstacle" in arrays:
        views["obstacle"] = obstacle_view
    report = {"arrays": arrays, "gas": gas, "time": reader.TimestepValues[-1], "shown": {}}
    for name, make in views.items():
        view = make(reader, gas, size)
        path = args.out / f"{name}.png"
        SaveScreenshot(str(path), view, ImageResolution=size)
        report["shown"][name] = shown(path)
        Delete(view)
    print("REPORT " + json.dumps(report))


if __name__ == "__main__":
    main()
