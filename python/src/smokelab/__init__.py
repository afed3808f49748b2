"""smokelab's solver from Python: set up, step, probe and change a simulation.

>>> import smokelab
>>> sim = smokelab.Simulation("hot-cold", res=32, density="gridless")  # doctest: +SKIP
>>> sim.step(10)                    # ten steps, the GIL released, Ctrl-C between steps
>>> f = sim.fields()                # {"hot", "cold", "u", "v", "w"}: float32 [z][y][x]
>>> img = sim.render(320, 240)      # (240, 320, 3) uint8, the volume render
>>> smokelab.run("slab-box", out="runs/a", frames=20)   # `smokelab run`, same folder

Every keyword is a configuration key, set as ``smokelab run --set KEY=VALUE``
sets it (same checks, same messages, as ``ValueError``); ``smokelab.keys(name)``
lists a scenario's keys with their defaults and help. Finished runs open with
``smokelab.xr`` (the xarray reader, also importable as ``smokelab_xr``).
"""

from . import _smokelab
from ._smokelab import BUILD_COMMIT, Simulation, __version__, keys, scenarios
from ._smokelab import run as _run

__all__ = ["BUILD_COMMIT", "Simulation", "keys", "run", "scenarios", "xr"]


def run(scenario="hot-cold", out=None, overwrite=False, progress=False, **keys):
    """Run ``scenario`` as ``smokelab run`` does and return its folder.

    The keywords are configuration keys, as ``Simulation``'s (``frames=20``,
    ``res=32``, ``save_every=5``); ``out`` is the run folder (default: a new
    folder under ``runs/``), ``overwrite`` replaces an earlier run there,
    ``progress`` shows the progress bar on stderr. The folder holds what
    ``smokelab run`` writes (volumes, previews, ``metrics.csv``,
    ``manifest.json``); open it with ``smokelab.xr.open_run``. The GIL is
    released while it runs; Ctrl-C takes effect when it returns.

    Raises ``ValueError`` with the command line's message for bad input.
    """
    import pathlib

    return pathlib.Path(_run(scenario, out, overwrite, progress, **keys))


def _keys_doc() -> str:
    """Every scenario's keys, defaults and help, for ``help(Simulation)``."""
    lines = ["", "Configuration keys (keyword=value; default in brackets):", ""]
    for name in scenarios():
        lines.append(f"{name}:")
        for key, default, text in keys(name):
            default = "unset" if default is None else default
            text = f" — {' '.join(text.split())}" if text else ""
            lines.append(f"    {key} [{default}]{text}")
        lines.append("")
    return "\n".join(lines)


def __getattr__(name):
    # `smokelab.xr` imports xarray and pandas only when first used.
    if name == "xr":
        import importlib

        return importlib.import_module(".xr", __name__)
    raise AttributeError(f"module 'smokelab' has no attribute {name!r}")


try:
    Simulation.__doc__ = (Simulation.__doc__ or "") + _keys_doc()
except (AttributeError, TypeError):  # an immutable type keeps its own doc
    pass
