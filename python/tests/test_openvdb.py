"""The VDB frames as the OpenVDB library reads them (Debian's
python3-openvdb, run as a separate process by ``openvdb_dump.py``): grid
names, classes, transform and values against the `.npy` volumes that
`open_run` places. Skipped where no interpreter has OpenVDB's module
(``$SMOKELAB_OPENVDB_PYTHON``, default ``/usr/bin/python3``)."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import smokelab_xr as sx
from conftest import smokelab

PYTHON = os.environ.get("SMOKELAB_OPENVDB_PYTHON", "/usr/bin/python3")
DUMP = Path(__file__).with_name("openvdb_dump.py")


def has_openvdb() -> bool:
    probe = "try:\n import openvdb\nexcept ImportError:\n import pyopenvdb"
    try:
        return subprocess.run([PYTHON, "-I", "-c", probe], capture_output=True).returncode == 0
    except OSError:
        return False


pytestmark = pytest.mark.skipif(
    not has_openvdb(),
    reason=f"OpenVDB's Python module is not importable by {PYTHON} "
    f"(apt-get install python3-openvdb, or set SMOKELAB_OPENVDB_PYTHON)",
)


def dump(path: Path, dims, out: Path):
    """``(meta, {grid: array})`` of a VDB file as OpenVDB reads it, each
    array over the index box ``[0, dims)`` reordered to smokelab's
    ``[z][y][x]`` (OpenVDB's copyToArray gives ``[x][y][z]``)."""
    out.mkdir()
    done = subprocess.run([PYTHON, "-I", str(DUMP), str(path), *map(str, dims), str(out)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    meta = json.loads((out / "meta.json").read_text())
    arrays = {}
    for g in meta["grids"]:
        a = np.load(out / f"{g['name']}.npy")
        arrays[g["name"]] = a.transpose(2, 1, 0, 3) if a.ndim == 4 else a.transpose(2, 1, 0)
    return meta, arrays


def by_name(meta):
    return {g["name"]: g for g in meta["grids"]}


def test_hot_cold_frames_as_openvdb_reads_them(hot_cold_dir, tmp_path):
    run = sx.open_run(hot_cold_dir)
    vol = run.volumes
    cell = run.grid.cell
    for n, step in enumerate(vol.step.values, start=1):
        meta, arrays = dump(hot_cold_dir / f"frame_{n:04d}.vdb", run.grid.dims, tmp_path / str(n))
        frame = vol.sel(step=step)
        assert meta["file"]["step"] == step
        assert meta["file"]["time"] == pytest.approx(float(frame.time), rel=1e-6)
        grids = by_name(meta)
        assert set(grids) == {"hot", "cold", "density", "vel"}
        for name in ("hot", "cold", "density"):
            assert (grids[name]["type"], grids[name]["class"]) == ("FloatGrid", "fog volume")
        assert grids["vel"]["type"] == "Vec3SGrid"
        assert grids["vel"]["vector_type"] == "contravariant relative"
        for g in grids.values():
            assert g["voxel_size"] == pytest.approx([cell] * 3, rel=1e-6)
            # Index (i, j, k) is the cell centre open_run puts at x[i], y[j], z[k].
            assert g["world_of_000"] == pytest.approx([float(frame.x[0]), float(frame.y[0]), float(frame.z[0])], rel=1e-6)
            assert g["world_of_123"] == pytest.approx([float(frame.x[1]), float(frame.y[2]), float(frame.z[3])], rel=1e-6)
        # Sparse: leaves whose values are all below 1e-6 of the peak are left
        # out (read as 0); every other value is the .npy's, bit for bit.
        for name, want in [("hot", frame.hot), ("cold", frame.cold), ("density", frame.hot + frame.cold)]:
            peak = float(want.max())
            assert peak > 0
            np.testing.assert_allclose(arrays[name], want.values, rtol=1e-6, atol=1e-6 * peak)
        kept = arrays["hot"] != 0
        np.testing.assert_array_equal(arrays["hot"][kept], frame.hot.values[kept])
        np.testing.assert_allclose(arrays["vel"], frame.vel.values, atol=1e-6 * float(abs(frame.vel).max()))


def test_obstacle_is_a_level_set_negative_inside(slab_dir, tmp_path):
    """`obstacle` is OpenVDB's kind of level set: class `level set`, a
    signed distance negative inside (obstacle.npy negated), active in the
    narrow band |φ| < 3Δx, reading −3Δx deep inside and the +3Δx background
    outside; the slab's configured centre is inside."""
    run = sx.open_run(slab_dir)
    cell = run.grid.cell
    meta, arrays = dump(slab_dir / "frame_0001.vdb", run.grid.dims, tmp_path / "slab")
    grids = by_name(meta)
    assert set(grids) == {"density", "obstacle", "vel"}
    assert (grids["obstacle"]["type"], grids["obstacle"]["class"]) == ("FloatGrid", "level set")
    assert grids["obstacle"]["background"] == pytest.approx(3 * cell, rel=1e-6)
    level = run.volumes.obstacle.values
    band = np.abs(level) < 3 * cell
    assert grids["obstacle"]["active_voxels"] == int(band.sum())
    np.testing.assert_allclose(arrays["obstacle"], np.clip(-level, -3 * cell, 3 * cell), rtol=1e-6, atol=1e-6)
    lo, hi = (np.array(run.manifest["config"][k]) for k in ("slab_min", "slab_max"))
    mid = (lo + hi) / 2
    i, j, k = (int(np.argmin(abs(run.volumes[a].values - mid[n]))) for n, a in enumerate("xyz"))
    assert arrays["obstacle"][k, j, i] < 0
    np.testing.assert_array_equal(arrays["density"], run.volumes.density.sel(step=2).values * (arrays["density"] != 0))


def test_up_z_export_stands_the_run_upright(hot_cold_dir, tmp_path):
    """`export vdb --up z`: in the file's world, z is the simulation's up.
    The hot gas's centroid, computed from OpenVDB's values and transform,
    is the simulation's (x, y, z) centroid rotated to (x, −z, y)."""
    out = tmp_path / "z-up"
    smokelab("export", "vdb", hot_cold_dir, "--up", "z", "--out", out)
    run = sx.open_run(hot_cold_dir)
    nx, ny, nz = run.grid.dims
    frame = run.volumes.isel(step=-1)
    meta, arrays = dump(out / "frame_0003.vdb", (nx, nz, ny), tmp_path / "dump")
    assert meta["file"]["step"] == int(frame.step)
    hot = by_name(meta)["hot"]
    origin, voxel = np.array(hot["world_of_000"]), np.array(hot["voxel_size"])
    assert np.array(hot["world_of_123"]) == pytest.approx(origin + voxel * [1, 2, 3])
    values = arrays["hot"]  # [file z][file y][file x]
    index = np.indices(values.shape)[::-1]  # file x, y, z index of each voxel
    world = [origin[a] + voxel[a] * index[a] for a in range(3)]
    file_centroid = [float((values * w).sum() / values.sum()) for w in world]
    mass = frame.hot.sum()
    x, y, z = (float((frame.hot * frame.hot[d]).sum() / mass) for d in "xyz")
    assert file_centroid == pytest.approx([x, -z, y], abs=1e-3 * run.grid.cell)
