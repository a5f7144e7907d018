"""The source volume on the GPU: one 3D texture where it fits, else the slices each pass needs.

A volume fits where every side is within ``GL_MAX_3D_TEXTURE_SIZE`` and its bytes within
:attr:`~glmls.volume.options.SlabOptions.texture_bytes`. Otherwise each pass holds only the
source slices [first, last] its texel fetches reach (their z indices after the border rule,
:func:`border_slices`): the texels are the same, so is the result. The sampling shader
(``volume/sample.glsl``) reads slice z at texture layer z - ``u_source_first``.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..gl import bindings
from ..gl.context import GLContext
from .source import SourceVolume

__all__ = ["SourceTexture", "border_index", "border_slices"]


def border_index(index: np.ndarray, n: int, border: str) -> np.ndarray:
    """The source index that stands at ``index`` (any integers) of an axis of ``n`` voxels by
    the border rule (``common/border.glsl``'s; ``constant`` clamps)."""
    if border == "symmetric":
        m = np.mod(index, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    if border == "reflect":
        if n == 1:
            return np.zeros_like(index)
        m = np.mod(index, 2 * n - 2)
        return np.where(m < n, m, 2 * n - 2 - m)
    if border == "wrap":
        return np.mod(index, n)
    return np.clip(index, 0, n - 1)


def border_slices(low: int, high: int, n: int, border: str) -> tuple[int, int]:
    """The smallest range of source slices that holds every index ``low`` .. ``high`` of an
    axis of ``n`` voxels maps to by the border rule."""
    period = {"symmetric": 2 * n, "reflect": max(1, 2 * n - 2), "wrap": n}.get(border)
    if period is not None and high - low + 1 >= period:
        return 0, n - 1
    mapped = border_index(np.arange(low, high + 1), n, border)
    return int(mapped.min()), int(mapped.max())


class SourceTexture:
    """The source volume's texture for a construction: the whole volume where it fits
    (:attr:`whole`), else the slices asked for by :meth:`hold`."""

    def __init__(self, gl: GLContext, source: SourceVolume, texture_bytes: int) -> None:
        self._gl = gl
        self.source = source
        depth, height, width = source.shape
        side = int(gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])
        if max(height, width) > side:
            raise ValueError(
                f"volume slices of {height} x {width} voxels exceed the GL 3D texture size "
                f"limit of {side} voxels per side on this device"
            )
        self._slice_bytes = height * width * source.channels * source.data.dtype.itemsize
        self._max_slices = max(1, min(side, texture_bytes // self._slice_bytes))
        self.whole = depth <= self._max_slices
        self._texture: moderngl.Texture3D | None = None
        self._held: tuple[int, int] | None = None
        if self.whole:
            self._upload(0, depth - 1)

    def _upload(self, first: int, last: int) -> None:
        if self._texture is not None:
            self._texture.release()
        _, height, width = self.source.shape
        data = self.source.data[first : last + 1]
        self._texture = self._gl.mgl.texture3d(
            (width, height, last - first + 1),
            self.source.channels,
            data,
            dtype=self.source.texture_dtype,
        )
        self._texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._held = (first, last)

    def hold(self, first: int, last: int) -> int:
        """Bind a texture holding source slices ``first`` .. ``last`` (within the volume) to
        the sampling unit; returns the slice at its layer 0 (``u_source_first``).
        ``ValueError`` where they are more than one texture holds."""
        held = self._held
        if held is None or first < held[0] or last > held[1]:
            if last - first + 1 > self._max_slices:
                raise ValueError(
                    f"a slab of the output samples source slices {first} to {last}, more "
                    f"than one texture holds ({self._max_slices} slices); give smaller "
                    "slabs (SlabOptions) or a larger texture_bytes"
                )
            self._upload(first, last)
        assert self._texture is not None and self._held is not None
        self._texture.use(bindings.VOLUME_SOURCE.index)
        return self._held[0]

    def release(self) -> None:
        if self._texture is not None:
            self._texture.release()
            self._texture = None
            self._held = None
