"""A smokelab run folder (or a ``results/<id>/`` folder) as xarray Datasets.

What a folder holds and what it becomes (see ``open_run``):

==========================  ====================================================
file                        in the ``Run``
==========================  ====================================================
``manifest.json``           ``run.manifest`` (a dict) and, flattened, the
                            ``attrs`` of every Dataset
``<gas>_NNNN.npy``          ``run.volumes[gas]``: dims ``(step, z, y, x)``,
                            cell centres
``<gas>_fine_NNNN.npy``     ``run.volumes[gas + "_fine"]``: dims
                            ``(step, z_fine, y_fine, x_fine)``
``u_NNNN.npy``              ``run.volumes.u``: dims ``(step, z, y, x_face)``
``v_NNNN.npy``              ``run.volumes.v``: dims ``(step, z, y_face, x)``
``w_NNNN.npy``              ``run.volumes.w``: dims ``(step, z_face, y, x)``
``vel_NNNN.npy``            ``run.volumes.vel``: dims ``(step, z, y, x,
                            component)``, the velocity averaged to the cell
                            centres, ``component`` = ``"x", "y", "z"``
``obstacle.npy``            ``run.volumes.obstacle``: dims ``(z, y, x)``, the
                            obstacles' level set, **positive inside**
``metrics.csv``             ``run.metrics``: one variable per column, dim
                            ``step``, coordinate ``time``
any other ``*.csv``         ``run.tables[name]``: dim ``row`` (an
                            experiment's ``data.csv`` is ``tables["data"]``)
a subfolder with a          ``run.runs[name]``, a ``Run`` itself (an
``manifest.json``           experiment's runs, e.g. ``06-3/gridless``)
==========================  ====================================================

``NNNN`` is the step: frame N is the state after N steps, at time ``N Δt``.
"""

from __future__ import annotations

import json
import re
import warnings
from functools import cached_property
from pathlib import Path
from typing import Iterable, Optional

import numpy as np
import pandas as pd
import xarray as xr

from .grid import AXES, Grid

#: A saved frame's file: ``<name>_NNNN.npy`` (the step, four digits or more).
FRAME_FILE = re.compile(r"^(?P<name>.+)_(?P<step>\d{4,})\.npy$")

#: The staggered velocity components and the axis each one's faces lie across.
FACE_AXIS = {"u": "x", "v": "y", "w": "z"}


class NotARunError(ValueError):
    """The path is not a folder smokelab wrote, or its files disagree with
    its manifest; the message names the path and what was expected."""


def open_run(path) -> "Run":
    """Open a run folder (``smokelab run --out DIR``) or an experiment's
    ``results/<id>/`` folder.

    Only ``manifest.json`` is read now; volumes, metrics and tables are read
    on first use (``run.volumes`` loads every saved frame into memory; use
    ``run.open_volumes(steps=[...])`` for a few).

    A folder without ``manifest.json`` whose subfolders have one (an
    experiment that writes none of its own, or ``results/``) opens with an
    empty manifest, its runs in ``run.runs``.

    Raises ``NotARunError`` (a ``ValueError``) with a message naming the path
    if it is missing, not a folder, has an unreadable ``manifest.json``, or
    has none and no subfolder with one.

    >>> run = open_run("runs/hot-cold-1700000000")      # doctest: +SKIP
    >>> run.volumes.hot.sel(step=100).mean("x")         # doctest: +SKIP
    """
    return Run(Path(path))


