"""f on one lattice for many images at once: every image's point handles in one buffer, one
dispatch of ``mls/points.comp.glsl`` (``MLS_BATCH``) for all of them.

Each image keeps its own scaling (:meth:`glmls.core.handles.Scaling.fit` of its handles and
the image), computed for the whole batch in numpy with the same float64 operations, and its
own values of the uniforms a single image's lattice pass sets (the lattice's origin, step and
last point, the weights' ``u_log2_s``, ``u_radius``, ``u_hit2``, ``u_snap``), one row of an
image table per image. The shader reads them once per work group and then runs the single
pass's code: each image's f is what :func:`glmls.engine.passes.evaluate_lattice` of its own
:class:`~glmls.engine.kernel.MLSKernel` gives, bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np

from ..core.config import MLSConfig
from ..core.handles import (
    MIN_GPU_SPREAD,
    check_affine_handles,
    check_gpu_distinct,
    check_gpu_spread,
    fit_boxes,
    same_source_sets,
    set_bounds,
)
from ..core.mesh import MeshLattice
from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import LOCAL_SIZE, set_uniforms
from ..gl.resources import Resources
from .bins import AUTO_MIN_HANDLES
from .kernel import config_defines, weight_rows
from .passes import POINTS_PASS, POINTS_PER_INVOCATION
from .storage import unroll_slots

__all__ = ["BatchLattices"]


def _bounds(
    src: list[np.ndarray], dst: list[np.ndarray], shape: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) lows and highs of each image's handles p and q and the image's pixel box."""
    height, width = shape
    if len({len(p) for p in src}) == 1:
        (p_lo, p_hi), (q_lo, q_hi) = set_bounds(np.stack(src)), set_bounds(np.stack(dst))
        lo, hi = np.minimum(p_lo, q_lo), np.maximum(p_hi, q_hi)
    else:
        points = [np.concatenate([p, q]) for p, q in zip(src, dst, strict=True)]
        lo = np.array([p.min(axis=0) for p in points])
        hi = np.array([p.max(axis=0) for p in points])
    lo = np.minimum(lo, (-0.5, -0.5))
    hi = np.maximum(hi, (width - 0.5, height - 0.5))
    return lo, hi


