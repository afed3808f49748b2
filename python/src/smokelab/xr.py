"""The xarray reader of finished runs, ``smokelab_xr``, as ``smokelab.xr``.

>>> import smokelab
>>> run = smokelab.xr.open_run("runs/a")     # doctest: +SKIP

See ``smokelab_xr`` for what each file of a run becomes.
"""

from smokelab_xr import Grid, NotARunError, Run, flatten_manifest, open_run

__all__ = ["Grid", "NotARunError", "Run", "flatten_manifest", "open_run"]
