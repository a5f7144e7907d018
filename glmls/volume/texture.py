"""The source volume on the GPU: one 3D texture where it fits, else the slices each pass needs.

A volume fits where every side is within ``GL_MAX_3D_TEXTURE_SIZE`` and its bytes within
:attr:`~glmls.volume.options.SlabOptions.texture_bytes`. Otherwise each pass holds only the
source slices its texel fetches reach: the slices that a range of z indices stands for by the
border rule (:func:`border_runs`), one run of slices, or two where ``wrap`` joins the last
slice to the first. The texels are the same, so is the result. The sampling shader
(``volume/sample.glsl``) reads slice z of run (first, last) at its layer in the texture, the
runs held one after the other (``u_source_runs``).
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..gl import bindings
from ..gl.context import GLContext
from .source import SourceVolume

__all__ = ["SourceTexture", "border_index", "border_runs", "border_slices"]


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
    if period is None:  # clamped: the range's ends, however far out
        return min(max(low, 0), n - 1), min(max(high, 0), n - 1)
    if high - low + 1 >= period:
        return 0, n - 1
    mapped = border_index(np.arange(low, high + 1), n, border)
    return int(mapped.min()), int(mapped.max())


def border_runs(low: int, high: int, n: int, border: str) -> list[tuple[int, int]]:
    """The source slices that every index ``low`` .. ``high`` of an axis of ``n`` voxels
    maps to by the border rule, as at most two runs (first, last) in increasing order: one
    for every rule but ``wrap``, whose range may cross from the last slice to the first."""
    if border == "wrap" and high - low + 1 < n:
        first, last = low % n, high % n
        if first > last:
            return [(0, last), (first, n - 1)]
        return [(first, last)]
    return [border_slices(low, high, n, border)]


def runs_size(runs: list[tuple[int, int]]) -> int:
    """Slices in ``runs``."""
    return sum(last - first + 1 for first, last in runs)


class SourceTexture:
    """The source volume's texture for a construction: the whole volume where it fits
    (:attr:`whole`), else the slices asked for by :meth:`hold`."""

    def __init__(self, gl: GLContext, source: SourceVolume, texture_bytes: int) -> None:
        self.gl = gl
        self.source = source
        depth, height, width = source.shape
        side = int(gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])
        if max(height, width) > side:
            raise ValueError(
                f"volume slices of {height} x {width} voxels exceed the GL 3D texture size "
                f"limit of {side} voxels per side on this device"
            )
        self._slice_bytes = height * width * source.channels * source.data.dtype.itemsize
        #: the most source slices one texture holds
        self.max_slices = max(1, min(side, texture_bytes // self._slice_bytes))
        self.whole = depth <= self.max_slices
        self._texture: moderngl.Texture3D | None = None
        self._held: list[tuple[int, int]] | None = None
        if self.whole:
            self._upload([(0, depth - 1)])

    def _upload(self, runs: list[tuple[int, int]]) -> None:
        if self._texture is not None:
            self._texture.release()
            self._texture = None
        _, height, width = self.source.shape
        size = (width, height, runs_size(runs))
        channels, dtype = self.source.channels, self.source.texture_dtype
        if len(runs) == 1:
            first, last = runs[0]
            data = self.source.data[first : last + 1]
            self._texture = self.gl.mgl.texture3d(size, channels, data, dtype=dtype)
        else:  # each run written in place: no copy of the slices joined
            self._texture = self.gl.mgl.texture3d(size, channels, dtype=dtype)
            layer = 0
            for first, last in runs:
                count = last - first + 1
                data = np.ascontiguousarray(self.source.data[first : last + 1])
                self._texture.write(data, viewport=(0, 0, layer, width, height, count))
                layer += count
        self._texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._held = list(runs)

    def hold(self, runs: list[tuple[int, int]]) -> tuple[int, int, int, int]:
        """Bind a texture holding the source slices of ``runs`` (at most two (first, last)
        runs within the volume, in increasing order: :func:`border_runs`) to the sampling
        unit; returns ``u_source_runs``, the runs held (an empty second run where there is
        one). ``ValueError`` where they are more than one texture holds."""
        held = self._held
        if held is None or not all(
            any(a <= first and last <= b for a, b in held) for first, last in runs
        ):
            if runs_size(runs) > self.max_slices:
                shown = " and ".join(f"{first} to {last}" for first, last in runs)
                raise ValueError(
                    f"a pass samples source slices {shown}, more than one texture holds "
                    f"({self.max_slices} slices of {self._slice_bytes} bytes); give a larger "
                    "texture_bytes (SlabOptions)"
                )
            self._upload(runs)
        assert self._texture is not None and self._held is not None
        self._texture.use(bindings.VOLUME_SOURCE.index)
        first, last = self._held[0]
        second = self._held[1] if len(self._held) > 1 else (last + 1, last)
        return first, last, *second

    def release(self) -> None:
        if self._texture is not None:
            self._texture.release()
            self._texture = None
            self._held = None
