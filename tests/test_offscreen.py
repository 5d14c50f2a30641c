"""Offscreen backend choice and the GL report."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import pv_cubemarch as cm
from pv_cubemarch.core import offscreen

PROBE = "import pv_cubemarch as cm; print(cm.gl_info()['window_class'])"


def run_probe(**env_changes):
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW")}
    env.update(env_changes)
    return subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True,
                          text=True, timeout=120)


def test_gl_info_reports_a_real_context():
    info = cm.gl_info()
    assert info["window_class"] in ("vtkOSOpenGLRenderWindow", "vtkEGLRenderWindow")
    assert info["renderer"] != "unknown" and info["version"][0].isdigit()


# a fresh process each (4 s): EGL's in the default run, OSMesa's in the slow step
@pytest.mark.parametrize("backend, window", [("egl", "vtkEGLRenderWindow"),
                                             pytest.param("osmesa", "vtkOSOpenGLRenderWindow",
                                                          marks=pytest.mark.slow)])
def test_backend_selected_by_environment_without_x_warnings(backend, window):
    if not offscreen.library_available(backend):
        other = "egl" if backend == "osmesa" else "osmesa"
        window = offscreen.WINDOW_CLASSES[other]  # documented fallback
    result = run_probe(PV_CUBEMARCH_GL=backend)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == window
    assert "X server" not in result.stderr and "X server" not in result.stdout


@pytest.mark.slow   # a fresh process (4 s)
def test_default_is_osmesa_when_available():
    result = run_probe()
    expected = "vtkOSOpenGLRenderWindow" if offscreen.library_available("osmesa") \
        else "vtkEGLRenderWindow"
    assert result.stdout.strip() == expected, result.stderr


def test_unknown_backend_name(monkeypatch):
    monkeypatch.setenv("PV_CUBEMARCH_GL", "vulkan")
    with pytest.raises(cm.OffscreenUnavailableError, match="osmesa"):
        offscreen.choose_backend()


def test_no_library_gives_install_advice(monkeypatch):
    monkeypatch.setattr(offscreen, "library_available", lambda backend: False)
    monkeypatch.setenv("PV_CUBEMARCH_GL", "auto")
    with pytest.raises(cm.OffscreenUnavailableError, match="libosmesa6"):
        offscreen.choose_backend()
