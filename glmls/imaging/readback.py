"""Reading an 8-bit result back from its RGBA8 framebuffer.

Asked for fewer than four channels, Mesa converts every pixel on the CPU in its generic
format code: at 512 x 512 an RGB read took 0.26-0.32 ms on llvmpipe, the whole RGBA8 read
0.03 ms (a copy), and numpy drops the fourth byte in 0.08-0.13 ms (:func:`drop_channels`).
So the framebuffer is read whole, in strips of at most :data:`STRIP_BYTES` that stay in the
cache and bound the scratch memory for huge outputs, and the channels are dropped here.
"""

from __future__ import annotations

import sys

import moderngl
import numpy as np

__all__ = ["STRIP_BYTES", "add_channel", "drop_channels", "read_rgba8"]

#: The most bytes of RGBA8 read at once (rows of the framebuffer; at least one row).
STRIP_BYTES = 1 << 20


def read_rgba8(
    framebuffer: moderngl.Framebuffer,
    size: tuple[int, int],
    channels: int,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """The first ``channels`` (1-4) of ``framebuffer``'s RGBA8 colour attachment over
    (0, 0, width, height) = ``size``, as a new writable (height, width, channels) uint8 array,
    row 0 the framebuffer's first row, or written into ``out`` (such an array, C-contiguous:
    a batch's rows read straight into the caller's result) and returned."""
    if channels not in (1, 2, 3, 4):
        raise ValueError(f"channels must be 1, 2, 3 or 4, got {channels!r}")
    width, height = size
    if out is None:
        out = np.empty((height, width, channels), np.uint8)
    elif out.shape != (height, width, channels) or not out.flags.c_contiguous:
        raise ValueError(f"out must be C-contiguous {(height, width, channels)}, got {out.shape}")
    if channels == 4 or width == 0 or height == 0:
        framebuffer.read_into(out, (0, 0, width, height), channels, alignment=1, dtype="f1")
        return out
    rows = max(1, STRIP_BYTES // (4 * width))
    strip = np.empty((min(rows, height), width, 4), np.uint8)
    for top in range(0, height, rows):
        count = min(rows, height - top)
        part = strip[:count]
        framebuffer.read_into(part, (0, top, width, count), 4, alignment=1, dtype="f1")
        drop_channels(part, out[top : top + count])
    return out


def drop_channels(rgba: np.ndarray, out: np.ndarray) -> None:
    """Copy the first ``out.shape[-1]`` channels (1-3) of ``rgba`` ((H, W, 4) uint8,
    C-contiguous) into ``out`` ((H, W, C) uint8, C-contiguous)."""
    channels = out.shape[-1]
    count = rgba.shape[0] * rgba.shape[1]
    if channels == 3 and sys.byteorder == "little" and count > 1:
        # Each pixel's RGBA word is stored at byte 3 i of the RGB output: its A byte lands on
        # the next pixel's R, which that pixel's own store (numpy stores a 1-D copy in
        # order, first to last) then overwrites. The last pixel's word would run past the
        # end: its three bytes are set apart. 2.5-4x numpy's strided per-byte copy.
        flat = out.reshape(-1)
        words = np.ndarray((count - 1,), np.uint32, buffer=flat, strides=(3,))
        np.copyto(words, rgba.reshape(-1).view(np.uint32)[:-1])
        flat[-3:] = rgba.reshape(-1)[-4:-1]
    elif channels == 2:
        # two bytes at a time (R and G together): order does not matter
        np.copyto(out.view(np.uint16)[..., 0], rgba.view(np.uint16)[..., 0])
    else:
        np.copyto(out, rgba[..., :channels])


def add_channel(image: np.ndarray, channel: np.ndarray, out: np.ndarray) -> None:
    """Copy ``image`` (..., C) uint8, C in 1..3, and ``channel`` (...) uint8 into ``out``
    (..., C + 1) uint8, C-contiguous: the channel as the last one (:func:`drop_channels`
    undone)."""
    channels = out.shape[-1] - 1
    count = channel.size
    flat = np.ascontiguousarray(image).reshape(-1)
    if channels == 3 and sys.byteorder == "little" and count > 1:
        # Pixel i's RGB read as the 4-byte word at byte 3 i (its fourth byte, the next
        # pixel's R, is overwritten by the channel below); the last pixel's word would run
        # past the end: its three bytes are set apart. A word a pixel, not a byte.
        words = np.ndarray((count - 1,), np.uint32, buffer=flat, strides=(3,))
        packed = out.reshape(-1)
        np.copyto(packed.view(np.uint32)[:-1], words)
        packed[-4:-1] = flat[-3:]
    else:
        np.copyto(out[..., :channels], flat.reshape(*out.shape[:-1], channels))
    out[..., channels] = channel
