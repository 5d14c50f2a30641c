#!/usr/bin/env bash
# Set up a fresh machine for pv_cubemarch: Debian packages (Mesa's OSMesa for offscreen
# OpenGL; python3-openvdb, the reference library the OpenVDB reader's tests compare with;
# chromium, the browser the viewer's tests drive) when missing and apt is usable, a virtual
# environment in .venv, and the package (editable) with its test extra.
set -euo pipefail
cd "$(dirname "$0")/.."
wanted=()
ldconfig -p 2>/dev/null | grep -q 'libOSMesa\.so' || wanted+=(libosmesa6)
/usr/bin/python3 -c "import pyopenvdb" >/dev/null 2>&1 || wanted+=(python3-openvdb)
[ -x /usr/bin/chromium ] || wanted+=(chromium)
if [ ${#wanted[@]} -gt 0 ]; then
  if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = "0" ]; then
    echo "setup: installing ${wanted[*]} (Debian)"
    apt-get update -qq >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${wanted[@]}" >/dev/null \
      || echo "setup: could not install ${wanted[*]}; without OSMesa pv_cubemarch uses EGL (PV_CUBEMARCH_GL=egl), without python3-openvdb the OpenVDB cross-check tests fail, without chromium the browser tests fail"
  else
    echo "setup: ${wanted[*]} missing and apt-get not usable: without OSMesa pv_cubemarch tries EGL; without python3-openvdb the OpenVDB cross-check tests fail; without chromium the browser tests fail"
  fi
fi
PYTHON=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
# setuptools says, on every editable install of a project whose package maps a folder
# (glsl_replacements/ -> pv_cubemarch.glsl_replacements), that folders named like the
# package may shadow it: information about editable installs, not a problem of ours
PYTHONWARNINGS="ignore:Editable installation" .venv/bin/python -m pip install -q -e ".[test]"
echo "setup: done ($(.venv/bin/python -c 'import pv_cubemarch, vtk; print("vtk", vtk.vtkVersion.GetVTKVersion())'))"
