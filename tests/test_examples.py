"""Every script in examples/ runs."""

from __future__ import annotations

import subprocess
import sys

import nbclient
import nbformat
import pytest
from conftest import ROOT

SCRIPTS = sorted((ROOT / "examples").glob("*.py"))
#: Scripts over 5 s: run by the slow step (pytest -m slow).
SLOW_SCRIPTS = {"cubemap_volumes.py", "volume_with_mesh.py", "voxel_world.py"}


@pytest.mark.parametrize("script", [
    pytest.param(s, marks=pytest.mark.slow) if s.name in SLOW_SCRIPTS else s for s in SCRIPTS],
    ids=[s.name for s in SCRIPTS])
def test_example_runs(script, tmp_path):
    out = tmp_path / "out.png"
    result = subprocess.run([sys.executable, str(script), str(out)], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert out.stat().st_size > 0


NOTEBOOKS = sorted((ROOT / "examples").glob("*.ipynb"))


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[n.name for n in NOTEBOOKS])
def test_notebook_runs_top_to_bottom(notebook, tmp_path):
    # catches a notebook that rots: every cell must run (the live view's included).
    book = nbformat.read(notebook, as_version=4)
    nbclient.NotebookClient(book, timeout=240, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for cell in book.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any("iframe" in str(o.get("data", {})) for o in outputs)   # the view was shown
