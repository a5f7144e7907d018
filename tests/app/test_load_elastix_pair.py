"""``l`` reloads the handles as the window was given them: an elastix pair (``--handles
MOVING.pts --targets FIXED.pts``) with its targets, a pair of voxel indices put in the
handles' units by the volume's spacing, as ``glmls warp`` reads them."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from helpers import child_env, write_elastix_points

import glmls
from glmls.app.events import Key
from glmls.app.volume_window import VolumeApp
from glmls.app.window import App

SRC2 = np.array([[10.0, 10.0], [40.0, 40.0], [30.0, 12.0]])
DST2 = SRC2 + [[2.0, 0.0], [0.0, 4.0], [-1.0, 1.0]]
SRC3 = np.array([[2.0, 3.0, 1.0], [8.0, 10.0, 4.0]])
DST3 = SRC3 + [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]
SPACING = (3.0, 1.0, 0.5)  # dz, dy, dx


def test_l_reloads_an_elastix_pair_with_its_targets(tmp_path):
    moving = write_elastix_points(tmp_path / "moving.pts", "point", SRC2)
    fixed = write_elastix_points(tmp_path / "fixed.pts", "point", DST2)
    image = np.zeros((60, 60), np.uint8)
    app = App(image, SRC2, SRC2, handles_path=moving, targets_path=fixed, out_dir=tmp_path)
    app.feed(Key("l"))  # refused: "an elastix point file holds the sources only"
    np.testing.assert_array_equal(app.controller.src, SRC2)
    np.testing.assert_array_equal(app.controller.dst, DST2)


@pytest.mark.parametrize("kind", ["index", "point"])
def test_l_reloads_a_volume_pair_in_the_handles_units(tmp_path, kind):
    moving = write_elastix_points(tmp_path / "moving.pts", kind, SRC3)
    fixed = write_elastix_points(tmp_path / "fixed.pts", kind, DST3)
    volume = np.zeros((8, 16, 12), np.float32)
    app = VolumeApp(volume, SRC3, SRC3, spacing=SPACING, handles_path=moving,
                    targets_path=fixed, out_dir=tmp_path)  # fmt: skip
    app.feed(Key("l"))
    scale = np.array(SPACING[::-1]) if kind == "index" else 1.0  # voxel (i, j, k) at (i dx, ...)
    np.testing.assert_allclose(app.controller.src, SRC3 * scale)
    np.testing.assert_allclose(app.controller.dst, DST3 * scale)


XVFB = shutil.which("xvfb-run")


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_glmls_demo_gives_l_the_targets_file(tmp_path):
    image = tmp_path / "grey.png"
    glmls.imwrite(image, np.full((60, 60), 128, np.uint8))
    moving = write_elastix_points(tmp_path / "moving.pts", "index", SRC2)
    fixed = write_elastix_points(tmp_path / "fixed.pts", "index", DST2)
    replay = tmp_path / "keys.json"  # reset, reload, save the handles
    replay.write_text(json.dumps([{"type": "key", "key": key} for key in "rlj"]))
    out = tmp_path / "out"
    result = subprocess.run(
        [XVFB, "-a", sys.executable, "-m", "glmls", "demo", str(image), "--handles", moving,
         "--targets", fixed, "--replay", str(replay), "--out", str(out)],
        capture_output=True, text=True, env=child_env(), timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    saved = json.loads((out / "grey-handles.json").read_text())
    assert saved == {"src": SRC2.tolist(), "dst": DST2.tolist()}
