"""16-bit colour PPM files (``P6`` binary or ``P3`` text, of a maximum value above 255), which
Pillow reduces to 8 bits: read here as uint16, scaled to 0..65535 as Pillow scales a 16-bit
grey ``P5``."""

from __future__ import annotations

import re

import numpy as np

__all__ = ["is_ppm16", "ppm16"]

#: The header: magic, width, height, maximum value, each after blanks and ``#`` comments,
#: then the single blank before the samples.
_GAP = rb"(?:\s+|#[^\n]*\n)+"
_HEADER = re.compile(rb"P([36])" + _GAP + rb"(\d+)" + _GAP + rb"(\d+)" + _GAP + rb"(\d+)\s")


def is_ppm16(head: bytes) -> tuple[int, int, int, int] | None:
    """(width, height, maximum value, offset of the samples, negative for a text ``P3``) of a
    16-bit PPM whose header is in ``head``, else None (another format, or 8 bits: Pillow
    reads those whole)."""
    found = _HEADER.match(head)
    if found is None:
        return None
    width, height, maxval = (int(found[k]) for k in (2, 3, 4))
    if not 255 < maxval < 65536:
        return None
    return width, height, maxval, found.end() if found[1] == b"6" else -found.end()


def ppm16(data: bytes, header: tuple[int, int, int, int]) -> np.ndarray:
    """The H x W x 3 uint16 image of a 16-bit PPM's bytes; ``ValueError`` for a truncated
    file or a sample above the maximum value."""
    width, height, maxval, offset = header
    count = width * height * 3
    if width < 1 or height < 1:
        raise ValueError(f"an image of {width} x {height} pixels")
    if offset < 0:  # text: the samples in decimal, between blanks (comments too)
        fields = re.sub(rb"#[^\n]*", b" ", data[-offset:]).split()
        if len(fields) < count or not all(field.isdigit() for field in fields[:count]):
            raise ValueError(f"{len(fields)} fields of samples, for {width} x {height} x 3")
        values = [int(field) for field in fields[:count]]
        if max(values) > maxval:  # before numpy: a field of 30 digits would overflow it
            raise ValueError(f"a sample of {max(values)} above the maximum value {maxval}")
        samples = np.array(values, dtype=np.uint64)
    elif len(data) - offset < 2 * count:
        raise ValueError(f"{len(data) - offset} bytes of samples, for {width} x {height} x 3 x 2")
    else:
        samples = np.frombuffer(data, ">u2", count, offset).astype(np.uint64)
    if samples.max() > maxval:
        raise ValueError(f"a sample of {samples.max()} above the maximum value {maxval}")
    scaled = np.round(samples * (65535.0 / maxval))  # as Pillow scales a P5's samples
    return scaled.astype(np.uint16).reshape(height, width, 3)
