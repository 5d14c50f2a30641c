#!/usr/bin/env bash
# The device check: on a machine with an NVIDIA GPU and EGL (no display), run
# `pv-cubemarch bench device` (the headline benches at GPU scale, and Mesa's rows compared
# error for error) and leave device.json, its log and the GL report in $OUT.
#
# With .venv set up (tools/setup.sh) it runs there. On the lent GPU machines (Python 3.12
# with numpy, scipy and scikit-image, no package index) build the rest here first with
# `python3 tools/device_bundle.py` and carry .devbundle and .gl: this script unpacks the GL
# loaders the device README names, and the bundle into /tmp/site.
# Usage: OUT=out BUDGET=420 bash tools/device_check.sh [--sections a,b] [--plan quick]
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-device_out}
WORK=${WORK:-/tmp/device_work}
mkdir -p "$OUT" "$WORK"
if compgen -G ".gl/*.deb" >/dev/null; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
PY=python3
if [ -f .devbundle/site.tar.xz ]; then
  if [ ! -f /tmp/site/vtk.py ]; then
    mkdir -p /tmp/site
    tar -xJf .devbundle/site.tar.xz -C /tmp/site 2>/dev/null || python3 -c \
      "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" \
      .devbundle/site.tar.xz /tmp/site
  fi
  # the package-dir mapping an install makes: glsl_replacements/ is pv_cubemarch's GLSL
  [ -e pv_cubemarch/glsl_replacements ] || ln -s ../glsl_replacements pv_cubemarch/glsl_replacements
  export PYTHONPATH=/tmp/site:$PWD
elif [ -x .venv/bin/python ]; then
  PY=.venv/bin/python
fi
vendor=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$vendor" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$vendor
export PV_CUBEMARCH_GL=egl PYTHONUNBUFFERED=1
nvidia-smi >"$OUT/gl.txt" 2>&1
"$PY" -m pv_cubemarch.cli info --gl >>"$OUT/gl.txt" 2>&1
cat "$OUT/gl.txt"
"$PY" -m pv_cubemarch.cli bench device --out "$WORK" --report "$OUT/device.json" \
  --budget "${BUDGET:-420}" "$@" 2>&1 | tee "$OUT/device.log"
exit "${PIPESTATUS[0]}"
