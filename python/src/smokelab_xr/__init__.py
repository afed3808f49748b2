"""smokelab's outputs as labelled xarray Datasets.

>>> import smokelab_xr as sx
>>> run = sx.open_run("runs/hot-cold-1700000000")     # doctest: +SKIP
>>> run.volumes.hot                # (step, z, y, x), coordinates in world units
>>> run.volumes.u                  # (step, z, y, x_face): the staggered x-velocity
>>> run.metrics.div_rms            # over step, with time as a coordinate
>>> run.manifest["config"]["dt"]   # or run.volumes.attrs["config.dt"]
>>> sweep = sx.open_sweep("runs/my-sweep")  # doctest: +SKIP
>>> sweep.hot_mass.sel(res=16)     # one variable per metric, a dimension per axis

Select by position, never by array index: ``run.volumes.hot.sel(x=5.0,
method="nearest")``; the array order (``[z][y][x]``) and the staggering (u on
the x-faces, …) are in the dims and coordinates. See ``smokelab_xr.run`` for
what each file becomes and ``smokelab_xr.grid`` for the conventions.
"""

from .grid import Grid
from .run import NotARunError, Run, flatten_manifest, open_run
from .sweep import open_sweep

__all__ = ["Grid", "NotARunError", "Run", "flatten_manifest", "open_run", "open_sweep"]
__version__ = "0.1.0"