class Run:
    """One folder smokelab wrote. See the module documentation for what each
    file becomes; ``path`` is the folder and ``manifest`` its manifest."""

    def __init__(self, path: Path):
        self.path = path
        self.manifest = _read_manifest(path)

    def __repr__(self) -> str:
        status = self.manifest.get("status", f"no manifest, {len(self.runs)} runs")
        return f"<smokelab run {self.path} ({status})>"

    @cached_property
    def attrs(self) -> dict:
        """The manifest flattened to ``attrs`` (see ``flatten_manifest``)."""
        return flatten_manifest(self.manifest)

    @cached_property
    def grid(self) -> Optional[Grid]:
        """The grid of the manifest's ``extra.grid``; ``None`` if it has none
        (an experiment's summary folder)."""
        extra = self.manifest.get("extra")
        record = extra.get("grid") if isinstance(extra, dict) else None
        if record is None:
            return None
        try:
            return Grid.from_record(record)
        except ValueError as e:
            raise NotARunError(f"{self.path / 'manifest.json'}: {e}") from None

    @cached_property
    def gases(self) -> list:
        """The gases in the run's order (``extra.gases``), or ``[]``."""
        extra = self.manifest.get("extra")
        return list(extra.get("gases", [])) if isinstance(extra, dict) else []

    @cached_property
    def steps(self) -> list:
        """The steps with a saved frame: those for which every frame volume
        the folder holds exists (a frame missing some file, as a killed run
        may leave, is left out with a warning)."""
        return _complete_steps(self.path)

    @cached_property
    def volumes(self) -> xr.Dataset:
        """Every saved frame's volumes (see the module documentation)."""
        return self.open_volumes()

    def open_volumes(self, steps: Optional[Iterable[int]] = None) -> xr.Dataset:
        """The volumes of the saved frames ``steps`` (default: all), as one
        Dataset with cell-centre (``x``, ``y``, ``z``), face (``x_face``…) and
        time coordinates; the layout is in the module documentation.

        Raises ``NotARunError`` if a step was not saved, if the folder has
        volumes but its manifest no grid, or if an array's shape is not the
        grid's.
        """
        saved = self.steps
        steps = saved if steps is None else [int(s) for s in steps]
        missing = sorted(set(steps) - set(saved))
        if missing:
            raise NotARunError(
                f"{self.path} has no saved frame at step {missing[0]}; "
                f"the saved steps are {_ranges(saved) or 'none'}"
            )
        obstacle = self.path / "obstacle.npy"
        if not steps and not obstacle.exists():
            if self.grid is not None:
                # A run's folder without its volumes: the committed results/
                # keep the manifest and metrics only (volumes are git-ignored).
                warnings.warn(
                    f"{self.path} holds no saved volumes (<gas>_NNNN.npy): an empty Dataset; "
                    f"committed results keep only the manifest and metrics, so rerun it "
                    f"(smokelab run … --out DIR) to have the volumes",
                    stacklevel=2,
                )
            return xr.Dataset(attrs=self.attrs)
        grid = self.grid
        if grid is None:
            raise NotARunError(
                f"{self.path / 'manifest.json'} has no extra.grid, so its volumes "
                f"cannot be placed; volumes are read from folders `smokelab run` wrote"
            )
        data_vars = {}
        for name in _frame_names(self.path, self.gases) if steps else []:
            files = [f"{name}_{s:04d}.npy" for s in steps]
            arrays = [self._load(f) for f in files]
            for f, a in zip(files, arrays):
                if a.shape != arrays[0].shape:
                    raise NotARunError(
                        f"{self.path / f} has shape {a.shape}, {files[0]} has {arrays[0].shape}; "
                        f"the frames of one volume must agree"
                    )
            data_vars[name] = _frame_variable(files[0], name, np.stack(arrays), grid, self.path)
        if obstacle.exists():
            level = self._load("obstacle.npy")
            _check_shape("obstacle.npy", level.shape, grid.shape, self.path)
            data_vars["obstacle"] = xr.Variable(
                ("z", "y", "x"),
                level,
                {"long_name": "obstacles' level set (signed distance), positive inside",
                 "units": "world units"},
            )
        ds = xr.Dataset(data_vars, attrs=self.attrs)
        ds = ds.assign_coords(_coords(grid, ds))
        if steps:
            ds = ds.assign_coords(step=("step", np.asarray(steps)))
            ds = ds.assign_coords(time=("step", self._times(steps)))
            ds.time.attrs.update(long_name="simulated time of the frame (step × Δt)")
            ds.step.attrs.update(long_name="steps taken: frame N is the state after N steps")
        return ds

    @cached_property
    def metrics(self) -> xr.Dataset:
        """``metrics.csv``: one variable per column over ``step``, with the
        column ``time`` as a coordinate (see the README's *Outputs* for the
        columns). Empty if the folder has none."""
        path = self.path / "metrics.csv"
        if not path.exists():
            return xr.Dataset(attrs=self.attrs)
        table = _read_csv(path)
        if "step" not in table:
            raise NotARunError(f"{path} has no `step` column; it is not a run's metrics.csv")
        ds = table.set_index("step").to_xarray()
        if "time" in ds:
            ds = ds.set_coords("time")
        ds.attrs.update(self.attrs)
        return ds

    @cached_property
    def tables(self) -> dict:
        """Every other ``*.csv`` in the folder, by file stem, as a Dataset
        over ``row`` (an experiment's ``data.csv`` is ``tables["data"]``)."""
        out = {}
        for path in sorted(self.path.glob("*.csv")):
            if path.name != "metrics.csv":
                ds = _read_csv(path).to_xarray().rename(index="row")
                ds.attrs.update(self.attrs)
                out[path.stem] = ds
        return out

    @cached_property
    def runs(self) -> dict:
        """The runs in subfolders (those with a ``manifest.json``), by name."""
        return {
            p.name: Run(p)
            for p in sorted(self.path.iterdir())
            if p.is_dir() and (p / "manifest.json").is_file()
        }

    def _load(self, name: str) -> np.ndarray:
        path = self.path / name
        try:
            return np.load(path)
        except (OSError, ValueError) as e:
            raise NotARunError(f"{path} cannot be read as .npy ({e})") from None

    def _times(self, steps: list) -> np.ndarray:
        """Each step's time: from ``metrics.csv`` where it has the step,
        else ``step × Δt`` from the configuration (NaN if neither)."""
        recorded = {}
        if "time" in self.metrics.coords:
            recorded = dict(zip(self.metrics.step.values.tolist(), self.metrics.time.values))
        config = self.manifest.get("config")
        dt = config.get("dt") if isinstance(config, dict) else None
        return np.array(
            [recorded.get(s, s * dt if dt is not None else np.nan) for s in steps], dtype=float
        )


