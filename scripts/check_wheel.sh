#!/usr/bin/env bash
# Builds the wheel, installs it into a fresh virtual environment and runs a deformation
# from outside the checkout, so that the packaged shaders (not the source tree's) are used.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
.venv/bin/python -m pip wheel -q --disable-pip-version-check --no-deps -w "$work/dist" .
python3 -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --disable-pip-version-check "$work"/dist/glmls-*.whl
cd "$work"
"$work/venv/bin/python" - <<'PY'
import pathlib

import numpy as np

import glmls
from glmls import data
from glmls.gl.shaders import library

root = pathlib.Path(str(library().root))
assert "site-packages" in str(root), f"shaders not from the installed wheel: {root}"
names = ("mls/core.glsl", "mls/visit.glsl", "warp/cells.comp.glsl", "adaptive/scan.comp.glsl")
for name in (*names, "draw/text.frag.glsl"):
    assert (root / name).is_file(), name
assert data.rocket().shape == (427, 640, 3)  # the bundled photographs are package data
image = data.astronaut()
src, dst = data.astronaut_handles()
with glmls.MLS(src, dst, shape=image.shape) as m:
    f = m(src)
assert np.abs(f - dst).max() < 1e-3, f
print(f"wheel OK: glmls {glmls.__version__} from {pathlib.Path(glmls.__file__).parent}, "
      f"shaders from {root}")
PY
"$work/venv/bin/glmls" --quiet analyze --example --out "$work/example" >/dev/null
test -s "$work/example/report.json" && test -s "$work/example/deformed.png"
echo "wheel OK: glmls analyze --example from the installed wheel"
