"""open_sweep on a real sweep of the binary: one dimension per axis, each
cell the gathered value of the point with those axis values (checked
against the point's own run folder), and a folder that is not a gathered
sweep refused with one clear error."""

import numpy as np
import pytest

import smokelab_xr as sx
from conftest import smokelab

SWEEP = """scenario = "hot-cold"
[keys]
frames = 3
save_every = 3
[axes]
res = [10, 12, 14]
density = ["gridded", "gridless"]
"""


def test_a_sweep_opens_with_its_axes_as_dimensions(tmp_path):
    (tmp_path / "sweep.toml").write_text(SWEEP)
    out = tmp_path / "sw"
    smokelab("sweep", tmp_path / "sweep.toml", "--out", out, "--jobs", "2")
    with pytest.raises(sx.NotARunError, match="sweep gather"):
        sx.open_sweep(out)
    smokelab("sweep", "gather", out)
    ds = sx.open_sweep(out)
    assert dict(ds.sizes) == {"res": 3, "density": 2}
    assert list(ds.res.values) == [10, 12, 14]
    assert sorted(ds.density.values) == ["gridded", "gridless"]
    assert (ds.state == "complete").all()
    assert ds.attrs["keys.frames"] == 3
    assert (ds.step == 3).all()
    # Each cell is its own point's run: the folder's manifest and last metrics row.
    for res in (10, 12, 14):
        for density in ("gridded", "gridless"):
            cell = ds.sel(res=res, density=density)
            run = sx.open_run(out / str(cell.folder.values))
            assert run.manifest["config"]["res"] == res
            assert run.manifest["config"]["density"] == density
            last = run.metrics.isel(step=-1)
            np.testing.assert_array_equal(cell.hot_mass.values, last.hot_mass.values)
            np.testing.assert_array_equal(cell.max_u.values, last.max_u.values)
    # More cells resolve the sources better: the hot mass differs along res.
    assert len(set(ds.hot_mass.sel(density="gridded").values.tolist())) == 3


def test_a_run_folder_is_not_a_sweep(hot_cold_dir):
    with pytest.raises(sx.NotARunError, match="no sweep.json"):
        sx.open_sweep(hot_cold_dir)
