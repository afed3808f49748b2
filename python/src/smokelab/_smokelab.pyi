"""Type stubs of the extension module ``smokelab._smokelab`` (PyO3)."""

import os
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
BUILD_COMMIT: str

_Path = Union[str, "os.PathLike[str]"]

class Simulation:
    """A simulation of one scenario, stepped from Python.

    ``Simulation(scenario="hot-cold", **keys)``: each keyword a configuration
    key, set as ``smokelab run --set KEY=VALUE`` sets it; bad input raises
    ``ValueError`` with the command line's message.
    """

    def __init__(self, scenario: str = "hot-cold", **keys: Any) -> None: ...
    @staticmethod
    def resume(path: _Path) -> "Simulation":
        """The simulation a ``checkpoint`` file holds, ready to step on bitwise."""
    def step(self, n: int = 1) -> None:
        """Take ``n`` steps; the GIL is released, Ctrl-C stops between steps."""
    @property
    def steps(self) -> int:
        """Steps taken."""
    @property
    def time(self) -> float:
        """Simulated time, steps × dt."""
    @property
    def scenario(self) -> str:
        """The scenario's name."""
    @property
    def config(self) -> Dict[str, Any]:
        """The resolved configuration, every key."""
    @property
    def stage_seconds(self) -> Dict[str, float]:
        """Wall seconds per stage of the last step (metrics.csv's t_* columns)."""
    @property
    def gases(self) -> List[str]:
        """The gases' names."""
    def fields(self) -> Dict[str, npt.NDArray[np.float32]]:
        """Each gas at the cell centres and "u", "v", "w" on the faces, [z][y][x]."""
    def set_density(self, name: str, array: npt.ArrayLike) -> None:
        """Replace gas ``name``'s density by ``array`` of shape (nz, ny, nx), finite."""
    def checkpoint(self, path: _Path) -> None:
        """Write the whole state to ``path`` for ``Simulation.resume``."""
    def render(self, width: int = 320, height: int = 240) -> npt.NDArray[np.uint8]:
        """The volume render now, (height, width, 3) sRGB."""

def run(
    scenario: str = "hot-cold",
    out: Optional[_Path] = None,
    overwrite: bool = False,
    progress: bool = False,
    **keys: Any,
) -> str: ...
def keys(scenario: str = "hot-cold") -> List[Tuple[str, Optional[str], Optional[str]]]:
    """Every key of ``scenario``: (key, default as TOML or None, flag help or None)."""
def scenarios() -> List[str]:
    """The scenarios ``smokelab run`` knows."""
