"""What the window's file keys do (``s``, ``j``, ``l``): the deformed image at full
resolution, the handles of every kind to a file and back."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.handleset import HandleSet
from ..errors import InputFileError
from ..files.images import imwrite
from ..files.landmarks import handle_dimension, read_handle_set, write_handles
from ..imaging.frame import Frame
from ..mls import MLS
from .controller import Controller
from .settings import Settings

__all__ = ["KEPT_DTYPES", "load_handles", "save_handles", "save_image", "warped_suffix"]

#: The image dtypes ``s`` saves as they are (others: 8-bit).
KEPT_DTYPES = (np.uint8, np.uint16, np.float32, np.float64)


def save_image(
    path: Path,
    mls: MLS | None,
    image: np.ndarray,
    display: np.ndarray,
    settings: Settings,
    canvas: Frame,
) -> None:
    """The deformed image on ``canvas`` (the input's frame, or with ``fit`` the whole
    deformed image) at full resolution, in the input's dtype where it can be written (uint8,
    uint16; float32 and float64 to a TIFF, :func:`warped_suffix`), another float's values as
    float32 to a TIFF, else 8-bit; ``ValueError`` without a valid deformation."""
    if mls is None:
        raise ValueError("no valid deformation to save")
    s = settings
    floating = np.issubdtype(image.dtype, np.floating)  # its own values, to a TIFF
    if image.dtype in KEPT_DTYPES:
        source = image
    elif floating:  # float16, longdouble: as float32, not the display's stretched RGB
        source = image.astype(np.float32)
    else:
        source = display
    out = mls.warp(source, options=s.warp_options(output_shape=canvas.shape, origin=canvas.origin))
    if not floating and out.dtype not in (np.uint8, np.uint16):
        out = np.round(np.clip(out, 0, 1) * 255).astype(np.uint8)
    imwrite(path, out)  # creates the folder; whole file or none


def warped_suffix(image: np.ndarray) -> str:
    """The file type ``s`` saves the deformed ``image`` as: ``.tif`` for a float image (a
    PNG cannot hold its values), else ``.png``."""
    return ".tif" if np.issubdtype(image.dtype, np.floating) else ".png"


def save_handles(path: Path, controller: Controller) -> None:
    """The controller's points and segments as a handle file (JSON by its suffix, else
    CSV); ``ValueError`` for handles MLS would refuse, and for none (a handle file holds
    one at least: ``l`` could not load it back)."""
    c = controller
    if not len(c.src) and not len(c.src_segments):
        raise ValueError("no handles to save")
    write_handles(path, c.src, c.dst, src_segments=c.src_segments, dst_segments=c.dst_segments)


def load_handles(path: Path, controller: Controller, *, targets: Path | None = None) -> HandleSet:
    """Replace the controller's handles (undoably) with those of a handle file (or of an
    elastix pair, ``targets`` the targets' file), points and segments; returns them.
    :class:`~glmls.errors.InputFileError` for a file of 3D handles, said for the window of a
    2D image."""
    if handle_dimension(path, dst=targets) == 3:
        raise InputFileError(
            f"{path}: 3D handles (x, y, z), but the window shows a 2D image: it takes 2D "
            "handles (x, y)"
        )
    handles = read_handle_set(path, dst=targets)
    controller.set_handles(
        handles.src,
        handles.dst,
        src_segments=handles.src_segments,
        dst_segments=handles.dst_segments,
    )
    return handles
