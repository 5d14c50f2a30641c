"""The code base stays ruff-clean and keeps its GLSL out of Python."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

from conftest import ROOT


def test_ruff_clean():
    ruff = shutil.which("ruff") or str(Path(sys.executable).parent / "ruff")
    result = subprocess.run([ruff, "check", "pv_cubemarch", "tests", "examples", "datasets"],
                            cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_no_glsl_in_python():
    pattern = re.compile(r"void main *\(|gl_FragData|fragOutput0 *=")
    sources = (ROOT / "pv_cubemarch").rglob("*.py")
    offenders = [str(p) for p in sources if pattern.search(p.read_text())]
    assert offenders == []
