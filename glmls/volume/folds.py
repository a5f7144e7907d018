"""The backward method's fold pass: Newton from the neighbours' source points.

Next to a fold of f, Newton's passes (``volume/newton.comp.glsl``) may leave an output voxel
u without a source point although one lies inside the volume: the cells' piecewise linear
guess lies on another sheet of f, and Newton from u itself ends there too, or converges to a
preimage outside the volume while another lies inside. The fold pass takes those voxels
again, from the points that Newton's passes found for u's neighbours within
:data:`~glmls.volume.fields.FOLD_REACH` voxels along each axis (nearest first; where u's
own Newton converged outside the volume, only the 3 x 3 x 3), as the 2D backward method's
second pass does (``warp/inverse.comp.glsl``). Two stages:
``volume/fold_list.comp.glsl`` copies each slab voxel's point into the slab's coordinates
buffer and lists the voxels left without one (where u's Newton converged outside the
volume, only those with a face neighbour whose point lies more than 2 voxels off the line
through the points on either side of it along that axis); the field's
:meth:`~glmls.volume.fields.Field.rescue` runs over those alone (``volume/folds.comp.glsl``
on the GPU). Where Newton converged for every voxel and f does not fold, the list is empty,
however much f shrinks the volume (f's inverse is smooth: its second differences are
small).

Each slab's neighbours past its sides are those of the next slabs: Newton's passes run over
a window, the slab's box grown by the reach on every side within the canvas
(:func:`fold_windows`), whose points the fold pass reads. A slab of whole slices takes the
first slices of its window from the window before it (the points of the previous slab's
last slices and of its own first, which Newton's passes computed for that one), so that
Newton's passes run once per voxel; a box of columns and rows computes its whole window. The
points read are those of Newton's passes, never the fold pass's own: each voxel's result is
the one-piece result, whatever the slabs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import moderngl

from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import SecondPass, run_1d, set_uniforms
from ..gl.resources import Resources
from .bands import Slab
from .fields import FOLD_REACH, NEWTON_ACCEPT, Field

__all__ = ["COORD_BYTES", "FoldPass", "FoldWindow", "fold_windows"]

#: Bytes of one voxel's source point (x, y, z, w).
COORD_BYTES = 16
#: Voxels an invocation of the fold pass's first stage takes (a CPU renderer's cost is its
#: work groups as much as its voxels).
FOLD_LIST_ITEMS = 16


@dataclass(frozen=True)
class FoldWindow:
    """The voxels whose points the fold pass reads for a slab: ``box``, the slab's voxels and
    those within :data:`~glmls.volume.fields.FOLD_REACH` of them that the canvas holds;
    ``solved``, those that Newton's passes compute for it, all of ``box`` but its first
    ``kept`` voxels, which the window before it holds (its last)."""

    box: Slab
    solved: Slab
    kept: int


def fold_windows(slabs: Sequence[Slab], shape: tuple[int, int, int]) -> list[FoldWindow]:
    """The :class:`FoldWindow` of each of ``slabs`` (in order) of a canvas of ``shape``
    (D, H, W): a slab of whole slices keeps the slices of its window that the one before
    it holds, where that one ends where it starts."""
    depth, height, width = shape
    reach = FOLD_REACH
    windows = []
    before = None
    for slab in slabs:
        x0, y0, z0 = (max(c - reach, 0) for c in slab.corner)
        x1 = min(slab.column + slab.width + reach, width)
        y1 = min(slab.row + slab.height + reach, height)
        z1 = min(slab.first + slab.depth + reach, depth)
        whole = slab.width == width and slab.height == height
        kept = 0
        if whole and before is not None and before.first + before.depth == slab.first:
            kept = min(slab.first + reach, z1) - z0
        box = Slab(z0, z1 - z0, x1 - x0, y1 - y0, x0, y0)
        solved = Slab(z0 + kept, z1 - z0 - kept, box.width, box.height, x0, y0)
        windows.append(FoldWindow(box, solved, kept * box.width * box.height))
        before = slab if whole else None
    return windows


class FoldPass:
    """Newton's passes and the fold pass over ``slabs`` of a canvas of ``shape`` (D, H, W),
    one slab after the other in their order (:meth:`solve`), in ``resources``' buffers."""

    def __init__(
        self,
        gl: GLContext,
        resources: Resources,
        slabs: Sequence[Slab],
        shape: tuple[int, int, int],
    ) -> None:
        self._gl = gl
        self._resources = resources
        self._slabs = list(slabs)
        self._windows = fold_windows(self._slabs, shape)
        self._next = 0

    def solve(
        self,
        field: Field,
        slab: Slab,
        newton: Callable[[Slab, moderngl.Buffer], None],
        *,
        origin: tuple[float, float, float],
        shape: tuple[int, int, int],
        constant: bool,
    ) -> moderngl.Buffer:
        """The coordinates buffer of ``slab`` (the next of the slabs): each voxel's source
        point (x, y, z, w), w >= 0 the residual where found. ``newton(region, buffer)``
        writes the points of Newton's passes for the voxels of ``region`` into ``buffer``;
        ``origin``: the source voxel that the canvas's voxel (0, 0, 0) shows; ``shape``:
        the source volume's; ``constant``: its border."""
        index = self._next
        if index >= len(self._slabs) or self._slabs[index] != slab:
            raise ValueError(f"{slab} is not the next slab of the fold pass")
        self._next += 1
        window = self._windows[index]
        after = self._windows[index + 1] if index + 1 < len(self._windows) else None
        mgl = self._gl.mgl
        points = self._resources.buffer("volume_window", window.box.voxels * COORD_BYTES)
        solved = points
        if window.kept:
            kept = self._resources.buffer("volume_kept", window.kept * COORD_BYTES)
            mgl.memory_barrier()
            mgl.copy_buffer(points, kept, size=window.kept * COORD_BYTES)
            solved = self._resources.buffer("volume_solved", window.solved.voxels * COORD_BYTES)
        if window.solved.voxels:
            newton(window.solved, solved)
        mgl.memory_barrier()
        if window.kept and window.solved.voxels:
            size = window.solved.voxels * COORD_BYTES
            mgl.copy_buffer(points, solved, size=size, write_offset=window.kept * COORD_BYTES)
        if after is not None and after.kept:
            slice_voxels = window.box.width * window.box.height
            start = (after.box.first - window.box.first) * slice_voxels * COORD_BYTES
            kept = self._resources.buffer("volume_kept", after.kept * COORD_BYTES)
            mgl.memory_barrier()
            mgl.copy_buffer(kept, points, size=after.kept * COORD_BYTES, read_offset=start)
        coords = self._resources.buffer("volume_coords", slab.voxels * COORD_BYTES)
        listed = self._list(points, coords, window, slab)
        field.rescue(
            points,
            coords,
            listed,
            size=slab.size,
            first=slab.corner,
            window=(window.box.corner, window.box.size),
            origin=origin,
            shape=shape,
            constant=constant,
        )
        mgl.memory_barrier()
        return coords

    def _list(
        self, points: moderngl.Buffer, coords: moderngl.Buffer, window: FoldWindow, slab: Slab
    ) -> moderngl.Buffer:
        """The fold pass's first stage over ``slab`` (``volume/fold_list.comp.glsl``): its
        points from the window's ``points`` into ``coords``, and the list of the voxels the
        second takes, returned."""
        program = self._gl.compute(
            "volume/fold_list.comp.glsl", {"VOLUME_LIST_ITEMS": FOLD_LIST_ITEMS}
        )
        listed = self._resources.buffer("volume_folds", 16 + 4 * slab.voxels)
        second = SecondPass(self._gl, listed, slab.voxels)
        second.start(program)
        set_uniforms(
            program,
            {
                "u_slab_size": slab.size,
                "u_slab_first": slab.corner,
                "u_window_first": window.box.corner,
                "u_window_size": window.box.size,
                "u_accept": NEWTON_ACCEPT,
            },
        )
        points.bind_to_storage_buffer(bindings.VOLUME_NEIGHBOURS.index)
        coords.bind_to_storage_buffer(bindings.VOLUME_COORDS.index)
        self._gl.mgl.memory_barrier()
        groups = self._gl.limits["max_work_groups_x"]
        run_1d(program, slab.voxels, max_groups=groups, per_invocation=FOLD_LIST_ITEMS)
        self._gl.mgl.memory_barrier()
        return listed
