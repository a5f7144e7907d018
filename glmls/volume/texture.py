"""The source volume on the GPU: one 3D texture where it fits, else the voxels each pass needs.

A volume fits where every side is within the texture side (``GL_MAX_3D_TEXTURE_SIZE``, or
:attr:`~glmls.volume.options.SlabOptions.texture_side` where smaller) and its bytes within
:attr:`~glmls.volume.options.SlabOptions.texture_bytes`. Otherwise each pass holds only the
source voxels its texel fetches reach, a box: along each axis the indices that a range of
indices stands for by the border rule (:func:`border_runs`), one run, or two where ``wrap``
joins the last index to the first. Slices within the texture side are held whole, a few at a
time; wider or taller ones a box of columns and rows at a time. The texels are the same, so
is the result. The sampling shader (``volume/sample.glsl``) reads voxel (x, y, z) at its
place in the texture, the runs of each axis held one after the other (``u_source_runs`` for
the slices, ``u_source_columns`` and ``u_source_rows`` where the slices are held in pieces).
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
    """Indices in ``runs``."""
    return sum(last - first + 1 for first, last in runs)


def runs_uniform(runs: list[tuple[int, int]]) -> tuple[int, int, int, int]:
    """``runs`` (one or two) as the sampling shader's ivec4: an empty second run where there
    is one."""
    first, last = runs[0]
    second = runs[1] if len(runs) > 1 else (last + 1, last)
    return first, last, *second


#: Runs of columns, rows and slices (x, y, z) of the source: a box that a texture holds.
Box = tuple[list[tuple[int, int]], list[tuple[int, int]], list[tuple[int, int]]]


def _holds(held: list[tuple[int, int]], runs: list[tuple[int, int]]) -> bool:
    return all(any(a <= first and last <= b for a, b in held) for first, last in runs)


class SourceTexture:
    """The source volume's texture for a construction: the whole volume where it fits
    (:attr:`whole`), else the boxes asked for by :meth:`hold`.

    Parameters
    ----------
    gl : GLContext
        The context.
    source : SourceVolume
        The volume.
    texture_bytes : int
        The most bytes of the texture (at least one slice of a box's columns and rows).
    side : int or None
        The most texels along each side of the texture; None: the GL limit (a smaller one is
        taken as the GL limit where it is larger).
    """

    def __init__(
        self, gl: GLContext, source: SourceVolume, texture_bytes: int, side: int | None = None
    ) -> None:
        self.gl = gl
        self.source = source
        depth, height, width = source.shape
        limit = int(gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])
        side = limit if side is None else min(side, limit)
        #: the most columns and rows one texture holds (x, y): the whole width and height
        #: where they are within the side
        self.max_box = (min(width, side), min(height, side))
        #: slices held whole (every column and row): no runs of columns and rows
        self.planar = width <= side and height <= side
        voxel_bytes = source.channels * source.data.dtype.itemsize
        self._slice_bytes = self.max_box[0] * self.max_box[1] * voxel_bytes
        #: the most source slices one texture holds
        self.max_slices = max(1, min(side, texture_bytes // self._slice_bytes))
        self.whole = self.planar and depth <= self.max_slices
        self._texture: moderngl.Texture3D | None = None
        self._held: Box | None = None
        if self.whole:
            self._upload(([(0, width - 1)], [(0, height - 1)], [(0, depth - 1)]))

    @property
    def limits(self) -> tuple[int, int, int]:
        """The most indices along x, y and z that one texture holds."""
        return (*self.max_box, self.max_slices)

    def fits(self, axis: int) -> bool:
        """Whether one texture holds every index of ``axis`` (0 x, 1 y, 2 z) at once."""
        return self.source.shape[2 - axis] <= self.limits[axis]

    def runs(self, axis: int, low: int, high: int, border: str) -> list[tuple[int, int]]:
        """The runs of ``axis`` (0 x, 1 y, 2 z) to hold for indices ``low`` .. ``high``
        (:func:`border_runs`): the whole axis where one texture holds it."""
        n = self.source.shape[2 - axis]
        if self.fits(axis):
            return [(0, n - 1)]
        return border_runs(low, high, n, border)

    def _upload(self, box: Box) -> None:
        if self._texture is not None:
            self._texture.release()
            self._texture = None
        columns, rows, slices = box
        size = (runs_size(columns), runs_size(rows), runs_size(slices))
        channels, dtype = self.source.channels, self.source.texture_dtype
        data = self.source.data
        if len(slices) == 1 and self.planar:
            first, last = slices[0]
            self._texture = self.gl.mgl.texture3d(
                size, channels, data[first : last + 1], dtype=dtype
            )
        else:  # each block of runs written in place: no copy of the runs joined
            self._texture = self.gl.mgl.texture3d(size, channels, dtype=dtype)
            z = 0
            for z0, z1 in slices:
                y = 0
                for y0, y1 in rows:
                    x = 0
                    for x0, x1 in columns:
                        block = np.ascontiguousarray(data[z0 : z1 + 1, y0 : y1 + 1, x0 : x1 + 1])
                        viewport = (x, y, z, x1 - x0 + 1, y1 - y0 + 1, z1 - z0 + 1)
                        self._texture.write(block, viewport=viewport)
                        x += x1 - x0 + 1
                    y += y1 - y0 + 1
                z += z1 - z0 + 1
        self._texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._held = box

    def hold(self, box: Box) -> dict[str, tuple[int, int, int, int]]:
        """Bind a texture holding the source voxels of ``box`` (runs of columns, rows and
        slices, each at most two (first, last) runs within the volume, in increasing order:
        :func:`border_runs`) to the sampling unit; returns the sampling shader's uniforms of
        the runs held. ``ValueError`` where they are more than one texture holds."""
        held = self._held
        if held is None or not all(_holds(h, r) for h, r in zip(held, box, strict=True)):
            for axis, (runs, most) in enumerate(zip(box, self.limits, strict=True)):
                if runs_size(runs) > most:
                    self._too_many(axis, runs, most)
            self._upload(box)
        assert self._texture is not None and self._held is not None
        self._texture.use(bindings.VOLUME_SOURCE.index)
        columns, rows, slices = self._held
        return {
            "u_source_runs": runs_uniform(slices),
            "u_source_columns": runs_uniform(columns),
            "u_source_rows": runs_uniform(rows),
        }

    def _too_many(self, axis: int, runs: list[tuple[int, int]], most: int) -> None:
        shown = " and ".join(f"{first} to {last}" for first, last in runs)
        if axis == 2:
            raise ValueError(
                f"a pass samples source slices {shown}, more than one texture holds "
                f"({self.max_slices} slices of {self._slice_bytes} bytes); give a larger "
                "texture_bytes (SlabOptions)"
            )
        name = "columns" if axis == 0 else "rows"
        raise ValueError(
            f"a pass samples source {name} {shown}, more than one texture holds ({most} a "
            "side); give a larger texture_side (SlabOptions)"
        )

    def release(self) -> None:
        if self._texture is not None:
            self._texture.release()
            self._texture = None
            self._held = None
