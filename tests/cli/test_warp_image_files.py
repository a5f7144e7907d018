"""glmls warp on image files as viewers show them: the EXIF orientation applied before the
handles (in displayed coordinates) deform the image, and a transparent colour kept as alpha."""

from __future__ import annotations

import numpy as np
import tifffile
from helpers import CLI_DST as DST
from helpers import CLI_SRC as SRC
from helpers import glmls_cli, write_cli_handles
from PIL import Image

import glmls


def test_warp_applies_the_orientation_before_the_handles(tmp_path, gl):
    """A TIFF stored on its side with orientation 7 (transverse) is warped upright."""
    rng = np.random.default_rng(5)
    stored = rng.integers(0, 65536, (40, 32, 3), dtype=np.uint16)
    tifffile.imwrite(tmp_path / "side.tif", stored, extratags=[(274, "H", 1, 7, True)])
    write_cli_handles(tmp_path)
    result = glmls_cli("warp", "side.tif", "out.tif", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    shown = np.ascontiguousarray(np.rot90(stored[:, ::-1], -1))  # as Pillow shows it
    assert shown.shape == (32, 40, 3)
    expected = glmls.warp(shown, SRC, DST, ctx=gl)
    np.testing.assert_array_equal(glmls.imread(tmp_path / "out.tif"), expected)


def test_a_keyed_grey_png_keeps_its_alpha(tmp_path):
    """A grey PNG's tRNS colour is alpha: written to PNG with it, refused by JPEG clearly."""
    grey = np.full((32, 40), 90, np.uint8)
    grey[10:20, 10:30] = 200
    Image.fromarray(grey).save(tmp_path / "keyed.png", transparency=200)
    write_cli_handles(tmp_path)
    result = glmls_cli("warp", "keyed.png", "out.png", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert glmls.imread(tmp_path / "out.png").shape == (32, 40, 2)
    result = glmls_cli("warp", "keyed.png", "out.jpg", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert ".jpg has no alpha channel" in result.stderr


def test_a_tiff_with_a_thumbnail_is_an_image_and_a_stack_a_volume(tmp_path, gl):
    """Pages of different sizes (a thumbnail, a pyramid) make an image: its first page is
    warped; pages of one size make a volume, which 2D handles do not deform."""
    rng = np.random.default_rng(6)
    photo = rng.integers(0, 256, (32, 40, 3), dtype=np.uint8)
    with tifffile.TiffWriter(tmp_path / "thumb.tif") as tiff:
        tiff.write(photo, photometric="rgb")
        tiff.write(photo[::4, ::4], photometric="rgb")
    stack = photo[..., 0][None].repeat(4, axis=0)
    tifffile.imwrite(tmp_path / "stack.tif", stack, photometric="minisblack")
    write_cli_handles(tmp_path)
    result = glmls_cli("warp", "thumb.tif", "out.tif", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "glmls warp: warning: thumb.tif: 2 pages; reading the first" in result.stderr
    expected = glmls.warp(photo, SRC, DST, ctx=gl)
    np.testing.assert_array_equal(glmls.imread(tmp_path / "out.tif"), expected)
    result = glmls_cli("analyze", "thumb.tif", "--handles", "h.json", "--out", "a", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "glmls analyze: warning: thumb.tif: 2 pages; reading the first" in result.stderr
    result = glmls_cli("warp", "stack.tif", "o.tif", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 2
    assert "2D handles (x, y), but stack.tif is a volume" in result.stderr


def test_a_folder_leaves_out_hidden_files_and_folders(tmp_path):
    """A folder of images is what ``folder/*`` names: macOS's ``._photo.png`` companions and
    other hidden files are no images, and a folder named like an image is no file."""
    from glmls.cli.inputs import image_inputs

    folder = tmp_path / "in"
    folder.mkdir()
    glmls.imwrite(folder / "a.png", np.zeros((8, 8), np.uint8))
    (folder / "._a.png").write_bytes(b"\x00\x05\x16\x07 AppleDouble")
    (folder / ".b.png.k3j_x0ab.png").write_bytes(b"half")
    (folder / "c.png").mkdir()
    assert image_inputs(str(folder)) == ([folder / "a.png"], True)
    assert image_inputs(str(folder / "*")) == ([folder / "a.png"], True)


def test_a_device_given_as_the_input_is_named_so(tmp_path, capsys):
    from glmls.cli.main import main

    write_cli_handles(tmp_path)
    assert (
        main(["warp", "/dev/zero", str(tmp_path / "o.png"), "--handles", str(tmp_path / "h.json")])
        == 2
    )
    assert capsys.readouterr().err == "glmls warp: /dev/zero: not a file or folder\n"


def test_a_gif_into_a_folder_is_written_as_a_png(tmp_path, gl):
    """glmls reads GIFs but writes none: into a folder a GIF's output is NAME.png (as
    ``glmls augment`` names its copies), which stderr says; a PNG of that name beside it in
    the batch is refused, as two inputs of one name are."""
    rng = np.random.default_rng(7)
    frame = rng.integers(0, 256, (32, 40, 3), dtype=np.uint8)
    Image.fromarray(frame).save(tmp_path / "anim.gif")
    shown = glmls.imread(tmp_path / "anim.gif")
    write_cli_handles(tmp_path)
    (tmp_path / "out").mkdir()
    result = glmls_cli("warp", "anim.gif", "out", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "anim.gif: glmls writes no .gif; written as out/anim.png" in result.stderr
    assert result.stdout.split() == ["out/anim.png"]
    expected = glmls.warp(shown, SRC, DST, ctx=gl)
    np.testing.assert_array_equal(glmls.imread(tmp_path / "out" / "anim.png"), expected)
    glmls.imwrite(tmp_path / "anim.png", frame)
    result = glmls_cli("warp", "anim.*", "many/", "--handles", "h.json", cwd=tmp_path)
    assert result.returncode == 2 and "have one name" in result.stderr
    assert not (tmp_path / "many").exists()


def test_a_file_that_is_no_image_is_said_skipped_not_written_as_a_png(tmp_path, gl):
    """Into a folder a file of a format glmls does not write would be NAME.png: that is
    said once written, and a file that turns out to be no image is said skipped only."""
    rng = np.random.default_rng(8)
    glmls.imwrite(tmp_path / "wi" / "a.png", rng.integers(0, 256, (16, 20, 3), dtype=np.uint8))
    (tmp_path / "wi" / "notes.txt").write_text("not an image\n")
    write_cli_handles(tmp_path)
    args = ("warp", "wi/*", "wb", "--handles", "h.json", "--keep-going")
    result = glmls_cli(*args, cwd=tmp_path)
    assert result.returncode == 1
    assert "written as" not in result.stderr
    assert "skipped" in result.stderr and "notes.txt" in result.stderr
    assert sorted(p.name for p in (tmp_path / "wb").iterdir()) == ["a.png"]
