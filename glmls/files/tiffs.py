"""What the TIFF readers (:mod:`.images`, :mod:`.volumes`, :mod:`.profiles`) share: the
files' first four bytes, and tifffile's log records held back while a file is read, since
glmls reports a corrupt file itself, in one line; the checks of a TIFF stack's pages
that :mod:`.volumes` reads as slices; and the TIFF (EXIF) orientation, applied to an image
and to a stack's slices."""

from __future__ import annotations

import contextlib
import logging
import os
import struct
import threading
from collections.abc import Iterator

import numpy as np

__all__ = [
    "TIFF_SIGNATURES",
    "broken_chain",
    "check_stack",
    "orient",
    "quiet_tifffile",
    "slice_series",
    "stack_orientation",
    "transposes",
]

#: The first four bytes of a TIFF (little- and big-endian) or BigTIFF file.
TIFF_SIGNATURES = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")

#: TIFF photometric interpretations a stack's numbers are read in as stored: min-is-white,
#: min-is-black, RGB and palette (its indices).
_AS_STORED = {0, 1, 2, 3}
#: The others by name, for the message that refuses them.
_PHOTOMETRIC_NAMES = {
    4: "transparency mask",
    5: "CMYK",
    6: "YCbCr",
    8: "CIE L*a*b*",
    9: "ICC L*a*b*",
    10: "ITU L*a*b*",
    32803: "colour filter array",
    32844: "LogL",
    32845: "LogLuv",
    34892: "linear raw",
}
_JPEG = (6, 7)  # TIFF compressions by JPEG (old and new), whose decoder turns YCbCr into RGB
_lock = threading.Lock()
_depth = 0
_level = logging.NOTSET


@contextlib.contextmanager
def quiet_tifffile() -> Iterator[None]:
    """Within the block, tifffile's logger passes nothing on; after the last of nested or
    concurrent blocks (reads on other threads) its level is as it was.

    Examples
    --------
    >>> import logging
    >>> with quiet_tifffile():
    ...     logging.getLogger("tifffile").isEnabledFor(logging.CRITICAL)
    False
    >>> logging.getLogger("tifffile").isEnabledFor(logging.CRITICAL)
    True
    """
    global _depth, _level
    logger = logging.getLogger("tifffile")
    with _lock:
        if _depth == 0:
            _level = logger.level
            logger.setLevel(logging.CRITICAL + 1)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                logger.setLevel(_level)


def broken_chain(tiff: object) -> str | None:
    """Why the chain of a TIFF's pages (each page's tags, then the offset of the next page's,
    0 after the last) breaks off, in words: a page whose tags run past the file's end, or
    that links to a next page past it or back to one before it, as in a stack cut short by
    a copy; None for a chain that ends as TIFF's do. tifffile gives the pages before the
    break as the whole file (a stack cut short as a shorter stack, or as one image), or
    takes bytes of a cut page for the link to another."""
    if not len(tiff.pages):
        return None
    fmt, handle = tiff.tiff, tiff.filehandle
    size, offset, index, seen = handle.size, tiff.pages[0].offset, 0, {}
    while True:
        seen[offset] = index
        handle.seek(offset)
        count = handle.read(fmt.tagnosize)
        end = offset + fmt.tagnosize + fmt.offsetsize
        if len(count) == fmt.tagnosize:
            end += struct.unpack(fmt.tagnoformat, count)[0] * fmt.tagsize
        if len(count) < fmt.tagnosize or end > size:
            return (
                f"cut short or damaged: the tags of page {index} run past the file's end "
                f"({size} bytes)"
            )
        handle.seek(end - fmt.offsetsize)
        following = struct.unpack(fmt.offsetformat, handle.read(fmt.offsetsize))[0]
        if following == 0:
            return None
        if following >= size:
            return (
                f"cut short or damaged: page {index} links to a next page at byte "
                f"{following}, past the file's end ({size} bytes)"
            )
        if following in seen:
            return f"damaged: page {index} links back to page {seen[following]}, a loop"
        offset, index = following, index + 1


def slice_series(tiff: object) -> list | None:
    """The series of a stack written one slice at a time: tifffile makes each ``write`` of
    a page a series of its own (``for s in volume: writer.write(s)``), where ImageJ reads
    the file's pages as one stack. Where the file holds two or more series beyond
    reduced-resolution ones (thumbnails), each of one page, all of one shape, dtype and
    photometric interpretation, those series in order (their pages are the slices); else
    None (one series; or several stacks or images, which :func:`check_stack` refuses)."""
    series = [
        one
        for one in tiff.series
        if not all(getattr(page, "is_reduced", False) for page in one.pages if page is not None)
    ]
    if len(series) < 2 or any(len(one.pages) != 1 for one in series):
        return None
    form = {(tuple(one.shape), one.dtype, int(one.keyframe.photometric)) for one in series}
    return series if len(form) == 1 else None


