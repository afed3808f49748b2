"""The ParaView frames (`frame_NNNN.vti`, `run.pvd`) as VTK itself reads
them (pip `vtk`): geometry, cell order, names and values against the
`.npy` volumes `open_run` places. Skipped where VTK is not installed.

VTK has no reader for `.pvd`, so the collection is parsed as the XML it
is and each file it lists is read by VTK; ParaView's own PVD reader
(`pvpython`, Debian's `python3-paraview`) reads it where installed."""

import json
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import smokelab_xr as sx

vtk = pytest.importorskip("vtkmodules.all", reason="VTK is not installed (pip install vtk)")
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402


def read_vti(path):
    reader = vtk.vtkXMLImageDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    image = reader.GetOutput()
    assert image.GetNumberOfCells() > 0, f"VTK read no cells from {path}"
    return image


def cell_array(image, name):
    """A cell-data array reshaped as smokelab's (nz, ny, nx[, 3])."""
    nx, ny, nz = (n - 1 for n in image.GetDimensions())
    array = image.GetCellData().GetArray(name)
    assert array is not None, f"no cell array {name!r}"
    values = vtk_to_numpy(array)
    return values.reshape((nz, ny, nx) + values.shape[1:])


def pvd_entries(path):
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


def test_vti_frames_hold_the_runs_volumes_where_open_run_puts_them(hot_cold_dir):
    run = sx.open_run(hot_cold_dir)
    vol = run.volumes
    entries = pvd_entries(hot_cold_dir / "run.pvd")
    assert [f for _, f in entries] == ["frame_0001.vti", "frame_0002.vti", "frame_0003.vti"]
    np.testing.assert_allclose([t for t, _ in entries], vol.time, rtol=1e-6)
    for (time, name), step in zip(entries, vol.step.values):
        image = read_vti(hot_cold_dir / name)
        frame = vol.sel(step=step)
        assert image.GetDimensions() == tuple(n + 1 for n in run.grid.dims)
        np.testing.assert_allclose(image.GetSpacing(), [run.grid.cell] * 3, rtol=1e-6)
        names = {image.GetCellData().GetArrayName(i) for i in range(image.GetCellData().GetNumberOfArrays())}
        assert names == {"hot", "cold", "vel"}
        for gas in ("hot", "cold"):
            np.testing.assert_array_equal(cell_array(image, gas), frame[gas].values)
        np.testing.assert_array_equal(cell_array(image, "vel"), frame.vel.values)
        # VTK's own centre of a cell is open_run's coordinate of it.
        i, j, k = 3, 9, 12
        nx, ny = run.grid.dims[:2]
        bounds = image.GetCell(i + nx * (j + ny * k)).GetBounds()
        centre = [(bounds[2 * a] + bounds[2 * a + 1]) / 2 for a in range(3)]
        np.testing.assert_allclose(centre, [frame.x[i], frame.y[j], frame.z[k]], rtol=1e-6)


def test_vti_obstacle_is_negative_inside(slab_dir):
    run = sx.open_run(slab_dir)
    image = read_vti(slab_dir / "frame_0001.vti")
    level = cell_array(image, "obstacle")
    np.testing.assert_array_equal(level, -run.volumes.obstacle.values)
    lo, hi = (np.array(run.manifest["config"][k]) for k in ("slab_min", "slab_max"))
    mid = (lo + hi) / 2
    # VTK locates the slab's centre in a cell whose obstacle value is negative.
    ijk, pcoords = [0, 0, 0], [0.0, 0.0, 0.0]
    assert image.ComputeStructuredCoordinates(list(mid), ijk, pcoords) == 1
    nx, ny = run.grid.dims[:2]
    assert vtk_to_numpy(image.GetCellData().GetArray("obstacle"))[ijk[0] + nx * (ijk[1] + ny * ijk[2])] < 0
    assert float(run.volumes.obstacle.sel(x=mid[0], y=mid[1], z=mid[2], method="nearest")) > 0


PVPYTHON = shutil.which("pvpython")

PVD_SCRIPT = """
import json, sys
from paraview.simple import PVDReader, servermanager
from vtk.util.numpy_support import vtk_to_numpy
reader = PVDReader(FileName=sys.argv[1])
reader.UpdatePipeline()
times = list(reader.TimestepValues)
sums = []
for t in times:
    reader.UpdatePipeline(t)
    image = servermanager.Fetch(reader)
    sums.append(float(vtk_to_numpy(image.GetCellData().GetArray("hot")).astype("float64").sum()))
print("REPORT " + json.dumps({"times": times, "arrays": sorted(reader.CellData.keys()), "hot_sums": sums}))
"""


@pytest.mark.skipif(PVPYTHON is None, reason="ParaView is not installed (apt-get install python3-paraview)")
def test_paraview_reads_run_pvd_as_a_time_series(hot_cold_dir, tmp_path):
    """ParaView's own PVD reader (pvpython) takes run.pvd as one time series
    whose time t shows the frame open_run puts at t."""
    script = tmp_path / "pvd.py"
    script.write_text(PVD_SCRIPT)
    done = subprocess.run(
        [PVPYTHON, "--force-offscreen-rendering", str(script), str(hot_cold_dir / "run.pvd")],
        capture_output=True, text=True, timeout=300,
    )
    lines = [l for l in done.stdout.splitlines() if l.startswith("REPORT ")]
    assert done.returncode == 0 and lines, done.stdout + done.stderr
    report = json.loads(lines[-1][len("REPORT "):])
    vol = sx.open_run(hot_cold_dir).volumes
    assert report["arrays"] == ["cold", "hot", "vel"]
    np.testing.assert_allclose(report["times"], vol.time, rtol=1e-6)
    sums = vol.hot.astype("float64").sum(("x", "y", "z"))
    assert len(set(np.round(sums.values, 6))) == 3  # the frames differ, so a mix-up shows
    np.testing.assert_allclose(report["hot_sums"], sums, rtol=1e-9)
