"""``glmls augment --labels``: a box whose maximum lies below its minimum, or a point beyond
the coordinate range, is refused as the file is read, naming the entry in the file's own terms
(its image's name and the row), not by its place in a batch of copies after the work on the
inputs before it."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import glmls_cli

import glmls
from glmls.cli.augment import read_labels
from glmls.cli.options import UsageError


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        (
            {"boxes": [[5, 5, 25, 25], [30, 30, 10, 10]]},
            "'a.png' boxes[1] [30.0, 30.0, 10.0, 10.0] has x_max < x_min or y_max < y_min",
        ),
        ({"boxes": [[5, 9, 25, 8]]}, "'a.png' boxes[0] [5.0, 9.0, 25.0, 8.0] has x_max"),
        (
            {"keypoints": [[1, 2], [3, 4], [1e9, 3]]},
            "'a.png' keypoints[2] [1000000000.0, 3.0] lies beyond ±1e+06 px",
        ),
        ({"boxes": [[0, 0, 2e6, 5]]}, "'a.png' boxes[0] [0.0, 0.0, 2000000.0, 5.0] lies beyond"),
    ],
)
def test_a_bad_row_is_named_as_the_file_is_read(tmp_path, entry, message):
    path = tmp_path / "labels.json"
    path.write_text(json.dumps({"a.png": entry}))
    with pytest.raises(UsageError, match=message.replace("[", r"\[").replace("+", r"\+")):
        read_labels(str(path), [tmp_path / "a.png"])


def test_rows_in_range_are_read(tmp_path):
    path = tmp_path / "labels.json"
    entry = {"keypoints": [[-1e6, 1e6]], "boxes": [[1, 1, 1, 1], [0, 0, 4, 3]]}
    path.write_text(json.dumps({"a.png": entry}))
    labels = read_labels(str(path), [tmp_path / "a.png"])
    assert labels["a.png"]["boxes"] == [[1.0, 1.0, 1.0, 1.0], [0.0, 0.0, 4.0, 3.0]]


def test_the_command_line_names_the_box_and_writes_nothing(tmp_path):
    rng = np.random.default_rng(1)
    (tmp_path / "in").mkdir()
    for name in ("a.png", "b.png"):
        glmls.imwrite(tmp_path / "in" / name, rng.integers(0, 256, (16, 24), dtype=np.uint8))
    labels = {"b.png": {"boxes": [[2, 2, 8, 8], [9, 9, 3, 12]]}}
    (tmp_path / "labels.json").write_text(json.dumps(labels))
    result = glmls_cli("augment", "in", "out", "--n", "2", "--labels", "labels.json", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert "labels.json: 'b.png' boxes[1] [9.0, 9.0, 3.0, 12.0] has x_max" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert not (tmp_path / "out").exists()


def test_an_option_one_input_s_size_refuses_is_named_before_any_image(tmp_path):
    """--segments 100 suits a 128-wide crop and not a 40-wide one: the command names the
    narrow input (not its place in a batch of copies) before it deforms the wide one."""
    (tmp_path / "in").mkdir()
    glmls.imwrite(tmp_path / "in" / "a.png", np.zeros((32, 128), np.uint8))
    glmls.imwrite(tmp_path / "in" / "b.png", np.zeros((32, 40), np.uint8))
    result = glmls_cli(
        "augment", "in", "out", "--n", "2", "--preset", "text-distort", "--segments", "100",
        cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    assert result.stderr.strip().splitlines() == [
        "glmls augment: in/b.png: segments = 100 is more than one per pixel of the image's "
        "width (40): at most 64 for this image"
    ]
    assert not (tmp_path / "out").exists()


def test_the_size_checked_up_front_is_the_size_read_after_exif_turns_it(tmp_path):
    """A crop stored 400 x 40 with EXIF orientation 6 is read 40 x 400 (imread turns it):
    --segments 100 suits it, as it suits the same pixels stored upright."""
    from PIL import Image

    stored = Image.fromarray(np.zeros((400, 40), np.uint8))
    exif = stored.getexif()
    exif[0x0112] = 6
    (tmp_path / "in").mkdir()
    stored.save(tmp_path / "in" / "line.jpg", exif=exif)
    result = glmls_cli(
        "augment", "in", "out", "--n", "1", "--preset", "text-distort", "--segments", "100",
        cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert glmls.imread(tmp_path / "out" / "line_000.jpg").shape[:2] == (40, 400)
