"""The volume window at the edges of what it can do: keys of the image window that have no
use here, a slice the warp refuses (a lattice past the GL limits) and a volume past the
GL texture limits."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from helpers import child_env

import glmls
from glmls.app.events import Key
from glmls.app.volume_controller import IMAGE_ONLY_KEYS, VolumeController, VolumeSettings
from glmls.app.volume_session import VolumeSession, check_fits

XVFB = shutil.which("xvfb-run")
#: A flat volume and four handles whose targets shrink it (similarity) a hundredfold about
#: its centre. The warp of such a map stands for one that the construction refuses (a
#: lattice past the GL limits): :data:`REFUSED` makes the slices' warp raise for it.
FLAT = (8, 200, 200)
FAR_SRC = [[5.0, 5.0, 1.0], [195.0, 5.0, 1.0], [5.0, 195.0, 6.0], [195.0, 195.0, 6.0]]
FAR_DST = (
    np.array([100.0, 100.0, 3.5]) + 0.01 * (np.array(FAR_SRC) - [100.0, 100.0, 3.5])
).tolist()


REFUSAL = "the lattice holds too many cells for one warp: use a coarser grid"

#: Installs, in a child process, a slices' warp that refuses the far targets as the
#: construction refuses a lattice past its numbers (a ValueError), and warps all others.
REFUSED = f"""
import numpy as np
from glmls.app.volume_session import VolumeSession

made = VolumeSession._slice
far = np.array({FAR_DST!r})

def refused_when_far(self, view, field, *, deform=True):
    if deform and np.allclose(np.asarray(self.controller.dst, float), far):
        raise ValueError({REFUSAL!r})
    return made(self, view, field, deform=deform)

VolumeSession._slice = refused_when_far
"""


def test_keys_of_the_image_window_say_they_are_for_images():
    """They did nothing at all: a user pressing ``m`` or ``]`` could not tell a key with no
    use here from one that failed."""
    assert set(IMAGE_ONLY_KEYS) == {"T", "o", "[", "]", "m", "a", "d", "p"}
    c = VolumeController([[2.0, 2, 5]], [[3.0, 2, 5]], (10, 12, 12))
    before = (c.settings, c.overlay, c.revision, c.point, c.active, c.show_handles)
    for key, what in IMAGE_ONLY_KEYS.items():
        assert c.feed(Key(key)) == []
        assert c.message == f"{key}: for images, not volumes ({what})"
        c.message = ""
    assert (c.settings, c.overlay, c.revision, c.point, c.active, c.show_handles) == before
    c.feed(Key("x"))  # bound in neither window: nothing to say
    assert c.message == ""


def _planes(volume: np.ndarray, point) -> list[np.ndarray]:
    x, y, z = point
    return [volume[z], volume[:, y], volume[:, :, x].T]


def test_a_slice_the_warp_refuses_is_shown_undeformed_and_said(gl, monkeypatch):
    """The warp's ValueError left the frame: the window closed on a drag (exit status 2)."""
    made = VolumeSession._slice

    def refused_when_far(self, view, field, *, deform=True):
        if deform and np.allclose(np.asarray(self.controller.dst, float), FAR_DST):
            raise ValueError(REFUSAL)
        return made(self, view, field, deform=deform)

    monkeypatch.setattr(VolumeSession, "_slice", refused_when_far)
    rng = np.random.default_rng(3)
    volume = rng.integers(0, 256, FLAT, dtype=np.uint8)
    settings = VolumeSettings(config=glmls.MLSConfig(transform="similarity"), grid=1)
    c = VolumeController(FAR_SRC, FAR_DST, FLAT, settings=settings)
    s = VolumeSession(gl, c, volume)
    try:
        s.sync()
        assert s.error == "" and s.mls is not None  # f itself is valid
        shown = s.slices()
        assert all("use a coarser grid" in error for error in s.slice_errors)
        assert s.slice_error == s.slice_errors[0]
        for picture, plane in zip(shown, _planes(volume, c.point), strict=True):
            np.testing.assert_array_equal(picture, plane)  # the volume as it is
        c.feed(Key("e"))
        assert s.overlays() is None  # no deformed slice to lay the error field on
        c.feed(Key("e"))
        # a target back near its source: the slices are deformed again, error gone
        dst = (np.array(FAR_SRC) + [[0.0, 3.0, 0.0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]).tolist()
        c.set_handles(FAR_SRC, dst)
        s.sync()
        shown = s.slices()
        assert s.slice_errors == ["", "", ""] and s.slice_error == ""
        with glmls.MLS(FAR_SRC, dst, transform="similarity", shape=FLAT, ctx=gl) as m:
            whole = m.warp(volume, interpolation="linear", grid=1, border="edge")
        for picture, plane in zip(shown, _planes(whole, c.point), strict=True):
            np.testing.assert_array_equal(picture, plane)  # as glmls warps the volume
        assert not np.array_equal(shown[0], volume[c.point[2]])
    finally:
        s.release()


def test_check_fits_names_the_volume_and_the_limit(gl):
    side = int(gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])
    flat = gl.limits["max_texture_size"]
    check_fits(gl, (1, side, side))  # at the limits: nothing said
    check_fits(gl, (flat, 4, 5))
    with pytest.raises(ValueError, match=rf"8 x {side + 1} x 1 voxels .* at most {side} x"):
        check_fits(gl, (1, side + 1, 8))
    with pytest.raises(ValueError, match=rf"{side + 1} x 3 x 2 voxels .* at most {side} x"):
        check_fits(gl, (2, 3, side + 1))
    with pytest.raises(ValueError, match=rf"5 x 4 x {flat + 1} voxels .* at most {flat} voxels"):
        check_fits(gl, (flat + 1, 4, 5))


