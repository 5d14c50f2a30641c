"""Every script in examples/ runs as the docs' gallery runs it, and draws something."""

from __future__ import annotations

import json
import subprocess
import sys

import nbclient
import nbformat
import pytest
from conftest import ROOT

SCRIPTS = sorted((ROOT / "examples").rglob("*.py"))
#: Run in the default step: the README's first script and the front page's labels. The
#: others run in the slow step (pytest -m slow) and in every docs build (the gallery).
QUICK_SCRIPTS = {"quickstart.py", "material_grid.py"}

#: Runs one example as sphinx-gallery does (pyvista.BUILDING_GALLERY keeps shown plotters
#: open), then grabs every plotter still open and every matplotlib figure.
DRIVER = """
import json, sys
import numpy as np
import pyvista as pv
pv.OFF_SCREEN = True
pv.BUILDING_GALLERY = True
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
plt.show = lambda *a, **k: None
import pv_cubemarch
from pyvista.plotting.plotter import _ALL_PLOTTERS
images = []
original = pv.Plotter.show
def show(self, *args, **kwargs):
    images.append(np.asarray(self.screenshot(return_img=True)))
    return original(self, *args, **kwargs)
pv.Plotter.show = show
# as sphinx-gallery runs it: no __file__ (an example finds its data through the package)
source = open(sys.argv[1]).read()
exec(compile(source, sys.argv[1], "exec"), {"__name__": "__main__"})
for plotter in list(_ALL_PLOTTERS.values()):
    if getattr(plotter, "render_window", None) is not None:
        images.append(np.asarray(plotter.screenshot(return_img=True)))
for number in plt.get_fignums():
    figure = plt.figure(number)
    figure.canvas.draw()
    images.append(np.asarray(figure.canvas.buffer_rgba())[..., :3])
print(json.dumps([[int(i.shape[0]), int(i.shape[1]), int(np.unique(
    i.reshape(-1, i.shape[-1]), axis=0).shape[0])] for i in images]))
"""


@pytest.mark.parametrize("script", [
    s if s.name in QUICK_SCRIPTS else pytest.param(s, marks=pytest.mark.slow)
    for s in SCRIPTS], ids=[str(s.relative_to(ROOT / "examples")) for s in SCRIPTS])
def test_example_runs_and_draws(script, tmp_path):
    # catches: an example that raises, that shows nothing, or whose every picture is one
    # flat colour (a technique drawing nothing over the background)
    result = subprocess.run([sys.executable, "-c", DRIVER, str(script)], cwd=tmp_path,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    pictures = json.loads(result.stdout.strip().splitlines()[-1])
    assert pictures, "the example showed no plotter and no figure"
    assert all(colours > 16 for _, _, colours in pictures), pictures
    assert not list(tmp_path.iterdir()), "an example wrote files where it was run"


NOTEBOOKS = sorted((ROOT / "examples").rglob("*.ipynb"))


@pytest.mark.slow   # long: its own CI step (pytest -m slow)
@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[n.name for n in NOTEBOOKS])
def test_notebook_runs_top_to_bottom(notebook, tmp_path):
    # catches a notebook that rots: every cell must run (the live view's included).
    book = nbformat.read(notebook, as_version=4)
    nbclient.NotebookClient(book, timeout=240, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    code = [cell for cell in book.cells if cell.cell_type == "code"]
    outputs = [o for cell in code for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any("iframe" in str(o.get("data", {})) for o in outputs)   # the view was shown
    if notebook.name == "live_view.ipynb":
        check_live_view_notebook(code)


def check_live_view_notebook(code) -> None:
    """plotter.show() gave the served view; the fitting's progress bar was the notebook's."""
    # catches: plotter.show() left to a client-side backend (no iframe of our server), and
    # a progress bar printed as text to stderr instead of the notebook's widget
    shown = next(cell for cell in code if "plotter.show()" in cell.source)
    assert any('<iframe id="cubemarch-' in str(o.get("data", {})) for o in shown.outputs)
    fitted = next(cell for cell in code if "make_field" in cell.source)
    widgets = [o for o in fitted.outputs if "application/vnd.jupyter.widget-view+json"
               in o.get("data", {})]
    assert any("signed distance" in o["data"].get("text/plain", "") for o in widgets)
    assert not any("signed distance" in o.get("text", "") for o in fitted.outputs
                   if o.output_type == "stream")
