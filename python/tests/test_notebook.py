"""The example notebook runs from top to bottom (nbclient, the venv's own
kernel) and draws its figure: three panels of gas, one per density mode."""

from pathlib import Path

import numpy as np
import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "density_modes.ipynb"


def test_the_density_modes_notebook_runs_and_draws_three_modes(tmp_path):
    nbformat = pytest.importorskip("nbformat", reason="pip install nbclient ipykernel matplotlib")
    nbclient = pytest.importorskip("nbclient", reason="pip install nbclient ipykernel matplotlib")
    pytest.importorskip("matplotlib", reason="pip install matplotlib")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(
        notebook, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
    printed = "".join(
        out.get("text", "") for cell in notebook.cells if cell.cell_type == "code" for out in cell.outputs
    )
    for mode in ["gridded", "gridless", "selma"]:
        assert f"{mode} " in printed and "hot mass" in printed, printed
    figure = tmp_path / "density_modes.png"
    import matplotlib.image

    image = matplotlib.image.imread(figure)
    # Three slice panels side by side in the top half, each with red (hot)
    # and blue (cold) gas on white.
    top = image[: image.shape[0] // 2, :, :3]
    thirds = np.array_split(top, 3, axis=1)
    for third in thirds:
        red = (third[..., 0] > 0.6) & (third[..., 2] < 0.4)
        blue = (third[..., 2] > 0.6) & (third[..., 0] < 0.4)
        assert red.sum() > 50 and blue.sum() > 50, (red.sum(), blue.sum())
