"""Which files the commands take as images, volumes or neither: by content where the
suffix says TIFF, and with messages that lead somewhere."""

from __future__ import annotations

import numpy as np
from helpers import glmls_cli, write_cli_handles
from PIL import Image

import glmls


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
