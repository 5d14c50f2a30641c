"""The GLSL travels inside the wheel: install it elsewhere and render from another directory."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from conftest import ROOT, SCENE


@pytest.mark.slow
def test_wheel_carries_glsl_and_renders_from_elsewhere(tmp_path):
    # Build from a clean copy: setuptools keeps a build/ folder in the source tree, and a
    # stale one would smuggle deleted files into the wheel.
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "*.egg-info", "__pycache__", ".pytest_cache", ".ruff_cache"))
    dist = tmp_path / "dist"
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "--no-build-isolation",
         "-q", "-w", str(dist)], capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr
    wheel = next(dist.glob("pv_cubemarch-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    folder = "pv_cubemarch/glsl_replacements/"
    glsl = {n[len(folder):] for n in names if n.endswith(".glsl")}
    shipped = {str(p.relative_to(ROOT / "glsl_replacements"))
               for p in (ROOT / "glsl_replacements").glob("*/*.glsl")}
    assert glsl == shipped
    assert all(n.startswith(folder) for n in names if n.endswith(".glsl"))

    site = tmp_path / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site),
         str(wheel)], capture_output=True, text=True, timeout=300)
    assert install.returncode == 0, install.stderr
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    # catches: a subpackage left out of pyproject's package list (the editable install of
    # the checkout would still find it; the wheel would not).
    packages = {str(p.parent.relative_to(ROOT))
                for p in (ROOT / "pv_cubemarch").rglob("__init__.py")}
    assert packages <= {str(Path(n).parent) for n in names if n.endswith("__init__.py")}
    code = ("import pv_cubemarch, sys; "
            f"pv_cubemarch.load_scene({str(SCENE)!r}).render('out.png', size=(48, 32), "
            "progress_bar=False); "
            "print('\\n'.join(m.__file__ for n, m in sorted(sys.modules.items()) "
            "if n.startswith('pv_cubemarch') and getattr(m, '__file__', None)))")
    env = dict(os.environ, PYTHONPATH=str(site))
    run = subprocess.run([sys.executable, "-c", code], cwd=elsewhere, capture_output=True,
                         text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    loaded = run.stdout.split()
    assert len(loaded) > 20 and all(path.startswith(str(site)) for path in loaded), loaded
    assert (elsewhere / "out.png").stat().st_size > 0