def _read_manifest(path: Path) -> dict:
    hint = "give a folder `smokelab run` or `smokelab experiment` wrote"
    if not path.exists():
        raise NotARunError(f"{path} does not exist; {hint}")
    if not path.is_dir():
        raise NotARunError(f"{path} is not a folder; {hint}")
    manifest = path / "manifest.json"
    if not manifest.is_file():
        if any((p / "manifest.json").is_file() for p in path.iterdir()):
            return {}  # a folder of runs (an experiment's, or results/): see Run.runs
        raise NotARunError(f"{path} has no manifest.json and no subfolder with one, so it is not a smokelab run; {hint}")
    try:
        value = json.loads(manifest.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise NotARunError(f"{manifest} cannot be read as JSON ({e}); {hint}") from None
    if not isinstance(value, dict) or not any(k in value for k in ("status", "config", "commit")):
        raise NotARunError(f"{manifest} is not a smokelab manifest (no status, config or commit); {hint}")
    return value


def flatten_manifest(manifest: dict) -> dict:
    """The manifest as flat ``attrs``: nested keys joined by dots
    (``config.dt``, ``extra.grid.cell``, ``machine.cpu``); ``null`` values
    left out; lists of numbers or strings kept, other lists (of records) as
    their JSON text, so the Datasets can be written to netCDF."""
    out = {}

    def walk(prefix: str, value):
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}.{k}" if prefix else str(k), v)
        elif value is None:
            return
        elif isinstance(value, list):
            simple = all(isinstance(v, (int, float, str)) and not isinstance(v, bool) for v in value)
            out[prefix] = value if simple and value else json.dumps(value)
        elif isinstance(value, bool):
            out[prefix] = int(value)
        else:
            out[prefix] = value

    walk("", manifest)
    return out


def _frame_files(path: Path) -> dict:
    """``{name: {step, …}}`` of the folder's ``<name>_NNNN.npy`` files."""
    found = {}
    for p in path.glob("*_*.npy"):
        m = FRAME_FILE.match(p.name)
        if m:
            found.setdefault(m["name"], set()).add(int(m["step"]))
    return found


def _frame_names(path: Path, gases: list) -> list:
    """The frame volumes' names: the gases in the run's order, any other
    scalar volumes alphabetically, then u, v, w, vel."""
    names = set(_frame_files(path))
    last = [n for n in ("u", "v", "w", "vel") if n in names]
    first = [g for g in gases if g in names]
    return first + sorted(names - set(first) - set(last)) + last


