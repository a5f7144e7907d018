"""ICC colour profiles: read from image files, written with images, kept by the commands."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import glmls_cli
from PIL import Image, ImageCms

import glmls
from glmls.files import read_icc_profile

SRGB = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
GREY = SRGB[:16] + b"GRAY" + SRGB[20:]  # the header says what the profile is for
CMYK = SRGB[:16] + b"CMYK" + SRGB[20:]
RGB = np.random.default_rng(0).integers(0, 256, (12, 16, 3), dtype=np.uint8)


@pytest.mark.parametrize(
    ("name", "image"),
    [
        ("a.png", RGB),
        ("a.png", RGB.astype(np.uint16) * 257),  # 16-bit PNGs are encoded by libpng
        ("a.png", RGB[..., 0]),
        ("a.tif", RGB),
        ("a.tif", RGB.astype(np.float32) / 255),
        ("a.jpg", RGB),
        ("a.webp", np.dstack([RGB, RGB[..., :1]])),
    ],
)
def test_a_profile_written_is_read_back_with_the_same_pixels(tmp_path, name, image):
    profile = GREY if image.ndim == 2 else SRGB
    glmls.imwrite(tmp_path / name, image, icc_profile=profile)
    assert read_icc_profile(tmp_path / name) == profile
    back = glmls.imread(tmp_path / name)
    assert back.shape == image.shape and back.dtype == image.dtype
    if not name.endswith((".jpg", ".webp")):  # lossy at Pillow's default quality
        np.testing.assert_array_equal(back, image)
    if image.dtype == np.float32:
        return  # Pillow does not read float RGB TIFFs
    # Pillow, another reader, sees the same profile
    with Image.open(tmp_path / name) as other:
        assert other.info.get("icc_profile") == profile


def test_files_without_a_profile_give_none(tmp_path):
    for name in ("a.png", "a.tif", "a.jpg", "a.bmp"):
        glmls.imwrite(tmp_path / name, RGB)
        assert read_icc_profile(tmp_path / name) is None
    (tmp_path / "bad.png").write_bytes(b"not an image")
    assert read_icc_profile(tmp_path / "bad.png") is None  # imread says what is wrong
    with pytest.raises(FileNotFoundError):
        read_icc_profile(tmp_path / "missing.png")


@pytest.mark.parametrize(
    ("name", "image", "profile", "message"),
    [
        ("a.bmp", RGB, SRGB, "a.bmp: .bmp cannot hold a colour profile; write .png"),
        ("a.png", RGB[..., 0], SRGB, "is for RGB images; a 1-channel image needs a grey one"),
        ("a.png", RGB, GREY, "is for grey images; a 3-channel image needs an RGB one"),
        ("a.png", RGB, CMYK, "is for CMYK images; a 3-channel image needs an RGB one"),
        ("a.png", RGB, b"\x00" * 200, "icc_profile is not an ICC profile (200 bytes"),
        ("a.png", RGB, "sRGB", "icc_profile must be bytes, got str"),
    ],
)
def test_a_profile_that_does_not_fit_is_refused_before_writing(
    tmp_path, name, image, profile, message
):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(".", r"\.")):
        glmls.imwrite(tmp_path / name, image, icc_profile=profile)
    assert not (tmp_path / name).exists()


def test_warp_keeps_the_profile_or_says_why_not(tmp_path):
    glmls.imwrite(tmp_path / "a.png", RGB, icc_profile=SRGB)
    Image.fromarray(RGB).convert("CMYK").save(tmp_path / "c.jpg", icc_profile=CMYK)
    (tmp_path / "h.json").write_text('{"src": [[3, 3], [12, 3], [8, 9]], '
                                      '"dst": [[4, 3], [12, 4], [8, 9]]}')  # fmt: skip
    for source, target in (("a.png", "o.png"), ("a.png", "o.jpg"), ("a.png", "o.bmp"),
                           ("c.jpg", "oc.png")):  # fmt: skip
        result = glmls_cli("warp", source, target, "--handles", "h.json", cwd=tmp_path)
        assert result.returncode == 0, result.stderr
        kept = read_icc_profile(tmp_path / target)
        if target in ("o.png", "o.jpg"):
            assert kept == SRGB and "profile" not in result.stderr
        else:
            assert kept is None
            assert f"glmls warp: warning: {source}: its colour profile is not kept: " in (
                result.stderr
            )
