"""ICC colour profiles: read from an image file, checked against the image they go with,
and written with it, so that a warped photograph in Adobe RGB or Display P3 shows the
colours it had (a viewer takes pixels without a profile for sRGB).

PNG (``iCCP``), JPEG (APP2), WebP (``ICCP``) and TIFF (tag 34675) hold a profile; BMP, as
glmls writes it, does not. A profile describes a colour space: an RGB profile goes with
3- and 4-channel images, a grey one with 1- and 2-channel images; a CMYK file's profile
does not describe the RGB pixels :func:`glmls.imread` converts it to.
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import tifffile
from PIL import Image

from .parsing import as_path, read_head
from .tiffs import TIFF_SIGNATURES, quiet_tifffile

__all__ = ["HOLD_PROFILES", "profile_problem", "read_icc_profile", "with_png_profile"]

HOLD_PROFILES = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".webp")
_SPACES = {b"RGB ": "RGB", b"GRAY": "grey", b"CMYK": "CMYK", b"Lab ": "Lab", b"XYZ ": "XYZ"}


def read_icc_profile(path: str | os.PathLike) -> bytes | None:
    """The ICC colour profile embedded in an image file.

    :func:`glmls.imread` returns the pixels only; pass this to :func:`glmls.imwrite`'s
    ``icc_profile`` to keep a photograph's colours (Adobe RGB, Display P3, ...) in the image
    written from it, as ``glmls warp`` does.

    Parameters
    ----------
    path : str or os.PathLike
        A PNG, JPEG, WebP, TIFF or other image file Pillow reads.

    Returns
    -------
    bytes or None
        The profile, or None where the file has none (or its metadata cannot be read:
        :func:`glmls.imread` says what is wrong with such a file).

    Raises
    ------
    FileNotFoundError, PermissionError
        For a missing or unreadable file.
    ValueError
        For a folder.
    TypeError
        For a ``path`` that is not a file path (None, a number).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from PIL import ImageCms
    >>> srgb = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "photo.png"
    >>> glmls.imwrite(path, np.zeros((2, 3, 3), np.uint8), icc_profile=srgb)
    >>> glmls.files.read_icc_profile(path) == srgb
    True
    """
    path = as_path(path)
    head = read_head(path, 4)
    try:
        if head in TIFF_SIGNATURES:
            with quiet_tifffile(), tifffile.TiffFile(path) as tiff:
                tag = tiff.pages[0].tags.get(34675)
                profile = None if tag is None else tag.value
        else:
            with Image.open(path) as image:
                profile = image.info.get("icc_profile")
    except (OSError, SyntaxError, ValueError, EOFError, tifffile.TiffFileError):
        return None
    return bytes(profile) if profile else None


def _space(profile: bytes) -> str | None:
    """The colour space an ICC profile describes (its header's bytes 16-19), or None where
    the bytes are not an ICC profile."""
    if len(profile) < 128 or profile[36:40] != b"acsp":
        return None
    return _SPACES.get(profile[16:20], profile[16:20].decode("latin-1").strip() or "unknown")


def profile_problem(path: str | os.PathLike, profile: object, channels: int) -> str | None:
    """Why ``profile`` cannot be written with an image of ``channels`` channels to ``path``
    (its suffix names the format), or None where it can."""
    if not isinstance(profile, (bytes, bytearray, memoryview)):
        return f"icc_profile must be bytes, got {type(profile).__name__}"
    space = _space(bytes(profile))
    if space is None:
        return f"icc_profile is not an ICC profile ({len(profile)} bytes without its header)"
    suffix = Path(path).suffix.lower()
    if suffix not in HOLD_PROFILES:
        holders = ", ".join(HOLD_PROFILES)
        return f"{suffix or '(no suffix)'} cannot hold a colour profile; write {holders}"
    wanted = "grey" if channels in (1, 2) else "RGB"
    if space != wanted:
        return (
            f"the colour profile is for {space} images; a {channels}-channel image needs "
            f"{'an RGB' if wanted == 'RGB' else 'a grey'} one"
        )
    return None


def with_png_profile(png: bytes, profile: bytes) -> bytes:
    """A PNG file's bytes with an ``iCCP`` chunk holding ``profile``, after ``IHDR`` (the
    chunk must come before the image data)."""
    body = b"ICC profile\x00\x00" + zlib.compress(bytes(profile))
    chunk = struct.pack(">I", len(body)) + b"iCCP" + body
    chunk += struct.pack(">I", zlib.crc32(b"iCCP" + body) & 0xFFFFFFFF)
    end_of_header = 8 + 8 + 13 + 4  # signature, IHDR's length and type, its data, its CRC
    return png[:end_of_header] + chunk + png[end_of_header:]