def _complete_steps(path: Path) -> list:
    files = _frame_files(path)
    if not files:
        return []
    every = set.intersection(*files.values())
    some = set.union(*files.values())
    for step in sorted(some - every):
        lacking = sorted(n for n, s in files.items() if step not in s)
        warnings.warn(
            f"{path}: the frame at step {step} lacks {', '.join(f'{n}_{step:04d}.npy' for n in lacking)}; "
            f"it is left out",
            stacklevel=3,
        )
    return sorted(every)


def _check_shape(name: str, shape: tuple, want: tuple, path: Path):
    if tuple(shape) != tuple(want):
        raise NotARunError(
            f"{path / name} has shape {tuple(shape)}; the manifest's grid "
            f"(nz, ny, nx) = {tuple(want[:3])} gives {tuple(want)}"
        )


def _frame_variable(first: str, name: str, stack: np.ndarray, grid: Grid, path: Path) -> xr.Variable:
    """The stacked frames ``(step, …)`` of volume ``name`` (read from files
    like ``first``), with its dims, checked against the grid."""
    nz, ny, nx = grid.shape
    shape = tuple(stack.shape[1:])
    if name in FACE_AXIS:
        axis = FACE_AXIS[name]
        a = 2 - AXES.index(axis)  # the array axis of `axis` in (nz, ny, nx)
        closed = list(grid.shape)
        closed[a] += 1
        if shape not in (grid.shape, tuple(closed)):
            raise NotARunError(
                f"{path / first} has shape {shape}; with the manifest's grid an {axis}-face "
                f"array is {grid.shape} (periodic box) or {tuple(closed)} (closed box)"
            )
        dims = ["z", "y", "x"]
        dims[a] = f"{axis}_face"
        return xr.Variable(
            ("step", *dims),
            stack,
            {"long_name": f"{axis} velocity on the {axis}-faces (staggered MAC grid)",
             "units": "world units per unit time"},
        )
    if name == "vel":
        _check_shape(first, shape, (nz, ny, nx, 3), path)
        return xr.Variable(
            ("step", "z", "y", "x", "component"),
            stack,
            {"long_name": "velocity averaged to the cell centres (each component the mean of its two faces)",
             "units": "world units per unit time"},
        )
    if name.endswith("_fine"):
        if len(shape) != 3:
            raise NotARunError(f"{path / first} has shape {shape}; a finely sampled gas is (nz, ny, nx)")
        return xr.Variable(
            ("step", "z_fine", "y_fine", "x_fine"),
            stack,
            {"long_name": f"{name[:-5]} sampled finely (--sample-res), at the fine cell centres"},
        )
    _check_shape(first, shape, grid.shape, path)
    return xr.Variable(("step", "z", "y", "x"), stack, {"long_name": f"{name} at the cell centres"})


def _coords(grid: Grid, ds: xr.Dataset) -> dict:
    """The spatial coordinates the Dataset's dims need."""
    coords = {}
    for axis in AXES:
        coords[axis] = (axis, grid.centres(axis), {
            "long_name": f"{axis} of the cell centres: origin + (i + 1/2) cell", "units": "world units"})
        face = f"{axis}_face"
        if face in ds.dims:
            coords[face] = (face, grid.faces(axis, ds.sizes[face]), {
                "long_name": f"{axis} of the {axis}-faces: origin + i cell (face i is the low face of cell i)",
                "units": "world units"})
        fine = f"{axis}_fine"
        if fine in ds.dims:
            shape = tuple(ds.sizes[f"{a}_fine"] for a in ("z", "y", "x"))
            coords[fine] = (fine, grid.fine_centres(axis, shape), {
                "long_name": f"{axis} of the fine cell centres", "units": "world units"})
    if "component" in ds.dims:
        coords["component"] = ("component", list(AXES))
    return coords


def _read_csv(path: Path) -> pd.DataFrame:
    try:
        return pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as e:
        raise NotARunError(f"{path} cannot be read as CSV ({e})") from None


def _ranges(steps: list) -> str:
    """``[2, 4, 6]`` as ``"2, 4, 6"``, shortened past eight."""
    text = ", ".join(str(s) for s in steps[:8])
    return text + (f", … {steps[-1]}" if len(steps) > 8 else "")
