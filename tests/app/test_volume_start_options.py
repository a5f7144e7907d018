"""Every start option of ``glmls demo`` for a volume reaches the volume window's first state
(the settings its controller starts with), an explicit one as given, one left out the volume
window's default; options the volume window has no use for are refused (exit status 2)."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.app.controller import Settings
from glmls.app.volume_controller import VolumeController, VolumeSettings
from glmls.app.volume_session import VolumeSession, display_volume
from glmls.app.volume_window import VolumeApp
from glmls.cli.demo import image_settings
from glmls.cli.demo_volume import volume_settings
from glmls.cli.main import build_parser, main


def parse(*words: str):
    return build_parser().parse_args(["demo", *words])


def test_left_out_the_volume_window_s_defaults():
    assert volume_settings(parse("--volume")) == VolumeSettings(config=glmls.MLSConfig())
    assert VolumeSettings().border == "edge" and VolumeSettings().interpolation == "linear"


@pytest.mark.parametrize("border", glmls.BORDERS)
def test_an_explicit_border_is_the_first_border(border):
    assert volume_settings(parse("--volume", "--border", border)).border == border


def test_every_start_option_reaches_the_settings():
    args = parse(
        "--volume", "--transform", "similarity", "--weight", "gaussian", "--alpha", "1.5",
        "--radius", "12", "--method", "backward", "--interpolation", "nearest", "--grid", "8",
        "--border", "constant",
    )  # fmt: skip
    settings = volume_settings(args)
    assert settings == VolumeSettings(
        config=glmls.MLSConfig(transform="similarity", weight="gaussian", alpha=1.5, radius=12),
        method="backward",
        interpolation="nearest",
        grid=8,
        border="constant",
    )
    app = VolumeApp(glmls.data.phantom(), np.zeros((0, 3)), np.zeros((0, 3)), settings=settings)
    assert app.controller.settings == settings


def test_the_image_window_keeps_its_own_defaults():
    assert image_settings(parse()) == Settings(config=glmls.MLSConfig())
    assert (Settings().border, Settings().interpolation) == ("constant", "nearest")
    given = image_settings(parse("--border", "edge", "--interpolation", "linear"))
    assert (given.border, given.interpolation) == ("edge", "linear")


@pytest.mark.parametrize(
    ("words", "message"),
    [
        (["--method", "splat"], "--method splat: the volume window builds quads or backward"),
        (["--grid", "3"], "grid must be one of (1, 2, 4, 8, 16), got 3"),
        (["--fit"], "--fit: for images, not for the volume window"),
        (["--tolerance", "0.05"], "--tolerance: for images, not for the volume window"),
        (["--reference", "r.json"], "--reference: for images, not for the volume window"),
        (["--max-pixels", "1000"], "--max-pixels: for images, not for the volume window"),
        (["--construction", "splat"], "--method splat: the volume window builds quads or"),
    ],
)
def test_an_option_the_volume_window_cannot_take_exits_2(capsys, words, message):
    assert main(["demo", "--volume", *words]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err


def test_the_session_warps_with_the_settings_interpolation_and_border(gl):
    volume = glmls.data.phantom()
    src, dst = glmls.data.phantom_handles()
    settings = VolumeSettings(interpolation="nearest", border="constant", grid=4)
    c = VolumeController(src, dst, volume.shape, pick_radius=2.0, settings=settings)
    s = VolumeSession(gl, c, display_volume(volume))
    try:
        s.sync()
        got = s.slices()
        assert s.error == ""
        with glmls.MLS(c.src, c.dst, shape=volume.shape, ctx=gl) as m:
            whole = m.warp(
                display_volume(volume), interpolation="nearest", grid=4, border="constant"
            )
        x, _, z = c.point
        np.testing.assert_array_equal(got[0], whole[z])
        np.testing.assert_array_equal(got[2], whole[:, :, x].T)
    finally:
        s.release()