def check_stack(path: object, tiff: object, series: object, *, slices: bool = False) -> None:
    """``ValueError`` naming ``path`` and the page where a TIFF stack's ``series`` (tifffile's
    first, read as slices) is not the file's stack: a file without axes metadata (tifffile's
    ``generic`` series) with a page of another shape, dtype or kind outside the series (not a
    reduced-resolution page, a thumbnail), which tifffile leaves to a series of its own, so
    that the first would lack a slice; a file of several series (images or stacks, as
    tifffile writes each ``write``) beyond reduced-resolution ones, whose first alone would
    be read, unless they are one stack's slices (``slices``: :func:`slice_series`); or
    pages whose numbers are not grey, RGB or palette
    indices (YCbCr other than JPEG's, CMYK, CIE Lab, LogLuv, ...), which reading them as
    stored would give as if they were."""
    if getattr(series, "kind", "") == "generic":
        inside = {page.index for page in series.pages}
        first = series.pages[0]
        for index, page in enumerate(tiff.pages):
            if index in inside or getattr(page, "is_reduced", False):
                continue
            raise ValueError(
                f"{path}: page {index} of the TIFF stack is {_page_kind(page)}, page "
                f"{first.index} is {_page_kind(first)}: a stack's pages are slices of one "
                "shape, dtype and kind"
            )
    for other in [] if slices else tiff.series[1:]:
        pages = [page for page in other.pages if page is not None]
        if pages and not all(getattr(page, "is_reduced", False) for page in pages):
            # a second image or stack (tifffile writes each write() as a series of its own):
            # read as the first alone, the file would lose its other pages unsaid
            shapes = ", ".join(f"{tuple(one.shape)} {one.axes}" for one in tiff.series[:3])
            more = ", ..." if len(tiff.series) > 3 else ""
            raise ValueError(
                f"{path}: a TIFF of {len(tiff.series)} images or stacks ({shapes}{more}; page "
                f"{pages[0].index} is outside the first): glmls reads one stack a file; save "
                "each volume to a file of its own"
            )
    page = series.keyframe
    photometric = int(page.photometric)
    if photometric == 6 and int(page.compression) in _JPEG:
        return  # tifffile's JPEG decoder gives RGB
    if photometric not in _AS_STORED:
        name = _PHOTOMETRIC_NAMES.get(photometric, "photometric interpretation")
        raise ValueError(
            f"{path}: a TIFF stack of {name} colours (photometric {photometric}); glmls reads "
            "grey, RGB and palette (its indices) stacks: convert it to RGB or grey"
        )


#: TIFF/EXIF orientation -> (mirror the columns, quarter turns counter-clockwise, transpose):
#: what shows the stored rows and columns as a viewer does (1 and unknown codes: as stored).
_ORIENTATIONS = {
    2: (True, 0, False),
    3: (False, 2, False),
    4: (True, 2, False),
    5: (False, 0, True),
    6: (False, 3, False),
    7: (True, 3, False),
    8: (False, 1, False),
}


def orient(array: np.ndarray, code: int, *, axes: tuple[int, int] = (0, 1)) -> np.ndarray:
    """``array`` with an EXIF/TIFF orientation ``code`` applied (1 = as stored, 2-8 = flips
    and quarter turns, as ``PIL.ImageOps.exif_transpose`` applies them), its rows and
    columns the ``axes`` (a stack's slices: ``(1, 2)``).

    Examples
    --------
    >>> orient(np.arange(6).reshape(2, 3), 6).tolist()  # stored on its side: turned upright
    [[3, 0], [4, 1], [5, 2]]
    """
    flip, turns, transpose = _ORIENTATIONS.get(code, (False, 0, False))
    if transpose:
        return np.ascontiguousarray(np.swapaxes(array, *axes))
    if flip:
        array = np.flip(array, axes[1])
    return np.ascontiguousarray(np.rot90(array, turns, axes=axes)) if turns else array


def transposes(code: int) -> bool:
    """Whether orientation ``code`` puts the stored rows as columns (5 to 8): the pixel
    width and height swap."""
    _, turns, transpose = _ORIENTATIONS.get(code, (False, 0, False))
    return transpose or turns % 2 == 1


def stack_orientation(path: object, tiff: object, pages: list) -> int:
    """The orientation (TIFF tag 274, 1 where a page has none) of a stack's ``pages`` (its
    series' pages, or its slices'); ``ValueError`` naming ``path`` and two pages where they
    differ (a stack whose slices are stored turned differently is no volume)."""
    codes: dict[int, int] = {}
    for page in pages:
        if page is None:
            continue
        full = page if hasattr(page, "tags") else tiff.pages.get(page.index, aspage=True)
        tag = full.tags.get(274)
        codes.setdefault(int(tag.value) if tag is not None else 1, full.index)
        if len(codes) > 1:
            (first, at), (other, where) = codes.items()
            raise ValueError(
                f"{path}: page {where} of the TIFF stack has orientation {other} (TIFF tag "
                f"274), page {at} has {first}: a stack's slices are stored one way; write "
                "them with one orientation"
            )
    return next(iter(codes), 1)


def _page_kind(page: object) -> str:
    """A page's shape, dtype and photometric interpretation, in words."""
    shape = " x ".join(str(n) for n in page.shape)
    photometric = getattr(page.photometric, "name", str(page.photometric)).lower()
    return f"{shape} {page.dtype} ({photometric})"


def _after_fork_in_child() -> None:
    """Reads that other threads of the parent were doing at the fork never end here: the
    lock is made anew (else every read here could wait for ever) and the level put back."""
    global _lock, _depth
    _lock = threading.Lock()
    if _depth:
        logging.getLogger("tifffile").setLevel(_level)
        _depth = 0


os.register_at_fork(after_in_child=_after_fork_in_child)
