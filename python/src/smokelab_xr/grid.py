"""Where a run's samples sit in the world: cell centres and faces.

smokelab's conventions (the README's *Conventions*), which this module turns
into coordinates so that nobody has to remember them:

- world units, **y is up** (gravity along −y);
- the box is ``dims = [nx, ny, nz]`` cubic cells of edge ``cell`` (Δx) with
  lower corner ``origin``; cell ``(i, j, k)`` is centred at
  ``origin + (i + ½, j + ½, k + ½) Δx``;
- arrays are stored ``[z][y][x]`` (x fastest): shape ``(nz, ny, nx)``;
- the velocity is **staggered** (MAC): ``u`` on the x-faces, ``v`` on the
  y-faces, ``w`` on the z-faces. Face ``i`` along x is the low-x face of
  cell ``i``, at ``origin.x + i Δx``. A periodic box stores ``n`` faces per
  axis (the high face of the last cell is face 0); a closed box stores
  ``n + 1``, the wall faces 0 and ``n`` exactly zero.

smokelab holds the box in f32, so a manifest records the cell 0.2 as
0.20000000298023224. The coordinates here are the f64 nearest the exact
centres and faces of the box the run was given: the origin and the cell are
read as the shortest decimal their f32 value prints as (0.2), and each
coordinate ``origin + (i + ½) Δx`` is computed exactly from those decimals,
then rounded once. So ``.sel(x=0.5)`` finds the centre at 0.5.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np


def _f32_decimal(value: float) -> float:
    """``value`` as the shortest decimal its f32 prints as, when it is an f32
    (0.20000000298023224 → 0.2); other values as they are."""
    single = np.float32(value)
    return float(str(single)) if float(single) == value and np.isfinite(single) else value


def _exact(value: float) -> Fraction:
    """The decimal Python prints ``value`` as, exactly (0.2 → 1/5)."""
    return Fraction(repr(float(value)))


def _positions(origin: float, step: Fraction, offset: Fraction, count: int) -> np.ndarray:
    """``origin + (i + offset) step`` for i = 0 … count − 1, each computed
    exactly and rounded once to f64."""
    o = _exact(origin)
    return np.array([float(o + (i + offset) * step) for i in range(count)], dtype=float)

AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Grid:
    """The box a run's arrays are sampled on (``extra.grid`` of its manifest)."""

    origin: tuple  # (x, y, z) of the lower corner
    cell: float  # edge Δx of a cubic cell
    dims: tuple  # cell counts (nx, ny, nz)
    boundary: str  # "periodic" or "closed"

    @classmethod
    def from_record(cls, record: dict) -> "Grid":
        """The grid of a manifest's ``extra.grid`` record.

        Raises ``ValueError`` naming the bad entry if the record is not a grid.
        """
        try:
            origin = tuple(_f32_decimal(float(v)) for v in record["origin"])
            cell = _f32_decimal(float(record["cell"]))
            dims = tuple(int(n) for n in record["dims"])
        except (KeyError, TypeError, ValueError) as e:
            raise ValueError(f"extra.grid is not a grid record ({e!r}): {record!r}") from None
        if len(origin) != 3 or len(dims) != 3 or not cell > 0 or min(dims) < 1:
            raise ValueError(
                f"extra.grid must have a 3-vector origin, a positive cell and three "
                f"positive counts; it has origin {origin}, cell {cell}, dims {dims}"
            )
        return cls(origin, cell, dims, str(record.get("boundary", "periodic")))

    @property
    def shape(self) -> tuple:
        """The ``(nz, ny, nx)`` shape of a cell-centred array."""
        nx, ny, nz = self.dims
        return (nz, ny, nx)

    @property
    def size(self) -> np.ndarray:
        """Edge lengths of the box along (x, y, z)."""
        return np.asarray(self.dims, dtype=float) * self.cell

    def centres(self, axis: str) -> np.ndarray:
        """Cell centres along ``axis``: ``origin + (i + ½) Δx``, i = 0 … n − 1."""
        a = AXES.index(axis)
        return _positions(self.origin[a], _exact(self.cell), Fraction(1, 2), self.dims[a])

    def faces(self, axis: str, count: int) -> np.ndarray:
        """The first ``count`` faces along ``axis``: ``origin + i Δx`` (face i
        is the low face of cell i); ``count`` is n (periodic) or n + 1 (closed)."""
        a = AXES.index(axis)
        return _positions(self.origin[a], _exact(self.cell), Fraction(0), count)

    def fine_centres(self, axis: str, shape: tuple) -> np.ndarray:
        """Cell centres along ``axis`` of the same box sampled to ``shape``
        ``(nz, ny, nx)`` (``--sample-res S``: S cells along the longest axis,
        so the fine cell is ``max(size) / max(shape)``)."""
        a = AXES.index(axis)
        cell = _exact(self.cell) * max(self.dims) / max(shape)
        return _positions(self.origin[a], cell, Fraction(1, 2), shape[2 - a])
