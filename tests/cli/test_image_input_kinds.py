"""Which files the commands take as images, volumes or neither: by content where the
suffix says TIFF, and with messages that lead somewhere."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tifffile
from helpers import glmls_cli, write_cli_handles
from PIL import Image

import glmls
from glmls.errors import InputFileError


def test_a_png_named_tif_is_an_image_to_warp_and_analyze(tmp_path):
    picture = np.random.default_rng(1).integers(0, 256, (32, 40, 3), dtype=np.uint8)
    Image.fromarray(picture).save(tmp_path / "photo.tif", format="PNG")
    write_cli_handles(tmp_path)
    result = glmls_cli("warp", "photo.tif", "out.png", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert glmls.imread(tmp_path / "out.png").shape == (32, 40, 3)
    result = glmls_cli(
        "analyze", "photo.tif", "--handles", "h.json", "--out", "rep", "--quiet", cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "rep" / "report.json").exists()


def test_augment_writes_a_gifs_copies_as_png(tmp_path):
    Image.fromarray(np.full((32, 40, 3), 80, np.uint8)).save(tmp_path / "still.gif")
    result = glmls_cli("augment", "still.gif", "aug", "--n", "2", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["aug/still_000.png", "aug/still_001.png"]
    assert "still.gif: glmls writes no .gif; its copies are .png" in result.stderr
    assert glmls.imread(tmp_path / "aug" / "still_001.png").shape == (32, 40, 3)


def test_augment_refuses_a_gif_and_a_png_of_one_stem(tmp_path):
    for suffix in (".gif", ".png"):
        Image.fromarray(np.full((32, 40, 3), 80, np.uint8)).save(tmp_path / f"a{suffix}")
    result = glmls_cli("augment", "a.*", "aug", "--n", "1", cwd=tmp_path)
    assert result.returncode == 2
    assert "would overwrite each other" in result.stderr
    assert not (tmp_path / "aug").exists()


def test_a_2d_npy_file_is_told_to_be_an_image_file(tmp_path):
    np.save(tmp_path / "plane.npy", np.zeros((32, 40), np.float32))
    write_cli_handles(tmp_path)
    points = [[2, 2, 0], [30, 3, 1], [5, 20, 1], [35, 20, 0]]
    (tmp_path / "h3.json").write_text(json.dumps({"src": points, "dst": points}))
    for command in (
        ["warp", "plane.npy", "o.npy", "--handles", "h.json"],
        ["warp", "plane.npy", "o.npy", "--handles", "h3.json"],
        ["analyze", "plane.npy", "--handles", "h.json", "--out", "rep"],
        ["augment", "plane.npy", "aug", "--n", "1"],
    ):
        result = glmls_cli(*command, cwd=tmp_path)
        assert result.returncode == 2, (command, result.stderr)
        assert result.stderr.count("\n") == 1, result.stderr
        assert "plane.npy: a 2D array (32, 40), but .npy files are volumes" in result.stderr
        assert "save a 2D image as an image file" in result.stderr
    with pytest.raises(InputFileError, match=r"\.npy files are volumes"):
        glmls.read_volume(tmp_path / "plane.npy")


def _stack_and_image(folder) -> None:
    folder.mkdir()
    ramp = np.tile(np.arange(40, dtype=np.uint8), (32, 1))
    tifffile.imwrite(
        folder / "stack.tif", np.stack([ramp, ramp + 1, ramp + 2]), photometric="minisblack"
    )
    glmls.imwrite(folder / "photo.png", ramp)


def test_a_tiff_stack_in_a_batch_of_images_is_refused_not_shortened(tmp_path):
    _stack_and_image(tmp_path / "in")
    write_cli_handles(tmp_path)
    result = glmls_cli("warp", "in", "out", "--handles", "h.json", "--keep-going", cwd=tmp_path)
    assert result.returncode == 1, result.stderr
    assert result.stdout.split() == ["out/photo.png"]
    assert (
        "glmls warp: skipped in/stack.tif: a volume (a TIFF stack); 2D images only here"
        in result.stderr
    )
    assert "1 of 2 images failed" in result.stderr
    assert not (tmp_path / "out" / "stack.tif").exists()
    result = glmls_cli("warp", "in", "out2", "--handles", "h.json", "--quiet", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "in/stack.tif: a volume" in result.stderr
    assert not (tmp_path / "out2" / "stack.tif").exists()


def test_augment_refuses_a_tiff_stack(tmp_path):
    _stack_and_image(tmp_path / "in")
    result = glmls_cli("augment", "in/stack.tif", "aug", "--n", "1", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "glmls augment: in/stack.tif: a volume (a TIFF stack); 2D images only here: warp, "
        "analyze and demo take a volume named on its own, with 3D handles"
    )
    assert not (tmp_path / "aug").exists()
