"""The demo notebook runs headless on a real kernel, and its frame and animation show
themselves (a PNG, an HTML5 video)."""

from pathlib import Path

import numpy as np
import pytest

from conftest import needs

pytestmark = [pytest.mark.gl, pytest.mark.slow]

NOTEBOOK = Path(__file__).resolve().parent.parent / "demos" / "notebook.ipynb"


def test_a_picture_and_an_animation_represent_themselves():
    from es2particles.io.notebook import Animation, Picture

    picture = Picture(np.zeros((4, 6, 3), np.uint8))
    assert picture._repr_png_().startswith(b"\x89PNG") and repr(picture) == "<Picture 6x4>"
    animation = Animation(fps=5).add(picture).add(picture)
    html = animation._repr_html_()
    assert html.startswith("<video") or html.startswith("<img")


def test_the_demo_notebook_runs_headless(tmp_path):
    nbformat = needs("nbformat", "test")
    nbclient = needs("nbclient", "test")
    needs("ipykernel", "test")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()  # a real IPython kernel, started and stopped here
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    kinds = {key for o in outputs for key in o.get("data", {})}
    assert "image/png" in kinds and "text/html" in kinds, kinds
    html = next(o["data"]["text/html"] for o in outputs if "text/html" in o.get("data", {}))
    assert "base64," in html
    assert not [o for o in outputs if o.get("output_type") == "error"]
