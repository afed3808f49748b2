"""The Blender recipe, run headless by Blender itself (Debian's `blender`,
or ``$SMOKELAB_BLENDER``) through ``python/examples/blender_import.py``:
the VDB frames import as one sequence with a `density` grid, the default
volume material renders it, and `--up z` stands the run upright. Skipped
where Blender is not installed."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

import smokelab_xr as sx
from conftest import HOT_CENTRE, smokelab

BLENDER = os.environ.get("SMOKELAB_BLENDER") or shutil.which("blender")
SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "blender_import.py"

pytestmark = pytest.mark.skipif(
    BLENDER is None, reason="Blender is not installed (apt-get install blender, or set SMOKELAB_BLENDER)"
)


def blender_report(folder: Path, png: Path) -> dict:
    done = subprocess.run(
        [BLENDER, "-b", "--factory-startup", "--python", str(SCRIPT), "--", str(folder), "--render", str(png)],
        capture_output=True, text=True, timeout=300,
    )
    lines = [l for l in done.stdout.splitlines() if l.startswith("REPORT ")]
    assert done.returncode == 0 and lines, done.stdout + done.stderr
    return json.loads(lines[-1][len("REPORT "):])


@pytest.fixture(scope="module")
def exports(hot_cold_dir, tmp_path_factory):
    """The hot/cold run exported with `density` = the hot gas, z up and y up."""
    out = tmp_path_factory.mktemp("blender")
    for up in ("z", "y"):
        smokelab("export", "vdb", hot_cold_dir, "--up", up, "--density-grid", "hot", "--out", out / up)
    return out


def test_z_up_sequence_imports_upright_and_the_default_material_shows_density(hot_cold_dir, exports, tmp_path):
    run = sx.open_run(hot_cold_dir)
    vol = run.volumes
    report = blender_report(exports / "z", tmp_path / "z.png")
    assert set(report["grids"]) == {"density", "hot", "cold", "vel"} and not report["load_error"]
    assert report["is_sequence"] and report["frames"] == vol.sizes["step"]
    assert report["materials"] == []  # so Blender's default volume material is what renders
    # Blender's box: x as simulated, y = −(simulated z), z = simulated y (up).
    edge = lambda a: [float(vol[a][0]), float(vol[a][-1])]  # noqa: E731
    low, high = report["bbox_low"], report["bbox_high"]
    assert [low[0], high[0]] == pytest.approx(edge("x"), abs=1e-4)
    assert [-high[1], -low[1]] == pytest.approx(edge("z"), abs=1e-4)
    assert [low[2], high[2]] == pytest.approx(edge("y"), abs=1e-4)
    # The hot gas (y ≈ 3 of 10: low in the box) renders in the image's lower half.
    assert report["coverage"] > 0.005
    assert report["height"] < 0.45, report


def test_y_up_files_lie_on_their_side_in_blender(exports, tmp_path):
    """The control: without --up z Blender's z is the simulation's z, and
    the hot gas (at z = 7) renders in the image's upper half."""
    assert HOT_CENTRE[2] > 5 > HOT_CENTRE[1]
    report = blender_report(exports / "y", tmp_path / "y.png")
    assert report["coverage"] > 0.005
    assert report["height"] > 0.55, report


def test_without_a_density_grid_the_default_material_shows_nothing(exports, tmp_path):
    """The control for the material: the same files with `density` removed
    (by OpenVDB) render empty, so the default material reads `density`."""
    from test_openvdb import PYTHON, has_openvdb

    if not has_openvdb():
        pytest.skip(f"OpenVDB's Python module is not importable by {PYTHON}, needed to remove the grid")
    stripped = tmp_path / "stripped"
    stripped.mkdir()
    script = (
        "import sys\ntry:\n import openvdb as vdb\nexcept ImportError:\n import pyopenvdb as vdb\n"
        "for src, dst in zip(sys.argv[1::2], sys.argv[2::2]):\n"
        " grids, meta = vdb.readAll(src)\n"
        " vdb.write(dst, grids=[g for g in grids if g.name != 'density'], metadata=meta)\n"
    )
    pairs = [str(p) for f in sorted((exports / "z").glob("frame_*.vdb")) for p in (f, stripped / f.name)]
    done = subprocess.run([PYTHON, "-I", "-c", script, *pairs], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    report = blender_report(stripped, tmp_path / "stripped.png")
    assert "density" not in report["grids"] and "hot" in report["grids"]
    assert report["coverage"] == 0, report
