#!/usr/bin/env bash
# Build the documentation site into docs/_build/html: installs the docs extra into .venv
# (made by tools/setup.sh), runs every gallery example offscreen, and fails on any warning.
# PV_CUBEMARCH_DOCS_GALLERY=quick runs only three gallery scripts (CI's fast subset).
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x .venv/bin/python ] || bash tools/setup.sh
PYTHONWARNINGS="ignore:Editable installation" .venv/bin/python -m pip install -q -e ".[docs]"
rm -rf docs/_build docs/auto_examples docs/_generated/api
.venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html "$@"
echo "docs: open docs/_build/html/index.html"
