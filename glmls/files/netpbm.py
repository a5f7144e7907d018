"""16-bit colour PPM files (binary ``P6`` of a maximum value above 255), which Pillow reduces
to 8 bits: read here as uint16, scaled to 0..65535 as Pillow scales a 16-bit grey ``P5``."""

from __future__ import annotations

import re

import numpy as np

__all__ = ["is_ppm16", "ppm16"]

#: The header: magic, width, height, maximum value, each after blanks and ``#`` comments,
#: then the single blank before the samples.
_HEADER = re.compile(rb"P6(?:\s+|#[^\n]*\n)+(\d+)(?:\s+|#[^\n]*\n)+(\d+)(?:\s+|#[^\n]*\n)+(\d+)\s")


def is_ppm16(head: bytes) -> tuple[int, int, int, int] | None:
    """(width, height, maximum value, offset of the samples) of a 16-bit binary PPM whose
    header is in ``head``, else None (another format, or 8 bits: Pillow reads those whole)."""
    found = _HEADER.match(head)
    if found is None:
        return None
    width, height, maxval = (int(found[k]) for k in (1, 2, 3))
    if not 255 < maxval < 65536:
        return None
    return width, height, maxval, found.end()


def ppm16(data: bytes, header: tuple[int, int, int, int]) -> np.ndarray:
    """The H x W x 3 uint16 image of a 16-bit PPM's bytes; ``ValueError`` for a truncated
    file or a sample above the maximum value."""
    width, height, maxval, offset = header
    count = width * height * 3
    if width < 1 or height < 1 or len(data) - offset < 2 * count:
        raise ValueError(f"{len(data) - offset} bytes of samples, for {width} x {height} x 3 x 2")
    samples = np.frombuffer(data, ">u2", count, offset).astype(np.uint32)
    if samples.max() > maxval:
        raise ValueError(f"a sample of {samples.max()} above the maximum value {maxval}")
    scaled = np.round(samples * (65535.0 / maxval))  # as Pillow scales a P5's samples
    return scaled.astype(np.uint16).reshape(height, width, 3)