class BatchLattices:
    """The point handles of N images, scaled each as its own :class:`~glmls.MLS` scales them
    (:attr:`centers`, :attr:`scales`), ready to evaluate f on one lattice for all
    (:meth:`evaluate`).

    Parameters
    ----------
    config : MLSConfig
        The configuration of every image.
    src, dst : list of numpy.ndarray
        Per image, its (K_i, 2) float64 handles p and q, checked (finite, K_i >= 1).
    shape : tuple of int
        (H, W) of every image.
    """

    def __init__(
        self, config: MLSConfig, src: list[np.ndarray], dst: list[np.ndarray], shape
    ) -> None:
        if config.transform == "affine":
            for p in src:
                check_affine_handles(p)
        self.config = config
        self.shape = tuple(shape)
        lo, hi = _bounds(src, dst, self.shape)
        #: (N, 2) float64 and (N,) float64: each image's scaling centre and scale
        #: (Scaling.center, Scaling.scale).
        self.centers, self.scales = fit_boxes(lo, hi)
        self.counts = np.array([len(p) for p in src])
        rows = np.repeat(np.arange(len(src)), self.counts)
        center, scale = self.centers[rows], self.scales[rows]
        both = np.concatenate(src), np.concatenate(dst)
        packed = np.empty((len(rows), 4), np.float32)
        for k, column in enumerate((both[0][:, 0], both[0][:, 1], both[1][:, 0], both[1][:, 1])):
            packed[:, k] = (column - center[:, k % 2]) / scale  # Scaling.to_gpu, column by column
        self.packed = packed
        starts = np.cumsum(self.counts) - self.counts
        spreads = (
            np.maximum.reduceat(both[0], starts, axis=0)
            - np.minimum.reduceat(both[0], starts, axis=0)
        ).max(axis=1)
        for i in np.flatnonzero((spreads > 0) & (spreads < MIN_GPU_SPREAD * self.scales)):
            try:
                check_gpu_spread(float(spreads[i]), float(self.scales[i]))
            except ValueError as error:
                raise ValueError(f"images[{i}]: {error}") from None
        self._check_distinct(src, dst)

    def _check_distinct(self, src: list[np.ndarray], dst: list[np.ndarray]) -> None:
        """:func:`~glmls.core.handles.check_gpu_distinct` of every image, the error naming
        the image; for handle counts alike, only the images whose scaled sources hold one
        point with two scaled targets (one sort of all, :func:`same_source_sets`) are
        checked again for the message."""
        if len(set(self.counts.tolist())) == 1:
            rows = self.packed.reshape(len(self.counts), -1, 4)
            merged = same_source_sets(rows[..., :2], rows[..., 2:])
            suspects = np.flatnonzero(merged).tolist()
        else:
            suspects = range(len(self.counts))
        starts = np.cumsum(self.counts) - self.counts
        for i in suspects:
            rows = self.packed[starts[i] : starts[i] + self.counts[i]]
            try:
                check_gpu_distinct(src[i], dst[i], rows[:, :2], rows[:, 2:], self.scales[i])
            except ValueError as error:
                raise ValueError(f"images[{i}]: {error}") from None

    @staticmethod
    def takes(config: MLSConfig, counts: list[int], storage: str, bins: bool | None) -> bool:
        """Whether :meth:`evaluate` gives these images what their own kernels give: point
        handles only (checked by the caller), handles in a buffer (a texture's fetch compiles
        to other arithmetic: f differs in its last bits) and no spatial bins (never asked
        for, never chosen for these counts)."""
        if bins or storage == "texture":
            return False
        return not config.uses_radius or bins is False or max(counts) < AUTO_MIN_HANDLES

    def __len__(self) -> int:
        return len(self.scales)

    def extents(self) -> np.ndarray:
        """(N,) float64: each image's :func:`~glmls.engine.kernel.handle_extent` (scaled), the
        value its own kernel computes from the same rows."""
        starts = np.cumsum(self.counts) - self.counts
        lo = np.minimum.reduceat(self.packed, starts, axis=0).astype(np.float64)
        hi = np.maximum.reduceat(self.packed, starts, axis=0).astype(np.float64)
        sides = np.maximum(hi[:, :2], hi[:, 2:]) - np.minimum(lo[:, :2], lo[:, 2:])
        return sides.max(axis=1) / 2

    def table(self, lattice: MeshLattice) -> np.ndarray:
        """(N, 16) float32: each image's row of the image table of ``mls/batch.glsl`` (its
        last four values int32) for passes over ``lattice``'s image."""
        count = len(self)
        table = np.zeros((count, 16), np.float32)
        ints = table[:, 12:].view(np.int32)
        columns = (
            (lattice.origin[0], lattice.origin[1], lattice.last[0], lattice.last[1]),
            (0, 1, 0, 1),
        )
        for k, (value, axis) in enumerate(zip(*columns, strict=True)):
            table[:, k] = (value - self.centers[:, axis]) / self.scales  # lattice.uniforms
        table[:, 4] = lattice.grid / self.scales
        radius = self.config.resolve_radius(self.shape)
        pairs = np.stack([self.scales, self.extents()], axis=1)
        distinct, inverse = np.unique(pairs, axis=0, return_inverse=True)  # often one scale
        inverse = inverse.reshape(-1)
        rows = weight_rows(self.config, distinct.tolist(), radius)
        weights = np.array([row[:4] for row in rows], np.float64).reshape(len(distinct), 4)
        table[:, 5:8] = weights[inverse, :3]
        snap = weights[inverse, 3] != 0
        table[:, 8:10] = self.centers
        table[:, 10] = self.scales
        ints[:, 0] = np.concatenate([[0], np.cumsum(self.counts)[:-1]])
        ints[:, 1], ints[:, 2], ints[:, 3] = self.counts, snap, np.arange(count)
        return table

    def dispatches(
        self, gl: GLContext, resources: Resources, lattice: MeshLattice, entry: str, defines
    ) -> Iterator[tuple[moderngl.ComputeShader, int]]:
        """The program of ``entry`` with ``defines`` and its number of work group rows (the
        images it evaluates), bound to their handles and rows of the image table: one per
        unrolling of the handle loop that the images' single passes use (one for handle
        counts alike) and part of the images whose handles fit in a uniform block (llvmpipe
        reads those faster than a storage buffer; one part for 256 images of 16 handles);
        the caller sets its own uniforms and runs each."""
        for (program,), rows in self.parts(gl, resources, lattice, entry, defines):
            yield program, rows

    def parts(
        self, gl: GLContext, resources: Resources, lattice: MeshLattice, entry: str, *defines
    ) -> Iterator[tuple[tuple[moderngl.ComputeShader, ...], int]]:
        """As :meth:`dispatches`, with one program of ``entry`` per mapping of ``defines`` for
        each part (a pass and its second pass, say), the part's handles and table rows
        uploaded and bound once for them all."""
        table = self.table(lattice)
        ends = np.cumsum(self.counts)
        capacity = int(gl.mgl.info["GL_MAX_UNIFORM_BLOCK_SIZE"]) // 16
        distinct, inverse = np.unique(self.counts, return_inverse=True)
        unrolls = np.array([unroll_slots(int(c)) for c in distinct])[inverse]
        for unroll in sorted(set(unrolls.tolist())):
            chosen = np.flatnonzero(unrolls == unroll)
            block = int(self.counts[chosen].max()) <= capacity
            parts, start, rows = [], 0, 0
            for k, image in enumerate(chosen.tolist()):
                count = int(self.counts[image])
                if block and rows + count > capacity:
                    parts.append(chosen[start:k])
                    start, rows = k, 0
                rows += count
            parts.append(chosen[start:])
            common = config_defines(self.config, unroll=unroll, binned=False, segments=False) | {
                "MLS_STORAGE": 0,
                "MLS_BATCH": True,
                "MLS_UBO_CAPACITY": capacity * block,
            }
            programs = tuple(gl.compute(entry, common | dict(d)) for d in defines)
            for program in programs:
                set_uniforms(program, {"u_alpha": self.config.alpha})
            for j, part in enumerate(parts):
                if part[-1] - part[0] + 1 == len(part):  # consecutive images: one slice
                    packed = self.packed[ends[part[0]] - self.counts[part[0]] : ends[part[-1]]]
                else:
                    packed = np.concatenate(
                        [self.packed[ends[i] - self.counts[i] : ends[i]] for i in part.tolist()]
                    )
                rows = table[part]
                rows[:, 12:].view(np.int32)[:, 0] = np.cumsum(self.counts[part]) - self.counts[part]
                size = 16 * capacity if block else packed.nbytes
                handles = resources.buffer(f"batch handles {unroll} {j}", size)
                handles.write(packed)
                images = resources.buffer(f"batch images {unroll} {j}", rows.nbytes)
                images.write(np.ascontiguousarray(rows))
                if block:
                    handles.bind_to_uniform_block(bindings.HANDLES_BLOCK.index)
                else:
                    handles.bind_to_storage_buffer(bindings.HANDLES.index)
                images.bind_to_storage_buffer(bindings.POINTS.index)
                yield programs, len(rows)

    def evaluate(
        self, gl: GLContext, resources: Resources, lattice: MeshLattice, target, stride: int
    ) -> None:
        """f (scaled) at every point of ``lattice`` for every image, image k's from byte
        ``k * stride`` of ``target`` (a multiple of 8)."""
        nx, ny = lattice.dims
        groups = -(-nx * ny // (LOCAL_SIZE * POINTS_PER_INVOCATION))
        if groups > gl.limits["max_work_groups_x"]:
            raise ValueError(f"a lattice of {nx} x {ny} points is too large for one dispatch")
        defines = {
            "MLS_LATTICE": True,
            "MLS_WRITE_MATRIX": False,
            "MLS_POINTS_PER_INVOCATION": POINTS_PER_INVOCATION,
        }
        for program, rows in self.dispatches(gl, resources, lattice, POINTS_PASS, defines):
            uniforms = {"u_lattice_dims": lattice.dims, "u_first_row": 0, "u_count": nx * ny}
            uniforms |= {"u_offset": 0, "u_batch_stride": stride // 8}
            set_uniforms(program, uniforms)
            target.bind_to_storage_buffer(bindings.DEFORMED.index)
            program.run(group_x=groups, group_y=rows)

    def evaluate_points(
        self, gl: GLContext, resources: Resources, points: list[np.ndarray], shape
    ) -> list[np.ndarray]:
        """f at each image's own ``points`` ((K_i, 2) float64 pixels; ``shape`` (H, W): the
        image whose default radius applies) as (K_i, 2) float64 arrays, in one dispatch per
        :meth:`dispatches` part: what :func:`~glmls.engine.passes.evaluate_points` of each
        image's own kernel gives, bit for bit (the same scaled points, pairs of points per
        invocation and float64 sum)."""
        count = len(self)
        sizes = np.array([len(p) for p in points])
        stride = max(2, int(sizes.max()) + int(sizes.max()) % 2)  # pairs never span images
        alike = int(sizes.min()) if len(set(sizes.tolist())) == 1 else 0
        # every image's points at once, with Scaling.to_gpu's float64 operations, x and y
        # apart (numpy runs operations over (P, 2) pairs several times slower)
        if alike:
            every = np.stack(points)
            scaled = np.empty((count, stride, 2), np.float32)
            for axis in (0, 1):
                scaled[:, :alike, axis] = (
                    every[..., axis] - self.centers[:, axis, None]
                ) / self.scales[:, None]
            scaled[:, alike:] = scaled[:, alike - 1 : alike]  # the padding: the last point
        else:  # ragged: slot j of image k holds its point min(j, K_k - 1) (0 where K_k = 0)
            flat = np.concatenate(points).astype(np.float64, copy=False).reshape(-1, 2)
            owner = np.repeat(np.arange(count), sizes)
            scales = self.scales[owner]
            values = np.empty((len(flat) + 1, 2), np.float32)
            values[-1] = 0.0
            for axis in (0, 1):
                values[:-1, axis] = (flat[:, axis] - self.centers[owner, axis]) / scales
            starts = np.cumsum(sizes) - sizes
            slot = np.minimum(np.arange(stride), np.maximum(sizes, 1)[:, None] - 1)
            scaled = values[np.where(sizes[:, None] > 0, starts[:, None] + slot, len(flat))]
        with gl.use():
            source = resources.buffer("batch points", scaled.nbytes)
            source.write(scaled)
            target = resources.buffer("batch points f", scaled.nbytes)
            groups = -(-stride // (LOCAL_SIZE * POINTS_PER_INVOCATION))
            defines = {
                "MLS_LATTICE": False,
                "MLS_WRITE_MATRIX": False,
                "MLS_POINTS_PER_INVOCATION": POINTS_PER_INVOCATION,
            }
            lattice = MeshLattice.corners(self.shape)  # the table's lattice rows go unread
            for program, rows in self.dispatches(gl, resources, lattice, POINTS_PASS, defines):
                uniforms = {"u_count": stride, "u_offset": 0, "u_out_first": 0}
                set_uniforms(program, uniforms | {"u_batch_stride": stride})
                source.bind_to_storage_buffer(bindings.BATCH_POINTS.index)
                target.bind_to_storage_buffer(bindings.DEFORMED.index)
                program.run(group_x=groups, group_y=rows)
            gl.mgl.memory_barrier()
            d = np.frombuffer(target.read(size=scaled.nbytes), np.float32).reshape(scaled.shape)
        # f = v + (f - v), as evaluate_points sums it
        if alike:
            moved = np.empty(every.shape)
            for axis in (0, 1):
                change = d[:, :alike, axis].astype(np.float64) * self.scales[:, None]
                moved[..., axis] = every[..., axis] + change
            return list(moved)
        at = owner * stride + (np.arange(len(flat)) - np.repeat(starts, sizes))
        moved = np.empty_like(flat)
        for axis in (0, 1):
            change = np.take(d[..., axis], at).astype(np.float64) * scales
            moved[:, axis] = flat[:, axis] + change
        return np.split(moved, np.cumsum(sizes)[:-1])
