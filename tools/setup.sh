#!/usr/bin/env bash
# Set up a fresh machine for pv_cubemarch: Mesa's OSMesa (when missing and apt is usable),
# a virtual environment in .venv, and the package (editable) with its test extra.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! ldconfig -p 2>/dev/null | grep -q 'libOSMesa\.so'; then
  if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = "0" ]; then
    echo "setup: installing libosmesa6 (offscreen OpenGL)"
    apt-get update -qq >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libosmesa6 >/dev/null \
      || echo "setup: could not install libosmesa6; pv_cubemarch will use EGL (PV_CUBEMARCH_GL=egl)"
  else
    echo "setup: libOSMesa not found and apt-get not usable; pv_cubemarch will try EGL"
  fi
fi
PYTHON=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -e ".[test]"
echo "setup: done ($(.venv/bin/python -c 'import pv_cubemarch, vtk; print("vtk", vtk.vtkVersion.GetVTKVersion())'))"
