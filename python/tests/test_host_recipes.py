"""The host recipes of the book's hosts page, run by the hosts themselves:
``python/examples/blender_scene.py`` in Blender (Debian's ``blender``, or
``$SMOKELAB_BLENDER``) and ``python/examples/paraview_views.py`` in
ParaView's ``pvbatch`` under ``xvfb-run`` (Debian's ``paraview`` and
``xvfb``). Each renders images whose share of non-background pixels, and
the colours and surfaces in them, are asserted. Skipped where the host is
not installed."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import smokelab

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
BLENDER = os.environ.get("SMOKELAB_BLENDER") or shutil.which("blender")
PVBATCH = shutil.which("pvbatch")
XVFB_RUN = shutil.which("xvfb-run")

needs_blender = pytest.mark.skipif(
    BLENDER is None, reason="Blender is not installed (apt-get install blender, or set SMOKELAB_BLENDER)"
)
needs_paraview = pytest.mark.skipif(
    PVBATCH is None or XVFB_RUN is None,
    reason="ParaView's pvbatch under xvfb-run is not installed (apt-get install paraview xvfb xauth)",
)


def report_of(command) -> dict:
    """Run a host on an example script; the ``REPORT {json}`` it prints."""
    done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    lines = [l for l in done.stdout.splitlines() if l.startswith("REPORT ")]
    assert done.returncode == 0 and lines, done.stdout[-3000:] + done.stderr[-3000:]
    return json.loads(lines[-1][len("REPORT "):])


def blender_scene(vdb: Path, png: Path) -> dict:
    return report_of([
        BLENDER, "-b", "--factory-startup", "--python", str(EXAMPLES / "blender_scene.py"), "--",
        str(vdb), "--render", str(png), "--size", "160x120", "--samples", "8",
    ])


def z_up(run: Path, out: Path) -> Path:
    smokelab("export", "vdb", run, "--up", "z", "--out", out)
    return out


@needs_blender
def test_blender_scene_shows_hot_red_and_cold_blue(hot_cold_dir, tmp_path):
    """The two-colour material: the gases render in red and in blue, where
    the default material renders grey (the control: the slab-box scene
    below has neither reddish nor bluish pixels)."""
    report = blender_scene(z_up(hot_cold_dir, tmp_path / "vdb"), tmp_path / "scene.png")
    assert report["material"] == "hot/cold" and report["frame"] == report["frames"] == 3
    assert report["shown"] > 0.02, report
    assert report["reddish"] > 0.01 and report["bluish"] > 0.01, report
    assert (tmp_path / "scene.png").stat().st_size > 0


@needs_blender
def test_blender_scene_puts_the_obstacle_mesh_where_the_obstacles_are(slab_dir, tmp_path):
    """The obstacle mesh: a vertical ray down the box's middle crosses the
    top wall's inside, the slab's top and bottom and the bottom wall's
    inside at the heights slab-box puts them (wall 0.9, slab y 5.5 … 6.3),
    to a hundredth of a cell; and with the front wall cut away the render
    shows the inside."""
    report = blender_scene(z_up(slab_dir, tmp_path / "vdb"), tmp_path / "scene.png")
    assert report["material"] == "default" and report["obstacle_vertices"] > 100
    cell = 10.0 / 24
    inner = [h for h in report["obstacle_heights"] if 0.5 < h < 9.5]
    assert inner == pytest.approx([9.1, 6.3, 5.5, 0.9], abs=0.01 * cell), report["obstacle_heights"]
    assert report["shown"] > 0.5, report
    assert report["reddish"] == report["bluish"] == 0, report


@needs_paraview
def test_paraview_views_show_the_slice_the_obstacle_and_the_volume(slab_dir, tmp_path):
    """The three ParaView views of the slab-box run: each image shows data
    (not the bare background), and the obstacle view exists because the
    run has obstacles."""
    report = report_of([
        XVFB_RUN, "-a", PVBATCH, str(EXAMPLES / "paraview_views.py"), str(slab_dir / "run.pvd"),
        "--out", str(tmp_path / "views"), "--size", "200x150",
    ])
    assert report["arrays"] == ["density", "obstacle", "vel"] and report["gas"] == "density"
    assert set(report["shown"]) == {"slice", "volume", "obstacle"}
    # The slice fills the box's square in the view; the obstacle view adds
    # the walls around it; the volume shows only the gas.
    assert report["shown"]["slice"] > 0.2, report
    assert report["shown"]["obstacle"] > report["shown"]["slice"] * 0.5, report
    assert 0.002 < report["shown"]["volume"] < report["shown"]["slice"], report
    for name in report["shown"]:
        assert (tmp_path / "views" / f"{name}.png").stat().st_size > 0
