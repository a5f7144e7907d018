"""Under ``xvfb-run``: every key of both windows, the screenshot key included, leaves the
window's GL context without an error, and a screenshot shows what the window drew."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from helpers import child_env

import glmls

XVFB = shutil.which("xvfb-run")
pytestmark = pytest.mark.skipif(
    XVFB is None, reason="xvfb-run is not installed (scripts/setup.sh installs xvfb xauth)"
)

EVERY_KEY = """
import json, sys
import numpy as np
import glmls
from glmls.app.controller import BINDINGS
from glmls.app.events import Key, Wait
from glmls.app.volume_controller import VOLUME_BINDINGS
from glmls.app.volume_window import VolumeApp
from glmls.app.window import App

out, which = sys.argv[1], sys.argv[2]
image = np.zeros((40, 60, 3), np.uint8)
image[10:30, 20:40] = 255
src = np.array([[15.0, 12.0], [45.0, 12.0], [30.0, 30.0]])
volume = np.zeros((12, 16, 20), np.float32)
volume[3:9, 4:12, 5:15] = 1.0
src3 = np.array([[5.0, 5.0, 4.0], [14.0, 10.0, 6.0], [10.0, 8.0, 8.0]])
if which == "image":
    app, bindings = App(image, src, src + [2.0, 1.0], name="image", out_dir=out), BINDINGS
else:
    app, bindings = VolumeApp(volume, src3, src3, name="volume", out_dir=out), VOLUME_BINDINGS
keys = [key for keys, _, _ in bindings for key in keys if key not in ("q", "Escape")]
events = [e for key in [*keys, "S"] for e in (Key(key), Wait(2))]
errors = []

def check(a):
    error = a.gl.mgl.error
    if error != "GL_NO_ERROR":
        errors.append([a.frames, error])

app.run(events=events, frames=2 * len(events) + 2, on_frame=check)
print(json.dumps(errors))
"""


@pytest.mark.parametrize("window", ["image", "volume"])
def test_no_key_leaves_a_gl_error(tmp_path, window):
    script = tmp_path / "keys.py"
    script.write_text(EVERY_KEY)
    result = subprocess.run(
        [XVFB, "-a", sys.executable, str(script), str(tmp_path), window],
        capture_output=True, text=True, env=child_env(), timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout.splitlines()[-1]) == []  # [frame, error] of each
    shot = glmls.imread(tmp_path / f"{window}-screenshot.png")  # what the window drew
    assert shot.ndim == 3 and shot.shape[2] == 3
    assert len(np.unique(shot.reshape(-1, 3), axis=0)) > 10  # text and pictures, not blank
