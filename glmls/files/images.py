"""Reading and writing images with Pillow, keeping 16-bit PNGs 16-bit.

Pillow keeps 16-bit greyscale PNGs (mode ``I;16``) but reduces 16-bit colour and grey+alpha
PNGs to 8 bits, and cannot write them; those go through the small PNG codec below (zlib and
numpy), so that a uint16 RGB(A) image survives ``imwrite`` then ``imread`` unchanged.
"""

from __future__ import annotations

import os
import struct
import zlib

import numpy as np
from PIL import Image

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_COLOR_TYPES = {2: 3, 4: 2, 6: 4}  # 16-bit PNG colour types Pillow reduces -> channels
_CHANNEL_TYPES = {2: 4, 3: 2, 4: 6}


def imread(path: str | os.PathLike) -> np.ndarray:
    """An image file as an array: H x W (grey) or H x W x C, uint8 or uint16 (16-bit PNG).

    Palette and other modes are converted to RGB or RGBA.
    """
    with open(path, "rb") as file:
        head = file.read(26)
    if head[:8] == _PNG_SIGNATURE and head[24] == 16 and head[25] in _COLOR_TYPES:
        return _read_png16(path)
    with Image.open(path) as image:
        image.load()
        mode = image.mode
        if mode in ("I;16", "I;16B", "I;16L"):
            return np.asarray(image).astype(np.uint16)
        if mode == "I":
            array = np.asarray(image)
            if array.min() >= 0 and array.max() <= 65535:
                return array.astype(np.uint16)
            return array
        if mode == "F":
            return np.asarray(image, dtype=np.float32)
        if mode not in ("L", "LA", "RGB", "RGBA"):
            alpha = "A" in mode or "transparency" in image.info
            image = image.convert("RGBA" if alpha else "RGB")
        return np.asarray(image).copy()


def imwrite(path: str | os.PathLike, image: object) -> None:
    """Write a uint8 or uint16 image (H x W or H x W x C, C in 1..4); the format follows the
    file name. uint16 needs PNG (or TIFF for greyscale)."""
    array = np.asarray(image)
    if array.ndim == 3 and array.shape[2] == 1:
        array = array[..., 0]
    if array.ndim not in (2, 3) or (array.ndim == 3 and not 2 <= array.shape[2] <= 4):
        raise ValueError(f"image must be H x W or H x W x C with C in 1..4, got {array.shape}")
    if array.size == 0:
        raise ValueError(f"image is empty: shape {array.shape}")
    if array.dtype == np.uint16 and array.ndim == 3:
        if not str(path).lower().endswith(".png"):
            raise ValueError(f"16-bit colour images can only be written as PNG, not {path}")
        _write_png16(path, array)
        return
    if array.dtype == np.uint16:
        Image.fromarray(np.ascontiguousarray(array)).save(path)  # mode I;16
        return
    if array.dtype != np.uint8:
        raise TypeError(
            f"imwrite takes uint8 or uint16 images, got {array.dtype}; scale and convert first"
        )
    Image.fromarray(np.ascontiguousarray(array)).save(path)


def _chunk(kind: bytes, data: bytes) -> bytes:
    crc = zlib.crc32(kind + data) & 0xFFFFFFFF
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)


def _write_png16(path: str | os.PathLike, array: np.ndarray) -> None:
    height, width, channels = array.shape
    rows = np.ascontiguousarray(array, dtype=">u2").reshape(height, width * channels)
    raw = np.concatenate([np.zeros((height, 1), np.uint8), rows.view(np.uint8)], axis=1)
    header = struct.pack(">IIBBBBB", width, height, 16, _CHANNEL_TYPES[channels], 0, 0, 0)
    with open(path, "wb") as file:
        file.write(_PNG_SIGNATURE)
        file.write(_chunk(b"IHDR", header))
        file.write(_chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)))
        file.write(_chunk(b"IEND", b""))


def _read_png16(path: str | os.PathLike) -> np.ndarray:
    with open(path, "rb") as file:
        data = file.read()
    pos, idat, header = 8, [], b""
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            header = body
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    width, height, _, color_type, _, _, interlace = struct.unpack(">IIBBBBB", header)
    if interlace:
        raise ValueError(f"interlaced 16-bit colour PNGs are not supported: {path}")
    channels = _COLOR_TYPES[color_type]
    bpp = 2 * channels
    stride = width * bpp
    raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8).reshape(height, stride + 1)
    out = np.zeros((height, stride), np.uint8)
    prev = np.zeros(stride, np.uint8)
    for r in range(height):
        kind, line = raw[r, 0], raw[r, 1:]
        if kind == 0:
            row = line.copy()
        elif kind == 1:  # Sub: a running sum per byte of the pixel, mod 256
            row = np.cumsum(line.reshape(width, bpp), axis=0, dtype=np.uint64)
            row = (row % 256).astype(np.uint8).ravel()
        elif kind == 2:
            row = line + prev
        else:  # Average and Paeth depend on the left neighbour just decoded: pixel by pixel
            row = _unfilter_sequential(kind, line.astype(np.int32), prev.astype(np.int32), bpp)
        out[r] = row
        prev = out[r]
    return out.view(">u2").reshape(height, width, channels).astype(np.uint16)


def _unfilter_sequential(kind: int, line: np.ndarray, prev: np.ndarray, bpp: int) -> np.ndarray:
    row = np.zeros_like(line)
    zero = np.zeros(bpp, np.int32)
    for x in range(0, len(line), bpp):
        left = row[x - bpp : x] if x else zero
        up = prev[x : x + bpp]
        if kind == 3:
            predictor = (left + up) // 2
        elif kind == 4:
            upleft = prev[x - bpp : x] if x else zero
            p = left + up - upleft
            pa, pb, pc = np.abs(p - left), np.abs(p - up), np.abs(p - upleft)
            predictor = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, up, upleft))
        else:
            raise ValueError(f"bad PNG filter type {kind}")
        row[x : x + bpp] = (line[x : x + bpp] + predictor) % 256
    return row.astype(np.uint8)
