"""A preset's handle count is bounded (:data:`glmls.augment.MAX_HANDLES`): a grid of
30000 x 30000 handles or a text preset of ten million segments is refused when the Augment
is made, naming the options, instead of exhausting the memory as the handles are drawn (the
process killed before :func:`glmls.warp_batch` could refuse them)."""

from __future__ import annotations

import pytest
from helpers import glmls_cli

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