def _demo(*args: str):
    command = [XVFB, "-a", sys.executable, "-m", "glmls", "demo", *args]
    return subprocess.run(command, capture_output=True, text=True, env=child_env(), timeout=300)


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_a_volume_past_the_3d_texture_limit_is_refused_before_the_window_shows(gl, tmp_path):
    """It opened, and the first handle added closed it (or a ``--handles`` file did at the
    first frame) with the warp's words, which do not say what to do."""
    side = int(gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])  # llvmpipe's, as under Xvfb
    path = tmp_path / "long.npy"
    np.save(path, np.zeros((1, side + 1, 6), np.uint8))
    done = _demo(str(path), "--frames", "2", "--screenshot", str(tmp_path / "shot.png"))
    assert done.returncode == 2, done.stderr
    assert "crop or downsample it" in done.stderr and "Traceback" not in done.stderr
    assert done.stderr.count("\n") == 1 and not (tmp_path / "shot.png").exists()


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_the_window_stays_open_where_the_warp_refuses_a_slice(tmp_path):
    path, handles, shot = tmp_path / "flat.npy", tmp_path / "h.json", tmp_path / "shot.png"
    np.save(path, np.full(FLAT, 90, np.uint8))
    glmls.files.write_handles(handles, np.array(FAR_SRC), np.array(FAR_DST))
    done = _demo(str(path), "--handles", str(handles), "--grid", "1", "--screenshot", str(shot))
    assert done.returncode == 0, done.stderr
    assert glmls.imread(shot).std() > 10


READOUT = (
    REFUSED
    + """
import json, sys
import numpy as np
from glmls.app.events import Key, Wait
from glmls.app.volume_controller import VolumeSettings
from glmls.app.volume_window import VolumeApp
import glmls

src, dst = json.loads(sys.argv[1])
app = VolumeApp(np.full((8, 200, 200), 90, np.uint8), src, dst,
                settings=VolumeSettings(config=glmls.MLSConfig(transform="similarity"), grid=1),
                window_size=(900, 600))
lines = []
errors = []

def keep(a):
    lines.append(a.readout())
    if a.gl.mgl.error != "GL_NO_ERROR":
        errors.append(a.gl.mgl.error)

app.run(events=[Wait(1), Key("m"), Wait(1)], frames=4, on_frame=keep)
print(json.dumps({"lines": lines, "errors": errors}))
"""
)


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_the_readout_says_why_the_slices_are_undeformed_and_what_a_key_is_for(tmp_path):
    script = tmp_path / "readout.py"
    script.write_text(READOUT)
    command = [XVFB, "-a", sys.executable, str(script), json.dumps([FAR_SRC, FAR_DST])]
    done = subprocess.run(command, capture_output=True, text=True, env=child_env(), timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.splitlines()[-1])
    assert result["errors"] == []
    text = " ".join(" ".join(result["lines"][-1]).split())  # wrapped lines joined
    assert "use a coarser grid" in text and "(those slices shown undeformed)" in text
    assert "m: for images, not volumes" in text


FLAKY = """
import json
import numpy as np
import glmls
from glmls.app.events import Key, Wait
from glmls.app.volume_session import VolumeSession
from glmls.app.volume_view import view_viewport
from glmls.app.volume_window import VolumeApp

made = VolumeSession._slice

def refused_with_a_field(self, view, field, *, deform=True):
    if field is not None and deform:  # the two-channel warp refused, the one-channel not
        raise ValueError("refused with the overlay's channel")
    return made(self, view, field, deform=deform)

VolumeSession._slice = refused_with_a_field
src, dst = glmls.data.phantom_handles()
app = VolumeApp(glmls.data.phantom(), src, dst + [[6.0, 6.0, 0.0]], window_size=(900, 600))
shots = []

def keep(a):
    x, y, w, h = view_viewport(a.layout, a.controller.grid, 0)  # the axial view
    top = a.window.framebuffer_size[1] - y - h
    shots.append((a.screenshot()[top : top + h, x : x + w], a.session.slice_error))

app.run(events=[Wait(2), Key("e"), Wait(2)], frames=5, on_frame=keep)
(before, error_before), (after, error_after) = shots[1], shots[-1]
print(json.dumps([float(np.abs(before.astype(int) - after).mean()), error_before, error_after]))
"""


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_a_view_shown_undeformed_is_drawn_undeformed(tmp_path):
    """The pictures were uploaded when f or the slice point changed: a view the warp refused
    only once the overlay's channel rode along kept showing its deformed picture."""
    script = tmp_path / "flaky.py"
    script.write_text(FLAKY)
    command = [XVFB, "-a", sys.executable, str(script)]
    done = subprocess.run(command, capture_output=True, text=True, env=child_env(), timeout=300)
    assert done.returncode == 0, done.stderr
    changed, error_before, error_after = json.loads(done.stdout.splitlines()[-1])
    assert error_before == "" and error_after == "refused with the overlay's channel"
    assert changed > 1.0  # the undeformed plane, not the deformed picture of before
