"""open_run on real runs of the binary: the coordinates put every sample
where the solver had it (checked by physics and by the solver's own
face-to-centre average, not by restating the formulas), and bad folders
give one clear error."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import smokelab_xr as sx
from conftest import HOT_CENTRE, smokelab


def centroid(field, dims=("x", "y", "z")):
    """The density-weighted mean position of ``field`` along each of ``dims``."""
    mass = field.sum(("x", "y", "z"))
    return [float((field * field[d]).sum(("x", "y", "z")) / mass) for d in dims]


def test_the_hot_gas_sits_at_its_source_and_rises_along_y(hot_cold_dir):
    """Labelled by the coordinates alone, the hot gas is centred on the
    source placed at (2.5, 3, 7) in x and z and moves towards +y (up), the
    cold gas (source mirrored through y = L/2) towards −y. A swapped or
    flipped axis, or a half-cell shift, fails this."""
    run = sx.open_run(hot_cold_dir)
    vol = run.volumes
    cell = run.grid.cell
    first = centroid(vol.hot.isel(step=0))
    last = centroid(vol.hot.isel(step=-1))
    assert abs(first[0] - HOT_CENTRE[0]) < 0.1 * cell, first
    assert abs(first[2] - HOT_CENTRE[2]) < 0.1 * cell, first
    assert abs(first[1] - HOT_CENTRE[1]) < cell, first  # buoyancy has acted for 4 steps
    assert last[1] > first[1] + 0.05 * cell, (first, last)
    cold_first, cold_last = (centroid(vol.cold.isel(step=s)) for s in (0, -1))
    size = run.grid.size[1]
    assert abs(cold_first[1] - (size - first[1])) < 1e-3 * cell, (cold_first, first)
    assert cold_last[1] < cold_first[1] - 0.05 * cell, (cold_first, cold_last)


def test_velocity_points_up_where_the_hot_gas_is(hot_cold_dir):
    """The staggered v at the hot source's centre (read by position) is
    upward, w and u there are much smaller (the head-on source is
    symmetric about its own vertical axis)."""
    vol = sx.open_run(hot_cold_dir).volumes.isel(step=-1)
    x, y, z = HOT_CENTRE
    v = float(vol.v.sel(x=x, y_face=y, z=z, method="nearest"))
    u = float(vol.u.sel(x_face=x, y=y, z=z, method="nearest"))
    w = float(vol.w.sel(x=x, y=y, z_face=z, method="nearest"))
    assert v > 0 and abs(u) < 0.2 * v and abs(w) < 0.2 * v, (u, v, w)


@pytest.mark.parametrize("fixture", ["closed_dir", "hot_cold_dir"])
def test_the_faces_half_a_cell_either_side_average_to_the_solvers_cell_velocity(fixture, request):
    """For each cell, the two faces found by position at its centre ∓ Δx/2
    (to within 0.1 % of a cell) average to the solver's own cell-centred
    `vel` — which holds only if x_face, y_face, z_face sit where the solver
    had the faces. In the periodic box the last cell's high face is face 0,
    so only the cells with both faces stored are compared there."""
    run = sx.open_run(request.getfixturevalue(fixture))
    vol = run.volumes.isel(step=-1)
    cell = run.grid.cell
    closed = run.grid.boundary == "closed"
    for name, axis in [("u", "x"), ("v", "y"), ("w", "z")]:
        face, dim = vol[name], f"{axis}_face"
        n = run.grid.dims["xyz".index(axis)]
        assert face.sizes[dim] == (n + 1 if closed else n)
        centres = vol[axis].values if closed else vol[axis].values[:-1]
        low, high = (
            face.sel({dim: centres + side * cell / 2}, method="nearest", tolerance=1e-3 * cell)
            .drop_vars(dim)
            .rename({dim: axis})
            for side in (-1, 1)
        )
        mean = ((low + high) / 2).assign_coords({axis: centres})
        cell_velocity = vol.vel.sel(component=axis, drop=True).sel({axis: centres})
        scale = float(abs(cell_velocity).max())
        assert scale > 0
        np.testing.assert_allclose(mean.transpose(*cell_velocity.dims), cell_velocity, atol=1e-6 * scale)


def test_closed_box_walls_and_divergence_by_coordinates(closed_dir):
    """In the closed box the wall faces are exactly zero, and the compact
    divergence Σ ∂u_a/∂a, computed by differencing each component along its
    own face dim, is round-off against |u|/Δx."""
    run = sx.open_run(closed_dir)
    vol = run.volumes.isel(step=-1)
    cell = run.grid.cell
    for name, axis in [("u", "x"), ("v", "y"), ("w", "z")]:
        face = vol[name]
        dim = f"{axis}_face"
        assert float(abs(face.isel({dim: [0, -1]})).max()) == 0.0
    div = sum(
        vol[name].diff(f"{axis}_face").rename({f"{axis}_face": axis}).assign_coords({axis: vol[axis]})
        for name, axis in [("u", "x"), ("v", "y"), ("w", "z")]
    ) / cell
    speed = float(abs(vol.vel).max()) / cell
    assert float(abs(div).max()) < 1e-4 * speed, (float(abs(div).max()), speed)


def test_coordinates_and_time_agree_with_manifest_and_metrics(hot_cold_dir):
    run = sx.open_run(hot_cold_dir)
    vol, metrics = run.volumes, run.metrics
    grid = run.manifest["extra"]["grid"]
    dt = run.manifest["config"]["dt"]
    assert list(vol.step.values) == [4, 8, 12]
    assert list(metrics.step.values) == list(range(1, 13))
    np.testing.assert_allclose(vol.time, vol.step * dt, rtol=1e-6)
    np.testing.assert_array_equal(vol.time, metrics.time.sel(step=vol.step))
    assert vol.hot.dims == ("step", "z", "y", "x")
    assert vol.vel.dims == ("step", "z", "y", "x", "component")
    np.testing.assert_allclose(vol.x[0] - vol.x_face[0], grid["cell"] / 2, rtol=1e-6)
    np.testing.assert_allclose(vol.x_face[0], grid["origin"][0])
    assert vol.attrs["config.dt"] == dt
    assert vol.attrs["status"] == "complete" and metrics.attrs == vol.attrs
    assert vol.attrs["extra.gases"] == ["hot", "cold"]
    assert float(metrics.div_rms.max()) < 1e-6


def test_coordinates_are_the_exact_centres_so_sel_finds_them(tmp_path):
    """smokelab's box is f32, so a manifest records the cell 0.2 as
    0.20000000298023224; the coordinates are the f64 of the exact centres
    and faces of the box the run was given, so selecting by the position a
    user types finds the sample (it raised KeyError at 0.50000001)."""
    f32 = lambda v: float(np.float32(v))  # noqa: E731
    grid = sx.Grid.from_record({"origin": [0.0, -1.0, f32(0.1)], "cell": f32(0.2), "dims": [50, 10, 5]})
    assert grid.cell == 0.2 and grid.origin == (0.0, -1.0, 0.1)
    assert list(grid.centres("x")[:4]) == [0.1, 0.3, 0.5, 0.7] and grid.centres("x")[49] == 9.9
    assert list(grid.faces("y", 4)) == [-1.0, -0.8, -0.6, -0.4]
    assert list(grid.centres("z")) == [0.2, 0.4, 0.6, 0.8, 1.0]
    assert list(grid.fine_centres("x", (5, 10, 100))[:3]) == [0.05, 0.15, 0.25]
    # A value that is not an f32 is kept as it is.
    assert sx.Grid.from_record({"origin": [0.1, 0, 0], "cell": 0.3, "dims": [2, 2, 2]}).cell == 0.3
    # End to end: the hot/cold default box, 50 cells of 0.2.
    out = tmp_path / "run"
    smokelab("run", "hot-cold", "--frames", 1, "--save-every", 1, "--quiet", "--out", out)
    vol = sx.open_run(out).volumes
    assert float(vol.x.sel(x=0.5)) == 0.5 and float(vol.y_face.sel(y_face=4.8)) == 4.8
    assert vol.hot.sel(step=1, x=0.5, y=4.9, z=7.1).shape == ()


def test_a_run_without_its_volumes_warns(hot_cold_dir, tmp_path):
    """A committed results/ run folder keeps its manifest and metrics but no
    volumes: its empty Dataset comes with a warning saying why."""
    copy = tmp_path / "run"
    shutil.copytree(hot_cold_dir, copy)
    for f in copy.glob("*.npy"):
        f.unlink()
    with pytest.warns(UserWarning, match=r"holds no saved volumes"):
        assert sx.open_run(copy).volumes.sizes == {}


def test_fine_samples_lie_on_their_own_centres(hot_cold_dir):
    """--sample-res 20: the fine grid's coordinates cover the same box and
    put the same gas at the same centroid as the 16³ one."""
    vol = sx.open_run(hot_cold_dir).volumes.isel(step=-1)
    assert vol.hot_fine.dims == ("z_fine", "y_fine", "x_fine")
    assert vol.hot_fine.shape == (20, 20, 20)
    np.testing.assert_allclose(vol.x_fine[[0, -1]], [0.25, 9.75])
    fine = vol.hot_fine.rename(x_fine="x", y_fine="y", z_fine="z")
    np.testing.assert_allclose(centroid(fine), centroid(vol.hot), atol=0.1)


def test_obstacle_is_positive_inside_the_slab_it_was_configured_as(slab_dir):
    """The level set, read by position, is positive at the centre of the
    configured slab and negative in the fluid below it."""
    run = sx.open_run(slab_dir)
    lo, hi = (np.array(run.manifest["config"][k]) for k in ("slab_min", "slab_max"))
    mid = (lo + hi) / 2
    level = run.volumes.obstacle
    assert level.dims == ("z", "y", "x")
    assert float(level.sel(x=mid[0], y=mid[1], z=mid[2], method="nearest")) > 0
    assert float(level.sel(x=mid[0], y=lo[1] - 2, z=mid[2], method="nearest")) < 0
    assert run.volumes.density.dims == ("step", "z", "y", "x")


def test_open_volumes_selects_steps_and_names_a_missing_one(hot_cold_dir):
    run = sx.open_run(hot_cold_dir)
    assert list(run.open_volumes(steps=[8]).step.values) == [8]
    with pytest.raises(sx.NotARunError, match=r"no saved frame at step 3; the saved steps are 4, 8, 12"):
        run.open_volumes(steps=[3])


def test_experiment_folder_has_tables_and_runs(tmp_path):
    """An experiment's folder (06-3 at smoke size): its own CSVs as tables,
    its runs as sub-runs that open like any run."""
    out = tmp_path / "06-3"
    smokelab("experiment", "06-3", "--smoke", "--out", out)
    run = sx.open_run(out)
    assert run.tables["summary"].sizes["row"] > 0
    assert set(run.runs) >= {"gridded", "gridless", "selma"}
    sub = run.runs["gridless"]
    assert sub.volumes.hot.dims == ("step", "z", "y", "x")
    assert sub.metrics.sizes["step"] == sub.manifest["config"]["frames"]


def test_a_folder_of_runs_without_a_manifest_opens_as_its_runs(hot_cold_dir, tmp_path):
    """As results/06-6: an experiment's data.csv and run subfolders, no
    manifest of its own."""
    (tmp_path / "hot-cold").symlink_to(hot_cold_dir)
    (tmp_path / "data.csv").write_text("a,b\n1,2\n")
    run = sx.open_run(tmp_path)
    assert run.manifest == {} and list(run.runs) == ["hot-cold"]
    assert int(run.tables["data"].b.sel(row=0)) == 2
    assert run.volumes.sizes == {} and run.metrics.sizes == {}
    assert run.runs["hot-cold"].volumes.sizes["step"] == 3


def test_a_frame_missing_a_file_is_left_out_with_a_warning(hot_cold_dir, tmp_path):
    copy = tmp_path / "run"
    shutil.copytree(hot_cold_dir, copy)
    (copy / "cold_0012.npy").unlink()
    with pytest.warns(UserWarning, match=r"step 12 lacks cold_0012.npy"):
        assert sx.open_run(copy).steps == [4, 8]


def write(path, text):
    """Write ``text`` to ``path``; return the folder it is in."""
    path.write_text(text)
    return path.parent


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda d: d / "missing", r"missing does not exist"),
        (lambda d: write(d / "file", "x") / "file", r"file is not a folder"),
        (lambda d: d, r"has no manifest.json and no subfolder with one, so it is not a smokelab run"),
        (lambda d: write(d / "manifest.json", "{"), r"manifest.json cannot be read as JSON"),
        (lambda d: write(d / "manifest.json", "[1]"), r"is not a smokelab manifest"),
    ],
)
def test_not_a_run_is_one_clear_error(tmp_path, make, message):
    with pytest.raises(sx.NotARunError, match=message):
        sx.open_run(make(tmp_path))


def test_an_array_of_the_wrong_shape_is_named(hot_cold_dir, tmp_path):
    copy = tmp_path / "run"
    shutil.copytree(hot_cold_dir, copy)
    np.save(copy / "hot_0008.npy", np.zeros((16, 16, 15), np.float32))
    with pytest.raises(sx.NotARunError, match=r"hot_0008.npy has shape \(16, 16, 15\), hot_0004.npy has"):
        sx.open_run(copy).volumes
    np.save(copy / "hot_0004.npy", np.zeros((16, 16, 15), np.float32))
    np.save(copy / "hot_0012.npy", np.zeros((16, 16, 15), np.float32))
    with pytest.raises(sx.NotARunError, match=r"hot_0004.npy has shape \(16, 16, 15\); the manifest's grid"):
        sx.open_run(copy).volumes


def test_command_line_prints_a_run_and_refuses_a_non_run(hot_cold_dir, tmp_path):
    ok = subprocess.run([sys.executable, "-m", "smokelab_xr", str(hot_cold_dir)], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    assert "x_face" in ok.stdout and "div_rms" in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "smokelab_xr", str(tmp_path)], capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.startswith("error: ") and "Traceback" not in bad.stderr
    assert str(tmp_path) in bad.stderr


def test_manifest_attrs_are_flat_and_simple():
    attrs = sx.flatten_manifest(
        {"config": {"dt": 0.05, "map_res": None, "force": False}, "extra": {"gases": ["a"], "renders": [{"n": 1}]}}
    )
    assert attrs == {"config.dt": 0.05, "config.force": 0, "extra.gases": ["a"], "extra.renders": json.dumps([{"n": 1}])}


def test_the_example_script_runs_on_a_run(hot_cold_dir):
    """python/examples/analyse_run.py, the README's example, prints a line
    per saved frame with the hot gas rising."""
    script = Path(__file__).resolve().parents[1] / "examples" / "analyse_run.py"
    done = subprocess.run([sys.executable, str(script), str(hot_cold_dir)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines()[1:]]
    assert len(rows) == 3 and all(float(r[4]) > 0 for r in rows[1:]), done.stdout
