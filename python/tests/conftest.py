"""Tiny runs of the real binary, made once per test session in a temp dir.

The binary is ``$SMOKELAB_BIN``, or ``target/release/smokelab`` of the
repository this folder sits in (``cargo build --release`` first).
"""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

#: The hot source's centre in the tiny hot/cold run: off every symmetry
#: plane, so a swapped or flipped axis moves it.
HOT_CENTRE = (2.5, 3.0, 7.0)


def smokelab_bin() -> Path:
    """The smokelab binary the tests run."""
    path = Path(os.environ.get("SMOKELAB_BIN", REPO / "target" / "release" / "smokelab"))
    if not path.is_file():
        pytest.fail(
            f"smokelab binary not found at {path}: run `cargo build --release` in {REPO} "
            f"or set SMOKELAB_BIN",
            pytrace=False,
        )
    return path


def smokelab(*args, cwd=None) -> subprocess.CompletedProcess:
    """Run the binary with ``args``; fail the test with its stderr if it fails."""
    done = subprocess.run(
        [str(smokelab_bin()), *map(str, args)], capture_output=True, text=True, cwd=cwd
    )
    if done.returncode != 0:
        pytest.fail(f"smokelab {' '.join(map(str, args))} exited {done.returncode}:\n{done.stderr}")
    return done


@pytest.fixture(scope="session")
def hot_cold_dir(tmp_path_factory) -> Path:
    """Hot/cold, periodic 16³, 12 steps saved every 4 (frames 4, 8, 12),
    gravity 10 (so the gases move within a few steps), the hot source at
    ``HOT_CENTRE`` (head-on: no offset), finely sampled at 20³, with VDB
    and ParaView frames."""
    out = tmp_path_factory.mktemp("runs") / "hot-cold"
    smokelab(
        "run", "hot-cold", "--res", 16, "--frames", 12, "--save-every", 4,
        "--gravity", 10, "--offset", 0, "--set", f"hot_center={list(HOT_CENTRE)}", "--sample-res", 20,
        "--vdb", "--paraview", "--quiet", "--out", out,
    )
    return out


@pytest.fixture(scope="session")
def closed_dir(tmp_path_factory) -> Path:
    """Hot/cold in a closed box (walls with no normal flow), 16³, 4 steps."""
    out = tmp_path_factory.mktemp("runs") / "closed"
    smokelab(
        "run", "hot-cold", "--box", "closed", "--res", 16, "--frames", 4,
        "--save-every", 2, "--quiet", "--out", out,
    )
    return out


@pytest.fixture(scope="session")
def slab_dir(tmp_path_factory) -> Path:
    """Slab-box (obstacles: the box walls and a slab), 24³, 4 steps, with
    VDB and ParaView frames."""
    out = tmp_path_factory.mktemp("runs") / "slab"
    smokelab(
        "run", "slab-box", "--res", 24, "--set", "wall=0.9", "--frames", 4,
        "--save-every", 2, "--vdb", "--paraview", "--quiet", "--out", out,
    )
    return out
