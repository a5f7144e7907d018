"""A preset's handle count is bounded (:data:`glmls.augment.MAX_HANDLES`): a grid of
30000 x 30000 handles or a text preset of ten million segments is refused when the Augment
is made, naming the options, instead of exhausting the memory as the handles are drawn (the
process killed before :func:`glmls.warp_batch` could refuse them)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import glmls_cli
from PIL import Image

from glmls.augment import MAX_HANDLES, Augment, GridPreset, TextDistortPreset


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"rows": 30000, "cols": 30000}, "rows * cols = 30000 * 30000 = 900,000,000 handles"),
        ({"rows": 1025, "cols": 1024}, "rows * cols = 1025 * 1024 = 1,049,600 handles"),
        ({"rows": 10**9, "cols": 2}, "handles per image; at most 1,048,576"),
    ],
)
def test_a_grid_of_too_many_handles_is_refused_when_made(options, message):
    with pytest.raises(ValueError, match=message.replace("*", r"\*")):
        Augment("grid", **options)
    with pytest.raises(ValueError, match="at most 1,048,576"):
        GridPreset(**options)


@pytest.mark.parametrize("preset", ["text-distort", "text-stretch", "text-perspective"])
def test_a_text_preset_of_too_many_segments_is_refused_when_made(preset):
    with pytest.raises(ValueError, match=r"2 \(segments \+ 1\) = 2 \(10000000 \+ 1\)"):
        Augment(preset, segments=10**7)


def test_the_limit_itself_is_taken():
    assert MAX_HANDLES == 1 << 20
    assert GridPreset(rows=1024, cols=1024).rows == 1024
    assert TextDistortPreset(segments=MAX_HANDLES // 2 - 1).segments == MAX_HANDLES // 2 - 1


def test_the_command_line_refuses_it_in_one_line(tmp_path):
    result = glmls_cli(
        "augment", "in.png", "out", "--rows", "30000", "--cols", "30000", cwd=tmp_path
    )
    assert result.returncode == 2, result.stderr
    assert "900,000,000 handles per image" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("preset", "options", "shape", "message"),
    [
        (
            "text-distort",
            {"segments": 500_000},
            (32, 128),
            r"images\[1\]: segments = 500,000 is more than one per pixel of the image's width "
            r"\(128\): at most 128 for this image",
        ),
        (
            "text-stretch",
            {"segments": 129},
            (32, 128),
            r"images\[1\]: segments = 129 .* at most 128",
        ),
        (
            "text-perspective",
            {"segments": 65},
            (32, 3),
            r"images\[1\]: segments = 65 .* width \(3\): at most 64",
        ),
        ("grid", {"rows": 65}, (32, 128), r"images\[1\]: rows = 65 .* height \(32\): at most 64"),
        (
            "grid",
            {"cols": 130},
            (32, 128),
            r"images\[1\]: cols = 130 .* width \(128\): at most 129",
        ),
    ],
)
def test_handles_finer_than_the_pixels_are_refused_naming_the_image(
    preset, options, shape, message
):
    """More handles than pixels along an axis (beyond 64) move nothing the pixels show and
    cost their number: 500,000 segments on a 128-wide crop ran for minutes. Refused at the
    draw, naming the image (the image before it is wide enough)."""
    aug = Augment(preset, **options)
    with pytest.raises(ValueError, match=message):
        aug.draw([(64, 600_000), shape])


@pytest.mark.parametrize(
    ("preset", "options", "shape", "count"),
    [
        ("text-stretch", {"segments": 128}, (32, 128), 2 * 129),
        ("grid", {"rows": 64, "cols": 129}, (32, 128), 64 * 129),
        ("grid", {}, (1, 1), 16),  # a few handles, whatever the image
        ("text-distort", {"segments": 64}, (2, 2), 2 * 65),
    ],
)
def test_handles_a_pixel_apart_or_a_few_are_taken(preset, options, shape, count):
    (params,) = Augment(preset, **options).draw([shape])
    assert np.asarray(params["src"]).shape == (count, 2)
    assert np.isfinite(params["dst"]).all()


def test_the_command_line_refuses_handles_finer_than_the_pixels_in_one_line(tmp_path):
    Image.fromarray(np.zeros((32, 128, 3), np.uint8)).save(tmp_path / "line.png")
    result = glmls_cli(
        "augment", "line.png", "out", "--preset", "text-distort", "--segments", "500000",
        cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    assert "segments = 500,000 is more than one per pixel" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert not (tmp_path / "out").exists()
