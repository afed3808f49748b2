"""A smokelab sweep folder as one xarray Dataset, the axes as dimensions.

``smokelab sweep FILE.toml --out DIR`` runs one point per combination of
the file's ``[axes]``; ``smokelab sweep gather DIR`` writes ``DIR/sweep.csv``,
a row per point. ``open_sweep(DIR)`` turns that table into a Dataset with one
dimension per axis (coordinates: the axis values, as typed in the sweep
file, read from ``DIR/sweep.json``) and one variable per column: the point's
``state``, its run's ``wall_seconds`` and the last row of its
``metrics.csv``, plus ``folder``, the point's run folder (relative to DIR),
which ``open_run(DIR / folder)`` opens. The fixed ``[keys]`` are the
``attrs`` (``keys.<name>``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import xarray as xr

from .run import NotARunError


def _label(value):
    """An axis value as a coordinate label: a list (e.g. a position) as its text."""
    return json.dumps(value) if isinstance(value, (list, dict)) else value


def open_sweep(path) -> xr.Dataset:
    """The gathered sweep in the folder ``path`` (see the module's doc)."""
    path = Path(path)
    index, table = path / "sweep.json", path / "sweep.csv"
    if not index.is_file():
        raise NotARunError(f"{path} is not a sweep folder: it has no sweep.json")
    if not table.is_file():
        raise NotARunError(f"{path} has no sweep.csv yet: run `smokelab sweep gather {path}`")
    plan = json.loads(index.read_text())
    frame = pd.read_csv(table)
    points = plan["points"]
    if list(frame["point"]) != [p["index"] for p in points]:
        raise NotARunError(
            f"{table} does not list the points of {index}: run `smokelab sweep gather {path}` again"
        )
    axes = [a["key"] for a in plan["axes"]]
    frame = frame.drop(columns=["point", *axes])
    for i, key in enumerate(axes):
        frame[key] = [_label(p["values"][i]) for p in points]
    frame["folder"] = [p["folder"] for p in points]
    data = frame.set_index(axes).to_xarray()
    data.attrs.update({f"keys.{k}": _label(v) for k, v in plan["keys"].items()})
    data.attrs["target"] = json.dumps(plan["target"])
    return data
