#!/usr/bin/env bash
# Builds the documentation site into build/docs (open build/docs/index.html): the guides,
# the API reference from the docstrings and the gallery made by running demos/. Sets up like
# scripts/setup.sh (the system GL packages, .venv), adds the `docs` extra, and builds with
# warnings as errors. Offline once the packages are installed. Extra arguments go to
# sphinx-build (e.g. -j auto, or -D sphinx_gallery_conf.plot_gallery=0 to skip the demos).
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
.venv/bin/python -m pip install -q --disable-pip-version-check -e ".[docs]"
# a fresh build: autosummary writes the stubs only for the pages it rereads, so the stubs
# removed here would be missing for pages a kept environment calls unchanged
rm -rf docs/api/generated docs/gallery docs/sg_execution_times.rst build/docs
.venv/bin/python -m sphinx -W --keep-going -b html docs build/docs "$@"
echo "docs: built build/docs/index.html" >&2
